//! The simulated physical cell — the ground truth the simulated board keeps: which wafers
//! lie in which station slots (flat, double or cross-slotted), whether one is on the hand,
//! and what happens to them as the hand moves and the vacuum switches.
//!
//! The board calls [`World::step`] with the hand's pose (forward kinematics of its axes)
//! and the vacuum valve every period; [`World::step`] does not allocate except to record a
//! lost wafer. The model:
//!
//! * The hand is *seated* at a station when its x, y are within [`SEAT_TOLERANCE_MM`] of the
//!   taught x, y and its yaw within [`SEAT_TOLERANCE_DEG`] of the taught yaw.
//! * **Pick**: seated, the hand rises through a slot's support height (z of the previous
//!   step below it, z now at or above it) with the vacuum on, the hand empty and one wafer
//!   flat in the slot: the wafer goes onto the hand. With the vacuum off the wafer is not
//!   taken ([`WorldEvent::UnclampedLift`], a fault); rising into a double or cross-slotted
//!   slot, or into a wafer while carrying one, is a [`WorldEvent::Collision`] (a fault, the
//!   wafers stay).
//! * **Release**: whenever the vacuum is off while a wafer is on the hand, the wafer leaves
//!   it. Seated, at most one stroke above a slot's support height, it drops onto that slot
//!   ([`WorldEvent::Placed`]; onto a wafer already there it makes a double,
//!   [`WorldEvent::Stacked`], a fault). Anywhere else it is lost ([`WorldEvent::Lost`], a
//!   fault, counted): a wafer lost in motion.
//! * The vacuum sensor ([`World::vacuum_sensor`]) is on when a wafer is on the hand and the
//!   vacuum is on (no delay here; the board adds its own).
//! * The mapping sensor ([`World::map_station`]) reports each slot's [`SlotCode`].
//! * **Collision with the cell**: the arm's bodies — links, blades, carried wafers
//!   ([`wrc_robot::Robot::bodies`]) — against every station's solid box and every fixed
//!   obstacle ([`crate::obstacle`], the controller's own model of the cell, here with the
//!   true stations, no margin and the cassette's tolerance [`LineTolerance::WORLD`]): a
//!   station is entered only through its opening, on its line (the TCP within
//!   [`SIDE_TOLERANCE_MM`] of it, the hand within [`SIDE_TOLERANCE_DEG`] of its direction, a
//!   blade at a slot's height); anything else that touches it — moving sideways or turning
//!   inside, swinging into its front, a link or the wafer brushing it — and anything that
//!   touches an obstacle is a [`WorldEvent::SideCollision`] (a fault, counted), reported
//!   once per contact: not again until the arm is out of that solid (back on the line
//!   inside it is still inside). The board calls
//!   [`World::touch`] every period with the joints at the period's start and end, and the
//!   world checks the joint-space segment between them as the board's servo interpolates
//!   it, in steps of at most 1 mm of any point's travel. The hand and the wafers stay
//!   where they are (the model records the crash; it does not model damage). Heights count:
//!   the arm passes under a station. The arm needs a robot ([`World::set_arm`]); a world
//!   without one checks nothing.
//! * A dual-blade robot's blade B is a second hand with its own pose (the board gives it
//!   its height) and vacuum: [`World::step_blade`]. Each blade picks and releases as above
//!   and is one of the arm's bodies for [`World::touch`]; the blades do not collide with
//!   each other or with the wafers next to the slot they serve (a cell engineer keeps them
//!   apart when teaching).
//!
//! # Identity: comparing the controller's map with the world
//!
//! Physical wafers carry a *tag* (a number given when the world is created, in station and
//! slot order from 1; a double slot holds two). The controller never sees tags: it gives its
//! own [`WaferId`]s when it maps. A test relates the two with [`Tracking`]: the first time
//! an id and a tag are seen at the same place they are bound one to one; from then on the
//! id must always be where that tag is. [`Tracking::check`] compares every place (each slot
//! and the hand) — occupancy, faults and identity — and returns the mismatches. Compare
//! after [`crate::WaferMap::reconcile`]: a pending transfer is itself reported.

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};
use wrc_robot::{BladeLoad, BodyKind, Joints, Pose, Robot};

use crate::blade::{Blade, MAX_BLADES};
use crate::mapping::SlotCode;
use crate::obstacle::{CellModel, LineTolerance, MAX_SOLIDS};
use crate::station::{same_name, Station, StationName};
use crate::stations::Stations;
use crate::wafer_map::{Location, SlotFault, SlotState, Transfer, WaferId, WaferMap};
use wrc_robot::wrap180;

