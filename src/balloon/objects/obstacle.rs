//! Another object's surface as an obstacle to a balloon (the paper's future work: balloons from
//! several seeds that stop where they meet): a grid of cells over its triangles that answers, for
//! a point near it, the exact signed distance to it — positive outside — and whether the point is
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

use std::sync::Arc;

use glam::DVec3;

use crate::closest_point::Triangle;
use crate::error::Result;
use crate::mesh::TriMesh;
use crate::self_intersection::self_intersections_among;

/// Cell size of the grid, in reaches: a triangle a voxel across, grown by a reach on each side,
/// enters about eight cells.
const CELL_REACHES: f64 = 2.0;

/// The grid's cells at most per triangle (and at least [`MIN_CELL_BUDGET`] cells allowed).
const MAX_CELLS_PER_TRIANGLE: usize = 8;
const MIN_CELL_BUDGET: usize = 4096;

/// Distances within this share of the shortest, and of the coordinates (their rounding), tie.
const TIE: f64 = 1e-9;

/// Another object's closed, outward surface, indexed for distance queries near it.
pub(crate) struct Obstacle {
    triangles: Vec<Triangle>,
    /// Each triangle's bounding sphere (centroid, radius): a lower bound on the distance to it
    /// that spares the exact test for most of a cell's triangles.
    spheres: Vec<(DVec3, f64)>,
    cells: Cells,
    reach: f64,
    /// Triangle ids by cell, each cell's ids in increasing order from `starts[cell]`.
    starts: Vec<u32>,
    entries: Vec<u32>,
}

/// A dense grid of cells over the surface's box grown by the reach: the surface lies within
/// the volume, so there are far fewer cells than voxels, and the index is filled by counting,
/// without hashing or sorting, as it is rebuilt at every step.
struct Cells {
    size: f64,
    lo: [i64; 3],
    dims: [usize; 3],
}

impl Cells {
    fn count(&self) -> usize {
        self.dims.iter().product()
    }

    /// The cell of `x`, `None` beyond the grid.
    fn of(&self, x: DVec3) -> Option<usize> {
        let c = cell_of(x, self.size);
        let mut id = 0;
        for axis in (0..3).rev() {
            let i = usize::try_from(c[axis] - self.lo[axis]).ok()?;
            if i >= self.dims[axis] {
                return None;
            }
            id = id * self.dims[axis] + i;
        }
        Some(id)
    }

    /// The cells that the box `lo..=hi` (world mm, inside the grid) overlaps.
    fn overlapping(&self, lo: DVec3, hi: DVec3) -> impl Iterator<Item = usize> + '_ {
        let (lo, hi) = (cell_of(lo, self.size), cell_of(hi, self.size));
        let index = |c: i64, axis: usize| (c - self.lo[axis]) as usize;
        let [nx, ny, _] = self.dims;
        (index(lo[2], 2)..=index(hi[2], 2)).flat_map(move |k| {
            (index(lo[1], 1)..=index(hi[1], 1)).flat_map(move |j| {
                (index(lo[0], 0)..=index(hi[0], 0)).map(move |i| (k * ny + j) * nx + i)
            })
        })
    }
}

