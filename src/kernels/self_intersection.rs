//! Self-intersections of a triangle mesh: the pairs of triangles that meet other than along the
//! edge or at the vertex they share, decided exactly and defined as CGAL's
//! `Polygon_mesh_processing::self_intersections` (CGAL 5.5, `do_faces_intersect`) defines them.
//!
//! Candidate pairs come from the spatial hash of the triangles' bounding boxes
//! (`spatial_hash`, Teschner et al. 2003); each is then decided by CGAL's rules, with exact
//! predicates (`predicates`, `triangle_intersection`):
//! - no shared vertex: the closed triangles intersect (touching counts);
//! - one shared vertex: the edge of one triangle opposite the shared vertex meets the other
//!   triangle, or the other way round;
//! - a shared edge (two shared vertex indices): the two opposite vertices are coplanar with the
//!   edge and on the same side of it, i.e. the triangles fold onto each other;
//! - all three vertices shared (a duplicate face): always, by the same rule.
//!
//! A degenerate triangle (collinear corners) is not tested against others; it is reported as
//! the pair (t, t), as CGAL does. Sharing is by vertex index, not position: two vertices at the
//! same place are as distinct as CGAL's `Surface_mesh` vertices read from the same file. CGAL
//! finds shared edges through its halfedge structure, which only holds manifold, consistently
//! oriented meshes; for other meshes (an edge in three triangles, a duplicate face with the
//! same winding) the same rules are applied to the shared indices.

use glam::{DVec3, DVec4};
use rayon::prelude::*;

use crate::allocation;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::predicates::{coplanar_orientation, orient3d_bound_for_differences_up_to, Plane, Sign};
use crate::spatial_hash::{overlapping_pairs, spatial_order, Aabb};
use crate::triangle_intersection::{prepared_triangles_intersect, segment_meets_prepared};

/// The most pairs a search over a mesh of `triangles` triangles holds: 16 per triangle (a mesh
/// laid over a copy of itself has about 13: each triangle meets its copy and those of its
/// neighbours) and 1,024 more for small meshes. The search stops past it, since triangles piled
/// into one place pair up quadratically, and so would its time and memory.
pub fn pair_limit(triangles: usize) -> usize {
    triangles.saturating_mul(16).saturating_add(1024)
}

/// How many pairs `self_intersections` finds, counted up to `pair_limit`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PairCount {
    Exactly(usize),
    /// More than this many: the search stopped there.
    MoreThan(usize),
}

impl PairCount {
    /// The count as one number, a count past the limit as the limit plus one.
    pub fn saturated(self) -> usize {
        match self {
            PairCount::Exactly(n) => n,
            PairCount::MoreThan(limit) => limit.saturating_add(1),
        }
    }
}

/// The pairs (a, b) of intersecting triangles, sorted, as CGAL's
/// `Polygon_mesh_processing::self_intersections` defines them: a < b for two non-degenerate
/// triangles, and (t, t) for each degenerate triangle t. Identical for any number of threads.
/// A mesh with more than `pair_limit` pairs is an error (`count_self_intersections` counts up
/// to it).
pub fn self_intersections(mesh: &TriMesh) -> Result<Vec<(u32, u32)>> {
    let limit = pair_limit(mesh.triangles().len());
    find(mesh, |_| true, limit)?.ok_or_else(|| {
        Error::invalid_mesh(format!(
            "the mesh intersects itself in more than {limit} pairs of triangles (16 per \
             triangle): it is no surface but triangles piled into one place, and the search \
             stops there to bound its time and memory"
        ))
    })
}

/// The number of pairs `self_intersections` finds, up to `pair_limit`: what a check of a mesh
/// reports, for any mesh.
pub fn count_self_intersections(mesh: &TriMesh) -> Result<PairCount> {
    let limit = pair_limit(mesh.triangles().len());
    Ok(match find(mesh, |_| true, limit)? {
        Some(pairs) => PairCount::Exactly(pairs.len()),
        None => PairCount::MoreThan(limit),
    })
}

/// `self_intersections` restricted to the pairs involving at least one triangle marked in
/// `active` (one flag per triangle). Every active triangle is still tested against all others;
/// the cost is that of the full search. Without a limit: it is for the balloon's own surfaces,
/// whose size the vertex limit bounds and which are repaired from all their pairs.
pub fn self_intersections_among(mesh: &TriMesh, active: &[bool]) -> Result<Vec<(u32, u32)>> {
    if active.len() != mesh.triangles().len() {
        return Err(Error::invalid_argument(format!(
            "{} activity flags for {} triangles; pass one flag per triangle",
            active.len(),
            mesh.triangles().len()
        )));
    }
    let all = find(mesh, |t| active[t as usize], usize::MAX)?;
    Ok(all.expect("no search without a limit stops early"))
}

