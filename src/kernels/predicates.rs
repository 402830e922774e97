//! Exact geometric predicates on f64 points: the sign of orient3d, of orient2d in a coordinate
//! projection, and the tests built only from those signs (collinearity, CGAL's
//! `coplanar_orientation`).
//!
//! The determinants are Shewchuk's adaptive-precision predicates ("Adaptive Precision
//! Floating-Point Arithmetic and Fast Robust Geometric Predicates", 1997, through the `robust`
//! crate): a floating-point evaluation with an error bound, refined to exact expansion
//! arithmetic only when the bound does not decide the sign. The signs are therefore exact for
//! every input whose intermediate products neither overflow nor underflow (non-zero coordinate
//! differences roughly within 1e-90..1e90 in magnitude), which covers any mesh in millimetres.
//!
//! Conventions follow CGAL so that code ported from its algorithms reads the same:
//! `orient3d(a, b, c, d)` is the sign of det[b-a, c-a, d-a], positive when `d` lies on the side
//! towards which the right-hand normal (b-a)×(c-a) points.

use std::ops::Mul;

use glam::DVec3;
use robust::{Coord, Coord3D};

/// The sign of a determinant: which side of a line or plane a point lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Sign {
    Negative,
    Zero,
    Positive,
}

impl Sign {
    /// The sign of an exactly-signed value (as the adaptive predicates return).
    #[inline]
    fn of(value: f64) -> Sign {
        if value > 0.0 {
            Sign::Positive
        } else if value < 0.0 {
            Sign::Negative
        } else {
            Sign::Zero
        }
    }

    #[inline]
    pub fn flipped(self) -> Sign {
        match self {
            Sign::Negative => Sign::Positive,
            Sign::Zero => Sign::Zero,
            Sign::Positive => Sign::Negative,
        }
    }
}

impl Mul for Sign {
    type Output = Sign;

    #[inline]
    fn mul(self, other: Sign) -> Sign {
        match (self, other) {
            (Sign::Zero, _) | (_, Sign::Zero) => Sign::Zero,
            (a, b) if a == b => Sign::Positive,
            _ => Sign::Negative,
        }
    }
}

/// Sign of det[b-a, c-a, d-a]: positive when `d` is on the side of the plane (a, b, c) that the
/// normal (b-a)×(c-a) points to, zero when the four points are coplanar. Exact.
#[inline]
pub fn orient3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Sign {
    let p = |v: DVec3| Coord3D {
        x: v.x,
        y: v.y,
        z: v.z,
    };
    // Shewchuk's orient3d is det[a-d, b-d, c-d], the opposite sign of the convention above.
    Sign::of(robust::orient3d(p(a), p(b), p(c), p(d))).flipped()
}

/// The oriented plane of a triangle (a, b, c), prepared for deciding the side of many points:
/// `side(p)` equals `orient3d(a, b, c, p)`, exactly.
///
/// The normal's components (the 2×2 minors of b-a and c-a) are computed once. A point is then
/// decided by a floating-point dot product checked against Shewchuk's error bound for the
/// first, non-adaptive stage of orient3d: the evaluation has the same shape as his (differences
/// from one corner, minors of two difference vectors, their products with the third, summed), so
/// the same bound applies, relative to the same permanent. Points the bound cannot decide, the
/// nearly coplanar ones, go to the adaptive exact predicate.
#[derive(Debug, Clone, Copy)]
pub struct Plane {
    a: DVec3,
    b: DVec3,
    c: DVec3,
    normal: DVec3,
    /// For each normal component, the sum of the magnitudes of its two products.
    magnitude: DVec3,
}

/// Shewchuk's O3DERRBOUND_A: (7 + 56ε)ε with ε = 2^-53.
const ORIENT3D_ERROR_BOUND: f64 = (7.0 + 56.0 * f64::EPSILON / 2.0) * f64::EPSILON / 2.0;
/// Shewchuk's CCWERRBOUND_A: (3 + 16ε)ε.
const ORIENT2D_ERROR_BOUND: f64 = (3.0 + 16.0 * f64::EPSILON / 2.0) * f64::EPSILON / 2.0;

