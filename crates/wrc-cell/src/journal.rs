//! The transfer journal: what a `GET`, `PUT` or `SWAP` was doing, step by step, kept on disk
//! so that after a power loss the controller knows what it knows — and what it does not.
//!
//! The wafer map ([`crate::WaferMap`]) records a transfer as pending before anything moves
//! and commits it when the vacuum sensor confirms the wafer's new place. That is enough when
//! only the controller dies: the board keeps its outputs, so the vacuum sensor still tells
//! where the wafer is. A power loss also switches every valve off: the sensor then sees no
//! wafer whatever happened, and only a record of the steps can tell a PUT that released its
//! wafer at the seat from one that lost it on the way. The journal is that record.
//!
//! # Records
//!
//! One record per line, appended and made durable (`fdatasync`) before the controller goes
//! on ([`JournalFile`]):
//!
//! | record | when |
//! |---|---|
//! | `OPEN <kind> <station> <slot> <blade> <wafer> plan=<act>,<act>,…` | the transfer begins (the file starts anew), before anything moves |
//! | `BEGIN <step> <act> [to=<pose>] at=<pose>` | before step `<step>` starts: what it does, its target, where the hand is |
//! | `DONE <step> <act> at=<pose>` | when the step has ended |
//! | `TRANSFER <kind> <station> <slot> <blade> <wafer>` | a SWAP's PUT half takes over from its GET half |
//! | `CLOSE <how>` | the transfer is settled (`committed`, `aborted`, `uncertain`, …) |
//!
//! Each line is `wrcj1 seq=<n> <record> crc=<crc32 of everything before " crc=">`. A line
//! whose CRC does not match, or the last line without its newline, is a write the power
//! cut short: reading stops there ([`read_journal`]). A step's `BEGIN` is durable before
//! the step starts, so the last durable record bounds what the robot did: with `BEGIN k`
//! last, step `k` may have run in part or whole and no later step has started.
//!
//! # What an interrupted transfer did
//!
//! [`judge`] reads an open transfer's records with what the sensors say now
//! ([`Evidence`]) and decides, for its wafer, whether it may be on the blade and whether it
//! may be in the slot ([`Maybe`]). A transfer is *committed* only when the journal shows the
//! release at the seat done (`PUT`: its `VACOFF` step, or begun with the valve off now: the
//! hand stood at the seat) or the vacuum confirmation after the lift done (`GET`: its
//! `CHECK1` step), or when the vacuum sensor, read with the valve on, sees the wafer on the
//! blade. It is *aborted* only when the journal proves the wafer never left its place (a
//! `GET` whose vacuum was never switched on, or whose lift had not ended and whose blade,
//! its valve on, holds nothing) or the sensor, read with the valve on, sees a `PUT`'s wafer
//! still held. In every other case the wafer and the places it may be in become uncertain,
//! until a `MAP`, a sensor reading or an operator settles them.
//!
//! The sensor confirms; it never alone takes a wafer out of the place the journal last had
//! it. Where the two disagree — a wafer the journal has on the blade (confirmed, or a `PUT`'s
//! not yet released) that the sensor, its valve on, no longer senses; a `GET` whose blade
//! rose through the slot and never sensed its wafer — the wafer becomes uncertain there
//! (it may have fallen, the sensor may have failed, the slot may have been emptied by
//! hand). The controller judges every transfer that ends abnormally this way, not only one
//! a power loss interrupted.

use std::fmt;
use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::path::Path;

use wrc_robot::{Num, Pose};

use crate::blade::Blade;
use crate::station::{parse_station_name, StationName};
use crate::transfer::TransferKind;
use crate::wafer_map::{Transfer, WaferId};

