//! Narrow-band signed distance on a voxel grid: step 6 of the paper (section 3). After the
//! balloon stops, its self-intersecting triangles are deleted; every voxel gets the distance to
//! the remaining triangles, negative where the closed balloon before deletion encloses it.
//! Marching cubes of this field at 0 gives the repaired surface.
//!
//! - Distance: exact Euclidean distance (to rounding) in world millimetres, with anisotropic
//!   spacing and any direction matrix, by scattering each triangle over the voxels that can be
//!   within the band of it and keeping per voxel the minimum of the exact point–triangle
//!   distances (`closest_point`). In each k-slab a triangle scans the rows that meet its ball
//!   (around the triangle, grown by the band) and, on each row, the voxels that are both within
//!   the ball's extent along i in that slab and within the band of the triangle's plane: bounds
//!   linear in i, with no square root or division per row, since rows of a few voxels make the
//!   per-row set-up as costly as the voxels. The exact distance is skipped where a lower bound —
//!   the distance to the triangle's bounding sphere, then to its bounding disk — is already no
//!   less than the voxel's current minimum; the sphere also rejects the voxels of the scan that
//!   lie outside the ball. Voxels farther than the band from every triangle get the band's
//!   half-width, like OpenVDB's background value, so the field is `sign · min(distance,
//!   band_mm)` everywhere.
//! - Sign: winding numbers of `inside_from` by exact ray crossings (`winding_number`), correct far
//!   from the surface too.
//!
//! Work is split over k-slabs: one thread adds up a slab's ray crossings, scatters the triangles
//! of the slab over it in a fixed order and applies the signs, so the result has the same bits
//! for any thread count, no grid of winding numbers is stored, and the output's pages are first
//! written by the threads that fill them. Per-triangle data is rebuilt in each slab rather than
//! stored: on a balloon's grid, first touching that memory costs more than the rebuild.

use glam::DVec3;
use rayon::prelude::*;

use crate::allocation;
use crate::closest_point::Triangle;
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::mesh::TriMesh;
use crate::volume::{Image, VoxelBuffer};
use crate::winding_number::{index_range, voxel_count, RowCrossings, SlabBins};

/// Relative growth of the regions scanned per triangle, so that rounding in the region bounds
/// never drops a voxel at exactly the band's distance; extra voxels are harmless.
const REGION_SLACK: f64 = 1e-9;
/// The same slack on index bounds, in voxels.
const INDEX_SLACK: f64 = 1e-6;

/// Options of [`signed_distance`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignedDistanceOptions {
    /// Half-width of the band of exact distances, in voxels of the grid's largest spacing:
    /// `band_mm = band_voxels · max(spacing)`, so the band covers at least `band_voxels` voxels
    /// along every axis on both sides of the surface. At least 1; default 3.
    pub band_voxels: f64,
}

impl Default for SignedDistanceOptions {
    fn default() -> Self {
        SignedDistanceOptions { band_voxels: 3.0 }
    }
}

impl SignedDistanceOptions {
    pub fn validate(&self) -> Result<()> {
        if !(self.band_voxels.is_finite() && self.band_voxels >= 1.0) {
            return Err(Error::invalid_argument(format!(
                "band_voxels is {}; it must be a finite number of voxels >= 1 (default 3): marching \
                 cubes needs exact distances at least one voxel on each side of the surface",
                self.band_voxels
            )));
        }
        Ok(())
    }

    /// The band's half-width in millimetres on `geometry`: `band_voxels` times the largest
    /// spacing. Values outside the band are ±this.
    pub fn band_mm(&self, geometry: &Geometry) -> f64 {
        let [si, sj, sk] = geometry.spacing();
        self.band_voxels * si.max(sj).max(sk)
    }
}

/// Signed distance (mm, negative inside) at every voxel centre (i fastest) of the grid
/// `dims`/`geometry` to the triangles of `surface`, which may be open (triangles deleted). The
/// inside is where the winding number of `inside_from` (a closed, outward-oriented mesh: the
/// surface before deletion) is positive. Exact within `options.band_mm(geometry)` of `surface`,
/// ±`band_mm` beyond; an empty `surface` gives ±`band_mm` everywhere. Returns an F64 image.
pub fn signed_distance(
    surface: &TriMesh,
    inside_from: &TriMesh,
    dims: [usize; 3],
    geometry: &Geometry,
    options: &SignedDistanceOptions,
) -> Result<Image> {
    let field = signed_distance_values(surface, inside_from, dims, geometry, options)?;
    Image::new(VoxelBuffer::F64(field), dims, *geometry)
}

