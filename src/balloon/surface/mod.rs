//! The balloon's dynamic mesh: a closed, consistently oriented triangulated 2-manifold (any
//! genus, any number of components) stored as an implicit half-edge structure, with the
//! per-vertex freeze state the balloon needs (paper, section 2; docs/method.md, step 1).
//!
//! Triangle `t` owns the half-edges `3t`, `3t+1`, `3t+2`; half-edge `3t+i` runs from corner `i`
//! to corner `i+1 (mod 3)`, so `next`/`prev` are arithmetic and only the twin of each half-edge
//! and one outgoing half-edge per vertex are stored. Triangles are counter-clockwise seen from
//! outside, as in [`TriMesh`].
//!
//! Index stability: remeshing (`split_long_edges`, `collapse_short_edges`, `flip_edges_for_valence`
//! and the single-edge variants) never moves a live vertex or triangle to another slot. New
//! vertices and triangles are appended, deleted ones become tombstones (their slots stay, with
//! [`Surface::is_vertex_live`] false), so per-vertex data kept by the caller stays valid: extend it
//! to [`Surface::vertex_slots`] after a split. Only [`Surface::compact`] renumbers, and it returns
//! the old→new map so that such data can follow.

pub(in crate::balloon) mod front;
mod remesh;

use std::collections::BTreeSet;

use glam::DVec3;
use rayon::prelude::*;

use crate::balloon::surface::front::Front;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::mesh_checks;

/// Marks a dead slot (vertex, triangle corner or twin) and the end of a ring walk.
pub(in crate::balloon) const NONE: u32 = u32::MAX;

/// Half-edge ids are `3 * triangle + corner` in a `u32`; this keeps them (and `NONE`) in range.
pub(in crate::balloon) const MAX_TRIANGLES: usize = (u32::MAX / 3 - 1) as usize;

/// Where a vertex is in the balloon's evolution. The values are the C ABI's `vertex_state` bytes.
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum VertexState {
    /// Still moved by the forces.
    #[default]
    Moving = 0,
    /// Reached the structure's border: it keeps its position.
    FrozenAtBorder = 1,
    /// Belongs to a self-intersecting triangle: it keeps its position until re-parametrisation.
    FrozenBySelfIntersection = 2,
}

impl VertexState {
    pub fn is_frozen(self) -> bool {
        self != VertexState::Moving
    }
}

/// One undirected edge `a–b` with its two opposite vertices: the edge runs `a → b` in the
/// triangle `(a, b, c)` and `b → a` in the triangle `(b, a, d)`, both counter-clockwise seen from
/// outside. The dihedral angle of the bending force lives on this edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Edge {
    pub a: u32,
    pub b: u32,
    pub c: u32,
    pub d: u32,
}

/// A closed, oriented, manifold triangle mesh that can be refined and coarsened in place.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    pub(in crate::balloon) positions: Vec<DVec3>,
    pub(in crate::balloon) states: Vec<VertexState>,
    /// One half-edge leaving each vertex; `NONE` for a deleted vertex.
    pub(in crate::balloon) outgoing: Vec<u32>,
    /// Corners of each triangle; `[NONE; 3]` for a deleted triangle.
    pub(in crate::balloon) triangles: Vec<[u32; 3]>,
    /// The opposite half-edge of each half-edge; `NONE` in deleted triangles.
    pub(in crate::balloon) twins: Vec<u32>,
    pub(in crate::balloon) live_vertices: usize,
    pub(in crate::balloon) live_triangles: usize,
    /// With [`Surface::record_rewrites`], the triangle slots whose corners, or a corner's
    /// position, remeshing has changed since [`Surface::take_rewritten`] (repeats allowed).
    pub(in crate::balloon) rewritten: Option<Vec<u32>>,
}

#[inline]
pub(in crate::balloon) fn next(h: u32) -> u32 {
    if h % 3 == 2 {
        h - 2
    } else {
        h + 1
    }
}

#[inline]
pub(in crate::balloon) fn prev(h: u32) -> u32 {
    if h % 3 == 0 {
        h + 2
    } else {
        h - 1
    }
}

