//! `balloonseg hausdorff A B [--steps N]`: the two-sided Hausdorff distance between two meshes
//! (`evaluation::hausdorff_distance`) as JSON on standard output.

use std::path::PathBuf;
use std::process::ExitCode;

use balloonseg::{evaluation::hausdorff_distance, io, Result};
use serde_json::json;

#[derive(clap::Args)]
pub struct Args {
    /// First mesh (.vtp, .vtk, .ply, .stl, .obj, .off).
    a: PathBuf,
    /// Second mesh.
    b: PathBuf,
    /// Samples per triangle edge on each mesh (1: the vertices only); the distances are exact
    /// from each sample to the other mesh's nearest triangle.
    #[arg(long, default_value_t = 4)]
    steps: usize,
}

pub fn run(args: &Args) -> Result<ExitCode> {
    let (a, b) = (io::read_mesh(&args.a)?, io::read_mesh(&args.b)?);
    let (forward, backward) = hausdorff_distance(&a, &b, args.steps)?;
    let summary = json!({
        "a": crate::shown(&args.a),
        "b": crate::shown(&args.b),
        "a_to_b_mm": forward,
        "b_to_a_mm": backward,
        "hausdorff_mm": forward.max(backward),
        "steps": args.steps,
    });
    let json = serde_json::to_string_pretty(&summary).expect("plain JSON values");
    crate::print_out(&format!("{json}\n"))?;
    Ok(ExitCode::SUCCESS)
}
