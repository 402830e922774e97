//! Family `touching-pair`: two capsules (radii U[3, 8] mm, axes 35–50 mm long) at an angle
//! θ ∈ U[0°, 60°] that touch: the shortest distance between their axes is r₁ + r₂ − δ with
//! δ ∈ U[0, 0.5] mm — a line or a point of contact at δ = 0, a patch beyond. The closest points
//! lie inside both axes (the contact is between the walls, not at a cap), so the distance
//! between the lines is the distance between the segments. The seeded capsule is painted on
//! top: the truth is all of it, the other object the rest of the second.

use std::sync::Arc;

use glam::{DQuat, DVec3};

use super::{Ball, BrightPair, Composition, Parameter, MARGIN};
use crate::phantom::random::SplitMix64;
use crate::phantom::scene::{Intensity, Layer, Scene};
use crate::phantom::sdf::Capsule;
use crate::volume::ScalarType;

pub(super) fn compose(rng: &mut SplitMix64) -> Composition {
    let colours = BrightPair::draw(rng);
    let (r1, r2) = (rng.uniform(3.0, 8.0), rng.uniform(3.0, 8.0));
    let (l1, l2) = (rng.uniform(35.0, 50.0), rng.uniform(35.0, 50.0));
    let theta = rng.uniform(0.0, 60.0).to_radians();
    let delta = rng.uniform(0.0, 0.5);
    // Where along each axis (from its middle) the closest points are.
    let (s1, s2) = (rng.uniform(-0.2, 0.2) * l1, rng.uniform(-0.2, 0.2) * l2);
    let (e1, across) = (DVec3::Z, DVec3::X);
    let e2 = DQuat::from_axis_angle(across, theta) * e1;
    let contact = s1 * e1;
    let closest = contact + (r1 + r2 - delta) * across;
    let first = Capsule {
        a: -0.5 * l1 * e1,
        b: 0.5 * l1 * e1,
        radius: r1,
    };
    let second = Capsule {
        a: closest - (0.5 * l2 + s2) * e2,
        b: closest + (0.5 * l2 - s2) * e2,
        radius: r2,
    };
    let balls = |c: &Capsule, margin: f64| {
        [c.a, c.b].map(|centre| Ball {
            centre,
            radius: c.radius + margin,
        })
    };
    let scene = Scene {
        background: colours.background,
        layers: vec![
            Layer {
                solid: Arc::new(second),
                intensity: Intensity::Constant(colours.second),
            },
            Layer {
                solid: Arc::new(first),
                intensity: Intensity::Constant(colours.first),
            },
        ],
    };
    let mut parameters = colours.parameters();
    parameters.extend([
        Parameter::new("radii_mm", [r1, r2]),
        Parameter::new("axis_lengths_mm", [l1, l2]),
        Parameter::new("angle_deg", [theta.to_degrees()]),
        Parameter::new("overlap_delta_mm", [delta]),
        Parameter::new("axis_distance_mm", [r1 + r2 - delta]),
        Parameter::new(
            "first_axis",
            [first.a.to_array(), first.b.to_array()].concat(),
        ),
        Parameter::new(
            "second_axis",
            [second.a.to_array(), second.b.to_array()].concat(),
        ),
    ]);
    Composition {
        scene,
        truth_layer: 1,
        other_layer: Some(0),
        seed: DVec3::ZERO,
        genus: 0,
        contrast: colours.contrast(),
        output: ScalarType::F32,
        bias: None,
        essential: [balls(&first, MARGIN), balls(&second, MARGIN)].concat(),
        context: Vec::new(),
        truth_hull: balls(&first, 0.0).to_vec(),
        other_hull: balls(&second, 0.0).to_vec(),
        parameters,
    }
}
