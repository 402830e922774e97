//! Data and timings for `scripts/compare_signed_distance.py` (libigl vs balloonseg), on the aorta
//! scan's grid. Raw little-endian files, no I/O crates:
//!
//! - `signed_distance_case export DIR`: writes the synthetic 12,928-triangle tube of the bench as
//!   `DIR/points.f64` (x, y, z per point) and `DIR/triangles.u32`, and prints the grid as JSON.
//! - `signed_distance_case time DIR REPEATS`: reads those two files (any closed outward mesh),
//!   computes the signed distance (default band) REPEATS times, writes `DIR/field.f64` (i fastest)
//!   and prints the timings as JSON.

use std::path::Path;
use std::time::Instant;

use balloonseg::{signed_distance, Error, Result, SignedDistanceOptions, TriMesh, VoxelBuffer};
use glam::DVec3;

#[path = "../benches/support/aorta_like.rs"]
mod aorta_like;
use aorta_like::{aorta_grid, aorta_like_tube, DIMS};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let outcome = match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["export", dir] => export(Path::new(dir)),
        ["time", dir, repeats] => match repeats.parse() {
            Ok(repeats) if repeats > 0 => time(Path::new(dir), repeats),
            _ => Err(Error::invalid_argument(format!(
                "REPEATS is {repeats:?}; give a positive count"
            ))),
        },
        _ => Err(Error::invalid_argument(
            "usage: signed_distance_case export DIR | time DIR REPEATS",
        )),
    };
    if let Err(e) = outcome {
        eprintln!("signed_distance_case: {e}");
        std::process::exit(1);
    }
}

fn export(dir: &Path) -> Result<()> {
    let geometry = aorta_grid();
    let tube = aorta_like_tube(&geometry);
    let points: Vec<u8> = tube
        .points()
        .iter()
        .flat_map(|p| p.to_array())
        .flat_map(f64::to_le_bytes)
        .collect();
    let triangles: Vec<u8> = tube
        .triangles()
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    write(&dir.join("points.f64"), &points)?;
    write(&dir.join("triangles.u32"), &triangles)?;
    println!(
        "{{\"dims\": {:?}, \"spacing\": {:?}, \"origin\": {:?}, \"direction\": {:?}, \"triangles\": {}, \"volume_mm3\": {}}}",
        DIMS,
        geometry.spacing(),
        geometry.origin(),
        geometry.direction(),
        tube.triangles().len(),
        tube.signed_volume()
    );
    Ok(())
}

fn time(dir: &Path, repeats: usize) -> Result<()> {
    let points: Vec<DVec3> = read(&dir.join("points.f64"))?
        .chunks_exact(24)
        .map(|c| {
            let f = |n: usize| f64::from_le_bytes(c[8 * n..8 * n + 8].try_into().unwrap());
            DVec3::new(f(0), f(1), f(2))
        })
        .collect();
    let triangles: Vec<[u32; 3]> = read(&dir.join("triangles.u32"))?
        .chunks_exact(12)
        .map(|c| {
            let v = |n: usize| u32::from_le_bytes(c[4 * n..4 * n + 4].try_into().unwrap());
            [v(0), v(1), v(2)]
        })
        .collect();
    let mesh = TriMesh::new(points, triangles)?;
    let geometry = aorta_grid();
    let options = SignedDistanceOptions::default();
    let mut seconds = Vec::with_capacity(repeats);
    let mut field = None;
    for _ in 0..repeats {
        let start = Instant::now();
        field = Some(signed_distance(&mesh, &mesh, DIMS, &geometry, &options)?);
        seconds.push(start.elapsed().as_secs_f64());
    }
    seconds.sort_by(f64::total_cmp);
    if let Some(VoxelBuffer::F64(values)) = field.as_ref().map(|f| f.buffer()) {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        write(&dir.join("field.f64"), &bytes)?;
    }
    println!(
        "{{\"seconds_min\": {}, \"seconds_median\": {}, \"repeats\": {repeats}, \"threads\": {}, \"band_mm\": {}}}",
        seconds[0],
        seconds[seconds.len() / 2],
        rayon::current_num_threads(),
        options.band_mm(&geometry)
    );
    Ok(())
}

fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).map_err(|e| Error::io(e.to_string()).context(path.display()))
}

fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| Error::io(e.to_string()).context(path.display()))
}
