//! A proof that a large output triangle lies within `ε` of the input at once, without cutting
//! it into parts: the input triangles just under it, seen from above.
//!
//! Take the input triangles (of the triangle's component, near it) whose corners all lie within
//! `ε` of the triangle's plane and that face the same way (their projection onto the plane is
//! positively oriented): the sheet `S`. Every point `x` of the plane that is the projection of a
//! point `q` of `S` has `|x − q| = |height(q)| ≤ ε`, the height being linear on each triangle of
//! `S`. So the triangle is within `ε` of the input if the projection of `S` covers it. Since
//! the input is a consistently oriented 2-manifold and `S`'s triangles all project positively,
//! the projection is open at every point of `S` off its boundary edges (across an inner edge the
//! two projections lie on opposite sides of it; around an inner vertex they wind at least once):
//! the projection's own boundary lies within the projection of `S`'s boundary edges. So if no
//! boundary edge's projection meets the triangle and one point of the triangle lies in the
//! projection, the whole triangle does (it is connected).
//!
//! Where the segmentation's balloon is simplified far (an output triangle over hundreds of input
//! triangles), cutting the triangle into parts each within reach of one input triangle takes
//! thousands of parts; this takes one pass over the triangles under it. Where it does not apply
//! (a fold, a steep input triangle, the input farther than `ε` from the plane), `false` sends
//! the triangle to the proof by parts (`error_bound::divide_onto`).

use glam::{DVec2, DVec3};

use super::error_bound::{Piece, Target};

/// Whether the sheet of `near` under `triangle` covers it (a `false` says nothing).
pub(super) fn covered_by_sheet(triangle: Piece, near: &[Target], limit: f64) -> bool {
    let [a, b, c] = triangle;
    let normal = (b - a).cross(c - a);
    let (Some(u), Some(n)) = ((b - a).try_normalize(), normal.try_normalize()) else {
        return false;
    };
    let v = n.cross(u);
    let flat = |p: DVec3| DVec2::new(u.dot(p - a), v.dot(p - a));
    let flat_triangle = triangle.map(flat);
    let mut sheet: Vec<[DVec2; 3]> = Vec::new();
    let mut edges: Vec<(u32, u32, DVec2, DVec2)> = Vec::new();
    for target in near {
        let corners = target.corners();
        let own = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        // Facing the same way, not merely not facing away: a steep triangle's projection is
        // too thin to trust its orientation.
        if own.dot(n) <= 1e-6 * own.length() {
            continue;
        }
        let projected = corners.map(flat);
        let heights = corners.map(|p| n.dot(p - a));
        if !within_over(projected, heights, flat_triangle, limit) {
            continue;
        }
        let vertices = target.vertices();
        for k in 0..3 {
            let next = (k + 1) % 3;
            edges.push((vertices[k], vertices[next], projected[k], projected[next]));
        }
        sheet.push(projected);
    }
    let centroid = (flat_triangle[0] + flat_triangle[1] + flat_triangle[2]) / 3.0;
    if !sheet.iter().any(|&q| contains(q, centroid)) {
        return false;
    }
    // An inner edge of the sheet is there both ways (the input is consistently oriented); an
    // edge there one way only borders it.
    let mut directed: Vec<(u32, u32)> = edges.iter().map(|e| (e.0, e.1)).collect();
    directed.sort_unstable();
    let longest = a.distance(b).max(b.distance(c)).max(c.distance(a));
    let margin = 1e-9 * longest;
    !edges
        .iter()
        .filter(|e| directed.binary_search(&(e.1, e.0)).is_err())
        .any(|e| segment_meets_triangle(e.2, e.3, flat_triangle, margin))
}

