//! The cell as an obstacle: every station a solid box with one opening — its transfer line —
//! and the cell's fixed obstacles (walls, columns); whether the arm's bodies
//! ([`wrc_robot::Robot::bodies`]) touch them at one joint vector ([`CellModel::contact`]) and
//! anywhere between two ([`Sweep`]).
//!
//! # The model
//!
//! * **A station** is the box that holds its wafers ([`StationVolume`], in the station's
//!   frame: x from the seat into the station along its yaw, y to its left, heights in the Z
//!   axis's frame like the station's z). By default ([`StationVolume::default_for`]) it
//!   reaches from `mouth_mm` in front of the seat — a wafer's radius and [`FRONT_GAP_MM`], or
//!   less where the approach pose is nearer: a wafer on the hand at the approach pose stays
//!   [`ENTRY_CLEARANCE_MM`] clear of the box — to a wafer's radius and [`BACK_GAP_MM`] beyond
//!   it, [`SIDE_GAP_MM`] wider than a wafer each side, from [`BELOW_MM`] below slot 1's
//!   support to [`ABOVE_MM`] above the top slot's less a pitch (at least [`MIN_HEIGHT_MM`]
//!   tall). The stations file may give each size (`[station.volume]`). The demo cell's
//!   robot reaches 396 mm and its approach poses are 200-220 mm before the seats, less than
//!   a wafer's diameter: a box that held the whole seated wafer would be in the way of the
//!   hand's wafer at the station's own approach pose, so its boxes begin 25-45 mm before
//!   the seats.
//! * **Its opening** is its transfer line: while the hand is *on the line* — the TCP within
//!   [`LineTolerance::lateral_mm`] of it, the hand's direction within
//!   [`LineTolerance::yaw_deg`] of the station's, not beyond the seat by more than
//!   [`INSIDE_BEYOND_SEAT_MM`], and a blade's wafer plane between slot 1's lowered height and
//!   the top slot's lifted height (±[`LineTolerance::height_mm`]) — the arm may be inside
//!   that station: that is how a transfer enters it. Otherwise no body may touch it.
//! * **A fixed obstacle** ([`Obstacle`]: a turned box or a vertical cylinder between two
//!   heights, `[[obstacle]]` in the stations file) is never entered.
//! * **Touching** is a body closer than the margin to a solid it may not enter: the
//!   controller keeps [`CellSettings::clearance_mm`] and its tighter tolerances
//!   ([`LineTolerance::CONTROLLER`]); the simulated cell, the ground truth, none
//!   ([`LineTolerance::WORLD`], margin 0). Heights count: the arm passes under a station.
//!
//! # Between two joint vectors
//!
//! The board moves the axes linearly in joint space between two periods' targets. No point
//! of the arm moves further than `Σ |Δq_i| · lever_i` ([`CellModel::levers`]: for each axis
//! the farthest any body reaches from it), so a solid whose clearances at both ends add up to
//! more than that and twice the margin is not touched in between; otherwise [`Sweep`] halves
//! the step until it is sure either way (to [`SWEEP_RESOLUTION_MM`]).
//!
//! Everything is fixed-size and `Copy`: a [`CellModel`] is built once (it allocates nothing
//! after that) and the checks run in a real-time cycle.

use std::fmt;

use serde::{Deserialize, Serialize};
use wrc_robot::solid::{Block, Capsule, Span};
use wrc_robot::{wrap180, ArmBodies, BladeLoad, BodyKind, Joints, Num, Robot, MAX_AXES};

use crate::station::{Station, StationError, StationName, INSIDE_BEYOND_SEAT_MM};

/// The box in front of a station's wafers reaches this far beyond a wafer's edge towards the
/// robot, where the approach pose leaves room [mm].
pub const FRONT_GAP_MM: f64 = 5.0;
/// How far the hand's wafer at the approach pose stays from the box's front [mm]: a joint
/// move that reaches or leaves the approach pose may cross the station's line a little
/// before it turns away.
pub const ENTRY_CLEARANCE_MM: f64 = 25.0;
/// The box reaches this far beyond a seated wafer's far edge [mm].
pub const BACK_GAP_MM: f64 = 40.0;
/// The box is this much wider than a wafer on each side [mm].
pub const SIDE_GAP_MM: f64 = 5.0;
/// The box's bottom below slot 1's support height [mm].
pub const BELOW_MM: f64 = 10.0;
/// The box's top above the top slot's support height, less one pitch [mm] (20 mm above a
/// one-slot station's support… and at least [`MIN_HEIGHT_MM`] tall).
pub const ABOVE_MM: f64 = 20.0;
/// The least height of a station's box [mm].
pub const MIN_HEIGHT_MM: f64 = 40.0;

/// Most stations and obstacles in one [`CellModel`].
pub const MAX_SOLIDS: usize = 64;

/// The step [`Sweep`] halves down to: no point of the arm moves further between two
/// samples it checks [mm].
pub const SWEEP_RESOLUTION_MM: f64 = 0.5;

/// Beyond this lower bound of its distance [mm] a solid's exact distance to a body is not
/// computed: the bound is used.
const NEAR_MM: f64 = 60.0;

