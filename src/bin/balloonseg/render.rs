//! `balloonseg render MESH [MESH ...] --volume VOLUME -o FILE.png [--centre X,Y,Z] [--index]
//! [--window LO,HI] [--size PX]`: the library's overview picture of a segmentation, several
//! meshes each in its own colour.

use std::path::PathBuf;
use std::process::ExitCode;

use balloonseg::render::{self, RenderObject, RenderOptions};
use balloonseg::{io, Result};
use glam::DVec3;

#[derive(clap::Args)]
pub struct Args {
    /// Mesh (.vtp, .vtk, .ply, .stl, .obj, .off) in the volume's world space. Several meshes
    /// are drawn each in its own colour, in the order given: yellow, violet, green, orange,
    /// pink, teal, brown, lime (then again), with a legend of their file names.
    #[arg(required = true, value_name = "MESH")]
    meshes: Vec<PathBuf>,
    /// The volume to draw the mesh on (.mha, .mhd, .nrrd, .nhdr, .nii, .nii.gz, .vti, .vtk).
    #[arg(long)]
    volume: PathBuf,
    #[command(flatten)]
    output: crate::Output,
    /// The point the three slices pass through, "x,y,z" in world mm (LPS) (default: the middle
    /// of the box holding every mesh).
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
    let meshes = args
        .meshes
        .iter()
        .map(|path| io::read_mesh(path))
        .collect::<Result<Vec<_>>>()?;
    // The legend names each mesh by its file name without the extension.
    let labels: Vec<String> = args
        .meshes
        .iter()
        .map(|path| {
            path.file_stem()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    let objects: Vec<RenderObject<'_>> = meshes
        .iter()
        .zip(&labels)
        .map(|(mesh, label)| RenderObject { mesh, label })
        .collect();
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
    let picture = render::render_objects(&image.view(), &objects, &options)?;
    render::write_png(&args.output.path, &picture)?;
    eprintln!(
        "{}: {} × {} pixels",
        crate::shown(&args.output.path),
        picture.width(),
        picture.height()
    );
    Ok(ExitCode::SUCCESS)
}
