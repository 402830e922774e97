//! `balloonseg segment INPUT --seed [L:]X,Y,Z [--seed ...] [--stop X,Y,Z ...]
//! [--roi X0,Y0,Z0,X1,Y1,Z1] [--index] [--ras] -o OUTPUT [--stats F] [--png F]`

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use balloonseg::balloon::image_model::seed_statistics::{Neighbours, RAYS};
use balloonseg::balloon::{
    segment_objects, ObjectSeeds, ObjectsRequest, Phase, ProgressCallback, Region,
    SegmentationStats, SegmentedObject, VertexState,
};
use balloonseg::io::{self, CellData, PointData, PointValues};
use balloonseg::render::{self, RenderObject, RenderOptions};
use balloonseg::{
    mesh_checks, self_intersection::count_self_intersections, Error, Geometry, Result, TriMesh,
};
use glam::DVec3;
use serde_json::json;

use crate::param_flags::ParamFlags;

#[derive(clap::Args)]
pub struct Args {
    /// Input volume (.mha, .mhd, .nrrd, .nhdr, .nii, .nii.gz, .vti, .vtk), or a folder holding
    /// a DICOM series.
    input: PathBuf,
    /// The DICOM series to read (its SeriesInstanceUID) when the input folder holds several.
    #[arg(long)]
    series: Option<String>,
    /// A seed inside a structure, "x,y,z" in world mm (LPS), for object 1; "L:x,y,z" for
    /// object L (a positive integer). Repeat for more seeds: seeds of one label grow as one
    /// object, objects of different labels stop at each other.
    #[arg(long = "seed", required = true, value_parser = parse_labelled_seed, allow_hyphen_values = true)]
    seeds: Vec<(u32, [f64; 3])>,
    /// A competitor's seed, "x,y,z": a balloon that only keeps the objects out of its structure
    /// and is left out of the output (the heart, to get the aorta alone). Repeatable.
    #[arg(long = "stop", value_parser = crate::parse_triple, allow_hyphen_values = true)]
    stops: Vec<[f64; 3]>,
    /// A box no object grows beyond, "x0,y0,z0,x1,y1,z1": two opposite corners in world mm
    /// (RAS with --ras; never voxel indices).
    #[arg(long, value_parser = parse_box, allow_hyphen_values = true)]
    roi: Option<[f64; 6]>,
    /// Seeds and stop seeds are voxel indices i,j,k instead of world coordinates.
    #[arg(long, conflicts_with = "ras")]
    index: bool,
    /// Seeds, stop seeds and the region are in RAS world coordinates, as 3D Slicer shows them.
    #[arg(long)]
    ras: bool,
    /// Output file; the format follows the extension. With several objects, a literal
    /// "{label}" in the path writes one file per object; otherwise every object goes into one
    /// .vtp, .vtk or .ply file with a triangle array `object` holding its label.
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
    /// Write run statistics as JSON to this file (with several objects, a list of them).
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Write a picture of the result to this PNG file: three slices through the first seed with
    /// the meshes' sections, and a 3D view; several objects each in their own colour (yellow,
    /// violet, green, orange, ... in increasing label order), with a legend of their labels.
    #[arg(long)]
    png: Option<PathBuf>,
    /// The balloon's parameters, one flag each (see docs/interfaces.md).
    #[command(flatten)]
    params: ParamFlags,
}

/// The literal an output path names each object's file by.
const LABEL_PLACEHOLDER: &str = "{label}";

/// Parses "x,y,z" (label 1) or "L:x,y,z".
fn parse_labelled_seed(text: &str) -> std::result::Result<(u32, [f64; 3]), String> {
    match text.split_once(':') {
        None => Ok((1, crate::parse_triple(text)?)),
        Some((label, point)) => {
            let label = label.trim().parse::<u32>().map_err(|e| {
                format!("'{label}' in '{text}' is not a label (a positive integer): {e}")
            })?;
            Ok((label, crate::parse_triple(point)?))
        }
    }
}

fn parse_box(text: &str) -> std::result::Result<[f64; 6], String> {
    crate::parse_numbers(text, "x0,y0,z0,x1,y1,z1")
}

impl Args {
    fn world(&self, point: [f64; 3], geometry: &Geometry) -> DVec3 {
        let s = DVec3::from(point);
        if self.index {
            geometry.index_to_world(s)
        } else if self.ras {
            DVec3::new(-s.x, -s.y, s.z)
        } else {
            s
        }
    }

