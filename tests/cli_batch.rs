//! `balloonseg batch` as a user runs a cohort: each mesh the one `segment` writes for its row,
//! failed cases recorded without stopping the others, a rerun that runs only what is not
//! finished, and manifests that cannot run refused before any case does.
#![cfg(feature = "cli")]

use std::path::{Path, PathBuf};
use std::process::Command;

#[allow(dead_code)]
#[path = "support/cli.rs"]
mod cli;
use cli::{balloonseg, stderr};

/// A phantom volume in `dir` and its seed, "x,y,z" in world mm.
fn phantom(dir: &Path, name: &str) -> (PathBuf, String) {
    let (volume, json) = cli::phantom(dir, &format!("{name}.mha"), name, &[]);
    (volume, cli::point(&json, "seed_world"))
}

fn results(dir: &Path) -> Vec<serde_json::Value> {
    let text = std::fs::read(dir.join("results.json")).unwrap();
    let json: serde_json::Value = serde_json::from_slice(&text).unwrap();
    json["cases"].as_array().unwrap().clone()
}

/// A cohort of a sphere, a torus (with a parameter) and a seed outside its volume.
fn cohort(dir: &Path) -> (PathBuf, String, String) {
    let (_, sphere) = phantom(dir, "sphere");
    let (_, torus) = phantom(dir, "torus");
    let manifest = dir.join("cohort.csv");
    std::fs::write(
        &manifest,
        format!(
            "id,image,seeds,edge-length\n\
             ball,sphere.mha,\"{sphere}\",\n\
             ring,torus.mha,\"{torus}\",1.5\n\
             # a seed far outside the volume\n\
             lost,sphere.mha,\"900,900,900\",\n"
        ),
    )
    .unwrap();
    (manifest, sphere, torus)
}

