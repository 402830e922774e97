//! Garland–Heckbert quadric error metrics ("Surface simplification using quadric error
//! metrics", SIGGRAPH 1997): each vertex carries the sum of the squared distances to the planes
//! of the input triangles around it, weighted by their areas, and a collapse is ranked by that
//! sum at the position it moves the merged vertex to.
//!
//! The quadric only orders the collapses; the distance bound itself is proved separately
//! (`error_bound`), so a placement here may be anything the quadric likes.

use glam::{DMat3, DVec3};

/// The quadric `Q(x) = xᵀAx + 2bᵀx + c` of a set of weighted planes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Quadric {
    a: DMat3,
    b: DVec3,
    c: f64,
}

impl Default for Quadric {
    /// The quadric of no planes. (glam's default matrix is the identity, not zero.)
    fn default() -> Quadric {
        Quadric {
            a: DMat3::ZERO,
            b: DVec3::ZERO,
            c: 0.0,
        }
    }
}

impl Quadric {
    /// The squared distance to the plane of the triangle, weighted by its area; zero for a
    /// triangle without a plane.
    pub(super) fn of_triangle([p, q, r]: [DVec3; 3]) -> Quadric {
        let cross = (q - p).cross(r - p);
        let doubled_area = cross.length();
        if doubled_area == 0.0 || !doubled_area.is_finite() {
            return Quadric::default();
        }
        let n = cross / doubled_area;
        let d = -n.dot(p);
        let w = 0.5 * doubled_area;
        Quadric {
            a: DMat3::from_cols(n * n.x, n * n.y, n * n.z) * w,
            b: n * (d * w),
            c: d * d * w,
        }
    }

    pub(super) fn value(&self, x: DVec3) -> f64 {
        (x.dot(self.a * x) + 2.0 * self.b.dot(x) + self.c).max(0.0)
    }

    /// The minimiser of the quadric plus a weak pull towards `p`, which settles the directions
    /// the planes leave free (along a flat or cylindrical surface) at `p`'s.
    pub(super) fn minimiser_near(&self, p: DVec3) -> DVec3 {
        let trace = self.a.x_axis.x + self.a.y_axis.y + self.a.z_axis.z;
        let pull = 1e-3 * trace;
        let x = (self.a + DMat3::IDENTITY * pull).inverse() * (pull * p - self.b);
        if x.is_finite() {
            x
        } else {
            p
        }
    }

    /// The positions worth trying for the collapse of the edge `p`–`q`, best first: the
    /// minimiser of the quadric when it is well determined and not far from the edge, then the
    /// minimiser along the edge (which always exists), then the two endpoints.
    pub(super) fn placements(&self, p: DVec3, q: DVec3) -> Vec<(f64, DVec3)> {
        let mut found: Vec<(f64, DVec3)> = Vec::with_capacity(4);
        let length = p.distance(q);
        // A flat or cylindrical neighbourhood leaves the minimiser undetermined along the
        // surface; the determinant relative to the trace's cube tells that apart.
        let trace = self.a.x_axis.x + self.a.y_axis.y + self.a.z_axis.z;
        let det = self.a.determinant();
        if det.abs() > 1e-6 * trace.powi(3) {
            let x = self.a.inverse() * -self.b;
            if x.is_finite() && x.distance(0.5 * (p + q)) <= length {
                found.push((self.value(x), x));
            }
        }
        let d = q - p;
        let curvature = d.dot(self.a * d);
        let t = if curvature > 0.0 {
            (-(d.dot(self.a * p) + self.b.dot(d)) / curvature).clamp(0.0, 1.0)
        } else {
            0.5
        };
        for x in [p + d * t, p, q] {
            if !found.iter().any(|&(_, y)| y == x) {
                found.push((self.value(x), x));
            }
        }
        found[1..].sort_by(|u, v| u.0.total_cmp(&v.0));
        found
    }
}

impl std::ops::Add for Quadric {
    type Output = Quadric;
    fn add(self, o: Quadric) -> Quadric {
        Quadric {
            a: self.a + o.a,
            b: self.b + o.b,
            c: self.c + o.c,
        }
    }
}

impl std::ops::AddAssign for Quadric {
    fn add_assign(&mut self, o: Quadric) {
        *self = *self + o;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_quadric_of_a_triangle_is_its_area_times_the_squared_distance_to_its_plane() {
        let q = Quadric::of_triangle([DVec3::ZERO, DVec3::X * 2.0, DVec3::Y * 2.0]);
        // Area 2, the plane z = 0.
        assert!((q.value(DVec3::new(5.0, -3.0, 1.5)) - 2.0 * 2.25).abs() < 1e-12);
        assert_eq!(q.value(DVec3::new(7.0, 1.0, 0.0)), 0.0);
    }

    #[test]
    fn three_planes_meeting_at_a_corner_place_the_vertex_on_the_corner() {
        let corner = DVec3::new(1.0, 2.0, 3.0);
        let mut q = Quadric::default();
        for (u, v) in [
            (DVec3::X, DVec3::Y),
            (DVec3::Y, DVec3::Z),
            (DVec3::Z, DVec3::X),
        ] {
            q += Quadric::of_triangle([corner, corner + u, corner + v]);
        }
        let best = q.placements(corner + DVec3::X * 0.3, corner + DVec3::Y * 0.4)[0];
        assert!(best.1.distance(corner) < 1e-12 && best.0 < 1e-12);
    }

    #[test]
    fn a_flat_neighbourhood_falls_back_to_the_edge_and_its_endpoints() {
        let q = Quadric::of_triangle([DVec3::ZERO, DVec3::X, DVec3::Y]);
        let (p, r) = (DVec3::new(0.2, 0.2, 0.0), DVec3::new(0.6, 0.2, 0.0));
        let found = q.placements(p, r);
        assert_eq!(found.len(), 3);
        assert!(found.iter().all(|&(cost, _)| cost == 0.0));
    }
}
