//! Where the real test scans live (`BALLOONSEG_DATA`, by default `../shared/data` from the
//! working directory, which is the project's root for `cargo test` and `cargo bench`) and what a
//! test does when they are missing: on a developer's machine it says loudly that it skipped and
//! returns; on CI (`CI=true`) it fails, because CI always has them.
//!
//! A crate of its own, balloonseg's dev-dependency, so that its unit tests, integration tests,
//! benchmarks and examples share it while the library users link never carries it.

use std::io::Write;
use std::path::PathBuf;

/// The data folder, or `None` after printing why the calling test skips. Panics on CI.
pub fn data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("BALLOONSEG_DATA")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("../shared/data"));
    let ci = std::env::var("CI").as_deref() == Ok("true");
    let test = std::thread::current()
        .name()
        .unwrap_or("this test")
        .to_string();
    match locate(dir.clone(), ci) {
        Ok(Some(dir)) => Some(dir),
        Ok(None) => {
            // Straight to stderr: the test harness captures `eprintln!` of passing tests.
            let _ = writeln!(
                std::io::stderr(),
                "\n*** SKIPPED: {test} needs the real scans, which are not at {}; set \
                 BALLOONSEG_DATA to the shared data folder to run it ***\n",
                dir.display()
            );
            None
        }
        Err(message) => panic!("{test}: {message}"),
    }
}

/// `dir` when it exists; otherwise `Ok(None)` to skip, or on CI the reason to fail.
fn locate(dir: PathBuf, ci: bool) -> Result<Option<PathBuf>, String> {
    if dir.is_dir() {
        Ok(Some(dir))
    } else if ci {
        Err(format!(
            "the test data folder {} does not exist, and CI (CI=true) must run the tests on the \
             real scans; set BALLOONSEG_DATA",
            dir.display()
        ))
    } else {
        Ok(None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_data_skips_locally_and_fails_on_ci() {
        let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
        assert_eq!(locate(here.clone(), true), Ok(Some(here.clone())));
        assert_eq!(locate(here.clone(), false), Ok(Some(here)));
        let nowhere = PathBuf::from("/nonexistent/balloonseg-data");
        assert_eq!(locate(nowhere.clone(), false), Ok(None));
        let e = locate(nowhere, true).unwrap_err();
        assert!(
            e.contains("/nonexistent/balloonseg-data") && e.contains("CI"),
            "{e}"
        );
    }
}