/// How far the hand's x, y may be from a station's taught x, y to count as seated \[mm\].
pub const SEAT_TOLERANCE_MM: f64 = 2.0;

/// How far the hand's yaw may be from a station's taught yaw to count as seated \[deg\].
pub const SEAT_TOLERANCE_DEG: f64 = 1.0;

/// How far sideways from a station's line the hand may be while inside the station \[mm\]
/// (see the module docs): far more than the controller's straight lines ever stray (they
/// stay within hundredths of a millimetre), a cassette's clearance.
pub const SIDE_TOLERANCE_MM: f64 = LineTolerance::WORLD.lateral_mm;

/// How far the hand's yaw may be from a station's taught yaw while inside the station
/// \[deg\] (see the module docs).
pub const SIDE_TOLERANCE_DEG: f64 = LineTolerance::WORLD.yaw_deg;

/// The longest step of any point of the arm between two checks of [`World::touch`] [mm].
pub const TOUCH_STEP_MM: f64 = 1.0;

/// How much less than `approach_mm` in front of the seat the inside of a station begins
/// \[mm\]: the approach pose itself, and a hand within this of it, is outside.
pub const ENTRY_MARGIN_MM: f64 = crate::station::INSIDE_ENTRY_MARGIN_MM;

/// How far beyond the seat (along the station's direction) a hand still counts as inside
/// \[mm\].
pub const BEYOND_SEAT_MM: f64 = crate::station::INSIDE_BEYOND_SEAT_MM;

/// How far sideways from a station's line its inside reaches \[mm\]: a 300 mm wafer's radius.
pub const STATION_HALF_WIDTH_MM: f64 = crate::station::INSIDE_HALF_WIDTH_MM;

/// Version of the world's text form.
const WORLD_VERSION: i64 = 1;

/// What one slot physically holds; the numbers are wafer tags.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SlotContent {
    /// Nothing.
    Empty,
    /// One wafer, flat.
    Wafer(u32),
    /// Two wafers stacked (lower, upper).
    Double(u32, u32),
    /// One wafer across this slot and the next.
    Cross(u32),
}

impl SlotContent {
    /// What the mapping sensor reports for it.
    pub fn code(self) -> SlotCode {
        match self {
            SlotContent::Empty => SlotCode::Absent,
            SlotContent::Wafer(_) => SlotCode::Present,
            SlotContent::Double(..) => SlotCode::Double,
            SlotContent::Cross(_) => SlotCode::Cross,
        }
    }
}

/// Something that happened to a wafer in [`World::step`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WorldEvent {
    /// A wafer went from the slot onto the hand.
    Picked {
        /// The station.
        station: StationName,
        /// The slot.
        slot: u16,
        /// The wafer's tag.
        tag: u32,
    },
    /// The wafer on the hand was set down into the empty slot.
    Placed {
        /// The station.
        station: StationName,
        /// The slot.
        slot: u16,
        /// The wafer's tag.
        tag: u32,
    },
    /// Fault: the wafer on the hand was set down onto a wafer; the slot is now double.
    Stacked {
        /// The station.
        station: StationName,
        /// The slot.
        slot: u16,
        /// The tag of the wafer set down.
        tag: u32,
    },
    /// Fault: the vacuum went off away from any slot: the wafer fell and is lost.
    Lost {
        /// The wafer's tag.
        tag: u32,
    },
    /// Fault: the hand rose into a double or cross-slotted slot, or into a wafer while it
    /// carried one. Nothing moved.
    Collision {
        /// The station.
        station: StationName,
        /// The slot.
        slot: u16,
    },
    /// Fault: the hand rose through a wafer with the vacuum off; the wafer was not taken.
    UnclampedLift {
        /// The station.
        station: StationName,
        /// The slot.
        slot: u16,
    },
    /// Fault: a body of the arm touched a station other than through its opening on its
    /// line, or a fixed obstacle (see the module docs). Nothing moved.
    SideCollision {
        /// The station or obstacle.
        station: StationName,
        /// The body that touched it.
        body: BodyKind,
    },
}

impl WorldEvent {
    /// Whether the event is a fault (anything but a clean pick or place).
    pub fn is_fault(&self) -> bool {
        !matches!(self, WorldEvent::Picked { .. } | WorldEvent::Placed { .. })
    }
}

