//! The verb table: every verb's name, usage, one-line summary and how the controller treats
//! it. Adding a verb starts here (a variant, its [`Verb::spec`] arm, its place in
//! [`Verb::ALL`]), then its [`Command`](crate::Command) variant and parse arm.

use core::fmt;

/// A request verb (the word after the optional id), matched case-insensitively.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Verb {
    /// `STATUS`: state, homed, speed, owner and last error.
    Status,
    /// `WHERE`: joint positions and the tool pose.
    Where,
    /// `HOME`: home every axis.
    Home,
    /// `MOVJ`: joint point-to-point move.
    MovJ,
    /// `MOVP`: point-to-point move to a Cartesian pose.
    MovP,
    /// `MOVL`: straight-line move to a Cartesian pose.
    MovL,
    /// `JOG`: move one axis by a number of pulses.
    Jog,
    /// `SPEED`: set the speed override [%].
    Speed,
    /// `STOP`: controlled stop.
    Stop,
    /// `ESTOP`: emergency stop.
    Estop,
    /// `HOLD`: brake on the path and keep the motion, to be resumed.
    Hold,
    /// `RESUME`: continue a held motion on the same path to the same target.
    Resume,
    /// `RESET`: clear ERROR or ESTOP.
    Reset,
    /// `IO`: input and output words.
    Io,
    /// `OUT`: set one output.
    Out,
    /// `WAIT`: reply INF when the robot stands still.
    Wait,
    /// `CONTROL`: take control for this connection.
    Control,
    /// `RELEASE`: give control back.
    Release,
    /// `HELP`: list the verbs.
    Help,
    /// `SUBSCRIBE`: receive the status stream on this connection.
    Subscribe,
    /// `UNSUBSCRIBE`: stop the status stream on this connection.
    Unsubscribe,
    /// `UPLOAD`: store a robot-language program (its lines follow, up to a line `.`).
    Upload,
    /// `PROGRAMS`: list the stored programs.
    Programs,
    /// `RUN`: compile and run a stored program.
    Run,
    /// `PAUSE`: pause the running program after its current motion.
    Pause,
    /// `CONTINUE`: continue a paused program.
    Continue,
    /// `ABORT`: end the running program and stop its motion.
    Abort,
    /// `DELETE`: remove a stored program.
    Delete,
    /// `ROBOT`: the robot's geometry and axes, for a GUI.
    Robot,
    /// `TASKS`: the real-time tasks' measured timing.
    Tasks,
    /// `TRACE SAVE`: write the trace recorder's last seconds to a file.
    Trace,
    /// `STN`: list the stations.
    Stn,
    /// `TEACH`: store the current pose as a station's taught pose.
    Teach,
    /// `WAFERS`: where every wafer is.
    Wafers,
    /// `GET`: take a wafer from a station slot onto the hand.
    Get,
    /// `PUT`: put the hand's wafer into a station slot.
    Put,
    /// `MAP`: scan a station's slots with the mapping sensor.
    Map,
    /// `SWAP`: at one slot, take its wafer with the empty blade and put the other blade's.
    Swap,
    /// `AUTH`: present the control token on a connection from off the machine.
    Auth,
    /// `BREAK`: set, list or clear the running program's breakpoints.
    Break,
    /// `STEP`: run one statement of the paused program (into, over or out of a call).
    Step,
    /// `VARS`: the values of the running program's variables.
    Vars,
    /// `POINTS`: a stored program's named points.
    Points,
    /// `POINT`: set, teach or delete one named point of a stored program.
    Point,
    /// `RECOVERY`: what an interrupted transfer left uncertain, and where the hand is.
    Recovery,
    /// `RETRACT`: take the hand straight out of the station it may be inside.
    Retract,
    /// `SENSE`: read a blade's vacuum sensor with its valve on.
    Sense,
    /// `CONFIRM`: an operator's word on an uncertain place.
    Confirm,
}

/// What a verb does, which decides who may send it (docs/protocol.md "Connections").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// It only reads: every connection may send it, a monitoring one included.
    Read,
    /// It acts without needing control (a stop, control itself, an upload): every
    /// connection that may command, whoever holds control.
    Act,
    /// It moves the robot or changes its settings: refused (code 120) while another source
    /// holds control.
    Control,
}

/// What the controller needs to know about a verb, and what `HELP` and the docs say.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VerbSpec {
    /// The verb as written on the wire, upper case.
    pub name: &'static str,
    /// Arguments, as in the docs (`<x> <y> <z> <yaw> [L|R]`); empty when there are none.
    pub args: &'static str,
    /// One-line description.
    pub summary: &'static str,
    /// The request runs in three phases: `ACK` when accepted, then `INF` when it finished
    /// normally or `ABS` when it ended abnormally.
    pub completes_later: bool,
    /// Who may send it: [`Access::Control`] verbs are refused (code 120) while another
    /// source holds control; a monitoring connection may send [`Access::Read`] verbs only.
    pub access: Access,
}