/// A station's solid volume, in the station's frame (see the module docs) [mm].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StationVolume {
    /// How far the box's front (towards the robot) is in front of the seat [mm]; negative:
    /// behind it.
    pub mouth_mm: f64,
    /// The box's depth from its front [mm].
    pub depth_mm: f64,
    /// Its width, centred on the station's line [mm].
    pub width_mm: f64,
    /// Its bottom and top in the Z axis's frame [mm].
    pub bottom_mm: f64,
    /// See `bottom_mm`.
    pub top_mm: f64,
}

impl StationVolume {
    /// The default box of `station` for wafers of `wafer_radius_mm` (see the module docs).
    pub fn default_for(station: &Station, wafer_radius_mm: f64) -> StationVolume {
        let r = wafer_radius_mm;
        let back = r + BACK_GAP_MM;
        let mouth = (r + FRONT_GAP_MM)
            .min(station.approach_mm - r - ENTRY_CLEARANCE_MM)
            .max(-back + 10.0);
        let bottom = station.pose.z - BELOW_MM;
        let height = (f64::from(station.slots) * station.pitch_mm + ABOVE_MM).max(MIN_HEIGHT_MM);
        StationVolume {
            mouth_mm: mouth,
            depth_mm: mouth + back,
            width_mm: 2.0 * (r + SIDE_GAP_MM),
            bottom_mm: bottom,
            top_mm: bottom + height,
        }
    }

    /// Check the sizes: finite, depth and width positive, bottom below top.
    pub fn check(&self, station: StationName) -> Result<(), StationError> {
        let bad = |field: &'static str, reason: String| StationError::Invalid {
            station,
            field,
            reason,
        };
        for (field, v) in [
            ("volume.mouth_mm", self.mouth_mm),
            ("volume.depth_mm", self.depth_mm),
            ("volume.width_mm", self.width_mm),
            ("volume.bottom_mm", self.bottom_mm),
            ("volume.top_mm", self.top_mm),
        ] {
            if !v.is_finite() {
                return Err(bad(field, format!("must be a finite number, got {v}")));
            }
        }
        for (field, v) in [
            ("volume.depth_mm", self.depth_mm),
            ("volume.width_mm", self.width_mm),
        ] {
            if v <= 0.0 {
                return Err(bad(field, format!("must be greater than 0, got {v}")));
            }
        }
        if self.bottom_mm >= self.top_mm {
            return Err(bad(
                "volume.top_mm",
                format!(
                    "must be above bottom_mm ({}), got {}",
                    Num(self.bottom_mm),
                    Num(self.top_mm)
                ),
            ));
        }
        Ok(())
    }

    /// The box in the robot's base frame for `station`.
    pub fn block(&self, station: &Station) -> Block {
        let (s, c) = station.pose.yaw.to_radians().sin_cos();
        let centre_along = 0.5 * self.depth_mm - self.mouth_mm;
        Block::new(
            [
                station.pose.x + centre_along * c,
                station.pose.y + centre_along * s,
            ],
            station.pose.yaw,
            [0.5 * self.depth_mm, 0.5 * self.width_mm],
            Span::new(self.bottom_mm, self.top_mm),
        )
    }
}

/// The shape of a fixed obstacle in plan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ObstacleShape {
    /// A box centred at x, y, its depth along `yaw_deg` [mm, mm, deg, mm, mm].
    Box {
        /// Centre x [mm].
        x_mm: f64,
        /// Centre y [mm].
        y_mm: f64,
        /// Direction of its depth [deg, counter-clockwise from the base x axis].
        yaw_deg: f64,
        /// Size along `yaw_deg` [mm].
        depth_mm: f64,
        /// Size across [mm].
        width_mm: f64,
    },
    /// A vertical cylinder (a column).
    Cylinder {
        /// Axis x [mm].
        x_mm: f64,
        /// Axis y [mm].
        y_mm: f64,
        /// Radius [mm].
        radius_mm: f64,
    },
}

/// A fixed obstacle of the cell (`[[obstacle]]` in the stations file): never entered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Obstacle {
    /// Its name (the same rules as a station's, and not a station's).
    pub name: StationName,
    /// Its shape in plan.
    pub shape: ObstacleShape,
    /// Its bottom and top in the Z axis's frame [mm].
    pub bottom_mm: f64,
    /// See `bottom_mm`.
    pub top_mm: f64,
}

impl Obstacle {
    /// Check the numbers: finite, sizes positive, bottom below top.
    pub fn check(&self) -> Result<(), StationError> {
        let bad = |field: &'static str, reason: String| StationError::Invalid {
            station: self.name,
            field,
            reason,
        };
        type Fields = Vec<(&'static str, f64)>;
        let (numbers, sizes): (Fields, Fields) = match self.shape {
            ObstacleShape::Box {
                x_mm,
                y_mm,
                yaw_deg,
                depth_mm,
                width_mm,
            } => (
                vec![("x_mm", x_mm), ("y_mm", y_mm), ("yaw_deg", yaw_deg)],
                vec![("depth_mm", depth_mm), ("width_mm", width_mm)],
            ),
            ObstacleShape::Cylinder {
                x_mm,
                y_mm,
                radius_mm,
            } => (
                vec![("x_mm", x_mm), ("y_mm", y_mm)],
                vec![("radius_mm", radius_mm)],
            ),
        };
        for (field, v) in numbers
            .iter()
            .chain(&sizes)
            .chain(&[("bottom_mm", self.bottom_mm), ("top_mm", self.top_mm)])
        {
            if !v.is_finite() {
                return Err(bad(field, format!("must be a finite number, got {v}")));
            }
        }
        for (field, v) in sizes {
            if v <= 0.0 {
                return Err(bad(field, format!("must be greater than 0, got {v}")));
            }
        }
        if self.bottom_mm >= self.top_mm {
            return Err(bad(
                "top_mm",
                format!(
                    "must be above bottom_mm ({}), got {}",
                    Num(self.bottom_mm),
                    Num(self.top_mm)
                ),
            ));
        }
        Ok(())
    }