/// A world that cannot be built or read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum WorldError {
    /// No station of that name.
    #[error("the simulated cell has no station named {name:?}")]
    NoSuchStation {
        /// The name asked for.
        name: String,
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
    /// Saved world text that does not fit the stations or is not readable.
    #[error("the saved simulated cell is unusable: {reason}")]
    Corrupt {
        /// What is wrong.
        reason: String,
    },
}

#[derive(Debug, Clone, PartialEq)]
struct WorldStation {
    station: Station,
    slots: Vec<SlotContent>,
}

/// The arm the world checks against the cell: the robot, its blades' heights, and the cell
/// as solids.
#[derive(Debug, Clone, PartialEq)]
struct WorldArm {
    robot: Robot,
    /// Each blade's wafer plane above the TCP [mm] (the hand first).
    offsets: Vec<f64>,
    model: CellModel,
    /// The joints at the end of the last [`World::touch`].
    last: Option<Joints>,
}

/// The simulated cell. See the module docs for the model.
#[derive(Debug, Clone, PartialEq)]
pub struct World {
    stations: Vec<WorldStation>,
    /// Per blade (A, B): the wafer on it, its valve, its last height.
    hands: [Option<u32>; MAX_BLADES],
    vacuum: [bool; MAX_BLADES],
    last_z: [Option<f64>; MAX_BLADES],
    lost: Vec<u32>,
    faults: u32,
    next_tag: u32,
    /// Side collisions so far, and the station of the latest.
    side_collisions: u32,
    last_side_collision: Option<StationName>,
    /// Per solid of the cell (stations, then obstacles): a body touches it now.
    touching: [bool; MAX_SOLIDS],
    /// The cell's fixed obstacles, by name (after the stations in `touching`).
    obstacles: Vec<StationName>,
    arm: Option<Box<WorldArm>>,
}

impl World {
    /// The cell of `stations` with the wafers of their `[station.sim]` tables (stations
    /// without one are empty), tagged from 1 in station and slot order; nothing on the hand,
    /// vacuum off.
    pub fn new(stations: &Stations) -> World {
        let mut next_tag = 1u32;
        let mut tag = || {
            let t = next_tag;
            next_tag = next_tag.saturating_add(1);
            t
        };
        let list = stations
            .iter()
            .map(|s| {
                let slots = (0..usize::from(s.slots))
                    .map(|i| {
                        let code = s
                            .sim
                            .as_ref()
                            .and_then(|sim| sim.wafers.get(i).copied())
                            .unwrap_or(SlotCode::Absent);
                        match code {
                            SlotCode::Absent => SlotContent::Empty,
                            SlotCode::Present => SlotContent::Wafer(tag()),
                            SlotCode::Double => {
                                let lower = tag();
                                SlotContent::Double(lower, tag())
                            }
                            SlotCode::Cross => SlotContent::Cross(tag()),
                        }
                    })
                    .collect();
                WorldStation {
                    station: s.clone(),
                    slots,
                }
            })
            .collect();
        World {
            stations: list,
            hands: [None; MAX_BLADES],
            vacuum: [false; MAX_BLADES],
            last_z: [None; MAX_BLADES],
            lost: Vec::new(),
            faults: 0,
            next_tag,
            side_collisions: 0,
            last_side_collision: None,
            touching: [false; MAX_SOLIDS],
            obstacles: stations.obstacles().iter().map(|o| o.name).collect(),
            arm: None,
        }
    }

    /// The index among the cell's solids (stations, then obstacles) of the one called
    /// `name`, ignoring case.
    fn solid_index(&self, name: &str) -> Option<usize> {
        self.station_index(name).ok().or_else(|| {
            self.obstacles
                .iter()
                .position(|o| same_name(o.as_str(), name))
                .map(|i| self.stations.len() + i)
        })
    }

    /// The name of solid `i` (see [`World::solid_index`]).
    fn solid_name(&self, i: usize) -> Option<StationName> {
        match self.stations.get(i) {
            Some(w) => Some(w.station.name),
            None => self.obstacles.get(i - self.stations.len()).copied(),
        }
    }

    /// Check the arm of `robot` against the cell of `stations` (the same the world was made
    /// with: its stations and obstacles) in [`World::touch`]; `offsets` are the blades'
    /// wafer planes above the TCP [mm], the hand's (0) first. A cell with more solids than
    /// the model holds is checked without the rest.
    pub fn set_arm(&mut self, robot: &Robot, stations: &Stations, offsets: &[f64]) {
        let model = stations
            .model(robot)
            .unwrap_or_else(|_| CellModel::empty(robot));
        self.arm = Some(Box::new(WorldArm {
            robot: robot.clone(),
            offsets: offsets.iter().copied().take(MAX_BLADES).collect(),
            model,
            last: None,
        }));
    }

