//! The geometry of a composite Cartesian path ([`PathSpec`]): straight lines and circular
//! arcs, each interior corner rounded by a blend, parametrised by σ, the length along the
//! path [mm] (exactly the arc length on lines and arcs, close to it on blends).
//!
//! **Blends.** The corner after segment i is cut d_in = min(zone, L_i/2) before the corner
//! along segment i and d_out = min(zone, L_{i+1}/2) after it along segment i + 1, and the two
//! cut points are joined by a polynomial of degree 7 in each of x, y, z and yaw that matches
//! the position and the first three derivatives with respect to σ of both segments there. So
//! the pose and its first three derivatives are continuous along the whole path, and with
//! them (the inverse kinematics being smooth) every joint's q, q′, q″ and q‴: the curvature
//! is continuous (G2: a joint's acceleration never jumps at speed), and so is its rate of
//! change, so a joint's jerk q⃛ = q′u⃛ + 3q″u̇ü + q‴u̇³ does not jump where pieces meet either.
//! (A quintic, G2 only, was tried first: q‴ jumped at the ends of every blend, and the timing
//! law, which checks its bounds at its knots every 4 ms, let the jerk of J2 reach 1.4 times
//! its limit for a millisecond or two after such a jump.) The polynomial's parameter runs
//! over a length T of σ; T is chosen among the chord between the cut points, d_in + d_out and
//! their mean, so that the curve stays within the zone of the corner point and the TCP's
//! speed along it stays within [`MIN_BLEND_SPEED`] of the ends' (the one whose speed varies
//! least is taken). A corner with no zone (0 mm) is passed only where the segments are
//! tangent (within [`TANGENT_DEG`]); it is then joined over [`TANGENT_ZONE_MM`], which keeps
//! the curvature continuous where a line meets a tangent arc.
//!
//! Refused, each with its own [`PlanError`]: no segment or more than [`MAX_PATH_SEGMENTS`];
//! a number that is not finite; a negative blend zone; a segment shorter than
//! [`MIN_SEGMENT_MM`] (a turn of the hand alone is a straight line of its own); an arc whose
//! three points are on a line (radius over [`MAX_ARC_RADIUS_MM`]), whose via point is at an
//! end, or that ends where it starts; a corner with no zone that is not tangent; a corner
//! that turns back so sharply that no blend within its zone keeps the TCP moving.
//!
//! Real-time promise: `Copy`, fixed-size, built and evaluated without allocation.

use wrc_robot::{wrap180, Jet, Pose, PoseJet};

use crate::error::{ArcProblem, PathPlace, PlanError};
use crate::path_spec::{PathSegment, PathSpec, MAX_PATH_SEGMENTS};

/// Most pieces of a path: its segments and the blends between them.
pub(crate) const MAX_PIECES: usize = 2 * MAX_PATH_SEGMENTS - 1;

/// Shortest segment of a path (and shortest arc chord, and closest via point to an arc's
/// ends) [mm].
pub const MIN_SEGMENT_MM: f64 = 0.01;

/// Largest radius of an arc: three points on a circle larger than this are on a line [mm].
pub const MAX_ARC_RADIUS_MM: f64 = 100_000.0;

/// Largest turn of the TCP's direction at a corner with no blend zone that counts as
/// tangent [deg].
pub const TANGENT_DEG: f64 = 0.5;

/// The zone over which a tangent corner with no blend zone is joined with continuous
/// curvature [mm]: a line meeting a tangent arc of 50 mm radius leaves them by 0.6 µm there
/// (a test pins it under 2 µm), and the curvature changes over 4 mm, more than the timing
/// law covers in one step.
pub const TANGENT_ZONE_MM: f64 = 2.0;

/// Slowest (and, inverted, fastest) speed of the TCP along a blend's parameter relative to
/// the speed at its ends [-]: a blend that would nearly stop the TCP (a corner that turns
/// back) is refused.
pub const MIN_BLEND_SPEED: f64 = 0.25;

/// Spacing of the samples along a path's lines and blends [mm] (as a straight line's).
pub(crate) const SAMPLE_MM: f64 = crate::path::SAMPLE_MM;

/// Spacing of the samples of an arc's sweep [deg].
pub(crate) const SAMPLE_ARC_DEG: f64 = 0.5;

/// How many times as densely as a line a blend is sampled (every 1/16 mm), and at least
/// [`MIN_BLEND_INTERVALS`] times however short: the third derivatives of its joints vary
/// over a fraction of its length, and the derivative table interpolates them linearly. At
/// the line's spacing the jerk of J2 reached 1.009 times its limit in a blend of 20 mm (at
/// 1 ms, from the exact positions); in a hairpin blend of 2.4 mm sampled 72 times, 1.007.
const BLEND_DENSITY: f64 = 8.0;

