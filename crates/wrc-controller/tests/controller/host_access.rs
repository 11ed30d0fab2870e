//! The host port's admission, on the TCP client set as the Ethernet task drives it: who may
//! connect and with what rights (`allow`, `monitor`, the control token), the per-address and
//! total limits that make room by closing the least recently active connection without
//! control, and the idle timeout. Each client is one end of a socket pair handed to the set
//! with the peer address the rules judge (so addresses off this machine can be tried); the
//! set's clock is set by hand.

use std::io::{BufRead, BufReader, ErrorKind, Read};
use std::net::IpAddr;
use std::os::unix::net::UnixStream;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;

use wrc_config::{Config, HostConfig};
use wrc_controller::clients::{Added, ClientSet, Routes, Stream};
use wrc_controller::host_access::HostAccess;
use wrc_controller::messages::{Incoming, SourceId, Urgent};
use wrc_controller::shared::Shared;
use wrc_protocol::{AuthToken, Command};
use wrc_rt::ipc::{MessageQueue, Semaphore};

const TOKEN: &str = "s3cret-token-0123456789";
const S: u64 = 1_000_000_000;

struct Rig {
    set: ClientSet,
    shared: Arc<Shared>,
    incoming: Arc<MessageQueue<Incoming>>,
    urgent: Arc<MessageQueue<Urgent>>,
}

/// One client: the far end of its socket pair.
struct Peer {
    r: BufReader<UnixStream>,
}

impl Peer {
    fn send(&mut self, line: &str) {
        use std::io::Write;
        self.r
            .get_mut()
            .write_all(format!("{line}\n").as_bytes())
            .unwrap();
    }

    fn line(&mut self) -> String {
        let mut l = String::new();
        self.r.read_line(&mut l).expect("a line before the timeout");
        l.trim_end().to_string()
    }

    /// Whether the controller closed its end (EOF, or a reset after unread input).
    fn closed(&mut self) -> bool {
        let mut byte = [0u8; 1];
        match self.r.read(&mut byte) {
            Ok(0) => true,
            Err(e) if e.kind() == ErrorKind::ConnectionReset => true,
            Ok(_) => false,
            Err(e) => panic!("neither a line nor the end: {e}"),
        }
    }
}

fn ip(text: &str) -> IpAddr {
    text.parse().unwrap()
}

impl Rig {
    fn new(host: HostConfig, token: Option<&str>) -> Rig {
        let config = Config::embedded_default();
        let shared = Arc::new(Shared::default());
        let incoming = Arc::new(MessageQueue::new(64));
        let urgent = Arc::new(MessageQueue::new(8));
        let routes = Routes {
            incoming: incoming.clone(),
            urgent: urgent.clone(),
            wake: Arc::new(Semaphore::new(0)),
            store: Arc::new(MessageQueue::new(8)),
        };
        let access = HostAccess::new(&host, token.map(|t| AuthToken::new(t).unwrap()));
        let set = ClientSet::new(
            SourceId::TCP,
            host.max_connections,
            false,
            config.robot.clone(),
            shared.clone(),
            routes,
        )
        .with_access(access);
        Rig {
            set,
            shared,
            incoming,
            urgent,
        }
    }

    /// A client from `peer` at `now_s` [s].
    fn connect(&mut self, peer: &str, now_s: u64) -> (Peer, Added) {
        let (ours, theirs) = UnixStream::pair().unwrap();
        ours.set_nonblocking(true).unwrap();
        theirs
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        self.set.set_time(now_s * S);
        let added = self.set.add(Stream::Unix(ours), Some(ip(peer)));
        self.set.flush();
        (
            Peer {
                r: BufReader::new(theirs),
            },
            added,
        )
    }

    /// Read every client at `now_s` [s], then write what is queued.
    fn cycle(&mut self, now_s: u64) {
        self.set.set_time(now_s * S);
        self.set.poll_reads();
        self.set.close_idle();
        self.set.flush();
    }

