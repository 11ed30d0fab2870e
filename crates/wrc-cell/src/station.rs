//! A station of the cell (load port, aligner, process module, buffer): where its slots are,
//! how the hand enters it, and the check that the robot reaches every slot.
//!
//! # Geometry
//!
//! All poses are poses of the tool centre point (TCP) in the robot's base frame, as
//! [`wrc_robot::Pose`]: x, y \[mm\] in the base plane, z \[mm\] the height of the Z lift, yaw \[deg\]
//! the direction the hand points (from the wrist towards the finger tips), counter-clockwise
//! from the base x axis. The TCP is the centre of a wafer lying on the hand.
//!
//! * **Taught pose** (`pose`): x, y = the centre of a wafer seated in slot 1; z = the slot's
//!   *support height* — the TCP height at which the hand's upper surface just touches the
//!   underside of the wafer resting on slot 1's supports; yaw = the hand direction pointing
//!   into the station. `TEACH` stores the current TCP pose with the hand placed exactly so.
//! * **Slots** are stacked upwards, slot 1 lowest (as in SEMI cassettes):
//!   `slot_z(n) = z + (n - 1) · pitch_mm`.
//! * **Seated poses** (hand fully inside, under or holding the wafer of slot n), x, y and yaw
//!   of the taught pose:
//!   - *lowered*: `z = slot_z(n) - stroke_mm / 2` — the hand is clear under the wafer
//!     (GET enters, PUT leaves here);
//!   - *lifted*: `z = slot_z(n) + stroke_mm / 2` — the wafer is lifted `stroke_mm / 2` off its
//!     supports (GET leaves, PUT enters here).
//!
//!   The Z stroke between them (`stroke_mm`) passes through the support height, which is
//!   where the wafer changes hands. `stroke_mm < pitch_mm` keeps a lifted wafer below the
//!   next slot's wafer.
//! * **Approach poses**: the seated pose moved back `approach_mm` against the hand direction,
//!   same z and yaw: `x - approach_mm · cos(yaw)`, `y - approach_mm · sin(yaw)`. The hand
//!   (and a wafer on it) is outside the station there; the robot reaches it with a PTP move
//!   and goes from it to the seated pose on a straight line that keeps the hand on the
//!   station's axis.
//!
//! ```text
//!            approach (lifted)  ─────────line────────▶  seated (lifted)   z_n + stroke/2
//!                                                          ▲ Z stroke
//!   support height of slot n  ─ ─ ─ ─ ─ ─ ─ ─ ─ ─ ─ ─ ─ ─ ─│─ ─ ─ ─ ─ ─   z_n
//!            approach (lowered) ─────────line────────▶  seated (lowered)  z_n - stroke/2
//!            |◀──────────── approach_mm ─────────────▶|    (x, y of the taught pose)
//! ```

use std::fmt;

use wrc_motion::{check_line, ptp_cost, solutions, sooner, PlanError};
use wrc_robot::{IkCheck, InlineName, Joints, KinematicsError, Pose, Posture, Robot};

use crate::mapping::SlotCode;
use crate::obstacle::{StationVolume, VolumeSpec};
use wrc_robot::{wrap180, Num};

/// The wafer radius the stations file's sizes are checked with (a 300 mm wafer) [mm].
pub const WAFER_RADIUS_MM: f64 = 150.0;

/// A station name: 1 to 16 ASCII letters, digits, `_` or `-`; compared case-insensitively.
pub type StationName = InlineName<16>;

/// Most slots a station may have.
pub const MAX_SLOTS: u16 = 50;

/// How far past the approach pose the hand still counts as outside a station
/// ([`Station::hand_inside`]) [mm]: the clearance in front of its opening. A joint move that
/// leaves or reaches an approach pose may cross its line by a few millimetres (up to 10 mm
/// measured in the demo cell's flows) before it turns away; inside the opening only straight
/// moves along the line are safe.
pub const INSIDE_ENTRY_MARGIN_MM: f64 = 15.0;

/// How far beyond the seat, along the station's direction, the hand still counts as inside
/// [mm] (the back of a cassette).
pub const INSIDE_BEYOND_SEAT_MM: f64 = 5.0;

