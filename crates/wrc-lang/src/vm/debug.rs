//! The debugger's side of the VM: breakpoints (statement starts), single steps (into,
//! over a call, out of a call), the call stack and the variables' values, read without
//! allocating into the caller's buffer. Stops happen before a statement runs, and only
//! when a breakpoint is set or a step is under way: otherwise the run loop pays one flag.

use core::fmt;

use crate::bytecode::{Program, SourcePos};
use crate::value::{Ty, Value};

use super::format::write_value;
use super::Vm;

/// Most breakpoints at once.
pub const MAX_BREAKPOINTS: usize = 64;

/// How far a single step goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepMode {
    /// To the next statement, into a called SUB or FUNCTION too.
    Into,
    /// To the next statement of this call (a CALL runs whole).
    Over,
    /// Until the running SUB or FUNCTION has returned.
    Out,
}

#[derive(Debug, Clone)]
pub(super) struct Debugger {
    breaks: [u32; MAX_BREAKPOINTS],
    count: usize,
    step: Option<(StepMode, usize)>,
    /// Do not stop at this instruction (the statement a break or a step starts from).
    skip: Option<usize>,
}

impl Default for Debugger {
    fn default() -> Debugger {
        Debugger {
            breaks: [0; MAX_BREAKPOINTS],
            count: 0,
            step: None,
            skip: None,
        }
    }
}

impl Debugger {
    pub(super) fn new_run(&mut self) {
        self.step = None;
        self.skip = None;
    }

    pub(super) fn armed(&self) -> bool {
        self.count > 0 || self.step.is_some()
    }

    /// Whether to stop before instruction `pc` at call depth `depth`: its position.
    pub(super) fn stop_here(
        &mut self,
        program: &Program,
        pc: usize,
        depth: usize,
    ) -> Option<SourcePos> {
        if self.skip.take() == Some(pc) || !program.starts_statement(pc) {
            return None;
        }
        let at_break = self.breaks[..self.count].contains(&(pc as u32));
        let step_done = match self.step {
            None => false,
            Some((StepMode::Into, _)) => true,
            Some((StepMode::Over, d)) => depth <= d,
            Some((StepMode::Out, d)) => depth < d,
        };
        if !(at_break || step_done) {
            return None;
        }
        self.step = None;
        // Going on from here runs this statement: do not stop at it again at once.
        self.skip = Some(pc);
        Some(program.position(pc).unwrap_or_default())
    }
}

/// A variable as the debugger shows it: its name, type, scope and size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VarView<'p> {
    /// Its name.
    pub name: &'p str,
    /// Its type (an array's elements').
    pub ty: Ty,
    /// A local of the running SUB or FUNCTION (else a global).
    pub local: bool,
    /// Elements (1 for a variable).
    pub len: u32,
    /// Its first slot.
    slot: u32,
}

impl Vm {
    /// Stop before the statements starting at these instructions (from
    /// [`Program::statement_at_line`]); at most [`MAX_BREAKPOINTS`] are kept. Kept across
    /// [`Vm::load`].
    pub fn set_breakpoints(&mut self, pcs: &[u32]) {
        let n = pcs.len().min(MAX_BREAKPOINTS);
        self.debug.breaks[..n].copy_from_slice(&pcs[..n]);
        self.debug.count = n;
    }

    /// Run to the end of one step ([`StepMode`]) and stop there with [`super::Step::Break`]
    /// (also when the program waits for the host on the way: a motion statement steps as
    /// one statement).
    pub fn step(&mut self, mode: StepMode) {
        self.debug.step = Some((mode, self.frames.len()));
    }

    /// Cancel a step under way (the program runs on to its next breakpoint).
    pub fn cancel_step(&mut self) {
        self.debug.step = None;
    }

    /// Whether a step is under way.
    pub fn stepping(&self) -> bool {
        self.debug.step.is_some()
    }

    /// The calls under way, innermost first: each routine's index in
    /// [`Program::routines`] and where it was called from.
    pub fn call_stack<'a>(
        &'a self,
        program: &'a Program,
    ) -> impl Iterator<Item = (u32, SourcePos)> + 'a {
        self.frames.iter().rev().map(move |f| {
            let at = program
                .position(f.ret.saturating_sub(1) as usize)
                .unwrap_or_default();
            (f.routine, at)
        })
    }

    /// The variables in scope: the running call's parameters and locals, then the globals
    /// (hidden slots left out).
    pub fn variables<'a>(&'a self, program: &'a Program) -> impl Iterator<Item = VarView<'a>> + 'a {
        let frame = self
            .frames
            .last()
            .and_then(|f| program.routines.get(f.routine as usize));
        let locals = frame.into_iter().flat_map(|r| {
            r.locals
                .iter()
                .enumerate()
                .filter(|(_, v)| !v.hidden)
                .map(|(i, v)| VarView {
                    name: &v.name,
                    ty: v.ty,
                    local: true,
                    len: v.len,
                    slot: i as u32,
                })
        });
        let globals = program
            .variables
            .iter()
            .enumerate()
            .filter(|(_, v)| !v.hidden)
            .map(|(i, v)| VarView {
                name: &v.name,
                ty: v.ty,
                local: false,
                len: v.len,
                slot: i as u32,
            });
        locals.chain(globals)
    }

    /// The variable `name` (case-insensitive) in scope: a local of the running call first.
    pub fn variable<'a>(&'a self, program: &'a Program, name: &str) -> Option<VarView<'a>> {
        self.variables(program)
            .find(|v| v.name.eq_ignore_ascii_case(name))
    }

    fn value_at(&self, v: &VarView<'_>, index: u32) -> Option<&Value> {
        let slot = (v.slot + index) as usize;
        if v.local {
            let base = self.frames.last()?.base as usize;
            self.locals.get(base + slot)
        } else {
            self.vars.get(slot)
        }
    }

    /// Write a variable's value as the debugger shows it (strings quoted; an array's
    /// elements comma-separated, as many as `out` takes; `index`: one element).
    pub fn write_variable(
        &self,
        program: &Program,
        v: &VarView<'_>,
        index: Option<u32>,
        out: &mut impl fmt::Write,
    ) -> fmt::Result {
        match index {
            Some(i) if i < v.len => match self.value_at(v, i) {
                Some(value) => write_value(out, program, value, true),
                None => Ok(()),
            },
            Some(_) => out.write_str("(index out of range)"),
            None if v.len <= 1 => match self.value_at(v, 0) {
                Some(value) => write_value(out, program, value, true),
                None => Ok(()),
            },
            None => {
                for i in 0..v.len {
                    if i > 0 {
                        out.write_str(",")?;
                    }
                    if let Some(value) = self.value_at(v, i) {
                        write_value(out, program, value, true)?;
                    }
                }
                Ok(())
            }
        }
    }
}