/// [`signed_distance`] as plain voxel values, i fastest.
pub fn signed_distance_values(
    surface: &TriMesh,
    inside_from: &TriMesh,
    dims: [usize; 3],
    geometry: &Geometry,
    options: &SignedDistanceOptions,
) -> Result<Vec<f64>> {
    options.validate()?;
    let len = voxel_count(dims)?;
    let band = options.band_mm(geometry);
    let [ni, nj, _] = dims;
    let crossings = RowCrossings::new(inside_from, dims, geometry);
    let distances = BandDistance::new(surface, dims, geometry, band);
    // Zeroed memory is mapped lazily, so each slab's pages are first touched by the thread that
    // fills it rather than all by this one.
    let mut field = allocation::zeroed(len, "a signed distance field")?;
    field.par_chunks_mut(ni * nj).enumerate().for_each_init(
        || vec![0i32; ni * nj],
        |counts, (k, slab)| {
            counts.fill(0);
            crossings.add_slab(k, counts);
            slab.fill(band);
            distances.fill_slab(k, slab);
            for (row, counts) in slab.chunks_mut(ni).zip(counts.chunks(ni)) {
                let mut winding = 0;
                for (d, &count) in row.iter_mut().zip(counts).rev() {
                    winding += count;
                    if winding > 0 {
                        *d = -*d;
                    }
                }
            }
        },
    );
    Ok(field)
}

/// A surface's triangles binned by the k-slabs their balls meet, for lowering, slab by slab,
/// the band's half-width to the distance from each voxel centre to the nearest of them.
struct BandDistance<'a> {
    surface: &'a TriMesh,
    frame: RowFrame,
    bins: SlabBins,
    ni: usize,
    nj: usize,
    band: f64,
}

impl<'a> BandDistance<'a> {
    fn new(surface: &'a TriMesh, dims: [usize; 3], geometry: &Geometry, band: f64) -> Self {
        let [ni, nj, nk] = dims;
        // Along index axis k a ball of radius r spans ±r·|row k of the world→index matrix|.
        let k_per_mm = geometry.world_to_index_matrix().row(2).length();
        let k_ranges: Vec<Option<(usize, usize)>> = (0..surface.triangles().len())
            .into_par_iter()
            .map(|t| {
                let (centre, _, reach) = bounding_ball(surface.corners(t), band);
                let k_reach = reach * k_per_mm + INDEX_SLACK;
                let k = geometry.world_to_index(centre).z;
                index_range(k - k_reach, k + k_reach, nk)
            })
            .collect();
        BandDistance {
            surface,
            frame: RowFrame::new(geometry),
            bins: SlabBins::new(nk, k_ranges.iter().copied()),
            ni,
            nj,
            band,
        }
    }

    /// Lowers the values of slab `k` (its `ni·nj` voxels, i fastest) to the distance from each
    /// voxel to the nearest triangle where that is less.
    fn fill_slab(&self, k: usize, slab: &mut [f64]) {
        let (frame, ni, band) = (&self.frame, self.ni, self.band);
        let slab_origin = frame.origin + frame.step_k * k as f64;
        for &t in self.bins.slab(k) {
            let tri = BandTriangle::new(self.surface.corners(t as usize), band);
            let Some((j0, j1)) = tri.rows(frame, slab_origin, self.nj) else {
                continue;
            };
            let Some(columns) = tri.columns(frame, slab_origin) else {
                continue;
            };
            let strip = tri.strip(frame, slab_origin, band);
            for j in j0..=j1 {
                let Some((i0, i1)) = strip.interval(columns, j as f64, ni) else {
                    continue;
                };
                let row_start = slab_origin + frame.step_j * j as f64;
                let row = &mut slab[j * ni..(j + 1) * ni];
                tri.update_row(frame, row_start, i0, &mut row[i0..=i1]);
            }
        }
    }
}

/// The centroid of a triangle, the distance from it to the farthest corner and the radius of
/// the ball around it that holds every point within `band` of the triangle, both grown by
/// `REGION_SLACK`.
fn bounding_ball(corners: [DVec3; 3], band: f64) -> (DVec3, f64, f64) {
    let [a, b, c] = corners;
    let centre = (a + b + c) / 3.0;
    let radius = (a - centre)
        .length()
        .max((b - centre).length())
        .max((c - centre).length())
        * (1.0 + REGION_SLACK);
    (centre, radius, (radius + band) * (1.0 + REGION_SLACK))
}

