//! The arm's bodies as simple solids ([`crate::solid`]) for the cell's collision checks:
//! each link a capsule from joint to joint, each blade (the hand's fork) a capsule along
//! the hand direction, and the wafer a blade carries a disc.
//!
//! Heights are given relative to the hand's wafer plane, which is the TCP's z: the Z lift
//! carries the whole arm, so the links stay the same distance below the hand whatever z is.
//! The defaults are the paper robot's as the GUI's 3D view draws it (`web/src/view3d`).
//!
//! Plain arithmetic, no allocation after the robot is built: [`crate::Robot::bodies`] runs
//! in a real-time cycle.

use crate::error::ModelError;
use crate::solid::{Capsule, Span};

/// Most blades a hand carries (the hand, blade A, and a dual-blade robot's blade B).
pub const MAX_BLADES: usize = 2;

/// Most bodies of one arm: two links, a bar from the wrist to a long hand, and per blade
/// its fork and its wafer.
pub const MAX_BODIES: usize = 3 + 2 * MAX_BLADES;

/// The sizes of the arm's bodies [mm] (`[robot.shape]` in the configuration).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmShape {
    /// Radius of link 1 around the shoulder–elbow line [mm].
    pub link1_radius_mm: f64,
    /// Bottom and top of link 1, relative to the hand's wafer plane [mm] (negative: below).
    pub link1_z_mm: [f64; 2],
    /// Radius of link 2 around the elbow–wrist line [mm].
    pub link2_radius_mm: f64,
    /// Bottom and top of link 2, relative to the hand's wafer plane [mm].
    pub link2_z_mm: [f64; 2],
    /// How far a blade reaches behind the TCP, along the hand [mm].
    pub blade_back_mm: f64,
    /// How far a blade reaches ahead of the TCP [mm].
    pub blade_front_mm: f64,
    /// Half a blade's width [mm].
    pub blade_half_width_mm: f64,
    /// A blade's thickness below its wafer plane [mm].
    pub blade_thickness_mm: f64,
    /// Radius of a carried wafer, centred on the TCP [mm].
    pub wafer_radius_mm: f64,
    /// A wafer's thickness above the blade's wafer plane [mm].
    pub wafer_thickness_mm: f64,
}

impl Default for ArmShape {
    /// The paper robot as the 3D view draws it: links 44 and 38 mm in radius, 34 and 28 mm
    /// thick, 57 and 27 mm below the hand; a fork 125 mm behind and 128 mm ahead of the TCP,
    /// 132 mm wide and 7 mm thick; a 300 mm wafer, 0.775 mm thick (SEMI M1).
    fn default() -> Self {
        ArmShape {
            link1_radius_mm: 44.0,
            link1_z_mm: [-91.0, -57.0],
            link2_radius_mm: 38.0,
            link2_z_mm: [-55.0, -27.0],
            blade_back_mm: 125.0,
            blade_front_mm: 128.0,
            blade_half_width_mm: 66.0,
            blade_thickness_mm: 7.0,
            wafer_radius_mm: 150.0,
            wafer_thickness_mm: 0.775,
        }
    }
}

