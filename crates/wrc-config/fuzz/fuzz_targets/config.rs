//! Fuzz the configuration loader: any text (a file `--config` names is read as UTF-8) →
//! `Config::parse` gives a configuration or an error that names the file, never a panic.
//! An accepted configuration must start a controller as `wrc up` builds one: the Velocity
//! Generator takes its robot and settings, plans a short jog of every axis and runs it for
//! a bounded number of periods; the robot's home pose converts to pulses and back; and the
//! trace recorder's ring for `[trace]` at the motion period fits in memory (about 1 GB of
//! samples at most).
#![no_main]

use libfuzzer_sys::fuzz_target;
use wrc_config::Config;
use wrc_motion::{BrakeLimits, Period, Status, VelocityGenerator};
use wrc_robot::MAX_AXES;
use wrc_trace::{ring_bytes_per_second, Message, Ring};

const FILE: &str = "fuzz.toml";

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let config = match Config::parse(text, FILE) {
        Ok(config) => config,
        Err(e) => {
            let message = e.to_string();
            assert!(
                message.contains(FILE),
                "the error does not name the file: {message}"
            );
            return;
        }
    };
    assert_eq!(config.text, text);
    let robot = &config.robot;
    assert!((1..=MAX_AXES).contains(&robot.axis_count()));
    assert!(!config.boards.is_empty(), "a configuration without a board");
    let home = robot.home();
    let _ = robot.forward(&home);
    let pulses = robot.joints_to_pulses(&home);
    let _ = robot.pulses_to_joints(&pulses);

    let mut generator = VelocityGenerator::new(robot.clone(), config.motion)
        .expect("validated motion settings make a generator");
    let mut period = Period::default();
    for axis in 0..robot.axis_count() {
        if generator.plan_jog(axis, 100).is_err() {
            continue;
        }
        for _ in 0..64 {
            if !matches!(generator.next_period(&mut period), Status::Working) {
                break;
            }
        }
        generator.stop(BrakeLimits::Full);
        for _ in 0..8 {
            if !matches!(generator.next_period(&mut period), Status::Working) {
                break;
            }
        }
        let _ = generator.set_position_pulses(&pulses);
    }

    // The trace recorder's ring, sized as the controller sizes it: within what a machine
    // holds (about 1 GB of samples at most, docs/trace.md), and allocated here when small (a
    // large one only slows the fuzzer down).
    let period_ns = (config.motion.period_s * 1e9).round().max(1.0) as u64;
    let bytes = ring_bytes_per_second(period_ns) * config.trace.seconds
        + (config.trace.messages * size_of::<Message>()) as f64;
    assert!(bytes <= 1.5e9, "the trace ring needs {bytes} bytes");
    if bytes <= 16e6 {
        drop(Ring::for_seconds(
            config.trace.seconds,
            period_ns,
            config.trace.messages,
        ));
    }
});
