//! The wafer map: where every wafer is (a station slot or the hand), with an id per wafer,
//! kept consistent across crashes.
//!
//! # Guarantees
//!
//! * No id is ever held twice, and no operation drops an id silently: every operation
//!   checks its preconditions first and either applies completely or returns an error and
//!   changes nothing. Ids leave the map only by [`WaferMap::remove`] (an operator takes a
//!   wafer out) or by a mapping that finds the slot empty or faulty
//!   ([`WaferMap::apply_mapping`], which reports it).
//! * Transfers are two-phase. [`WaferMap::begin`] records the pending transfer; the caller
//!   saves the map ([`WaferMap::save_atomic`]) *before* the robot moves. [`WaferMap::commit`]
//!   moves the wafer once the vacuum sensor confirmed it; the caller saves again.
//!   [`WaferMap::abort`] keeps the wafer where it was. Saves are atomic, so after `kill -9`
//!   at any moment the file holds either the state before `begin`, the pending transfer, or
//!   the committed state: the only place a wafer can be in the middle of a transfer is its
//!   source or the hand.
//! * A transfer that ends abnormally, and one left pending by a crash or a power loss, is
//!   judged by the transfer journal ([`crate::journal`]) and the vacuum sensors together
//!   ([`crate::journal::judge`]): [`WaferMap::settle_interrupted`] commits it, aborts it, or
//!   leaves its wafer *uncertain* at each place it may be in (on the blade: `W3?`; in the
//!   slot: [`SlotState::Uncertain`]). The sensor alone never moves a wafer out of the place
//!   the journal had it ([`WaferMap::reconcile`], the sensor-only rule, is for a map
//!   without a journal whose sensors are known good, as the world model's crash tests
//!   use it). Nothing assumed, nothing lost: an uncertain place keeps its
//!   wafer id until a sensor ([`WaferMap::apply_mapping`] for a slot, [`WaferMap::sense_blade`]
//!   for a blade) or an operator ([`WaferMap::confirm_at`], [`WaferMap::confirm_gone`],
//!   [`WaferMap::confirm_empty`]) settles it, and GET and PUT refuse it until then.
//!
//! # Start-up
//!
//! [`WaferMap::load`] the file (a missing one is an empty map), [`WaferMap::adopt_stations`]
//! the current stations, then — before any output is written, so the vacuum valve is still
//! as the previous run left it — settle a pending transfer as the journal and the vacuum
//! sensors judge it ([`WaferMap::settle_interrupted`]), and save. The vacuum output must survive the controller's death (the simulated board keeps
//! its outputs); a board that dropped it would drop the wafer.
//!
//! # Slots
//!
//! Each slot of each station is [`SlotState::Unknown`] (never mapped: GET and PUT refuse it
//! until `MAP <station>`), [`SlotState::Empty`], [`SlotState::Wafer`] or
//! [`SlotState::Fault`] (the mapping saw a double or cross-slotted wafer there: GET and PUT
//! refuse it until it is mapped clean) or [`SlotState::Uncertain`] (perhaps a wafer,
//! perhaps nothing, after an interrupted transfer: GET and PUT refuse it until it is mapped
//! or confirmed).
//!
//! # File format (TOML, version 3)
//!
//! ```toml
//! # wrc wafer map ...
//! version = 3
//! next_id = 27                 # the next new id; every id in the map is below it
//! hand = "W3"                  # omitted when the hand (blade A) is empty
//! hand_b = "W4"                # blade B of a dual-blade robot; omitted when empty
//! hand_uncertain = true        # the wafer on blade A is uncertain (the board stopped
//!                              # answering while it was there); omitted when false
//! hand_b_uncertain = true      # the same for blade B
//! note = "PUT LP2 1 (W1) was interrupted …"   # what left places uncertain; omitted when
//!                              # nothing is
//!
//! [pending]                    # omitted when no transfer is in progress
//! kind = "get"                 # "get" or "put"
//! station = "LP1"
//! slot = 3
//! wafer = "W3"
//! blade = "B"                  # the blade making it; omitted for blade A
//!
//! [[station]]
//! name = "LP1"
//! slots = ["W1", "W2", "-", "?", "double", "cross", "W9?"]   # slot 1 first
//!
//! # end of the wafer map
//! ```
//!
//! Slot tokens: `W<n>` a wafer, `-` empty, `?` unknown, `double`, `cross`, `W<n>?` perhaps
//! that wafer (uncertain). The last line is [`END_LINE`]: a version 2 or 3 file without it
//! was cut short and is refused (version 1, which had none, and version 2 are still read;
//! the map is written back as version 3).
//!
//! # The `WAFERS` reply
//!
//! [`WaferMap::wafers_line`] gives one line: `hand=<tok> <STN>=<slots> … [pending=…]` (the
//! hand's token is `W<n>?` while its wafer is uncertain: the board stopped answering, or a
//! power loss switched its vacuum off), for
//! example `hand=- LP1=W1..W25 LP2=-x25 AL=- PM1=? PM2=W26 pending=get:LP1.3:W3`. `<slots>`
//! lists every slot from slot 1 up, comma-separated, with the tokens `W<n>` (a wafer), `-`
//! (empty), `?` (unknown), `D` (double), `X` (cross-slotted), `W<n>?` (uncertain: perhaps
//! that wafer, perhaps nothing), compressed two ways: three or
//! more wafers with ids rising by one in successive slots as `W<a>..W<b>`, and a token
//! repeated n ≥ 2 times as `<tok>x<n>` (a lower-case x: in the protocol `*` only ever starts a checksum). With D the number of digits of the largest id, the
//! line is at most `7 + D` bytes for the hand (`hand=W<n>?`), `1 + len(name) + slots · (D + 2)` per station
//! and `19 + len(name) + D` for a pending transfer: with the demo cell (58 places) and ids
//! below 100 000 (D = 5), at most 462 bytes even when no run compresses. When it would exceed a protocol line, [`WaferMap::wafers_lines`] gives the
//! same content as one line per place group (the hand, each station, the pending transfer),
//! for one `EVT WAFER` line each.

use std::fmt;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::atomic::write_atomic;
use crate::blade::{Blade, MAX_BLADES};
use crate::journal::Maybe;
use crate::mapping::SlotCode;
use crate::station::{parse_station_name, same_name, StationName, MAX_SLOTS};
use crate::stations::Stations;
use crate::transfer::TransferKind;

/// Version of the wafer map file format written by [`WaferMap::to_text`]. Version 3 adds
/// uncertain slots (`W3?`) and the `note`; versions 2 and 3 end with [`END_LINE`]; versions 1
/// (no end line) and 2 are still read.
pub const FORMAT_VERSION: u32 = 3;

/// The last line of a version 2 or 3 wafer map: a file that does not end with it was cut
/// short.
/// TOML cannot tell: a file cut at the end of a line (a lost stretch of a disk, a partial
/// copy) is often still valid TOML, with the pending transfer, the hand or whole stations
/// missing, which the map would otherwise take as unknown and write back.
pub const END_LINE: &str = "# end of the wafer map";

/// A wafer's id in the map, shown as `W<n>`. Ids are handed out rising from `W1` and never
/// reused (the next id is saved with the map).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct WaferId(pub u32);

impl WaferId {
    /// The id written as `W<n>` (or `w<n>`), `n` a decimal number without sign.
    pub fn parse(text: &str) -> Option<WaferId> {
        let digits = text.strip_prefix(['W', 'w'])?;
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        digits.parse().ok().map(WaferId)
    }
}

impl fmt::Display for WaferId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "W{}", self.0)
    }
}

/// Where a wafer can be.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Location {
    /// In slot `slot` (1-based) of station `station`; shown `LP1.3`.
    Slot {
        /// The station.
        station: StationName,
        /// The slot, from 1.
        slot: u16,
    },
    /// On one of the robot's blades; shown `hand` (blade A, the hand of a single-hand
    /// robot) or `hand.B`.
    Hand(Blade),
}

impl Location {
    /// Blade A: the hand of a single-hand robot.
    pub const HAND: Location = Location::Hand(Blade::A);
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Slot { station, slot } => write!(f, "{station}.{slot}"),
            Location::Hand(Blade::A) => f.write_str("hand"),
            Location::Hand(b) => write!(f, "hand.{b}"),
        }
    }
}

/// A mapping fault that makes a slot unusable until it is mapped clean.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SlotFault {
    /// Two wafers in one slot.
    Double,
    /// A wafer across two slots.
    Cross,
}

