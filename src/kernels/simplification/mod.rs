//! Error-bounded simplification of a closed surface: as few triangles as edge collapses can
//! reach while the result stays within a given two-sided Hausdorff distance of the input and
//! keeps every guarantee of the segmentation output (closed, 2-manifold, oriented as it was,
//! free of self-intersections, same genus and components), with no triangle angle below
//! [`MIN_ANGLE_DEGREES`] among the triangles it makes. The paper's last step ("error preserving
//! mesh simplification"), and a tool on its own for meshes from anywhere.
//!
//! Collapses are taken greedily in the order of Garland–Heckbert's quadric error (`quadric`),
//! each at the first of a few positions (the quadric's minimiser, the best point of the edge,
//! its endpoints, the first of these moved ½, ¼ and ¾ of the bound off the surface either way,
//! then up to [`REFINEMENTS`] positions each moved from the closest miss so far towards the
//! input point that missed the bound) that passes every check (in the order of the list below,
//! except that the input's side of the distance bound, which fails most often, comes before
//! the search for self-intersections). When the queue is empty, rounds of edge flips
//! (`flip_gain`) change the triangulation where that flattens it or evens its valences, and
//! vertex moves (`try_relocate`) lower the error the collapses left a vertex's triangles at,
//! both under the same checks; the collapses they let through run again:
//! 1. topology: the link condition of Dey et al. (the endpoints' common neighbours are the two
//!    opposite vertices), and no opposite vertex left with two triangles, so a collapse never
//!    changes the genus, splits a component or collapses a tetrahedron;
//! 2. shape: no triangle around the edge turns over (its normal keeps a positive dot product
//!    with the old one), none has an angle below the floor, and the component's signed volume
//!    keeps its sign. The last is not implied by the first: on a coarse component (a few dozen
//!    triangles, as a small balloon under a large bound becomes) a vertex can jump through the
//!    opposite side, keeping every normal within 90° of the old one, and leave a tetrahedron
//!    that is closed and free of self-intersections but inside out. Since the result stays free
//!    of self-intersections, the volume's sign is the component's orientation;
//! 3. self-intersection: the moved triangles against each other and against every triangle
//!    whose box meets theirs (`triangle_grid`), by the exact test of `self_intersection`;
//! 4. distance: both sides of the Hausdorff bound, proved for every point and not only for
//!    samples (`error_bound`).
//!
//! The queue holds each edge once with its cost, which depends only on its endpoints, so a
//! collapse queues again only the edges of the vertex it keeps (whose position and quadric
//! changed) and the edges around it that were tried and failed: a change next to them may let
//! them pass now. An entry whose endpoint has since been kept by a collapse is stale.
//!
//! Collapses run one after the other, so the result is the same for any number of threads.

mod box_tree;
mod error_bound;
mod quadric;
mod sheet_cover;
mod triangle_grid;

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashSet};

use glam::DVec3;

use self::error_bound::{
    tested_limit, Attached, Attachments, Displaced, InputSurface, Miss, Target,
};
use self::quadric::Quadric;
use self::triangle_grid::{Bounds, TriangleGrid};
use crate::allocation;
use crate::balloon::fast_hash::FastHash;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::mesh_checks::{check, component_volumes};
use crate::self_intersection::{mesh_triangles_intersect, self_intersections};

/// The smallest angle of any triangle the simplification makes, in degrees. Triangles of the
/// input that it leaves as they are keep their angles. Ten degrees keeps the result fit for a
/// tetrahedral mesher (TetGen's and CGAL's surface-mesh inputs break on slivers) while costing
/// little reduction on smooth anatomy.
pub const MIN_ANGLE_DEGREES: f64 = 10.0;

/// How many more positions a collapse tries when all of the quadric's miss the bound, each
/// moved from the closest miss so far towards the input point that missed. The quadric's
/// positions minimise a sum of squares, the bound is a maximum: half the collapses refused on
/// the aorta at 0.1 mm missed by under 5% of it. Without flips, six steps kept 2.6% fewer
/// triangles there (12,652 -> 12,326 of 41,482) and 3.2% at 0.25 mm (4,500 -> 4,356); ten,
/// another 0.3% and 0.8% (12,288, 4,322).
const REFINEMENTS: usize = 10;

/// The most rounds of edge flips and vertex moves after the queue first empties, each followed
/// by the collapses it lets through. They die out by themselves within a few rounds (most of
/// the changes in the first, and none after the seventh on the aorta at 0.1 mm); the bound
/// only caps the work. Flips keep fewer triangles on every mesh tried: the aorta
/// 12,288 -> 12,086 at 0.1 mm and 4,322 -> 4,184 at 0.25 mm, the carotid's balloon 910 -> 896
/// and 364 -> 356. Moves on top: the aorta 11,902 and 4,130, the carotid 884 and 362 (6 more),
/// the 20k and 80k isosurfaces 4,750 / 548 and 7,460 / 536 (from 4,740 / 560 and
/// 7,488 / 536), for 10-60% more time.
const CHANGE_ROUNDS: usize = 8;

/// The fractions of the bound a vertex move (`try_relocate`) must bring its triangles' input
/// pieces under, one step lower than they were. The collapses leave nearly every star close to
/// the bound (on the aorta at 0.25 mm, 92% of the stars tried over 0.9 of it, 43% over 0.98): a
/// move that lowers one opens collapses next to it that missed narrowly. Steps of a tenth
/// from 0.5 to 0.9 moved 70 vertices there, these 528.
const RELOCATION_LEVELS: [f64; 6] = [0.8, 0.85, 0.9, 0.93, 0.96, 0.98];

/// What one unit of valence deviation (`flip_gain`) is worth against the cosine of the
/// dihedral angle. Between 0.005 and 0.05 the aorta's counts move by 0.1%.
const VALENCE_WEIGHT: f64 = 0.02;

/// What flipping the edge between triangles `before` into `after` gains: the cosine of the
/// angle between the two triangles' normals (a flatter pair fits the input better, as a
/// collapse's error grows with the dihedral angles around it), plus `VALENCE_WEIGHT` per unit
/// of the squared deviation from valence 6 the flip removes from its four vertices (valences
/// near 6 leave each vertex collapsible: `star` refuses to leave a vertex with three
/// triangles). Flipping back loses what the flip gained, so the two never alternate. The
/// valences are those of (a, b, c, d) for the edge a–b and the opposite vertices c and d.
fn flip_gain(before: [[DVec3; 3]; 2], after: [[DVec3; 3]; 2], valences: [usize; 4]) -> f64 {
    let unit = |[p, q, r]: [DVec3; 3]| (q - p).cross(r - p).normalize_or_zero();
    let flatness = |pair: [[DVec3; 3]; 2]| unit(pair[0]).dot(unit(pair[1]));
    let deviation = |changes: [i64; 4]| -> i64 {
        valences
            .iter()
            .zip(changes)
            .map(|(&v, change)| (v as i64 + change - 6).pow(2))
            .sum()
    };
    let valence_gain = deviation([0; 4]) - deviation([-1, -1, 1, 1]);
    flatness(after) - flatness(before) + VALENCE_WEIGHT * valence_gain as f64
}

