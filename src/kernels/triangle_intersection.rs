//! Exact intersection tests between closed triangles and segments in space.
//!
//! The triangle–triangle test follows Guigue & Devillers, "Fast and robust triangle-triangle
//! overlap test using orientation predicates" (J. Graphics Tools 8(1), 2003), the algorithm
//! behind CGAL's `do_intersect(Triangle_3, Triangle_3)`: each triangle is classified against
//! the other's plane, and when the planes cross, the two segments in which the triangles meet
//! the common line are compared by two more orientation signs. Coplanar triangles are compared
//! in a coordinate projection. Every decision is the sign of an exact orient3d or orient2d
//! (see `predicates`), so the answers are exact for f64 input: touching at a single point or
//! along an edge counts as intersecting.

use glam::DVec3;

use crate::predicates::{orient2d, orient3d, Plane, Projection, Sign};

/// Whether two closed triangles share at least one point, exactly.
///
/// Both triangles must be non-degenerate (their corners not collinear): a degenerate triangle
/// has no plane and the answer is `false`, as in CGAL's self-intersection test, which never
/// tests degenerate faces against others.
pub fn triangles_intersect(a: [DVec3; 3], b: [DVec3; 3]) -> bool {
    let (a, b) = (Plane::new(a[0], a[1], a[2]), Plane::new(b[0], b[1], b[2]));
    !a.is_degenerate() && !b.is_degenerate() && prepared_triangles_intersect(&a, &b)
}

/// `triangles_intersect` for non-degenerate triangles given with their planes (which callers
/// testing one triangle against many compute once).
pub(crate) fn prepared_triangles_intersect(a_plane: &Plane, b_plane: &Plane) -> bool {
    let (a, b) = (a_plane.corners(), b_plane.corners());
    let a_sides = a.map(|p| b_plane.side(p));
    if strictly_one_side(a_sides) {
        return false;
    }
    let b_sides = b.map(|p| a_plane.side(p));
    if strictly_one_side(b_sides) {
        return false;
    }
    if a_sides == [Sign::Zero; 3] {
        return coplanar_triangles_intersect(a, b);
    }
    // The planes cross along a line L. Rotate each triangle so that its first corner is alone
    // on one side of the other plane: the triangle then meets L in the segment between the
    // crossings of its two edges leaving that corner.
    let (mut a, a_side) = isolate(a, a_sides);
    let (mut b, b_side) = isolate(b, b_sides);
    // Reversing a triangle's winding flips its plane's orientation; do it so that each isolated
    // corner lies on the positive side of the other triangle's plane.
    if a_side == Sign::Negative {
        b.swap(1, 2);
    }
    if b_side == Sign::Negative {
        a.swap(1, 2);
    }
    // Along L directed by n_a × n_b, triangle a covers [j, i] with i on edge a0a1 and j on
    // edge a0a2, and triangle b covers [k, l] with k on b0b1 and l on b0b2. The sign of
    // orient3d(a0, a1, b0, b1) is that of k - i, and orient3d(a0, a2, b0, b2) that of l - j,
    // so the segments overlap iff k <= i and j <= l.
    orient3d(a[0], a[1], b[0], b[1]) != Sign::Positive
        && orient3d(a[0], a[2], b[0], b[2]) != Sign::Negative
}

/// Whether a closed segment and a closed non-degenerate triangle share a point, exactly. The
/// segment may be degenerate (a point).
pub fn segment_triangle_intersect(s: [DVec3; 2], t: [DVec3; 3]) -> bool {
    segment_meets_prepared(s, &Plane::new(t[0], t[1], t[2]))
}

/// `segment_triangle_intersect` with the triangle given by its plane.
pub(crate) fn segment_meets_prepared(s: [DVec3; 2], plane: &Plane) -> bool {
    let ([p, q], t) = (s, plane.corners());
    let (sp, sq) = (plane.side(p), plane.side(q));
    match (sp, sq) {
        (Sign::Zero, Sign::Zero) => match Projection::of_triangle(t[0], t[1], t[2]) {
            Some(proj) => {
                !separated_2d(&ccw(t, proj), &[p, q], proj) && !line_separates(p, q, &t, proj)
            }
            None => false,
        },
        _ if sp == sq => false,
        _ => {
            // The segment crosses the plane, so it meets the triangle iff its line does. For
            // the line through p and q, the three signs below are those of the barycentric
            // coordinates of its crossing point (times one common non-zero factor).
            let signs = [
                orient3d(p, q, t[0], t[1]),
                orient3d(p, q, t[1], t[2]),
                orient3d(p, q, t[2], t[0]),
            ];
            !(signs.contains(&Sign::Positive) && signs.contains(&Sign::Negative))
        }
    }
}