impl SlotFault {
    /// The mapping code of the fault.
    pub fn code(self) -> SlotCode {
        match self {
            SlotFault::Double => SlotCode::Double,
            SlotFault::Cross => SlotCode::Cross,
        }
    }
}

impl fmt::Display for SlotFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.code().name())
    }
}

/// What the map knows about one slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SlotState {
    /// Never mapped since the station was added: GET and PUT refuse it.
    Unknown,
    /// No wafer.
    Empty,
    /// This wafer.
    Wafer(WaferId),
    /// A mapping fault: GET and PUT refuse it.
    Fault(SlotFault),
    /// Perhaps this wafer, perhaps nothing: a transfer was interrupted (a power loss) and
    /// nothing has proven either yet. GET and PUT refuse it until a `MAP` of the station, a
    /// sensor or an operator settles it ([`WaferMap::settle_interrupted`]).
    Uncertain(WaferId),
}

impl SlotState {
    /// The code a `MAP` of the slot reports when the map is right (`Present` for any
    /// wafer); `None` for a slot the map does not know.
    pub fn code(self) -> Option<SlotCode> {
        match self {
            SlotState::Unknown => None,
            SlotState::Empty => Some(SlotCode::Absent),
            SlotState::Wafer(_) => Some(SlotCode::Present),
            SlotState::Fault(fault) => Some(fault.code()),
            SlotState::Uncertain(_) => None,
        }
    }
}

/// A transfer between a slot and the hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Transfer {
    /// GET (slot → hand) or PUT (hand → slot).
    pub kind: TransferKind,
    /// The station.
    pub station: StationName,
    /// The slot, from 1.
    pub slot: u16,
    /// The wafer moved.
    pub wafer: WaferId,
    /// The blade that takes or gives the wafer.
    pub blade: Blade,
}

impl Transfer {
    /// The slot's location.
    pub fn slot_location(&self) -> Location {
        Location::Slot {
            station: self.station,
            slot: self.slot,
        }
    }

    /// Where the wafer is before the transfer.
    pub fn source(&self) -> Location {
        match self.kind {
            TransferKind::Get => self.slot_location(),
            TransferKind::Put => Location::Hand(self.blade),
        }
    }

    /// Where the wafer is after the transfer.
    pub fn destination(&self) -> Location {
        match self.kind {
            TransferKind::Get => Location::Hand(self.blade),
            TransferKind::Put => self.slot_location(),
        }
    }
}

impl fmt::Display for Transfer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} {}", self.kind, self.station, self.slot)?;
        if self.blade != Blade::A {
            write!(f, " {}", self.blade)?;
        }
        write!(f, " ({})", self.wafer)
    }
}

/// What [`WaferMap::reconcile`] did at start-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reconciled {
    /// No transfer was pending and the hand agrees with the map.
    Consistent,
    /// The pending transfer had happened (GET: a wafer is sensed on the hand; PUT: none is):
    /// it is committed.
    Committed(Transfer),
    /// The pending transfer had not happened (GET: no wafer on the hand; PUT: the wafer is
    /// still held): it is aborted, the wafer stays at its source.
    Aborted(Transfer),
    /// No transfer was pending, the map has this wafer on the blade, but none is sensed: it
    /// was lost or dropped. The map is unchanged; an operator must find the wafer and
    /// [`WaferMap::remove`] or re-place it.
    HandWaferNotSensed(Blade, WaferId),
    /// No transfer was pending and the map has no wafer on the blade, but one is sensed. The
    /// map is unchanged; an operator must identify it ([`WaferMap::place`] on the blade).
    UnknownWaferOnHand(Blade),
}

impl Reconciled {
    /// Whether the map and the sensed hand agree now (no operator action needed).
    pub fn is_consistent(&self) -> bool {
        matches!(
            self,
            Reconciled::Consistent | Reconciled::Committed(_) | Reconciled::Aborted(_)
        )
    }
}

/// What [`WaferMap::settle_interrupted`] did with the interrupted transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interrupted {
    /// The wafer is certainly at the destination.
    Committed(Transfer),
    /// The wafer is certainly at the source.
    Aborted(Transfer),
    /// The wafer may be on the blade, in the slot (or gone): those places are uncertain.
    Uncertain(Transfer),
    /// The wafer is on neither (a sensor said so): it left the map.
    Gone(Transfer),
}

/// What [`WaferMap::sense_blade`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sensed {
    /// The blade holds this wafer, now certain.
    Held(WaferId),
    /// The blade holds a wafer the map did not have: this new id.
    Unknown(WaferId),
    /// The blade holds nothing; the wafer the map had on it may still be elsewhere.
    NotHere(WaferId),
    /// The blade holds nothing, and the wafer the map had on it is nowhere else: it left
    /// the map.
    Gone(WaferId),
    /// The blade holds nothing, as the map said.
    Empty,
}

/// What [`WaferMap::apply_mapping`] changed in a station, slot by slot.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MappingChanges {
    /// Slots with a wafer the map did not know: the new ids.
    pub created: Vec<(u16, WaferId)>,
    /// Slots whose wafer the mapping confirmed: the id is kept.
    pub kept: Vec<(u16, WaferId)>,
    /// Slots where the map had a wafer but the mapping found none or a fault: the ids that
    /// left the map.
    pub removed: Vec<(u16, WaferId)>,
    /// Slots with a double or cross-slotted wafer.
    pub faults: Vec<(u16, SlotFault)>,
}

/// An operation the wafer map refuses, or a wafer map file that cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WaferMapError {
    /// No station of that name in the map.
    #[error("the wafer map has no station named {station:?}")]
    NoSuchStation {
        /// The name asked for.
        station: String,
    },
    /// A slot number the station does not have.
    #[error("station {station} has no slot {slot}: its slots are 1 to {slots}")]
    NoSuchSlot {
        /// The station.
        station: StationName,
        /// The slot asked for.
        slot: u16,
        /// Its slot count.
        slots: u16,
    },
    /// GET from a slot the map says is empty.
    #[error("no GET from {station} slot {slot}: the wafer map says it is empty")]
    SlotEmpty {
        /// The station.
        station: StationName,
        /// The slot.
        slot: u16,
    },
    /// PUT (or place) into a slot that holds a wafer.
    #[error("{station} slot {slot} already holds wafer {wafer}")]
    SlotOccupied {
        /// The station.
        station: StationName,
        /// The slot.
        slot: u16,
        /// The wafer there.
        wafer: WaferId,
    },
    /// A slot with a mapping fault.
    #[error("{station} slot {slot} has a {fault} wafer: fix it by hand, then map the station again (MAP {station})")]
    SlotFault {
        /// The station.
        station: StationName,
        /// The slot.
        slot: u16,
        /// The fault.
        fault: SlotFault,
    },
    /// A slot that was never mapped.
    #[error("{station} slot {slot} has not been mapped: map the station first (MAP {station})")]
    SlotUnknown {
        /// The station.
        station: StationName,
        /// The slot.
        slot: u16,
    },
    /// GET (or place on the hand) with a wafer already on the hand.
    #[error("the hand already holds wafer {wafer}: PUT it somewhere first")]
    HandOccupied {
        /// The wafer on the hand.
        wafer: WaferId,
    },
    /// PUT with no wafer on the hand.
    #[error("no PUT: the wafer map says the hand holds no wafer")]
    HandEmpty,
    /// A transfer names another wafer than the one at its source.
    #[error("the transfer names wafer {expected}, but {location} holds {}", found.map_or_else(|| "no wafer".to_string(), |w| w.to_string()))]
    WrongWafer {
        /// The transfer's source.
        location: Location,
        /// The wafer the transfer names.
        expected: WaferId,
        /// The wafer there, if any.
        found: Option<WaferId>,
    },
    /// An operation while a transfer is pending.
    #[error(
        "transfer {transfer} is still pending: commit or abort it first (at start-up: reconcile)"
    )]
    TransferPending {
        /// The pending transfer.
        transfer: Transfer,
    },
    /// Commit or abort with no transfer pending.
    #[error("no transfer is pending")]
    NoPendingTransfer,
    /// Placing a wafer whose id is already in the map.
    #[error("wafer {wafer} is already in the map, at {at}; an id is held only once")]
    AlreadyInMap {
        /// The wafer.
        wafer: WaferId,
        /// Where it is.
        at: Location,
    },
    /// Removing a wafer from a place that holds none.
    #[error("{location} holds no wafer")]
    NoWafer {
        /// The place.
        location: Location,
    },
    /// A place that is uncertain after an interrupted transfer: GET and PUT refuse it.
    #[error("{}", uncertain_text(location, *wafer))]
    Uncertain {
        /// The place.
        location: Location,
        /// The wafer that may be there.
        wafer: WaferId,
    },
    /// An operator named a wafer the map does not hold.
    #[error("wafer {wafer} is not in the wafer map; WAFERS lists the wafers")]
    NotInMap {
        /// The wafer named.
        wafer: WaferId,
    },
    /// Every id up to `W4294967295` has been handed out.
    #[error(
        "all wafer ids up to W{} have been used; start a new wafer map",
        u32::MAX
    )]
    IdsExhausted,
    /// A mapping result with the wrong number of codes.
    #[error("station {station} has {slots} slots but the mapping reported {got} codes")]
    CodeCount {
        /// The station.
        station: StationName,
        /// Its slot count.
        slots: u16,
        /// Codes reported.
        got: usize,
    },
    /// The stations file no longer has a station or slot that holds a wafer (or the pending
    /// transfer's slot).
    #[error("{location} holds {what} but is no longer in the stations file: restore the station, or move or remove the wafer first")]
    StationGone {
        /// The slot.
        location: Location,
        /// What it holds (`wafer W3`, `the pending transfer`).
        what: String,
    },
    /// The map breaks one of its own rules (a bug, or a hand-edited file).
    #[error("the wafer map is inconsistent: {reason}")]
    Inconsistent {
        /// Which rule.
        reason: String,
    },
    /// The file could not be read.
    #[error("cannot read wafer map {file}: {source}")]
    Read {
        /// The file.
        file: String,
        /// Why.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("cannot write wafer map {file}: {source}; the previous file is unchanged")]
    Write {
        /// The file.
        file: String,
        /// Why.
        source: std::io::Error,
    },
    /// The file is not a usable wafer map: it is never replaced by an empty one.
    #[error("wafer map {file} is corrupt: {reason}; fix or remove the file (removing it forgets every wafer: map all stations again)")]
    Corrupt {
        /// The file.
        file: String,
        /// What is wrong, with the line when the TOML parser gives it.
        reason: String,
    },
    /// A file written by another version of wrc.
    #[error(
        "wafer map {file} has format version {found}; this wrc reads versions 1 to {supported}"
    )]
    Version {
        /// The file.
        file: String,
        /// The version in the file.
        found: i64,
        /// The version this build reads and writes.
        supported: u32,
    },
}