/// The pairs involving an active triangle, or `None` when there are more than `limit`.
fn find(
    mesh: &TriMesh,
    active: impl Fn(u32) -> bool + Sync,
    limit: usize,
) -> Result<Option<Vec<(u32, u32)>>> {
    // Unreachable in practice: 2^32 triangles take 48 GiB of indices alone.
    assert!(
        u32::try_from(mesh.triangles().len()).is_ok(),
        "more than 2^32 triangles: the pair ids of the result cannot hold them"
    );
    let count = mesh.triangles().len() as u32;
    let boxes = allocation::par_collect(
        (0..count)
            .into_par_iter()
            .map(|t| Aabb::of_triangle(mesh.corners(t as usize))),
        "the triangles' boxes",
    )?;
    let degenerate = allocation::par_collect(
        (0..count).into_par_iter().map(|t| {
            let [a, b, c] = mesh.corners(t as usize);
            Plane::new(a, b, c).is_degenerate()
        }),
        "the triangles' degeneracy flags",
    )?;
    // The non-degenerate triangles in Morton order of their boxes' lower corners, the order in
    // which the spatial hash visits them. Their data is gathered from the mesh in that order,
    // so that the exact tests read memory almost sequentially instead of jumping around.
    let order: Vec<u32> = if degenerate.contains(&true) {
        let kept: Vec<u32> = (0..count).filter(|&t| !degenerate[t as usize]).collect();
        let kept_boxes: Vec<Aabb> = kept.par_iter().map(|&t| boxes[t as usize]).collect();
        let order = spatial_order(&kept_boxes);
        order.par_iter().map(|&k| kept[k as usize]).collect()
    } else {
        spatial_order(&boxes)
    };
    drop(boxes);
    let faces = allocation::par_collect(
        order.par_iter().map(|&t| Face::new(mesh, t)),
        "the triangles in spatial order",
    )?;
    let boxes = allocation::par_collect(
        faces.par_iter().map(|face| Aabb::of_triangle(face.corners)),
        "the triangles' boxes",
    )?;
    drop(order);
    let alone: Vec<(u32, u32)> = (0..count)
        .filter(|&t| degenerate[t as usize] && active(t))
        .map(|t| (t, t))
        .collect();
    let Some(limit) = limit.checked_sub(alone.len()) else {
        return Ok(None);
    };
    let Some(found) = overlapping_pairs(&boxes, limit, |x, y| {
        let (a, b) = (&faces[x as usize], &faces[y as usize]);
        (active(a.id) || active(b.id)) && faces_intersect(a, b)
    }) else {
        return Ok(None);
    };
    let mut pairs: Vec<(u32, u32)> = found
        .par_iter()
        .map(|&(x, y)| {
            let (a, b) = (faces[x as usize].id, faces[y as usize].id);
            (a.min(b), a.max(b))
        })
        .collect();
    pairs.extend(alone);
    pairs.par_sort_unstable();
    Ok(Some(pairs))
}

/// Whether two triangles of one mesh, given by their corners and vertex ids, intersect as
/// `self_intersections` decides it: for callers that test a few pairs of a mesh they are
/// changing. Both triangles must be distinct and non-degenerate.
pub(crate) fn mesh_triangles_intersect(
    a: ([DVec3; 3], [u32; 3]),
    b: ([DVec3; 3], [u32; 3]),
) -> bool {
    let face = |(corners, vertices): ([DVec3; 3], [u32; 3])| Face {
        corners,
        vertices,
        id: 0,
    };
    faces_intersect(&face(a), &face(b))
}

/// A non-degenerate triangle of the mesh, as the exact tests need it. Its plane is not stored
/// but made per test: 88 bytes per face instead of 136 (with the plane's normal and error
/// magnitudes) take fewer fresh pages and cache lines than the plane takes arithmetic
/// (measured about 10% faster on 1.3M triangle spheres).
#[derive(Clone, Copy)]
struct Face {
    corners: [DVec3; 3],
    vertices: [u32; 3],
    /// Index in the mesh.
    id: u32,
}

