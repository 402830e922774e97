//! Tests of the families: determinism, the truth against the rendering, seeds, the drawn
//! geometry, topology and size.

use glam::DQuat;

use super::*;
use crate::geometry::Geometry;
use crate::marching_cubes::marching_cubes;
use crate::mesh_checks;
use crate::phantom::families::placement::min_along;
use crate::phantom::scene::{Intensity, Layer};
use crate::phantom::sdf::Capsule;
use crate::volume::VoxelBuffer;
use rayon::prelude::*;

fn parameter(design: &Design, name: &str) -> Vec<f64> {
    design
        .parameters
        .iter()
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("no parameter {name}"))
        .values
        .clone()
}

fn values(image: &Image) -> Vec<f64> {
    match image.buffer() {
        VoxelBuffer::I16(v) => v.iter().map(|&x| f64::from(x)).collect(),
        VoxelBuffer::F32(v) => v.iter().map(|&x| f64::from(x)).collect(),
        other => panic!("unexpected voxels {:?}", other.scalar_type()),
    }
}

fn index_of(n: usize, dims: [usize; 3]) -> DVec3 {
    DVec3::new(
        (n % dims[0]) as f64,
        (n / dims[0] % dims[1]) as f64,
        (n / (dims[0] * dims[1])) as f64,
    )
}

#[test]
fn a_variant_is_the_same_bytes_for_one_and_two_threads() {
    let pool = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
    };
    for family in Family::ALL {
        let one = pool(1).install(|| family.variant(3).unwrap());
        let two = pool(2).install(|| family.variant(3).unwrap());
        assert_eq!(one.image, two.image, "{family:?}");
        assert_eq!(one.describe(), two.describe());
        assert_ne!(
            Design::new(family, 4).unwrap().parameters.as_slice(),
            one.describe(),
            "{family:?}: another number, another scene"
        );
    }
}

/// The design without noise and blur (the bias stays: it is part of the ideal intensity).
fn clean(design: &Design) -> Image {
    let imaging = Imaging {
        blur_mm: 0.0,
        noise_sigma: 0.0,
        ..design.imaging
    };
    design.scene.render(&design.grid, &imaging).unwrap()
}

#[test]
fn voxels_deep_inside_the_truth_carry_the_objects_intensity() {
    for family in Family::ALL {
        let design = Design::new(family, 5).unwrap();
        let image = clean(&design);
        let g = design.grid.geometry;
        let reach = 0.5 * DVec3::from(g.spacing()).length();
        let layer = &design.scene.layers[design.truth_layer];
        let mut deep = 0;
        for (n, v) in values(&image).into_iter().enumerate() {
            let p = g.index_to_world(index_of(n, design.grid.dims));
            if design.shown(design.truth_layer, p) >= -reach {
                continue;
            }
            deep += 1;
            let bias = design.imaging.bias.map_or(1.0, |b| b.factor(p));
            let expected = layer.intensity.at(p) * bias;
            let tolerance = match design.imaging.output {
                ScalarType::I16 => 0.5,
                _ => 1e-6 * expected.abs(),
            };
            assert!(
                (v - expected).abs() <= tolerance,
                "{family:?} {p}: {v} {expected}"
            );
        }
        assert!(deep > 100, "{family:?}: {deep} deep voxels");
    }
}

#[test]
fn the_partial_volume_of_the_seeded_object_is_the_truths_volume() {
    for family in Family::ALL {
        let design = Design::new(family, 6).unwrap();
        // The scene with the seeded object at 1 and everything else at 0.
        let indicator = Scene {
            background: 0.0,
            layers: design
                .scene
                .layers
                .iter()
                .enumerate()
                .map(|(i, l)| Layer {
                    solid: l.solid.clone(),
                    intensity: Intensity::Constant(f64::from(u8::from(i == design.truth_layer))),
                })
                .collect(),
        };
        let spacing = design.grid.geometry.spacing();
        let voxel: f64 = spacing.iter().product();
        let rendered: f64 = indicator
            .composite(&design.grid)
            .iter()
            .map(|&v| f64::from(v))
            .sum::<f64>()
            * voxel;
        let (lo, hi) = design.truth_bounds;
        let step = 0.4;
        let size = ((hi - lo) / step).ceil();
        let inside: usize = (0..size.z as usize)
            .into_par_iter()
            .map(|k| {
                let mut count = 0;
                for j in 0..size.y as usize {
                    for i in 0..size.x as usize {
                        let p = lo + (DVec3::new(i as f64, j as f64, k as f64) + 0.5) * step;
                        count += usize::from(design.shown(design.truth_layer, p) < 0.0);
                    }
                }
                count
            })
            .sum();
        let sampled = inside as f64 * step.powi(3);
        let error = (rendered - sampled).abs() / sampled;
        assert!(error < 0.02, "{family:?}: {rendered} against {sampled} mm³");
    }
}

#[test]
fn seeds_lie_a_voxel_deep_inside_the_truth_and_volumes_keep_to_the_budget() {
    for family in Family::ALL {
        for number in 0..60 {
            let design = Design::new(family, number).unwrap();
            let g = design.grid.geometry;
            assert!(
                design.shown(design.truth_layer, design.seed) <= -g.max_spacing(),
                "{family:?} {number}"
            );
            let index = g.world_to_index(design.seed);
            let top = DVec3::from(design.grid.dims.map(|d| (d - 1) as f64));
            assert!(index.cmpge(DVec3::ZERO).all() && index.cmple(top).all());
            assert!(design.grid.voxels() <= VOXEL_BUDGET, "{family:?} {number}");
            let (lo, hi) = design.truth_bounds;
            assert!(lo.cmple(design.seed).all() && design.seed.cmple(hi).all());
        }
    }
}