    fn solid(&self) -> SolidShape {
        let z = Span::new(self.bottom_mm, self.top_mm);
        match self.shape {
            ObstacleShape::Box {
                x_mm,
                y_mm,
                yaw_deg,
                depth_mm,
                width_mm,
            } => SolidShape::Block(Block::new(
                [x_mm, y_mm],
                yaw_deg,
                [0.5 * depth_mm, 0.5 * width_mm],
                z,
            )),
            ObstacleShape::Cylinder {
                x_mm,
                y_mm,
                radius_mm,
            } => SolidShape::Column(Capsule::disc([x_mm, y_mm], radius_mm, z)),
        }
    }
}

/// The body of an `EVT OBSTACLE` line: `<name> kind=box x= y= yaw= depth= width= bottom=
/// top=` or `<name> kind=cylinder x= y= radius= bottom= top=` \[mm, deg\].
pub fn obstacle_line(o: &Obstacle) -> String {
    let shape = match o.shape {
        ObstacleShape::Box {
            x_mm,
            y_mm,
            yaw_deg,
            depth_mm,
            width_mm,
        } => format!(
            "kind=box x={} y={} yaw={} depth={} width={}",
            Num(x_mm),
            Num(y_mm),
            Num(yaw_deg),
            Num(depth_mm),
            Num(width_mm)
        ),
        ObstacleShape::Cylinder {
            x_mm,
            y_mm,
            radius_mm,
        } => format!(
            "kind=cylinder x={} y={} radius={}",
            Num(x_mm),
            Num(y_mm),
            Num(radius_mm)
        ),
    };
    format!(
        "{} {shape} bottom={} top={}",
        o.name,
        Num(o.bottom_mm),
        Num(o.top_mm)
    )
}

/// The cell's own settings (`[cell]` in the stations file).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellSettings {
    /// The height at which the folded arm may travel anywhere (a PTP that would touch the
    /// cell is routed through it) [mm]; `None`: the highest at which every body of the arm
    /// is below every station and obstacle that does not reach down to the arm's lowest
    /// height, if there is one.
    pub travel_z_mm: Option<f64>,
    /// How close the controller lets a body come to a solid it may not enter [mm].
    pub clearance_mm: f64,
}

impl Default for CellSettings {
    fn default() -> Self {
        CellSettings {
            travel_z_mm: None,
            clearance_mm: 2.0,
        }
    }
}

impl CellSettings {
    /// Check the numbers: finite, the clearance 0 to 100 mm.
    pub fn check(&self) -> Result<(), String> {
        if let Some(z) = self.travel_z_mm {
            if !z.is_finite() {
                return Err(format!("cell.travel_z_mm must be a finite number, got {z}"));
            }
        }
        if !(0.0..=100.0).contains(&self.clearance_mm) {
            return Err(format!(
                "cell.clearance_mm must be 0 to 100 mm, got {}",
                self.clearance_mm
            ));
        }
        Ok(())
    }
}

/// How close to a station's line the hand must be to pass its opening.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineTolerance {
    /// The TCP's distance from the line [mm].
    pub lateral_mm: f64,
    /// The hand's direction from the station's [deg].
    pub yaw_deg: f64,
    /// A blade's wafer plane beyond the slots' lowered and lifted heights [mm].
    pub height_mm: f64,
}

impl LineTolerance {
    /// The controller's: its lines stay within hundredths of a millimetre of the line, a
    /// stop on a line on it, and an axis's own brake in a blended approach's first part
    /// (a transfer resumed near its seat) within 1.5 mm and 1 degree; 0.2 mm and degree
    /// inside the simulated cell's for the servo's lag.
    pub const CONTROLLER: LineTolerance = LineTolerance {
        lateral_mm: 1.8,
        yaw_deg: 1.8,
        height_mm: 1.0,
    };
    /// The simulated cell's (the ground truth): a cassette's clearance.
    pub const WORLD: LineTolerance = LineTolerance {
        lateral_mm: 2.0,
        yaw_deg: 2.0,
        height_mm: 2.0,
    };
}

/// What a solid of the cell is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolidKind {
    /// A station (entered along its line).
    Station,
    /// A fixed obstacle (never entered).
    Obstacle,
}

impl fmt::Display for SolidKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SolidKind::Station => "station",
            SolidKind::Obstacle => "obstacle",
        })
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum SolidShape {
    Block(Block),
    Column(Capsule),
}

impl SolidShape {
    fn distance(&self, body: &Capsule) -> f64 {
        match self {
            SolidShape::Block(b) => body.distance_to_block(b),
            SolidShape::Column(c) => body.distance_to_capsule(c),
        }
    }

    fn bounds(&self) -> ([f64; 2], f64, Span) {
        match self {
            SolidShape::Block(b) => {
                let (c, r) = b.bounds();
                (c, r, b.z)
            }
            SolidShape::Column(c) => {
                let (p, r) = c.bounds();
                (p, r, c.z)
            }
        }
    }
}