impl Surface {
    /// A geodesic sphere, outward-oriented: an icosahedron whose triangles are each divided into
    /// four `subdivisions` times, vertices projected onto the sphere. It has `10·4^s + 2`
    /// vertices and `20·4^s` triangles (162 and 320 for `s = 2`).
    pub fn icosphere(centre: DVec3, radius: f64, subdivisions: u32) -> Result<Surface> {
        const MAX_SUBDIVISIONS: u32 = 10;
        if !centre.is_finite() {
            return Err(Error::invalid_argument(format!(
                "sphere centre {centre:?} is not finite; give finite coordinates"
            )));
        }
        if !(radius.is_finite() && radius > 0.0) {
            return Err(Error::invalid_argument(format!(
                "sphere radius {radius} must be positive and finite"
            )));
        }
        if subdivisions > MAX_SUBDIVISIONS {
            return Err(Error::invalid_argument(format!(
                "{subdivisions} subdivisions would make {} triangles; use at most {MAX_SUBDIVISIONS}",
                20u128 << (2 * subdivisions)
            )));
        }
        let (points, triangles) = TriMesh::icosphere(centre, radius, subdivisions).into_parts();
        Surface::build(points, triangles)
    }

    /// Takes over a closed, edge- and vertex-manifold, consistently oriented mesh (any genus,
    /// any number of components) whose every point is used by a triangle. Vertex `i` of the
    /// mesh is vertex `i` of the surface; every vertex starts `Moving`.
    pub fn from_mesh(mesh: &TriMesh) -> Result<Surface> {
        if mesh.is_empty() {
            return Err(Error::invalid_mesh(
                "the mesh has no triangles; a surface needs a closed triangle mesh",
            ));
        }
        if mesh.triangles().len() > MAX_TRIANGLES {
            return Err(Error::invalid_mesh(format!(
                "{} triangles exceed the surface's limit of {MAX_TRIANGLES}",
                mesh.triangles().len()
            )));
        }
        match Surface::linked(mesh.points().to_vec(), mesh.triangles().to_vec()) {
            Some(surface) => surface.with_valence_checked(),
            None => Err(Self::why_not_a_surface(mesh)),
        }
    }

    /// The error for a mesh that [`Surface::linked`] refused, naming every kind of problem.
    fn why_not_a_surface(mesh: &TriMesh) -> Error {
        let r = mesh_checks::check(mesh);
        let problems: Vec<String> = [
            (r.degenerate_triangles, "triangles repeat a vertex (remove them)"),
            (r.boundary_edges, "edges have one triangle only: the mesh is open (close its holes)"),
            (r.non_manifold_edges, "edges are shared by more than two triangles (non-manifold edges: separate the sheets)"),
            (r.non_manifold_vertices, "vertices join several fans of triangles (non-manifold vertices: duplicate them per fan)"),
            (r.inconsistently_oriented_edges, "edges are traversed twice in the same direction (orient all triangles consistently)"),
            (r.unreferenced_vertices, "points are used by no triangle (remove unreferenced points)"),
        ]
        .iter()
        .filter(|(count, _)| *count > 0)
        .map(|(count, what)| format!("{count} {what}"))
        .collect();
        Error::invalid_mesh(format!(
            "the balloon surface needs a closed, manifold, consistently oriented mesh: {}",
            problems.join("; ")
        ))
    }

