//! `balloonseg segment INPUT --seed X,Y,Z [--seed ...] [--index] [--ras] -o OUTPUT [--stats F]
//! [--png F]`

use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use balloonseg::balloon::image_model::seed_statistics::{Neighbours, RAYS};
use balloonseg::balloon::{Phase, SegmentationStats, Segmenter, VertexState};
use balloonseg::io::{self, PointData, PointValues};
use balloonseg::render::{self, RenderOptions};
use balloonseg::{mesh_checks, self_intersection::self_intersections, Error, Geometry, Result};
use glam::DVec3;
use serde_json::json;

use crate::param_flags::ParamFlags;

#[derive(clap::Args)]
pub struct Args {
    /// Input volume (.mha, .mhd, .nrrd, .nhdr, .nii, .nii.gz, .vti, .vtk).
    input: PathBuf,
    /// A seed inside the structure, "x,y,z" in world mm (LPS); repeat for more seeds.
    #[arg(long = "seed", required = true, value_parser = crate::parse_triple, allow_hyphen_values = true)]
    seeds: Vec<[f64; 3]>,
    /// Seeds are voxel indices i,j,k instead of world coordinates.
    #[arg(long, conflicts_with = "ras")]
    index: bool,
    /// Seeds are in RAS world coordinates, as 3D Slicer shows them.
    #[arg(long)]
    ras: bool,
    #[command(flatten)]
    output: crate::Output,
    /// Write run statistics as JSON to this file.
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Write a picture of the result to this PNG file: three slices through the first seed with
    /// the mesh's section, and a 3D view.
    #[arg(long)]
    png: Option<PathBuf>,
    /// The balloon's parameters, one flag each (see docs/interfaces.md).
    #[command(flatten)]
    params: ParamFlags,
}

impl Args {
    fn seed_world(&self, seed: [f64; 3], geometry: &Geometry) -> DVec3 {
        let s = DVec3::from(seed);
        if self.index {
            geometry.index_to_world(s)
        } else if self.ras {
            DVec3::new(-s.x, -s.y, s.z)
        } else {
            s
        }
    }
}

pub fn run(args: &Args, threads: usize) -> Result<ExitCode> {
    let start = Instant::now();
    let image = io::read_image(&args.input)?;
    let geometry = *image.geometry();
    let seeds: Vec<DVec3> = args
        .seeds
        .iter()
        .map(|&s| args.seed_world(s, &geometry))
        .collect();
    let mut segmenter = Segmenter::new(image.view(), args.params.params(threads)?, seeds[0])?;
    for &seed in &seeds[1..] {
        segmenter.add_seed(seed)?;
    }
    eprintln!("{}", window_line(segmenter.stats()));
    if std::io::stderr().is_terminal() {
        segmenter.set_progress(Some(Box::new(draw_progress)));
    }
    let result = segmenter.segment();
    if std::io::stderr().is_terminal() {
        eprintln!();
    }
    let (mesh, states) = result?;
    let state_bytes: Vec<u8> = states.iter().map(|&s| s as u8).collect();
    let point_data = [PointData {
        name: "vertex_state",
        values: PointValues::U8(&state_bytes),
    }];
    io::write_mesh(&args.output.path, &mesh, &point_data)?;
    if let Some(path) = &args.stats {
        let stats = stats_json(&mesh, segmenter.stats(), start.elapsed().as_secs_f64());
        std::fs::write(
            path,
            serde_json::to_string_pretty(&stats).expect("plain JSON values"),
        )
        .map_err(|e| Error::io(format!("cannot write {}: {e}", crate::shown(path))))?;
    }
    if let Some(path) = &args.png {
        let options = RenderOptions {
            centre: Some(seeds[0]),
            window: Some(segmenter.stats().display_window()),
            ..RenderOptions::default()
        };
        render::write_png(
            path,
            &render::render_overview(&image.view(), Some(&mesh), &options)?,
        )?;
    }
    let moving = states.iter().filter(|&&s| s == VertexState::Moving).count();
    eprintln!(
        "{}: {} points, {} triangles ({moving} vertices still moving)",
        crate::shown(&args.output.path),
        mesh.points().len(),
        mesh.triangles().len()
    );
    Ok(ExitCode::SUCCESS)
}

