//! The balloon per phase and end to end (issue 3's speed targets): inflation steps and
//! self-intersection searches on the aorta half-grown, re-parametrisation plus refinement on the
//! torus phantom once it has met itself, and whole runs — torus phantom, aorta, carotid, and
//! the clinical-size angiogram phantom (issue 18) at the tests' reduced size, 512×512×128 — from
//! defaults and a seed. Marching cubes and signed distance on their own have their own benches.
//!
//! The real scans come from `BALLOONSEG_DATA` (default ../shared/data); without them only the
//! phantom benches run. `BALLOONSEG_BENCH_FULL_SIZE=1` adds the angiogram at 512×512×600 (a
//! minute to render, 300 MB of voxels). `cargo bench --features io --bench balloon`.

use std::hint::black_box;

use balloonseg::balloon::{BalloonParams, Segmenter};
use balloonseg::phantom::{self, Angiogram, PhantomOptions, Shape};
use balloonseg::{io, Image};
use balloonseg_testkit::data_dir;
use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use glam::DVec3;

/// Steps of inflation before the per-phase benches: the aorta balloon is then a few thousand
/// vertices, growing along the vessel in both directions.
const HALF_GROWN_STEPS: u32 = 150;

struct Case {
    name: &'static str,
    image: Image,
    seed: DVec3,
}

fn real_case(name: &'static str, file: &str, seed: [f64; 3]) -> Option<Case> {
    let path = data_dir()?.join(file);
    Some(Case {
        name,
        image: io::read_image(&path).expect("readable scan"),
        seed: DVec3::from(seed),
    })
}

fn angiogram(name: &'static str, dims: [usize; 3]) -> Case {
    let angiogram = Angiogram::new(0, dims).expect("the angiogram fits its grid");
    Case {
        name,
        image: angiogram.render().expect("rendered"),
        seed: angiogram.seed(),
    }
}

fn torus() -> Case {
    let options = PhantomOptions {
        spacing: [0.8, 0.8, 1.5],
        direction: phantom::oblique_direction(),
        noise: 0.1,
        ..PhantomOptions::default()
    };
    let phantom = phantom::render(Shape::Torus, &options).expect("phantom");
    Case {
        name: "torus",
        seed: phantom.seed_world(),
        image: phantom.image,
    }
}

fn segmenter(case: &Case, params: BalloonParams) -> Segmenter<'_, 'static> {
    Segmenter::new(case.image.view(), params, case.seed).expect("valid seed")
}

/// A segmenter after `steps` steps of inflation without self-intersection searches, so that
/// the searches can be timed on their own.
fn grown(case: &Case, steps: u32) -> Segmenter<'_, 'static> {
    let params = BalloonParams {
        self_intersection_interval: u32::MAX,
        ..BalloonParams::default()
    };
    let mut s = segmenter(case, params);
    s.step(steps).expect("inflation");
    s
}

fn bench_phases(c: &mut Criterion, case: &Case) {
    let mut group = c.benchmark_group(format!("balloon_{}", case.name));
    group.sample_size(10);
    group.bench_function("inflation_10_steps_half_grown", |b| {
        b.iter_batched(
            || grown(case, HALF_GROWN_STEPS),
            |mut s| black_box(s.step(10).expect("inflation")),
            BatchSize::PerIteration,
        )
    });
    group.bench_function("self_intersection_half_grown", |b| {
        b.iter_batched(
            || grown(case, HALF_GROWN_STEPS),
            |mut s| black_box(s.freeze_self_intersections().expect("search")),
            BatchSize::PerIteration,
        )
    });
    group.finish();
}

fn bench_repair(c: &mut Criterion, case: &Case) {
    let mut group = c.benchmark_group(format!("balloon_{}", case.name));
    group.sample_size(10);
    let params = BalloonParams::default();
    let refinement = params.refinement_iterations;
    group.bench_function("reparametrize_and_refine_at_contact", |b| {
        b.iter_batched(
            || {
                let mut s = segmenter(case, params.clone());
                s.step(params.max_iterations).expect("inflation");
                s.freeze_self_intersections().expect("search");
                s
            },
            |mut s| {
                s.reparametrize().expect("repair");
                black_box(s.step(refinement).expect("refinement"))
            },
            BatchSize::PerIteration,
        )
    });
    group.finish();
}

fn bench_whole(c: &mut Criterion, cases: &[Case]) {
    let mut group = c.benchmark_group("balloon_segment");
    group.sample_size(10);
    for case in cases {
        group.bench_function(case.name, |b| {
            b.iter(|| black_box(segmenter(case, BalloonParams::default()).segment()))
        });
    }
    group.finish();
}

fn bench_balloon(c: &mut Criterion) {
    let torus = torus();
    let aorta = real_case(
        "aorta",
        "vmtk-aorta/aorta.mha",
        [-221.484, -156.445, 22.501],
    );
    let carotid = real_case("carotid", "vtk-carotid/carotid.mha", [117.0, 103.0, 9.0]);
    if let Some(aorta) = &aorta {
        bench_phases(c, aorta);
    }
    bench_repair(c, &torus);
    let full_size = std::env::var_os("BALLOONSEG_BENCH_FULL_SIZE")
        .is_some()
        .then(|| angiogram("angiogram_512x512x600", Angiogram::FULL_SIZE));
    let reduced = angiogram("angiogram_512x512x128", [512, 512, 128]);
    let cases: Vec<Case> = [Some(torus), aorta, carotid, Some(reduced), full_size]
        .into_iter()
        .flatten()
        .collect();
    bench_whole(c, &cases);
}

criterion_group!(benches, bench_balloon);
criterion_main!(benches);
