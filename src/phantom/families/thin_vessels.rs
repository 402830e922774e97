//! Family `thin-vessels`: an MR-like angiogram of thin tortuous vessels around a ring, like
//! the circle of Willis. The ring is a perturbed ellipse (semi-axes 9–15 mm) in a random plane
//! with smooth in- and out-of-plane wiggles of 1–3 mm, its tube radius U[1.5, 2.5] × the mean
//! spacing; 2–3 tortuous branches leave it and taper to as little as 1.5 × the mean spacing,
//! and a feeding trunk (radius U[2.5, 3.5] × the mean spacing) joins it. Branches and the trunk
//! run out of the volume: their ends are open, cut by the volume's faces.
//!
//! The contrast drifts along the arc length from the trunk's: around the ring to a factor
//! f ∈ U[0.5, 2] at the point opposite the trunk, and along each branch from the ring's value
//! at its root to its own f ∈ U[0.5, 2] (smoothstep profiles, so no vessel falls below half
//! the trunk's contrast). A bias field 1 ± U[0, 0.2] multiplies everything (MR's drift). No
//! fixed units: background U[80, 300], the trunk's contrast 1–3 times the background;
//! float32. The truth is the whole network in the volume: genus 1, the ring.
//!
//! A draw whose vessels come closer to each other than 1 mm away from their junctions, or
//! whose ring closes its own hole, is drawn again.

use std::f64::consts::TAU;
use std::sync::Arc;

use glam::DVec3;

use super::{Acquisition, Ball, Composition, Parameter, MARGIN};
use crate::error::{Error, Result};
use crate::phantom::imaging::BiasField;
use crate::phantom::random::SplitMix64;
use crate::phantom::scene::{Intensity, Layer, Scene};
use crate::phantom::sdf::Sdf;
use crate::phantom::tube::{Path, Tubes};
use crate::volume::ScalarType;

/// Points on the ring's centre line.
const RING_POINTS: usize = 240;
/// Distance between the points of a branch's or the trunk's centre line, mm.
const STEP: f64 = 0.4;
/// The trunk's length, enough to leave the volume.
const TRUNK_LENGTH: f64 = 30.0;
/// Clearance between vessels away from their junctions, mm.
const CLEARANCE: f64 = 1.0;
const ATTEMPTS: usize = 100;

/// A smooth random function: a sum of two sinusoids scaled so that its largest magnitude on
/// the sampled domain is `amplitude`.
struct Wiggle {
    terms: [(f64, f64, f64); 2],
}

impl Wiggle {
    /// `frequencies` in radians per unit of the argument; the domain is sampled at `samples`.
    fn draw(
        rng: &mut SplitMix64,
        amplitude: f64,
        frequencies: [f64; 2],
        samples: &[f64],
    ) -> Wiggle {
        let mut terms = frequencies.map(|f| (rng.uniform(0.2, 1.0), f, rng.uniform(0.0, TAU)));
        let raw = Wiggle { terms };
        let peak = samples.iter().map(|&x| raw.at(x).abs()).fold(0.0, f64::max);
        for term in &mut terms {
            term.0 *= amplitude / peak;
        }
        Wiggle { terms }
    }