/// A station's opening: its line and the heights at which a blade passes it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Opening {
    seat: [f64; 2],
    cos: f64,
    sin: f64,
    yaw_deg: f64,
    /// A blade's wafer plane between slot 1's lowered and the top slot's lifted height [mm].
    planes: Span,
}

impl Opening {
    fn of(station: &Station) -> Opening {
        let (sin, cos) = station.pose.yaw.to_radians().sin_cos();
        let half = 0.5 * station.stroke_mm;
        let top = station.pose.z + f64::from(station.slots.saturating_sub(1)) * station.pitch_mm;
        Opening {
            seat: [station.pose.x, station.pose.y],
            cos,
            sin,
            yaw_deg: station.pose.yaw,
            planes: Span::new(station.pose.z - half, top + half),
        }
    }

    /// Whether the hand of `bodies` with `blades` is on the line (see the module docs).
    fn passes(&self, bodies: &ArmBodies, blades: &[BladeLoad], tol: &LineTolerance) -> bool {
        let (dx, dy) = (bodies.tcp[0] - self.seat[0], bodies.tcp[1] - self.seat[1]);
        let along = dx * self.cos + dy * self.sin;
        let lateral = (dx * self.sin - dy * self.cos).abs();
        let turned = wrap180(bodies.yaw - self.yaw_deg).abs();
        if !(along <= INSIDE_BEYOND_SEAT_MM && lateral <= tol.lateral_mm && turned <= tol.yaw_deg) {
            return false;
        }
        let (lo, hi) = (
            self.planes.lo - tol.height_mm,
            self.planes.hi + tol.height_mm,
        );
        let hand = [BladeLoad::default()];
        let blades = if blades.is_empty() { &hand[..] } else { blades };
        blades
            .iter()
            .any(|b| (lo..=hi).contains(&bodies.blade_z(b)))
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct CellSolid {
    name: StationName,
    kind: SolidKind,
    shape: SolidShape,
    opening: Option<Opening>,
    /// A circle in plan that holds it, and its heights.
    centre: [f64; 2],
    radius: f64,
    z: Span,
}

/// A body touching a solid of the cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// The solid's index in the model ([`CellModel::name`]).
    pub solid: usize,
    /// The station's or obstacle's name.
    pub name: StationName,
    /// Whether it is a station or an obstacle.
    pub kind: SolidKind,
    /// The body that touches it.
    pub body: BodyKind,
    /// The gap [mm] (below the margin; 0 or negative: they overlap).
    pub distance: f64,
}

impl fmt::Display for Contact {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} would touch {} {}",
            self.body.describe(),
            self.kind,
            self.name
        )
    }
}

/// A cell model that cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CellModelError {
    /// More stations and obstacles than [`MAX_SOLIDS`].
    #[error("the cell has {count} stations and obstacles; at most {MAX_SOLIDS} are supported")]
    TooMany {
        /// How many there are.
        count: usize,
    },
}

/// Every station and obstacle of a cell as solids, fixed-size (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellModel {
    solids: [CellSolid; MAX_SOLIDS],
    len: usize,
    settings: CellSettings,
    /// Per axis: how far a point of the arm moves at most per unit of the axis [mm per deg
    /// or mm].
    levers: [f64; MAX_AXES],
}

impl CellModel {
    /// A model with nothing in it (every motion is clear).
    pub fn empty(robot: &Robot) -> CellModel {
        let blank = CellSolid {
            // A constant that is a valid name: the blank solids are never read.
            name: StationName::new("unused").unwrap_or_else(|| unreachable!()),
            kind: SolidKind::Obstacle,
            shape: SolidShape::Column(Capsule::default()),
            opening: None,
            centre: [0.0; 2],
            radius: 0.0,
            z: Span::default(),
        };
        CellModel {
            solids: [blank; MAX_SOLIDS],
            len: 0,
            settings: CellSettings::default(),
            levers: levers(robot),
        }
    }

