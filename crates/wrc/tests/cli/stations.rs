//! Stations as an equipment engineer meets them: `wrc up` writes the
//! demo cell into the state directory, `STN` lists it, `TEACH` stores the current pose
//! (atomically, surviving a restart), `WAFERS` reports the wafer map.

use wrc_protocol::reply_field;

use crate::up::Controller;

fn field(line: &str, key: &str) -> f64 {
    reply_field(line, key)
        .unwrap_or_else(|| panic!("no {key} in {line}"))
        .parse()
        .unwrap()
}

#[test]
fn stations_are_listed_taught_saved_and_kept_across_a_restart() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    host.seen.clear();
    assert_eq!(host.ask("1 STN"), "ACK 1 stations=6");
    let stations: Vec<&String> = host
        .seen
        .iter()
        .filter(|l| l.starts_with("EVT STATION "))
        .collect();
    assert_eq!(stations.len(), 6, "{:?}", host.seen);
    assert!(
        stations[0].starts_with("EVT STATION LP1 kind=load_port "),
        "{stations:?}"
    );
    assert!(stations[0].contains(" slots=25 pitch=10 "), "{stations:?}");
    assert!(c.dir_path().join("stations.toml").exists());

    // Nothing mapped yet: every slot is unknown.
    assert_eq!(
        host.ask("2 WAFERS"),
        "ACK 2 hand=- LP1=?x25 LP2=?x25 AL=? PM1=? PM2=? BF1=?x5"
    );

    // Teaching needs a homed robot at rest, a known station and a valid name.
    assert!(host.ask("3 TEACH LP1").starts_with("NAK 3 110 "));
    assert_eq!(host.motion(4, "HOME"), "INF 4");
    assert!(host
        .ask("5 TEACH LP9")
        .starts_with("NAK 5 130 no station named LP9"));
    assert!(host
        .ask("6 TEACH a-name-longer-than-16")
        .starts_with("NAK 6 106 "));
    // Into LP1 as a transfer goes: to its approach pose (220 mm before the seat, LP1 at
    // -30°) and straight in along its line, the only way into a station; the seat taught
    // 10 mm short of the configured one (294.449, -170) and 5 mm higher.
    let (x, y) = (294.449 - 10.0 * 0.866_025, -170.0 + 10.0 * 0.5);
    assert_eq!(host.motion(7, "MOVP 103.923 -60 25 -30"), "INF 7");
    assert_eq!(
        host.motion(8, &format!("MOVL {x:.3} {y:.3} 25 -30")),
        "INF 8"
    );
    let taught = host.ask("9 TEACH lp1");
    assert!(taught.starts_with("ACK 9 LP1 kind=load_port "), "{taught}");
    assert!((field(&taught, "x") - x).abs() < 0.01, "{taught}");
    assert!((field(&taught, "y") - y).abs() < 0.01, "{taught}");
    assert!((field(&taught, "z") - 25.0).abs() < 0.01, "{taught}");

    // Another host may not teach while this one holds control.
    assert!(host.ask("10 CONTROL").starts_with("ACK 10"));
    let mut other = c.client();
    assert!(other.ask("11 TEACH LP2").starts_with("NAK 11 120 "));
    drop(other);

    // The taught pose is in the file and survives a restart.
    let c = c.restart();
    let mut host = c.client();
    host.seen.clear();
    assert_eq!(host.ask("12 STN"), "ACK 12 stations=6");
    let lp1 = host
        .seen
        .iter()
        .find(|l| l.starts_with("EVT STATION LP1 "))
        .cloned()
        .unwrap();
    assert!((field(&lp1, "x") - x).abs() < 0.01, "{lp1}");
    assert!((field(&lp1, "z") - 25.0).abs() < 0.01, "{lp1}");
    // Into LP1 only along its line: the simulated cell felt no touch.
    c.stop_clear_of_the_cell();
}
