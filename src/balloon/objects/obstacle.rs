//! Another object's surface as an obstacle to a balloon (the paper's future work: balloons from
//! several seeds that stop where they meet): a spatial hash of its triangles that answers, for a
//! point near it, the exact signed distance to it — positive outside — and whether the point is
//! closer to it than the clearance the objects keep between them.
//!
//! The sign is that of the angle-weighted pseudo-normal at the closest point (Bærentzen and
//! Aanæs, "Signed distance computation using the angle weighted pseudonormal", IEEE TVCG 2005),
//! correct for any point of a closed, outward, 2-manifold surface. It needs no adjacency: the
//! triangles tied for the closest distance are exactly those around the closest feature — one
//! on a face, the two of an edge, the fan of a vertex — and each counts with its angle at the
//! closest point when that is one of its corners (a vertex's fan), with equal weights otherwise.
//!
//! Distances are exact only within `reach` of the surface: triangles are entered into every
//! cell their box, grown by `reach`, overlaps, and a query looks into its own cell only. Beyond
//! that a point is taken to be outside; a balloon's vertex moves less than a step from where it
//! was outside, so it never gets that deep into another object unseen.

use std::collections::HashMap;
use std::ops::Range;
use std::sync::Arc;

use glam::DVec3;

use crate::balloon::fast_hash::FastHash;
use crate::closest_point::Triangle;
use crate::error::Result;
use crate::mesh::TriMesh;
use crate::self_intersection::self_intersections_among;

/// Cell size of the hash, in reaches: a triangle a voxel across, grown by a reach on each side,
/// enters about eight cells.
const CELL_REACHES: f64 = 2.0;

/// Distances within this share of the shortest, and of the coordinates (their rounding), tie.
const TIE: f64 = 1e-9;

/// Another object's closed, outward surface, indexed for distance queries near it.
pub(crate) struct Obstacle {
    triangles: Vec<Triangle>,
    cell: f64,
    reach: f64,
    /// Triangle ids by cell, each cell a range of `entries`.
    cells: HashMap<[i64; 3], Range<u32>, FastHash>,
    entries: Vec<u32>,
}

impl Obstacle {
    /// The surface made of `triangles` (their corners, world mm), with exact distances within
    /// `reach` (mm, positive) of it.
    pub fn new(triangles: impl IntoIterator<Item = [DVec3; 3]>, reach: f64) -> Obstacle {
        let triangles: Vec<Triangle> = triangles
            .into_iter()
            .map(|[a, b, c]| Triangle::new(a, b, c))
            .collect();
        let cell = CELL_REACHES * reach;
        let mut keyed: Vec<([i64; 3], u32)> = Vec::with_capacity(8 * triangles.len());
        for (t, triangle) in triangles.iter().enumerate() {
            let [a, b, c] = triangle.corners();
            let lo = cell_of(a.min(b).min(c) - DVec3::splat(reach), cell);
            let hi = cell_of(a.max(b).max(c) + DVec3::splat(reach), cell);
            for k in lo[2]..=hi[2] {
                for j in lo[1]..=hi[1] {
                    for i in lo[0]..=hi[0] {
                        keyed.push(([i, j, k], t as u32));
                    }
                }
            }
        }
        keyed.sort_unstable();
        let mut cells = HashMap::with_capacity_and_hasher(keyed.len() / 4, FastHash::default());
        let mut start = 0;
        while start < keyed.len() {
            let key = keyed[start].0;
            let end = start + keyed[start..].partition_point(|e| e.0 == key);
            cells.insert(key, start as u32..end as u32);
            start = end;
        }
        Obstacle {
            triangles,
            cell,
            reach,
            cells,
            entries: keyed.into_iter().map(|(_, t)| t).collect(),
        }
    }

    /// The closed surface `mesh` (world mm).
    pub fn of_mesh(mesh: &TriMesh, reach: f64) -> Obstacle {
        Obstacle::new(
            mesh.triangles()
                .iter()
                .map(|t| t.map(|v| mesh.points()[v as usize])),
            reach,
        )
    }

    /// The triangles' corners (world mm).
    pub fn triangles(&self) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        self.triangles.iter().map(Triangle::corners)
    }

    /// The signed distance (mm, positive outside) from `x` to the surface, when `x` is within
    /// the reach of it.
    pub fn signed_distance(&self, x: DVec3) -> Option<f64> {
        let range = self.cells.get(&cell_of(x, self.cell))?.clone();
        let near = &self.entries[range.start as usize..range.end as usize];
        let closest = near
            .iter()
            .map(|&t| self.triangles[t as usize].distance_squared(x))
            .fold(f64::INFINITY, f64::min)
            .sqrt();
        if closest.is_nan() || closest > self.reach {
            return None;
        }
        let tie = closest + TIE * (closest + x.abs().max_element().max(1.0));
        let mut direction = 0.0;
        for &t in near {
            let triangle = &self.triangles[t as usize];
            let Some(normal) = triangle.normal() else {
                continue;
            };
            let c = triangle.closest_point(x);
            if (x - c).length() > tie {
                continue;
            }
            direction += corner_angle(triangle, c, tie) * normal.normalize().dot(x - c);
        }
        Some(if direction < 0.0 { -closest } else { closest })
    }
}

