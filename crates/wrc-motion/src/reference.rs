//! Reference figures for a straight line or a composite path, to measure the planner
//! against: lower bounds on the duration of *any* motion along it that keeps the same
//! limits ([`line_bound`], [`path_bound`]). Not used by the
//! controller; this module allocates (it is for benchmarks and tests).
//!
//! - [`topp_va`]: the time-optimal path parameterisation with every joint's velocity and
//!   acceleration limits and the Cartesian line speed and acceleration (no jerk limits): the
//!   reachability-analysis algorithm of TOPP-RA (Pham & Pham, 2018) on a grid of
//!   [`TOPP_GRID`] intervals — backward controllable sets, then the greedy forward pass —
//!   with the exact joint derivatives of the inverse kinematics. Dropping the jerk limits
//!   can only make a motion faster, so this is a lower bound (to the grid's precision,
//!   about 0.1 %; it agrees with the `toppra` Python package to that).
//! - the one-dimensional jerk-limited time-optimal duration of the TCP's travel with the
//!   Cartesian speed, acceleration and jerk limits ([`DoubleS`], equal to Ruckig's): the TCP
//!   must cover the line's length from rest to rest.
//! - the same for each joint's net travel with its own limits.
//!
//! [`LineBound::lower_bound_s`] is the larger of the first two; with the third,
//! [`LineBound::with_joints_s`].

use wrc_robot::{Joints, Pose, Robot};

use crate::double_s::DoubleS;
use crate::error::PlanError;
use crate::geometry::{check_path, path_window, Geometry};
use crate::path::{check_line, Derivs, LineAxes, CHANNELS};
use crate::path_spec::PathSpec;
use crate::settings::LineLimits;

/// Grid intervals of the TOPP-RA reference.
pub const TOPP_GRID: usize = 2000;

/// Lower bounds on the duration of a straight line [s].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineBound {
    /// TOPP-RA with joint velocity and acceleration and Cartesian speed and acceleration.
    pub topp_va_s: f64,
    /// The TCP's one-dimensional jerk-limited time over the line's length.
    pub cartesian_jerk_s: f64,
    /// The slowest joint's one-dimensional jerk-limited time over its net travel.
    pub joint_jerk_s: f64,
}

impl LineBound {
    /// max(TOPP-RA v/a, the TCP's 1-D jerk-limited time).
    pub fn lower_bound_s(&self) -> f64 {
        self.topp_va_s.max(self.cartesian_jerk_s)
    }

    /// [`LineBound::lower_bound_s`] and each joint's 1-D jerk-limited time.
    pub fn with_joints_s(&self) -> f64 {
        self.lower_bound_s().max(self.joint_jerk_s)
    }
}

/// The lower bounds of the straight line from the pose of `start` (joints) to `target`, at
/// 100 % speed.
pub fn line_bound(
    robot: &Robot,
    line: &LineLimits,
    start: &Joints,
    target: &Pose,
) -> Result<LineBound, PlanError> {
    let (path, check) = check_line(robot, start, target)?;
    let axes = LineAxes::of(robot);
    let length = path.length_mm();
    // Exact derivatives at the grid points, following the joints continuously.
    let n = TOPP_GRID;
    let mut grid = Vec::with_capacity(n + 1);
    let mut reference = *start;
    for i in 0..=n {
        let u = i as f64 / n as f64;
        let jets = path.jets_at(robot, u, &reference)?;
        for (q, j) in reference
            .iter_mut()
            .zip(&jets.joints)
            .take(robot.axis_count())
        {
            *q = j.value();
        }
        grid.push(Derivs::of(&jets, &axes));
    }
    let mut limits = [(0.0, 0.0); CHANNELS];
    for (k, l) in limits.iter_mut().enumerate().take(axes.n) {
        let a = &robot.axes()[axes.idx[k]].limits;
        *l = (a.max_velocity, a.max_acceleration);
    }
    let (cv, ca) = if length > 0.0 {
        (line.max_speed_mm_s / length, line.max_accel_mm_s2 / length)
    } else {
        (f64::INFINITY, f64::INFINITY)
    };
    let us: Vec<f64> = (0..=n).map(|i| i as f64 / n as f64).collect();
    let topp_va_s = topp_va(&us, &grid, axes.n, &limits, (cv, ca, f64::INFINITY));
    let cartesian_jerk_s = if length > 0.0 {
        DoubleS::time_optimal(
            length,
            line.max_speed_mm_s,
            line.max_accel_mm_s2,
            line.max_jerk_mm_s3,
        )
        .duration()
    } else {
        0.0
    };
    let joint_jerk_s = joint_jerk_s(robot, start, &check.end_joints);
    Ok(LineBound {
        topp_va_s,
        cartesian_jerk_s,
        joint_jerk_s,
    })
}

