//! Guarded outputs: `OUT` of a blade's vacuum valve to off while the wafer map has a wafer on
//! that blade (certain, uncertain, or in a transfer under way), or of an output the
//! configuration guards (`[io] guarded_outputs`) while any blade holds one, is refused with
//! 141 unless the request says `FORCE`; a forced switch is done, and the cell service logs
//! it and tells everyone (`EVT RECOVERY forced OUT …`). The map's facts come from
//! [`crate::shared::Shared::blade_wafers`], which the cell service publishes: this task never
//! looks into the map.
//!
//! Real-time promise: as the rest of the task — fixed-size texts, no allocation, no
//! blocking.

use std::fmt::Write as _;
use std::sync::atomic::Ordering;

use wrc_board::MotionBoard;
use wrc_cell::{Blade, MAX_BLADES};
use wrc_config::HandConfig;
use wrc_protocol::{Code, ReplyTo};
use wrc_rt::FixedText;

use super::{deliver, CommandInterpreter};
use crate::messages::cell_job::CellEvent;
use crate::messages::SourceId;
use crate::shared::{BLADE_PENDING, BLADE_UNCERTAIN};

/// Longest output name kept for the refusal's text [bytes].
const NAME_BYTES: usize = 48;

/// The outputs the configuration guards and the names of all outputs.
#[derive(Clone, Copy)]
pub(super) struct OutputGuard {
    /// Bit n: output n is guarded while any blade holds a wafer (`[io] guarded_outputs`).
    guarded: u32,
    /// Each output's name (`vacuum valve`, `[io] names.outputs`…); empty when it has none.
    names: [FixedText<NAME_BYTES>; 32],
}

impl Default for OutputGuard {
    fn default() -> Self {
        OutputGuard {
            guarded: 0,
            names: [FixedText::new(); 32],
        }
    }
}

/// The blade and wafer that make an output guarded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Held {
    /// The blade.
    pub(super) blade: Blade,
    /// Its wafer's number.
    pub(super) wafer: u32,
    /// The map is not sure of it.
    pub(super) uncertain: bool,
    /// A transfer under way takes or gives it.
    pub(super) pending: bool,
    /// The output is that blade's vacuum valve (else one the configuration guards).
    pub(super) valve: bool,
}

/// Why `OUT n on` would need `FORCE` now (`None`: it may be switched), from the blades'
/// wafers as [`crate::shared::Shared::blade_wafers`] publishes them.
pub(super) fn guard(
    hand: &HandConfig,
    guarded: u32,
    blades: [u64; MAX_BLADES],
    n: u8,
    on: bool,
) -> Option<Held> {
    let held = |b: Blade, valve: bool| {
        let w = blades[b.index()];
        (w != 0).then_some(Held {
            blade: b,
            wafer: w as u32,
            uncertain: w & BLADE_UNCERTAIN != 0,
            pending: w & BLADE_PENDING != 0,
            valve,
        })
    };
    let valve_of = Blade::ALL
        .into_iter()
        .find(|b| hand.blade(b.index()).is_some_and(|s| s.vacuum_output == n));
    if let (Some(b), false) = (valve_of, on) {
        if let Some(h) = held(b, true) {
            return Some(h);
        }
    }
    if n < 32 && guarded & (1 << n) != 0 {
        return Blade::ALL.into_iter().find_map(|b| held(b, false));
    }
    None
}

impl<B: MotionBoard> CommandInterpreter<B> {
    /// Take the outputs' names and the outputs `[io] guarded_outputs` lists (bit n: output
    /// n) from the configuration (at start-up, not in a cycle).
    pub fn name_outputs(&mut self, signals: &[wrc_config::Signal], guarded: u32) {
        let mut g = OutputGuard {
            guarded,
            ..OutputGuard::default()
        };
        for s in signals {
            if s.dir == wrc_config::SignalDir::Out && s.n < 32 {
                let _ = g.names[usize::from(s.n)].write_str(&s.name);
            }
        }
        self.output_guard = g;
    }

