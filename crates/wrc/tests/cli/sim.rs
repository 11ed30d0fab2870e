//! `wrc sim`: a program run under virtual time prints what `wrc run` prints, twice the same
//! to the byte (transcript and pulse stream); bad input is refused; `--listen` serves a host
//! session at a multiple of real time.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::up::LONG_MOVE;
use crate::wafer_cycle::KillOnDrop;
use crate::{side_collisions, text, wait_until, wrc};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(name)
}

#[test]
fn a_program_runs_under_virtual_time_and_twice_gives_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let program = example("fig7_ptp.wrl");
    let run = |n: usize| {
        let (t, p) = (
            dir.path().join(format!("transcript{n}.txt")),
            dir.path().join(format!("pulses{n}.csv")),
        );
        let out = wrc(&[
            "sim",
            program.to_str().unwrap(),
            "--transcript",
            t.to_str().unwrap(),
            "--pulses",
            p.to_str().unwrap(),
        ]);
        let (stdout, stderr) = text(&out);
        assert!(out.status.success(), "{stdout}\n{stderr}");
        (
            stdout,
            stderr,
            std::fs::read(t).unwrap(),
            std::fs::read(p).unwrap(),
        )
    };
    let (stdout, stderr, transcript, pulses) = run(1);
    // What `wrc run` prints against `wrc up`.
    assert_eq!(
        stdout,
        "Fig. 7 PTP done at POSE(173.205081, 300, 0, 0)\nINF 2\n"
    );
    assert!(
        stderr.contains("s of virtual time in") && stderr.contains("s of wall time"),
        "{stderr}"
    );
    let transcript_text = String::from_utf8_lossy(&transcript);
    assert!(
        transcript_text.contains("> 2 RUN fig7_ptp"),
        "{transcript_text}"
    );
    assert!(transcript_text.contains("< INF 2"), "{transcript_text}");
    // The pulse stream: every board period of board 0 with its four axes, ending on the
    // target (J1 30°, J2 60°, J3 -90°, Z 0 mm in pulses).
    let rows: Vec<&str> = std::str::from_utf8(&pulses).unwrap().lines().collect();
    assert!(rows.len() > 50, "{} rows", rows.len());
    assert_eq!(rows[0].split(',').count(), 5, "{}", rows[0]);
    let (_, _, transcript2, pulses2) = run(2);
    assert!(transcript == transcript2, "the transcripts differ");
    assert!(pulses == pulses2, "the pulse streams differ");
}

#[test]
fn a_program_that_does_not_compile_or_a_bad_option_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.wrl");
    std::fs::write(&bad, "MOVEJ 1, 2\n").unwrap();
    let out = wrc(&["sim", bad.to_str().unwrap()]);
    let (_, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("does not compile; nothing sent"),
        "{stderr}"
    );

    let program = example("fig7_ptp.wrl");
    let out = wrc(&["sim", program.to_str().unwrap(), "--timeout", "0"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).1.contains("--timeout must be a positive number"));
    let out = wrc(&["sim", "--listen", "127.0.0.1:0", "--rate", "0"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).1.contains("--rate must be a positive number"));
    let out = wrc(&["sim"]);
    assert_eq!(out.status.code(), Some(2));

    // A damaged simulated cell kept in the state directory is named, with what to do.
    let state = dir.path().join("state");
    std::fs::create_dir_all(&state).unwrap();
    std::fs::write(state.join("world.toml"), "garbage = [\n").unwrap();
    let out = wrc(&[
        "sim",
        program.to_str().unwrap(),
        "--state-dir",
        state.to_str().unwrap(),
    ]);
    let (_, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(&format!(
            "the simulated cell kept in {}",
            state.join("world.toml").display()
        )) && stderr.contains("remove it"),
        "{stderr}"
    );
}

