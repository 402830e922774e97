//! balloonseg's readers against the crates that read the same formats: nifti, stl_io, vtkio,
//! ply-rs-bw, and quick-xml against the XML parser it replaced. BENCHMARKS.md, "io: our readers
//! against the crates", has the commands and the results.
//!
//! - `xml FILE...`: the hand-written XML parser against the quick-xml one of src/io/xml.rs on
//!   each file (the same tree checked), best of 5 interleaved.
//! - `speed DIR`: each reader on the files of DIR (made by make_files.sh), best of 5
//!   interleaved, as a ratio to ours.
//! - `fuzz READER FILE N`: the file itself and N - 1 copies with one to three bytes replaced
//!   (half of them within the first 512 bytes, where the headers are). Each read runs in a
//!   worker process limited to 4 GiB of address space that catches panics; a worker that dies
//!   counts as an abort, one silent for 5 s as a hang, and a new worker goes on with the next
//!   case.

mod error;
// The readers need more of the tree API than the timing does.
#[allow(dead_code)]
mod hand_xml;
#[allow(dead_code)]
#[path = "../../../src/io/xml.rs"]
mod xml;

use std::io::{BufRead, BufReader, Cursor, Write};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{mpsc, Mutex};
use std::time::{Duration, Instant};

use balloonseg::io;

/// What a reader found, in a few words, or why it failed.
type Read = fn(&Path) -> Result<String, String>;

fn mesh_summary(mesh: balloonseg::Result<balloonseg::TriMesh>) -> Result<String, String> {
    let mesh = mesh.map_err(|e| e.to_string())?;
    Ok(format!(
        "{} points, {} triangles",
        mesh.points().len(),
        mesh.triangles().len()
    ))
}

fn image_summary(image: balloonseg::Result<balloonseg::Image>) -> Result<String, String> {
    let image = image.map_err(|e| e.to_string())?;
    Ok(format!("{:?} voxels", image.dims()))
}

fn whole(path: &Path) -> Result<Cursor<Vec<u8>>, String> {
    std::fs::read(path)
        .map(Cursor::new)
        .map_err(|e| e.to_string())
}

fn nifti_crate(path: &Path) -> Result<String, String> {
    use nifti::{IntoNdArray, NiftiObject};
    let object = nifti::ReaderOptions::new()
        .read_file(path)
        .map_err(|e| e.to_string())?;
    let voxels = object
        .into_volume()
        .into_ndarray::<f32>()
        .map_err(|e| e.to_string())?;
    Ok(format!("{:?} voxels", voxels.shape()))
}

fn stl_crate(path: &Path) -> Result<String, String> {
    let mesh = stl_io::read_stl(&mut whole(path)?).map_err(|e| e.to_string())?;
    Ok(format!(
        "{} points, {} triangles",
        mesh.vertices.len(),
        mesh.faces.len()
    ))
}

fn ply_crate(path: &Path) -> Result<String, String> {
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::DefaultElement;
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut whole(path)?)
        .map_err(|e| e.to_string())?;
    let count = |name: &str| ply.payload.get(name).map_or(0, Vec::len);
    Ok(format!(
        "{} points, {} faces",
        count("vertex"),
        count("face")
    ))
}

fn vtkio_crate(path: &Path) -> Result<String, String> {
    use vtkio::model::DataSet;
    let mut vtk = vtkio::Vtk::import(path).map_err(|e| e.to_string())?;
    vtk.load_all_pieces().map_err(|e| e.to_string())?;
    Ok(match &vtk.data {
        DataSet::PolyData { pieces, .. } => format!("PolyData, {} pieces", pieces.len()),
        DataSet::ImageData { extent, .. } => format!("ImageData {extent:?}"),
        _ => "another data set".into(),
    })
}

