//! The commands that print JSON (`phantom`, `check`) as a user pipes them: a reader that stops
//! early ends the command quietly.
#![cfg(feature = "cli")]

use std::process::{Command, Stdio};

#[test]
fn a_reader_that_stops_early_ends_the_command_quietly_not_with_a_panic() {
    // `balloonseg phantom … | head -c 0`: println! panicked on the broken pipe, with a
    // backtrace on standard error.
    let dir = std::env::temp_dir().join(format!("balloonseg-cli-output-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let volume = dir.join("tube.mha");
    let mut child = Command::new(env!("CARGO_BIN_EXE_balloonseg"))
        .args(["phantom", "thin-vessels", "--variant", "3", "-o"])
        .arg(&volume)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the balloonseg binary runs");
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}: {stderr}", out.status);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(volume.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}
