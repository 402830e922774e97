//! `balloonseg batch MANIFEST.csv -o DIR [--jobs N] [--format EXT] [--png]`: a cohort, one case
//! per row of the manifest, each run by the code that runs `segment` (so each mesh is the one
//! `segment` writes for the same row), up to `--jobs` at a time.
//!
//! Every row is checked before any case runs: a manifest with an unknown column, a missing
//! image or a value `segment` would refuse is an error that names the row. A case that fails
//! while it runs is recorded with its error and the others go on. The results table
//! (`DIR/results.csv` and `DIR/results.json`) is rewritten after every case, so a batch that is
//! stopped keeps what it finished; a rerun skips the cases whose row is unchanged and whose
//! mesh is there, and runs the failed, changed and new ones.

use std::collections::{HashMap, HashSet};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::Instant;

use balloonseg::balloon::params::PARAMETERS;
use balloonseg::balloon::SegmentedObject;
use balloonseg::{io, mesh_checks, Error, Result};
use clap::Parser;
use serde_json::{json, Value};

use crate::segment::{self, Chatter};

#[derive(clap::Args)]
pub struct Args {
    /// The cohort, a CSV file with a header row and one case per row. Columns: `id` (the case's
    /// name: letters, digits, '.', '_' and '-'; its files are DIR/ID.*), `image` (a volume, or a
    /// path relative to the manifest's folder; a folder holds a DICOM series), `seeds` (one or more of segment's --seed
    /// values, "x,y,z" or "L:x,y,z", separated by ';'; quote the cell), and optionally `stops`
    /// (';'-separated), `roi` ("x0,y0,z0,x1,y1,z1"), `series` (the DICOM series' UID in a
    /// folder holding several), `coordinates` (world, index or ras; default
    /// world) and any of segment's parameter flags without the dashes (`tolerance`,
    /// `edge-length`, `simplify`, ...; an empty cell keeps the default).
    manifest: PathBuf,
    /// The folder for the meshes, their statistics (ID.json) and the results table
    /// (results.csv, results.json); made when missing.
    #[arg(short = 'o', long = "output")]
    dir: PathBuf,
    /// Cases run at the same time; the threads (--threads, 0 = all cores) are shared among
    /// them. Every mesh is the same for any count.
    #[arg(long, default_value_t = 1)]
    jobs: usize,
    /// The meshes' format, by extension: vtp, vtk or ply (these hold several objects' labels),
    /// stl, obj or off.
    #[arg(long, default_value = "vtp")]
    format: String,
    /// Also write a picture of each case (ID.png): slices through its first seed with the
    /// surface over them, to look at before trusting a table.
    #[arg(long)]
    png: bool,
}

/// `segment`'s command line, parsed from a row the way the user would have typed it.
#[derive(Parser)]
#[command(name = "segment", no_binary_name = true)]
struct SegmentLine {
    #[command(flatten)]
    args: segment::Args,
}

/// The manifest's columns other than the parameters.
const COLUMNS: [&str; 7] = [
    "id",
    "image",
    "seeds",
    "stops",
    "roi",
    "series",
    "coordinates",
];

/// One row of the manifest, checked.
struct Case {
    /// The row's line in the manifest, for messages.
    line: u64,
    id: String,
    /// `segment`'s arguments for this case, output files included: what makes a rerun's
    /// finished case the same case.
    command: Vec<String>,
    args: segment::Args,
    mesh: PathBuf,
    /// The files the case writes: its mesh, statistics and picture.
    outputs: Vec<PathBuf>,
}

/// What one case gave.
struct Outcome {
    index: usize,
    seconds: f64,
    result: std::result::Result<Vec<SegmentedObject>, String>,
}

