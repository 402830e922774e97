//! Signed distance functions (world mm, negative inside) of the solids the phantom families
//! are built from, and the set operations that combine them (after Quilez's primitives).
//!
//! Every function here has the exact sign, and its magnitude never exceeds the distance to the
//! surface (it is 1-Lipschitz): that is what the renderer needs to know a voxel lies wholly on
//! one side without sampling it, and what lets a union (min), an intersection or a difference
//! (max) of them stay valid (a scene's layers are differences: `scene::visible`). Capsules, rounded boxes, rounded cylinders and half-spaces are exact;
//! ellipsoids and elliptic cylinders are the scaled-sphere bound (exact on the axes), where an
//! exact distance would need an iteration per point.

use std::sync::Arc;

use glam::{DMat3, DVec2, DVec3};

/// A solid given by its signed distance (or a 1-Lipschitz bound with the exact sign).
pub trait Sdf: Send + Sync {
    fn distance(&self, p: DVec3) -> f64;
}

/// A shared solid: scenes and truths hold the same ones.
pub type Solid = Arc<dyn Sdf>;

/// The points within `radius` of the segment a–b: a cylinder with hemispherical caps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capsule {
    pub a: DVec3,
    pub b: DVec3,
    pub radius: f64,
}

impl Sdf for Capsule {
    fn distance(&self, p: DVec3) -> f64 {
        segment_distance(p, self.a, self.b) - self.radius
    }
}

/// Distance from `p` to the segment a–b (a point when a = b).
pub fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let length_squared = ab.length_squared();
    let t = if length_squared > 0.0 {
        ((p - a).dot(ab) / length_squared).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + t * ab)).length()
}

/// A box with rounded edges and corners: `half` is the half-size to the flat faces, `rounding`
/// the radius of the edges; `axes` (columns) are the box's axes in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundedBox {
    pub centre: DVec3,
    pub axes: DMat3,
    pub half: DVec3,
    pub rounding: f64,
}

impl Sdf for RoundedBox {
    fn distance(&self, p: DVec3) -> f64 {
        let local = self.axes.transpose() * (p - self.centre);
        let q = local.abs() - (self.half - self.rounding);
        q.max(DVec3::ZERO).length() + q.max_element().min(0.0) - self.rounding
    }
}

/// A cylinder of `radius` and half-height `half_height` along the unit `axis`, its rims
/// rounded by `rounding`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundedCylinder {
    pub centre: DVec3,
    pub axis: DVec3,
    pub radius: f64,
    pub half_height: f64,
    pub rounding: f64,
}

impl Sdf for RoundedCylinder {
    fn distance(&self, p: DVec3) -> f64 {
        let v = p - self.centre;
        let along = v.dot(self.axis);
        let across = (v - along * self.axis).length();
        let q = DVec2::new(
            across - self.radius + self.rounding,
            along.abs() - self.half_height + self.rounding,
        );
        q.max(DVec2::ZERO).length() + q.max_element().min(0.0) - self.rounding
    }
}

/// An ellipsoid with semi-axes `radii` along the columns of `axes`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    pub centre: DVec3,
    pub axes: DMat3,
    pub radii: DVec3,
}

impl Ellipsoid {
    /// The ellipsoid whose surface point with outward normal `normal` (unit) is `surface_point`:
    /// a convex solid placed so that it touches a plane at a chosen point.
    pub fn touching(surface_point: DVec3, normal: DVec3, axes: DMat3, radii: DVec3) -> Ellipsoid {
        let n = axes.transpose() * normal;
        let scaled = radii * radii * n;
        let local = scaled / (radii * n).length();
        Ellipsoid {
            centre: surface_point - axes * local,
            axes,
            radii,
        }
    }
}

impl Sdf for Ellipsoid {
    fn distance(&self, p: DVec3) -> f64 {
        let local = self.axes.transpose() * (p - self.centre);
        ((local / self.radii).length() - 1.0) * self.radii.min_element()
    }
}

/// An infinite cylinder with an elliptic cross-section: semi-axes `radii` along the first two
/// columns of `axes`, the third its axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EllipticCylinder {
    pub centre: DVec3,
    pub axes: DMat3,
    pub radii: DVec2,
}

impl Sdf for EllipticCylinder {
    fn distance(&self, p: DVec3) -> f64 {
        let v = p - self.centre;
        let local = DVec2::new(v.dot(self.axes.x_axis), v.dot(self.axes.y_axis));
        ((local / self.radii).length() - 1.0) * self.radii.min_element()
    }
}

/// The points behind a plane: `normal` (unit) points out of the solid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HalfSpace {
    pub point: DVec3,
    pub normal: DVec3,
}