/// All three signs equal and non-zero: the points are strictly on one side of a plane.
#[inline]
fn strictly_one_side(s: [Sign; 3]) -> bool {
    s[0] != Sign::Zero && s[0] == s[1] && s[1] == s[2]
}

/// Rotates the triangle (keeping its winding) so that its first corner is alone on its side of
/// a plane, given the corners' sides; returns the side assigned to that corner. Precondition:
/// the signs are neither all zero nor all equal and non-zero.
///
/// The isolated corner is a corner strictly on one side with both others on the other closed
/// side; when there is none (one corner on the plane, two strictly on one side), it is the corner
/// on the plane, assigned the side opposite to the others. Either way both edges leaving it
/// reach the plane, and the triangle meets the plane in the segment between those points.
fn isolate(t: [DVec3; 3], s: [Sign; 3]) -> ([DVec3; 3], Sign) {
    let rotated = |i: usize| [t[i], t[(i + 1) % 3], t[(i + 2) % 3]];
    for i in 0..3 {
        let others = [s[(i + 1) % 3], s[(i + 2) % 3]];
        if s[i] != Sign::Zero && others.iter().all(|&o| o != s[i]) {
            return (rotated(i), s[i]);
        }
    }
    // No corner qualified, so the pattern is one corner on the plane and two strictly on the
    // same side.
    let i = s.iter().position(|&x| x == Sign::Zero).unwrap_or(0);
    (rotated(i), s[(i + 1) % 3].flipped())
}

/// Two coplanar non-degenerate triangles, compared in a projection where both stay
/// non-degenerate. Two convex polygons are disjoint iff a line through an edge of one of them
/// has the other strictly on its outer side (the separating axis theorem in the plane).
fn coplanar_triangles_intersect(a: [DVec3; 3], b: [DVec3; 3]) -> bool {
    let Some(proj) = Projection::of_triangle(a[0], a[1], a[2]) else {
        return false;
    };
    let (a, b) = (ccw(a, proj), ccw(b, proj));
    !separated_2d(&a, &b, proj) && !separated_2d(&b, &a, proj)
}

/// The triangle with its winding made counter-clockwise in the projection.
fn ccw(mut t: [DVec3; 3], proj: Projection) -> [DVec3; 3] {
    if orient2d(t[0], t[1], t[2], proj) == Sign::Negative {
        t.swap(1, 2);
    }
    t
}

/// Whether a line through an edge of the counter-clockwise triangle `t` has all `points`
/// strictly outside (to its right) in the projection.
fn separated_2d(t: &[DVec3; 3], points: &[DVec3], proj: Projection) -> bool {
    (0..3).any(|i| {
        let (u, v) = (t[i], t[(i + 1) % 3]);
        points
            .iter()
            .all(|&p| orient2d(u, v, p, proj) == Sign::Negative)
    })
}