#[test]
fn a_cohort_gives_segments_meshes_and_records_the_failed_case() {
    let dir = tempfile::tempdir().unwrap();
    let (manifest, sphere, torus) = cohort(dir.path());
    let out_dir = dir.path().join("out");
    let run = |jobs: &str, out_dir: &Path| {
        balloonseg(&[
            "batch",
            manifest.to_str().unwrap(),
            "-o",
            out_dir.to_str().unwrap(),
            "--jobs",
            jobs,
        ])
    };
    let out = run("2", &out_dir);
    assert!(!out.status.success(), "a failed case fails the batch");
    let text = stderr(&out);
    assert!(
        text.contains("lost: failed:") && text.contains("outside"),
        "{text}"
    );
    let rows = results(&out_dir);
    let status: Vec<&str> = rows.iter().map(|r| r["status"].as_str().unwrap()).collect();
    assert_eq!(status, ["ok", "ok", "failed"]);
    assert_eq!(rows[1]["genus"], serde_json::json!([1]));
    assert!(rows[2]["error"].as_str().unwrap().contains("outside"));
    let csv = std::fs::read_to_string(out_dir.join("results.csv")).unwrap();
    assert!(csv.starts_with("id,status,"), "{csv}");
    assert_eq!(csv.lines().count(), 4, "{csv}");

    // Each mesh byte for byte the one `segment` writes for the same row.
    for (id, volume, seed, extra) in [
        ("ball", "sphere.mha", &sphere, &[][..]),
        ("ring", "torus.mha", &torus, &["--edge-length", "1.5"][..]),
    ] {
        let alone = dir.path().join(format!("{id}_alone.vtp"));
        let mut args = vec![
            "segment",
            volume,
            "--seed",
            seed,
            "-o",
            alone.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let out = Command::new(env!("CARGO_BIN_EXE_balloonseg"))
            .current_dir(dir.path())
            .args(&args)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        assert_eq!(
            std::fs::read(&alone).unwrap(),
            std::fs::read(out_dir.join(format!("{id}.vtp"))).unwrap(),
            "{id}"
        );
    }

    // One job at a time gives the same meshes.
    let serial = dir.path().join("serial");
    run("1", &serial);
    for id in ["ball", "ring"] {
        assert_eq!(
            std::fs::read(serial.join(format!("{id}.vtp"))).unwrap(),
            std::fs::read(out_dir.join(format!("{id}.vtp"))).unwrap(),
        );
    }
}

#[test]
fn a_rerun_runs_only_the_failed_and_changed_cases() {
    let dir = tempfile::tempdir().unwrap();
    let (manifest, _, _) = cohort(dir.path());
    let out_dir = dir.path().join("out");
    let run = || {
        balloonseg(&[
            "batch",
            manifest.to_str().unwrap(),
            "-o",
            out_dir.to_str().unwrap(),
        ])
    };
    run();
    let first = results(&out_dir);
    let out = run();
    assert!(
        stderr(&out).contains("2 of 3 cases already finished with the same row"),
        "{}",
        stderr(&out)
    );
    let second = results(&out_dir);
    assert_eq!(first[0], second[0], "a finished case is kept as it was");
    assert_eq!(first[1], second[1]);

    // A changed parameter runs that case again; a fixed seed runs the failed one.
    let text = std::fs::read_to_string(&manifest).unwrap();
    let text = text
        .replace(",1.5\n", ",1.25\n")
        .replace("\"900,900,900\"", "\"901,900,900\"");
    std::fs::write(&manifest, text).unwrap();
    let out = run();
    assert!(
        stderr(&out).contains("1 of 3 cases already finished"),
        "{}",
        stderr(&out)
    );
    let third = results(&out_dir);
    assert_eq!(first[0], third[0]);
    assert_ne!(first[1]["command"], third[1]["command"]);
    assert_eq!(third[1]["status"], "ok");
    assert_eq!(third[2]["status"], "failed");
}

#[test]
fn a_manifest_that_cannot_run_is_refused_before_any_case_runs() {
    let dir = tempfile::tempdir().unwrap();
    let (_, sphere) = phantom(dir.path(), "sphere");
    let cases = [
        (
            "id,image,seeds,tolerence\na,sphere.mha,\"1,2,3\",5\n",
            "unknown column 'tolerence'",
        ),
        ("id,image\na,sphere.mha\n", "no 'seeds' column"),
        (
            &format!("id,image,seeds\na,sphere.mha,\"{sphere}\"\na,sphere.mha,\"{sphere}\"\n"),
            "line 3: the id 'a' is used twice",
        ),
        (
            "id,image,seeds\na,nothing.mha,\"1,2,3\"\n",
            "line 2: the image",
        ),
        (
            &format!("id,image,seeds,tolerance\na,sphere.mha,\"{sphere}\",-4\n"),
            "line 2:",
        ),
        ("id,image,seeds\na,sphere.mha,\"1,2\"\n", "line 2:"),
        ("id,image,seeds\n../a,sphere.mha,\"1,2,3\"\n", "names files"),
        ("id,image,seeds\n", "no cases"),
    ];
    let manifest = dir.path().join("good.csv");
    std::fs::write(
        &manifest,
        format!("id,image,seeds\na,sphere.mha,\"{sphere}\"\n"),
    )
    .unwrap();
    let out = balloonseg(&[
        "batch",
        manifest.to_str().unwrap(),
        "-o",
        dir.path().join("out").to_str().unwrap(),
        "--format",
        "xyz",
    ]);
    assert!(
        stderr(&out).contains("--format xyz is not a mesh format"),
        "{}",
        stderr(&out)
    );
    assert!(!dir.path().join("out").exists());
    // A legacy .vtk volume beside its case's .vtk mesh: the mesh would replace the image. (The
    // check comes before any image is read, so the bytes need not be a .vtk volume's.)
    let vtk = dir.path().join("scan.vtk");
    std::fs::copy(dir.path().join("sphere.mha"), &vtk).unwrap();
    let before = std::fs::read(&vtk).unwrap();
    let manifest = dir.path().join("clash.csv");
    std::fs::write(
        &manifest,
        format!("id,image,seeds\nscan,scan.vtk,\"{sphere}\"\n"),
    )
    .unwrap();
    let out = balloonseg(&[
        "batch",
        manifest.to_str().unwrap(),
        "-o",
        dir.path().to_str().unwrap(),
        "--format",
        "vtk",
    ]);
    assert!(
        stderr(&out).contains("over its own image"),
        "{}",
        stderr(&out)
    );
    assert_eq!(std::fs::read(&vtk).unwrap(), before);
    for (k, (text, expected)) in cases.iter().enumerate() {
        let manifest = dir.path().join(format!("m{k}.csv"));
        std::fs::write(&manifest, text).unwrap();
        let out_dir = dir.path().join(format!("out{k}"));
        let out = balloonseg(&[
            "batch",
            manifest.to_str().unwrap(),
            "-o",
            out_dir.to_str().unwrap(),
        ]);
        let message = stderr(&out);
        assert!(!out.status.success(), "{text}");
        assert!(message.contains(expected), "{text}: {message}");
        assert!(!out_dir.join("results.json").exists(), "{text}");
    }
}
