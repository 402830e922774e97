//! Narrow-band signed distance on a voxel grid: step 6 of the paper (section 3). After the
//! balloon stops, its self-intersecting triangles are deleted; every voxel gets the distance to
//! the remaining triangles, negative where the closed balloon before deletion encloses it.
//! Marching cubes of this field at 0 gives the repaired surface.
//!
//! - Distance: exact Euclidean distance in world millimetres (anisotropic spacing and any
//!   direction matrix), by scattering each triangle over the voxels that can be within the band
//!   of it (a ball around the triangle, cut by the slab along its plane, row by row) and keeping
//!   the minimum of the exact point–triangle distances (`closest_point`). Voxels farther than the
//!   band from every triangle get the band's half-width, like OpenVDB's background value, so the
//!   field is `sign · min(distance, band_mm)` everywhere.
//! - Sign: winding numbers of `inside_from` by exact ray crossings (`winding_number`), correct far
//!   from the surface too.
//!
//! Work is split over k-slabs, each filled by one thread from a fixed triangle order, so the
//! result has the same bits for any thread count.

use glam::DVec3;
use rayon::prelude::*;

use crate::closest_point::Triangle;
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::mesh::TriMesh;
use crate::volume::{Image, VoxelBuffer};
use crate::winding_number::{index_range, inside_mask, voxel_count, SlabBins};

/// Relative growth of the regions scanned per triangle, so that rounding in the region bounds
/// never drops a voxel at exactly the band's distance; extra voxels are harmless.
const REGION_SLACK: f64 = 1e-9;
/// The same slack on index bounds, in voxels.
const INDEX_SLACK: f64 = 1e-6;

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
    options.validate()?;
    let len = voxel_count(dims)?;
    let band = options.band_mm(geometry);
    let inside = inside_mask(inside_from, dims, geometry)?;
    let band2 = band * band;
    let mut field = band_distance_squared(surface, dims, len, geometry, band);
    field
        .par_iter_mut()
        .zip(inside.par_iter())
        .for_each(|(v, &inside)| {
            // Exactly ±band outside the band, not sqrt(band²).
            let d = if *v < band2 { v.sqrt() } else { band };
            *v = if inside { -d } else { d };
        });
    Image::new(VoxelBuffer::F64(field), dims, *geometry)
}

/// Squared distance from every voxel centre to the nearest triangle of `surface` where that is
/// less than `band²`, and `band²` elsewhere. `len` is the voxel count of the valid `dims`.
fn band_distance_squared(
    surface: &TriMesh,
    dims: [usize; 3],
    len: usize,
    geometry: &Geometry,
    band: f64,
) -> Vec<f64> {
    let [ni, nj, nk] = dims;
    let triangles: Vec<BandTriangle> = (0..surface.triangles().len())
        .filter_map(|t| BandTriangle::new(surface.corners(t), geometry, dims, band))
        .collect();
    let bins = SlabBins::new(nk, triangles.iter().map(|t| t.k_range));
    let step = geometry.index_vector_to_world(DVec3::X);
    let band2 = band * band;
    let mut field = vec![band2; len];
    field
        .par_chunks_mut(ni * nj)
        .enumerate()
        .for_each(|(k, slab)| {
            for &t in bins.slab(k) {
                let tri = &triangles[t as usize];
                for j in tri.j_range.0..=tri.j_range.1 {
                    let row_start = geometry.index_to_world(DVec3::new(0.0, j as f64, k as f64));
                    let Some((lo, hi)) = tri.row_interval(row_start, step, band) else {
                        continue;
                    };
                    let Some((i0, i1)) = index_range(lo - INDEX_SLACK, hi + INDEX_SLACK, ni) else {
                        continue;
                    };
                    let row = &mut slab[j * ni..(j + 1) * ni];
                    for (i, d2) in (i0..=i1).zip(&mut row[i0..=i1]) {
                        let p = row_start + step * i as f64;
                        *d2 = d2.min(tri.triangle.distance_squared(p));
                    }
                }
            }
        });
    field
}

/// A triangle with the part of the grid within the band of it: the index box of its band, and a
/// ball around it for cutting each row.
struct BandTriangle {
    triangle: Triangle,
    centre: DVec3,
    reach2: f64,
    unit_normal: Option<DVec3>,
    j_range: (usize, usize),
    k_range: Option<(usize, usize)>,
}

impl BandTriangle {
    /// `None` when no voxel of the grid is within `band` of the triangle's box.
    fn new(corners: [DVec3; 3], geometry: &Geometry, dims: [usize; 3], band: f64) -> Option<Self> {
        let [a, b, c] = corners;
        // Index-space box of the triangle grown by a ball of radius `band`: along index axis n
        // the ball spans ±band·|row n of the world→index matrix|.
        let to_index = geometry.world_to_index_matrix();
        let index = corners.map(|p| geometry.world_to_index(p));
        let axis_range = |n: usize| {
            let reach = band * to_index.row(n).length() * (1.0 + REGION_SLACK) + INDEX_SLACK;
            let lo = index[0][n].min(index[1][n]).min(index[2][n]);
            let hi = index[0][n].max(index[1][n]).max(index[2][n]);
            index_range(lo - reach, hi + reach, dims[n])
        };
        axis_range(0)?;
        let j_range = axis_range(1)?;
        let k_range = Some(axis_range(2)?);
        let triangle = Triangle::new(a, b, c);
        let centre = (a + b + c) / 3.0;
        let radius = (a - centre)
            .length()
            .max((b - centre).length())
            .max((c - centre).length());
        let reach = (radius + band) * (1.0 + REGION_SLACK);
        Some(BandTriangle {
            triangle,
            centre,
            reach2: reach * reach,
            unit_normal: triangle.normal().map(DVec3::normalize),
            j_range,
            k_range,
        })
    }

    /// The parameters `t` of the row `start + t·step` that can be within `band` of the triangle:
    /// inside the ball around it and inside the slab of half-width `band` along its plane.
    fn row_interval(&self, start: DVec3, step: DVec3, band: f64) -> Option<(f64, f64)> {
        let w = start - self.centre;
        let (ss, sw) = (step.length_squared(), step.dot(w));
        let disc = sw * sw - ss * (w.length_squared() - self.reach2);
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        let (mut lo, mut hi) = ((-sw - root) / ss, (-sw + root) / ss);
        if let Some(n) = self.unit_normal {
            let half = band * (1.0 + REGION_SLACK);
            let (height, rate) = (n.dot(start - self.triangle.corners()[0]), n.dot(step));
            if rate != 0.0 {
                let (ta, tb) = ((-half - height) / rate, (half - height) / rate);
                lo = lo.max(ta.min(tb));
                hi = hi.min(ta.max(tb));
            } else if height.abs() > half {
                return None;
            }
        }
        (lo <= hi).then_some((lo, hi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_shapes::{cube, icosphere};
    use crate::winding_number::test_fixtures::*;

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
