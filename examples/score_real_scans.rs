//! The balloon on the real scans (`BALLOONSEG_DATA`), scored as `tests/real_scans.rs` and
//! `tests/newer_real_scans.rs` score it:
//! for the aorta, Dice, mean symmetric surface distance (between the surfaces and between voxel
//! masks) and HD95 against vmtk's reference inside its rows y = 89…176; for the carotid,
//! validity, components, genus, steps and seconds; for every seed of the newer scans
//! (`tests/support/real_scan_cases.rs`), Dice against its label, genus, volume, the window and
//! what it misses of the data README's expectation.
//!
//! `score_real_scans [aorta|carotid|cases|CASE...] [--reference R] [--tolerance T]
//! [--threads N] [--step-fraction F] [--max-reparametrizations N] [--save DIR]
//! [--pictures DIR]` (all of them without a name) prints one JSON line per scan (and with
//! `--save`, writes `DIR/NAME.vtp`; with `--pictures`, `DIR/NAME.png`: `balloonseg render`'s
//! picture through the seed, windowed as `segment --png` windows it); for trying parameters and
//! estimators against the numbers BENCHMARKS.md quotes, and for docs/real_scans.md.

#[path = "../tests/support/real_scan_cases.rs"]
mod real_scan_cases;

use std::path::Path;
use std::time::Instant;

use balloonseg::balloon::{BalloonParams, Segmenter};
use balloonseg::evaluation::{score_against_level_set, IndexBox, LevelSetScore};
use balloonseg::render::{self, RenderOptions};
use balloonseg::{io, mesh_checks, Error, Image, Result, TriMesh};
use balloonseg_testkit::data_dir;
use glam::DVec3;

