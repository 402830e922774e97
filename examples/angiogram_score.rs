//! Scores a mesh against the clinical-size angiogram it was segmented from
//! (`phantom::Angiogram`, drawn again from its variant number and grid; not rendered): Dice
//! against the analytic vessel tree, the share of the tree covered, validity and genus, as one
//! JSON line. `scripts/fullsize_run.py` runs it after timing `balloonseg segment`.
//!
//! `angiogram_score --variant N --dims X,Y,Z MESH`

use std::path::Path;

use balloonseg::phantom::Angiogram;
use balloonseg::{io, mesh_checks, Error, Result};

fn main() {
    if let Err(e) = run() {
        eprintln!("angiogram_score: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<()> {
    let usage = || Error::invalid_argument("usage: angiogram_score --variant N --dims X,Y,Z MESH");
    let mut args = std::env::args().skip(1);
    let (mut variant, mut dims, mut mesh) = (None, None, None);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--variant" => variant = args.next().and_then(|v| v.parse::<u64>().ok()),
            "--dims" => {
                dims = args.next().and_then(|v| {
                    let d: Vec<usize> = v.split(',').filter_map(|x| x.parse().ok()).collect();
                    <[usize; 3]>::try_from(d).ok()
                })
            }
            _ => mesh = Some(arg),
        }
    }
    let (Some(variant), Some(dims), Some(mesh)) = (variant, dims, mesh) else {
        return Err(usage());
    };
    let angiogram = Angiogram::new(variant, dims)?;
    let mesh = io::read_mesh(Path::new(&mesh))?;
    let report = mesh_checks::check(&mesh);
    let overlap = angiogram.overlap(&mesh)?;
    println!(
        "{{\"dice\": {:.4}, \"covered\": {:.4}, \"valid\": {}, \"genus\": {}, \"truth_genus\": {}}}",
        overlap.dice(),
        overlap.covered(),
        report.is_valid_closed_surface(),
        report.genus().map_or("null".to_string(), |g| g.to_string()),
        angiogram.genus()
    );
    Ok(())
}
