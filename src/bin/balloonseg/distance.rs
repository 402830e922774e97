//! `balloonseg distance MESH --like VOLUME -o VOLUME`: the signed distance map of a closed mesh
//! on another volume's grid (same dims, spacing, origin and direction).

use std::path::PathBuf;
use std::process::ExitCode;

use balloonseg::signed_distance::{signed_distance, SignedDistanceOptions};
use balloonseg::{io, Image, Result, VoxelBuffer};

#[derive(clap::Args)]
pub struct Args {
    /// Closed mesh (.vtp, .vtk, .ply, .stl, .obj, .off) in the volume's world space.
    mesh: PathBuf,
    /// The volume whose grid the distance is sampled on.
    #[arg(long)]
    like: PathBuf,
    /// Width in voxels of the band of exact distances; outside it the map holds ±band.
    #[arg(long, default_value_t = SignedDistanceOptions::default().band_voxels)]
    band: f64,
    /// Write float64 voxels instead of float32.
    #[arg(long)]
    double: bool,
    #[command(flatten)]
    output: crate::Output,
}

pub fn run(args: &Args) -> Result<ExitCode> {
    let mesh = io::read_mesh(&args.mesh)?;
    let like = io::read_image(&args.like)?;
    let options = SignedDistanceOptions {
        band_voxels: args.band,
        ..SignedDistanceOptions::default()
    };
    let distance = signed_distance(&mesh, &mesh, like.dims(), like.geometry(), &options)?;
    let distance = if args.double {
        distance
    } else {
        narrow_to_f32(distance)?
    };
    io::write_image(&args.output.path, &distance)?;
    Ok(ExitCode::SUCCESS)
}

/// Float32 is what ITK and VTK pipelines expect of a distance map, and keeps 1e-6 mm precision
/// at the band's distances.
fn narrow_to_f32(image: Image) -> Result<Image> {
    let (dims, geometry) = (image.dims(), *image.geometry());
    let buffer = match image.into_buffer() {
        VoxelBuffer::F64(v) => VoxelBuffer::F32(v.into_iter().map(|x| x as f32).collect()),
        other => other,
    };
    Image::new(buffer, dims, geometry)
}
