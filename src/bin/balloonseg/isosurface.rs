//! `balloonseg isosurface VOLUME --level L -o MESH`

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use balloonseg::{io, marching_cubes::marching_cubes, Result};

#[derive(clap::Args)]
pub struct Args {
    /// Input volume (.mha, .mhd, .nrrd, .nhdr, .nii, .nii.gz, .vti, .vtk).
    volume: PathBuf,
    /// The iso-value; normals point towards higher values.
    #[arg(long, allow_negative_numbers = true)]
    level: f64,
    #[command(flatten)]
    output: crate::Output,
}

pub fn run(args: &Args) -> Result<ExitCode> {
    let image = io::read_image(&args.volume)?;
    let start = Instant::now();
    let mesh = marching_cubes(&image.view(), args.level)?;
    let seconds = start.elapsed().as_secs_f64();
    io::write_mesh(&args.output.path, &mesh, &[])?;
    eprintln!(
        "{}: {} points, {} triangles ({seconds:.3} s)",
        crate::shown(&args.output.path),
        mesh.points().len(),
        mesh.triangles().len()
    );
    Ok(ExitCode::SUCCESS)
}