    /// The objects in increasing label order, the stop seeds and the region, in world mm.
    fn request(&self, geometry: &Geometry) -> Result<ObjectsRequest> {
        let mut objects: Vec<ObjectSeeds> = Vec::new();
        let mut labels: Vec<u32> = self.seeds.iter().map(|&(label, _)| label).collect();
        labels.sort_unstable();
        labels.dedup();
        for label in labels {
            objects.push(ObjectSeeds {
                label,
                seeds: self
                    .seeds
                    .iter()
                    .filter(|&&(l, _)| l == label)
                    .map(|&(_, p)| self.world(p, geometry))
                    .collect(),
            });
        }
        let region = self
            .roi
            .map(|b| {
                let corner = |p: [f64; 3]| {
                    let p = DVec3::from(p);
                    if self.ras {
                        DVec3::new(-p.x, -p.y, p.z)
                    } else {
                        p
                    }
                };
                Region::new(corner([b[0], b[1], b[2]]), corner([b[3], b[4], b[5]]))
            })
            .transpose()?;
        Ok(ObjectsRequest {
            objects,
            stops: self
                .stops
                .iter()
                .map(|&p| self.world(p, geometry))
                .collect(),
            region,
        })
    }
}

pub fn run(args: &Args, threads: usize) -> Result<ExitCode> {
    let progress: Option<ProgressCallback> = std::io::stderr()
        .is_terminal()
        .then(|| Box::new(draw_progress) as ProgressCallback);
    segment(args, threads, progress, Chatter::Stderr)?;
    Ok(ExitCode::SUCCESS)
}

/// Whether `segment` tells standard error about the window, its warnings and the files it
/// writes (a command run alone), or keeps quiet (a case of a batch, whose table says it).
#[derive(Clone, Copy, PartialEq)]
pub enum Chatter {
    Stderr,
    Quiet,
}

/// The command's whole work with its `threads` and `progress`: read, segment, write the mesh
/// and the optional statistics and picture. Returns the objects.
pub fn segment(
    args: &Args,
    threads: usize,
    progress: Option<ProgressCallback>,
    chatter: Chatter,
) -> Result<Vec<SegmentedObject>> {
    let start = Instant::now();
    let per_object = args.output.to_string_lossy().contains(LABEL_PLACEHOLDER);
    let drawn = progress.is_some();
    let series = args.series.as_deref();
    let image = if drawn {
        let bar = |fraction, stage: io::ReadStage| draw_bar(fraction, stage.name());
        io::read_image_reporting(&args.input, series, Box::new(bar))?
    } else {
        io::read_image_series(&args.input, series)?
    };
    let geometry = *image.geometry();
    let request = args.request(&geometry)?;
    if request.objects.len() > 1 && !per_object {
        io::check_holds_cell_data(&args.output, "object")?;
    }
    let params = args.params.params(threads)?;
    let max_iterations = params.max_iterations;
    let result = segment_objects(image.view(), params, &request, progress);
    if drawn {
        eprintln!();
    }
    let objects = result?;
    if chatter == Chatter::Stderr {
        for object in &objects {
            let name = if objects.len() > 1 {
                format!("object {}: ", object.label)
            } else {
                String::new()
            };
            eprintln!("{name}{}", window_line(&object.stats));
            if object.stats.out_of_steps {
                eprintln!(
                    "warning: {name}the balloon was still growing after max_iterations \
                     ({max_iterations}) steps: it has most likely leaked out of the structure \
                     (look at it with --png); narrow the window (give a smaller tolerance), or \
                     raise --max-iterations if the structure is really that long"
                );
            }
        }
    }
    write_meshes(&args.output, &objects, per_object, chatter)?;
    if let Some(path) = &args.stats {
        let total = start.elapsed().as_secs_f64();
        let stats = match &objects[..] {
            [one] => stats_json(&one.mesh, &one.stats, total)?,
            _ => json!({
                "objects": objects.iter().map(|o| {
                    let mut entry = stats_json(&o.mesh, &o.stats, total)?;
                    entry["label"] = json!(o.label);
                    entry["seeds"] = json!(o.seeds.iter().map(|s| s.to_array()).collect::<Vec<_>>());
                    Ok(entry)
                }).collect::<Result<Vec<_>>>()?,
                "stop_seeds": request.stops.iter().map(|s| s.to_array()).collect::<Vec<_>>(),
                "seconds_total": total,
            }),
        };
        std::fs::write(
            path,
            serde_json::to_string_pretty(&stats).expect("plain JSON values"),
        )
        .map_err(|e| Error::io(format!("cannot write {}: {e}", crate::shown(path))))?;
    }
    if let Some(path) = &args.png {
        let labels: Vec<String> = objects.iter().map(|o| o.label.to_string()).collect();
        let shown: Vec<RenderObject<'_>> = objects
            .iter()
            .zip(&labels)
            .map(|(o, label)| RenderObject {
                mesh: &o.mesh,
                label,
            })
            .collect();
        let options = RenderOptions {
            centre: Some(request.objects[0].seeds[0]),
            window: Some(objects[0].stats.display_window()),
            ..RenderOptions::default()
        };
        render::write_png(
            path,
            &render::render_objects(&image.view(), &shown, &options)?,
        )?;
    }
    Ok(objects)
}

