//! Where the real test scans live (`BALLOONSEG_DATA`, by default `../shared/data` beside the
//! project) and what a test does when they are missing: on a developer's machine it says loudly
//! that it skipped and returns; on CI (`CI=true`) it fails, because CI always has them.

use std::path::PathBuf;

/// The data folder, or `None` after printing why the calling test skips. Panics on CI.
pub(crate) fn data_dir() -> Option<PathBuf> {
    let configured = std::env::var_os("BALLOONSEG_DATA").map(PathBuf::from);
    let ci = std::env::var("CI").as_deref() == Ok("true");
    let test = std::thread::current()
        .name()
        .unwrap_or("this test")
        .to_string();
    match locate(configured, ci) {
        Ok(Some(dir)) => Some(dir),
        Ok(None) => {
            eprintln!(
                "\n*** SKIPPED: {test} needs the real scans, not found at {}; set BALLOONSEG_DATA \
                 to the shared data folder ***\n",
                default_dir().display()
            );
            None
        }
        Err(message) => panic!("{test}: {message}"),
    }
}

fn default_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data")
}

/// The folder to use, `Ok(None)` to skip, or the reason to fail.
fn locate(configured: Option<PathBuf>, ci: bool) -> Result<Option<PathBuf>, String> {
    let set = configured.is_some();
    let dir = configured.unwrap_or_else(default_dir);
    if dir.is_dir() {
        Ok(Some(dir))
    } else if ci || set {
        Err(format!(
            "the test data folder {} does not exist{}",
            dir.display(),
            if ci {
                " and CI (CI=true) must run the tests on the real scans"
            } else {
                " although BALLOONSEG_DATA names it"
            }
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
        assert_eq!(locate(Some(here.clone()), true), Ok(Some(here)));
        let nowhere = PathBuf::from("/nonexistent/balloonseg-data");
        assert!(locate(Some(nowhere.clone()), true).is_err());
        assert!(locate(Some(nowhere), false).is_err());
        if !default_dir().is_dir() {
            assert_eq!(locate(None, false), Ok(None));
            assert!(locate(None, true).is_err());
        }
    }
}
