//! Simple solids for the cell's collision checks, and their distances.
//!
//! A solid is a plan shape extruded between two heights (a *prism*): a [`Capsule`] — a
//! segment with a radius, a disc or a cylinder when its two ends coincide — or a [`Block`],
//! a rectangle turned by a yaw. Heights are in the Z axis's frame, as a TCP's z [mm]; plan
//! coordinates are the robot's base frame [mm]. [`Capsule::distance_to_block`] and
//! [`Capsule::distance_to_capsule`] give the gap between two solids [mm]: positive apart,
//! zero or negative when they touch or overlap (a negative value says only that they
//! overlap, not by how much).
//!
//! Plain arithmetic on `Copy` values: no allocation, no I/O, safe in a real-time cycle.
//!
//! ```
//! use wrc_robot::solid::{Block, Capsule, Span};
//!
//! // A 40 mm thick link from (0, 0) to (200, 0), 10 mm high, and a box 100 mm further.
//! let link = Capsule::new([0.0, 0.0], [200.0, 0.0], 20.0, Span::new(0.0, 10.0));
//! let wall = Block::new([400.0, 0.0], 0.0, [50.0, 100.0], Span::new(-50.0, 50.0));
//! assert!((link.distance_to_block(&wall) - 130.0).abs() < 1e-9);
//! ```

/// A closed interval of heights [mm]: `lo ≤ hi`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Span {
    /// Bottom [mm].
    pub lo: f64,
    /// Top [mm].
    pub hi: f64,
}

impl Span {
    /// The span from `a` to `b`, whichever is lower first.
    pub fn new(a: f64, b: f64) -> Span {
        Span {
            lo: a.min(b),
            hi: a.max(b),
        }
    }

    /// The span moved up by `dz` [mm].
    pub fn raised(self, dz: f64) -> Span {
        Span {
            lo: self.lo + dz,
            hi: self.hi + dz,
        }
    }

    /// The vertical gap to `other` [mm]: positive when they are apart, zero or negative
    /// (the overlap) when they overlap.
    pub fn gap(&self, other: &Span) -> f64 {
        self.lo.max(other.lo) - self.hi.min(other.hi)
    }
}

/// A segment in plan with a radius, extruded over a span of heights: a link, a blade, a
/// wafer (a disc: both ends the same point), a column.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Capsule {
    /// One end of its axis in plan [mm].
    pub a: [f64; 2],
    /// The other end [mm].
    pub b: [f64; 2],
    /// Radius around the axis [mm].
    pub radius: f64,
    /// Heights [mm].
    pub z: Span,
}

/// A rectangle in plan turned by a yaw, extruded over a span of heights: a station, a wall.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Block {
    /// Centre in plan [mm].
    pub centre: [f64; 2],
    /// cos and sin of the yaw of its own x axis (its depth) from the base x axis.
    pub cos: f64,
    /// See `cos`.
    pub sin: f64,
    /// Half its size along its own x (depth) and y (width) [mm].
    pub half: [f64; 2],
    /// Heights [mm].
    pub z: Span,
}

impl Capsule {
    /// A capsule from `a` to `b` [mm] with `radius` [mm] over the heights `z`.
    pub fn new(a: [f64; 2], b: [f64; 2], radius: f64, z: Span) -> Capsule {
        Capsule { a, b, radius, z }
    }

    /// A disc or cylinder of `radius` centred at `c` [mm].
    pub fn disc(c: [f64; 2], radius: f64, z: Span) -> Capsule {
        Capsule::new(c, c, radius, z)
    }

    /// The gap to `block` [mm] (see the module docs).
    pub fn distance_to_block(&self, block: &Block) -> f64 {
        let la = block.to_local(self.a);
        let lb = block.to_local(self.b);
        let plan = segment_box_distance(la, lb, block.half) - self.radius;
        combine(plan, self.z.gap(&block.z))
    }

    /// The gap to `other` [mm] (see the module docs).
    pub fn distance_to_capsule(&self, other: &Capsule) -> f64 {
        let plan = segment_distance(self.a, self.b, other.a, other.b) - self.radius - other.radius;
        combine(plan, self.z.gap(&other.z))
    }

    /// A circle in plan that holds it: centre and radius [mm].
    pub fn bounds(&self) -> ([f64; 2], f64) {
        let c = [0.5 * (self.a[0] + self.b[0]), 0.5 * (self.a[1] + self.b[1])];
        let half = 0.5 * (self.b[0] - self.a[0]).hypot(self.b[1] - self.a[1]);
        (c, half + self.radius)
    }
}

impl Block {
    /// A block centred at `centre` [mm], its depth along `yaw_deg` [deg], `half` its half
    /// depth and half width [mm], over the heights `z`.
    pub fn new(centre: [f64; 2], yaw_deg: f64, half: [f64; 2], z: Span) -> Block {
        let (sin, cos) = yaw_deg.to_radians().sin_cos();
        Block {
            centre,
            cos,
            sin,
            half,
            z,
        }
    }

    /// `p` [mm] in the block's own frame (its centre the origin, x along its depth).
    pub fn to_local(&self, p: [f64; 2]) -> [f64; 2] {
        let (dx, dy) = (p[0] - self.centre[0], p[1] - self.centre[1]);
        [
            dx * self.cos + dy * self.sin,
            -dx * self.sin + dy * self.cos,
        ]
    }

    /// A circle in plan that holds it: centre and radius [mm].
    pub fn bounds(&self) -> ([f64; 2], f64) {
        (self.centre, self.half[0].hypot(self.half[1]))
    }
}