    /// `line` from `peer` at `now_s`: the set's immediate reply, if any.
    fn ask(&mut self, peer: &mut Peer, line: &str, now_s: u64) {
        peer.send(line);
        self.cycle(now_s);
    }

    fn routed(&self) -> Vec<(SourceId, Command)> {
        let mut got = Vec::new();
        while let Ok(m) = self.incoming.try_recv() {
            if let Incoming::Request(from, r) = m {
                got.push((from, r.command));
            }
        }
        got
    }

    fn urgent(&self) -> usize {
        let mut n = 0;
        while self.urgent.try_recv().is_ok() {
            n += 1;
        }
        n
    }
}

fn guarded() -> HostConfig {
    HostConfig {
        allow: vec!["192.168.1.0/24".parse().unwrap()],
        monitor: vec!["10.0.0.0/8".parse().unwrap()],
        ..HostConfig::default()
    }
}

#[test]
fn a_monitoring_address_reads_but_cannot_act_even_with_the_token() {
    let mut rig = Rig::new(guarded(), Some(TOKEN));
    let (mut m, added) = rig.connect("10.2.3.4", 0);
    assert_eq!(added, Added::Yes);
    rig.ask(&mut m, "1 STATUS", 0);
    assert!(matches!(rig.routed()[..], [(_, Command::Status)]));
    for request in ["2 ESTOP", "3 MOVJ 0 0 0 0", "4 CONTROL", "5 UPLOAD p"] {
        rig.ask(&mut m, request, 0);
        let id = &request[..1];
        assert!(m.line().starts_with(&format!("NAK {id} 107 ")), "{request}");
    }
    rig.ask(&mut m, &format!("6 AUTH {TOKEN}"), 0);
    assert!(m.line().starts_with("NAK 6 108 "));
    rig.ask(&mut m, "7 STOP", 0);
    assert!(m.line().starts_with("NAK 7 107 "));
    assert!(rig.routed().is_empty());
    assert_eq!(
        rig.urgent(),
        0,
        "a monitor's STOP or ESTOP reached the urgent path"
    );
}

#[test]
fn an_allowed_address_commands_after_auth_and_three_wrong_tokens_close_it() {
    let mut rig = Rig::new(guarded(), Some(TOKEN));
    let (mut h, _) = rig.connect("192.168.1.7", 0);
    rig.ask(&mut h, "1 ESTOP", 0);
    assert_eq!(
        h.line(),
        "NAK 1 107 this connection may only monitor until AUTH <token>"
    );
    rig.ask(&mut h, "2 AUTH wrong-token-0123456789", 0);
    assert_eq!(h.line(), "NAK 2 108 wrong token");
    rig.ask(&mut h, &format!("3 AUTH {TOKEN}"), 0);
    assert_eq!(h.line(), "ACK 3 rights=command");
    rig.ask(&mut h, "4 ESTOP", 0);
    assert_eq!(
        rig.urgent(),
        1,
        "the ESTOP after AUTH did not reach the urgent path"
    );
    rig.ask(&mut h, "5 MOVJ 0 0 0 0", 0);
    assert!(matches!(rig.routed()[..], [(_, Command::MovJ { .. })]));

    let (mut g, _) = rig.connect("192.168.1.8", 0);
    for id in 1..=3 {
        rig.ask(&mut g, &format!("{id} AUTH wrong-token-0123456789"), 0);
        assert_eq!(g.line(), format!("NAK {id} 108 wrong token"));
    }
    assert!(g.line().starts_with("EVT CLOSING AUTH "));
    assert!(g.closed());
    // The other connection is untouched.
    rig.ask(&mut h, "6 STATUS", 0);
    assert!(matches!(rig.routed()[..], [(_, Command::Status)]));
}

