//! The proof that a simplified surface stays within `ε` of the input, both ways (two-sided
//! Hausdorff distance), kept up collapse by collapse.
//!
//! Both directions rest on one fact: the distance to a convex set (one triangle) is a convex
//! function, so its largest value over a triangle is at one of its corners. A triangle whose
//! three corners lie within `ε` of one triangle lies within `ε` of it entirely. Where no single
//! triangle serves, the piece is cut and each part tried again (`divide_onto`): a piece over
//! two adjacent triangles along the plane where it passes from one to the other, any other into
//! four at its edge midpoints; a piece that still fails after `MAX_DEPTH` cuts, or among
//! `MAX_PARTS` parts, fails the collapse.
//!
//! - **Input within ε of the output.** The input surface is partitioned into pieces (at first
//!   its triangles), each attached to one output triangle whose distance to its corners is at
//!   most `ε`. A collapse changes the triangles around the collapsed edge; their pieces must
//!   find a place on the new triangles there, or the collapse is refused. Pieces on other
//!   triangles keep their proof. This is the bookkeeping of Frey & Borouchaki's
//!   Hausdorff-envelope decimation and of CGAL's bounded-distance placement, with the
//!   convexity argument instead of samples, so the bound covers every point, not only sampled
//!   ones.
//! - **Output within ε of the input.** Each triangle a collapse makes is tested against the
//!   input triangles near it (`InputSurface::covers`): pieces within `ε` of one input triangle
//!   pass, and so do pieces whose corners are within `ε − ℓ/√3` of the input, `ℓ` the piece's
//!   longest edge (the distance to a set is 1-Lipschitz, and every point of a triangle is
//!   within `ℓ/√3` of a corner), and pieces over two adjacent input triangles that unfold into
//!   a convex quadrilateral within the bound (`FlattenedPair`); the others are cut into
//!   quarters, whose reach shrinks. A corner farther than `ε` from the input disproves the
//!   triangle at once.
//!
//! Distances are computed in f64 against a limit `ε·(1 − 1e-9)`, which keeps the rounding of
//! the distance computation inside the bound.

use glam::DVec3;

use super::triangle_grid::{Bounds, TriangleGrid};
use crate::allocation;
use crate::closest_point::Triangle;
use crate::error::Result;
use crate::mesh::TriMesh;

/// How many times a part is cut again before a proof is given up. A cut along a boundary
/// between targets settles one boundary, so a part over many targets needs several.
const MAX_DEPTH: u32 = 12;

/// The most parts one piece is examined in before a proof is given up, which bounds a
/// collapse's cost whatever the geometry.
const MAX_PARTS: usize = 4096;

/// A part of a triangle, by its corners in world millimetres.
pub(super) type Piece = [DVec3; 3];

/// The distance limit actually tested, a hair inside the bound, for the rounding of the
/// distance computation.
pub(super) fn tested_limit(max_error: f64) -> f64 {
    max_error * (1.0 - 1e-9)
}

fn quarters([a, b, c]: Piece) -> [Piece; 4] {
    let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
}

/// Longest edge over √3: every point of the triangle is within it of some corner (the
/// circumradius bounds it for an acute triangle, half the longest edge otherwise).
fn corner_reach([a, b, c]: Piece) -> f64 {
    let longest = a.distance(b).max(b.distance(c)).max(c.distance(a));
    longest / 3f64.sqrt()
}

/// The input surface, for the test that the output stays near it: each component of the
/// output near the same component of the input, so that where several objects come close,
/// each keeps the bound to its own surface.
pub(super) struct InputSurface {
    triangles: Vec<Target>,
    bounds: Vec<Bounds>,
    /// The connected component of each input triangle.
    components: Vec<u32>,
    grid: TriangleGrid,
}

impl InputSurface {
    /// `components` labels each triangle of `mesh` with its connected component.
    pub(super) fn new(mesh: &TriMesh, components: Vec<u32>, cell: f64) -> Result<InputSurface> {
        let count = mesh.triangles().len();
        let mut grid = TriangleGrid::new(cell);
        let mut triangles = allocation::with_capacity(count, "the input's triangles")?;
        let mut bounds = allocation::with_capacity(count, "the input's boxes")?;
        for t in 0..mesh.triangles().len() {
            let corners = mesh.corners(t);
            let b = Bounds::of(corners);
            grid.try_insert(t as u32, &b)?;
            triangles.push(Target::new(corners, mesh.triangles()[t]));
            bounds.push(b);
        }
        Ok(InputSurface {
            triangles,
            bounds,
            components,
            grid,
        })
    }

