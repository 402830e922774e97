//! Inside/outside of every voxel centre of a grid with respect to a closed, possibly
//! self-intersecting triangle mesh, by exact ray crossing counts (winding numbers).
//!
//! This is the sign of step 6 of the paper (section 3): the balloon before its self-intersecting
//! triangles are deleted is still watertight and defines the inside. Where it overlaps itself the
//! winding number is 2, which is inside too.
//!
//! Method: the mesh is mapped to continuous index space once per vertex (so the mesh stays closed
//! there whatever the rounding), and a ray is cast along +i through every (j, k) row of voxel
//! centres. Each triangle is rasterised over the rows its (j, k) projection covers. Whether a row
//! passes through a projected triangle is decided with Shewchuk's exact `orient2d`; a row through
//! an edge or a vertex is decided by simulation of simplicity, moving the row by the infinitesimal
//! `(ε, ε²)` in (j, k). The moved row never meets an edge or vertex, so a closed mesh is crossed
//! a consistent number of times, and triangles parallel to the ray (zero projected area) are never
//! crossed. Each crossing adds ±1 (the triangle's facing along i) at its position in the row, and
//! a suffix sum along the row gives, for every voxel, the signed number of crossings between it and
//! +∞: its winding number. Rows through voxels exactly on the surface are classified by the same
//! rule, so a voxel on a face belongs to exactly one side (half-open, like a fill rule).
//!
//! The crossings are added up k-slab by k-slab, one slab per thread (`RowCrossings`), which lets
//! the signed distance turn them into signs without a grid of winding numbers. A triangle's
//! projection is rebuilt in each slab it covers rather than stored: on a balloon's grid, first
//! touching the memory that would hold them costs more.

use glam::DVec3;
use rayon::prelude::*;
use robust::{orient2d, Coord};

use crate::allocation;
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::mesh::TriMesh;

/// Winding number of every voxel centre (i fastest, then j, then k) with respect to `mesh`: the
/// number of times the closed surface wraps around the centre, positive for an outward-oriented
/// mesh (1 inside a simple closed surface, 2 where two outward parts overlap, 0 outside; an
/// inward-oriented mesh gives negative numbers). For a surface that is not closed the numbers are
/// those of the rays along +i and are not meaningful.
pub fn winding_numbers(mesh: &TriMesh, dims: [usize; 3], geometry: &Geometry) -> Result<Vec<i32>> {
    per_voxel(mesh, dims, geometry, "winding numbers", |w| w)
}

/// `map` of the winding number of every voxel centre, summed slab by slab in a buffer of one
/// slab: a mask needs a byte per voxel, not the four of a winding number.
fn per_voxel<T: Copy + Default + Send>(
    mesh: &TriMesh,
    dims: [usize; 3],
    geometry: &Geometry,
    what: &str,
    map: impl Fn(i32) -> T + Sync,
) -> Result<Vec<T>> {
    let len = voxel_count(dims)?;
    let crossings = RowCrossings::new(mesh, dims, geometry);
    let mut values = allocation::filled(len, T::default(), what)?;
    values
        .par_chunks_mut(dims[0] * dims[1])
        .enumerate()
        .for_each_init(
            || vec![0i32; dims[0] * dims[1]],
            |crossed, (k, slab)| {
                crossed.fill(0);
                crossings.add_slab(k, crossed);
                for (row, out) in crossed.chunks(dims[0]).zip(slab.chunks_mut(dims[0])) {
                    let mut after = 0;
                    for (w, v) in row.iter().zip(out).rev() {
                        after += *w;
                        *v = map(after);
                    }
                }
            },
        );
    Ok(values)
}

/// The ray crossings of a mesh on the rows of a grid, to be added up slab by slab.
pub(crate) struct RowCrossings<'a> {
    triangles: &'a [[u32; 3]],
    index_points: Vec<DVec3>,
    facing: i32,
    bins: SlabBins,
    ni: usize,
    nj: usize,
}

