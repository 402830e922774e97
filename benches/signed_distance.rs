//! Step 6 on the aorta scan's grid (157×393×34, anisotropic, mirrored) for a 12,928-triangle
//! tube: the whole signed-distance field (band of 3 voxels + sign everywhere), and the sign alone.
//! libigl's fast-winding-number `signed_distance` takes seconds for this grid; see
//! `scripts/compare_signed_distance.py` for a same-run comparison.

use std::hint::black_box;

use balloonseg::winding_number::inside_mask;
use balloonseg::{signed_distance, SignedDistanceOptions};
use criterion::{criterion_group, criterion_main, Criterion};

#[path = "support/aorta_like.rs"]
mod aorta_like;
use aorta_like::{aorta_grid, aorta_like_tube, DIMS};

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

criterion_group!(benches, aorta_grid_tube);
criterion_main!(benches);
