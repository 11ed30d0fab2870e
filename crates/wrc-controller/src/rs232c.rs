//! RS232C task (Table 1: priority 45, 100 ms): the teaching pendant on a serial line. The
//! same protocol as the Ethernet task, plus the optional `*HH` checksum; a request that
//! carries one gets replies that carry one. Without `--serial` the task idles.
//!
//! Real-time promise: non-blocking reads and writes on the tty only; no allocation.

use std::fs::{File, OpenOptions};
use std::os::unix::fs::OpenOptionsExt;
use std::os::unix::io::AsRawFd;
use std::path::Path;
use std::sync::Arc;

use wrc_rt::ipc::MessageQueue;
use wrc_rt::{CycleContext, Task};

use crate::clients::{ClientSet, Stream};
use crate::shared::OutLine;

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

    /// One cycle (public for tests that step the task by hand).
    pub fn step(&mut self) {
        self.pendant.poll_reads();
        while let Ok(line) = self.replies.try_recv() {
            self.pendant.deliver(&line);
        }
        self.pendant.flush();
    }
}

impl Task for Rs232c {
    fn cycle(&mut self, _ctx: &CycleContext) {
        self.step();
    }
}