    /// The arm moved from where the last call left it to `joints` [deg, mm] (the first call:
    /// is at `joints`), each point of it along the straight joint-space segment: report the
    /// first new contact of a body with a solid of the cell (see the module docs). The
    /// blades carry the wafers the world has on them. Nothing without [`World::set_arm`].
    pub fn touch(&mut self, joints: &Joints) -> Option<WorldEvent> {
        let arm = self.arm.as_mut()?;
        let from = arm.last.replace(*joints).unwrap_or(*joints);
        let mut blades = [BladeLoad::default(); MAX_BLADES];
        let n = arm.offsets.len().max(1);
        for (b, blade) in blades.iter_mut().enumerate().take(n) {
            *blade = BladeLoad {
                z_offset_mm: arm.offsets.get(b).copied().unwrap_or(0.0),
                wafer: self.hands[b].is_some(),
            };
        }
        let blades = &blades[..n];
        let travel: f64 = from
            .iter()
            .zip(joints)
            .zip(arm.model.levers())
            .map(|((a, b), l)| (b - a).abs() * l)
            .sum();
        let steps = (travel / TOUCH_STEP_MM).ceil().clamp(1.0, 10_000.0) as u32;
        let mut event = None;
        for k in 1..=steps {
            let t = f64::from(k) / f64::from(steps);
            let mut q = from;
            for (v, (a, b)) in q.iter_mut().zip(from.iter().zip(joints)) {
                *v = a + t * (b - a);
            }
            let bodies = arm.robot.bodies(&q, blades);
            for i in 0..arm.model.len() {
                if self.touching[i] {
                    // A contact lasts until the arm is out of the solid, through its
                    // opening or not.
                    self.touching[i] = arm.model.overlaps(i, &bodies, 0.0);
                    continue;
                }
                let hit = arm
                    .model
                    .contact_with(i, &bodies, blades, &LineTolerance::WORLD, 0.0);
                match hit {
                    None => {}
                    Some(c) => {
                        self.touching[i] = true;
                        self.faults = self.faults.saturating_add(1);
                        self.side_collisions = self.side_collisions.saturating_add(1);
                        self.last_side_collision = Some(c.name);
                        event.get_or_insert(WorldEvent::SideCollision {
                            station: c.name,
                            body: c.body,
                        });
                    }
                }
            }
        }
        event
    }

    /// The names of the stations and obstacles a body of the arm touches now.
    pub fn touching(&self) -> Vec<StationName> {
        (0..MAX_SOLIDS)
            .filter(|&i| self.touching[i])
            .filter_map(|i| self.solid_name(i))
            .collect()
    }

    fn station_index(&self, name: &str) -> Result<usize, WorldError> {
        self.stations
            .iter()
            .position(|w| same_name(w.station.name.as_str(), name))
            .ok_or_else(|| WorldError::NoSuchStation {
                name: name.chars().take(40).collect(),
            })
    }

    /// Whether `pose` is seated at station `w` (x, y and yaw within the tolerances).
    fn seated(w: &WorldStation, pose: &Pose) -> bool {
        let p = &w.station.pose;
        (pose.x - p.x).hypot(pose.y - p.y) <= SEAT_TOLERANCE_MM
            && wrap180(pose.yaw - p.yaw).abs() <= SEAT_TOLERANCE_DEG
    }

    /// Advance the world: the hand (blade A) is now at `pose` with the vacuum valve
    /// `vacuum_on`. Returns what happened to a wafer, if anything (see the module docs).
    pub fn step(&mut self, pose: Pose, vacuum_on: bool) -> Option<WorldEvent> {
        self.step_blade(Blade::A, pose, vacuum_on)
    }

