//! The stable reply codes of the host protocol, grouped by severity; the numbers are a
//! contract with every client and are never renumbered or reused.

use core::fmt;

/// How serious a [`Code`] is, as the robots' warning / alarm / fatal levels.
///
/// The hundreds digit of the number says the severity: 1xx warning, 2xx alarm, 3xx fatal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Severity {
    /// 1xx: a request was refused (`NAK`); nothing moved and the state did not change.
    Warning,
    /// 2xx: an action ended abnormally or the controller stopped (`ABS`, `EVT ERROR`); the
    /// robot is stopped and `RESET` clears the condition once its cause is gone.
    Alarm,
    /// 3xx: the controller cannot go on (`ABS`, `EVT ERROR`); restart it.
    Fatal,
}

impl Severity {
    /// The severity's name as written in documentation (`warning`, `alarm`, `fatal`).
    pub fn as_str(self) -> &'static str {
        match self {
            Severity::Warning => "warning",
            Severity::Alarm => "alarm",
            Severity::Fatal => "fatal",
        }
    }
}

impl fmt::Display for Severity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A reply code: the number after `NAK` / `ABS` / `EVT ERROR` and after `err=` in `STATUS`.
///
/// The discriminant is the code's number. New codes are added with new numbers; existing
/// numbers never change meaning. `err=0` in `STATUS` means "no error" and is not a `Code`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
#[repr(u16)]
pub enum Code {
    // 1xx warning: the request is refused (NAK), nothing moved.
    /// 100: the verb is not one the controller knows.
    UnknownVerb = 100,
    /// 101: too many or too few arguments for the verb.
    ArgumentCount = 101,
    /// 102: an argument is not a (finite, whole where required) number.
    BadNumber = 102,
    /// 103: the line is longer than 256 bytes.
    LineTooLong = 103,
    /// 104: the `*HH` checksum is malformed or does not match.
    BadChecksum = 104,
    /// 105: the line is not a request (bytes that are not printable ASCII, a bad id, empty).
    Malformed = 105,
    /// 106: an argument that is not a number is not one of the accepted words.
    BadArgument = 106,
    /// 107: the connection may only monitor (read-only verbs) and the request acts.
    MonitorOnly = 107,
    /// 108: `AUTH` with a wrong token, or on a connection that cannot take control.
    AuthFailed = 108,
    /// 110: the robot is not homed; send `HOME` first.
    NotHomed = 110,
    /// 111: the target is out of the arm's reach.
    OutOfReach = 111,
    /// 112: the target is beyond a joint's soft limit.
    JointLimit = 112,
    /// 113: the straight path leaves the workspace.
    PathLeavesWorkspace = 113,
    /// 114: no such axis.
    AxisUnknown = 114,
    /// 115: the speed is not within 1-100 [%].
    SpeedOutOfRange = 115,
    /// 116: no such output.
    OutputUnknown = 116,
    /// 117: the motion would touch a station off its line or a fixed obstacle of the cell
    /// (or its brake would), and no safe route goes around it.
    Collision = 117,
    /// 120: another command source holds control.
    ControlHeld = 120,
    /// 121: the robot is busy with a motion; wait for it or send `STOP`.
    Busy = 121,
    /// 122: the controller is in the ERROR state; send `RESET` first.
    InError = 122,
    /// 123: the emergency stop is active; release it and send `RESET` first.
    InEstop = 123,
    /// 124: the verb is not available on this connection.
    NotAvailable = 124,
    /// 125: no stored program has that name.
    ProgramUnknown = 125,
    /// 126: the program does not compile (diagnostics precede the NAK as `DIAG` lines).
    ProgramInvalid = 126,
    /// 127: a program is running (or paused); ABORT it first.
    ProgramRunning = 127,
    /// 128: no program is running.
    NoProgram = 128,
    /// 129: RESUME with no held motion.
    NotHeld = 129,
    /// 130: no station has that name.
    StationUnknown = 130,
    /// 131: GET from a slot the wafer map says is empty.
    SlotEmpty = 131,
    /// 132: PUT into a slot the wafer map says is occupied.
    SlotOccupied = 132,
    /// 133: GET while the hand already holds a wafer.
    HandFull = 133,
    /// 134: PUT while the hand holds no wafer.
    HandEmpty = 134,
    /// 135: the station's interlock input says it is closed (not safe to enter).
    InterlockClosed = 135,
    /// 136: the slot is not usable: not mapped yet, a double or a cross-slotted wafer.
    SlotNotUsable = 136,
    /// 137: the station has no such slot.
    SlotUnknown = 137,
    /// 138: a wafer transfer or mapping is in progress.
    TransferBusy = 138,
    /// 139: the place (a slot or a blade) is uncertain after an interrupted transfer: MAP
    /// the station, SENSE the blade or CONFIRM it first.
    PlaceUncertain = 139,
    /// 140: the hand may be inside a station (after an interrupted transfer): RETRACT or
    /// HOME first.
    HandInside = 140,
    /// 141: the output is guarded while a blade holds a wafer (a blade's vacuum valve
    /// switched off, or an output the configuration guards): `OUT <n> <0|1> FORCE` if it is
    /// meant.
    OutputGuarded = 141,

