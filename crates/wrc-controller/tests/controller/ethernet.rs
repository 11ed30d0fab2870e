//! The Ethernet task, stepped by hand the way its thread runs it: wait on its `FdWake`, then
//! one cycle with the release the wait gave. Requests are routed in the event cycle their
//! line releases, replies are written in the event cycle their push releases, replies reach
//! the client they are for (TCP host or local GUI) and events reach every client, the status
//! stream goes out on the period only, and a flooding client cannot starve another.
//!
//! No sleeps: every wait has a far deadline that only bounds a failure, and sockets are read
//! with a timeout that only bounds a failure.

use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use wrc_config::Config;
use wrc_controller::clients::{ClientSet, Routes, READ_BUDGET};
use wrc_controller::ethernet::Ethernet;
use wrc_controller::messages::{Incoming, OutLine, SourceId, Urgent};
use wrc_controller::shared::Shared;
use wrc_protocol::Command;
use wrc_rt::ipc::{MessageQueue, Semaphore};
use wrc_rt::wake::{FdWake, Waiter};
use wrc_rt::{Clock, MonotonicClock, Release};

/// Clients of each kind the rig's task has room for.
const CLIENTS: usize = 4;

/// A deadline no test reaches unless it fails [ns].
fn far() -> u64 {
    MonotonicClock.now_ns() + 20_000_000_000
}

struct Rig {
    task: Ethernet,
    wake: FdWake,
    replies: Arc<MessageQueue<OutLine>>,
    incoming: Arc<MessageQueue<Incoming>>,
    urgent: Arc<MessageQueue<Urgent>>,
    urgent_wake: Arc<Semaphore>,
    tcp_addr: std::net::SocketAddr,
    gui_path: PathBuf,
    tcp: BufReader<TcpStream>,
    gui: BufReader<UnixStream>,
    _dir: tempfile::TempDir,
}

fn timed<S>(stream: S, set: impl Fn(&S, Option<Duration>) -> std::io::Result<()>) -> S {
    set(&stream, Some(Duration::from_secs(5))).unwrap();
    stream
}

impl Rig {
    /// The task as `controller::start` builds it, with one TCP host and one GUI connected
    /// and accepted.
    fn new() -> Rig {
        let config = Config::embedded_default();
        let shared = Arc::new(Shared::default());
        let incoming = Arc::new(MessageQueue::new(64));
        let urgent = Arc::new(MessageQueue::new(8));
        let urgent_wake = Arc::new(Semaphore::new(0));
        let routes = Routes {
            incoming: incoming.clone(),
            urgent: urgent.clone(),
            wake: urgent_wake.clone(),
            store: Arc::new(MessageQueue::new(8)),
        };
        let set = |kind| {
            ClientSet::new(
                kind,
                CLIENTS,
                false,
                config.robot.clone(),
                shared.clone(),
                routes.clone(),
            )
        };
        let tcp = TcpListener::bind("127.0.0.1:0").unwrap();
        tcp.set_nonblocking(true).unwrap();
        let tcp_addr = tcp.local_addr().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let gui_path = dir.path().join("gui.sock");
        let unix = UnixListener::bind(&gui_path).unwrap();
        unix.set_nonblocking(true).unwrap();
        let wake = FdWake::new(Ethernet::tokens(CLIENTS, CLIENTS)).unwrap();
        let replies = Arc::new(MessageQueue::with_notify(64, wake.notifier()));
        let task = Ethernet::new(
            Some(tcp),
            Some(unix),
            set(SourceId::TCP),
            set(SourceId::GUI),
            replies.clone(),
        )
        .released_by(wake.registry())
        .unwrap();
        let tcp = timed(
            TcpStream::connect(tcp_addr).unwrap(),
            TcpStream::set_read_timeout,
        );
        // Each request goes out at once, as a host's would (no Nagle delay).
        tcp.set_nodelay(true).unwrap();
        let gui = timed(
            UnixStream::connect(&gui_path).unwrap(),
            UnixStream::set_read_timeout,
        );
        let mut rig = Rig {
            task,
            wake,
            replies,
            incoming,
            urgent,
            urgent_wake,
            tcp_addr,
            gui_path,
            tcp: BufReader::new(tcp),
            gui: BufReader::new(gui),
            _dir: dir,
        };
        rig.settle();
        rig
    }

