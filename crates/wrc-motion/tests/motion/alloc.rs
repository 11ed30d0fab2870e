//! Counting allocator: planning, producing periods and stopping (STOP and ESTOP, PTP and
//! lines, in this generator or another one) allocate nothing, nor do the PTP blends'
//! searches and their fallbacks.

use wrc_alloc_count::{heap_calls, CountingAllocator};
use wrc_motion::{BlendSearch, BrakeLimits, EntryRule, Goal, Period, Profile, Status};
use wrc_robot::{Pose, Posture};

use crate::common::generator;

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

#[test]
fn planning_and_periods_allocate_nothing() {
    wrc_alloc_count::assert_installed();
    for profile in [Profile::Fir, Profile::Paper { mask_len: 20 }] {
        for period in [0.01, 0.001] {
            let mut vg = generator(profile, period, 100.0);
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
            let mut out = Period::default();
            let mut stopper = generator(profile, period, 100.0);
            let before = heap_calls().allocations;
            // A straight line, stopped half-way, then a PTP and a jog to the end.
            vg.plan_line(&Pose {
                x: 300.0,
                y: 100.0,
                z: 50.0,
                yaw: 30.0,
            })
            .unwrap();
            let mut k = 0;
            while vg.next_period(&mut out) != Status::Idle && vg.is_moving() {
                k += 1;
                if k == 40 {
                    vg.stop(BrakeLimits::Override);
                }
            }
            // A line started the real-time way (its law computed as it runs), stopped
            // half-way by another generator from the state reached (as the controller's
            // Pulse Generator does, with derivatives computed on the spot).
            let before_line = heap_calls().allocations;
            vg.start_line(&Pose {
                x: 250.0,
                y: -150.0,
                z: 10.0,
                yaw: -20.0,
            })
            .unwrap();
            for _ in 0..30 {
                vg.next_period(&mut out);
            }
            stopper.restore(&vg.state());
            stopper.stop(BrakeLimits::Override);
            while stopper.is_moving() {
                stopper.next_period(&mut out);
            }
            let line_allocations = heap_calls().allocations - before_line;
            assert_eq!(
                line_allocations, 0,
                "{profile:?} at {period} s: a started line allocated"
            );
            // The same with ESTOP below 100 %: the law rescaled to real time and braked with
            // the full limits, in another generator, then in this one.
            vg.restore(&stopper.state());
            vg.set_speed_pct(40.0).unwrap();
            vg.start_line(&Pose {
                x: 300.0,
                y: 100.0,
                z: 50.0,
                yaw: 30.0,
            })
            .unwrap();
            for _ in 0..30 {
                vg.next_period(&mut out);
            }
            stopper.restore(&vg.state());
            stopper.stop(BrakeLimits::Full);
            vg.stop(BrakeLimits::Override);
            for _ in 0..3 {
                vg.next_period(&mut out);
            }
            vg.stop(BrakeLimits::Full);
            while vg.is_moving() {
                vg.next_period(&mut out);
            }
            while stopper.is_moving() {
                stopper.next_period(&mut out);
            }
            let line_allocations = heap_calls().allocations - before_line;
            assert_eq!(
                line_allocations, 0,
                "{profile:?} at {period} s: an ESTOP on a line allocated"
            );
            // PTP moves: STOP, ESTOP, STOP then ESTOP, and the goal and exact resume.
            for (first, then) in [
                (BrakeLimits::Override, None),
                (BrakeLimits::Full, None),
                (BrakeLimits::Override, Some(BrakeLimits::Full)),
            ] {
                let mut t = vg.joints();
                t[0] += 30.0;
                t[3] += 20.0;
                vg.plan_ptp(&t).unwrap();
                for _ in 0..20 {
                    vg.next_period(&mut out);
                }
                vg.stop(first);
                vg.next_period(&mut out);
                if let Some(then) = then {
                    vg.stop(then);
                }
                let goal = vg.goal();
                while vg.is_moving() {
                    vg.next_period(&mut out);
                }
                if let Some(Goal::Joints(target)) = goal {
                    vg.plan_ptp_pulses(&target).unwrap();
                }
                while vg.is_moving() {
                    vg.next_period(&mut out);
                }
            }
            vg.set_speed_pct(100.0).unwrap();
            let mut t = vg.joints();
            t[0] += 30.0;
            vg.plan_ptp(&t).unwrap();
            while vg.is_moving() {
                vg.next_period(&mut out);
            }
            vg.plan_jog(3, 5000).unwrap();
            while vg.is_moving() {
                vg.next_period(&mut out);
            }
            vg.next_period(&mut out);
            // A blended approach (default profile only): planned (Ruckig's calculation
            // included), played into its line, and another one stopped in its first part by
            // another generator, then at full limits after a STOP.
            if profile == Profile::Fir {
                let robot = vg.robot();
                let from = robot
                    .inverse(
                        &Pose {
                            x: 0.0,
                            y: 120.0,
                            z: 20.0,
                            yaw: 90.0,
                        },
                        Posture::Right,
                        None,
                    )
                    .unwrap();
                let via = robot
                    .inverse(
                        &Pose {
                            x: 120.0,
                            y: 0.0,
                            z: 30.0,
                            yaw: 0.0,
                        },
                        Posture::Right,
                        None,
                    )
                    .unwrap();
                let seat = Pose {
                    x: 330.0,
                    y: 0.0,
                    z: 30.0,
                    yaw: 0.0,
                };
                for stop_at in [None, Some(10)] {
                    vg.plan_ptp(&from).unwrap();
                    while vg.is_moving() {
                        vg.next_period(&mut out);
                    }
                    assert!(vg.plan_approach(&via, &seat, 60.0).unwrap());
                    let mut k = 0;
                    while vg.is_moving() {
                        vg.next_period(&mut out);
                        k += 1;
                        if Some(k) == stop_at {
                            stopper.restore(&vg.state());
                            stopper.stop(BrakeLimits::Override);
                            stopper.next_period(&mut out);
                            stopper.stop(BrakeLimits::Full);
                            while stopper.is_moving() {
                                stopper.next_period(&mut out);
                            }
                            vg.stop(BrakeLimits::Full);
                        }
                    }
                }
            }
            assert_eq!(
                heap_calls().allocations - before,
                0,
                "{profile:?} at {period} s allocated"
            );
        }
    }
}