impl<'a> RowCrossings<'a> {
    /// `dims` must be valid (see [`voxel_count`]).
    pub(crate) fn new(mesh: &'a TriMesh, dims: [usize; 3], geometry: &Geometry) -> Self {
        let [ni, nj, nk] = dims;
        let index_points: Vec<DVec3> = mesh
            .points()
            .par_iter()
            .map(|&p| geometry.world_to_index(p))
            .collect();
        let mut crossings = RowCrossings {
            triangles: mesh.triangles(),
            index_points,
            // A mirroring index map turns an outward mesh inward, which flips every crossing's
            // sign.
            facing: if geometry.is_left_handed() { -1 } else { 1 },
            // Replaced below, once the triangles' slabs are known.
            bins: SlabBins::default(),
            ni,
            nj,
        };
        let k_ranges: Vec<Option<(usize, usize)>> = (0..crossings.triangles.len())
            .into_par_iter()
            .map(|t| crossings.projected(t)?.k_range(nk))
            .collect();
        crossings.bins = SlabBins::new(nk, k_ranges.into_iter());
        crossings
    }

    fn projected(&self, t: usize) -> Option<ProjectedTriangle> {
        let corners = self.triangles[t].map(|v| self.index_points[v as usize]);
        ProjectedTriangle::new(corners, self.facing, self.nj)
    }

    /// Adds to `slab` (the `ni·nj` voxels of slab `k`, i fastest) the crossings of its rows: the
    /// winding contribution of each crossing at the last voxel before it, so that the sum of a
    /// row from a voxel to its end is the voxel's winding number.
    pub(crate) fn add_slab(&self, k: usize, slab: &mut [i32]) {
        let ni = self.ni;
        debug_assert_eq!(slab.len(), ni * self.nj);
        for &t in self.bins.slab(k) {
            let Some(tri) = self.projected(t as usize) else {
                continue;
            };
            for j in tri.j_lo..=tri.j_hi {
                let Some(x) = tri.crossing(j as f64, k as f64) else {
                    continue;
                };
                // The crossing counts for the voxels strictly before it: i < x.
                let before = x.ceil().clamp(0.0, ni as f64) as usize;
                if before > 0 {
                    slab[j * ni + before - 1] += tri.sign;
                }
            }
        }
    }
}

/// Whether each voxel centre (i fastest) is inside the closed, outward-oriented `mesh`: winding
/// number > 0, so regions where a self-intersecting mesh overlaps itself are inside too.
pub fn inside_mask(mesh: &TriMesh, dims: [usize; 3], geometry: &Geometry) -> Result<Vec<bool>> {
    per_voxel(mesh, dims, geometry, "an inside mask", |w| w > 0)
}

/// The number of voxels of a grid, or an error when a size is zero or the count overflows.
pub(crate) fn voxel_count(dims: [usize; 3]) -> Result<usize> {
    match dims.iter().try_fold(1usize, |n, &d| n.checked_mul(d)) {
        Some(n) if n > 0 => Ok(n),
        _ => Err(Error::invalid_argument(format!(
            "grid dims {dims:?} are unusable; every size must be at least 1 and their product must \
             fit in memory"
        ))),
    }
}

/// The integer indices in `[lo, hi]` that are also in `0..n`, as an inclusive pair; `None` for
/// an empty range or a NaN bound.
pub(crate) fn index_range(lo: f64, hi: f64, n: usize) -> Option<(usize, usize)> {
    if lo.is_nan() || hi.is_nan() {
        return None;
    }
    // Clamped first, both are in [0, n − 1] and truncation is exact; this avoids the libm
    // calls that `ceil` and `floor` become without SSE4.1, in the innermost setup loops.
    let (lo, hi) = (lo.max(0.0), hi.min(n as f64 - 1.0));
    if lo > hi {
        return None;
    }
    let (first, last) = (lo as i64, hi as i64);
    let first = first + i64::from((first as f64) < lo);
    (first <= last).then_some((first as usize, last as usize))
}

/// Items grouped by the k-slabs they touch, in item order within each slab (so that per-slab
/// work is deterministic whatever the thread count), stored compactly.
#[derive(Default)]
pub(crate) struct SlabBins {
    start: Vec<usize>,
    items: Vec<u32>,
}

