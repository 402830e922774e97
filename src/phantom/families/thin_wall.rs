//! Family `thin-wall`: two bright rounded boxes (18–24 × 18–24 × 12–16 mm, edges rounded by
//! 1–2 mm) facing each other across a planar wall of background whose thickness is t · h, with
//! t ∈ U[0.6, 1.5] and h the voxel's extent along the wall's normal — below a voxel the wall
//! survives only as a dip of partial volume. The truth is the seeded box, the other object the
//! box beyond the wall.

use std::sync::Arc;

use glam::{DMat3, DVec3};

use super::{Acquisition, Ball, BrightPair, Composition, Parameter, MARGIN};
use crate::phantom::random::SplitMix64;
use crate::phantom::scene::{Intensity, Layer, Scene};
use crate::phantom::sdf::RoundedBox;
use crate::volume::ScalarType;

pub(super) fn compose(rng: &mut SplitMix64, scan: &Acquisition) -> Composition {
    let colours = BrightPair::draw(rng);
    // Half-sizes: x across the wall (12–16 mm), y and z along it (18–24 mm).
    let mut half = || {
        DVec3::new(
            rng.uniform(6.0, 8.0),
            rng.uniform(9.0, 12.0),
            rng.uniform(9.0, 12.0),
        )
    };
    let (half_first, half_second) = (half(), half());
    let rounding = rng.uniform(1.0, 2.0);
    let t = rng.uniform(0.6, 1.5);
    let shift = DVec3::new(0.0, rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0));
    let normal = DVec3::X;
    let h = scan.voxel_extent_along(normal);
    let wall = t * h;
    let rounded = |centre: DVec3, half: DVec3| RoundedBox {
        centre,
        axes: DMat3::IDENTITY,
        half,
        rounding,
    };
    let first = rounded(-(0.5 * wall + half_first.x) * normal, half_first);
    let second = rounded((0.5 * wall + half_second.x) * normal + shift, half_second);
    let essential = [first, second]
        .iter()
        .flat_map(|b| corner_balls(b, MARGIN))
        .collect();
    let scene = Scene {
        background: colours.background,
        layers: vec![
            Layer {
                solid: Arc::new(first),
                intensity: Intensity::Constant(colours.first),
            },
            Layer {
                solid: Arc::new(second),
                intensity: Intensity::Constant(colours.second),
            },
        ],
    };
    let mut parameters = colours.parameters();
    parameters.extend([
        Parameter::new("first_half_size_mm", half_first.to_array()),
        Parameter::new("second_half_size_mm", half_second.to_array()),
        Parameter::new("second_shift_mm", shift.to_array()),
        Parameter::new("rounding_mm", [rounding]),
        Parameter::new("wall_normal", normal.to_array()),
        Parameter::new("wall_voxels_t", [t]),
        Parameter::new("voxel_extent_h_mm", [h]),
        Parameter::new("wall_mm", [wall]),
    ]);
    Composition {
        scene,
        truth_layer: 0,
        other_layer: Some(1),
        seed: first.centre,
        genus: 0,
        contrast: colours.contrast(),
        output: ScalarType::F32,
        bias: None,
        essential,
        context: Vec::new(),
        truth_hull: corner_balls(&first, 0.0),
        other_hull: corner_balls(&second, 0.0),
        parameters,
    }
}

/// Balls at the centres of a rounded box's corner roundings: their hull is the box.
fn corner_balls(b: &RoundedBox, margin: f64) -> Vec<Ball> {
    let inner = b.half - b.rounding;
    (0..8)
        .map(|corner| {
            let sign = DVec3::new(
                if corner & 1 == 0 { -1.0 } else { 1.0 },
                if corner & 2 == 0 { -1.0 } else { 1.0 },
                if corner & 4 == 0 { -1.0 } else { 1.0 },
            );
            Ball {
                centre: b.centre + b.axes * (sign * inner),
                radius: b.rounding + margin,
            }
        })
        .collect()
}
