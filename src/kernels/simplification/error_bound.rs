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
//!   input triangles near it (`InputSurface::covers`, which finds them in a `BoxTree`): first
//!   whole, by the input's sheet under it (`sheet_cover`); failing that, in pieces. Pieces
//!   within `ε` of one input triangle pass, and so do pieces whose corners are within
//!   `ε − ℓ/√3` of the input, `ℓ` the piece's longest edge (the distance to a set is
//!   1-Lipschitz, and every point of a triangle is within `ℓ/√3` of a corner), pieces over two
//!   adjacent input triangles that unfold into a convex quadrilateral within the bound
//!   (`FlattenedPair`), and pieces over the triangles around an input vertex that flatten into
//!   a convex polygon within the bound (`FlattenedFan`); the others are cut into quarters,
//!   whose reach shrinks. A corner farther than `ε` from the input disproves the triangle at
//!   once.
//!
//! Distances are computed in f64 against a limit `ε·(1 − 1e-9)`, which keeps the rounding of
//! the distance computation inside the bound.

use glam::DVec3;

use super::box_tree::BoxTree;
use super::sheet_cover::covered_by_sheet;
use super::triangle_grid::Bounds;
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

/// Why a piece found no place: its corner `corner` lies farther than the limit from every
/// target, the nearest point of them being `nearest`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Miss {
    pub corner: DVec3,
    pub nearest: DVec3,
}

impl Miss {
    pub(super) fn distance(&self) -> f64 {
        self.corner.distance(self.nearest)
    }
}

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
    /// The connected component of each input triangle.
    components: Vec<u32>,
    /// The triangles' boxes.
    tree: BoxTree,
}