    /// Links the half-edges of a mesh known to be closed, manifold and oriented.
    fn build(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<Surface> {
        Surface::linked(positions, triangles)
            .ok_or_else(|| Error::internal("a generated mesh is not a closed oriented manifold"))?
            .with_valence_checked()
    }

    /// Links the half-edges, checking on the way everything [`Surface::from_mesh`] requires
    /// (so that the marching-cubes surface of every re-parametrisation is not measured twice):
    /// `None` if a triangle repeats a vertex, a directed edge occurs twice (a non-manifold or
    /// inconsistently oriented edge) or has no opposite (a boundary), a point is unused, or a
    /// vertex's fan does not reach all of its half-edges (a non-manifold vertex).
    fn linked(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Option<Surface> {
        if triangles
            .iter()
            .any(|&[a, b, c]| a == b || b == c || a == c)
        {
            return None;
        }
        // The half-edges leaving each vertex with their destinations, as compressed rows in
        // half-edge order: a twin is found among the few half-edges leaving the other end,
        // without sorting them all.
        let half_edges = 3 * triangles.len();
        let mut start = vec![0u32; positions.len() + 1];
        for tri in &triangles {
            for &v in tri {
                start[v as usize + 1] += 1;
            }
        }
        for v in 0..positions.len() {
            start[v + 1] += start[v];
        }
        let mut fill = start.clone();
        let mut leaving = vec![(0u32, 0u32); half_edges];
        for (t, tri) in triangles.iter().enumerate() {
            for i in 0..3 {
                let a = tri[i] as usize;
                leaving[fill[a] as usize] = (tri[(i + 1) % 3], (3 * t + i) as u32);
                fill[a] += 1;
            }
        }
        let row = |v: u32| &leaving[start[v as usize] as usize..start[v as usize + 1] as usize];
        // Exactly one opposite for every half-edge also rules out a repeated one: a second
        // a → b leaves b → a either missing or with two opposites.
        let mut twins = vec![NONE; half_edges];
        for a in 0..positions.len() as u32 {
            for &(b, h) in row(a) {
                let mut opposite = row(b).iter().filter(|&&(c, _)| c == a);
                let (Some(&(_, g)), None) = (opposite.next(), opposite.next()) else {
                    return None;
                };
                twins[h as usize] = g;
            }
        }
        // Each vertex starts its fan at its edge to the lowest-numbered neighbour.
        let mut outgoing = Vec::with_capacity(positions.len());
        for v in 0..positions.len() as u32 {
            outgoing.push(row(v).iter().min()?.1);
        }
        let vertices = positions.len() as u32;
        let surface = Surface {
            states: vec![VertexState::Moving; positions.len()],
            live_vertices: positions.len(),
            live_triangles: triangles.len(),
            positions,
            outgoing,
            triangles,
            twins,
            rewritten: None,
        };
        let one_fan = (0..vertices).all(|v| surface.outgoing_half_edges(v).count() == row(v).len());
        one_fan.then_some(surface)
    }

    fn with_valence_checked(self) -> Result<Surface> {
        // A vertex of valence two sits between two triangles with the same three corners (a
        // two-triangle "pillow"), which no edge operation can handle.
        if let Some(v) = self.live_vertices().find(|&v| self.valence(v) < 3) {
            return Err(Error::invalid_mesh(format!(
                "vertex {v} has fewer than three neighbours (two triangles share all three \
                 corners); remove such two-triangle components"
            )));
        }
        Ok(self)
    }

    /// The live part as an indexed mesh: vertices in slot order, then triangles in slot order.
    /// Fails only if the caller has moved a vertex to a non-finite position.
    pub fn to_mesh(&self) -> Result<TriMesh> {
        self.to_mesh_with_map().map(|(mesh, _)| mesh)
    }

    /// [`Surface::to_mesh`] and the old→new vertex map (`u32::MAX` for deleted slots), so that
    /// per-vertex attributes can follow: `new_attr[map[v]] = attr[v]` for every live `v`.
    pub fn to_mesh_with_map(&self) -> Result<(TriMesh, Vec<u32>)> {
        let map = self.vertex_map();
        let points = self
            .live_vertices()
            .map(|v| self.positions[v as usize])
            .collect();
        let triangles = self
            .triangles()
            .map(|(_, tri)| tri.map(|v| map[v as usize]))
            .collect();
        Ok((TriMesh::new(points, triangles)?, map))
    }

    /// Drops the tombstones: live vertices and triangles are renumbered densely in slot order.
    /// Invalidates every vertex, triangle and half-edge index held outside; returns the
    /// old→new vertex map (`u32::MAX` for deleted vertices) to carry per-vertex data over.
    pub fn compact(&mut self) -> Vec<u32> {
        let vmap = self.vertex_map();
        let mut tmap = vec![NONE; self.triangles.len()];
        let mut live = 0u32;
        for (t, slot) in tmap.iter_mut().enumerate() {
            if self.triangles[t][0] != NONE {
                *slot = live;
                live += 1;
            }
        }
        let map_half_edge = |h: u32| 3 * tmap[(h / 3) as usize] + h % 3;
        let mut triangles = Vec::with_capacity(self.live_triangles);
        let mut twins = Vec::with_capacity(3 * self.live_triangles);
        for (t, tri) in self.triangles.iter().enumerate() {
            if tri[0] != NONE {
                triangles.push(tri.map(|v| vmap[v as usize]));
                twins.extend((0..3).map(|i| map_half_edge(self.twins[3 * t + i])));
            }
        }
        let mut positions = Vec::with_capacity(self.live_vertices);
        let mut states = Vec::with_capacity(self.live_vertices);
        let mut outgoing = Vec::with_capacity(self.live_vertices);
        for v in self.live_vertices() {
            positions.push(self.positions[v as usize]);
            states.push(self.states[v as usize]);
            outgoing.push(map_half_edge(self.outgoing[v as usize]));
        }
        self.positions = positions;
        self.states = states;
        self.outgoing = outgoing;
        self.triangles = triangles;
        self.twins = twins;
        if let Some(rewritten) = &mut self.rewritten {
            rewritten.clear();
        }
        vmap
    }

    /// From now on, remeshing notes the triangle slots it rewrites, for
    /// [`Surface::take_rewritten`]: an index of the frozen triangles can then follow the few
    /// that change instead of scanning them all.
    pub fn record_rewrites(&mut self) {
        self.rewritten.get_or_insert_with(Vec::new);
    }

    /// The triangle slots remeshing has rewritten (new ones included) since the last call or
    /// since [`Surface::record_rewrites`]; empty unless recording. Compaction renumbers every
    /// slot and forgets the record.
    pub fn take_rewritten(&mut self) -> Vec<u32> {
        self.rewritten
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// Notes that remeshing rewrote triangle `t`.
    pub(in crate::balloon) fn note_rewritten(&mut self, t: u32) {
        if let Some(rewritten) = &mut self.rewritten {
            rewritten.push(t);
        }
    }

    fn vertex_map(&self) -> Vec<u32> {
        let mut next_index = 0u32;
        self.outgoing
            .iter()
            .map(|&h| {
                if h == NONE {
                    NONE
                } else {
                    next_index += 1;
                    next_index - 1
                }
            })
            .collect()
    }

    /// Positions by vertex slot (deleted slots keep their last position).
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    pub fn positions_mut(&mut self) -> &mut [DVec3] {
        &mut self.positions
    }

    /// Freeze states by vertex slot.
    pub fn states(&self) -> &[VertexState] {
        &self.states
    }

    pub fn states_mut(&mut self) -> &mut [VertexState] {
        &mut self.states
    }

    /// Positions and states by slot together, to update both in one pass.
    pub fn positions_and_states_mut(&mut self) -> (&mut [DVec3], &mut [VertexState]) {
        (&mut self.positions, &mut self.states)
    }

    /// Length of the per-vertex arrays, tombstones included.
    pub fn vertex_slots(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangle slots, tombstones included.
    pub fn triangle_slots(&self) -> usize {
        self.triangles.len()
    }

    /// Live vertices.
    pub fn vertex_count(&self) -> usize {
        self.live_vertices
    }

    /// Live triangles.
    pub fn triangle_count(&self) -> usize {
        self.live_triangles
    }

    /// Live undirected edges (every closed triangle mesh has 3/2 edges per triangle).
    pub fn edge_count(&self) -> usize {
        3 * self.live_triangles / 2
    }

    pub fn is_vertex_live(&self, v: u32) -> bool {
        self.outgoing.get(v as usize).is_some_and(|&h| h != NONE)
    }

    pub fn is_triangle_live(&self, t: u32) -> bool {
        self.triangles
            .get(t as usize)
            .is_some_and(|tri| tri[0] != NONE)
    }

    /// Live vertex ids in increasing order.
    pub fn live_vertices(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.outgoing.len() as u32).filter(|&v| self.outgoing[v as usize] != NONE)
    }

    /// Live `Moving` vertex ids in increasing order: the front, rebuilt every step.
    pub fn moving_vertices(&self) -> impl Iterator<Item = u32> + '_ {
        (0u32..)
            .zip(self.states.iter().zip(&self.outgoing))
            .filter(|(_, (&state, &h))| state == VertexState::Moving && h != NONE)
            .map(|(v, _)| v)
    }

    /// Corners of triangle `t`, `None` if it is deleted or out of range.
    pub fn triangle(&self, t: u32) -> Option<[u32; 3]> {
        self.triangles
            .get(t as usize)
            .copied()
            .filter(|tri| tri[0] != NONE)
    }

    /// Live triangles `(slot, corners)` in slot order.
    pub fn triangles(&self) -> impl Iterator<Item = (u32, [u32; 3])> + '_ {
        (0..self.triangles.len() as u32).filter_map(|t| self.triangle(t).map(|tri| (t, tri)))
    }

    /// The enclosed volume (mm³), positive for the outward balloon; summed in slot order.
    pub fn signed_volume(&self) -> f64 {
        self.triangles()
            .map(|(_, t)| {
                let [a, b, c] = t.map(|v| self.positions[v as usize]);
                a.dot(b.cross(c))
            })
            .sum::<f64>()
            / 6.0
    }

    /// Corner positions of triangle `t`, `None` if it is deleted or out of range.
    pub fn triangle_corners(&self, t: u32) -> Option<[DVec3; 3]> {
        self.triangle(t)
            .map(|tri| tri.map(|v| self.positions[v as usize]))
    }

    /// The neighbours of `v`, in counter-clockwise order seen from outside, starting at an
    /// arbitrary but fixed one. Empty for a deleted or out-of-range vertex.
    pub fn neighbours(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        self.outgoing_half_edges(v).map(|h| self.dest(h))
    }

    /// The vertices `around` and every vertex within `rings` rings of them.
    pub fn neighbourhood(
        &self,
        around: impl IntoIterator<Item = u32>,
        rings: usize,
    ) -> BTreeSet<u32> {
        let mut patch: BTreeSet<u32> = around.into_iter().collect();
        for _ in 0..rings {
            let ring: Vec<u32> = patch.iter().flat_map(|&v| self.neighbours(v)).collect();
            patch.extend(ring);
        }
        patch
    }

    /// The neighbours of each of `vertices`, for repeated [`Surface::umbrella_pass`]es.
    pub fn rings(&self, vertices: &[u32]) -> Vec<Vec<u32>> {
        vertices
            .par_iter()
            .map(|&v| self.neighbours(v).collect())
            .collect()
    }

    /// One pass of the umbrella operator: each of `vertices` (neighbours `rings`, from
    /// [`Surface::rings`]) moves `factor` of the way to its neighbours' centroid, every move
    /// computed from the positions before the pass — so the same for any thread count.
    pub fn umbrella_pass(&mut self, vertices: &[u32], rings: &[Vec<u32>], factor: f64) {
        let positions = &self.positions;
        let moved: Vec<DVec3> = vertices
            .par_iter()
            .zip(rings)
            .map(|(&v, ring)| {
                let p = positions[v as usize];
                let sum: DVec3 = ring.iter().map(|&u| positions[u as usize]).sum();
                p + factor * (sum / ring.len() as f64 - p)
            })
            .collect();
        for (&v, p) in vertices.iter().zip(moved) {
            self.positions[v as usize] = p;
        }
    }

    /// Number of neighbours of `v` (0 for a deleted vertex).
    pub fn valence(&self, v: u32) -> usize {
        self.outgoing_half_edges(v).count()
    }

    /// Every live undirected edge once, in half-edge slot order.
    pub fn edges(&self) -> impl Iterator<Item = Edge> + '_ {
        (0..self.twins.len() as u32)
            .filter(|&h| self.represents_edge(h))
            .map(|h| self.edge(h))
    }

