//! `wrc up` and `wrc send` as an equipment engineer uses them: real processes (controller and
//! simulated board) on free ports in a temporary directory, driven over TCP, the serial line
//! (a pty) and UDP.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use wrc_protocol::reply_field;

use crate::{wait_until, BoardView};

/// Board periods (10 ms each) that a test watches the arm after a stop to see nothing move.
pub(crate) const STILL_PERIODS: u64 = 30;

/// A long PTP from HOME (J1 -75°, J2 150°, J3 -75° [deg], Z 0 [mm]) for a test to stop,
/// hold or lose on the way: J1 turns 245°, J3 75° and Z rises 250 mm, with the arm folded
/// (J2 150°) all the way, so that the hand and the links stay within about 230 mm of the
/// base, short of every station of the demo cell (their boxes begin 270-315 mm out) at any
/// height: it goes straight, and so does any brake along it.
pub(crate) const LONG_MOVE: &str = "MOVJ 170 150 0 250";

pub(crate) struct Controller {
    child: Child,
    pub(crate) port: u16,
    sim_port: u16,
    dir: tempfile::TempDir,
}

pub(crate) fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Run `wrc up --no-rt --no-ui` on free ports of `host` (`127.0.0.1`, or `0.0.0.0` for a
/// port the network reaches) in `dir` with `extra` arguments, to its end: for starts that
/// must be refused.
pub(crate) fn up_once(dir: &Path, host: &str, extra: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_wrc"))
        .args(["up", "--no-rt", "--no-ui"])
        .args(["--port", &format!("{host}:{}", free_port())])
        .args(["--sim-addr", &format!("127.0.0.1:{}", free_udp_port())])
        .arg("--state-dir")
        .arg(dir)
        .args(extra)
        .output()
        .unwrap()
}

/// The names of the files in `dir`, sorted.
pub(crate) fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn free_udp_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

impl Controller {
    pub(crate) fn start(extra: &[&str]) -> Controller {
        Controller::start_in(tempfile::tempdir().unwrap(), extra)
    }

    /// Stop this controller (SIGTERM) and start a new one on the same state directory.
    pub(crate) fn restart(mut self) -> Controller {
        assert!(self.terminate().success());
        let dir = std::mem::replace(&mut self.dir, tempfile::tempdir().unwrap());
        Controller::start_in(dir, &[])
    }

    fn start_in(dir: tempfile::TempDir, extra: &[&str]) -> Controller {
        let port = free_port();
        let sim_port = free_udp_port();
        // Tests run in parallel: only a test that asks for the GUI (with --ui-port) gets one.
        let no_ui: &[&str] = if extra.contains(&"--ui-port") {
            &[]
        } else {
            &["--no-ui"]
        };
        let child = Command::new(env!("CARGO_BIN_EXE_wrc"))
            .arg("up")
            .arg("--no-rt")
            .args(no_ui)
            .args(["--port", &format!("127.0.0.1:{port}")])
            .args(["--sim-addr", &format!("127.0.0.1:{sim_port}")])
            .arg("--state-dir")
            .arg(dir.path())
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let c = Controller {
            child,
            port,
            sim_port,
            dir,
        };
        wait_until("wrc up to open its port", || {
            TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())
        });
        c
    }

    pub(crate) fn client(&self) -> Client {
        Client::connect(self.port)
    }

    pub(crate) fn dir_path(&self) -> &Path {
        self.dir.path()
    }

    /// The process id of `wrc up`.
    pub(crate) fn pid(&self) -> u32 {
        self.child.id()
    }

    pub(crate) fn dpram(&self) -> PathBuf {
        self.dir.path().join("board0.dpram")
    }

    /// The simulated board that `wrc up` started, seen through its DPRAM.
    pub(crate) fn board(&self) -> BoardView {
        BoardView::open(&self.dpram())
    }

    /// Stop this controller (SIGTERM: its board saves the simulated cell as it stops) and
    /// assert that the cell counted no side collision: no body of the arm touched a station
    /// off its line, or an obstacle, while this controller moved it.
    pub(crate) fn stop_clear_of_the_cell(mut self) {
        assert!(self.terminate().success());
        let (count, latest) = crate::side_collisions(self.dir.path());
        assert_eq!(
            count, 0,
            "side collisions in the simulated cell, the latest at {latest:?}"
        );
    }

    fn terminate(&mut self) -> std::process::ExitStatus {
        // SAFETY: signals our own child.
        unsafe {
            libc::kill(self.child.id() as libc::pid_t, libc::SIGTERM);
        }
        wait_until("wrc up to stop on SIGTERM", || {
            self.child
                .try_wait()
                .unwrap()
                .ok_or_else(|| "still running".to_string())
        })
    }
}