/// What a step does, as the journal names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Act {
    /// A joint move to the approach pose, in front of the station (`APPROACH`).
    Approach,
    /// The approach blended into the straight line in: it ends inside (`ENTER`).
    Enter,
    /// The straight line in to the seat (`IN`).
    In,
    /// The vacuum valve switched on (`VACON`).
    VacuumOn,
    /// The vacuum valve switched off: a PUT's release (`VACOFF`).
    VacuumOff,
    /// The vertical move up through the support: a GET's pick (`LIFT`).
    Lift,
    /// The vertical move down through the support: a PUT's set-down (`LOWER`).
    Lower,
    /// The vacuum sensor must see a wafer (`CHECK1`).
    CheckWafer,
    /// The vacuum sensor must see none (`CHECK0`).
    CheckNoWafer,
    /// The map is committed (`COMMIT`).
    Commit,
    /// The straight line out to the approach pose (`OUT`).
    Out,
    /// The station's interlock is checked (`INTERLOCK`).
    Interlock,
    /// The station's speed is set, or the operator's restored (`SPEED`).
    Speed,
    /// The following vacuum steps use this blade (`BLADE.A`, `BLADE.B`).
    Blade(Blade),
    /// A step of a mapping scan (`SCAN`).
    Scan,
    /// Before the transfer (or mapping) starts: the straight line out of a station the hand
    /// stood inside (a fault, a program or an operator left it there) (`LEAVE`).
    Leave,
}

impl Act {
    /// The journal's word for it.
    pub fn word(self) -> &'static str {
        match self {
            Act::Approach => "APPROACH",
            Act::Enter => "ENTER",
            Act::In => "IN",
            Act::VacuumOn => "VACON",
            Act::VacuumOff => "VACOFF",
            Act::Lift => "LIFT",
            Act::Lower => "LOWER",
            Act::CheckWafer => "CHECK1",
            Act::CheckNoWafer => "CHECK0",
            Act::Commit => "COMMIT",
            Act::Out => "OUT",
            Act::Interlock => "INTERLOCK",
            Act::Speed => "SPEED",
            Act::Blade(Blade::A) => "BLADE.A",
            Act::Blade(Blade::B) => "BLADE.B",
            Act::Scan => "SCAN",
            Act::Leave => "LEAVE",
        }
    }

    /// What an operator reads: `the straight line in`, …
    pub fn describe(self) -> &'static str {
        match self {
            Act::Approach => "the move to the approach pose",
            Act::Enter => "the approach and the straight line in",
            Act::In => "the straight line in to the seat",
            Act::VacuumOn => "switching the vacuum on",
            Act::VacuumOff => "the release (vacuum off) at the seat",
            Act::Lift => "the lift through the support",
            Act::Lower => "the set-down through the support",
            Act::CheckWafer => "the vacuum sensor's check of the wafer",
            Act::CheckNoWafer => "the vacuum sensor's check of the release",
            Act::Commit => "the commit of the wafer map",
            Act::Out => "the straight line out",
            Act::Interlock => "the interlock check",
            Act::Speed => "the station's speed",
            Act::Blade(_) => "the choice of blade",
            Act::Scan => "the mapping scan",
            Act::Leave => {
                "the straight line out of the station the hand stood in, before the transfer"
            }
        }
    }

    /// Whether it moves the hand.
    pub fn moves(self) -> bool {
        matches!(
            self,
            Act::Approach
                | Act::Enter
                | Act::In
                | Act::Lift
                | Act::Lower
                | Act::Out
                | Act::Scan
                | Act::Leave
        )
    }

    /// Its word read back.
    pub fn parse(word: &str) -> Option<Act> {
        Some(match word {
            "APPROACH" => Act::Approach,
            "ENTER" => Act::Enter,
            "IN" => Act::In,
            "VACON" => Act::VacuumOn,
            "VACOFF" => Act::VacuumOff,
            "LIFT" => Act::Lift,
            "LOWER" => Act::Lower,
            "CHECK1" => Act::CheckWafer,
            "CHECK0" => Act::CheckNoWafer,
            "COMMIT" => Act::Commit,
            "OUT" => Act::Out,
            "INTERLOCK" => Act::Interlock,
            "SPEED" => Act::Speed,
            "BLADE.A" => Act::Blade(Blade::A),
            "BLADE.B" => Act::Blade(Blade::B),
            "SCAN" => Act::Scan,
            "LEAVE" => Act::Leave,
            _ => return None,
        })
    }
}