/// The lower bounds of the composite path `spec` from the joints `start` (its start; from a
/// point of the path, the rest of it), at 100 % speed, with the same limits as the planner
/// (docs/motion.md, "Arcs", "Blended paths"):
///
/// - TOPP-RA with every joint's velocity and acceleration limit, the TCP's speed and
///   tangential acceleration along the path and its centripetal acceleration (no jerk
///   limits), on a grid of the planner's samples of each piece, twice as dense (a blend
///   as finely as the table holds it);
/// - the TCP's one-dimensional jerk-limited time over the path's arc length;
/// - each joint's one-dimensional jerk-limited time over its net travel.
pub fn path_bound(
    robot: &Robot,
    line: &LineLimits,
    start: &Joints,
    spec: &PathSpec,
) -> Result<LineBound, PlanError> {
    let check = check_path(robot, start, spec)?;
    let Some(window) = path_window(robot, start, spec)? else {
        return Ok(LineBound {
            topp_va_s: 0.0,
            cartesian_jerk_s: 0.0,
            joint_jerk_s: 0.0,
        });
    };
    let path = Geometry::Curve(window);
    let axes = LineAxes::of(robot);
    let (pieces, count) = path.pieces();
    let (mut us, mut grid) = (Vec::new(), Vec::new());
    let mut reference = *start;
    let mut arc_mm = 0.0;
    let mut last: Option<(f64, f64)> = None;
    for &(v0, v1, n) in &pieces[..count] {
        let n = 2 * n;
        for i in 0..=n {
            let u = v0 + (v1 - v0) * (i as f64 / n as f64);
            if last.is_some_and(|(lu, _)| u <= lu) {
                continue;
            }
            let (row, jets) = path.row(robot, &axes, u, &reference)?;
            for (q, j) in reference
                .iter_mut()
                .zip(&jets.joints)
                .take(robot.axis_count())
            {
                *q = j.value();
            }
            // The TCP's speed along the path per unit of u: its arc length by trapezoids.
            let speed = row.d1[axes.n];
            if let Some((lu, ls)) = last {
                arc_mm += 0.5 * (speed + ls) * (u - lu);
            }
            last = Some((u, speed));
            us.push(u);
            grid.push(row);
        }
    }
    let mut limits = [(0.0, 0.0); CHANNELS];
    for (k, l) in limits.iter_mut().enumerate().take(axes.n) {
        let a = &robot.axes()[axes.idx[k]].limits;
        *l = (a.max_velocity, a.max_acceleration);
    }
    limits[axes.n] = (line.max_speed_mm_s, line.max_accel_mm_s2);
    let centripetal = line.max_accel_mm_s2.sqrt();
    let topp_va_s = topp_va(
        &us,
        &grid,
        axes.n + 1,
        &limits,
        (f64::INFINITY, f64::INFINITY, centripetal),
    );
    let cartesian_jerk_s = DoubleS::time_optimal(
        arc_mm,
        line.max_speed_mm_s,
        line.max_accel_mm_s2,
        line.max_jerk_mm_s3,
    )
    .duration();
    Ok(LineBound {
        topp_va_s,
        cartesian_jerk_s,
        joint_jerk_s: joint_jerk_s(robot, start, &check.end_joints),
    })
}

/// The slowest joint's one-dimensional jerk-limited time over its net travel from `start`
/// to `end` [s].
fn joint_jerk_s(robot: &Robot, start: &Joints, end: &Joints) -> f64 {
    let mut t = 0.0f64;
    for (i, axis) in robot.axes().iter().enumerate() {
        let d = (end[i] - start[i]).abs();
        if d > 0.0 {
            let l = &axis.limits;
            t = t.max(
                DoubleS::time_optimal(d, l.max_velocity, l.max_acceleration, l.max_jerk).duration(),
            );
        }
    }
    t
}

