//! Test helpers shared by the format modules: corrupted copies of a file and the real data set.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

/// Runs `parse` on every truncation of `bytes` and on `flips` copies with one to three bytes
/// replaced at deterministic pseudo-random places, and fails if any of them panics. Returns how
/// many of the corrupted inputs were rejected, so a test can check the parser is not blind.
pub(crate) fn assert_never_panics<T>(
    bytes: &[u8],
    flips: usize,
    parse: impl Fn(&[u8]) -> crate::Result<T>,
) -> usize {
    let mut rejected = 0;
    let mut run =
        |case: &[u8], what: &dyn Fn() -> String| match catch_unwind(AssertUnwindSafe(|| {
            parse(case)
        })) {
            Ok(Ok(_)) => {}
            Ok(Err(_)) => rejected += 1,
            Err(_) => panic!("the parser panicked on {}", what()),
        };
    for len in 0..bytes.len() {
        run(&bytes[..len], &|| format!("the first {len} bytes"));
    }
    // SplitMix64: a fixed sequence, so a failure reproduces.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    for case in 0..flips {
        let mut copy = bytes.to_vec();
        let mut changed = Vec::new();
        for _ in 0..1 + next() % 3 {
            let at = (next() % bytes.len() as u64) as usize;
            copy[at] = next() as u8;
            changed.push(at);
        }
        run(&copy, &|| format!("flip case {case} (bytes {changed:?})"));
    }
    rejected
}

/// A file of the shared real data set, or `None` when the tests skip for lack of it (see
/// `balloonseg_testkit`, which also makes the data mandatory on CI).
pub(crate) fn shared_data(relative: &str) -> Option<PathBuf> {
    Some(balloonseg_testkit::data_dir()?.join(relative))
}
