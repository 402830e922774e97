//! Remeshing of the balloon while it grows (paper, section 2, Figure 1.b; docs/method.md, step 1):
//! longest-edge-first midpoint splits, shortest-edge-first collapses guarded by the link
//! condition (Dey, Edelsbrunner et al., "Topology preserving edge contraction", 1999) and by
//! geometric checks, and valence-improving edge flips (as in Botsch & Kobbelt's isotropic
//! remeshing, 2004).
//!
//! Each pass collects the candidate edges in one scan and sorts them; edges that appear during
//! the pass go into a binary heap merged with that order. Entries name an edge by its two
//! vertices (non-negative floats order like their bit patterns, so squared lengths are keyed by
//! their bits) and are validated lazily when popped, so every operation costs O(valence) plus a
//! heap operation. Ties are broken by vertex ids: the result depends only on the input.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};
use std::fmt;

use glam::DVec3;
use rayon::prelude::*;

use crate::balloon::fast_hash::FastHash;
use crate::balloon::surface::front::Front;
use crate::balloon::surface::{next, prev, Surface, VertexState, MAX_TRIANGLES, NONE};
use crate::error::{Error, Result};

/// A triangle is degenerate when its height is below this fraction of its longest edge.
const DEGENERATE_SHAPE: f64 = 1e-6;

/// Why an edge collapse was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(in crate::balloon) enum Refusal {
    /// The endpoints are frozen in different states (border and self-intersection).
    FrozenStates,
    /// The endpoints share a neighbour other than the two opposite vertices: collapsing would
    /// pinch the surface (non-manifold edge or vertex).
    LinkCondition,
    /// A vertex would be left with fewer than three neighbours (the component is a tetrahedron).
    Valence,
    /// A neighbouring edge would become longer than the maximum edge length.
    TooLong,
    /// A neighbouring triangle would turn by more than 90° or become degenerate.
    Fold,
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Refusal::FrozenStates => "its ends are frozen for different reasons",
            Refusal::LinkCondition => {
                "its ends share a neighbour besides the two opposite vertices (link condition)"
            }
            Refusal::Valence => "a vertex would keep fewer than three neighbours (tetrahedron)",
            Refusal::TooLong => "a neighbouring edge would exceed the maximum edge length",
            Refusal::Fold => "a neighbouring triangle would flip over or degenerate",
        })
    }
}

/// An edge waiting in a pass: `order` first, then the vertex ids `a < b`; `hint` is a
/// half-edge that joined them when the entry was made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct Candidate {
    order: u64,
    a: u32,
    b: u32,
    hint: u32,
}

/// Candidates smallest first: the initial ones sorted once, those found during the pass in a
/// binary heap. (Popping a sorted array is cache-friendly; popping a 100k-entry heap is not.)
/// Entries are never removed early: they are checked against the mesh when popped.
struct EdgeQueue {
    /// Largest first, so that the smallest pops off the end.
    sorted: Vec<Candidate>,
    heap: BinaryHeap<Reverse<Candidate>>,
}

impl EdgeQueue {
    fn new(mut initial: Vec<Candidate>) -> Self {
        initial.par_sort_unstable_by(|x, y| y.cmp(x));
        EdgeQueue {
            sorted: initial,
            heap: BinaryHeap::new(),
        }
    }

    fn pop(&mut self) -> Option<Candidate> {
        match (self.sorted.last(), self.heap.peek()) {
            (Some(first), Some(Reverse(found))) if found < first => self.heap.pop().map(|r| r.0),
            (Some(_), _) => self.sorted.pop(),
            (None, _) => self.heap.pop().map(|r| r.0),
        }
    }
}

impl Extend<Candidate> for EdgeQueue {
    fn extend<I: IntoIterator<Item = Candidate>>(&mut self, candidates: I) {
        self.heap.extend(candidates.into_iter().map(Reverse));
    }
}

/// Scratch space for collapse checks: the fans of the kept and the removed vertex.
#[derive(Default)]
struct Fans {
    keep: Vec<[u32; 2]>,
    remove: Vec<[u32; 2]>,
}

/// Whether the triangle `(p, q, r)` has turned by 90° or more from the normal `old`, or is
/// degenerate. NaN coordinates count as folded.
fn folds(old: DVec3, p: DVec3, q: DVec3, r: DVec3) -> bool {
    let new = (q - p).cross(r - p);
    let longest2 = p
        .distance_squared(q)
        .max(q.distance_squared(r))
        .max(r.distance_squared(p));
    !(new.dot(old) > 0.0 && new.length_squared() > (DEGENERATE_SHAPE * longest2).powi(2))
}

impl Surface {
    /// Splits every edge of the moving front (`Front`: the edges with a moving end or
    /// opposite vertex; frozen parts keep their triangles) longer than `max_length` at its
    /// midpoint, longest first, until none is longer, and with them the long edges of the
    /// triangles the splits touch (Rivara's longest-edge bisection terminates because each
    /// split halves an edge). Both triangles of a split edge become two. The new vertex is
    /// appended and is `Moving` unless both ends are frozen; then it takes the later of their
    /// states in [`VertexState`] order (self-intersection wins over border), because a point
    /// between two frozen vertices lies where they stopped. Returns the number of splits
    /// (= new vertices).
    pub fn split_long_edges(&mut self, max_length: f64) -> Result<usize> {
        if !(max_length.is_finite() && max_length > 0.0) {
            return Err(Error::invalid_argument(format!(
                "maximum edge length {max_length} must be positive and finite"
            )));
        }
        self.require_finite_positions()?;
        let max2 = max_length * max_length;
        // Complemented bits put the longest edge first.
        let select = |length2: f64| (length2 > max2).then(|| !length2.to_bits());
        let mut queue = EdgeQueue::new(self.edge_candidates(&select));
        let mut splits = 0;
        while let Some(candidate) = queue.pop() {
            // Positions do not move during the pass, so an edge that still exists is still
            // as long as when it was queued.
            let Some(h) = self.resolve(candidate) else {
                continue;
            };
            let m = self.split_half_edge(h)?;
            splits += 1;
            // Every edge of the four triangles around `m`, also those outside the front: a
            // long edge next to a split must be split too, or bisecting its neighbours would
            // go on making slivers against it (longest-edge bisection ends because each
            // triangle's longest edge is split).
            for h in self.outgoing_half_edges(m) {
                queue.extend(self.candidate(h, &select));
                queue.extend(self.candidate(next(h), &select));
            }
        }
        Ok(splits)
    }