impl Drop for Controller {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

pub(crate) struct Client {
    reader: BufReader<TcpStream>,
    writer: TcpStream,
    /// Every line received, events included.
    pub(crate) seen: Vec<String>,
}

impl Client {
    /// A client of the controller on `port`.
    pub(crate) fn connect_to(port: u16) -> Client {
        Client::connect(port)
    }

    fn connect(port: u16) -> Client {
        let s = TcpStream::connect(("127.0.0.1", port)).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
        Client {
            reader: BufReader::new(s.try_clone().unwrap()),
            writer: s,
            seen: Vec::new(),
        }
    }

    pub(crate) fn line(&mut self) -> String {
        let mut l = String::new();
        if let Err(e) = self.reader.read_line(&mut l) {
            panic!(
                "no reply before the timeout ({e}); seen so far: {:?}",
                self.seen
            );
        }
        let l = l.trim_end().to_string();
        self.seen.push(l.clone());
        l
    }

    pub(crate) fn send_raw(&mut self, bytes: &[u8]) {
        self.writer.write_all(bytes).unwrap();
    }

    /// Send `line` and return the first reply that is not an event.
    pub(crate) fn ask(&mut self, line: &str) -> String {
        self.send_raw(format!("{line}\n").as_bytes());
        self.reply()
    }

    pub(crate) fn reply(&mut self) -> String {
        loop {
            let l = self.line();
            if !l.starts_with("EVT") {
                return l;
            }
        }
    }

    /// Send a motion with `id`: expect ACK, then return the final INF/ABS.
    pub(crate) fn motion(&mut self, id: u32, line: &str) -> String {
        let ack = self.ask(&format!("{id} {line}"));
        assert_eq!(ack, format!("ACK {id}"), "{line}");
        self.reply()
    }

    pub(crate) fn where_(&mut self) -> (Vec<f64>, f64, f64) {
        let r = self.ask("WHERE");
        let field = |k: &str| reply_field(&r, k).unwrap_or_else(|| panic!("no {k} in {r}"));
        let joints = field("j").split(',').map(|v| v.parse().unwrap()).collect();
        (
            joints,
            field("x").parse().unwrap(),
            field("y").parse().unwrap(),
        )
    }

    pub(crate) fn status(&mut self) -> String {
        self.ask("STATUS")
    }

    /// Poll STATUS until the state is `state` (`IDLE`, `ERROR`, …); the STATUS reply then.
    pub(crate) fn wait_state(&mut self, state: &str) -> String {
        let want = format!("state={state}");
        wait_until(&format!("STATUS {want}"), || {
            let status = self.status();
            if status.split_whitespace().any(|w| w == want) {
                Ok(status)
            } else {
                Err(status)
            }
        })
    }

