//! Wafer-mapping slot codes: what the mapping sensor reports for one slot of a station
//! (`MAP <station>` replies one code per slot), and their one-character text form
//! (`0` absent, `1` present, `2` double, `X` cross-slotted).

use std::fmt;

/// What the mapping sensor sees in one slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SlotCode {
    /// No wafer (`0`).
    Absent,
    /// One wafer, seated flat (`1`).
    Present,
    /// Two wafers stacked in one slot (`2`): must not be picked.
    Double,
    /// A wafer lying across two slots (`X`): must not be picked.
    Cross,
}

impl SlotCode {
    /// Every code, in the order of their characters.
    pub const ALL: [SlotCode; 4] = [
        SlotCode::Absent,
        SlotCode::Present,
        SlotCode::Double,
        SlotCode::Cross,
    ];

    /// The code's character: `0`, `1`, `2` or `X`.
    pub fn as_char(self) -> char {
        match self {
            SlotCode::Absent => '0',
            SlotCode::Present => '1',
            SlotCode::Double => '2',
            SlotCode::Cross => 'X',
        }
    }

    /// The code of a character (`x` is accepted for `X`).
    pub fn from_char(c: char) -> Option<SlotCode> {
        match c {
            '0' => Some(SlotCode::Absent),
            '1' => Some(SlotCode::Present),
            '2' => Some(SlotCode::Double),
            'X' | 'x' => Some(SlotCode::Cross),
            _ => None,
        }
    }

    /// A word for messages: `absent`, `present`, `double`, `cross-slotted`.
    pub fn name(self) -> &'static str {
        match self {
            SlotCode::Absent => "absent",
            SlotCode::Present => "present",
            SlotCode::Double => "double",
            SlotCode::Cross => "cross-slotted",
        }
    }
}

impl fmt::Display for SlotCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.as_char())
    }
}

/// A string of slot codes that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SlotCodesError {
    /// A character that is no slot code.
    #[error(
        "character {position} of the slot codes is {found:?}; use 0 (absent), 1 (present), \
         2 (double) or X (cross-slotted), one per slot from slot 1 up"
    )]
    BadCode {
        /// 1-based position of the character in the string.
        position: usize,
        /// The character found.
        found: char,
    },
}

/// Parse a string of slot codes, slot 1 first: `0` absent, `1` present, `2` double, `X`
/// cross-slotted. Spaces and `_` are ignored so long strings can be grouped
/// (`"11111 11111 00000"`). The caller checks the count against the station's slots.
pub fn parse_slot_codes(text: &str) -> Result<Vec<SlotCode>, SlotCodesError> {
    let mut codes = Vec::with_capacity(text.len().min(64));
    for (i, c) in text.chars().enumerate() {
        if c == ' ' || c == '_' {
            continue;
        }
        let code = SlotCode::from_char(c).ok_or(SlotCodesError::BadCode {
            position: i + 1,
            found: c,
        })?;
        codes.push(code);
    }
    Ok(codes)
}

/// The codes as one string, slot 1 first, without separators (`MAP` reply form).
pub fn slot_codes_string(codes: &[SlotCode]) -> String {
    codes.iter().map(|c| c.as_char()).collect()
}

/// The codes in groups of five separated by spaces (the stations file form).
pub(crate) fn slot_codes_grouped(codes: &[SlotCode]) -> String {
    let mut s = String::with_capacity(codes.len() + codes.len() / 5);
    for (i, c) in codes.iter().enumerate() {
        if i > 0 && i % 5 == 0 {
            s.push(' ');
        }
        s.push(c.as_char());
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn codes_read_and_write() {
        let codes = parse_slot_codes("012X x").unwrap();
        assert_eq!(
            codes,
            [
                SlotCode::Absent,
                SlotCode::Present,
                SlotCode::Double,
                SlotCode::Cross,
                SlotCode::Cross
            ]
        );
        assert_eq!(slot_codes_string(&codes), "012XX");
        assert_eq!(slot_codes_grouped(&codes[..4]), "012X");
        assert_eq!(slot_codes_grouped(&[SlotCode::Present; 7]), "11111 11");
        assert_eq!(parse_slot_codes("").unwrap(), []);
    }

    #[test]
    fn a_bad_character_is_named_with_its_position() {
        let err = parse_slot_codes("11_3").unwrap_err();
        assert_eq!(
            err,
            SlotCodesError::BadCode {
                position: 4,
                found: '3'
            }
        );
        assert!(err.to_string().contains("character 4") && err.to_string().contains("'3'"));
        assert!(parse_slot_codes("1é").is_err());
    }

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 256,
            rng_seed: proptest::test_runner::RngSeed::Fixed(8),
            failure_persistence: None,
            ..ProptestConfig::default()
        })]
        #[test]
        fn grouped_and_plain_forms_round_trip(idx in proptest::collection::vec(0usize..4, 0..60)) {
            let codes: Vec<SlotCode> = idx.iter().map(|&i| SlotCode::ALL[i]).collect();
            prop_assert_eq!(parse_slot_codes(&slot_codes_string(&codes)).unwrap(), codes.clone());
            prop_assert_eq!(parse_slot_codes(&slot_codes_grouped(&codes)).unwrap(), codes);
        }

        #[test]
        fn any_string_parses_or_errs_without_panicking(s in "\\PC{0,40}") {
            let _ = parse_slot_codes(&s);
        }
    }
}
