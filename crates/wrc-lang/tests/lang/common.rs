//! Shared helpers: the default robot, compiling without errors, and a host that runs a
//! program to its end and records what it asked for.

use wrc_lang::{
    compile, Answer, CellInfo, Program, Request, Resume, RuntimeError, Step, Text, Vm, VmIo,
    VmLimits,
};
use wrc_robot::{Pose, Robot};

/// Stored programs and points files, by name: what `INCLUDE`, `CALL PROGRAM` and named
/// points read (the controller's program store, in memory).
#[derive(Default)]
pub struct Store {
    pub programs: std::collections::HashMap<String, String>,
    pub points: std::collections::HashMap<String, String>,
}

impl wrc_lang::Sources for Store {
    fn program(&self, name: &str) -> Result<String, String> {
        self.programs
            .get(name)
            .cloned()
            .ok_or_else(|| format!("there is no stored program named {name}"))
    }

    fn points(&self, name: &str) -> Result<Option<String>, String> {
        Ok(self.points.get(name).cloned())
    }
}

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
    /// Its text.
    pub error_text: String,
}

/// The answer of the test's cell to a request: every slot holds wafer `W<slot>`, stations
/// have 25 slots 10 mm apart 200 mm from their approach pose at POSE(300, 0, 0, 0), the hand
/// is empty, TEACH stores the pose `HERE()` gives (or zero joints).
pub fn answer(request: &Request, io: &Io) -> Resume {
    match request {
        Request::Cell(q) => Resume::Value(match q.info {
            CellInfo::SlotState => Answer::Number(1.0),
            CellInfo::SlotWafer => {
                // Written without allocating: the allocation tests answer with it.
                let mut t = Text::EMPTY;
                let _ = std::fmt::Write::write_fmt(&mut t, format_args!("W{}", q.slot));
                Answer::Text(t)
            }
            CellInfo::HandWafer => Answer::Text(Text::EMPTY),
            CellInfo::Slots => Answer::Number(25.0),
            CellInfo::Pitch => Answer::Number(10.0),
            CellInfo::Pose => Answer::Pose(Pose {
                x: 300.0,
                y: 0.0,
                z: 0.0,
                yaw: 0.0,
            }),
            CellInfo::Approach => Answer::Number(200.0),
            other => panic!("{other:?}"),
        }),
        Request::Teach { joints: true, .. } => Resume::Value(Answer::Joints([0.0; 16])),
        Request::Teach { .. } => Resume::Value(Answer::Pose(io.here)),
        _ => Resume::Ok,
    }
}

/// Run `program` to its end, answering every request as [`answer`] does (an input wait
/// sets the input, so it is met). Panics after a million budget rounds.
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
                out.error_text = vm.error_text().to_string();
                return out;
            }
            Step::Break(at) => panic!("stopped at {at:?}"),
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
                vm.resume(answer(&r, &io));
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