    /// The edge of the live half-edge `h`, running `a → b` along `h`.
    pub fn edge(&self, h: u32) -> Edge {
        Edge {
            a: self.origin(h),
            b: self.dest(h),
            c: self.opposite(h),
            d: self.opposite(self.twins[h as usize]),
        }
    }

    /// Unit vertex normals by slot, area-weighted: the normalised sum of the incident triangles'
    /// cross products (each twice the triangle's area along its normal). Zero for deleted
    /// vertices and for vertices whose triangles cancel out. Bit-identical for any thread count:
    /// the sums run over the triangles in slot order, only the normalisation is parallel.
    /// (Gathering around each vertex in parallel was 10–30× slower on a grown 100k-vertex
    /// surface: every step of a ring walk waits for a scattered twin load.)
    pub fn vertex_normals(&self) -> Vec<DVec3> {
        let mut normals = Vec::new();
        self.vertex_normals_into(&mut normals);
        normals
    }

    /// [`Surface::vertex_normals`] into a reused buffer.
    pub fn vertex_normals_into(&self, normals: &mut Vec<DVec3>) {
        normals.clear();
        normals.resize(self.positions.len(), DVec3::ZERO);
        for (_, tri) in self.triangles() {
            self.add_triangle_normal(tri, normals);
        }
        normals
            .par_iter_mut()
            .for_each(|n| *n = n.normalize_or_zero());
    }