/// Fewest sample intervals of a segment's piece.
const MIN_SEGMENT_INTERVALS: usize = 8;
/// Fewest sample intervals of a blend (see [`BLEND_DENSITY`]).
const MIN_BLEND_INTERVALS: usize = 256;

/// Most sample intervals of a whole path: 8 segments of up to 800 mm at 0.5 mm are 12,800,
/// so a path that long is sampled at 0.8 mm; the table holds this many plus one point per
/// piece (each piece keeps both its ends: q‴ may jump where pieces meet).
pub(crate) const MAX_CURVE_INTERVALS: usize = 8192;

/// Points checked along a candidate blend (its zone and its speed).
const BLEND_CHECKS: usize = 64;

/// x, y, z [mm] and yaw [deg].
pub(crate) type P4 = [f64; 4];

/// A point and its first three derivatives with respect to a parameter: `d[m][c]`, the m-th
/// derivative of coordinate c.
pub(crate) type Jet4 = [P4; 4];

/// A segment's shape over its own parameter w in [0, 1] (beyond 1 it continues: a line
/// straight on, an arc around its circle).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Shape {
    /// p0 + w·d.
    Line { p0: P4, d: P4 },
    /// Centre c, radius r, angle th0 + w·dth [rad]; z and yaw linear in w.
    Arc {
        c: [f64; 2],
        r: f64,
        th0: f64,
        dth: f64,
        z0: f64,
        dz: f64,
        yaw0: f64,
        dyaw: f64,
    },
}

impl Shape {
    fn eval(&self, w: f64) -> Jet4 {
        match *self {
            Shape::Line { p0, d } => {
                let mut out = [[0.0; 4]; 4];
                for c in 0..4 {
                    out[0][c] = p0[c] + w * d[c];
                    out[1][c] = d[c];
                }
                out
            }
            Shape::Arc {
                c,
                r,
                th0,
                dth,
                z0,
                dz,
                yaw0,
                dyaw,
            } => {
                let (s, k) = (th0 + w * dth).sin_cos();
                let (d1, d2, d3) = (dth, dth * dth, dth * dth * dth);
                [
                    [c[0] + r * k, c[1] + r * s, z0 + w * dz, yaw0 + w * dyaw],
                    [-r * s * d1, r * k * d1, dz, dyaw],
                    [-r * k * d2, -r * s * d2, 0.0, 0.0],
                    [r * s * d3, -r * k * d3, 0.0, 0.0],
                ]
            }
        }
    }
}

/// One segment: its shape and its length [mm].
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    shape: Shape,
    len: f64,
}

impl Segment {
    /// The point at arc length `s` [mm] from the segment's start, with its derivatives with
    /// respect to the arc length.
    fn at_length(&self, s: f64) -> Jet4 {
        per_length(self.shape.eval(s / self.len), self.len)
    }
}

/// Derivatives with respect to w turned into derivatives with respect to σ = w·len.
fn per_length(mut j: Jet4, len: f64) -> Jet4 {
    let mut f = 1.0;
    for d in j.iter_mut().skip(1) {
        f /= len;
        for x in d.iter_mut() {
            *x *= f;
        }
    }
    j
}

/// A corner's blend: a polynomial of degree 7 in each coordinate over w in [0, 1], spanning
/// `len` of σ.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Blend {
    /// Coefficients of w⁰ … w⁷ per coordinate.
    c: [[f64; 8]; 4],
    len: f64,
}

impl Blend {
    /// The septic from `a` to `b` (points with their first three derivatives with respect
    /// to σ) over a length `len` of σ: it matches both to the third derivative.
    fn hermite(a: &Jet4, b: &Jet4, len: f64) -> Blend {
        let mut c = [[0.0; 8]; 4];
        for (k, ck) in c.iter_mut().enumerate() {
            let d = |j: &Jet4, m: usize| j[m][k] * len.powi(m as i32);
            let (c0, c1, c2, c3) = (d(a, 0), d(a, 1), 0.5 * d(a, 2), d(a, 3) / 6.0);
            // What the cubic of the start leaves to the four higher terms at the end.
            let r0 = d(b, 0) - (c0 + c1 + c2 + c3);
            let r1 = d(b, 1) - (c1 + 2.0 * c2 + 3.0 * c3);
            let r2 = d(b, 2) - (2.0 * c2 + 6.0 * c3);
            let r3 = d(b, 3) - 6.0 * c3;
            *ck = [
                c0,
                c1,
                c2,
                c3,
                35.0 * r0 - 15.0 * r1 + 2.5 * r2 - r3 / 6.0,
                -84.0 * r0 + 39.0 * r1 - 7.0 * r2 + 0.5 * r3,
                70.0 * r0 - 34.0 * r1 + 6.5 * r2 - 0.5 * r3,
                -20.0 * r0 + 10.0 * r1 - 2.0 * r2 + r3 / 6.0,
            ];
        }
        Blend { c, len }
    }