    /// Run event cycles until nothing is pending (the pending connections are accepted).
    fn settle(&mut self) {
        for _ in 0..100 {
            // A deadline already passed: the wait says at once whether an event is pending.
            if !self.wake.wait_until_ns(0) {
                return;
            }
            self.task.step(Release::Event);
        }
        panic!("events never stopped coming");
    }

    /// Wait for the next event (a failure if none comes before the far deadline), then run
    /// the event cycle it releases.
    fn event_cycle(&mut self) {
        assert!(self.wake.wait_until_ns(far()), "no event released the task");
        self.task.step(Release::Event);
    }

    fn requests(&self) -> Vec<(SourceId, Command)> {
        let mut got = Vec::new();
        while let Ok(m) = self.incoming.try_recv() {
            if let Incoming::Request(from, request) = m {
                got.push((from, request.command));
            }
        }
        got
    }

    /// The source id the Command Interpreter sees for each client.
    fn sources(&mut self) -> (SourceId, SourceId) {
        self.tcp.get_mut().write_all(b"STATUS\n").unwrap();
        self.gui.get_mut().write_all(b"STATUS\n").unwrap();
        let (mut tcp, mut gui) = (None, None);
        for _ in 0..4 {
            self.event_cycle();
            for (from, _) in self.requests() {
                match from.kind() {
                    SourceId::TCP => tcp = Some(from),
                    SourceId::GUI => gui = Some(from),
                    k => panic!("unexpected kind {k}"),
                }
            }
            if let (Some(t), Some(g)) = (tcp, gui) {
                return (t, g);
            }
        }
        panic!("the requests never reached the Command Interpreter's queue");
    }
}

fn read(r: &mut impl BufRead) -> String {
    let mut l = String::new();
    r.read_line(&mut l).expect("a line before the timeout");
    l.trim_end().to_string()
}

#[test]
fn a_request_is_routed_in_the_event_cycle_its_line_releases_and_its_reply_written_in_the_next() {
    let mut rig = Rig::new();
    // A new host is accepted in the event cycle its connection releases.
    let mut host = BufReader::new(timed(
        TcpStream::connect(rig.tcp_addr).unwrap(),
        TcpStream::set_read_timeout,
    ));
    rig.event_cycle();
    rig.settle();
    host.get_mut().write_all(b"1 SPEED 100\n").unwrap();
    rig.event_cycle();
    let routed = rig.requests();
    assert_eq!(routed.len(), 1, "{routed:?}");
    let (from, command) = routed[0];
    assert_eq!(from.kind(), SourceId::TCP);
    assert_eq!(command, Command::Speed(100.0));
    // The Command Interpreter's reply, pushed from any thread, releases the task again.
    rig.replies
        .try_send(OutLine::new(from, b"ACK 1\n"))
        .unwrap();
    rig.event_cycle();
    assert_eq!(read(&mut host), "ACK 1");
}

#[test]
fn replies_reach_their_own_client_of_either_kind_and_events_reach_all() {
    let mut rig = Rig::new();
    let (tcp, gui) = rig.sources();
    // The GUI's line is queued first: draining for the hosts must not swallow it.
    for line in [
        OutLine::new(gui, b"ACK for-gui\n"),
        OutLine::new(tcp, b"ACK for-tcp\n"),
        OutLine::new(SourceId::NONE, b"EVT STATE IDLE\n"),
    ] {
        rig.replies.try_send(line).unwrap();
    }
    // Three pushes, one release: the cycle drains the whole queue.
    rig.event_cycle();
    assert_eq!(read(&mut rig.gui), "ACK for-gui");
    assert_eq!(read(&mut rig.gui), "EVT STATE IDLE");
    assert_eq!(read(&mut rig.tcp), "ACK for-tcp");
    assert_eq!(read(&mut rig.tcp), "EVT STATE IDLE");
    assert!(!rig.wake.wait_until_ns(0), "nothing left to release it");
}