impl SlabBins {
    /// `ranges` gives, per item in order, the inclusive range of slabs it touches, if any.
    pub(crate) fn new(
        slabs: usize,
        ranges: impl Iterator<Item = Option<(usize, usize)>> + Clone,
    ) -> Self {
        let mut start = vec![0usize; slabs + 1];
        for (lo, hi) in ranges.clone().flatten() {
            for count in &mut start[lo + 1..=hi + 1] {
                *count += 1;
            }
        }
        for k in 0..slabs {
            start[k + 1] += start[k];
        }
        let mut next = start.clone();
        let mut items = vec![0u32; start[slabs]];
        for (item, range) in ranges.enumerate() {
            let Some((lo, hi)) = range else { continue };
            for slot in &mut next[lo..=hi] {
                items[*slot] = item as u32;
                *slot += 1;
            }
        }
        SlabBins { start, items }
    }

    pub(crate) fn slab(&self, k: usize) -> &[u32] {
        &self.items[self.start[k]..self.start[k + 1]]
    }
}

/// A triangle in index space seen along the i axis: its (j, k) projection and the i of its
/// corners.
struct ProjectedTriangle {
    jk: [Coord<f64>; 3],
    i: [f64; 3],
    /// Sign of the projected area, the triangle's facing along +i.
    area_sign: f64,
    /// The winding contribution of a crossing: +1 when the ray leaves an outward mesh.
    sign: i32,
    j_lo: usize,
    j_hi: usize,
    k_min: f64,
    k_max: f64,
}

impl ProjectedTriangle {
    /// `None` when the triangle is parallel to the ray or covers no row of the grid's j extent.
    fn new(corners: [DVec3; 3], facing: i32, nj: usize) -> Option<Self> {
        let jk = corners.map(|p| Coord { x: p.y, y: p.z });
        let area = orient2d(jk[0], jk[1], jk[2]);
        if area == 0.0 {
            return None;
        }
        let (j_lo, j_hi) = index_range(
            jk[0].x.min(jk[1].x).min(jk[2].x),
            jk[0].x.max(jk[1].x).max(jk[2].x),
            nj,
        )?;
        let sign = if area > 0.0 { facing } else { -facing };
        Some(ProjectedTriangle {
            jk,
            i: corners.map(|p| p.x),
            area_sign: area.signum(),
            sign,
            j_lo,
            j_hi,
            k_min: jk[0].y.min(jk[1].y).min(jk[2].y),
            k_max: jk[0].y.max(jk[1].y).max(jk[2].y),
        })
    }

    fn k_range(&self, nk: usize) -> Option<(usize, usize)> {
        index_range(self.k_min, self.k_max, nk)
    }

    /// Where the row (j, k), moved by (ε, ε²), crosses the triangle: the i of the crossing, or
    /// `None` when it misses.
    fn crossing(&self, j: f64, k: f64) -> Option<f64> {
        let q = Coord { x: j, y: k };
        let [a, b, c] = self.jk;
        let (wa, sa) = perturbed_side(b, c, q);
        let (wb, sb) = perturbed_side(c, a, q);
        let (wc, sc) = perturbed_side(a, b, q);
        if sa != self.area_sign || sb != self.area_sign || sc != self.area_sign {
            return None;
        }
        // Barycentric weights that all have the area's sign (or are zero), so the crossing is a
        // convex combination of the corners' i, even with inexact magnitudes.
        Some((wa * self.i[0] + wb * self.i[1] + wc * self.i[2]) / (wa + wb + wc))
    }
}

/// `orient2d(u, v, q)` and its sign once `q` is moved by `(ε, ε²)`, `ε → 0⁺`: the determinant
/// gains `(v.x − u.x)·ε² − (v.y − u.y)·ε`, so on the line through `u` and `v` the sign comes from
/// `u.y − v.y`, or from `v.x − u.x` when the edge is parallel to the x axis. Differences of floats
/// have exact signs, so the rule is exact and antisymmetric in `u`, `v`: an edge shared by two
/// triangles sends the moved row to exactly one of them. Zero only when `u == v`.
fn perturbed_side(u: Coord<f64>, v: Coord<f64>, q: Coord<f64>) -> (f64, f64) {
    let o = orient2d(u, v, q);
    let sign = if o != 0.0 {
        o.signum()
    } else if u.y != v.y {
        (u.y - v.y).signum()
    } else if u.x != v.x {
        (v.x - u.x).signum()
    } else {
        0.0
    };
    (o, sign)
}

