//! `balloonseg render MESH --volume VOLUME -o FILE.png [--centre X,Y,Z] [--index]
//! [--window LO,HI] [--size PX]`: the library's overview picture of a segmentation.

use std::path::PathBuf;
use std::process::ExitCode;

use balloonseg::render::{self, RenderOptions};
use balloonseg::{io, Result};
use glam::DVec3;

#[derive(clap::Args)]
pub struct Args {
    /// Mesh (.vtp, .vtk, .ply, .stl, .obj, .off) in the volume's world space.
    mesh: PathBuf,
    /// The volume to draw the mesh on (.mha, .mhd, .nrrd, .nhdr, .nii, .nii.gz, .vti, .vtk).
    #[arg(long)]
    volume: PathBuf,
    #[command(flatten)]
    output: crate::Output,
    /// The point the three slices pass through, "x,y,z" in world mm (LPS) (default: the middle
    /// of the mesh's bounds).
    #[arg(long, value_parser = crate::parse_triple, allow_hyphen_values = true)]
    centre: Option<[f64; 3]>,
    /// --centre is a voxel index i,j,k of VOLUME instead of world coordinates.
    #[arg(long, requires = "centre")]
    index: bool,
    /// Display window "lo,hi": lo black, hi white (default: the 1st to 99th percentile of
    /// the slices).
    #[arg(long, value_parser = crate::parse_pair, allow_hyphen_values = true)]
    window: Option<[f64; 2]>,
    /// Side of each of the four panels in pixels; the picture is 2 × PX + 2 square.
    #[arg(long, default_value_t = RenderOptions::default().panel_px)]
    size: u32,
}

pub fn run(args: &Args) -> Result<ExitCode> {
    let mesh = io::read_mesh(&args.mesh)?;
    let image = io::read_image(&args.volume)?;
    let centre = args.centre.map(|c| {
        let c = DVec3::from(c);
        if args.index {
            image.geometry().index_to_world(c)
        } else {
            c
        }
    });
    let options = RenderOptions {
        centre,
        window: args.window.map(|[lo, hi]| (lo, hi)),
        panel_px: args.size,
        field_mm: None,
    };
    let picture = render::render_overview(&image.view(), Some(&mesh), &options)?;
    render::write_png(&args.output.path, &picture)?;
    eprintln!(
        "{}: {} × {} pixels",
        crate::shown(&args.output.path),
        picture.width(),
        picture.height()
    );
    Ok(ExitCode::SUCCESS)
}
