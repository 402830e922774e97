//! Writing and reading a 1M-triangle surface (a torus, 500k points) in the binary mesh formats,
//! through the page cache of a temporary folder.

use std::hint::black_box;
use std::path::Path;

use balloonseg::io::{ply, stl, vtk_legacy, vtk_xml, PointData};
use balloonseg::{Result, TriMesh};
use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;

/// A torus of `nu` × `nv` quads split into triangles.
fn torus(nu: usize, nv: usize) -> TriMesh {
    let tau = std::f64::consts::TAU;
    let mut points = Vec::with_capacity(nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            let (u, v) = (tau * i as f64 / nu as f64, tau * j as f64 / nv as f64);
            let r = 30.0 + 10.0 * v.cos();
            points.push(DVec3::new(r * u.cos(), r * u.sin(), 10.0 * v.sin()));
        }
    }
    let id = |i: usize, j: usize| ((j % nv) * nu + i % nu) as u32;
    let mut triangles = Vec::with_capacity(2 * nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    TriMesh::new(points, triangles).expect("the torus is valid")
}

type Write = fn(&Path, &TriMesh, &[PointData]) -> Result<()>;
type Read = fn(&Path) -> Result<TriMesh>;

fn write_vtp_raw(path: &Path, mesh: &TriMesh, data: &[PointData]) -> Result<()> {
    vtk_xml::write_vtp_with(path, mesh, data, vtk_xml::Compression::None)
}

fn mesh_io(c: &mut Criterion) {
    let mesh = torus(1000, 500);
    let dir = std::env::temp_dir().join(format!("balloonseg-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    let formats: [(&str, Write, Read); 5] = [
        ("ply", ply::write, ply::read),
        ("vtp", vtk_xml::write_vtp, vtk_xml::read_vtp),
        ("vtp_uncompressed", write_vtp_raw, vtk_xml::read_vtp),
        ("vtk", vtk_legacy::write_mesh, vtk_legacy::read_mesh),
        ("stl", stl::write, stl::read),
    ];
    let mut group = c.benchmark_group("mesh_io_1M_triangles");
    group.sample_size(10);
    for (name, write, read) in formats {
        let path = dir.join(format!("torus.{name}"));
        group.bench_function(format!("write_{name}"), |b| {
            b.iter(|| write(&path, black_box(&mesh), &[]).expect("write"))
        });
        group.bench_function(format!("read_{name}"), |b| {
            b.iter(|| black_box(read(&path).expect("read")))
        });
    }
    group.finish();
    std::fs::remove_dir_all(&dir).expect("remove the temporary folder");
}

criterion_group!(benches, mesh_io);
criterion_main!(benches);