/// The grid's axes in world space: voxel (i, j, k) is at `origin + i·step_i + j·step_j +
/// k·step_k`, and rows run along `step_i`.
struct RowFrame {
    origin: DVec3,
    step_i: DVec3,
    step_j: DVec3,
    step_k: DVec3,
    step_i2: f64,
    /// `step_j` without its component along the rows, and its squared length.
    step_j_across: DVec3,
    step_j_across2: f64,
    /// `step_i` without its component along `step_j`, and its squared length.
    step_i_across: DVec3,
    step_i_across2: f64,
}

impl RowFrame {
    fn new(geometry: &Geometry) -> Self {
        let m = geometry.index_to_world_matrix();
        let (step_i, step_j) = (m.x_axis, m.y_axis);
        let step_i2 = step_i.length_squared();
        let step_j_across = step_j - step_i * (step_i.dot(step_j) / step_i2);
        let step_i_across = step_i - step_j * (step_j.dot(step_i) / step_j.length_squared());
        RowFrame {
            origin: DVec3::from(geometry.origin()),
            step_i,
            step_j,
            step_k: m.z_axis,
            step_i2,
            step_j_across,
            step_j_across2: step_j_across.length_squared(),
            step_i_across,
            step_i_across2: step_i_across.length_squared(),
        }
    }

    /// `v` without its component along the rows.
    fn across(&self, v: DVec3) -> DVec3 {
        v - self.step_i * (self.step_i.dot(v) / self.step_i2)
    }
}

/// A triangle with the part of the grid that can be within the band of it: a ball around the
/// triangle grown by the band, cut by the slab of half-width `band` along its plane.
struct BandTriangle {
    triangle: Triangle,
    centre: DVec3,
    /// Distance from `centre` to the farthest corner, grown by `REGION_SLACK`.
    radius: f64,
    /// Squared radius of the ball that holds every point within the band.
    reach2: f64,
    /// Unit normal `n` and offset `n·a` of the plane; a zero normal for a degenerate triangle,
    /// which makes the plane tests below vacuous.
    normal: DVec3,
    offset: f64,
}

impl BandTriangle {
    fn new(corners: [DVec3; 3], band: f64) -> Self {
        let [a, b, c] = corners;
        let triangle = Triangle::new(a, b, c);
        let (centre, radius, reach) = bounding_ball(corners, band);
        let normal = triangle.normal().map_or(DVec3::ZERO, DVec3::normalize);
        BandTriangle {
            triangle,
            centre,
            radius,
            reach2: reach * reach,
            normal,
            offset: normal.dot(a),
        }
    }

    /// The rows j of the slab through `slab_origin` (its voxel (0, 0, k)) that meet the ball.
    fn rows(&self, frame: &RowFrame, slab_origin: DVec3, nj: usize) -> Option<(usize, usize)> {
        // Squared distance from the centre to row j: |w + j·step_j_across|², w across the rows.
        let w = frame.across(slab_origin - self.centre);
        let (a, half_b) = (frame.step_j_across2, w.dot(frame.step_j_across));
        let (lo, hi) = quadratic_roots(a, half_b, w.length_squared() - self.reach2)?;
        index_range(lo - INDEX_SLACK, hi + INDEX_SLACK, nj)
    }

    /// The range of `i` over which the slab through `slab_origin` meets the ball: an interval
    /// that holds every row's chord of the ball.
    fn columns(&self, frame: &RowFrame, slab_origin: DVec3) -> Option<(f64, f64)> {
        // Squared distance from the centre to the line i = const, j free, of the slab.
        let v = slab_origin - self.centre;
        let w = v - frame.step_j * (frame.step_j.dot(v) / frame.step_j.length_squared());
        let (a, half_b) = (frame.step_i_across2, w.dot(frame.step_i_across));
        quadratic_roots(a, half_b, w.length_squared() - self.reach2)
    }

    /// The slab along the triangle's plane as seen by the rows of the slab through
    /// `slab_origin`.
    fn strip(&self, frame: &RowFrame, slab_origin: DVec3, band: f64) -> Strip {
        let rise = self.normal.dot(frame.step_i);
        Strip {
            height: self.height(slab_origin),
            rise_j: self.normal.dot(frame.step_j),
            inv_rise: (rise != 0.0).then(|| 1.0 / rise),
            half: band * (1.0 + REGION_SLACK),
        }
    }