impl fmt::Display for Act {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.word())
    }
}

/// How a transfer was settled (`CLOSE`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Closed {
    /// The wafer is at its destination.
    Committed,
    /// The wafer stayed at its source.
    Aborted,
    /// Settled from the sensors after it ended abnormally.
    Settled,
    /// Left uncertain (after a power loss).
    Uncertain,
    /// A mapping scan ended.
    Ended,
}

impl Closed {
    fn word(self) -> &'static str {
        match self {
            Closed::Committed => "committed",
            Closed::Aborted => "aborted",
            Closed::Settled => "settled",
            Closed::Uncertain => "uncertain",
            Closed::Ended => "ended",
        }
    }

    fn parse(word: &str) -> Option<Closed> {
        Some(match word {
            "committed" => Closed::Committed,
            "aborted" => Closed::Aborted,
            "settled" => Closed::Settled,
            "uncertain" => Closed::Uncertain,
            "ended" => Closed::Ended,
            _ => return None,
        })
    }
}

/// One journal record (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub enum Record {
    /// A job begins: its transfer (`None` for a mapping scan of `station`) and its steps.
    Open {
        /// The transfer (its wafer and blade), or `None` for a mapping scan.
        transfer: Option<Transfer>,
        /// The station.
        station: StationName,
        /// What each step does, in order.
        plan: Vec<Act>,
    },
    /// Step `step` is about to start.
    Begin {
        /// Its index in the plan.
        step: u8,
        /// What it does.
        act: Act,
        /// Where it goes (a motion), if it moves.
        to: Option<Pose>,
        /// Where the hand is.
        at: Pose,
    },
    /// Step `step` has ended.
    Done {
        /// Its index in the plan.
        step: u8,
        /// What it did.
        act: Act,
        /// Where the hand is.
        at: Pose,
    },
    /// A SWAP's PUT half takes over from its GET half.
    Transfer(Transfer),
    /// The job is settled.
    Close(Closed),
}

fn write_pose(out: &mut String, key: &str, p: &Pose) {
    use std::fmt::Write as _;
    let _ = write!(
        out,
        " {key}={},{},{},{}",
        Num(p.x),
        Num(p.y),
        Num(p.z),
        Num(p.yaw)
    );
}

fn write_transfer(out: &mut String, t: &Transfer) {
    use std::fmt::Write as _;
    let kind = match t.kind {
        TransferKind::Get => "get",
        TransferKind::Put => "put",
    };
    let _ = write!(
        out,
        " {kind} {} {} {} {}",
        t.station, t.slot, t.blade, t.wafer
    );
}

impl Record {
    /// The record's text (without `wrcj1 seq=…` and the CRC).
    pub fn text(&self) -> String {
        let mut out = String::new();
        match self {
            Record::Open {
                transfer,
                station,
                plan,
            } => {
                out.push_str("OPEN");
                match transfer {
                    Some(t) => write_transfer(&mut out, t),
                    None => {
                        out.push_str(" map ");
                        out.push_str(station.as_str());
                    }
                }
                out.push_str(" plan=");
                let words: Vec<&str> = plan.iter().map(|a| a.word()).collect();
                out.push_str(&words.join(","));
            }
            Record::Begin { step, act, to, at } => {
                out.push_str(&format!("BEGIN {step} {act}"));
                if let Some(to) = to {
                    write_pose(&mut out, "to", to);
                }
                write_pose(&mut out, "at", at);
            }
            Record::Done { step, act, at } => {
                out.push_str(&format!("DONE {step} {act}"));
                write_pose(&mut out, "at", at);
            }
            Record::Transfer(t) => {
                out.push_str("TRANSFER");
                write_transfer(&mut out, t);
            }
            Record::Close(how) => {
                out.push_str("CLOSE ");
                out.push_str(how.word());
            }
        }
        out
    }

