//! Family `ct-scene`: a CT-like thorax or abdomen around a contrast vessel, in Hounsfield units
//! (int16). In the vessel's cross-section at the seed, angle 0 on the arc's convex side: the
//! lung at 0° ± 15° and the skin beyond it, the vertebra at 130–170° to one side, the second
//! vessel at 100–140° to the other.
//!
//! Bottom to top, each layer painted over the ones below:
//! - air (−1000) outside a body, an elliptic cylinder along z (semi-axes 110–160 and
//!   90–130 mm) with a subcutaneous fat layer (−100 HU, 3–6 mm) around soft tissue (40 HU);
//! - a peri-vascular fat sheath (−100 HU, 0.5–3 mm) on the part of the vessel's circumference
//!   beyond a plane along it; soft tissue touches the vessel everywhere else;
//! - a lung (−850 HU, an ellipsoid) 3–8 mm from the vessel's wall, kept 3–8 mm (a chest wall)
//!   inside the soft tissue; the skin lies 5–20 mm of lung beyond that;
//! - a vertebra-like bone: a rounded cylinder along z (radius 14–20 mm), its cortex 1–2 mm at
//!   U[700, 1200] HU around marrow at U[150, 300] HU, 1–4 mm from the vessel (the gap soft
//!   tissue, or fat where the sheath reaches);
//! - a second contrast vessel (radius U[2, 8] mm, intensity within ±25% of the first's),
//!   straight, turned up to 40° from the first across the line between them, its wall
//!   U[1.5, 3] mm from the first's at the closest;
//! - the seeded vessel: a tube along an arc (bending radius 80–200 mm, 45–55 mm long, capped
//!   well inside the volume), radius U[4, 12] mm, U[180, 450] HU;
//! - 0–4 calcifications on its wall (ellipsoids 1–2.5 mm across, U[600, 1200] HU), half in the
//!   lumen, at least 6 mm of arc from the seed.
//!
//! The lung is placed against a tangent plane (the ellipsoid touching the point at the drawn
//! gap, on the arc's convex side, so nothing else of the arc comes nearer); the bone and the
//! second vessel are moved away along their directions until the gap is the drawn one
//! (`placement`). A draw where neighbours come within 1 mm of each other or leave the soft
//! tissue is drawn again (about one in five, mostly a steeply turned second vessel reaching the
//! bone). The truth is the seeded lumen minus the calcifications, genus 0; the other object the
//! second vessel. The noise follows the vessel's contrast against soft tissue.

use std::f64::consts::TAU;
use std::sync::Arc;

use glam::{DMat3, DQuat, DVec2, DVec3};

use super::placement::{min_along, place_beside};
use super::{Ball, Composition, Parameter, MARGIN};
use crate::error::{Error, Result};
use crate::phantom::random::SplitMix64;
use crate::phantom::scene::{Intensity, Layer, Scene};
use crate::phantom::sdf::{
    Capsule, Ellipsoid, EllipticCylinder, HalfSpace, Intersection, Offset, RoundedCylinder, Sdf,
    Solid,
};
use crate::phantom::tube::{Path, Tubes};
use crate::volume::ScalarType;

const AIR: f64 = -1000.0;
const FAT: f64 = -100.0;
const TISSUE: f64 = 40.0;
const LUNG: f64 = -850.0;
/// Distance between the points of the vessel's centre line, mm.
const STEP: f64 = 0.5;
/// Calcifications keep this far (mm of arc) from the seed at the vessel's middle.
const SEED_CLEARANCE: f64 = 6.0;
const ATTEMPTS: usize = 100;

/// The seeded vessel: an arc through the origin with tangent z there, bending towards `inward`.
struct CurvedAxis {
    inward: DVec3,
    bend: f64,
    length: f64,
}

impl CurvedAxis {
    fn point(&self, s: f64) -> DVec3 {
        let a = s / self.bend;
        self.bend * (a.sin() * DVec3::Z + (1.0 - a.cos()) * self.inward)
    }

    /// The unit normal towards the centre of curvature at arc length `s`.
    fn normal(&self, s: f64) -> DVec3 {
        let a = s / self.bend;
        -a.sin() * DVec3::Z + a.cos() * self.inward
    }