    /// The model of `stations` (their volumes), `obstacles` and `settings` for `robot`.
    pub fn new<'a>(
        robot: &Robot,
        stations: impl IntoIterator<Item = &'a Station>,
        obstacles: &[Obstacle],
        settings: CellSettings,
    ) -> Result<CellModel, CellModelError> {
        let mut model = CellModel::empty(robot);
        model.settings = settings;
        let wafer = robot.shape().wafer_radius_mm;
        let mut count = 0;
        let mut add = |solid: CellSolid| {
            if count < MAX_SOLIDS {
                model.solids[count] = solid;
            }
            count += 1;
        };
        for s in stations {
            let shape = SolidShape::Block(s.volume(wafer).block(s));
            let (centre, radius, z) = shape.bounds();
            add(CellSolid {
                name: s.name,
                kind: SolidKind::Station,
                shape,
                opening: Some(Opening::of(s)),
                centre,
                radius,
                z,
            });
        }
        for o in obstacles {
            let shape = o.solid();
            let (centre, radius, z) = shape.bounds();
            add(CellSolid {
                name: o.name,
                kind: SolidKind::Obstacle,
                shape,
                opening: None,
                centre,
                radius,
                z,
            });
        }
        if count > MAX_SOLIDS {
            return Err(CellModelError::TooMany { count });
        }
        model.len = count;
        Ok(model)
    }

    /// How many stations and obstacles it has.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it has none.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The name of solid `i`.
    pub fn name(&self, i: usize) -> Option<StationName> {
        self.solids[..self.len].get(i).map(|s| s.name)
    }

    /// The settings it was built with.
    pub fn settings(&self) -> &CellSettings {
        &self.settings
    }

    /// Per axis, how far a point of the arm moves at most per unit of that axis [mm/deg,
    /// mm/mm] (see the module docs).
    pub fn levers(&self) -> &[f64; MAX_AXES] {
        &self.levers
    }

    /// The height at which the arm travels clear of every station and of every obstacle
    /// that leaves room below it (see [`CellSettings::travel_z_mm`]) [mm]; `None` when the
    /// Z axis's range has none.
    pub fn travel_z(&self, robot: &Robot, blades: &[BladeLoad]) -> Option<f64> {
        if let Some(z) = self.settings.travel_z_mm {
            return Some(z);
        }
        let axis = &robot.axes()[robot.arm().z?];
        let shape = robot.shape();
        let top =
            blades.iter().map(|b| b.z_offset_mm).fold(0.0f64, f64::max) + shape.wafer_thickness_mm;
        let bottom = blades
            .iter()
            .map(|b| b.z_offset_mm - shape.blade_thickness_mm)
            .fold(0.0f64, f64::min)
            .min(shape.link1_z_mm[0])
            .min(shape.link2_z_mm[0]);
        // Solids that reach below the arm's lowest body at the lowest z cannot be passed
        // under: the route's checks deal with them.
        let floor = axis.min + bottom;
        let lowest = self.solids[..self.len]
            .iter()
            .map(|s| s.z.lo)
            .filter(|&lo| lo > floor)
            .fold(f64::INFINITY, f64::min);
        let z = if lowest.is_finite() {
            lowest - self.settings.clearance_mm - top
        } else {
            axis.min
        };
        (z >= axis.min).then(|| z.min(axis.max))
    }

    /// The clearance of `bodies` (with `blades`) to every solid, into `out[..len()]` [mm]:
    /// the smallest gap of any body, a lower bound of it when it is more than some
    /// centimetres, and `f64::INFINITY` for a station whose opening the hand passes.
    pub fn clearances(
        &self,
        bodies: &ArmBodies,
        blades: &[BladeLoad],
        tol: &LineTolerance,
        out: &mut [f64; MAX_SOLIDS],
    ) {
        for (solid, d) in self.solids[..self.len].iter().zip(out.iter_mut()) {
            *d = match &solid.opening {
                Some(o) if o.passes(bodies, blades, tol) => f64::INFINITY,
                _ => solid_clearance(solid, bodies).0,
            };
        }
    }

    /// The first solid a body of `bodies` comes closer to than `margin_mm` [mm], if any.
    pub fn contact(
        &self,
        bodies: &ArmBodies,
        blades: &[BladeLoad],
        tol: &LineTolerance,
        margin_mm: f64,
    ) -> Option<Contact> {
        (0..self.len).find_map(|i| self.contact_with(i, bodies, blades, tol, margin_mm))
    }

    /// Whether a body of `bodies` comes closer to solid `i` than `margin_mm` [mm], whether or
    /// not the hand passes its opening.
    pub fn overlaps(&self, i: usize, bodies: &ArmBodies, margin_mm: f64) -> bool {
        self.solids[..self.len]
            .get(i)
            .is_some_and(|solid| solid_clearance(solid, bodies).0 < margin_mm)
    }

    /// Whether a body of `bodies` comes closer to solid `i` than `margin_mm` [mm].
    pub fn contact_with(
        &self,
        i: usize,
        bodies: &ArmBodies,
        blades: &[BladeLoad],
        tol: &LineTolerance,
        margin_mm: f64,
    ) -> Option<Contact> {
        let solid = self.solids[..self.len].get(i)?;
        if solid.opening.is_some_and(|o| o.passes(bodies, blades, tol)) {
            return None;
        }
        let (distance, body) = solid_clearance(solid, bodies);
        (distance < margin_mm).then_some(Contact {
            solid: i,
            name: solid.name,
            kind: solid.kind,
            body,
            distance,
        })
    }
}

/// The smallest gap of any body to `solid` (or a lower bound beyond [`NEAR_MM`]) [mm], and
/// that body.
fn solid_clearance(solid: &CellSolid, bodies: &ArmBodies) -> (f64, BodyKind) {
    let mut best = (f64::INFINITY, BodyKind::Link1);
    for (body, kind) in bodies.iter() {
        let (c, r) = body.bounds();
        let plan = (c[0] - solid.centre[0]).hypot(c[1] - solid.centre[1]) - r - solid.radius;
        let vertical = body.z.gap(&solid.z);
        let bound = if vertical <= 0.0 {
            plan
        } else if plan <= 0.0 {
            vertical
        } else {
            plan.hypot(vertical)
        };
        let d = if bound > NEAR_MM {
            bound
        } else {
            solid.shape.distance(body)
        };
        if d < best.0 {
            best = (d, kind);
        }
    }
    best
}

