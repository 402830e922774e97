//! The `render` command and `segment --png` as a user runs them: a phantom, its isosurface or
//! its segmentation, and the picture; bad arguments end with a reason, not a panic.
#![cfg(feature = "cli")]

use std::path::Path;

#[allow(dead_code)]
#[path = "support/cli.rs"]
mod cli;
use cli::{balloonseg, succeed};

/// Width and height of a PNG file, from its header.
fn png_size(path: &Path) -> (u32, u32) {
    let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let info = png::Decoder::new(file).read_info().unwrap().info().clone();
    (info.width, info.height)
}

/// The RGB bytes of a PNG file.
fn png_pixels(path: &Path) -> Vec<[u8; 3]> {
    let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut reader = png::Decoder::new(file).read_info().unwrap();
    let mut bytes = vec![0; reader.output_buffer_size().unwrap()];
    let frame = reader.next_frame(&mut bytes).unwrap();
    assert_eq!(frame.color_type, png::ColorType::Rgb);
    bytes[..frame.buffer_size()]
        .chunks(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect()
}

#[test]
fn render_draws_several_meshes_each_in_its_colour() {
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (volume, inner, outer) = (at("torus.mha"), at("inner.vtp"), at("outer.ply"));
    succeed(&["phantom", "torus", "-o", &volume]);
    succeed(&["isosurface", &volume, "--level", "800", "-o", &inner]);
    succeed(&["isosurface", &volume, "--level", "200", "-o", &outer]);
    let (one, two) = (at("one.png"), at("two.png"));
    succeed(&[
        "render", &inner, "--volume", &volume, "-o", &one, "--size", "120",
    ]);
    succeed(&[
        "render", &inner, &outer, "--volume", &volume, "-o", &two, "--size", "120",
    ]);
    assert_eq!(png_size(Path::new(&two)), (242, 242));
    let (yellow, violet) = ([255, 232, 0], [150, 130, 255]);
    let count = |path: &str, colour: [u8; 3]| {
        png_pixels(Path::new(path))
            .into_iter()
            .filter(|&p| p == colour)
            .count()
    };
    assert!(count(&one, yellow) > 100 && count(&one, violet) == 0);
    assert!(count(&two, yellow) > 100 && count(&two, violet) > 100);
    let out = balloonseg(&["render", "--volume", &volume, "-o", &two]);
    assert_eq!(out.status.code(), Some(2), "no mesh is a usage error");
}

#[test]
fn render_and_segment_write_pictures_and_refuse_bad_arguments() {
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let (volume, mesh, picture) = (at("torus.mha"), at("torus.vtp"), at("torus.png"));
    succeed(&["phantom", "torus", "-o", &volume]);
    succeed(&["isosurface", &volume, "--level", "600", "-o", &mesh]);
    succeed(&[
        "render", &mesh, "--volume", &volume, "-o", &picture, "--size", "100",
    ]);
    assert_eq!(png_size(Path::new(&picture)), (202, 202));
    let centred = at("centred.png");
    succeed(&[
        "render", &mesh, "--volume", &volume, "-o", &centred, "--centre", "20,20,10", "--index",
        "--window", "-50,1200",
    ]);
    assert_eq!(png_size(Path::new(&centred)), (842, 842));

    let segmented = at("segmented.png");
    succeed(&[
        "segment",
        &volume,
        "--seed",
        "0,12,0",
        "-o",
        &at("segmented.vtp"),
        "--png",
        &segmented,
    ]);
    assert_eq!(png_size(Path::new(&segmented)), (842, 842));

    for (args, reason) in [
        (vec!["--size", "0"], "pixels"),
        (vec!["--size", "5000"], "pixels"),
        (vec!["--window", "5,1"], "window"),
        (vec!["--centre", "900,0,0"], "outside the volume"),
        (vec!["--centre", "nan,0,0"], "centre"),
    ] {
        let mut all = vec!["render", &mesh, "--volume", &volume, "-o", &picture];
        all.extend(args);
        let out = balloonseg(&all);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{all:?}: {stderr}");
        assert!(stderr.contains(reason), "{all:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
}
