use wrc_motion::{BrakeLimits, Brake1d, Period, Profile};
use wrc_robot::{Pose, Posture};
use crate::common::*;

#[test]
fn scratch_line() {
    let a = Pose { x: 250.0, y: -250.0, z: 0.0, yaw: 0.0 };
    let b = Pose { x: 250.0, y: 250.0, z: 100.0, yaw: 40.0 };
    let b2 = Pose { x: 250.0, y: 250.0, z: 0.0, yaw: 0.0 };
    for b in [b, b2] {
    for pct in [20.0, 50.0, 100.0] {
        for frac in [0.05, 0.15, 0.5, 0.9] {
            for limits in [BrakeLimits::Override, BrakeLimits::Full] {
                let ts = 0.001;
                let mut vg = generator(Profile::Fir, ts, pct);
                let robot = vg.robot().clone();
                let start = robot.inverse(&a, Posture::Right, None).unwrap();
                vg.set_position_pulses(&robot.joints_to_pulses(&start)).unwrap();
                let a0 = vg.pose();
                let info = vg.plan_line(&b).unwrap();
                let k = (info.periods as f64 * frac) as usize;
                let sigma = |q: &wrc_robot::Joints| { let p = robot.forward(q); ((p.x-a0.x).powi(2)+(p.y-a0.y).powi(2)+(p.z-a0.z).powi(2)).sqrt() };
                let mut probe = vg.clone();
                let mut p = Period::default();
                let mut xs = vec![sigma(&probe.joints())];
                for _ in 0..k+1 { probe.next_period(&mut p); xs.push(sigma(&p.exact)); }
                let (xm, x0, xp) = (xs[k-1], xs[k], xs[k+1]);
                let v = (xp - xm) / (2.0*ts); let acc = (xp - 2.0*x0 + xm)/(ts*ts);
                let s = if limits == BrakeLimits::Full { 1.0 } else { pct/100.0 };
                let l = vg.settings().line;
                let r = Brake1d::new(0.0, v, acc, l.max_accel_mm_s2*s*s, l.max_jerk_mm_s3*s*s*s);
                let run = run_with(&mut vg, 1_000_000, |vg, i| if i == k { vg.stop(limits) });
                let t = (run.periods.len() - k) as f64 * ts;
                let d = sigma(&run.periods.last().unwrap().exact) - x0;
                eprintln!("{} {pct} {frac} {limits:?}: v {v:.1} a {acc:.0}: {:.0} ms vs {:.0} ms ({:.3}), {d:.2} mm vs {:.2} ({:.3})", b.z, t*1e3, r.duration()*1e3, t/r.duration(), r.stop_position(), d/r.stop_position());
            }
        }
    }}
}