/// Whether the heights of a projected input triangle (`heights` at its `corners`, linear in
/// between) stay within `limit` over the part of it that lies over the output triangle: the
/// largest is at a corner of the polygon where the two overlap. Only that part can stand for a
/// point of the output triangle, so the rest of it may curve away.
fn within_over(corners: [DVec2; 3], heights: [f64; 3], triangle: [DVec2; 3], limit: f64) -> bool {
    if heights.iter().all(|h| h.abs() <= limit) {
        return true;
    }
    let area = (corners[1] - corners[0]).perp_dot(corners[2] - corners[0]);
    let height_at = |p: DVec2| {
        let l1 = (p - corners[0]).perp_dot(corners[2] - corners[0]) / area;
        let l2 = (corners[1] - corners[0]).perp_dot(p - corners[0]) / area;
        heights[0] + (heights[1] - heights[0]) * l1 + (heights[2] - heights[0]) * l2
    };
    overlap(corners, triangle)
        .into_iter()
        .all(|p| height_at(p).abs() <= limit)
}

/// The polygon where two counter-clockwise triangles overlap (Sutherland–Hodgman: `a` clipped
/// by each edge of `b`), empty when they do not.
fn overlap(a: [DVec2; 3], b: [DVec2; 3]) -> Vec<DVec2> {
    let mut polygon = a.to_vec();
    for k in 0..3 {
        let (from, to) = (b[k], b[(k + 1) % 3]);
        let side = |p: DVec2| (to - from).perp_dot(p - from);
        let mut clipped = Vec::with_capacity(polygon.len() + 1);
        for i in 0..polygon.len() {
            let (p, q) = (polygon[i], polygon[(i + 1) % polygon.len()]);
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                clipped.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                clipped.push(p + (q - p) * (sp / (sp - sq)));
            }
        }
        polygon = clipped;
        if polygon.is_empty() {
            break;
        }
    }
    polygon
}

/// Whether `p` lies in the counter-clockwise triangle `t`, edges included.
fn contains(t: [DVec2; 3], p: DVec2) -> bool {
    (0..3).all(|k| (t[(k + 1) % 3] - t[k]).perp_dot(p - t[k]) >= 0.0)
}