#[test]
fn paths_and_ptp_blends_allocate_nothing() {
    wrc_alloc_count::assert_installed();
    let (_, spec) = crate::path::cases().remove(2);
    for period in [0.01, 0.001] {
        let mut vg = crate::path::at(Profile::Fir, period, 100.0, &spec.start);
        let mut stopper = generator(Profile::Fir, period, 100.0);
        let start = vg.joints();
        let elsewhere = vg
            .robot()
            .inverse(
                &Pose {
                    x: 100.0,
                    y: 250.0,
                    z: 150.0,
                    yaw: 90.0,
                },
                Posture::Right,
                None,
            )
            .unwrap();
        let mut out = Period::default();
        let before = heap_calls().allocations;
        // The admission check; a path at ACCEL 50 % started, held half-way by another
        // generator (with the derivatives computed on the spot), resumed to its end.
        wrc_motion::check_path(vg.robot(), &start, &spec).unwrap();
        vg.set_accel_pct(50.0).unwrap();
        assert!(vg.start_path(&spec).unwrap());
        for _ in 0..(0.6 / period) as usize {
            vg.next_period(&mut out);
        }
        stopper.restore(&vg.state());
        stopper.stop(BrakeLimits::Override);
        while stopper.is_moving() {
            stopper.next_period(&mut out);
        }
        vg.restore(&stopper.state());
        vg.set_accel_pct(100.0).unwrap();
        assert!(vg.start_path(&spec).unwrap());
        while vg.is_moving() {
            vg.next_period(&mut out);
        }
        // The path into a PTP (flowing, its candidates planned with Ruckig), stopped in its
        // PTP part with ESTOP; the PTP part alone to resume.
        vg.plan_ptp(&start).unwrap();
        while vg.is_moving() {
            vg.next_period(&mut out);
        }
        assert!(vg.plan_depart(&spec, &elsewhere, 100.0).unwrap());
        let mut k = 0;
        while vg.is_moving() {
            vg.next_period(&mut out);
            k += 1;
            if k == (2.1 / period) as usize {
                vg.stop(BrakeLimits::Full);
            }
        }
        if vg.plan_depart(&spec, &elsewhere, 100.0).unwrap() {
            while vg.is_moving() {
                vg.next_period(&mut out);
            }
        }
        // A PTP into the path, and a PTP through a via point, each stopped once.
        assert!(vg
            .plan_ptp_into(&start, &spec, 80.0, EntryRule::Free)
            .unwrap());
        while vg.is_moving() {
            vg.next_period(&mut out);
        }
        let end = vg.joints();
        vg.plan_ptp(&elsewhere).unwrap();
        while vg.is_moving() {
            vg.next_period(&mut out);
        }
        let here = vg.joints();
        assert!(vg.plan_ptp_via(&here, &start, &end).unwrap());
        let mut k = 0;
        while vg.is_moving() {
            vg.next_period(&mut out);
            k += 1;
            if k == 20 {
                vg.stop(BrakeLimits::Override);
            }
        }
        assert!(vg.plan_ptp_via(&here, &start, &end).unwrap());
        while vg.is_moving() {
            vg.next_period(&mut out);
        }
        // The searches' fallbacks: with no budget, a PTP into the path enters it at rest and
        // the path into a PTP stops at its end.
        vg.set_blend_search(BlendSearch::Bounded { work: 0 });
        vg.plan_ptp(&elsewhere).unwrap();
        while vg.is_moving() {
            vg.next_period(&mut out);
        }
        assert!(vg
            .plan_ptp_into(&start, &spec, 100.0, EntryRule::Free)
            .unwrap());
        while vg.is_moving() {
            vg.next_period(&mut out);
        }
        vg.plan_ptp(&start).unwrap();
        while vg.is_moving() {
            vg.next_period(&mut out);
        }
        assert!(vg.plan_depart(&spec, &elsewhere, 100.0).unwrap());
        while vg.is_moving() {
            vg.next_period(&mut out);
        }
        assert_eq!(vg.search_stats().fallbacks, 2);
        assert_eq!(
            heap_calls().allocations - before,
            0,
            "paths and blends at {period} s allocated"
        );
    }
}
