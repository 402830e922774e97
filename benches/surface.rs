//! Balloon surface remeshing: growing a sphere from 162 to about 100k vertices by repeated
//! scaling and remeshing (split, collapse), and vertex normals on the grown surface (with
//! triangle normals as the peer to compare them with).

use std::hint::black_box;

use balloonseg::balloon::surface::Surface;
use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;

const TARGET_VERTICES: usize = 100_000;

/// Scales the sphere by 1.05 about its centre and remeshes, until it has `TARGET_VERTICES`.
fn grow() -> Surface {
    let mut s = Surface::icosphere(DVec3::ZERO, 1.0, 2).expect("valid sphere");
    let p = s.positions();
    let target = s
        .edges()
        .map(|e| p[e.a as usize].distance(p[e.b as usize]))
        .sum::<f64>()
        / s.edge_count() as f64;
    let (min, max) = (0.8 * target, 4.0 / 3.0 * target);
    while s.vertex_count() < TARGET_VERTICES {
        s.positions_mut().iter_mut().for_each(|p| *p *= 1.05);
        s.split_long_edges(max).expect("finite positions");
        s.collapse_short_edges(min, max).expect("finite positions");
    }
    s
}

fn bench_surface(c: &mut Criterion) {
    let mut group = c.benchmark_group("surface");
    group.sample_size(10);
    group.bench_function("grow_162_to_100k", |b| b.iter(|| black_box(grow())));
    let mut grown = grow();
    grown.compact();
    let mut normals = Vec::new();
    group.bench_function("vertex_normals_100k", |b| {
        b.iter(|| {
            black_box(&grown).vertex_normals_into(&mut normals);
            black_box(&normals);
        })
    });
    // A peer for the normals: one parallel pass over the triangles, no scatter.
    group.bench_function("triangle_normals_100k", |b| {
        b.iter(|| black_box(black_box(&grown).triangle_normals()))
    });
    group.finish();
}

criterion_group!(benches, bench_surface);
criterion_main!(benches);
