//! IPC latency probes for `wrc bench rt` (the paper's Table 5): a sender stamps the time and
//! signals; a higher-priority receiver blocked on the other end records how long it took to
//! run. Semaphore, message queue and a UDP packet on loopback, each on its own pair of
//! threads, while the task set runs.

use std::net::UdpSocket;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use wrc_rt::clock::{monotonic_now_ns, Clock, MonotonicClock};
use wrc_rt::histogram::Histogram;
use wrc_rt::ipc::{MessageQueue, Semaphore};
use wrc_rt::sched_policy::{fifo_priority, set_current_thread_fifo, RealtimeMode};

/// Paper priority of the probe receivers (the Velocity Generator's, waiting on commands).
pub const RECEIVER_PRIORITY: u8 = 30;
/// Paper priority of the probe senders (the Command Interpreter's).
pub const SENDER_PRIORITY: u8 = 40;
/// Interval between probe messages [µs].
pub const PROBE_INTERVAL_US: u64 = 5_000;

/// The kinds of IPC measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IpcKind {
    /// [`Semaphore`] post → wake.
    Semaphore,
    /// [`MessageQueue`] send → receive.
    MessageQueue,
    /// A UDP datagram on 127.0.0.1, send → `recv` returns.
    Udp,
}

impl IpcKind {
    /// The name used in tables and JSON (`semaphore`, `message_queue`, `udp`).
    pub fn key(self) -> &'static str {
        match self {
            IpcKind::Semaphore => "semaphore",
            IpcKind::MessageQueue => "message_queue",
            IpcKind::Udp => "udp",
        }
    }

    /// The paper's name.
    pub fn label(self) -> &'static str {
        match self {
            IpcKind::Semaphore => "Semaphore",
            IpcKind::MessageQueue => "Message queue",
            IpcKind::Udp => "UDP packet",
        }
    }
}

/// Running probes; [`IpcProbes::finish`] returns their latencies.
pub struct IpcProbes {
    stop: Arc<AtomicBool>,
    threads: Vec<(IpcKind, JoinHandle<Histogram>, JoinHandle<()>)>,
}

impl std::fmt::Debug for IpcProbes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("IpcProbes").finish_non_exhaustive()
    }
}

fn rt(mode: RealtimeMode, paper_priority: u8) {
    if mode == RealtimeMode::Auto {
        // Without permission the probe runs on normal scheduling, like the tasks (said once
        // by the runtime).
        let _ = set_current_thread_fifo(fifo_priority(paper_priority));
    }
}

/// A sender loop on its own absolute grid, offset by `phase_us` [µs].
fn sender(
    mode: RealtimeMode,
    stop: Arc<AtomicBool>,
    phase_us: u64,
    mut send: impl FnMut(u64) + Send + 'static,
) -> JoinHandle<()> {
    std::thread::spawn(move || {
        rt(mode, SENDER_PRIORITY);
        let clock = MonotonicClock;
        let mut next = clock.now_ns() + phase_us * 1000 + 10_000_000;
        while !stop.load(Ordering::Acquire) {
            clock.sleep_until_ns(next);
            send(clock.now_ns());
            next += PROBE_INTERVAL_US * 1000;
        }
    })
}

impl IpcProbes {
    /// Start the three probe pairs.
    pub fn start(mode: RealtimeMode) -> std::io::Result<IpcProbes> {
        let stop = Arc::new(AtomicBool::new(false));
        let mut threads = Vec::new();

        // Semaphore: the stamp travels in an atomic next to it.
        let sem = Arc::new(Semaphore::new(0));
        let stamp = Arc::new(AtomicU64::new(0));
        let rx = {
            let (sem, stamp, stop) = (sem.clone(), stamp.clone(), stop.clone());
            std::thread::spawn(move || {
                rt(mode, RECEIVER_PRIORITY);
                let mut h = Histogram::new();
                while !stop.load(Ordering::Acquire) {
                    if sem.wait_timeout(Duration::from_millis(50)) {
                        let now = monotonic_now_ns();
                        h.record(now.saturating_sub(stamp.load(Ordering::Acquire)));
                    }
                }
                h
            })
        };
        let tx = sender(mode, stop.clone(), 0, move |t| {
            stamp.store(t, Ordering::Release);
            sem.post();
        });
        threads.push((IpcKind::Semaphore, rx, tx));

        // Message queue: the stamp is the message.
        let queue = Arc::new(MessageQueue::<u64>::new(16));
        let rx = {
            let (queue, stop) = (queue.clone(), stop.clone());
            std::thread::spawn(move || {
                rt(mode, RECEIVER_PRIORITY);
                let mut h = Histogram::new();
                while !stop.load(Ordering::Acquire) {
                    if let Ok(sent) = queue.recv_timeout(Duration::from_millis(50)) {
                        h.record(monotonic_now_ns().saturating_sub(sent));
                    }
                }
                h
            })
        };
        let tx = sender(mode, stop.clone(), PROBE_INTERVAL_US / 3, move |t| {
            let _ = queue.try_send(t);
        });
        threads.push((IpcKind::MessageQueue, rx, tx));

        // UDP on loopback: the stamp is the datagram.
        let receiver = UdpSocket::bind("127.0.0.1:0")?;
        receiver.set_read_timeout(Some(Duration::from_millis(50)))?;
        let to = receiver.local_addr()?;
        let socket = UdpSocket::bind("127.0.0.1:0")?;
        let rx = {
            let stop = stop.clone();
            std::thread::spawn(move || {
                rt(mode, RECEIVER_PRIORITY);
                let mut h = Histogram::new();
                let mut buf = [0u8; 16];
                while !stop.load(Ordering::Acquire) {
                    if let Ok(8) = receiver.recv(&mut buf) {
                        let now = monotonic_now_ns();
                        let sent = u64::from_le_bytes(buf[..8].try_into().unwrap_or([0; 8]));
                        h.record(now.saturating_sub(sent));
                    }
                }
                h
            })
        };
        let tx = sender(mode, stop.clone(), 2 * PROBE_INTERVAL_US / 3, move |t| {
            let _ = socket.send_to(&t.to_le_bytes(), to);
        });
        threads.push((IpcKind::Udp, rx, tx));

        Ok(IpcProbes { stop, threads })
    }

    /// Stop the probes and return each kind's latencies [ns].
    pub fn finish(self) -> Vec<(IpcKind, Histogram)> {
        self.stop.store(true, Ordering::Release);
        self.threads
            .into_iter()
            .map(|(kind, rx, tx)| {
                let _ = tx.join();
                (kind, rx.join().unwrap_or_default())
            })
            .collect()
    }
}