    /// Poll STATUS and WHERE until the arm is MOVING and `moved(joints, x, y)` says it has
    /// got far enough (`what`, for the failure message); the joints then [deg, mm]. On a
    /// connection whose motion is still open, its INF/ABS must not come meanwhile.
    pub(crate) fn wait_moving(
        &mut self,
        what: &str,
        moved: impl Fn(&[f64], f64, f64) -> bool,
    ) -> Vec<f64> {
        wait_until(what, || {
            let status = self.status();
            if !status.contains("state=MOVING") {
                return Err(status);
            }
            let (j, x, y) = self.where_();
            if moved(&j, x, y) {
                Ok(j)
            } else {
                Err(format!("j={j:?} x={x} y={y}"))
            }
        })
    }
}

#[test]
fn home_then_ptp_and_straight_moves_reach_their_targets() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    assert!(host.status().starts_with("ACK state=IDLE homed=0"));
    assert!(
        host.ask("MOVJ 0 90 0 0").starts_with("NAK 110"),
        "motion before HOME is refused"
    );
    assert_eq!(host.motion(1, "HOME"), "INF 1");
    assert!(host.status().contains("homed=1"));
    // At Z 0 the arm passes under every station of the demo cell (the lowest, the load
    // ports, begin at 10 mm); higher, this pose would put the hand into LP2.
    assert_eq!(host.motion(2, "MOVP 250 100 0 30"), "INF 2");
    let (j, x, y) = host.where_();
    assert!(
        (x - 250.0).abs() < 0.05 && (y - 100.0).abs() < 0.05,
        "{x} {y}"
    );
    assert!(j[3].abs() < 0.01);
    assert_eq!(host.motion(3, "MOVL 250 -100 0 30"), "INF 3");
    let (_, x, y) = host.where_();
    assert!(
        (x - 250.0).abs() < 0.05 && (y + 100.0).abs() < 0.05,
        "{x} {y}"
    );
    assert_eq!(host.motion(4, "JOG z 5000"), "INF 4");
    assert!((host.where_().0[3] - 5.0).abs() < 0.01);
    // A queued pair: both accepted, both finish in order.
    host.send_raw(b"5 MOVJ 10 80 0 0\n6 MOVJ 20 70 0 0\n");
    assert_eq!(host.reply(), "ACK 5");
    assert_eq!(host.reply(), "ACK 6");
    assert_eq!(host.reply(), "INF 5");
    assert_eq!(host.reply(), "INF 6");
    assert_eq!(host.ask("7 WAIT"), "ACK 7");
    assert_eq!(host.reply(), "INF 7");
    assert!(host.seen.iter().any(|l| l == "EVT STATE MOVING"));
    c.stop_clear_of_the_cell();
}

#[test]
fn bad_input_gets_nak_and_nothing_moves() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    assert_eq!(host.motion(1, "HOME"), "INF 1");
    let before = host.where_().0;
    for (line, code) in [
        ("FOO", "NAK 100"),
        ("MOVJ 1 2", "NAK 101"),
        ("MOVJ a b c d", "NAK 102"),
        ("MOVJ 0 170 0 0", "NAK 112"),
        ("MOVP 500 0 0 0", "NAK 111"),
        ("MOVL -250 0 0 0", "NAK 113"),
        ("JOG q 10", "NAK 114"),
        ("SPEED 0", "NAK 115"),
        ("MOVJ nan 0 0 0", "NAK 102"),
        ("9 MOVJ 1 2 3", "NAK 9 101"),
    ] {
        let r = host.ask(line);
        assert!(r.starts_with(code), "{line}: {r}");
    }
    let long = "X".repeat(300);
    assert!(host.ask(&long).starts_with("NAK 103"));
    // Garbage does not desynchronise the reader.
    host.send_raw(b"\x00\xff\xfe garbage \x01\n");
    assert!(host.reply().starts_with("NAK"));
    assert!(host.status().starts_with("ACK state=IDLE"));
    assert_eq!(host.where_().0, before);
}

#[test]
fn stop_and_estop_mid_move_abort_and_nothing_moves_afterwards() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    let mut other = c.client();
    assert_eq!(host.motion(1, "HOME"), "INF 1");
    assert_eq!(host.ask(&format!("2 {LONG_MOVE}")), "ACK 2");
    // STOP once j1 is on its way from -75, far from 170.
    other.wait_moving("j1 past -65 deg", |j, _, _| j[0] > -65.0);
    assert_eq!(other.ask("3 STOP"), "ACK 3");
    assert_eq!(host.reply(), "ABS 2 200 stopped by STOP");
    // Once the controller has braked (WAIT) and the board has executed the brake, nothing
    // moves for STILL_PERIODS board periods.
    assert_eq!(host.motion(7, "WAIT"), "INF 7");
    let board = c.board();
    board.wait_at_rest();
    let a = host.where_().0;
    board.wait_periods(STILL_PERIODS);
    assert_eq!(host.where_().0, a, "no pulses after the stop");
    assert!(a[0] < 170.0 && a[0] > -75.0);
    assert!(host.status().starts_with("ACK state=IDLE"));

    // Folded, as LONG_MOVE: clear of the cell from wherever the STOP left the arm.
    assert_eq!(host.ask("4 MOVJ -100 150 0 0"), "ACK 4");
    other.wait_moving("j1 on its way to -100 deg", |j, _, _| j[0] < a[0] - 2.0);
    assert_eq!(other.ask("5 ESTOP"), "ACK 5");
    assert_eq!(host.reply(), "ABS 4 201 emergency stop");
    // WAIT answers (with the E-stop's code) once the brake is over; RESET needs that.
    assert!(host.motion(8, "WAIT").starts_with("ABS 8 201"));
    assert!(host.status().starts_with("ACK state=ESTOP"));
    assert!(host.ask("MOVJ 0 150 0 0").starts_with("NAK 123"));
    assert_eq!(host.ask("RESET"), "ACK");
    assert!(host.status().starts_with("ACK state=IDLE"));
    assert_eq!(host.motion(6, "MOVJ 0 150 0 0"), "INF 6");

    // TASKS counts both stops on the Pulse Generator's line: with a FIFO flush on this one
    // board, unless a board period began at every try (then behind the queue).
    assert_eq!(host.ask("9 TASKS"), "ACK 9 tasks=8");
    let pg = host
        .seen
        .iter()
        .find(|l| l.starts_with("EVT TASK pulse_generator "))
        .expect("the Pulse Generator's line");
    let count = |key: &str| -> u64 {
        reply_field(pg, key)
            .unwrap_or_else(|| panic!("no {key} in {pg}"))
            .parse()
            .unwrap()
    };
    assert_eq!(
        count("stops_flushed") + count("stops_behind_queue"),
        2,
        "{pg}"
    );
    c.stop_clear_of_the_cell();
}