impl Obstacle {
    /// The surface made of `triangles` (their corners, world mm), with exact distances within
    /// `reach` (mm, positive) of it.
    pub fn new(triangles: impl IntoIterator<Item = [DVec3; 3]>, reach: f64) -> Obstacle {
        // A corner that is not finite has no place in the grid, nor any distance to give.
        let triangles: Vec<Triangle> = triangles
            .into_iter()
            .filter(|corners| corners.iter().all(|c| c.is_finite()))
            .map(|[a, b, c]| Triangle::new(a, b, c))
            .collect();
        let spheres = triangles.iter().map(bounding_sphere).collect();
        let grown = DVec3::splat(reach);
        let boxes: Vec<(DVec3, DVec3)> = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.corners();
                (a.min(b).min(c) - grown, a.max(b).max(c) + grown)
            })
            .collect();
        let (lo, hi) = boxes
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), b| {
                (lo.min(b.0), hi.max(b.1))
            });
        // A surface spread thin over a large box would need more cells than it has triangles:
        // larger cells keep the grid within a few words per triangle, at the cost of more
        // triangles per cell for the bounding spheres to skip.
        let cells_of_size = |size: f64| {
            let span = (hi / size).floor() - (lo / size).floor() + 1.0;
            span.x * span.y * span.z
        };
        let most = (MAX_CELLS_PER_TRIANGLE * triangles.len()).max(MIN_CELL_BUDGET) as f64;
        let mut size = CELL_REACHES * reach;
        while size.is_finite() && size > 0.0 && cells_of_size(size) > most {
            size *= 2.0;
        }
        let cells = if boxes.is_empty() {
            Cells {
                size,
                lo: [0; 3],
                dims: [0; 3],
            }
        } else {
            let (lo, hi) = (cell_of(lo, size), cell_of(hi, size));
            Cells {
                size,
                lo,
                dims: [0, 1, 2].map(|axis| (hi[axis] - lo[axis] + 1) as usize),
            }
        };
        let mut starts = vec![0u32; cells.count() + 1];
        for &(lo, hi) in &boxes {
            for id in cells.overlapping(lo, hi) {
                starts[id + 1] += 1;
            }
        }
        for id in 0..cells.count() {
            starts[id + 1] += starts[id];
        }
        let mut filled = starts.clone();
        let mut entries = vec![0u32; *starts.last().expect("one start at least") as usize];
        for (t, &(lo, hi)) in boxes.iter().enumerate() {
            for id in cells.overlapping(lo, hi) {
                entries[filled[id] as usize] = t as u32;
                filled[id] += 1;
            }
        }
        Obstacle {
            triangles,
            spheres,
            cells,
            reach,
            starts,
            entries,
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
        self.nearest(x).map(|(distance, _)| distance)
    }

    /// The signed distance (mm, positive outside) from `x` to the surface and the closest point
    /// of it, when `x` is within the reach of it.
    pub fn nearest(&self, x: DVec3) -> Option<(f64, DVec3)> {
        let id = self.cells.of(x)?;
        let near = &self.entries[self.starts[id] as usize..self.starts[id + 1] as usize];
        // A triangle whose sphere lies farther than the closest found so far (or the reach)
        // cannot be the closest nor tie with it; `slack` covers the bound's rounding.
        let slack = TIE * (self.reach + x.abs().max_element().max(1.0));
        let could_reach = |t: u32, limit: f64| {
            let (centre, radius) = self.spheres[t as usize];
            let within = limit + radius + slack;
            (x - centre).length_squared() <= within * within
        };
        let mut closest = self.reach;
        let mut found = None;
        for &t in near {
            if could_reach(t, closest) {
                let d = self.triangles[t as usize].distance_squared(x).sqrt();
                if d <= closest {
                    closest = d;
                    found = Some(t);
                }
            }
        }
        let point = self.triangles[found? as usize].closest_point(x);
        let tie = closest + TIE * (closest + x.abs().max_element().max(1.0));
        let mut direction = 0.0;
        for &t in near {
            if !could_reach(t, tie) {
                continue;
            }
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
        Some((if direction < 0.0 { -closest } else { closest }, point))
    }
}

/// The triangles of `mesh` that meet a triangle of one of `obstacles` (touching counts), in
/// increasing order.
pub(crate) fn crossings(mesh: &TriMesh, obstacles: &[Arc<Obstacle>]) -> Result<Vec<u32>> {
    if obstacles.is_empty() {
        return Ok(Vec::new());
    }
    let own = mesh.triangles().len();
    // Only the others' triangles that reach into the mesh's box can meet it.
    let (lo, hi) = mesh
        .points()
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let reaches_in = |[a, b, c]: &[DVec3; 3]| {
        a.min(*b).min(*c).cmple(hi).all() && a.max(*b).max(*c).cmpge(lo).all()
    };
    let mut points = mesh.points().to_vec();
    let mut triangles = mesh.triangles().to_vec();
    for corners in obstacles
        .iter()
        .flat_map(|o| o.triangles())
        .filter(reaches_in)
    {
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

fn bounding_sphere(triangle: &Triangle) -> (DVec3, f64) {
    let corners = triangle.corners();
    let centre = (corners[0] + corners[1] + corners[2]) / 3.0;
    let radius = corners
        .iter()
        .map(|&c| (c - centre).length())
        .fold(0.0, f64::max);
    (centre, radius)
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
    fn the_nearest_point_is_on_the_surface_at_the_signed_distance() {
        let centre = DVec3::new(1.0, 2.0, 3.0);
        let o = sphere(centre, 5.0);
        for (direction, depth) in [
            (DVec3::Y, 0.7),
            (DVec3::new(1.0, -1.0, 2.0).normalize(), -0.6),
        ] {
            let x = centre + (5.0 + depth) * direction;
            let (d, closest) = o.nearest(x).unwrap();
            assert_eq!(Some(d), o.signed_distance(x));
            assert!(
                (d.abs() - (x - closest).length()).abs() < 1e-12,
                "{d} {closest}"
            );
            assert!(((closest - centre).length() - 5.0).abs() < 0.1, "{closest}");
            // Straight out from the centre, as the sphere's faces are nearly normal to it.
            assert!(
                (closest - centre).normalize().dot(direction) > 0.999,
                "{closest}"
            );
        }
    }

    #[test]
    fn a_surface_spread_over_a_large_box_gets_larger_cells_not_a_huge_grid() {
        // Two small triangles ten metres apart with a reach of half a millimetre: cells of
        // the reach would number 10¹², which no machine holds.
        let far = DVec3::splat(1e4);
        let triangle = |o: DVec3| [o, o + DVec3::X, o + DVec3::Y];
        let o = Obstacle::new([triangle(DVec3::ZERO), triangle(far)], 0.5);
        assert!(o.cells.count() <= MIN_CELL_BUDGET, "{}", o.cells.count());
        for base in [DVec3::ZERO, far] {
            let d = o.signed_distance(base + DVec3::new(0.2, 0.2, 0.3)).unwrap();
            assert!((d.abs() - 0.3).abs() < 1e-12, "{d}");
        }
        assert!(o.signed_distance(DVec3::splat(5e3)).is_none());
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