const READERS: &[(&str, Read)] = &[
    ("ours-nifti", |p| image_summary(io::nifti::read(p))),
    ("nifti", nifti_crate),
    ("ours-stl", |p| mesh_summary(io::stl::read(p))),
    ("stl_io", stl_crate),
    ("ours-ply", |p| mesh_summary(io::ply::read(p))),
    ("ply-rs-bw", ply_crate),
    ("ours-vtk-mesh", |p| {
        mesh_summary(io::vtk_legacy::read_mesh(p))
    }),
    ("ours-vtk-image", |p| {
        image_summary(io::vtk_legacy::read_image(p))
    }),
    ("ours-vtp", |p| mesh_summary(io::vtk_xml::read_vtp(p))),
    ("ours-vti", |p| image_summary(io::vtk_xml::read_vti(p))),
    ("vtkio", vtkio_crate),
];

fn reader(name: &str) -> Read {
    READERS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, read)| *read)
        .unwrap_or_else(|| panic!("unknown reader {name}"))
}

/// The best of `rounds` interleaved runs of each closure, in seconds.
fn best_of<const N: usize>(rounds: usize, runs: [&dyn Fn(); N]) -> [f64; N] {
    let mut best = [f64::INFINITY; N];
    for _ in 0..rounds {
        for (run, best) in runs.iter().zip(&mut best) {
            let start = Instant::now();
            run();
            *best = best.min(start.elapsed().as_secs_f64());
        }
    }
    best
}

/// The old way to find appended data: scan for the tag, parse it alone, parse the XML before it.
fn hand_open(
    bytes: &[u8],
) -> error::Result<(hand_xml::Element<'_>, Option<hand_xml::Element<'_>>)> {
    let marker = b"<AppendedData";
    let Some(at) = (0..bytes.len()).find(|&i| bytes[i] == b'<' && bytes[i..].starts_with(marker))
    else {
        return Ok((hand_xml::parse(bytes, false)?, None));
    };
    let tag_end = bytes[at..]
        .iter()
        .position(|&b| b == b'>')
        .map(|n| at + n + 1)
        .ok_or_else(|| error::Error::format("unclosed"))?;
    let tag = hand_xml::parse(&bytes[at..tag_end], true)?;
    Ok((hand_xml::parse(&bytes[..at], true)?, Some(tag)))
}

fn new_open(bytes: &[u8]) -> error::Result<(xml::Element<'_>, Option<xml::Element<'_>>)> {
    let document = xml::parse(bytes, Some("AppendedData"))?;
    Ok((document.root, document.rest.map(|(tag, _)| tag)))
}

fn compare_xml(files: &[String]) {
    println!("| file | size | hand-written ms | quick-xml ms | quick-xml / hand-written |");
    println!("|---|---|---|---|---|");
    for file in files {
        let bytes = std::fs::read(file).unwrap();
        let old = hand_open(&bytes).unwrap();
        let new = new_open(&bytes).unwrap();
        // Both trees print alike (a Cow<str> prints as its str) when they hold the same.
        assert_eq!(
            format!("{old:?}"),
            format!("{new:?}"),
            "{file}: the trees differ"
        );
        let [old, new] = best_of(
            5,
            [
                &|| drop(std::hint::black_box(hand_open(&bytes).unwrap())),
                &|| drop(std::hint::black_box(new_open(&bytes).unwrap())),
            ],
        );
        let name = Path::new(file).file_name().unwrap().to_string_lossy();
        println!(
            "| {name} | {:.1} MB | {:.3} | {:.3} | **{:.2}** |",
            bytes.len() as f64 / 1e6,
            old * 1e3,
            new * 1e3,
            new / old
        );
    }
}

