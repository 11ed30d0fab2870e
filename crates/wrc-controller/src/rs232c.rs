//! RS232C task (Table 1: priority 45, 100 ms): the teaching pendant on a serial line. The
//! same protocol as the Ethernet task, plus the optional `*HH` checksum; a request that
//! carries one gets replies that carry one. Without `--serial` the task idles.
//!
//! Released by its period or by an event, whichever comes first ([`Rs232c::released_by`]
//! with the task's [`FdWake`](wrc_rt::wake::FdWake)): input on the tty, or a line pushed
//! into its reply queue (made with `MessageQueue::with_notify` and the waiter's notifier).
//! An event cycle reads the line that came and writes the replies waiting; the periodic
//! cycle also retries output the line could not take.
//!
//! Real-time promise: non-blocking reads and writes on the tty only; no allocation.

use std::fs::{File, OpenOptions};
use std::io;
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;

use nix::sys::termios::{self, BaudRate, ControlFlags, SetArg};
use std::sync::Arc;

use wrc_rt::ipc::MessageQueue;
use wrc_rt::wake::FdRegistry;
use wrc_rt::{CycleContext, Release, Task};

use crate::clients::{ClientSet, Stream};
use crate::messages::OutLine;

/// Parity of the serial line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Parity {
    /// No parity bit.
    None,
    /// Even parity.
    Even,
    /// Odd parity.
    Odd,
}

/// Why the serial port could not be opened.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SerialError {
    /// The device could not be opened.
    #[error("cannot open serial port {path}: {reason}")]
    Open {
        /// The device.
        path: String,
        /// Why.
        reason: std::io::Error,
    },
    /// The device is not a terminal or refused the settings.
    #[error("cannot configure serial port {path} ({baud} baud): {reason}")]
    Configure {
        /// The device.
        path: String,
        /// Requested speed.
        baud: u32,
        /// Why.
        reason: std::io::Error,
    },
    /// A speed the line does not support.
    #[error("unsupported baud rate {0}; use 9600, 19200, 38400, 57600 or 115200")]
    Baud(u32),
}

/// Open `path` non-blocking as a raw 8-bit line at `baud` with `parity`, one stop bit.
pub fn open_serial(path: &Path, baud: u32, parity: Parity) -> Result<File, SerialError> {
    let speed = match baud {
        9600 => BaudRate::B9600,
        19200 => BaudRate::B19200,
        38400 => BaudRate::B38400,
        57600 => BaudRate::B57600,
        115200 => BaudRate::B115200,
        other => return Err(SerialError::Baud(other)),
    };
    let file = OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(libc::O_NOCTTY | libc::O_NONBLOCK)
        .open(path)
        .map_err(|reason| SerialError::Open {
            path: path.display().to_string(),
            reason,
        })?;
    // Raw 8-bit, no echo, the receiver on, modem lines ignored, one stop bit, the parity.
    let configure = || -> nix::Result<()> {
        let mut t = termios::tcgetattr(&file)?;
        termios::cfmakeraw(&mut t);
        t.control_flags |= ControlFlags::CLOCAL | ControlFlags::CREAD;
        t.control_flags &= !(ControlFlags::PARENB | ControlFlags::PARODD | ControlFlags::CSTOPB);
        match parity {
            Parity::None => {}
            Parity::Even => t.control_flags |= ControlFlags::PARENB,
            Parity::Odd => t.control_flags |= ControlFlags::PARENB | ControlFlags::PARODD,
        }
        termios::cfsetspeed(&mut t, speed)?;
        termios::tcsetattr(&file, SetArg::TCSANOW, &t)
    };
    configure().map_err(|errno| SerialError::Configure {
        path: path.display().to_string(),
        baud,
        reason: std::io::Error::from(errno),
    })?;
    Ok(file)
}

/// The RS232C task.
pub struct Rs232c {
    pendant: ClientSet,
    replies: Arc<MessageQueue<OutLine>>,
}

impl Rs232c {
    /// The task on an opened serial line (or none); `replies` carries the pendant's lines.
    pub fn new(
        port: Option<File>,
        mut pendant: ClientSet,
        replies: Arc<MessageQueue<OutLine>>,
    ) -> Rs232c {
        if let Some(port) = port {
            pendant.add(Stream::Serial(port), None);
        }
        Rs232c { pendant, replies }
    }

    /// Record every line read from and delivered to the pendant into `tap`.
    pub fn set_trace(&mut self, tap: crate::recorder::MessageTap) {
        self.pendant.set_trace(tap);
    }

    /// Tokens the task's [`FdWake`](wrc_rt::wake::FdWake) needs (the pendant's line).
    pub const TOKENS: usize = 1;