    /// Splits the edge `a–b` at its midpoint (see [`Surface::split_long_edges`] for the state
    /// of the new vertex) and returns the new vertex.
    pub fn split_edge(&mut self, a: u32, b: u32) -> Result<u32> {
        let h = self.half_edge(a, b).ok_or_else(|| {
            Error::invalid_argument(format!("vertices {a} and {b} are not joined by an edge"))
        })?;
        self.split_half_edge(h)
    }

    /// Collapses edges of the moving front shorter than `min_length`, shortest first, each
    /// into one vertex, when the result stays a closed 2-manifold that is geometrically sound:
    /// - the ends' common neighbours are exactly the two opposite vertices (link condition),
    ///   and no vertex keeps fewer than three neighbours (so a tetrahedron is never collapsed);
    /// - no remaining triangle around the edge turns by 90° or more or becomes degenerate;
    /// - no edge whose length changes becomes longer than `max_length`.
    ///
    /// Where the merged vertex goes follows the freeze states: two `Moving` ends merge at the
    /// midpoint; a frozen end stays where it is and absorbs the moving one; two ends frozen for
    /// the same reason merge at the midpoint and stay frozen; ends frozen for different reasons
    /// are never merged. The merged vertex keeps the smaller id (or the frozen end's id); the
    /// other vertex and the edge's two triangles become tombstones. An edge refused now is
    /// retried in the same pass only when a collapse next to it changes its length. Returns
    /// the number of collapses (= removed vertices).
    pub fn collapse_short_edges(&mut self, min_length: f64, max_length: f64) -> Result<usize> {
        if !(min_length.is_finite() && max_length.is_finite() && 0.0 <= min_length)
            || min_length > max_length
        {
            return Err(Error::invalid_argument(format!(
                "edge lengths must satisfy 0 <= minimum ({min_length}) <= maximum ({max_length}) \
                 and be finite"
            )));
        }
        self.require_finite_positions()?;
        let min2 = min_length * min_length;
        let select = |length2: f64| (length2 < min2).then(|| length2.to_bits());
        let mut queue = EdgeQueue::new(self.edge_candidates(&select));
        let mut fans = Fans::default();
        let mut collapses = 0;
        while let Some(candidate) = queue.pop() {
            let Some(h) = self.resolve(candidate) else {
                continue;
            };
            let (pa, pb) = (
                self.positions[candidate.a as usize],
                self.positions[candidate.b as usize],
            );
            if pa.distance_squared(pb).to_bits() != candidate.order {
                continue;
            }
            let Ok(kept) = self.try_collapse(h, max_length, &mut fans) else {
                continue;
            };
            collapses += 1;
            for h in self.outgoing_half_edges(kept) {
                queue.extend(self.candidate(h, &select));
            }
        }
        Ok(collapses)
    }

    /// Collapses the edge `a–b` under the rules of [`Surface::collapse_short_edges`] and
    /// returns the merged vertex, or says why it may not be collapsed.
    pub fn collapse_edge(&mut self, a: u32, b: u32, max_length: f64) -> Result<u32> {
        let h = self.half_edge(a, b).ok_or_else(|| {
            Error::invalid_argument(format!("vertices {a} and {b} are not joined by an edge"))
        })?;
        self.try_collapse(h, max_length, &mut Fans::default())
            .map_err(|why| {
                Error::invalid_argument(format!("edge {a}–{b} cannot be collapsed: {why}"))
            })
    }

    /// One pass over the moving front's edges in slot order, flipping each edge whose flip
    /// brings the valences of its four vertices closer to 6 (sum of squared deviations strictly
    /// decreases), as long as the two new triangles are not degenerate and both stay within
    /// 90° of both old ones, the new diagonal is not already an edge and no vertex drops below
    /// three neighbours. Edges whose four vertices are all frozen are left as they are. Flips
    /// keep every vertex but change triangle corners. Returns the number of flips.
    pub fn flip_edges_for_valence(&mut self) -> usize {
        let front = Front::of(self);
        // Valences of the quads' corners, counted when first needed and kept up to date.
        let mut valence: HashMap<u32, i64, FastHash> = HashMap::default();
        let mut flips = 0;
        for h in front.edges {
            // An earlier flip may have put another edge in this slot, standing for it or not,
            // and with a wholly frozen quad (skipped below).
            if !self.represents_edge(h) {
                continue;
            }
            let g = self.twins[h as usize];
            let quad = [
                self.origin(h),
                self.dest(h),
                self.opposite(h),
                self.opposite(g),
            ];
            // Frozen parts of the balloon keep their triangles: they no longer move.
            if quad.iter().all(|&v| self.states[v as usize].is_frozen()) {
                continue;
            }
            let counts = quad.map(|v| *valence.entry(v).or_insert_with(|| self.valence(v) as i64));
            let deviation = |shift: [i64; 4]| -> i64 {
                counts
                    .iter()
                    .zip(shift)
                    .map(|(&n, s)| (n + s - 6).pow(2))
                    .sum()
            };
            if deviation([-1, -1, 1, 1]) >= deviation([0; 4])
                || counts[0] <= 3
                || counts[1] <= 3
                || self.half_edge(quad[2], quad[3]).is_some()
                || !self.flip_keeps_shape(quad)
            {
                continue;
            }
            self.flip_half_edge(h);
            for (v, shift) in quad.into_iter().zip([-1, -1, 1, 1]) {
                *valence.get_mut(&v).expect("counted above") += shift;
            }
            flips += 1;
        }
        flips
    }