    /// Advance the world for one blade: its wafer centre is now at `pose` with its vacuum
    /// valve `vacuum_on`. Returns what happened to a wafer, if anything.
    pub fn step_blade(&mut self, blade: Blade, pose: Pose, vacuum_on: bool) -> Option<WorldEvent> {
        let b = blade.index();
        let prev_z = self.last_z[b].replace(pose.z);
        self.vacuum[b] = vacuum_on;
        if let (Some(tag), false) = (self.hands[b], vacuum_on) {
            self.hands[b] = None;
            return Some(self.release(tag, &pose));
        }
        let prev_z = prev_z?;
        if pose.z.is_nan() || pose.z <= prev_z {
            return None;
        }
        let hand = self.hands[b];
        for w in &mut self.stations {
            if !World::seated(w, &pose) {
                continue;
            }
            for (i, content) in w.slots.iter_mut().enumerate() {
                let support = w.station.pose.z + i as f64 * w.station.pitch_mm;
                if !(prev_z < support && support <= pose.z) || *content == SlotContent::Empty {
                    continue;
                }
                let station = w.station.name;
                let slot = (i + 1) as u16;
                let event = match (*content, hand, vacuum_on) {
                    (SlotContent::Wafer(tag), None, true) => {
                        *content = SlotContent::Empty;
                        self.hands[b] = Some(tag);
                        WorldEvent::Picked { station, slot, tag }
                    }
                    (SlotContent::Wafer(_), None, false) => {
                        WorldEvent::UnclampedLift { station, slot }
                    }
                    _ => WorldEvent::Collision { station, slot },
                };
                if event.is_fault() {
                    self.faults = self.faults.saturating_add(1);
                }
                return Some(event);
            }
        }
        None
    }

    /// The wafer `tag` leaves the hand at `pose`.
    fn release(&mut self, tag: u32, pose: &Pose) -> WorldEvent {
        for w in &mut self.stations {
            if !World::seated(w, pose) {
                continue;
            }
            // The highest slot whose support is at most one stroke below the hand.
            let below = (0..w.slots.len()).rev().find(|&i| {
                let support = w.station.pose.z + i as f64 * w.station.pitch_mm;
                support <= pose.z && pose.z - support <= w.station.stroke_mm
            });
            let Some(i) = below else { continue };
            let station = w.station.name;
            let slot = (i + 1) as u16;
            match w.slots[i] {
                SlotContent::Empty => {
                    w.slots[i] = SlotContent::Wafer(tag);
                    return WorldEvent::Placed { station, slot, tag };
                }
                SlotContent::Wafer(lower) => {
                    w.slots[i] = SlotContent::Double(lower, tag);
                    self.faults = self.faults.saturating_add(1);
                    return WorldEvent::Stacked { station, slot, tag };
                }
                // No room for a third wafer: it slides off.
                SlotContent::Double(..) | SlotContent::Cross(_) => break,
            }
        }
        self.lost.push(tag);
        self.faults = self.faults.saturating_add(1);
        WorldEvent::Lost { tag }
    }

    /// The vacuum-sensed input of the hand (blade A): a wafer is on it and its vacuum is on.
    pub fn vacuum_sensor(&self) -> bool {
        self.vacuum_sensor_of(Blade::A)
    }

    /// The vacuum-sensed input of `blade`.
    pub fn vacuum_sensor_of(&self, blade: Blade) -> bool {
        self.hands[blade.index()].is_some() && self.vacuum[blade.index()]
    }

    /// The mapping sensor's scan of station `name`: one code per slot, slot 1 first.
    pub fn map_station(&self, name: &str) -> Result<Vec<SlotCode>, WorldError> {
        let i = self.station_index(name)?;
        Ok(self.stations[i].slots.iter().map(|c| c.code()).collect())
    }

    /// What slot `slot` of station `name` holds.
    pub fn slot(&self, name: &str, slot: u16) -> Result<SlotContent, WorldError> {
        let w = &self.stations[self.station_index(name)?];
        let slots = w.slots.len() as u16;
        if slot == 0 || slot > slots {
            return Err(WorldError::NoSuchSlot {
                station: w.station.name,
                slot,
                slots,
            });
        }
        Ok(w.slots[usize::from(slot - 1)])
    }

    /// The tag of the wafer on the hand (blade A).
    pub fn hand(&self) -> Option<u32> {
        self.hands[0]
    }

    /// The tag of the wafer on `blade`.
    pub fn hand_of(&self, blade: Blade) -> Option<u32> {
        self.hands[blade.index()]
    }

    /// The hand's (blade A's) vacuum valve's last state.
    pub fn vacuum(&self) -> bool {
        self.vacuum[0]
    }

    /// Tags of the wafers lost so far, in order.
    pub fn lost(&self) -> &[u32] {
        &self.lost
    }

    /// Faults so far (every [`WorldEvent`] with [`WorldEvent::is_fault`]).
    pub fn faults(&self) -> u32 {
        self.faults
    }