/// The text of [`WaferMapError::Uncertain`].
fn uncertain_text(location: &Location, wafer: WaferId) -> String {
    match location {
        Location::Hand(_) => format!(
            "wafer {wafer} on the {location} is uncertain after an interrupted transfer: SENSE the blade (or CONFIRM what it holds) first"
        ),
        Location::Slot { station, slot } => format!(
            "{station} slot {slot} is uncertain after an interrupted transfer (perhaps {wafer}, perhaps empty): MAP {station} (or CONFIRM what it holds) first"
        ),
    }
}

#[derive(Debug, Clone, PartialEq, Eq)]
struct MapStation {
    name: StationName,
    slots: Vec<SlotState>,
}

/// Where every wafer is. See the module docs for the guarantees and the file format.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WaferMap {
    stations: Vec<MapStation>,
    /// The wafer on each blade (A, B).
    hands: [Option<WaferId>; MAX_BLADES],
    /// Whether the robot has blade B (`WAFERS` shows `hand.B` then); not saved: it is the
    /// robot's, not the map's.
    dual: bool,
    pending: Option<Transfer>,
    /// The wafer on each blade is uncertain: the motion board stopped answering while it was
    /// there, so no sensor has confirmed it since ([`WaferMap::mark_uncertain`]).
    uncertain: [bool; MAX_BLADES],
    /// The next new id; every id in the map is below it. Up to `u32::MAX + 1`.
    next_id: u64,
    /// What left places uncertain (an interrupted transfer's judgement), kept while any
    /// place is uncertain.
    note: Option<String>,
}

impl Default for WaferMap {
    /// No stations, nothing on the hand, the next id `W1`.
    fn default() -> Self {
        WaferMap {
            stations: Vec::new(),
            hands: [None; MAX_BLADES],
            dual: false,
            pending: None,
            uncertain: [false; MAX_BLADES],
            next_id: 1,
            note: None,
        }
    }
}

const MAX_NEXT_ID: u64 = u32::MAX as u64 + 1;

impl WaferMap {
    /// A map of `stations` with every slot unknown and the hand empty.
    pub fn new(stations: &Stations) -> WaferMap {
        WaferMap {
            stations: stations
                .iter()
                .map(|s| MapStation {
                    name: s.name,
                    slots: vec![SlotState::Unknown; usize::from(s.slots)],
                })
                .collect(),
            ..WaferMap::default()
        }
    }

    /// Follow a changed stations file: stations and slots in the file's order, new ones
    /// unknown, names spelled as in the file. Refused, changing nothing, when a station or
    /// slot that goes away holds a wafer or the pending transfer.
    pub fn adopt_stations(&mut self, stations: &Stations) -> Result<(), WaferMapError> {
        let mut new = Vec::with_capacity(stations.len());
        for s in stations {
            let n = usize::from(s.slots);
            let mut slots = match self.station_index(s.name.as_str()) {
                Some(i) => self.stations[i].slots.clone(),
                None => Vec::new(),
            };
            for (i, state) in slots.iter().enumerate().skip(n) {
                let slot = (i + 1) as u16;
                self.check_goes_away(s.name, slot, *state)?;
            }
            slots.resize(n, SlotState::Unknown);
            new.push(MapStation {
                name: s.name,
                slots,
            });
        }
        for old in &self.stations {
            if stations.get(old.name.as_str()).is_none() {
                for (i, state) in old.slots.iter().enumerate() {
                    self.check_goes_away(old.name, (i + 1) as u16, *state)?;
                }
            }
        }
        if let Some(t) = &mut self.pending {
            // Its slot survived (checked above): follow the file's spelling of the name.
            if let Some(s) = stations.get(t.station.as_str()) {
                t.station = s.name;
            }
        }
        self.stations = new;
        Ok(())
    }

    fn check_goes_away(
        &self,
        station: StationName,
        slot: u16,
        state: SlotState,
    ) -> Result<(), WaferMapError> {
        let location = Location::Slot { station, slot };
        if let SlotState::Wafer(w) | SlotState::Uncertain(w) = state {
            return Err(WaferMapError::StationGone {
                location,
                what: format!("wafer {w}"),
            });
        }
        if let Some(t) = &self.pending {
            if same_name(t.station.as_str(), station.as_str()) && t.slot == slot {
                return Err(WaferMapError::StationGone {
                    location,
                    what: "the pending transfer".into(),
                });
            }
        }
        Ok(())
    }

    fn station_index(&self, name: &str) -> Option<usize> {
        self.stations
            .iter()
            .position(|s| same_name(s.name.as_str(), name))
    }

    fn find(&self, station: &str, slot: u16) -> Result<(usize, usize), WaferMapError> {
        let si = self
            .station_index(station)
            .ok_or_else(|| WaferMapError::NoSuchStation {
                station: station.chars().take(40).collect(),
            })?;
        let s = &self.stations[si];
        let slots = s.slots.len() as u16;
        if slot == 0 || slot > slots {
            return Err(WaferMapError::NoSuchSlot {
                station: s.name,
                slot,
                slots,
            });
        }
        Ok((si, usize::from(slot - 1)))
    }

    /// The state of slot `slot` of station `station` (name ignoring case).
    pub fn slot(&self, station: &str, slot: u16) -> Result<SlotState, WaferMapError> {
        let (si, i) = self.find(station, slot)?;
        Ok(self.stations[si].slots[i])
    }

    /// Every slot's state of station `station`, slot 1 first.
    pub fn slots(&self, station: &str) -> Option<&[SlotState]> {
        self.station_index(station)
            .map(|i| self.stations[i].slots.as_slice())
    }

