//! The balloon's moving front: its moving vertices, the triangles with a moving corner and
//! those triangles' edges. Frozen vertices are "excluded from the further evolution in order
//! to speed up the computation" (paper, section 2): forces, remeshing and the search for new
//! contacts only have work on the front, so a step costs in proportion to the front, not to
//! the whole balloon, which on a long vessel is mostly frozen.
//!
//! The lists are ascending slot ids, so that sums over them run in the same order as a pass
//! over the whole surface in slot order: the results do not depend on the thread count, and
//! are the same as if the frozen parts had been visited and skipped.

use crate::balloon::surface::Surface;

/// The moving part of a [`Surface`] at one moment; rebuilt with [`Front::update`] whenever
/// the surface's connectivity or freeze states have changed.
#[derive(Debug, Default, Clone, PartialEq)]
pub(crate) struct Front {
    /// Live moving vertices.
    pub vertices: Vec<u32>,
    /// Live triangles with at least one moving corner.
    pub triangles: Vec<u32>,
    /// The half-edges that stand for the edges of those triangles, each edge once: every edge
    /// with a moving end or a moving opposite vertex.
    pub edges: Vec<u32>,
}

impl Front {
    pub fn of(surface: &Surface) -> Front {
        let mut front = Front::default();
        front.update(surface);
        front
    }

    pub fn update(&mut self, surface: &Surface) {
        self.vertices.clear();
        self.vertices.extend(surface.moving_vertices());
        let mut triangles = SlotSet::new(surface.triangle_slots());
        for &v in &self.vertices {
            for h in surface.outgoing_half_edges(v) {
                triangles.insert(h / 3);
            }
        }
        triangles.ascending_into(&mut self.triangles);
        let mut edges = SlotSet::new(3 * surface.triangle_slots());
        for &t in &self.triangles {
            for h in 3 * t..3 * t + 3 {
                edges.insert(surface.edge_representative(h));
            }
        }
        edges.ascending_into(&mut self.edges);
    }

    /// The corners of the front's triangles, with repeats: the moving vertices and their
    /// neighbours.
    pub fn reached_vertices<'a>(&'a self, surface: &'a Surface) -> impl Iterator<Item = u32> + 'a {
        self.triangles
            .iter()
            .flat_map(|&t| surface.triangle(t).expect("front triangles are live"))
    }
}

/// A set of slot ids as a bit per slot: the front's triangles and edges come out ascending
/// and without repeats in one pass over the words. Sorting the ids with their repeats (six
/// triangles per vertex, three edges per triangle) took 12% of the aorta's instructions.
struct SlotSet {
    words: Vec<u64>,
}

impl SlotSet {
    fn new(slots: usize) -> SlotSet {
        SlotSet {
            words: vec![0; slots.div_ceil(64)],
        }
    }

    fn insert(&mut self, slot: u32) {
        self.words[(slot / 64) as usize] |= 1 << (slot % 64);
    }

    /// Replaces `out` by the set's slots, ascending.
    fn ascending_into(&self, out: &mut Vec<u32>) {
        out.clear();
        for (w, &word) in self.words.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                out.push(64 * w as u32 + bits.trailing_zeros());
                bits &= bits - 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::balloon::surface::VertexState;
    use glam::DVec3;

    #[test]
    fn front_of_a_partly_frozen_sphere_is_the_moving_cap_and_its_ring() {
        let mut s = Surface::icosphere(DVec3::ZERO, 1.0, 2).unwrap();
        for v in 0..s.vertex_slots() {
            if s.positions()[v].z < 0.5 {
                s.states_mut()[v] = VertexState::FrozenAtBorder;
            }
        }
        let front = Front::of(&s);
        let moving: Vec<u32> = (0..s.vertex_slots() as u32)
            .filter(|&v| s.positions()[v as usize].z >= 0.5)
            .collect();
        assert_eq!(front.vertices, moving);
        let expected: Vec<u32> = s
            .triangles()
            .filter(|(_, t)| t.iter().any(|&v| s.positions()[v as usize].z >= 0.5))
            .map(|(t, _)| t)
            .collect();
        assert_eq!(front.triangles, expected);
        // Exactly the edges that are not wholly frozen (ends and opposite vertices).
        let expected: Vec<(u32, u32)> = s
            .edges()
            .filter(|e| [e.a, e.b, e.c, e.d].iter().any(|&v| moving.contains(&v)))
            .map(|e| (e.a.min(e.b), e.a.max(e.b)))
            .collect();
        let found: Vec<(u32, u32)> = front
            .edges
            .iter()
            .map(|&h| {
                let e = s.edge(h);
                (e.a.min(e.b), e.a.max(e.b))
            })
            .collect();
        assert_eq!(found, expected);
    }

    #[test]
    fn slot_sets_come_out_ascending_without_repeats_across_words() {
        let mut set = SlotSet::new(200);
        for slot in [130, 0, 64, 63, 199, 64, 1, 130] {
            set.insert(slot);
        }
        let mut out = vec![7];
        set.ascending_into(&mut out);
        assert_eq!(out, [0, 1, 63, 64, 130, 199]);
    }
}