    // 2xx alarm: an action ended abnormally (ABS) or the controller stopped (EVT ERROR).
    /// 200: the motion was stopped by `STOP`.
    Stopped = 200,
    /// 201: the motion was stopped by `ESTOP`.
    EmergencyStop = 201,
    /// 202: the emergency-stop input opened.
    EstopInput = 202,
    /// 203: an axis lagged its command by more than the allowed following error.
    FollowingError = 203,
    /// 204: an axis reached a soft limit.
    SoftLimit = 204,
    /// 205: a servo drive reported an alarm.
    ServoAlarm = 205,
    /// 206: the motion board's watchdog expired.
    BoardWatchdog = 206,
    /// 207: a real-time task overran its period.
    TaskOverrun = 207,
    /// 208: the client that held control disconnected during a motion.
    ClientLost = 208,
    /// 209: the motion could not be carried out (planning or execution fault).
    MotionFault = 209,
    /// 210: the program ended on a runtime error (the text names the source line).
    ProgramError = 210,
    /// 211: a program's `WAIT IN(n) = v TIMEOUT s` timed out.
    WaitTimeout = 211,
    /// 212: the vacuum sensor did not confirm the wafer after a GET (or its release after a
    /// PUT).
    WaferNotSensed = 212,
    /// 213: the vacuum sensor lost the wafer while the hand carried it.
    WaferLost = 213,
    /// 214: the station's interlock opened while the hand was entering or inside it.
    InterlockOpened = 214,
    /// 215: the program ended on an error it raised itself (`RAISE` with a code of its
    /// own, 1000 and up) that no TRY caught; the text names the code.
    ProgramAlarm = 215,
    /// 216: at start-up the transfer journal showed a transfer (or mapping) interrupted by a
    /// power loss: the wafer map has uncertain places, or the hand may be inside a station
    /// (`RECOVERY` says which).
    TransferInterrupted = 216,

    // 3xx fatal: the controller cannot go on.
    /// 300: the motion board stopped answering.
    BoardLost = 300,
    /// 301: an internal error; please report it.
    Internal = 301,
}