/// (file, our reader, the crate's reader) for `speed`.
const SPEED_CASES: &[(&str, &str, &str)] = &[
    ("ts.nii", "ours-nifti", "nifti"),
    ("ts.nii.gz", "ours-nifti", "nifti"),
    ("avf.nii.gz", "ours-nifti", "nifti"),
    ("aorta.stl", "ours-stl", "stl_io"),
    ("ref-binary.stl", "ours-stl", "stl_io"),
    ("ref-ascii.stl", "ours-stl", "stl_io"),
    ("aorta.ply", "ours-ply", "ply-rs-bw"),
    ("ref-binary-le.ply", "ours-ply", "ply-rs-bw"),
    ("ref-binary-be.ply", "ours-ply", "ply-rs-bw"),
    ("ref-ascii.ply", "ours-ply", "ply-rs-bw"),
    ("aorta.vtk", "ours-vtk-mesh", "vtkio"),
    ("ref-binary.vtk", "ours-vtk-mesh", "vtkio"),
    ("ref-ascii.vtk", "ours-vtk-mesh", "vtkio"),
    ("aorta-binary.vtk", "ours-vtk-image", "vtkio"),
    ("aorta-ascii.vtk", "ours-vtk-image", "vtkio"),
    ("aorta.vtp", "ours-vtp", "vtkio"),
    ("ref-appended.vtp", "ours-vtp", "vtkio"),
    ("ref-binary.vtp", "ours-vtp", "vtkio"),
    ("ref-binary-raw.vtp", "ours-vtp", "vtkio"),
    ("ref-ascii.vtp", "ours-vtp", "vtkio"),
    ("aorta-appended.vti", "ours-vti", "vtkio"),
    ("aorta-binary.vti", "ours-vti", "vtkio"),
    ("aorta-ascii.vti", "ours-vti", "vtkio"),
];

/// `read` on `path`, with a panic as an error.
fn guarded(read: Read, path: &Path) -> Result<String, String> {
    catch_unwind(AssertUnwindSafe(|| read(path)))
        .unwrap_or_else(|_| Err(format!("panic: {}", PANIC_MESSAGE.lock().unwrap())))
}

fn quiet_panics() {
    std::panic::set_hook(Box::new(|info| {
        *PANIC_MESSAGE.lock().unwrap() = info.to_string().replace('\n', " ");
    }));
}

fn speed(dir: &Path) {
    quiet_panics();
    println!("| file | ours ms | crate | crate ms | crate / ours | ours read | crate read |");
    println!("|---|---|---|---|---|---|---|");
    for &(file, ours, theirs) in SPEED_CASES {
        let path = dir.join(file);
        let (ours_read, their_read) = (reader(ours), reader(theirs));
        let ours_found = guarded(ours_read, &path);
        let their_found = guarded(their_read, &path);
        let [ours_s, their_s] = best_of(
            5,
            [&|| drop(guarded(ours_read, &path)), &|| {
                drop(guarded(their_read, &path))
            }],
        );
        let shown = |r: Result<String, String>| match r {
            Ok(s) => s,
            Err(e) => format!("error: {}", e.chars().take(90).collect::<String>()),
        };
        let ratio = if their_found.is_ok() {
            format!("**{:.2}**", their_s / ours_s)
        } else {
            "–".into()
        };
        println!(
            "| {file} | {:.2} | {theirs} | {:.2} | {ratio} | {} | {} |",
            ours_s * 1e3,
            their_s * 1e3,
            shown(ours_found),
            shown(their_found)
        );
    }
}

/// Case 0 is the file itself; case i > 0 has one to three bytes replaced, the same every run.
fn mutation(bytes: &[u8], case: u64) -> Vec<u8> {
    let mut copy = bytes.to_vec();
    if case == 0 || bytes.is_empty() {
        return copy;
    }
    // SplitMix64 seeded by the case number.
    let mut state = case.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    for _ in 0..1 + next() % 3 {
        let span = if next() % 2 == 0 {
            bytes.len().min(512)
        } else {
            bytes.len()
        };
        let at = (next() % span as u64) as usize;
        copy[at] = next() as u8;
    }
    copy
}

/// The mutated copy's path: the original's name (extensions matter to some readers) in a
/// folder of this process.
fn scratch_path(file: &Path) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("io_crates-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(file.file_name().unwrap())
}

