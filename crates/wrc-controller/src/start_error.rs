//! Why the controller could not start ([`StartError`]): its own module, below both the
//! controller's assembly and the hosts (real and virtual time) that report it.

use crate::rs232c::SerialError;

/// Why the controller could not start.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StartError {
    /// A board could not be opened.
    #[error("motion board: {0}")]
    Board(#[from] wrc_board::OpenError),
    /// The simulated wafer cell (under virtual time) does not fit the stations or robot.
    #[error("simulated cell: {0}")]
    SimCell(String),
    /// A simulated board (under virtual time) could not be made.
    #[cfg(feature = "sim")]
    #[error("simulated board: {0}")]
    SimBoard(#[from] wrc_board_sim::SimError),
    /// The boards do not fit the robot's axes.
    #[error("motion boards: {0}")]
    Boards(#[from] wrc_board::MultiError),
    /// An endpoint could not be bound.
    #[error("cannot listen on {what} {at}: {reason}")]
    Bind {
        /// TCP port, Unix socket or UDP sender.
        what: &'static str,
        /// The address or path.
        at: String,
        /// Why.
        reason: std::io::Error,
    },
    /// The host port's admission: bound off loopback without saying who may connect, a
    /// token file that cannot be used, too few file descriptors.
    #[error("host port: {0}")]
    Access(#[from] crate::host_access::AccessError),
    /// The serial port could not be used.
    #[error(transparent)]
    Serial(#[from] SerialError),
    /// The configuration's motion settings.
    #[error("{0}")]
    Settings(#[from] wrc_motion::SettingsError),
    /// The runtime could not start a task.
    #[error("{0}")]
    Runtime(#[from] wrc_rt::RuntimeError),
    /// A task's event waiter (epoll over its sockets or tty and its reply queue) could not
    /// be set up.
    #[error("task {task}: cannot watch its connections and reply queue (epoll): {reason}")]
    Waiter {
        /// The task.
        task: &'static str,
        /// Why.
        reason: std::io::Error,
    },
    /// The stations file or the wafer map is unusable.
    #[error("wafer cell: {0}")]
    Cell(#[from] crate::cell_service::CellError),
    /// The trace directory could not be made.
    #[error("cannot use the trace directory {path}: {reason}")]
    Traces {
        /// The directory.
        path: String,
        /// Why.
        reason: std::io::Error,
    },
    /// The program directory could not be used.
    #[error("cannot use the program directory {path}: {reason}")]
    Programs {
        /// The directory.
        path: String,
        /// Why.
        reason: std::io::Error,
    },
}