#[cfg(test)]
pub(crate) mod test_fixtures {
    //! Closed meshes and an oblique grid for the sign and distance tests, beyond
    //! `mesh::test_shapes`.
    use super::*;
    use crate::mesh::test_shapes::icosphere;
    use glam::{DMat3, EulerRot};
    use proptest::prelude::*;
    use std::f64::consts::TAU;
    use std::ops::Range;

    /// Random grid geometries for the properties, mirrored half of the time (a left-handed grid
    /// reverses the orientation the kernels must keep track of), of two kinds:
    /// - axis-aligned, with spacings of 0.5 or 1 and an integer origin within 10 mm of zero:
    ///   integer indices go to world and back exactly, so rays along voxel rows meet the
    ///   vertices and edges of meshes built on grid lines exactly (the degenerate cases);
    /// - any rotation, spacings from `spacing` and any origin within 10 mm of zero.
    pub fn any_geometry(spacing: Range<f64>) -> impl Strategy<Value = Geometry> {
        let exact_spacing = prop_oneof![Just(1.0), Just(0.5)];
        let aligned = (
            [exact_spacing.clone(), exact_spacing.clone(), exact_spacing],
            [-10i8..=10, -10..=10, -10..=10].prop_map(|o| o.map(f64::from)),
            Just([0.0; 3]),
        );
        let rotated = (
            [spacing.clone(), spacing.clone(), spacing],
            [-10.0f64..10.0, -10.0..10.0, -10.0..10.0],
            [0.0f64..TAU, 0.0..TAU, 0.0..TAU],
        );
        (prop_oneof![aligned, rotated], any::<bool>()).prop_map(
            |((spacing, origin, [a, b, c]), mirrored)| {
                let mirror = DVec3::new(if mirrored { -1.0 } else { 1.0 }, 1.0, 1.0);
                let direction =
                    DMat3::from_euler(EulerRot::ZYX, a, b, c) * DMat3::from_diagonal(mirror);
                // Geometry takes the direction row-major.
                Geometry::new(spacing, origin, direction.transpose().to_cols_array()).unwrap()
            },
        )
    }

    /// The regular octahedron `|x − c|₁ ≤ r`, outward.
    pub fn octahedron(c: DVec3, r: f64) -> TriMesh {
        let points = vec![
            c + DVec3::X * r,
            c - DVec3::X * r,
            c + DVec3::Y * r,
            c - DVec3::Y * r,
            c + DVec3::Z * r,
            c - DVec3::Z * r,
        ];
        let triangles = vec![
            [0, 2, 4],
            [2, 1, 4],
            [1, 3, 4],
            [3, 0, 4],
            [2, 0, 5],
            [1, 2, 5],
            [3, 1, 5],
            [0, 3, 5],
        ];
        TriMesh::new(points, triangles).unwrap()
    }

    /// A left-handed, rotated, anisotropic grid.
    pub fn oblique_geometry() -> Geometry {
        let (s, c) = 0.4f64.sin_cos();
        Geometry::new(
            [0.7, 0.9, 1.3],
            [-4.0, 3.0, -2.0],
            [c, -s, 0.0, s, c, 0.0, 0.0, 0.0, -1.0],
        )
        .unwrap()
    }

    /// Two overlapping spheres in one (self-intersecting) mesh.
    pub fn two_spheres(c0: DVec3, c1: DVec3, r: f64) -> TriMesh {
        let (p0, t0) = icosphere(c0, r, 2).into_parts();
        let (p1, t1) = icosphere(c1, r, 2).into_parts();
        let offset = p0.len() as u32;
        let points = p0.into_iter().chain(p1).collect();
        let triangles = t0
            .into_iter()
            .chain(t1.into_iter().map(|t| t.map(|v| v + offset)))
            .collect();
        TriMesh::new(points, triangles).unwrap()
    }
}

#[cfg(test)]
mod tests {
    use super::test_fixtures::*;
    use super::*;
    use crate::mesh::test_shapes::{cube, icosphere};
    use proptest::prelude::*;

    fn index(dims: [usize; 3], i: usize, j: usize, k: usize) -> usize {
        i + dims[0] * (j + dims[1] * k)
    }

