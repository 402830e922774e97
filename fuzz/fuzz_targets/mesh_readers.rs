//! Every mesh reader on arbitrary bytes: a mesh or an error, never a panic, an abort or a hang;
//! and `check` on whatever mesh comes back, as `balloonseg check` runs it.

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
        }
    }
});