/// How far off a station's line the hand still counts as in front of it (a 300 mm wafer's
/// radius) [mm].
pub const INSIDE_HALF_WIDTH_MM: f64 = 150.0;

/// Highest digital input number an interlock may name.
pub const MAX_INPUT: u8 = 31;

/// What kind of station it is. Only informative for now (shown by `STN`); motions are the
/// same for every kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StationKind {
    /// A load port with a cassette or FOUP of stacked slots.
    LoadPort,
    /// A wafer aligner (one slot).
    Aligner,
    /// A process module (usually one slot).
    ProcessModule,
    /// A buffer or storage shelf.
    Buffer,
}

impl StationKind {
    /// Every kind.
    pub const ALL: [StationKind; 4] = [
        StationKind::LoadPort,
        StationKind::Aligner,
        StationKind::ProcessModule,
        StationKind::Buffer,
    ];

    /// The name used in the stations file and in `STN` lines: `load_port`, `aligner`,
    /// `process_module`, `buffer`.
    pub fn as_str(self) -> &'static str {
        match self {
            StationKind::LoadPort => "load_port",
            StationKind::Aligner => "aligner",
            StationKind::ProcessModule => "process_module",
            StationKind::Buffer => "buffer",
        }
    }

    /// The kind named `text` (exactly as [`StationKind::as_str`] writes it).
    pub fn parse(text: &str) -> Option<StationKind> {
        StationKind::ALL.into_iter().find(|k| k.as_str() == text)
    }
}

impl fmt::Display for StationKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The simulated board's initial contents of a station (`[station.sim]` in the stations
/// file): used only when the board is simulated.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StationSim {
    /// One code per slot, slot 1 first.
    pub wafers: Vec<SlotCode>,
}

/// One station. The fields are public plain data; [`Station::check`] checks them on their
/// own and [`Station::validate`] against a robot. Containers ([`crate::Stations`]) only hold
/// checked stations.
#[derive(Debug, Clone, PartialEq)]
pub struct Station {
    /// Name used in commands (`GET LP1 3`).
    pub name: StationName,
    /// What kind of station it is.
    pub kind: StationKind,
    /// Taught pose of slot 1: wafer centre x, y \[mm\], support height z \[mm\], hand yaw into
    /// the station \[deg\] (see the module docs).
    pub pose: Pose,
    /// Number of slots, 1 to [`MAX_SLOTS`].
    pub slots: u16,
    /// Height from one slot to the next \[mm\]; > 0 when there are several slots (unused with
    /// one).
    pub pitch_mm: f64,
    /// How far the hand stays back from the seated pose, against the hand direction, before
    /// it extends into the station \[mm\]; > 0.
    pub approach_mm: f64,
    /// Z stroke that lifts a wafer off its supports (from `stroke_mm / 2` below the support
    /// height to `stroke_mm / 2` above it) \[mm\]; > 0 and below `pitch_mm` for several slots.
    pub stroke_mm: f64,
    /// Speed override for the motions inside and near the station [%], 1 to 100.
    pub speed_pct: f64,
    /// Digital input (0 to [`MAX_INPUT`]) that must be asserted — the station is safe to
    /// enter (door or slit valve open, cassette present) — before and while the hand moves
    /// into it; `None`: no interlock.
    pub interlock_input: Option<u8>,
    /// Elbow posture for the transfers; `None`: the one the arm has when the transfer starts,
    /// so both must work.
    pub posture: Option<Posture>,
    /// The simulated board's initial wafers here, if given.
    pub sim: Option<StationSim>,
    /// Sizes of its solid volume that differ from the default ([`Station::volume`]).
    pub volume: VolumeSpec,
}

/// Which of a slot's four poses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PoseKind {
    /// Outside the station, in front of the slot.
    Approach {
        /// `true`: at the lifted height, `false`: at the lowered height.
        lifted: bool,
    },
    /// Inside the station, at the slot.
    Seated {
        /// `true`: at the lifted height, `false`: at the lowered height.
        lifted: bool,
    },
}

