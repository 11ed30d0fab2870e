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
use std::os::unix::io::AsRawFd;
use std::path::Path;
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
        9600 => libc::B9600,
        19200 => libc::B19200,
        38400 => libc::B38400,
        57600 => libc::B57600,
        115200 => libc::B115200,
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
    let fd = file.as_raw_fd();
    let configure = || -> std::io::Result<()> {
        // SAFETY: `termios` is plain data that tcgetattr fills completely; `fd` is an open
        // descriptor owned by `file` for the duration of these calls.
        unsafe {
            let mut t: libc::termios = std::mem::zeroed();
            if libc::tcgetattr(fd, &mut t) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            libc::cfmakeraw(&mut t);
            t.c_cflag |= libc::CLOCAL | libc::CREAD;
            t.c_cflag &= !(libc::PARENB | libc::PARODD | libc::CSTOPB);
            match parity {
                Parity::None => {}
                Parity::Even => t.c_cflag |= libc::PARENB,
                Parity::Odd => t.c_cflag |= libc::PARENB | libc::PARODD,
            }
            if libc::cfsetispeed(&mut t, speed) != 0 || libc::cfsetospeed(&mut t, speed) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            if libc::tcsetattr(fd, libc::TCSANOW, &t) != 0 {
                return Err(std::io::Error::last_os_error());
            }
        }
        Ok(())
    };
    configure().map_err(|reason| SerialError::Configure {
        path: path.display().to_string(),
        baud,
        reason,
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
            pendant.add(Stream::Serial(port));
        }
        Rs232c { pendant, replies }
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
        self.step(ctx.release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};
    use std::os::fd::AsRawFd;

    use wrc_config::Config;
    use wrc_rt::ipc::Semaphore;
    use wrc_rt::wake::{FdWake, Waiter};
    use wrc_rt::{Clock, MonotonicClock};

    use crate::clients::Routes;
    use crate::messages::{Incoming, SourceId};
    use crate::shared::Shared;

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

    /// Read one line from the master, waiting at most 5 s (a failure bound) for each byte.
    fn read_line(master: &mut File) -> String {
        let mut line = Vec::new();
        let mut byte = [0u8; 1];
        while !line.ends_with(b"\n") {
            let mut fds = libc::pollfd {
                fd: master.as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            };
            // SAFETY: one valid pollfd that lives across the call.
            assert_eq!(unsafe { libc::poll(&mut fds, 1, 5_000) }, 1, "no reply");
            assert_eq!(master.read(&mut byte).unwrap(), 1);
            line.push(byte[0]);
        }
        String::from_utf8(line).unwrap().trim_end().to_string()
    }

    #[test]
    fn a_pendant_line_is_routed_and_its_reply_written_in_event_cycles() {
        let far = || MonotonicClock.now_ns() + 20_000_000_000;
        let (mut master, path) = pty();
        let port = open_serial(&path, 115_200, Parity::None).unwrap();
        let config = Config::embedded_default();
        let incoming = Arc::new(MessageQueue::new(8));
        let routes = Routes {
            incoming: incoming.clone(),
            urgent: Arc::new(MessageQueue::new(8)),
            wake: Arc::new(Semaphore::new(0)),
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
        let mut wake = FdWake::new(Rs232c::TOKENS).unwrap();
        let replies = Arc::new(MessageQueue::with_notify(8, wake.notifier()));
        let mut task = Rs232c::new(Some(port), pendant, replies.clone())
            .released_by(wake.registry())
            .unwrap();

        master.write_all(b"4 STATUS\n").unwrap();
        // The tty layer may hand the line over in pieces: an event cycle per piece.
        let mut routed = None;
        for _ in 0..9 {
            assert!(
                wake.wait_until_ns(far()),
                "the line did not release the task"
            );
            task.step(Release::Event);
            if let Ok(Incoming::Request(from, request)) = incoming.try_recv() {
                routed = Some((from, request));
                break;
            }
        }
        let (from, request) = routed.expect("the line was routed");
        assert_eq!((from.kind(), request.id), (SourceId::PENDANT, Some(4)));

        replies.try_send(OutLine::new(from, b"ACK 4\n")).unwrap();
        assert!(
            wake.wait_until_ns(far()),
            "the reply did not release the task"
        );
        task.step(Release::Event);
        assert_eq!(read_line(&mut master), "ACK 4");
    }
}
