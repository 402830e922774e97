//! Random seeds in every phantom family (issue 19, "Seeds everywhere"): wherever a user clicks,
//! inside the object, anywhere on the background, on the volume's faces or in its corners, the
//! balloon with the defaults ends with a valid mesh (closed, 2-manifold, outward, free of
//! self-intersections) or an error that says something, never a panic. The families' own tests
//! (`phantom_families.rs`) judge the result from the documented seed; these judge only that
//! promise, from seeds nobody chose, in variants nobody chose, and in the six analytic shapes
//! (the other half of `balloonseg phantom`) too.
//!
//! Everything is drawn from fixed SplitMix64 streams, so a failure names a case that reruns the
//! same. Two variants of five seeds each per family keep the file within about a minute on two
//! cores in release: a seed on the background fills the volume up to its faces, seconds a run.

use std::panic::{catch_unwind, AssertUnwindSafe};

use balloonseg::balloon::{BalloonParams, Segmenter};
use balloonseg::mesh_checks;
use balloonseg::phantom::{self, Family, PhantomOptions, Shape};
use balloonseg::self_intersection::self_intersections;
use balloonseg::Image;
use glam::DVec3;

/// SplitMix64 (the phantoms' own generator is private to the crate).
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in 0..n.
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// Where a seed was drawn.
#[derive(Debug, Clone, Copy)]
enum Place {
    Inside,
    Anywhere,
    Face,
    Corner,
}

/// A seed of the kind `place` (world mm); `inside` tells whether a world point lies in the
/// seeded object and `bounds` is a world box around it.
fn draw(
    rng: &mut SplitMix64,
    place: Place,
    image: &Image,
    inside: &dyn Fn(DVec3) -> bool,
    bounds: (DVec3, DVec3),
) -> DVec3 {
    let dims = image.dims().map(|n| (n - 1) as f64);
    let geometry = image.geometry();
    let index = match place {
        Place::Inside => {
            // Rejection in the object's box: the objects fill a fair share of it.
            let (lo, hi) = bounds;
            for _ in 0..100_000 {
                let p = lo + (hi - lo) * DVec3::new(rng.unit(), rng.unit(), rng.unit());
                let i = geometry.world_to_index(p);
                if inside(p) && (0..3).all(|a| i[a] >= 0.0 && i[a] <= dims[a]) {
                    return p;
                }
            }
            panic!("no point inside the object in 100,000 draws");
        }
        Place::Anywhere => DVec3::from(dims) * DVec3::new(rng.unit(), rng.unit(), rng.unit()),
        Place::Face => {
            let mut i = DVec3::new(
                rng.below(dims[0] as usize + 1) as f64,
                rng.below(dims[1] as usize + 1) as f64,
                rng.below(dims[2] as usize + 1) as f64,
            );
            let axis = rng.below(3);
            i[axis] = if rng.below(2) == 0 { 0.0 } else { dims[axis] };
            i
        }
        Place::Corner => {
            let c = rng.below(8);
            DVec3::new(
                if c & 1 == 0 { 0.0 } else { dims[0] },
                if c & 2 == 0 { 0.0 } else { dims[1] },
                if c & 4 == 0 { 0.0 } else { dims[2] },
            )
        }
    };
    geometry.index_to_world(index)
}

/// What went wrong from `seed`, if anything: a panic, an invalid mesh or a silent error.
fn broken_promise(image: &Image, seed: DVec3) -> Option<String> {
    let run = catch_unwind(AssertUnwindSafe(|| {
        Segmenter::new(image.view(), BalloonParams::default(), seed).and_then(|mut s| s.segment())
    }));
    match run {
        Err(panic) => Some(format!(
            "panicked: {}",
            panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or(panic.downcast_ref::<&str>().copied())
                .unwrap_or("?")
        )),
        Ok(Err(e)) if e.message().trim().is_empty() => {
            Some(format!("{:?} without a message", e.kind()))
        }
        Ok(Err(_)) => None,
        Ok(Ok((mesh, _))) => {
            let report = mesh_checks::check(&mesh);
            let pairs = self_intersections(&mesh).unwrap().len();
            (!report.is_valid_closed_surface() || pairs > 0)
                .then(|| format!("invalid mesh, {pairs} self-intersecting pairs: {report:?}"))
        }
    }
}

/// Two seeds inside the object, and one each anywhere, on a face and in a corner of the volume.
const PLACES: [Place; 5] = [
    Place::Inside,
    Place::Inside,
    Place::Anywhere,
    Place::Face,
    Place::Corner,
];

/// Variants a family's test draws (numbers below 1,000, from the test's own stream).
const VARIANTS: usize = 2;

/// The promise from `PLACES` seeds in `VARIANTS` variants of `family`, drawn from `stream`.
fn family_keeps_the_promise(family: Family, stream: u64) {
    let mut rng = SplitMix64(stream);
    let mut failures = Vec::new();
    for _ in 0..VARIANTS {
        let number = rng.below(1000) as u64;
        let variant = family.variant(number).unwrap();
        for place in PLACES {
            let seed = draw(
                &mut rng,
                place,
                &variant.image,
                &|p| variant.truth(p) < 0.0,
                variant.truth_bounds(),
            );
            if let Some(what) = broken_promise(&variant.image, seed) {
                failures.push(format!(
                    "{} variant {number}, {place:?} seed {seed} (world mm): {what}",
                    family.name()
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn ct_scenes() {
    family_keeps_the_promise(Family::CtScene, 1);
}

#[test]
fn thin_walls() {
    family_keeps_the_promise(Family::ThinWall, 2);
}

#[test]
fn touching_pairs() {
    family_keeps_the_promise(Family::TouchingPair, 3);
}

#[test]
fn thin_vessels() {
    family_keeps_the_promise(Family::ThinVessels, 4);
}

#[test]
fn stents() {
    family_keeps_the_promise(Family::Stent, 5);
}

#[test]
fn vessel_chambers() {
    family_keeps_the_promise(Family::VesselChamber, 6);
}

/// The analytic shapes on the grid of `balloon_phantoms.rs`: anisotropic, oblique, 10% noise.
#[test]
fn shapes() {
    let mut failures = Vec::new();
    let mut rng = SplitMix64(7);
    for shape in Shape::ALL {
        let p = phantom::render(
            shape,
            &PhantomOptions {
                spacing: [0.8, 0.8, 1.5],
                direction: phantom::oblique_direction(),
                noise: 0.1,
                ..PhantomOptions::default()
            },
        )
        .unwrap();
        for place in PLACES {
            let seed = draw(
                &mut rng,
                place,
                &p.image,
                &|q| shape.signed_distance(q) < 0.0,
                shape.bounds(),
            );
            if let Some(what) = broken_promise(&p.image, seed) {
                failures.push(format!("{} {place:?} seed {seed}: {what}", shape.name()));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
