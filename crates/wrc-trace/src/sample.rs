//! One period of the controller as the Pulse Generator saw it: a plain `Copy` value it
//! pushes into the ring every period, with no allocation.

/// The most axes a sample holds: 4 motion boards of 4 axes.
pub const MAX_AXES: usize = wrc_robot::MAX_AXES;

/// The controller in one Pulse Generator period.
///
/// Only the first `axis_count` entries of the position arrays are meaningful (the trace's
/// [`Meta::axis_names`](crate::Meta::axis_names) says how many); the rest are 0 and are not
/// written to a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Sample {
    /// Controller clock at this period [ns since the controller started], virtual or
    /// monotonic (see [`Meta::clock`](crate::Meta::clock)).
    pub t_ns: u64,
    /// Commanded position per axis [pulse].
    pub commanded: [i64; MAX_AXES],
    /// Encoder position per axis [pulse].
    pub actual: [i64; MAX_AXES],
    /// Digital inputs of board 0, bit n = input n asserted.
    pub inputs: u32,
    /// Digital outputs of board 0, bit n = output n on.
    pub outputs: u32,
    /// Robot state code: the number of `wrc_protocol::State` (0 `IDLE` …); the trace's
    /// [`Meta::state_names`](crate::Meta::state_names) names it.
    pub state: u8,
    /// Last error code, 0 for none.
    pub error_code: u16,
    /// Level of the board's command FIFO [periods].
    pub fifo_level: u16,
    /// Pulse Generator wake-up latency of this cycle [ns].
    pub latency_ns: u32,
    /// Pulse Generator execution time of its previous cycle [ns].
    pub exec_ns: u32,
}

/// Bytes one sample of `axis_count` axes takes in a trace file [byte]: 29 + 16 per axis
/// (93 for 4 axes). `axis_count` above [`MAX_AXES`] counts as [`MAX_AXES`].
pub const fn sample_file_bytes(axis_count: usize) -> usize {
    let axes = if axis_count > MAX_AXES {
        MAX_AXES
    } else {
        axis_count
    };
    // t_ns, 2 positions per axis, inputs, outputs, state, error_code, fifo_level,
    // latency_ns, exec_ns.
    8 + 16 * axes + 4 + 4 + 1 + 2 + 2 + 4 + 4
}
