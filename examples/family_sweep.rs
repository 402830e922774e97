//! The balloon on the phantom families (`phantom::Family`), from the seed alone with the
//! default parameters, over random variants: how robust it is on scans it was never tuned on.
//! A family whose other object nothing in the image separates from the seeded one
//! (`Family::needs_competitor`) gets that object's deepest point as a stop seed, as a user
//! would give it.
//!
//! `family_sweep [--family NAME] [--variants N] [--first K] [--threads N] [--save DIR]` runs
//! variants K..K+N (default 0..20) of each family (or of one) and prints, as markdown, one row
//! per variant — valid (closed, manifold, outward, no self-intersections), genus found and
//! expected, Dice against the truth (sampled every half of the smallest spacing), the share of
//! the other object inside the mesh where the family has one, the mesh's and the truth's
//! volumes, the seconds of the segmentation, and the error of a failed run — then a summary per
//! family: a variant passes when it is valid, has the right genus and a Dice of at least 0.95;
//! the median Dice counts a failed run as 0. `--save DIR` writes each variant's volume
//! (`FAMILY-N.nii.gz`), the truth's signed distance on its grid (`FAMILY-N-truth.nii.gz`, mm,
//! negative inside), mesh (`FAMILY-N.vtp`) and row with its drawn parameters
//! (`FAMILY-N.json`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use balloonseg::balloon::{segment_objects, BalloonParams, ObjectSeeds, ObjectsRequest, Segmenter};
use balloonseg::evaluation::overlap_with_shape;
use balloonseg::phantom::{Family, Variant};
use balloonseg::self_intersection::self_intersections;
use balloonseg::{io, mesh_checks, Error, Image, Result, TriMesh};
use glam::DVec3;
use serde_json::{json, Map, Value};

/// A variant passes from this Dice on (with a valid mesh of the right genus).
const PASS_DICE: f64 = 0.95;

struct Options {
    families: Vec<Family>,
    variants: u64,
    first: u64,
    threads: usize,
    save: Option<PathBuf>,
}

fn main() {
    if let Err(e) = parse().and_then(|options| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(options.threads)
            .build()
            .map_err(|e| Error::invalid_argument(format!("cannot start the threads: {e}")))?;
        pool.install(|| run(&options))
    }) {
        eprintln!("family_sweep: {e}");
        std::process::exit(1);
    }
}

fn parse() -> Result<Options> {
    let mut options = Options {
        families: Family::ALL.to_vec(),
        variants: 20,
        first: 0,
        threads: 0,
        save: None,
    };
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = || {
            args.next()
                .ok_or_else(|| Error::invalid_argument(format!("{arg} needs a value")))
        };
        let number = |text: String| {
            text.parse::<u64>()
                .map_err(|_| Error::invalid_argument(format!("'{text}' is not a whole number")))
        };
        match arg.as_str() {
            "--family" => options.families = vec![Family::from_name(&value()?)?],
            "--variants" => options.variants = number(value()?)?,
            "--first" => options.first = number(value()?)?,
            "--threads" => options.threads = number(value()?)? as usize,
            "--save" => options.save = Some(PathBuf::from(value()?)),
            other => {
                return Err(Error::invalid_argument(format!(
                    "unknown argument {other}; usage: family_sweep [--family NAME] \
                     [--variants N] [--first K] [--threads N] [--save DIR]"
                )))
            }
        }
    }
    if let Some(dir) = &options.save {
        std::fs::create_dir_all(dir)
            .map_err(|e| Error::io(format!("cannot create {}: {e}", dir.display())))?;
    }
    Ok(options)
}

/// What one variant gave.
struct Row {
    number: u64,
    expected_genus: u32,
    outcome: std::result::Result<Scores, String>,
}

struct Scores {
    valid: bool,
    genus: Option<i64>,
    dice: f64,
    other_inside: Option<f64>,
    volume: f64,
    truth_volume: f64,
    seconds: f64,
}

impl Row {
    fn passes(&self) -> bool {
        self.outcome.as_ref().is_ok_and(|s| {
            s.valid && s.genus == Some(i64::from(self.expected_genus)) && s.dice >= PASS_DICE
        })
    }