    /// Collisions with the cell so far ([`WorldEvent::SideCollision`], also counted in
    /// [`World::faults`]).
    pub fn side_collisions(&self) -> u32 {
        self.side_collisions
    }

    /// The station or obstacle of the latest [`WorldEvent::SideCollision`], if there was
    /// one.
    pub fn last_side_collision(&self) -> Option<StationName> {
        self.last_side_collision
    }

    /// Every tag still in the cell (slots and hand, not the lost ones), sorted.
    pub fn tags(&self) -> Vec<u32> {
        let mut tags: Vec<u32> = self
            .stations
            .iter()
            .flat_map(|w| w.slots.iter())
            .flat_map(|c| match *c {
                SlotContent::Empty => [None, None],
                SlotContent::Wafer(t) | SlotContent::Cross(t) => [Some(t), None],
                SlotContent::Double(a, b) => [Some(a), Some(b)],
            })
            .flatten()
            .chain(self.hands.iter().flatten().copied())
            .collect();
        tags.sort_unstable();
        tags
    }

    /// The world's state as text (TOML) for tests and for a board that restarts; read it
    /// back with [`World::from_text`] and the same stations.
    pub fn to_text(&self) -> String {
        let raw = RawWorld {
            version: WORLD_VERSION,
            next_tag: i64::from(self.next_tag),
            vacuum: self.vacuum[0],
            hand: self.hands[0].map(i64::from),
            last_z: self.last_z[0],
            vacuum_b: self.vacuum[1],
            hand_b: self.hands[1].map(i64::from),
            last_z_b: self.last_z[1],
            lost: self.lost.iter().map(|&t| i64::from(t)).collect(),
            faults: i64::from(self.faults),
            side_collisions: i64::from(self.side_collisions),
            last_side_collision: self.last_side_collision.map(|n| n.to_string()),
            touching: self.touching().iter().map(|n| n.to_string()).collect(),
            station: self
                .stations
                .iter()
                .map(|w| RawWorldStation {
                    name: w.station.name.to_string(),
                    slots: w.slots.iter().map(|c| content_token(*c)).collect(),
                    side_hit: Vec::new(),
                })
                .collect(),
        };
        toml::to_string(&raw).unwrap_or_else(|e| format!("# could not write the world: {e}\n"))
    }

    /// Read [`World::to_text`] back; `stations` must be the ones it was made with (same
    /// names and slot counts). Tags must be unique.
    pub fn from_text(text: &str, stations: &Stations) -> Result<World, WorldError> {
        let corrupt = |reason: String| WorldError::Corrupt { reason };
        let raw: RawWorld = toml::from_str(text).map_err(|e| corrupt(e.to_string()))?;
        if raw.version != WORLD_VERSION {
            return Err(corrupt(format!(
                "version {} (this build reads {WORLD_VERSION})",
                raw.version
            )));
        }
        let tag = |v: i64, what: &str| {
            u32::try_from(v).map_err(|_| corrupt(format!("{what} {v} is not a wafer tag")))
        };
        let mut world = World::new(stations);
        if raw.station.len() != world.stations.len() {
            return Err(corrupt(format!(
                "{} stations saved, {} configured",
                raw.station.len(),
                world.stations.len()
            )));
        }
        for (i, (w, r)) in world.stations.iter_mut().zip(&raw.station).enumerate() {
            if !same_name(w.station.name.as_str(), &r.name) || r.slots.len() != w.slots.len() {
                return Err(corrupt(format!(
                    "saved station {} with {} slots does not match station {} with {} slots",
                    r.name,
                    r.slots.len(),
                    w.station.name,
                    w.slots.len()
                )));
            }
            for (c, token) in w.slots.iter_mut().zip(&r.slots) {
                *c = parse_content_token(token)
                    .ok_or_else(|| corrupt(format!("{token:?} is not a slot content")))?;
            }
            // Written by an older build: a blade that hit this station's side.
            for blade in &r.side_hit {
                Blade::parse(blade).ok_or_else(|| {
                    corrupt(format!(
                        "station {}: side_hit {blade:?} is not a blade (A or B)",
                        r.name
                    ))
                })?;
                world.touching[i] = true;
            }
        }
        for name in &raw.touching {
            let i = world
                .solid_index(name)
                .filter(|&i| i < MAX_SOLIDS)
                .ok_or_else(|| {
                    corrupt(format!("touching {name:?} is not a station or obstacle"))
                })?;
            world.touching[i] = true;
        }
        world.hands = [
            raw.hand.map(|h| tag(h, "hand")).transpose()?,
            raw.hand_b.map(|h| tag(h, "hand_b")).transpose()?,
        ];
        world.vacuum = [raw.vacuum, raw.vacuum_b];
        world.last_z = [raw.last_z, raw.last_z_b];
        world.lost = raw
            .lost
            .iter()
            .map(|&t| tag(t, "lost"))
            .collect::<Result<_, _>>()?;
        world.faults = u32::try_from(raw.faults).map_err(|_| corrupt("faults".into()))?;
        world.side_collisions = u32::try_from(raw.side_collisions)
            .map_err(|_| corrupt(format!("side_collisions {}", raw.side_collisions)))?;
        world.last_side_collision = match &raw.last_side_collision {
            Some(name) => Some(
                world
                    .solid_index(name)
                    .and_then(|i| world.solid_name(i))
                    .ok_or_else(|| {
                        corrupt(format!(
                            "last_side_collision {name:?} is not a station or obstacle"
                        ))
                    })?,
            ),
            None => None,
        };
        world.next_tag = tag(raw.next_tag, "next_tag")?;
        let mut all = world.tags();
        all.extend(&world.lost);
        all.sort_unstable();
        if all.windows(2).any(|p| p[0] == p[1]) {
            return Err(corrupt("a wafer tag appears twice".into()));
        }
        if all.last().is_some_and(|&t| t >= world.next_tag) {
            return Err(corrupt("a wafer tag is not below next_tag".into()));
        }
        Ok(world)
    }
}