    fn centre_line(&self) -> Vec<DVec3> {
        let n = (self.length / STEP).ceil() as usize;
        (0..=n)
            .map(|i| self.point(self.length * (i as f64 / n as f64 - 0.5)))
            .collect()
    }
}

pub(super) fn compose(rng: &mut SplitMix64) -> Result<Composition> {
    for _ in 0..ATTEMPTS {
        if let Some(c) = attempt(rng)? {
            return Ok(c);
        }
    }
    Err(Error::internal(format!(
        "no CT scene without overlaps in {ATTEMPTS} draws"
    )))
}

/// One draw of the scene; `None` when its neighbours overlap or leave the body.
fn attempt(rng: &mut SplitMix64) -> Result<Option<Composition>> {
    let r1 = rng.uniform(4.0, 12.0);
    let vessel_hu = rng.uniform(180.0, 450.0);
    let gamma = rng.uniform(0.0, TAU);
    let inward = DVec3::new(gamma.cos(), gamma.sin(), 0.0);
    let arc = CurvedAxis {
        inward,
        bend: rng.uniform(80.0, 200.0),
        length: rng.uniform(45.0, 55.0),
    };
    let line = arc.centre_line();
    let binormal = DVec3::Z.cross(inward);
    // Directions across the vessel at the seed: angle 0 is the arc's convex side.
    let across = |degrees: f64| {
        let (s, c) = degrees.to_radians().sin_cos();
        -c * inward + s * binormal
    };
    let side = rng.sign();

    // Lung, on the convex side: touching the plane at the drawn gap from the wall.
    let lung_gap = rng.uniform(3.0, 8.0);
    let lung_angle = rng.uniform(-15.0, 15.0);
    let lung_direction = across(lung_angle);
    let lung_turn = rng.uniform(0.0, TAU);
    let lung_radii = DVec3::new(
        rng.uniform(25.0, 45.0),
        rng.uniform(35.0, 60.0),
        rng.uniform(60.0, 100.0),
    );
    let lung_point = (r1 + lung_gap) * lung_direction;
    let lung = Ellipsoid::touching(
        lung_point,
        -lung_direction,
        DMat3::from_rotation_z(lung_turn),
        lung_radii,
    );

    // Bone: moved out along its direction until its cortex is at the drawn gap.
    let bone_radius = rng.uniform(14.0, 20.0);
    let bone_half_height = rng.uniform(10.0, 14.0);
    let bone_rounding = rng.uniform(2.0, 4.0);
    let cortex = rng.uniform(1.0, 2.0);
    let cortex_hu = rng.uniform(700.0, 1200.0);
    let marrow_hu = rng.uniform(150.0, 300.0);
    let bone_gap = rng.uniform(1.0, 4.0);
    let bone_direction = across(side * rng.uniform(130.0, 170.0));
    let bone_at = |t: f64| RoundedCylinder {
        centre: t * bone_direction,
        axis: DVec3::Z,
        radius: bone_radius,
        half_height: bone_half_height,
        rounding: bone_rounding,
    };
    let bone = place_beside(&line, r1, bone_gap, r1 + bone_radius, bone_at)?;

    // The second vessel, likewise.
    let r2 = rng.uniform(2.0, 8.0);
    let second_hu = vessel_hu * rng.uniform(0.75, 1.25);
    let second_length = rng.uniform(40.0, 55.0);
    let second_angle = rng.uniform(-40.0, 40.0).to_radians();
    let second_gap = rng.uniform(1.5, 3.0);
    let second_direction = across(-side * rng.uniform(100.0, 140.0));
    let along = DQuat::from_axis_angle(second_direction, second_angle) * DVec3::Z;
    let second_at = |t: f64| Capsule {
        a: t * second_direction - 0.5 * second_length * along,
        b: t * second_direction + 0.5 * second_length * along,
        radius: r2,
    };
    let second = place_beside(&line, r1, second_gap, r1 + r2, second_at)?;

    // The body: beyond the lung, a chest wall of soft tissue, the fat and the skin, which
    // crosses the drawn direction at the drawn gap from the vessel's wall and is nearest to the
    // seed there (the gap is below the ellipse's smallest bending radius).
    let fat = rng.uniform(3.0, 6.0);
    let chest_wall = rng.uniform(3.0, 8.0);
    let skin_gap = lung_gap + chest_wall + fat + rng.uniform(5.0, 20.0);
    let skin_direction = across(lung_angle + rng.uniform(-20.0, 20.0));
    let body_axes = DMat3::from_rotation_z(rng.uniform(0.0, TAU));
    let body_radii = DVec2::new(rng.uniform(110.0, 160.0), rng.uniform(90.0, 130.0));
    let skin_point = (r1 + skin_gap) * skin_direction;
    let body_centre = Ellipsoid::touching(
        skin_point,
        skin_direction,
        body_axes,
        body_radii.extend(1.0),
    )
    .centre;
    let body = EllipticCylinder {
        centre: body_centre,
        axes: body_axes,
        radii: body_radii,
    };
    let tissue = EllipticCylinder {
        radii: body_radii - fat,
        ..body
    };

    // The sheath: the vessel grown by its width, beyond a plane along the vessel.
    let sheath_width = rng.uniform(0.5, 3.0);
    let sheath_facing = across(rng.uniform(0.0, 360.0));
    let sheath_offset = rng.uniform(-0.6, 0.6) * (r1 + sheath_width);

    let calcifications = draw_calcifications(rng, &arc, r1);

    let bone_axis = [
        bone.centre - bone_half_height * DVec3::Z,
        bone.centre + bone_half_height * DVec3::Z,
    ];
    let second_axis = [second.a, second.b];
    let inside_tissue =
        |points: &[DVec3], radius: f64| points.iter().all(|&p| tissue.distance(p) + radius <= -2.0);
    let clear = min_along(&second_axis, &bone) - r2 >= 1.0
        && min_along(&second_axis, &lung) - r2 >= 1.0
        && min_along(&bone_axis, &lung) - bone_radius >= 1.0
        && inside_tissue(&line, r1 + sheath_width)
        && inside_tissue(&second_axis, r2)
        && inside_tissue(&bone_axis, bone_radius);
    if !clear {
        return Ok(None);
    }

    let vessel_path = |radius: f64| Tubes::new(&[Path::uniform(line.clone(), radius)]);
    let sheath = Intersection(vec![
        Arc::new(vessel_path(r1 + sheath_width)?),
        Arc::new(HalfSpace {
            point: sheath_offset * sheath_facing,
            normal: -sheath_facing,
        }),
    ]);
    let tissue: Solid = Arc::new(tissue);
    let bone: Solid = Arc::new(bone);
    let constant = |solid: Solid, hu: f64| Layer {
        solid,
        intensity: Intensity::Constant(hu),
    };
    let mut layers = vec![
        constant(Arc::new(body), FAT),
        constant(tissue.clone(), TISSUE),
        constant(Arc::new(sheath), FAT),
        constant(
            Arc::new(Intersection(vec![
                Arc::new(lung),
                Arc::new(Offset(tissue, -chest_wall)),
            ])),
            LUNG,
        ),
        constant(bone.clone(), cortex_hu),
        constant(Arc::new(Offset(bone, -cortex)), marrow_hu),
        constant(Arc::new(second), second_hu),
        constant(Arc::new(vessel_path(r1)?), vessel_hu),
    ];
    let truth_layer = layers.len() - 1;
    let mut calcification_parameters = Vec::new();
    for (c, hu) in &calcifications {
        layers.push(constant(Arc::new(*c), *hu));
        calcification_parameters.extend(c.centre.to_array());
        calcification_parameters.extend(c.radii.to_array());
        calcification_parameters.push(*hu);
    }

    let vessel_balls = |margin: f64| -> Vec<Ball> {
        line.iter()
            .map(|&centre| Ball {
                centre,
                radius: r1 + margin,
            })
            .collect()
    };
    let second_balls = |margin: f64| {
        second_axis.map(|centre| Ball {
            centre,
            radius: r2 + margin,
        })
    };
    let mut essential = vessel_balls(MARGIN);
    essential.extend(second_balls(MARGIN));
    let context = vec![
        Ball {
            centre: skin_point,
            radius: 8.0,
        },
        Ball {
            centre: lung_point,
            radius: 8.0,
        },
        Ball {
            centre: bone_axis[0].lerp(bone_axis[1], 0.5),
            radius: bone_radius + 2.0,
        },
    ];
    Ok(Some(Composition {
        scene: Scene {
            background: AIR,
            layers,
        },
        truth_layer,
        other_layer: Some(truth_layer - 1),
        seed: DVec3::ZERO,
        genus: 0,
        contrast: vessel_hu - TISSUE,
        output: ScalarType::I16,
        bias: None,
        essential,
        context,
        truth_hull: vessel_balls(0.0),
        other_hull: second_balls(0.0).to_vec(),
        parameters: vec![
            Parameter::new("vessel_radius_mm", [r1]),
            Parameter::new("vessel_hu", [vessel_hu]),
            Parameter::new("vessel_length_mm", [arc.length]),
            Parameter::new("vessel_bend_radius_mm", [arc.bend]),
            Parameter::new("vessel_bends_towards", inward.to_array()),
            Parameter::new("lung_gap_mm", [lung_gap]),
            Parameter::new("lung_radii_mm", lung_radii.to_array()),
            Parameter::new("lung_centre", lung.centre.to_array()),
            Parameter::new("bone_radius_mm", [bone_radius]),
            Parameter::new("bone_half_height_mm", [bone_half_height]),
            Parameter::new("bone_gap_mm", [bone_gap]),
            Parameter::new(
                "bone_centre",
                bone_axis[0].lerp(bone_axis[1], 0.5).to_array(),
            ),
            Parameter::new("cortex_mm", [cortex]),
            Parameter::new("cortex_marrow_hu", [cortex_hu, marrow_hu]),
            Parameter::new("second_radius_mm", [r2]),
            Parameter::new("second_hu", [second_hu]),
            Parameter::new("second_angle_deg", [second_angle.to_degrees()]),
            Parameter::new("second_gap_mm", [second_gap]),
            Parameter::new(
                "second_axis",
                [second_axis[0].to_array(), second_axis[1].to_array()].concat(),
            ),
            Parameter::new("sheath_mm", [sheath_width]),
            Parameter::new("sheath_facing", sheath_facing.to_array()),
            Parameter::new("sheath_plane_offset_mm", [sheath_offset]),
            Parameter::new("fat_mm", [fat]),
            Parameter::new("chest_wall_mm", [chest_wall]),
            Parameter::new("skin_gap_mm", [skin_gap]),
            Parameter::new("body_semi_axes_mm", body_radii.to_array()),
            Parameter::new("calcifications", [calcifications.len() as f64]),
            Parameter::new("calcification_centre_radii_hu", calcification_parameters),
        ],
    }))
}

