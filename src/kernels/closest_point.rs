//! Exact Euclidean distance from a point to a triangle in f64: the region-based closest point of
//! Ericson, *Real-Time Collision Detection* (2005), section 5.1.5 (Voronoi regions of the
//! vertices, edges and face, decided by dot products), with two changes for robustness:
//!
//! - In the face region the closest point is the orthogonal projection on the triangle's plane,
//!   not `a + v·ab + w·ac` with barycentrics divided by the squared area: for a needle triangle
//!   that division amplifies rounding, the projection does not.
//! - A triangle whose area is negligible against its longest edge (collinear or coincident
//!   corners) has no usable plane; it is treated as the union of its three edges.
//!
//! Edge parameters are clamped to `[0, 1]`, so every result lies on the triangle and is finite.

use glam::DVec3;

/// Below this ratio of the doubled area to the squared longest edge a triangle is treated as its
/// edges: the triangle is then narrower than `1e-8` times its length, so the distance to its edges
/// differs from the distance to its face by less than that, while its normal would be unreliable.
const DEGENERATE_AREA_RATIO: f64 = 1e-8;

/// A triangle prepared for many distance queries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triangle {
    a: DVec3,
    ab: DVec3,
    ac: DVec3,
    /// Gram terms `ab·ab`, `ab·ac`, `ac·ac`: with them the six dot products of Ericson's region
    /// tests follow from two (`bp = ap − ab`, `cp = ap − ac`).
    ab_ab: f64,
    ab_ac: f64,
    ac_ac: f64,
    /// `ab × ac` and `1 / |ab × ac|²`, or `None` for a degenerate triangle.
    normal: Option<(DVec3, f64)>,
}

/// Where the closest point lies: `a + offset` on an edge or a corner, or inside the face.
enum Nearest {
    Boundary(DVec3),
    Face,
}

impl Triangle {
    pub fn new(a: DVec3, b: DVec3, c: DVec3) -> Self {
        let (ab, ac) = (b - a, c - a);
        let n = ab.cross(ac);
        let longest2 = ab
            .length_squared()
            .max(ac.length_squared())
            .max((c - b).length_squared());
        // Also false for a NaN area (coordinates so large that products overflow).
        let usable = n.length() > DEGENERATE_AREA_RATIO * longest2;
        Triangle {
            a,
            ab,
            ac,
            ab_ab: ab.length_squared(),
            ab_ac: ab.dot(ac),
            ac_ac: ac.length_squared(),
            normal: usable.then(|| (n, 1.0 / n.length_squared())),
        }
    }

    pub fn corners(&self) -> [DVec3; 3] {
        [self.a, self.a + self.ab, self.a + self.ac]
    }

    /// The unnormalised normal `(b − a) × (c − a)`, `None` when the triangle is degenerate.
    pub fn normal(&self) -> Option<DVec3> {
        self.normal.map(|(n, _)| n)
    }

    /// The point of the triangle closest to `p`.
    pub fn closest_point(&self, p: DVec3) -> DVec3 {
        let ap = p - self.a;
        match self.normal {
            None => self.a + self.degenerate_offset(ap),
            Some((n, inv_n2)) => match self.nearest(ap) {
                Nearest::Boundary(offset) => self.a + offset,
                Nearest::Face => p - n * (n.dot(ap) * inv_n2),
            },
        }
    }

    /// Squared Euclidean distance from `p` to the triangle.
    #[inline]
    pub fn distance_squared(&self, p: DVec3) -> f64 {
        let ap = p - self.a;
        match self.normal {
            None => (ap - self.degenerate_offset(ap)).length_squared(),
            Some((n, inv_n2)) => match self.nearest(ap) {
                Nearest::Boundary(offset) => (ap - offset).length_squared(),
                Nearest::Face => {
                    let h = n.dot(ap);
                    h * h * inv_n2
                }
            },
        }
    }

    /// Ericson's Voronoi-region walk for `p = a + ap`.
    #[inline]
    fn nearest(&self, ap: DVec3) -> Nearest {
        let (ab, ac) = (self.ab, self.ac);
        let d1 = ab.dot(ap);
        let d2 = ac.dot(ap);
        if d1 <= 0.0 && d2 <= 0.0 {
            return Nearest::Boundary(DVec3::ZERO);
        }
        // ab·bp and ac·bp.
        let d3 = d1 - self.ab_ab;
        let d4 = d2 - self.ab_ac;
        if d3 >= 0.0 && d4 <= d3 {
            return Nearest::Boundary(ab);
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            return Nearest::Boundary(ab * fraction(d1, d1 - d3));
        }
        // ab·cp and ac·cp.
        let d5 = d1 - self.ab_ac;
        let d6 = d2 - self.ac_ac;
        if d6 >= 0.0 && d5 <= d6 {
            return Nearest::Boundary(ac);
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            return Nearest::Boundary(ac * fraction(d2, d2 - d6));
        }
        let va = d3 * d6 - d5 * d4;
        let (along_b, along_c) = (d4 - d3, d5 - d6);
        if va <= 0.0 && along_b >= 0.0 && along_c >= 0.0 {
            return Nearest::Boundary(ab + (ac - ab) * fraction(along_b, along_b + along_c));
        }
        Nearest::Face
    }

    /// For a degenerate triangle, `closest − a` over its three edges.
    fn degenerate_offset(&self, ap: DVec3) -> DVec3 {
        let (ab, ac) = (self.ab, self.ac);
        let candidates = [
            closest_point_on_segment(ap, DVec3::ZERO, ab),
            closest_point_on_segment(ap, ab, ac),
            closest_point_on_segment(ap, DVec3::ZERO, ac),
        ];
        candidates
            .into_iter()
            .min_by(|x, y| {
                (ap - *x)
                    .length_squared()
                    .total_cmp(&(ap - *y).length_squared())
            })
            .unwrap_or(DVec3::ZERO)
    }
}