impl Face {
    fn new(mesh: &TriMesh, id: u32) -> Face {
        let [a, b, c] = mesh.corners(id as usize);
        Face {
            corners: [a, b, c],
            vertices: mesh.triangles()[id as usize],
            id,
        }
    }

    /// The plane prepared for the side tests of one pair.
    #[inline]
    fn plane(&self) -> Plane {
        let [a, b, c] = self.corners;
        Plane::new(a, b, c)
    }

    /// The corners after corner `k`, in winding order.
    #[inline]
    fn others(&self, k: usize) -> [DVec3; 2] {
        OTHERS[k].map(|o| self.corners[o])
    }
}

/// CGAL's decision for two distinct non-degenerate triangles.
///
/// On a closed mesh most candidate pairs are neighbours, so the shared vertices are found with
/// plain comparisons and the neighbour cases are settled by one floating-point filter each;
/// only the pairs it cannot settle go to the exact tests, kept out of line so that the filters
/// compile to straight code without spills.
#[inline]
fn faces_intersect(a: &Face, b: &Face) -> bool {
    // Bit i of `in_b` (`in_a`): corner i of a (b) is a vertex of b (a). The corners of a
    // non-degenerate face are distinct vertices, so both masks have as many bits as shared
    // vertices. Without branches: on a closed mesh most pairs share some vertex, which
    // defeats the branch predictor.
    let mask = |x: [u32; 3], y: [u32; 3]| {
        (0..3).fold(0u8, |m, i| {
            let hit = (x[i] == y[0]) | (x[i] == y[1]) | (x[i] == y[2]);
            m | u8::from(hit) << i
        })
    };
    let (in_b, in_a) = (mask(a.vertices, b.vertices), mask(b.vertices, a.vertices));
    match in_b.count_ones() {
        0 => unconnected_faces_intersect(a, b),
        1 => {
            let (i, j) = (
                in_b.trailing_zeros() as usize,
                in_a.trailing_zeros() as usize,
            );
            !opposite_edges_clear(a.corners[i], a.others(i), b.others(j))
                && faces_at_vertex_intersect(a, b, i, j)
        }
        _ => {
            // The first corner p of a such that p and its successor q are shared; r is a's
            // third corner, s the corner of b off the edge pq (for a duplicate face, the one
            // at r's vertex: the same point).
            let p = match in_b {
                0b110 => 1,
                0b101 => 2,
                _ => 0,
            };
            let [q, r] = OTHERS[p];
            let (ca, cb) = (&a.corners, &b.corners);
            let s = match (!in_a & 0b111).trailing_zeros() as usize {
                k @ 0..=2 => cb[k],
                _ => ca[r],
            };
            // Intersecting iff the triangles fold onto each other: s coplanar with a (whose
            // corners p, q, r are, in rotated order) and strictly on the same side of pq as r.
            // The filter first: on a surface, s is clearly off a's plane.
            let (u, w, d) = (ca[q] - ca[p], ca[r] - ca[p], s - ca[p]);
            let m = u.abs().max(w.abs()).max(d.abs()).max_element();
            u.cross(w).dot(d).abs() <= orient3d_bound_for_differences_up_to(m)
                && folded_onto([ca[p], ca[q], ca[r]], s)
        }
    }
}

/// Two faces without a shared vertex: whether the closed triangles meet.
#[inline(never)]
fn unconnected_faces_intersect(a: &Face, b: &Face) -> bool {
    prepared_triangles_intersect(&a.plane(), &b.plane())
}

/// Two faces sharing only corner `i` of `a`, corner `j` of `b`: whether the edge of either
/// opposite the shared corner meets the other face.
#[cold]
#[inline(never)]
fn faces_at_vertex_intersect(a: &Face, b: &Face, i: usize, j: usize) -> bool {
    let (v, [a1, a2], [b1, b2]) = (a.corners[i], a.others(i), b.others(j));
    // Both planes are taken from the shared corner; a rotation keeps the orientation.
    let (pa, pb) = (Plane::new(v, a1, a2), Plane::new(v, b1, b2));
    !edge_misses([b1, b2], &pa) || !edge_misses([a1, a2], &pb)
}