pub fn run(args: &Args, threads: usize) -> Result<ExitCode> {
    if args.jobs == 0 {
        return Err(Error::invalid_argument(
            "--jobs is 0; give the number of cases to run at a time (1 or more)",
        ));
    }
    let extension = mesh_extension(&args.format)?;
    let cases = read_manifest(args, &extension)?;
    std::fs::create_dir_all(&args.dir).map_err(|e| {
        Error::io(format!(
            "cannot make the output folder {}: {e}",
            crate::shown(&args.dir)
        ))
    })?;
    let mut table = ResultsTable::new(&args.dir, &cases);
    let to_run: Vec<usize> = (0..cases.len())
        .filter(|&i| !table.finished(&cases[i]))
        .collect();
    let skipped = cases.len() - to_run.len();
    if skipped > 0 {
        eprintln!(
            "{skipped} of {} cases already finished with the same row (in {}); {} to run",
            cases.len(),
            crate::shown(&table.json_path()),
            to_run.len()
        );
    }
    table.write()?;

    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let total_threads = if threads == 0 { cores } else { threads };
    let jobs = args.jobs.min(to_run.len()).max(1);
    run_cases(
        &cases,
        &to_run,
        jobs,
        (total_threads / jobs).max(1),
        &mut table,
    )?;
    let failed_in_table = table.failed();
    eprintln!(
        "{} cases: {} finished, {} failed; results in {} and {}",
        cases.len(),
        cases.len() - failed_in_table,
        failed_in_table,
        crate::shown(&table.csv_path()),
        crate::shown(&table.json_path())
    );
    Ok(if failed_in_table == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The meshes' extension for `--format` ("vtp", ".VTP"), or an error listing the formats.
fn mesh_extension(format: &str) -> Result<String> {
    let extension = format.trim_start_matches('.').to_ascii_lowercase();
    if io::MESH_FORMATS
        .split(", ")
        .any(|f| f.trim_start_matches('.') == extension)
    {
        Ok(extension)
    } else {
        Err(Error::invalid_argument(format!(
            "--format {format} is not a mesh format; give one of {}",
            io::MESH_FORMATS
        )))
    }
}

/// Runs the cases `to_run`, `jobs` at a time with `threads` each, recording each outcome in
/// `table` (and on disk) as it comes, under one progress bar.
fn run_cases(
    cases: &[Case],
    to_run: &[usize],
    jobs: usize,
    threads: usize,
    table: &mut ResultsTable,
) -> Result<()> {
    let next = AtomicUsize::new(0);
    let (sender, receiver) = mpsc::channel::<Outcome>();
    let mut bar = CohortBar::new(to_run.len());
    let mut failed = 0;
    let result = std::thread::scope(|scope| -> Result<()> {
        for _ in 0..jobs {
            let (sender, next) = (sender.clone(), &next);
            scope.spawn(move || {
                while let Some(&index) = to_run.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let start = Instant::now();
                    let result = run_case(&cases[index], threads);
                    let outcome = Outcome {
                        index,
                        seconds: start.elapsed().as_secs_f64(),
                        result,
                    };
                    if sender.send(outcome).is_err() {
                        break;
                    }
                }
            });
        }
        drop(sender);
        for outcome in receiver {
            let case = &cases[outcome.index];
            bar.clear();
            match &outcome.result {
                Ok(objects) => eprintln!(
                    "{}: {} triangles, {:.1} s{}",
                    case.id,
                    objects
                        .iter()
                        .map(|o| o.mesh.triangles().len())
                        .sum::<usize>(),
                    outcome.seconds,
                    if objects.iter().any(|o| o.stats.out_of_steps) {
                        " (still growing when max_iterations ran out: most likely a leak)"
                    } else {
                        ""
                    }
                ),
                Err(message) => {
                    failed += 1;
                    eprintln!("{}: failed: {message}", case.id);
                }
            }
            table.record(case, &outcome);
            table.write()?;
            bar.advance(failed);
        }
        Ok(())
    });
    bar.clear();
    result
}

/// Runs one case as `segment` would, quietly, after removing what an earlier run of it left
/// (a failed case must not keep an older mesh); a panic (a bug) is that case's failure, not
/// the batch's.
fn run_case(case: &Case, threads: usize) -> std::result::Result<Vec<SegmentedObject>, String> {
    for path in &case.outputs {
        if let Err(e) = std::fs::remove_file(path) {
            if e.kind() != std::io::ErrorKind::NotFound {
                return Err(format!(
                    "cannot remove the earlier {}: {e}",
                    crate::shown(path)
                ));
            }
        }
    }
    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        segment::segment(&case.args, threads, None, Chatter::Quiet)
    }));
    match run {
        Ok(Ok(objects)) => Ok(objects),
        Ok(Err(e)) => Err(e.to_string()),
        Err(panic) => Err(format!(
            "internal error (please report it): {}",
            panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("a panic")
        )),
    }
}

