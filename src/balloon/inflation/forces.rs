//! The balloon's per-vertex forces (paper, section 2): elastic springs along the edges, bending
//! on the dihedral angle of each edge, and inflation along the vertex normal driven by the
//! intensity under the vertex.
//!
//! Forces are displacements in units of the target edge length per step; the integrator
//! scales them and clamps each step to a fraction of a voxel.
//!
//! - **Elastic**: each edge is a zero-length spring, so a vertex is pulled towards the centroid
//!   of its neighbours (the umbrella operator). Only the tangential part is kept: the normal
//!   part is proportional to curvature and would shrink the balloon away from the border,
//!   biasing the result inward; smoothness across the surface is the bending force's job.
//! - **Bending**: on an edge a–b with opposite vertices c and d, the signed dihedral angle θ
//!   (positive on a ridge) pushes c and d along their triangles' normals by θ and a, b back
//!   by half the sum, so the edge flattens and the forces cancel: a sphere, whose dihedral
//!   angles are all equal, feels no net bending, but a dent or a spike does.
//! - **Inflation**: along the normal, with the speed the place under the vertex gets from the
//!   border rule (`border`): slower towards the border, reversed beyond it (the paper's
//!   containing force). The integrator freezes a vertex on the exact border crossing.
//!
//! Elastic and bending terms are accumulated over the front's edges sequentially, in slot
//! order, so the sums are the same whatever the thread count; the per-vertex parts run in
//! parallel.

use glam::DVec3;
use rayon::prelude::*;

use crate::balloon::surface::front::Front;
use crate::balloon::surface::Surface;

/// Relative weights of the three forces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceWeights {
    pub elastic: f64,
    pub bending: f64,
    pub inflation: f64,
}

impl Default for ForceWeights {
    fn default() -> Self {
        ForceWeights {
            elastic: 0.4,
            bending: 0.15,
            inflation: 1.0,
        }
    }
}

/// Per-vertex sums reused from step to step, by vertex slot; only the entries the front
/// reaches are cleared and filled, so a step does not touch the frozen rest of the balloon.
#[derive(Debug, Default)]
pub(crate) struct ForceScratch {
    neighbour_sum: Vec<DVec3>,
    valence: Vec<u32>,
    bending: Vec<DVec3>,
}

/// Elastic (tangential umbrella) plus bending forces of the front's moving vertices, in units
/// of the edge length `scale`: `forces[i]` is the force on `front.vertices[i]`. `normals` are
/// the unit vertex normals by slot (at least of the moving vertices).
pub(crate) fn internal_forces(
    surface: &Surface,
    front: &Front,
    normals: &[DVec3],
    weights: &ForceWeights,
    scale: f64,
    scratch: &mut ForceScratch,
    forces: &mut Vec<DVec3>,
) {
    let slots = surface.vertex_slots();
    let positions = surface.positions();
    let ForceScratch {
        neighbour_sum,
        valence,
        bending,
    } = scratch;
    neighbour_sum.resize(slots, DVec3::ZERO);
    valence.resize(slots, 0);
    bending.resize(slots, DVec3::ZERO);
    let edges = || front.edges.iter().map(|&h| surface.edge(h));
    for e in edges() {
        for v in [e.a, e.b, e.c, e.d] {
            neighbour_sum[v as usize] = DVec3::ZERO;
            valence[v as usize] = 0;
            bending[v as usize] = DVec3::ZERO;
        }
    }
    // The front's edges are every edge with a moving end or opposite vertex, so the sums of
    // the moving vertices are complete.
    for e in edges() {
        let [a, b, c, d] = [e.a, e.b, e.c, e.d].map(|v| v as usize);
        neighbour_sum[a] += positions[b];
        neighbour_sum[b] += positions[a];
        valence[a] += 1;
        valence[b] += 1;
        let (pa, pb, pc, pd) = (positions[a], positions[b], positions[c], positions[d]);
        let n1 = (pb - pa).cross(pc - pa).normalize_or_zero();
        let n2 = (pa - pb).cross(pd - pb).normalize_or_zero();
        let theta = dihedral(n1, n2, pc - pa);
        let push_c = theta * n1;
        let push_d = theta * n2;
        bending[c] += push_c;
        bending[d] += push_d;
        bending[a] -= 0.5 * (push_c + push_d);
        bending[b] -= 0.5 * (push_c + push_d);
    }
    let (neighbour_sum, valence, bending) = (&*neighbour_sum, &*valence, &*bending);
    front
        .vertices
        .par_iter()
        .with_min_len(1024)
        .map(|&v| {
            let v = v as usize;
            let umbrella = neighbour_sum[v] / valence[v] as f64 - positions[v];
            let n = normals[v];
            let tangential = umbrella - n * umbrella.dot(n);
            weights.elastic * tangential / scale + weights.bending * bending[v]
        })
        .collect_into_vec(forces);
}

