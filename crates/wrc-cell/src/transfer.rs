//! The steps of a wafer transfer (`GET` and `PUT`) as plain data: the controller executes
//! them in order, one at a time, and stops the transfer at the first step that fails.
//!
//! A transfer goes with the wafer map's two phases ([`crate::WaferMap`]): the controller
//! calls `begin` and saves the map *before the first step*, and `commit` and saves the map
//! at [`Step::CommitMap`], right after the vacuum sensor confirmed the wafer's new place.
//!
//! `GET` (the hand is empty; the slot holds a wafer):
//!
//! | # | step | pose / value |
//! |---|------|--------------|
//! | 1 | [`Step::RequireInput`] | interlock input, if the station has one |
//! | 2 | [`Step::Ptp`] | approach pose, lowered |
//! | 3 | [`Step::Speed`] | the station's `speed_pct` |
//! | 4 | [`Step::RequireInput`] | interlock again, right before entering (if any) |
//! | 5 | [`Step::Line`] | seated pose, lowered (hand under the wafer) |
//! | 6 | [`Step::Vacuum`] | on |
//! | 7 | [`Step::Z`] | seated pose, lifted (the wafer comes off its supports) |
//! | 8 | [`Step::CheckVacuum`] | expect a wafer |
//! | 9 | [`Step::CommitMap`] | |
//! | 10 | [`Step::Line`] | approach pose, lifted |
//! | 11 | [`Step::RestoreSpeed`] | |
//!
//! `PUT` (the hand holds a wafer; the slot is empty):
//!
//! | # | step | pose / value |
//! |---|------|--------------|
//! | 1 | [`Step::CheckVacuum`] | expect a wafer (it is still held) |
//! | 2 | [`Step::RequireInput`] | interlock input, if any |
//! | 3 | [`Step::Ptp`] | approach pose, lifted |
//! | 4 | [`Step::Speed`] | the station's `speed_pct` |
//! | 5 | [`Step::RequireInput`] | interlock again (if any) |
//! | 6 | [`Step::Line`] | seated pose, lifted |
//! | 7 | [`Step::Vacuum`] | off (the wafer is released above its supports) |
//! | 8 | [`Step::Z`] | seated pose, lowered (the wafer stays on the supports) |
//! | 9 | [`Step::CheckVacuum`] | expect no wafer: the vacuum has released |
//! | 10 | [`Step::CommitMap`] | |
//! | 11 | [`Step::Line`] | approach pose, lowered |
//! | 12 | [`Step::RestoreSpeed`] | |
//!
//! A dual-blade robot's blade B sits `z_offset_mm` above the TCP (negative: below it); a
//! transfer with blade B plans the same steps at the station as blade B sees it
//! ([`Station::for_blade`]: every height lowered by the offset), so that blade B's wafer
//! centre follows the poses above. Its vacuum steps switch and read blade B's valve and
//! sensor (the controller picks them by the blade the job names).
//!
//! With `[motion] blend = true` (the default) the controller carries out the approach, the
//! station's speed, the interlock check and the straight line in (GET steps 2-5, PUT 3-6) as
//! one blended move: the hand reaches the approach pose at the line's speed instead of
//! stopping there, never further in before it is on the line, with the interlock checked
//! when the move starts and watched until it is committed to enter (docs/motion.md,
//! "Blended approach"). The steps, and what each stop leaves in the wafer map, are the same.
//!
//! While a wafer is on the hand (GET from step 8 on, PUT until step 7) the controller watches
//! the vacuum-sensed input during every motion and stops in a controlled way if it drops (a
//! wafer lost in motion).

use std::fmt;

use wrc_robot::{Pose, Posture};

use crate::station::{Station, StationError};
use wrc_robot::Num;

/// Which way a transfer moves a wafer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TransferKind {
    /// From a station slot onto the hand.
    Get,
    /// From the hand into a station slot.
    Put,
}