    /// The point at w and its derivatives with respect to w.
    fn eval(&self, w: f64) -> Jet4 {
        let mut out = [[0.0; 4]; 4];
        for (k, c) in self.c.iter().enumerate() {
            // Horner on the polynomial and on its first three derivatives.
            let (mut p, mut d1, mut d2, mut d3) = (0.0, 0.0, 0.0, 0.0);
            for i in (0..8).rev() {
                let f = i as f64;
                p = p * w + c[i];
                if i >= 1 {
                    d1 = d1 * w + f * c[i];
                }
                if i >= 2 {
                    d2 = d2 * w + f * (f - 1.0) * c[i];
                }
                if i >= 3 {
                    d3 = d3 * w + f * (f - 1.0) * (f - 2.0) * c[i];
                }
            }
            out[0][k] = p;
            out[1][k] = d1;
            out[2][k] = d2;
            out[3][k] = d3;
        }
        out
    }
}

/// A composite path: segments, the blends between them, and where each piece lies along σ.
/// Pieces alternate: segment 0, blend 0, segment 1, … segment n − 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Curve {
    segments: [Segment; MAX_PATH_SEGMENTS],
    blends: [Blend; MAX_PATH_SEGMENTS - 1],
    n: usize,
    /// Where each segment's own piece starts and ends along the segment [mm].
    cut: [(f64, f64); MAX_PATH_SEGMENTS],
    /// σ where each piece starts, and the path's total at index `pieces()` [mm].
    sigma: [f64; MAX_PIECES + 1],
    /// Sample intervals of each piece (0 for a piece of no length).
    intervals: [u16; MAX_PIECES],
}

fn finite(p: &Pose) -> bool {
    p.x.is_finite() && p.y.is_finite() && p.z.is_finite() && p.yaw.is_finite()
}

fn xyz_norm(p: &P4) -> f64 {
    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
}

fn xyz_dist(a: &P4, b: &P4) -> f64 {
    xyz_norm(&[a[0] - b[0], a[1] - b[1], a[2] - b[2], 0.0])
}

/// The arc from `s` through `via` to `t` (z and yaw of `s` and `t`).
fn arc(s: &P4, via: &Pose, t: &P4) -> Result<Shape, ArcProblem> {
    let (bx, by) = (via.x - s[0], via.y - s[1]);
    let (cx, cy) = (t[0] - s[0], t[1] - s[1]);
    if cx.hypot(cy) < MIN_SEGMENT_MM {
        return Err(ArcProblem::Closed);
    }
    if bx.hypot(by) < MIN_SEGMENT_MM || (cx - bx).hypot(cy - by) < MIN_SEGMENT_MM {
        return Err(ArcProblem::ViaAtEnd);
    }
    let cross = bx * cy - by * cx;
    let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
    let d = 2.0 * cross;
    let (ux, uy) = ((cy * b2 - by * c2) / d, (bx * c2 - cx * b2) / d);
    let r = ux.hypot(uy);
    if cross == 0.0 || !r.is_finite() || r > MAX_ARC_RADIUS_MM {
        return Err(ArcProblem::Collinear);
    }
    let centre = [s[0] + ux, s[1] + uy];
    let th0 = (-uy).atan2(-ux);
    let th1 = (t[1] - centre[1]).atan2(t[0] - centre[0]);
    let turn = std::f64::consts::TAU;
    // Counter-clockwise when the via point is on the left of start → end.
    let dth = if cross > 0.0 {
        (th1 - th0).rem_euclid(turn)
    } else {
        -(th0 - th1).rem_euclid(turn)
    };
    Ok(Shape::Arc {
        c: centre,
        r,
        th0,
        dth,
        z0: s[2],
        dz: t[2] - s[2],
        yaw0: s[3],
        dyaw: t[3] - s[3],
    })
}

/// The angle between the directions (x, y, z) of two derivatives [deg].
fn turn_deg(a: &P4, b: &P4) -> f64 {
    let (na, nb) = (xyz_norm(a), xyz_norm(b));
    let dot = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (na * nb);
    dot.clamp(-1.0, 1.0).acos().to_degrees()
}

