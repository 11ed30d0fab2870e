//! `wrc bench faults` as `make test` runs it: one round each of a few fault kinds that are
//! quick to inject (the E-stop input, a controlling client dropping mid-transfer, a corrupt
//! wafer map at start-up), on normal scheduling. Every round must be detected, stop the
//! arm safely, leave the wafer map as the simulated cell is, and recover. `make faults`
//! runs the whole campaign.

use crate::{text, wrc};

#[test]
fn a_short_fault_campaign_detects_stops_keeps_the_map_and_recovers() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("faults.json");
    let kinds = ["estop", "client-drop", "corrupt-wafers"];
    let out = wrc(&[
        "bench",
        "faults",
        "--rounds",
        "1",
        "--seed",
        "1",
        "--no-rt",
        "--only",
        &kinds.join(","),
        "--json",
        json.to_str().unwrap(),
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("| fault | injected | detected |"),
        "{stdout}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = report["kinds"].as_array().unwrap();
    assert_eq!(rows.len(), kinds.len(), "{report}");
    for (row, kind) in rows.iter().zip(kinds) {
        assert_eq!(row["kind"], kind);
        assert!(row["skipped"].is_null(), "{row}");
        let rounds = row["rounds"].as_array().unwrap();
        assert_eq!(rounds.len(), 1, "{row}");
        for r in rounds {
            assert!(r["latency_ms"].is_number(), "{kind} not detected: {r}");
            for judged in ["stopped", "consistent", "recovered"] {
                assert_eq!(r[judged]["pass"], true, "{kind} {judged}: {r}");
            }
            assert_eq!(r["clean"], true, "{r}");
        }
    }
}
