//! Admission: whether a request may be carried out now (the control lock and the
//! interlocks), decided from a snapshot of the controller's state before anything acts. A
//! pure function: no clock, no queues, so every rule is a unit test.

use wrc_protocol::{Code, Command};

use crate::messages::SourceId;
use crate::shared::RobotState;

/// What admission looks at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Situation {
    /// Who sent the request (a connection, [`SourceId::PROGRAM`] or [`SourceId::CELL`]).
    pub from: SourceId,
    /// On whose behalf: a program acts for its starter, a wafer job for its requester.
    pub acting: SourceId,
    /// The source holding control ([`SourceId::NONE`]: nobody).
    pub owner: SourceId,
    /// The controller's state.
    pub state: RobotState,
    /// The robot has been homed.
    pub homed: bool,
    /// A wafer job is under way.
    pub job: bool,
    /// A program is running (or paused).
    pub program: bool,
}

/// Why a request is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Refused {
    /// Another source holds control (the reply names it).
    ControlHeld(SourceId),
    /// An interlock: the code and the sentence the client sees.
    Interlock(Code, &'static str),
}

/// Whether `command` is a motion request (it moves the arm from standstill).
pub(super) fn is_motion(command: &Command) -> bool {
    matches!(
        command,
        Command::Home
            | Command::Retract
            | Command::MovJ { .. }
            | Command::MovP { .. }
            | Command::MovL { .. }
            | Command::Jog { .. }
    )
}

/// Admit `command` in situation `s`, or say why not. Every rule, in the order it is checked:
/// the control lock (verbs that need control, from anyone but the owner); then, for a
/// motion: a wafer job or a program owns the arm, ERROR, ESTOP, a stop or a HOLD under way,
/// a held motion (RESUME or STOP first), not homed (HOME excepted).
pub(super) fn admit(command: &Command, s: &Situation) -> Result<(), Refused> {
    if command.verb().spec().needs_control() && s.owner != SourceId::NONE && s.owner != s.acting {
        return Err(Refused::ControlHeld(s.owner));
    }
    if !is_motion(command) {
        return Ok(());
    }
    let refuse = |code, text| Err(Refused::Interlock(code, text));
    if s.job && s.from != SourceId::CELL {
        return refuse(
            Code::TransferBusy,
            "a transfer or mapping is in progress; wait for its end or STOP",
        );
    }
    if s.program && s.from != SourceId::PROGRAM && s.from != SourceId::CELL {
        return refuse(Code::ProgramRunning, "a program is running; ABORT it first");
    }
    match s.state {
        RobotState::Error => return refuse(Code::InError, "the robot is in ERROR; RESET first"),
        RobotState::Estop => return refuse(Code::InEstop, "the robot is in ESTOP; RESET first"),
        RobotState::Stopping => {
            return refuse(Code::Busy, "the robot is stopping; repeat when it is IDLE")
        }
        RobotState::Held => {
            return refuse(
                Code::Busy,
                "a motion is held; RESUME it or STOP to abandon it first",
            )
        }
        RobotState::Idle | RobotState::Moving => {}
        _ => return refuse(Code::Busy, "the robot is not ready for a motion"),
    }
    if !matches!(command, Command::Home | Command::Retract) && !s.homed {
        return refuse(Code::NotHomed, "the robot is not homed; send HOME first");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use wrc_robot::Pose;

    const HOST: SourceId = SourceId(0x1000_0001);
    const OTHER: SourceId = SourceId(0x1000_0002);

    fn idle() -> Situation {
        Situation {
            from: HOST,
            acting: HOST,
            owner: SourceId::NONE,
            state: RobotState::Idle,
            homed: true,
            job: false,
            program: false,
        }
    }

    fn movl() -> Command {
        Command::MovL {
            pose: Pose {
                x: 300.0,
                y: 0.0,
                z: 0.0,
                yaw: 0.0,
            },
        }
    }

    fn code(r: Result<(), Refused>) -> Option<Code> {
        match r {
            Ok(()) => None,
            Err(Refused::ControlHeld(_)) => Some(Code::ControlHeld),
            Err(Refused::Interlock(code, _)) => Some(code),
        }
    }

    #[test]
    fn the_control_lock_refuses_others_but_never_stop_queries_or_hold() {
        let s = Situation {
            owner: OTHER,
            ..idle()
        };
        assert_eq!(admit(&movl(), &s), Err(Refused::ControlHeld(OTHER)));
        assert_eq!(
            code(admit(&Command::Speed(50.0), &s)),
            Some(Code::ControlHeld)
        );
        assert_eq!(code(admit(&Command::Resume, &s)), Some(Code::ControlHeld));
        for free in [
            Command::Stop,
            Command::Estop,
            Command::Hold,
            Command::Status,
        ] {
            assert_eq!(admit(&free, &s), Ok(()), "{free:?}");
        }
        // The owner itself, and a program acting for the owner, pass.
        let own = Situation {
            owner: HOST,
            ..idle()
        };
        assert_eq!(admit(&movl(), &own), Ok(()));
        let program = Situation {
            from: SourceId::PROGRAM,
            acting: HOST,
            owner: HOST,
            program: true,
            ..idle()
        };
        assert_eq!(admit(&movl(), &program), Ok(()));
    }

    #[test]
    fn motions_are_refused_in_every_state_that_forbids_them() {
        let cases = [
            (RobotState::Error, Some(Code::InError)),
            (RobotState::Estop, Some(Code::InEstop)),
            (RobotState::Stopping, Some(Code::Busy)),
            (RobotState::Held, Some(Code::Busy)),
            (RobotState::Moving, None),
            (RobotState::Idle, None),
        ];
        for (state, want) in cases {
            let s = Situation { state, ..idle() };
            assert_eq!(code(admit(&movl(), &s)), want, "{state:?}");
            // Queries are never interlocked.
            assert_eq!(admit(&Command::Where, &s), Ok(()));
        }
    }

    #[test]
    fn a_job_or_a_program_owns_the_arm_and_home_needs_no_homing() {
        let job = Situation {
            job: true,
            ..idle()
        };
        assert_eq!(code(admit(&movl(), &job)), Some(Code::TransferBusy));
        let own = Situation {
            from: SourceId::CELL,
            ..job
        };
        assert_eq!(admit(&movl(), &own), Ok(()));
        let program = Situation {
            program: true,
            ..idle()
        };
        assert_eq!(code(admit(&movl(), &program)), Some(Code::ProgramRunning));
        let unhomed = Situation {
            homed: false,
            ..idle()
        };
        assert_eq!(code(admit(&movl(), &unhomed)), Some(Code::NotHomed));
        assert_eq!(admit(&Command::Home, &unhomed), Ok(()));
    }
}