#[test]
fn an_unlisted_address_is_told_and_closed_and_loopback_always_commands() {
    let mut rig = Rig::new(guarded(), Some(TOKEN));
    let (mut x, added) = rig.connect("172.16.0.1", 0);
    assert_eq!(added, Added::Refused);
    assert_eq!(
        x.line(),
        "EVT CLOSING DENIED 172.16.0.1 may not connect to this controller"
    );
    assert!(x.closed());
    assert_eq!(rig.set.connected(), 0);
    let (mut local, _) = rig.connect("127.0.0.1", 0);
    rig.ask(&mut local, "1 ESTOP", 0);
    assert_eq!(rig.urgent(), 1);
    rig.ask(&mut local, &format!("2 AUTH {TOKEN}"), 0);
    assert_eq!(local.line(), "ACK 2 rights=command");
    // Loopback needs no token, but a wrong one is still called wrong.
    rig.ask(&mut local, "3 AUTH wrong-token-0123456789", 0);
    assert_eq!(local.line(), "NAK 3 108 wrong token");
    rig.ask(&mut local, "4 ESTOP", 0);
    assert_eq!(rig.urgent(), 1);
}

#[test]
fn an_address_at_its_limit_replaces_its_own_least_recently_active_connection_never_the_controlling_one(
) {
    let host = HostConfig {
        max_connections: 8,
        max_per_address: 3,
        ..HostConfig::default()
    };
    let mut rig = Rig::new(host, None);
    let (mut other, _) = rig.connect("127.0.0.2", 0);
    let (mut a1, _) = rig.connect("127.0.0.1", 1);
    // a1 takes control at 1 and is the least recently active from then on.
    rig.ask(&mut a1, "CONTROL", 1);
    let Some((owner, _)) = rig.routed().pop() else {
        panic!("CONTROL was not routed");
    };
    rig.shared.owner.store(owner.0, Ordering::Release);
    let (mut a2, _) = rig.connect("127.0.0.1", 2);
    let (mut a3, _) = rig.connect("127.0.0.1", 3);
    rig.ask(&mut a2, "STATUS", 5);
    let (mut a4, added) = rig.connect("127.0.0.1", 6);
    assert_eq!(added, Added::Evicted);
    // a3 (active at 3) goes: a1 (1) holds control, a2 spoke at 5.
    assert!(a3.line().starts_with(
        "EVT CLOSING ADDRESS 127.0.0.1 holds 3 connections, the most one address may"
    ));
    assert!(a3.closed());
    rig.routed();
    for (name, peer) in [
        ("a1", &mut a1),
        ("a2", &mut a2),
        ("a4", &mut a4),
        ("other", &mut other),
    ] {
        rig.ask(peer, "STATUS", 7);
        assert_eq!(rig.routed().len(), 1, "{name} lost its connection");
    }
    assert_eq!(rig.set.evicted, 1);
}

#[test]
fn a_full_set_replaces_the_least_recently_active_connection_of_all() {
    let host = HostConfig {
        max_connections: 3,
        max_per_address: 3,
        ..HostConfig::default()
    };
    let mut rig = Rig::new(host, None);
    let (mut a, _) = rig.connect("127.0.0.1", 0);
    let (mut b, _) = rig.connect("127.0.0.2", 1);
    let (mut c, _) = rig.connect("127.0.0.3", 2);
    rig.ask(&mut a, "STATUS", 3);
    let (mut d, added) = rig.connect("127.0.0.4", 4);
    assert_eq!(added, Added::Evicted);
    assert_eq!(
        b.line(),
        "EVT CLOSING FULL all 3 connections are taken; closing the least recently active one"
    );
    assert!(b.closed());
    rig.routed();
    for peer in [&mut a, &mut c, &mut d] {
        rig.ask(peer, "STATUS", 5);
        assert_eq!(rig.routed().len(), 1);
    }
}

