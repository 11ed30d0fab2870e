//! Velocity Generator cost: one 50 ms cycle of a straight line for 4 axes, IK included
//! (5 periods at 10 ms, 50 at 1 ms). The paper needed 5,185-9,181 µs per cycle; the target
//! here is 20 µs. Also the cost of starting a line (checked point by point), of planning one
//! with its whole timing law, of stopping one, a PTP cycle, and of a transfer's blended
//! approach (its bounded search, and the exhaustive one).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use wrc_motion::{BlendSearch, BrakeLimits, MotionSettings, Period, Profile, VelocityGenerator};
use wrc_robot::{Pose, Posture, Robot};

/// Where the 250 mm line of these benchmarks ends.
const LINE_END: Pose = Pose {
    x: 300.0,
    y: 150.0,
    z: 50.0,
    yaw: 30.0,
};

/// A generator in the middle of a 250 mm straight line (so every period does real work).
fn mid_line(period_s: f64, profile: Profile) -> VelocityGenerator {
    let settings = MotionSettings {
        period_s,
        profile,
        ..MotionSettings::default()
    };
    let mut vg = VelocityGenerator::new(Robot::paper_default(), settings).unwrap();
    let start = vg
        .robot()
        .inverse(
            &Pose {
                x: 300.0,
                y: -100.0,
                z: 0.0,
                yaw: 0.0,
            },
            Posture::Right,
            None,
        )
        .unwrap();
    vg.set_position_pulses(&vg.robot().joints_to_pulses(&start))
        .unwrap();
    let info = vg.plan_line(&LINE_END).unwrap();
    let mut p = Period::default();
    for _ in 0..info.periods / 3 {
        vg.next_period(&mut p);
    }
    vg
}

fn cycle(c: &mut Criterion) {
    for (name, period_s, periods, profile) in [
        (
            "vg_cycle_line_50ms/10ms_period_5_periods",
            0.010,
            5,
            Profile::Fir,
        ),
        (
            "vg_cycle_line_50ms/1ms_period_50_periods",
            0.001,
            50,
            Profile::Fir,
        ),
        (
            "vg_cycle_line_50ms/1ms_period_50_periods_paper",
            0.001,
            50,
            Profile::Paper { mask_len: 100 },
        ),
    ] {
        let base = mid_line(period_s, profile);
        c.bench_function(name, |b| {
            b.iter_batched_ref(
                || base.clone(),
                |vg| {
                    let mut p = Period::default();
                    for _ in 0..periods {
                        black_box(vg.next_period(&mut p));
                    }
                    black_box(p.pulses[0])
                },
                BatchSize::SmallInput,
            )
        });
    }

    let settings = MotionSettings {
        period_s: 0.001,
        ..MotionSettings::default()
    };
    let mut ptp = VelocityGenerator::new(Robot::paper_default(), settings).unwrap();
    let mut target = ptp.joints();
    target[0] = 100.0;
    target[1] = 20.0;
    target[3] = 200.0;
    ptp.plan_ptp(&target).unwrap();
    c.bench_function("vg_cycle_ptp_50ms/1ms_period_50_periods", |b| {
        b.iter_batched_ref(
            || ptp.clone(),
            |vg| {
                let mut p = Period::default();
                for _ in 0..50 {
                    black_box(vg.next_period(&mut p));
                }
            },
            BatchSize::SmallInput,
        )
    });

    let idle = mid_line(0.010, Profile::Fir);
    let mut fresh = VelocityGenerator::new(Robot::paper_default(), *idle.settings()).unwrap();
    let start = fresh
        .robot()
        .inverse(
            &Pose {
                x: 300.0,
                y: -100.0,
                z: 0.0,
                yaw: 0.0,
            },
            Posture::Right,
            None,
        )
        .unwrap();
    fresh
        .set_position_pulses(&fresh.robot().joints_to_pulses(&start))
        .unwrap();
    // What the controller's Velocity Generator pays before a line's first pulse: the check of
    // every point and the derivative table (the law then advances with the periods).
    c.bench_function("start_line_250mm", |b| {
        b.iter_batched_ref(
            || fresh.clone(),
            |vg| black_box(vg.start_line(&LINE_END).unwrap()),
            BatchSize::SmallInput,
        )
    });
    // What a stop costs the task that brakes (the Pulse Generator's, on ESTOP and STOP): the
    // brake from the present state, every candidate simulated to its stop, a third of the way
    // along the line, at 100 % and at 20 % (where ESTOP brakes in real time).
    for (name, pct, limits) in [
        ("stop_line_mid/estop_100pct", 100.0, BrakeLimits::Full),
        ("stop_line_mid/stop_100pct", 100.0, BrakeLimits::Override),
        ("stop_line_mid/estop_20pct", 20.0, BrakeLimits::Full),
        ("stop_line_mid/stop_20pct", 20.0, BrakeLimits::Override),
    ] {
        let mut moving = mid_line(0.010, Profile::Fir);
        moving.set_speed_pct(pct).unwrap();
        c.bench_function(name, |b| {
            b.iter_batched_ref(
                || moving.clone(),
                |vg| vg.stop(black_box(limits)),
                BatchSize::SmallInput,
            )
        });
    }
    // What the Velocity Generator pays before a blended approach's first pulse (docs/motion.md,
    // "Blended approach"): the line's check, then for each entry speed tried (four) Ruckig's
    // move into it, its samples, its commit point and the line's law run once: the demo cell's
    // LP1 approach pose to the aligner's line at 80 %.
    let robot = fresh.robot().clone();
    let mut at_lp1 = fresh.clone();
    let lp1 = robot
        .inverse(
            &Pose {
                x: 103.923,
                y: -60.0,
                z: 23.0,
                yaw: -30.0,
            },
            Posture::Right,
            None,
        )
        .unwrap();
    at_lp1
        .set_position_pulses(&robot.joints_to_pulses(&lp1))
        .unwrap();
    let al = robot
        .inverse(
            &Pose {
                x: 0.0,
                y: 100.0,
                z: 83.0,
                yaw: 90.0,
            },
            Posture::Right,
            None,
        )
        .unwrap();
    let seat = Pose {
        x: 0.0,
        y: 300.0,
        z: 83.0,
        yaw: 90.0,
    };
    c.bench_function("plan_approach_lp1_to_al", |b| {
        b.iter_batched_ref(
            || at_lp1.clone(),
            |vg| black_box(vg.plan_approach(&al, &seat, 80.0).unwrap()),
            BatchSize::SmallInput,
        )
    });
    // The same with every entry timed by the line's law run to its end (no budget).
    let mut exhaustive = at_lp1.clone();
    exhaustive.set_blend_search(BlendSearch::Exhaustive);
    c.bench_function("plan_approach_lp1_to_al_exhaustive", |b| {
        b.iter_batched_ref(
            || exhaustive.clone(),
            |vg| black_box(vg.plan_approach(&al, &seat, 80.0).unwrap()),
            BatchSize::SmallInput,
        )
    });
    // With the whole timing law run ahead, for the duration (`wrc plan`).
    c.bench_function("plan_line_250mm", |b| {
        b.iter_batched_ref(
            || fresh.clone(),
            |vg| black_box(vg.plan_line(&LINE_END).unwrap()),
            BatchSize::SmallInput,
        )
    });
}

criterion_group!(benches, cycle);
criterion_main!(benches);