impl Code {
    /// Every code, in number order.
    pub const ALL: &'static [Code] = &[
        Code::UnknownVerb,
        Code::ArgumentCount,
        Code::BadNumber,
        Code::LineTooLong,
        Code::BadChecksum,
        Code::Malformed,
        Code::BadArgument,
        Code::MonitorOnly,
        Code::AuthFailed,
        Code::NotHomed,
        Code::OutOfReach,
        Code::JointLimit,
        Code::PathLeavesWorkspace,
        Code::AxisUnknown,
        Code::SpeedOutOfRange,
        Code::OutputUnknown,
        Code::Collision,
        Code::ControlHeld,
        Code::Busy,
        Code::InError,
        Code::InEstop,
        Code::NotAvailable,
        Code::ProgramUnknown,
        Code::ProgramInvalid,
        Code::ProgramRunning,
        Code::NoProgram,
        Code::NotHeld,
        Code::StationUnknown,
        Code::SlotEmpty,
        Code::SlotOccupied,
        Code::HandFull,
        Code::HandEmpty,
        Code::InterlockClosed,
        Code::SlotNotUsable,
        Code::SlotUnknown,
        Code::TransferBusy,
        Code::PlaceUncertain,
        Code::HandInside,
        Code::OutputGuarded,
        Code::Stopped,
        Code::EmergencyStop,
        Code::EstopInput,
        Code::FollowingError,
        Code::SoftLimit,
        Code::ServoAlarm,
        Code::BoardWatchdog,
        Code::TaskOverrun,
        Code::ClientLost,
        Code::MotionFault,
        Code::ProgramError,
        Code::WaitTimeout,
        Code::WaferNotSensed,
        Code::WaferLost,
        Code::InterlockOpened,
        Code::ProgramAlarm,
        Code::TransferInterrupted,
        Code::BoardLost,
        Code::Internal,
    ];

    /// The code's number (100-399).
    pub fn number(self) -> u16 {
        self as u16
    }

    /// The code with `number`, if there is one.
    pub fn from_number(number: u16) -> Option<Code> {
        Code::ALL.iter().copied().find(|c| c.number() == number)
    }

    /// The code's severity, from its hundreds digit.
    pub fn severity(self) -> Severity {
        match self.number() {
            0..=199 => Severity::Warning,
            200..=299 => Severity::Alarm,
            _ => Severity::Fatal,
        }
    }

    /// The code's short default text, for replies that have nothing more precise to say.
    pub fn text(self) -> &'static str {
        match self {
            Code::UnknownVerb => "unknown verb; HELP lists the verbs",
            Code::ArgumentCount => "wrong number of arguments",
            Code::BadNumber => "bad number",
            Code::LineTooLong => "line longer than 256 bytes",
            Code::BadChecksum => "checksum mismatch",
            Code::Malformed => "malformed request",
            Code::BadArgument => "bad argument",
            Code::MonitorOnly => "this connection may only monitor",
            Code::AuthFailed => "wrong token",
            Code::NotHomed => "not homed; send HOME first",
            Code::OutOfReach => "target out of reach",
            Code::JointLimit => "target beyond a joint limit",
            Code::PathLeavesWorkspace => "path leaves the workspace",
            Code::AxisUnknown => "no such axis",
            Code::SpeedOutOfRange => "speed must be 1-100",
            Code::OutputUnknown => "no such output",
            Code::Collision => "the motion would touch the cell",
            Code::ControlHeld => "control held by another source",
            Code::Busy => "busy with a motion; WAIT or STOP first",
            Code::InError => "in ERROR state; send RESET first",
            Code::InEstop => "emergency stop active; release it and send RESET",
            Code::NotAvailable => "not available on this connection",
            Code::ProgramUnknown => "no such program; PROGRAMS lists them",
            Code::ProgramInvalid => "the program does not compile",
            Code::ProgramRunning => "a program is running; ABORT it first",
            Code::NoProgram => "no program is running",
            Code::NotHeld => "no motion is held",
            Code::StationUnknown => "no such station; STN lists them",
            Code::SlotEmpty => "the slot is empty",
            Code::SlotOccupied => "the slot is occupied",
            Code::HandFull => "the hand already holds a wafer",
            Code::HandEmpty => "the hand holds no wafer",
            Code::InterlockClosed => "the station's interlock is closed",
            Code::SlotNotUsable => "the slot is not mapped or holds a faulty wafer; MAP it",
            Code::SlotUnknown => "no such slot",
            Code::TransferBusy => "a transfer or mapping is in progress",
            Code::PlaceUncertain => {
                "the place is uncertain after an interrupted transfer; MAP, SENSE or CONFIRM it"
            }
            Code::HandInside => "the hand may be inside a station; RETRACT or HOME first",
            Code::OutputGuarded => {
                "the output is guarded while a blade holds a wafer; add FORCE if you mean it"
            }
            Code::Stopped => "stopped by STOP",
            Code::EmergencyStop => "emergency stop",
            Code::EstopInput => "emergency-stop input opened",
            Code::FollowingError => "following error",
            Code::SoftLimit => "soft limit reached",
            Code::ServoAlarm => "servo alarm",
            Code::BoardWatchdog => "motion board watchdog expired",
            Code::TaskOverrun => "real-time task overran its period",
            Code::ClientLost => "controlling client lost",
            Code::MotionFault => "motion fault",
            Code::ProgramError => "program error",
            Code::WaitTimeout => "WAIT timed out",
            Code::WaferNotSensed => "wafer not sensed",
            Code::WaferLost => "wafer lost",
            Code::InterlockOpened => "station interlock opened",
            Code::ProgramAlarm => "the program raised an alarm",
            Code::TransferInterrupted => {
                "a transfer was interrupted by a power loss; RECOVERY says what is uncertain"
            }
            Code::BoardLost => "motion board lost",
            Code::Internal => "internal error",
        }
    }
}