    /// [`Surface::vertex_normals`] of the front's moving vertices, into a buffer by slot
    /// reused from step to step; the entries of other vertices are meaningless, and only
    /// those the front reaches are written, so the work follows the moving front.
    pub(crate) fn front_vertex_normals_into(&self, front: &Front, normals: &mut Vec<DVec3>) {
        normals.resize(self.positions.len(), DVec3::ZERO);
        for v in front.reached_vertices(self) {
            normals[v as usize] = DVec3::ZERO;
        }
        for &t in &front.triangles {
            self.add_triangle_normal(self.triangles[t as usize], normals);
        }
        for &v in &front.vertices {
            normals[v as usize] = normals[v as usize].normalize_or_zero();
        }
    }

    fn add_triangle_normal(&self, tri: [u32; 3], normals: &mut [DVec3]) {
        let [a, b, c] = tri.map(|v| self.positions[v as usize]);
        let n = (b - a).cross(c - a);
        for v in tri {
            normals[v as usize] += n;
        }
    }

    /// Unit triangle normals by slot (zero for deleted or degenerate triangles).
    pub fn triangle_normals(&self) -> Vec<DVec3> {
        (0..self.triangles.len() as u32)
            .into_par_iter()
            .map(|t| {
                self.triangle_corners(t).map_or(DVec3::ZERO, |[a, b, c]| {
                    (b - a).cross(c - a).normalize_or_zero()
                })
            })
            .collect()
    }