impl Curve {
    /// The path of `spec`, from `spec.start`. `wrist`: whether the arm has a hand joint
    /// (without one the yaw is not interpolated: it follows the arm).
    pub(crate) fn build(spec: &PathSpec, wrist: bool) -> Result<Curve, PlanError> {
        let n = spec.len;
        if n == 0 || n > MAX_PATH_SEGMENTS {
            return Err(PlanError::PathSegments { len: n });
        }
        if !finite(&spec.start) {
            return Err(PlanError::NotFinite {
                what: "the path's start",
            });
        }
        let mut curve = Curve {
            segments: [Segment {
                shape: Shape::Line {
                    p0: [0.0; 4],
                    d: [0.0; 4],
                },
                len: 0.0,
            }; MAX_PATH_SEGMENTS],
            blends: [Blend::default(); MAX_PATH_SEGMENTS - 1],
            n,
            cut: [(0.0, 0.0); MAX_PATH_SEGMENTS],
            sigma: [0.0; MAX_PIECES + 1],
            intervals: [0; MAX_PIECES],
        };
        let s = &spec.start;
        let mut from: P4 = [s.x, s.y, s.z, s.yaw];
        for (i, seg) in spec.segments().iter().enumerate() {
            let number = i + 1;
            let to = seg.to();
            let blend = seg.blend_mm();
            let via_ok = match seg {
                PathSegment::Arc { via, .. } => via.x.is_finite() && via.y.is_finite(),
                PathSegment::Line { .. } => true,
            };
            if !finite(&to) || !via_ok {
                return Err(PlanError::NotFinite {
                    what: "a pose of the path",
                });
            }
            if !(blend.is_finite() && blend >= 0.0) {
                return Err(PlanError::BlendZone {
                    segment: number,
                    blend_mm: blend,
                });
            }
            let yaw = if wrist {
                from[3] + wrap180(to.yaw - from[3])
            } else {
                from[3]
            };
            let end: P4 = [to.x, to.y, to.z, yaw];
            let shape = match seg {
                PathSegment::Line { .. } => {
                    let mut d = [0.0; 4];
                    for c in 0..4 {
                        d[c] = end[c] - from[c];
                    }
                    Shape::Line { p0: from, d }
                }
                PathSegment::Arc { via, .. } => {
                    arc(&from, via, &end).map_err(|problem| PlanError::Arc {
                        segment: number,
                        problem,
                    })?
                }
            };
            let len = match shape {
                Shape::Line { d, .. } => xyz_norm(&d),
                Shape::Arc { r, dth, dz, .. } => (r * dth).hypot(dz),
            };
            if len < MIN_SEGMENT_MM {
                return Err(PlanError::SegmentTooShort { segment: number });
            }
            curve.segments[i] = Segment { shape, len };
            curve.cut[i] = (0.0, len);
            from = end;
        }
        for i in 0..n - 1 {
            curve.corner(i, spec.segments[i].blend_mm())?;
        }
        // Where each piece lies along σ, and how densely it is sampled.
        let mut total = 0.0;
        let mut want = [0usize; MAX_PIECES];
        for (k, want) in want.iter_mut().enumerate().take(curve.pieces()) {
            curve.sigma[k] = total;
            let (len, yaw, sweep_deg) = curve.piece_extent(k);
            total += len;
            if len > 0.0 {
                // A blend's derivatives vary faster: sampled more densely (BLEND_DENSITY).
                let density = if k % 2 == 1 { BLEND_DENSITY } else { 1.0 };
                let n = (density * len / SAMPLE_MM)
                    .max(density * yaw.abs() / crate::path::SAMPLE_DEG)
                    .max(sweep_deg.abs() / SAMPLE_ARC_DEG)
                    .ceil();
                let least = if k % 2 == 1 {
                    MIN_BLEND_INTERVALS
                } else {
                    MIN_SEGMENT_INTERVALS
                };
                *want = if n.is_finite() {
                    (n as usize).clamp(least, MAX_CURVE_INTERVALS)
                } else {
                    least
                };
            }
        }
        curve.sigma[curve.pieces()] = total;
        // A path too long for the table is sampled more coarsely: along its segments first
        // (the blends keep theirs while they fill at most half of it), then everywhere.
        let sum: usize = want.iter().sum();
        if sum > MAX_CURVE_INTERVALS {
            let blends: usize = want.iter().skip(1).step_by(2).sum();
            let (pieces, room) = if blends <= MAX_CURVE_INTERVALS / 2 {
                (0, MAX_CURVE_INTERVALS - blends)
            } else {
                (1, MAX_CURVE_INTERVALS)
            };
            let scaled: usize = sum - if pieces == 0 { blends } else { 0 };
            let least = MIN_SEGMENT_INTERVALS.min(MIN_BLEND_INTERVALS);
            for (k, w) in want.iter_mut().enumerate() {
                if *w > 0 && (k % 2 == 0 || pieces == 1) {
                    // Leave room for the pieces that keep their least.
                    let f = (room - least * MAX_PIECES) as f64 / scaled as f64;
                    *w = ((*w as f64 * f).floor() as usize).max(least);
                }
            }
        }
        for (i, w) in curve.intervals.iter_mut().zip(want) {
            *i = w.min(u16::MAX as usize) as u16;
        }
        Ok(curve)
    }