fn manifest_error(args: &Args, line: Option<u64>, message: impl std::fmt::Display) -> Error {
    let place = line.map_or(String::new(), |l| format!(", line {l}"));
    Error::invalid_argument(format!(
        "{}{place}: {message}",
        crate::shown(&args.manifest)
    ))
}

/// Every row of the manifest as a case, each checked as `segment` checks its command line,
/// with its image there and its id unique.
fn read_manifest(args: &Args, extension: &str) -> Result<Vec<Case>> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_path(&args.manifest)
        .map_err(|e| manifest_error(args, None, format!("cannot read it: {e}")))?;
    let headers: Vec<String> = reader
        .headers()
        .map_err(|e| manifest_error(args, Some(1), e))?
        .iter()
        .map(str::to_string)
        .collect();
    let parameters: Vec<&str> = PARAMETERS
        .iter()
        .map(|p| p.flag)
        .filter(|&f| f != "threads")
        .collect();
    for column in &headers {
        if !COLUMNS.contains(&column.as_str()) && !parameters.contains(&column.as_str()) {
            return Err(manifest_error(
                args,
                Some(1),
                format!(
                    "unknown column '{column}'; the columns are {} and the parameters {}",
                    COLUMNS.join(", "),
                    parameters.join(", ")
                ),
            ));
        }
    }
    for required in ["id", "image", "seeds"] {
        if !headers.iter().any(|h| h == required) {
            return Err(manifest_error(
                args,
                Some(1),
                format!("no '{required}' column (the header row names the columns)"),
            ));
        }
    }
    let base = args.manifest.parent().unwrap_or(Path::new(""));
    let mut cases = Vec::new();
    let mut ids = HashSet::new();
    for record in reader.records() {
        let record = record.map_err(|e| manifest_error(args, None, e))?;
        let line = record.position().map_or(0, |p| p.line());
        let cell = |name: &str| {
            headers
                .iter()
                .position(|h| h == name)
                .and_then(|k| record.get(k))
                .filter(|v| !v.is_empty())
        };
        let row_error = |message: String| manifest_error(args, Some(line), message);
        let id = cell("id")
            .ok_or_else(|| row_error("no id".into()))?
            .to_string();
        if !id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'))
            || id.starts_with('.')
        {
            return Err(row_error(format!(
                "the id '{id}' names files: use letters, digits, '.', '_' and '-', not first '.'"
            )));
        }
        if id == "results" {
            return Err(row_error(
                "the id 'results' is the results table's name; give the case another".into(),
            ));
        }
        if !ids.insert(id.clone()) {
            return Err(row_error(format!("the id '{id}' is used twice")));
        }
        let image = base.join(cell("image").ok_or_else(|| row_error("no image".into()))?);
        if !image.exists() {
            return Err(row_error(format!(
                "the image {} is not there",
                crate::shown(&image)
            )));
        }
        let mesh = args.dir.join(format!("{id}.{extension}"));
        let mut command = vec![image.to_string_lossy().into_owned()];
        let mut points = |flag: &str, column: &str| {
            for point in cell(column).into_iter().flat_map(|v| v.split(';')) {
                command.extend([format!("--{flag}"), point.trim().to_string()]);
            }
        };
        points("seed", "seeds");
        points("stop", "stops");
        for column in ["roi", "series"] {
            if let Some(value) = cell(column) {
                command.extend([format!("--{column}"), value.to_string()]);
            }
        }
        match cell("coordinates") {
            None | Some("world") => {}
            Some(c @ ("index" | "ras")) => command.push(format!("--{c}")),
            Some(other) => {
                return Err(row_error(format!(
                    "coordinates '{other}' is not world, index or ras"
                )))
            }
        }
        for (k, column) in headers.iter().enumerate() {
            if let Some(value) = record.get(k).filter(|v| !v.is_empty()) {
                if parameters.contains(&column.as_str()) {
                    command.extend([format!("--{column}"), value.to_string()]);
                }
            }
        }
        let stats = args.dir.join(format!("{id}.json"));
        let mut outputs = vec![mesh.clone(), stats.clone()];
        command.extend(["-o".to_string(), mesh.to_string_lossy().into_owned()]);
        command.extend(["--stats".to_string(), stats.to_string_lossy().into_owned()]);
        if args.png {
            let png = args.dir.join(format!("{id}.png"));
            command.extend(["--png".to_string(), png.to_string_lossy().into_owned()]);
            outputs.push(png);
        }
        let same_file = |a: &Path, b: &Path| matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y);
        if let Some(clash) = outputs.iter().find(|o| same_file(o, &image)) {
            return Err(row_error(format!(
                "the case would write {} over its own image; give another id, format or \
                 output folder",
                crate::shown(clash)
            )));
        }
        let parsed = SegmentLine::try_parse_from(&command).map_err(|e| {
            let text = e.to_string();
            let first = text.lines().next().unwrap_or_default();
            row_error(first.trim_start_matches("error: ").to_string())
        })?;
        cases.push(Case {
            line,
            id,
            command,
            args: parsed.args,
            mesh,
            outputs,
        });
    }
    if cases.is_empty() {
        return Err(manifest_error(
            args,
            None,
            "no cases (rows after the header)",
        ));
    }
    Ok(cases)
}