    /// Verifies the half-edge structure: live triangles have three distinct live corners, twins
    /// are mutual and run the opposite way, every live vertex's outgoing half-edge leaves it and
    /// its ring walks once over all its half-edges (one fan: vertex-manifold), no two edges join
    /// the same two vertices, and the live counts are right. For tests and debugging: O(n log n).
    pub fn check_invariants(&self) -> Result<()> {
        let fail = |msg: String| Err(Error::invalid_mesh(msg));
        let n = self.positions.len();
        if self.states.len() != n || self.outgoing.len() != n {
            return fail("per-vertex arrays differ in length".into());
        }
        if self.twins.len() != 3 * self.triangles.len() {
            return fail("twin array does not have three entries per triangle".into());
        }
        let mut leaving = vec![0usize; n];
        let mut edges = Vec::with_capacity(3 * self.live_triangles / 2);
        for (t, tri) in self.triangles() {
            let [a, b, c] = tri;
            if a == b || b == c || a == c {
                return fail(format!("triangle {t} {tri:?} repeats a vertex"));
            }
            for h in 3 * t..3 * t + 3 {
                let v = self.origin(h);
                if !self.is_vertex_live(v) {
                    return fail(format!("triangle {t} uses deleted vertex {v}"));
                }
                leaving[v as usize] += 1;
                let g = self.twins[h as usize];
                if g == NONE || !self.is_triangle_live(g / 3) || self.twins[g as usize] != h {
                    return fail(format!("half-edge {h} has no mutual twin (twin {g})"));
                }
                if self.origin(g) != self.dest(h) || self.dest(g) != self.origin(h) {
                    return fail(format!(
                        "half-edge {h} and its twin {g} do not run opposite"
                    ));
                }
                if h < g {
                    edges.push((v.min(self.dest(h)), v.max(self.dest(h))));
                }
            }
        }
        edges.sort_unstable();
        if let Some(w) = edges.windows(2).find(|w| w[0] == w[1]) {
            return fail(format!("two edges join vertices {} and {}", w[0].0, w[0].1));
        }
        for (t, tri) in self.triangles.iter().enumerate() {
            let twins_dead = self.twins[3 * t..3 * t + 3].iter().all(|&g| g == NONE);
            if tri[0] == NONE && (tri.iter().any(|&v| v != NONE) || !twins_dead) {
                return fail(format!("deleted triangle {t} is only partly cleared"));
            }
        }
        let mut live_vertices = 0;
        for v in 0..n as u32 {
            let h = self.outgoing[v as usize];
            if h == NONE {
                continue;
            }
            live_vertices += 1;
            if !self.is_triangle_live(h / 3) || self.origin(h) != v {
                return fail(format!(
                    "outgoing half-edge {h} of vertex {v} does not leave it"
                ));
            }
            let mut walked = 0;
            let mut g = h;
            loop {
                walked += 1;
                if walked > leaving[v as usize] {
                    return fail(format!("the ring of vertex {v} does not close"));
                }
                g = self.twins[prev(g) as usize];
                if g == h {
                    break;
                }
            }
            if walked != leaving[v as usize] || walked < 3 {
                return fail(format!(
                    "vertex {v} has {} half-edges but its ring has {walked}: not one fan of at least three",
                    leaving[v as usize]
                ));
            }
        }
        if let Some(v) = (0..n).find(|&v| self.outgoing[v] == NONE && leaving[v] > 0) {
            return fail(format!("deleted vertex {v} is still used"));
        }
        if live_vertices != self.live_vertices || self.triangles().count() != self.live_triangles {
            return fail("live vertex or triangle counts are stale".into());
        }
        Ok(())
    }

    #[inline]
    pub(in crate::balloon) fn origin(&self, h: u32) -> u32 {
        self.triangles[(h / 3) as usize][(h % 3) as usize]
    }

    #[inline]
    pub(in crate::balloon) fn dest(&self, h: u32) -> u32 {
        self.origin(next(h))
    }

    /// The corner of `h`'s triangle that is not on `h`.
    #[inline]
    pub(in crate::balloon) fn opposite(&self, h: u32) -> u32 {
        self.origin(prev(h))
    }

    /// Whether `h` is the live half-edge that stands for its undirected edge (the smaller id of
    /// the twin pair).
    #[inline]
    pub(in crate::balloon) fn represents_edge(&self, h: u32) -> bool {
        let g = self.twins[h as usize];
        g != NONE && h < g
    }