    /// The queue entry for the edge of `h`, if `select` takes its squared length.
    fn candidate(&self, h: u32, select: &impl Fn(f64) -> Option<u64>) -> Option<Candidate> {
        let (a, b) = (self.origin(h), self.dest(h));
        let length2 = self.positions[a as usize].distance_squared(self.positions[b as usize]);
        select(length2).map(|order| Candidate {
            order,
            a: a.min(b),
            b: a.max(b),
            hint: h,
        })
    }

    /// The entries of the moving front's edges that `select` takes, in half-edge order. The
    /// edges of the frozen rest no longer change length.
    fn edge_candidates(&self, select: &(impl Fn(f64) -> Option<u64> + Sync)) -> Vec<Candidate> {
        Front::of(self)
            .edges
            .into_par_iter()
            .filter_map(|h| self.candidate(h, select))
            .collect()
    }

    /// The half-edge `a → b` of a queued edge, if the edge still exists. Its hint is checked
    /// first: a ring walk is the expensive part of a stale entry.
    fn resolve(&self, c: Candidate) -> Option<u32> {
        if self.is_triangle_live(c.hint / 3) {
            let ends = (self.origin(c.hint), self.dest(c.hint));
            if ends == (c.a, c.b) {
                return Some(c.hint);
            }
            if ends == (c.b, c.a) {
                return Some(self.twins[c.hint as usize]);
            }
        }
        self.half_edge(c.a, c.b)
    }

    fn require_finite_positions(&self) -> Result<()> {
        match self
            .live_vertices()
            .find(|&v| !self.positions[v as usize].is_finite())
        {
            Some(v) => Err(Error::invalid_argument(format!(
                "vertex {v} is at {:?}; remeshing needs finite positions",
                self.positions[v as usize]
            ))),
            None => Ok(()),
        }
    }

    /// Makes `twin` of each other.
    fn link(&mut self, h: u32, g: u32) {
        self.twins[h as usize] = g;
        self.twins[g as usize] = h;
    }

    /// Splits the edge of `h = a → b` at its midpoint `m`: `(a, b, c)` becomes `(a, m, c)` and
    /// `(m, b, c)`, `(b, a, d)` becomes `(b, m, d)` and `(m, a, d)`.
    fn split_half_edge(&mut self, h: u32) -> Result<u32> {
        if self.triangles.len() + 2 > MAX_TRIANGLES {
            return Err(Error::invalid_argument(format!(
                "splitting would exceed the surface's limit of {MAX_TRIANGLES} triangles"
            )));
        }
        let g = self.twins[h as usize];
        let (a, b, c, d) = (
            self.origin(h),
            self.dest(h),
            self.opposite(h),
            self.opposite(g),
        );
        let outer = [next(h), prev(h), next(g), prev(g)].map(|e| self.twins[e as usize]);
        let [x_bc, x_ca, x_ad, x_db] = outer;
        let (sa, sb) = (self.states[a as usize], self.states[b as usize]);
        let state = if sa.is_frozen() && sb.is_frozen() {
            sa.max(sb)
        } else {
            VertexState::Moving
        };
        let m = self.positions.len() as u32;
        self.positions
            .push(0.5 * (self.positions[a as usize] + self.positions[b as usize]));
        self.states.push(state);
        self.outgoing.push(NONE);
        let (t0, t1) = (h / 3, g / 3);
        let t2 = self.triangles.len() as u32;
        let t3 = t2 + 1;
        self.triangles[t0 as usize] = [a, m, c];
        self.triangles[t1 as usize] = [b, m, d];
        self.triangles.extend([[m, b, c], [m, a, d]]);
        self.twins.extend([NONE; 6]);
        let he = |t: u32, i: u32| 3 * t + i;
        self.link(he(t0, 0), he(t3, 0));
        self.link(he(t0, 1), he(t2, 2));
        self.link(he(t0, 2), x_ca);
        self.link(he(t2, 0), he(t1, 0));
        self.link(he(t2, 1), x_bc);
        self.link(he(t1, 1), he(t3, 2));
        self.link(he(t1, 2), x_db);
        self.link(he(t3, 1), x_ad);
        // Every corner of the two rewritten triangles may have pointed at a half-edge whose
        // slot now holds another edge.
        for (v, e) in [
            (a, he(t0, 0)),
            (b, he(t1, 0)),
            (c, he(t0, 2)),
            (d, he(t1, 2)),
        ] {
            self.outgoing[v as usize] = e;
        }
        self.outgoing[m as usize] = he(t0, 1);
        self.live_vertices += 1;
        self.live_triangles += 2;
        for t in [t0, t1, t2, t3] {
            self.note_rewritten(t);
        }
        Ok(m)
    }

