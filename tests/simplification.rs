//! Error-bounded simplification (issue 17) on the meshes users bring: isosurfaces of analytic
//! fields, the balloon's results on phantoms and on the real scans (`BALLOONSEG_DATA`), through
//! the library and the `simplify` / `segment --simplify` commands. Every result is checked for
//! every guarantee: the two-sided Hausdorff bound (exact point-to-triangle distances on a
//! lattice of samples), closed, manifold, same orientation, genus and components, no
//! self-intersection.

#![cfg(all(feature = "io", feature = "cli"))]

use std::path::{Path, PathBuf};
use std::process::Command;

use balloonseg::balloon::{
    segment_objects, simplify_objects, BalloonParams, ObjectSeeds, ObjectsRequest, Segmenter,
    VertexState,
};
use balloonseg::evaluation::hausdorff_distance;
use balloonseg::marching_cubes::marching_cubes;
use balloonseg::phantom::{self, Family, PhantomOptions, Shape};
use balloonseg::simplification::{simplify, Simplified};
use balloonseg::{io, mesh_checks, self_intersection::self_intersections, TriMesh};
use balloonseg_testkit::data_dir;

/// Every guarantee `simplify` gives, measured on `out`; returns the kept share of triangles.
fn assert_guarantees(input: &TriMesh, out: &TriMesh, max_error: f64) -> f64 {
    let (before, after) = (mesh_checks::check(input), mesh_checks::check(out));
    assert!(
        after.closed() && after.manifold() && after.consistently_oriented(),
        "{after:?}"
    );
    assert_eq!(after.genus(), before.genus());
    assert_eq!(after.components, before.components);
    assert_eq!(after.inward_components, before.inward_components);
    assert!(self_intersections(out).unwrap().is_empty());
    let (forward, backward) = hausdorff_distance(input, out, 4).unwrap();
    assert!(
        forward <= max_error && backward <= max_error,
        "Hausdorff {forward:.4} / {backward:.4} mm over the bound {max_error} mm"
    );
    out.triangles().len() as f64 / input.triangles().len() as f64
}

fn simplified(input: &TriMesh, max_error: f64) -> Simplified {
    let out = simplify(input, max_error).unwrap();
    assert_guarantees(input, &out.mesh, max_error);
    out
}

#[test]
fn isosurfaces_of_analytic_fields_are_simplified_within_the_bound() {
    for (shape, genus) in [("sphere", 0), ("torus", 1), ("double-torus", 2)] {
        let options = PhantomOptions {
            blur_mm: 1.5,
            ..PhantomOptions::default()
        };
        let phantom = phantom::render(Shape::from_name(shape).unwrap(), &options).unwrap();
        let mesh = marching_cubes(&phantom.image.view(), 500.0).unwrap();
        assert_eq!(mesh_checks::check(&mesh).genus(), Some(genus), "{shape}");
        for max_error in [0.1, 0.25] {
            let out = simplified(&mesh, max_error);
            let kept = out.mesh.triangles().len() as f64 / mesh.triangles().len() as f64;
            assert!(kept < 0.5, "{shape} at {max_error} mm kept {kept:.3}");
        }
    }
}

/// The balloon's result on a real scan, simplified at 0.1 and 0.25 mm: the shares kept are
/// pinned a little above what was measured (the aorta: 0.287 and 0.0996 of 41,482 triangles,
/// the second at the 10% the simplification promises there; the carotid: 0.512 and 0.210 of
/// 1,726; 2026-12-07, with refined positions, flips and vertex moves), to catch regressions.
fn real_scan(path: &str, seed: [usize; 3], shares: [f64; 2]) {
    let Some(dir) = data_dir() else {
        return;
    };
    let image = io::read_image(&dir.join(path)).unwrap();
    let seed = image
        .geometry()
        .index_to_world(seed.map(|i| i as f64).into());
    let (mesh, _) = Segmenter::new(image.view(), BalloonParams::default(), seed)
        .unwrap()
        .segment()
        .unwrap();
    for (max_error, share) in [0.1, 0.25].into_iter().zip(shares) {
        let out = simplified(&mesh, max_error);
        let kept = out.mesh.triangles().len() as f64 / mesh.triangles().len() as f64;
        eprintln!(
            "{path}: {max_error} mm keeps {kept:.3} of {}",
            mesh.triangles().len()
        );
        assert!(kept <= share, "{path} at {max_error} mm kept {kept:.3}");
    }
}

#[test]
fn the_aortas_balloon_is_simplified_within_the_bound() {
    real_scan("vmtk-aorta/aorta.mha", [74, 150, 15], [0.29, 0.1]);
}

#[test]
fn the_carotids_balloon_is_simplified_within_the_bound() {
    real_scan("vtk-carotid/carotid.mha", [17, 23, 8], [0.53, 0.215]);
}

fn scratch(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("balloonseg-simplify-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn balloonseg(args: &[&str], paths: &[&Path]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_balloonseg"))
        .args(args)
        .args(paths)
        .output()
        .expect("the balloonseg binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!stderr.contains("panicked"), "{stderr}");
    (out.status.success(), stderr)
}

