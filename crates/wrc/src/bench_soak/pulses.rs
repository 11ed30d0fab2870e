//! Lost pulses: with the robot at rest, the pulse count the controller commanded on each axis
//! (its status stream, `EVT STATUS … j=`) against the count its board executed (the board's
//! commanded position in its DPRAM). A pulse pushed and never executed, or executed twice,
//! leaves them apart for good.

use std::path::Path;
use std::time::Duration;

use anyhow::{bail, Context};
use serde_json::{json, Value};
use wrc_board::{DpramBoard, Expect, Feedback, MotionBoard};
use wrc_config::Config;

use crate::up_process::{poll, Conn, PATIENCE};

/// How long the board may take to execute what is queued once the host stands still: the
/// soak runs the default configuration, whose look-ahead is 100 ms.
const DRAIN: Duration = Duration::from_secs(2);

/// `WHERE`-style numbers have 3 decimals: a joint in units gives its pulse count exactly when
/// an axis has at most this many pulses per unit.
const EXACT_PPU: f64 = 1000.0;

/// One axis at rest.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct AxisPulses {
    /// The axis's name (`j1`).
    pub(crate) name: String,
    /// The controller's commanded count [pulse].
    pub(crate) host: i64,
    /// The board's commanded count [pulse].
    pub(crate) board: i64,
    /// The board's encoder [pulse].
    pub(crate) encoder: i64,
    /// Underruns the board counted on this axis since it started.
    pub(crate) board_underruns: u32,
    /// Entries the board consumed without executing them (axis alarmed or stopping).
    pub(crate) discarded: u32,
}

impl AxisPulses {
    /// Pulses the board is short of the controller's count (negative: executed too many).
    pub(crate) fn lost(&self) -> i64 {
        self.host - self.board
    }

    pub(crate) fn to_json(&self) -> Value {
        json!({
            "axis": self.name,
            "host_pulses": self.host,
            "board_pulses": self.board,
            "encoder_pulses": self.encoder,
            "lost_pulses": self.lost(),
            "board_underruns": self.board_underruns,
            "board_discarded": self.discarded,
        })
    }
}

/// Compare the controller's and the boards' counts with the robot at rest: subscribe to the
/// status stream on `c` until two samples in a row agree and the robot neither moves nor
/// brakes, then read every board until it has executed as far (at most [`DRAIN`]).
pub(crate) fn at_rest(
    c: &mut Conn,
    config: &Config,
    state: &Path,
) -> anyhow::Result<Vec<AxisPulses>> {
    let robot = &config.robot;
    if let Some(a) = robot.axes().iter().find(|a| a.pulses_per_unit > EXACT_PPU) {
        bail!(
            "axis {} has {} pulses per unit: the status stream's 3 decimals do not give its pulse count exactly",
            a.name.as_str(),
            a.pulses_per_unit
        );
    }
    let host = host_at_rest(c)?;
    if host.len() != robot.axis_count() {
        bail!(
            "the status stream gave {} joints for {} axes",
            host.len(),
            robot.axis_count()
        );
    }
    let host: Vec<i64> = robot
        .axes()
        .iter()
        .zip(&host)
        .map(|(a, &units)| a.units_to_pulses(units))
        .collect();
    let mut boards = Vec::new();
    for b in &config.boards {
        let path = state.join(format!("board{}.dpram", b.id));
        let board = DpramBoard::open(&path, Expect::default())
            .with_context(|| format!("cannot open board {}'s DPRAM {}", b.id, path.display()))?;
        boards.push((b, board));
    }
    let read = || -> Option<Vec<AxisPulses>> {
        let mut axes = Vec::new();
        for (b, board) in &boards {
            let mut f = Feedback::default();
            board.read_feedback(&mut f).ok()?;
            for (channel, &axis) in b.axes.iter().enumerate() {
                let fb = &f.axes[channel];
                axes.push(AxisPulses {
                    name: robot.axes()[axis].name.as_str().to_string(),
                    host: host[axis],
                    board: fb.commanded,
                    encoder: fb.encoder,
                    board_underruns: fb.underruns,
                    discarded: fb.discarded,
                });
            }
        }
        Some(axes)
    };
    if let Some(axes) = poll(DRAIN, || read().filter(|a| a.iter().all(|a| a.lost() == 0))) {
        return Ok(axes);
    }
    read().context("the boards' feedback stayed torn")
}

/// The joints of the status stream [axis units] once two samples in a row are the same and
/// the state is neither `MOVING` nor `STOPPING`.
fn host_at_rest(c: &mut Conn) -> anyhow::Result<Vec<f64>> {
    let mark = c.lines.mark();
    c.ask("SUBSCRIBE")?;
    let mut from = mark;
    let mut last: Option<String> = None;
    loop {
        let (i, _, line) = c
            .lines
            .find(from, PATIENCE, |l| l.starts_with("EVT STATUS "))
            .with_context(|| format!("the robot did not come to rest within {PATIENCE:?}"))?;
        from = i + 1;
        let state = wrc_protocol::reply_field(&line, "state").unwrap_or("?");
        let joints = wrc_protocol::reply_field(&line, "j").map(str::to_string);
        let resting = !matches!(state, "MOVING" | "STOPPING");
        if resting && joints.is_some() && joints == last {
            c.ask("UNSUBSCRIBE")?;
            return joints
                .unwrap_or_default()
                .split(',')
                .map(|v| {
                    v.parse::<f64>()
                        .context("EVT STATUS: a joint that is not a number")
                })
                .collect();
        }
        last = if resting { joints } else { None };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lost_pulses_are_the_host_count_less_the_board_count() {
        let a = AxisPulses {
            name: "j1".into(),
            host: 150_000,
            board: 149_998,
            encoder: 149_998,
            board_underruns: 0,
            discarded: 0,
        };
        assert_eq!(a.lost(), 2);
        assert_eq!(a.to_json()["lost_pulses"], 2);
        let b = AxisPulses {
            board: 150_001,
            ..a
        };
        assert_eq!(b.lost(), -1);
    }
}
