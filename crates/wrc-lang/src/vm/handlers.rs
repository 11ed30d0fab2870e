//! Error handling in the VM: raising an error to the innermost TRY whose CATCH is not busy
//! (unwinding the calls and the stack to where the TRY began), RETRY, passing an error on
//! (`Rethrow`), and what `ERR`, `ERRMSG$` and `ERRLINE` read. Nothing here allocates: the
//! TRY stack and the texts are fixed-size.

use core::fmt::Write as _;

use crate::bytecode::{Program, SourcePos};
use crate::error::{RuntimeError, RuntimeErrorKind};
use crate::value::Text;

use super::format::TextBuffer;
use super::{Caught, Handler, State, Step, Vm};

/// Set the error's text: `text`, or its kind's message.
pub(super) fn set_text(buf: &mut TextBuffer, kind: RuntimeErrorKind, text: Option<&str>) {
    buf.clear();
    let _ = match text {
        Some(t) => buf.write_str(t),
        None => write!(buf, "{kind}"),
    };
}

impl Vm {
    /// Raise `kind` at instruction `at` with `text` (else the kind's own message): go to the
    /// innermost TRY that is not handling an error, or end the program. `None` when a TRY
    /// took it (run goes on), the [`Step::Fault`] otherwise.
    pub(super) fn raise(
        &mut self,
        program: &Program,
        kind: RuntimeErrorKind,
        at: usize,
        text: Option<&str>,
    ) -> Option<Step> {
        set_text(&mut self.error_text, kind, text);
        self.raise_kept(program, kind, at)
    }

    /// [`Vm::raise`] with the text already in the error's buffer (the host's).
    pub(super) fn raise_kept(
        &mut self,
        program: &Program,
        kind: RuntimeErrorKind,
        at: usize,
    ) -> Option<Step> {
        let pos = program.position(at).unwrap_or_default();
        let retry = program.statement_of(at);
        self.deliver(program, kind, pos, retry as u32, None)
    }

    /// Hand an error to the innermost free TRY. `retry_pc` is the statement RETRY runs
    /// when the TRY is in the current call; `via_try`: the error comes from the TRY at this
    /// instruction (its CATCH passed it on), which is then the statement to retry.
    fn deliver(
        &mut self,
        program: &Program,
        kind: RuntimeErrorKind,
        pos: SourcePos,
        retry_pc: u32,
        via_try: Option<u32>,
    ) -> Option<Step> {
        if kind.catchable() {
            while self.handlers.last().is_some_and(|h| h.caught.is_some()) {
                self.handlers.pop();
            }
        } else {
            self.handlers.clear();
        }
        let Some(h) = self.handlers.last().copied() else {
            let e = RuntimeError {
                kind,
                line: pos.line,
                col: pos.col,
                file: pos.file,
            };
            self.state = State::Faulted(e);
            self.stack.clear();
            self.frames.clear();
            self.locals.clear();
            return Some(Step::Fault(e));
        };
        // The statement of the TRY's own call that failed: the call that led to the error,
        // when it came from deeper.
        let depth = h.frames as usize;
        let retry = if depth < self.frames.len() {
            let ret = self.frames[depth].ret as usize;
            program.statement_of(ret.saturating_sub(1)) as u32
        } else {
            via_try.unwrap_or(retry_pc)
        };
        if depth < self.frames.len() {
            let base = self.frames[depth].base as usize;
            self.frames.truncate(depth);
            self.locals.truncate(base);
        }
        self.stack.truncate(h.stack as usize);
        let code = kind.code();
        if let Some(top) = self.handlers.last_mut() {
            top.caught = Some(Caught {
                kind,
                code,
                pos,
                retry_pc: retry,
                text: Text::cut(self.error_text.as_str()),
            });
        }
        self.pc = h.catch_pc as usize;
        self.state = State::Running;
        None
    }

    /// `TryBegin`: a TRY starts.
    pub(super) fn try_begin(
        &mut self,
        catch_pc: u32,
        try_pc: usize,
    ) -> Result<(), RuntimeErrorKind> {
        if self.handlers.len() >= self.limits.handlers {
            return Err(RuntimeErrorKind::TryTooDeep);
        }
        self.handlers.push(Handler {
            catch_pc,
            try_pc: try_pc as u32,
            frames: self.frames.len() as u32,
            stack: self.stack.len() as u32,
            caught: None,
        });
        Ok(())
    }

    /// `TryEnd` / `CatchEnd`: the TRY's block or a CATCH clause ended.
    pub(super) fn try_end(&mut self) {
        self.handlers.pop();
    }

    /// `Rethrow`: no CATCH clause took the error; pass it to the TRY around this one.
    pub(super) fn rethrow(&mut self, program: &Program) -> Option<Step> {
        let Some(h) = self.handlers.pop() else {
            return self.raise(
                program,
                RuntimeErrorKind::InvalidProgram("RETHROW without a TRY"),
                self.pc.saturating_sub(1),
                None,
            );
        };
        let Some(caught) = h.caught else {
            return self.raise(
                program,
                RuntimeErrorKind::InvalidProgram("RETHROW outside a CATCH"),
                self.pc.saturating_sub(1),
                None,
            );
        };
        self.error_text.clear();
        let _ = self.error_text.write_str(caught.text.as_str());
        self.deliver(program, caught.kind, caught.pos, h.try_pc, Some(h.try_pc))
    }

    /// `Retry`: run the failed statement of the innermost CATCH's TRY again, with the TRY
    /// in force again.
    pub(super) fn retry(&mut self) -> Result<(), RuntimeErrorKind> {
        let Some(k) = self.handlers.iter().rposition(|h| h.caught.is_some()) else {
            return Err(RuntimeErrorKind::InvalidProgram("RETRY outside a CATCH"));
        };
        self.handlers.truncate(k + 1);
        let h = &mut self.handlers[k];
        let retry = h.caught.take().map_or(h.try_pc, |c| c.retry_pc);
        self.stack.truncate(h.stack as usize);
        self.pc = retry as usize;
        Ok(())
    }

    /// The error the innermost CATCH handles, if one does.
    pub(super) fn caught(&self) -> Option<&Caught> {
        self.handlers.iter().rev().find_map(|h| h.caught.as_ref())
    }

    /// `Ret`: drop the TRYs of the call that returns.
    pub(super) fn drop_frame_handlers(&mut self) {
        let depth = self.frames.len() as u32;
        while self.handlers.last().is_some_and(|h| h.frames > depth) {
            self.handlers.pop();
        }
    }
}