#[test]
fn a_board_alarm_aborts_the_move_and_reset_recovers() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    assert_eq!(host.motion(1, "HOME"), "INF 1");
    assert_eq!(host.ask(&format!("2 {LONG_MOVE}")), "ACK 2");
    host.wait_moving("j1 past -65 deg", |j, _, _| j[0] > -65.0);
    let out = Command::new(env!("CARGO_BIN_EXE_wrc"))
        .args(["board-sim", "inject", "--dpram"])
        .arg(c.dpram())
        .args(["alarm", "1"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r = host.reply();
    assert!(r.starts_with("ABS 2 205"), "{r}");
    // The ABS comes at once; the arm is still braking. WAIT answers when it stands still
    // (with the fault's code), after which RESET is accepted.
    assert_eq!(host.ask("4 WAIT"), "ACK 4");
    let r = host.reply();
    assert!(r.starts_with("ABS 4 205"), "{r}");
    assert!(
        host.status().starts_with("ACK state=ERROR"),
        "{:?}",
        host.seen
    );
    assert!(
        host.seen.iter().any(|l| l.starts_with("EVT ERROR 205")),
        "{:?}",
        host.seen
    );
    assert!(host.ask("MOVJ 0 150 0 0").starts_with("NAK 122"));
    assert_eq!(host.ask("RESET"), "ACK");
    assert!(host.status().contains("state=IDLE") && host.status().contains("err=0"));
    assert_eq!(host.motion(3, "MOVJ 0 150 0 0"), "INF 3");
    c.stop_clear_of_the_cell();
}

#[test]
fn two_clients_share_the_control_lock() {
    let c = Controller::start(&[]);
    let mut a = c.client();
    let mut b = c.client();
    let r = a.ask("CONTROL");
    assert!(r.starts_with("ACK owner=tcp"), "{r}");
    let owner = r.trim_start_matches("ACK owner=").to_string();
    assert!(
        b.ask("HOME").starts_with("NAK 120"),
        "another source holds control"
    );
    assert!(b.status().contains(&format!("owner={owner}")));
    assert!(b.ask("CONTROL").starts_with("NAK 120"));
    assert_eq!(a.motion(1, "HOME"), "INF 1");
    assert_eq!(a.ask("RELEASE"), "ACK owner=none");
    assert_eq!(b.motion(2, "MOVJ 0 90 0 0"), "INF 2");
    assert!(
        b.seen.iter().any(|l| l == &format!("EVT CONTROL {owner}")),
        "{:?}",
        b.seen
    );
}

#[test]
fn simulator_datagrams_arrive_and_decode() {
    let c = Controller::start(&[]);
    let socket = UdpSocket::bind(("127.0.0.1", c.sim_port)).unwrap();
    socket
        .set_read_timeout(Some(Duration::from_secs(5)))
        .unwrap();
    let mut buf = [0u8; 1024];
    let mut last = None;
    for _ in 0..10 {
        let n = socket.recv(&mut buf).unwrap();
        let frame = wrc_protocol::sim_stream::decode(&buf[..n]).unwrap();
        assert_eq!(frame.axis_count, 4);
        assert!((frame.positions[1] - 150.0).abs() < 0.01, "home J2");
        if let Some(prev) = last {
            assert!(frame.sequence > prev);
        }
        last = Some(frame.sequence);
    }
}

/// The wrc processes whose command line names `dir`: (pid, command line).
fn wrc_processes_in(dir: &Path) -> Vec<(u32, String)> {
    let needle = dir.to_string_lossy().to_string();
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Some(pid) = entry.file_name().to_str().and_then(|p| p.parse().ok()) else {
            continue;
        };
        if let Ok(cmd) = std::fs::read(entry.path().join("cmdline")) {
            let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
            if cmd.contains(&needle) && cmd.contains("wrc") {
                found.push((pid, cmd));
            }
        }
    }
    found
}