    #[test]
    fn cube_on_voxel_rows_is_the_half_open_box_of_the_fill_rule() {
        // Every face, edge and vertex of this cube lies exactly on rows of voxel centres.
        let dims = [9, 9, 9];
        let mesh = cube(DVec3::splat(2.0), DVec3::splat(6.0));
        let w = winding_numbers(&mesh, dims, &Geometry::identity()).unwrap();
        for k in 0..9 {
            for j in 0..9 {
                for i in 0..9 {
                    let inside = [i, j, k].iter().all(|&x| (2..6).contains(&x));
                    assert_eq!(w[index(dims, i, j, k)], inside as i32, "at {i},{j},{k}");
                }
            }
        }
    }

    #[test]
    fn octahedron_with_vertices_on_grid_points_counts_every_row_once() {
        let dims = [11, 11, 11];
        let c = DVec3::splat(5.0);
        let mesh = octahedron(c, 4.0);
        let w = winding_numbers(&mesh, dims, &Geometry::identity()).unwrap();
        for k in 0..11 {
            for j in 0..11 {
                for i in 0..11 {
                    let l1 = (DVec3::new(i as f64, j as f64, k as f64) - c)
                        .abs()
                        .element_sum();
                    let got = w[index(dims, i, j, k)];
                    if l1 < 4.0 {
                        assert_eq!(got, 1, "at {i},{j},{k}");
                    } else if l1 > 4.0 {
                        assert_eq!(got, 0, "at {i},{j},{k}");
                    } else {
                        assert!(got == 0 || got == 1, "{got} on the surface at {i},{j},{k}");
                    }
                }
            }
        }
    }