impl ArmShape {
    /// Check every size: finite, radii and thicknesses positive, each link's bottom below
    /// its top. Errors name the key as the configuration spells it.
    pub fn validate(&self) -> Result<(), ModelError> {
        let key = |k: &str| format!("robot.shape.{k}");
        for (k, v) in [
            ("link1_radius_mm", self.link1_radius_mm),
            ("link2_radius_mm", self.link2_radius_mm),
            ("blade_half_width_mm", self.blade_half_width_mm),
            ("blade_thickness_mm", self.blade_thickness_mm),
            ("wafer_radius_mm", self.wafer_radius_mm),
            ("wafer_thickness_mm", self.wafer_thickness_mm),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ModelError::new(
                    key(k),
                    format!("must be a number greater than 0, got {v}"),
                ));
            }
        }
        for (k, v) in [
            ("blade_back_mm", self.blade_back_mm),
            ("blade_front_mm", self.blade_front_mm),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ModelError::new(
                    key(k),
                    format!("must be a number of 0 or more, got {v}"),
                ));
            }
        }
        for (k, [lo, hi]) in [
            ("link1_z_mm", self.link1_z_mm),
            ("link2_z_mm", self.link2_z_mm),
        ] {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(ModelError::new(
                    key(k),
                    format!(
                        "must be [bottom, top] with bottom below top (relative to the hand's wafer plane), got [{lo}, {hi}]"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// How far any point of a blade or its wafer lies from the TCP [mm].
    pub fn hand_reach_mm(&self) -> f64 {
        let w = self.blade_half_width_mm;
        self.wafer_radius_mm
            .max(self.blade_front_mm.hypot(w))
            .max(self.blade_back_mm.hypot(w))
    }
}

/// Which body of the arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BodyKind {
    /// Link 1, shoulder to elbow.
    Link1,
    /// Link 2, elbow to wrist.
    Link2,
    /// The bar from the wrist to a blade's palm (a hand longer than its blades reach back).
    HandBar,
    /// Blade `n` (0: the hand, blade A; 1: blade B).
    Blade(u8),
    /// The wafer on blade `n`.
    Wafer(u8),
}

impl BodyKind {
    /// How a message names it: `link 1`, `link 2`, `the hand's bar`, `the hand`, `blade B`,
    /// `the hand's wafer`, `blade B's wafer`.
    pub fn describe(self) -> &'static str {
        match self {
            BodyKind::Link1 => "link 1",
            BodyKind::Link2 => "link 2",
            BodyKind::HandBar => "the hand's bar",
            BodyKind::Blade(0) => "the hand",
            BodyKind::Blade(_) => "blade B",
            BodyKind::Wafer(0) => "the hand's wafer",
            BodyKind::Wafer(_) => "blade B's wafer",
        }
    }
}

/// One blade of the hand as the checks see it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BladeLoad {
    /// Height of its wafer plane above the hand's (the TCP's z) [mm]; 0 for the hand.
    pub z_offset_mm: f64,
    /// Whether it carries a wafer (or may: an uncertain one counts).
    pub wafer: bool,
}

/// The arm's bodies at one joint vector ([`crate::Robot::bodies`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmBodies {
    /// The solids; those from `len` on are not used.
    pub solids: [Capsule; MAX_BODIES],
    /// Which body each solid is.
    pub kinds: [BodyKind; MAX_BODIES],
    /// How many there are.
    pub len: usize,
    /// Where the TCP is in plan [mm], the hand's direction [deg] and its z [mm].
    pub tcp: [f64; 2],
    /// See `tcp` [deg].
    pub yaw: f64,
    /// See `tcp` [mm].
    pub z: f64,
}

impl Default for ArmBodies {
    fn default() -> Self {
        ArmBodies {
            solids: [Capsule::default(); MAX_BODIES],
            kinds: [BodyKind::Link1; MAX_BODIES],
            len: 0,
            tcp: [0.0; 2],
            yaw: 0.0,
            z: 0.0,
        }
    }
}

impl ArmBodies {
    /// The bodies and their kinds.
    pub fn iter(&self) -> impl Iterator<Item = (&Capsule, BodyKind)> + '_ {
        self.solids[..self.len]
            .iter()
            .zip(self.kinds[..self.len].iter().copied())
    }

    pub(crate) fn push(&mut self, solid: Capsule, kind: BodyKind) {
        if self.len < MAX_BODIES {
            self.solids[self.len] = solid;
            self.kinds[self.len] = kind;
            self.len += 1;
        }
    }

    /// The plane heights of each blade: the TCP's z plus its offset [mm].
    pub fn blade_z(&self, blade: &BladeLoad) -> f64 {
        self.z + blade.z_offset_mm
    }
}

/// A blade as a capsule (a rectangle with round ends): from `blade_back_mm` behind to
/// `blade_front_mm` ahead of the TCP at `tcp` along the hand direction `(c, s)`,
/// `blade_half_width_mm` each side, over the heights `z`; a blade shorter than it is wide,
/// the disc that holds it.
pub(crate) fn blade_capsule(
    shape: &ArmShape,
    tcp: [f64; 2],
    (c, s): (f64, f64),
    z: Span,
) -> Capsule {
    let w = shape.blade_half_width_mm;
    // The rounded rectangle from -back to +front, as a capsule of radius w (its axis shorter
    // by w at each end; a blade shorter than its width is a disc at its middle).
    let (from, to) = (-shape.blade_back_mm + w, shape.blade_front_mm - w);
    if from > to {
        let mid = 0.5 * (from + to);
        let half = 0.5 * (shape.blade_front_mm + shape.blade_back_mm);
        let at = [tcp[0] + mid * c, tcp[1] + mid * s];
        return Capsule::disc(at, half.hypot(w), z);
    }
    Capsule::new(
        [tcp[0] + from * c, tcp[1] + from * s],
        [tcp[0] + to * c, tcp[1] + to * s],
        w,
        z,
    )
}