    /// The stations of the map, in order.
    pub fn station_names(&self) -> impl Iterator<Item = StationName> + '_ {
        self.stations.iter().map(|s| s.name)
    }

    /// The wafer on the hand (blade A).
    pub fn hand(&self) -> Option<WaferId> {
        self.hands[0]
    }

    /// The wafer on `blade`.
    pub fn hand_of(&self, blade: Blade) -> Option<WaferId> {
        self.hands[blade.index()]
    }

    /// Say whether the robot has blade B (a dual-blade robot): `WAFERS` then lists
    /// `hand.B` too.
    pub fn set_dual(&mut self, dual: bool) {
        self.dual = dual;
    }

    /// Whether the map is a dual-blade robot's (or holds a wafer on blade B).
    pub fn is_dual(&self) -> bool {
        self.dual || self.hands[1].is_some()
    }

    /// The transfer in progress, if any.
    pub fn pending(&self) -> Option<&Transfer> {
        self.pending.as_ref()
    }

    /// The wafer at `location`, if any (none for an unknown place).
    pub fn wafer_at(&self, location: &Location) -> Option<WaferId> {
        match location {
            Location::Hand(b) => self.hands[b.index()],
            Location::Slot { station, slot } => match self.slot(station.as_str(), *slot) {
                Ok(SlotState::Wafer(w)) => Some(w),
                _ => None,
            },
        }
    }

    /// Where wafer `id` is.
    pub fn location_of(&self, id: WaferId) -> Option<Location> {
        self.iter().find(|&(_, w)| w == id).map(|(at, _)| at)
    }

    /// Every wafer and where it is: station slots in order, then the hand. An uncertain
    /// wafer ([`WaferMap::is_certain`]) is listed at each place it may be.
    pub fn iter(&self) -> impl Iterator<Item = (Location, WaferId)> + '_ {
        self.stations
            .iter()
            .flat_map(|s| {
                s.slots
                    .iter()
                    .enumerate()
                    .filter_map(move |(i, state)| match state {
                        SlotState::Wafer(w) | SlotState::Uncertain(w) => Some((
                            Location::Slot {
                                station: s.name,
                                slot: (i + 1) as u16,
                            },
                            *w,
                        )),
                        _ => None,
                    })
            })
            .chain(
                Blade::ALL
                    .into_iter()
                    .filter_map(|b| self.hands[b.index()].map(|w| (Location::Hand(b), w))),
            )
    }

    /// Number of wafers in the map (an uncertain wafer once, however many places it may
    /// be in).
    pub fn len(&self) -> usize {
        let mut ids: Vec<WaferId> = self.iter().map(|(_, w)| w).collect();
        ids.sort_unstable();
        ids.dedup();
        ids.len()
    }

    /// Whether the wafer the map has at `location` is certain there (false for a place
    /// that holds none).
    pub fn is_certain(&self, location: &Location) -> bool {
        match location {
            Location::Hand(b) => self.hands[b.index()].is_some() && !self.uncertain[b.index()],
            Location::Slot { station, slot } => {
                matches!(self.slot(station.as_str(), *slot), Ok(SlotState::Wafer(_)))
            }
        }
    }

    /// Whether anything in the map is uncertain (a place that may or may not hold a wafer).
    pub fn has_uncertain(&self) -> bool {
        self.uncertain
            .iter()
            .zip(&self.hands)
            .any(|(u, h)| *u && h.is_some())
            || self.stations.iter().any(|s| {
                s.slots
                    .iter()
                    .any(|st| matches!(st, SlotState::Uncertain(_)))
            })
    }

    /// Every uncertain place and the wafer that may be there.
    pub fn uncertain_places(&self) -> Vec<(Location, WaferId)> {
        self.iter().filter(|(at, _)| !self.is_certain(at)).collect()
    }

    /// What left places uncertain (kept while any is), for the operator.
    pub fn note(&self) -> Option<&str> {
        self.note.as_deref()
    }

    /// Record what left places uncertain ([`WaferMap::note`]); a text is kept only while a
    /// place is uncertain, and at most 400 bytes of it.
    pub fn set_note(&mut self, text: &str) {
        let mut end = text.len().min(400);
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        self.note = Some(text[..end].to_string());
        self.tidy();
    }

    /// Forget the note once nothing is uncertain.
    fn tidy(&mut self) {
        for (u, h) in self.uncertain.iter_mut().zip(&self.hands) {
            if h.is_none() {
                *u = false;
            }
        }
        if !self.has_uncertain() {
            self.note = None;
        }
    }

    /// Whether the map holds no wafer.
    pub fn is_empty(&self) -> bool {
        self.iter().next().is_none()
    }

    /// The next id, never used before in this map.
    pub fn new_id(&mut self) -> Result<WaferId, WaferMapError> {
        if self.next_id >= MAX_NEXT_ID {
            return Err(WaferMapError::IdsExhausted);
        }
        let id = WaferId(self.next_id as u32);
        self.next_id += 1;
        Ok(id)
    }

    fn refuse_if_pending(&self) -> Result<(), WaferMapError> {
        match self.pending {
            Some(transfer) => Err(WaferMapError::TransferPending { transfer }),
            None => Ok(()),
        }
    }

    /// Put wafer `id` at `location` by hand (an operator placed or identified it). Refused
    /// while a transfer is pending, when the id is already in the map, or the place holds a
    /// wafer or a fault. An unknown slot becomes known. Later new ids stay above `id`.
    pub fn place(&mut self, location: Location, id: WaferId) -> Result<(), WaferMapError> {
        self.refuse_if_pending()?;
        if let Some(at) = self.location_of(id) {
            return Err(WaferMapError::AlreadyInMap { wafer: id, at });
        }
        match location {
            Location::Hand(b) => {
                if let Some(wafer) = self.hands[b.index()] {
                    return Err(WaferMapError::HandOccupied { wafer });
                }
                self.hands[b.index()] = Some(id);
                self.uncertain[b.index()] = false;
            }
            Location::Slot { station, slot } => {
                let (si, i) = self.find(station.as_str(), slot)?;
                let name = self.stations[si].name;
                match self.stations[si].slots[i] {
                    SlotState::Empty | SlotState::Unknown => {}
                    SlotState::Wafer(wafer) => {
                        return Err(WaferMapError::SlotOccupied {
                            station: name,
                            slot,
                            wafer,
                        })
                    }
                    SlotState::Fault(fault) => {
                        return Err(WaferMapError::SlotFault {
                            station: name,
                            slot,
                            fault,
                        })
                    }
                    SlotState::Uncertain(wafer) => {
                        return Err(WaferMapError::Uncertain { location, wafer })
                    }
                }
                self.stations[si].slots[i] = SlotState::Wafer(id);
            }
        }
        self.next_id = self.next_id.max(u64::from(id.0) + 1);
        Ok(())
    }

    /// Take the wafer at `location` out of the map (an operator removed it); returns its id.
    /// Refused while a transfer is pending.
    pub fn remove(&mut self, location: Location) -> Result<WaferId, WaferMapError> {
        self.refuse_if_pending()?;
        match location {
            Location::Hand(b) => {
                self.uncertain[b.index()] = false;
                self.hands[b.index()]
                    .take()
                    .ok_or(WaferMapError::NoWafer { location })
            }
            Location::Slot { station, slot } => {
                let (si, i) = self.find(station.as_str(), slot)?;
                match self.stations[si].slots[i] {
                    SlotState::Wafer(w) => {
                        self.stations[si].slots[i] = SlotState::Empty;
                        Ok(w)
                    }
                    _ => Err(WaferMapError::NoWafer { location }),
                }
            }
        }
    }

    /// Set a station's slots from a mapping scan (`codes`, slot 1 first): present → the
    /// wafer the map already had there, or a new id; absent → empty; double or cross → that
    /// fault (GET and PUT refuse it). Ids of wafers the scan did not find leave the map and
    /// are reported. Refused while a transfer is pending.
    pub fn apply_mapping(
        &mut self,
        station: &str,
        codes: &[SlotCode],
    ) -> Result<MappingChanges, WaferMapError> {
        self.refuse_if_pending()?;
        let si = self
            .station_index(station)
            .ok_or_else(|| WaferMapError::NoSuchStation {
                station: station.chars().take(40).collect(),
            })?;
        let s = &self.stations[si];
        if codes.len() != s.slots.len() {
            return Err(WaferMapError::CodeCount {
                station: s.name,
                slots: s.slots.len() as u16,
                got: codes.len(),
            });
        }
        let needed = codes
            .iter()
            .zip(&s.slots)
            .filter(|(c, old)| {
                **c == SlotCode::Present
                    && !matches!(old, SlotState::Wafer(_) | SlotState::Uncertain(_))
            })
            .count() as u64;
        if self.next_id + needed > MAX_NEXT_ID {
            return Err(WaferMapError::IdsExhausted);
        }
        let mut changes = MappingChanges::default();
        let mut slots = s.slots.clone();
        // Uncertain wafers the scan found here (they are nowhere else), and those it did
        // not (they may still be elsewhere).
        let mut found = Vec::new();
        let mut not_here = Vec::new();
        for (i, (state, code)) in slots.iter_mut().zip(codes).enumerate() {
            let slot = (i + 1) as u16;
            let old = *state;
            if let SlotState::Uncertain(w) = old {
                if *code == SlotCode::Present {
                    found.push(w);
                } else {
                    not_here.push((slot, w));
                }
            }
            *state = match code {
                SlotCode::Present => match old {
                    SlotState::Wafer(w) | SlotState::Uncertain(w) => {
                        changes.kept.push((slot, w));
                        SlotState::Wafer(w)
                    }
                    _ => {
                        let w = WaferId(self.next_id as u32);
                        self.next_id += 1;
                        changes.created.push((slot, w));
                        SlotState::Wafer(w)
                    }
                },
                SlotCode::Absent => SlotState::Empty,
                SlotCode::Double => SlotState::Fault(SlotFault::Double),
                SlotCode::Cross => SlotState::Fault(SlotFault::Cross),
            };
            if let (SlotState::Wafer(w), false) = (old, *code == SlotCode::Present) {
                changes.removed.push((slot, w));
            }
            if let SlotState::Fault(f) = *state {
                changes.faults.push((slot, f));
            }
        }
        self.stations[si].slots = slots;
        for w in found {
            self.forget_elsewhere(
                w,
                Location::Slot {
                    station: self.stations[si].name,
                    slot: 0,
                },
            );
        }
        // A wafer the scan did not find in its uncertain slot, and that may be nowhere
        // else, leaves the map on the mapping sensor's word.
        for (slot, w) in not_here {
            if self.location_of(w).is_none() {
                changes.removed.push((slot, w));
            }
        }
        self.tidy();
        Ok(changes)
    }

    /// Wafer `w` is certain at `kept` (a slot of station `kept` with slot 0: every slot of
    /// that station is spared): clear every other place that holds it, uncertain or not.
    fn forget_elsewhere(&mut self, w: WaferId, kept: Location) {
        for b in Blade::ALL {
            let i = b.index();
            if self.hands[i] == Some(w) && kept != Location::Hand(b) {
                self.hands[i] = None;
                self.uncertain[i] = false;
            }
        }
        for s in &mut self.stations {
            for (i, st) in s.slots.iter_mut().enumerate() {
                let here = Location::Slot {
                    station: s.name,
                    slot: (i + 1) as u16,
                };
                let spared = match kept {
                    Location::Slot { station, slot: 0 } => station == s.name,
                    other => other == here,
                };
                let holds = matches!(st, SlotState::Wafer(x) | SlotState::Uncertain(x) if *x == w);
                if holds && !spared {
                    *st = SlotState::Empty;
                }
            }
        }
    }

    /// Check a transfer with the hand (blade A) against the map and build it with the wafer
    /// it moves: [`WaferMap::prepare_blade`] with blade A.
    pub fn prepare(
        &self,
        kind: TransferKind,
        station: &str,
        slot: u16,
    ) -> Result<Transfer, WaferMapError> {
        self.prepare_blade(kind, station, slot, Blade::A)
    }

    /// Check a transfer with `blade` against the map and build it with the wafer it moves:
    /// GET needs an empty blade and a wafer in the slot; PUT a wafer on the blade and an
    /// empty slot. Unknown and faulty slots are refused, and so is anything while a transfer
    /// is pending. Changes nothing.
    pub fn prepare_blade(
        &self,
        kind: TransferKind,
        station: &str,
        slot: u16,
        blade: Blade,
    ) -> Result<Transfer, WaferMapError> {
        self.refuse_if_pending()?;
        let (si, i) = self.find(station, slot)?;
        let name = self.stations[si].name;
        let state = self.stations[si].slots[i];
        match state {
            SlotState::Unknown => {
                return Err(WaferMapError::SlotUnknown {
                    station: name,
                    slot,
                })
            }
            SlotState::Fault(fault) => {
                return Err(WaferMapError::SlotFault {
                    station: name,
                    slot,
                    fault,
                })
            }
            SlotState::Uncertain(wafer) => {
                return Err(WaferMapError::Uncertain {
                    location: Location::Slot {
                        station: name,
                        slot,
                    },
                    wafer,
                })
            }
            SlotState::Empty | SlotState::Wafer(_) => {}
        }
        if let (Some(wafer), true) = (self.hands[blade.index()], self.uncertain[blade.index()]) {
            return Err(WaferMapError::Uncertain {
                location: Location::Hand(blade),
                wafer,
            });
        }
        let wafer = match kind {
            TransferKind::Get => {
                if let Some(wafer) = self.hands[blade.index()] {
                    return Err(WaferMapError::HandOccupied { wafer });
                }
                match state {
                    SlotState::Wafer(w) => w,
                    _ => {
                        return Err(WaferMapError::SlotEmpty {
                            station: name,
                            slot,
                        })
                    }
                }
            }
            TransferKind::Put => {
                let Some(w) = self.hands[blade.index()] else {
                    return Err(WaferMapError::HandEmpty);
                };
                if let SlotState::Wafer(wafer) = state {
                    return Err(WaferMapError::SlotOccupied {
                        station: name,
                        slot,
                        wafer,
                    });
                }
                w
            }
        };
        Ok(Transfer {
            kind,
            station: name,
            slot,
            wafer,
            blade,
        })
    }

    /// Record `transfer` as pending (save the map before the robot moves). It must pass
    /// [`WaferMap::prepare`] and name the wafer at its source.
    pub fn begin(&mut self, transfer: Transfer) -> Result<(), WaferMapError> {
        let checked = self.prepare_blade(
            transfer.kind,
            transfer.station.as_str(),
            transfer.slot,
            transfer.blade,
        )?;
        if checked.wafer != transfer.wafer {
            return Err(WaferMapError::WrongWafer {
                location: checked.source(),
                expected: transfer.wafer,
                found: Some(checked.wafer),
            });
        }
        self.pending = Some(checked);
        Ok(())
    }

    /// The pending transfer happened (the vacuum sensor confirmed it): move its wafer to the
    /// destination (save the map now). Returns the transfer.
    pub fn commit(&mut self) -> Result<Transfer, WaferMapError> {
        let t = self.pending.ok_or(WaferMapError::NoPendingTransfer)?;
        // begin() checked the source and destination, and nothing else may change while a
        // transfer is pending, so these indices are valid.
        let (si, i) = self.find(t.station.as_str(), t.slot)?;
        match t.kind {
            TransferKind::Get => {
                self.stations[si].slots[i] = SlotState::Empty;
                self.hands[t.blade.index()] = Some(t.wafer);
                self.uncertain[t.blade.index()] = false;
            }
            TransferKind::Put => {
                self.hands[t.blade.index()] = None;
                self.uncertain[t.blade.index()] = false;
                self.stations[si].slots[i] = SlotState::Wafer(t.wafer);
            }
        }
        self.pending = None;
        Ok(t)
    }

    /// The pending transfer did not happen: the wafer stays at its source. Returns the
    /// transfer.
    pub fn abort(&mut self) -> Result<Transfer, WaferMapError> {
        self.pending.take().ok_or(WaferMapError::NoPendingTransfer)
    }

    /// The sensor-only rule, for a map without a transfer journal whose sensors are known
    /// good (the controller judges with the journal instead: [`crate::journal::judge`] and
    /// [`WaferMap::settle_interrupted`]): resolve a pending transfer from whether the
    /// vacuum sensor of each blade senses a wafer (`sensed[blade.index()]`; a single-hand
    /// robot gives `false` for blade B), or compare the blades with the map (the first that
    /// disagrees is reported). See [`Reconciled`]. Never adds or drops an id.
    ///
    /// A blade whose wafer was uncertain ([`WaferMap::mark_uncertain`]) is certain again when
    /// its sensor senses a wafer (or the blade ends up empty); one that senses none stays
    /// uncertain, reported as [`Reconciled::HandWaferNotSensed`].
    pub fn reconcile(&mut self, sensed: [bool; MAX_BLADES]) -> Reconciled {
        let r = self.settle(sensed);
        for b in Blade::ALL {
            let i = b.index();
            if self.hands[i].is_none() {
                self.uncertain[i] = false;
            } else if sensed[i] && self.uncertain[i] {
                // Sensed: certain on this blade, so nowhere else it was perhaps (its slot,
                // the other blade).
                self.uncertain[i] = false;
                if let Some(w) = self.hands[i] {
                    self.forget_elsewhere(w, Location::Hand(b));
                }
            }
        }
        r
    }

    /// The board stopped answering: every wafer the map has on a blade is uncertain until a
    /// sensor confirms it ([`WaferMap::reconcile`]) or an operator places or removes it. A
    /// pending transfer stays pending (its wafer is at its source or on the blade). Returns
    /// how many wafers became uncertain.
    pub fn mark_uncertain(&mut self) -> usize {
        let mut n = 0;
        for (flag, hand) in self.uncertain.iter_mut().zip(&self.hands) {
            if hand.is_some() && !*flag {
                *flag = true;
                n += 1;
            }
        }
        n
    }

    /// The vacuum sensor of `blade` stopped sensing its wafer: the wafer stays in the map,
    /// uncertain, until a sensor reading with the valve on ([`WaferMap::sense_blade`]) or an
    /// operator settles it. The sensor cannot tell a wafer that fell from one it no longer
    /// sees.
    /// False (nothing changed) when the map has no wafer on the blade.
    pub fn mark_blade_uncertain(&mut self, blade: Blade) -> bool {
        let i = blade.index();
        if self.hands[i].is_none() {
            return false;
        }
        self.uncertain[i] = true;
        true
    }

    /// A GET committed when the power failed, its hand perhaps still in the slot: the
    /// wafer on `blade` may have fallen back into the (empty) slot at `location`. Both
    /// become uncertain. False (nothing changed) unless the blade holds a wafer and the
    /// slot is empty.
    pub fn doubt_back_in_slot(&mut self, blade: Blade, location: Location) -> bool {
        let (Some(w), Location::Slot { station, slot }) = (self.hands[blade.index()], location)
        else {
            return false;
        };
        let Ok((si, i)) = self.find(station.as_str(), slot) else {
            return false;
        };
        if self.stations[si].slots[i] != SlotState::Empty {
            return false;
        }
        self.stations[si].slots[i] = SlotState::Uncertain(w);
        self.uncertain[blade.index()] = true;
        true
    }

    /// Whether the wafer on `blade` is uncertain ([`WaferMap::mark_uncertain`]).
    pub fn is_uncertain(&self, blade: Blade) -> bool {
        self.uncertain[blade.index()]
    }

    /// Settle the pending transfer after it was interrupted, as the transfer journal
    /// judged it ([`crate::journal::judge`]): its wafer is certainly, perhaps or not on its
    /// blade and in its slot. A place that is `Perhaps` becomes uncertain (the wafer shows
    /// there with a `?`, GET and PUT refuse it); `Yes` on one side makes the other `No`.
    /// `No` on both sides takes the wafer out of the map, and the result names the wafer
    /// ([`crate::journal::judge`] never gives it: the sensor alone does not say where a
    /// wafer went).
    pub fn settle_interrupted(
        &mut self,
        on_blade: Maybe,
        in_slot: Maybe,
    ) -> Result<Interrupted, WaferMapError> {
        let t = self.pending.ok_or(WaferMapError::NoPendingTransfer)?;
        let (si, i) = self.find(t.station.as_str(), t.slot)?;
        let b = t.blade.index();
        let (on_blade, in_slot) = match (on_blade, in_slot) {
            (Maybe::Yes, _) => (Maybe::Yes, Maybe::No),
            (_, Maybe::Yes) => (Maybe::No, Maybe::Yes),
            other => other,
        };
        self.hands[b] = (on_blade != Maybe::No).then_some(t.wafer);
        self.uncertain[b] = on_blade == Maybe::Perhaps;
        self.stations[si].slots[i] = match in_slot {
            Maybe::Yes => SlotState::Wafer(t.wafer),
            Maybe::Perhaps => SlotState::Uncertain(t.wafer),
            Maybe::No => SlotState::Empty,
        };
        self.pending = None;
        self.tidy();
        Ok(match (on_blade, in_slot) {
            (Maybe::No, Maybe::No) => Interrupted::Gone(t),
            (Maybe::Yes, _) | (_, Maybe::Yes) => {
                let at_destination = match t.kind {
                    TransferKind::Get => on_blade == Maybe::Yes,
                    TransferKind::Put => in_slot == Maybe::Yes,
                };
                if at_destination {
                    Interrupted::Committed(t)
                } else {
                    Interrupted::Aborted(t)
                }
            }
            _ => Interrupted::Uncertain(t),
        })
    }

    /// The vacuum sensor of `blade`, read with its valve on and the hand out of every
    /// station (`SENSE`): a wafer sensed is certain on the blade (a wafer the map did not
    /// have gets a new id), and wherever else the map had it uncertain is empty; none sensed
    /// empties the blade, and a wafer that may then be nowhere else leaves the map on the
    /// sensor's word. Refused while a transfer is pending.
    pub fn sense_blade(&mut self, blade: Blade, sensed: bool) -> Result<Sensed, WaferMapError> {
        self.refuse_if_pending()?;
        let b = blade.index();
        let result = match (self.hands[b], sensed) {
            (Some(w), true) => {
                self.uncertain[b] = false;
                self.forget_elsewhere(w, Location::Hand(blade));
                Sensed::Held(w)
            }
            (None, true) => {
                let w = self.new_id()?;
                self.hands[b] = Some(w);
                self.uncertain[b] = false;
                Sensed::Unknown(w)
            }
            (Some(w), false) => {
                self.hands[b] = None;
                self.uncertain[b] = false;
                if self.location_of(w).is_none() {
                    Sensed::Gone(w)
                } else {
                    Sensed::NotHere(w)
                }
            }
            (None, false) => Sensed::Empty,
        };
        self.tidy();
        Ok(result)
    }

    /// An operator's word: wafer `w` is at `location` (`CONFIRM W3 LP2 1`, `CONFIRM W3
    /// HAND`). The place becomes certain with it, and every other place the map had it in
    /// is empty. Refused while a transfer is pending, for a wafer the map does not hold, and
    /// for a place that holds (or may hold) another wafer or a fault.
    pub fn confirm_at(&mut self, w: WaferId, location: Location) -> Result<(), WaferMapError> {
        self.refuse_if_pending()?;
        if self.location_of(w).is_none() {
            return Err(WaferMapError::NotInMap { wafer: w });
        }
        match location {
            Location::Hand(b) => match self.hands[b.index()] {
                Some(other) if other != w => {
                    return Err(WaferMapError::HandOccupied { wafer: other })
                }
                _ => {
                    self.hands[b.index()] = Some(w);
                    self.uncertain[b.index()] = false;
                }
            },
            Location::Slot { station, slot } => {
                let (si, i) = self.find(station.as_str(), slot)?;
                let name = self.stations[si].name;
                match self.stations[si].slots[i] {
                    SlotState::Wafer(other) | SlotState::Uncertain(other) if other != w => {
                        return Err(WaferMapError::SlotOccupied {
                            station: name,
                            slot,
                            wafer: other,
                        })
                    }
                    SlotState::Fault(fault) => {
                        return Err(WaferMapError::SlotFault {
                            station: name,
                            slot,
                            fault,
                        })
                    }
                    _ => self.stations[si].slots[i] = SlotState::Wafer(w),
                }
            }
        }
        let kept = match location {
            Location::Slot { station, slot } => Location::Slot {
                station: self.stations[self.station_index(station.as_str()).unwrap_or(0)].name,
                slot,
            },
            hand => hand,
        };
        self.forget_elsewhere(w, kept);
        self.tidy();
        Ok(())
    }

    /// An operator's word: wafer `w` is gone from the cell (`CONFIRM W3 GONE`): it leaves
    /// the map from every place it was (or may have been) in; returns them.
    pub fn confirm_gone(&mut self, w: WaferId) -> Result<Vec<Location>, WaferMapError> {
        self.refuse_if_pending()?;
        let places: Vec<Location> = self
            .iter()
            .filter(|(_, id)| *id == w)
            .map(|(at, _)| at)
            .collect();
        if places.is_empty() {
            return Err(WaferMapError::NotInMap { wafer: w });
        }
        for at in &places {
            self.clear_place(at);
        }
        self.tidy();
        Ok(places)
    }

    /// An operator's word: `location` is empty (`CONFIRM HAND EMPTY`, `CONFIRM LP2 1
    /// EMPTY`). The wafer the map had (or perhaps had) there leaves it; one that may then
    /// be nowhere else leaves the map, and is returned. An unknown slot becomes empty;
    /// a faulty one is refused (MAP it).
    pub fn confirm_empty(&mut self, location: Location) -> Result<Option<WaferId>, WaferMapError> {
        self.refuse_if_pending()?;
        let had = match location {
            Location::Hand(b) => self.hands[b.index()],
            Location::Slot { station, slot } => {
                let (si, i) = self.find(station.as_str(), slot)?;
                match self.stations[si].slots[i] {
                    SlotState::Fault(fault) => {
                        return Err(WaferMapError::SlotFault {
                            station: self.stations[si].name,
                            slot,
                            fault,
                        })
                    }
                    SlotState::Wafer(w) | SlotState::Uncertain(w) => Some(w),
                    SlotState::Empty | SlotState::Unknown => None,
                }
            }
        };
        self.clear_place(&location);
        self.tidy();
        Ok(had.filter(|w| self.location_of(*w).is_none()))
    }

    /// Empty a place (a slot becomes empty, a blade holds nothing).
    fn clear_place(&mut self, at: &Location) {
        match at {
            Location::Hand(b) => {
                self.hands[b.index()] = None;
                self.uncertain[b.index()] = false;
            }
            Location::Slot { station, slot } => {
                if let Ok((si, i)) = self.find(station.as_str(), *slot) {
                    self.stations[si].slots[i] = SlotState::Empty;
                }
            }
        }
    }

    fn settle(&mut self, sensed: [bool; MAX_BLADES]) -> Reconciled {
        if let Some(t) = self.pending {
            let hand_has_wafer = sensed[t.blade.index()];
            let happened = match t.kind {
                TransferKind::Get => hand_has_wafer,
                TransferKind::Put => !hand_has_wafer,
            };
            if happened {
                // Cannot fail in a verified map (begin checked the slot); if it did, nothing
                // moved, so aborting keeps the wafer at its source.
                if let Ok(t) = self.commit() {
                    return Reconciled::Committed(t);
                }
            }
            self.pending = None;
            return Reconciled::Aborted(t);
        }
        for b in Blade::ALL {
            match (self.hands[b.index()], sensed[b.index()]) {
                (Some(w), false) => return Reconciled::HandWaferNotSensed(b, w),
                (None, true) => return Reconciled::UnknownWaferOnHand(b),
                _ => {}
            }
        }
        Reconciled::Consistent
    }

    /// Check the map's rules: station names valid and unique, 1 to 50 slots each, no id
    /// twice, every id below the next id, and a pending transfer's wafer at its source with
    /// its destination free.
    pub fn verify(&self) -> Result<(), WaferMapError> {
        let bad = |reason: String| Err(WaferMapError::Inconsistent { reason });
        for (i, s) in self.stations.iter().enumerate() {
            if self.stations[..i]
                .iter()
                .any(|o| same_name(o.name.as_str(), s.name.as_str()))
            {
                return bad(format!("station {} is listed twice", s.name));
            }
            if s.slots.is_empty() || s.slots.len() > usize::from(MAX_SLOTS) {
                return bad(format!(
                    "station {} has {} slots; a station has 1 to {MAX_SLOTS}",
                    s.name,
                    s.slots.len()
                ));
            }
        }
        if self.next_id == 0 || self.next_id > MAX_NEXT_ID {
            return bad(format!(
                "next_id {} is not between 1 and {MAX_NEXT_ID}",
                self.next_id
            ));
        }
        let mut seen: Vec<(WaferId, Location)> = Vec::new();
        for (at, w) in self.iter() {
            // An uncertain wafer may be listed at each place it may be in; a certain one is
            // at one place only, and nowhere else even uncertain.
            if let Some((_, first)) = seen.iter().find(|(id, _)| *id == w) {
                if self.is_certain(first) || self.is_certain(&at) {
                    return bad(format!("wafer {w} is both at {first} and at {at}"));
                }
                continue;
            }
            if u64::from(w.0) >= self.next_id {
                return bad(format!(
                    "wafer {w} at {at} is not below next_id {}",
                    self.next_id
                ));
            }
            seen.push((w, at));
        }
        if let Some(t) = &self.pending {
            let state = match self.find(t.station.as_str(), t.slot) {
                Ok((si, i)) => self.stations[si].slots[i],
                Err(e) => return bad(format!("the pending transfer {t}: {e}")),
            };
            let hand = self.hands[t.blade.index()];
            let ok = match t.kind {
                TransferKind::Get => state == SlotState::Wafer(t.wafer) && hand.is_none(),
                TransferKind::Put => hand == Some(t.wafer) && state == SlotState::Empty,
            };
            if !ok {
                return bad(format!(
                    "the pending transfer {t} does not match the map: its wafer must be at {} and {} must be free",
                    t.source(),
                    t.destination()
                ));
            }
        }
        Ok(())
    }

    /// The map as wafer-map file text (TOML, see the module docs).
    pub fn to_text(&self) -> String {
        let raw = RawMap {
            version: i64::from(FORMAT_VERSION),
            next_id: self.next_id as i64,
            hand: self.hands[0].map(|w| w.to_string()),
            hand_b: self.hands[1].map(|w| w.to_string()),
            hand_uncertain: self.uncertain[0],
            hand_b_uncertain: self.uncertain[1],
            note: self.note.clone(),
            pending: self.pending.map(|t| RawPending {
                kind: match t.kind {
                    TransferKind::Get => "get".into(),
                    TransferKind::Put => "put".into(),
                },
                station: t.station.to_string(),
                slot: i64::from(t.slot),
                wafer: t.wafer.to_string(),
                blade: (t.blade != Blade::A).then(|| t.blade.to_string()),
            }),
            station: self
                .stations
                .iter()
                .map(|s| RawMapStation {
                    name: s.name.to_string(),
                    slots: s.slots.iter().map(|st| file_token(*st)).collect(),
                })
                .collect(),
        };
        let body = toml::to_string(&raw)
            .unwrap_or_else(|e| format!("# could not write the wafer map: {e}\n"));
        format!(
            "# wrc wafer map: where every wafer is. Written atomically by the controller on \
             every change;\n# do not edit while it runs. Format: the wrc-cell crate's \
             wafer_map module.\n{body}\n{END_LINE}\n"
        )
    }

    /// Parse wafer-map file text; `file` names it in errors. Anything unusable — bad TOML,
    /// an unknown key, a bad token, a broken rule ([`WaferMap::verify`]) — is an error, never
    /// an empty map.
    pub fn from_text(text: &str, file: &str) -> Result<WaferMap, WaferMapError> {
        let corrupt = |reason: String| WaferMapError::Corrupt {
            file: file.to_string(),
            reason,
        };
        let toml_err = |e: toml::de::Error| corrupt(e.to_string().trim_end().replace('\n', "\n  "));
        // The version first, so a newer format is named as such rather than as unknown keys.
        let version: RawVersion = toml::from_str(text).map_err(toml_err)?;
        match version.version {
            None => return Err(corrupt("it has no format version (version = 3)".into())),
            // Version 1 had no end line.
            Some(1) => {}
            Some(v) if (2..=i64::from(FORMAT_VERSION)).contains(&v) => {
                if text.trim_end().lines().next_back().map(str::trim) != Some(END_LINE) {
                    return Err(corrupt(format!(
                        "it does not end with the line `{END_LINE}`: it was cut short"
                    )));
                }
            }
            Some(v) => {
                return Err(WaferMapError::Version {
                    file: file.to_string(),
                    found: v,
                    supported: FORMAT_VERSION,
                })
            }
        }
        let raw: RawMap = toml::from_str(text).map_err(toml_err)?;
        let mut map = WaferMap {
            stations: Vec::with_capacity(raw.station.len()),
            hands: [None; MAX_BLADES],
            dual: false,
            pending: None,
            note: raw.note.clone(),
            uncertain: [raw.hand_uncertain, raw.hand_b_uncertain],
            next_id: u64::try_from(raw.next_id)
                .ok()
                .filter(|n| (1..=MAX_NEXT_ID).contains(n))
                .ok_or_else(|| {
                    corrupt(format!(
                        "next_id = {} is not between 1 and {MAX_NEXT_ID}",
                        raw.next_id
                    ))
                })?,
        };
        let wafer = |text: &str, what: &str| {
            WaferId::parse(text)
                .ok_or_else(|| corrupt(format!("{what}: {text:?} is not a wafer id like \"W12\"")))
        };
        if let Some(h) = &raw.hand {
            map.hands[0] = Some(wafer(h, "hand")?);
        }
        if let Some(h) = &raw.hand_b {
            map.hands[1] = Some(wafer(h, "hand_b")?);
        }
        for s in &raw.station {
            let name = parse_station_name(&s.name).map_err(|e| corrupt(e.to_string()))?;
            let mut slots = Vec::with_capacity(s.slots.len());
            for (i, token) in s.slots.iter().enumerate() {
                let state = parse_file_token(token).ok_or_else(|| {
                    corrupt(format!(
                        "station {name} slot {}: {token:?} is not a slot state; expected \"W<n>\", \"-\", \"?\", \"double\" or \"cross\"",
                        i + 1
                    ))
                })?;
                slots.push(state);
            }
            map.stations.push(MapStation { name, slots });
        }
        if let Some(p) = &raw.pending {
            let kind = match p.kind.as_str() {
                "get" => TransferKind::Get,
                "put" => TransferKind::Put,
                other => {
                    return Err(corrupt(format!(
                        "pending.kind {other:?} is neither \"get\" nor \"put\""
                    )))
                }
            };
            let station = parse_station_name(&p.station).map_err(|e| corrupt(e.to_string()))?;
            let slot = u16::try_from(p.slot)
                .map_err(|_| corrupt(format!("pending.slot {} is not a slot number", p.slot)))?;
            let blade = match p.blade.as_deref() {
                None => Blade::A,
                Some(b) => Blade::parse(b).ok_or_else(|| {
                    corrupt(format!("pending.blade {b:?} is neither \"A\" nor \"B\""))
                })?,
            };
            map.pending = Some(Transfer {
                kind,
                station,
                slot,
                wafer: wafer(&p.wafer, "pending.wafer")?,
                blade,
            });
        }
        map.verify().map_err(|e| match e {
            WaferMapError::Inconsistent { reason } => corrupt(reason),
            other => other,
        })?;
        Ok(map)
    }

    /// Write [`WaferMap::to_text`] to `path` atomically: `path.tmp` in the same directory,
    /// fsync, rename over `path`, fsync the directory. A crash leaves the old or the new map.
    pub fn save_atomic(&self, path: &Path) -> Result<(), WaferMapError> {
        write_atomic(path, self.to_text().as_bytes()).map_err(|source| WaferMapError::Write {
            file: path.display().to_string(),
            source,
        })
    }

    /// Read the map saved at `path`. A missing file is an empty map without stations
    /// ([`WaferMap::default`]; follow with [`WaferMap::adopt_stations`]); an unreadable or
    /// corrupt file is an error, never an empty map. A leftover `path.tmp` is ignored.
    pub fn load(path: &Path) -> Result<WaferMap, WaferMapError> {
        let file = path.display().to_string();
        match std::fs::read_to_string(path) {
            Ok(text) => WaferMap::from_text(&text, &file),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(WaferMap::default()),
            Err(source) => Err(WaferMapError::Read { file, source }),
        }
    }

    /// The `WAFERS` reply body on one line (format in the module docs), e.g.
    /// `hand=- LP1=W1..W25 LP2=-x25 AL=- PM1=? PM2=W26`.
    pub fn wafers_line(&self) -> String {
        self.wafers_lines().join(" ")
    }

    /// The `WAFERS` content as one item per place group: `hand=…` (and `hand.B=…` on a
    /// dual-blade robot), then `<STN>=…` per station, then
    /// `pending=<kind>:<STN>.<slot>:<id>[:B]` while a transfer is pending (kind `get` or
    /// `put`; `:B` when blade B makes it). Each is at most `len(name) + 1 + 50 · 12` bytes.
    pub fn wafers_lines(&self) -> Vec<String> {
        let mut lines = Vec::with_capacity(self.stations.len() + 3);
        let token = |b: usize| match self.hands[b] {
            None => "-".to_string(),
            Some(w) if self.uncertain[b] => format!("{w}?"),
            Some(w) => w.to_string(),
        };
        lines.push(format!("hand={}", token(0)));
        if self.is_dual() {
            lines.push(format!("hand.B={}", token(1)));
        }
        for s in &self.stations {
            lines.push(format!("{}={}", s.name, compact_slots(&s.slots)));
        }
        if let Some(t) = &self.pending {
            let kind = match t.kind {
                TransferKind::Get => "get",
                TransferKind::Put => "put",
            };
            let blade = if t.blade == Blade::A { "" } else { ":B" };
            lines.push(format!(
                "pending={kind}:{}.{}:{}{blade}",
                t.station, t.slot, t.wafer
            ));
        }
        lines
    }
}

