//! Counting allocator: planning and producing periods allocate nothing.

use wrc_alloc_count::{heap_calls, CountingAllocator};
use wrc_motion::{BrakeLimits, Period, Profile, Status};
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
            vg.restore(&stopper.state());
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
            assert_eq!(
                heap_calls().allocations - before,
                0,
                "{profile:?} at {period} s allocated"
            );
        }
    }
}