/// Every object's mesh in one, and the label of each triangle.
fn merged(objects: &[SegmentedObject]) -> Result<(TriMesh, Vec<i32>)> {
    let mut all = objects[0].mesh.clone();
    for object in &objects[1..] {
        all.append(&object.mesh)?;
    }
    let labels = objects
        .iter()
        .flat_map(|o| std::iter::repeat(o.label as i32).take(o.mesh.triangles().len()))
        .collect();
    Ok((all, labels))
}

/// One file per object where `path` holds the placeholder, else one file with a `vertex_state`
/// point array and, for several objects, an `object` triangle array.
fn write_meshes(
    path: &Path,
    objects: &[SegmentedObject],
    per_object: bool,
    chatter: Chatter,
) -> Result<()> {
    let write = |path: &Path, mesh: &TriMesh, states: &[VertexState], labels: Option<&[i32]>| {
        let state_bytes: Vec<u8> = states.iter().map(|&s| s as u8).collect();
        let point_data = [PointData {
            name: "vertex_state",
            values: PointValues::U8(&state_bytes),
        }];
        match labels {
            Some(values) => io::write_mesh_with_cells(
                path,
                mesh,
                &point_data,
                &[CellData {
                    name: "object",
                    values,
                }],
            )?,
            None => io::write_mesh(path, mesh, &point_data)?,
        }
        if chatter == Chatter::Stderr {
            let moving = states.iter().filter(|&&s| s == VertexState::Moving).count();
            eprintln!(
                "{}: {} points, {} triangles ({moving} vertices still moving)",
                crate::shown(path),
                mesh.points().len(),
                mesh.triangles().len()
            );
        }
        Ok(())
    };
    if per_object {
        for object in objects {
            let named = path
                .to_string_lossy()
                .replace(LABEL_PLACEHOLDER, &object.label.to_string());
            write(Path::new(&named), &object.mesh, &object.states, None)?;
        }
        return Ok(());
    }
    match objects {
        [one] => write(path, &one.mesh, &one.states, None),
        _ => {
            let (all, labels) = merged(objects)?;
            let states: Vec<VertexState> = objects
                .iter()
                .flat_map(|o| o.states.iter().copied())
                .collect();
            write(path, &all, &states, Some(&labels))
        }
    }
}

fn draw_progress(fraction: f64, phase: Phase) -> bool {
    draw_bar(fraction, phase.name())
}

/// Redraws the bar on standard error's line: `fraction` done of the stage `name`.
pub fn draw_bar(fraction: f64, name: &str) -> bool {
    let width = 30;
    let filled = (fraction * width as f64).round() as usize;
    let mut err = std::io::stderr();
    let _ = write!(
        err,
        "\r[{}{}] {:>3.0}% {:<18}",
        "#".repeat(filled),
        " ".repeat(width - filled),
        fraction * 100.0,
        name
    );
    let _ = err.flush();
    true
}

fn stats_json(
    mesh: &balloonseg::TriMesh,
    stats: &SegmentationStats,
    total: f64,
) -> Result<serde_json::Value> {
    let report = mesh_checks::check(mesh);
    let s = &stats.seconds;
    Ok(json!({
        "vertices": report.vertices,
        "triangles": report.triangles,
        "euler_characteristic": report.euler_characteristic,
        "genus": report.genus(),
        "components": report.components,
        "closed": report.closed(),
        "manifold": report.manifold(),
        "outward": report.outward(),
        "self_intersecting_pairs": count_self_intersections(mesh)?.saturated(),
        "iterations": stats.iterations,
        "reparametrizations": stats.reparametrizations,
        "out_of_steps": stats.out_of_steps,
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
            "simplification": s.simplification,
            "total": total,
        },
    }))
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