/// Per axis of `robot`, the farthest any body reaches from it [mm per axis unit].
fn levers(robot: &Robot) -> [f64; MAX_AXES] {
    let arm = robot.arm();
    let shape = robot.shape();
    let hand = arm.hand_mm + shape.hand_reach_mm();
    let from_elbow = (arm.link2_mm + shape.link2_radius_mm).max(arm.link2_mm + hand);
    let from_shoulder = (arm.link1_mm + shape.link1_radius_mm).max(arm.link1_mm + from_elbow);
    let mut out = [0.0; MAX_AXES];
    let per_deg = std::f64::consts::PI / 180.0;
    out[arm.shoulder] = from_shoulder * per_deg;
    out[arm.elbow] = from_elbow * per_deg;
    if let Some(w) = arm.wrist {
        out[w] = hand * per_deg;
    }
    if let Some(z) = arm.z {
        out[z] = 1.0;
    }
    out
}

/// Most via points of a [`TravelRoute`].
pub const MAX_VIA: usize = 4;

/// How far short of its joint limit the elbow folds for travel [deg].
pub const FOLD_MARGIN_DEG: f64 = 2.0;

/// A way from one joint vector to another through the travel height: the joints it passes,
/// one PTP to each and a last one to the target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TravelRoute {
    /// The via points, in order; those from `len` on are not used.
    pub via: [Joints; MAX_VIA],
    /// How many there are.
    pub len: usize,
    /// Whether the arm folds on the way.
    pub folded: bool,
}

impl TravelRoute {
    fn new(folded: bool) -> TravelRoute {
        TravelRoute {
            via: [[0.0; MAX_AXES]; MAX_VIA],
            len: 0,
            folded,
        }
    }

    fn push(&mut self, q: Joints) {
        let last = if self.len == 0 {
            None
        } else {
            Some(self.via[self.len - 1])
        };
        if self.len < MAX_VIA && last != Some(q) {
            self.via[self.len] = q;
            self.len += 1;
        }
    }

    /// The via points in use.
    pub fn via(&self) -> &[Joints] {
        &self.via[..self.len]
    }
}

/// How many routes [`travel_routes`] offers at most.
pub const MAX_ROUTES: usize = 5;

/// The routes from `from` to `to` through `travel_z` [mm] (the Z axis's value), shortest
/// first: (1) down or up to `travel_z` where the arm stands, a PTP there to the target's
/// joints, and up or down to the target; then the same with the arm folded on the way — the
/// elbow folds (to its limit less [`FOLD_MARGIN_DEG`], on the side it is on, the hand keeping
/// its direction), the shoulder and hand turn to the target's side, the elbow unfolds —
/// folding at `travel_z` or where the arm stands before it goes down or up (a hand above or
/// below a station), and unfolding at `travel_z` or at the target's height. A PTP between
/// two of them is a straight line in joint space. A robot without a Z axis has only the
/// folded route at its one height; an elbow that cannot fold past 90 degrees, only the
/// first.
pub fn travel_routes(
    robot: &Robot,
    from: &Joints,
    to: &Joints,
    travel_z: f64,
) -> [Option<TravelRoute>; MAX_ROUTES] {
    let arm = robot.arm();
    let at_z = |q: &Joints| {
        let mut q = *q;
        if let Some(z) = arm.z {
            q[z] = travel_z;
        }
        q
    };
    let (a, b) = (at_z(from), at_z(to));
    let mut out = [None; MAX_ROUTES];
    if arm.z.is_some() {
        let mut direct = TravelRoute::new(false);
        direct.push(a);
        direct.push(b);
        out[0] = Some(direct);
    }
    let elbow = &robot.axes()[arm.elbow];
    let fold = elbow.max.min(-elbow.min).min(180.0) - FOLD_MARGIN_DEG;
    if fold > 90.0 {
        let (f0, f1) = (folded_at(robot, from, fold), folded_at(robot, to, fold));
        let (f0_low, f1_low) = (at_z(&f0), at_z(&f1));
        // Fold below (or above) and unfold there; fold first, then go down; go down, then
        // fold, and come up folded; fold first and come up folded.
        let ways: [[Joints; 4]; 4] = [
            [a, f0_low, f1_low, b],
            [f0, f0_low, f1_low, b],
            [a, f0_low, f1_low, f1],
            [f0, f0_low, f1_low, f1],
        ];
        for (slot, way) in out[1..].iter_mut().zip(ways) {
            let mut route = TravelRoute::new(true);
            for q in way {
                route.push(q);
            }
            *slot = Some(route);
        }
    }
    out
}

/// `q` with the elbow folded to `fold` [deg] on the side it is on, the hand keeping its
/// direction where the wrist's range lets it.
fn folded_at(robot: &Robot, q: &Joints, fold: f64) -> Joints {
    let arm = robot.arm();
    let mut f = *q;
    let sign = if q[arm.elbow] < 0.0 { -1.0 } else { 1.0 };
    f[arm.elbow] = sign * fold;
    if let Some(w) = arm.wrist {
        let axis = &robot.axes()[w];
        let keep = q[w] + q[arm.elbow] - f[arm.elbow];
        f[w] = keep.clamp(axis.min, axis.max);
    }
    f
}

/// A contact found along a motion: which, and where the arm was.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepContact {
    /// The contact.
    pub contact: Contact,
    /// The joints at which it was found [deg, mm].
    pub joints: Joints,
}

/// One end of a step of a [`Sweep`]: its joints and its clearance to every solid.
#[derive(Debug, Clone, Copy)]
struct Sample {
    joints: Joints,
    clear: [f64; MAX_SOLIDS],
}