    /// The half-edge of the twin pair of the live half-edge `h` that stands for their edge.
    #[inline]
    pub(in crate::balloon) fn edge_representative(&self, h: u32) -> u32 {
        h.min(self.twins[h as usize])
    }

    /// The half-edges leaving `v`, counter-clockwise seen from outside.
    pub(in crate::balloon) fn outgoing_half_edges(&self, v: u32) -> OutgoingHalfEdges<'_> {
        let start = self.outgoing.get(v as usize).copied().unwrap_or(NONE);
        OutgoingHalfEdges {
            surface: self,
            start,
            current: start,
        }
    }

    /// The half-edge `a → b`, if `a` and `b` are adjacent.
    pub(in crate::balloon) fn half_edge(&self, a: u32, b: u32) -> Option<u32> {
        self.outgoing_half_edges(a).find(|&h| self.dest(h) == b)
    }
}

/// Walks around a vertex: from `v → b` in `(v, b, c)`, the previous half-edge `c → v` has the
/// twin `v → c`, the next one counter-clockwise.
pub(in crate::balloon) struct OutgoingHalfEdges<'a> {
    surface: &'a Surface,
    start: u32,
    current: u32,
}

impl Iterator for OutgoingHalfEdges<'_> {
    type Item = u32;

    fn next(&mut self) -> Option<u32> {
        if self.current == NONE {
            return None;
        }
        let h = self.current;
        let following = self.surface.twins[prev(h) as usize];
        self.current = if following == self.start {
            NONE
        } else {
            following
        };
        Some(h)
    }
}

#[cfg(test)]
pub(in crate::balloon) mod tests {
    use super::*;
    use crate::mesh::test_shapes::{cube, icosphere, torus};
    use crate::mesh_checks::check;

    /// Invariants hold and the exported mesh is a closed oriented manifold of Euler
    /// characteristic `euler`.
    pub(in crate::balloon) fn assert_valid(s: &Surface, euler: i64) {
        s.check_invariants().unwrap();
        let r = check(&s.to_mesh().unwrap());
        assert!(
            r.closed() && r.manifold() && r.consistently_oriented(),
            "{r:?}"
        );
        assert_eq!(r.euler_characteristic, euler, "{r:?}");
        assert_eq!(r.vertices, s.vertex_count());
        assert_eq!(r.triangles, s.triangle_count());
        assert_eq!(r.edges, s.edge_count());
    }

