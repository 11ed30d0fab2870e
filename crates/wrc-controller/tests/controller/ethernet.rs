//! The Ethernet task, stepped by hand: replies reach the client they are for, whichever
//! kind of client (TCP host or local GUI), and events reach every client.

use std::io::{BufRead, BufReader};
use std::net::{TcpListener, TcpStream};
use std::os::unix::net::{UnixListener, UnixStream};
use std::sync::Arc;
use std::time::Duration;

use wrc_config::Config;
use wrc_controller::clients::{ClientSet, Incoming, Routes};
use wrc_controller::ethernet::Ethernet;
use wrc_controller::shared::{OutLine, Shared, SourceId};
use wrc_rt::ipc::{MessageQueue, Semaphore};

struct Rig {
    task: Ethernet,
    replies: Arc<MessageQueue<OutLine>>,
    incoming: Arc<MessageQueue<Incoming>>,
    tcp: BufReader<TcpStream>,
    gui: BufReader<UnixStream>,
    _dir: tempfile::TempDir,
}

impl Rig {
    fn new() -> Rig {
        let config = Config::embedded_default();
        let shared = Arc::new(Shared::default());
        let incoming = Arc::new(MessageQueue::new(64));
        let routes = Routes {
            incoming: incoming.clone(),
            urgent: Arc::new(MessageQueue::new(8)),
            wake: Arc::new(Semaphore::new(0)),
            store: Arc::new(MessageQueue::new(8)),
        };
        let set = |kind| {
            ClientSet::new(
                kind,
                4,
                false,
                config.robot.clone(),
                shared.clone(),
                routes.clone(),
            )
        };
        let tcp = TcpListener::bind("127.0.0.1:0").unwrap();
        tcp.set_nonblocking(true).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("gui.sock");
        let unix = UnixListener::bind(&path).unwrap();
        unix.set_nonblocking(true).unwrap();
        let tcp_client = TcpStream::connect(tcp.local_addr().unwrap()).unwrap();
        let gui_client = UnixStream::connect(&path).unwrap();
        for t in [
            tcp_client.set_read_timeout(Some(Duration::from_secs(5))),
            gui_client.set_read_timeout(Some(Duration::from_secs(5))),
        ] {
            t.unwrap();
        }
        let replies = Arc::new(MessageQueue::new(64));
        let mut task = Ethernet::new(
            Some(tcp),
            Some(unix),
            set(SourceId::TCP),
            set(SourceId::GUI),
            replies.clone(),
        );
        task.step();
        Rig {
            task,
            replies,
            incoming,
            tcp: BufReader::new(tcp_client),
            gui: BufReader::new(gui_client),
            _dir: dir,
        }
    }

    /// The source id the Command Interpreter would see for each client.
    fn sources(&mut self) -> (SourceId, SourceId) {
        use std::io::Write;
        self.tcp.get_mut().write_all(b"STATUS\n").unwrap();
        self.gui.get_mut().write_all(b"STATUS\n").unwrap();
        let mut tcp = None;
        let mut gui = None;
        for _ in 0..200 {
            self.task.step();
            while let Ok(Incoming::Request(from, _)) = self.incoming.try_recv() {
                match from.kind() {
                    SourceId::TCP => tcp = Some(from),
                    SourceId::GUI => gui = Some(from),
                    k => panic!("unexpected kind {k}"),
                }
            }
            if let (Some(t), Some(g)) = (tcp, gui) {
                return (t, g);
            }
            std::thread::sleep(Duration::from_millis(5));
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
    rig.task.step();
    assert_eq!(read(&mut rig.gui), "ACK for-gui");
    assert_eq!(read(&mut rig.gui), "EVT STATE IDLE");
    assert_eq!(read(&mut rig.tcp), "ACK for-tcp");
    assert_eq!(read(&mut rig.tcp), "EVT STATE IDLE");
}

#[test]
fn a_subscribed_gui_gets_status_samples_every_cycle() {
    let mut rig = Rig::new();
    use std::io::Write;
    rig.gui.get_mut().write_all(b"SUBSCRIBE\n").unwrap();
    let mut samples = 0;
    for _ in 0..3 {
        rig.task.step();
        std::thread::sleep(Duration::from_millis(5));
    }
    let mut lines = Vec::new();
    while samples < 3 {
        let l = read(&mut rig.gui);
        if l.starts_with("EVT STATUS ") {
            samples += 1;
        }
        lines.push(l);
    }
    assert_eq!(lines[0], "ACK", "{lines:?}");
}