    fn dice(&self) -> f64 {
        self.outcome.as_ref().map_or(0.0, |s| s.dice)
    }

    fn markdown(&self, family: Family) -> String {
        let name = family.name();
        match &self.outcome {
            Ok(s) => format!(
                "| {name} | {} | {} | {}/{} | {:.4} | {} | {:.0} | {:.0} | {:.2} | {} |",
                self.number,
                if s.valid { "yes" } else { "NO" },
                s.genus.map_or("-".to_string(), |g| g.to_string()),
                self.expected_genus,
                s.dice,
                s.other_inside
                    .map_or("".to_string(), |o| format!("{:.1}", 100.0 * o)),
                s.volume,
                s.truth_volume,
                s.seconds,
                if self.passes() { "pass" } else { "fail" },
            ),
            Err(message) => format!(
                "| {name} | {} | - | -/{} | - | - | - | - | - | fail: {} |",
                self.number,
                self.expected_genus,
                message.replace('|', "/")
            ),
        }
    }

    fn json(&self, family: Family, variant: Option<&Variant>) -> Value {
        let mut row = Map::new();
        row.insert("family".into(), json!(family.name()));
        row.insert("variant".into(), json!(self.number));
        row.insert("expected_genus".into(), json!(self.expected_genus));
        row.insert("pass".into(), json!(self.passes()));
        match &self.outcome {
            Ok(s) => {
                row.insert("valid".into(), json!(s.valid));
                row.insert("genus".into(), json!(s.genus));
                row.insert("dice".into(), json!(s.dice));
                row.insert("other_inside".into(), json!(s.other_inside));
                row.insert("volume_mm3".into(), json!(s.volume));
                row.insert("truth_volume_mm3".into(), json!(s.truth_volume));
                row.insert("seconds".into(), json!(s.seconds));
            }
            Err(message) => {
                row.insert("error".into(), json!(message));
            }
        }
        if let Some(v) = variant {
            let parameters: Map<String, Value> = v
                .describe()
                .iter()
                .map(|p| (p.name.to_string(), json!(p.values)))
                .collect();
            row.insert("seed_world".into(), json!(v.seed().to_array()));
            row.insert("parameters".into(), Value::Object(parameters));
        }
        Value::Object(row)
    }
}

fn run(options: &Options) -> Result<()> {
    let mut summaries = Vec::new();
    for &family in &options.families {
        println!("\n### {}\n", family.name());
        println!(
            "| family | variant | valid | genus | Dice | other % | volume mm³ | truth mm³ | s | |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|");
        let mut rows = Vec::new();
        for number in options.first..options.first + options.variants {
            let row = sweep_one(family, number, options)?;
            println!("{}", row.markdown(family));
            rows.push(row);
        }
        let summary = summarise(family, &rows);
        println!("\n{summary}");
        summaries.push(summary);
    }
    println!("\n### summary\n");
    for summary in summaries {
        println!("- {summary}");
    }
    Ok(())
}

/// Generates, segments and scores variant `number`; only a failure to write `--save` files
/// stops the sweep.
fn sweep_one(family: Family, number: u64, options: &Options) -> Result<Row> {
    let variant = match family.variant(number) {
        Ok(v) => v,
        Err(e) => {
            return Ok(Row {
                number,
                expected_genus: 0,
                outcome: Err(format!("cannot generate the variant: {e}")),
            })
        }
    };
    let stem = format!("{}-{number}", family.name());
    let mesh_and_scores = segment(&variant, options.threads);
    if let Some(dir) = &options.save {
        io::write_image(&dir.join(format!("{stem}.nii.gz")), &variant.image)?;
        io::write_image(
            &dir.join(format!("{stem}-truth.nii.gz")),
            &truth_map(&variant)?,
        )?;
        if let Ok((mesh, _)) = &mesh_and_scores {
            io::write_mesh(&dir.join(format!("{stem}.vtp")), mesh, &[])?;
        }
    }
    let row = Row {
        number,
        expected_genus: variant.genus(),
        outcome: mesh_and_scores.map(|(_, s)| s).map_err(|e| e.to_string()),
    };
    if let Some(dir) = &options.save {
        write_json(
            &dir.join(format!("{stem}.json")),
            &row.json(family, Some(&variant)),
        )?;
    }
    Ok(row)
}