/// `triangle`'s vertices starting at its `k`-th (the same triangle, the same orientation).
fn rotated(triangle: [u32; 3], k: usize) -> [u32; 3] {
    [triangle[k], triangle[(k + 1) % 3], triangle[(k + 2) % 3]]
}

/// Marks an input point that no triangle uses in [`Simplified::vertex_map`].
pub const NO_VERTEX: u32 = u32::MAX;

/// A simplified mesh and where the input's vertices went.
#[derive(Debug, Clone, PartialEq)]
pub struct Simplified {
    pub mesh: TriMesh,
    /// For each input point, the output vertex it was merged into ([`NO_VERTEX`] for a point
    /// no triangle uses), for carrying per-vertex data over.
    pub vertex_map: Vec<u32>,
}

/// Reduces a closed, 2-manifold, consistently oriented, self-intersection-free mesh to as few
/// triangles as it can while every point of the result lies within `max_error_mm` of the input
/// and every point of the input within `max_error_mm` of the result, component by component:
/// each component of the result within the bound of its own component of the input, both ways,
/// however close the components come. Each component keeps its
/// orientation (outward stays outward; an isosurface whose normals point inward stays so).
///
/// Errors: `max_error_mm` not positive and finite (invalid argument); a mesh that is empty,
/// open, non-manifold, inconsistently oriented, or that has self-intersecting or degenerate
/// triangles (invalid mesh, saying which).
pub fn simplify(mesh: &TriMesh, max_error_mm: f64) -> Result<Simplified> {
    simplify_with_progress(mesh, max_error_mm, |_| true)
}

/// [`simplify`], telling `progress` now and then the fraction done (0 to 1, never decreasing;
/// an estimate from the queue of collapses, whose length is not known in advance). When it
/// returns `false` the simplification stops with a cancelled error and nothing is returned.
/// The result does not depend on the callback.
pub fn simplify_with_progress(
    mesh: &TriMesh,
    max_error_mm: f64,
    mut progress: impl FnMut(f64) -> bool,
) -> Result<Simplified> {
    if !(max_error_mm.is_finite() && max_error_mm > 0.0) {
        return Err(Error::invalid_argument(format!(
            "the maximum error is {max_error_mm} mm; give a positive distance in millimetres, \
             e.g. a tenth of the voxel size"
        )));
    }
    check_simplifiable(mesh)?;
    let mut simplifier = Simplifier::new(mesh, max_error_mm)?;
    simplifier.run(&mut progress)?;
    simplifier.into_result()
}

fn check_simplifiable(mesh: &TriMesh) -> Result<()> {
    if mesh.triangles().is_empty() {
        return Err(Error::invalid_mesh("the mesh has no triangles"));
    }
    let report = check(mesh);
    let problem = if !report.closed() {
        Some(format!(
            "is not closed ({} boundary and {} non-manifold edges)",
            report.boundary_edges, report.non_manifold_edges
        ))
    } else if !report.manifold() {
        Some(format!(
            "is not 2-manifold ({} non-manifold vertices, {} degenerate triangles)",
            report.non_manifold_vertices, report.degenerate_triangles
        ))
    } else if !report.consistently_oriented() {
        Some(format!(
            "is not consistently oriented ({} edges traversed twice the same way)",
            report.inconsistently_oriented_edges
        ))
    } else {
        None
    };
    if let Some(problem) = problem {
        return Err(Error::invalid_mesh(format!(
            "the mesh {problem}; simplification keeps a closed, oriented 2-manifold and needs \
             one to start from (repair it first)"
        )));
    }
    let pairs = self_intersections(mesh)?;
    if let Some(&(a, b)) = pairs.first() {
        let what = if a == b {
            format!("triangle {a} is degenerate (its corners are collinear)")
        } else {
            format!("triangles {a} and {b} intersect")
        };
        return Err(Error::invalid_mesh(format!(
            "the mesh has {} self-intersecting or degenerate triangle pairs ({what}); \
             simplification keeps a surface free of them and needs one to start from",
            pairs.len()
        )));
    }
    Ok(())
}

/// A queued collapse: its quadric cost, the edge, and the endpoints' stamps when it was queued
/// (a changed stamp means the endpoint moved and the entry is stale).
type QueueEntry = Reverse<(u64, u32, u32, u32, u32)>;

struct Simplifier {
    points: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    alive: Vec<bool>,
    /// The live triangles around each vertex (empty once the vertex is merged away).
    around: Vec<Vec<u32>>,
    quadrics: Vec<Quadric>,
    stamps: Vec<u32>,
    /// The vertex each merged vertex went into (itself while it lives).
    merged_into: Vec<u32>,
    /// The input pieces each live triangle answers for (`error_bound`).
    pieces: Attachments,
    /// Each component's signed volume, kept up to date by the collapses.
    volumes: Vec<f64>,
    bounds: Vec<Bounds>,
    grid: TriangleGrid,
    input: InputSurface,
    limit: f64,
    cos_min_angle: f64,
    queue: BinaryHeap<QueueEntry>,
    /// Edges (lower vertex first) whose collapse was tried and refused, to try again when a
    /// collapse changes the triangles around them.
    refused: HashSet<(u32, u32), FastHash>,
    /// Vertices whose move was tried and refused since their triangles last changed.
    settled: Vec<bool>,
    scratch: Vec<u32>,
}

/// What a collapse of `keep`–`remove` changes: the two triangles it deletes and the others
/// around either endpoint, which it moves.
struct Star {
    keep: u32,
    remove: u32,
    deleted: [u32; 2],
    moved: Vec<u32>,
}

/// What a collapse or a flip changes: the triangles it replaces (sorted; each by the
/// triangle at the same place in the list of new ones), those it removes, and a point near
/// them to measure volumes from.
struct Change<'a> {
    replaced: &'a [u32],
    removed: &'a [u32],
    origin: DVec3,
}

/// The progress reported so far: queue entries taken, and the fraction reported (which never
/// falls).
#[derive(Default)]
struct Estimate {
    popped: usize,
    reported: f64,
}

/// A collapse that passed every check: the input pieces each moved triangle will answer for,
/// and its component's signed volume after it.
struct Admitted {
    pieces: Vec<Vec<Attached>>,
    volume: f64,
}