impl Sdf for HalfSpace {
    fn distance(&self, p: DVec3) -> f64 {
        (p - self.point).dot(self.normal)
    }
}

/// The solid grown by `amount` mm (shrunk when negative). Exact offsets of exact distances;
/// of a bound, a bound of a slightly different solid.
pub struct Offset(pub Solid, pub f64);

impl Sdf for Offset {
    fn distance(&self, p: DVec3) -> f64 {
        self.0.distance(p) - self.1
    }
}

/// What all the solids share.
pub struct Intersection(pub Vec<Solid>);

impl Sdf for Intersection {
    fn distance(&self, p: DVec3) -> f64 {
        self.0
            .iter()
            .map(|s| s.distance(p))
            .fold(f64::NEG_INFINITY, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Checks the sign and the 1-Lipschitz bound on random pairs of points.
    fn check_bound(solid: &dyn Sdf, scale: f64) {
        let mut rng = super::super::random::SplitMix64::new(5);
        for _ in 0..2000 {
            let p = rng.direction() * rng.uniform(0.0, scale);
            let q = p + rng.direction() * rng.uniform(0.0, 2.0);
            let (dp, dq) = (solid.distance(p), solid.distance(q));
            assert!((dp - dq).abs() <= (p - q).length() * (1.0 + 1e-9) + 1e-12);
        }
    }

    #[test]
    fn primitives_are_zero_on_known_surface_points() {
        let capsule = Capsule {
            a: DVec3::ZERO,
            b: DVec3::Z * 10.0,
            radius: 2.0,
        };
        assert!(capsule.distance(DVec3::new(2.0, 0.0, 5.0)).abs() < 1e-12);
        assert!((capsule.distance(DVec3::Z * 14.0) - 2.0).abs() < 1e-12);
        let rounded = RoundedBox {
            centre: DVec3::ONE,
            axes: DMat3::IDENTITY,
            half: DVec3::new(3.0, 2.0, 1.0),
            rounding: 0.5,
        };
        assert!(rounded.distance(DVec3::new(4.0, 1.0, 1.0)).abs() < 1e-12);
        assert!((rounded.distance(DVec3::ONE) + 1.0).abs() < 1e-12);
        let cylinder = RoundedCylinder {
            centre: DVec3::ZERO,
            axis: DVec3::X,
            radius: 5.0,
            half_height: 3.0,
            rounding: 1.0,
        };
        assert!(cylinder.distance(DVec3::new(0.0, 5.0, 0.0)).abs() < 1e-12);
        assert!(cylinder.distance(DVec3::new(3.0, 0.0, 0.0)).abs() < 1e-12);
        let ellipsoid = Ellipsoid {
            centre: DVec3::ZERO,
            axes: DMat3::IDENTITY,
            radii: DVec3::new(1.0, 2.0, 3.0),
        };
        assert!(ellipsoid.distance(DVec3::new(0.0, 0.0, 3.0)).abs() < 1e-12);
        assert!(ellipsoid.distance(DVec3::new(0.0, 0.0, 2.9)) < 0.0);
    }

    #[test]
    fn distances_are_one_lipschitz() {
        let mut rng = super::super::random::SplitMix64::new(1);
        let axes = rng.rotation();
        let ellipsoid: Solid = Arc::new(Ellipsoid {
            centre: DVec3::X,
            axes,
            radii: DVec3::new(2.0, 5.0, 9.0),
        });
        let cylinder: Solid = Arc::new(EllipticCylinder {
            centre: DVec3::ZERO,
            axes,
            radii: DVec2::new(3.0, 7.0),
        });
        let boxed: Solid = Arc::new(RoundedBox {
            centre: DVec3::ZERO,
            axes,
            half: DVec3::new(4.0, 3.0, 2.0),
            rounding: 1.0,
        });
        check_bound(ellipsoid.as_ref(), 12.0);
        check_bound(cylinder.as_ref(), 12.0);
        check_bound(&Intersection(vec![boxed, ellipsoid]), 12.0);
        check_bound(&Offset(cylinder, -1.0), 12.0);
    }

    #[test]
    fn a_touching_ellipsoid_touches_at_its_point() {
        let mut rng = super::super::random::SplitMix64::new(2);
        let axes = rng.rotation();
        let point = DVec3::new(1.0, 2.0, 3.0);
        let normal = rng.direction();
        let e = Ellipsoid::touching(point, normal, axes, DVec3::new(3.0, 8.0, 20.0));
        assert!(e.distance(point).abs() < 1e-9);
        // Convex: the whole solid lies behind the tangent plane at the point.
        for _ in 0..1000 {
            let local = rng.direction() * rng.uniform(0.0, 1.0);
            let inside = e.centre + axes * (local * e.radii);
            assert!((inside - point).dot(normal) <= 1e-9);
        }
    }
}