impl fmt::Display for PoseKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (what, lifted) = match *self {
            PoseKind::Approach { lifted } => ("approach", lifted),
            PoseKind::Seated { lifted } => ("seated", lifted),
        };
        let height = if lifted { "lifted" } else { "lowered" };
        write!(f, "{what} pose ({height})")
    }
}

/// A station that cannot be used as it is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum StationError {
    /// The name is not a usable station name.
    #[error(
        "{name:?} is not a usable station name: use 1 to 16 ASCII letters, digits, '_' or '-'"
    )]
    BadName {
        /// The name as given.
        name: String,
    },
    /// A field has an unusable value.
    #[error("station {station}: {field} {reason}")]
    Invalid {
        /// The station.
        station: StationName,
        /// The field, as the stations file names it (`pitch_mm`).
        field: &'static str,
        /// What is wrong and what is expected.
        reason: String,
    },
    /// A slot number the station does not have.
    #[error("station {station} has no slot {slot}: its slots are 1 to {slots}")]
    NoSuchSlot {
        /// The station.
        station: StationName,
        /// The slot asked for.
        slot: u16,
        /// The station's slot count.
        slots: u16,
    },
    /// One of a slot's poses is out of the robot's reach.
    #[error(
        "station {station} slot {slot}: the {what} x={} y={} z={} yaw={} cannot be reached \
         with the {} elbow: {source}; re-teach the station or change approach_mm/stroke_mm",
        Num(pose.x), Num(pose.y), Num(pose.z), Num(pose.yaw), posture_word(*posture)
    )]
    Unreachable {
        /// The station.
        station: StationName,
        /// The slot.
        slot: u16,
        /// Which pose.
        what: PoseKind,
        /// The pose [mm, deg].
        pose: Pose,
        /// The elbow posture tried.
        posture: Posture,
        /// Why the kinematics refuse it.
        source: KinematicsError,
    },
    /// The straight line between a slot's approach and seated poses leaves the workspace or
    /// a joint's range, from every approach solution the station allows.
    #[error(
        "station {station} slot {slot}: the straight {} line into the station, with the {} \
         elbow: {source}; re-teach the station, shorten approach_mm{}",
        if *lifted { "lifted" } else { "lowered" }, posture_word(*posture),
        posture_hint(*fixed)
    )]
    PathLeavesWorkspace {
        /// The station.
        station: StationName,
        /// The slot.
        slot: u16,
        /// `true`: the lifted line, `false`: the lowered one.
        lifted: bool,
        /// The elbow posture of the solution reported (the first tried).
        posture: Posture,
        /// Whether the station fixes its posture.
        fixed: bool,
        /// Why the planner refuses the line: where and what.
        source: PlanError,
    },
}

fn posture_word(p: Posture) -> &'static str {
    match p {
        Posture::Right => "right",
        Posture::Left => "left",
    }
}

fn posture_hint(fixed: bool) -> &'static str {
    if fixed {
        ""
    } else {
        " or fix the elbow with posture = \"right\" or \"left\""
    }
}

/// Parse a station name (1 to 16 of `[A-Za-z0-9_-]`).
pub fn parse_station_name(text: &str) -> Result<StationName, StationError> {
    StationName::new(text).ok_or_else(|| StationError::BadName {
        name: text.chars().take(40).collect(),
    })
}

/// Whether two station names are the same, ignoring ASCII case.
pub(crate) fn same_name(a: &str, b: &str) -> bool {
    a.eq_ignore_ascii_case(b)
}

impl Station {
    /// A station with `slots` slots and the given geometry; no pitch, speed 100 %, no
    /// interlock, either posture, no simulated wafers. Check it with [`Station::check`].
    pub fn new(
        name: StationName,
        kind: StationKind,
        pose: Pose,
        approach_mm: f64,
        stroke_mm: f64,
    ) -> Station {
        Station {
            name,
            kind,
            pose,
            slots: 1,
            pitch_mm: 0.0,
            approach_mm,
            stroke_mm,
            speed_pct: 100.0,
            interlock_input: None,
            posture: None,
            sim: None,
            volume: VolumeSpec::default(),
        }
    }

