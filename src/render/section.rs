//! A triangle mesh's cross-section with a plane: one segment for every triangle the plane cuts.
//!
//! Each vertex is classified by the sign of its distance to the plane, a vertex on the plane
//! counting as on its positive side (the plane is moved by an infinitesimal amount: the
//! simplest case of Edelsbrunner and Mücke's simulation of simplicity). So every cut edge has a
//! strictly negative and a non-negative end and its crossing point is well defined; a face
//! lying in the plane gives nothing, an edge lying in it is given once, by the triangle on its
//! negative side; the crossing of an edge is computed from its negative end in both of its
//! triangles, so the segments of a closed mesh meet end to end, bit for bit, in closed loops.

use glam::DVec3;
use rayon::prelude::*;

use crate::TriMesh;

/// Triangles handed to one worker at a time: enough to amortise the hand-over, few enough to
/// balance two to a few dozen cores on a million-triangle mesh.
const CHUNK: usize = 16 * 1024;

/// The segments where the plane `normal · p = offset` cuts the triangles of `mesh`, in
/// triangle order; zero-length ones (a triangle touching the plane at a vertex) are left out.
pub(crate) fn section(mesh: &TriMesh, normal: DVec3, offset: f64) -> Vec<[DVec3; 2]> {
    let points = mesh.points();
    mesh.triangles()
        .par_chunks(CHUNK)
        .flat_map_iter(|chunk| {
            chunk.iter().filter_map(move |t| {
                let p = t.map(|v| points[v as usize]);
                cut(p, p.map(|q| q.dot(normal) - offset))
            })
        })
        .collect()
}

/// The segment where a triangle with corners `p` at signed distances `d` crosses the plane.
fn cut(p: [DVec3; 3], d: [f64; 3]) -> Option<[DVec3; 2]> {
    let below = d.map(|v| v < 0.0);
    let count = below.iter().filter(|&&b| b).count();
    if count == 0 || count == 3 {
        return None;
    }
    // The corner alone on its side; the two edges from it are the cut ones.
    let lone = below.iter().position(|&b| b == (count == 1))?;
    let crossing = |other: usize| {
        let (neg, pos) = if below[lone] {
            (lone, other)
        } else {
            (other, lone)
        };
        let t = d[neg] / (d[neg] - d[pos]);
        p[neg] + (p[pos] - p[neg]) * t
    };
    let segment = [crossing((lone + 1) % 3), crossing((lone + 2) % 3)];
    (segment[0] != segment[1]).then_some(segment)
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;
    use crate::mesh::test_shapes::{cube, icosphere, torus};

    fn length(segments: &[[DVec3; 2]]) -> f64 {
        segments.iter().map(|[a, b]| a.distance(*b)).sum()
    }

    /// Every end point is shared by exactly two segments (bit for bit).
    fn closed_loops(segments: &[[DVec3; 2]]) -> bool {
        let mut ends: HashMap<[u64; 3], usize> = HashMap::new();
        for p in segments.iter().flatten() {
            *ends.entry(p.to_array().map(f64::to_bits)).or_default() += 1;
        }
        ends.values().all(|&n| n == 2)
    }

    #[test]
    fn a_unit_cube_cut_through_its_middle_gives_its_square() {
        let mesh = cube(DVec3::ZERO, DVec3::ONE);
        let segments = section(&mesh, DVec3::Z, 0.5);
        // Four sides of two triangles each.
        assert_eq!(segments.len(), 8);
        assert!((length(&segments) - 4.0).abs() < 1e-12);
        assert!(closed_loops(&segments));
        assert!(segments.iter().flatten().all(|p| p.z == 0.5));
    }

    #[test]
    fn planes_through_faces_edges_and_vertices_give_whole_loops_or_nothing() {
        let mesh = cube(DVec3::ZERO, DVec3::ONE);
        // The top face lies in the plane: its four edges, each once.
        let top = section(&mesh, DVec3::Z, 1.0);
        assert_eq!(top.len(), 4);
        assert!((length(&top) - 4.0).abs() < 1e-12);
        // The bottom face lies in it too, but the cube is on the positive side.
        assert!(section(&mesh, DVec3::Z, 0.0).is_empty());
        // Through two opposite edges: a rectangle of sides 1 and √2.
        let diagonal = section(&mesh, DVec3::new(1.0, -1.0, 0.0).normalize(), 0.0);
        assert!((length(&diagonal) - 2.0 * (1.0 + 2f64.sqrt())).abs() < 1e-9);
        assert!(closed_loops(&diagonal));
        // Missing the mesh altogether.
        assert!(section(&mesh, DVec3::X, 5.0).is_empty());
    }

    #[test]
    fn a_sphere_cut_off_centre_gives_a_closed_circle_of_the_right_length() {
        let r = 10.0;
        let mesh = icosphere(DVec3::new(1.0, 2.0, 3.0), r, 4);
        for (normal, offset) in [(DVec3::Z, 3.0 + 0.3 * r), (DVec3::X, 1.0), (DVec3::Y, 2.0)] {
            let h = offset - normal.dot(DVec3::new(1.0, 2.0, 3.0));
            let expected = std::f64::consts::TAU * (r * r - h * h).sqrt();
            let segments = section(&mesh, normal, offset);
            let l = length(&segments);
            assert!((l - expected).abs() < 0.01 * expected, "{l} vs {expected}");
            assert!(closed_loops(&segments));
        }
    }

    #[test]
    fn a_torus_cut_through_its_axis_gives_two_circles() {
        let mesh = torus(DVec3::ZERO, 12.0, 4.0, 48, 24);
        let segments = section(&mesh, DVec3::X, 0.0);
        let expected = 2.0 * std::f64::consts::TAU * 4.0;
        assert!((length(&segments) - expected).abs() < 0.02 * expected);
        assert!(closed_loops(&segments));
    }
}