/// The results table: a row per case, in the manifest's order, kept from an earlier run for
/// the cases that are skipped.
struct ResultsTable {
    dir: PathBuf,
    rows: Vec<Value>,
}

impl ResultsTable {
    fn new(dir: &Path, cases: &[Case]) -> ResultsTable {
        let mut table = ResultsTable {
            dir: dir.to_path_buf(),
            rows: cases
                .iter()
                .map(|c| json!({"id": c.id, "line": c.line, "status": "pending", "command": c.command}))
                .collect(),
        };
        let earlier: HashMap<String, Value> = std::fs::read(table.json_path())
            .ok()
            .and_then(|bytes| serde_json::from_slice::<Value>(&bytes).ok())
            .and_then(|v| v["cases"].as_array().cloned())
            .into_iter()
            .flatten()
            .filter_map(|row| Some((row["id"].as_str()?.to_string(), row)))
            .collect();
        for (row, case) in table.rows.iter_mut().zip(cases) {
            if let Some(before) = earlier.get(&case.id) {
                if before["status"] == "ok"
                    && before["command"] == json!(case.command)
                    && case.mesh.is_file()
                {
                    *row = before.clone();
                    row["line"] = json!(case.line);
                }
            }
        }
        table
    }

    fn csv_path(&self) -> PathBuf {
        self.dir.join("results.csv")
    }

    fn json_path(&self) -> PathBuf {
        self.dir.join("results.json")
    }

    fn position(&self, case: &Case) -> usize {
        self.rows
            .iter()
            .position(|r| r["id"] == json!(case.id))
            .expect("every case has a row")
    }

    /// Whether an earlier run finished this case with the same row.
    fn finished(&self, case: &Case) -> bool {
        self.rows[self.position(case)]["status"] == "ok"
    }

    fn failed(&self) -> usize {
        self.rows.iter().filter(|r| r["status"] != "ok").count()
    }

