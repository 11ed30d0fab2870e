//! Fuzz the compiler: arbitrary bytes (as lossy UTF-8) → `compile` must not panic, whatever
//! the input. A program that compiles must round-trip through its binary form and run in
//! the VM for a bounded budget without panicking, its requests answered, or failed with a
//! host's code (a TRY's handlers run), as the input's bytes choose; its diagnostics must
//! render.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wrc_lang::{compile, Program, Resume, Step, Vm, VmIo, VmLimits};
use wrc_robot::{Pose, Robot};

struct Io(u32);

impl VmIo for Io {
    fn input(&self, n: u8) -> bool {
        n < 32 && self.0 & (1 << n) != 0
    }
    fn here(&self) -> Pose {
        Pose {
            x: 300.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let source = String::from_utf8_lossy(data);
    let robot = Robot::paper_default();
    let compiled = compile(&source, "fuzz.wrl", &robot);
    for d in &compiled.diagnostics {
        let _ = d.render("fuzz.wrl", &source);
    }
    let Some(program) = compiled.program else {
        return;
    };
    let back = Program::from_bytes(&program.to_bytes()).expect("a compiled program decodes");
    assert!(back == program, "the binary form round-trips");
    let _ = program.listing();
    let mut vm = Vm::new(VmLimits::default());
    if vm.load(&back).is_err() {
        return;
    }
    let mut io = Io(data.first().copied().unwrap_or(0).into());
    for k in 0..100 {
        match vm.run(&back, 1000, &mut io) {
            Step::Budget => {}
            Step::Yield(_) => match data.get(k).copied().unwrap_or(0) % 4 {
                0 => vm.fail(212, "wafer not sensed"),
                1 => vm.fail(131, "the slot is empty"),
                _ => vm.resume(Resume::Ok),
            },
            Step::Done | Step::Fault(_) | Step::Break(_) => break,
        }
    }
});
