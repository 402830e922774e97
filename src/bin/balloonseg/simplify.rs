//! `balloonseg simplify MESH --max-error MM -o OUT`: error-bounded simplification of any closed
//! mesh (the library's `simplification::simplify`).

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use balloonseg::{io, simplification::simplify_with_progress, Result};

#[derive(clap::Args)]
pub struct Args {
    /// Input mesh (.vtp, .vtk, .ply, .stl, .obj, .off): closed, 2-manifold, consistently
    /// oriented (either way; the result keeps it) and free of self-intersections.
    mesh: PathBuf,
    /// The largest distance (mm) allowed between the input and the result, both ways.
    #[arg(long = "max-error", allow_negative_numbers = true)]
    max_error: f64,
    #[command(flatten)]
    output: crate::Output,
}

pub fn run(args: &Args) -> Result<ExitCode> {
    let mesh = io::read_mesh(&args.mesh)?;
    let start = Instant::now();
    // A bar on a terminal: a mesh of a million triangles takes minutes.
    let drawn = std::io::stderr().is_terminal();
    let simplified = simplify_with_progress(&mesh, args.max_error, |fraction| {
        if drawn {
            crate::segment::draw_bar(fraction, "simplification");
        }
        true
    });
    if drawn {
        eprintln!();
    }
    let simplified = simplified
        .map_err(|e| e.context(format!("cannot simplify {}", crate::shown(&args.mesh))))?;
    let seconds = start.elapsed().as_secs_f64();
    io::write_mesh(&args.output.path, &simplified.mesh, &[])?;
    eprintln!(
        "{}: {} -> {} triangles within {} mm ({seconds:.3} s)",
        crate::shown(&args.output.path),
        mesh.triangles().len(),
        simplified.mesh.triangles().len(),
        args.max_error
    );
    Ok(ExitCode::SUCCESS)
}
