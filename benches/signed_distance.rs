//! Step 6 on the aorta scan's grid (157×393×34, anisotropic, mirrored) for a 12,928-triangle
//! tube: the whole signed-distance field (band of 3 voxels + sign everywhere), and the sign alone.
//! libigl's fast-winding-number `signed_distance` takes seconds for this grid; see
//! `scripts/compare_signed_distance.py` for a same-run comparison.
//!
//! And the re-parametrisation's call: a balloon-like closed tube of 32,640 triangles with edges
//! of about 1.1 mm, a few of its triangles deleted, on a 120×290×44 grid of the scan's spacing
//! and direction, band of 1 voxel, inside a thread pool like the segmenter's.

use std::hint::black_box;

use balloonseg::signed_distance::signed_distance_values;
use balloonseg::winding_number::inside_mask;
use balloonseg::{signed_distance, Geometry, SignedDistanceOptions, TriMesh};
use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;

#[path = "support/aorta_like.rs"]
mod aorta_like;
use aorta_like::{aorta_grid, aorta_like_tube, pole_to_pole_tube, DIMS};

fn aorta_grid_tube(c: &mut Criterion) {
    let geometry = aorta_grid();
    let tube = aorta_like_tube(&geometry);
    let options = SignedDistanceOptions::default();
    let mut group = c.benchmark_group("signed_distance_aorta_grid");
    group.sample_size(20);
    group.bench_function("band_3_voxels_and_sign", |b| {
        b.iter(|| signed_distance(black_box(&tube), &tube, DIMS, &geometry, &options).unwrap())
    });
    group.bench_function("sign_only", |b| {
        b.iter(|| inside_mask(black_box(&tube), DIMS, &geometry).unwrap())
    });
    group.finish();
}

const BALLOON_DIMS: [usize; 3] = [120, 290, 44];

fn balloon_grid() -> Geometry {
    Geometry::new(
        [0.878906, 0.878906, 1.50009],
        [-20.0, 130.0, -30.0],
        [-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0],
    )
    .expect("the balloon grid is valid")
}

/// A closed, outward tube winding through the grid in x and z, rings of `AROUND` vertices
/// across world y from pole to pole, two voxels or more from every side of the grid.
fn balloon_like_tube(geometry: &Geometry) -> TriMesh {
    const AROUND: u32 = 68;
    const RINGS: u32 = 240;
    let centre = geometry.index_to_world(DVec3::new(59.5, 144.5, 21.5));
    let (half_length, radius) = (122.0, 12.0);
    let point = |ring: u32, around: u32| {
        let u = 2.0 * ring as f64 / (RINGS + 1) as f64 - 1.0;
        let phi = std::f64::consts::TAU * around as f64 / AROUND as f64;
        let along = half_length * u;
        let section = radius * (1.0 - u * u).powf(0.3);
        let bend = DVec3::new(
            34.0 * (along / 60.0).sin(),
            0.0,
            16.0 * (along / 45.0).cos(),
        );
        centre + bend + DVec3::new(section * phi.cos(), along, section * phi.sin())
    };
    pole_to_pole_tube(RINGS, AROUND, point)
}

fn reparametrisation_grid_tube(c: &mut Criterion) {
    let geometry = balloon_grid();
    let balloon = balloon_like_tube(&geometry);
    assert!(balloon.signed_volume() > 0.0);
    // The re-parametrisation deletes the balloon's self-intersecting triangles: a few.
    let (points, triangles) = balloon.clone().into_parts();
    let kept = triangles.into_iter().enumerate();
    let kept = kept
        .filter(|(t, _)| t % 1500 != 700)
        .map(|(_, t)| t)
        .collect();
    let surface = TriMesh::new(points, kept).expect("a subset of a valid mesh is valid");
    let options = SignedDistanceOptions { band_voxels: 1.0 };
    let mut group = c.benchmark_group("signed_distance_balloon_grid");
    group.sample_size(30);
    group.bench_function("band_1_voxel_and_sign", |b| {
        b.iter(|| {
            signed_distance_values(
                black_box(&surface),
                &balloon,
                BALLOON_DIMS,
                &geometry,
                &options,
            )
            .unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, reparametrisation_grid_tube, aorta_grid_tube);
criterion_main!(benches);