    /// Signed distance from `p` to the triangle's plane (0 for a degenerate triangle).
    fn height(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.offset
    }

    /// Lowers the distances of the row's voxels `i0, i0 + 1, …` (in `row`) to this triangle's.
    ///
    /// Most voxels that reach here are already closer to another triangle. Two lower bounds of
    /// the distance to this one skip them cheaply: the distance to its bounding sphere (centre
    /// and radius), then the distance to its bounding disk (that sphere cut by the plane).
    /// `|p − centre|²` and the height above the plane follow the row by finite differences.
    fn update_row(&self, frame: &RowFrame, row_start: DVec3, i0: usize, row: &mut [f64]) {
        let step2 = frame.step_i2;
        let first = row_start + frame.step_i * i0 as f64;
        let w = first - self.centre;
        let mut centre2 = w.length_squared();
        let mut delta = 2.0 * frame.step_i.dot(w) + step2;
        let mut height = self.height(first);
        let rise = self.normal.dot(frame.step_i);
        for (i, d) in (i0..).zip(row) {
            let bound = *d + self.radius;
            if centre2 < bound * bound {
                let height2 = height * height;
                let beyond_rim = ((centre2 - height2).max(0.0).sqrt() - self.radius).max(0.0);
                if height2 + beyond_rim * beyond_rim < *d * *d {
                    let p = row_start + frame.step_i * i as f64;
                    *d = d.min(self.triangle.distance_squared(p).sqrt());
                }
            }
            centre2 += delta;
            delta += 2.0 * step2;
            height += rise;
        }
    }
}

/// The voxels of the rows of one k-slab within `half` of a triangle's plane: along row j the
/// height above the plane is `height + j·rise_j + i·rise`. `REGION_SLACK` in `half` covers the
/// rounding of these sums and of the reciprocal, which differ from a voxel's exact height.
struct Strip {
    height: f64,
    rise_j: f64,
    /// `1 / rise`, `None` for rows parallel to the plane.
    inv_rise: Option<f64>,
    half: f64,
}

impl Strip {
    /// The voxels of row `j` inside both the strip and `columns` (an interval of `i`).
    fn interval(&self, columns: (f64, f64), j: f64, ni: usize) -> Option<(usize, usize)> {
        let (mut lo, mut hi) = columns;
        let height = self.height + j * self.rise_j;
        match self.inv_rise {
            Some(inv_rise) => {
                let (ta, tb) = (
                    (-self.half - height) * inv_rise,
                    (self.half - height) * inv_rise,
                );
                lo = lo.max(ta.min(tb));
                hi = hi.min(ta.max(tb));
            }
            None if height.abs() > self.half => return None,
            None => {}
        }
        index_range(lo - INDEX_SLACK, hi + INDEX_SLACK, ni)
    }
}