/// The triangles of `mesh` that meet a triangle of one of `obstacles` (touching counts), in
/// increasing order.
pub(crate) fn crossings(mesh: &TriMesh, obstacles: &[Arc<Obstacle>]) -> Result<Vec<u32>> {
    if obstacles.is_empty() {
        return Ok(Vec::new());
    }
    let own = mesh.triangles().len();
    let mut points = mesh.points().to_vec();
    let mut triangles = mesh.triangles().to_vec();
    for corners in obstacles.iter().flat_map(|o| o.triangles()) {
        let first = points.len() as u32;
        points.extend(corners);
        triangles.push([first, first + 1, first + 2]);
    }
    let active: Vec<bool> = (0..triangles.len()).map(|t| t < own).collect();
    let combined = TriMesh::new(points, triangles)?;
    let mut crossing: Vec<u32> = self_intersections_among(&combined, &active)?
        .into_iter()
        .filter_map(|(a, b)| {
            let (a, b) = (a.min(b) as usize, a.max(b) as usize);
            (a < own && b >= own).then_some(a as u32)
        })
        .collect();
    crossing.sort_unstable();
    crossing.dedup();
    Ok(crossing)
}

/// The angle of `triangle` at `c` when `c` is one of its corners (within `tie`), else 1.
fn corner_angle(triangle: &Triangle, c: DVec3, tie: f64) -> f64 {
    let corners = triangle.corners();
    for i in 0..3 {
        if (corners[i] - c).length() <= tie {
            let (u, v) = (corners[(i + 1) % 3] - c, corners[(i + 2) % 3] - c);
            // atan2 of the cross and dot products: acos of their ratio is NaN when rounding
            // takes the ratio past 1.
            return u.cross(v).length().atan2(u.dot(v));
        }
    }
    1.0
}

fn cell_of(x: DVec3, cell: f64) -> [i64; 3] {
    let c = (x / cell).floor();
    [c.x as i64, c.y as i64, c.z as i64]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::balloon::surface::Surface;

    fn sphere(centre: DVec3, radius: f64) -> Obstacle {
        let s = Surface::icosphere(centre, radius, 3).unwrap();
        let corners: Vec<[DVec3; 3]> = s
            .triangles()
            .map(|(t, _)| s.triangle_corners(t).unwrap())
            .collect();
        Obstacle::new(corners, 1.0)
    }

    #[test]
    fn signed_distance_is_negative_inside_and_absent_beyond_the_reach() {
        let o = sphere(DVec3::new(1.0, 2.0, 3.0), 5.0);
        for (direction, depth) in [
            (DVec3::X, 0.5),
            (DVec3::new(1.0, 1.0, 1.0).normalize(), -0.5),
            (DVec3::NEG_Z, 0.9),
            (DVec3::new(-0.3, 0.2, 0.9).normalize(), -0.2),
        ] {
            let x = DVec3::new(1.0, 2.0, 3.0) + (5.0 + depth) * direction;
            let d = o.signed_distance(x).unwrap();
            assert_eq!(d.signum(), depth.signum(), "{x} {d}");
            // The icosphere's faces sit a little inside its circumscribed sphere.
            assert!((d - depth).abs() < 0.1, "{d} vs {depth}");
        }
        assert!(o.signed_distance(DVec3::new(1.0, 2.0, 3.0)).is_none());
        assert!(o.signed_distance(DVec3::new(1.0, 2.0, 11.0)).is_none());
    }

    #[test]
    fn corner_angles_are_finite_at_right_and_nearly_flat_corners() {
        // The acos of the normalised dot product goes NaN when rounding takes it past ±1; a NaN
        // weight made the seed of touching-pair variant 1, 5.9 mm deep in its tube, "outside".
        let right = Triangle::new(DVec3::ZERO, DVec3::X, DVec3::Y);
        let angle = corner_angle(&right, DVec3::ZERO, 1e-12);
        assert!(
            (angle - std::f64::consts::FRAC_PI_2).abs() < 1e-12,
            "{angle}"
        );
        let flat = Triangle::new(DVec3::ZERO, DVec3::X, DVec3::new(-1.0, 1e-12, 0.0));
        let angle = corner_angle(&flat, DVec3::ZERO, 1e-15);
        assert!((angle - std::f64::consts::PI).abs() < 1e-9, "{angle}");
    }

    #[test]
    fn a_point_straight_out_from_a_vertex_or_an_edge_gets_the_right_sign() {
        // Closest features that are a vertex or an edge, where the faces around them disagree
        // on the side: the pseudo-normal decides.
        let s = Surface::icosphere(DVec3::ZERO, 4.0, 1).unwrap();
        let corners: Vec<[DVec3; 3]> = s
            .triangles()
            .map(|(t, _)| s.triangle_corners(t).unwrap())
            .collect();
        let o = Obstacle::new(corners.clone(), 1.0);
        for [a, b, _] in corners {
            for p in [a, 0.5 * (a + b)] {
                let out = p + 0.3 * p.normalize();
                let inside = p - 0.3 * p.normalize();
                assert!(o.signed_distance(out).unwrap() > 0.0, "{out}");
                assert!(o.signed_distance(inside).unwrap() < 0.0, "{inside}");
            }
        }
    }
}
