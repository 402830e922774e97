//! Family `stent`: a contrast lumen (radius U[4, 10] mm, ~40 mm long, U[250, 450] HU) in
//! thrombus or soft tissue (40 HU, 3–8 mm thick) with fat beyond (−100 HU), lined by a stent:
//! a diamond lattice of two opposite families of helical wires (6–10 wires each, pitch
//! 10–16 mm, wire radius U[0.15, 0.3] mm at 2500–3500 HU) centred on the lumen's wall. The
//! wires are far thinner than a voxel; the family's PSF (σ ≥ 0.4 mm) spreads them into
//! blooming struts, as a scanner does. The truth is the lumen minus the wires' volume.

use std::f64::consts::TAU;
use std::sync::Arc;

use glam::DVec3;

use super::{Ball, Composition, Parameter, MARGIN};
use crate::error::Result;
use crate::phantom::random::SplitMix64;
use crate::phantom::scene::{Intensity, Layer, Scene};
use crate::phantom::sdf::Capsule;
use crate::phantom::tube::{Path, Tubes};
use crate::volume::ScalarType;

/// Soft tissue around the lumen, HU.
const TISSUE: f64 = 40.0;
const FAT: f64 = -100.0;
/// Angle between the points of a wire's centre line.
const WIRE_STEP: f64 = 4.0 * std::f64::consts::PI / 180.0;

pub(super) fn compose(rng: &mut SplitMix64) -> Result<Composition> {
    let radius = rng.uniform(4.0, 10.0);
    let length = rng.uniform(36.0, 44.0);
    let lumen = rng.uniform(250.0, 450.0);
    let thrombus = rng.uniform(3.0, 8.0);
    let wires = rng.integer(6, 10) as usize;
    let pitch = rng.uniform(10.0, 16.0);
    let wire_radius = rng.uniform(0.15, 0.3);
    let wire = rng.uniform(2500.0, 3500.0);
    let phase = rng.uniform(0.0, TAU);
    let half = 0.5 * length;
    // The stent stops 1 mm short of the lumen's rounded ends.
    let reach = half - 1.0;
    let steps = ((2.0 * reach / pitch * TAU) / WIRE_STEP).ceil() as usize;
    let paths: Vec<Path> = [1.0, -1.0]
        .into_iter()
        .flat_map(|hand| {
            (0..wires).map(move |k| {
                let start = phase + TAU * k as f64 / wires as f64;
                let points = (0..=steps)
                    .map(|i| {
                        let z = -reach + 2.0 * reach * i as f64 / steps as f64;
                        let angle = start + hand * TAU * z / pitch;
                        DVec3::new(radius * angle.cos(), radius * angle.sin(), z)
                    })
                    .collect();
                Path::uniform(points, wire_radius)
            })
        })
        .collect();
    let (a, b) = (-half * DVec3::Z, half * DVec3::Z);
    let capsule = |r: f64| Capsule { a, b, radius: r };
    let scene = Scene {
        background: FAT,
        layers: vec![
            Layer {
                solid: Arc::new(capsule(radius + thrombus)),
                intensity: Intensity::Constant(TISSUE),
            },
            Layer {
                solid: Arc::new(capsule(radius)),
                intensity: Intensity::Constant(lumen),
            },
            Layer {
                solid: Arc::new(Tubes::new(&paths)?),
                intensity: Intensity::Constant(wire),
            },
        ],
    };
    let balls = |r: f64| [a, b].map(|centre| Ball { centre, radius: r }).to_vec();
    Ok(Composition {
        scene,
        truth_layer: 1,
        other_layer: None,
        seed: DVec3::ZERO,
        genus: 0,
        contrast: lumen - TISSUE,
        output: ScalarType::I16,
        bias: None,
        essential: balls(radius + wire_radius + MARGIN),
        context: balls(radius + thrombus + 2.0),
        truth_hull: balls(radius),
        other_hull: Vec::new(),
        parameters: vec![
            Parameter::new("lumen_radius_mm", [radius]),
            Parameter::new("lumen_axis_mm", [length]),
            Parameter::new("lumen_hu", [lumen]),
            Parameter::new("thrombus_mm", [thrombus]),
            Parameter::new("wires_per_helix_family", [wires as f64]),
            Parameter::new("pitch_mm", [pitch]),
            Parameter::new("wire_radius_mm", [wire_radius]),
            Parameter::new("wire_hu", [wire]),
            Parameter::new("lattice_phase_rad", [phase]),
        ],
    })
}
