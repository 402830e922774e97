//! The balloon on bad input (issue 3): a clear error or a documented result, never a panic or a
//! mesh that breaks the guarantees (closed, 2-manifold, outward, no self-intersections).

use balloonseg::balloon::{BalloonParams, Segmenter};
use balloonseg::phantom::{self, Phantom, PhantomOptions, Shape};
use balloonseg::self_intersection::self_intersections;
use balloonseg::{mesh_checks, ErrorKind, Geometry, Image, TriMesh, VoxelBuffer};
use glam::DVec3;

fn sphere() -> Phantom {
    phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap()
}

fn assert_valid(mesh: &TriMesh) {
    let report = mesh_checks::check(mesh);
    assert!(report.is_valid_closed_surface(), "{report:?}");
    assert!(self_intersections(mesh).unwrap().is_empty());
}

#[test]
fn seed_outside_the_volume_is_an_invalid_argument_naming_it() {
    let p = sphere();
    let e = Segmenter::new(
        p.image.view(),
        BalloonParams::default(),
        DVec3::new(0.0, 0.0, 500.0),
    )
    .err()
    .unwrap();
    assert_eq!(e.kind(), ErrorKind::InvalidArgument);
    assert!(e.message().contains("outside the volume"), "{e}");
}

#[test]
fn zero_iterations_is_an_invalid_argument() {
    let p = sphere();
    let params = BalloonParams {
        max_iterations: 0,
        ..BalloonParams::default()
    };
    let e = Segmenter::new(p.image.view(), params, p.seed_world())
        .err()
        .unwrap();
    assert_eq!(e.kind(), ErrorKind::InvalidArgument);
    assert!(e.message().contains("max_iterations"), "{e}");
}

/// Documented: a seed on the background with the defaults segments the background region it is
/// in (the window is estimated there), bounded by the volume's faces; the result is valid.
#[test]
fn seed_on_background_segments_the_background_validly() {
    let p = sphere();
    let corner = p.image.geometry().index_to_world(DVec3::splat(2.0));
    match Segmenter::new(p.image.view(), BalloonParams::default(), corner)
        .and_then(|mut s| s.segment())
    {
        Ok((mesh, _)) => {
            assert_valid(&mesh);
            assert!(mesh.signed_volume() > 0.0);
        }
        Err(e) => assert!(!e.message().is_empty()),
    }
}

/// Documented: when everything is foreground the balloon stops at the volume's faces; with a
/// vertex limit too small for that, it is a leak, and the message says so.
#[test]
fn everything_foreground_fills_the_volume_or_is_a_leak() {
    let p = sphere();
    let wide = BalloonParams {
        reference: Some(600.0),
        tolerance: Some(1e6),
        ..BalloonParams::default()
    };
    let (mesh, _) = Segmenter::new(p.image.view(), wide.clone(), p.seed_world())
        .unwrap()
        .segment()
        .unwrap();
    assert_valid(&mesh);
    let [nx, ny, nz] = p.image.dims();
    let spacing = p.image.geometry().spacing();
    let box_volume =
        (nx - 1) as f64 * spacing[0] * (ny - 1) as f64 * spacing[1] * (nz - 1) as f64 * spacing[2];
    assert!(
        mesh.signed_volume() > 0.9 * box_volume,
        "{} of {box_volume}",
        mesh.signed_volume()
    );

    let limited = BalloonParams {
        max_vertices: 500,
        ..wide
    };
    let e = Segmenter::new(p.image.view(), limited, p.seed_world())
        .unwrap()
        .segment()
        .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::Leak);
    assert!(
        e.message().contains("leaked") && e.message().contains("tolerance"),
        "{e}"
    );
}