impl Plane {
    pub fn new(a: DVec3, b: DVec3, c: DVec3) -> Plane {
        let (u, v) = (b - a, c - a);
        let products = [
            (u.y * v.z, u.z * v.y),
            (u.z * v.x, u.x * v.z),
            (u.x * v.y, u.y * v.x),
        ];
        Plane {
            a,
            b,
            c,
            normal: DVec3::from_array(products.map(|(p, q)| p - q)),
            magnitude: DVec3::from_array(products.map(|(p, q)| p.abs() + q.abs())),
        }
    }

    /// Whether the triangle is degenerate (its corners collinear), so that it has no plane;
    /// `collinear(a, b, c)`, exactly. The normal's components are the triangle's orientations
    /// in the three coordinate projections, evaluated as the first stage of Shewchuk's orient2d;
    /// one that its error bound shows non-zero settles the question.
    pub fn is_degenerate(&self) -> bool {
        let decided = self
            .normal
            .abs()
            .cmpgt(ORIENT2D_ERROR_BOUND * self.magnitude);
        !decided.any() && collinear(self.a, self.b, self.c)
    }

    /// The triangle the plane was made from.
    #[inline]
    pub fn corners(&self) -> [DVec3; 3] {
        [self.a, self.b, self.c]
    }

    /// `orient3d(a, b, c, p)`.
    #[inline]
    pub fn side(&self, p: DVec3) -> Sign {
        let w = p - self.a;
        let det = self.normal.dot(w);
        let permanent = self.magnitude.dot(w.abs());
        if det.abs() > ORIENT3D_ERROR_BOUND * permanent {
            Sign::of(det)
        } else if permanent == 0.0 {
            // Every product of the expansion is zero (differences that round to zero are
            // zero), so the determinant is exactly zero: the common case of points on an
            // axis-aligned plane, which the adaptive predicate would take long to prove.
            Sign::Zero
        } else {
            orient3d(self.a, self.b, self.c, p)
        }
    }
}

/// The error bound of Shewchuk's first orient3d stage with its permanent replaced by the upper
/// bound 6 m³ (six products of three differences, each at most `m` in magnitude), padded for
/// the rounding of m³ itself. Checking several determinants of differences from one common
/// point against this one bound saves computing a permanent for each: a determinant
/// `(u × v) · w` of floating-point differences u, v, w from that point, none of whose
/// components exceeds `m` in magnitude, has the sign of the exact orient3d when its magnitude
/// is larger than the bound.
#[inline]
pub fn orient3d_bound_for_differences_up_to(m: f64) -> f64 {
    ORIENT3D_ERROR_BOUND * 6.5 * (m * m * m)
}

/// A projection of 3D points onto a coordinate plane, dropping one axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Projection {
    /// Keeps (x, y).
    Xy,
    /// Keeps (y, z).
    Yz,
    /// Keeps (x, z).
    Xz,
}

impl Projection {
    pub const ALL: [Projection; 3] = [Projection::Xy, Projection::Yz, Projection::Xz];

    #[inline]
    fn apply(self, v: DVec3) -> Coord<f64> {
        match self {
            Projection::Xy => Coord { x: v.x, y: v.y },
            Projection::Yz => Coord { x: v.y, y: v.z },
            Projection::Xz => Coord { x: v.x, y: v.z },
        }
    }

    /// The first projection (in the order xy, yz, xz) in which `a, b, c` are not collinear;
    /// `None` when they are collinear in space. Within the plane of a non-degenerate triangle
    /// this projection is an affine bijection, so 2D signs computed in it decide the same
    /// questions as in the plane itself.
    pub fn of_triangle(a: DVec3, b: DVec3, c: DVec3) -> Option<Projection> {
        Projection::ALL
            .into_iter()
            .find(|&proj| orient2d(a, b, c, proj) != Sign::Zero)
    }
}