    /// Check the fields on their own: finite pose, 1 to [`MAX_SLOTS`] slots, a positive pitch
    /// for several slots, positive approach and stroke, a stroke below the pitch, a speed of
    /// 1 to 100 %, an interlock input up to [`MAX_INPUT`], and one simulated code per slot.
    pub fn check(&self) -> Result<(), StationError> {
        let bad = |field: &'static str, reason: String| StationError::Invalid {
            station: self.name,
            field,
            reason,
        };
        for (field, v) in [
            ("x_mm", self.pose.x),
            ("y_mm", self.pose.y),
            ("z_mm", self.pose.z),
            ("yaw_deg", self.pose.yaw),
            ("pitch_mm", self.pitch_mm),
            ("approach_mm", self.approach_mm),
            ("stroke_mm", self.stroke_mm),
            ("speed_pct", self.speed_pct),
        ] {
            if !v.is_finite() {
                return Err(bad(field, format!("must be a finite number, got {v}")));
            }
        }
        if !(1..=MAX_SLOTS).contains(&self.slots) {
            return Err(bad(
                "slots",
                format!("must be 1 to {MAX_SLOTS}, got {}", self.slots),
            ));
        }
        if self.slots > 1 && self.pitch_mm <= 0.0 {
            return Err(bad(
                "pitch_mm",
                format!(
                    "must be greater than 0 for a station with {} slots, got {}",
                    self.slots, self.pitch_mm
                ),
            ));
        }
        if self.pitch_mm < 0.0 {
            return Err(bad(
                "pitch_mm",
                format!("must be 0 or more, got {}", self.pitch_mm),
            ));
        }
        if self.approach_mm <= 0.0 {
            return Err(bad(
                "approach_mm",
                format!("must be greater than 0, got {}", self.approach_mm),
            ));
        }
        if self.stroke_mm <= 0.0 {
            return Err(bad(
                "stroke_mm",
                format!("must be greater than 0, got {}", self.stroke_mm),
            ));
        }
        if self.slots > 1 && self.stroke_mm >= self.pitch_mm {
            return Err(bad(
                "stroke_mm",
                format!(
                    "must be below pitch_mm ({}) so a lifted wafer stays clear of the slot \
                     above, got {}",
                    Num(self.pitch_mm),
                    Num(self.stroke_mm)
                ),
            ));
        }
        if !(1.0..=100.0).contains(&self.speed_pct) {
            return Err(bad(
                "speed_pct",
                format!("must be 1 to 100 %, got {}", self.speed_pct),
            ));
        }
        if let Some(input) = self.interlock_input {
            if input > MAX_INPUT {
                return Err(bad(
                    "interlock_input",
                    format!("must be an input number 0 to {MAX_INPUT}, got {input}"),
                ));
            }
        }
        self.volume(WAFER_RADIUS_MM).check(self.name)?;
        if let Some(sim) = &self.sim {
            if sim.wafers.len() != usize::from(self.slots) {
                return Err(bad(
                    "sim.wafers",
                    format!(
                        "needs one code per slot: {} codes for {} slots",
                        sim.wafers.len(),
                        self.slots
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Its solid volume for wafers of `wafer_radius_mm` [mm]: the default
    /// ([`StationVolume::default_for`]) with the sizes its `volume` gives.
    pub fn volume(&self, wafer_radius_mm: f64) -> StationVolume {
        self.volume
            .over(StationVolume::default_for(self, wafer_radius_mm))
    }

    /// Whether the station has slot `slot` (1-based).
    pub fn has_slot(&self, slot: u16) -> bool {
        (1..=self.slots).contains(&slot)
    }

    fn slot_checked(&self, slot: u16) -> Result<(), StationError> {
        if self.has_slot(slot) {
            Ok(())
        } else {
            Err(StationError::NoSuchSlot {
                station: self.name,
                slot,
                slots: self.slots,
            })
        }
    }

    /// Support height of slot `slot`: `z + (slot - 1) · pitch_mm` \[mm\].
    pub fn slot_z(&self, slot: u16) -> Result<f64, StationError> {
        self.slot_checked(slot)?;
        Ok(self.pose.z + f64::from(slot - 1) * self.pitch_mm)
    }

    /// The seated pose at `slot`: the taught x, y, yaw; z = support height ± `stroke_mm / 2`
    /// (`lifted`: above, holding the wafer off its supports; otherwise below, clear under it).
    pub fn seated_pose(&self, slot: u16, lifted: bool) -> Result<Pose, StationError> {
        let half = 0.5 * self.stroke_mm;
        let z = self.slot_z(slot)? + if lifted { half } else { -half };
        Ok(Pose {
            x: self.pose.x,
            y: self.pose.y,
            z,
            yaw: self.pose.yaw,
        })
    }

    /// The station as a blade whose wafer plane is `z_offset_mm` above the TCP sees it (a
    /// dual-blade robot's blade B; 0 for the hand): every height lowered by the offset, so
    /// that the TCP poses of its transfers put that blade's wafer where the hand's would be.
    /// Reachability checks of the result check the TCP (the wrist's Z axis) at those heights.
    pub fn for_blade(&self, z_offset_mm: f64) -> Station {
        let mut s = self.clone();
        s.pose.z -= z_offset_mm;
        s
    }

    /// The approach pose at `slot`: the seated pose moved back `approach_mm` against the
    /// hand direction (`x - approach_mm·cos yaw`, `y - approach_mm·sin yaw`), same z and yaw.
    pub fn approach_pose(&self, slot: u16, lifted: bool) -> Result<Pose, StationError> {
        let seated = self.seated_pose(slot, lifted)?;
        let (s, c) = self.pose.yaw.to_radians().sin_cos();
        Ok(Pose {
            x: seated.x - self.approach_mm * c,
            y: seated.y - self.approach_mm * s,
            ..seated
        })
    }

    /// Where `pose` is relative to the station's line: `(along, lateral)` [mm], `along` the
    /// distance past the seat in the hand's direction (0 at the seat, `-approach_mm` at the
    /// approach pose), `lateral` the distance off the line.
    pub fn line_offset(&self, pose: &Pose) -> (f64, f64) {
        let (s, c) = self.pose.yaw.to_radians().sin_cos();
        let (dx, dy) = (pose.x - self.pose.x, pose.y - self.pose.y);
        (dx * c + dy * s, (dx * s - dy * c).abs())
    }

    /// Whether the hand at `pose` is inside the station: past its approach pose by more
    /// than [`INSIDE_ENTRY_MARGIN_MM`], not beyond the seat by more than
    /// [`INSIDE_BEYOND_SEAT_MM`], and in front of it (within a wafer's radius,
    /// [`INSIDE_HALF_WIDTH_MM`], of its line). Heights are not looked at. There the hand may
    /// only move along the line and vertically within its slot: anything sideways hits the
    /// station (the simulated cell reports it, `WorldEvent::SideCollision`).
    pub fn hand_inside(&self, pose: &Pose) -> bool {
        let (along, lateral) = self.line_offset(pose);
        along > -(self.approach_mm - INSIDE_ENTRY_MARGIN_MM)
            && along <= INSIDE_BEYOND_SEAT_MM
            && lateral <= INSIDE_HALF_WIDTH_MM
    }

    /// The elbow postures a transfer may use here: the station's own, or both.
    pub fn postures(&self) -> &'static [Posture] {
        match self.posture {
            Some(Posture::Right) => &[Posture::Right],
            Some(Posture::Left) => &[Posture::Left],
            None => &[Posture::Right, Posture::Left],
        }
    }

    /// Check the station against `robot`: for every slot, lifted and lowered, the approach
    /// and seated poses are reachable with the singularity margin and within the joint limits
    /// (as the motion planner checks targets), and from at least one approach solution the
    /// straight line into the station keeps every joint within its range and away from the
    /// singularities at every point ([`Station::approach_joints`]). The vertical Z strokes
    /// only change z, so their end poses cover them.
    pub fn validate(&self, robot: &Robot) -> Result<(), StationError> {
        self.check()?;
        let home = robot.home();
        for slot in 1..=self.slots {
            for lifted in [false, true] {
                self.approach_joints(robot, slot, lifted, &home)?;
            }
        }
        Ok(())
    }

    /// The joints a transfer at `slot` moves to (PTP) at the approach pose, `lifted` or not,
    /// before its straight line into the station: among the solutions within the joint
    /// limits — each posture [`Station::postures`] allows, each turn of the shoulder and the
    /// hand the ranges allow — those from which that line keeps every limit at every point
    /// ([`wrc_motion::check_line`]; the line out is the same path), and of those the one
    /// reached soonest from `from` ([`wrc_motion::ptp_target`]'s rule). An error says why
    /// the first solution tried cannot be used.
    pub fn approach_joints(
        &self,
        robot: &Robot,
        slot: u16,
        lifted: bool,
        from: &Joints,
    ) -> Result<Joints, StationError> {
        let approach = self.approach_pose(slot, lifted)?;
        let seated = self.seated_pose(slot, lifted)?;
        let mut best: Option<(Joints, (f64, f64))> = None;
        let mut first_error = None;
        for &posture in self.postures() {
            let unreachable =
                |pose: &Pose, what: PoseKind, source: KinematicsError| StationError::Unreachable {
                    station: self.name,
                    slot,
                    what,
                    pose: *pose,
                    posture,
                    source,
                };
            let all = match solutions(robot, &approach, posture, from) {
                Ok(all) => all,
                Err(e) => {
                    let source = match e {
                        PlanError::Kinematics(k) => k,
                        _ => KinematicsError::NotFinite { what: "pose" },
                    };
                    first_error.get_or_insert(unreachable(
                        &approach,
                        PoseKind::Approach { lifted },
                        source,
                    ));
                    continue;
                }
            };
            if let Err(e) = robot.inverse_checked(&seated, posture, None, IkCheck::STRICT) {
                first_error.get_or_insert(unreachable(&seated, PoseKind::Seated { lifted }, e));
                continue;
            }
            for q in all.as_slice() {
                match check_line(robot, q, &seated) {
                    Ok(_) => {
                        let cost = ptp_cost(robot, from, q);
                        if best.is_none_or(|(_, b)| sooner(cost, b)) {
                            best = Some((*q, cost));
                        }
                    }
                    Err(source) => {
                        first_error.get_or_insert(StationError::PathLeavesWorkspace {
                            station: self.name,
                            slot,
                            lifted,
                            posture,
                            fixed: self.posture.is_some(),
                            source,
                        });
                    }
                }
            }
        }
        match (best, first_error) {
            (Some((q, _)), _) => Ok(q),
            (None, Some(e)) => Err(e),
            (None, None) => Err(StationError::PathLeavesWorkspace {
                station: self.name,
                slot,
                lifted,
                posture: Posture::Right,
                fixed: self.posture.is_some(),
                source: PlanError::PostureChange,
            }),
        }
    }

    /// The station with a new taught pose (yaw wrapped into (-180, 180]).
    pub(crate) fn with_pose(&self, pose: Pose) -> Station {
        Station {
            pose: Pose {
                yaw: wrap180(pose.yaw),
                ..pose
            },
            ..self.clone()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    fn cassette() -> Station {
        Station {
            slots: 25,
            pitch_mm: 10.0,
            interlock_input: Some(14),
            ..Station::new(
                parse_station_name("LP1").unwrap(),
                StationKind::LoadPort,
                Pose {
                    x: 294.449,
                    y: -170.0,
                    z: 20.0,
                    yaw: -30.0,
                },
                220.0,
                6.0,
            )
        }
    }

    #[test]
    fn slot_heights_rise_by_the_pitch() {
        let s = cassette();
        assert!(close(s.slot_z(1).unwrap(), 20.0));
        assert!(close(s.slot_z(25).unwrap(), 260.0));
        assert_eq!(
            s.slot_z(0),
            Err(StationError::NoSuchSlot {
                station: s.name,
                slot: 0,
                slots: 25
            })
        );
        assert!(s
            .slot_z(26)
            .unwrap_err()
            .to_string()
            .contains("slots are 1 to 25"));
    }

    #[test]
    fn seated_and_approach_poses_follow_the_documented_geometry() {
        let s = cassette();
        let low = s.seated_pose(3, false).unwrap();
        let high = s.seated_pose(3, true).unwrap();
        assert!(close(low.z, 40.0 - 3.0) && close(high.z, 40.0 + 3.0));
        assert!(close(low.x, s.pose.x) && close(low.y, s.pose.y) && close(low.yaw, -30.0));
        let app = s.approach_pose(3, true).unwrap();
        let yaw = (-30f64).to_radians();
        assert!(close(app.x, s.pose.x - 220.0 * yaw.cos()));
        assert!(close(app.y, s.pose.y - 220.0 * yaw.sin()));
        assert!(close(app.z, high.z) && close(app.yaw, high.yaw));
        assert!(close((app.x - high.x).hypot(app.y - high.y), 220.0));
        assert!(s.approach_pose(26, false).is_err());
    }

    #[test]
    fn a_reachable_station_validates() {
        cassette().validate(&Robot::paper_default()).unwrap();
    }

    fn refusal(station: Station) -> String {
        let err = station.check().unwrap_err();
        assert!(station.validate(&Robot::paper_default()).is_err());
        err.to_string()
    }

    #[test]
    fn every_field_is_checked() {
        let base = cassette();
        let e = refusal(Station {
            slots: 0,
            ..base.clone()
        });
        assert!(
            e.contains("LP1") && e.contains("slots must be 1 to 50"),
            "{e}"
        );
        let e = refusal(Station {
            slots: 51,
            ..base.clone()
        });
        assert!(e.contains("got 51"), "{e}");
        let e = refusal(Station {
            pitch_mm: 0.0,
            ..base.clone()
        });
        assert!(e.contains("pitch_mm must be greater than 0"), "{e}");
        let e = refusal(Station {
            slots: 1,
            pitch_mm: -1.0,
            ..base.clone()
        });
        assert!(e.contains("pitch_mm must be 0 or more"), "{e}");
        let e = refusal(Station {
            approach_mm: 0.0,
            ..base.clone()
        });
        assert!(e.contains("approach_mm must be greater than 0"), "{e}");
        let e = refusal(Station {
            stroke_mm: -2.0,
            ..base.clone()
        });
        assert!(e.contains("stroke_mm must be greater than 0"), "{e}");
        let e = refusal(Station {
            stroke_mm: 10.0,
            ..base.clone()
        });
        assert!(e.contains("stroke_mm must be below pitch_mm (10)"), "{e}");
        let e = refusal(Station {
            speed_pct: 0.5,
            ..base.clone()
        });
        assert!(e.contains("speed_pct must be 1 to 100"), "{e}");
        let e = refusal(Station {
            speed_pct: 101.0,
            ..base.clone()
        });
        assert!(e.contains("speed_pct"), "{e}");
        let e = refusal(Station {
            interlock_input: Some(32),
            ..base.clone()
        });
        assert!(
            e.contains("interlock_input must be an input number 0 to 31"),
            "{e}"
        );
        let e = refusal(Station {
            pose: Pose {
                x: f64::NAN,
                ..base.pose
            },
            ..base.clone()
        });
        assert!(e.contains("x_mm must be a finite number"), "{e}");
        let e = refusal(Station {
            approach_mm: f64::INFINITY,
            ..base.clone()
        });
        assert!(e.contains("approach_mm must be a finite number"), "{e}");
        let e = refusal(Station {
            sim: Some(StationSim {
                wafers: vec![SlotCode::Present; 24],
            }),
            ..base.clone()
        });
        assert!(e.contains("24 codes for 25 slots"), "{e}");
    }

    #[test]
    fn names_are_checked() {
        assert!(parse_station_name("PM-1_a").is_ok());
        assert!(parse_station_name("sixteen_chars_ok").is_ok());
        for bad in ["", "seventeen_chars_x", "LP 1", "LP1;", "ÄL"] {
            let e = parse_station_name(bad).unwrap_err().to_string();
            assert!(e.contains("not a usable station name"), "{bad}: {e}");
        }
    }

    #[test]
    fn an_unreachable_slot_names_station_slot_and_pose() {
        let robot = Robot::paper_default();
        // The top slots are too high for the 300 mm Z lift.
        let s = Station {
            pose: Pose {
                z: 60.0,
                ..cassette().pose
            },
            ..cassette()
        };
        let e = s.validate(&robot).unwrap_err();
        assert!(
            matches!(e, StationError::Unreachable { slot: 25, .. }),
            "{e}"
        );
        let msg = e.to_string();
        assert!(
            msg.contains("station LP1 slot 25") && msg.contains("approach pose (lifted)"),
            "{msg}"
        );
        assert!(msg.contains("axis z"), "{msg}");

        // Seated too far out: 398 mm from the base, within the 2 mm singularity margin.
        let s = Station {
            pose: Pose {
                x: 398.0,
                y: 0.0,
                yaw: 0.0,
                ..cassette().pose
            },
            ..cassette()
        };
        let msg = s.validate(&robot).unwrap_err().to_string();
        assert!(
            msg.contains("slot 1")
                && msg.contains("seated pose (lowered)")
                && msg.contains("out of reach"),
            "{msg}"
        );

        // Approach pose behind the base, through the folded arm's dead zone.
        let s = Station {
            approach_mm: 300.0,
            pose: Pose {
                x: 200.0,
                y: 0.0,
                yaw: 0.0,
                ..cassette().pose
            },
            ..cassette()
        };
        let msg = s.validate(&robot).unwrap_err().to_string();
        assert!(
            msg.contains("approach pose (lowered)") || msg.contains("line"),
            "{msg}"
        );
    }

    #[test]
    fn a_line_through_the_folded_zone_is_refused_even_with_reachable_ends() {
        let robot = Robot::paper_default();
        // Approach at x = -100, seated at x = +150 (yaw 0): both ends are reachable, but the
        // straight line passes through the base, where the folded arm cannot go.
        let s = Station {
            approach_mm: 250.0,
            slots: 1,
            pitch_mm: 0.0,
            pose: Pose {
                x: 150.0,
                y: 0.0,
                z: 20.0,
                yaw: 0.0,
            },
            ..cassette()
        };
        let e = s.validate(&robot).unwrap_err();
        assert!(
            matches!(
                e,
                StationError::PathLeavesWorkspace {
                    slot: 1,
                    lifted: false,
                    ..
                }
            ),
            "{e}"
        );
        let msg = e.to_string();
        assert!(
            msg.contains("straight lowered line") && msg.contains("posture"),
            "{msg}"
        );
    }

    #[test]
    fn a_station_where_one_elbow_would_pass_the_shoulders_limit_uses_the_other() {
        let robot = Robot::paper_default();
        // A radial station at 130 deg: with the left elbow J1 runs from 130 + 72.6 to
        // 130 + 31.8 deg and passes its +180 deg limit on the way in; the right elbow is
        // fine, so a station that allows either posture validates and its transfers use the
        // right one.
        let phi = 130f64.to_radians();
        let s = Station {
            slots: 1,
            pitch_mm: 0.0,
            approach_mm: 220.0,
            pose: Pose {
                x: 340.0 * phi.cos(),
                y: 340.0 * phi.sin(),
                z: 20.0,
                yaw: 130.0,
            },
            ..cassette()
        };
        s.validate(&robot).unwrap();
        let q = s.approach_joints(&robot, 1, false, &robot.home()).unwrap();
        assert_eq!(Posture::of(&robot, &q), Some(Posture::Right));
        let left = Station {
            posture: Some(Posture::Left),
            ..s.clone()
        };
        let e = left.validate(&robot).unwrap_err();
        assert!(
            matches!(
                e,
                StationError::PathLeavesWorkspace {
                    posture: Posture::Left,
                    fixed: true,
                    ..
                }
            ),
            "{e}"
        );
        let msg = e.to_string();
        assert!(
            msg.contains("station LP1 slot 1")
                && msg.contains("axis j1 would go beyond its limits"),
            "{msg}"
        );
    }

    #[test]
    fn kinds_round_trip() {
        for k in StationKind::ALL {
            assert_eq!(StationKind::parse(k.as_str()), Some(k));
        }
        assert_eq!(StationKind::parse("LoadPort"), None);
    }
}