fn processes_mentioning(dir: &Path) -> Vec<String> {
    wrc_processes_in(dir)
        .into_iter()
        .map(|(_, cmd)| cmd)
        .collect()
}

#[test]
fn sigterm_stops_cleanly_and_leaves_no_process() {
    let mut c = Controller::start(&[]);
    let mut host = c.client();
    assert_eq!(host.motion(1, "HOME"), "INF 1");
    assert_eq!(host.ask(&format!("2 {LONG_MOVE}")), "ACK 2");
    host.wait_moving("j1 past -65 deg", |j, _, _| j[0] > -65.0);
    let status = c.terminate();
    assert!(status.success(), "{status:?}");
    let mut out = String::new();
    c.child
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut out)
        .unwrap();
    assert!(
        out.contains("host protocol on tcp") && out.contains("stopped"),
        "{out}"
    );
    assert!(c.dir.path().join("state.toml").exists());
    // wrc up reaps its children (the simulated board) before it exits.
    let left = processes_mentioning(c.dir.path());
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn the_pendant_speaks_the_protocol_on_a_serial_line_with_checksums() {
    // A pty pair stands in for the RS232C cable.
    let (mut master, slave) = open_pty();
    let c = Controller::start(&["--serial", slave.to_str().unwrap(), "--baud", "9600"]);
    let read_line = |m: &mut std::fs::File| -> String {
        let mut line = Vec::new();
        let mut byte = [0u8; 1];
        wait_until("a line on the serial port", || loop {
            match m.read(&mut byte) {
                Ok(1) if byte[0] == b'\n' => {
                    return Ok(String::from_utf8_lossy(&line)
                        .trim_end_matches('\r')
                        .to_string())
                }
                Ok(1) => line.push(byte[0]),
                _ => return Err(String::from_utf8_lossy(&line).into_owned()),
            }
        })
    };
    master.write_all(b"STATUS\n").unwrap();
    let r = read_line(&mut master);
    assert!(r.starts_with("ACK state=IDLE"), "{r}");
    let body = "4 STATUS";
    let sum = body.bytes().fold(0u8, |a, b| a ^ b);
    master
        .write_all(format!("{body}*{sum:02X}\n").as_bytes())
        .unwrap();
    let r = read_line(&mut master);
    let (text, check) = r
        .rsplit_once('*')
        .unwrap_or_else(|| panic!("a reply with a checksum, got {r:?}"));
    assert!(text.starts_with("ACK 4 state=IDLE"), "{r}");
    assert_eq!(
        u8::from_str_radix(check, 16).unwrap(),
        text.bytes().fold(0u8, |a, b| a ^ b)
    );
    master.write_all(b"5 STATUS*00\n").unwrap();
    let r = read_line(&mut master);
    assert!(r.starts_with("NAK 5 104"), "{r}");
    drop(c);
}

fn open_pty() -> (std::fs::File, PathBuf) {
    use std::os::unix::io::FromRawFd;
    let (mut master, mut slave) = (0, 0);
    let mut name = [0 as libc::c_char; 128];
    // SAFETY: openpty writes two descriptors and the slave's name into our buffers.
    let rc = unsafe {
        libc::openpty(
            &mut master,
            &mut slave,
            name.as_mut_ptr(),
            std::ptr::null(),
            std::ptr::null(),
        )
    };
    assert_eq!(rc, 0, "openpty failed");
    // SAFETY: the name is NUL-terminated by openpty.
    let path = unsafe { std::ffi::CStr::from_ptr(name.as_ptr()) }
        .to_string_lossy()
        .to_string();
    // SAFETY: we own the master descriptor; keep the slave open so the line stays up.
    let master = unsafe { std::fs::File::from_raw_fd(master) };
    let fd = std::os::unix::io::AsRawFd::as_raw_fd(&master);
    // SAFETY: fcntl on a descriptor we own: make the master non-blocking for the polling
    // reader above. The slave descriptor stays open (never closed) so the line stays up.
    unsafe {
        let flags = libc::fcntl(fd, libc::F_GETFL);
        libc::fcntl(fd, libc::F_SETFL, flags | libc::O_NONBLOCK);
    }
    let _ = slave;
    (master, PathBuf::from(path))
}