    fn record(&mut self, case: &Case, outcome: &Outcome) {
        let mut row = json!({
            "id": case.id,
            "line": case.line,
            "command": case.command,
            "seconds": outcome.seconds,
        });
        match &outcome.result {
            Ok(objects) => {
                let reports: Vec<_> = objects
                    .iter()
                    .map(|o| mesh_checks::check(&o.mesh))
                    .collect();
                row["status"] = json!("ok");
                row["mesh"] = json!(case.mesh);
                row["objects"] = json!(objects.len());
                row["vertices"] = json!(reports.iter().map(|r| r.vertices).sum::<usize>());
                row["triangles"] = json!(reports.iter().map(|r| r.triangles).sum::<usize>());
                row["volume_mm3"] = json!(reports.iter().map(|r| r.signed_volume).sum::<f64>());
                row["genus"] = json!(reports.iter().map(|r| r.genus()).collect::<Vec<_>>());
                row["out_of_steps"] = json!(objects.iter().any(|o| o.stats.out_of_steps));
            }
            Err(message) => {
                row["status"] = json!("failed");
                row["error"] = json!(message);
            }
        }
        let k = self.position(case);
        self.rows[k] = row;
    }

    /// Both files, each replaced whole (written beside, then renamed), so that a batch
    /// stopped at any moment leaves a readable table.
    fn write(&self) -> Result<()> {
        let json = serde_json::to_string_pretty(&json!({ "cases": self.rows }))
            .expect("plain JSON values");
        replace(&self.json_path(), json.as_bytes())?;
        let columns = [
            "id",
            "status",
            "seconds",
            "objects",
            "vertices",
            "triangles",
            "genus",
            "volume_mm3",
            "out_of_steps",
            "mesh",
            "error",
        ];
        let mut csv = csv::Writer::from_writer(Vec::new());
        let io = |e: csv::Error| Error::io(format!("cannot write the results table: {e}"));
        csv.write_record(columns).map_err(io)?;
        for row in &self.rows {
            csv.write_record(columns.map(|c| {
                match &row[c] {
                    Value::Null => String::new(),
                    Value::String(s) => s.clone(),
                    Value::Array(genera) => genera
                        .iter()
                        .map(Value::to_string)
                        .collect::<Vec<_>>()
                        .join(";"),
                    other => other.to_string(),
                }
            }))
            .map_err(io)?;
        }
        let bytes = csv
            .into_inner()
            .map_err(|e| Error::io(format!("cannot write the results table: {e}")))?;
        replace(&self.csv_path(), &bytes)
    }
}

fn replace(path: &Path, bytes: &[u8]) -> Result<()> {
    let partial = path.with_extension("partial");
    std::fs::write(&partial, bytes)
        .and_then(|()| std::fs::rename(&partial, path))
        .map_err(|e| Error::io(format!("cannot write {}: {e}", crate::shown(path))))
}

/// One progress bar over the cohort, drawn on a terminal only.
struct CohortBar {
    total: usize,
    done: usize,
    start: Instant,
    shown: bool,
}

impl CohortBar {
    fn new(total: usize) -> CohortBar {
        let bar = CohortBar {
            total,
            done: 0,
            start: Instant::now(),
            shown: std::io::stderr().is_terminal(),
        };
        bar.draw(0);
        bar
    }

    fn advance(&mut self, failed: usize) {
        self.done += 1;
        self.draw(failed);
    }

    fn draw(&self, failed: usize) {
        if !self.shown || self.total == 0 {
            return;
        }
        let width = 30;
        let filled = width * self.done / self.total;
        let left = match self.done {
            0 => String::new(),
            done => {
                let each = self.start.elapsed().as_secs_f64() / done as f64;
                format!(", about {:.0} s left", each * (self.total - done) as f64)
            }
        };
        let mut err = std::io::stderr();
        let _ = write!(
            err,
            "\r[{}{}] {}/{} cases, {failed} failed{left}   ",
            "#".repeat(filled),
            " ".repeat(width - filled),
            self.done,
            self.total
        );
        let _ = err.flush();
    }

    fn clear(&self) {
        if self.shown {
            let _ = write!(std::io::stderr(), "\r{:80}\r", "");
        }
    }
}