    fn at(&self, x: f64) -> f64 {
        self.terms
            .iter()
            .map(|(a, f, p)| a * (f * x + p).sin())
            .sum()
    }
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// A tortuous vessel leaving `root` along `direction`: it starts straight and wiggles by up to
/// `amplitude` across, its radius going linearly from `radii.0` to `radii.1`.
fn tortuous(
    rng: &mut SplitMix64,
    root: DVec3,
    direction: DVec3,
    length: f64,
    amplitude: f64,
    radii: (f64, f64),
) -> Path {
    let n = (length / STEP).ceil() as usize;
    let s: Vec<f64> = (0..=n).map(|i| length * i as f64 / n as f64).collect();
    let (across1, across2) = direction.any_orthonormal_pair();
    let mut wiggle = || {
        let wavelengths = [rng.uniform(12.0, 30.0), rng.uniform(12.0, 30.0)];
        Wiggle::draw(rng, amplitude, wavelengths.map(|w| TAU / w), &s)
    };
    let (w1, w2) = (wiggle(), wiggle());
    let points = s
        .iter()
        .map(|&s| {
            let bend = smoothstep(s / 8.0);
            root + s * direction + bend * (w1.at(s) * across1 + w2.at(s) * across2)
        })
        .collect();
    let radii = s
        .iter()
        .map(|&s| radii.0 + (radii.1 - radii.0) * s / length)
        .collect();
    Path { points, radii }
}

/// The drawn network, before the checks.
struct Network {
    /// Trunk (from its open end to the ring), ring (closed, from the trunk's junction),
    /// branches (from the ring out).
    paths: Vec<Path>,
    /// The contrast factor at the ring's far point and at each branch's end.
    ring_far: f64,
    branch_ends: Vec<f64>,
    /// Arc length along the ring of each branch's root.
    branch_roots: Vec<f64>,
    parameters: Vec<Parameter>,
}

impl Network {
    fn draw(rng: &mut SplitMix64, mean_spacing: f64) -> Network {
        let plane = rng.rotation();
        let (a, b) = (rng.uniform(9.0, 15.0), rng.uniform(9.0, 15.0));
        let angles: Vec<f64> = (0..RING_POINTS)
            .map(|i| TAU * i as f64 / RING_POINTS as f64)
            .collect();
        let amplitude = rng.uniform(1.0, 3.0);
        let in_plane = Wiggle::draw(rng, amplitude, [2.0, 3.0], &angles);
        let amplitude = rng.uniform(1.0, 3.0);
        let out_of_plane = Wiggle::draw(rng, amplitude, [2.0, 3.0], &angles);
        let ring_radius = rng.uniform(1.5, 2.5) * mean_spacing;
        let trunk_radius = rng.uniform(2.5, 3.5) * mean_spacing;
        let junction = rng.uniform(0.0, TAU);
        let ring_point = |phi: f64| {
            let local = DVec3::new(
                (a + in_plane.at(phi)) * phi.cos(),
                (b + in_plane.at(phi)) * phi.sin(),
                out_of_plane.at(phi),
            );
            plane * local
        };
        // Outward along the ring's plane, tilted out of it by `tilt`.
        let outward = |phi: f64, tilt: f64| {
            let p = ring_point(phi);
            let radial = (p - plane.z_axis * p.dot(plane.z_axis)).normalize();
            (tilt.cos() * radial + tilt.sin() * plane.z_axis).normalize()
        };
        let mut ring: Vec<DVec3> = (0..=RING_POINTS)
            .map(|i| ring_point(junction + TAU * i as f64 / RING_POINTS as f64))
            .collect();
        *ring.last_mut().expect("the ring has points") = ring[0];
        let ring = Path::uniform(ring, ring_radius);

        let tilt = rng.uniform(-40.0, 40.0).to_radians();
        let wiggle = rng.uniform(0.5, 1.5);
        let mut trunk = tortuous(
            rng,
            ring.points[0],
            outward(junction, tilt),
            TRUNK_LENGTH,
            wiggle,
            (trunk_radius, trunk_radius),
        );
        trunk.points.reverse();

        let count = rng.integer(2, 3) as usize;
        let ring_far = rng.uniform(0.5, 2.0);
        let mut paths = vec![trunk, ring];
        let (mut branch_ends, mut branch_roots) = (Vec::new(), Vec::new());
        let mut branch_parameters = Vec::new();
        for k in 0..count {
            let fraction = (k as f64 + 1.0 + rng.uniform(-0.25, 0.25)) / (count as f64 + 1.0);
            let phi = junction + TAU * fraction;
            let tilt = rng.uniform(-50.0, 50.0).to_radians();
            let length = rng.uniform(20.0, 30.0);
            let amplitude = rng.uniform(1.0, 3.0);
            let end_radius = rng.uniform(1.5 * mean_spacing, ring_radius);
            let root = ring_point(phi);
            paths.push(tortuous(
                rng,
                root,
                outward(phi, tilt),
                length,
                amplitude,
                (ring_radius, end_radius),
            ));
            branch_ends.push(rng.uniform(0.5, 2.0));
            branch_roots.push(fraction * paths[1].length());
            branch_parameters.extend([fraction, tilt.to_degrees(), length, end_radius]);
        }
        Network {
            parameters: vec![
                Parameter::new("ring_semi_axes_mm", [a, b]),
                Parameter::new("ring_plane_normal", plane.z_axis.to_array()),
                Parameter::new("ring_radius_mm", [ring_radius]),
                Parameter::new("trunk_radius_mm", [trunk_radius]),
                Parameter::new("trunk_tilt_deg", [tilt.to_degrees()]),
                Parameter::new("ring_far_factor", [ring_far]),
                Parameter::new("branch_end_factors", branch_ends.clone()),
                Parameter::new(
                    "branches_root_fraction_tilt_deg_length_mm_end_radius_mm",
                    branch_parameters,
                ),
            ],
            paths,
            ring_far,
            branch_ends,
            branch_roots,
        }
    }