/// Whether `s`, the far corner of a face sharing the edge pq with the triangle `[p, q, r]`, is
/// coplanar with it and strictly on r's side of pq.
#[cold]
#[inline(never)]
fn folded_onto([p, q, r]: [DVec3; 3], s: DVec3) -> bool {
    Plane::new(p, q, r).side(s) == Sign::Zero && coplanar_orientation(p, q, r, s) == Sign::Positive
}

/// Whether, for two triangles sharing the corner `v`, each one's opposite edge is provably
/// strictly on one side of the other's plane, so that they meet only at `v`: the common case
/// of neighbours on a smooth surface. The four side determinants are differences from `v` and
/// are checked against one error bound for all (`orient3d_bound_for_differences_up_to`), which
/// decides them all unless some point is nearly coplanar with the other triangle; `false`
/// leaves the pair to the exact tests.
#[inline(always)]
fn opposite_edges_clear(v: DVec3, a: [DVec3; 2], b: [DVec3; 2]) -> bool {
    let (u, w, d1, d2) = (a[0] - v, a[1] - v, b[0] - v, b[1] - v);
    let (na, nb) = (u.cross(w), d1.cross(d2));
    let sides = DVec4::new(na.dot(d1), na.dot(d2), nb.dot(u), nb.dot(w));
    let m = u
        .abs()
        .max(w.abs())
        .max(d1.abs())
        .max(d2.abs())
        .max_element();
    let bound = orient3d_bound_for_differences_up_to(m);
    sides.abs().cmpgt(DVec4::splat(bound)).all()
        && sides.x * sides.y > 0.0
        && sides.z * sides.w > 0.0
}

/// For each corner of a triangle, the two others in winding order.
const OTHERS: [[usize; 2]; 3] = [[1, 2], [2, 0], [0, 1]];