    /// The task released by events as well as its period: the serial line is registered
    /// with `registry` (from the [`FdWake`](wrc_rt::wake::FdWake) the task is added with,
    /// sized [`Rs232c::TOKENS`]); its reply queue should notify that waiter.
    pub fn released_by(mut self, registry: FdRegistry) -> io::Result<Rs232c> {
        self.pendant.set_registry(registry, 0)?;
        Ok(self)
    }

    /// One cycle, released by `release` (public for tests that step the task by hand).
    pub fn step(&mut self, release: Release) {
        let period = release == Release::Period;
        if period {
            self.pendant.poll_reads();
        } else {
            self.pendant.read_ready();
        }
        // The whole queue each cycle (one notification may stand for several lines).
        while let Ok(line) = self.replies.try_recv() {
            self.pendant.deliver(&line);
        }
        if period {
            self.pendant.flush();
        } else {
            self.pendant.flush_new();
        }
    }
}

impl Task for Rs232c {
    fn cycle(&mut self, ctx: &CycleContext) {
        self.pendant.set_time(ctx.woke_ns);
        self.step(ctx.release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};
    use std::os::fd::AsRawFd;

    use wrc_config::Config;
    use wrc_protocol::ReplyTo;
    use wrc_rt::ipc::Semaphore;
    use wrc_rt::wake::{FdWake, Waiter};
    use wrc_rt::{Clock, MonotonicClock};

    use crate::clients::Routes;
    use crate::messages::{Incoming, SourceId, Urgent};
    use crate::shared::Shared;

    /// A deadline no test reaches unless it fails [ns].
    fn far() -> u64 {
        MonotonicClock.now_ns() + 20_000_000_000
    }

    /// A pseudo-terminal: the master end (the pendant's side) and the slave's path.
    fn pty() -> (File, std::path::PathBuf) {
        let master = OpenOptions::new()
            .read(true)
            .write(true)
            .custom_flags(libc::O_NOCTTY)
            .open("/dev/ptmx")
            .unwrap();
        let mut name = [0 as libc::c_char; 128];
        // SAFETY: `master` is an open pty master; `name` is a writable buffer of the length
        // given, which ptsname_r fills with a NUL-terminated path.
        unsafe {
            assert_eq!(libc::grantpt(master.as_raw_fd()), 0);
            assert_eq!(libc::unlockpt(master.as_raw_fd()), 0);
            assert_eq!(
                libc::ptsname_r(master.as_raw_fd(), name.as_mut_ptr(), name.len()),
                0
            );
        }
        // SAFETY: ptsname_r wrote a NUL-terminated string into `name`.
        let path = unsafe { std::ffi::CStr::from_ptr(name.as_ptr()) };
        (master, path.to_str().unwrap().into())
    }

    /// Whether the master has a byte to read within `timeout_ms` [ms].
    fn readable(master: &File, timeout_ms: i32) -> bool {
        let mut fds = libc::pollfd {
            fd: master.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        // SAFETY: one valid pollfd that lives across the call.
        unsafe { libc::poll(&mut fds, 1, timeout_ms) == 1 }
    }

    /// Read one line from the master, waiting at most 5 s (a failure bound) for each byte.
    fn read_line(master: &mut File) -> String {
        let mut line = Vec::new();
        let mut byte = [0u8; 1];
        while !line.ends_with(b"\n") {
            assert!(readable(master, 5_000), "no reply");
            assert_eq!(master.read(&mut byte).unwrap(), 1);
            line.push(byte[0]);
        }
        String::from_utf8(line).unwrap().trim_end().to_string()
    }

    /// `body` with its `*HH` checksum and a newline, as a pendant sends it.
    fn with_checksum(body: &str) -> Vec<u8> {
        let sum = body.bytes().fold(0u8, |a, b| a ^ b);
        format!("{body}*{sum:02X}\n").into_bytes()
    }

    /// The task as `controller::start` builds it, on the slave end of a pty, with the
    /// queues it routes to.
    struct Rig {
        master: File,
        task: Rs232c,
        wake: FdWake,
        replies: Arc<MessageQueue<OutLine>>,
        incoming: Arc<MessageQueue<Incoming>>,
        urgent: Arc<MessageQueue<Urgent>>,
        urgent_wake: Arc<Semaphore>,
    }

    impl Rig {
        fn new() -> Rig {
            let (master, path) = pty();
            let port = open_serial(&path, 115_200, Parity::None).unwrap();
            let config = Config::embedded_default();
            let incoming = Arc::new(MessageQueue::new(8));
            let urgent = Arc::new(MessageQueue::new(8));
            let urgent_wake = Arc::new(Semaphore::new(0));
            let routes = Routes {
                incoming: incoming.clone(),
                urgent: urgent.clone(),
                wake: urgent_wake.clone(),
                store: Arc::new(MessageQueue::new(8)),
            };
            let pendant = ClientSet::new(
                SourceId::PENDANT,
                1,
                true,
                config.robot.clone(),
                Arc::new(Shared::default()),
                routes,
            );
            let wake = FdWake::new(Rs232c::TOKENS).unwrap();
            let replies = Arc::new(MessageQueue::with_notify(8, wake.notifier()));
            let task = Rs232c::new(Some(port), pendant, replies.clone())
                .released_by(wake.registry())
                .unwrap();
            Rig {
                master,
                task,
                wake,
                replies,
                incoming,
                urgent,
                urgent_wake,
            }
        }

        /// Send `bytes` from the pendant and run the event cycles its input releases until
        /// `routed` says it has arrived (the tty layer may hand a line over in pieces: an
        /// event cycle per piece).
        fn send_until<T>(&mut self, bytes: &[u8], mut routed: impl FnMut(&Rig) -> Option<T>) -> T {
            self.master.write_all(bytes).unwrap();
            for _ in 0..bytes.len() {
                assert!(
                    self.wake.wait_until_ns(far()),
                    "the line did not release the task"
                );
                self.task.step(Release::Event);
                if let Some(got) = routed(self) {
                    return got;
                }
            }
            panic!("{:?} was never routed", String::from_utf8_lossy(bytes));
        }

        /// Run the event cycles the pendant's input releases until a line comes back on it
        /// (a reply the task wrote at once); that line.
        fn cycle_until_reply(&mut self) -> String {
            let deadline = far();
            while MonotonicClock.now_ns() < deadline {
                if self.wake.wait_until_ns(0) {
                    self.task.step(Release::Event);
                } else if readable(&self.master, 10) {
                    return read_line(&mut self.master);
                }
            }
            panic!("no reply on the line");
        }
    }

    #[test]
    fn a_pendant_line_is_routed_and_its_reply_written_in_event_cycles() {
        let mut rig = Rig::new();
        let (from, request) = rig.send_until(b"4 STATUS\n", |r| match r.incoming.try_recv() {
            Ok(Incoming::Request(from, request)) => Some((from, request)),
            _ => None,
        });
        assert_eq!((from.kind(), request.id), (SourceId::PENDANT, Some(4)));

        rig.replies
            .try_send(OutLine::new(from, b"ACK 4\n"))
            .unwrap();
        assert!(
            rig.wake.wait_until_ns(far()),
            "the reply did not release the task"
        );
        rig.task.step(Release::Event);
        assert_eq!(read_line(&mut rig.master), "ACK 4");
    }

    #[test]
    fn estop_and_stop_from_the_pendant_overtake_a_full_request_queue() {
        let mut rig = Rig::new();
        // The Command Interpreter is busy: its request queue is full.
        while rig
            .incoming
            .try_send(Incoming::Disconnected(SourceId::NONE))
            .is_ok()
        {}
        // ESTOP (with a checksum, as a pendant sends it) and STOP (without) go to the urgent
        // path in the event cycle their line completes, each with one post of its semaphore.
        let estop = rig.send_until(&with_checksum("7 ESTOP"), |r| r.urgent.try_recv().ok());
        assert_eq!(rig.urgent_wake.count(), 1);
        let stop = rig.send_until(b"STOP\n", |r| r.urgent.try_recv().ok());
        assert_eq!(rig.urgent_wake.count(), 2);
        let pendant = |u: &Urgent| match u {
            Urgent::Estop(from, _) | Urgent::Stop(from, _) => from.kind() == SourceId::PENDANT,
            Urgent::Fault(_) => false,
        };
        assert!(pendant(&estop) && pendant(&stop), "{estop:?} {stop:?}");
        // Their replies (ACK from the Command Interpreter's bookkeeping) carry a checksum
        // exactly when the request did.
        assert!(matches!(
            estop,
            Urgent::Estop(
                _,
                ReplyTo {
                    id: Some(7),
                    checksum: true
                }
            )
        ));
        assert!(matches!(
            stop,
            Urgent::Stop(
                _,
                ReplyTo {
                    id: None,
                    checksum: false
                }
            )
        ));
        // An ordinary request after them is refused as busy at once: the first line the
        // pendant gets, so neither ESTOP nor STOP was refused.
        rig.master.write_all(&with_checksum("8 SPEED 50")).unwrap();
        let busy = rig.cycle_until_reply();
        assert!(busy.starts_with("NAK 8 121 "), "{busy}");
        assert_eq!(rig.incoming.len(), rig.incoming.capacity());
    }
}