/// The `WAFERS` token of a slot state.
fn line_token(state: SlotState) -> String {
    match state {
        SlotState::Unknown => "?".into(),
        SlotState::Empty => "-".into(),
        SlotState::Wafer(w) => w.to_string(),
        SlotState::Uncertain(w) => format!("{w}?"),
        SlotState::Fault(SlotFault::Double) => "D".into(),
        SlotState::Fault(SlotFault::Cross) => "X".into(),
    }
}

/// Slots, comma-separated, with rising-id runs `Wa..Wb` (3 or more) and repeats `tokxn` (a lower-case x: `*` only ever starts a checksum in the protocol).
fn compact_slots(slots: &[SlotState]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < slots.len() {
        let mut j = i + 1;
        if let SlotState::Wafer(first) = slots[i] {
            while j < slots.len() {
                match (slots[j], first.0.checked_add((j - i) as u32)) {
                    (SlotState::Wafer(w), Some(next)) if w.0 == next => j += 1,
                    _ => break,
                }
            }
            if j - i >= 3 {
                parts.push(format!("{first}..W{}", first.0 + (j - i - 1) as u32));
            } else {
                j = i + 1;
                parts.push(first.to_string());
            }
        } else {
            while j < slots.len() && slots[j] == slots[i] {
                j += 1;
            }
            let token = line_token(slots[i]);
            if j - i >= 2 {
                parts.push(format!("{token}x{}", j - i));
            } else {
                parts.push(token);
            }
        }
        i = j;
    }
    parts.join(",")
}

