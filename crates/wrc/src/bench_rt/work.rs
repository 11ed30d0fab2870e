//! Synthetic tasks for `wrc bench rt`: each spins for an execution time drawn from the range
//! the paper measured for it (Table 4), and the Velocity Generator → Pulse Generator →
//! Simulator Manager chain passes pulse batches and positions through the real IPC types.
//! Cycles allocate nothing.

use wrc_rt::clock::{Clock, MonotonicClock};
use wrc_rt::ipc::{MailboxReader, MailboxWriter, SpscReceiver, SpscSender};
use wrc_rt::task::{CycleContext, Task};

/// Execution time range of a task's synthetic work [µs], after the paper's Table 4.
///
/// Table 4 lists min/max; where its maximum is plainly an outlier of the measurement (the
/// Pulse Generator's 2999 µs against a 0 µs minimum, a timer-tick artefact of 2008's RTAI on
/// that board), a typical range is used instead, and tasks Table 4 omits (Ethernet, RS232C)
/// get the I/O Monitor's small range.
pub fn paper_work_range_us(task: &str) -> (u64, u64) {
    match task {
        "error_check" => (134, 386),
        "pulse_generator" => (5, 30),
        "simulator_manager" => (50, 427),
        "velocity_generator" => (5185, 9181),
        "command_interpreter" => (8, 17),
        "io_monitor" => (1, 59),
        "ethernet" | "rs232c" => (5, 40),
        _ => (10, 50),
    }
}

/// One pulse batch: pulses per axis for one Pulse Generator period.
pub type PulseBatch = [i32; 4];

/// What a synthetic task passes on besides spinning.
pub enum Role {
    /// Spin only.
    Plain,
    /// Velocity Generator: each cycle, push one batch per Pulse Generator period to come.
    VelocityGenerator(SpscSender<PulseBatch>, u32),
    /// Pulse Generator: pop one batch per cycle and publish the summed position.
    PulseGenerator(SpscReceiver<PulseBatch>, MailboxWriter<[i64; 4]>),
    /// Simulator Manager: read the newest position.
    SimulatorManager(MailboxReader<[i64; 4]>),
}

/// A task that spins for a pseudo-random time in `[min_us, max_us]` each cycle.
pub struct SyntheticTask {
    min_ns: u64,
    max_ns: u64,
    rng: u64,
    role: Role,
    position: [i64; 4],
    sink: f64,
}

impl SyntheticTask {
    /// A task whose work lasts `min_us` to `max_us` [µs]; `seed` varies the sequence.
    pub fn new(min_us: u64, max_us: u64, seed: u64, role: Role) -> SyntheticTask {
        SyntheticTask {
            min_ns: min_us * 1000,
            max_ns: max_us.max(min_us) * 1000,
            rng: seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
            role,
            position: [0; 4],
            sink: 0.0,
        }
    }

    fn next_work_ns(&mut self) -> u64 {
        // xorshift64*: allocation-free and good enough to spread execution times.
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        let r = self.rng.wrapping_mul(0x2545_F491_4F6C_DD1D);
        self.min_ns + r % (self.max_ns - self.min_ns + 1)
    }
}

impl Task for SyntheticTask {
    fn cycle(&mut self, ctx: &CycleContext) {
        let work_ns = self.next_work_ns();
        match &mut self.role {
            Role::Plain => {}
            Role::VelocityGenerator(tx, batches) => {
                for k in 0..*batches {
                    let p = ((ctx.cycle as i32) & 0xff) + k as i32;
                    // A full ring means the Pulse Generator fell behind; the batch is dropped.
                    let _ = tx.try_send([p, -p, p / 2, 1]);
                }
            }
            Role::PulseGenerator(rx, out) => {
                if let Some(batch) = rx.try_recv() {
                    for (pos, pulses) in self.position.iter_mut().zip(batch) {
                        *pos += i64::from(pulses);
                    }
                }
                out.write(self.position);
            }
            Role::SimulatorManager(rx) => {
                let p = rx.read();
                self.sink += p[0] as f64;
            }
        }
        // Spin on arithmetic until the work time has passed (reading the vDSO clock, no
        // system call), like a computation of that length.
        let until = ctx.woke_ns + work_ns;
        let mut x = self.sink + 1.0;
        while MonotonicClock.now_ns() < until {
            for _ in 0..64 {
                x = (x * 1.000_000_1 + 0.5).sqrt();
            }
        }
        self.sink = std::hint::black_box(x);
    }
}

#[cfg(test)]
mod tests {
    use wrc_alloc_count::allocations_in;
    use wrc_rt::{ipc, Clock, CycleContext, MonotonicClock};

    use super::*;

    /// The benchmark's synthetic tasks do in their cycles what the controller's do (move a
    /// batch through the ring, a position through the mailbox, spin their work) without
    /// allocating: what `wrc bench rt` measures is the real-time path.
    #[test]
    fn the_benchmark_tasks_allocate_nothing() {
        wrc_alloc_count::assert_installed();
        let (tx, rx) = ipc::spsc::channel(16);
        let (w, r) = ipc::mailbox([0i64; 4]);
        let mut tasks = [
            SyntheticTask::new(1, 3, 1, Role::VelocityGenerator(tx, 5)),
            SyntheticTask::new(1, 3, 2, Role::PulseGenerator(rx, w)),
            SyntheticTask::new(1, 3, 3, Role::SimulatorManager(r)),
            SyntheticTask::new(1, 3, 4, Role::Plain),
        ];
        let (n, ()) = allocations_in(|| {
            for cycle in 0..100 {
                for t in tasks.iter_mut() {
                    let now = MonotonicClock.now_ns();
                    let ctx = CycleContext {
                        cycle,
                        scheduled_ns: now,
                        woke_ns: now,
                        period_ns: 1_000_000,
                        release: wrc_rt::Release::Period,
                        previous_exec_ns: 20_000,
                    };
                    wrc_rt::Task::cycle(t, &ctx);
                }
            }
        });
        assert_eq!(n.total(), 0, "{n:?}");
    }
}
