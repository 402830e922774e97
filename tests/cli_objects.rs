//! `balloonseg segment` with several objects, as a user runs it: labelled seeds, a stop seed,
//! a region of interest, one file per object or one file with an `object` triangle array.
#![cfg(feature = "cli")]

use std::path::Path;

#[allow(dead_code)]
#[path = "support/cli.rs"]
mod cli;
use cli::balloonseg;

fn text(path: &Path) -> String {
    String::from_utf8_lossy(&std::fs::read(path).unwrap()).into_owned()
}

/// A touching pair and its two seeds ("x,y,z", world mm).
fn touching_pair(dir: &Path) -> (String, String, String) {
    let (volume, json) = cli::phantom(dir, "pair.nii.gz", "touching-pair", &["--variant", "6"]);
    (
        volume.to_str().unwrap().to_string(),
        cli::point(&json, "seed_world"),
        cli::point(&json, "other_seed_world"),
    )
}

#[test]
fn two_labels_give_two_files_or_one_file_with_an_object_array() {
    let dir = tempfile::tempdir().unwrap();
    let (volume, first, second) = touching_pair(dir.path());
    let each = dir.path().join("tube_{label}.vtp");
    let all = dir.path().join("tubes.vtp");
    let stats = dir.path().join("stats.json");
    let second_seed = format!("2:{second}");
    for output in [&each, &all] {
        let out = balloonseg(&[
            "segment",
            &volume,
            "--seed",
            &first,
            "--seed",
            &second_seed,
            "-o",
            output.to_str().unwrap(),
            "--stats",
            stats.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert!(dir.path().join("tube_1.vtp").exists());
    assert!(dir.path().join("tube_2.vtp").exists());
    assert!(!each.exists());
    let written = text(&all);
    assert!(
        written.contains("<CellData Scalars=\"object\">")
            && written.contains("type=\"Int32\" Name=\"object\""),
        "{}",
        &written[..written.len().min(2000)]
    );
    let stats: serde_json::Value = serde_json::from_str(&text(&stats)).unwrap();
    let objects = stats["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 2);
    for (object, label) in objects.iter().zip([1, 2]) {
        assert_eq!(object["label"], label);
        assert_eq!(object["seeds"].as_array().unwrap().len(), 1);
        assert_eq!(object["genus"], 0);
        assert_eq!(object["self_intersecting_pairs"], 0);
        assert!(object["volume_mm3"].as_f64().unwrap() > 0.0);
        assert!(object["window"]["lower"].is_number());
    }
}

#[test]
fn a_stop_seed_is_left_out_and_the_output_is_one_object() {
    let dir = tempfile::tempdir().unwrap();
    let (volume, first, second) = touching_pair(dir.path());
    let mesh = dir.path().join("tube.off");
    let stats = dir.path().join("stats.json");
    let out = balloonseg(&[
        "segment",
        &volume,
        "--seed",
        &first,
        "--stop",
        &second,
        "-o",
        mesh.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stats: serde_json::Value = serde_json::from_str(&text(&stats)).unwrap();
    assert!(stats.get("objects").is_none());
    assert_eq!(stats["genus"], 0);
}

#[test]
fn a_format_without_a_triangle_array_is_refused_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let (volume, first, second) = touching_pair(dir.path());
    let mesh = dir.path().join("tubes.stl");
    let out = balloonseg(&[
        "segment",
        &volume,
        "--seed",
        &first,
        "--seed",
        &format!("2:{second}"),
        "-o",
        mesh.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("STL cannot hold the triangle array \"object\""),
        "{stderr}"
    );
    assert!(
        !stderr.contains("window"),
        "segmented before refusing: {stderr}"
    );
    assert!(!mesh.exists());
}

#[test]
fn bad_labels_and_regions_say_what_to_change() {
    let dir = tempfile::tempdir().unwrap();
    let (volume, first, _) = touching_pair(dir.path());
    let mesh = dir.path().join("tube.vtp");
    let run = |extra: &[&str]| {
        let mut args = vec!["segment", volume.as_str(), "-o", mesh.to_str().unwrap()];
        args.extend_from_slice(extra);
        let out = balloonseg(&args);
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let zero = format!("0:{first}");
    assert!(run(&["--seed", &zero]).contains("labels are 1 to 2147483647"));
    assert!(run(&["--seed", &format!("one:{first}")]).contains("is not a label"));
    let flat = run(&["--seed", &first, "--roi", "0,0,0,10,0,10"]);
    assert!(flat.contains("flat"), "{flat}");
    let short = run(&["--seed", &first, "--roi", "0,0,0,10"]);
    assert!(short.contains("x0,y0,z0,x1,y1,z1"), "{short}");
    assert!(!mesh.exists());
}