/// The roots of `a·t² + 2·half_b·t + c` (`a > 0`), where it is ≤ 0; `None` when it never is.
fn quadratic_roots(a: f64, half_b: f64, c: f64) -> Option<(f64, f64)> {
    let disc = half_b * half_b - a * c;
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let root = disc.sqrt();
    Some(((-half_b - root) / a, (-half_b + root) / a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_shapes::{cube, icosphere, torus};
    use crate::winding_number::inside_mask;
    use crate::winding_number::test_fixtures::*;
    use proptest::prelude::*;
    use std::f64::consts::TAU;

    fn values(image: &Image) -> &[f64] {
        match image.buffer() {
            VoxelBuffer::F64(v) => v,
            other => panic!("expected F64, got {:?}", other.scalar_type()),
        }
    }

    /// Every voxel against every triangle, in world space.
    fn brute_force_distance(surface: &TriMesh, dims: [usize; 3], g: &Geometry) -> Vec<f64> {
        let triangles: Vec<Triangle> = (0..surface.triangles().len())
            .map(|t| {
                let [a, b, c] = surface.corners(t);
                Triangle::new(a, b, c)
            })
            .collect();
        let mut out = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = g.index_to_world(DVec3::new(i as f64, j as f64, k as f64));
                    let d2 = triangles
                        .iter()
                        .map(|t| t.distance_squared(p))
                        .fold(f64::INFINITY, f64::min);
                    out.push(d2.sqrt());
                }
            }
        }
        out
    }

    /// The field is `sign · min(d, band)` with `d` the brute-force distance and the sign from
    /// `inside_from`'s winding numbers; returns how many voxels were inside the band.
    fn assert_matches_brute_force(
        surface: &TriMesh,
        inside_from: &TriMesh,
        dims: [usize; 3],
        g: &Geometry,
        options: &SignedDistanceOptions,
    ) -> usize {
        let band = options.band_mm(g);
        let field = signed_distance(surface, inside_from, dims, g, options).unwrap();
        let inside = inside_mask(inside_from, dims, g).unwrap();
        let exact = brute_force_distance(surface, dims, g);
        let mut in_band = 0;
        for (n, ((&got, &d), &inside)) in values(&field).iter().zip(&exact).zip(&inside).enumerate()
        {
            let expected = if inside { -d.min(band) } else { d.min(band) };
            assert!(
                (got - expected).abs() <= 1e-9 * (1.0 + band),
                "voxel {n}: {got} instead of {expected}"
            );
            if d < band {
                in_band += 1;
            } else {
                assert_eq!(got.abs(), band, "voxel {n} outside the band");
            }
        }
        in_band
    }

    #[test]
    fn icosphere_cube_and_torus_match_brute_force_on_an_oblique_left_handed_grid() {
        let g = oblique_geometry();
        assert!(g.is_left_handed());
        let dims = [18, 15, 12];
        let at = |i, j, k| g.index_to_world(DVec3::new(i, j, k));
        let sphere = icosphere(at(8.0, 7.0, 5.5), 3.7, 2);
        let r = g.index_vector_to_world(DVec3::new(3.0, 2.5, 2.0));
        let box_mesh = cube(at(8.0, 7.0, 5.5) - r.abs(), at(8.0, 7.0, 5.5) + r.abs());
        let torus = torus(at(9.0, 7.0, 6.0), 4.5, 1.6, 24, 12);
        let options = SignedDistanceOptions { band_voxels: 2.0 };
        for mesh in [sphere, box_mesh, torus] {
            let in_band = assert_matches_brute_force(&mesh, &mesh, dims, &g, &options);
            // The band is narrow enough that the clamping is exercised too.
            assert!(
                in_band > 100 && in_band < dims.iter().product::<usize>(),
                "{in_band}"
            );
        }
    }

    #[test]
    fn wide_band_on_anisotropic_grid_is_exact_everywhere() {
        let g = Geometry::with_spacing([0.5, 1.25, 2.0], [1.0, -2.0, 3.0]).unwrap();
        let dims = [20, 9, 7];
        let mesh = icosphere(g.index_to_world(DVec3::new(9.5, 4.0, 3.2)), 3.0, 2);
        let options = SignedDistanceOptions { band_voxels: 20.0 };
        let in_band = assert_matches_brute_force(&mesh, &mesh, dims, &g, &options);
        assert_eq!(in_band, dims.iter().product::<usize>());
    }

    #[test]
    fn band_covers_band_voxels_along_every_axis() {
        // The band is 3 voxels of the largest spacing, 6 mm: 12 voxels along i, 6 along j, 3
        // along k, on both sides of a face perpendicular to that axis.
        let g = Geometry::with_spacing([0.5, 1.0, 2.0], [0.0; 3]).unwrap();
        let dims = [30, 30, 30];
        let options = SignedDistanceOptions { band_voxels: 3.0 };
        assert_eq!(options.band_mm(&g), 6.0);
        for axis in 0..3 {
            let mut lo = DVec3::splat(-10.0);
            lo[axis] = 7.25;
            let mesh = cube(lo, DVec3::splat(100.0));
            let field = signed_distance(&mesh, &mesh, dims, &g, &options).unwrap();
            let v = values(&field);
            let mut exact = 0;
            for step in 0..30 {
                let mut index = [5usize; 3];
                index[axis] = step;
                let [i, j, k] = index;
                let above = g.spacing()[axis] * step as f64 - 7.25;
                let expected = -above.signum() * above.abs().min(6.0);
                let got = v[i + 30 * (j + 30 * k)];
                assert!(
                    (got - expected).abs() < 1e-12,
                    "axis {axis}, step {step}: {got}"
                );
                exact += (above.abs() < 6.0) as usize;
            }
            // At least 3 exact voxels on each side of the face.
            assert!(exact >= 2 * 3, "axis {axis}: {exact}");
        }
    }

    #[test]
    fn cube_with_vertices_on_voxel_rows_has_the_right_signs() {
        let dims = [10, 10, 10];
        let g = Geometry::identity();
        let mesh = cube(DVec3::splat(2.0), DVec3::splat(7.0));
        let field = signed_distance(&mesh, &mesh, dims, &g, &Default::default()).unwrap();
        let v = values(&field);
        for k in 0..10 {
            for j in 0..10 {
                for i in 0..10 {
                    let p = DVec3::new(i as f64, j as f64, k as f64);
                    let got = v[i + 10 * (j + 10 * k)];
                    if p.cmpgt(DVec3::splat(2.0)).all() && p.cmplt(DVec3::splat(7.0)).all() {
                        assert!(got < 0.0, "{p}: {got}");
                    } else if p.cmplt(DVec3::splat(2.0)).any() || p.cmpgt(DVec3::splat(7.0)).any() {
                        assert!(got > 0.0, "{p}: {got}");
                    } else {
                        assert_eq!(got, 0.0, "{p} is on the surface");
                    }
                }
            }
        }
    }

    #[test]
    fn overlap_of_a_self_intersecting_balloon_is_inside() {
        let g = Geometry::with_spacing([0.5, 0.5, 0.75], [0.0; 3]).unwrap();
        let dims = [22, 12, 9];
        let (c0, c1) = (DVec3::new(3.5, 3.0, 3.0), DVec3::new(7.5, 3.0, 3.0));
        let balloon = two_spheres(c0, c1, 2.5);
        assert_matches_brute_force(&balloon, &balloon, dims, &g, &Default::default());
        // The voxel at the middle of the lens, 2 mm from both centres, is inside both spheres.
        let field = signed_distance(&balloon, &balloon, dims, &g, &Default::default()).unwrap();
        assert_eq!(
            g.index_to_world(DVec3::new(11.0, 6.0, 4.0)),
            DVec3::new(5.5, 3.0, 3.0)
        );
        let v = values(&field)[11 + 22 * (6 + 12 * 4)];
        assert!(v < 0.0, "{v}");
    }

    #[test]
    fn open_surface_keeps_the_closed_signs_and_distances_grow_across_the_hole() {
        let g = Geometry::with_spacing([0.5, 0.5, 0.9], [0.0; 3]).unwrap();
        let dims = [20, 20, 12];
        let centre = DVec3::new(4.5, 4.5, 5.0);
        let closed = icosphere(centre, 3.0, 2);
        let kept: Vec<[DVec3; 3]> = (0..closed.triangles().len())
            .map(|t| closed.corners(t))
            .filter(|c| c.iter().all(|p| p.z < centre.z + 2.0))
            .collect();
        let open = TriMesh::from_soup(&kept).unwrap();
        assert!(open.triangles().len() < closed.triangles().len());
        let options = SignedDistanceOptions { band_voxels: 4.0 };
        assert_matches_brute_force(&open, &closed, dims, &g, &options);
        let with_cap = signed_distance(&closed, &closed, dims, &g, &options).unwrap();
        let without = signed_distance(&open, &closed, dims, &g, &options).unwrap();
        let (with_cap, without) = (values(&with_cap), values(&without));
        for n in 0..with_cap.len() {
            assert_eq!(with_cap[n] < 0.0, without[n] < 0.0, "sign of voxel {n}");
            assert!(without[n].abs() >= with_cap[n].abs() - 1e-12);
        }
        // Voxel (9, 9, 8) is 0.8 mm below the north pole; without the cap the nearest triangles
        // are on the rim at z = 7, 2.2 mm away.
        let voxel = 9 + 20 * (9 + 20 * 8);
        assert_eq!(
            g.index_to_world(DVec3::new(9.0, 9.0, 8.0)),
            DVec3::new(4.5, 4.5, 7.2)
        );
        assert!(
            with_cap[voxel] < -0.5 && with_cap[voxel] > -1.0,
            "{}",
            with_cap[voxel]
        );
        assert!(without[voxel] < -1.5, "{}", without[voxel]);
    }

    #[test]
    fn degenerate_and_needle_triangles_match_brute_force() {
        let g = oblique_geometry();
        let dims = [14, 12, 10];
        let at = |i, j, k| g.index_to_world(DVec3::new(i, j, k));
        let (p, q, r) = (at(3.0, 3.0, 3.0), at(9.0, 8.0, 5.0), at(4.0, 9.0, 6.5));
        let soup = [
            [p, q, r],
            [p, p, q],                                   // two equal corners
            [p, (p + q) * 0.5, q],                       // collinear
            [r, r, r],                                   // a point
            [p, q, (p + q) * 0.5 + DVec3::splat(1e-11)], // a needle
        ];
        let surface = TriMesh::from_soup(&soup).unwrap();
        let closed = icosphere(at(6.0, 6.0, 5.0), 3.0, 1);
        assert_matches_brute_force(&surface, &closed, dims, &g, &Default::default());
    }

    #[test]
    fn planes_parallel_and_nearly_parallel_to_the_rows_match_brute_force() {
        // The band along a plane is found on each row from its rise along i, which is zero or
        // tiny here: the cut of the band by a row is then the whole row or none of it.
        let g = Geometry::with_spacing([0.7, 0.9, 1.3], [0.5, -1.0, 0.0]).unwrap();
        let dims = [24, 10, 9];
        let at = |i, j, k| g.index_to_world(DVec3::new(i, j, k));
        for tilt in [0.0, 1e-13, 1e-9, 0.02] {
            let (lo, hi) = (at(-2.0, 1.2, 3.7), at(26.0, 8.4, 3.7));
            let soup = [
                [lo, DVec3::new(hi.x, lo.y, lo.z + tilt), hi],
                [lo, hi, DVec3::new(lo.x, hi.y, lo.z)],
                // Parallel to the rows, across the slabs.
                [
                    at(-1.0, 5.5, 0.2),
                    at(25.0, 5.5, 0.2),
                    at(25.0, 5.5 + tilt, 8.0),
                ],
            ];
            let surface = TriMesh::from_soup(&soup).unwrap();
            let closed = cube(at(3.0, 2.0, 1.0), at(20.0, 7.0, 6.0));
            let options = SignedDistanceOptions { band_voxels: 1.0 };
            let in_band = assert_matches_brute_force(&surface, &closed, dims, &g, &options);
            assert!(in_band > 200, "{in_band}");
        }
    }

    #[test]
    fn empty_surface_gives_the_band_with_the_sign_of_the_closed_mesh() {
        let g = Geometry::with_spacing([1.0, 1.0, 1.5], [0.0; 3]).unwrap();
        let dims = [8, 8, 6];
        let closed = cube(DVec3::splat(1.2), DVec3::new(5.8, 5.8, 5.3));
        let field =
            signed_distance(&TriMesh::default(), &closed, dims, &g, &Default::default()).unwrap();
        let inside = inside_mask(&closed, dims, &g).unwrap();
        for (&v, &inside) in values(&field).iter().zip(&inside) {
            assert_eq!(v, if inside { -4.5 } else { 4.5 });
        }
        assert!(inside.contains(&true));
    }

    #[test]
    fn mesh_beyond_the_grid_and_mismatched_meshes_do_not_fail() {
        let g = Geometry::identity();
        let dims = [6, 6, 6];
        let big = icosphere(DVec3::new(2.0, 2.0, 2.0), 6.0, 2);
        let far = icosphere(DVec3::splat(1000.0), 1.0, 1);
        assert_matches_brute_force(&big, &big, dims, &g, &Default::default());
        assert_matches_brute_force(&far, &big, dims, &g, &Default::default());
        assert_matches_brute_force(&big, &far, dims, &g, &Default::default());
    }

    #[test]
    fn invalid_band_and_dims_are_rejected_with_a_reason() {
        let g = Geometry::identity();
        let mesh = cube(DVec3::ZERO, DVec3::ONE);
        for band_voxels in [0.5, -1.0, f64::NAN, f64::INFINITY] {
            let options = SignedDistanceOptions { band_voxels };
            let e = signed_distance(&mesh, &mesh, [4, 4, 4], &g, &options).unwrap_err();
            assert_eq!(e.kind(), crate::ErrorKind::InvalidArgument);
            assert!(e.message().contains("band_voxels"), "{e}");
        }
        let e = signed_distance(&mesh, &mesh, [4, 0, 4], &g, &Default::default()).unwrap_err();
        assert!(e.message().contains("dims"), "{e}");
    }

    /// An icosphere made into an arbitrary closed mesh: placed at `centre` (fractions of the
    /// grid's extent along i, j and k), of `radius` voxels of the largest spacing, stretched and
    /// rotated, each vertex moved by up to `jitter` radii (`noise`, cycled), which folds it
    /// through itself when large, and, if `snapped`, moved to the nearest voxel centre, so that
    /// voxel rows run through its vertices and along its edges.
    #[derive(Debug, Clone)]
    struct Blob {
        levels: u32,
        centre: [f64; 3],
        radius: f64,
        stretch: [f64; 3],
        angles: [f64; 3],
        jitter: f64,
        noise: Vec<[f64; 3]>,
        snapped: bool,
    }

    impl Blob {
        fn mesh(&self, dims: [usize; 3], g: &Geometry) -> TriMesh {
            let extent = DVec3::from_array(dims.map(|d| (d - 1) as f64));
            let centre = g.index_to_world(DVec3::from_array(self.centre) * extent);
            let [a, b, c] = self.angles;
            let rotation = glam::DQuat::from_euler(glam::EulerRot::ZYX, a, b, c);
            let radius = self.radius * g.max_spacing();
            let (points, triangles) = icosphere(DVec3::ZERO, 1.0, self.levels).into_parts();
            let points = points
                .into_iter()
                .zip(self.noise.iter().cycle())
                .map(|(p, &noise)| {
                    let p = p * DVec3::from_array(self.stretch)
                        + DVec3::from_array(noise) * self.jitter;
                    let p = centre + rotation * p * radius;
                    if self.snapped {
                        g.index_to_world(g.world_to_index(p).round())
                    } else {
                        p
                    }
                })
                .collect();
            TriMesh::new(points, triangles).unwrap()
        }
    }

    fn blob() -> impl Strategy<Value = Blob> {
        (
            1u32..=2,
            [0.0f64..1.0, 0.0..1.0, 0.0..1.0],
            1.0f64..5.0,
            [0.4f64..2.5, 0.4..2.5, 0.4..2.5],
            [0.0f64..TAU, 0.0..TAU, 0.0..TAU],
            prop_oneof![Just(0.0), 0.0f64..0.5],
            proptest::collection::vec([-1.0f64..1.0, -1.0..1.0, -1.0..1.0], 1..32),
            any::<bool>(),
        )
            .prop_map(
                |(levels, centre, radius, stretch, angles, jitter, noise, snapped)| Blob {
                    levels,
                    centre,
                    radius,
                    stretch,
                    angles,
                    jitter,
                    noise,
                    snapped,
                },
            )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]

        /// Unions of one to three blobs (convex polytopes, overlapping ones, folded ones) on
        /// random grids, as the closed mesh and, with every `k`-th triangle deleted, as the
        /// surface: negative exactly where the winding number is positive, wherever the
        /// distance is not within rounding of zero, and of the brute-force magnitude.
        #[test]
        fn sign_follows_the_winding_number_and_magnitude_the_brute_force_distance(
            dims in [3usize..=12, 3usize..=12, 3usize..=12],
            g in any_geometry(0.3..3.0),
            blobs in proptest::collection::vec(blob(), 1..=3),
            delete_every in proptest::option::of(2usize..6),
            band_voxels in 1.0f64..5.0,
        ) {
            let mut closed = TriMesh::default();
            for blob in &blobs {
                closed.append(&blob.mesh(dims, &g)).unwrap();
            }
            let surface = match delete_every {
                Some(k) => {
                    let kept: Vec<[DVec3; 3]> = (0..closed.triangles().len())
                        .filter(|t| t % k != 0)
                        .map(|t| closed.corners(t))
                        .collect();
                    TriMesh::from_soup(&kept).unwrap()
                }
                None => closed.clone(),
            };
            let options = SignedDistanceOptions { band_voxels };
            assert_matches_brute_force(&surface, &closed, dims, &g, &options);
        }
    }

    #[test]
    fn same_bits_with_one_and_two_threads() {
        let g = oblique_geometry();
        let dims = [25, 21, 18];
        let at = |i, j, k| g.index_to_world(DVec3::new(i, j, k));
        let balloon = two_spheres(at(10.0, 10.0, 8.0), at(14.0, 10.0, 9.0), 4.0);
        let surface = torus(at(12.0, 10.0, 9.0), 5.0, 1.5, 20, 10);
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    signed_distance(&surface, &balloon, dims, &g, &Default::default()).unwrap()
                })
        };
        let (one, two) = (run(1), run(2));
        let bits = |image: &Image| {
            values(image)
                .iter()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&one), bits(&two));
    }
}