    /// Whether vessels keep clear of each other away from their junctions and the ring's hole
    /// stays open.
    fn is_clear(&self, tubes: &Tubes) -> bool {
        let ring = &self.paths[1];
        let perimeter = ring.length();
        let r = ring.radii[0];
        // The ring against itself, beyond the stretch where it bends away from a point.
        let n = ring.points.len() - 1;
        for i in 0..n {
            for j in i + 1..n {
                let along = perimeter * ((j - i) as f64 / n as f64);
                let along = along.min(perimeter - along);
                if along > 4.0 * r + 2.0 * CLEARANCE
                    && ring.points[i].distance(ring.points[j]) < 2.0 * r + CLEARANCE
                {
                    return false;
                }
            }
        }
        // The ring is drawn around the origin: its hole.
        if tubes.distance(DVec3::ZERO) < CLEARANCE {
            return false;
        }
        // Trunk and branches: clear of the ring beyond their roots, and of each other.
        let others: Vec<(usize, &Path)> = self
            .paths
            .iter()
            .enumerate()
            .filter(|&(i, _)| i != 1)
            .collect();
        let ring_only = Tubes::new(std::slice::from_ref(ring)).expect("the ring is a valid path");
        for &(i, path) in &others {
            let root = if i == 0 { path.points.len() - 1 } else { 0 };
            for (k, (&p, &radius)) in path.points.iter().zip(&path.radii).enumerate() {
                let from_root = STEP * k.abs_diff(root) as f64;
                if from_root > radius + r + 2.0 * CLEARANCE
                    && ring_only.distance(p) < radius + CLEARANCE
                {
                    return false;
                }
            }
            for &(j, other) in &others {
                if j <= i {
                    continue;
                }
                let close = path.points.iter().zip(&path.radii).any(|(&p, &rp)| {
                    other
                        .points
                        .iter()
                        .zip(&other.radii)
                        .any(|(&q, &rq)| p.distance(q) < rp + rq + CLEARANCE)
                });
                if close {
                    return false;
                }
            }
        }
        true
    }

