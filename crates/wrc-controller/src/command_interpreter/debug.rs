//! The program debugger's verbs: `BREAK` (breakpoints, kept by the controller across runs
//! and applied to the program that runs), `STEP` (one statement of a paused program, into,
//! over or out of a call; its motions at the step speed) and `VARS` (the running program's
//! variables, one `EVT VAR` line each). Allocation-free, like the rest of the cycle: the
//! lines are formatted into fixed buffers.

use std::fmt::Write as _;

use wrc_board::MotionBoard;
use wrc_lang::{StepMode, MAX_BREAKPOINTS};
use wrc_protocol::{BreakArg, Code, Event, ReplyTo, SourceLine, StepKind, VarNames};
use wrc_rt::FixedText;

use super::program::{file_label, ProgramWait};
use super::{deliver, CommandInterpreter};
use crate::messages::SourceId;

/// Most variables one `VARS` lists (the rest are counted: `more=<n>`).
pub const MAX_VARS_LISTED: usize = 64;

/// The breakpoints: source lines (of the program, or of a library: `file`).
#[derive(Debug, Clone, Copy)]
pub(super) struct Breakpoints {
    list: [Option<SourceLine>; MAX_BREAKPOINTS],
}

impl Default for Breakpoints {
    fn default() -> Breakpoints {
        Breakpoints {
            list: [None; MAX_BREAKPOINTS],
        }
    }
}

impl Breakpoints {
    fn iter(&self) -> impl Iterator<Item = &SourceLine> {
        self.list.iter().flatten()
    }
}

/// `12` or `lib:30`.
fn write_line(out: &mut impl std::fmt::Write, l: &SourceLine) {
    let _ = match &l.file {
        Some(f) => write!(out, "{}:{}", f.as_str(), l.line),
        None => write!(out, "{}", l.line),
    };
}

/// A `VARS` name: the variable and, for `A[3]`, the element.
fn var_and_index(text: &str) -> Result<(&str, Option<u32>), &'static str> {
    let Some((name, rest)) = text.split_once('[') else {
        return Ok((text, None));
    };
    let index = rest
        .strip_suffix(']')
        .ok_or("an element is written NAME[i]")?;
    if index.contains(',') {
        return Err("VARS takes one index: a two-dimensional array's elements are numbered row by row (M[i * columns + j]), or ask for the whole array");
    }
    index
        .parse::<u32>()
        .map(|i| (name, Some(i)))
        .map_err(|_| "an index is a whole number from 0")
}

impl<B: MotionBoard> CommandInterpreter<B> {
    /// The source file of `line` in the running program: its index.
    fn file_index(&self, line: &SourceLine) -> Option<u16> {
        let p = self.program.as_ref()?;
        match &line.file {
            None => Some(0),
            Some(name) => (0..p.program.files().len() as u16)
                .find(|&i| file_label(&p.program, i) == name.as_str()),
        }
    }

    /// Give the VM the breakpoints that fall on statements of the running program.
    pub(super) fn apply_breakpoints(&mut self) {
        let mut pcs = [0u32; MAX_BREAKPOINTS];
        let mut n = 0;
        if let Some(p) = self.program.as_ref() {
            for l in self.breaks.iter() {
                let Some(file) = self.file_index(l) else {
                    continue;
                };
                if let Some((pc, _)) = p.program.statement_at_line(file, l.line) {
                    pcs[n] = pc;
                    n += 1;
                }
            }
        }
        self.vm.set_breakpoints(&pcs[..n]);
    }

    /// `BREAK …`.
    pub(super) fn break_command(&mut self, from: SourceId, to: ReplyTo, arg: BreakArg) {
        let mut note = FixedText::<40>::new();
        match arg {
            BreakArg::List => {}
            BreakArg::Clear(None) => self.breaks = Breakpoints::default(),
            BreakArg::Clear(Some(l)) => {
                for b in self.breaks.list.iter_mut() {
                    if b.is_some_and(|b| b == l) {
                        *b = None;
                    }
                }
            }
            BreakArg::Set(mut l) => {
                // On a running program, a line without a statement moves to the next one
                // that has one (as the VM stops there).
                if self.program.is_some() {
                    let resolved = self.file_index(&l).and_then(|file| {
                        let p = self.program.as_ref()?;
                        p.program.statement_at_line(file, l.line)
                    });
                    match resolved {
                        Some((_, actual)) => l.line = actual,
                        None => {
                            return self.nak(
                                from,
                                to,
                                Code::BadArgument,
                                "no statement on that line or after it in the running program (a library is named lib:line)",
                            )
                        }
                    }
                    let _ = write!(note, "line={} ", l.line);
                }
                if !self.breaks.iter().any(|b| *b == l) {
                    match self.breaks.list.iter_mut().find(|b| b.is_none()) {
                        Some(slot) => *slot = Some(l),
                        None => {
                            return self.nak(
                                from,
                                to,
                                Code::Busy,
                                "64 breakpoints are set; BREAK CLEAR some first",
                            )
                        }
                    }
                }
            }
        }
        self.apply_breakpoints();
        let mut body = FixedText::<800>::new();
        let _ = write!(body, "{}breaks=", note.as_str());
        let mut first = true;
        for l in self.breaks.iter() {
            if !first {
                let _ = body.write_str(",");
            }
            first = false;
            write_line(&mut body, l);
        }
        if first {
            let _ = body.write_str("none");
        }
        let line = self.buf.ack(to, body.as_str());
        deliver(&self.io.out, from, line);
    }

