//! Every seed of ../shared/data/README.md's newer scans (`support/real_scan_cases.rs`) through
//! the balloon with the defaults and the seed alone. Each must give a valid closed surface of
//! one component. The seeds whose result meets the README's expectation today ([`MET`]) must
//! go on meeting it; for the others, what they still miss is printed (BENCHMARKS.md has their
//! numbers, issue 14 is open on them).

#![cfg(feature = "io")]

// Shared with examples/score_real_scans.rs, which reads the rest of each outcome.
#[allow(dead_code)]
#[path = "support/real_scan_cases.rs"]
mod real_scan_cases;

use std::io::Write;

use balloonseg::balloon::BalloonParams;
use balloonseg_testkit::data_dir;
use real_scan_cases::CASES;

/// The seeds that meet the README's expectation.
const MET: &[&str] = &[
    "head_carotid",
    "head_basilar",
    "head_sagittal_sinus",
    "heart_aorta",
    "heart_blood_pool",
];

fn check(name: &str) {
    let Some(dir) = data_dir() else {
        return;
    };
    let case = CASES
        .iter()
        .find(|c| c.name == name)
        .expect("a case of real_scan_cases");
    let outcome = real_scan_cases::run(case, &dir, BalloonParams::default()).unwrap();
    assert!(outcome.valid, "{name}: not a valid closed surface");
    assert_eq!(outcome.components, 1, "{name}");
    let misses = outcome.misses(case);
    if MET.contains(&name) {
        assert!(
            misses.is_empty(),
            "{name} no longer meets the README: {misses:?}"
        );
    } else {
        assert!(
            !misses.is_empty(),
            "{name} now meets the README: add it to MET"
        );
        // Straight to stderr: the harness captures `eprintln!` of passing tests.
        let _ = writeln!(
            std::io::stderr(),
            "{name} still misses the README's expectation: {}",
            misses.join("; ")
        );
    }
}

/// One test per case, and the list of them.
macro_rules! cases {
    ($($name:ident),* $(,)?) => {
        $(
            #[test]
            fn $name() {
                check(stringify!($name));
            }
        )*
        const TESTED: &[&str] = &[$(stringify!($name)),*];
    };
}

cases!(
    ircad_aorta,
    ircad_portal_vein,
    ircad_ivc,
    ircad_liver,
    slab_aorta,
    slab_liver,
    slab_portal_vein,
    fistula_main_vein,
    fistula_thin_arm,
    head_carotid,
    head_basilar,
    head_sagittal_sinus,
    head_schwannoma,
    heart_aorta,
    heart_blood_pool,
);

#[test]
fn every_case_has_a_test() {
    for case in CASES {
        assert!(
            TESTED.contains(&case.name),
            "{} has no test in `cases!`",
            case.name
        );
    }
}
