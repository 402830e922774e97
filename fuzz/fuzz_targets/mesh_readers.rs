//! Every mesh reader on arbitrary bytes: a mesh or an error, never a panic, an abort or a hang;
//! `check` on whatever mesh comes back, as `balloonseg check` runs it; and `simplify` on it,
//! which must refuse it or keep it closed, manifold, oriented and free of self-intersections.

#![no_main]

#[path = "as_file.rs"]
mod as_file;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let extensions = ["vtp", "vtk", "ply", "stl", "obj", "off"];
    if let Some(path) = as_file::as_file(data, &extensions) {
        if let Ok(mesh) = balloonseg::io::read_mesh(&path) {
            let _ = balloonseg::mesh_checks::check(&mesh);
            let _ = balloonseg::self_intersection::self_intersections(&mesh);
            simplify_keeps_the_guarantees(&mesh, data[data.len() - 1]);
        }
    }
});

/// A bound from 0 to a tenth of the mesh's size, picked by `byte`.
fn simplify_keeps_the_guarantees(mesh: &balloonseg::TriMesh, byte: u8) {
    let Some((lo, hi)) = mesh.bounds() else {
        return;
    };
    let bound = 0.1 * lo.distance(hi) * f64::from(byte) / 255.0;
    if let Ok(out) = balloonseg::simplification::simplify(mesh, bound) {
        let report = balloonseg::mesh_checks::check(&out.mesh);
        assert!(report.closed() && report.manifold() && report.consistently_oriented());
        assert!(balloonseg::self_intersection::self_intersections(&out.mesh).unwrap().is_empty());
    }
}