impl Simplifier {
    fn new(mesh: &TriMesh, max_error: f64) -> Result<Simplifier> {
        let points = allocation::collect(mesh.points().iter().copied(), "the points")?;
        let triangles = allocation::collect(mesh.triangles().iter().copied(), "the triangles")?;
        let mut around = allocation::filled(points.len(), Vec::new(), "the vertices' triangles")?;
        let mut quadrics = allocation::filled(points.len(), Quadric::default(), "the quadrics")?;
        let mut edge_length_sum = 0.0;
        for (t, tri) in triangles.iter().enumerate() {
            let corners = mesh.corners(t);
            let q = Quadric::of_triangle(corners);
            for k in 0..3 {
                around[tri[k] as usize].push(t as u32);
                quadrics[tri[k] as usize] += q;
                edge_length_sum += corners[k].distance(corners[(k + 1) % 3]);
            }
        }
        let mean_edge = edge_length_sum / (3 * triangles.len()) as f64;
        // Cells about the triangles' size at the start; they grow as the mesh coarsens, which
        // the grid's oversized list absorbs.
        let cell = (2.0 * mean_edge).max(max_error);
        let (components, volumes) = component_volumes(mesh);
        let mut grid = TriangleGrid::new(cell);
        let bounds = allocation::collect(
            (0..triangles.len()).map(|t| Bounds::of(mesh.corners(t))),
            "the triangles' boxes",
        )?;
        for (t, b) in bounds.iter().enumerate() {
            grid.try_insert(t as u32, b)?;
        }
        let mut simplifier = Simplifier {
            pieces: Attachments::new(mesh)?,
            alive: allocation::filled(triangles.len(), true, "the triangles' flags")?,
            stamps: allocation::filled(points.len(), 0, "the vertices' stamps")?,
            merged_into: allocation::collect(0..points.len() as u32, "the vertex map")?,
            input: InputSurface::new(mesh, components)?,
            volumes,
            limit: tested_limit(max_error),
            cos_min_angle: MIN_ANGLE_DEGREES.to_radians().cos(),
            queue: BinaryHeap::from(allocation::with_capacity(
                3 * points.len(),
                "the queue of collapses",
            )?),
            refused: HashSet::default(),
            settled: allocation::filled(points.len(), false, "the vertices' flags")?,
            scratch: Vec::new(),
            points,
            triangles,
            around,
            quadrics,
            bounds,
            grid,
        };
        for v in 0..simplifier.points.len() as u32 {
            for w in simplifier.neighbours(v) {
                if v < w {
                    simplifier.enqueue(v, w)?;
                }
            }
        }
        Ok(simplifier)
    }

    fn run(&mut self, progress: &mut dyn FnMut(f64) -> bool) -> Result<()> {
        let mut estimate = Estimate::default();
        self.drain(&mut estimate, progress)?;
        for _ in 0..CHANGE_ROUNDS {
            if self.flip_round()? + self.relocate_round()? == 0 {
                break;
            }
            self.drain(&mut estimate, progress)?;
        }
        Ok(())
    }

    /// Tries to flip every edge once (in the order of the triangles, so the same for any
    /// number of threads); how many it flipped.
    fn flip_round(&mut self) -> Result<usize> {
        let mut flipped = 0;
        for t in 0..self.triangles.len() as u32 {
            for k in 0..3 {
                if !self.alive[t as usize] {
                    break;
                }
                let [a, b, c] = rotated(self.triangles[t as usize], k);
                let other = self.around[a as usize]
                    .iter()
                    .copied()
                    .find(|&u| u != t && self.triangles[u as usize].contains(&b));
                // Each edge once, from its lower triangle.
                if let Some(u) = other.filter(|&u| u > t) {
                    if self.try_flip(t, u, [a, b, c])? {
                        flipped += 1;
                    }
                }
            }
        }
        Ok(flipped)
    }

    /// Flips the edge a–b between `t` = (a, b, c) and `u` = (b, a, d) into c–d, making (c, a, d)
    /// and (d, b, c), if that gains (`flip_gain`) and keeps every guarantee (the checks of a
    /// collapse, with the link condition that c–d is no edge yet and a and b keep three
    /// triangles); whether it did.
    fn try_flip(&mut self, t: u32, u: u32, [a, b, c]: [u32; 3]) -> Result<bool> {
        let d = self.triangles[u as usize]
            .into_iter()
            .find(|&v| v != a && v != b)
            .expect("a triangle has three distinct vertices");
        if c == d
            || self.around[a as usize].len() <= 3
            || self.around[b as usize].len() <= 3
            || self.neighbours(c).binary_search(&d).is_ok()
        {
            return Ok(false);
        }
        let (t_after, u_after) = ([c, a, d], [d, b, c]);
        let corners = |vertices: [u32; 3]| vertices.map(|v| self.points[v as usize]);
        let valence = |v: u32| self.around[v as usize].len();
        let gain = flip_gain(
            [self.corners(t), self.corners(u)],
            [corners(t_after), corners(u_after)],
            [valence(a), valence(b), valence(c), valence(d)],
        );
        if gain <= 1e-9 {
            return Ok(false);
        }
        let replaced = [t.min(u), t.max(u)];
        let after: Vec<([DVec3; 3], [u32; 3])> = replaced
            .iter()
            .map(|&x| if x == t { t_after } else { u_after })
            .map(|vertices| (corners(vertices), vertices))
            .collect();
        let displaced = self
            .pieces
            .displaced(&replaced, |x| replaced.binary_search(&x).ok());
        let change = Change {
            replaced: &replaced,
            removed: &[],
            origin: self.points[a as usize],
        };
        let Ok(admitted) = self.admissible(&change, &after, &displaced) else {
            return Ok(false);
        };
        self.apply(&change, &after, admitted);
        self.around[a as usize].retain(|&x| x != u);
        self.around[b as usize].retain(|&x| x != t);
        for (v, x) in [(c, u), (d, t)] {
            let around = &mut self.around[v as usize];
            around.push(x);
            around.sort_unstable();
        }
        self.queue_again(vec![(c.min(d), c.max(d))], &[a, b, c, d])?;
        Ok(true)
    }

    /// Tries to move every vertex once (in their order, so the same for any number of
    /// threads); how many it moved.
    fn relocate_round(&mut self) -> Result<usize> {
        let mut moved = 0;
        for v in 0..self.points.len() as u32 {
            if !self.around[v as usize].is_empty() && self.try_relocate(v)? {
                moved += 1;
            }
        }
        Ok(moved)
    }

