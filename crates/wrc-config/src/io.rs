//! The digital signals (`[io]`): which outputs are guarded while a blade holds a wafer, and
//! the names of the inputs and outputs, for the operator. The configuration already knows
//! some signals by their role — each blade's vacuum valve and sensor and the mapping sensor
//! (`[hand]`), the E-stop button (`[board.sim] estop_input`) — and names those itself;
//! `[io] names` names any other and may rename those.
//!
//! ```toml
//! [io]
//! guarded_outputs = [7]                  # refused (NAK 141) while a blade holds a wafer
//! names.inputs = { 5 = "door closed" }   # input 5
//! names.outputs = { 7 = "lamp" }         # output 7
//! ```
//!
//! A blade's vacuum valve is always guarded against being switched off while the wafer map
//! has a wafer on that blade; `guarded_outputs` guards other outputs (a gripper, a door
//! lock) against any switch while any blade holds one. `OUT <n> <0|1> FORCE` overrides the
//! guard (docs/protocol.md, "Guarded outputs").

use std::collections::BTreeMap;

use serde::Deserialize;

use crate::hand::HandConfig;
use crate::ConfigError;

/// Digital inputs and outputs per word (board 0's), numbered 0 to 31.
pub const SIGNALS: u8 = 32;

/// Longest name of a signal [characters].
pub const MAX_SIGNAL_NAME: usize = 40;

/// Whether a signal is an input or an output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SignalDir {
    /// An output (the controller switches it).
    Out,
    /// An input (the controller reads it).
    In,
}

impl SignalDir {
    /// `in` or `out`, as the protocol writes it.
    pub fn as_str(self) -> &'static str {
        match self {
            SignalDir::In => "in",
            SignalDir::Out => "out",
        }
    }
}

/// One named signal.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Signal {
    /// Input or output.
    pub dir: SignalDir,
    /// Its number, 0 to 31.
    pub n: u8,
    /// An output the controller refuses to switch while a blade holds a wafer (a vacuum
    /// valve, or one `[io] guarded_outputs` lists), unless the request says `FORCE`.
    pub guarded: bool,
    /// What it is, for a person (printable ASCII, may contain blanks).
    pub name: String,
}

/// `[io]`: guarded outputs and signal names.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct IoConfig {
    /// Outputs refused while any blade holds a wafer (bit n: output n), besides the vacuum
    /// valves.
    pub guarded_outputs: u32,
    /// Names of inputs, by number (`[io] names.inputs`).
    pub input_names: BTreeMap<u8, String>,
    /// Names of outputs, by number (`[io] names.outputs`).
    pub output_names: BTreeMap<u8, String>,
}

impl IoConfig {
    /// Whether `[io] guarded_outputs` lists output `n`.
    pub fn lists_guarded(&self, n: u8) -> bool {
        n < SIGNALS && self.guarded_outputs & (1 << n) != 0
    }