    /// Round the corner after segment `i` (from 0) with zone `zone` [mm].
    fn corner(&mut self, i: usize, zone: f64) -> Result<(), PlanError> {
        let (a, b) = (self.segments[i], self.segments[i + 1]);
        let end_a = a.at_length(a.len);
        let start_b = b.at_length(0.0);
        let angle = turn_deg(&end_a[1], &start_b[1]);
        let zone = if zone > 0.0 {
            zone
        } else if angle <= TANGENT_DEG {
            TANGENT_ZONE_MM
        } else {
            return Err(PlanError::SharpCorner {
                segment: i + 1,
                angle_deg: angle,
            });
        };
        let d_in = zone.min(0.5 * a.len);
        let d_out = zone.min(0.5 * b.len);
        let p0 = a.at_length(a.len - d_in);
        let p1 = b.at_length(d_out);
        let corner = end_a[0];
        let chord = xyz_dist(&p0[0], &p1[0]);
        let mut best: Option<(f64, Blend)> = None;
        for len in [chord, 0.5 * (chord + d_in + d_out), d_in + d_out] {
            if len <= 1e-9 {
                continue;
            }
            let blend = Blend::hermite(&p0, &p1, len);
            let (mut slow, mut fast, mut inside) = (f64::INFINITY, 0.0f64, true);
            for k in 0..=BLEND_CHECKS {
                let j = blend.eval(k as f64 / BLEND_CHECKS as f64);
                let speed = xyz_norm(&j[1]) / len;
                slow = slow.min(speed);
                fast = fast.max(speed);
                inside &= xyz_dist(&j[0], &corner) <= zone * (1.0 + 1e-9) + 1e-9;
            }
            if !inside || slow < MIN_BLEND_SPEED || fast * MIN_BLEND_SPEED > 1.0 {
                continue;
            }
            let spread = fast.max(1.0 / slow);
            if best.is_none_or(|(s, _)| spread < s) {
                best = Some((spread, blend));
            }
        }
        let Some((_, blend)) = best else {
            return Err(PlanError::CornerTurnsBack {
                segment: i + 1,
                angle_deg: angle,
                blend_mm: zone,
            });
        };
        self.blends[i] = blend;
        self.cut[i].1 = a.len - d_in;
        self.cut[i + 1].0 = d_out;
        Ok(())
    }

    /// Number of pieces: segments and blends.
    pub(crate) fn pieces(&self) -> usize {
        2 * self.n - 1
    }

    /// Length of piece `k` along σ [mm], its change of yaw [deg] and of an arc's angle
    /// [deg].
    fn piece_extent(&self, k: usize) -> (f64, f64, f64) {
        if k % 2 == 1 {
            let b = &self.blends[k / 2];
            let yaw = b.eval(1.0)[0][3] - b.eval(0.0)[0][3];
            return (b.len, yaw, 0.0);
        }
        let i = k / 2;
        let seg = &self.segments[i];
        let (s0, s1) = self.cut[i];
        let len = (s1 - s0).max(0.0);
        let frac = len / seg.len;
        match seg.shape {
            Shape::Line { d, .. } => (len, d[3] * frac, 0.0),
            Shape::Arc { dth, dyaw, .. } => (len, dyaw * frac, dth.to_degrees() * frac),
        }
    }

    /// The total length of σ [mm].
    pub(crate) fn total(&self) -> f64 {
        self.sigma[self.pieces()]
    }

    /// Where piece `k` starts and ends along the path's parameter u in [0, 1], and its
    /// sample intervals.
    pub(crate) fn piece(&self, k: usize) -> (f64, f64, usize) {
        let t = self.total();
        (
            self.sigma[k] / t,
            self.sigma[k + 1] / t,
            self.intervals[k] as usize,
        )
    }

    /// The piece that holds u (the later one where two meet; the last one beyond the end,
    /// which continues its segment).
    pub(crate) fn piece_at(&self, u: f64) -> usize {
        let sigma = u * self.total();
        let last = self.pieces() - 1;
        (1..=last)
            .rev()
            .find(|&k| self.sigma[k] <= sigma)
            .unwrap_or(0)
    }

    /// Where along the path u lies: the segment or the blend after it.
    pub(crate) fn place(&self, u: f64) -> PathPlace {
        let k = self.piece_at(u);
        PathPlace {
            segment: (k / 2 + 1) as u8,
            blend: k % 2 == 1,
        }
    }

