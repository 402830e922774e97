//! Several objects on the touching-pair phantom family: both capsules seeded (the family's seed
//! and the other capsule's deepest point), over random variants, against each capsule alone.
//!
//! `objects_sweep [--variants N] [--first K] [--save DIR]` prints, as markdown, one row per
//! variant: whether both meshes are valid and apart (no triangle of one meets the other), each
//! object's Dice against its own capsule (sampled every quarter of the smallest spacing), the
//! widest gap between them where the capsules touch (in voxels of the largest spacing: the
//! largest distance to the other mesh over the vertices of each within half a voxel of the
//! other capsule's surface), the seconds of the two objects together and of each capsule
//! segmented alone, and the error of a failed run; then the median Dice and the ratio of the
//! total time to the total of the runs alone. `--save DIR` writes each variant's volume and
//! both meshes (`pair-N.nii.gz`, `pair-N-1.vtp`, `pair-N-2.vtp`).

use std::path::PathBuf;
use std::time::Instant;

use balloonseg::balloon::{segment_objects, BalloonParams, ObjectSeeds, ObjectsRequest, Segmenter};
use balloonseg::evaluation::{overlap_with_shape, widest_gap_at_contact};
use balloonseg::phantom::{Family, Variant};
use balloonseg::self_intersection::self_intersections;
use balloonseg::{io, mesh_checks, Error, Result, TriMesh};
use glam::DVec3;

fn main() {
    if let Err(e) = run() {
        eprintln!("objects_sweep: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<()> {
    let (mut variants, mut first, mut save) = (10u64, 0u64, None::<PathBuf>);
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = || {
            args.next()
                .ok_or_else(|| Error::invalid_argument(format!("{arg} needs a value")))
        };
        match arg.as_str() {
            "--variants" => variants = number(&value()?)?,
            "--first" => first = number(&value()?)?,
            "--save" => save = Some(PathBuf::from(value()?)),
            _ => {
                return Err(Error::invalid_argument(format!(
                    "unknown argument {arg}; use --variants N, --first K, --save DIR"
                )))
            }
        }
    }
    println!("| variant | valid, apart | Dice 1 | Dice 2 | gap (voxels) | s together | s alone | error |");
    println!("|---|---|---|---|---|---|---|---|");
    let (mut dice, mut together, mut alone) = (Vec::new(), 0.0, 0.0);
    for number in first..first + variants {
        let variant = Family::TouchingPair.variant(number)?;
        let seeds = [variant.seed(), variant.other_seed().expect("a pair")];
        let request = ObjectsRequest {
            objects: vec![
                ObjectSeeds {
                    label: 1,
                    seeds: vec![seeds[0]],
                },
                ObjectSeeds {
                    label: 2,
                    seeds: vec![seeds[1]],
                },
            ],
            ..ObjectsRequest::default()
        };
        let start = Instant::now();
        let result = segment_objects(
            variant.image.view(),
            BalloonParams::default(),
            &request,
            None,
        );
        let seconds = start.elapsed().as_secs_f64();
        let start = Instant::now();
        for seed in seeds {
            let _ = Segmenter::new(variant.image.view(), BalloonParams::default(), seed)
                .and_then(|mut s| s.segment());
        }
        let seconds_alone = start.elapsed().as_secs_f64();
        let objects = match result {
            Ok(objects) => objects,
            Err(e) => {
                dice.extend([0.0, 0.0]);
                println!("| {number} | no | | | | {seconds:.2} | {seconds_alone:.2} | {e} |");
                continue;
            }
        };
        together += seconds;
        alone += seconds_alone;
        let (a, b) = (&objects[0].mesh, &objects[1].mesh);
        let scores = [
            score(a, &variant, |p| variant.truth(p), variant.truth_bounds())?,
            score(
                b,
                &variant,
                variant.other().expect("a pair"),
                variant.other_bounds().expect("a pair"),
            )?,
        ];
        dice.extend(scores);
        let valid = [a, b].iter().all(|m| {
            mesh_checks::check(m).is_valid_closed_surface()
                && self_intersections(m).unwrap().is_empty()
        });
        let mut both = a.clone();
        both.append(b)?;
        let apart = self_intersections(&both).unwrap().len()
            == self_intersections(a).unwrap().len() + self_intersections(b).unwrap().len();
        let voxel = variant.image.geometry().max_spacing();
        let other = variant.other().expect("a pair");
        let gap = widest_gap_at_contact(a, other, b, 0.5 * voxel)?.max(widest_gap_at_contact(
            b,
            |p| variant.truth(p),
            a,
            0.5 * voxel,
        )?) / voxel;
        if let Some(dir) = &save {
            io::write_image(&dir.join(format!("pair-{number}.nii.gz")), &variant.image)?;
            io::write_mesh(&dir.join(format!("pair-{number}-1.vtp")), a, &[])?;
            io::write_mesh(&dir.join(format!("pair-{number}-2.vtp")), b, &[])?;
        }
        println!(
            "| {number} | {} | {:.4} | {:.4} | {gap:.2} | {seconds:.2} | {seconds_alone:.2} | |",
            if valid && apart { "yes" } else { "NO" },
            scores[0],
            scores[1]
        );
    }
    dice.sort_by(f64::total_cmp);
    println!(
        "\nmedian Dice {:.4}, lowest {:.4}; together / alone {:.2}",
        dice[dice.len() / 2],
        dice[0],
        together / alone
    );
    Ok(())
}

fn number(text: &str) -> Result<u64> {
    text.parse()
        .map_err(|e| Error::invalid_argument(format!("{text:?} is not a count: {e}")))
}

fn score(
    mesh: &TriMesh,
    variant: &Variant,
    truth: impl Fn(DVec3) -> f64 + Sync,
    bounds: (DVec3, DVec3),
) -> Result<f64> {
    let step = 0.25 * variant.image.geometry().min_spacing();
    Ok(overlap_with_shape(mesh, truth, bounds, step)?.dice())
}