    /// `STEP [INTO|OVER|OUT]`: run the paused program to the end of one step.
    pub(super) fn step_command(&mut self, from: SourceId, to: ReplyTo, kind: StepKind) {
        let Some(p) = self.program.as_mut() else {
            return self.nak(from, to, Code::NoProgram, "no program is running");
        };
        if p.wait == ProgramWait::Operator {
            return self.nak(
                from,
                to,
                Code::ProgramRunning,
                "the program waits for the operator: answer with CONTINUE [answer]",
            );
        }
        if !p.paused {
            return self.nak(
                from,
                to,
                Code::ProgramRunning,
                "the program is running; PAUSE it or stop it at a BREAK first",
            );
        }
        p.paused = false;
        p.stepping = true;
        let name = p.name;
        self.vm.step(match kind {
            StepKind::Into => StepMode::Into,
            StepKind::Over => StepMode::Over,
            StepKind::Out => StepMode::Out,
        });
        let line = self.buf.ack(to, "");
        deliver(&self.io.out, from, line);
        self.program_event(name, "RUNNING", "step");
    }

    /// `VARS [<name> …]`: one `EVT VAR <name> <type> <value>` line per variable, then
    /// `ACK vars=<n>`.
    pub(super) fn vars_command(&mut self, from: SourceId, to: ReplyTo, names: &VarNames) {
        let Some(p) = self.program.as_ref() else {
            return self.nak(
                from,
                to,
                Code::NoProgram,
                "no program is running; VARS reads a running program's variables",
            );
        };
        // Disjoint fields: the program and the VM are read while the reply buffer is written.
        let program = &p.program;
        let (vm, buf, out) = (&self.vm, &mut self.buf, &self.io.out);
        let mut listed = 0;
        let mut more = 0;
        let mut send = |text: &FixedText<900>| {
            let line = buf.event(to.checksum, &Event::Var(text.as_str()));
            out.send(from, line);
        };
        if names.is_empty() {
            for v in vm.variables(program) {
                if listed == MAX_VARS_LISTED {
                    more += 1;
                    continue;
                }
                let mut text = FixedText::new();
                write_view(&mut text, vm, program, &v, None, v.name);
                send(&text);
                listed += 1;
            }
        } else {
            for name in names.iter() {
                let mut text = FixedText::new();
                match var_and_index(name.as_str()) {
                    Ok((var, index)) => match vm.variable(program, var) {
                        Some(v) => write_view(&mut text, vm, program, &v, index, name.as_str()),
                        None => {
                            let _ = write!(text, "{} unknown", name.as_str());
                        }
                    },
                    Err(why) => {
                        let _ = write!(text, "{} unknown ({why})", name.as_str());
                    }
                }
                send(&text);
                listed += 1;
            }
        }
        let mut body = FixedText::<40>::new();
        let _ = write!(body, "vars={listed}");
        if more > 0 {
            let _ = write!(body, " more={more}");
        }
        let line = self.buf.ack(to, body.as_str());
        deliver(&self.io.out, from, line);
    }
}

/// `<name> <type>[<n>] <value>` of one variable (`index`: one element).
fn write_view(
    out: &mut FixedText<900>,
    vm: &wrc_lang::Vm,
    program: &wrc_lang::Program,
    v: &wrc_lang::VarView<'_>,
    index: Option<u32>,
    shown: &str,
) {
    let _ = write!(out, "{shown} {}", v.ty.name());
    if v.len > 1 && index.is_none() {
        let _ = write!(out, "[{}]", v.len);
    }
    let _ = out.write_str(" ");
    if vm.write_variable(program, v, index, out).is_err() || out.truncated() {
        let _ = out.write_str("...");
    }
}