    /// The pose at u and its first three derivatives with respect to u (u beyond 1
    /// continues the last segment).
    pub(crate) fn jet4(&self, u: f64) -> Jet4 {
        let total = self.total();
        let sigma = u * total;
        let k = self.piece_at(u);
        let local = sigma - self.sigma[k];
        let per_sigma = if k % 2 == 1 {
            let b = &self.blends[k / 2];
            per_length(b.eval(local / b.len), b.len)
        } else {
            let i = k / 2;
            self.segments[i].at_length(self.cut[i].0 + local)
        };
        let mut out = per_sigma;
        let mut f = 1.0;
        for d in out.iter_mut().skip(1) {
            f *= total;
            for x in d.iter_mut() {
                *x *= f;
            }
        }
        out
    }

    /// The pose at u.
    pub(crate) fn pose_at(&self, u: f64) -> Pose {
        let p = self.jet4(u)[0];
        Pose {
            x: p[0],
            y: p[1],
            z: p[2],
            yaw: p[3],
        }
    }

    /// The pose at u with its derivatives with respect to u, scaled by `scale` per order
    /// (the derivatives with respect to a parameter v with du/dv = `scale`).
    pub(crate) fn pose_jet(&self, u: f64, scale: f64) -> PoseJet {
        let j = self.jet4(u);
        let coord = |c: usize| Jet {
            d: [
                j[0][c],
                j[1][c] * scale,
                j[2][c] * scale * scale,
                j[3][c] * scale * scale * scale,
            ],
        };
        PoseJet {
            x: coord(0),
            y: coord(1),
            z: coord(2),
            yaw: coord(3),
        }
    }

    /// The distance of `p` from the path in x, y and z [mm], and the u of the nearest point:
    /// sampled every quarter millimetre (at most 16,384 samples), the nearest sample refined
    /// by golden-section search.
    pub(crate) fn nearest(&self, p: &Pose) -> (f64, f64) {
        let samples = ((self.total() / 0.25).ceil() as usize).clamp(64, 16_384);
        let h = 1.0 / samples as f64;
        let dist = |u: f64| {
            let q = self.pose_at(u);
            (q.x - p.x).hypot(q.y - p.y).hypot(q.z - p.z)
        };
        let (mut best, mut at) = (f64::INFINITY, 0.0);
        for i in 0..=samples {
            let d = dist(i as f64 * h);
            if d < best {
                (best, at) = (d, i as f64 * h);
            }
        }
        let u = golden(dist, (at - h).max(0.0), (at + h).min(1.0));
        (dist(u).min(best), u)
    }

    /// The first u in [0, `upto`] where the path passes within `tol_mm` of `p` (in x, y, z)
    /// and within `tol_deg` of its yaw (when `yaw` is checked); `None` if it never does.
    /// Samples every quarter millimetre (at most 16,384 samples), then refines each near
    /// sample by golden-section search. No allocation.
    pub(crate) fn locate(
        &self,
        p: &Pose,
        upto: f64,
        (tol_mm, tol_deg, yaw): (f64, f64, bool),
    ) -> Option<f64> {
        let samples = ((self.total() * upto / 0.25).ceil() as usize).clamp(64, 16_384);
        let h = upto / samples as f64;
        let spacing = self.total() * h;
        let dist = |u: f64| {
            let q = self.pose_at(u);
            (q.x - p.x).hypot(q.y - p.y).hypot(q.z - p.z)
        };
        for i in 0..=samples {
            let u = i as f64 * h;
            if dist(u) > tol_mm + spacing {
                continue;
            }
            // The nearest point around this sample.
            let best = golden(dist, (u - h).max(0.0), (u + h).min(upto));
            let yaw_ok = !yaw || wrap180(self.pose_at(best).yaw - p.yaw).abs() <= tol_deg;
            if dist(best) <= tol_mm && yaw_ok {
                return Some(best);
            }
        }
        None
    }
}

