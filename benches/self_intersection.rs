//! Self-intersection search on a clean torus and on one with a patch pushed through the tube,
//! with 1 and 2 threads; and the exact triangle–triangle test alone.
//!
//! `cargo bench --bench self_intersection`

use std::f64::consts::TAU;
use std::hint::black_box;

use balloonseg::self_intersection::self_intersections;
use balloonseg::triangle_intersection::triangles_intersect;
use balloonseg::TriMesh;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use glam::DVec3;

/// A torus (major radius 3, minor radius 1) of `n` × `m` quads, two triangles each.
fn torus(n: u32, m: u32, dent: bool) -> TriMesh {
    let mut points = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (u, v) = (TAU * i as f64 / n as f64, TAU * j as f64 / m as f64);
            // Pushing the outer side of one sector in by 2.5 takes it through the inner side.
            let inward = if dent && u < 0.5 && v.cos() > 0.5 {
                2.5
            } else {
                0.0
            };
            let r = 3.0 + v.cos() - inward * v.cos();
            points.push(DVec3::new(r * u.cos(), r * u.sin(), v.sin()));
        }
    }
    let index = |i: u32, j: u32| (i % n) * m + (j % m);
    let mut triangles = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (a, b, c, d) = (
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            );
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    TriMesh::new(points, triangles).expect("the torus is a valid mesh")
}

fn search(c: &mut Criterion) {
    let mut group = c.benchmark_group("self_intersections");
    group.sample_size(20);
    for (name, mesh) in [
        ("clean torus 98k", torus(256, 192, false)),
        ("dented torus 98k", torus(256, 192, true)),
    ] {
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a thread pool");
            group.bench_with_input(BenchmarkId::new(name, threads), &mesh, |b, mesh| {
                b.iter(|| pool.install(|| self_intersections(black_box(mesh)).unwrap()))
            });
        }
    }
    group.finish();
}

fn exact_test(c: &mut Criterion) {
    // Pairs of nearby triangles in a unit cube: a mix of crossing, touching and apart.
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut point = || DVec3::new(uniform(), uniform(), uniform());
    let pairs: Vec<([DVec3; 3], [DVec3; 3])> = (0..1000)
        .map(|_| ([point(), point(), point()], [point(), point(), point()]))
        .collect();
    c.bench_function("triangles_intersect x1000", |b| {
        b.iter(|| {
            pairs
                .iter()
                .filter(|(p, q)| triangles_intersect(black_box(*p), black_box(*q)))
                .count()
        })
    });
}

criterion_group!(benches, search, exact_test);
criterion_main!(benches);