/// The truth's signed distance (mm, negative inside) at the variant's voxel centres, for
/// comparing a segmentation with it voxel by voxel or drawing its zero isosurface.
fn truth_map(variant: &Variant) -> Result<Image> {
    let geometry = *variant.image.geometry();
    Image::from_fn(variant.image.dims(), geometry, |i, j, k| {
        let index = DVec3::new(i as f64, j as f64, k as f64);
        variant.truth(geometry.index_to_world(index)) as f32
    })
}

fn segment(variant: &Variant, threads: usize) -> Result<(TriMesh, Scores)> {
    let params = BalloonParams {
        threads,
        ..BalloonParams::default()
    };
    let start = Instant::now();
    let mesh = match variant.other_seed() {
        Some(stop) if variant.family().needs_competitor() => {
            let request = ObjectsRequest {
                objects: vec![ObjectSeeds {
                    label: 1,
                    seeds: vec![variant.seed()],
                }],
                stops: vec![stop],
                region: None,
            };
            let objects = segment_objects(variant.image.view(), params, &request, None)?;
            objects.into_iter().next().expect("one object").mesh
        }
        _ => {
            Segmenter::new(variant.image.view(), params, variant.seed())?
                .segment()?
                .0
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    let report = mesh_checks::check(&mesh);
    let valid = report.is_valid_closed_surface() && self_intersections(&mesh).unwrap().is_empty();
    let step = 0.5 * variant.image.geometry().min_spacing();
    let overlap = overlap_with_shape(&mesh, |p| variant.truth(p), variant.truth_bounds(), step)?;
    let other_inside = match (variant.other(), variant.other_bounds()) {
        (Some(other), Some(bounds)) => {
            Some(overlap_with_shape(&mesh, other, bounds, step)?.covered())
        }
        _ => None,
    };
    let scores = Scores {
        valid,
        genus: report.genus(),
        dice: overlap.dice(),
        other_inside,
        volume: report.signed_volume,
        truth_volume: overlap.truth,
        seconds,
    };
    Ok((mesh, scores))
}

fn summarise(family: Family, rows: &[Row]) -> String {
    let passed = rows.iter().filter(|r| r.passes()).count();
    let failed = rows.iter().filter(|r| r.outcome.is_err()).count();
    let invalid = rows
        .iter()
        .filter(|r| r.outcome.as_ref().is_ok_and(|s| !s.valid))
        .count();
    let wrong_genus = rows
        .iter()
        .filter(|r| {
            r.outcome
                .as_ref()
                .is_ok_and(|s| s.genus != Some(i64::from(r.expected_genus)))
        })
        .count();
    let low_dice = rows
        .iter()
        .filter(|r| r.outcome.as_ref().is_ok_and(|s| s.dice < PASS_DICE))
        .count();
    let mut dice: Vec<f64> = rows.iter().map(Row::dice).collect();
    dice.sort_by(f64::total_cmp);
    let median = match dice.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => dice[n / 2],
        n => 0.5 * (dice[n / 2 - 1] + dice[n / 2]),
    };
    format!(
        "**{}**: {passed}/{} pass ({:.0}%), median Dice {median:.4}; errors {failed}, invalid \
         {invalid}, wrong genus {wrong_genus}, Dice < {PASS_DICE} {low_dice}",
        family.name(),
        rows.len(),
        100.0 * passed as f64 / rows.len().max(1) as f64,
    )
}

fn write_json(path: &Path, value: &Value) -> Result<()> {
    let text = serde_json::to_string_pretty(value).expect("plain JSON values");
    std::fs::write(path, text + "\n")
        .map_err(|e| Error::io(format!("cannot write {}: {e}", path.display())))
}
