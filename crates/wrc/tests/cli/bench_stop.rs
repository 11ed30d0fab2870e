//! `wrc bench stop`: the stopping table (ISO 10218-1 Annex B form) and its JSON; `wrc bench
//! cell`: the throughput of a short sequence in virtual time, its JSON and its bad input.

use crate::{text, wrc};

#[test]
fn the_stopping_table_is_measured_and_written_as_json() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("stop.json");
    let out = wrc(&[
        "bench",
        "stop",
        "--speed",
        "100",
        "--json",
        json.to_str().unwrap(),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    for heading in [
        "j1 [deg]",
        "z [mm]",
        "straight line",
        "ESTOP",
        "STOP",
        "cruise",
    ] {
        assert!(stdout.contains(heading), "no {heading:?} in\n{stdout}");
    }
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = doc["rows"].as_array().unwrap();
    // Four axes and the line, two moments, two stops.
    assert_eq!(rows.len(), 5 * 2 * 2);
    for r in rows {
        let (t, d) = (
            r["time_ratio"].as_f64().unwrap(),
            r["distance_ratio"].as_f64().unwrap(),
        );
        if r["subject"] == "line" {
            // Joint limits come on top of the Cartesian reference's.
            assert!(t < 1.3 && d < 1.35, "{r}");
        } else {
            // An axis alone takes the 1-D optimum: the distance exactly (to a pulse), the
            // time rounded to whole periods (the last pulses of the tail may round to 0).
            assert!((d - 1.0).abs() < 1e-3, "{r}");
            let ref_ms = r["ref_time_ms"].as_f64().unwrap();
            assert!(t > 0.9 && t * ref_ms <= ref_ms + 10.0 + 1e-6, "{r}");
        }
    }
}

#[test]
fn a_bad_speed_is_named() {
    let out = wrc(&["bench", "stop", "--speed", "0"]);
    let (_, stderr) = text(&out);
    assert!(!out.status.success());
    assert!(stderr.contains("--speed"), "{stderr}");
}

#[test]
fn bench_cell_prints_and_writes_the_throughput_of_a_short_sequence() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("cell.json");
    let out = wrc(&[
        "bench",
        "cell",
        "--wafers",
        "1",
        "--only",
        "lp-lp",
        "--json",
        json.to_str().unwrap(),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("virtual time"), "{stdout}");
    assert!(stdout.contains("LP1 → LP2"), "{stdout}");
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(doc["mode"], "virtual");
    let seq = &doc["sequences"][0];
    assert_eq!(seq["sequence"], "lp-lp");
    let transfers = seq["transfers"].as_array().unwrap();
    let names: Vec<&str> = transfers
        .iter()
        .map(|t| t["request"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["GET LP1 1", "PUT LP2 1"]);
    let total = seq["seconds"].as_f64().unwrap();
    assert!((seq["wafers_per_hour"].as_f64().unwrap() - 3600.0 / total).abs() < 1e-6);
    for t in transfers {
        let s = t["seconds"].as_f64().unwrap();
        assert!(t["moving_s"].as_f64().unwrap() <= s + 0.011, "{t}");
        // The reference is rest to rest per motion; a blended transfer comes under it, but
        // not by more than what the approach's two rest-to-rest ends cost (well within 15 %).
        let r = t["reference_s"].as_f64().unwrap();
        assert!(r > 1.0 && s >= 0.85 * r && s <= 1.15 * r, "{t}");
        // The motion starts within two Pulse Generator periods of the request.
        assert!(t["first_motion_s"].as_f64().unwrap() <= 0.02 + 1e-9, "{t}");
    }
    // Bad input: one sentence, exit 2.
    let out = wrc(&["bench", "cell", "--wafers", "0"]);
    assert_eq!(out.status.code(), Some(2));
    let out = wrc(&["bench", "cell", "--only", "lp-xx"]);
    assert_eq!(out.status.code(), Some(2));
}
