//! The smoothed view the balloon reads the image through (`smoothed_volume`): smoothing a
//! volume of the vmtk aorta's size brick by brick at the fine and coarse scales (σ half a voxel
//! and two voxels), and 100,000 trilinear samples with gradients once the bricks exist.
//! `cargo bench --bench smoothed_volume`.

use std::hint::black_box;

use balloonseg::smoothed_volume::SmoothedVolume;
use balloonseg::{Geometry, Image, VoxelBuffer};
use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec3;

/// 157 × 393 × 34 float32 voxels of 0.88 × 0.88 × 1.5 mm: a bright tube in noise.
fn aorta_sized() -> Image {
    let dims = [157, 393, 34];
    let spacing = [0.878906, 0.878906, 1.50009];
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut noise = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % 200) as f32 - 100.0
    };
    let mut values = Vec::with_capacity(dims.iter().product());
    for k in 0..dims[2] {
        for _ in 0..dims[1] {
            for i in 0..dims[0] {
                let dx = (i as f64 - 78.0) * spacing[0];
                let dz = (k as f64 - 17.0) * spacing[2];
                let inside = (dx * dx + dz * dz).sqrt() < 10.0;
                values.push(if inside { 1900.0 } else { 340.0 } + noise());
            }
        }
    }
    let geometry = Geometry::with_spacing(spacing, [0.0; 3]).expect("valid geometry");
    Image::new(VoxelBuffer::F32(values), dims, geometry).expect("valid image")
}

fn every_voxel(s: &SmoothedVolume<'_>) -> f64 {
    let [nx, ny, nz] = s.dims();
    let mut sum = 0.0;
    for k in (0..nz).step_by(4) {
        for j in (0..ny).step_by(4) {
            for i in (0..nx).step_by(4) {
                sum += s.voxel(i, j, k);
            }
        }
    }
    sum
}

fn bench(c: &mut Criterion) {
    let image = aorta_sized();
    let mut group = c.benchmark_group("smoothed_volume");
    group.sample_size(10);
    for (name, sigma) in [("fine", 0.44), ("coarse", 1.76)] {
        group.bench_function(format!("all_bricks_{name}"), |b| {
            b.iter(|| every_voxel(&SmoothedVolume::new(image.view(), black_box(sigma))))
        });
    }
    let coarse = SmoothedVolume::new(image.view(), 1.76);
    every_voxel(&coarse);
    let points: Vec<DVec3> = (0..100_000)
        .map(|n| {
            let f = n as f64;
            image.geometry().index_to_world(DVec3::new(
                (f * 0.731).rem_euclid(156.0),
                (f * 0.377).rem_euclid(392.0),
                (f * 0.173).rem_euclid(33.0),
            ))
        })
        .collect();
    group.bench_function("samples_with_gradient_100k", |b| {
        b.iter(|| {
            points
                .iter()
                .map(|&p| coarse.sample_with_gradient_world(p).map_or(0.0, |(v, _)| v))
                .sum::<f64>()
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