/// Writes the number, e.g. `110`.
impl fmt::Display for Code {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.number())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_unique_sorted_and_round_trip() {
        for pair in Code::ALL.windows(2) {
            assert!(pair[0].number() < pair[1].number(), "{pair:?}");
        }
        for &code in Code::ALL {
            assert_eq!(Code::from_number(code.number()), Some(code));
            assert!(!code.text().is_empty());
            assert!(code.text().is_ascii());
        }
        assert_eq!(Code::from_number(0), None);
        assert_eq!(Code::from_number(199), None);
    }

    /// The numbers are a contract with clients: this test pins them.
    #[test]
    fn numbers_never_change() {
        let pinned = [
            (Code::UnknownVerb, 100),
            (Code::ArgumentCount, 101),
            (Code::BadNumber, 102),
            (Code::LineTooLong, 103),
            (Code::BadChecksum, 104),
            (Code::Malformed, 105),
            (Code::BadArgument, 106),
            (Code::MonitorOnly, 107),
            (Code::AuthFailed, 108),
            (Code::NotHomed, 110),
            (Code::OutOfReach, 111),
            (Code::JointLimit, 112),
            (Code::PathLeavesWorkspace, 113),
            (Code::AxisUnknown, 114),
            (Code::SpeedOutOfRange, 115),
            (Code::OutputUnknown, 116),
            (Code::Collision, 117),
            (Code::ControlHeld, 120),
            (Code::Busy, 121),
            (Code::InError, 122),
            (Code::InEstop, 123),
            (Code::NotAvailable, 124),
            (Code::ProgramUnknown, 125),
            (Code::ProgramInvalid, 126),
            (Code::ProgramRunning, 127),
            (Code::NoProgram, 128),
            (Code::NotHeld, 129),
            (Code::StationUnknown, 130),
            (Code::SlotEmpty, 131),
            (Code::SlotOccupied, 132),
            (Code::HandFull, 133),
            (Code::HandEmpty, 134),
            (Code::InterlockClosed, 135),
            (Code::SlotNotUsable, 136),
            (Code::SlotUnknown, 137),
            (Code::TransferBusy, 138),
            (Code::PlaceUncertain, 139),
            (Code::HandInside, 140),
            (Code::OutputGuarded, 141),
            (Code::Stopped, 200),
            (Code::EmergencyStop, 201),
            (Code::EstopInput, 202),
            (Code::FollowingError, 203),
            (Code::SoftLimit, 204),
            (Code::ServoAlarm, 205),
            (Code::BoardWatchdog, 206),
            (Code::TaskOverrun, 207),
            (Code::ClientLost, 208),
            (Code::MotionFault, 209),
            (Code::ProgramError, 210),
            (Code::WaitTimeout, 211),
            (Code::WaferNotSensed, 212),
            (Code::WaferLost, 213),
            (Code::InterlockOpened, 214),
            (Code::ProgramAlarm, 215),
            (Code::TransferInterrupted, 216),
            (Code::BoardLost, 300),
            (Code::Internal, 301),
        ];
        assert_eq!(pinned.len(), Code::ALL.len());
        for (code, number) in pinned {
            assert_eq!(code.number(), number, "{code:?}");
        }
    }

    #[test]
    fn severity_follows_the_hundreds_digit() {
        assert_eq!(Code::NotHomed.severity(), Severity::Warning);
        assert_eq!(Code::Stopped.severity(), Severity::Alarm);
        assert_eq!(Code::BoardLost.severity(), Severity::Fatal);
        assert_eq!(Code::ControlHeld.to_string(), "120");
    }
}