    /// Moves vertex `v` to the one of a few positions (its quadric's minimiser, and a fifth of
    /// the bound off the surface either way) where the input pieces its triangles answer for
    /// fit the lowest `RELOCATION_LEVELS` step, the first of them on a tie, when that is lower
    /// than where it is and the move keeps every guarantee; whether it moved.
    fn try_relocate(&mut self, v: u32) -> Result<bool> {
        if self.settled[v as usize] {
            return Ok(false);
        }
        // Whatever changes v's triangles again unsettles it (`set_triangle`).
        self.settled[v as usize] = true;
        let star = self.around[v as usize].clone();
        let here = self.points[v as usize];
        let displaced = self
            .pieces
            .displaced(&star, |t| star.binary_search(&t).ok());
        // Levels are searched from the top, where nearly every vertex stays after the
        // collapses: most stars cost one proof, most positions another.
        let level_below = |position: DVec3, from: usize| {
            let targets: Vec<Target> = star
                .iter()
                .map(|&t| {
                    let (corners, vertices) = self.relocated_triangle(v, t, position);
                    Target::new(corners, vertices)
                })
                .collect();
            let mut level = from;
            while level > 0
                && displaced
                    .place(&targets, RELOCATION_LEVELS[level - 1] * self.limit)
                    .is_ok()
            {
                level -= 1;
            }
            level
        };
        let current = level_below(here, RELOCATION_LEVELS.len());
        if current == 0 {
            return Ok(false);
        }
        let normal = self.normal_around(&star);
        let mut best = (current, here);
        for position in [
            self.quadrics[v as usize].minimiser_near(here),
            here + normal * (0.2 * self.limit),
            here - normal * (0.2 * self.limit),
        ] {
            let level = level_below(position, best.0);
            if level < best.0 {
                best = (level, position);
            }
        }
        if best.0 == current {
            return Ok(false);
        }
        let position = best.1;
        let after: Vec<([DVec3; 3], [u32; 3])> = star
            .iter()
            .map(|&t| self.relocated_triangle(v, t, position))
            .collect();
        let change = Change {
            replaced: &star,
            removed: &[],
            origin: here,
        };
        let Ok(admitted) = self.admissible(&change, &after, &displaced) else {
            return Ok(false);
        };
        self.points[v as usize] = position;
        self.apply(&change, &after, admitted);
        self.stamps[v as usize] = self.stamps[v as usize].wrapping_add(1);
        let around = self.neighbours(v);
        let edges = around.iter().map(|&w| (v.min(w), v.max(w))).collect();
        self.queue_again(edges, &around)?;
        Ok(true)
    }

    /// Triangle `t`'s corners and vertices with its vertex `v` at `position`.
    fn relocated_triangle(&self, v: u32, t: u32, position: DVec3) -> ([DVec3; 3], [u32; 3]) {
        let vertices = self.triangles[t as usize];
        let corners = vertices.map(|w| {
            if w == v {
                position
            } else {
                self.points[w as usize]
            }
        });
        (corners, vertices)
    }

    /// The unit normal of a set of triangles, weighted by their areas.
    fn normal_around(&self, triangles: &[u32]) -> DVec3 {
        triangles
            .iter()
            .map(|&t| {
                let [p, q, r] = self.corners(t);
                (q - p).cross(r - p)
            })
            .sum::<DVec3>()
            .normalize_or_zero()
    }

    /// Collapses edges from the queue until it is empty.
    fn drain(
        &mut self,
        estimate: &mut Estimate,
        progress: &mut dyn FnMut(f64) -> bool,
    ) -> Result<()> {
        /// Queue entries taken between two reports.
        const REPORT_EVERY: usize = 1024;
        while let Some(Reverse((_, a, b, stamp_a, stamp_b))) = self.queue.pop() {
            estimate.popped += 1;
            if estimate.popped % REPORT_EVERY == 0 {
                // Collapses and flips queue edges again, so the queue's length only bounds
                // what is left; the estimate rises to 1 as it drains.
                let popped = estimate.popped as f64;
                let fraction = popped / (popped + self.queue.len() as f64);
                estimate.reported = estimate.reported.max(fraction);
                if !progress(estimate.reported) {
                    return Err(Error::cancelled(
                        "cancelled by the progress callback during simplification",
                    ));
                }
            }
            if self.stamps[a as usize] != stamp_a
                || self.stamps[b as usize] != stamp_b
                || self.around[a as usize].is_empty()
                || self.around[b as usize].is_empty()
            {
                continue;
            }
            if !self.try_collapse(a, b)? {
                allocation::reserved::<(u32, u32)>(
                    self.refused.try_reserve(1),
                    self.refused.len() + 1,
                    "the refused collapses",
                )?;
                self.refused.insert((a, b));
            }
        }
        Ok(())
    }

    fn corners(&self, t: u32) -> [DVec3; 3] {
        self.triangles[t as usize].map(|v| self.points[v as usize])
    }