/// The minimum of `f` on [lo, hi] by golden-section search (80 steps: to 1e-16 of the
/// interval), for a function with one minimum there.
fn golden(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..80 {
        if f1 <= f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        }
    }
    if f1 <= f2 {
        x1
    } else {
        x2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(x: f64, y: f64, z: f64, yaw: f64) -> Pose {
        Pose { x, y, z, yaw }
    }

    fn spec(start: Pose, segments: &[PathSegment]) -> PathSpec {
        let mut s = PathSpec::new(start);
        for seg in segments {
            s.push(*seg).unwrap();
        }
        s
    }

    #[test]
    fn the_blend_matches_both_ends_to_the_third_derivative() {
        let a = [
            [1.0, 2.0, 3.0, 4.0],
            [0.5, -0.2, 0.1, 1.0],
            [0.01, 0.02, 0.0, -0.3],
            [0.001, 0.0, -0.02, 0.0],
        ];
        let b = [
            [2.0, 1.0, 3.5, 6.0],
            [-0.1, 0.7, 0.0, 0.4],
            [0.03, -0.01, 0.2, 0.0],
            [0.0, 0.004, 0.0, 0.01],
        ];
        let len = 2.5;
        let q = Blend::hermite(&a, &b, len);
        let (s, e) = (per_length(q.eval(0.0), len), per_length(q.eval(1.0), len));
        for m in 0..4 {
            for c in 0..4 {
                assert!((s[m][c] - a[m][c]).abs() < 1e-12, "start d{m} c{c}");
                assert!((e[m][c] - b[m][c]).abs() < 1e-11, "end d{m} c{c}");
            }
        }
    }

    #[test]
    fn an_arc_goes_through_its_via_point_and_ends_on_its_target() {
        for (via, to) in [
            (pose(300.0, 50.0, 0.0, 0.0), pose(350.0, 0.0, 20.0, 90.0)),
            // Clockwise, and a via on the far side: more than half a turn.
            (pose(300.0, -50.0, 0.0, 0.0), pose(350.0, 0.0, 0.0, -30.0)),
            (pose(300.0, 60.0, 0.0, 0.0), pose(300.0, -1.0, 0.0, 0.0)),
        ] {
            let c = Curve::build(
                &spec(
                    pose(250.0, 0.0, 0.0, 0.0),
                    &[PathSegment::Arc {
                        via,
                        to,
                        blend_mm: 0.0,
                    }],
                ),
                true,
            )
            .unwrap();
            let end = c.pose_at(1.0);
            assert!((end.x - to.x).abs() < 1e-9 && (end.y - to.y).abs() < 1e-9);
            assert!((end.z - to.z).abs() < 1e-9 && (end.yaw - to.yaw).abs() < 1e-9);
            // Through the via point in x-y (its z and yaw are not used).
            let near = (0..=20_000)
                .map(|k| {
                    let p = c.pose_at(k as f64 / 20_000.0);
                    (p.x - via.x).hypot(p.y - via.y)
                })
                .fold(f64::INFINITY, f64::min);
            assert!(near < 0.01, "{near} mm from the via");
            // locate() finds the points of the path.
            let mid = c.pose_at(0.37);
            let u = c.locate(&mid, 1.0, (1e-6, 1e-6, true)).unwrap();
            assert!((u - 0.37).abs() < 1e-6, "{u}");
            // Arc-length parametrised: the speed along u is the length everywhere.
            for i in 0..=100 {
                let j = c.jet4(i as f64 / 100.0);
                assert!((xyz_norm(&j[1]) - c.total()).abs() < 1e-9 * c.total());
            }
        }
    }

    #[test]
    fn bad_arcs_and_corners_are_refused_with_their_reason() {
        let s = pose(250.0, 0.0, 0.0, 0.0);
        let arc = |via: Pose, to: Pose| PathSegment::Arc {
            via,
            to,
            blend_mm: 0.0,
        };
        let build = |segs: &[PathSegment]| Curve::build(&spec(s, segs), true).unwrap_err();
        assert_eq!(
            build(&[arc(pose(260.0, 0.0, 0.0, 0.0), pose(280.0, 0.0, 0.0, 0.0))]),
            PlanError::Arc {
                segment: 1,
                problem: ArcProblem::Collinear
            }
        );
        let e = build(&[arc(pose(300.0, 0.0, 0.0, 0.0), pose(280.0, 0.0, 0.0, 0.0))]);
        assert!(e.to_string().contains("use a straight line (MOVL)"), "{e}");
        assert_eq!(
            build(&[arc(pose(260.0, 10.0, 0.0, 0.0), s)]),
            PlanError::Arc {
                segment: 1,
                problem: ArcProblem::Closed
            }
        );
        assert_eq!(
            build(&[arc(s, pose(280.0, 10.0, 0.0, 0.0))]),
            PlanError::Arc {
                segment: 1,
                problem: ArcProblem::ViaAtEnd
            }
        );
        let line = |x: f64, y: f64, blend_mm: f64| PathSegment::Line {
            to: pose(x, y, 0.0, 0.0),
            blend_mm,
        };
        assert!(matches!(
            build(&[line(300.0, 0.0, 0.0), line(300.0, 50.0, 0.0)]),
            PlanError::SharpCorner { segment: 1, angle_deg } if (angle_deg - 90.0).abs() < 1e-9
        ));
        assert!(matches!(
            build(&[line(300.0, 0.0, 10.0), line(260.0, 0.0, 0.0)]),
            PlanError::CornerTurnsBack { segment: 1, .. }
        ));
        assert_eq!(
            build(&[line(300.0, 0.0, -1.0), line(300.0, 50.0, 0.0)]),
            PlanError::BlendZone {
                segment: 1,
                blend_mm: -1.0
            }
        );
        assert_eq!(
            build(&[PathSegment::Line {
                to: pose(250.0, 0.0, 0.0, 45.0),
                blend_mm: 0.0
            }]),
            PlanError::SegmentTooShort { segment: 1 }
        );
        assert_eq!(build(&[]), PlanError::PathSegments { len: 0 });
        let mut nan = line(300.0, 0.0, 0.0);
        if let PathSegment::Line { to, .. } = &mut nan {
            to.y = f64::NAN;
        }
        assert!(matches!(build(&[nan]), PlanError::NotFinite { .. }));
        // Tangent with no zone: joined over a millimetre.
        let ok = Curve::build(
            &spec(
                s,
                &[
                    line(300.0, 0.0, 0.0),
                    arc(pose(350.0, 50.0, 0.0, 0.0), pose(300.0, 100.0, 0.0, 0.0)),
                ],
            ),
            true,
        );
        assert!(ok.is_ok(), "{ok:?}");
    }

    #[test]
    fn a_tangent_corner_without_zone_stays_on_its_segments() {
        // A line into a tangent arc of radius 50 mm: the transition of curvature leaves the
        // line and the circle by less than a micrometre.
        let c = Curve::build(
            &spec(
                pose(150.0, -100.0, 0.0, 0.0),
                &[
                    PathSegment::Line {
                        to: pose(250.0, -100.0, 0.0, 0.0),
                        blend_mm: 0.0,
                    },
                    PathSegment::Arc {
                        via: pose(300.0, -50.0, 0.0, 0.0),
                        to: pose(250.0, 0.0, 0.0, 0.0),
                        blend_mm: 0.0,
                    },
                ],
            ),
            true,
        )
        .unwrap();
        let (u0, u1, _) = c.piece(1);
        let mut off = 0.0f64;
        for k in 0..=1000 {
            let p = c.pose_at(u0 + (u1 - u0) * k as f64 / 1000.0);
            // The nearer of the line y = -100 (x ≤ 250) and the circle about (250, -50).
            let to_line = if p.x <= 250.0 {
                (p.y + 100.0).abs()
            } else {
                f64::INFINITY
            };
            let to_circle = ((p.x - 250.0).hypot(p.y + 50.0) - 50.0).abs();
            off = off.max(to_line.min(to_circle));
        }
        assert!(off < 0.002, "{off} mm");
        assert!(off > 0.0);
    }

    #[test]
    fn blends_stay_in_their_zone_with_continuous_second_derivatives() {
        let s = pose(200.0, -100.0, 0.0, 0.0);
        let segs = [
            PathSegment::Line {
                to: pose(300.0, -100.0, 10.0, 30.0),
                blend_mm: 20.0,
            },
            PathSegment::Arc {
                via: pose(340.0, -60.0, 0.0, 0.0),
                to: pose(300.0, -20.0, 20.0, 60.0),
                blend_mm: 15.0,
            },
            PathSegment::Line {
                to: pose(200.0, 50.0, 20.0, 0.0),
                blend_mm: 200.0,
            },
            PathSegment::Line {
                to: pose(250.0, 120.0, 0.0, 0.0),
                blend_mm: 0.0,
            },
        ];
        let c = Curve::build(&spec(s, &segs), true).unwrap();
        let corners = [segs[0].to(), segs[1].to(), segs[2].to()];
        let zones = [20.0, 15.0, 200.0];
        for (i, (corner, zone)) in corners.iter().zip(zones).enumerate() {
            let (u0, u1, _) = c.piece(2 * i + 1);
            let mut far = 0.0f64;
            for k in 0..=2000 {
                let p = c.pose_at(u0 + (u1 - u0) * k as f64 / 2000.0);
                far = far.max((p.x - corner.x).hypot(p.y - corner.y).hypot(p.z - corner.z));
            }
            assert!(
                far <= zone + 1e-9,
                "blend {i}: {far} mm from its corner, zone {zone}"
            );
            // At both ends: the pose and its first three derivatives continuous.
            for u in [u0, u1] {
                let (a, b) = (c.jet4(u - 1e-12), c.jet4(u + 1e-12));
                for m in 0..4 {
                    // Per millimetre of the path.
                    let per = c.total().powi(m as i32);
                    for k in 0..4 {
                        let (x, y) = (a[m][k] / per, b[m][k] / per);
                        assert!(
                            (x - y).abs() < 1e-7 * x.abs().max(1.0),
                            "blend {i} at u={u}: d{m} of coordinate {k}: {} vs {}",
                            a[m][k],
                            b[m][k]
                        );
                    }
                }
            }
        }
        // The path ends where its last segment does, and the zone of 200 mm was clamped to
        // half of each segment.
        let end = c.pose_at(1.0);
        assert!((end.x - 250.0).abs() < 1e-9 && (end.y - 120.0).abs() < 1e-9);
        assert_eq!(
            c.place(0.999),
            PathPlace {
                segment: 4,
                blend: false
            }
        );
    }
}
