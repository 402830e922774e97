//! The balloon's moving front: its moving vertices, the triangles with a moving corner and
//! those triangles' edges. Frozen vertices are "excluded from the further evolution in order
//! to speed up the computation" (paper, section 2): forces, remeshing and the search for new
//! contacts only have work on the front, so a step costs in proportion to the front, not to
//! the whole balloon, which on a long vessel is mostly frozen.
//!
//! The lists are ascending slot ids, so that sums over them run in the same order as a pass
//! over the whole surface in slot order: the results do not depend on the thread count, and
//! are the same as if the frozen parts had been visited and skipped.

use super::surface::{Surface, VertexState};

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
        self.vertices
            .extend((0..surface.vertex_slots() as u32).filter(|&v| {
                surface.states()[v as usize] == VertexState::Moving && surface.is_vertex_live(v)
            }));
        self.triangles.clear();
        for &v in &self.vertices {
            self.triangles
                .extend(surface.outgoing_half_edges(v).map(|h| h / 3));
        }
        self.triangles.sort_unstable();
        self.triangles.dedup();
        self.edges.clear();
        for &t in &self.triangles {
            self.edges
                .extend((3 * t..3 * t + 3).map(|h| surface.edge_representative(h)));
        }
        self.edges.sort_unstable();
        self.edges.dedup();
    }

    /// The corners of the front's triangles, with repeats: the moving vertices and their
    /// neighbours.
    pub fn reached_vertices<'a>(&'a self, surface: &'a Surface) -> impl Iterator<Item = u32> + 'a {
        self.triangles
            .iter()
            .flat_map(|&t| surface.triangle(t).expect("front triangles are live"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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
}