/// The slots of one station's list in a `WAFERS` reply (`W1,-x2,W3..W25,?,D,X`): the
/// inverse of the reply's compaction, for host software and tests that read the map back.
/// `None` for text that is not such a list (an unknown token, a falling or empty run, a
/// repeat of 0).
pub fn parse_slot_list(text: &str) -> Option<Vec<SlotState>> {
    let mut slots = Vec::new();
    for part in text.split(',') {
        if let Some((a, b)) = part.split_once("..") {
            let (a, b) = (WaferId::parse(a)?, WaferId::parse(b)?);
            if b.0 < a.0 {
                return None;
            }
            slots.extend((a.0..=b.0).map(|n| SlotState::Wafer(WaferId(n))));
            continue;
        }
        // `tokxn`: a repeat (wafer ids never repeat, so `W…x` is not one).
        let (token, times) = match part.rsplit_once('x') {
            Some((t, n)) if !t.starts_with(['W', 'w']) => (t, n.parse::<usize>().ok()?),
            _ => (part, 1),
        };
        if times == 0 {
            return None;
        }
        let state = match token {
            "?" => SlotState::Unknown,
            "-" => SlotState::Empty,
            "D" => SlotState::Fault(SlotFault::Double),
            "X" => SlotState::Fault(SlotFault::Cross),
            w => match w.strip_suffix('?') {
                Some(w) => SlotState::Uncertain(WaferId::parse(w)?),
                None => SlotState::Wafer(WaferId::parse(w)?),
            },
        };
        slots.extend(std::iter::repeat_n(state, times));
    }
    Some(slots)
}