/// Documented: NaN voxels count as outside the structure (the balloon stops at them and flows
/// around them); NaN around the seed itself is an invalid volume.
#[test]
fn nan_voxels_near_the_seed_are_outside_and_at_the_seed_an_error() {
    let p = sphere();
    let dims = p.image.dims();
    let centre = p.image.geometry().world_to_index(p.seed_world()).round();
    let voxels = |radius: f64| -> Image {
        let VoxelBuffer::F32(mut v) = p.image.buffer().clone() else {
            panic!("phantoms are float32");
        };
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let d = DVec3::new(i as f64, j as f64, k as f64) - centre;
                    // A plate of NaN, 3 voxels from the seed.
                    if (d.x - radius).abs() < 0.5 && d.y.abs() < 3.0 && d.z.abs() < 3.0 {
                        v[(k * dims[1] + j) * dims[0] + i] = f32::NAN;
                    }
                }
            }
        }
        Image::new(VoxelBuffer::F32(v), dims, *p.image.geometry()).unwrap()
    };
    let near = voxels(3.0);
    let (mesh, _) = Segmenter::new(near.view(), BalloonParams::default(), p.seed_world())
        .unwrap()
        .segment()
        .unwrap();
    assert_valid(&mesh);
    // The balloon flows around the plate: the sphere, less a little.
    let clean = sphere_volume();
    let volume = mesh.signed_volume();
    assert!(volume > 0.8 * clean && volume < clean, "{volume}");

    let at_seed = voxels(0.0);
    let e = Segmenter::new(at_seed.view(), BalloonParams::default(), p.seed_world())
        .err()
        .unwrap();
    assert!(e.message().contains("NaN"), "{e}");
}

fn sphere_volume() -> f64 {
    4.0 / 3.0 * std::f64::consts::PI * 1000.0
}

/// The error of a balloon started at voxel (10, 10, 10) of the sphere phantom with its
/// voxels laid out by `spacing` and `direction` instead.
fn refused_geometry(spacing: [f64; 3], direction: [f64; 9]) -> balloonseg::Error {
    let p = sphere();
    let geometry = Geometry::new(spacing, p.image.geometry().origin(), direction).unwrap();
    let image = Image::new(p.image.buffer().clone(), p.image.dims(), geometry).unwrap();
    let seed = geometry.index_to_world(DVec3::new(10.0, 10.0, 10.0));
    let e = Segmenter::new(image.view(), BalloonParams::default(), seed)
        .err()
        .unwrap();
    assert_eq!(e.kind(), ErrorKind::InvalidVolume, "{e}");
    e
}

const IDENTITY: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

#[test]
fn voxels_a_hundred_times_longer_one_way_are_an_invalid_volume_naming_the_spacing() {
    // A header that says 1e-9 mm along one axis made the balloon's grids of the smallest
    // spacing ask for gigabytes (issue 19).
    for spacing in [[1.0, 1.0, 1e-9], [1.0, 1000.0, 1.0]] {
        let e = refused_geometry(spacing, IDENTITY);
        assert!(e.message().contains("times longer"), "{e}");
    }
}

#[test]
fn an_edge_length_far_from_the_voxel_size_is_refused_naming_the_range() {
    // 1000 mm on the aorta grew until the machine ran out of memory; 0.01 mm ran for minutes
    // without nearing the vertex limit (issue 19).
    let p = sphere();
    for edge in [1000.0, 0.01] {
        let params = BalloonParams {
            edge_length: Some(edge),
            ..BalloonParams::default()
        };
        let e = Segmenter::new(p.image.view(), params, p.seed_world())
            .err()
            .unwrap();
        assert_eq!(e.kind(), ErrorKind::InvalidArgument, "{e}");
        assert!(
            e.message().contains("edge_length_mm") && e.message().contains(".."),
            "{e}"
        );
    }
}

#[test]
fn a_direction_with_long_or_nearly_coplanar_columns_is_an_invalid_volume() {
    // Found by fuzzing the C ABI: a direction column 1e9 long passed every spacing check and
    // the seed's intensity profiles asked for a 94 GB smoothing kernel.
    let long_column = [0.0, 0.0, 1e9, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    // The k axis 3° from the i axis.
    let (s, c) = 0.05f64.sin_cos();
    let coplanar = [1.0, 0.0, c, 0.0, 1.0, 0.0, 0.0, 0.0, s];
    for (direction, says) in [(long_column, "unit"), (coplanar, "coplanar")] {
        let e = refused_geometry([1.0; 3], direction);
        assert!(e.message().contains(says), "{e}");
    }
}
