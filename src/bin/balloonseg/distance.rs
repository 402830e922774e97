//! `balloonseg distance MESH --like VOLUME -o VOLUME`: the signed distance map of a closed mesh
//! on another volume's grid (same dims, spacing, origin and direction).

use std::path::PathBuf;
use std::process::ExitCode;

use balloonseg::signed_distance::{signed_distance, SignedDistanceOptions};
use balloonseg::{io, mesh_checks, Error, Image, Result, TriMesh, VoxelBuffer};

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
    let mesh = oriented_outward(io::read_mesh(&args.mesh)?, &args.mesh)?;
    let like = io::read_image(&args.like)?;
    let options = SignedDistanceOptions {
        band_voxels: args.band,
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

/// The sign needs a closed surface; one that faces inward (as vmtk writes them) is turned
/// around rather than giving every voxel the wrong sign.
fn oriented_outward(mesh: TriMesh, path: &std::path::Path) -> Result<TriMesh> {
    let report = mesh_checks::check(&mesh);
    if !report.closed() || !report.consistently_oriented() {
        return Err(Error::invalid_mesh(format!(
            "{}: the mesh must be closed and consistently oriented to tell inside from outside \
             ({} boundary edges, {} non-manifold edges, {} inconsistently oriented edges); check \
             it with `balloonseg check`",
            crate::shown(path),
            report.boundary_edges,
            report.non_manifold_edges,
            report.inconsistently_oriented_edges
        )));
    }
    if report.signed_volume < 0.0 {
        eprintln!(
            "{}: its triangles face inward; using them reversed",
            crate::shown(path)
        );
        return Ok(mesh.flipped());
    }
    Ok(mesh)
}
