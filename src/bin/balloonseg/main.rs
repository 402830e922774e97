//! The `balloonseg` command line (docs/interfaces.md, "Command line"): thin wrappers that read
//! files, call the library and write files. Every error ends the process with a one-line reason and
//! a non-zero exit code.

mod batch;
mod check;
mod demo;
mod distance;
mod hausdorff;
mod info;
mod isosurface;
mod param_flags;
mod phantom;
mod render;
mod segment;
mod simplify;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "balloonseg",
    version,
    about = "Balloon segmentation of CT/MR volumes and its geometry kernels"
)]
struct Cli {
    /// Worker threads (0 = all cores). Results are identical for any count.
    #[arg(long, global = true, default_value_t = 0)]
    threads: usize,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Segment the structure around the seed(s): the balloon, grown and repaired, as a mesh.
    Segment(segment::Args),
    /// Segment a cohort: one case per row of a CSV manifest (image, seeds, parameters), each
    /// as `segment` would, with a results table; failed cases are recorded, finished ones
    /// skipped on a rerun.
    Batch(batch::Args),
    /// Marching cubes of a volume at a level, written as a welded mesh in world mm.
    Isosurface(isosurface::Args),
    /// What a volume file holds, as JSON: dims, spacing, origin, direction, voxel type, and the
    /// time the read took.
    Info(info::Args),
    /// Topology and geometry of a mesh as JSON: closed, manifold, oriented, genus, ...
    Check(check::Args),
    /// Signed distance (mm, negative inside) from a closed mesh on the grid of a volume.
    Distance(distance::Args),
    /// Two-sided Hausdorff distance between two meshes (exact point-to-triangle distances from
    /// samples on each), as JSON.
    Hausdorff(hausdorff::Args),
    /// Write a synthetic test volume: a shape (sphere, torus, double-torus, y-vessel,
    /// touching-tubes, fading-tube) or a variant of a family (ct-scene, thin-wall,
    /// touching-pair, thin-vessels, stent, vessel-chamber).
    Phantom(phantom::Args),
    /// Run on the built-in phantoms, no input needed; writes meshes and a report.
    Demo(demo::Args),
    /// A PNG of a mesh (or several, each in its colour) over three slices of its volume, and a
    /// shaded 3D view of it.
    Render(render::Args),
    /// Fewer triangles within a distance of the input, both ways, keeping the mesh closed,
    /// manifold, outward, free of self-intersections and of the same genus.
    Simplify(simplify::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Err(e) = balloonseg::balloon::params::check_threads(cli.threads) {
        return fail(&e.to_string());
    }
    let pool = match rayon::ThreadPoolBuilder::new()
        .num_threads(cli.threads)
        .build()
    {
        Ok(pool) => pool,
        Err(e) => return fail(&format!("cannot start {} threads: {e}", cli.threads)),
    };
    let result = pool.install(|| match cli.command {
        Command::Segment(args) => segment::run(&args, cli.threads),
        Command::Batch(args) => batch::run(&args, cli.threads),
        Command::Isosurface(args) => isosurface::run(&args),
        Command::Info(args) => info::run(&args),
        Command::Check(args) => check::run(&args),
        Command::Distance(args) => distance::run(&args),
        Command::Hausdorff(args) => hausdorff::run(&args),
        Command::Phantom(args) => phantom::run(&args),
        Command::Demo(args) => demo::run(&args, cli.threads),
        Command::Render(args) => render::run(&args),
        Command::Simplify(args) => simplify::run(&args),
    });
    match result {
        Ok(code) => code,
        Err(e) => fail(&e.to_string()),
    }
}

fn fail(reason: &str) -> ExitCode {
    eprintln!("balloonseg: error: {reason}");
    ExitCode::FAILURE
}

/// Writes `text` to standard output. A reader that went away (`balloonseg check … | head -3`)
/// is not an error: it wants no more. `println!` panicked on the broken pipe.
fn print_out(text: &str) -> balloonseg::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(balloonseg::Error::io(
            format!("cannot write to standard output: {e}"),
        )),
        _ => Ok(()),
    }
}

/// The file name for messages: what the user typed.
fn shown(path: &std::path::Path) -> String {
    path.display().to_string()
}

/// An output path argument, shared by the commands that write one file.
#[derive(clap::Args)]
struct Output {
    /// Output file; the format follows the extension.
    #[arg(short = 'o', long = "output")]
    path: PathBuf,
}

/// Parses "x,y,z" into three numbers.
fn parse_triple(text: &str) -> Result<[f64; 3], String> {
    parse_numbers(text, "x,y,z")
}

/// Parses "lo,hi" into two numbers.
fn parse_pair(text: &str) -> Result<[f64; 2], String> {
    parse_numbers(text, "lo,hi")
}

/// Parses `N` comma-separated numbers; `form` names them for the message.
fn parse_numbers<const N: usize>(text: &str, form: &str) -> Result<[f64; N], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("'{text}' is not {N} numbers {form}: {e}"))?;
    values
        .try_into()
        .map_err(|v: Vec<f64>| format!("'{text}' has {} numbers; give {N}: {form}", v.len()))
}