fn point_segment_distance(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let length2 = ab.length_squared();
    let t = if length2 > 0.0 {
        (ab.dot(p - a) / length2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + ab * t)
}

/// Whether segment `p`–`q` comes within `margin` of the counter-clockwise triangle `t`: an end
/// inside, a crossing of an edge, or a near miss (which the rounding of the projection could
/// turn either way).
fn segment_meets_triangle(p: DVec2, q: DVec2, t: [DVec2; 3], margin: f64) -> bool {
    if contains(t, p) || contains(t, q) {
        return true;
    }
    (0..3).any(|k| {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        let crosses = (b - a).perp_dot(p - a) * (b - a).perp_dot(q - a) <= 0.0
            && (q - p).perp_dot(a - p) * (q - p).perp_dot(b - p) <= 0.0;
        crosses
            || point_segment_distance(p, a, b) <= margin
            || point_segment_distance(q, a, b) <= margin
            || point_segment_distance(a, p, q) <= margin
    })
}

#[cfg(test)]
mod tests {
    use super::super::error_bound::farthest_sample;
    use super::*;

    /// A grid of `n`×`n` squares over [0, size]², each cut into two triangles, lifted by
    /// `height(x, y)`, counter-clockwise seen from +z.
    fn sheet(n: usize, size: f64, height: impl Fn(f64, f64) -> f64) -> Vec<Target> {
        let at = |i: usize, j: usize| {
            let (x, y) = (size * i as f64 / n as f64, size * j as f64 / n as f64);
            (DVec3::new(x, y, height(x, y)), (j * (n + 1) + i) as u32)
        };
        let mut targets = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let [(p0, v0), (p1, v1), (p2, v2), (p3, v3)] =
                    [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                targets.push(Target::new([p0, p1, p2], [v0, v1, v2]));
                targets.push(Target::new([p0, p2, p3], [v0, v2, v3]));
            }
        }
        targets
    }

    fn inside_triangle(z: f64) -> Piece {
        [
            DVec3::new(1.0, 1.0, z),
            DVec3::new(9.0, 2.0, z),
            DVec3::new(4.0, 8.5, z),
        ]
    }

    #[test]
    fn a_triangle_over_a_gently_waving_sheet_is_covered_and_the_bound_holds() {
        let wave = |x: f64, y: f64| 0.03 * (x * 1.3).sin() * (y * 0.7).cos();
        let targets = sheet(20, 10.0, wave);
        let triangle = inside_triangle(0.05);
        assert!(covered_by_sheet(triangle, &targets, 0.1));
        // Sound: sampled points of the triangle are within the bound of the sheet.
        let farthest = farthest_sample(triangle, &targets);
        assert!(farthest <= 0.1, "{farthest}");
    }

    #[test]
    fn heights_are_checked_over_the_overlap_only_and_at_its_true_values() {
        let output = [DVec2::ZERO, DVec2::new(4.0, 0.0), DVec2::new(0.0, 4.0)];
        // An input triangle reaching past the output's long edge x + y = 4, its heights 0 at
        // the two corners over the output and `far` at the corner beyond: linear in between,
        // so largest over the output where its edges cross the output's, at (3, 1).
        let input = [
            DVec2::new(1.0, 1.0),
            DVec2::new(5.0, 1.0),
            DVec2::new(1.0, 2.0),
        ];
        // At (3, 1) on the output's edge, the height is far·(3 − 1)/4 = far/2.
        assert!(within_over(input, [0.0, 0.19, 0.0], output, 0.1));
        assert!(!within_over(input, [0.0, 0.21, 0.0], output, 0.1));
        // Lifted by 0.06 everywhere: 0.06 + (far − 0.06)/2 at (3, 1). (A sign slip in the
        // interpolation read 0.06 − (far − 0.06)/2 there and let 0.16 through.)
        assert!(within_over(input, [0.06, 0.13, 0.06], output, 0.1));
        assert!(!within_over(input, [0.06, 0.16, 0.06], output, 0.1));
        // The other corners' heights count where they are over the output.
        assert!(!within_over(input, [0.0, 0.0, 0.11], output, 0.1));
        assert!(!within_over(input, [-0.11, 0.0, 0.0], output, 0.1));
        // Wholly outside the output: nothing of it stands for the output.
        let outside = input.map(|p| p + DVec2::new(10.0, 0.0));
        assert!(within_over(outside, [5.0, 5.0, 5.0], output, 0.1));
        assert!(overlap(outside, output).is_empty());
    }

    #[test]
    fn no_cover_where_the_sheet_is_too_far_has_a_hole_ends_or_faces_away() {
        let flat = sheet(20, 10.0, |_, _| 0.0);
        // Too far above.
        assert!(!covered_by_sheet(inside_triangle(0.11), &flat, 0.1));
        // A hole under the triangle: two input triangles missing.
        let holed: Vec<Target> = flat
            .iter()
            .enumerate()
            .filter(|(k, _)| !(176..178).contains(k))
            .map(|(_, t)| *t)
            .collect();
        assert!(covered_by_sheet(inside_triangle(0.05), &flat, 0.1));
        assert!(!covered_by_sheet(inside_triangle(0.05), &holed, 0.1));
        // Reaching past the sheet's end.
        let past = [
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(10.5, 2.0, 0.0),
            DVec3::new(4.0, 8.5, 0.0),
        ];
        assert!(!covered_by_sheet(past, &flat, 0.1));
        // Seen from below, the sheet faces away.
        let [p, q, r] = inside_triangle(0.0);
        assert!(!covered_by_sheet([p, r, q], &flat, 0.1));
        // A bump higher than the bound under one corner's region.
        let bumped = sheet(20, 10.0, |x, y| {
            if (x - 2.0).abs() < 0.6 && (y - 2.0).abs() < 0.6 {
                0.3
            } else {
                0.0
            }
        });
        assert!(!covered_by_sheet(inside_triangle(0.0), &bumped, 0.1));
    }
}
