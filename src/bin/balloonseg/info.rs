//! `balloonseg info VOLUME [--series UID]`: what a volume file (or a DICOM series' folder) holds, as JSON on standard output — the
//! geometry the balloon will use (dims, spacing, origin, direction), the voxel type and the
//! time the read took. The check of a header before a long run, and the reader's benchmark
//! (`scripts/read_speed.py`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use balloonseg::{io, Result};
use serde_json::json;

#[derive(clap::Args)]
pub struct Args {
    /// Volume file (.mha, .mhd, .nrrd, .nhdr, .nii, .nii.gz, .vti, .vtk), or a folder holding a
    /// DICOM series.
    volume: PathBuf,
    /// The DICOM series to read (its SeriesInstanceUID) when the folder holds several.
    #[arg(long)]
    series: Option<String>,
    /// Also write the volume as it was read (.mha, .nrrd, .nii.gz): a DICOM series converted,
    /// and the voxels a reader comparison needs.
    #[arg(long)]
    write: Option<PathBuf>,
}

pub fn run(args: &Args) -> Result<ExitCode> {
    let start = Instant::now();
    let image = io::read_image_series(&args.volume, args.series.as_deref())?;
    let seconds = start.elapsed().as_secs_f64();
    if let Some(path) = &args.write {
        io::write_image(path, &image)?;
    }
    let geometry = image.geometry();
    let scalar = image.buffer().scalar_type();
    let voxels = image.buffer().len();
    let summary = json!({
        "file": crate::shown(&args.volume),
        "dims": image.dims(),
        "spacing": geometry.spacing(),
        "origin": geometry.origin(),
        "direction": geometry.direction(),
        "scalar_type": scalar.name(),
        "voxel_bytes": voxels * scalar.size_in_bytes(),
        "read_seconds": seconds,
    });
    crate::print_out(&format!(
        "{}\n",
        serde_json::to_string_pretty(&summary).expect("plain JSON values")
    ))?;
    Ok(ExitCode::SUCCESS)
}