#[test]
fn wrc_send_prints_replies_and_sets_its_exit_code() {
    let c = Controller::start(&[]);
    let addr = format!("127.0.0.1:{}", c.port);
    let send = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_wrc"))
            .args(["send", "--addr", &addr])
            .args(args)
            .output()
            .unwrap()
    };
    let out = send(&["STATUS"]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("ACK state=IDLE"));
    let out = send(&["7", "HOME"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        text.starts_with("ACK 7") && text.trim_end().ends_with("INF 7"),
        "{text}"
    );
    let out = send(&["MOVP", "900", "0", "0", "0"]);
    assert_eq!(out.status.code(), Some(1));
    // An event broadcast while this connection opened (HOME's `EVT STATE IDLE` on a busy
    // machine) may come first: events are unsolicited.
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    let reply = text.lines().find(|l| !l.starts_with("EVT ")).unwrap_or("");
    assert!(reply.starts_with("NAK 111"), "{text}");
    let out = Command::new(env!("CARGO_BIN_EXE_wrc"))
        .args(["send", "--addr", "127.0.0.1:1", "STATUS"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot connect"));
    // UPLOAD needs the program's lines after it: refused at once, never a hang.
    let out = send(&["UPLOAD", "p"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("wrc run FILE"));
}

#[test]
fn the_local_gui_socket_speaks_the_protocol_and_streams_status() {
    use std::os::unix::net::UnixStream;
    let c = Controller::start(&[]);
    let path = c.dir.path().join("wrc.sock");
    // The TCP port answering (what `start` waits for) does not mean the socket is bound yet.
    let s = wait_until("the local GUI socket", || {
        UnixStream::connect(&path).map_err(|e| e.to_string())
    });
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let mut w = s.try_clone().unwrap();
    let mut r = BufReader::new(s);
    w.write_all(b"1 STATUS\n2 SUBSCRIBE\n").unwrap();
    // Replies to different requests may come in either order (SUBSCRIBE is answered by
    // the Ethernet task itself); the ids tell them apart.
    let mut line = String::new();
    let mut acks = Vec::new();
    while acks.len() < 2 {
        line.clear();
        r.read_line(&mut line).unwrap();
        if line.starts_with("ACK") {
            acks.push(line.trim_end().to_string());
        }
    }
    acks.sort();
    assert!(acks[0].starts_with("ACK 1 state=IDLE"), "{acks:?}");
    assert_eq!(acks[1], "ACK 2");
    let mut samples = 0;
    while samples < 3 {
        line.clear();
        r.read_line(&mut line).unwrap();
        if line.starts_with("EVT STATUS") {
            assert!(
                line.contains("state=IDLE") && line.contains(" j="),
                "{line}"
            );
            samples += 1;
        }
    }
}

#[test]
fn losing_the_controlling_client_mid_move_stops_the_robot_in_error() {
    let c = Controller::start(&[]);
    let mut watcher = c.client();
    {
        let mut owner = c.client();
        assert!(owner.ask("CONTROL").starts_with("ACK owner="));
        assert_eq!(owner.motion(1, "HOME"), "INF 1");
        assert_eq!(owner.ask(&format!("2 {LONG_MOVE}")), "ACK 2");
        watcher.wait_moving("j1 past -65 deg", |j, _, _| j[0] > -65.0);
    } // the owner's connection drops here
    let s = watcher.wait_state("ERROR");
    assert!(s.contains("err=208") && s.contains("owner=none"), "{s}");
    assert!(
        watcher.seen.iter().any(|l| l.starts_with("EVT ERROR 208")),
        "{:?}",
        watcher.seen
    );
    // WAIT answers (with the fault's code) once the brake is over.
    assert!(watcher.motion(3, "WAIT").starts_with("ABS 3 208"));
    let board = c.board();
    board.wait_at_rest();
    let a = watcher.where_().0;
    board.wait_periods(STILL_PERIODS);
    assert_eq!(watcher.where_().0, a, "stopped");
    assert_eq!(watcher.ask("RESET"), "ACK");
}

/// The pid of the `wrc board-sim` process that `wrc up` runs in `dir`.
fn board_sim_pid(dir: &Path) -> Option<u32> {
    wrc_processes_in(dir)
        .into_iter()
        .find_map(|(pid, cmd)| cmd.contains("board-sim").then_some(pid))
}

/// Whether process `pid` is gone: reaped, not a zombie.
fn reaped(pid: u32) -> Result<(), String> {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => Ok(()),
        Ok(stat) => Err(format!("still there: {stat}")),
    }
}

/// `kill -9` of the board process during a move: ABS 300, the dead process reaped.
fn kill_board_mid_move(c: &Controller, host: &mut Client) -> u32 {
    assert_eq!(host.motion(1, "HOME"), "INF 1");
    // The board has run for more than a second (`--restart-boards` restarts only such a
    // board; one that dies as it starts is left dead).
    c.board().wait_periods(120);
    assert_eq!(host.ask(&format!("2 {LONG_MOVE}")), "ACK 2");
    host.wait_moving("j1 past -65 deg", |j, _, _| j[0] > -65.0);
    let pid = board_sim_pid(c.dir_path()).expect("a board-sim process");
    // SAFETY: signals the board process of our own wrc up.
    unsafe {
        libc::kill(pid as libc::pid_t, libc::SIGKILL);
    }
    let abs = host.reply();
    assert!(abs.starts_with("ABS 2 300 "), "{abs}; seen {:?}", host.seen);
    assert!(host.status().contains("state=ERROR"));
    // (The event came with the ABS, before the STATUS reply.)
    assert!(
        host.seen.iter().any(|l| l.starts_with("EVT ERROR 300 ")),
        "{:?}",
        host.seen
    );
    wait_until("the killed board process to be reaped", || reaped(pid));
    pid
}

#[test]
fn a_killed_board_is_reported_reaped_and_left_dead_without_restart_boards() {
    let mut c = Controller::start(&[]);
    let mut host = c.client();
    kill_board_mid_move(&c, &mut host);
    let (stood, _, _) = host.where_();
    let refused = host.ask("3 RESET");
    assert!(refused.starts_with("NAK 3 300 "), "{refused}");
    assert_eq!(board_sim_pid(c.dir_path()), None, "not restarted");
    assert_eq!(host.where_().0, stood, "the arm's position stands");
    assert!(c.terminate().success());
    let mut err = String::new();
    c.child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(
        err.contains("simulated board 0") && err.contains("signal: 9"),
        "{err}"
    );
    assert!(err.contains("is not restarted"), "{err}");
    let left = processes_mentioning(c.dir.path());
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn a_killed_board_restarts_with_restart_boards_and_reset_reattaches_it() {
    let c = Controller::start(&["--restart-boards"]);
    let mut host = c.client();
    let dead = kill_board_mid_move(&c, &mut host);
    let (stood, _, _) = host.where_();
    let again = wait_until("the board to be restarted", || {
        board_sim_pid(c.dir_path())
            .filter(|&p| p != dead)
            .ok_or_else(|| "no new board-sim yet".to_string())
    });
    assert_ne!(again, dead);
    // RESET re-attaches it once its heartbeat runs again (300 until then).
    wait_until("RESET to re-attach the restarted board", || {
        let r = host.ask("4 RESET");
        if r == "ACK 4" {
            Ok(())
        } else if r.starts_with("NAK 4 300 ") {
            Err(r)
        } else {
            panic!("{r}")
        }
    });
    let (joints, _, _) = host.where_();
    for (a, b) in joints.iter().zip(&stood) {
        assert!(
            (a - b).abs() < 0.01,
            "re-attached at {joints:?}, stood at {stood:?}"
        );
    }
    assert_eq!(host.motion(5, "MOVJ 0 150 0 10"), "INF 5");
}

/// Raise this process's descriptor limit to its hard limit; the descriptors it may open then.
fn descriptors_allowed() -> u64 {
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: get/setrlimit read and write the struct they are given, alive for each call.
    unsafe {
        assert_eq!(libc::getrlimit(libc::RLIMIT_NOFILE, &mut limit), 0);
        limit.rlim_cur = limit.rlim_max;
        libc::setrlimit(libc::RLIMIT_NOFILE, &limit);
        libc::getrlimit(libc::RLIMIT_NOFILE, &mut limit);
    }
    limit.rlim_cur
}

#[test]
fn a_flood_of_idle_connections_cannot_lock_out_a_new_clients_status_and_estop() {
    // 1,500 idle connections (fewer only where this process may not open that many) against
    // the default limits: 256 connections, 64 per address.
    let flood_size = 1500.min(descriptors_allowed().saturating_sub(200) as usize);
    assert!(
        flood_size > 300,
        "too few descriptors to flood: {flood_size}"
    );
    let c = Controller::start(&[]);
    let mut host = c.client();
    assert_eq!(host.motion(1, "HOME"), "INF 1");
    let flood: Vec<TcpStream> = (0..flood_size)
        .map(|_| TcpStream::connect(("127.0.0.1", c.port)).unwrap())
        .collect();
    // The host that was there before the flood spoke before it: it was among the least
    // recently active and has been closed to make room (its address held 64).
    let mut late = c.client();
    assert!(
        late.ask("2 STATUS").starts_with("ACK 2 state=IDLE"),
        "{:?}",
        late.seen
    );
    assert_eq!(late.ask("3 ESTOP"), "ACK 3");
    late.wait_state("ESTOP");
    // The first flood connections were told why they were closed.
    let mut first = BufReader::new(&flood[0]);
    first
        .get_ref()
        .set_read_timeout(Some(Duration::from_secs(30)))
        .unwrap();
    let mut line = String::new();
    first.read_line(&mut line).unwrap();
    assert!(
        line.starts_with("EVT CLOSING ADDRESS 127.0.0.1 holds 64 connections"),
        "{line}"
    );
    assert_eq!(late.ask("4 RESET"), "ACK 4");
    assert!(late.status().contains("state=IDLE"), "{:?}", late.seen);
    let told = loop {
        let l = host.line();
        if l.is_empty() {
            break false;
        }
        if l.starts_with("EVT CLOSING ADDRESS ") {
            break true;
        }
    };
    assert!(told, "{:?}", host.seen);
}

#[test]
fn a_host_port_off_loopback_needs_an_allow_list_or_a_token() {
    let dir = tempfile::tempdir().unwrap();
    let out = up_once(dir.path(), "0.0.0.0", &[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("reachable from the network") && stderr.contains("[host] allow"),
        "{stderr}"
    );
    assert!(
        wrc_processes_in(dir.path()).is_empty(),
        "a refused start left processes behind"
    );
}

#[test]
fn a_control_token_file_must_be_private_and_wrc_send_presents_it() {
    use std::os::unix::fs::PermissionsExt;
    let keys = tempfile::tempdir().unwrap();
    let token = keys.path().join("host.token");
    std::fs::write(&token, "s3cret-token-0123456789\n").unwrap();
    std::fs::set_permissions(&token, std::fs::Permissions::from_mode(0o644)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = up_once(
        dir.path(),
        "127.0.0.1",
        &["--token-file", token.to_str().unwrap()],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("chmod 600"),
        "{stderr}"
    );

    std::fs::set_permissions(&token, std::fs::Permissions::from_mode(0o600)).unwrap();
    let c = Controller::start(&["--token-file", token.to_str().unwrap()]);
    let send = |token_file: &Path| {
        Command::new(env!("CARGO_BIN_EXE_wrc"))
            .args(["send", "--addr", &format!("127.0.0.1:{}", c.port)])
            .arg("--token-file")
            .arg(token_file)
            .arg("STATUS")
            .output()
            .unwrap()
    };
    let good = send(&token);
    assert!(
        good.status.success() && String::from_utf8_lossy(&good.stdout).starts_with("ACK state="),
        "{good:?}"
    );
    let wrong = keys.path().join("wrong.token");
    std::fs::write(&wrong, "wrong-token-0123456789\n").unwrap();
    std::fs::set_permissions(&wrong, std::fs::Permissions::from_mode(0o600)).unwrap();
    let refused = send(&wrong);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success()
            && stderr.contains("refused the control token: NAK 108 wrong token"),
        "{refused:?}"
    );
}