    /// Read a record's text back.
    pub fn parse(text: &str) -> Option<Record> {
        let mut words = text.split(' ');
        let head = words.next()?;
        let pose = |w: &str, key: &str| -> Option<Pose> {
            let v: Vec<f64> = w
                .strip_prefix(key)?
                .strip_prefix('=')?
                .split(',')
                .map(|n| n.parse::<f64>().ok().filter(|x| x.is_finite()))
                .collect::<Option<_>>()?;
            match v[..] {
                [x, y, z, yaw] => Some(Pose { x, y, z, yaw }),
                _ => None,
            }
        };
        let transfer = |words: &mut std::str::Split<'_, char>, kind: &str| -> Option<Transfer> {
            let kind = match kind {
                "get" => TransferKind::Get,
                "put" => TransferKind::Put,
                _ => return None,
            };
            let station = parse_station_name(words.next()?).ok()?;
            let slot = words.next()?.parse().ok()?;
            let blade = Blade::parse(words.next()?)?;
            let wafer = WaferId::parse(words.next()?)?;
            Some(Transfer {
                kind,
                station,
                slot,
                wafer,
                blade,
            })
        };
        let record = match head {
            "OPEN" => {
                let kind = words.next()?;
                let (t, station) = if kind == "map" {
                    (None, parse_station_name(words.next()?).ok()?)
                } else {
                    let t = transfer(&mut words, kind)?;
                    (Some(t), t.station)
                };
                let plan = words
                    .next()?
                    .strip_prefix("plan=")?
                    .split(',')
                    .filter(|w| !w.is_empty())
                    .map(Act::parse)
                    .collect::<Option<Vec<_>>>()?;
                Record::Open {
                    transfer: t,
                    station,
                    plan,
                }
            }
            "BEGIN" | "DONE" => {
                let step = words.next()?.parse().ok()?;
                let act = Act::parse(words.next()?)?;
                let rest: Vec<&str> = words.by_ref().collect();
                let (to, at) = match rest[..] {
                    [at] => (None, pose(at, "at")?),
                    [to, at] if head == "BEGIN" => (Some(pose(to, "to")?), pose(at, "at")?),
                    _ => return None,
                };
                if head == "BEGIN" {
                    Record::Begin { step, act, to, at }
                } else if to.is_none() {
                    Record::Done { step, act, at }
                } else {
                    return None;
                }
            }
            "TRANSFER" => {
                let kind = words.next()?;
                Record::Transfer(transfer(&mut words, kind)?)
            }
            "CLOSE" => Record::Close(Closed::parse(words.next()?)?),
            _ => return None,
        };
        words.next().is_none().then_some(record)
    }
}

/// The journal's line for `record`, number `seq`, with its CRC and newline.
pub fn journal_line(seq: u64, record: &Record) -> String {
    let body = format!("wrcj1 seq={seq} {}", record.text());
    let crc = crc32fast::hash(body.as_bytes());
    format!("{body} crc={crc:08x}\n")
}

/// Read one journal line (without its newline): its number and record; `None` for a line
/// that is not one whole, intact record.
pub fn parse_journal_line(line: &str) -> Option<(u64, Record)> {
    let (body, crc) = line.rsplit_once(" crc=")?;
    let crc = u32::from_str_radix(crc, 16)
        .ok()
        .filter(|_| crc.len() == 8)?;
    if crc32fast::hash(body.as_bytes()) != crc {
        return None;
    }
    let rest = body.strip_prefix("wrcj1 seq=")?;
    let (seq, text) = rest.split_once(' ')?;
    Some((seq.parse().ok()?, Record::parse(text)?))
}