fn main() {
    if let Err(e) = run() {
        eprintln!("score_real_scans: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let mut which: Vec<String> = Vec::new();
    let mut params = BalloonParams::default();
    let mut save = None;
    let mut pictures = None;
    while let Some(arg) = args.next() {
        let mut value = |name: &str| -> Result<f64> {
            args.next()
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| Error::invalid_argument(format!("{name} needs a number")))
        };
        match arg.as_str() {
            "--reference" => params.reference = Some(value("--reference")?),
            "--tolerance" => params.tolerance = Some(value("--tolerance")?),
            "--threads" => params.threads = value("--threads")? as usize,
            "--step-fraction" => params.step_fraction = value("--step-fraction")?,
            "--max-reparametrizations" => {
                params.max_reparametrizations = value("--max-reparametrizations")? as u32
            }
            "--save" => save = args.next().map(std::path::PathBuf::from),
            "--pictures" => pictures = args.next().map(std::path::PathBuf::from),
            name if !name.starts_with('-') => which.push(arg),
            other => {
                return Err(Error::invalid_argument(format!(
                "unknown argument {other}; usage: score_real_scans [aorta|carotid|cases|CASE...] \
                     [--reference R] [--tolerance T] [--threads N] [--step-fraction F] \
                     [--max-reparametrizations N] [--save DIR] [--pictures DIR]"
            )))
            }
        }
    }
    let dir = data_dir().ok_or_else(|| Error::invalid_argument("no BALLOONSEG_DATA"))?;
    let wanted = |name: &str| which.is_empty() || which.iter().any(|w| w == name);
    if wanted("aorta") {
        let image = io::read_image(&dir.join("vmtk-aorta/aorta.mha"))?;
        let seed = DVec3::new(-221.484, -156.445, 22.501);
        let start = Instant::now();
        let mut segmenter = Segmenter::new(image.view(), params.clone(), seed)?;
        let (mesh, _) = segmenter.segment()?;
        let seconds = start.elapsed().as_secs_f64();
        if let Some(dir) = &save {
            io::write_mesh(&dir.join("aorta.vtp"), &mesh, &[])?;
        }
        if let Some(dir) = &pictures {
            let window = segmenter.stats().display_window();
            picture(&dir.join("aorta.png"), &image, &mesh, seed, window)?;
        }
        let level_set = io::read_image(&dir.join("vmtk-aorta/aorta-reference-levelset.mha"))?;
        let region = IndexBox {
            lo: [0, 89, 0],
            hi: [level_set.dims()[0] - 1, 176, level_set.dims()[2] - 1],
        };
        let LevelSetScore {
            overlap,
            distances,
            voxel_distances,
        } = score_against_level_set(&mesh, &level_set.view(), region)?;
        let report = mesh_checks::check(&mesh);
        let stats = segmenter.stats();
        println!(
            "{{\"scan\": \"aorta\", \"valid\": {}, \"components\": {}, \"genus\": {:?}, \
             \"dice\": {:.4}, \"mssd_mm\": {:.3}, \"voxel_mssd_mm\": {:.3}, \"hd95_mm\": {:.3}, \
             \"volume_mm3\": {:.0}, \
             \"reference_volume_mm3\": {:.0}, \"reference\": {:.1}, \"tolerance\": {:.1}, \
             \"steps\": {}, \"reparametrizations\": {}, \"seconds\": {:.3}, \"phases\": \"{:.3?}\"}}",
            report.is_valid_closed_surface(),
            report.components,
            report.genus(),
            overlap.dice(),
            distances.mean(),
            voxel_distances.mean(),
            distances.hd95(),
            overlap.mesh,
            overlap.truth,
            stats.reference_intensity,
            stats.tolerance,
            stats.iterations,
            stats.reparametrizations,
            seconds,
            stats.seconds
        );
    }
    if wanted("carotid") {
        let image = io::read_image(&dir.join("vtk-carotid/carotid.mha"))?;
        let start = Instant::now();
        let seed = DVec3::new(117.0, 103.0, 9.0);
        let mut segmenter = Segmenter::new(image.view(), params.clone(), seed)?;
        let (mesh, _) = segmenter.segment()?;
        let seconds = start.elapsed().as_secs_f64();
        if let Some(dir) = &save {
            io::write_mesh(&dir.join("carotid.vtp"), &mesh, &[])?;
        }
        if let Some(dir) = &pictures {
            let window = segmenter.stats().display_window();
            picture(&dir.join("carotid.png"), &image, &mesh, seed, window)?;
        }
        let report = mesh_checks::check(&mesh);
        let stats = segmenter.stats();
        println!(
            "{{\"scan\": \"carotid\", \"valid\": {}, \"components\": {}, \"genus\": {:?}, \
             \"volume_mm3\": {:.0}, \"reference\": {:.1}, \"tolerance\": {:.1}, \"steps\": {}, \
             \"reparametrizations\": {}, \"seconds\": {:.3}}}",
            report.is_valid_closed_surface(),
            report.components,
            report.genus(),
            report.signed_volume,
            stats.reference_intensity,
            stats.tolerance,
            stats.iterations,
            stats.reparametrizations,
            seconds
        );
    }
    for case in real_scan_cases::CASES {
        if !(wanted("cases") || wanted(case.name)) {
            continue;
        }
        let line = match real_scan_cases::run(case, &dir, params.clone()) {
            Ok(outcome) => {
                if let Some(dir) = &save {
                    io::write_mesh(&dir.join(format!("{}.vtp", case.name)), &outcome.mesh, &[])?;
                }
                if let Some(dir) = &pictures {
                    picture(
                        &dir.join(format!("{}.png", case.name)),
                        &outcome.image,
                        &outcome.mesh,
                        outcome.seed,
                        outcome.display_window,
                    )?;
                }
                serde_json::json!({
                    "case": case.name,
                    "valid": outcome.valid,
                    "components": outcome.components,
                    "genus": outcome.genus,
                    "dice": outcome.dice.map(|d| (d * 1e4).round() / 1e4),
                    "volume_cm3": (outcome.volume_cm3 * 100.0).round() / 100.0,
                    "window": outcome.window,
                    "seconds": (outcome.seconds * 100.0).round() / 100.0,
                    "misses": outcome.misses(case),
                })
            }
            Err(e) => serde_json::json!({"case": case.name, "error": e.to_string()}),
        };
        println!("{line}");
    }
    Ok(())
}

/// Each panel's side in `--pictures`: small enough for the repository, large enough to see a leak.
const PICTURE_PANEL_PX: u32 = 300;

/// `balloonseg render`'s picture of `mesh` over `image` through `seed`, with `window`.
fn picture(
    path: &Path,
    image: &Image,
    mesh: &TriMesh,
    seed: DVec3,
    window: (f64, f64),
) -> Result<()> {
    let options = RenderOptions {
        centre: Some(seed),
        window: Some(window),
        panel_px: PICTURE_PANEL_PX,
        ..RenderOptions::default()
    };
    render::write_png(
        path,
        &render::render_overview(&image.view(), Some(mesh), &options)?,
    )
}