    /// The component of input triangle `t` (and of every output triangle that keeps its id).
    pub(super) fn component(&self, t: u32) -> u32 {
        self.components[t as usize]
    }

    /// Whether every point of `triangle` is within `limit` of the input's `component` (a
    /// `false` may also mean that the proof gave up).
    pub(super) fn covers(
        &self,
        triangle: Piece,
        component: u32,
        limit: f64,
        scratch: &mut Vec<u32>,
    ) -> bool {
        let reach = Bounds::of(triangle).grown(limit);
        self.grid.query(&reach, scratch);
        // Every triangle of the component within `limit` of the triangle is among these, so a
        // corner farther than `limit` from all of them is that far from the whole component.
        let near: Vec<Target> = scratch
            .iter()
            .filter(|&&t| {
                self.components[t as usize] == component && self.bounds[t as usize].overlaps(&reach)
            })
            .map(|&t| self.triangles[t as usize])
            .collect();
        !near.is_empty()
            && divide_onto(triangle, None, &near, limit, Fallback::Lipschitz, |_, _| {})
    }
}

/// A part of an input triangle (`source`) that an output triangle answers for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Attached {
    pub source: u32,
    pub corners: Piece,
}

/// The input pieces each output triangle answers for, and how many pieces each input triangle
/// is cut into.
pub(super) struct Attachments {
    pieces: Vec<Vec<Attached>>,
    fragments: Vec<u32>,
    input: Vec<Piece>,
}

impl Attachments {
    /// Each input triangle whole, on itself.
    pub(super) fn new(mesh: &TriMesh) -> Result<Attachments> {
        let input = allocation::collect(
            (0..mesh.triangles().len()).map(|t| mesh.corners(t)),
            "the input's pieces",
        )?;
        Ok(Attachments {
            pieces: allocation::collect(
                input.iter().enumerate().map(|(t, &corners)| {
                    vec![Attached {
                        source: t as u32,
                        corners,
                    }]
                }),
                "the pieces of each triangle",
            )?,
            fragments: allocation::filled(input.len(), 1, "the fragment counts")?,
            input,
        })
    }

    /// The pieces of the output triangles `from` placed on `targets` (the triangles that
    /// replace them): each piece, or each part it is cut into (`divide_onto`), goes to a target
    /// whose distance to all its corners is at most `limit`, trying first the target in
    /// `slot_of` its triangle.
    /// An input triangle all of whose pieces are among them is tried whole first, so that the
    /// cuts of earlier collapses heal where they are no longer needed. Returns the pieces per
    /// target, or `None` when some piece fits nowhere.
    pub(super) fn place(
        &self,
        from: &[u32],
        slot_of: impl Fn(u32) -> Option<usize>,
        targets: &[Target],
        limit: f64,
    ) -> Option<Vec<Vec<Attached>>> {
        let mut gathered: Vec<(Attached, Option<usize>)> = from
            .iter()
            .flat_map(|&t| self.pieces[t as usize].iter().map(move |&p| (p, t)))
            .map(|(p, t)| (p, slot_of(t)))
            .collect();
        // Grouped by source; the order within a group is the order gathered (sort_by_key is
        // stable), so that the result does not depend on the sort.
        gathered.sort_by_key(|(p, _)| p.source);
        let mut work = Vec::with_capacity(gathered.len());
        for group in gathered.chunk_by(|x, y| x.0.source == y.0.source) {
            let source = group[0].0.source;
            if group.len() > 1 && group.len() == self.fragments[source as usize] as usize {
                let whole = Attached {
                    source,
                    corners: self.input[source as usize],
                };
                work.push((whole, group[0].1));
            } else {
                work.extend_from_slice(group);
            }
        }
        // The pieces of the two deleted triangles first: they lie where the surface changes
        // most, so a collapse that fails usually fails there, before the others are tried.
        work.sort_by_key(|(_, slot)| slot.is_some());
        place_pieces(work, targets, limit)
    }

    /// Takes the pieces of `deleted` and `moved` away and gives `moved` the `placed` ones.
    pub(super) fn commit(&mut self, deleted: &[u32], moved: &[u32], placed: Vec<Vec<Attached>>) {
        for &t in deleted.iter().chain(moved) {
            for p in std::mem::take(&mut self.pieces[t as usize]) {
                self.fragments[p.source as usize] -= 1;
            }
        }
        for (&t, pieces) in moved.iter().zip(placed) {
            for p in &pieces {
                self.fragments[p.source as usize] += 1;
            }
            self.pieces[t as usize] = pieces;
        }
    }
}