impl TransferKind {
    /// `GET` or `PUT`, as in the host protocol.
    pub fn as_str(self) -> &'static str {
        match self {
            TransferKind::Get => "GET",
            TransferKind::Put => "PUT",
        }
    }
}

impl fmt::Display for TransferKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One step of a transfer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Step {
    /// Refuse to go on unless digital input `n` is asserted (the station is safe to enter).
    RequireInput(u8),
    /// Joint-interpolated (PTP) move to a pose; with `Some(posture)` in that elbow posture,
    /// with `None` in the arm's current one (as `plan_ptp_pose` does).
    Ptp(Pose, Option<Posture>),
    /// Set the speed override to this [%] for the following motions (a controller keeps a
    /// lower operator override: it uses the smaller of the two).
    Speed(f64),
    /// Straight TCP line to a pose (same z and yaw as the start: the hand stays on the
    /// station's axis).
    Line(Pose),
    /// Switch the hand's vacuum valve on (`true`) or off.
    Vacuum(bool),
    /// Straight vertical TCP move to a pose (only z changes).
    Z(Pose),
    /// Refuse to go on unless the vacuum-sensed input says a wafer is held (`expect: true`)
    /// or not (`expect: false`), after the sensor's settling delay.
    CheckVacuum {
        /// Whether a held wafer is expected.
        expect: bool,
    },
    /// The wafer's move is physically confirmed: commit the wafer map and save it now.
    CommitMap,
    /// Restore the speed override that was in force before [`Step::Speed`].
    RestoreSpeed,
}

impl fmt::Display for Step {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let pose = |f: &mut fmt::Formatter<'_>, name: &str, p: &Pose| {
            write!(
                f,
                "{name} x={} y={} z={} yaw={}",
                Num(p.x),
                Num(p.y),
                Num(p.z),
                Num(p.yaw)
            )
        };
        match self {
            Step::RequireInput(n) => write!(f, "REQUIRE IN{n}"),
            Step::Ptp(p, posture) => {
                pose(f, "PTP", p)?;
                match posture {
                    Some(Posture::Right) => f.write_str(" R"),
                    Some(Posture::Left) => f.write_str(" L"),
                    None => Ok(()),
                }
            }
            Step::Speed(pct) => write!(f, "SPEED {}", Num(*pct)),
            Step::Line(p) => pose(f, "LINE", p),
            Step::Vacuum(on) => f.write_str(if *on { "VACUUM ON" } else { "VACUUM OFF" }),
            Step::Z(p) => pose(f, "Z", p),
            Step::CheckVacuum { expect } => f.write_str(if *expect {
                "CHECK WAFER"
            } else {
                "CHECK NO WAFER"
            }),
            Step::CommitMap => f.write_str("COMMIT"),
            Step::RestoreSpeed => f.write_str("SPEED RESTORE"),
        }
    }
}

/// The steps of `GET <station> <slot>` (see the module docs).
pub fn plan_get(station: &Station, slot: u16) -> Result<Vec<Step>, StationError> {
    let approach_low = station.approach_pose(slot, false)?;
    let seated_low = station.seated_pose(slot, false)?;
    let seated_high = station.seated_pose(slot, true)?;
    let approach_high = station.approach_pose(slot, true)?;
    let mut steps = Vec::with_capacity(11);
    steps.extend(station.interlock_input.map(Step::RequireInput));
    steps.push(Step::Ptp(approach_low, station.posture));
    steps.push(Step::Speed(station.speed_pct));
    steps.extend(station.interlock_input.map(Step::RequireInput));
    steps.extend([
        Step::Line(seated_low),
        Step::Vacuum(true),
        Step::Z(seated_high),
        Step::CheckVacuum { expect: true },
        Step::CommitMap,
        Step::Line(approach_high),
        Step::RestoreSpeed,
    ]);
    Ok(steps)
}

