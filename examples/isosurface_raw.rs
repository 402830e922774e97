//! Marching cubes of a raw little-endian float32 volume, timed, for comparison with other
//! implementations (see `scripts/compare_marching_cubes.py`).
//!
//! ```text
//! isosurface_raw FILE NX NY NZ [--level L] [--spacing SX SY SZ] [--origin OX OY OZ]
//!                [--direction D00 D01 D02 D10 D11 D12 D20 D21 D22] [--threads N] [--repeat R]
//!                [--points OUT] [--triangles OUT]
//! ```
//! Prints one JSON object: counts, best and all timings of `marching_cubes` (file reading
//! excluded), area and signed volume. `--points` writes the points as f64 LE triples,
//! `--triangles` the triangles as u32 LE triples.

use std::process::ExitCode;
use std::time::Instant;

use balloonseg::marching_cubes::marching_cubes;
use balloonseg::{Geometry, TriMesh, TypedVolume, Volume};

const USAGE: &str = "usage: isosurface_raw FILE NX NY NZ [--level L] [--spacing SX SY SZ] \
    [--origin OX OY OZ] [--direction D00 .. D22 (9 values, row-major)] [--threads N] \
    [--repeat R] [--points OUT] [--triangles OUT]";

struct Options {
    file: String,
    dims: [usize; 3],
    level: f64,
    spacing: [f64; 3],
    origin: [f64; 3],
    direction: [f64; 9],
    threads: usize,
    repeat: usize,
    points: Option<String>,
    triangles: Option<String>,
}

fn parse_args() -> Result<Options, String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 4 {
        return Err(USAGE.to_string());
    }
    let number = |s: &str, what: &str| -> Result<f64, String> {
        s.parse::<f64>()
            .map_err(|_| format!("{what} must be a number, got {s:?}"))
    };
    let count = |s: &str, what: &str| -> Result<usize, String> {
        s.parse::<usize>()
            .map_err(|_| format!("{what} must be a non-negative integer, got {s:?}"))
    };
    let mut options = Options {
        file: args[0].clone(),
        dims: [
            count(&args[1], "NX")?,
            count(&args[2], "NY")?,
            count(&args[3], "NZ")?,
        ],
        level: 0.0,
        spacing: [1.0; 3],
        origin: [0.0; 3],
        direction: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        threads: 1,
        repeat: 1,
        points: None,
        triangles: None,
    };
    let mut rest = args[4..].iter();
    while let Some(flag) = rest.next() {
        let mut values = |n: usize| -> Result<Vec<String>, String> {
            let v: Vec<String> = rest.by_ref().take(n).cloned().collect();
            if v.len() == n {
                Ok(v)
            } else {
                Err(format!("{flag} needs {n} value(s)\n{USAGE}"))
            }
        };
        let mut floats = |n: usize| -> Result<Vec<f64>, String> {
            values(n)?.iter().map(|s| number(s, flag)).collect()
        };
        match flag.as_str() {
            "--level" => options.level = floats(1)?[0],
            "--spacing" => options.spacing.copy_from_slice(&floats(3)?),
            "--origin" => options.origin.copy_from_slice(&floats(3)?),
            "--direction" => options.direction.copy_from_slice(&floats(9)?),
            "--threads" => options.threads = count(&values(1)?[0], flag)?,
            "--repeat" => options.repeat = count(&values(1)?[0], flag)?.max(1),
            "--points" => options.points = Some(values(1)?.remove(0)),
            "--triangles" => options.triangles = Some(values(1)?.remove(0)),
            _ => return Err(format!("unknown option {flag:?}\n{USAGE}")),
        }
    }
    Ok(options)
}

fn run(options: &Options) -> Result<(), String> {
    let bytes =
        std::fs::read(&options.file).map_err(|e| format!("cannot read {}: {e}", options.file))?;
    let expected = options.dims.iter().product::<usize>() * 4;
    if bytes.len() != expected {
        return Err(format!(
            "{} holds {} bytes but {:?} float32 voxels need {expected}",
            options.file,
            bytes.len(),
            options.dims
        ));
    }
    let data: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let geometry = Geometry::new(options.spacing, options.origin, options.direction)
        .map_err(|e| e.to_string())?;
    let volume: Volume = TypedVolume::contiguous(&data, options.dims, geometry)
        .map_err(|e| e.to_string())?
        .into();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads)
        .build()
        .map_err(|e| e.to_string())?;
    let mut seconds = Vec::with_capacity(options.repeat);
    let mut mesh = TriMesh::default();
    for _ in 0..options.repeat {
        // Drop the previous mesh first so that every run allocates its output afresh.
        drop(std::mem::take(&mut mesh));
        let start = Instant::now();
        mesh = pool
            .install(|| marching_cubes(&volume, options.level))
            .map_err(|e| e.to_string())?;
        seconds.push(start.elapsed().as_secs_f64());
    }
    if let Some(path) = &options.points {
        let bytes: Vec<u8> = mesh
            .points()
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f64::to_le_bytes)
            .collect();
        std::fs::write(path, bytes).map_err(|e| format!("cannot write {path}: {e}"))?;
    }
    if let Some(path) = &options.triangles {
        let bytes: Vec<u8> = mesh
            .triangles()
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        std::fs::write(path, bytes).map_err(|e| format!("cannot write {path}: {e}"))?;
    }
    let best = seconds.iter().copied().fold(f64::INFINITY, f64::min);
    let all: Vec<String> = seconds.iter().map(|s| format!("{s:.6}")).collect();
    println!(
        "{{\"points\": {}, \"triangles\": {}, \"threads\": {}, \"seconds\": {best:.6}, \
         \"seconds_all\": [{}], \"area\": {:.17e}, \"volume\": {:.17e}}}",
        mesh.points().len(),
        mesh.triangles().len(),
        options.threads,
        all.join(", "),
        mesh.area(),
        mesh.signed_volume()
    );
    Ok(())
}

fn main() -> ExitCode {
    match parse_args().and_then(|options| run(&options)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("{message}");
            ExitCode::FAILURE
        }
    }
}