/// Checks a motion given as joint vectors one after the other (a motion's periods, or the
/// corners of a joint-space path): no body touches a solid it may not enter at them or
/// between them (see the module docs). Allocation-free.
#[derive(Debug, Clone, Copy)]
pub struct Sweep<'a> {
    model: &'a CellModel,
    robot: &'a Robot,
    blades: &'a [BladeLoad],
    tol: LineTolerance,
    margin_mm: f64,
    last: Option<Sample>,
    /// Samples evaluated so far (the cost).
    evaluations: u64,
    /// Solids not held against the motion ([`Sweep::ignore_touched`]).
    ignored: [bool; MAX_SOLIDS],
}

impl<'a> Sweep<'a> {
    /// A sweep over `model` for `robot` with `blades`, keeping `margin_mm` [mm] with the
    /// line tolerance `tol`.
    pub fn new(
        model: &'a CellModel,
        robot: &'a Robot,
        blades: &'a [BladeLoad],
        tol: LineTolerance,
        margin_mm: f64,
    ) -> Sweep<'a> {
        Sweep {
            model,
            robot,
            blades,
            tol,
            margin_mm,
            last: None,
            evaluations: 0,
            ignored: [false; MAX_SOLIDS],
        }
    }

    /// From now on, do not hold against the motion the solids the arm is closer to than the
    /// margin at the last joints: a motion that starts where a fault left the arm touching
    /// something may take it out. Returns how many.
    pub fn ignore_touched(&mut self) -> usize {
        let Some(last) = self.last else {
            return 0;
        };
        let mut n = 0;
        for i in 0..self.model.len {
            if last.clear[i] < self.margin_mm && !self.ignored[i] {
                self.ignored[i] = true;
                n += 1;
            }
        }
        n
    }

    /// The least clearance at the last joints to a solid held against the motion [mm]: 0 for
    /// a station whose opening the hand passes (a brake could take it off its line),
    /// `f64::INFINITY` before the first joints or in an empty cell.
    pub fn min_clearance(&self) -> f64 {
        let Some(last) = &self.last else {
            return f64::INFINITY;
        };
        (0..self.model.len)
            .filter(|&i| !self.ignored[i])
            .map(|i| {
                let d = last.clear[i];
                if d.is_finite() {
                    d
                } else {
                    0.0
                }
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// How many joint vectors it has evaluated (the bisection's included).
    pub fn evaluations(&self) -> u64 {
        self.evaluations
    }

    fn sample(&mut self, joints: &Joints) -> Sample {
        self.evaluations += 1;
        let bodies = self.robot.bodies(joints, self.blades);
        let mut clear = [f64::INFINITY; MAX_SOLIDS];
        self.model
            .clearances(&bodies, self.blades, &self.tol, &mut clear);
        for (c, ignored) in clear.iter_mut().zip(&self.ignored) {
            if *ignored {
                *c = f64::INFINITY;
            }
        }
        Sample {
            joints: *joints,
            clear,
        }
    }

    /// The contact at `joints` with solid `i`, if any.
    fn contact_at(&self, joints: &Joints, i: usize) -> Option<SweepContact> {
        let bodies = self.robot.bodies(joints, self.blades);
        self.model
            .contact_with(i, &bodies, self.blades, &self.tol, self.margin_mm)
            .map(|contact| SweepContact {
                contact,
                joints: *joints,
            })
    }

    /// Forget where the motion was: the next joints start a new one.
    pub fn restart(&mut self) {
        self.last = None;
    }

    /// The motion goes on to `joints` (the first call: starts there). The first contact at
    /// or before it, if any; after one the sweep starts again from `joints`.
    // The contact is returned by value on purpose: boxing it would allocate in a real-time
    // cycle.
    #[allow(clippy::result_large_err)]
    pub fn to(&mut self, joints: &Joints) -> Result<(), SweepContact> {
        let b = self.sample(joints);
        let result = match self.last {
            None => {
                let mut found = None;
                for i in 0..self.model.len {
                    if b.clear[i] < self.margin_mm {
                        found = self.contact_at(joints, i);
                        if found.is_some() {
                            break;
                        }
                    }
                }
                found.map_or(Ok(()), Err)
            }
            Some(a) => self.between(&a, &b, 0),
        };
        self.last = Some(b);
        result
    }

    /// The first contact between `a` and `b` (both ends included, `a` checked before).
    #[allow(clippy::result_large_err)]
    fn between(&mut self, a: &Sample, b: &Sample, depth: u32) -> Result<(), SweepContact> {
        let levers = self.model.levers;
        let disp: f64 = a
            .joints
            .iter()
            .zip(&b.joints)
            .zip(&levers)
            .map(|((p, q), l)| (q - p).abs() * l)
            .sum();
        let m = self.margin_mm;
        let mut unsure = false;
        for i in 0..self.model.len {
            let (da, db) = (a.clear[i], b.clear[i]);
            if da == f64::INFINITY && db == f64::INFINITY {
                continue;
            }
            if da.is_finite() && db.is_finite() && da + db >= disp + 2.0 * m {
                continue;
            }
            if disp <= SWEEP_RESOLUTION_MM || depth >= 40 {
                // As fine as it gets: the ends decide.
                if db < m {
                    if let Some(c) = self.contact_at(&b.joints, i) {
                        return Err(c);
                    }
                }
                continue;
            }
            unsure = true;
            break;
        }
        if !unsure {
            return Ok(());
        }
        let mut mid = a.joints;
        for (m, q) in mid.iter_mut().zip(&b.joints) {
            *m = 0.5 * (*m + q);
        }
        let mid = self.sample(&mid);
        self.between(a, &mid, depth + 1)?;
        self.between(&mid, b, depth + 1)
    }
}

/// A station's own sizes of its volume (`[station.volume]` in the stations file): each one
/// given replaces the default's ([`StationVolume::default_for`]) [mm].
#[derive(Debug, Default, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VolumeSpec {
    /// See [`StationVolume::mouth_mm`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mouth_mm: Option<f64>,
    /// See [`StationVolume::depth_mm`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_mm: Option<f64>,
    /// See [`StationVolume::width_mm`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width_mm: Option<f64>,
    /// See [`StationVolume::bottom_mm`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bottom_mm: Option<f64>,
    /// See [`StationVolume::top_mm`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub top_mm: Option<f64>,
}

impl VolumeSpec {
    /// Whether it gives no size (every one is the default's).
    pub fn is_empty(&self) -> bool {
        *self == VolumeSpec::default()
    }

    /// `default` with the sizes given here.
    pub fn over(&self, default: StationVolume) -> StationVolume {
        StationVolume {
            mouth_mm: self.mouth_mm.unwrap_or(default.mouth_mm),
            depth_mm: self.depth_mm.unwrap_or(default.depth_mm),
            width_mm: self.width_mm.unwrap_or(default.width_mm),
            bottom_mm: self.bottom_mm.unwrap_or(default.bottom_mm),
            top_mm: self.top_mm.unwrap_or(default.top_mm),
        }
    }
}

/// `[[obstacle]]` as written in the stations file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawObstacle {
    pub name: String,
    pub kind: String,
    pub x_mm: f64,
    pub y_mm: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yaw_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub width_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius_mm: Option<f64>,
    pub bottom_mm: f64,
    pub top_mm: f64,
}