    /// The contrast factor at arc length `s` of path `path`.
    fn factor(&self, path: usize, s: f64) -> f64 {
        let perimeter = self.paths[1].length();
        let ring = |s: f64| {
            let s = s.rem_euclid(perimeter);
            let from_junction = s.min(perimeter - s);
            1.0 + (self.ring_far - 1.0) * smoothstep(from_junction / (0.5 * perimeter))
        };
        match path {
            0 => 1.0,
            1 => ring(s),
            branch => {
                let k = branch - 2;
                let root = ring(self.branch_roots[k]);
                let length = self.paths[branch].length();
                root + (self.branch_ends[k] - root) * smoothstep(s / length)
            }
        }
    }
}

pub(super) fn compose(rng: &mut SplitMix64, scan: &Acquisition) -> Result<Composition> {
    let background = rng.uniform(80.0, 300.0);
    let contrast = background * rng.uniform(1.0, 3.0);
    let bias = BiasField {
        centre: DVec3::ZERO,
        direction: rng.direction(),
        wavelength: rng.uniform(100.0, 200.0),
        phase: rng.uniform(0.0, TAU),
        amplitude: rng.uniform(0.0, 0.2),
    };
    for _ in 0..ATTEMPTS {
        let network = Network::draw(rng, scan.mean_spacing());
        let tubes = Arc::new(Tubes::new(&network.paths)?);
        if !network.is_clear(&tubes) {
            continue;
        }
        let trunk = &network.paths[0];
        let ring = &network.paths[1];
        let trunk_radius = trunk.radii[0];
        let seed = trunk.at(trunk.length() - (trunk_radius + ring.radii[0] + 2.0));
        let mut essential: Vec<Ball> = ring
            .points
            .iter()
            .map(|&centre| Ball {
                centre,
                radius: ring.radii[0] + MARGIN,
            })
            .collect();
        essential.push(Ball {
            centre: seed,
            radius: trunk_radius + MARGIN,
        });
        let truth_hull = network
            .paths
            .iter()
            .flat_map(|p| {
                p.points
                    .iter()
                    .zip(&p.radii)
                    .map(|(&centre, &radius)| Ball { centre, radius })
            })
            .collect();
        let mut parameters = vec![
            Parameter::new("background", [background]),
            Parameter::new("trunk_contrast", [contrast]),
            Parameter::new(
                "bias_amplitude_wavelength_mm",
                [bias.amplitude, bias.wavelength],
            ),
        ];
        parameters.extend(network.parameters.iter().cloned());
        let field = {
            let tubes = tubes.clone();
            move |p: DVec3| {
                let nearest = tubes.nearest(p);
                background + contrast * network.factor(nearest.path, nearest.arc_length)
            }
        };
        return Ok(Composition {
            scene: Scene {
                background,
                layers: vec![Layer {
                    solid: tubes,
                    intensity: Intensity::Field(Arc::new(field)),
                }],
            },
            truth_layer: 0,
            other_layer: None,
            seed,
            genus: 1,
            contrast,
            output: ScalarType::F32,
            bias: Some(bias),
            essential,
            context: Vec::new(),
            truth_hull,
            other_hull: Vec::new(),
            parameters,
        });
    }
    Err(Error::internal(format!(
        "no clear vessel network in {ATTEMPTS} draws"
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_contrast_is_continuous_at_the_junctions_and_within_its_range() {
        let mut rng = SplitMix64::new(8);
        let network = Network::draw(&mut rng, 0.9);
        let perimeter = network.paths[1].length();
        assert!((network.factor(1, 0.0) - 1.0).abs() < 1e-12);
        assert!((network.factor(1, perimeter) - 1.0).abs() < 1e-12);
        assert!((network.factor(1, 0.5 * perimeter) - network.ring_far).abs() < 1e-12);
        for (k, &root) in network.branch_roots.iter().enumerate() {
            assert!((network.factor(2 + k, 0.0) - network.factor(1, root)).abs() < 1e-12);
        }
        for path in 0..network.paths.len() {
            let length = network.paths[path].length();
            for i in 0..=100 {
                let f = network.factor(path, length * i as f64 / 100.0);
                assert!((0.5..=2.0).contains(&f), "{path} {f}");
            }
        }
    }
}