static PANIC_MESSAGE: Mutex<String> = Mutex::new(String::new());

fn worker(read: Read, file: &Path, first: u64, end: u64) {
    quiet_panics();
    let bytes = std::fs::read(file).unwrap();
    let path = scratch_path(file);
    let mut out = std::io::stdout().lock();
    for case in first..end {
        std::fs::write(&path, mutation(&bytes, case)).unwrap();
        writeln!(out, "start {case}").unwrap();
        out.flush().unwrap();
        let line = match catch_unwind(AssertUnwindSafe(|| read(&path))) {
            Ok(Ok(_)) => format!("ok {case}"),
            Ok(Err(_)) => format!("err {case}"),
            Err(_) => format!("panic {case} {}", PANIC_MESSAGE.lock().unwrap()),
        };
        writeln!(out, "{line}").unwrap();
        out.flush().unwrap();
    }
    let _ = std::fs::remove_dir_all(path.parent().unwrap());
}

fn fuzz(name: &str, file: &Path, cases: u64) {
    let exe = std::env::current_exe().unwrap();
    let (mut ok, mut errors) = (0, 0);
    let (mut panics, mut aborts, mut hangs) = (Vec::new(), Vec::new(), Vec::new());
    let mut next = 0;
    while next < cases {
        let mut child = Command::new("sh")
            .arg("-c")
            .arg("ulimit -v 4194304; exec \"$0\" \"$@\"")
            .arg(&exe)
            .args(["worker", name])
            .arg(file)
            .args([next.to_string(), cases.to_string()])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let stdout = child.stdout.take().unwrap();
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut running = None;
        loop {
            match rx.recv_timeout(Duration::from_secs(5)) {
                Ok(line) => {
                    let mut words = line.splitn(3, ' ');
                    let (kind, case) = (words.next().unwrap(), words.next().unwrap());
                    let case: u64 = case.parse().unwrap();
                    match kind {
                        "start" => running = Some(case),
                        "ok" => ok += 1,
                        "err" => errors += 1,
                        _ => panics.push((case, words.next().unwrap_or("").to_string())),
                    }
                    if kind != "start" {
                        running = None;
                        next = case + 1;
                    }
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    child.kill().unwrap();
                    child.wait().unwrap();
                    let case = running.unwrap_or(next);
                    hangs.push(case);
                    next = case + 1;
                    break;
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    let status = child.wait().unwrap();
                    if let Some(case) = running {
                        aborts.push((case, status.to_string()));
                        next = case + 1;
                    }
                    break;
                }
            }
        }
    }
    println!(
        "{name} on {}: {cases} cases: {ok} read, {errors} errors, {} panics, {} aborts, {} hangs",
        file.display(),
        panics.len(),
        aborts.len(),
        hangs.len()
    );
    let mut seen = Vec::new();
    for (case, message) in &panics {
        // One line per panic site.
        let site = message.split(": ").next().unwrap_or("").to_string();
        if !seen.contains(&site) {
            println!("  panic, e.g. case {case}: {message}");
            seen.push(site);
        }
    }
    for (case, status) in aborts.iter().take(3) {
        println!("  abort, e.g. case {case}: {status}");
    }
    if !hangs.is_empty() {
        println!("  hangs: cases {:?}", &hangs[..hangs.len().min(5)]);
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: io_crates xml FILE... | speed DIR | fuzz READER FILE N";
    match args.first().map(String::as_str) {
        Some("xml") => compare_xml(&args[1..]),
        Some("speed") => speed(Path::new(&args[1])),
        Some("fuzz") => fuzz(&args[1], Path::new(&args[2]), args[3].parse().expect(usage)),
        Some("worker") => worker(
            reader(&args[1]),
            Path::new(&args[2]),
            args[3].parse().unwrap(),
            args[4].parse().unwrap(),
        ),
        _ => panic!("{usage}"),
    }
}