/// What a journal file holds: its intact records in order, and whether reading stopped at a
/// damaged or cut-short line (a write the power cut short: everything before it is kept).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JournalText {
    /// The records, in order.
    pub records: Vec<Record>,
    /// Reading stopped at a line that is not an intact record (its 1-based number).
    pub torn_at: Option<usize>,
}

/// Read journal text: every intact record up to the first line that is not one (a line
/// whose CRC fails, or a last line without its newline).
pub fn read_journal_text(text: &str) -> JournalText {
    let mut out = JournalText::default();
    let mut rest = text;
    let mut n = 0;
    while !rest.is_empty() {
        n += 1;
        let Some((line, after)) = rest.split_once('\n') else {
            out.torn_at = Some(n);
            break;
        };
        match parse_journal_line(line) {
            Some((_, r)) => out.records.push(r),
            None => {
                out.torn_at = Some(n);
                break;
            }
        }
        rest = after;
    }
    out
}

/// Read the journal at `path` ([`read_journal_text`]); a missing file is an empty journal.
pub fn read_journal(path: &Path) -> io::Result<JournalText> {
    match std::fs::read(path) {
        Ok(bytes) => Ok(read_journal_text(&String::from_utf8_lossy(&bytes))),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(JournalText::default()),
        Err(e) => Err(e),
    }
}

/// The journal file, open for appending.
#[derive(Debug)]
pub struct JournalFile {
    file: File,
    seq: u64,
}

impl JournalFile {
    /// Open (or create) the journal at `path` for appending.
    pub fn open(path: &Path) -> io::Result<JournalFile> {
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .read(true)
            .open(path)?;
        Ok(JournalFile { file, seq: 0 })
    }

    /// Start the journal anew with `record` (an `OPEN`): the file is emptied, then the
    /// record written and made durable.
    pub fn restart(&mut self, record: &Record) -> io::Result<()> {
        self.file.set_len(0)?;
        self.append(record)
    }

    /// Append `record` and make it durable before returning (`fdatasync`).
    pub fn append(&mut self, record: &Record) -> io::Result<()> {
        self.write(record)?;
        self.sync()
    }

    /// Append `record` without waiting for the disk: durable only after [`JournalFile::sync`]
    /// (several records, one sync).
    pub fn write(&mut self, record: &Record) -> io::Result<()> {
        self.seq += 1;
        self.file
            .write_all(journal_line(self.seq, record).as_bytes())
    }

    /// Make every record written so far durable (`fdatasync`).
    pub fn sync(&mut self) -> io::Result<()> {
        self.file.sync_data()
    }
}

/// Three-valued knowledge of a place.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Maybe {
    /// Certainly not there.
    No,
    /// Perhaps there: uncertain until a sensor or an operator settles it.
    Perhaps,
    /// Certainly there.
    Yes,
}

/// What the sensors say now about the interrupted transfer's blade.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Evidence {
    /// Its vacuum valve is on (the board kept its outputs: only the controller stopped).
    /// With the valve off the sensor cannot see a wafer, whatever happened.
    pub valve_on: bool,
    /// Its vacuum sensor senses a wafer (meaningful only with the valve on).
    pub sensed: bool,
}

/// What [`judge`] decided about an interrupted job.
#[derive(Debug, Clone, PartialEq)]
pub struct Judgement {
    /// The transfer whose wafer is in question (a SWAP's current half); `None` for a
    /// mapping scan or an empty journal.
    pub transfer: Option<Transfer>,
    /// The station of the job.
    pub station: Option<StationName>,
    /// Its wafer may be on the blade.
    pub on_blade: Maybe,
    /// Its wafer may be in the slot.
    pub in_slot: Maybe,
    /// The hand may be inside the station (between its approach pose and the seat).
    pub inside: bool,
    /// The last step begun or done, as recorded: `(step, act, done)`.
    pub last: Option<(u8, Act, bool)>,
    /// Where the journal last saw the hand.
    pub at: Option<Pose>,
    /// What happened, for the log and the operator.
    pub text: String,
}