/// Sign of the 2D orientation of the projected points: positive when `c` is left of the
/// directed line a→b in the projection. Exact.
#[inline]
pub fn orient2d(a: DVec3, b: DVec3, c: DVec3, proj: Projection) -> Sign {
    Sign::of(robust::orient2d(
        proj.apply(a),
        proj.apply(b),
        proj.apply(c),
    ))
}

/// Whether three points lie on one line (including coincident points). Exact: the three
/// components of (b-a)×(c-a) are the orientations of the three coordinate projections.
pub fn collinear(a: DVec3, b: DVec3, c: DVec3) -> bool {
    Projection::of_triangle(a, b, c).is_none()
}

/// CGAL's `coplanar_orientation(p, q, r, s)` for four coplanar points with p, q, r not
/// collinear: positive when `r` and `s` are on the same side of the line pq within their plane,
/// negative when on opposite sides, zero when `s` is on the line. Returns zero as well when
/// p, q, r are collinear, where the question has no answer.
pub fn coplanar_orientation(p: DVec3, q: DVec3, r: DVec3, s: DVec3) -> Sign {
    match Projection::of_triangle(p, q, r) {
        Some(proj) => orient2d(p, q, r, proj) * orient2d(p, q, s, proj),
        None => Sign::Zero,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact sign of det[b-a, c-a, d-a] for points with integer coordinates below 2^38, where
    /// every product fits in an i128.
    fn exact_orient3d(a: [i64; 3], b: [i64; 3], c: [i64; 3], d: [i64; 3]) -> Sign {
        let sub = |u: [i64; 3], v: [i64; 3]| [0, 1, 2].map(|k| (u[k] - v[k]) as i128);
        let (u, v, w) = (sub(b, a), sub(c, a), sub(d, a));
        let det = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
            + u[2] * (v[0] * w[1] - v[1] * w[0]);
        Sign::of(det as f64)
    }

    fn naive_orient3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Sign {
        Sign::of((b - a).cross(c - a).dot(d - a))
    }

    #[test]
    fn orient3d_follows_the_right_hand_normal() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        assert_eq!(orient3d(a, b, c, DVec3::Z), Sign::Positive);
        assert_eq!(orient3d(a, b, c, -DVec3::Z), Sign::Negative);
        assert_eq!(orient3d(a, b, c, DVec3::new(3.0, -7.0, 0.0)), Sign::Zero);
        assert_eq!(orient3d(a, c, b, DVec3::Z), Sign::Negative);
    }

    #[test]
    fn orient3d_decides_points_one_ulp_off_a_tilted_plane() {
        // The plane z = 1 + x/2 + y/4 through points far from the origin, and points on it whose
        // height is exactly representable; one ulp up or down must change the sign.
        let o = DVec3::new(1.0e6, -3.0e6, 2.0e6);
        let on_plane = |x: f64, y: f64| o + DVec3::new(x, y, 1.0 + 0.5 * x + 0.25 * y);
        let (a, b, c) = (on_plane(0.0, 0.0), on_plane(1.0, 0.0), on_plane(0.0, 1.0));
        for (x, y) in [(3.0, 7.0), (-1024.5, 0.25), (12345.0, -6789.0)] {
            let d = on_plane(x, y);
            let up = DVec3::new(d.x, d.y, d.z.next_up());
            let down = DVec3::new(d.x, d.y, d.z.next_down());
            let plane = Plane::new(a, b, c);
            for (p, expected) in [
                (d, Sign::Zero),
                (up, Sign::Positive),
                (down, Sign::Negative),
            ] {
                assert_eq!(orient3d(a, b, c, p), expected, "{p}");
                assert_eq!(plane.side(p), expected, "{p}");
            }
        }
    }

    #[test]
    fn orient2d_and_orient3d_are_exact_where_the_naive_determinant_fails() {
        // Kettner et al.'s classroom example: points within a few ulps of the line y = x,
        // tested against the far-away points (12, 12) and (24, 24). The exact sign is that of
        // (y - x); lifted to 3D with a vertical plane through the same line.
        let (a, b) = (DVec3::new(12.0, 12.0, 0.0), DVec3::new(24.0, 24.0, 0.0));
        let lift = DVec3::new(12.0, 12.0, 1.0);
        let ulp = 0.5f64.next_up() - 0.5;
        let mut naive_wrong = 0;
        for i in 0..64 {
            for j in 0..64 {
                let p = DVec3::new(0.5 + i as f64 * ulp, 0.5 + j as f64 * ulp, 0.0);
                let exact = Sign::of((j - i) as f64);
                assert_eq!(orient2d(a, b, p, Projection::Xy), exact, "{i} {j}");
                // det[b-a, lift-a, p-a] = -(b-a)×(p-a)·z, hence the flip.
                assert_eq!(orient3d(a, b, lift, p), exact.flipped(), "{i} {j}");
                assert_eq!(Plane::new(a, b, lift).side(p), exact.flipped(), "{i} {j}");
                naive_wrong += usize::from(naive_orient3d(a, b, lift, p) != exact.flipped());
            }
        }
        // The cases are hard enough that plain floating point gets some of them wrong.
        assert!(naive_wrong > 0);
    }

    #[test]
    fn orient3d_matches_integer_arithmetic_on_nearly_coplanar_points() {
        // Points on a lattice of spacing 2^-20 (exactly representable) near a random plane,
        // with the exact sign from 128-bit integers.
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = |range: i64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % (2 * range as u64 + 1)) as i64 - range
        };
        let scale = (-20f64).exp2();
        let to_f64 = |p: [i64; 3]| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) * scale;
        let mut zeros = 0;
        for _ in 0..20_000 {
            let base = [next(1 << 36), next(1 << 36), next(1 << 36)];
            let shift = |p: [i64; 3]| [0, 1, 2].map(|k| base[k] + p[k]);
            let a = shift([0, 0, 0]);
            let u = [next(1 << 20), next(1 << 20), next(1 << 20)];
            let v = [next(1 << 20), next(1 << 20), next(1 << 20)];
            let b = shift(u);
            let c = shift(v);
            // d = a + s u + t v, then nudged by at most one lattice step.
            let (s, t) = (next(8), next(8));
            let d = shift([0, 1, 2].map(|k| s * u[k] + t * v[k] + next(1)));
            let exact = exact_orient3d(a, b, c, d);
            zeros += usize::from(exact == Sign::Zero);
            let (a, b, c, d) = (to_f64(a), to_f64(b), to_f64(c), to_f64(d));
            assert_eq!(orient3d(a, b, c, d), exact, "{a} {b} {c} {d}");
            assert_eq!(Plane::new(a, b, c).side(d), exact, "{a} {b} {c} {d}");
        }
        assert!(
            zeros > 100,
            "the generator must produce exactly coplanar cases"
        );
    }

    #[test]
    fn the_bound_for_differences_never_lets_a_wrong_sign_through() {
        // Nearly coplanar points, offset from the plane by 1e-17 to 1e-12, where the
        // floating-point determinant is often wrong: whenever it exceeds the bound, its sign
        // must be the exact one.
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut decided, mut undecided) = (0, 0);
        for _ in 0..20_000 {
            let o = DVec3::new(next(), next(), next()) * 4.0;
            let (u, v) = (
                DVec3::new(next(), next(), next()),
                DVec3::new(next(), next(), next()),
            );
            let (p, q) = (o + u, o + v);
            // A point on the plane up to the rounding of its coordinates, or slightly off it.
            let off = u.cross(v) * next() * 10f64.powf(-17.0 + 10.0 * next().abs());
            let r = o + u * next() + v * next() + off;
            let (du, dv, dw) = (p - o, q - o, r - o);
            let m = du.abs().max(dv.abs()).max(dw.abs()).max_element();
            let det = du.cross(dv).dot(dw);
            if det.abs() > orient3d_bound_for_differences_up_to(m) {
                decided += 1;
                assert_eq!(Sign::of(det), orient3d(o, p, q, r), "{o} {p} {q} {r}");
            } else {
                undecided += 1;
            }
        }
        assert!(decided > 1000 && undecided > 1000, "{decided} {undecided}");
    }

    #[test]
    fn collinear_is_exact_in_every_projection() {
        // A collinear triple in the xy and yz projections but not in xz.
        let (p, q, r) = (DVec3::ZERO, DVec3::X, DVec3::Z);
        assert_eq!(orient2d(p, q, r, Projection::Xy), Sign::Zero);
        assert_eq!(orient2d(p, q, r, Projection::Yz), Sign::Zero);
        assert!(!collinear(p, q, r));
        assert_eq!(Projection::of_triangle(p, q, r), Some(Projection::Xz));
        assert!(collinear(p, q, DVec3::new(7.0, 0.0, 0.0)));
        assert!(collinear(p, p, r));
        // One ulp off the line is not collinear.
        let (u, w) = (DVec3::ONE, DVec3::splat(3.0));
        assert!(collinear(p, u, w));
        assert!(!collinear(p, u, DVec3::new(3.0, 3f64.next_up(), 3.0)));
        for (a, b, c) in [
            (p, q, r),
            (p, u, w),
            (p, p, r),
            (p, u, DVec3::new(3.0, 3f64.next_up(), 3.0)),
        ] {
            assert_eq!(
                Plane::new(a, b, c).is_degenerate(),
                collinear(a, b, c),
                "{a} {b} {c}"
            );
        }
    }

    #[test]
    fn plane_side_on_axis_aligned_planes_is_exact() {
        // A triangle in the plane y = 0.1 (every product with a y difference vanishes).
        let (a, b, c) = (
            DVec3::new(0.3, 0.1, -2.0),
            DVec3::new(5.0, 0.1, 1.0),
            DVec3::new(-1.0, 0.1, 7.0),
        );
        let plane = Plane::new(a, b, c);
        for x in [-1e6, 0.0, 0.7, 3e5] {
            let on = DVec3::new(x, 0.1, x / 3.0);
            let above = DVec3::new(x, 0.1f64.next_down(), x / 3.0);
            assert_eq!(plane.side(on), Sign::Zero);
            assert_eq!(plane.side(on), orient3d(a, b, c, on));
            assert_eq!(plane.side(above), orient3d(a, b, c, above));
            assert_ne!(plane.side(above), Sign::Zero);
        }
    }

    #[test]
    fn coplanar_orientation_tells_sides_of_a_line_in_any_plane() {
        // A vertical plane x = 2 (degenerate in the xy projection).
        let p = DVec3::new(2.0, 0.0, 0.0);
        let q = DVec3::new(2.0, 1.0, 1.0);
        let r = DVec3::new(2.0, 0.0, 1.0);
        assert_eq!(
            coplanar_orientation(p, q, r, DVec3::new(2.0, -3.0, 5.0)),
            Sign::Positive
        );
        assert_eq!(
            coplanar_orientation(p, q, r, DVec3::new(2.0, 5.0, -3.0)),
            Sign::Negative
        );
        assert_eq!(
            coplanar_orientation(p, q, r, DVec3::new(2.0, 9.0, 9.0)),
            Sign::Zero
        );
        assert_eq!(coplanar_orientation(p, q, r, r), Sign::Positive);
        assert_eq!(coplanar_orientation(p, q, p, r), Sign::Zero);
    }
}