/// The 3-D gap from a gap in plan and a gap in height (each positive apart).
fn combine(plan: f64, vertical: f64) -> f64 {
    if vertical <= 0.0 {
        plan
    } else if plan <= 0.0 {
        vertical
    } else {
        plan.hypot(vertical)
    }
}

/// Distance from point `p` to the segment `a`–`b` [mm].
pub fn point_segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

/// Whether the segments `a`–`b` and `c`–`d` cross or touch.
fn segments_cross(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let cross = |o: [f64; 2], p: [f64; 2], q: [f64; 2]| {
        (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0])
    };
    let (d1, d2) = (cross(c, d, a), cross(c, d, b));
    let (d3, d4) = (cross(a, b, c), cross(a, b, d));
    ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
}

/// Distance between the segments `a`–`b` and `c`–`d` [mm] (0 when they cross).
pub fn segment_distance(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> f64 {
    if segments_cross(a, b, c, d) {
        return 0.0;
    }
    point_segment_distance(a, c, d)
        .min(point_segment_distance(b, c, d))
        .min(point_segment_distance(c, a, b))
        .min(point_segment_distance(d, a, b))
}

/// Distance from the segment `a`–`b` to the box `[-h0, h0] × [-h1, h1]` [mm] (0 when the
/// segment touches or enters it).
pub fn segment_box_distance(a: [f64; 2], b: [f64; 2], half: [f64; 2]) -> f64 {
    if segment_enters_box(a, b, half) {
        return 0.0;
    }
    let point_box = |p: [f64; 2]| {
        let dx = (p[0].abs() - half[0]).max(0.0);
        let dy = (p[1].abs() - half[1]).max(0.0);
        dx.hypot(dy)
    };
    let mut d = point_box(a).min(point_box(b));
    for corner in [
        [half[0], half[1]],
        [-half[0], half[1]],
        [-half[0], -half[1]],
        [half[0], -half[1]],
    ] {
        d = d.min(point_segment_distance(corner, a, b));
    }
    d
}

/// Whether the segment `a`–`b` has a point in the box `[-h0, h0] × [-h1, h1]`
/// (Liang–Barsky clipping).
fn segment_enters_box(a: [f64; 2], b: [f64; 2], half: [f64; 2]) -> bool {
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for axis in 0..2 {
        for (p, q) in [
            (-d[axis], a[axis] + half[axis]),
            (d[axis], half[axis] - a[axis]),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return false;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
                if t0 > t1 {
                    return false;
                }
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn spans_overlap_or_keep_a_gap() {
        let a = Span::new(10.0, 0.0);
        assert_eq!(a, Span { lo: 0.0, hi: 10.0 });
        assert!(close(a.gap(&Span::new(15.0, 20.0)), 5.0));
        assert!(close(a.gap(&Span::new(5.0, 20.0)), -5.0));
        assert!(close(a.raised(3.0).gap(&Span::new(-10.0, 1.0)), 2.0));
    }

    #[test]
    fn a_capsule_and_a_turned_block() {
        // A block 100 x 40 turned 90 degrees: 40 wide along x, 100 deep along y.
        let block = Block::new([0.0, 0.0], 90.0, [50.0, 20.0], Span::new(0.0, 100.0));
        let disc = |x: f64, y: f64| Capsule::disc([x, y], 5.0, Span::new(50.0, 60.0));
        assert!(close(disc(30.0, 0.0).distance_to_block(&block), 5.0));
        assert!(close(disc(0.0, 60.0).distance_to_block(&block), 5.0));
        // Beyond a corner: the diagonal.
        assert!(close(disc(23.0, 54.0).distance_to_block(&block), 5.0 - 5.0));
        assert!(disc(10.0, 10.0).distance_to_block(&block) < 0.0);
        // Above it: the vertical gap; above and beside: the diagonal.
        let high = Capsule::disc([0.0, 0.0], 5.0, Span::new(110.0, 120.0));
        assert!(close(high.distance_to_block(&block), 10.0));
        let high_beside = Capsule::disc([33.0, 0.0], 5.0, Span::new(106.0, 120.0));
        assert!(close(high_beside.distance_to_block(&block), 10.0));
    }

    #[test]
    fn a_segment_through_a_box_touches_it_though_its_ends_are_outside() {
        let block = Block::new([0.0, 0.0], 0.0, [10.0, 10.0], Span::new(0.0, 1.0));
        let through = Capsule::new([-50.0, 0.0], [50.0, 0.0], 1.0, Span::new(0.0, 1.0));
        assert!(through.distance_to_block(&block) < 0.0);
        let past = Capsule::new([-50.0, 30.0], [50.0, 12.0], 1.0, Span::new(0.0, 1.0));
        let expected = point_segment_distance([10.0, 10.0], [-50.0, 30.0], [50.0, 12.0]) - 1.0;
        assert!(close(past.distance_to_block(&block), expected));
    }

    #[test]
    fn capsules_measure_between_their_axes() {
        let z = Span::new(0.0, 1.0);
        let a = Capsule::new([0.0, 0.0], [100.0, 0.0], 10.0, z);
        let b = Capsule::disc([50.0, 40.0], 5.0, z);
        assert!(close(a.distance_to_capsule(&b), 25.0));
        let crossing = Capsule::new([50.0, -50.0], [50.0, 50.0], 1.0, z);
        assert!(a.distance_to_capsule(&crossing) < 0.0);
        let (c, r) = a.bounds();
        assert!(close(c[0], 50.0) && close(r, 60.0));
    }
}