/// Signed angle between the normals of two triangles sharing an edge, given the vector from the
/// edge to the first triangle's far corner: positive
/// where the surface bends away from its normal (a ridge), negative in a valley.
fn dihedral(n1: DVec3, n2: DVec3, to_c: DVec3) -> f64 {
    let angle = n1.dot(n2).clamp(-1.0, 1.0).acos();
    // On a ridge, the second triangle's normal leans away from the first triangle's far corner.
    if n2.dot(to_c) > 0.0 {
        -angle
    } else {
        angle
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The internal forces of a surface whose vertices all move, by slot.
    fn forces(s: &Surface, normals: &[DVec3]) -> Vec<DVec3> {
        let front = Front::of(s);
        assert_eq!(front.vertices.len(), s.vertex_slots());
        let mut f = Vec::new();
        let weights = ForceWeights::default();
        internal_forces(
            s,
            &front,
            normals,
            &weights,
            1.0,
            &mut ForceScratch::default(),
            &mut f,
        );
        f
    }

    #[test]
    fn forces_on_a_front_equal_those_on_the_whole_surface() {
        // Freezing a cap must not change the forces on the vertices that still move.
        let mut s = Surface::icosphere(DVec3::ZERO, 5.0, 3).unwrap();
        s.positions_mut()[7] *= 1.2;
        let normals = s.vertex_normals();
        let all = forces(&s, &normals);
        for v in 0..s.vertex_slots() {
            if s.positions()[v].z < 1.0 {
                s.states_mut()[v] = crate::balloon::surface::VertexState::FrozenAtBorder;
            }
        }
        let front = Front::of(&s);
        let mut f = Vec::new();
        let weights = ForceWeights::default();
        let mut scratch = ForceScratch::default();
        for _ in 0..2 {
            internal_forces(&s, &front, &normals, &weights, 1.0, &mut scratch, &mut f);
            for (i, &v) in front.vertices.iter().enumerate() {
                assert_eq!(f[i], all[v as usize], "vertex {v}");
            }
        }
    }

    #[test]
    fn a_sphere_feels_no_net_bending_and_no_elastic_shrinking() {
        let s = Surface::icosphere(DVec3::ZERO, 5.0, 3).unwrap();
        let normals = s.vertex_normals();
        let f = forces(&s, &normals);
        let normal_parts: Vec<f64> = s
            .live_vertices()
            .map(|v| f[v as usize].dot(normals[v as usize]))
            .collect();
        // Icosphere vertices are not all alike (valence 5 and 6), which leaves a residue of a
        // few hundredths where a spike of one edge length (below) gets tenths; on average the
        // sphere neither shrinks nor grows.
        let worst = normal_parts.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let mean = normal_parts.iter().sum::<f64>() / normal_parts.len() as f64;
        assert!(worst < 0.1, "worst {worst}");
        assert!(mean.abs() < 0.005, "mean {mean}");
    }

    #[test]
    fn a_spike_is_pushed_back_and_a_dent_pushed_out() {
        let mut s = Surface::icosphere(DVec3::ZERO, 5.0, 3).unwrap();
        let v = 0usize;
        let out = s.positions()[v].normalize();
        s.positions_mut()[v] += out * 1.5;
        let f = forces(&s, &s.vertex_normals());
        assert!(f[v].dot(out) < -0.1, "spike: {}", f[v].dot(out));

        s.positions_mut()[v] -= out * 3.0;
        let f = forces(&s, &s.vertex_normals());
        assert!(f[v].dot(out) > 0.1, "dent: {}", f[v].dot(out));
    }

    #[test]
    fn dihedral_sign_is_positive_on_a_ridge() {
        // Edge along x; triangle 1 on y > 0 and triangle 2 on y < 0, both sloping down (z < 0):
        // a roof ridge seen from above.
        let (a, b) = (DVec3::ZERO, DVec3::X);
        let c = DVec3::new(0.5, 1.0, -1.0);
        let d = DVec3::new(0.5, -1.0, -1.0);
        let n1 = (b - a).cross(c - a).normalize();
        let n2 = (a - b).cross(d - b).normalize();
        assert!(n1.z > 0.0 && n2.z > 0.0);
        assert!(dihedral(n1, n2, c - a) > 0.0);
        let c = DVec3::new(0.5, 1.0, 1.0);
        let d = DVec3::new(0.5, -1.0, 1.0);
        let n1 = (b - a).cross(c - a).normalize();
        let n2 = (a - b).cross(d - b).normalize();
        assert!(dihedral(n1, n2, c - a) < 0.0);
    }
}