/// A triangle pieces can be placed on: an output triangle for the pieces of the input, an
/// input triangle for the parts of an output triangle.
#[derive(Clone, Copy)]
pub(super) struct Target {
    triangle: Triangle,
    corners: [DVec3; 3],
    vertices: [u32; 3],
    bounds: Bounds,
}

impl Target {
    pub(super) fn new(corners: [DVec3; 3], vertices: [u32; 3]) -> Target {
        let [a, b, c] = corners;
        Target {
            triangle: Triangle::new(a, b, c),
            corners,
            vertices,
            bounds: Bounds::of(corners),
        }
    }

    fn distance_squared(&self, p: DVec3) -> f64 {
        self.triangle.distance_squared(p)
    }

    fn unit_normal(&self) -> DVec3 {
        let [a, b, c] = self.corners;
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// The edge this target shares with `other`, as two points.
    fn shared_edge(&self, other: &Target) -> Option<[DVec3; 2]> {
        let mut shared = (0..3).filter(|&k| other.vertices.contains(&self.vertices[k]));
        match (shared.next(), shared.next()) {
            (Some(i), Some(j)) => Some([self.corners[i], self.corners[j]]),
            _ => None,
        }
    }
}

/// Two adjacent targets seen as one convex quadrilateral: the second unfolded into the first's
/// plane (its far corner projected), when the four corners then make a convex quadrilateral.
/// The distance to the pair is at most the distance to the quadrilateral plus how far the
/// projection moved the far corner (a point of the quadrilateral's second half is the image of
/// a point of the second target moved by at most that), and the distance to a convex set is
/// convex: so a part whose corners are within `limit − lift` of the quadrilateral is within
/// `limit` of the pair, without cutting it where it passes from one target to the other.
struct FlattenedPair {
    first: Triangle,
    unfolded: Triangle,
    lift: f64,
}

impl FlattenedPair {
    fn new(t1: &Target, t2: &Target) -> Option<FlattenedPair> {
        let [e0, e1] = t1.shared_edge(t2)?;
        let far = |t: &Target| {
            t.corners
                .into_iter()
                .find(|&c| c != e0 && c != e1)
                .expect("a target sharing an edge has a third corner")
        };
        let (f1, f2) = (far(t1), far(t2));
        let n = t1.unit_normal();
        if n == DVec3::ZERO {
            return None;
        }
        let height = n.dot(f2 - e0);
        let f2p = f2 - n * height;
        // Convex: the far corners on opposite sides of the shared edge, and the edge's ends on
        // opposite sides of the line between the far corners (all within the first's plane).
        let side = |a: DVec3, b: DVec3, p: DVec3| (b - a).cross(p - a).dot(n);
        let convex = side(e0, e1, f1) * side(e0, e1, f2p) < 0.0
            && side(f1, f2p, e0) * side(f1, f2p, e1) < 0.0;
        convex.then(|| FlattenedPair {
            first: t1.triangle,
            unfolded: Triangle::new(e0, f2p, e1),
            lift: height.abs(),
        })
    }