    #[test]
    fn icosphere_has_the_geodesic_counts_and_points_outward() {
        for s in 0..3 {
            let surface = Surface::icosphere(DVec3::new(1.0, 2.0, 3.0), 2.0, s).unwrap();
            assert_eq!(surface.vertex_count(), 10 * 4usize.pow(s) + 2);
            assert_eq!(surface.triangle_count(), 20 * 4usize.pow(s));
            assert_valid(&surface, 2);
            assert!(surface.to_mesh().unwrap().signed_volume() > 0.0);
            for v in surface.live_vertices() {
                let d = surface.positions()[v as usize] - DVec3::new(1.0, 2.0, 3.0);
                assert!((d.length() - 2.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn icosphere_rejects_bad_parameters() {
        assert!(Surface::icosphere(DVec3::ZERO, 0.0, 1).is_err());
        assert!(Surface::icosphere(DVec3::ZERO, f64::NAN, 1).is_err());
        assert!(Surface::icosphere(DVec3::splat(f64::INFINITY), 1.0, 1).is_err());
        let e = Surface::icosphere(DVec3::ZERO, 1.0, 30).unwrap_err();
        assert!(e.message().contains("at most"), "{e}");
    }

    #[test]
    fn mesh_round_trip_keeps_numbering() {
        let m = icosphere(DVec3::ZERO, 1.0, 2);
        let s = Surface::from_mesh(&m).unwrap();
        assert_valid(&s, 2);
        assert_eq!(s.to_mesh().unwrap(), m);
    }

    #[test]
    fn from_mesh_rejects_open_and_non_manifold_meshes_saying_why() {
        let (points, mut tris) = cube(DVec3::ZERO, DVec3::ONE).into_parts();
        tris.pop();
        let e = Surface::from_mesh(&TriMesh::new(points.clone(), tris).unwrap()).unwrap_err();
        assert!(
            e.message().contains("3 edges have one triangle only"),
            "{e}"
        );

        let (_, mut tris) = cube(DVec3::ZERO, DVec3::ONE).into_parts();
        tris[3].swap(1, 2);
        let e = Surface::from_mesh(&TriMesh::new(points.clone(), tris).unwrap()).unwrap_err();
        assert!(e.message().contains("orient"), "{e}");

        let fin = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, -DVec3::Y];
        let e =
            Surface::from_mesh(&TriMesh::new(fin, vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]).unwrap())
                .unwrap_err();
        assert!(e.message().contains("non-manifold edges"), "{e}");

        // Two cubes glued at one corner: closed and edge-manifold, but the corner has two fans.
        let (mut pts, mut tris) = cube(DVec3::ZERO, DVec3::ONE).into_parts();
        let b = cube(DVec3::ONE, DVec3::splat(2.0));
        let offset = pts.len() as u32;
        pts.extend_from_slice(&b.points()[1..]);
        tris.extend(
            b.triangles()
                .iter()
                .map(|t| t.map(|v| if v == 0 { 6 } else { v - 1 + offset })),
        );
        let e = Surface::from_mesh(&TriMesh::new(pts, tris).unwrap()).unwrap_err();
        assert!(e.message().contains("non-manifold vertices"), "{e}");

        let (mut pts, tris) = cube(DVec3::ZERO, DVec3::ONE).into_parts();
        pts.push(DVec3::splat(5.0));
        let e = Surface::from_mesh(&TriMesh::new(pts, tris).unwrap()).unwrap_err();
        assert!(
            e.message().contains("1 points are used by no triangle"),
            "{e}"
        );

        let e = Surface::from_mesh(&TriMesh::default()).unwrap_err();
        assert!(e.message().contains("no triangles"), "{e}");
    }

    #[test]
    fn torus_is_accepted_with_euler_characteristic_zero() {
        let s = Surface::from_mesh(&torus(DVec3::ZERO, 3.0, 1.0, 12, 8)).unwrap();
        assert_valid(&s, 0);
        assert!(s.live_vertices().all(|v| s.valence(v) == 6));
    }

    #[test]
    fn ring_is_counter_clockwise_seen_from_outside() {
        let s = Surface::icosphere(DVec3::ZERO, 1.0, 1).unwrap();
        for v in s.live_vertices() {
            let p = s.positions()[v as usize];
            let ring: Vec<u32> = s.neighbours(v).collect();
            assert!(ring.len() == 5 || ring.len() == 6);
            for (i, &b) in ring.iter().enumerate() {
                let c = ring[(i + 1) % ring.len()];
                let n = (s.positions()[b as usize] - p).cross(s.positions()[c as usize] - p);
                assert!(n.dot(p) > 0.0, "ring of {v} turns clockwise at {b}, {c}");
            }
        }
    }

    #[test]
    fn edges_are_listed_once_with_their_opposite_vertices() {
        let s = Surface::from_mesh(&cube(DVec3::ZERO, DVec3::ONE)).unwrap();
        let edges: Vec<Edge> = s.edges().collect();
        assert_eq!(edges.len(), 18);
        let tris: Vec<[u32; 3]> = s.triangles().map(|(_, t)| t).collect();
        let has = |t: [u32; 3]| {
            tris.iter()
                .any(|&u| u == t || u == [t[1], t[2], t[0]] || u == [t[2], t[0], t[1]])
        };
        for e in edges {
            assert!(has([e.a, e.b, e.c]) && has([e.b, e.a, e.d]), "{e:?}");
        }
    }

    #[test]
    fn normals_point_outward_on_a_sphere_and_ignore_thread_count() {
        let s = Surface::icosphere(DVec3::ONE, 3.0, 3).unwrap();
        let normals = s.vertex_normals();
        for v in s.live_vertices() {
            let radial = (s.positions()[v as usize] - DVec3::ONE).normalize();
            assert!(normals[v as usize].dot(radial) > 0.999);
        }
        for (t, n) in s.triangle_normals().iter().enumerate() {
            let [a, b, c] = s.triangle_corners(t as u32).unwrap();
            assert!(n.dot((a + b + c) / 3.0 - DVec3::ONE) > 0.0);
        }
        let pool = |k| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(k)
                .build()
                .unwrap()
        };
        let one = pool(1).install(|| s.vertex_normals());
        let two = pool(2).install(|| s.vertex_normals());
        assert_eq!(one, two);
        assert_eq!(one, normals);
    }

    #[test]
    fn invariant_check_catches_a_broken_twin() {
        let mut s = Surface::icosphere(DVec3::ZERO, 1.0, 0).unwrap();
        s.twins.swap(0, 1);
        assert!(s.check_invariants().is_err());
    }
}