    /// Every named signal: each blade's vacuum valve (guarded) and sensor, the mapping
    /// sensor, the E-stop button (`estop_input`), the stations' interlock inputs
    /// (`interlocks`: each input and its name, e.g. `interlock LP1 LP2`, from the stations
    /// file), the outputs `guarded_outputs` lists, and `[io] names`, whose name wins over a
    /// role's (a signal with two roles shows both, joined by a comma). Outputs first, then
    /// inputs, each by number.
    pub fn signals(
        &self,
        hand: &HandConfig,
        estop_input: Option<u8>,
        interlocks: &[(u8, String)],
    ) -> Vec<Signal> {
        let mut named: BTreeMap<(SignalDir, u8), String> = BTreeMap::new();
        let mut add = |dir: SignalDir, n: u8, name: String| {
            named
                .entry((dir, n))
                .and_modify(|old| {
                    old.push_str(", ");
                    old.push_str(&name);
                })
                .or_insert(name);
        };
        let dual = hand.blade_b.is_some();
        for (i, blade) in ["A", "B"].iter().enumerate() {
            let Some(s) = hand.blade(i) else { continue };
            let suffix = if dual {
                format!(" {blade}")
            } else {
                String::new()
            };
            add(
                SignalDir::Out,
                s.vacuum_output,
                format!("vacuum valve{suffix}"),
            );
            add(
                SignalDir::In,
                s.vacuum_input,
                format!("vacuum sensor{suffix}"),
            );
        }
        add(SignalDir::Out, hand.mapping_output, "mapping sensor".into());
        if let Some(n) = estop_input {
            add(SignalDir::In, n, "E-stop button".into());
        }
        for (n, name) in interlocks {
            if *n < SIGNALS {
                add(SignalDir::In, *n, name.clone());
            }
        }
        for n in 0..SIGNALS {
            if self.lists_guarded(n) && !named.contains_key(&(SignalDir::Out, n)) {
                named.insert((SignalDir::Out, n), format!("output {n}"));
            }
        }
        for (dir, names) in [
            (SignalDir::In, &self.input_names),
            (SignalDir::Out, &self.output_names),
        ] {
            for (n, name) in names {
                named.insert((dir, *n), name.clone());
            }
        }
        let valves: Vec<u8> = (0..hand.blades())
            .filter_map(|i| hand.blade(i))
            .map(|s| s.vacuum_output)
            .collect();
        named
            .into_iter()
            .map(|((dir, n), name)| Signal {
                dir,
                n,
                guarded: dir == SignalDir::Out && (valves.contains(&n) || self.lists_guarded(n)),
                name,
            })
            .collect()
    }
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct RawIo {
    guarded_outputs: Vec<i64>,
    names: RawNames,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RawNames {
    inputs: BTreeMap<String, String>,
    outputs: BTreeMap<String, String>,
}

impl RawIo {
    pub(crate) fn into_io(self, file: &str) -> Result<IoConfig, ConfigError> {
        let invalid = |key: String, reason: String| ConfigError::Invalid {
            file: file.to_string(),
            key,
            reason,
        };
        let mut guarded = 0u32;
        for &n in &self.guarded_outputs {
            if !(0..i64::from(SIGNALS)).contains(&n) {
                return Err(invalid(
                    "io.guarded_outputs".into(),
                    format!("output {n} does not exist; outputs are 0 to 31"),
                ));
            }
            if guarded & (1 << n) != 0 {
                return Err(invalid(
                    "io.guarded_outputs".into(),
                    format!("output {n} is listed twice; list each output once"),
                ));
            }
            guarded |= 1 << n;
        }
        let names = |table: BTreeMap<String, String>, what: &str| {
            let mut out = BTreeMap::new();
            for (key, name) in table {
                let n = key
                    .parse::<u8>()
                    .ok()
                    .filter(|n| *n < SIGNALS && key == n.to_string())
                    .ok_or_else(|| {
                        invalid(
                            format!("io.names.{what}s"),
                            format!(
                                "{key:?} is not an {what} number; write the number, 0 to 31, as the key (e.g. {{ 5 = \"door closed\" }})"
                            ),
                        )
                    })?;
                check_name(&name).map_err(|reason| {
                    invalid(
                        format!("io.names.{what}s.{n}"),
                        format!("{name:?} {reason}"),
                    )
                })?;
                out.insert(n, name);
            }
            Ok::<_, ConfigError>(out)
        };
        Ok(IoConfig {
            guarded_outputs: guarded,
            input_names: names(self.names.inputs, "input")?,
            output_names: names(self.names.outputs, "output")?,
        })
    }
}

/// A signal's name must fit one protocol line's end: 1 to [`MAX_SIGNAL_NAME`] printable
/// ASCII characters, not beginning or ending with a blank.
fn check_name(name: &str) -> Result<(), String> {
    if name.is_empty() || name.len() > MAX_SIGNAL_NAME {
        return Err(format!(
            "is not a usable name: give 1 to {MAX_SIGNAL_NAME} characters"
        ));
    }
    if !name.bytes().all(|b| (0x20..0x7f).contains(&b)) {
        return Err(
            "is not a usable name: use printable ASCII only (letters, digits, blanks, punctuation)"
                .into(),
        );
    }
    if name.starts_with(' ') || name.ends_with(' ') {
        return Err("is not a usable name: it begins or ends with a blank".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Config;

    fn parse(io: &str) -> Result<Config, String> {
        assert!(crate::DEFAULT_TOML.contains("\n[io]\n"));
        let text = crate::DEFAULT_TOML.replacen("\n[io]\n", &format!("\n[io]\n{io}\n"), 1);
        Config::parse(&text, "cell.toml").map_err(|e| e.to_string())
    }

    fn line(s: &Signal) -> String {
        format!(
            "{} {} {} {}",
            s.dir.as_str(),
            s.n,
            if s.guarded { "guarded" } else { "-" },
            s.name
        )
    }

    #[test]
    fn the_default_names_the_hands_signals_and_the_estop_button() {
        let c = Config::embedded_default();
        assert_eq!(c.io, IoConfig::default());
        let lines: Vec<String> = c.signals(&[]).iter().map(line).collect();
        assert_eq!(
            lines,
            [
                "out 0 guarded vacuum valve",
                "out 1 - mapping sensor",
                "in 0 - vacuum sensor",
                "in 15 - E-stop button",
            ]
        );
        let dual = Config::embedded_dual_blade();
        let lines: Vec<String> = dual.signals(&[]).iter().map(line).collect();
        assert_eq!(
            lines,
            [
                "out 0 guarded vacuum valve A",
                "out 1 - mapping sensor",
                "out 2 guarded vacuum valve B",
                "in 0 - vacuum sensor A",
                "in 2 - vacuum sensor B",
                "in 15 - E-stop button",
            ]
        );
    }

    #[test]
    fn guarded_outputs_and_names_are_read() {
        let c = parse(
            "guarded_outputs = [7, 3]\nnames.inputs = { 5 = \"door closed\", 0 = \"vacuum OK\" }\nnames.outputs = { 7 = \"lamp\" }",
        )
        .unwrap();
        assert!(c.io.lists_guarded(7) && c.io.lists_guarded(3) && !c.io.lists_guarded(0));
        let lines: Vec<String> = c.signals(&[]).iter().map(line).collect();
        assert_eq!(
            lines,
            [
                "out 0 guarded vacuum valve",
                "out 1 - mapping sensor",
                "out 3 guarded output 3",
                "out 7 guarded lamp",
                "in 0 - vacuum OK",
                "in 5 - door closed",
                "in 15 - E-stop button",
            ]
        );
        // The stations' interlocks, and an [io] name over a role's.
        let interlocks = [
            (14, "interlock LP1 LP2".to_string()),
            (15, "interlock PM1".into()),
        ];
        let lines: Vec<String> =
            c.io.signals(&c.hand, c.estop_input(), &interlocks)
                .iter()
                .map(line)
                .filter(|l| l.starts_with("in 1"))
                .collect();
        assert_eq!(
            lines,
            [
                "in 14 - interlock LP1 LP2",
                "in 15 - E-stop button, interlock PM1"
            ]
        );
        // The table form reads the same.
        let c = parse("[io.names]\ninputs = { 5 = \"door closed\" }").unwrap();
        assert!(c.io.output_names.is_empty());
        assert_eq!(
            c.io.input_names.get(&5).map(String::as_str),
            Some("door closed")
        );
    }

    #[test]
    fn bad_values_are_refused_by_key_with_the_reason() {
        for (io, key, reason) in [
            ("guarded_outputs = [32]", "io.guarded_outputs", "0 to 31"),
            ("guarded_outputs = [-1]", "io.guarded_outputs", "0 to 31"),
            (
                "guarded_outputs = [4, 4]",
                "io.guarded_outputs",
                "listed twice",
            ),
            (
                "names.inputs = { door = \"door closed\" }",
                "io.names.inputs",
                "not an input number",
            ),
            (
                "names.outputs = { 32 = \"lamp\" }",
                "io.names.outputs",
                "not an output number",
            ),
            (
                "names.outputs = { 07 = \"lamp\" }",
                "io.names.outputs",
                "not an output number",
            ),
            (
                "names.outputs = { 7 = \"\" }",
                "io.names.outputs.7",
                "1 to 40",
            ),
            (
                "names.outputs = { 7 = \"a lamp that has a name far too long to read\" }",
                "io.names.outputs.7",
                "1 to 40",
            ),
            (
                "names.outputs = { 7 = \"lamp\\n\" }",
                "io.names.outputs.7",
                "printable ASCII",
            ),
            (
                "names.outputs = { 7 = \"Lampe grün\" }",
                "io.names.outputs.7",
                "printable ASCII",
            ),
            (
                "names.outputs = { 7 = \" lamp\" }",
                "io.names.outputs.7",
                "blank",
            ),
        ] {
            let e = parse(io).unwrap_err();
            assert!(
                e.contains("cell.toml") && e.contains(key) && e.contains(reason),
                "{io}: {e}"
            );
        }
        let e = parse("guarded = [1]").unwrap_err();
        assert!(e.contains("guarded"), "{e}");
        let e = parse("guarded_outputs = 7").unwrap_err();
        assert!(e.contains("guarded_outputs"), "{e}");
    }
}