#[test]
fn the_status_stream_goes_out_on_every_period_and_never_on_events() {
    let mut rig = Rig::new();
    rig.gui.get_mut().write_all(b"SUBSCRIBE\n").unwrap();
    rig.event_cycle();
    assert_eq!(read(&mut rig.gui), "ACK");
    // Event cycles in between send no sample: the next line is the marker.
    rig.replies
        .try_send(OutLine::new(SourceId::NONE, b"EVT MARK\n"))
        .unwrap();
    rig.event_cycle();
    assert_eq!(read(&mut rig.gui), "EVT MARK");
    for _ in 0..3 {
        rig.task.step(Release::Period);
    }
    for _ in 0..3 {
        let l = read(&mut rig.gui);
        assert!(l.starts_with("EVT STATUS "), "{l}");
    }
}

#[test]
fn a_flooding_client_does_not_starve_another() {
    let mut rig = Rig::new();
    let mut flood = UnixStream::connect(&rig.gui_path).unwrap();
    let mut other = UnixStream::connect(&rig.gui_path).unwrap();
    rig.settle();
    // 3 000 requests in one burst, then one line from another client.
    flood.write_all(&b"STATUS\n".repeat(3_000)).unwrap();
    other.write_all(b"7 SPEED 50\n").unwrap();
    rig.event_cycle();
    let routed = rig.requests();
    let speed: Vec<_> = routed
        .iter()
        .filter(|(_, c)| *c == Command::Speed(50.0))
        .collect();
    assert_eq!(
        speed.len(),
        1,
        "the other client's line waits behind the flood"
    );
    let flooded = routed.len() - 1;
    assert!(
        (1..=READ_BUDGET / b"STATUS\n".len()).contains(&flooded),
        "{flooded} lines of the flood in one cycle"
    );
    // The rest of the flood is still unread, so the task is released again at once.
    assert!(rig.wake.wait_until_ns(0));
}

#[test]
fn a_client_that_goes_away_is_reported_and_no_longer_releases_the_task() {
    let mut rig = Rig::new();
    let (_, gui) = rig.sources();
    drop(std::mem::replace(
        &mut rig.gui,
        BufReader::new(UnixStream::pair().unwrap().0),
    ));
    rig.event_cycle();
    let mut gone = Vec::new();
    while let Ok(m) = rig.incoming.try_recv() {
        if let Incoming::Disconnected(from) = m {
            gone.push(from);
        }
    }
    assert_eq!(gone, [gui]);
    assert!(
        !rig.wake.wait_until_ns(0),
        "a closed client still releases it"
    );
}

#[test]
fn event_cycles_allocate_nothing() {
    wrc_alloc_count::assert_installed();
    let mut rig = Rig::new();
    let (tcp, gui) = rig.sources();
    let (calls, ()) = wrc_alloc_count::allocations_in(|| {
        for i in 0..50 {
            rig.tcp.get_mut().write_all(b"1 SPEED 100\n").unwrap();
            rig.event_cycle();
            while rig.incoming.try_recv().is_ok() {}
            let to = if i % 2 == 0 { tcp } else { gui };
            rig.replies.try_send(OutLine::new(to, b"ACK 1\n")).unwrap();
            rig.event_cycle();
        }
    });
    assert_eq!(calls.total(), 0, "{calls:?}");
    for _ in 0..25 {
        assert_eq!(read(&mut rig.tcp), "ACK 1");
        assert_eq!(read(&mut rig.gui), "ACK 1");
    }
}

#[test]
fn estop_and_stop_overtake_a_full_request_queue_from_a_host_and_a_gui() {
    let mut rig = Rig::new();
    let (tcp, gui) = rig.sources();
    // The Command Interpreter is busy: its request queue is full.
    while rig
        .incoming
        .try_send(Incoming::Disconnected(SourceId::NONE))
        .is_ok()
    {}
    rig.tcp.get_mut().write_all(b"7 ESTOP\n").unwrap();
    rig.event_cycle();
    rig.gui.get_mut().write_all(b"STOP\n").unwrap();
    rig.event_cycle();
    // Both went to the urgent path, each with one post of its semaphore, in the event cycle
    // their line released; neither was refused as busy.
    let mut got = Vec::new();
    while let Ok(u) = rig.urgent.try_recv() {
        got.push(u);
    }
    assert!(
        matches!(got[..], [Urgent::Estop(a, _), Urgent::Stop(b, _)] if a == tcp && b == gui),
        "{got:?}"
    );
    assert_eq!(rig.urgent_wake.count(), 2);
    assert!(rig.replies.is_empty());
}