fn content_token(c: SlotContent) -> String {
    match c {
        SlotContent::Empty => "-".into(),
        SlotContent::Wafer(t) => format!("T{t}"),
        SlotContent::Double(a, b) => format!("D{a}+{b}"),
        SlotContent::Cross(t) => format!("X{t}"),
    }
}

fn parse_content_token(token: &str) -> Option<SlotContent> {
    let num = |s: &str| -> Option<u32> {
        if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) {
            None
        } else {
            s.parse().ok()
        }
    };
    if token == "-" {
        return Some(SlotContent::Empty);
    }
    if let Some(rest) = token.strip_prefix('T') {
        return num(rest).map(SlotContent::Wafer);
    }
    if let Some(rest) = token.strip_prefix('X') {
        return num(rest).map(SlotContent::Cross);
    }
    let (a, b) = token.strip_prefix('D')?.split_once('+')?;
    Some(SlotContent::Double(num(a)?, num(b)?))
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWorld {
    version: i64,
    next_tag: i64,
    vacuum: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    hand: Option<i64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    last_z: Option<f64>,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    vacuum_b: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    hand_b: Option<i64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    last_z_b: Option<f64>,
    #[serde(default)]
    lost: Vec<i64>,
    #[serde(default)]
    faults: i64,
    #[serde(default, skip_serializing_if = "is_zero")]
    side_collisions: i64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    last_side_collision: Option<String>,
    /// The stations and obstacles a body touches now.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    touching: Vec<String>,
    #[serde(default)]
    station: Vec<RawWorldStation>,
}

fn is_zero(n: &i64) -> bool {
    *n == 0
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWorldStation {
    name: String,
    slots: Vec<String>,
    /// Read from an older build's file: the blades (`A`, `B`) that hit its side since they
    /// entered it (now `touching`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    side_hit: Vec<String>,
}

/// A difference between the controller's wafer map and the world, found by
/// [`Tracking::check`].
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Mismatch {
    /// The map still has a pending transfer (reconcile first).
    Pending(Transfer),
    /// A station is in one but not the other.
    Station {
        /// Its name.
        name: String,
    },
    /// A place where the map and the world disagree on what is there.
    Occupancy {
        /// The place.
        location: Location,
        /// What the map says (`W3`, `-`, `?`, `double`, `cross`).
        map: String,
        /// What is there (`T3`, `-`, `D1+2`, `X4`).
        world: String,
    },
    /// The map's wafer at a place is not the physical wafer its id was bound to.
    Identity {
        /// The place.
        location: Location,
        /// The map's id there.
        wafer: WaferId,
        /// The tag that is there.
        tag: u32,
        /// The tag the id was bound to earlier, if any.
        bound_tag: Option<u32>,
        /// The id the tag was bound to earlier, if any.
        bound_id: Option<WaferId>,
    },
}

impl fmt::Display for Mismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Mismatch::Pending(t) => write!(f, "transfer {t} is still pending in the map"),
            Mismatch::Station { name } => {
                write!(f, "station {name} is in only one of the map and the cell")
            }
            Mismatch::Occupancy {
                location,
                map,
                world,
            } => write!(f, "{location}: the map says {map}, the cell has {world}"),
            Mismatch::Identity {
                location,
                wafer,
                tag,
                bound_tag,
                bound_id,
            } => write!(
                f,
                "{location}: the map's {wafer} (physical tag {}) is where tag {tag} (tracked as {}) is",
                bound_tag.map_or_else(|| "-".into(), |t| t.to_string()),
                bound_id.map_or_else(|| "-".into(), |w| w.to_string())
            ),
        }
    }
}