    /// An upper bound of the distance from any point of `part` to the pair.
    fn bound(&self, part: Piece) -> f64 {
        let to_quad = part
            .iter()
            .map(|&p| {
                self.first
                    .distance_squared(p)
                    .min(self.unfolded.distance_squared(p))
            })
            .fold(0.0f64, f64::max);
        to_quad.sqrt() + self.lift
    }
}

/// The plane through the edge two adjacent targets share that stands across the surface there
/// (it contains the edge and the mean of their normals): it divides a piece lying over both
/// into the part over each. `None` when the targets fold onto each other.
fn dividing_plane(t1: &Target, t2: &Target) -> Option<(DVec3, DVec3)> {
    let [e0, e1] = t1.shared_edge(t2)?;
    let normal = (e1 - e0).cross(t1.unit_normal() + t2.unit_normal());
    let length = normal.length();
    (length > 1e-6 * e0.distance(e1)).then(|| (e0, normal / length))
}

/// The piece cut by the plane through `origin` with `normal` into a triangle and a
/// quadrilateral (as two triangles), or `None` when the plane does not cross it.
fn cut(piece: Piece, origin: DVec3, normal: DVec3) -> Option<[Piece; 3]> {
    let side = piece.map(|p| normal.dot(p - origin));
    // The corner alone on its side: the one whose sign differs from both others.
    let alone = (0..3).find(|&k| {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        (side[k] > 0.0 && side[i] <= 0.0 && side[j] <= 0.0)
            || (side[k] < 0.0 && side[i] >= 0.0 && side[j] >= 0.0)
    })?;
    let (i, j) = ((alone + 1) % 3, (alone + 2) % 3);
    let crossing = |m: usize| {
        let t = side[alone] / (side[alone] - side[m]);
        piece[alone] + (piece[m] - piece[alone]) * t
    };
    let (on_i, on_j) = (crossing(i), crossing(j));
    Some([
        [piece[alone], on_i, on_j],
        [on_i, piece[i], piece[j]],
        [on_i, piece[j], on_j],
    ])
}

/// What else proves a piece that no single target holds.
#[derive(Clone, Copy, PartialEq)]
enum Fallback {
    /// Nothing: the piece is cut.
    None,
    /// The corners' distances to the union of the targets plus the piece's corner reach
    /// (1-Lipschitz): only where the proof is not kept for later, since it rests on several
    /// targets at once. Misfits are cut into quarters, which shrinks the reach.
    Lipschitz,
}

impl Fallback {
    fn max_depth(self) -> u32 {
        match self {
            Fallback::None => MAX_DEPTH,
            // Quarters multiply: 4^6 parts at most.
            Fallback::Lipschitz => 6,
        }
    }
}

/// Places `pieces` on the `targets`, each with its preferred target slot; see
/// `Attachments::place`.
fn place_pieces(
    pieces: Vec<(Attached, Option<usize>)>,
    targets: &[Target],
    limit: f64,
) -> Option<Vec<Vec<Attached>>> {
    let mut placed: Vec<Vec<Attached>> = vec![Vec::new(); targets.len()];
    for (piece, preferred) in pieces {
        let fitted = divide_onto(
            piece.corners,
            preferred,
            targets,
            limit,
            Fallback::None,
            |corners, k| {
                placed[k].push(Attached {
                    source: piece.source,
                    corners,
                })
            },
        );
        if !fitted {
            return None;
        }
    }
    Some(placed)
}

/// Divides `piece` into parts each within `limit` of one target (at all its corners, hence
/// everywhere), calling `fit(part, target)` for each; `false` when some part fits nowhere
/// after `MAX_DEPTH` cuts or among `MAX_PARTS` parts. The `preferred` target is tried first. A part over two adjacent
/// targets is cut where it passes from one to the other (`dividing_plane`), any other misfit
/// into quarters.
fn divide_onto(
    piece: Piece,
    preferred: Option<usize>,
    targets: &[Target],
    limit: f64,
    fallback: Fallback,
    mut fit: impl FnMut(Piece, usize),
) -> bool {
    let limit2 = limit * limit;
    let mut stack = vec![(piece, preferred, 0u32)];
    let mut examined = 0;
    while let Some((piece, preferred, depth)) = stack.pop() {
        examined += 1;
        if examined > MAX_PARTS {
            return false;
        }
        // Only targets whose boxes come within the limit of the part's box can be within
        // the limit of its corners.
        let reach = Bounds::of(piece).grown(limit);
        let order = preferred
            .into_iter()
            .chain((0..targets.len()).filter(|&k| Some(k) != preferred))
            .filter(|&k| targets[k].bounds.overlaps(&reach));
        // The nearest target of each corner, until one target holds all three.
        let mut nearest = [(f64::INFINITY, 0usize); 3];
        let mut slot = None;
        for k in order {
            let d2 = piece.map(|p| targets[k].distance_squared(p));
            for (n, &d) in nearest.iter_mut().zip(&d2) {
                if d < n.0 {
                    *n = (d, k);
                }
            }
            if d2.iter().all(|&d| d <= limit2) {
                slot = Some(k);
                break;
            }
        }
        if let Some(k) = slot {
            fit(piece, k);
            continue;
        }
        // A corner farther than the limit from every target stays a corner of any part of
        // the piece: cutting cannot help.
        let farthest2 = nearest.iter().fold(0.0f64, |m, n| m.max(n.0));
        if farthest2 > limit2 {
            return false;
        }
        if fallback == Fallback::Lipschitz {
            if farthest2.sqrt() + corner_reach(piece) <= limit {
                continue;
            }
            let first = nearest[0].1;
            let pair = nearest
                .iter()
                .map(|n| n.1)
                .find(|&k| k != first)
                .and_then(|second| FlattenedPair::new(&targets[first], &targets[second]));
            if pair.is_some_and(|pair| pair.bound(piece) <= limit) {
                continue;
            }
        }
        if depth == fallback.max_depth() {
            return false;
        }
        let first = nearest[0].1;
        let across = (fallback == Fallback::None)
            .then(|| nearest.iter().map(|n| n.1).find(|&k| k != first))
            .flatten()
            .and_then(|second| dividing_plane(&targets[first], &targets[second]))
            .and_then(|(origin, normal)| cut(piece, origin, normal));
        // The parts start with the target nearest the first corner.
        let child = |part| (part, Some(first), depth + 1);
        match across {
            Some(parts) => stack.extend(parts.map(child)),
            None => stack.extend(quarters(piece).map(child)),
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square_mesh(z: f64) -> TriMesh {
        let p = [
            DVec3::new(0.0, 0.0, z),
            DVec3::new(1.0, 0.0, z),
            DVec3::new(1.0, 1.0, z),
            DVec3::new(0.0, 1.0, z),
        ];
        TriMesh::new(p.to_vec(), vec![[0, 1, 2], [0, 2, 3]]).unwrap()
    }

    #[test]
    fn a_triangle_over_two_input_triangles_is_covered_when_close_and_not_when_far() {
        let input = InputSurface::new(&square_mesh(0.0), vec![0, 0], 0.5).unwrap();
        let mut scratch = Vec::new();
        let over = |z: f64| {
            [
                DVec3::new(0.1, 0.05, z),
                DVec3::new(0.95, 0.5, z),
                DVec3::new(0.05, 0.9, z),
            ]
        };
        assert!(input.covers(over(0.09), 0, 0.1, &mut scratch));
        assert!(!input.covers(over(0.11), 0, 0.1, &mut scratch));
        // Sticking out past the square's edge by 0.2: the corner is 0.2 away.
        let out = [
            DVec3::new(0.1, 0.1, 0.0),
            DVec3::new(1.2, 0.5, 0.0),
            DVec3::new(0.1, 0.9, 0.0),
        ];
        assert!(!input.covers(out, 0, 0.1, &mut scratch));
        assert!(input.covers(out, 0, 0.21, &mut scratch));
    }

    #[test]
    fn a_folded_pair_bounds_the_distance_to_both_from_above_without_cutting() {
        // A unit square folded along its diagonal: the second half's far corner lifted 0.02.
        let (e0, e1) = (DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0));
        let first = Target::new([e0, DVec3::X, e1], [0, 1, 2]);
        let second = Target::new([e0, e1, DVec3::new(0.0, 1.0, 0.02)], [0, 2, 3]);
        let pair = FlattenedPair::new(&first, &second).unwrap();
        let across = [
            DVec3::new(0.8, 0.1, 0.05),
            DVec3::new(0.2, 0.9, 0.05),
            DVec3::new(0.3, 0.3, 0.05),
        ];
        let bound = pair.bound(across);
        assert!(bound < 0.08, "{bound}");
        // Sound: no point of the part is farther from the pair than the bound.
        for i in 0..=20 {
            for j in 0..=20 - i {
                let (u, v) = (i as f64 / 20.0, j as f64 / 20.0);
                let p = across[0] + (across[1] - across[0]) * u + (across[2] - across[0]) * v;
                let d = first
                    .distance_squared(p)
                    .min(second.distance_squared(p))
                    .sqrt();
                assert!(d <= bound, "{d} > {bound} at {p}");
            }
        }
        // Folded onto itself (not convex once unfolded): no pair.
        let onto = Target::new([e0, e1, DVec3::new(0.9, 0.2, 0.01)], [0, 2, 4]);
        assert!(FlattenedPair::new(&first, &onto).is_none());
    }

    #[test]
    fn pieces_go_to_the_triangle_they_lie_near_and_are_split_between_two() {
        let square = square_mesh(0.0);
        let targets: Vec<Target> = (0..2)
            .map(|t| Target::new(square.corners(t), square.triangles()[t]))
            .collect();
        // A piece across the diagonal, 0.05 above: neither half alone holds all its corners
        // within 0.06, so it is cut.
        let across = [
            DVec3::new(0.9, 0.1, 0.05),
            DVec3::new(0.1, 0.9, 0.05),
            DVec3::new(0.2, 0.3, 0.05),
        ];
        let piece = |corners| (Attached { source: 0, corners }, None);
        let placed = place_pieces(vec![piece(across)], &targets, 0.06).unwrap();
        assert!(!placed[0].is_empty() && !placed[1].is_empty());
        let far = [
            DVec3::new(0.5, 0.5, 0.2),
            DVec3::new(0.6, 0.5, 0.2),
            DVec3::new(0.5, 0.6, 0.2),
        ];
        assert!(place_pieces(vec![piece(far)], &targets, 0.1).is_none());
    }
}