/// Whether the segment `edge` misses the triangle of `plane`, which shares a vertex with the
/// segment's triangle. Both endpoints strictly on one side of the plane (the common case,
/// decided by the plane's filtered side test) settle it at once.
#[inline(always)]
fn edge_misses(edge: [DVec3; 2], plane: &Plane) -> bool {
    let (s0, s1) = (plane.side(edge[0]), plane.side(edge[1]));
    (s0 == s1 && s0 != Sign::Zero) || !segment_meets_prepared(edge, plane)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_shapes::icosphere;
    use crate::phantom::random::SplitMix64;
    use crate::predicates::collinear;
    use proptest::prelude::*;

    /// The pairs of a mesh small enough that its buffers cannot fail.
    fn pairs(mesh: &TriMesh) -> Vec<(u32, u32)> {
        self_intersections(mesh).unwrap()
    }

    /// Every pair tested, no bounding boxes: the reference for the spatial hash.
    fn brute_force(mesh: &TriMesh) -> Vec<(u32, u32)> {
        let n = mesh.triangles().len() as u32;
        let degenerate = |t: u32| {
            let [a, b, c] = mesh.corners(t as usize);
            collinear(a, b, c)
        };
        let mut pairs: Vec<(u32, u32)> =
            (0..n).filter(|&t| degenerate(t)).map(|t| (t, t)).collect();
        let face = |id: u32| Face::new(mesh, id);
        for a in (0..n).filter(|&t| !degenerate(t)) {
            for b in (a + 1..n).filter(|&t| !degenerate(t)) {
                if faces_intersect(&face(a), &face(b)) {
                    pairs.push((a, b));
                }
            }
        }
        pairs.sort_unstable();
        pairs
    }

    fn mesh(points: &[[f64; 3]], triangles: &[[u32; 3]]) -> TriMesh {
        let points = points.iter().map(|&p| DVec3::from_array(p)).collect();
        TriMesh::new(points, triangles.to_vec()).unwrap()
    }

    fn merged(meshes: &[TriMesh]) -> TriMesh {
        let mut all = TriMesh::default();
        for m in meshes {
            all.append(m).unwrap();
        }
        all
    }

    /// A unit icosphere whose cap above z = 0.7 is pushed down through the opposite side: the
    /// stretched ring of triangles around the cap crosses the lower hemisphere.
    fn pushed_cap_sphere(levels: u32) -> TriMesh {
        icosphere(DVec3::ZERO, 1.0, levels)
            .map_points(|p| {
                if p.z > 0.7 {
                    p - DVec3::new(0.0, 0.0, 2.4)
                } else {
                    p
                }
            })
            .unwrap()
    }

    #[test]
    fn a_clean_icosphere_has_no_self_intersection() {
        let sphere = icosphere(DVec3::new(3.0, -1.0, 2.0), 5.0, 4);
        assert!(pairs(&sphere).is_empty());
    }

    #[test]
    fn pushed_through_cap_matches_brute_force() {
        let m = pushed_cap_sphere(3);
        let pairs = pairs(&m);
        assert!(pairs.len() > 50, "{}", pairs.len());
        assert_eq!(pairs, brute_force(&m));
    }

    #[test]
    fn two_overlapping_spheres_intersect_only_across() {
        let a = icosphere(DVec3::ZERO, 1.0, 3);
        let b = icosphere(DVec3::new(0.9, 0.3, 0.1), 1.0, 3);
        let n = a.triangles().len() as u32;
        let m = merged(&[a, b]);
        let pairs = pairs(&m);
        assert!(!pairs.is_empty());
        assert!(pairs.iter().all(|&(x, y)| x < n && y >= n));
        assert_eq!(pairs, brute_force(&m));
    }

    #[test]
    fn coplanar_overlap_of_unconnected_triangles() {
        let with_height = |z: f64| {
            mesh(
                &[
                    [0., 0., 1.],
                    [4., 0., 1.],
                    [0., 4., 1.],
                    [1., 1., z],
                    [5., 1., z],
                    [1., 5., z],
                ],
                &[[0, 1, 2], [3, 4, 5]],
            )
        };
        assert_eq!(pairs(&with_height(1.0)), vec![(0, 1)]);
        // Lifted by one ulp they are apart.
        assert!(pairs(&with_height(1f64.next_up())).is_empty());
    }

    #[test]
    fn unconnected_triangles_touching_at_a_point_or_along_an_edge() {
        // Vertex of the second triangle at the first one's corner (a distinct vertex index).
        let at_vertex = mesh(
            &[
                [0., 0., 0.],
                [4., 0., 0.],
                [0., 4., 0.],
                [4., 0., 0.],
                [5., 0., 3.],
                [5., 1., 3.],
            ],
            &[[0, 1, 2], [3, 4, 5]],
        );
        assert_eq!(pairs(&at_vertex), vec![(0, 1)]);
        // A vertical triangle standing on the first one's edge.
        let on_edge = mesh(
            &[
                [0., 0., 0.],
                [4., 0., 0.],
                [0., 4., 0.],
                [1., 0., 0.],
                [3., 0., 0.],
                [2., 0., 5.],
            ],
            &[[0, 1, 2], [3, 4, 5]],
        );
        assert_eq!(pairs(&on_edge), vec![(0, 1)]);
    }

    #[test]
    fn shared_edge_counts_only_a_coplanar_fold_over() {
        let (p, q, r) = ([0., 0., 0.], [4., 0., 0.], [0., 4., 0.]);
        let with_s = |s: [f64; 3]| pairs(&mesh(&[p, q, r, s], &[[0, 1, 2], [1, 0, 3]]));
        // Flat continuation across the edge, dihedral folds (even a very sharp one): clean.
        assert!(with_s([2., -3., 0.]).is_empty());
        assert!(with_s([2., 3., 1.]).is_empty());
        assert!(with_s([2., 3., 1e-300]).is_empty());
        // Folded flat onto the first triangle: intersecting, even if s lands outside it.
        assert_eq!(with_s([1., 1., 0.]), vec![(0, 1)]);
        assert_eq!(with_s([9., 9., 0.]), vec![(0, 1)]);
        // s on the line of the shared edge makes the second triangle degenerate.
        assert_eq!(with_s([6., 0., 0.]), vec![(1, 1)]);
    }

    #[test]
    fn shared_vertex_cases() {
        // Triangle 0 in the plane z = 0, triangle 1 shares vertex 0.
        let base = [[0., 0., 0.], [4., 0., 0.], [0., 4., 0.]];
        let with = |u: [f64; 3], w: [f64; 3]| {
            pairs(&mesh(
                &[base[0], base[1], base[2], u, w],
                &[[0, 1, 2], [0, 3, 4]],
            ))
        };
        // Apart except for the vertex.
        assert!(with([-1., -2., 1.], [-2., -1., 1.]).is_empty());
        // Second triangle's opposite edge pierces the first triangle.
        assert_eq!(with([1., 1., -1.], [1., 1., 1.]), vec![(0, 1)]);
        // First triangle's opposite edge pierces the second.
        assert_eq!(with([3., 3., -2.], [3., 3., 2.]), vec![(0, 1)]);
        // Coplanar, overlapping the first triangle (a fan folded back).
        assert_eq!(with([3., 1., 0.], [1., 3., 0.]), vec![(0, 1)]);
        // Coplanar and beside it; coplanar with an edge on the line of the first triangle's
        // edge but outside it: only the vertex is common, no pair.
        assert!(with([-1., -3., 0.], [-3., -1., 0.]).is_empty());
        assert!(with([-1., 0., 0.], [-3., -1., 0.]).is_empty());
        // Coplanar with an edge running along the first triangle's edge: overlap.
        assert_eq!(with([2., 0., 0.], [2., -2., 0.]), vec![(0, 1)]);
        // The opposite edge touches the first triangle's hypotenuse at one point, (2, 2, 0).
        assert_eq!(with([1., 3., 1.], [3., 1., -1.]), vec![(0, 1)]);
    }

    #[test]
    fn duplicate_faces_intersect_and_degenerate_faces_are_reported_alone() {
        let pts = [
            [0., 0., 0.],
            [4., 0., 0.],
            [0., 4., 0.],
            [2., 2., 0.],
            [-4., 8., 0.],
        ];
        // A pillow: the same triangle twice, opposite windings.
        assert_eq!(pairs(&mesh(&pts, &[[0, 1, 2], [0, 2, 1]])), vec![(0, 1)]);
        // Points 1 to 4 lie on the line x + y = 4 and triangle 3 repeats a vertex: all but
        // triangle 0 are degenerate, and they are not tested against it.
        let m = mesh(&pts, &[[0, 1, 2], [1, 2, 3], [2, 3, 4], [0, 0, 4]]);
        assert_eq!(pairs(&m), vec![(1, 1), (2, 2), (3, 3)]);
        assert_eq!(pairs(&m), brute_force(&m));
    }

    #[test]
    fn active_flags_keep_pairs_with_an_active_triangle() {
        let m = pushed_cap_sphere(2);
        let all = pairs(&m);
        let active: Vec<bool> = (0..m.triangles().len()).map(|t| t % 3 == 0).collect();
        let some = self_intersections_among(&m, &active).unwrap();
        let expected: Vec<_> = all
            .iter()
            .copied()
            .filter(|&(a, b)| active[a as usize] || active[b as usize])
            .collect();
        assert!(!expected.is_empty() && expected.len() < all.len());
        assert_eq!(some, expected);
        let e = self_intersections_among(&m, &[true]).unwrap_err();
        assert_eq!(e.kind(), crate::ErrorKind::InvalidArgument);
    }

    /// `n` triangles on random corners in a unit cube: nearly every two of them intersect.
    fn pile(n: usize, seed: u64) -> TriMesh {
        let mut random = SplitMix64::new(seed);
        let points: Vec<[f64; 3]> = (0..n / 2)
            .map(|_| [random.unit(), random.unit(), random.unit()])
            .collect();
        let last = points.len() as u64 - 1;
        let mut corner = || random.integer(0, last) as u32;
        let triangles: Vec<[u32; 3]> = (0..n).map(|_| [corner(), corner(), corner()]).collect();
        mesh(&points, &triangles)
    }

    #[test]
    fn regression_triangles_piled_into_one_place_were_all_paired_in_quadratic_time() {
        // The fuzzer's mesh_readers found a 688-triangle PLY with 53,735 pairs: 27 s under its
        // instrumentation, every pair tested and kept. 3,000 triangles have millions.
        let m = pile(3000, 11);
        let limit = pair_limit(3000);
        assert_eq!(
            count_self_intersections(&m).unwrap(),
            PairCount::MoreThan(limit)
        );
        let e = self_intersections(&m).unwrap_err();
        assert_eq!(e.kind(), crate::ErrorKind::InvalidMesh);
        assert!(
            e.message().contains(&format!("more than {limit} pairs")),
            "{e}"
        );
        assert_eq!(PairCount::MoreThan(limit).saturated(), limit + 1);
    }

    #[test]
    fn a_search_finds_every_pair_up_to_its_limit_and_none_past_it() {
        // Degenerate triangles (a repeated corner) count towards the limit too.
        let mut m = pile(120, 5);
        let degenerate = TriMesh::new(m.points().to_vec(), vec![[0, 0, 1], [2, 3, 3]]).unwrap();
        m.append(&degenerate).unwrap();
        let all = brute_force(&m);
        assert!(
            all.contains(&(120, 120)) && all.len() > 1000,
            "{}",
            all.len()
        );
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let everything = |_| true;
                assert_eq!(
                    find(&m, everything, all.len()).unwrap().as_ref(),
                    Some(&all)
                );
                assert_eq!(find(&m, everything, all.len() - 1).unwrap(), None);
                assert_eq!(find(&m, everything, 1).unwrap(), None);
            });
        }
        assert_eq!(
            count_self_intersections(&pile(40, 5)).unwrap(),
            PairCount::Exactly(brute_force(&pile(40, 5)).len())
        );
    }

    #[test]
    fn result_is_identical_with_one_and_two_threads() {
        let m = merged(&[
            pushed_cap_sphere(4),
            icosphere(DVec3::new(0.5, 0.5, 0.0), 0.8, 3),
        ]);
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| pairs(&m))
        };
        let one = run(1);
        assert!(!one.is_empty());
        assert_eq!(one, run(2));
    }

    /// Small meshes on an integer grid, where shared vertices, shared edges, coplanar folds,
    /// touching and degenerate triangles are all frequent.
    fn small_mesh() -> impl Strategy<Value = TriMesh> {
        let point = [-2i32..=2, -2i32..=2, -2i32..=2];
        (
            proptest::collection::vec(point, 4..9),
            proptest::collection::vec([0u32..9, 0u32..9, 0u32..9], 1..12),
        )
            .prop_map(|(points, triangles)| {
                let n = points.len() as u32;
                let points = points
                    .iter()
                    .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
                    .collect();
                let triangles = triangles.iter().map(|t| t.map(|v| v % n)).collect();
                TriMesh::new(points, triangles).unwrap()
            })
    }

    /// A point of `float_mesh`: anywhere, or an earlier point (by index, modulo) moved by a
    /// small multiple of 10^-exponent of its size, zero included.
    #[derive(Debug, Clone)]
    enum PointRecipe {
        Anywhere([f64; 3]),
        Near(usize, [i8; 3], i32),
    }

    /// Small meshes with arbitrary coordinates, at any scale and far from the origin, with
    /// triangles from slivers across the whole mesh to ones a few ulps wide and points that
    /// repeat or nearly repeat others: where the single-precision boxes and the cells of the
    /// spatial hash have rounding to get wrong, which integer meshes never reach.
    fn float_mesh() -> impl Strategy<Value = TriMesh> {
        let recipe = prop_oneof![
            [-2.0f64..2.0, -2.0..2.0, -2.0..2.0].prop_map(PointRecipe::Anywhere),
            (any::<usize>(), [-2i8..=2, -2..=2, -2..=2], 1i32..=16)
                .prop_map(|(i, step, exponent)| PointRecipe::Near(i, step, exponent)),
        ];
        (
            proptest::collection::vec(recipe, 3..24),
            proptest::collection::vec([0u32..24, 0u32..24, 0u32..24], 1..40),
            -3i32..=3,
            [-1e4f64..1e4, -1e4..1e4, -1e4..1e4],
        )
            .prop_map(|(recipes, triangles, scale, offset)| {
                let (scale, offset) = (10f64.powi(scale), DVec3::from_array(offset));
                let mut points: Vec<DVec3> = Vec::with_capacity(recipes.len());
                for recipe in recipes {
                    let p = match recipe {
                        PointRecipe::Near(i, step, exponent) if !points.is_empty() => {
                            let base = points[i % points.len()];
                            let size = base.abs().max_element().max(scale);
                            let step = DVec3::new(step[0].into(), step[1].into(), step[2].into());
                            base + step * size * 10f64.powi(-exponent)
                        }
                        PointRecipe::Near(..) => offset,
                        PointRecipe::Anywhere(p) => offset + DVec3::from_array(p) * scale,
                    };
                    points.push(p);
                }
                let n = points.len() as u32;
                let triangles = triangles.iter().map(|t| t.map(|v| v % n)).collect();
                TriMesh::new(points, triangles).unwrap()
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]

        #[test]
        fn spatial_hash_finds_what_brute_force_finds(m in small_mesh()) {
            prop_assert_eq!(pairs(&m), brute_force(&m));
        }

        #[test]
        fn spatial_hash_finds_what_brute_force_finds_at_any_coordinates(m in float_mesh()) {
            prop_assert_eq!(pairs(&m), brute_force(&m));
        }
    }
}
