//! What a trace says about itself: why and when it was saved, how to read its samples, and
//! what a replay needs to start the controller as the session started.

/// Which clock the times of a trace come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockKind {
    /// `CLOCK_MONOTONIC`: the controller ran in real time.
    Monotonic,
    /// Virtual time: the controller ran under a simulated clock (a replay, a test).
    Virtual,
}

impl ClockKind {
    /// The clock's name as `wrc trace info` prints it (`monotonic`, `virtual`).
    pub fn as_str(self) -> &'static str {
        match self {
            ClockKind::Monotonic => "monotonic",
            ClockKind::Virtual => "virtual",
        }
    }
}

/// What a reader and a replay need besides the samples and messages.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Meta {
    /// Version of the wrc that wrote the trace (`CARGO_PKG_VERSION`), filled by the caller.
    pub wrc_version: String,
    /// Why the trace was saved: `TRACE SAVE`, `alarm 206 motion board watchdog expired`, ….
    pub reason: String,
    /// The clock the times come from.
    pub clock: ClockKind,
    /// Sample period [ns].
    pub period_ns: u64,
    /// One name per axis, in axis order; their number is the trace's axis count (at most
    /// [`MAX_AXES`](crate::MAX_AXES)).
    pub axis_names: Vec<String>,
    /// State code → name ([`Sample::state`](crate::Sample::state) indexes it).
    pub state_names: Vec<String>,
    /// The configuration text (TOML) the controller ran.
    pub config_toml: String,
    /// The stations file (TOML) the controller ran, if any.
    pub stations_toml: Option<String>,
    /// The wafer map (TOML) at session start, if any.
    pub wafers_toml: Option<String>,
    /// The simulated cell's ground truth (TOML) at session start, if any.
    pub world_toml: Option<String>,
    /// Stored robot programs at session start: (name, source text).
    pub programs: Vec<(String, String)>,
    /// Commanded position per axis at session start [pulse].
    pub start_pulses: Vec<i64>,
    /// The messages cover the session from its start, so a replay can re-run it.
    pub from_start: bool,
    /// Controller clock when the trace was saved [ns since the controller started].
    pub saved_at_ns: u64,
}

impl Meta {
    /// A meta with `reason`, `period_ns` [ns], the axis names and the state names (the
    /// controller passes `wrc_protocol::State::ALL`'s names) and everything else empty:
    /// monotonic clock, no configuration, not from start, saved at 0.
    pub fn new(reason: &str, period_ns: u64, axis_names: &[&str], state_names: &[&str]) -> Meta {
        let owned = |names: &[&str]| names.iter().map(|s| s.to_string()).collect();
        Meta {
            wrc_version: String::new(),
            reason: reason.to_string(),
            clock: ClockKind::Monotonic,
            period_ns,
            axis_names: owned(axis_names),
            state_names: owned(state_names),
            config_toml: String::new(),
            stations_toml: None,
            wafers_toml: None,
            world_toml: None,
            programs: Vec::new(),
            start_pulses: Vec::new(),
            from_start: false,
            saved_at_ns: 0,
        }
    }

    /// The number of axes of the trace: the number of axis names.
    pub fn axis_count(&self) -> usize {
        self.axis_names.len()
    }

    /// The name of state code `state`, or `state N` when the table has none.
    pub fn state_name(&self, state: u8) -> String {
        self.state_names
            .get(usize::from(state))
            .cloned()
            .unwrap_or_else(|| format!("state {state}"))
    }
}