#[test]
fn a_program_that_would_run_forever_ends_at_its_virtual_timeout() {
    let dir = tempfile::tempdir().unwrap();
    let forever = dir.path().join("forever.wrl");
    std::fs::write(&forever, "WHILE 1 = 1\n  DELAY 1\nENDWHILE\n").unwrap();
    let out = wrc(&["sim", forever.to_str().unwrap(), "--timeout", "30"]);
    let (stdout, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{stderr}");
    assert!(
        stderr.contains("did not end within 30 s of virtual time"),
        "{stderr}"
    );
}

/// A `wrc sim --listen` at 20× real time on a free port, state in `dir`: the process
/// (killed if the test fails first), its output and the address it serves.
struct Listening {
    child: KillOnDrop,
    out: BufReader<std::process::ChildStdout>,
    stderr: std::process::ChildStderr,
    addr: String,
}

fn listen(dir: &Path) -> Listening {
    let mut child = Command::new(env!("CARGO_BIN_EXE_wrc"))
        .args([
            "sim",
            "--listen",
            "127.0.0.1:0",
            "--rate",
            "20",
            "--state-dir",
        ])
        .arg(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let stderr = child.stderr.take().unwrap();
    let child = KillOnDrop(child);
    let mut line = String::new();
    let addr = loop {
        line.clear();
        assert!(out.read_line(&mut line).unwrap() > 0, "wrc sim ended early");
        if let Some(a) = line.trim().strip_prefix("wrc sim: host protocol on tcp ") {
            break a.to_string();
        }
    };
    Listening {
        child,
        out,
        stderr,
        addr,
    }
}

#[test]
fn listen_serves_a_host_session_faster_than_real_time() {
    let dir = tempfile::tempdir().unwrap();
    let Listening {
        mut child,
        mut out,
        mut stderr,
        addr,
    } = listen(dir.path());
    let mut line = String::new();
    let stream = wait_until("wrc sim's port", || {
        std::net::TcpStream::connect(&addr).map_err(|e| e.to_string())
    });
    let mut reader = BufReader::new(stream.try_clone().unwrap());
    let mut writer = stream;
    let mut heard = Vec::new();
    // The Fig. 7 move as examples/fig7_ptp.wrl makes it: Z stays at 0, under the stations.
    for (id, request) in [(1, "HOME"), (2, "MOVJ 30 60 -90 0")] {
        writer
            .write_all(format!("{id} {request}\n").as_bytes())
            .unwrap();
        while !heard
            .iter()
            .any(|l: &String| l.starts_with(&format!("INF {id}")))
        {
            line.clear();
            assert!(reader.read_line(&mut line).unwrap() > 0, "{heard:?}");
            assert!(
                !line.starts_with("NAK") && !line.starts_with("ABS"),
                "{line}"
            );
            heard.push(line.trim().to_string());
        }
    }
    // SIGTERM ends it cleanly, saying how far virtual time got.
    // SAFETY: kill with the pid of a child we spawned and have not reaped.
    unsafe {
        libc::kill(child.0.id() as libc::pid_t, libc::SIGTERM);
    }
    let status = child.0.wait().unwrap();
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut out, &mut rest).unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(&mut stderr, &mut err).unwrap();
    assert!(status.success(), "{rest}\n{err}");
    assert!(rest.contains("wrc sim: stopped"), "{rest}");
    assert!(err.contains("s of virtual time in"), "{err}");
    assert_eq!(side_collisions(dir.path()), (0, None));
}

#[test]
fn a_session_trace_replays_identically_and_a_changed_one_is_caught_at_its_period() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("session.wrctrace");
    let program = example("pick_place.wrl");
    let out = wrc(&[
        "sim",
        program.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{:?}", text(&out));
    let out = wrc(&["trace", "replay", trace.to_str().unwrap()]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.starts_with("replay identical: "), "{stdout}");

    // The same trace with one encoder count changed in the middle of the run.
    let mut recorded = wrc_trace::TraceFile::load(&trace).unwrap();
    let n = recorded.samples.len() / 2;
    recorded.samples[n].actual[1] += 7;
    let t_s = (recorded.samples[n].t_ns - 1_000_000_000) as f64 / 1e9;
    let changed = dir.path().join("changed.wrctrace");
    recorded.save(&changed).unwrap();
    let out = wrc(&["trace", "replay", changed.to_str().unwrap()]);
    let (stdout, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{stderr}");
    assert!(
        stdout.starts_with(&format!("first difference at t = {t_s:.3} s")),
        "{stdout}"
    );

    // A trace that does not hold the session from its start cannot be replayed.
    recorded.meta.from_start = false;
    recorded.save(&changed).unwrap();
    let out = wrc(&["trace", "replay", changed.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).1.contains("not the session from its start"));
}

#[test]
fn wrc_trace_save_asks_a_running_controller() {
    let dir = tempfile::tempdir().unwrap();
    // Its output stays open (bound, unread) until it has stopped.
    let Listening {
        mut child,
        addr,
        out: _out,
        stderr: _stderr,
    } = listen(dir.path());
    let saved = wait_until("a trace saved through wrc trace save", || {
        let o = wrc(&["trace", "save", "mine", "--addr", &addr]);
        if o.status.success() {
            Ok(text(&o).0)
        } else {
            Err(format!("{:?}", text(&o)))
        }
    });
    let path = dir.path().join("traces/mine.wrctrace");
    assert!(
        saved.starts_with(&format!("file={} samples=", path.display())),
        "{saved}"
    );
    let info = wrc(&["trace", "info", path.to_str().unwrap()]);
    assert!(info.status.success());
    assert!(
        text(&info).0.contains("TRACE SAVE from a host"),
        "{:?}",
        text(&info)
    );
    // SAFETY: kill with the pid of a child we spawned and have not reaped.
    unsafe {
        libc::kill(child.0.id() as libc::pid_t, libc::SIGTERM);
    }
    assert!(child.0.wait().unwrap().success());
}

/// A TCP client of `wrc sim --listen` that keeps every line it heard.
struct Line {
    reader: BufReader<std::net::TcpStream>,
    writer: std::net::TcpStream,
    heard: Vec<String>,
}

impl Line {
    fn connect(addr: &str) -> Line {
        let stream = wait_until("wrc sim's port", || {
            std::net::TcpStream::connect(addr).map_err(|e| e.to_string())
        });
        stream
            .set_read_timeout(Some(std::time::Duration::from_secs(30)))
            .unwrap();
        Line {
            reader: BufReader::new(stream.try_clone().unwrap()),
            writer: stream,
            heard: Vec::new(),
        }
    }

    fn send(&mut self, line: &str) {
        self.writer
            .write_all(format!("{line}\n").as_bytes())
            .unwrap();
    }

    /// Read until a line that starts with `prefix`; return it.
    fn until(&mut self, prefix: &str) -> String {
        loop {
            let mut l = String::new();
            let n = self.reader.read_line(&mut l).unwrap_or(0);
            assert!(n > 0, "no {prefix:?}; heard {:?}", self.heard);
            let l = l.trim_end().to_string();
            self.heard.push(l.clone());
            if l.starts_with(prefix) {
                return l;
            }
        }
    }
}

#[test]
fn a_client_lost_mid_move_is_in_the_trace_and_its_loss_replays_identically() {
    let dir = tempfile::tempdir().unwrap();
    let Listening {
        mut child,
        out: _out,
        stderr: _stderr,
        addr,
    } = listen(dir.path());
    let mut watcher = Line::connect(&addr);
    {
        let mut owner = Line::connect(&addr);
        owner.send("1 CONTROL");
        owner.until("ACK 1");
        owner.send("2 HOME");
        owner.until("INF 2");
        owner.send(&format!("3 {LONG_MOVE}"));
        assert_eq!(owner.until("ACK 3"), "ACK 3");
        watcher.until("EVT STATE MOVING");
    } // the owner's connection drops here, mid-move
    watcher.until("EVT ERROR 208");
    watcher.send("9 TRACE SAVE lost");
    let saved = watcher.until("ACK 9");
    let path = dir.path().join("traces/lost.wrctrace");
    assert!(
        saved.starts_with(&format!("ACK 9 file={}", path.display())),
        "{saved}"
    );
    // SAFETY: kill with the pid of a child we spawned and have not reaped.
    unsafe {
        libc::kill(child.0.id() as libc::pid_t, libc::SIGTERM);
    }
    assert!(child.0.wait().unwrap().success());
    // The move's E-stop braked the folded arm clear of the cell.
    assert_eq!(side_collisions(dir.path()), (0, None));

    // Two hosts connected, one closed: the recording says when.
    let trace = wrc_trace::TraceFile::load(&path).unwrap();
    let count = |d| {
        trace
            .messages
            .iter()
            .filter(|m| m.direction == d && m.source == wrc_trace::SOURCE_HOST)
            .count()
    };
    use wrc_trace::Direction::{Closed, Opened};
    assert_eq!((count(Opened), count(Closed)), (2, 1));
    let info = wrc(&["trace", "info", path.to_str().unwrap()]);
    assert!(
        text(&info).0.contains("connections: 2 opened, 1 closed"),
        "{:?}",
        text(&info)
    );
    // The replay loses the owner at the same instant: the same E-stop of the move, the same
    // 208, period for period.
    let out = wrc(&["trace", "replay", path.to_str().unwrap()]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.starts_with("replay identical: "), "{stdout}");
    assert!(stdout.contains("from 2 connection(s)"), "{stdout}");
    let replayed = trace
        .messages
        .iter()
        .any(|m| m.text().starts_with("EVT ERROR 208"));
    assert!(replayed, "the recording holds the loss's error");
}

#[test]
fn a_programs_points_and_those_of_the_program_it_calls_go_before_their_uploads() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| std::fs::write(dir.path().join(name), text).unwrap();
    write(
        "main.wrl",
        "HOME\nMOVEL ABOVE\nPRINT \"main at\", HERE()\nCALL PROGRAM \"other\"\n",
    );
    write(
        "main.points.toml",
        "[points]\nABOVE = { x = 250.0, y = 50.0, z = 0.0, yaw = 0.0 }\n",
    );
    write("other.wrl", "MOVEJ PARK\nPRINT \"other at\", HERE()\n");
    write(
        "other.points.toml",
        "[points]\nPARK = { joints = [30.0, 60.0, -90.0, 0.0] }\n",
    );
    let program = dir.path().join("main.wrl");
    let out = wrc(&["sim", program.to_str().unwrap()]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines[0], "main at POSE(250, 50, 0, 0)", "{stdout}");
    assert!(lines[1].starts_with("other at POSE("), "{stdout}");
    assert_eq!(lines[2], "INF 2");
}