    /// The voxel centres of `dims` in world space, with their flat index.
    fn centres(dims: [usize; 3], g: &Geometry) -> impl Iterator<Item = (usize, DVec3)> + '_ {
        (0..dims[2]).flat_map(move |k| {
            (0..dims[1]).flat_map(move |j| {
                (0..dims[0]).map(move |i| {
                    let p = g.index_to_world(DVec3::new(i as f64, j as f64, k as f64));
                    (index(dims, i, j, k), p)
                })
            })
        })
    }

    #[test]
    fn sphere_on_an_oblique_left_handed_grid_matches_the_ball() {
        let g = oblique_geometry();
        let dims = [16, 14, 12];
        let centre = g.index_to_world(DVec3::new(7.3, 6.1, 5.4));
        let mesh = icosphere(centre, 4.5, 3);
        let w = winding_numbers(&mesh, dims, &g).unwrap();
        // The icosphere lies between the ball of radius r·cos(small angle) and r.
        for (n, p) in centres(dims, &g) {
            let r = (p - centre).length();
            if r < 4.4 {
                assert_eq!(w[n], 1, "at {p}");
            } else if r > 4.5 {
                assert_eq!(w[n], 0, "at {p}");
            }
        }
        let mesh = mesh.flipped();
        let flipped = winding_numbers(&mesh, dims, &g).unwrap();
        assert!(w.iter().zip(&flipped).all(|(a, b)| *a == -b));
        assert!(inside_mask(&mesh, dims, &g).unwrap().iter().all(|&x| !x));
    }

    #[test]
    fn overlap_of_a_self_intersecting_mesh_has_winding_two_and_is_inside() {
        let dims = [20, 12, 12];
        let g = Geometry::with_spacing([0.5, 0.5, 0.5], [0.0; 3]).unwrap();
        let (c0, c1) = (DVec3::new(3.5, 3.0, 3.0), DVec3::new(6.0, 3.0, 3.0));
        let mesh = two_spheres(c0, c1, 2.0);
        let w = winding_numbers(&mesh, dims, &g).unwrap();
        let inside = inside_mask(&mesh, dims, &g).unwrap();
        for (n, p) in centres(dims, &g) {
            let (r0, r1) = ((p - c0).length(), (p - c1).length());
            let expected = (r0 < 1.95) as i32 + (r1 < 1.95) as i32;
            if (r0 - 2.0).abs() > 0.06 && (r1 - 2.0).abs() > 0.06 {
                assert_eq!(w[n], expected, "at {p}");
                assert_eq!(inside[n], expected > 0);
            }
        }
        assert!(w.contains(&2));
    }

    #[test]
    fn mesh_larger_than_the_grid_gives_inside_everywhere_it_covers() {
        // A cube that crosses every border of the grid and one that contains it entirely.
        let dims = [6, 5, 4];
        let g = Geometry::identity();
        let half = cube(DVec3::new(-3.5, -1.0, -1.0), DVec3::new(2.5, 9.0, 9.0));
        let w = winding_numbers(&half, dims, &g).unwrap();
        for (n, p) in centres(dims, &g) {
            assert_eq!(w[n], (p.x < 2.5) as i32, "at {p}");
        }
        let all = cube(DVec3::splat(-100.0), DVec3::splat(100.0));
        assert!(winding_numbers(&all, dims, &g)
            .unwrap()
            .iter()
            .all(|&x| x == 1));
    }

    #[test]
    fn degenerate_and_ray_parallel_triangles_change_nothing() {
        let dims = [9, 9, 9];
        let mesh = cube(DVec3::splat(2.0), DVec3::splat(6.0));
        let reference = winding_numbers(&mesh, dims, &Geometry::identity()).unwrap();
        // Zero-area triangles, and a pair of opposite coplanar triangles parallel to the rays.
        let (mut points, mut triangles) = mesh.into_parts();
        points.extend([
            DVec3::new(4.0, 4.0, 4.0),
            DVec3::new(5.0, 4.0, 4.0),
            DVec3::new(4.0, 4.0, 5.0),
        ]);
        triangles.extend([[8, 8, 9], [8, 9, 9], [0, 6, 0], [8, 9, 10], [8, 10, 9]]);
        let noisy = TriMesh::new(points, triangles).unwrap();
        assert_eq!(
            winding_numbers(&noisy, dims, &Geometry::identity()).unwrap(),
            reference
        );
    }

    #[test]
    fn empty_mesh_is_outside_and_bad_dims_are_errors() {
        let g = Geometry::identity();
        assert_eq!(
            winding_numbers(&TriMesh::default(), [2, 3, 1], &g).unwrap(),
            vec![0; 6]
        );
        let e = winding_numbers(&TriMesh::default(), [2, 0, 1], &g).unwrap_err();
        assert!(e.message().contains("dims"), "{e}");
        assert!(winding_numbers(&TriMesh::default(), [usize::MAX, 2, 1], &g).is_err());
    }

    #[test]
    fn same_winding_numbers_with_one_and_two_threads() {
        let g = oblique_geometry();
        let dims = [23, 19, 17];
        let mesh = two_spheres(
            g.index_to_world(DVec3::new(9.0, 9.0, 8.0)),
            g.index_to_world(DVec3::new(13.0, 9.0, 8.0)),
            4.0,
        );
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| winding_numbers(&mesh, dims, &g).unwrap())
        };
        assert_eq!(run(1), run(2));
    }

    proptest! {
        /// Random convex polytopes (stretched, rotated, shifted icospheres) on random grids: a
        /// centre is inside exactly when it is behind every face plane.
        #[test]
        fn convex_polytope_inside_matches_its_face_planes(
            stretch in (0.5f64..3.0, 0.5f64..3.0, 0.5f64..3.0),
            angle in 0.0f64..std::f64::consts::TAU,
            shift in (-2.0f64..2.0, -2.0f64..2.0, -2.0f64..2.0),
            g in any_geometry(0.3..1.5),
        ) {
            let stretch = DVec3::new(stretch.0, stretch.1, stretch.2);
            let rot = glam::DQuat::from_euler(glam::EulerRot::XYZ, angle, 0.3, -angle);
            // Around the middle of the grid, wherever the geometry puts it.
            let shift = g.index_to_world(DVec3::new(5.5, 6.0, 5.0))
                + DVec3::new(shift.0, shift.1, shift.2);
            let mesh = icosphere(DVec3::ZERO, 1.0, 1)
                .map_points(|p| rot * (p * stretch) + shift)
                .unwrap();
            let planes: Vec<(DVec3, DVec3)> = (0..mesh.triangles().len())
                .map(|t| {
                    let [a, b, c] = mesh.corners(t);
                    (a, (b - a).cross(c - a).normalize())
                })
                .collect();
            let dims = [12, 13, 11];
            let inside = inside_mask(&mesh, dims, &g).unwrap();
            for (n, p) in centres(dims, &g) {
                let depth = planes.iter().map(|(a, nrm)| nrm.dot(p - *a)).fold(f64::MIN, f64::max);
                if depth.abs() > 1e-9 {
                    prop_assert_eq!(inside[n], depth < 0.0, "at {} (depth {})", p, depth);
                }
            }
        }
    }
}