/// Whether the line through p and q has all corners of `t` strictly on one side in the
/// projection (never when p == q, which has no line).
fn line_separates(p: DVec3, q: DVec3, t: &[DVec3; 3], proj: Projection) -> bool {
    strictly_one_side(t.map(|c| orient2d(p, q, c, proj)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    type I3 = [i64; 3];

    fn v(p: I3) -> DVec3 {
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    }

    fn tri(t: [I3; 3]) -> [DVec3; 3] {
        t.map(v)
    }

    fn sub(a: I3, b: I3) -> I3 {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }

    fn cross(a: I3, b: I3) -> I3 {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }

    fn dot(a: I3, b: I3) -> i64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    /// Exact reference on integer points by the separating axis theorem: two convex polytopes
    /// (here flat ones, possibly a segment) are disjoint iff their projections on one of the
    /// candidate axes are disjoint. For flat sets the candidates are the face normals, the
    /// cross products of edge directions, and each normal crossed with each edge.
    fn sat_disjoint(a: &[I3], b: &[I3]) -> bool {
        let edges = |s: &[I3]| -> Vec<I3> {
            (0..s.len())
                .flat_map(|i| (i + 1..s.len()).map(move |j| (i, j)))
                .map(|(i, j)| sub(s[j], s[i]))
                .collect()
        };
        let (ea, eb) = (edges(a), edges(b));
        let normals: Vec<I3> = [&ea, &eb]
            .iter()
            .filter(|e| e.len() >= 2)
            .map(|e| cross(e[0], e[1]))
            .collect();
        let mut axes = normals.clone();
        for &x in ea.iter().chain(&eb) {
            axes.extend(ea.iter().chain(&eb).map(|&y| cross(x, y)));
            axes.extend(normals.iter().map(|&n| cross(n, x)));
        }
        axes.iter().filter(|&&ax| ax != [0, 0, 0]).any(|&ax| {
            let range = |s: &[I3]| {
                let d = s.iter().map(|&p| dot(p, ax));
                (d.clone().min().unwrap(), d.max().unwrap())
            };
            let (ra, rb) = (range(a), range(b));
            ra.1 < rb.0 || rb.1 < ra.0
        })
    }

    fn degenerate(t: [I3; 3]) -> bool {
        cross(sub(t[1], t[0]), sub(t[2], t[0])) == [0, 0, 0]
    }

    /// Every permutation of both triangles and the swap of the two must give one answer.
    fn check_all_orders(a: [I3; 3], b: [I3; 3], expected: bool) {
        let perms = [
            [0, 1, 2],
            [1, 2, 0],
            [2, 0, 1],
            [0, 2, 1],
            [2, 1, 0],
            [1, 0, 2],
        ];
        for pa in perms {
            for pb in perms {
                let ta = tri(pa.map(|i| a[i]));
                let tb = tri(pb.map(|i| b[i]));
                assert_eq!(
                    triangles_intersect(ta, tb),
                    expected,
                    "{a:?} {b:?} {pa:?} {pb:?}"
                );
                assert_eq!(
                    triangles_intersect(tb, ta),
                    expected,
                    "{b:?} {a:?} {pb:?} {pa:?}"
                );
            }
        }
    }

    #[test]
    fn crossing_and_separated_triangles() {
        let a = [[0, 0, 0], [4, 0, 0], [0, 4, 0]];
        check_all_orders(a, [[1, 1, -1], [1, 1, 1], [5, 5, 0]], true);
        check_all_orders(a, [[1, 1, 1], [2, 1, 1], [1, 2, 3]], false);
        // Crossing the plane but beside the triangle.
        check_all_orders(a, [[3, 3, -1], [3, 3, 1], [6, 6, 0]], false);
    }

    #[test]
    fn touching_at_a_point_or_along_an_edge_counts() {
        let a = [[0, 0, 0], [4, 0, 0], [0, 4, 0]];
        // Vertex on the face.
        check_all_orders(a, [[1, 1, 0], [1, 1, 3], [2, 5, 3]], true);
        // Vertex on a vertex.
        check_all_orders(a, [[4, 0, 0], [5, 0, 3], [5, 1, 3]], true);
        // Vertex on an edge.
        check_all_orders(a, [[2, 0, 0], [2, -1, 3], [3, -1, 3]], true);
        // Edge across an edge, the triangle above the plane.
        check_all_orders(a, [[2, -1, 0], [2, 1, 0], [2, 0, 5]], true);
        // Sharing an edge segment, dihedral fold.
        check_all_orders(a, [[1, 0, 0], [3, 0, 0], [2, 0, 5]], true);
        // One unit above: apart.
        check_all_orders(a, [[1, 1, 1], [1, 1, 3], [2, 5, 3]], false);
        check_all_orders(a, [[2, -1, 1], [2, 1, 1], [2, 0, 5]], false);
        // Edge on the line through an edge but beyond its end.
        check_all_orders(a, [[5, 0, 0], [7, 0, 0], [6, 0, 5]], false);
    }

    #[test]
    fn coplanar_overlap_containment_and_touching() {
        let a = [[0, 0, 0], [4, 0, 0], [0, 4, 0]];
        // Overlapping corners.
        check_all_orders(a, [[1, 1, 0], [5, 1, 0], [1, 5, 0]], true);
        // One inside the other.
        check_all_orders(a, [[1, 1, 0], [2, 1, 0], [1, 2, 0]], true);
        // Star of David: edges cross, no vertex inside the other.
        check_all_orders(
            [[0, 0, 0], [6, 0, 0], [3, 6, 0]],
            [[0, 4, 0], [6, 4, 0], [3, -2, 0]],
            true,
        );
        // Touching at a vertex, along an edge.
        check_all_orders(a, [[4, 0, 0], [8, 0, 0], [4, 4, 0]], true);
        check_all_orders(a, [[0, 0, 0], [4, 0, 0], [2, -3, 0]], true);
        // Apart across the hypotenuse.
        check_all_orders(a, [[3, 3, 0], [6, 3, 0], [3, 6, 0]], false);
        // A tilted plane, degenerate in the xy projection.
        let t = [[0, 0, 0], [4, 0, 4], [0, 4, 0]];
        check_all_orders(t, [[1, 1, 1], [3, 1, 3], [1, 3, 1]], true);
        check_all_orders(t, [[3, 3, 3], [6, 3, 6], [3, 6, 3]], false);
        let vertical = [[0, 0, 0], [4, 0, 0], [0, 0, 4]];
        check_all_orders(vertical, [[1, 0, 1], [5, 0, 1], [1, 0, 5]], true);
        check_all_orders(vertical, [[3, 0, 3], [6, 0, 3], [3, 0, 6]], false);
    }

    #[test]
    fn degenerate_triangles_are_outside_the_domain() {
        let a = tri([[0, 0, 0], [4, 0, 0], [0, 4, 0]]);
        let needle = tri([[1, 1, -1], [1, 1, 0], [1, 1, 1]]);
        assert!(!triangles_intersect(a, needle));
        assert!(!triangles_intersect(needle, a));
    }

    #[test]
    fn segment_through_on_and_beside_a_triangle() {
        let t = tri([[0, 0, 0], [4, 0, 0], [0, 4, 0]]);
        let seg = |p: I3, q: I3| [v(p), v(q)];
        assert!(segment_triangle_intersect(seg([1, 1, -1], [1, 1, 1]), t));
        assert!(segment_triangle_intersect(seg([1, 1, 0], [1, 1, 1]), t));
        assert!(segment_triangle_intersect(seg([4, 0, -1], [4, 0, 1]), t));
        assert!(segment_triangle_intersect(seg([2, 2, -1], [2, 2, 1]), t));
        assert!(!segment_triangle_intersect(seg([3, 3, -1], [3, 3, 1]), t));
        assert!(!segment_triangle_intersect(seg([1, 1, 1], [1, 1, 2]), t));
        // In the plane: across, touching a corner, and beside.
        assert!(segment_triangle_intersect(seg([-1, 1, 0], [5, 1, 0]), t));
        assert!(segment_triangle_intersect(seg([4, 0, 0], [6, 0, 0]), t));
        assert!(!segment_triangle_intersect(seg([3, 3, 0], [5, 1, 0]), t));
        // A degenerate segment is a point.
        assert!(segment_triangle_intersect(seg([1, 1, 0], [1, 1, 0]), t));
        assert!(!segment_triangle_intersect(seg([5, 1, 0], [5, 1, 0]), t));
    }

    #[test]
    fn the_exact_test_decides_points_one_ulp_from_a_face() {
        let t = [
            DVec3::new(0.1, 0.2, 0.3),
            DVec3::new(1.7, 0.2, 0.3),
            DVec3::new(0.1, 1.9, 0.3),
        ];
        let hit = DVec3::new(0.5, 0.5, 0.3);
        let spike = |tip: DVec3| [tip, tip + DVec3::new(0.0, 0.0, 1.0), tip + DVec3::X];
        assert!(triangles_intersect(t, spike(hit)));
        let above = DVec3::new(hit.x, hit.y, hit.z.next_up());
        assert!(!triangles_intersect(t, spike(above)));
        assert!(segment_triangle_intersect([hit, hit + DVec3::Z], t));
        assert!(!segment_triangle_intersect([above, above + DVec3::Z], t));
    }

    /// Small integer coordinates make coplanar, collinear and touching configurations common.
    fn point() -> impl Strategy<Value = I3> {
        [-3i64..=3, -3i64..=3, -3i64..=3]
    }

    fn triangle() -> impl Strategy<Value = [I3; 3]> {
        [point(), point(), point()].prop_filter("non-degenerate", |t| !degenerate(*t))
    }

    fn flat_triangle() -> impl Strategy<Value = [I3; 3]> {
        let flat = || [-3i64..=3, -3i64..=3].prop_map(|[x, y]| [x, y, 0]);
        [flat(), flat(), flat()].prop_filter("non-degenerate", |t| !degenerate(*t))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]

        #[test]
        fn triangle_test_matches_separating_axes(a in triangle(), b in triangle()) {
            let expected = !sat_disjoint(&a, &b);
            prop_assert_eq!(triangles_intersect(tri(a), tri(b)), expected);
            prop_assert_eq!(triangles_intersect(tri(b), tri(a)), expected);
        }

        #[test]
        fn coplanar_triangle_test_matches_separating_axes(a in flat_triangle(), b in flat_triangle()) {
            prop_assert_eq!(triangles_intersect(tri(a), tri(b)), !sat_disjoint(&a, &b));
        }

        #[test]
        fn segment_test_matches_separating_axes(t in triangle(), p in point(), q in point()) {
            let expected = !sat_disjoint(&t, &[p, q]);
            prop_assert_eq!(segment_triangle_intersect([v(p), v(q)], tri(t)), expected);
        }
    }
}
