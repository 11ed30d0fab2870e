//! Ethernet task (Table 1: priority 45, 100 ms): the host protocol on TCP (default
//! `127.0.0.1:7100`) and on the local GUI's Unix socket. Each cycle accepts new clients,
//! reads and parses their lines, routes requests to the Command Interpreter (STOP and ESTOP
//! through its urgent path), writes replies and events, and feeds the status stream.
//!
//! Real-time promise: non-blocking socket calls only; every buffer exists before the first
//! cycle (see [`crate::clients`]).

use std::io;
use std::net::TcpListener;
use std::os::unix::net::UnixListener;
use std::sync::Arc;

use wrc_rt::{CycleContext, Task};

use wrc_rt::ipc::MessageQueue;

use crate::clients::{ClientSet, Stream};
use crate::shared::OutLine;

/// The Ethernet task.
pub struct Ethernet {
    tcp: Option<TcpListener>,
    unix: Option<UnixListener>,
    hosts: ClientSet,
    guis: ClientSet,
    replies: Arc<MessageQueue<OutLine>>,
    /// Connections refused because every slot was taken.
    pub refused: u64,
}

impl Ethernet {
    /// The task on bound, non-blocking listeners; `replies` carries the lines for hosts and
    /// GUIs (drained here only, once per cycle, and handed to the set each line is for).
    pub fn new(
        tcp: Option<TcpListener>,
        unix: Option<UnixListener>,
        hosts: ClientSet,
        guis: ClientSet,
        replies: Arc<MessageQueue<OutLine>>,
    ) -> Ethernet {
        Ethernet {
            tcp,
            unix,
            hosts,
            guis,
            replies,
            refused: 0,
        }
    }

    fn accept(&mut self) {
        if let Some(listener) = &self.tcp {
            loop {
                match listener.accept() {
                    Ok((stream, _)) => {
                        let _ = stream.set_nonblocking(true);
                        let _ = stream.set_nodelay(true);
                        if !self.hosts.add(Stream::Tcp(stream)) {
                            self.refused += 1;
                        }
                    }
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                    Err(_) => break,
                }
            }
        }
        if let Some(listener) = &self.unix {
            loop {
                match listener.accept() {
                    Ok((stream, _)) => {
                        let _ = stream.set_nonblocking(true);
                        if !self.guis.add(Stream::Unix(stream)) {
                            self.refused += 1;
                        }
                    }
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                    Err(_) => break,
                }
            }
        }
    }

    /// One cycle (public for tests that step the task by hand).
    pub fn step(&mut self) {
        self.accept();
        self.hosts.poll_reads();
        self.guis.poll_reads();
        while let Ok(line) = self.replies.try_recv() {
            self.hosts.deliver(&line);
            self.guis.deliver(&line);
        }
        for set in [&mut self.hosts, &mut self.guis] {
            set.status_stream();
            set.flush();
        }
    }
}

impl Task for Ethernet {
    fn cycle(&mut self, _ctx: &CycleContext) {
        self.step();
    }
}