/// TOPP-RA on a grid of u: `grid[k]` are the derivatives at `us[k]` (increasing, from 0 to
/// 1), `limits[i]` the velocity and acceleration limits of channel i (the moving axes, and
/// a composite path's TCP), and `(cv, ca, cn)` a straight line's Cartesian speed and
/// acceleration in u units and the bound of the centripetal channel ([`Derivs::dn`]).
/// Returns the duration [s].
fn topp_va(
    us: &[f64],
    grid: &[Derivs],
    n_axes: usize,
    limits: &[(f64, f64)],
    (cv, ca, cn): (f64, f64, f64),
) -> f64 {
    let n = grid.len() - 1;
    let du = |k: usize| us[k + 1] - us[k];
    // x = u̇²: the velocity limits bound x at each point.
    let x_vel: Vec<f64> = grid
        .iter()
        .map(|d| {
            let mut x = cv * cv;
            for (k, &(v, _)) in limits.iter().enumerate().take(n_axes) {
                let d1 = d.d1[k].abs();
                if d1 > 0.0 {
                    x = x.min((v / d1) * (v / d1));
                }
            }
            if d.dn > 0.0 {
                x = x.min((cn / d.dn) * (cn / d.dn));
            }
            x
        })
        .collect();
    // The admissible ü at (point k, x): an interval, empty when lo > hi.
    let accel = |k: usize, x: f64| -> (f64, f64) {
        let d = &grid[k];
        let (mut lo, mut hi) = (-ca, ca);
        for (i, &(_, a)) in limits.iter().enumerate().take(n_axes) {
            let (d1, c) = (d.d1[i], d.d2[i] * x);
            if d1.abs() < 1e-12 {
                if c.abs() > a {
                    return (1.0, -1.0);
                }
                continue;
            }
            let (l, h) = ((-a - c) / d1, (a - c) / d1);
            lo = lo.max(l.min(h));
            hi = hi.min(l.max(h));
        }
        (lo, hi)
    };
    // Whether x at point k can reach [0, next_max] at point k + 1 with an admissible ü.
    let feasible = |k: usize, x: f64, next_max: f64| -> bool {
        if x > x_vel[k] * (1.0 + 1e-12) || x < 0.0 {
            return false;
        }
        let (lo, hi) = accel(k, x);
        let lo = lo.max(-x / (2.0 * du(k)));
        let hi = hi.min((next_max - x) / (2.0 * du(k)));
        lo <= hi + 1e-12
    };
    // Backward pass: the largest controllable x at every point.
    let mut k_max = vec![0.0; n + 1];
    for k in (0..n).rev() {
        let next = k_max[k + 1];
        let (mut lo, mut hi) = (0.0, x_vel[k]);
        if feasible(k, hi, next) {
            lo = hi;
        } else {
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                if feasible(k, mid, next) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
        }
        k_max[k] = lo;
    }
    // Forward pass: the greedy largest x within the controllable sets.
    let mut x = vec![0.0; n + 1];
    for k in 0..n {
        let (_, hi) = accel(k, x[k]);
        let next = (x[k] + 2.0 * du(k) * hi).min(k_max[k + 1]).max(0.0);
        x[k + 1] = next;
    }
    (0..n)
        .map(|k| {
            let s = x[k].sqrt() + x[k + 1].sqrt();
            if s > 0.0 {
                2.0 * du(k) / s
            } else {
                0.0
            }
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::MotionSettings;
    use wrc_robot::Posture;

    #[test]
    fn a_line_far_from_the_joint_limits_is_bound_by_the_cartesian_limits() {
        // Short radial line at mid reach: the TCP's own limits bind.
        let robot = Robot::paper_default();
        let a = Pose {
            x: 250.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
        };
        let b = Pose {
            x: 250.0,
            y: 20.0,
            z: 0.0,
            yaw: 0.0,
        };
        let start = robot.inverse(&a, Posture::Right, None).unwrap();
        let line = MotionSettings::default().line;
        let bound = line_bound(&robot, &line, &start, &b).unwrap();
        // v/a only: a triangle of 2·sqrt(D/A).
        let tri = 2.0 * (20.0f64 / line.max_accel_mm_s2).sqrt();
        assert!(
            (bound.topp_va_s - tri).abs() < 2e-3 * tri,
            "{bound:?} vs {tri}"
        );
        assert!(bound.cartesian_jerk_s > bound.topp_va_s);
        assert_eq!(bound.lower_bound_s(), bound.cartesian_jerk_s);
    }

    #[test]
    fn toppra_matches_the_python_package() {
        // The same lines through toppra 0.6.10 (Python; 2000-interval grid, joint velocity
        // and acceleration, and the arc length as a fifth coordinate with the Cartesian
        // speed and acceleration): 0.84231 s, 0.77133 s and 0.65859 s.
        let robot = Robot::paper_default();
        let line = MotionSettings::default().line;
        let cases = [
            (
                [203.3216, 13.9324, 225.9091, -126.7481],
                [133.4363, 299.4676, 236.1291, -111.0181],
                Posture::Left,
                0.84231,
            ),
            (
                [164.7758, 238.7826, 129.368, 132.2354],
                [-93.4869, 234.9369, 102.5384, 15.7209],
                Posture::Right,
                0.77133,
            ),
            (
                [85.7209, 144.9134, 136.7787, 31.1466],
                [49.4685, 332.2109, 109.5022, -18.5773],
                Posture::Right,
                0.65859,
            ),
        ];
        for (a, b, posture, want) in cases {
            let pose = |p: [f64; 4]| Pose {
                x: p[0],
                y: p[1],
                z: p[2],
                yaw: p[3],
            };
            let start = robot.inverse(&pose(a), posture, None).unwrap();
            let bound = line_bound(&robot, &line, &start, &pose(b)).unwrap();
            assert!(
                (bound.topp_va_s - want).abs() < 1e-3 * want,
                "{} vs toppra {want}",
                bound.topp_va_s
            );
        }
    }
}
