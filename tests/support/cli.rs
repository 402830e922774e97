//! The command line as the CLI tests run it: the binary with arguments, its messages, and a
//! phantom written to a folder with its seed. Included by each `tests/cli_*.rs` with
//! `#[path = "support/cli.rs"] mod cli;`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// `balloonseg ARGS`, run to the end.
pub fn balloonseg(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_balloonseg"))
        .args(args)
        .output()
        .expect("the balloonseg binary runs")
}

/// `balloonseg ARGS`, which must succeed.
pub fn succeed(args: &[&str]) -> Output {
    let out = balloonseg(args);
    assert!(
        out.status.success(),
        "balloonseg {args:?}: {}",
        stderr(&out)
    );
    out
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A point of the phantom's JSON as "x,y,z".
pub fn point(json: &serde_json::Value, key: &str) -> String {
    json[key]
        .as_array()
        .unwrap_or_else(|| panic!("no {key} in {json}"))
        .iter()
        .map(|v| v.as_f64().unwrap().to_string())
        .collect::<Vec<_>>()
        .join(",")
}

/// `balloonseg phantom NAME OPTIONS -o DIR/FILE`: the volume's path and the phantom's JSON.
pub fn phantom(
    dir: &Path,
    file: &str,
    name: &str,
    options: &[&str],
) -> (PathBuf, serde_json::Value) {
    let volume = dir.join(file);
    let mut args = vec!["phantom", name];
    args.extend_from_slice(options);
    args.extend(["-o", volume.to_str().unwrap()]);
    let out = succeed(&args);
    (volume, serde_json::from_slice(&out.stdout).unwrap())
}