#[test]
fn the_only_connection_left_to_close_holds_control_so_a_newcomer_is_refused() {
    let host = HostConfig {
        max_connections: 1,
        max_per_address: 1,
        ..HostConfig::default()
    };
    let mut rig = Rig::new(host, None);
    let (mut a, _) = rig.connect("127.0.0.1", 0);
    rig.ask(&mut a, "CONTROL", 0);
    let (owner, _) = rig.routed().pop().unwrap();
    rig.shared.owner.store(owner.0, Ordering::Release);
    let (mut b, added) = rig.connect("127.0.0.1", 1);
    assert_eq!(added, Added::Refused);
    assert!(b.line().starts_with("EVT CLOSING ADDRESS "));
    assert!(b.closed());
    rig.ask(&mut a, "STATUS", 2);
    assert_eq!(
        rig.routed().len(),
        1,
        "the controlling connection was closed"
    );
}

#[test]
fn a_silent_connection_without_control_or_subscription_is_closed_after_the_idle_timeout() {
    let host = HostConfig {
        idle_timeout_s: 60.0,
        ..HostConfig::default()
    };
    let mut rig = Rig::new(host, None);
    let (mut quiet, _) = rig.connect("127.0.0.1", 0);
    let (mut talker, _) = rig.connect("127.0.0.1", 0);
    let (mut subscriber, _) = rig.connect("127.0.0.1", 0);
    let (mut owner, _) = rig.connect("127.0.0.1", 0);
    rig.ask(&mut subscriber, "1 SUBSCRIBE", 0);
    assert_eq!(subscriber.line(), "ACK 1");
    rig.ask(&mut owner, "CONTROL", 0);
    let (source, _) = rig.routed().pop().unwrap();
    rig.shared.owner.store(source.0, Ordering::Release);
    rig.ask(&mut talker, "STATUS", 30);
    rig.cycle(59);
    assert_eq!(rig.set.closed_idle, 0, "closed before the timeout");
    rig.cycle(60);
    assert_eq!(rig.set.closed_idle, 1);
    assert_eq!(
        quiet.line(),
        "EVT CLOSING IDLE no request for 60 s and no control or subscription; reconnect when needed"
    );
    assert!(quiet.closed());
    rig.cycle(89);
    assert_eq!(rig.set.closed_idle, 1);
    rig.cycle(90);
    assert!(talker.line().starts_with("EVT CLOSING IDLE "));
    rig.cycle(10_000);
    assert_eq!(
        rig.set.closed_idle, 2,
        "the subscriber or the owner was closed"
    );
    rig.routed();
    for peer in [&mut subscriber, &mut owner] {
        rig.ask(peer, "STATUS", 10_000);
        assert_eq!(rig.routed().len(), 1);
    }
}

#[test]
fn the_ethernet_task_closes_an_idle_host_on_its_period_in_virtual_time() {
    use wrc_controller::simulation::{SimCellFrom, Simulation};
    let mut config = Config::embedded_default();
    config.host.idle_timeout_s = 5.0;
    let dir = tempfile::tempdir().unwrap();
    let mut sim = Simulation::in_state_dir(
        &config,
        dir.path(),
        SimCellFrom::default(),
        Some("127.0.0.1:0".parse().unwrap()),
        "127.0.0.1:9".parse().unwrap(),
    )
    .unwrap();
    let mut quiet = sim.connect_tcp().unwrap();
    let mut busy = sim.connect_tcp().unwrap();
    let start = sim.now_ns();
    sim.run_for_ns(3 * S);
    assert!(sim
        .ask(&mut busy, "1 STATUS", S)
        .unwrap()
        .starts_with("ACK 1 "));
    let closing = sim.next_line(&mut quiet, 10 * S).unwrap();
    assert!(
        closing.starts_with("EVT CLOSING IDLE no request for 5 s"),
        "{closing}"
    );
    let waited = sim.now_ns() - start;
    // Closed on the first Ethernet period (100 ms) after 5 s of silence.
    assert!(
        (5 * S..5 * S + 200_000_000).contains(&waited),
        "closed after {waited} ns"
    );
    // The other one spoke 3 s in, so it is still open now.
    assert!(sim
        .ask(&mut busy, "2 STATUS", S)
        .unwrap()
        .starts_with("ACK 2 "));
}