#[test]
fn the_simplify_command_writes_a_valid_mesh_and_nothing_for_bad_input() {
    let dir = scratch("command");
    let (volume, mesh, out) = (dir.join("v.mha"), dir.join("m.vtp"), dir.join("s.ply"));
    let args = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert!(balloonseg(&["phantom", "torus", "--blur", "1.5", "-o"], &[&volume]).0);
    assert!(balloonseg(&["isosurface", "--level", "500", "-o"], &[&mesh, &volume]).0);
    let (ok, stderr) = balloonseg(&["simplify", "--max-error", "0.2", "-o"], &[&out, &mesh]);
    assert!(ok, "{stderr}");
    let input = io::read_mesh(&mesh).unwrap();
    // Marching cubes faces towards higher values, into the bright torus: inward, and so it
    // stays (`check --strict` would want outward normals).
    assert_guarantees(&input, &io::read_mesh(&out).unwrap(), 0.2);

    // An open mesh (a triangle taken away), and bounds that are not a positive distance.
    let (points, mut triangles) = input.into_parts();
    triangles.pop();
    let open = dir.join("open.vtp");
    io::write_mesh(&open, &TriMesh::new(points, triangles).unwrap(), &[]).unwrap();
    let refused = dir.join("refused.vtp");
    for (flags, input, expected) in [
        (
            args(&["simplify", "--max-error", "0.2", "-o"]),
            &open,
            "not closed",
        ),
        (
            args(&["simplify", "--max-error", "0", "-o"]),
            &mesh,
            "positive distance",
        ),
        (
            args(&["simplify", "--max-error", "-1", "-o"]),
            &mesh,
            "positive distance",
        ),
        (
            args(&["simplify", "--max-error", "NaN", "-o"]),
            &mesh,
            "positive distance",
        ),
    ] {
        let flags: Vec<&str> = flags.iter().map(String::as_str).collect();
        let (ok, stderr) = balloonseg(&flags, &[&refused, input]);
        assert!(!ok && stderr.contains(expected), "{flags:?}: {stderr}");
        assert!(!refused.exists(), "{flags:?} wrote a file");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn segment_simplifies_its_result_and_carries_the_vertex_states_over() {
    let variant = Family::ThinVessels.variant(1).unwrap();
    let request = ObjectsRequest {
        objects: vec![ObjectSeeds {
            label: 1,
            seeds: vec![variant.seed()],
        }],
        ..ObjectsRequest::default()
    };
    let mut objects = segment_objects(
        variant.image.view(),
        BalloonParams::default(),
        &request,
        None,
    )
    .unwrap();
    let full = objects[0].clone();
    simplify_objects(&mut objects, 0.1, |_| true).unwrap();
    let out = &objects[0];
    assert!(assert_guarantees(&full.mesh, &out.mesh, 0.1) < 0.8);
    assert_eq!(out.states.len(), out.mesh.points().len());
    // A vertex merged from several takes the least settled state: every state left was one of
    // the input's, and none that was moving everywhere became frozen.
    let moving_before = full
        .states
        .iter()
        .filter(|&&s| s == VertexState::Moving)
        .count();
    let moving_after = out
        .states
        .iter()
        .filter(|&&s| s == VertexState::Moving)
        .count();
    assert!(moving_after <= moving_before && (moving_before == 0) == (moving_after == 0));

    // The command: a valid mesh, and nothing written for a negative bound (0 is no
    // simplification, the parameter's default).
    let dir = scratch("segment");
    let (volume, reduced) = (dir.join("v.mha"), dir.join("r.vtp"));
    assert!(balloonseg(&["phantom", "sphere", "--blur", "1.5", "-o"], &[&volume]).0);
    let segment = |bound: &str, out: &Path| {
        let args = ["segment", "--seed", "0,0,0", "--simplify", bound, "-o"];
        balloonseg(&args, &[out, &volume])
    };
    let (ok, stderr) = segment("0.1", &reduced);
    assert!(ok, "{stderr}");
    assert!(balloonseg(&["check", "--strict"], &[&reduced]).0);
    let never = dir.join("never.vtp");
    let (ok, stderr) = segment("-0.1", &never);
    assert!(!ok && stderr.contains("--simplify"), "{stderr}");
    assert!(!never.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_hausdorff_command_measures_both_ways() {
    let dir = scratch("hausdorff");
    let (small, large) = (dir.join("small.ply"), dir.join("large.ply"));
    let sphere = |radius: f64| TriMesh::icosphere(glam::DVec3::ZERO, radius, 3);
    io::write_mesh(&small, &sphere(10.0), &[]).unwrap();
    io::write_mesh(&large, &sphere(10.5), &[]).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_balloonseg"))
        .args(["hausdorff", "--steps", "1"])
        .args([&small, &large])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // From the inner sphere's vertices to the outer polyhedron: at least the 0.5 mm between
    // the spheres less the outer one's sag; from the outer vertices: 0.5 mm plus the inner sag.
    let (forward, backward) = (
        json["a_to_b_mm"].as_f64().unwrap(),
        json["b_to_a_mm"].as_f64().unwrap(),
    );
    assert!(forward > 0.3 && forward <= 0.5 + 1e-9, "{json}");
    assert!((0.5 - 1e-9..0.7).contains(&backward), "{json}");
    assert_eq!(
        json["hausdorff_mm"].as_f64().unwrap(),
        forward.max(backward)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