/// The steps of `PUT <station> <slot>` (see the module docs).
pub fn plan_put(station: &Station, slot: u16) -> Result<Vec<Step>, StationError> {
    let approach_high = station.approach_pose(slot, true)?;
    let seated_high = station.seated_pose(slot, true)?;
    let seated_low = station.seated_pose(slot, false)?;
    let approach_low = station.approach_pose(slot, false)?;
    let mut steps = Vec::with_capacity(12);
    steps.push(Step::CheckVacuum { expect: true });
    steps.extend(station.interlock_input.map(Step::RequireInput));
    steps.push(Step::Ptp(approach_high, station.posture));
    steps.push(Step::Speed(station.speed_pct));
    steps.extend(station.interlock_input.map(Step::RequireInput));
    steps.extend([
        Step::Line(seated_high),
        Step::Vacuum(false),
        Step::Z(seated_low),
        Step::CheckVacuum { expect: false },
        Step::CommitMap,
        Step::Line(approach_low),
        Step::RestoreSpeed,
    ]);
    Ok(steps)
}

/// The steps of a transfer of either kind.
pub fn plan(kind: TransferKind, station: &Station, slot: u16) -> Result<Vec<Step>, StationError> {
    match kind {
        TransferKind::Get => plan_get(station, slot),
        TransferKind::Put => plan_put(station, slot),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Stations;

    fn close(a: &Pose, b: &Pose) -> bool {
        (a.x - b.x).abs() < 1e-9
            && (a.y - b.y).abs() < 1e-9
            && (a.z - b.z).abs() < 1e-9
            && (a.yaw - b.yaw).abs() < 1e-9
    }

    fn poses(steps: &[Step]) -> Vec<Pose> {
        steps
            .iter()
            .filter_map(|s| match s {
                Step::Ptp(p, _) | Step::Line(p) | Step::Z(p) => Some(*p),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn get_enters_low_lifts_and_leaves_high() {
        let stations = Stations::embedded_demo();
        let lp1 = stations.get("LP1").unwrap();
        let steps = plan_get(lp1, 3).unwrap();
        let kinds: Vec<String> = steps
            .iter()
            .map(|s| s.to_string().split(' ').next().unwrap().to_string())
            .collect();
        assert_eq!(
            kinds,
            [
                "REQUIRE", "PTP", "SPEED", "REQUIRE", "LINE", "VACUUM", "Z", "CHECK", "COMMIT",
                "LINE", "SPEED"
            ]
        );
        assert_eq!(steps[0], Step::RequireInput(14));
        assert_eq!(steps[2], Step::Speed(60.0));
        assert_eq!(steps[5], Step::Vacuum(true));
        assert_eq!(steps[7], Step::CheckVacuum { expect: true });
        assert_eq!(steps[10], Step::RestoreSpeed);

        // Geometry: slot 3 support at 20 + 2·10 = 40 mm, ± stroke/2 = 3 mm.
        let p = poses(&steps);
        let yaw = (-30f64).to_radians();
        let (x, y) = (lp1.pose.x, lp1.pose.y);
        let back = |z| Pose {
            x: x - 220.0 * yaw.cos(),
            y: y - 220.0 * yaw.sin(),
            z,
            yaw: -30.0,
        };
        let inside = |z| Pose {
            x,
            y,
            z,
            yaw: -30.0,
        };
        assert!(close(&p[0], &back(37.0)), "{:?}", p[0]);
        assert!(close(&p[1], &inside(37.0)), "{:?}", p[1]);
        assert!(close(&p[2], &inside(43.0)), "{:?}", p[2]);
        assert!(close(&p[3], &back(43.0)), "{:?}", p[3]);
        assert_eq!(steps[1], Step::Ptp(p[0], None));
    }

    #[test]
    fn put_enters_high_releases_and_leaves_low() {
        let stations = Stations::embedded_demo();
        let pm2 = stations.get("PM2").unwrap();
        let steps = plan_put(pm2, 1).unwrap();
        // PM2 has no interlock: no RequireInput.
        assert!(!steps.iter().any(|s| matches!(s, Step::RequireInput(_))));
        assert_eq!(steps[0], Step::CheckVacuum { expect: true });
        let vac = steps
            .iter()
            .position(|s| *s == Step::Vacuum(false))
            .unwrap();
        assert!(matches!(steps[vac + 1], Step::Z(_)));
        assert_eq!(steps[vac + 2], Step::CheckVacuum { expect: false });
        assert_eq!(steps[vac + 3], Step::CommitMap);
        let p = poses(&steps);
        // Support at 100 mm, stroke 10 mm; approach 220 mm back from (0, -340) along yaw -90.
        let inside = |z| Pose {
            x: 0.0,
            y: -340.0,
            z,
            yaw: -90.0,
        };
        let back = |z| Pose {
            x: 0.0,
            y: -120.0,
            z,
            yaw: -90.0,
        };
        assert!(close(&p[0], &back(105.0)), "{:?}", p[0]);
        assert!(close(&p[1], &inside(105.0)));
        assert!(close(&p[2], &inside(95.0)));
        assert!(close(&p[3], &back(95.0)), "{:?}", p[3]);
        assert_eq!(plan(TransferKind::Put, pm2, 1).unwrap(), steps);
    }

    #[test]
    fn the_station_posture_is_passed_to_the_ptp() {
        let mut al = Stations::embedded_demo().get("AL").unwrap().clone();
        al.posture = Some(Posture::Left);
        let steps = plan_get(&al, 1).unwrap();
        assert!(matches!(steps[0], Step::Ptp(_, Some(Posture::Left))));
        assert!(steps[0].to_string().ends_with(" L"), "{}", steps[0]);
    }

    #[test]
    fn blade_b_follows_the_hands_poses_lowered_by_its_offset() {
        let stations = Stations::embedded_demo();
        let pm1 = stations.get("PM1").unwrap();
        let a = plan(TransferKind::Get, pm1, 1).unwrap();
        let b = plan(TransferKind::Get, &pm1.for_blade(-30.0), 1).unwrap();
        assert_eq!(a.len(), b.len());
        for (sa, sb) in a.iter().zip(&b) {
            match (sa, sb) {
                (Step::Ptp(pa, _), Step::Ptp(pb, _))
                | (Step::Line(pa), Step::Line(pb))
                | (Step::Z(pa), Step::Z(pb)) => {
                    // The wrist 30 mm higher puts blade B's wafer where the hand's was.
                    assert!((pb.z - (pa.z + 30.0)).abs() < 1e-12);
                    assert!(close(&Pose { z: pa.z, ..*pb }, pa));
                }
                _ => assert_eq!(sa, sb),
            }
        }
        assert_eq!(
            plan(TransferKind::Put, &pm1.for_blade(0.0), 1).unwrap(),
            plan(TransferKind::Put, pm1, 1).unwrap()
        );
    }

    #[test]
    fn a_missing_slot_is_refused() {
        let stations = Stations::embedded_demo();
        let e = plan_get(stations.get("LP2").unwrap(), 26).unwrap_err();
        assert!(e.to_string().contains("LP2 has no slot 26"), "{e}");
        assert!(plan_put(stations.get("AL").unwrap(), 0).is_err());
        assert!(plan(TransferKind::Get, stations.get("AL").unwrap(), 2).is_err());
    }

    #[test]
    fn steps_print_readably() {
        assert_eq!(Step::RequireInput(14).to_string(), "REQUIRE IN14");
        assert_eq!(
            Step::Line(Pose {
                x: 1.5,
                y: -2.0,
                z: 3.25,
                yaw: 90.0
            })
            .to_string(),
            "LINE x=1.5 y=-2 z=3.25 yaw=90"
        );
        assert_eq!(
            Step::CheckVacuum { expect: false }.to_string(),
            "CHECK NO WAFER"
        );
        assert_eq!(TransferKind::Put.to_string(), "PUT");
    }
}
