//! `wrc ui` as a browser and an operator meet it: real processes (`wrc up` with its GUI, or
//! `wrc ui` alone against a controller's TCP port), driven over HTTP and WebSocket the way
//! the web app does (docs/gui.md). The browser itself is exercised by web/e2e.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use tungstenite::{Message, WebSocket};

use crate::up::{free_port, Controller};
use crate::{poll_until, wait_until, PATIENCE};

type Ws = WebSocket<TcpStream>;

fn connect_ws(port: u16, query: &str) -> Result<Ws, String> {
    let stream = poll_until(PATIENCE, || {
        TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())
    })
    .map_err(|e| format!("no GUI port: {e}"))?;
    stream
        .set_read_timeout(Some(Duration::from_secs(30)))
        .unwrap();
    let url = format!("ws://127.0.0.1:{port}/ws{query}");
    tungstenite::client(url.as_str(), stream)
        .map(|(ws, _)| ws)
        .map_err(|e| e.to_string())
}

/// The next text frame (binary simulator frames are counted and skipped).
fn text(ws: &mut Ws, binaries: &mut usize) -> String {
    loop {
        match ws.read().expect("a frame before the timeout") {
            Message::Text(t) => return t.to_string(),
            Message::Binary(_) => *binaries += 1,
            _ => {}
        }
    }
}

/// Send `line` and collect text frames until the first non-event line.
fn ask(ws: &mut Ws, line: &str) -> (Vec<String>, String) {
    ws.send(Message::Text(line.into())).unwrap();
    let mut events = Vec::new();
    let mut binaries = 0;
    loop {
        let t = text(ws, &mut binaries);
        if t.starts_with("EVT ") {
            events.push(t);
        } else {
            return (events, t);
        }
    }
}

fn wait_for(ws: &mut Ws, what: impl Fn(&str) -> bool) -> String {
    let mut binaries = 0;
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        assert!(Instant::now() < deadline, "timed out waiting");
        let t = text(ws, &mut binaries);
        if what(&t) {
            return t;
        }
    }
}

fn http_get(port: u16, path: &str) -> (String, Vec<u8>) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    // Read to the end: the connection must close after the reply.
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut all = Vec::new();
    s.read_to_end(&mut all).unwrap();
    let split = all.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&all[..split]).to_string();
    (head, all[split + 4..].to_vec())
}

/// The pid of `wrc up`'s `wrc ui` child.
fn ui_child(up_pid: u32) -> i32 {
    let children = std::fs::read_to_string(format!("/proc/{up_pid}/task/{up_pid}/children"))
        .expect("children of wrc up");
    children
        .split_whitespace()
        .filter_map(|p| p.parse::<i32>().ok())
        .find(|p| {
            std::fs::read(format!("/proc/{p}/cmdline"))
                .map(|c| c.split(|b| *b == 0).any(|a| a == b"ui"))
                .unwrap_or(false)
        })
        .expect("wrc up started wrc ui")
}

#[test]
fn the_gui_bridges_requests_events_and_the_simulator_stream() {
    let ui_port = free_port();
    let port_arg = ui_port.to_string();
    let c = Controller::start(&["--ui-port", &port_arg]);
    let mut ws = connect_ws(ui_port, "").unwrap();
    let mut binaries = 0;
    let hello = text(&mut ws, &mut binaries);
    assert!(hello.starts_with("EVT UI CONNECTED unix:"), "{hello}");

    // The robot as the 3D view builds it, and its named signals.
    let (events, ack) = ask(&mut ws, "1 ROBOT");
    let axes: Vec<&String> = events
        .iter()
        .filter(|l| l.starts_with("EVT AXIS "))
        .collect();
    assert_eq!(axes.len(), 4, "{events:?}");
    assert!(
        axes[1].starts_with("EVT AXIS 2 name=j2 role=elbow unit=deg"),
        "{axes:?}"
    );
    assert!(
        events.contains(&"EVT SIGNAL out 0 guarded vacuum valve".to_string()),
        "{events:?}"
    );
    assert!(
        ack.starts_with("ACK 1 name=paper-300mm link1=200 link2=200"),
        "{ack}"
    );

    // Task timing for the plots: eight tasks, each with its histogram.
    let (tasks, ack) = ask(&mut ws, "2 TASKS");
    assert_eq!(ack, "ACK 2 tasks=8");
    assert!(
        tasks[1].starts_with("EVT TASK pulse_generator prio=20 period_ms=10"),
        "{tasks:?}"
    );
    assert!(tasks.iter().all(|t| t.contains(" lat_hist=")), "{tasks:?}");

    // Several lines in one frame are several requests; each browser is its own source.
    ws.send(Message::Text("3 CONTROL\n4 STATUS".into()))
        .unwrap();
    assert_eq!(
        wait_for(&mut ws, |t| t.starts_with("ACK 3")),
        "ACK 3 owner=gui0"
    );
    let status = wait_for(&mut ws, |t| t.starts_with("ACK 4"));
    assert!(status.contains("owner=gui0"), "{status}");

    // Simulator datagrams arrive as binary frames in the documented layout.
    let mut frames = Vec::new();
    while frames.len() < 5 {
        if let Message::Binary(b) = ws.read().unwrap() {
            frames.push(wrc_protocol::sim_stream::decode(&b).expect("a valid datagram"));
        }
    }
    assert!(frames.iter().all(|f| f.axis_count == 4));
    assert!(frames.windows(2).all(|w| w[1].sequence > w[0].sequence));

    // A motion through the GUI ends with INF like on any connection.
    let (_, ack) = ask(&mut ws, "5 HOME");
    assert_eq!(ack, "ACK 5");
    let end = wait_for(&mut ws, |t| {
        t.starts_with("INF 5") || t.starts_with("ABS 5")
    });
    assert_eq!(end, "INF 5");

    // The app itself (or the page saying how to build it) and no escaping the folder.
    let (head, _) = http_get(ui_port, "/");
    assert!(
        head.starts_with("HTTP/1.1 200") || head.starts_with("HTTP/1.1 503"),
        "{head}"
    );
    let (head, body) = http_get(ui_port, "/../../../../etc/passwd");
    assert!(!head.starts_with("HTTP/1.1 200"), "{head}");
    assert!(!String::from_utf8_lossy(&body).contains("root:"));
    drop(c);
}

