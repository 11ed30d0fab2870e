//! Shared helpers: the default robot, compiling without errors, and a host that runs a
//! program to its end and records what it asked for.

use wrc_lang::{compile, Program, Request, Resume, RuntimeError, Step, Vm, VmIo, VmLimits};
use wrc_robot::{Pose, Robot};

/// The robot of the embedded default configuration (the paper's 300 mm robot).
pub fn robot() -> Robot {
    wrc_config::Config::embedded_default().robot
}

/// Compile `source` for the default robot; panic with the rendered diagnostics on an error.
pub fn program(source: &str) -> Program {
    let compiled = compile(source, "test.wrl", &robot());
    match compiled.program {
        Some(p) if compiled.errors() == 0 => p,
        _ => panic!("{}", compiled.render("test.wrl", source)),
    }
}

/// A host: inputs as a bit mask, the pose HERE() returns.
#[derive(Debug, Clone, Copy, Default)]
pub struct Io {
    pub inputs: u32,
    pub here: Pose,
}

impl VmIo for Io {
    fn input(&self, n: u8) -> bool {
        n < 32 && self.inputs & (1 << n) != 0
    }
    fn here(&self) -> Pose {
        self.here
    }
}

/// What a run produced.
#[derive(Debug, Default)]
pub struct Run {
    /// Every request, in order.
    pub requests: Vec<Request>,
    /// The text of every PRINT, in order.
    pub printed: Vec<String>,
    /// The fault that ended the run, if any.
    pub fault: Option<RuntimeError>,
}

/// Run `program` to its end, answering every request with `Resume::Ok` (an input wait sets
/// the input, so it is met). Panics after a million budget rounds.
pub fn run(program: &Program) -> Run {
    run_with(program, Io::default(), VmLimits::default())
}

/// [`run`] with a host and limits.
pub fn run_with(program: &Program, mut io: Io, limits: VmLimits) -> Run {
    let mut vm = Vm::new(limits);
    vm.load(program).expect("the program fits the VM");
    let mut out = Run::default();
    for _ in 0..1_000_000 {
        match vm.run(program, 97, &mut io) {
            Step::Budget => {}
            Step::Done => return out,
            Step::Fault(e) => {
                out.fault = Some(e);
                return out;
            }
            Step::Yield(r) => {
                if r == Request::Print {
                    out.printed.push(vm.print_text().to_string());
                }
                if let Request::WaitInput { n, value, .. } = r {
                    if value {
                        io.inputs |= 1 << n;
                    } else {
                        io.inputs &= !(1 << n);
                    }
                }
                out.requests.push(r);
                vm.resume(Resume::Ok);
            }
        }
    }
    panic!("the program did not end");
}

/// The PRINT output of `source`, which must run without a fault.
pub fn printed(source: &str) -> Vec<String> {
    let r = run(&program(source));
    assert_eq!(r.fault, None, "{source}");
    r.printed
}