    /// `OUT n 0|1 [FORCE]`.
    pub(super) fn out_request(
        &mut self,
        from: SourceId,
        to: ReplyTo,
        n: u8,
        on: bool,
        force: bool,
    ) {
        let blades = std::array::from_fn(|i| self.shared.blade_wafers[i].load(Ordering::Acquire));
        let held = guard(&self.hand, self.output_guard.guarded, blades, n, on);
        if let (Some(h), false) = (held, force) {
            let mut text = FixedText::<320>::new();
            let name = self.output_guard.names[usize::from(n & 31)];
            let _ = write!(text, "output {n}");
            if !name.as_str().is_empty() && !name.as_str().starts_with("output ") {
                let _ = write!(text, " ({name})");
            }
            let holds = if h.pending {
                "is transferring"
            } else if h.uncertain {
                "may hold"
            } else {
                "holds"
            };
            let uncertain = if h.uncertain { "?" } else { "" };
            let _ = if h.valve {
                write!(
                    text,
                    " is blade {b}'s vacuum valve and blade {b} {holds} W{w}{uncertain}: switched off, the wafer drops; send OUT {n} 0 FORCE if you mean it",
                    b = h.blade,
                    w = h.wafer
                )
            } else {
                write!(
                    text,
                    " is guarded while a blade holds a wafer, and blade {b} {holds} W{w}{uncertain}; send OUT {n} {v} FORCE if you mean it",
                    b = h.blade,
                    w = h.wafer,
                    v = u8::from(on)
                )
            };
            return self.nak(from, to, Code::OutputGuarded, text.as_str());
        }
        self.shared.set_output(n, on);
        let line = self.buf.ack(to, "");
        deliver(&self.io.out, from, line);
        if let Some(h) = held {
            // Logged and told by the cell service (it may print; this task may not).
            let _ = self.io.store.cell_events.try_send(CellEvent::Forced {
                n,
                on,
                from,
                blade: h.blade,
                wafer: h.wafer,
                valve: h.valve,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dual() -> HandConfig {
        wrc_config::Config::embedded_dual_blade().hand
    }

    #[test]
    fn a_valve_is_guarded_off_while_its_blade_holds_a_wafer() {
        let hand = HandConfig::default();
        let w4 = [4, 0];
        // Off: refused while blade A holds W4; on, or another output: free.
        let held = guard(&hand, 0, w4, 0, false).unwrap();
        assert_eq!((held.blade, held.wafer, held.valve), (Blade::A, 4, true));
        assert_eq!(guard(&hand, 0, w4, 0, true), None);
        assert_eq!(guard(&hand, 0, w4, 5, false), None);
        assert_eq!(guard(&hand, 0, [0, 0], 0, false), None);
        // Uncertain or in a transfer: still guarded, and said so.
        let h = guard(&hand, 0, [4 | BLADE_UNCERTAIN, 0], 0, false).unwrap();
        assert!(h.uncertain && !h.pending);
        let h = guard(&hand, 0, [4 | BLADE_PENDING, 0], 0, false).unwrap();
        assert!(h.pending);
        // Dual blade: each valve by its own blade.
        let hand = dual();
        assert_eq!(guard(&hand, 0, [0, 9], 0, false), None);
        let h = guard(&hand, 0, [0, 9], 2, false).unwrap();
        assert_eq!((h.blade, h.wafer, h.valve), (Blade::B, 9, true));
    }

    #[test]
    fn a_listed_output_is_guarded_both_ways_while_any_blade_holds_a_wafer() {
        let hand = dual();
        let guarded = 1 << 7;
        for on in [false, true] {
            let h = guard(&hand, guarded, [0, 9], 7, on).unwrap();
            assert_eq!((h.blade, h.wafer, h.valve), (Blade::B, 9, false));
            assert_eq!(guard(&hand, guarded, [0, 0], 7, on), None);
        }
    }
}