impl InputSurface {
    /// `components` labels each triangle of `mesh` with its connected component.
    pub(super) fn new(mesh: &TriMesh, components: Vec<u32>) -> Result<InputSurface> {
        let count = mesh.triangles().len();
        let mut triangles = allocation::with_capacity(count, "the input's triangles")?;
        let mut bounds = allocation::with_capacity(count, "the input's boxes")?;
        for t in 0..count {
            let corners = mesh.corners(t);
            triangles.push(Target::new(corners, mesh.triangles()[t]));
            bounds.push(Bounds::of(corners));
        }
        Ok(InputSurface {
            triangles,
            components,
            tree: BoxTree::new(bounds)?,
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
        self.tree.query(&reach, scratch);
        // Every triangle of the component within `limit` of the triangle is among these, so a
        // corner farther than `limit` from all of them is that far from the whole component.
        let near: Vec<Target> = scratch
            .iter()
            .filter(|&&t| self.components[t as usize] == component)
            .map(|&t| self.triangles[t as usize])
            .collect();
        !near.is_empty()
            && (covered_by_sheet(triangle, &near, limit)
                || divide_onto(triangle, None, &near, limit, Fallback::Lipschitz, |_, _| {})
                    .is_ok())
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

    /// The pieces of the output triangles `from` that a collapse must place again on the
    /// triangles replacing them, each with the slot (`slot_of`) of the triangle that held it,
    /// tried first. An input triangle all of whose pieces are among them comes whole, so that
    /// the cuts of earlier collapses heal where they are no longer needed. Gathered once for
    /// all the positions a collapse tries.
    pub(super) fn displaced(
        &self,
        from: &[u32],
        slot_of: impl Fn(u32) -> Option<usize>,
    ) -> Displaced {
        let count = from.iter().map(|&t| self.pieces[t as usize].len()).sum();
        let mut gathered: Vec<(Attached, Option<usize>)> = Vec::with_capacity(count);
        for &t in from {
            let slot = slot_of(t);
            gathered.extend(self.pieces[t as usize].iter().map(|&p| (p, slot)));
        }
        // Grouped by source, in the order gathered within a group, so that the result does not
        // depend on the sort: the keys (source, place) are distinct, and sorting them moves
        // eight bytes a piece instead of the piece.
        let mut order: Vec<(u32, u32)> = (0..count as u32)
            .map(|k| (gathered[k as usize].0.source, k))
            .collect();
        order.sort_unstable();
        // The pieces of the two deleted triangles (no slot) first: they lie where the surface
        // changes most, so a collapse that fails usually fails there, before the others are
        // tried.
        let (mut work, mut kept) = (Vec::with_capacity(count), Vec::with_capacity(count));
        let mut put = |item: (Attached, Option<usize>)| match item.1 {
            None => work.push(item),
            Some(_) => kept.push(item),
        };
        for group in order.chunk_by(|x, y| x.0 == y.0) {
            let source = group[0].0;
            if group.len() > 1 && group.len() == self.fragments[source as usize] as usize {
                let whole = Attached {
                    source,
                    corners: self.input[source as usize],
                };
                put((whole, gathered[group[0].1 as usize].1));
            } else {
                group.iter().for_each(|&(_, k)| put(gathered[k as usize]));
            }
        }
        work.append(&mut kept);
        Displaced(work)
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

/// The input pieces a collapse displaces (`Attachments::displaced`), each with the slot of the
/// target it is tried on first.
pub(super) struct Displaced(Vec<(Attached, Option<usize>)>);

impl Displaced {
    /// The pieces placed on `targets` (the triangles that replace theirs): each piece, or each
    /// part it is cut into (`divide_onto`), goes to a target whose distance to all its corners
    /// is at most `limit`. Returns the pieces per target, or, when some piece fits nowhere,
    /// the miss that showed it (see `divide_onto`).
    pub(super) fn place(
        &self,
        targets: &[Target],
        limit: f64,
    ) -> Result<Vec<Vec<Attached>>, Option<Miss>> {
        place_pieces(&self.0, targets, limit)
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

    pub(super) fn distance_squared(&self, p: DVec3) -> f64 {
        self.triangle.distance_squared(p)
    }

    pub(super) fn corners(&self) -> [DVec3; 3] {
        self.corners
    }

    pub(super) fn vertices(&self) -> [u32; 3] {
        self.vertices
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

/// The targets around one vertex seen as one convex polygon: the fan projected onto a plane
/// through the vertex, when it covers a convex polygon there once (a height field over the
/// plane whose rim turns left at every ring vertex and once around). As for
/// [`FlattenedPair`], the distance to the fan is at most the distance to the polygon plus the
/// largest height of the fan over the plane (the height is linear on each target, so largest
/// at a ring vertex), and the distance to a convex set is convex: a part whose corners are
/// within `limit − lift` of the polygon is within `limit` of the fan, wherever it passes from
/// one target to the next. It proves the parts near an input vertex, where three or more
/// targets meet and neither single targets nor pairs hold the corners.
struct FlattenedFan {
    centre: DVec3,
    normal: DVec3,
    /// The ring projected onto the plane, in order around the centre.
    rim: Vec<DVec3>,
    lift: f64,
}

impl FlattenedFan {
    /// The fan of the targets around vertex `v`, or `None` when they do not close around it
    /// or do not flatten into a convex polygon.
    fn around(v: u32, targets: &[Target]) -> Option<FlattenedFan> {
        // Each target around `v` as the edge of the ring opposite it, in the target's order.
        let ring_edges: Vec<(u32, u32, DVec3, DVec3)> = targets
            .iter()
            .filter_map(|t| {
                let k = t.vertices.iter().position(|&u| u == v)?;
                let (i, j) = ((k + 1) % 3, (k + 2) % 3);
                Some((t.vertices[i], t.vertices[j], t.corners[i], t.corners[j]))
            })
            .collect();
        if ring_edges.len() < 3 {
            return None;
        }
        let centre = targets.iter().find_map(|t| {
            t.vertices
                .iter()
                .position(|&u| u == v)
                .map(|k| t.corners[k])
        })?;
        let normal = ring_edges
            .iter()
            .map(|&(_, _, p, q)| (p - centre).cross(q - centre))
            .sum::<DVec3>()
            .normalize_or_zero();
        if normal == DVec3::ZERO {
            return None;
        }
        // Walk the ring: it closes when every ring vertex starts exactly one edge and the
        // walk comes back to its start after visiting all of them.
        let mut rim = Vec::with_capacity(ring_edges.len());
        let mut lift = 0.0f64;
        let (first, ..) = ring_edges[0];
        let mut at = first;
        for _ in 0..ring_edges.len() {
            let mut starting = ring_edges.iter().filter(|e| e.0 == at);
            let (&(_, next, p, _), None) = (starting.next()?, starting.next()) else {
                return None;
            };
            let height = normal.dot(p - centre);
            lift = lift.max(height.abs());
            rim.push(p - normal * height);
            at = next;
        }
        if at != first {
            return None;
        }
        // Every rim vertex a left turn and the rim once around the centre: a convex polygon
        // that the projected targets cover (each projected target turns the same way).
        let n = rim.len();
        let turn = |a: DVec3, b: DVec3, c: DVec3| normal.dot((b - a).cross(c - b));
        let convex = (0..n).all(|i| {
            let (a, b, c) = (rim[i], rim[(i + 1) % n], rim[(i + 2) % n]);
            turn(a, b, c) > 0.0 && turn(centre, a, b) > 0.0
        });
        let winding: f64 = (0..n)
            .map(|i| {
                let (a, b) = (rim[i] - centre, rim[(i + 1) % n] - centre);
                normal.dot(a.cross(b)).atan2(a.dot(b))
            })
            .sum();
        let once = (winding - std::f64::consts::TAU).abs() < 1e-6;
        (convex && once).then_some(FlattenedFan {
            centre,
            normal,
            rim,
            lift,
        })
    }

    /// The distance from `p` to the polygon.
    fn polygon_distance(&self, p: DVec3) -> f64 {
        let height = self.normal.dot(p - self.centre);
        let q = p - self.normal * height;
        let n = self.rim.len();
        let edges = (0..n).map(|i| (self.rim[i], self.rim[(i + 1) % n]));
        let inside = edges
            .clone()
            .all(|(a, b)| self.normal.dot((b - a).cross(q - a)) >= 0.0);
        let across = if inside {
            0.0
        } else {
            edges
                .map(|(a, b)| {
                    let ab = b - a;
                    let t = (ab.dot(q - a) / ab.length_squared()).clamp(0.0, 1.0);
                    (a + ab * t).distance_squared(q)
                })
                .fold(f64::INFINITY, f64::min)
                .sqrt()
        };
        height.hypot(across)
    }

    /// An upper bound of the distance from any point of `part` to the fan.
    fn bound(&self, part: Piece) -> f64 {
        let to_polygon = part
            .iter()
            .map(|&p| self.polygon_distance(p))
            .fold(0.0f64, f64::max);
        to_polygon + self.lift
    }
}

/// The vertices that all of `targets` share, each once.
fn shared_vertices<'a>(targets: &'a [&'a Target; 3]) -> impl Iterator<Item = u32> + 'a {
    targets[0]
        .vertices
        .into_iter()
        .filter(|v| targets[1..].iter().all(|t| t.vertices.contains(v)))
}

/// The fans one proof has flattened, by their centre vertex (a handful per proof).
#[derive(Default)]
struct Fans(Vec<(u32, Option<FlattenedFan>)>);

impl Fans {
    fn get(&mut self, v: u32, targets: &[Target]) -> Option<&FlattenedFan> {
        let k = match self.0.iter().position(|f| f.0 == v) {
            Some(k) => k,
            None => {
                self.0.push((v, FlattenedFan::around(v, targets)));
                self.0.len() - 1
            }
        };
        self.0[k].1.as_ref()
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
    pieces: &[(Attached, Option<usize>)],
    targets: &[Target],
    limit: f64,
) -> Result<Vec<Vec<Attached>>, Option<Miss>> {
    let mut placed: Vec<Vec<Attached>> = vec![Vec::new(); targets.len()];
    for &(piece, preferred) in pieces {
        divide_onto(
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
        )?;
    }
    Ok(placed)
}

/// Divides `piece` into parts each within `limit` of one target (at all its corners, hence
/// everywhere), calling `fit(part, target)` for each. The `preferred` target is tried first.
/// A part over two adjacent targets is cut where it passes from one to the other
/// (`dividing_plane`), any other misfit into quarters. An error when some part fits nowhere:
/// the `Miss` of a corner farther than `limit` from every target within reach of the part, or
/// `None` when no target is within reach or the proof gave up after `MAX_DEPTH` cuts or among
/// `MAX_PARTS` parts.
fn divide_onto(
    piece: Piece,
    preferred: Option<usize>,
    targets: &[Target],
    limit: f64,
    fallback: Fallback,
    mut fit: impl FnMut(Piece, usize),
) -> Result<(), Option<Miss>> {
    let limit2 = limit * limit;
    let mut fans = Fans::default();
    let mut stack = vec![(piece, preferred, 0u32)];
    let mut examined = 0;
    while let Some((piece, preferred, depth)) = stack.pop() {
        examined += 1;
        if examined > MAX_PARTS {
            return Err(None);
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
        let far = (1..3).fold(0, |m, k| if nearest[k].0 > nearest[m].0 { k } else { m });
        let farthest2 = nearest[far].0;
        if farthest2 > limit2 {
            let corner = piece[far];
            return Err(farthest2.is_finite().then(|| Miss {
                corner,
                nearest: targets[nearest[far].1].triangle.closest_point(corner),
            }));
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
            if shared_vertices(&nearest.map(|n| &targets[n.1])).any(|v| {
                fans.get(v, targets)
                    .is_some_and(|fan| fan.bound(piece) <= limit)
            }) {
                continue;
            }
        }
        if depth == fallback.max_depth() {
            return Err(None);
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
    Ok(())
}

/// The largest distance from a lattice of points on `part` (40 steps a side) to the nearest
/// of `targets`: what the proofs' bounds must not fall below.
#[cfg(test)]
pub(super) fn farthest_sample(part: Piece, targets: &[Target]) -> f64 {
    const STEPS: usize = 40;
    let [a, b, c] = part;
    (0..=STEPS)
        .flat_map(|i| (0..=STEPS - i).map(move |j| (i, j)))
        .map(|(i, j)| {
            let (u, v) = (i as f64 / STEPS as f64, j as f64 / STEPS as f64);
            let p = a + (b - a) * u + (c - a) * v;
            targets
                .iter()
                .map(|t| t.distance_squared(p))
                .fold(f64::INFINITY, f64::min)
                .sqrt()
        })
        .fold(0.0, f64::max)
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
        let input = InputSurface::new(&square_mesh(0.0), vec![0, 0]).unwrap();
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
        let farthest = farthest_sample(across, &[first, second]);
        assert!(farthest <= bound, "{farthest} > {bound}");
        // Folded onto itself (not convex once unfolded): no pair.
        let onto = Target::new([e0, e1, DVec3::new(0.9, 0.2, 0.01)], [0, 2, 4]);
        assert!(FlattenedPair::new(&first, &onto).is_none());
    }

    /// Six targets around vertex 0 at the origin, their ring on a circle of radius 1 lifted
    /// by `lift(angle)`.
    fn fan(lift: impl Fn(f64) -> f64) -> Vec<Target> {
        let ring: Vec<DVec3> = (0..6)
            .map(|k| {
                let angle = k as f64 * std::f64::consts::TAU / 6.0;
                DVec3::new(angle.cos(), angle.sin(), lift(angle))
            })
            .collect();
        (0..6)
            .map(|k| {
                let next = (k + 1) % 6;
                Target::new(
                    [DVec3::ZERO, ring[k], ring[next]],
                    [0, 1 + k as u32, 1 + next as u32],
                )
            })
            .collect()
    }

    #[test]
    fn a_flattened_fan_bounds_the_distance_to_its_targets_from_above() {
        // A bowl: the ring 0.03 to 0.05 above the centre.
        let targets = fan(|angle| 0.04 + 0.01 * (3.0 * angle).cos());
        let fan = FlattenedFan::around(0, &targets).unwrap();
        // A part over the centre, reaching into four of the six targets.
        let part = [
            DVec3::new(-0.3, -0.2, 0.05),
            DVec3::new(0.4, -0.1, 0.03),
            DVec3::new(0.0, 0.45, 0.06),
        ];
        let bound = fan.bound(part);
        assert!(bound < 0.12, "{bound}");
        let farthest = farthest_sample(part, &targets);
        assert!(farthest <= bound, "{farthest} > {bound}");
        // Not a fan for a vertex on its rim, nor with a target missing.
        assert!(FlattenedFan::around(1, &targets).is_none());
        assert!(FlattenedFan::around(0, &targets[1..]).is_none());
    }

    #[test]
    fn a_fan_that_does_not_flatten_into_a_convex_polygon_gives_no_bound() {
        // A rim vertex pulled in towards the centre: a reflex corner of the rim.
        let mut dented = fan(|_| 0.0);
        let pulled = DVec3::new(0.2, 0.0, 0.0);
        dented[0] = Target::new([DVec3::ZERO, pulled, dented[0].corners[2]], [0, 1, 2]);
        dented[5] = Target::new([DVec3::ZERO, dented[5].corners[1], pulled], [0, 6, 1]);
        assert!(FlattenedFan::around(0, &dented).is_none());
        // A rim vertex folded back over the centre: two targets overlap once projected.
        let mut folded = fan(|_| 0.0);
        let over = DVec3::new(-0.3, 0.0, 0.5);
        folded[0] = Target::new([DVec3::ZERO, over, folded[0].corners[2]], [0, 1, 2]);
        folded[5] = Target::new([DVec3::ZERO, folded[5].corners[1], over], [0, 6, 1]);
        assert!(FlattenedFan::around(0, &folded).is_none());
        // A steep saddle still flattens (a height field over the plane), but its lift makes
        // the bound no better than the lift itself: sound, if useless.
        let saddle = fan(|angle| 3.0 * (2.0 * angle).cos());
        let part = [
            DVec3::ZERO,
            DVec3::new(0.1, 0.0, 0.0),
            DVec3::new(0.0, 0.1, 0.0),
        ];
        assert!(FlattenedFan::around(0, &saddle).unwrap().bound(part) >= 3.0);
    }

    #[test]
    fn pieces_go_to_the_triangle_they_lie_near_and_are_split_between_two_or_name_their_miss() {
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
        let placed = place_pieces(&[piece(across)], &targets, 0.06).unwrap();
        assert!(!placed[0].is_empty() && !placed[1].is_empty());
        // A corner beyond the bound: the miss names the farthest corner and the nearest point
        // of the targets to it, towards which a refined position moves the surface.
        let far = [
            DVec3::new(0.5, 0.5, 0.05),
            DVec3::new(0.6, 0.5, 0.14),
            DVec3::new(0.5, 0.6, 0.08),
        ];
        let miss = place_pieces(&[piece(far)], &targets, 0.1)
            .unwrap_err()
            .expect("a corner misses");
        assert_eq!(miss.corner, far[1]);
        assert!(miss.nearest.distance(DVec3::new(0.6, 0.5, 0.0)) < 1e-12);
        assert!((miss.distance() - 0.14).abs() < 1e-12);
        // Far beyond: no target within reach, so no nearest point to name.
        let beyond = far.map(|p| p + DVec3::Z);
        assert!(place_pieces(&[piece(beyond)], &targets, 0.1)
            .unwrap_err()
            .is_none());
    }
}