fn draw_progress(fraction: f64, phase: Phase) -> bool {
    let width = 30;
    let filled = (fraction * width as f64).round() as usize;
    let mut err = std::io::stderr();
    let _ = write!(
        err,
        "\r[{}{}] {:>3.0}% {:<18}",
        "#".repeat(filled),
        " ".repeat(width - filled),
        fraction * 100.0,
        phase.name()
    );
    let _ = err.flush();
    true
}

fn stats_json(
    mesh: &balloonseg::TriMesh,
    stats: &SegmentationStats,
    total: f64,
) -> serde_json::Value {
    let report = mesh_checks::check(mesh);
    let s = &stats.seconds;
    json!({
        "vertices": report.vertices,
        "triangles": report.triangles,
        "euler_characteristic": report.euler_characteristic,
        "genus": report.genus(),
        "components": report.components,
        "closed": report.closed(),
        "manifold": report.manifold(),
        "outward": report.outward(),
        "self_intersecting_pairs": self_intersections(mesh).len(),
        "iterations": stats.iterations,
        "reparametrizations": stats.reparametrizations,
        "volume_mm3": report.signed_volume,
        "area_mm2": report.area,
        "reference_intensity": stats.reference_intensity,
        "tolerance": stats.tolerance,
        "window": {
            "lower": finite(stats.window.lower),
            "upper": finite(stats.window.upper),
            "reference": stats.window.reference,
        },
        "intensity_model": stats.seed_statistics.map(|m| json!({
            "noise_sigma": m.noise,
            "texture_sigma": m.texture,
            "fine_texture_sigma": m.fine_texture,
            "ct_soft_tissue": m.soft_tissue,
            "rays": RAYS,
            "rays_with_edge": m.rays_exited(),
            "edge_strength": m.edge_strength,
            "darker": neighbours_json(&m.darker),
            "brighter": neighbours_json(&m.brighter),
        })),
        "edge_length_mm": stats.edge_length,
        "seconds": {
            "inflation": s.inflation,
            "self_intersection": s.self_intersection,
            "reparametrization": s.reparametrization,
            "refinement": s.refinement,
            "validation": s.validation,
            "total": total,
        },
    })
}

/// JSON has no infinity: an open end of the window is `null`.
fn finite(value: f64) -> Option<f64> {
    value.is_finite().then_some(value)
}

fn neighbours_json(n: &Neighbours) -> serde_json::Value {
    json!({
        "rays": n.rays,
        "level": finite(n.level),
        "border": finite(n.border),
        "edge_strength": finite(n.edge_strength),
    })
}

/// One line on the window the balloon inflates in, and where it came from.
fn window_line(stats: &SegmentationStats) -> String {
    let w = stats.window;
    let end = |v: f64| {
        if v.is_finite() {
            format!("{v:.1}")
        } else {
            "open".to_string()
        }
    };
    let mut line = format!(
        "window {} .. {} around {:.1}",
        end(w.lower),
        end(w.upper),
        w.reference
    );
    match &stats.seed_statistics {
        Some(m) => {
            let side = |name: &str, n: &Neighbours| {
                if n.rays == 0 {
                    format!("no {name} tissue")
                } else {
                    format!("{name} tissue at {:.1} on {} rays", n.level, n.rays)
                }
            };
            line += &format!(
                " (estimated from {} of {RAYS} rays: {}, {}; noise σ {:.1}{})",
                m.rays_exited(),
                side("darker", &m.darker),
                side("brighter", &m.brighter),
                m.noise,
                m.soft_tissue
                    .map_or(String::new(), |s| format!("; CT, soft tissue at {s:.0} HU"))
            );
        }
        None => line += " (as given)",
    }
    line
}
