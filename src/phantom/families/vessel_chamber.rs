//! Family `vessel-chamber`: a vessel that opens into a chamber of the same brightness, as the
//! aorta opens into the left ventricle — no wall between them, so one balloon fills both. The
//! chamber is a ball (radius R ∈ U[11, 18] mm; a sphere's distance is exact, so the partial
//! volume of the vessel's end is too); the vessel a capsule of radius r ∈ U[2.5, 6] mm from the
//! ball's centre, running L ∈ U[25, 40] mm beyond it. The vessel meets the chamber on a circle,
//! in the plane across its axis at √(R² − r²) from the chamber's centre: the opening. The truth
//! is the vessel outside the chamber, the other object the chamber; the seed is half way along
//! the vessel.

use std::sync::Arc;

use glam::DVec3;

use super::{Ball, BrightPair, Composition, Parameter, MARGIN};
use crate::phantom::random::SplitMix64;
use crate::phantom::scene::{Intensity, Layer, Scene};
use crate::phantom::sdf::Capsule;
use crate::volume::ScalarType;

pub(super) fn compose(rng: &mut SplitMix64) -> Composition {
    let mut colours = BrightPair::draw(rng);
    colours.second = colours.first;
    let big = rng.uniform(11.0, 18.0);
    let r = rng.uniform(2.5, 6.0);
    let length = rng.uniform(25.0, 40.0);
    let axis = DVec3::X;
    let opening = (big * big - r * r).sqrt();
    let chamber = Capsule {
        a: DVec3::ZERO,
        b: DVec3::ZERO,
        radius: big,
    };
    // From the chamber's centre, so that the two join without a seam.
    let vessel = Capsule {
        a: DVec3::ZERO,
        b: (big + length) * axis,
        radius: r,
    };
    let scene = Scene {
        background: colours.background,
        layers: vec![
            Layer {
                solid: Arc::new(vessel),
                intensity: Intensity::Constant(colours.first),
            },
            Layer {
                solid: Arc::new(chamber),
                intensity: Intensity::Constant(colours.second),
            },
        ],
    };
    let vessel_balls = |margin: f64| {
        [opening * axis, vessel.b].map(|centre| Ball {
            centre,
            radius: r + margin,
        })
    };
    let chamber_ball = |margin: f64| Ball {
        centre: DVec3::ZERO,
        radius: big + margin,
    };
    let mut parameters = colours.parameters();
    parameters.extend([
        Parameter::new("chamber_radius_mm", [big]),
        Parameter::new("vessel_radius_mm", [r]),
        Parameter::new("vessel_length_mm", [length]),
        Parameter::new("opening_centre", (opening * axis).to_array()),
        Parameter::new("opening_normal", axis.to_array()),
    ]);
    Composition {
        scene,
        truth_layer: 0,
        other_layer: Some(1),
        seed: (0.5 * (opening + big + length)) * axis,
        genus: 0,
        contrast: colours.contrast(),
        output: ScalarType::F32,
        bias: None,
        essential: [vessel_balls(MARGIN).as_slice(), &[chamber_ball(MARGIN)]].concat(),
        context: Vec::new(),
        truth_hull: vessel_balls(0.0).to_vec(),
        other_hull: vec![chamber_ball(0.0)],
        parameters,
    }
}
