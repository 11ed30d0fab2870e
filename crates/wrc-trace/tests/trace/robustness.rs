//! Reading never panics: random bytes, and valid files cut short, with bits flipped, or with
//! bits flipped and their CRCs made good again (so the decoders behind the CRC check see
//! damaged content too). Every input gives a trace or an error.

use proptest::prelude::*;
use wrc_trace::{TraceFile, MAGIC};

use crate::{bytes_of, sample_trace};

fn read(bytes: &[u8]) -> bool {
    TraceFile::read_from(&mut &bytes[..]).is_ok()
}

/// Recompute every section's CRC of `bytes`, as far as the section lengths make sense.
fn reseal_all(bytes: &mut [u8]) {
    let mut at = 12;
    while at + 12 <= bytes.len() {
        let len = u64::from_le_bytes(bytes[at + 4..at + 12].try_into().unwrap());
        let Some(end) = usize::try_from(len)
            .ok()
            .and_then(|l| (at + 12).checked_add(l))
        else {
            return;
        };
        if end + 4 > bytes.len() {
            return;
        }
        let crc = crc32fast::hash(&bytes[at..end]);
        bytes[end..end + 4].copy_from_slice(&crc.to_le_bytes());
        at = end + 4;
    }
}

fn valid() -> Vec<u8> {
    bytes_of(&sample_trace(25))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        read(&bytes);
        // The same bytes behind a valid header reach the section reader.
        let mut framed = MAGIC.to_vec();
        framed.extend_from_slice(&1u32.to_le_bytes());
        framed.extend_from_slice(&bytes);
        read(&framed);
    }

    #[test]
    fn a_cut_valid_file_is_an_error(cut in 0usize..4096) {
        let bytes = valid();
        let cut = cut % bytes.len();
        prop_assert!(!read(&bytes[..cut]));
    }

    #[test]
    fn flipped_bits_never_panic_and_are_caught_by_the_crc(
        flips in proptest::collection::vec((any::<prop::sample::Index>(), 0u8..8), 1..6),
    ) {
        let original = valid();
        let mut bytes = original.clone();
        for (i, bit) in &flips {
            let i = i.index(bytes.len());
            bytes[i] ^= 1 << bit;
        }
        if bytes != original {
            prop_assert!(!read(&bytes), "a damaged file was accepted");
        }
    }

    #[test]
    fn damaged_content_behind_good_crcs_never_panics(
        flips in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
        cut in proptest::option::of(any::<prop::sample::Index>()),
    ) {
        let mut bytes = valid();
        for (i, value) in &flips {
            let i = 12 + i.index(bytes.len() - 12);
            bytes[i] = *value;
        }
        if let Some(cut) = cut {
            bytes.truncate(cut.index(bytes.len()));
        }
        reseal_all(&mut bytes);
        read(&bytes);
    }
}