/// The point of segment `ab` closest to `p`; `a` when the segment has zero length.
pub fn closest_point_on_segment(p: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    let ab = b - a;
    a + ab * fraction(ab.dot(p - a), ab.length_squared())
}

/// `num / den` clamped to `[0, 1]`; 0 when `den` is not positive. Ericson's regions guarantee
/// `0 ≤ num ≤ den` in exact arithmetic, rounding may not.
#[inline]
fn fraction(num: f64, den: f64) -> f64 {
    if den > 0.0 {
        (num / den).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn right_triangle() -> Triangle {
        Triangle::new(
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
        )
    }

    #[test]
    fn every_voronoi_region_of_a_right_triangle_gives_its_analytic_point() {
        let t = right_triangle();
        let cases = [
            // Face, above and below.
            (DVec3::new(0.5, 0.5, 3.0), DVec3::new(0.5, 0.5, 0.0)),
            (DVec3::new(0.5, 0.25, -2.0), DVec3::new(0.5, 0.25, 0.0)),
            // Vertices.
            (DVec3::new(-1.0, -1.0, 1.0), DVec3::ZERO),
            (DVec3::new(3.0, -0.5, 0.0), DVec3::new(2.0, 0.0, 0.0)),
            (DVec3::new(-0.5, 3.0, 0.0), DVec3::new(0.0, 2.0, 0.0)),
            // Edges ab, ac and the hypotenuse bc.
            (DVec3::new(1.0, -1.0, 1.0), DVec3::new(1.0, 0.0, 0.0)),
            (DVec3::new(-2.0, 1.5, 0.0), DVec3::new(0.0, 1.5, 0.0)),
            (DVec3::new(2.0, 2.0, 0.0), DVec3::new(1.0, 1.0, 0.0)),
        ];
        for (p, expected) in cases {
            let q = t.closest_point(p);
            assert!(
                (q - expected).length() < 1e-15,
                "{p} -> {q}, not {expected}"
            );
            assert_eq!(t.distance_squared(p), (p - expected).length_squared());
        }
    }

    #[test]
    fn degenerate_triangles_are_their_edges_and_never_give_nan() {
        let p = DVec3::new(1.0, 1.0, 0.5);
        // Collinear corners: the segment from 0 to 3 on the x axis.
        let collinear = Triangle::new(DVec3::ZERO, DVec3::new(3.0, 0.0, 0.0), DVec3::X);
        assert!(collinear.normal().is_none());
        assert!((collinear.distance_squared(p) - 1.25).abs() < 1e-15);
        // All corners equal: a point.
        let point = Triangle::new(DVec3::ONE, DVec3::ONE, DVec3::ONE);
        assert_eq!(point.distance_squared(p), 0.25);
        // Two equal corners and a far one.
        let cap = Triangle::new(DVec3::ZERO, DVec3::ZERO, DVec3::new(0.0, 4.0, 0.0));
        assert!((cap.distance_squared(p) - 1.25).abs() < 1e-15);
        // A needle one part in 1e12 wide: its plane is unreliable, its edges are not.
        let needle = Triangle::new(
            DVec3::ZERO,
            DVec3::new(1.0, 1e-12, 0.0),
            DVec3::new(2.0, 0.0, 1e-12),
        );
        let far = DVec3::new(1.0, 5.0, -7.0);
        let d = needle.distance_squared(far).sqrt();
        assert!((d - (25.0f64 + 49.0).sqrt()).abs() < 1e-9, "{d}");
    }

    #[test]
    fn segment_parameter_is_clamped_to_the_ends() {
        let (a, b) = (DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0));
        assert_eq!(
            closest_point_on_segment(DVec3::new(-3.0, 1.0, 0.0), a, b),
            a
        );
        assert_eq!(closest_point_on_segment(DVec3::new(5.0, 1.0, 0.0), a, b), b);
        assert_eq!(
            closest_point_on_segment(DVec3::new(0.5, 1.0, 0.0), a, b),
            DVec3::new(0.5, 0.0, 0.0)
        );
        assert_eq!(closest_point_on_segment(DVec3::ONE, a, a), a);
    }

    fn coord() -> impl Strategy<Value = f64> {
        -3.0f64..3.0
    }

    fn point() -> impl Strategy<Value = DVec3> {
        (coord(), coord(), coord()).prop_map(|(x, y, z)| DVec3::new(x, y, z))
    }

    proptest! {
        /// Against dense sampling: the distance is never more than the distance to any sample
        /// and never less than the nearest sample minus the sampling step.
        #[test]
        fn distance_agrees_with_dense_sampling(a in point(), b in point(), c in point(), p in point()) {
            let t = Triangle::new(a, b, c);
            let d = t.distance_squared(p).sqrt();
            const N: usize = 60;
            let mut nearest = f64::INFINITY;
            for u in 0..=N {
                for v in 0..=N - u {
                    let s = a + (b - a) * (u as f64 / N as f64) + (c - a) * (v as f64 / N as f64);
                    nearest = nearest.min((p - s).length());
                }
            }
            let step = ((b - a).length() + (c - a).length()) / N as f64;
            prop_assert!(d <= nearest + 1e-12, "{d} > sampled {nearest}");
            prop_assert!(d >= nearest - step - 1e-12, "{d} < sampled {nearest} - {step}");
            // The closest point is on the triangle: its distance to the triangle is zero.
            let q = t.closest_point(p);
            prop_assert!(t.distance_squared(q) < 1e-20);
        }
    }
}
