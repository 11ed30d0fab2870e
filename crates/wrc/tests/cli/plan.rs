//! `wrc plan`: CSV layout, pulse conservation end to end, the SVG plot, and clear errors.

use crate::{text, wrc};

struct Csv {
    header: Vec<String>,
    rows: Vec<Vec<f64>>,
}

fn csv(stdout: &str) -> Csv {
    let mut lines = stdout.lines();
    let header = lines
        .next()
        .expect("a header")
        .split(',')
        .map(String::from)
        .collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|v| v.parse::<f64>().expect("numbers"))
                .collect()
        })
        .collect();
    Csv { header, rows }
}

impl Csv {
    fn col(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name}"))
    }
    fn sum(&self, name: &str) -> f64 {
        let c = self.col(name);
        self.rows.iter().map(|r| r[c]).sum()
    }
    fn last(&self, name: &str) -> f64 {
        self.rows.last().unwrap()[self.col(name)]
    }
}

#[test]
fn ptp_csv_has_the_documented_columns_and_conserves_pulses() {
    let out = wrc(&["plan", "ptp", "--from=-75,150,-75,0", "--to=30,60,-90,100"]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    let csv = csv(&stdout);
    assert_eq!(
        csv.header.join(","),
        "k,t_s,j1_pulses,j2_pulses,j3_pulses,z_pulses,j1_pos,j2_pos,j3_pos,z_pos,x_mm,y_mm"
    );
    // 1000 pulse/deg and pulse/mm: target − start, exactly.
    assert_eq!(csv.sum("j1_pulses"), 105_000.0);
    assert_eq!(csv.sum("j2_pulses"), -90_000.0);
    assert_eq!(csv.sum("j3_pulses"), -15_000.0);
    assert_eq!(csv.sum("z_pulses"), 100_000.0);
    assert_eq!(csv.last("j1_pos"), 30.0);
    assert_eq!(csv.last("z_pos"), 100.0);
    // Row 0 is the start; t advances by the 10 ms period.
    assert_eq!(csv.rows[0][csv.col("j1_pos")], -75.0);
    assert!((csv.rows[1][csv.col("t_s")] - 0.01).abs() < 1e-9);
    assert!(stderr.contains("periods of 10 ms"), "{stderr}");
}

#[test]
fn line_ends_on_its_target_and_stays_on_the_line() {
    let out = wrc(&[
        "plan",
        "line",
        "--from=300,-100,0,0",
        "--to=300,150,40,0",
        "--period-ms",
        "1",
    ]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stderr}");
    let csv = csv(&stdout);
    let x = csv.col("x_mm");
    for r in &csv.rows {
        assert!((r[x] - 300.0).abs() <= 0.01, "x = {} at k = {}", r[x], r[0]);
    }
    assert!((csv.last("y_mm") - 150.0).abs() <= 0.01);
    assert!((csv.last("z_pos") - 40.0).abs() < 1e-9);
    assert!((csv.rows[1][csv.col("t_s")] - 0.001).abs() < 1e-9);
}

#[test]
fn joint_mode_moves_one_axis_by_its_pulses() {
    for profile in ["fir", "paper"] {
        let out = wrc(&[
            "plan",
            "joint",
            "--axis",
            "J3",
            "--pulses",
            "-12345",
            "--profile",
            profile,
        ]);
        let (stdout, stderr) = text(&out);
        assert!(out.status.success(), "{stderr}");
        let csv = csv(&stdout);
        assert_eq!(csv.sum("j3_pulses"), -12345.0);
        assert_eq!(csv.sum("j1_pulses"), 0.0);
    }
}

#[test]
fn plot_writes_an_svg() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fig7.svg");
    let out = wrc(&[
        "plan",
        "ptp",
        "--to=30,60,-90,100",
        "--plot",
        path.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out).1);
    let svg = std::fs::read_to_string(&path).unwrap();
    assert!(
        svg.starts_with("<svg") && svg.contains("polyline") && svg.contains("j1"),
        "{}",
        &svg[..200.min(svg.len())]
    );
}

#[test]
fn bad_input_gets_one_clear_sentence_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let bad_config = dir.path().join("bad.toml");
    std::fs::write(
        &bad_config,
        wrc_config::DEFAULT_TOML.replacen("max_jerk = 7200.0", "max_jerk = 0.0", 1),
    )
    .unwrap();
    let bad_config = bad_config.to_str().unwrap().to_string();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["plan", "ptp", "--to=1,2,3"],
            "needs 4 comma-separated values",
        ),
        (vec!["plan", "ptp", "--to=1,2,nan,4"], "not a finite number"),
        (vec!["plan", "ptp", "--to=1,2,x,4"], "\"x\" is not a number"),
        (vec!["plan", "ptp", "--to=0,170,0,0"], "outside its limits"),
        (vec!["plan", "line", "--to=500,0,0,0"], "out of reach"),
        (
            vec!["plan", "line", "--from=200,0,0,0", "--to=-200,0,0,0"],
            "leaves the workspace",
        ),
        (
            vec!["plan", "joint", "--axis", "q", "--pulses", "5"],
            "not an axis",
        ),
        (
            vec!["plan", "joint", "--axis", "z", "--pulses", "-5"],
            "outside its limits",
        ),
        (
            vec!["plan", "ptp", "--to=0,0,0,0", "--speed", "0"],
            "--speed",
        ),
        (
            vec!["plan", "ptp", "--to=0,0,0,0", "--period-ms", "-1"],
            "--period-ms",
        ),
        (
            vec![
                "plan",
                "ptp",
                "--to=0,0,0,0",
                "--profile",
                "paper",
                "--paper-n",
                "7",
            ],
            "--paper-n",
        ),
        (
            vec![
                "plan",
                "ptp",
                "--to=0,0,0,0",
                "--config",
                "/nonexistent/wrc.toml",
            ],
            "/nonexistent/wrc.toml",
        ),
        (
            vec!["plan", "ptp", "--to=0,0,0,0", "--config", &bad_config],
            "axis.j1.max_jerk",
        ),
    ];
    for (args, needle) in cases {
        let out = wrc(&args);
        let (stdout, stderr) = text(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains(needle),
            "{args:?}: expected {needle:?} in {stderr}"
        );
        assert!(
            !stderr.contains("panicked") && !stderr.contains("internal error"),
            "{args:?}: {stderr}"
        );
        assert!(stdout.is_empty(), "{args:?} printed CSV: {stdout}");
    }
    // clap's own errors (unknown profile) also exit 2.
    let out = wrc(&["plan", "ptp", "--to=0,0,0,0", "--profile", "scurve"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out).1.contains("scurve"));
}

#[test]
fn help_shows_examples() {
    let out = wrc(&["plan", "--help"]);
    let (stdout, _) = text(&out);
    assert!(out.status.success());
    assert!(
        stdout.contains("Examples:") && stdout.contains("wrc plan line"),
        "{stdout}"
    );
}
