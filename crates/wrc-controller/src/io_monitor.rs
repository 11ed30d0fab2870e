//! I/O Monitor task (Table 1: priority 45, 100 ms): reads every board's digital inputs,
//! publishes each changed bit as `EVT INPUT <n> <0|1>` to every client, and applies the
//! outputs the Command Interpreter requested (OUT, a transfer's vacuum valve). Released by
//! its period and by every output request ([`Shared::set_output`]), so an output is applied
//! at once; it then releases the Command Interpreter, which may be waiting for it.
//!
//! Real-time promise: DPRAM reads and writes and lock-free queue sends only; no allocation,
//! no blocking, no printing.

use std::fmt::Write as _;

use std::sync::atomic::Ordering;
use std::sync::Arc;
use wrc_rt::FixedText;

use wrc_board::MotionBoard;
use wrc_rt::ipc::MessageQueue;
use wrc_rt::Notify;
use wrc_rt::{CycleContext, Task};

use crate::messages::{OutLine, SourceId};
use crate::shared::Shared;

/// The I/O Monitor.
pub struct IoMonitor<B: MotionBoard> {
    board: B,
    shared: Arc<Shared>,
    events: Vec<Arc<MessageQueue<OutLine>>>,
    previous: [u32; 4],
    first: bool,
    applied: Option<Arc<dyn Notify>>,
}

impl<B: MotionBoard> IoMonitor<B> {
    /// An I/O Monitor that sends events to every queue in `events` (one per I/O task).
    pub fn new(board: B, shared: Arc<Shared>, events: Vec<Arc<MessageQueue<OutLine>>>) -> Self {
        IoMonitor {
            board,
            shared,
            events,
            previous: [0; 4],
            first: true,
            applied: None,
        }
    }

    /// Wake `notify` (the Command Interpreter) whenever this task has applied new outputs.
    pub fn with_applied(mut self, notify: Arc<dyn Notify>) -> Self {
        self.applied = Some(notify);
        self
    }

    /// Read the inputs (and write the outputs) once now, before any task runs, so the
    /// controller never serves a request on inputs it has not read: a transfer sent the
    /// moment the host port opens judges the station's interlock and the vacuum sensor on
    /// the board's real inputs.
    pub fn primed(mut self) -> Self {
        self.step();
        self
    }

    fn broadcast(&self, text: &[u8]) {
        for q in &self.events {
            let _ = q.try_send(OutLine::new(SourceId::NONE, text));
        }
    }

    /// One period (public for tests that step the task by hand).
    pub fn step(&mut self) {
        if self.shared.board_dead.load(Ordering::Acquire) {
            // A board that does not answer has stale inputs and may lose what is written.
            return;
        }
        // Inputs not (or no longer) real: the first read, or the first since a board stopped
        // answering (the Pulse Generator cleared the flag). Every output is written again
        // then: a restarted board may not hold them.
        let rewrite = !self.shared.io_ready.load(Ordering::Acquire);
        for b in 0..self.board.board_count().min(4) {
            let wanted = self.shared.outputs[b].load(Ordering::Acquire);
            if rewrite || self.board.outputs(b) != wanted {
                self.board.write_outputs(b, wanted);
                if let Some(notify) = &self.applied {
                    notify.notify();
                }
            }
            let inputs = self.board.read_inputs(b);
            self.shared.inputs[b].store(inputs, Ordering::Release);
            let changed = inputs ^ self.previous[b];
            if !self.first && changed != 0 {
                for bit in 0..32u32 {
                    if changed & (1 << bit) != 0 {
                        let mut line = FixedText::<48>::new();
                        let n = 32 * b as u32 + bit;
                        let on = u8::from(inputs & (1 << bit) != 0);
                        let _ = writeln!(line, "EVT INPUT {n} {on}");
                        self.broadcast(line.as_bytes());
                    }
                }
            }
            self.previous[b] = inputs;
        }
        self.shared.io_samples.fetch_add(1, Ordering::AcqRel);
        if rewrite {
            self.shared.io_ready.store(true, Ordering::Release);
        }
        self.first = false;
    }
}

impl<B: MotionBoard + 'static> Task for IoMonitor<B> {
    fn cycle(&mut self, _ctx: &CycleContext) {
        self.step();
    }
}