impl VerbSpec {
    /// The request is refused (code 120) while another source holds control. `STOP`,
    /// `ESTOP` and queries are accepted from every source.
    pub fn needs_control(&self) -> bool {
        self.access == Access::Control
    }
}

impl Verb {
    /// Every verb, in the order `HELP` lists them.
    pub const ALL: &'static [Verb] = &[
        Verb::Status,
        Verb::Where,
        Verb::Home,
        Verb::MovJ,
        Verb::MovP,
        Verb::MovL,
        Verb::Jog,
        Verb::Speed,
        Verb::Stop,
        Verb::Estop,
        Verb::Hold,
        Verb::Resume,
        Verb::Reset,
        Verb::Io,
        Verb::Out,
        Verb::Wait,
        Verb::Control,
        Verb::Release,
        Verb::Help,
        Verb::Subscribe,
        Verb::Unsubscribe,
        Verb::Upload,
        Verb::Programs,
        Verb::Run,
        Verb::Pause,
        Verb::Continue,
        Verb::Abort,
        Verb::Delete,
        Verb::Robot,
        Verb::Tasks,
        Verb::Trace,
        Verb::Stn,
        Verb::Teach,
        Verb::Wafers,
        Verb::Get,
        Verb::Put,
        Verb::Map,
        Verb::Swap,
        Verb::Auth,
        Verb::Break,
        Verb::Step,
        Verb::Vars,
        Verb::Points,
        Verb::Point,
        Verb::Recovery,
        Verb::Retract,
        Verb::Sense,
        Verb::Confirm,
    ];

    /// The verb's table entry.
    pub fn spec(self) -> VerbSpec {
        const fn v(
            name: &'static str,
            args: &'static str,
            summary: &'static str,
            completes_later: bool,
            access: Access,
        ) -> VerbSpec {
            VerbSpec {
                name,
                args,
                summary,
                completes_later,
                access,
            }
        }
        match self {
            Verb::Status => v(
                "STATUS",
                "",
                "state, homed, speed, owner, last error",
                false,
                Access::Read,
            ),
            Verb::Where => v("WHERE", "", "joint positions and tool pose", false, Access::Read),
            Verb::Home => v("HOME", "", "home every axis", true, Access::Control),
            Verb::MovJ => v(
                "MOVJ",
                "<j1> ... <jn>",
                "joint PTP move [deg|mm]",
                true,
                Access::Control,
            ),
            Verb::MovP => v(
                "MOVP",
                "<x> <y> <z> <yaw> [L|R]",
                "PTP move to a pose [mm, deg]",
                true,
                Access::Control,
            ),
            Verb::MovL => v(
                "MOVL",
                "<x> <y> <z> <yaw>",
                "straight-line move to a pose [mm, deg]",
                true,
                Access::Control,
            ),
            Verb::Jog => v(
                "JOG",
                "<axis> <pulses>",
                "move one axis [pulse]",
                true,
                Access::Control,
            ),
            Verb::Speed => v("SPEED", "<1-100>", "speed override [%]", false, Access::Control),
            Verb::Stop => v("STOP", "", "controlled stop", false, Access::Act),
            Verb::Estop => v("ESTOP", "", "emergency stop", false, Access::Act),
            Verb::Hold => v(
                "HOLD",
                "",
                "brake on the path and keep the motion (RESUME continues it)",
                false,
                Access::Act,
            ),
            Verb::Resume => v(
                "RESUME",
                "",
                "continue a held motion on its path to its target",
                false,
                Access::Control,
            ),
            Verb::Reset => v("RESET", "", "clear ERROR or ESTOP", false, Access::Control),
            Verb::Io => v("IO", "", "input and output words", false, Access::Read),
            Verb::Out => v(
                "OUT",
                "<n> 0|1 [FORCE]",
                "set output n; FORCE: even a guarded one while a blade holds a wafer",
                false,
                Access::Control,
            ),
            Verb::Wait => v("WAIT", "", "INF when the robot stands still", true, Access::Read),
            Verb::Control => v("CONTROL", "", "take control", false, Access::Act),
            Verb::Release => v("RELEASE", "", "give control back", false, Access::Act),
            Verb::Help => v("HELP", "", "list the verbs", false, Access::Read),
            Verb::Subscribe => v("SUBSCRIBE", "", "start the status stream", false, Access::Read),
            Verb::Unsubscribe => v("UNSUBSCRIBE", "", "stop the status stream", false, Access::Read),
            Verb::Upload => v(
                "UPLOAD",
                "<name>",
                "store a program: its lines follow, then a line \".\"",
                false,
                Access::Act,
            ),
            Verb::Programs => v("PROGRAMS", "", "list the stored programs", false, Access::Read),
            Verb::Run => v(
                "RUN",
                "<name> [STEP]",
                "run a stored program (STEP: paused before its first statement)",
                true,
                Access::Control,
            ),
            Verb::Pause => v("PAUSE", "", "pause the running program", false, Access::Control),
            Verb::Continue => v(
                "CONTINUE",
                "[<answer>]",
                "continue a paused program, or answer its WAIT OPERATOR",
                false,
                Access::Control,
            ),
            Verb::Abort => v("ABORT", "", "end the running program", false, Access::Act),
            Verb::Delete => v("DELETE", "<name>", "remove a stored program", false, Access::Control),
            Verb::Robot => v("ROBOT", "", "the robot's geometry and axes", false, Access::Read),
            Verb::Tasks => v("TASKS", "", "the real-time tasks' timing", false, Access::Read),
            Verb::Trace => v(
                "TRACE",
                "SAVE [<name>]",
                "save the trace recorder's last seconds to a file",
                false,
                Access::Act,
            ),
            Verb::Stn => v("STN", "", "list the stations", false, Access::Read),
            Verb::Teach => v(
                "TEACH",
                "<station>",
                "store the current pose as the station's taught pose",
                false,
                Access::Control,
            ),
            Verb::Wafers => v("WAFERS", "", "where every wafer is", false, Access::Read),
            Verb::Get => v(
                "GET",
                "<station> <slot> [A|B]",
                "take the wafer in a station slot onto the hand (or blade A or B)",
                true,
                Access::Control,
            ),
            Verb::Put => v(
                "PUT",
                "<station> <slot> [A|B]",
                "put the hand's (or blade A's or B's) wafer into a station slot",
                true,
                Access::Control,
            ),
            Verb::Map => v(
                "MAP",
                "<station>",
                "scan a station's slots with the mapping sensor",
                true,
                Access::Control,
            ),
            Verb::Swap => v(
                "SWAP",
                "<station> <slot>",
                "dual-blade robot: take the slot's wafer with the empty blade, put the other blade's there",
                true,
                Access::Control,
            ),
            Verb::Auth => v(
                "AUTH",
                "<token>",
                "present the control token (connections from off the machine)",
                false,
                Access::Read,
            ),
            Verb::Break => v(
                "BREAK",
                "[[<file>:]<line> | CLEAR [[<file>:]<line>]]",
                "set a breakpoint, list them, or clear one or all",
                false,
                Access::Control,
            ),
            Verb::Step => v(
                "STEP",
                "[INTO|OVER|OUT]",
                "run one statement of the paused program (its motion at the step speed)",
                false,
                Access::Control,
            ),
            Verb::Vars => v(
                "VARS",
                "[<name> ...]",
                "the running program's variables (all in scope, or these)",
                false,
                Access::Read,
            ),
            Verb::Points => v(
                "POINTS",
                "<program>",
                "a stored program's named points",
                false,
                Access::Read,
            ),
            Verb::Point => v(
                "POINT",
                "<program> <name> <x> <y> <z> <yaw> | JOINTS <j1> ... | HERE | DELETE",
                "set, teach or delete a named point of a stored program",
                false,
                Access::Control,
            ),
            Verb::Recovery => v(
                "RECOVERY",
                "",
                "what an interrupted transfer left uncertain, where the hand is, what to do next",
                false,
                Access::Read,
            ),
            Verb::Retract => v(
                "RETRACT",
                "",
                "take the hand straight out of the station it may be inside, to its approach pose",
                true,
                Access::Control,
            ),
            Verb::Sense => v(
                "SENSE",
                "[A|B]",
                "switch a blade's vacuum on and read its sensor: the wafer map learns what it holds",
                true,
                Access::Control,
            ),
            Verb::Confirm => v(
                "CONFIRM",
                "<wafer> <station> <slot> | <wafer> HAND [A|B] | <wafer> GONE | HAND [A|B] EMPTY | <station> <slot> EMPTY",
                "an operator's word on an uncertain place: where a wafer is, that it is gone, that a place is empty",
                false,
                Access::Control,
            ),
        }
    }

    /// The verb as written on the wire, upper case.
    pub fn name(self) -> &'static str {
        self.spec().name
    }

    /// The verb named `word`, compared ignoring ASCII case.
    pub fn from_name(word: &[u8]) -> Option<Verb> {
        Verb::ALL
            .iter()
            .copied()
            .find(|v| v.name().as_bytes().eq_ignore_ascii_case(word))
    }
}

impl fmt::Display for Verb {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_upper_case_and_found_in_any_case() {
        for (i, &a) in Verb::ALL.iter().enumerate() {
            assert_eq!(a.name(), a.name().to_ascii_uppercase());
            assert_eq!(Verb::from_name(a.name().as_bytes()), Some(a));
            let lower = a.name().to_ascii_lowercase();
            assert_eq!(Verb::from_name(lower.as_bytes()), Some(a));
            for &b in &Verb::ALL[i + 1..] {
                assert_ne!(a.name(), b.name());
            }
        }
        assert_eq!(Verb::from_name(b"MOVE"), None);
        assert_eq!(Verb::from_name(b""), None);
    }
}
