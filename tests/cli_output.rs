//! What the commands print, as a user reads it: the JSON of `phantom` and `check` piped to a
//! reader that stops early ends the command quietly; `segment` warns when the balloon ran out
//! of steps; `info` shows a volume's geometry.
#![cfg(feature = "cli")]

use std::process::{Command, Stdio};

#[allow(dead_code)]
#[path = "support/cli.rs"]
mod cli;

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

#[test]
fn a_balloon_stopped_by_max_iterations_warns_and_says_so_in_its_stats() {
    // The 1,000-seed sweep's slowest runs (ircad17's liver) leaked into the soft tissue until
    // the step budget ran out, and ended with a valid mesh and no word of it.
    let dir = tempfile::tempdir().unwrap();
    let (volume, json) = cli::phantom(dir.path(), "sphere.mha", "sphere", &[]);
    let seed = cli::point(&json, "seed_world");
    let (mesh, stats) = (dir.path().join("s.vtp"), dir.path().join("s.json"));
    let segment = |max_iterations: &str| {
        let out = cli::succeed(&[
            "segment",
            volume.to_str().unwrap(),
            "--seed",
            &seed,
            "--max-iterations",
            max_iterations,
            "-o",
            mesh.to_str().unwrap(),
            "--stats",
            stats.to_str().unwrap(),
        ]);
        let stats: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
        (cli::stderr(&out), stats)
    };
    let (stderr, stats) = segment("10");
    assert!(
        stderr.contains("still growing after max_iterations (10)"),
        "{stderr}"
    );
    assert_eq!(stats["out_of_steps"], true);
    let (stderr, stats) = segment("4000");
    assert!(!stderr.contains("warning"), "{stderr}");
    assert_eq!(stats["out_of_steps"], false);
}

#[test]
fn info_prints_the_geometry_the_balloon_will_use() {
    let dir = tempfile::tempdir().unwrap();
    let (volume, made) = cli::phantom(
        dir.path(),
        "y.nii.gz",
        "y-vessel",
        &["--oblique", "--spacing", "0.8,1.1,1.4"],
    );
    let info = cli::succeed(&["info", volume.to_str().unwrap()]);
    let read: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(read["dims"], made["dims"]);
    let spacing: Vec<f64> = read["spacing"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    for (got, want) in spacing.iter().zip([0.8, 1.1, 1.4]) {
        assert!((got - want).abs() < 1e-6, "{spacing:?}");
    }
    assert_ne!(read["direction"][1], 0.0, "oblique: {read}");
    assert!(read["read_seconds"].as_f64().unwrap() >= 0.0);
    let missing = cli::balloonseg(&["info", "nothing.mha"]);
    assert!(!missing.status.success());
    assert!(cli::stderr(&missing).contains("nothing.mha"));
}