    /// The vertices sharing a triangle with `v`, sorted.
    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut found: Vec<u32> = self.around[v as usize]
            .iter()
            .flat_map(|&t| self.triangles[t as usize])
            .filter(|&w| w != v)
            .collect();
        found.sort_unstable();
        found.dedup();
        found
    }

    fn enqueue(&mut self, a: u32, b: u32) -> Result<()> {
        // Stale entries stay queued until popped, so the queue may outgrow the mesh.
        let room = self.queue.len() + 1;
        allocation::reserved::<QueueEntry>(
            self.queue.try_reserve(1),
            room,
            "the collapses' queue",
        )?;
        let q = self.quadrics[a as usize] + self.quadrics[b as usize];
        let cost = q.placements(self.points[a as usize], self.points[b as usize])[0].0;
        // Non-negative floats order as their bits do.
        self.queue.push(Reverse((
            cost.to_bits(),
            a,
            b,
            self.stamps[a as usize],
            self.stamps[b as usize],
        )));
        Ok(())
    }

    /// The star of the edge, or `None` when collapsing it would change the topology.
    fn star(&self, keep: u32, remove: u32) -> Option<Star> {
        let shared: Vec<u32> = self.around[keep as usize]
            .iter()
            .copied()
            .filter(|&t| self.triangles[t as usize].contains(&remove))
            .collect();
        let &[first, second] = shared.as_slice() else {
            return None;
        };
        let opposite = |t: u32| {
            self.triangles[t as usize]
                .into_iter()
                .find(|&v| v != keep && v != remove)
                .expect("a triangle has three distinct vertices")
        };
        let (c, d) = (opposite(first), opposite(second));
        let (from_keep, from_remove) = (self.neighbours(keep), self.neighbours(remove));
        let common = from_keep
            .iter()
            .filter(|v| from_remove.binary_search(v).is_ok())
            .count();
        if common != 2 || self.around[c as usize].len() <= 3 || self.around[d as usize].len() <= 3 {
            return None;
        }
        let mut moved: Vec<u32> = self.around[keep as usize]
            .iter()
            .chain(&self.around[remove as usize])
            .copied()
            .filter(|&t| t != first && t != second)
            .collect();
        moved.sort_unstable();
        moved.dedup();
        Some(Star {
            keep,
            remove,
            deleted: [first, second],
            moved,
        })
    }

    /// Collapses `a`–`b` at the first placement that keeps every guarantee, if one does;
    /// whether it did.
    fn try_collapse(&mut self, a: u32, b: u32) -> Result<bool> {
        let Some(star) = self.star(a, b) else {
            return Ok(false);
        };
        let q = self.quadrics[a as usize] + self.quadrics[b as usize];
        let mut tried = q.placements(self.points[a as usize], self.points[b as usize]);
        // Then the best of those moved off the surface, on either side: where the surface
        // curves, a vertex on it makes chords that sag to one side, and one off it splits the
        // error between both. Half the bound first; a quarter and three quarters take 3.7%
        // fewer triangles on the aorta at 0.1 mm for 8% more time (an eighth-step ladder only
        // 2% more).
        let from: Vec<u32> = star.deleted.iter().chain(&star.moved).copied().collect();
        let normal = self.normal_around(&from);
        let best = tried[0].1;
        tried.extend(
            [0.5, -0.5, 0.25, -0.25, 0.75, -0.75]
                .map(|fraction| (0.0, best + normal * (fraction * self.limit))),
        );
        let displaced = self
            .pieces
            .displaced(&from, |t| star.moved.binary_search(&t).ok());
        let mut closest: Option<(DVec3, Miss)> = None;
        for (_, position) in tried {
            match self.collapse_at(&star, &displaced, position)? {
                Ok(()) => return Ok(true),
                Err(Some(miss))
                    if closest.map_or(true, |(_, c)| miss.distance() < c.distance()) =>
                {
                    closest = Some((position, miss));
                }
                Err(_) => {}
            }
        }
        for _ in 0..REFINEMENTS {
            let Some((position, miss)) = closest else {
                break;
            };
            // Twice the excess over nine tenths of the bound: the kept vertex carries about
            // half the motion of its triangles' points where the miss lies.
            let excess = miss.distance() - 0.9 * self.limit;
            let step = (2.0 * excess).min(self.limit) / miss.distance();
            let position = position + (miss.corner - miss.nearest) * step;
            match self.collapse_at(&star, &displaced, position)? {
                Ok(()) => return Ok(true),
                Err(miss) => closest = miss.map(|miss| (position, miss)),
            }
        }
        Ok(false)
    }

    /// Collapses `star` to `position` if that keeps every guarantee; otherwise the input point
    /// that missed the bound there, when that was the reason.
    fn collapse_at(
        &mut self,
        star: &Star,
        displaced: &Displaced,
        position: DVec3,
    ) -> Result<std::result::Result<(), Option<Miss>>> {
        let after: Vec<([DVec3; 3], [u32; 3])> = star
            .moved
            .iter()
            .map(|&t| self.moved_triangle(star, t, position))
            .collect();
        let change = Change {
            replaced: &star.moved,
            removed: &star.deleted,
            origin: self.points[star.keep as usize],
        };
        Ok(match self.admissible(&change, &after, displaced) {
            Ok(admitted) => {
                self.commit(star, &change, &after, position, admitted)?;
                Ok(())
            }
            Err(miss) => Err(miss),
        })
    }

    /// A moved triangle's vertices and corners after the collapse.
    fn moved_triangle(&self, star: &Star, t: u32, position: DVec3) -> ([DVec3; 3], [u32; 3]) {
        let vertices =
            self.triangles[t as usize].map(|v| if v == star.remove { star.keep } else { v });
        let corners = vertices.map(|v| {
            if v == star.keep {
                position
            } else {
                self.points[v as usize]
            }
        });
        (corners, vertices)
    }

    /// Checks 2–4 for the collapse of `star` to `position`: what the collapse would answer
    /// for, or why not (`Some` when an input point would be farther than the bound).
    fn admissible(
        &mut self,
        change: &Change,
        after: &[([DVec3; 3], [u32; 3])],
        displaced: &Displaced,
    ) -> std::result::Result<Admitted, Option<Miss>> {
        for (&t, (corners, _)) in change.replaced.iter().zip(after) {
            let [p, q, r] = self.corners(t);
            let before = (q - p).cross(r - p);
            let [p, q, r] = *corners;
            if before.dot((q - p).cross(r - p)) <= 0.0 || !self.well_shaped(*corners) {
                return Err(None);
            }
        }
        let component = self.input.component(change.replaced[0]);
        let old_volume = self.volumes[component as usize];
        let volume = old_volume + self.volume_change(change, after);
        if volume * old_volume <= 0.0 {
            return Err(None);
        }
        // The distance bound before the self-intersection search: most tried collapses fail
        // the bound, and hardly any of those that pass it intersect.
        let targets: Vec<Target> = after
            .iter()
            .map(|&(corners, vertices)| Target::new(corners, vertices))
            .collect();
        let placed = displaced.place(&targets, self.limit)?;
        if self.intersects_after(change, after) {
            return Err(None);
        }
        let mut scratch = std::mem::take(&mut self.scratch);
        let covered = after.iter().all(|&(corners, _)| {
            self.input
                .covers(corners, component, self.limit, &mut scratch)
        });
        self.scratch = scratch;
        if !covered {
            return Err(None);
        }
        Ok(Admitted {
            pieces: placed,
            volume,
        })
    }

    /// How much the collapse changes its component's signed volume: the old star and the new
    /// one close over the same boundary, so the change is their difference, measured from
    /// any point (the kept vertex, for precision).
    fn volume_change(&self, change: &Change, after: &[([DVec3; 3], [u32; 3])]) -> f64 {
        let origin = change.origin;
        let volume = |[a, b, c]: [DVec3; 3]| (a - origin).dot((b - origin).cross(c - origin)) / 6.0;
        let new: f64 = after.iter().map(|&(corners, _)| volume(corners)).sum();
        let old: f64 = change
            .replaced
            .iter()
            .chain(change.removed)
            .map(|&t| volume(self.corners(t)))
            .sum();
        new - old
    }

    /// No angle below the floor (which also rules out degenerate triangles).
    fn well_shaped(&self, [p, q, r]: [DVec3; 3]) -> bool {
        let corners = [(p, q, r), (q, r, p), (r, p, q)];
        corners.iter().all(|&(at, u, v)| {
            let (x, y) = (u - at, v - at);
            let lengths = x.length() * y.length();
            lengths > 0.0 && x.dot(y) <= self.cos_min_angle * lengths
        })
    }

    /// Whether a moved triangle would meet another triangle, moved or not, other than where
    /// the mesh joins them. The grid holds the moved triangles where they were, so they are
    /// tested against each other directly and against the grid's others.
    fn intersects_after(&mut self, change: &Change, after: &[([DVec3; 3], [u32; 3])]) -> bool {
        let boxes: Vec<Bounds> = after
            .iter()
            .map(|&(corners, _)| Bounds::of(corners))
            .collect();
        for (k, &moved) in after.iter().enumerate() {
            for (j, &other) in after.iter().enumerate().skip(k + 1) {
                if boxes[k].overlaps(&boxes[j]) && mesh_triangles_intersect(moved, other) {
                    return true;
                }
            }
        }
        let mut near = std::mem::take(&mut self.scratch);
        let found = after.iter().zip(&boxes).any(|(&moved, bounds)| {
            self.grid.query(bounds, &mut near);
            near.iter().any(|&other| {
                let unchanged = self.alive[other as usize]
                    && !change.removed.contains(&other)
                    && change.replaced.binary_search(&other).is_err();
                unchanged
                    && bounds.overlaps(&self.bounds[other as usize])
                    && mesh_triangles_intersect(
                        moved,
                        (self.corners(other), self.triangles[other as usize]),
                    )
            })
        });
        self.scratch = near;
        found
    }

    /// Collapses `star` to `position`, as `change` and `after` describe it and `admissible`
    /// admitted it.
    fn commit(
        &mut self,
        star: &Star,
        change: &Change,
        after: &[([DVec3; 3], [u32; 3])],
        position: DVec3,
        admitted: Admitted,
    ) -> Result<()> {
        let (keep, remove) = (star.keep, star.remove);
        for &t in &star.deleted {
            self.alive[t as usize] = false;
            self.grid.remove(t, &self.bounds[t as usize]);
            for v in self.triangles[t as usize] {
                self.around[v as usize].retain(|&u| u != t);
            }
        }
        let moved_from_remove = std::mem::take(&mut self.around[remove as usize]);
        self.around[keep as usize].extend(moved_from_remove);
        self.around[keep as usize].sort_unstable();
        self.around[keep as usize].dedup();
        self.points[keep as usize] = position;
        self.quadrics[keep as usize] =
            self.quadrics[keep as usize] + self.quadrics[remove as usize];
        self.merged_into[remove as usize] = keep;
        self.apply(change, after, admitted);
        self.stamps[keep as usize] = self.stamps[keep as usize].wrapping_add(1);
        let around_keep = self.neighbours(keep);
        let edges = around_keep
            .iter()
            .map(|&w| (keep.min(w), keep.max(w)))
            .collect();
        self.queue_again(edges, &around_keep)
    }

    /// The end every admitted change shares, once its points are where `after` has them: its
    /// component's volume, the input pieces its triangles answer for, and the replaced
    /// triangles' new vertices.
    fn apply(&mut self, change: &Change, after: &[([DVec3; 3], [u32; 3])], admitted: Admitted) {
        let component = self.input.component(change.replaced[0]);
        self.volumes[component as usize] = admitted.volume;
        self.pieces
            .commit(change.removed, change.replaced, admitted.pieces);
        for (&t, &(_, vertices)) in change.replaced.iter().zip(after) {
            self.set_triangle(t, vertices);
        }
    }

    /// Gives live triangle `t` new `vertices` (which may then move again), and the grid its
    /// new box.
    fn set_triangle(&mut self, t: u32, vertices: [u32; 3]) {
        self.grid.remove(t, &self.bounds[t as usize]);
        self.triangles[t as usize] = vertices;
        for v in vertices {
            self.settled[v as usize] = false;
        }
        let bounds = Bounds::of(self.corners(t));
        self.grid.insert(t, &bounds);
        self.bounds[t as usize] = bounds;
    }

    /// Queues `edges` (lower vertex first), and the refused edges at the `changed` vertices,
    /// whose stars a change may have opened.
    fn queue_again(&mut self, mut edges: Vec<(u32, u32)>, changed: &[u32]) -> Result<()> {
        for &v in changed {
            for w in self.neighbours(v) {
                let edge = (v.min(w), v.max(w));
                if self.refused.contains(&edge) {
                    edges.push(edge);
                }
            }
        }
        edges.sort_unstable();
        edges.dedup();
        for (v, w) in edges {
            self.refused.remove(&(v, w));
            self.enqueue(v, w)?;
        }
        Ok(())
    }

    fn into_result(self) -> Result<Simplified> {
        let mut new_index = allocation::filled(self.points.len(), NO_VERTEX, "the vertex map")?;
        let mut points = Vec::new();
        let mut triangles = Vec::new();
        for (t, tri) in self.triangles.iter().enumerate() {
            if !self.alive[t] {
                continue;
            }
            triangles.push(tri.map(|v| {
                let slot = &mut new_index[v as usize];
                if *slot == NO_VERTEX {
                    *slot = points.len() as u32;
                    points.push(self.points[v as usize]);
                }
                *slot
            }));
        }
        let mut root = self.merged_into;
        for v in 0..root.len() {
            // Merges point to a vertex alive at the time, so following them ends at a survivor;
            // pointing each vertex at its root on the way keeps later walks short.
            let mut r = v;
            while root[r] as usize != r {
                r = root[r] as usize;
            }
            let mut w = v;
            while root[w] as usize != r {
                let next = root[w] as usize;
                root[w] = r as u32;
                w = next;
            }
        }
        let vertex_map = root.iter().map(|&r| new_index[r as usize]).collect();
        let mesh = TriMesh::new(points, triangles)
            .expect("collapses keep every index in range and every point finite");
        Ok(Simplified { mesh, vertex_map })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::ErrorKind;
    use crate::evaluation::hausdorff_distance;
    use crate::marching_cubes::marching_cubes;
    use crate::mesh::test_shapes::{icosphere, torus};
    use crate::phantom::random::SplitMix64;
    use crate::{Geometry, Image};

    fn smallest_angle_degrees([p, q, r]: [DVec3; 3]) -> f64 {
        [(p, q, r), (q, r, p), (r, p, q)]
            .iter()
            .map(|&(at, u, v)| (u - at).angle_between(v - at).to_degrees())
            .fold(f64::INFINITY, f64::min)
    }

    /// Every promise of `simplify`, measured on its result.
    fn assert_guarantees(input: &TriMesh, out: &Simplified, max_error: f64) {
        let (before, after) = (check(input), check(&out.mesh));
        assert!(after.closed() && after.manifold() && after.consistently_oriented());
        assert_eq!(after.genus(), before.genus());
        assert_eq!(after.components, before.components);
        assert_eq!(after.inward_components, before.inward_components);
        assert_eq!(after.unreferenced_vertices, 0);
        assert!(self_intersections(&out.mesh).unwrap().is_empty());
        let (input_to_output, output_to_input) = hausdorff_distance(input, &out.mesh, 6).unwrap();
        assert!(
            input_to_output <= max_error && output_to_input <= max_error,
            "Hausdorff {input_to_output} / {output_to_input} over {max_error}"
        );
        let bits = |c: [DVec3; 3]| {
            let mut key = c.map(|p| p.to_array().map(f64::to_bits));
            key.sort_unstable();
            key
        };
        let kept: std::collections::HashSet<_> = (0..input.triangles().len())
            .map(|t| bits(input.corners(t)))
            .collect();
        for t in 0..out.mesh.triangles().len() {
            let corners = out.mesh.corners(t);
            assert!(
                kept.contains(&bits(corners))
                    || smallest_angle_degrees(corners) >= MIN_ANGLE_DEGREES - 1e-9,
                "triangle {t} has an angle of {}°",
                smallest_angle_degrees(corners)
            );
        }
        assert_eq!(out.vertex_map.len(), input.points().len());
        let n = out.mesh.points().len() as u32;
        assert!(out.vertex_map.iter().all(|&v| v < n));
        let mut reached = out.vertex_map.clone();
        reached.sort_unstable();
        reached.dedup();
        assert_eq!(
            reached.len(),
            n as usize,
            "every output vertex comes from the input"
        );
    }

    #[test]
    fn a_sphere_is_reduced_within_the_bound_and_keeps_every_guarantee() {
        let sphere = icosphere(DVec3::new(1.0, -2.0, 3.0), 10.0, 4);
        for max_error in [0.05, 0.2] {
            let out = simplify(&sphere, max_error).unwrap();
            assert_guarantees(&sphere, &out, max_error);
            assert!(out.mesh.triangles().len() * 2 < sphere.triangles().len());
        }
    }

    #[test]
    fn progress_rises_to_the_end_and_a_cancel_returns_nothing() {
        let sphere = icosphere(DVec3::ZERO, 10.0, 4);
        let mut fractions = Vec::new();
        let out = simplify_with_progress(&sphere, 0.05, |f| {
            fractions.push(f);
            true
        })
        .unwrap();
        assert_eq!(out, simplify(&sphere, 0.05).unwrap());
        assert!(fractions.len() >= 3, "{fractions:?}");
        assert!(fractions.windows(2).all(|w| w[0] <= w[1]), "{fractions:?}");
        assert!(fractions[0] > 0.0 && fractions[fractions.len() - 1] <= 1.0);
        let mut calls = 0;
        let cancelled = simplify_with_progress(&sphere, 0.05, |_| {
            calls += 1;
            calls < 2
        })
        .unwrap_err();
        assert_eq!(cancelled.kind(), crate::ErrorKind::Cancelled);
        assert!(cancelled.message().contains("simplification"));
    }

    #[test]
    fn flips_change_the_triangulation_and_keep_every_guarantee_before_and_after_collapses() {
        // A marching-cubes ellipsoid in anisotropic voxels: its diagonals follow the grid, not
        // the surface, so many flips flatten it.
        let geometry = Geometry::with_spacing([1.0, 1.0, 1.5], [0.0; 3]).unwrap();
        let image = Image::from_fn([16, 16, 12], geometry, |i, j, k| {
            let p = DVec3::new(i as f64 - 7.4, j as f64 - 7.7, 1.5 * k as f64 - 8.1);
            (1.0 - (p / DVec3::new(6.0, 5.0, 7.0)).length()) as f32
        })
        .unwrap();
        let mesh = marching_cubes(&image.view(), 0.0).unwrap();
        let max_error = 0.2;
        let mut flipped_only = Simplifier::new(&mesh, max_error).unwrap();
        let flipped = flipped_only.flip_round().unwrap();
        assert!(flipped > 10, "{flipped} flips");
        let sorted = |mut t: [u32; 3]| {
            t.sort_unstable();
            t
        };
        let before: HashSet<[u32; 3]> = mesh.triangles().iter().map(|&t| sorted(t)).collect();
        let changed = flipped_only
            .triangles
            .iter()
            .filter(|&&t| !before.contains(&sorted(t)))
            .count();
        // Two new triangles a flip, unless a later flip in the round took one of them again.
        assert!(
            changed > flipped && changed <= 2 * flipped,
            "{changed} for {flipped}"
        );
        assert_guarantees(&mesh, &flipped_only.into_result().unwrap(), max_error);
        // And the collapses after them, with the input's pieces the flips moved.
        let mut simplifier = Simplifier::new(&mesh, max_error).unwrap();
        simplifier.flip_round().unwrap();
        simplifier.run(&mut |_| true).unwrap();
        assert_guarantees(&mesh, &simplifier.into_result().unwrap(), max_error);
    }

    #[test]
    fn vertex_moves_lower_the_error_near_the_bound_and_keep_every_guarantee() {
        // A torus after the collapses: nearly every star answers for input pieces close to the
        // bound, so moves find positions where they fit lower.
        let ring = torus(DVec3::ZERO, 10.0, 3.0, 64, 24);
        let max_error = 0.1;
        let mut simplifier = Simplifier::new(&ring, max_error).unwrap();
        simplifier
            .drain(&mut Estimate::default(), &mut |_| true)
            .unwrap();
        let before = simplifier.points.clone();
        let moved = simplifier.relocate_round().unwrap();
        let changed = before
            .iter()
            .zip(&simplifier.points)
            .filter(|(p, q)| p != q)
            .count();
        assert!(
            moved > 10 && changed == moved,
            "{moved} moves, {changed} points changed"
        );
        // A second round tries again only the vertices whose triangles changed.
        let live: Vec<usize> = (0..before.len())
            .filter(|&v| !simplifier.around[v].is_empty())
            .collect();
        let unsettled = live.iter().filter(|&&v| !simplifier.settled[v]).count();
        assert!(
            unsettled < live.len() / 2,
            "{unsettled} of {} unsettled",
            live.len()
        );
        assert_guarantees(&ring, &simplifier.into_result().unwrap(), max_error);
    }

    #[test]
    fn a_torus_keeps_its_genus_and_two_spheres_stay_two() {
        let ring = torus(DVec3::ZERO, 10.0, 3.0, 64, 24);
        let out = simplify(&ring, 0.1).unwrap();
        assert_guarantees(&ring, &out, 0.1);
        assert_eq!(check(&out.mesh).genus(), Some(1));
        let mut two = icosphere(DVec3::ZERO, 5.0, 3);
        two.append(&icosphere(DVec3::X * 10.4, 5.0, 3)).unwrap();
        let out = simplify(&two, 0.3).unwrap();
        assert_guarantees(&two, &out, 0.3);
    }

    #[test]
    fn each_component_keeps_the_bound_to_itself_where_two_come_closer_than_it() {
        // Two spheres 0.1 mm apart, simplified within 0.3 mm: a point of one's result must not
        // lean on the other's input.
        let (left, right) = (
            icosphere(DVec3::ZERO, 5.0, 3),
            icosphere(DVec3::X * 10.1, 5.0, 3),
        );
        let mut two = left.clone();
        two.append(&right).unwrap();
        let out = simplify(&two, 0.3).unwrap();
        assert_guarantees(&two, &out, 0.3);
        let first_points = left.points().len();
        let part = |of_left: bool| {
            let (points, triangles) = out.mesh.clone().into_parts();
            let from_left: Vec<bool> = (0..points.len())
                .map(|v| out.vertex_map[..first_points].contains(&(v as u32)))
                .collect();
            let kept = triangles
                .into_iter()
                .filter(|t| from_left[t[0] as usize] == of_left)
                .collect();
            TriMesh::new(points, kept).unwrap()
        };
        for (input, of_left) in [(&left, true), (&right, false)] {
            let (there, back) = hausdorff_distance(input, &part(of_left), 6).unwrap();
            assert!(there <= 0.3 && back <= 0.3, "{there} / {back}");
        }
    }

    #[test]
    fn an_inward_mesh_stays_inward() {
        let inward = icosphere(DVec3::ZERO, 8.0, 3).flipped();
        let out = simplify(&inward, 0.1).unwrap();
        assert_guarantees(&inward, &out, 0.1);
        assert!(out.mesh.signed_volume() < 0.0);
    }

    /// Five voxels (a 2×2 square and one more on a corner of it) as marching cubes makes them.
    fn five_voxels(spacing: f64) -> TriMesh {
        let filled = [[1, 1, 1], [2, 1, 1], [1, 2, 1], [2, 2, 1], [2, 1, 2]];
        let geometry = Geometry::with_spacing([spacing; 3], [0.0; 3]).unwrap();
        let image = Image::from_fn([4, 4, 4], geometry, |i, j, k| {
            f32::from(u8::from(filled.contains(&[i, j, k])))
        })
        .unwrap();
        marching_cubes(&image.view(), 0.5).unwrap()
    }

    #[test]
    fn regression_a_small_component_was_turned_inside_out_under_a_large_bound() {
        // The c_abi fuzzer's balloon_segment with simplify_error_mm 196 returned an inside-out
        // tetrahedron: each collapse kept every normal within 90° of its old one, yet the last
        // ones moved a vertex through the opposite side. 36 triangles of five voxels did it too.
        for mesh in [five_voxels(1.0), five_voxels(1.86).flipped()] {
            let sign = mesh.signed_volume().signum();
            for max_error in [0.5, 2.0, 196.0] {
                let out = simplify(&mesh, max_error).unwrap();
                assert_guarantees(&mesh, &out, max_error);
                assert_eq!(out.mesh.signed_volume().signum(), sign, "at {max_error} mm");
            }
        }
    }

    #[test]
    fn random_voxel_clusters_keep_every_guarantee_under_any_bound() {
        // The family the regression above came from: small clusters, often several components
        // and some with handles, inward as marching cubes makes them or flipped outward.
        let mut rng = SplitMix64::new(19);
        for variant in 0..150 {
            let density = rng.uniform(0.3, 0.8);
            let filled: Vec<bool> = (0..5 * 3 * 5).map(|_| rng.unit() < density).collect();
            let geometry = Geometry::with_spacing(
                [
                    rng.uniform(0.5, 2.0),
                    rng.uniform(0.5, 2.0),
                    rng.uniform(0.5, 2.0),
                ],
                [0.0; 3],
            )
            .unwrap();
            let image = Image::from_fn([7, 5, 7], geometry, |i, j, k| {
                let inside = (1..6).contains(&i) && (1..4).contains(&j) && (1..6).contains(&k);
                let filled = inside && filled[(i - 1) + 5 * ((j - 1) + 3 * (k - 1))];
                f32::from(u8::from(filled))
            })
            .unwrap();
            let mesh = marching_cubes(&image.view(), 0.5).unwrap();
            let mesh = if variant % 2 == 0 {
                mesh
            } else {
                mesh.flipped()
            };
            let max_error = [0.3, 3.0, 196.0][variant % 3];
            let out = simplify(&mesh, max_error).unwrap();
            assert_guarantees(&mesh, &out, max_error);
        }
    }

    #[test]
    fn a_bound_larger_than_the_shape_stops_at_a_small_valid_mesh() {
        let sphere = icosphere(DVec3::ZERO, 5.0, 3);
        let out = simplify(&sphere, 100.0).unwrap();
        assert_guarantees(&sphere, &out, 100.0);
        assert!(out.mesh.triangles().len() >= 4 && out.mesh.triangles().len() <= 40);
    }

    #[test]
    fn a_bound_that_is_not_a_positive_distance_is_an_invalid_argument() {
        let sphere = icosphere(DVec3::ZERO, 5.0, 2);
        for bad in [0.0, -0.1, f64::NAN, f64::INFINITY] {
            let e = simplify(&sphere, bad).unwrap_err();
            assert_eq!(e.kind(), ErrorKind::InvalidArgument);
            assert!(e.message().contains("positive distance"), "{e}");
        }
    }

    #[test]
    fn a_mesh_without_the_guarantees_is_an_invalid_mesh_that_says_why() {
        let sphere = icosphere(DVec3::ZERO, 5.0, 2);
        let (points, mut triangles) = sphere.clone().into_parts();
        triangles.pop();
        let open = TriMesh::new(points, triangles).unwrap();
        let mut overlapping = sphere.clone();
        overlapping.append(&icosphere(DVec3::X, 5.0, 2)).unwrap();
        let (points, mut triangles) = sphere.into_parts();
        triangles[0].swap(0, 1);
        let misoriented = TriMesh::new(points, triangles).unwrap();
        for (mesh, reason) in [
            (TriMesh::default(), "no triangles"),
            (open, "not closed"),
            (overlapping, "intersect"),
            (misoriented, "consistently oriented"),
        ] {
            let e = simplify(&mesh, 0.1).unwrap_err();
            assert_eq!(e.kind(), ErrorKind::InvalidMesh);
            assert!(e.message().contains(reason), "{e}");
        }
    }

    #[test]
    fn the_result_is_the_same_for_any_number_of_threads() {
        let ring = torus(DVec3::ZERO, 10.0, 3.0, 48, 16);
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| simplify(&ring, 0.15).unwrap())
        };
        assert_eq!(run(1), run(2));
    }
}
