//! Ethernet task (Table 1: priority 45, 100 ms): the host protocol on TCP (default
//! `127.0.0.1:7100`) and on the local GUI's Unix socket. It accepts new clients, reads and
//! parses their lines, routes requests to the Command Interpreter (STOP and ESTOP through
//! its urgent path), writes replies and events, and feeds the status stream.
//!
//! Released by its period or by an event, whichever comes first ([`Ethernet::released_by`]
//! with the task's [`FdWake`](wrc_rt::wake::FdWake)): a listener with a connection waiting, a client's input, or
//! a line pushed into its reply queue (made with `MessageQueue::with_notify` and the
//! waiter's notifier). An **event** cycle accepts on a ready listener, reads the clients
//! that have input (a bounded amount each, see [`crate::clients`]), routes their requests,
//! and writes every reply waiting in the queue — so a request is routed, and its reply
//! written, the moment each arrives. The **periodic** cycle also sends the status stream to
//! subscribers, retries the output of clients that are backed up, and reads every client.
//!
//! Real-time promise: non-blocking socket calls only (plus one `epoll_ctl` when a client
//! comes or goes); every buffer exists before the first cycle (see [`crate::clients`]).

use std::io;
use std::net::TcpListener;
use std::os::unix::net::UnixListener;
use std::sync::Arc;

use wrc_rt::wake::{FdRegistry, Token};
use wrc_rt::{CycleContext, Release, Task};

use wrc_rt::ipc::MessageQueue;

use crate::clients::{Added, ClientSet, Stream};
use crate::messages::OutLine;
use crate::recorder::MessageTap;

/// The waiter's token of the TCP listener.
const TCP_LISTENER: Token = 0;
/// The waiter's token of the Unix-socket listener.
const UNIX_LISTENER: Token = 1;
/// The waiter's token of host slot 0 (GUI slots follow the host slots).
const FIRST_CLIENT: Token = 2;

/// The Ethernet task.
pub struct Ethernet {
    tcp: Option<TcpListener>,
    unix: Option<UnixListener>,
    hosts: ClientSet,
    guis: ClientSet,
    replies: Arc<MessageQueue<OutLine>>,
    registry: Option<FdRegistry>,
    /// The TCP listener is out of the waiter after an accept failed (out of descriptors):
    /// it is tried again on the period, so a failing accept cannot release the task in a
    /// loop.
    tcp_paused: bool,
    /// Connections refused (their address may not connect, or no slot could be made free).
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
            registry: None,
            tcp_paused: false,
            refused: 0,
        }
    }

    /// Tokens the task's [`FdWake`](wrc_rt::wake::FdWake) needs for `hosts` TCP clients and
    /// `guis` GUI clients (and the two listeners).
    pub fn tokens(hosts: usize, guis: usize) -> usize {
        FIRST_CLIENT + hosts + guis
    }

    /// The task released by events as well as its period: its listeners and every client
    /// are registered with `registry` (from the [`FdWake`](wrc_rt::wake::FdWake) the task is
    /// added with, sized with [`Ethernet::tokens`]); its reply queue should notify that
    /// waiter. Fails when the waiter has too few tokens or the kernel refuses a registration.
    pub fn released_by(mut self, registry: FdRegistry) -> io::Result<Ethernet> {
        if let Some(l) = &self.tcp {
            registry.register(l, TCP_LISTENER)?;
        }
        if let Some(l) = &self.unix {
            registry.register(l, UNIX_LISTENER)?;
        }
        let hosts = self.hosts.capacity();
        self.hosts.set_registry(registry.clone(), FIRST_CLIENT)?;
        self.guis
            .set_registry(registry.clone(), FIRST_CLIENT + hosts)?;
        self.registry = Some(registry);
        Ok(self)
    }

    fn accept(&mut self, period: bool) {
        if let Some(listener) = &self.tcp {
            if self.tcp_paused && period {
                if let Some(r) = &self.registry {
                    self.tcp_paused = r.register(listener, TCP_LISTENER).is_err();
                }
            }
            loop {
                match listener.accept() {
                    Ok((stream, peer)) => {
                        let _ = stream.set_nonblocking(true);
                        let _ = stream.set_nodelay(true);
                        let added = self.hosts.add(Stream::Tcp(stream), Some(peer.ip()));
                        if added == Added::Refused {
                            self.refused += 1;
                        }
                    }
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                    Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                    Err(_) => {
                        // Out of descriptors (or memory): the connection stays in the
                        // backlog, and the listener, still readable, would release the task
                        // again at once. Leave it to the period until an accept succeeds.
                        if let (Some(r), false) = (&self.registry, self.tcp_paused) {
                            self.tcp_paused = r.deregister(listener).is_ok();
                        }
                        break;
                    }
                }
            }
        }
        if let Some(listener) = &self.unix {
            loop {
                match listener.accept() {
                    Ok((stream, _)) => {
                        let _ = stream.set_nonblocking(true);
                        if self.guis.add(Stream::Unix(stream), None) == Added::Refused {
                            self.refused += 1;
                        }
                    }
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                    Err(_) => break,
                }
            }
        }
    }

    /// One cycle, released by `release` (public for tests that step the task by hand).
    pub fn step(&mut self, release: Release) {
        let period = release == Release::Period;
        let listener_ready = match &self.registry {
            // Take both marks (no short circuit): a stale one would cost an empty accept.
            Some(r) => r.take_ready(TCP_LISTENER) | r.take_ready(UNIX_LISTENER),
            None => false,
        };
        // Without a registry (under virtual time) nothing marks a listener ready: every
        // cycle looks (a non-blocking accept).
        if period || listener_ready || self.registry.is_none() {
            self.accept(period);
        }
        for set in [&mut self.hosts, &mut self.guis] {
            if period {
                set.poll_reads();
            } else {
                set.read_ready();
            }
        }
        // The whole queue each cycle: the notification that released this cycle may stand
        // for several lines (see `MessageQueue::with_notify`).
        while let Ok(line) = self.replies.try_recv() {
            self.hosts.deliver(&line);
            self.guis.deliver(&line);
        }
        for set in [&mut self.hosts, &mut self.guis] {
            if period {
                set.close_idle();
                set.status_stream();
                set.flush();
            } else {
                set.flush_new();
            }
        }
    }
}

impl Ethernet {
    /// Record every line read and delivered: hosts into `hosts`, GUIs into `guis`.
    pub fn set_trace(&mut self, hosts: MessageTap, guis: MessageTap) {
        self.hosts.set_trace(hosts);
        self.guis.set_trace(guis);
    }
}

impl Task for Ethernet {
    fn cycle(&mut self, ctx: &CycleContext) {
        self.hosts.set_time(ctx.woke_ns);
        self.guis.set_time(ctx.woke_ns);
        self.step(ctx.release);
    }
}