/// The binding between the controller's wafer ids and the world's physical tags, built up
/// over a test (see the module docs).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Tracking {
    tag_of: BTreeMap<WaferId, u32>,
    id_of: BTreeMap<u32, WaferId>,
}

impl Tracking {
    /// No bindings yet.
    pub fn new() -> Tracking {
        Tracking::default()
    }

    /// The tag wafer `id` is bound to.
    pub fn tag_of(&self, id: WaferId) -> Option<u32> {
        self.tag_of.get(&id).copied()
    }

    /// Compare every place of `map` with `world`, binding new id–tag pairs found at the same
    /// place; empty when they agree. Unknown slots in the map agree only with empty ones.
    pub fn check(&mut self, map: &WaferMap, world: &World) -> Vec<Mismatch> {
        let mut out = Vec::new();
        if let Some(t) = map.pending() {
            out.push(Mismatch::Pending(*t));
        }
        for name in map.station_names() {
            if world.station_index(name.as_str()).is_err() {
                out.push(Mismatch::Station {
                    name: name.to_string(),
                });
            }
        }
        for w in &world.stations {
            let name = w.station.name;
            let Some(states) = map.slots(name.as_str()) else {
                out.push(Mismatch::Station {
                    name: name.to_string(),
                });
                continue;
            };
            if states.len() != w.slots.len() {
                out.push(Mismatch::Station {
                    name: name.to_string(),
                });
                continue;
            }
            for (i, (state, content)) in states.iter().zip(&w.slots).enumerate() {
                let location = Location::Slot {
                    station: name,
                    slot: (i + 1) as u16,
                };
                self.compare(location, *state, *content, &mut out);
            }
        }
        for b in Blade::ALL {
            let hand_state = match map.hand_of(b) {
                None => SlotState::Empty,
                Some(w) if map.is_uncertain(b) => SlotState::Uncertain(w),
                Some(w) => SlotState::Wafer(w),
            };
            let hand_content =
                world.hands[b.index()].map_or(SlotContent::Empty, SlotContent::Wafer);
            self.compare(Location::Hand(b), hand_state, hand_content, &mut out);
        }
        out
    }

    fn compare(
        &mut self,
        location: Location,
        state: SlotState,
        content: SlotContent,
        out: &mut Vec<Mismatch>,
    ) {
        match (state, content) {
            (SlotState::Empty | SlotState::Unknown, SlotContent::Empty)
            | (SlotState::Fault(SlotFault::Double), SlotContent::Double(..))
            | (SlotState::Fault(SlotFault::Cross), SlotContent::Cross(_)) => {}
            // An uncertain place may hold its wafer or nothing.
            (SlotState::Uncertain(_), SlotContent::Empty) => {}
            (SlotState::Wafer(wafer) | SlotState::Uncertain(wafer), SlotContent::Wafer(tag)) => {
                let bound_tag = self.tag_of.get(&wafer).copied();
                let bound_id = self.id_of.get(&tag).copied();
                match (bound_tag, bound_id) {
                    (None, None) => {
                        self.tag_of.insert(wafer, tag);
                        self.id_of.insert(tag, wafer);
                    }
                    (Some(t), Some(w)) if t == tag && w == wafer => {}
                    _ => out.push(Mismatch::Identity {
                        location,
                        wafer,
                        tag,
                        bound_tag,
                        bound_id,
                    }),
                }
            }
            _ => out.push(Mismatch::Occupancy {
                location,
                map: match state {
                    SlotState::Unknown => "?".into(),
                    SlotState::Empty => "-".into(),
                    SlotState::Wafer(w) => w.to_string(),
                    SlotState::Uncertain(w) => format!("{w}?"),
                    SlotState::Fault(SlotFault::Double) => "double".into(),
                    SlotState::Fault(SlotFault::Cross) => "cross".into(),
                },
                world: content_token(content),
            }),
        }
    }
}

#[cfg(test)]
mod tests;
