//! Self-intersections of an OFF mesh, timed: the Rust side of the comparison against CGAL
//! (`scripts/compare_self_intersection.py`, `cpp_tests/cgal_self_intersections.cpp`).
//!
//! Usage: `self_intersections_off <mesh.off> <pairs.txt> [repeats] [threads]`
//!
//! Runs the search `repeats` times (default 3) on a rayon pool of `threads` threads (default 2),
//! writes the pairs of the last run one per line as "a b", and prints
//! `ours_seconds <best time> pairs <count> read_seconds <time to read the file>`.

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use balloonseg::self_intersection::self_intersections;

fn main() {
    if let Err(message) = run() {
        eprintln!("self_intersections_off: {message}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(input), Some(output)) = (args.first(), args.get(1)) else {
        return Err(
            "usage: self_intersections_off <mesh.off> <pairs.txt> [repeats] [threads]".into(),
        );
    };
    let number = |i: usize, default: usize| -> Result<usize, String> {
        args.get(i).map_or(Ok(default), |a| {
            a.parse::<usize>()
                .ok()
                .filter(|&n| n > 0)
                .ok_or_else(|| format!("argument {} must be a positive integer, not {a:?}", i + 1))
        })
    };
    let (repeats, threads) = (number(2, 3)?, number(3, 2)?);

    let start = Instant::now();
    let mesh = balloonseg::io::off::read(&PathBuf::from(input)).map_err(|e| e.to_string())?;
    let read_seconds = start.elapsed().as_secs_f64();

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| e.to_string())?;
    let mut best = f64::INFINITY;
    let mut pairs = Vec::new();
    for _ in 0..repeats {
        let start = Instant::now();
        pairs = pool
            .install(|| self_intersections(&mesh))
            .map_err(|e| e.to_string())?;
        best = best.min(start.elapsed().as_secs_f64());
    }

    let file = std::fs::File::create(output).map_err(|e| format!("cannot create {output}: {e}"))?;
    let mut out = std::io::BufWriter::new(file);
    for (a, b) in &pairs {
        writeln!(out, "{a} {b}").map_err(|e| format!("cannot write {output}: {e}"))?;
    }
    out.flush()
        .map_err(|e| format!("cannot write {output}: {e}"))?;
    println!(
        "ours_seconds {best:.6} pairs {} read_seconds {read_seconds:.3}",
        pairs.len()
    );
    Ok(())
}