#[test]
fn a_page_of_another_origin_cannot_open_the_websocket() {
    let ui_port = free_port();
    let port_arg = ui_port.to_string();
    let _c = Controller::start(&["--ui-port", &port_arg]);
    let _ = connect_ws(ui_port, "").unwrap();
    let mut s = TcpStream::connect(("127.0.0.1", ui_port)).unwrap();
    write!(
        s,
        "GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{ui_port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\
         Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\
         Origin: http://evil.example\r\n\r\n"
    )
    .unwrap();
    let mut reply = String::new();
    s.read_to_string(&mut reply).unwrap();
    assert!(reply.starts_with("HTTP/1.1 403"), "{reply}");
}

/// Kill -9 of the GUI process while its browser holds control and the robot moves: the
/// controller stops the motion as for any lost controlling client (208), and goes on
/// serving everyone else; a new `wrc ui` on the same socket works.
#[test]
fn killing_the_gui_leaves_the_controller_serving() {
    let ui_port = free_port();
    let port_arg = ui_port.to_string();
    let c = Controller::start(&["--ui-port", &port_arg]);
    let mut host = c.client();
    let mut ws = connect_ws(ui_port, "").unwrap();
    wait_for(&mut ws, |t| t.starts_with("EVT UI CONNECTED"));
    assert_eq!(ask(&mut ws, "1 HOME").1, "ACK 1");
    assert_eq!(
        wait_for(&mut ws, |t| t.starts_with("INF 1")
            || t.starts_with("ABS 1")),
        "INF 1"
    );
    assert_eq!(ask(&mut ws, "2 CONTROL").1, "ACK 2 owner=gui0");
    // Far in J1, J3 and Z with the arm folded (J2 150°): clear of the cell at any height,
    // it goes straight, and so does its brake.
    assert_eq!(ask(&mut ws, "3 MOVJ 170 150 200 290").1, "ACK 3");
    wait_for(&mut ws, |t| t == "EVT STATE MOVING");

    // SAFETY: signals the wrc ui process that wrc up started.
    unsafe {
        libc::kill(ui_child(c.pid()), libc::SIGKILL);
    }
    let lost = loop {
        let l = host.line();
        if l.starts_with("EVT ERROR") {
            break l;
        }
    };
    assert!(lost.starts_with("EVT ERROR 208"), "{lost}");
    wait_until("control freed and the robot stopping", || {
        let status = host.status();
        if status.contains("owner=none") && !status.contains("MOVING") {
            Ok(())
        } else {
            Err(status)
        }
    });
    // The fault is answered at once; WAIT answers when the arm has braked to a standstill.
    assert_eq!(host.ask("9 WAIT"), "ACK 9");
    let r = host.reply();
    assert!(r.starts_with("ABS 9 208"), "{r}");
    assert_eq!(host.ask("10 RESET"), "ACK 10");
    assert_eq!(host.motion(11, "MOVJ 0 150 -90 10"), "INF 11");

    // A new GUI on the same controller socket serves again.
    let socket = c.dir_path().join("wrc.sock");
    let ui_port2 = free_port();
    let mut ui = Command::new(env!("CARGO_BIN_EXE_wrc"))
        .args([
            "ui",
            "--no-sim",
            "--ui-port",
            &ui_port2.to_string(),
            "--controller",
        ])
        .arg(&socket)
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let mut ws2 = connect_ws(ui_port2, "").unwrap();
    wait_for(&mut ws2, |t| t.starts_with("EVT UI CONNECTED"));
    let (_, r) = ask(&mut ws2, "12 WHERE");
    assert!(r.starts_with("ACK 12 j=0,150,-90,10"), "{r}");
    stop(&mut ui);
    c.stop_clear_of_the_cell();
}