/// 0–4 calcifications: ellipsoids centred on the vessel's wall, away from the seed and from
/// each other (overlapping ones could arch over the lumen and give it a handle).
fn draw_calcifications(
    rng: &mut SplitMix64,
    arc: &CurvedAxis,
    radius: f64,
) -> Vec<(Ellipsoid, f64)> {
    let count = rng.integer(0, 4);
    let binormal = DVec3::Z.cross(arc.inward);
    let mut placed: Vec<(Ellipsoid, f64)> = Vec::new();
    for _ in 0..count {
        let radii = DVec3::new(
            rng.uniform(0.5, 1.25),
            rng.uniform(0.5, 1.25),
            rng.uniform(0.5, 1.25),
        );
        let axes = rng.rotation();
        let hu = rng.uniform(600.0, 1200.0);
        let reach = 0.5 * arc.length - 3.0 - SEED_CLEARANCE;
        let s = rng.sign() * (SEED_CLEARANCE + rng.uniform(0.0, reach));
        let (sin, cos) = rng.uniform(0.0, TAU).sin_cos();
        let centre = arc.point(s) + radius * (cos * arc.normal(s) + sin * binormal);
        let apart = placed.iter().all(|(c, _)| {
            c.centre.distance(centre) > c.radii.max_element() + radii.max_element() + 1.0
        });
        if apart {
            placed.push((
                Ellipsoid {
                    centre,
                    axes,
                    radii,
                },
                hu,
            ));
        }
    }
    placed
}