    /// The triangles `(v, w1, w2)` around `v` as `[w1, w2]`, counter-clockwise.
    fn fan(&self, v: u32, fan: &mut Vec<[u32; 2]>) {
        fan.clear();
        fan.extend(
            self.outgoing_half_edges(v)
                .map(|h| [self.dest(h), self.opposite(h)]),
        );
    }

    /// Checks and performs the collapse of the edge of `h`. Each end's fan is walked once
    /// into `fans`: ring walks are the cost of a collapse, and most attempts are refused.
    fn try_collapse(&mut self, h: u32, max_length: f64, fans: &mut Fans) -> Result<u32, Refusal> {
        let (a, b) = (self.origin(h), self.dest(h));
        let (sa, sb) = (self.states[a as usize], self.states[b as usize]);
        let (pa, pb) = (self.positions[a as usize], self.positions[b as usize]);
        let midpoint = 0.5 * (pa + pb);
        let (keep, target) = match (sa.is_frozen(), sb.is_frozen()) {
            (true, false) => (a, pa),
            (false, true) => (b, pb),
            _ if sa == sb => (a.min(b), midpoint),
            _ => return Err(Refusal::FrozenStates),
        };
        let hk = if keep == a { h } else { self.twins[h as usize] };
        let remove = self.dest(hk);
        let (c, d) = (self.opposite(hk), self.opposite(self.twins[hk as usize]));

        self.fan(keep, &mut fans.keep);
        self.fan(remove, &mut fans.remove);
        let shared = |w: u32| fans.keep.iter().any(|&[u, _]| u == w);
        if fans
            .remove
            .iter()
            .any(|&[w, _]| w != keep && w != c && w != d && shared(w))
        {
            return Err(Refusal::LinkCondition);
        }
        // The link condition holds on a tetrahedron too; elsewhere it already keeps every
        // other vertex at three neighbours or more.
        if fans.keep.len() + fans.remove.len() < 7 {
            return Err(Refusal::Valence);
        }
        self.check_fan(keep, remove, target, max_length, &fans.keep)?;
        self.check_fan(remove, keep, target, max_length, &fans.remove)?;

        self.collapse_half_edge(hk);
        self.positions[keep as usize] = target;
        self.states[keep as usize] = sa.max(sb);
        // The triangles that were the removed vertex's now have `keep`, and `keep` may have
        // moved: its whole fan changed.
        if self.rewritten.is_some() {
            let fan: Vec<u32> = self.outgoing_half_edges(keep).map(|h| h / 3).collect();
            for t in fan {
                self.note_rewritten(t);
            }
        }
        Ok(keep)
    }

    /// Whether moving `v` to `target` keeps the triangles of its `fan` that do not contain
    /// `other` unfolded and the edges whose length changes within `max_length`.
    fn check_fan(
        &self,
        v: u32,
        other: u32,
        target: DVec3,
        max_length: f64,
        fan: &[[u32; 2]],
    ) -> Result<(), Refusal> {
        let p = self.positions[v as usize];
        let moves = p != target;
        for &[w1, w2] in fan {
            if w1 == other {
                continue;
            }
            let (q1, q2) = (self.positions[w1 as usize], self.positions[w2 as usize]);
            if moves && target.distance_squared(q1) > max_length * max_length {
                return Err(Refusal::TooLong);
            }
            if w2 != other && folds((q1 - p).cross(q2 - p), target, q1, q2) {
                return Err(Refusal::Fold);
            }
        }
        Ok(())
    }

    /// Removes `remove = dest(hk)` by merging it into `keep = origin(hk)`, with the two
    /// triangles `(keep, remove, c)` and `(remove, keep, d)`; positions are left to the caller.
    fn collapse_half_edge(&mut self, hk: u32) {
        let gk = self.twins[hk as usize];
        let (keep, remove) = (self.origin(hk), self.dest(hk));
        let (c, d) = (self.opposite(hk), self.opposite(gk));
        let [c_to_remove, keep_to_c, d_to_keep, remove_to_d] =
            [next(hk), prev(hk), next(gk), prev(gk)].map(|e| self.twins[e as usize]);

        // The walk around `remove` reads only twins, so its corners can be relabelled on the way.
        let start = self.outgoing[remove as usize];
        let mut e = start;
        loop {
            self.triangles[(e / 3) as usize][(e % 3) as usize] = keep;
            e = self.twins[prev(e) as usize];
            if e == start {
                break;
            }
        }
        self.link(c_to_remove, keep_to_c);
        self.link(d_to_keep, remove_to_d);
        for t in [hk / 3, gk / 3] {
            self.triangles[t as usize] = [NONE; 3];
            self.twins[3 * t as usize..3 * t as usize + 3].fill(NONE);
        }
        self.outgoing[keep as usize] = keep_to_c;
        self.outgoing[c as usize] = c_to_remove;
        self.outgoing[d as usize] = d_to_keep;
        self.outgoing[remove as usize] = NONE;
        self.live_vertices -= 1;
        self.live_triangles -= 2;
    }

    /// Whether replacing `(a, b, c)` and `(b, a, d)` by `(c, a, d)` and `(d, b, c)` keeps
    /// both new triangles non-degenerate and within 90° of both old ones.
    fn flip_keeps_shape(&self, quad: [u32; 4]) -> bool {
        let [pa, pb, pc, pd] = quad.map(|v| self.positions[v as usize]);
        let old = [(pb - pa).cross(pc - pa), (pa - pb).cross(pd - pb)];
        old.iter()
            .all(|&n| !folds(n, pc, pa, pd) && !folds(n, pd, pb, pc))
    }