#[test]
fn the_thin_wall_is_t_voxels_thick_along_its_normal() {
    for number in 0..30 {
        let design = Design::new(Family::ThinWall, number).unwrap();
        let other = design.other_layer.unwrap();
        let normal = DVec3::from_slice(&parameter(&design, "wall_normal"));
        let t = parameter(&design, "wall_voxels_t")[0];
        let g = design.grid.geometry;
        let to_index = g.world_to_index_matrix();
        let h = 1.0 / (to_index * normal).length();
        // Where a distance along the normal line through the seed changes sign.
        let crossing = |f: &dyn Fn(DVec3) -> f64, from: f64, to: f64| {
            let (mut a, mut b) = (from, to);
            for _ in 0..100 {
                let mid = 0.5 * (a + b);
                if (f(design.seed + mid * normal) < 0.0) == (f(design.seed + a * normal) < 0.0) {
                    a = mid;
                } else {
                    b = mid;
                }
            }
            0.5 * (a + b)
        };
        let first_face = crossing(&|p| design.shown(design.truth_layer, p), 0.0, 20.0);
        let second_face = crossing(&|p| design.shown(other, p), first_face, first_face + 10.0);
        let wall = second_face - first_face;
        assert!(
            (wall - t * h).abs() < 1e-9,
            "{number}: {wall} against {}",
            t * h
        );
        assert!((0.6 * h..=1.5 * h).contains(&wall));
    }
}

#[test]
fn the_touching_pair_touches() {
    for number in 0..30 {
        let design = Design::new(Family::TouchingPair, number).unwrap();
        let first = parameter(&design, "first_axis");
        let second = parameter(&design, "second_axis");
        let radii = parameter(&design, "radii_mm");
        let delta = parameter(&design, "overlap_delta_mm")[0];
        let axis = Capsule {
            a: DVec3::from_slice(&second[..3]),
            b: DVec3::from_slice(&second[3..]),
            radius: 0.0,
        };
        let line = [
            DVec3::from_slice(&first[..3]),
            DVec3::from_slice(&first[3..]),
        ];
        let between = min_along(&line, &axis);
        assert!(
            (between - (radii[0] + radii[1] - delta)).abs() < 1e-6,
            "{number}"
        );
        assert!((0.0..=0.5).contains(&delta));
    }
}

#[test]
fn the_vessel_opens_into_the_chamber_on_the_opening_plane() {
    for number in 0..30 {
        let design = Design::new(Family::VesselChamber, number).unwrap();
        let centre = DVec3::from_slice(&parameter(&design, "opening_centre"));
        let normal = DVec3::from_slice(&parameter(&design, "opening_normal"));
        let r = parameter(&design, "vessel_radius_mm")[0];
        let across = normal.any_orthonormal_vector();
        let (vessel, chamber) = (design.truth_layer, design.other_layer.unwrap());
        // Just inside the opening's rim: beyond its plane the vessel, before it the chamber.
        for turn in [0.0, 2.0, 4.0] {
            let p = centre + 0.99 * r * (DQuat::from_axis_angle(normal, turn) * across);
            let beyond = p + 0.2 * normal;
            let before = p - 0.2 * normal;
            assert!(
                design.scene.visible(vessel, beyond) < 0.0,
                "{number} {turn}"
            );
            assert!(
                design.scene.visible(chamber, before) < 0.0,
                "{number} {turn}"
            );
            assert!(
                design.scene.visible(vessel, before) >= 0.0,
                "{number} {turn}"
            );
        }
        let intensities = [
            parameter(&design, "first_intensity")[0],
            parameter(&design, "second_intensity")[0],
        ];
        assert_eq!(intensities[0], intensities[1], "{number}");
    }
}

/// Genus of marching cubes of the truth sampled on the variant's grid, one voxel wider on
/// every side so that the surface closes.
fn truth_genus(design: &Design) -> Option<i64> {
    let g = design.grid.geometry;
    let dims = design.grid.dims.map(|d| d + 2);
    let origin = g.index_to_world(DVec3::splat(-1.0));
    let grid = Geometry::new(g.spacing(), origin.to_array(), g.direction()).unwrap();
    let sdf = Image::from_fn(dims, grid, |i, j, k| {
        let p = grid.index_to_world(DVec3::new(i as f64, j as f64, k as f64));
        design.shown(design.truth_layer, p) as f32
    })
    .unwrap();
    let mesh = marching_cubes(&sdf.view(), 0.0).unwrap();
    mesh_checks::check(&mesh).genus()
}

#[test]
fn the_vessel_ring_has_genus_one() {
    for number in 0..4 {
        let design = Design::new(Family::ThinVessels, number).unwrap();
        assert_eq!(design.genus, 1);
        assert_eq!(truth_genus(&design), Some(1), "variant {number}");
    }
}

#[test]
fn the_other_truths_have_genus_zero() {
    for family in [
        Family::CtScene,
        Family::ThinWall,
        Family::TouchingPair,
        Family::Stent,
        Family::VesselChamber,
    ] {
        let design = Design::new(family, 2).unwrap();
        assert_eq!(design.genus, 0);
        assert_eq!(truth_genus(&design), Some(0), "{family:?}");
    }
}

#[test]
fn unknown_names_are_errors_that_list_the_families() {
    let error = Family::from_name("cube").unwrap_err();
    assert!(
        error.message().contains("thin-vessels"),
        "{}",
        error.message()
    );
    for family in Family::ALL {
        assert_eq!(Family::from_name(family.name()).unwrap(), family);
    }
}