impl Judgement {
    /// Whether the journal held a job that did not close.
    pub fn open(&self) -> bool {
        self.station.is_some()
    }
}

/// The records of the last job, from its `OPEN`; empty when the journal is empty or the
/// job was closed.
fn open_job(records: &[Record]) -> &[Record] {
    let start = records
        .iter()
        .rposition(|r| matches!(r, Record::Open { .. }));
    match start {
        Some(i) if !records[i..].iter().any(|r| matches!(r, Record::Close(_))) => &records[i..],
        _ => &[],
    }
}

/// Decide what an interrupted job did from its records and the blade's sensors now (see
/// the module docs): where its wafer may be, and whether the hand may be inside the
/// station. A closed or empty journal gives a judgement with no station ([`Judgement::open`]
/// is false).
pub fn judge(records: &[Record], evidence: Evidence) -> Judgement {
    let job = open_job(records);
    let mut j = Judgement {
        transfer: None,
        station: None,
        on_blade: Maybe::No,
        in_slot: Maybe::No,
        inside: false,
        last: None,
        at: None,
        text: String::new(),
    };
    let Some(Record::Open {
        transfer, station, ..
    }) = job.first()
    else {
        return j;
    };
    j.station = Some(*station);
    // A SWAP's PUT half: only the records after it count for its wafer.
    let (transfer, half) = match job.iter().rposition(|r| matches!(r, Record::Transfer(_))) {
        Some(i) => match job[i] {
            Record::Transfer(t) => (Some(t), &job[i..]),
            _ => (*transfer, job),
        },
        None => (*transfer, job),
    };
    j.transfer = transfer;
    let begun = |act: Act| {
        half.iter()
            .any(|r| matches!(r, Record::Begin { act: a, .. } if *a == act))
    };
    let done = |act: Act| {
        half.iter()
            .any(|r| matches!(r, Record::Done { act: a, .. } if *a == act))
    };
    for r in job {
        match r {
            Record::Begin { step, act, at, .. } => {
                j.last = Some((*step, *act, false));
                j.at = Some(*at);
            }
            Record::Done { step, act, at } => {
                j.last = Some((*step, *act, true));
                j.at = Some(*at);
            }
            _ => {}
        }
    }
    // Inside: the line in (or a blended approach) began and the line out has not ended.
    let entered = job
        .iter()
        .any(|r| matches!(r, Record::Begin { act, .. } if matches!(act, Act::In | Act::Enter)));
    let left = job
        .iter()
        .rposition(|r| matches!(r, Record::Done { act: Act::Out, .. }));
    let last_entry = job.iter().rposition(
        |r| matches!(r, Record::Begin { act, .. } if matches!(act, Act::In | Act::Enter)),
    );
    // Or it began to leave a station it stood in before the transfer and had not left it.
    let leaving = matches!(j.last, Some((_, Act::Leave, false)));
    j.inside = leaving || (entered && left.is_none_or(|out| last_entry.is_some_and(|e| e > out)));
    let where_ = match j.last {
        Some((step, act, true)) => format!("after step {} ({})", step + 1, act.describe()),
        Some((step, act, false)) => format!("during step {} ({})", step + 1, act.describe()),
        None => "before its first step".to_string(),
    };
    let Some(t) = transfer else {
        j.text = format!("a MAP of {station} was interrupted {where_}");
        return j;
    };
    let sensor = if evidence.valve_on {
        if evidence.sensed {
            "the vacuum sensor senses a wafer on the blade"
        } else {
            "the vacuum sensor senses no wafer on the blade"
        }
    } else {
        "the vacuum is off, so its sensor cannot tell"
    };
    let (on_blade, in_slot, why) = match t.kind {
        TransferKind::Get => {
            if !begun(Act::VacuumOn) {
                (
                    Maybe::No,
                    Maybe::Yes,
                    "the vacuum was never switched on: the wafer cannot have left the slot",
                )
            } else if evidence.valve_on {
                if evidence.sensed {
                    (Maybe::Yes, Maybe::No, "the wafer is on the blade")
                } else if done(Act::CheckWafer) {
                    // Confirmed on the blade, then no longer sensed: the journal and the
                    // sensor disagree. It may have fallen (on the way out, or back into the
                    // slot) or the sensor may have failed: uncertain where it was last.
                    let slot = if done(Act::Out) {
                        Maybe::No
                    } else {
                        Maybe::Perhaps
                    };
                    (
                        Maybe::Perhaps,
                        slot,
                        "the wafer was confirmed on the blade and is no longer sensed: it may have fallen, or the sensor failed",
                    )
                } else if done(Act::Lift) {
                    // The blade rose through the slot with the vacuum on and never sensed
                    // the wafer: the slot may have been empty (a wafer taken away by hand)
                    // or the pick failed. Not on the blade, not certainly in the slot.
                    (
                        Maybe::No,
                        Maybe::Perhaps,
                        "the blade rose through the slot with the vacuum on and never sensed the wafer: the slot may be empty",
                    )
                } else {
                    (
                        Maybe::No,
                        Maybe::Yes,
                        "the lift through the slot had not ended and the blade does not hold the wafer: it is still in the slot",
                    )
                }
            } else if done(Act::CheckWafer) {
                let slot = if done(Act::Out) {
                    Maybe::No
                } else {
                    Maybe::Perhaps
                };
                (
                    Maybe::Perhaps,
                    slot,
                    "the wafer was confirmed on the blade, then the vacuum went off (a power loss): it may have stayed on the blade, fallen back into the slot or fallen on the way",
                )
            } else if begun(Act::Lift) {
                (
                    Maybe::Perhaps,
                    Maybe::Perhaps,
                    "the lift had begun without the vacuum's confirmation: the wafer may be on the blade or in the slot",
                )
            } else {
                (
                    Maybe::No,
                    Maybe::Yes,
                    "the lift never began: the wafer cannot have left the slot",
                )
            }
        }
        TransferKind::Put => {
            // A SWAP's PUT half entered with its GET half: the whole job counts.
            let entered_slot = entered;
            if done(Act::VacuumOff) {
                (
                    Maybe::No,
                    Maybe::Yes,
                    "the release at the seat was done: the wafer is in the slot",
                )
            } else if begun(Act::VacuumOff) && !evidence.valve_on {
                // The release begins only once the line in has ended at the seat, and
                // nothing moves while the valve switches: a valve off now (the release's
                // own, or a power loss's) let the wafer down onto its supports there.
                (
                    Maybe::No,
                    Maybe::Yes,
                    "the release at the seat had begun and the vacuum is off: the wafer is in the slot",
                )
            } else if evidence.valve_on {
                if evidence.sensed {
                    (
                        Maybe::Yes,
                        Maybe::No,
                        "the wafer is still held on the blade",
                    )
                } else {
                    // The journal has the wafer held (never released), the sensor sees
                    // none: it may have fallen, or the sensor failed. Uncertain on the blade
                    // (where it was last), and in the slot once the hand had entered; never
                    // out of the map on the sensor's word alone.
                    let slot = if entered_slot {
                        Maybe::Perhaps
                    } else {
                        Maybe::No
                    };
                    (
                        Maybe::Perhaps,
                        slot,
                        "the wafer was never released, but the vacuum sensor senses none: it may have fallen, or the sensor failed",
                    )
                }
            } else {
                let slot = if entered_slot {
                    Maybe::Perhaps
                } else {
                    Maybe::No
                };
                (
                    Maybe::Perhaps,
                    slot,
                    "the vacuum went off before the release at the seat was done (a power loss): the wafer may be on the blade, in the slot or fallen",
                )
            }
        }
    };
    j.on_blade = on_blade;
    j.in_slot = in_slot;
    j.text = format!("{t} was interrupted {where_}; {sensor}: {why}");
    j
}

#[cfg(test)]
mod tests;