impl RawObstacle {
    pub(crate) fn into_obstacle(self) -> Result<Obstacle, StationError> {
        let name = crate::station::parse_station_name(&self.name)?;
        let bad = |field: &'static str, reason: String| StationError::Invalid {
            station: name,
            field,
            reason,
        };
        let need = |field: &'static str, v: Option<f64>, kind: &str| {
            v.ok_or_else(|| bad(field, format!("is needed by an obstacle of kind {kind}")))
        };
        let refuse = |field: &'static str, v: Option<f64>, kind: &str| match v {
            Some(_) => Err(bad(
                field,
                format!("is not used by an obstacle of kind {kind}"),
            )),
            None => Ok(()),
        };
        let shape = match self.kind.as_str() {
            "box" => {
                refuse("radius_mm", self.radius_mm, "box")?;
                ObstacleShape::Box {
                    x_mm: self.x_mm,
                    y_mm: self.y_mm,
                    yaw_deg: self.yaw_deg.unwrap_or(0.0),
                    depth_mm: need("depth_mm", self.depth_mm, "box")?,
                    width_mm: need("width_mm", self.width_mm, "box")?,
                }
            }
            "cylinder" => {
                refuse("yaw_deg", self.yaw_deg, "cylinder")?;
                refuse("depth_mm", self.depth_mm, "cylinder")?;
                refuse("width_mm", self.width_mm, "cylinder")?;
                ObstacleShape::Cylinder {
                    x_mm: self.x_mm,
                    y_mm: self.y_mm,
                    radius_mm: need("radius_mm", self.radius_mm, "cylinder")?,
                }
            }
            other => {
                return Err(bad(
                    "kind",
                    format!("{other:?} is not an obstacle kind; expected \"box\" or \"cylinder\""),
                ))
            }
        };
        let o = Obstacle {
            name,
            shape,
            bottom_mm: self.bottom_mm,
            top_mm: self.top_mm,
        };
        o.check()?;
        Ok(o)
    }

    pub(crate) fn from_obstacle(o: &Obstacle) -> RawObstacle {
        let mut raw = RawObstacle {
            name: o.name.to_string(),
            kind: String::new(),
            x_mm: 0.0,
            y_mm: 0.0,
            yaw_deg: None,
            depth_mm: None,
            width_mm: None,
            radius_mm: None,
            bottom_mm: o.bottom_mm,
            top_mm: o.top_mm,
        };
        match o.shape {
            ObstacleShape::Box {
                x_mm,
                y_mm,
                yaw_deg,
                depth_mm,
                width_mm,
            } => {
                raw.kind = "box".into();
                (raw.x_mm, raw.y_mm) = (x_mm, y_mm);
                raw.yaw_deg = Some(yaw_deg);
                raw.depth_mm = Some(depth_mm);
                raw.width_mm = Some(width_mm);
            }
            ObstacleShape::Cylinder {
                x_mm,
                y_mm,
                radius_mm,
            } => {
                raw.kind = "cylinder".into();
                (raw.x_mm, raw.y_mm) = (x_mm, y_mm);
                raw.radius_mm = Some(radius_mm);
            }
        }
        raw
    }
}

/// `[cell]` as written in the stations file.
#[derive(Debug, Default, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawCell {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub travel_z_mm: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clearance_mm: Option<f64>,
}

#[cfg(test)]
mod tests;