fn stop(child: &mut Child) {
    // SAFETY: signals our own child.
    unsafe {
        libc::kill(child.id() as libc::pid_t, libc::SIGTERM);
    }
    let stopped = poll_until(PATIENCE, || {
        child
            .try_wait()
            .unwrap()
            .ok_or_else(|| "running".to_string())
    });
    if stopped.is_err() {
        let _ = child.kill();
    }
}

/// On another PC: `wrc ui --controller HOST:PORT` over TCP, listening off loopback only with
/// a token that every WebSocket must present.
#[test]
fn a_remote_gui_needs_a_token_off_loopback() {
    let c = Controller::start(&[]);
    let controller = format!("127.0.0.1:{}", c.port);
    let ui_port = free_port().to_string();
    let remote_ui = || {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_wrc"));
        cmd.args([
            "ui",
            "--no-sim",
            "--listen",
            "0.0.0.0",
            "--ui-port",
            &ui_port,
        ])
        .args(["--controller", &controller])
        .env_remove("WRC_UI_TOKEN");
        cmd
    };
    let refused = remote_ui().output().unwrap();
    assert_eq!(refused.status.code(), Some(2));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(err.contains("requires --token"), "{err}");

    let mut ui = remote_ui()
        .args(["--token", "s3cret-token"])
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let port: u16 = ui_port.parse().unwrap();
    let without = connect_ws(port, "").unwrap_err();
    assert!(without.contains("403"), "{without}");
    let wrong = connect_ws(port, "?token=s3cret-tokex").unwrap_err();
    assert!(wrong.contains("403"), "{wrong}");
    let mut ws = connect_ws(port, "?token=s3cret-token").unwrap();
    let hello = wait_for(&mut ws, |t| t.starts_with("EVT UI"));
    assert_eq!(hello, format!("EVT UI CONNECTED tcp:{controller}"));
    let (_, r) = ask(&mut ws, "7 CONTROL");
    assert!(r.starts_with("ACK 7 owner=tcp"), "{r}");
    stop(&mut ui);
}

/// A controller that asks for a control token: `wrc ui --controller-token-file` presents it
/// on each browser's connection, and a wrong one is reported instead of connecting.
#[test]
fn the_gui_presents_the_controllers_token() {
    use std::os::unix::fs::PermissionsExt;
    let keys = tempfile::tempdir().unwrap();
    let write_token = |name: &str, text: &str| {
        let path = keys.path().join(name);
        std::fs::write(&path, text).unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).unwrap();
        path
    };
    let good = write_token("good.token", "s3cret-token-0123456789\n");
    let wrong = write_token("wrong.token", "wrong-token-0123456789\n");
    let c = Controller::start(&["--token-file", good.to_str().unwrap()]);
    let controller = format!("127.0.0.1:{}", c.port);
    let gui = |token: &std::path::Path| {
        let ui_port = free_port();
        let child = Command::new(env!("CARGO_BIN_EXE_wrc"))
            .args(["ui", "--no-sim", "--ui-port", &ui_port.to_string()])
            .args(["--controller", &controller])
            .arg("--controller-token-file")
            .arg(token)
            .stdout(Stdio::null())
            .spawn()
            .unwrap();
        (child, ui_port)
    };
    let (mut ui, port) = gui(&good);
    let mut ws = connect_ws(port, "").unwrap();
    let hello = wait_for(&mut ws, |t| t.starts_with("EVT UI"));
    assert_eq!(hello, format!("EVT UI CONNECTED tcp:{controller}"));
    let (_, r) = ask(&mut ws, "7 CONTROL");
    assert!(r.starts_with("ACK 7 owner=tcp"), "{r}");
    stop(&mut ui);

    let (mut ui, port) = gui(&wrong);
    let mut ws = connect_ws(port, "").unwrap();
    let hello = wait_for(&mut ws, |t| t.starts_with("EVT UI"));
    assert!(
        hello.starts_with("EVT UI DISCONNECTED")
            && hello.contains("refused the control token: NAK 108 wrong token"),
        "{hello}"
    );
    stop(&mut ui);
}