    /// Replaces the edge of `h = a → b`, with triangles `(a, b, c)` and `(b, a, d)`, by `c–d`.
    fn flip_half_edge(&mut self, h: u32) {
        let g = self.twins[h as usize];
        let (a, b, c, d) = (
            self.origin(h),
            self.dest(h),
            self.opposite(h),
            self.opposite(g),
        );
        let [x_bc, x_ca, x_ad, x_db] =
            [next(h), prev(h), next(g), prev(g)].map(|e| self.twins[e as usize]);
        let (t0, t1) = (h / 3, g / 3);
        self.triangles[t0 as usize] = [c, a, d];
        self.triangles[t1 as usize] = [d, b, c];
        self.link(3 * t0, x_ca);
        self.link(3 * t0 + 1, x_ad);
        self.link(3 * t0 + 2, 3 * t1 + 2);
        self.link(3 * t1, x_db);
        self.link(3 * t1 + 1, x_bc);
        for (v, e) in [(a, 3 * t0 + 1), (b, 3 * t1 + 1), (c, 3 * t0), (d, 3 * t1)] {
            self.outgoing[v as usize] = e;
        }
        self.note_rewritten(t0);
        self.note_rewritten(t1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::balloon::surface::tests::assert_valid;
    use crate::mesh::test_shapes::torus;
    use crate::mesh::TriMesh;
    use crate::mesh_checks::check;
    use glam::{DMat3, EulerRot};
    use proptest::prelude::*;
    use std::f64::consts::TAU;

    /// splitmix64: a seeded, dependency-free source of test randomness.
    struct Rng(u64);

    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        }

        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }

        fn below(&mut self, n: u64) -> u64 {
            self.next_u64() % n
        }
    }

    fn surface(points: &[[f64; 3]], triangles: Vec<[u32; 3]>) -> Surface {
        let points = points.iter().map(|&p| DVec3::from_array(p)).collect();
        Surface::from_mesh(&TriMesh::new(points, triangles).unwrap()).unwrap()
    }

    fn tetrahedron() -> Surface {
        surface(
            &[
                [1.0, 1.0, 1.0],
                [1.0, -1.0, -1.0],
                [-1.0, 1.0, -1.0],
                [-1.0, -1.0, 1.0],
            ],
            vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]],
        )
    }

    fn edge_lengths(s: &Surface) -> Vec<f64> {
        let p = s.positions();
        s.edges()
            .map(|e| p[e.a as usize].distance(p[e.b as usize]))
            .collect()
    }

    fn mean_edge_length(s: &Surface) -> f64 {
        let lengths = edge_lengths(s);
        lengths.iter().sum::<f64>() / lengths.len() as f64
    }

    #[test]
    fn one_split_of_an_icosahedron_edge_adds_a_vertex_two_triangles_three_edges() {
        let mut s = Surface::icosphere(DVec3::ZERO, 1.0, 0).unwrap();
        let e = s.edges().next().unwrap();
        let m = s.split_edge(e.a, e.b).unwrap();
        assert_eq!(m, 12);
        assert_eq!(
            (s.vertex_count(), s.triangle_count(), s.edge_count()),
            (13, 22, 33)
        );
        assert_valid(&s, 2);
        let p = s.positions();
        assert_eq!(p[m as usize], 0.5 * (p[e.a as usize] + p[e.b as usize]));
        let mut ring: Vec<u32> = s.neighbours(m).collect();
        ring.sort_unstable();
        let mut expected = vec![e.a, e.b, e.c, e.d];
        expected.sort_unstable();
        assert_eq!(ring, expected);
        assert!(s.split_edge(e.a, e.b).is_err(), "a–b is no longer an edge");
    }

    #[test]
    fn split_long_edges_leaves_no_edge_above_the_maximum() {
        let mut s = Surface::icosphere(DVec3::ZERO, 5.0, 0).unwrap();
        let splits = s.split_long_edges(1.0).unwrap();
        assert_eq!(s.vertex_count(), 12 + splits);
        assert_eq!(s.triangle_count(), 20 + 2 * splits);
        assert!(edge_lengths(&s).iter().all(|&l| l <= 1.0));
        assert_valid(&s, 2);
        assert_eq!(s.split_long_edges(1.0).unwrap(), 0);
        assert!(s.split_long_edges(0.0).is_err());
        s.positions_mut()[3] = DVec3::NAN;
        assert!(s.split_long_edges(1.0).is_err());
    }

    #[test]
    fn split_follows_longest_first_with_ties_by_vertex_ids() {
        // Reference: scan every edge before each split, as the rule reads.
        let mut noisy = Surface::icosphere(DVec3::ZERO, 1.0, 1).unwrap();
        let mut rng = Rng(5);
        for p in noisy.positions_mut() {
            *p *= rng.uniform(0.7, 1.6);
        }
        let max = 0.6 * mean_edge_length(&noisy);
        let mut reference = noisy.clone();
        let mut reference_splits = 0;
        loop {
            let p = reference.positions().to_vec();
            let longest = reference
                .edges()
                .map(|e| {
                    (
                        p[e.a as usize].distance_squared(p[e.b as usize]),
                        e.a.min(e.b),
                        e.a.max(e.b),
                    )
                })
                .filter(|&(l2, _, _)| l2 > max * max)
                .max_by(|x, y| x.0.total_cmp(&y.0).then((y.1, y.2).cmp(&(x.1, x.2))));
            let Some((_, a, b)) = longest else { break };
            reference.split_edge(a, b).unwrap();
            reference_splits += 1;
        }
        assert!(reference_splits > 50);
        assert_eq!(noisy.split_long_edges(max).unwrap(), reference_splits);
        assert_eq!(noisy, reference);
    }

    #[test]
    fn legal_collapse_removes_a_vertex_and_two_triangles() {
        let mut s = Surface::icosphere(DVec3::ZERO, 1.0, 0).unwrap();
        let e = s.edges().next().unwrap();
        let kept = s.collapse_edge(e.a, e.b, 10.0).unwrap();
        assert_eq!(kept, e.a.min(e.b));
        assert_eq!((s.vertex_count(), s.triangle_count()), (11, 18));
        assert!(!s.is_vertex_live(e.a.max(e.b)));
        assert_valid(&s, 2);
    }

    #[test]
    fn collapse_refuses_a_tetrahedron() {
        let mut s = tetrahedron();
        let before = s.clone();
        for e in before.edges() {
            let h = s.half_edge(e.a, e.b).unwrap();
            assert_eq!(
                s.try_collapse(h, 100.0, &mut Fans::default()),
                Err(Refusal::Valence)
            );
        }
        assert_eq!(s.collapse_short_edges(100.0, 100.0).unwrap(), 0);
        assert_eq!(s, before);
    }

    #[test]
    fn collapse_refuses_to_violate_the_link_condition() {
        // A triangular bipyramid: the equator vertices 0 and 1 share the apices 3 and 4
        // (opposite vertices) and also vertex 2.
        let h = 0.5 * 3f64.sqrt();
        let mut s = surface(
            &[
                [1.0, 0.0, 0.0],
                [-0.5, h, 0.0],
                [-0.5, -h, 0.0],
                [0.0, 0.0, 1.0],
                [0.0, 0.0, -1.0],
            ],
            vec![
                [0, 1, 3],
                [1, 2, 3],
                [2, 0, 3],
                [1, 0, 4],
                [2, 1, 4],
                [0, 2, 4],
            ],
        );
        let he = s.half_edge(0, 1).unwrap();
        assert_eq!(
            s.try_collapse(he, 100.0, &mut Fans::default()),
            Err(Refusal::LinkCondition)
        );
        let e = s.collapse_edge(0, 1, 100.0).unwrap_err();
        assert!(e.message().contains("link condition"), "{e}");
        assert_valid(&s, 2);
    }

    #[test]
    fn collapse_refuses_to_fold_a_triangle() {
        // A flat, non-convex ring 1, 2, 3, 4 around apex 0, closed below by apex 5: moving 0
        // halfway to the far vertex 1 carries it across the edge 2–3.
        let mut s = surface(
            &[
                [0.0, 0.0, 0.1],
                [4.0, 0.0, 0.0],
                [1.0, 0.1, 0.0],
                [-1.0, 0.5, 0.0],
                [1.0, -0.1, 0.0],
                [0.0, 0.0, -1.0],
            ],
            vec![
                [0, 1, 2],
                [0, 2, 3],
                [0, 3, 4],
                [0, 4, 1],
                [5, 2, 1],
                [5, 3, 2],
                [5, 4, 3],
                [5, 1, 4],
            ],
        );
        let h = s.half_edge(0, 1).unwrap();
        assert_eq!(
            s.try_collapse(h, 100.0, &mut Fans::default()),
            Err(Refusal::Fold)
        );
        assert_valid(&s, 2);
    }

    #[test]
    fn collapse_refuses_to_create_an_edge_above_the_maximum() {
        let mut s = Surface::icosphere(DVec3::ZERO, 1.0, 0).unwrap();
        let longest = edge_lengths(&s).into_iter().fold(0.0, f64::max);
        let e = s.edges().next().unwrap();
        let h = s.half_edge(e.a, e.b).unwrap();
        assert_eq!(
            s.try_collapse(h, 1.1 * longest, &mut Fans::default()),
            Err(Refusal::TooLong)
        );
        assert!(s.collapse_short_edges(2.0, 1.0).is_err());
    }

    #[test]
    fn collapse_short_edges_leaves_only_refused_short_edges() {
        let mut s = Surface::icosphere(DVec3::ZERO, 1.0, 3).unwrap();
        let min = 1.5 * mean_edge_length(&s);
        let max = 4.0 * min;
        let (v, t) = (s.vertex_count(), s.triangle_count());
        let collapses = s.collapse_short_edges(min, max).unwrap();
        assert!(collapses > 0);
        assert_eq!(s.vertex_count(), v - collapses);
        assert_eq!(s.triangle_count(), t - 2 * collapses);
        assert_valid(&s, 2);
        assert!(edge_lengths(&s).iter().all(|&l| l <= max));
        let p = s.positions().to_vec();
        for e in s.edges().collect::<Vec<_>>() {
            if p[e.a as usize].distance(p[e.b as usize]) < min {
                let mut probe = s.clone();
                let h = probe.half_edge(e.a, e.b).unwrap();
                assert!(
                    probe.try_collapse(h, max, &mut Fans::default()).is_err(),
                    "{e:?}"
                );
            }
        }
    }

    #[test]
    fn collapsing_everything_stops_at_a_valid_closed_surface() {
        let mut s = Surface::icosphere(DVec3::ZERO, 1.0, 2).unwrap();
        while s.collapse_short_edges(1e3, 1e3).unwrap() > 0 {}
        assert!(s.vertex_count() >= 4);
        assert_valid(&s, 2);
    }

    #[test]
    fn frozen_states_propagate_through_splits() {
        use VertexState::*;
        let cases = [
            (FrozenAtBorder, FrozenAtBorder, FrozenAtBorder),
            (FrozenAtBorder, Moving, Moving),
            (Moving, FrozenBySelfIntersection, Moving),
            (
                FrozenAtBorder,
                FrozenBySelfIntersection,
                FrozenBySelfIntersection,
            ),
            (
                FrozenBySelfIntersection,
                FrozenBySelfIntersection,
                FrozenBySelfIntersection,
            ),
        ];
        for (sa, sb, expected) in cases {
            let mut s = Surface::icosphere(DVec3::ZERO, 1.0, 0).unwrap();
            let e = s.edges().next().unwrap();
            s.states_mut()[e.a as usize] = sa;
            s.states_mut()[e.b as usize] = sb;
            let m = s.split_edge(e.a, e.b).unwrap();
            assert_eq!(s.states()[m as usize], expected, "{sa:?} + {sb:?}");
            assert_eq!(s.states().len(), s.vertex_slots());
        }
    }

    #[test]
    fn frozen_states_decide_where_a_collapse_goes() {
        use VertexState::*;
        let fresh = || {
            let s = Surface::icosphere(DVec3::ZERO, 1.0, 0).unwrap();
            let e = s.edges().next().unwrap();
            let (a, b) = (e.a.max(e.b), e.a.min(e.b));
            (s, a, b)
        };
        // A frozen end absorbs a moving one and keeps its place, even with the larger id.
        let (mut s, a, b) = fresh();
        s.states_mut()[a as usize] = FrozenAtBorder;
        let pa = s.positions()[a as usize];
        assert_eq!(s.collapse_edge(a, b, 10.0).unwrap(), a);
        assert_eq!(
            (s.positions()[a as usize], s.states()[a as usize]),
            (pa, FrozenAtBorder)
        );
        assert_valid(&s, 2);
        // Ends frozen alike merge at the midpoint and stay frozen.
        let (mut s, a, b) = fresh();
        s.states_mut()[a as usize] = FrozenBySelfIntersection;
        s.states_mut()[b as usize] = FrozenBySelfIntersection;
        let mid = 0.5 * (s.positions()[a as usize] + s.positions()[b as usize]);
        assert_eq!(s.collapse_edge(a, b, 10.0).unwrap(), b);
        assert_eq!(
            (s.positions()[b as usize], s.states()[b as usize]),
            (mid, FrozenBySelfIntersection)
        );
        // Ends frozen for different reasons stay apart.
        let (mut s, a, b) = fresh();
        s.states_mut()[a as usize] = FrozenAtBorder;
        s.states_mut()[b as usize] = FrozenBySelfIntersection;
        let h = s.half_edge(a, b).unwrap();
        assert_eq!(
            s.try_collapse(h, 10.0, &mut Fans::default()),
            Err(Refusal::FrozenStates)
        );
    }

    fn valence_deviation(s: &Surface) -> i64 {
        s.live_vertices()
            .map(|v| (s.valence(v) as i64 - 6).pow(2))
            .sum()
    }

    #[test]
    fn flips_improve_valence_and_keep_the_surface_valid() {
        let mut s = Surface::icosphere(DVec3::ZERO, 1.0, 2).unwrap();
        s.split_long_edges(0.7 * mean_edge_length(&s)).unwrap();
        let (before, v) = (valence_deviation(&s), s.vertex_count());
        let flips = s.flip_edges_for_valence();
        assert!(flips > 0);
        assert!(valence_deviation(&s) < before);
        assert_eq!(s.vertex_count(), v);
        assert_valid(&s, 2);
        assert!(s.to_mesh().unwrap().signed_volume() > 0.0);
    }

    /// Random scaling, noise, freezing and remeshing, checking the surface after every step.
    /// Returns the final surface.
    fn random_session(seed: u64, mut s: Surface, euler: i64) -> Surface {
        let mut rng = Rng(seed);
        let target = mean_edge_length(&s);
        let (max, min) = (4.0 / 3.0 * target, 0.8 * target);
        for _ in 0..40 {
            let (v, t) = (s.vertex_count(), s.triangle_count());
            match rng.below(6) {
                0 => {
                    let f = rng.uniform(0.8, 1.3);
                    s.positions_mut().iter_mut().for_each(|p| *p *= f);
                }
                1 => {
                    let amplitude = 0.15 * target;
                    for p in s.positions_mut() {
                        *p += DVec3::new(
                            rng.uniform(-amplitude, amplitude),
                            rng.uniform(-amplitude, amplitude),
                            rng.uniform(-amplitude, amplitude),
                        );
                    }
                }
                2 => {
                    let n = s.split_long_edges(max).unwrap();
                    assert_eq!((s.vertex_count(), s.triangle_count()), (v + n, t + 2 * n));
                }
                3 => {
                    let n = s.collapse_short_edges(min, max).unwrap();
                    assert_eq!((s.vertex_count(), s.triangle_count()), (v - n, t - 2 * n));
                }
                4 => {
                    s.flip_edges_for_valence();
                }
                _ => {
                    for _ in 0..s.vertex_count() / 10 {
                        let v = rng.below(s.vertex_slots() as u64) as usize;
                        s.states_mut()[v] = match rng.below(3) {
                            0 => VertexState::Moving,
                            1 => VertexState::FrozenAtBorder,
                            _ => VertexState::FrozenBySelfIntersection,
                        };
                    }
                }
            }
            assert_valid(&s, euler);
            assert_eq!(s.states().len(), s.vertex_slots());
        }
        s
    }

    #[test]
    fn random_remeshing_keeps_a_sphere_closed_manifold_and_oriented() {
        for seed in 0..4 {
            random_session(seed, Surface::icosphere(DVec3::ZERO, 1.0, 2).unwrap(), 2);
        }
    }

    #[test]
    fn random_remeshing_keeps_a_torus_of_genus_one() {
        for seed in 10..13 {
            random_session(
                seed,
                Surface::from_mesh(&torus(DVec3::ZERO, 3.0, 1.0, 16, 8)).unwrap(),
                0,
            );
        }
        let mut s = Surface::from_mesh(&torus(DVec3::ZERO, 3.0, 1.0, 16, 8)).unwrap();
        s.split_long_edges(0.5).unwrap();
        while s.collapse_short_edges(1e3, 1e3).unwrap() > 0 {}
        assert_valid(&s, 0);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]

        /// One remeshing step as inflation takes it (splits above `split`, collapses below
        /// `collapse · split`, valence flips), with any lengths, on a sphere or a torus that is
        /// stretched along random axes (edges of very different lengths), jittered by up to
        /// `jitter` mean edge lengths and partly frozen: the surface stays one closed,
        /// consistently oriented 2-manifold of the same genus.
        #[test]
        fn a_remeshing_step_keeps_a_closed_oriented_manifold_of_the_same_genus(
            start_with_torus in any::<bool>(),
            stretch in [0.3f64..3.0, 0.3..3.0, 0.3..3.0],
            [a, b, c] in [0.0f64..TAU, 0.0..TAU, 0.0..TAU],
            jitter in 0.0f64..0.4,
            noise in proptest::collection::vec([-1.0f64..1.0, -1.0..1.0, -1.0..1.0], 1..64),
            states in proptest::collection::vec(0u8..4, 1..64),
            split in 0.3f64..3.0,
            collapse in 0.0f64..1.0,
        ) {
            let (mut s, euler) = if start_with_torus {
                (Surface::from_mesh(&torus(DVec3::ZERO, 3.0, 1.0, 16, 8)).unwrap(), 0)
            } else {
                (Surface::icosphere(DVec3::ZERO, 1.0, 2).unwrap(), 2)
            };
            let rotation = DMat3::from_euler(EulerRot::ZYX, a, b, c);
            let stretch =
                rotation * DMat3::from_diagonal(DVec3::from_array(stretch)) * rotation.transpose();
            let step = jitter * mean_edge_length(&s);
            for (p, &n) in s.positions_mut().iter_mut().zip(noise.iter().cycle()) {
                *p = stretch * (*p + DVec3::from_array(n) * step);
            }
            // Half of the vertices moving; shrinking goes towards all of them.
            for (state, &code) in s.states_mut().iter_mut().zip(states.iter().cycle()) {
                *state = match code {
                    2 => VertexState::FrozenAtBorder,
                    3 => VertexState::FrozenBySelfIntersection,
                    _ => VertexState::Moving,
                };
            }
            let split = split * mean_edge_length(&s);
            s.split_long_edges(split).unwrap();
            s.collapse_short_edges(collapse * split, split).unwrap();
            s.flip_edges_for_valence();
            assert_valid(&s, euler);
            prop_assert_eq!(check(&s.to_mesh().unwrap()).components, 1);
        }
    }

    #[test]
    fn same_operations_give_the_same_surface_for_any_thread_count() {
        let pool = |k| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(k)
                .build()
                .unwrap()
        };
        let start = Surface::icosphere(DVec3::ZERO, 1.0, 2).unwrap();
        let one = pool(1).install(|| random_session(7, start.clone(), 2));
        let two = pool(2).install(|| random_session(7, start.clone(), 2));
        assert_eq!(one, two);
        assert_ne!(
            one,
            random_session(8, start, 2),
            "the sessions must differ to mean anything"
        );
    }

    #[test]
    fn splits_next_to_long_frozen_edges_terminate() {
        // One moving vertex in a frozen sphere whose edges are all too long: bisecting only the
        // front's edges would make slivers against the frozen ones for ever.
        let mut s = Surface::icosphere(DVec3::ZERO, 3.0, 2).unwrap();
        s.states_mut().fill(VertexState::FrozenAtBorder);
        s.states_mut()[0] = VertexState::Moving;
        let max = 0.3 * mean_edge_length(&s);
        let splits = s.split_long_edges(max).unwrap();
        assert!(splits > 0);
        assert_valid(&s, 2);
        assert!(s
            .outgoing_half_edges(0)
            .all(|h| s.positions()[0].distance(s.positions()[s.dest(h) as usize]) <= max));
    }

    #[test]
    fn compaction_renumbers_without_changing_the_mesh() {
        let mut s = random_session(3, Surface::icosphere(DVec3::ZERO, 1.0, 2).unwrap(), 2);
        assert!(
            s.vertex_slots() > s.vertex_count(),
            "the session should leave tombstones"
        );
        let (mesh, map) = s.to_mesh_with_map().unwrap();
        let old_positions = s.positions().to_vec();
        let old_states = s.states().to_vec();
        assert_eq!(s.compact(), map);
        assert_eq!(s.vertex_slots(), s.vertex_count());
        assert_eq!(s.triangle_slots(), s.triangle_count());
        assert_valid(&s, 2);
        assert_eq!(s.to_mesh().unwrap(), mesh);
        for (old, &new) in map.iter().enumerate() {
            if new != NONE {
                assert_eq!(s.positions()[new as usize], old_positions[old]);
                assert_eq!(s.states()[new as usize], old_states[old]);
            }
        }
        s.split_long_edges(0.5 * mean_edge_length(&s)).unwrap();
        assert_valid(&s, 2);
    }
}