fn file_token(state: SlotState) -> String {
    match state {
        SlotState::Unknown => "?".into(),
        SlotState::Empty => "-".into(),
        SlotState::Wafer(w) => w.to_string(),
        SlotState::Uncertain(w) => format!("{w}?"),
        SlotState::Fault(SlotFault::Double) => "double".into(),
        SlotState::Fault(SlotFault::Cross) => "cross".into(),
    }
}

fn parse_file_token(token: &str) -> Option<SlotState> {
    match token {
        "?" => Some(SlotState::Unknown),
        "-" => Some(SlotState::Empty),
        "double" => Some(SlotState::Fault(SlotFault::Double)),
        "cross" => Some(SlotState::Fault(SlotFault::Cross)),
        other => match other.strip_suffix('?') {
            Some(w) => WaferId::parse(w).map(SlotState::Uncertain),
            None => WaferId::parse(other).map(SlotState::Wafer),
        },
    }
}

#[derive(Debug, Deserialize)]
struct RawVersion {
    version: Option<i64>,
}

fn is_false(b: &bool) -> bool {
    !*b
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMap {
    version: i64,
    next_id: i64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    hand: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    hand_b: Option<String>,
    #[serde(default, skip_serializing_if = "is_false")]
    hand_uncertain: bool,
    #[serde(default, skip_serializing_if = "is_false")]
    hand_b_uncertain: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    note: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pending: Option<RawPending>,
    #[serde(default)]
    station: Vec<RawMapStation>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPending {
    kind: String,
    station: String,
    slot: i64,
    wafer: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    blade: Option<String>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMapStation {
    name: String,
    slots: Vec<String>,
}

#[cfg(test)]
mod tests;
