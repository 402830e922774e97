//! Marching cubes on the two fields of `scripts/compare_marching_cubes.py` (which times the
//! 512³ versions against VTK): a torus distance field (small surface, the classification pass
//! dominates) and a gyroid (a surface through almost every row, output dominates), as float32,
//! plus the gyroid as uint8 and through a Fortran-ordered (strided) view.

use std::f64::consts::PI;
use std::hint::black_box;

use balloonseg::marching_cubes::marching_cubes;
use balloonseg::{Geometry, Image, TypedVolume, Volume, VoxelBuffer};
use criterion::{criterion_group, criterion_main, Criterion};

const N: usize = 160;

fn coordinate(i: usize, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * i as f64 / (N - 1) as f64
}

fn torus() -> Image {
    Image::from_fn([N; 3], Geometry::identity(), |i, j, k| {
        let [x, y, z] = [i, j, k].map(|c| coordinate(c, -1.0, 1.0));
        let ring = (x * x + y * y).sqrt() - 0.55;
        ((ring * ring + z * z).sqrt() - 0.25) as f32
    })
    .expect("valid dims")
}

fn gyroid() -> Image {
    Image::from_fn([N; 3], Geometry::identity(), |i, j, k| {
        let [x, y, z] = [i, j, k].map(|c| coordinate(c, 0.0, 2.0 * PI * 3.0));
        (x.sin() * y.cos() + y.sin() * z.cos() + z.sin() * x.cos()) as f32
    })
    .expect("valid dims")
}

fn bench(c: &mut Criterion) {
    let (torus, gyroid) = (torus(), gyroid());
    let VoxelBuffer::F32(values) = gyroid.buffer() else {
        unreachable!("Image::from_fn makes float32 images")
    };
    let bytes: Vec<u8> = values.iter().map(|v| (v * 60.0 + 128.0) as u8).collect();
    let gyroid_u8: Volume = TypedVolume::contiguous(&bytes, [N; 3], Geometry::identity())
        .expect("valid layout")
        .into();
    let mut fortran = vec![0.0f32; values.len()];
    for (n, &v) in values.iter().enumerate() {
        let (i, j, k) = (n % N, n / N % N, n / (N * N));
        fortran[k + N * (j + N * i)] = v;
    }
    let strides = [(N * N) as isize, N as isize, 1];
    let gyroid_fortran: Volume =
        TypedVolume::new(&fortran, 0, [N; 3], strides, Geometry::identity())
            .expect("valid layout")
            .into();

    let mut group = c.benchmark_group("marching_cubes");
    group.sample_size(10);
    let cases = [
        ("torus_f32_160", torus.view(), 0.0),
        ("gyroid_f32_160", gyroid.view(), 0.0),
        ("gyroid_u8_160", gyroid_u8, 127.5),
        ("gyroid_f32_fortran_160", gyroid_fortran, 0.0),
    ];
    for (name, volume, level) in cases {
        group.bench_function(name, |b| {
            b.iter(|| marching_cubes(black_box(&volume), level).expect("finite level"))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
