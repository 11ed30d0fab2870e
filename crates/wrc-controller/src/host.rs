//! Where the controller's tasks run: on real-time threads ([`RealHost`], the
//! [`wrc_rt::Runtime`] on `CLOCK_MONOTONIC`) or under virtual time ([`VirtualHost`], the
//! [`wrc_rt::virtual_time::VirtualRuntime`]). The controller is assembled once, against
//! [`Host`]; the task code is the same on both, only the clock and the waiters differ.

use std::sync::Arc;

#[cfg(feature = "sim")]
use wrc_rt::virtual_time::VirtualRuntime;
use wrc_rt::virtual_time::VirtualWake;
use wrc_rt::wake::{FdRegistry, FdWake, Wake};
use wrc_rt::{Notify, Runtime, Task, TaskSpec, Waiter};

use crate::start_error::StartError;

/// What a task released by events waits on, as the assembly sees it.
pub(crate) trait HostWake {
    /// The handle its producers (queues, stop requests) notify.
    fn notifier(&self) -> Arc<dyn Notify>;
    /// Where the task registers its descriptors to be released by their input; `None` when
    /// the host does not watch descriptors (the task reads them at its period).
    fn registry(&self) -> Option<FdRegistry>;
}

/// A place to run the controller's tasks.
pub(crate) trait Host {
    /// The waiter of a task released by events.
    type Wake: HostWake;
    /// A waiter for `task`; `fd_tokens`: it also watches that many descriptors.
    fn wake(
        &mut self,
        task: &'static str,
        fd_tokens: Option<usize>,
    ) -> Result<Self::Wake, StartError>;
    /// Add `task`, released by its period.
    fn add(&mut self, spec: TaskSpec, task: impl Task) -> Result<(), StartError>;
    /// Add `task`, released by its period or by `wake`.
    fn add_released(
        &mut self,
        spec: TaskSpec,
        task: impl Task,
        wake: Self::Wake,
    ) -> Result<(), StartError>;
}

/// The waiter of a task on a real-time thread.
pub(crate) enum RealWake {
    /// Notifications only (a futex word).
    Futex(Wake),
    /// Descriptors and notifications (epoll).
    Fd(FdWake),
}

impl Waiter for RealWake {
    fn wait_until_ns(&mut self, deadline_ns: u64) -> bool {
        match self {
            RealWake::Futex(w) => w.wait_until_ns(deadline_ns),
            RealWake::Fd(w) => w.wait_until_ns(deadline_ns),
        }
    }

    fn notifier(&self) -> Option<Arc<dyn Notify>> {
        Some(HostWake::notifier(self))
    }
}

impl HostWake for RealWake {
    fn notifier(&self) -> Arc<dyn Notify> {
        match self {
            RealWake::Futex(w) => w.notifier(),
            RealWake::Fd(w) => w.notifier(),
        }
    }

    fn registry(&self) -> Option<FdRegistry> {
        match self {
            RealWake::Futex(_) => None,
            RealWake::Fd(w) => Some(w.registry()),
        }
    }
}

/// The real-time runtime: one SCHED_FIFO thread per task on `CLOCK_MONOTONIC`.
pub(crate) struct RealHost(pub Runtime);

impl Host for RealHost {
    type Wake = RealWake;

    fn wake(
        &mut self,
        task: &'static str,
        fd_tokens: Option<usize>,
    ) -> Result<RealWake, StartError> {
        match fd_tokens {
            None => Ok(RealWake::Futex(Wake::new())),
            Some(tokens) => FdWake::new(tokens)
                .map(RealWake::Fd)
                .map_err(|reason| StartError::Waiter { task, reason }),
        }
    }

    fn add(&mut self, spec: TaskSpec, task: impl Task) -> Result<(), StartError> {
        self.0.add(spec, task);
        Ok(())
    }

    fn add_released(
        &mut self,
        spec: TaskSpec,
        task: impl Task,
        wake: RealWake,
    ) -> Result<(), StartError> {
        self.0.add_released(spec, task, wake);
        Ok(())
    }
}

impl HostWake for VirtualWake {
    fn notifier(&self) -> Arc<dyn Notify> {
        VirtualWake::notifier(self)
    }

    fn registry(&self) -> Option<FdRegistry> {
        None
    }
}

/// Virtual time: every task on one thread, released by a deterministic scheduler. The
/// Pulse Generator runs behind a stall gate: until the virtual time in the second field
/// [ns] its cycles do nothing, as a host that does not schedule it
/// ([`crate::simulation::Simulation::stall_pulse_generator`]).
#[cfg(feature = "sim")]
pub(crate) struct VirtualHost(
    pub VirtualRuntime,
    pub std::sync::Arc<std::sync::atomic::AtomicU64>,
);

/// A task whose cycles do nothing until a virtual time: a stalled thread.
#[cfg(feature = "sim")]
struct Stallable<T> {
    task: T,
    until_ns: std::sync::Arc<std::sync::atomic::AtomicU64>,
}

#[cfg(feature = "sim")]
impl<T: Task> Task for Stallable<T> {
    fn cycle(&mut self, ctx: &wrc_rt::CycleContext) {
        if ctx.woke_ns >= self.until_ns.load(std::sync::atomic::Ordering::Relaxed) {
            self.task.cycle(ctx);
        }
    }
}

#[cfg(feature = "sim")]
impl Host for VirtualHost {
    type Wake = VirtualWake;

    fn wake(&mut self, _: &'static str, _: Option<usize>) -> Result<VirtualWake, StartError> {
        Ok(VirtualWake::new())
    }

    fn add(&mut self, spec: TaskSpec, task: impl Task) -> Result<(), StartError> {
        Ok(self.0.add(spec, task)?)
    }

    fn add_released(
        &mut self,
        spec: TaskSpec,
        task: impl Task,
        wake: VirtualWake,
    ) -> Result<(), StartError> {
        if spec.name == "pulse_generator" {
            let task = Stallable {
                task,
                until_ns: self.1.clone(),
            };
            return Ok(self.0.add_released(spec, task, &wake)?);
        }
        Ok(self.0.add_released(spec, task, &wake)?)
    }
}
