//! Tubes along polylines: vessels, wires and rings as one solid, whose distance query also
//! says which polyline is nearest and the arc length of its nearest centre-line point (what a
//! contrast that drifts along a vessel is a function of).
//!
//! A tube is the union of its segments' capsules, the radius interpolated linearly along each
//! segment so that a vessel can taper; a segment's distance is the distance to its nearest
//! centre-line point minus the radius there, divided by (1 + the steepest taper) to stay a
//! 1-Lipschitz bound (exact for constant radii). The nearest segment is found by branch and
//! bound in a bounding-volume hierarchy of axis-aligned boxes (median splits, leaves of a few
//! segments), so that a stent of thousands of wire segments costs a few dozen box tests per
//! point. Ties keep the segment met first in a fixed traversal order, so the answer never
//! depends on threads.

use glam::DVec3;

use super::sdf::Sdf;
use crate::error::{Error, Result};

/// One centre line: points and the tube's radius at each.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    pub points: Vec<DVec3>,
    pub radii: Vec<f64>,
}

impl Path {
    /// A path of constant radius.
    pub fn uniform(points: Vec<DVec3>, radius: f64) -> Path {
        let radii = vec![radius; points.len()];
        Path { points, radii }
    }

    /// Length of the centre line.
    pub fn length(&self) -> f64 {
        self.points.windows(2).map(|w| w[0].distance(w[1])).sum()
    }

    /// The centre-line point at arc length `s` (clamped to the path).
    pub fn at(&self, s: f64) -> DVec3 {
        let mut left = s.max(0.0);
        for w in self.points.windows(2) {
            let length = w[0].distance(w[1]);
            if left <= length && length > 0.0 {
                return w[0].lerp(w[1], left / length);
            }
            left -= length;
        }
        self.points[self.points.len() - 1]
    }
}

/// The nearest tube to a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    /// Signed distance (bound) to the union of the tubes.
    pub distance: f64,
    /// Index of the nearest path.
    pub path: usize,
    /// Arc length along that path of its nearest centre-line point.
    pub arc_length: f64,
}

#[derive(Debug, Clone, Copy)]
struct Segment {
    a: DVec3,
    b: DVec3,
    radius_a: f64,
    radius_b: f64,
    path: usize,
    /// Arc length of the path at `a`.
    start: f64,
}

impl Segment {
    /// Distance to the centre line minus the radius, and the parameter of the nearest point.
    fn evaluate(&self, p: DVec3) -> (f64, f64) {
        let ab = self.b - self.a;
        let t = ((p - self.a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
        let radius = self.radius_a + t * (self.radius_b - self.radius_a);
        ((p - (self.a + t * ab)).length() - radius, t)
    }

    fn taper(&self) -> f64 {
        (self.radius_b - self.radius_a).abs() / self.a.distance(self.b)
    }
}

#[derive(Debug, Clone, Copy)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// The largest radius below the node.
    radius: f64,
    /// A leaf's segments `first..first + count`; an inner node's children are `first` and
    /// `first + 1` (`count == 0`).
    first: usize,
    count: usize,
}

impl Node {
    /// No segment below the node is nearer than this.
    fn lower_bound(&self, p: DVec3) -> f64 {
        (self.lo - p).max(p - self.hi).max(DVec3::ZERO).length() - self.radius
    }
}

const LEAF_SIZE: usize = 4;

/// Tubes along a set of paths, as one solid.
#[derive(Debug, Clone)]
pub struct Tubes {
    segments: Vec<Segment>,
    nodes: Vec<Node>,
    /// 1 + the steepest taper of any segment.
    lipschitz: f64,
}

impl Tubes {
    /// Errors unless every path has two or more points, as many positive finite radii, and no
    /// segment of zero length.
    pub fn new(paths: &[Path]) -> Result<Tubes> {
        let mut segments = Vec::new();
        for (index, path) in paths.iter().enumerate() {
            if path.points.len() < 2 || path.radii.len() != path.points.len() {
                return Err(Error::invalid_argument(format!(
                    "tube {index} has {} points and {} radii; give two or more points and a \
                     radius for each",
                    path.points.len(),
                    path.radii.len()
                )));
            }
            if !path.radii.iter().all(|r| r.is_finite() && *r > 0.0)
                || !path.points.iter().all(|p| p.is_finite())
            {
                return Err(Error::invalid_argument(format!(
                    "tube {index} has a point that is not finite or a radius that is not \
                     positive"
                )));
            }
            let mut start = 0.0;
            for (w, r) in path.points.windows(2).zip(path.radii.windows(2)) {
                let length = w[0].distance(w[1]);
                if length <= 0.0 {
                    return Err(Error::invalid_argument(format!(
                        "tube {index} repeats the point {}; consecutive points must differ",
                        w[0]
                    )));
                }
                segments.push(Segment {
                    a: w[0],
                    b: w[1],
                    radius_a: r[0],
                    radius_b: r[1],
                    path: index,
                    start,
                });
                start += length;
            }
        }
        if segments.is_empty() {
            return Err(Error::invalid_argument(
                "a tube set needs at least one path",
            ));
        }
        let lipschitz = 1.0 + segments.iter().map(Segment::taper).fold(0.0, f64::max);
        let mut tubes = Tubes {
            segments,
            nodes: Vec::new(),
            lipschitz,
        };
        tubes.nodes.push(tubes.bounds(0, tubes.segments.len()));
        tubes.split(0);
        Ok(tubes)
    }

    fn bounds(&self, first: usize, count: usize) -> Node {
        let mut node = Node {
            lo: DVec3::INFINITY,
            hi: DVec3::NEG_INFINITY,
            radius: 0.0,
            first,
            count,
        };
        for s in &self.segments[first..first + count] {
            node.lo = node.lo.min(s.a.min(s.b));
            node.hi = node.hi.max(s.a.max(s.b));
            node.radius = node.radius.max(s.radius_a).max(s.radius_b);
        }
        node
    }

    /// Splits node `index` at the median of its segments' midpoints along its longest axis,
    /// down to leaves.
    fn split(&mut self, index: usize) {
        let Node {
            lo,
            hi,
            first,
            count,
            ..
        } = self.nodes[index];
        if count <= LEAF_SIZE {
            return;
        }
        let extent = hi - lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let half = count / 2;
        self.segments[first..first + count]
            .select_nth_unstable_by(half, |s, t| (s.a + s.b)[axis].total_cmp(&(t.a + t.b)[axis]));
        let children = self.nodes.len();
        self.nodes.push(self.bounds(first, half));
        self.nodes.push(self.bounds(first + half, count - half));
        self.nodes[index].first = children;
        self.nodes[index].count = 0;
        self.split(children);
        self.split(children + 1);
    }

    /// The nearest tube to `p`, its distance and the arc length of its nearest point.
    pub fn nearest(&self, p: DVec3) -> Nearest {
        let mut best = (f64::INFINITY, 0usize, 0.0f64);
        // Median splits keep the depth under 64 for any number of segments that fits in memory,
        // and a depth-first walk holds at most one pending node per level.
        let mut stack = [0usize; 64];
        let mut pending = 1;
        while pending > 0 {
            pending -= 1;
            let node = &self.nodes[stack[pending]];
            if node.lower_bound(p) >= best.0 {
                continue;
            }
            if node.count > 0 {
                for (k, s) in self.segments[node.first..node.first + node.count]
                    .iter()
                    .enumerate()
                {
                    let (d, t) = s.evaluate(p);
                    if d < best.0 {
                        best = (d, node.first + k, t);
                    }
                }
                continue;
            }
            let (near, far) = (node.first, node.first + 1);
            let (near, far) = if self.nodes[near].lower_bound(p) <= self.nodes[far].lower_bound(p) {
                (near, far)
            } else {
                (far, near)
            };
            stack[pending] = far;
            stack[pending + 1] = near;
            pending += 2;
        }
        let (d, segment, t) = best;
        let s = &self.segments[segment];
        Nearest {
            distance: d / self.lipschitz,
            path: s.path,
            arc_length: s.start + t * s.a.distance(s.b),
        }
    }
}

impl Sdf for Tubes {
    fn distance(&self, p: DVec3) -> f64 {
        self.nearest(p).distance
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::random::SplitMix64;
    use crate::phantom::sdf::segment_distance;

    fn helix(turns: f64, phase: f64, points: usize) -> Vec<DVec3> {
        (0..points)
            .map(|i| {
                let t = i as f64 / (points - 1) as f64 * turns;
                let angle = phase + std::f64::consts::TAU * t;
                DVec3::new(5.0 * angle.cos(), 5.0 * angle.sin(), 12.0 * t)
            })
            .collect()
    }

    #[test]
    fn the_hierarchy_finds_the_same_nearest_segment_as_a_scan() {
        let paths: Vec<Path> = (0..6)
            .map(|k| Path::uniform(helix(3.0, k as f64, 200), 0.2 + 0.05 * k as f64))
            .collect();
        let tubes = Tubes::new(&paths).unwrap();
        let mut rng = SplitMix64::new(9);
        for _ in 0..2000 {
            let p = DVec3::new(
                rng.uniform(-8.0, 8.0),
                rng.uniform(-8.0, 8.0),
                rng.uniform(-4.0, 40.0),
            );
            let scan = paths
                .iter()
                .flat_map(|path| {
                    path.points
                        .windows(2)
                        .map(move |w| segment_distance(p, w[0], w[1]) - path.radii[0])
                })
                .fold(f64::INFINITY, f64::min);
            assert!((tubes.distance(p) - scan).abs() < 1e-12);
        }
    }

    #[test]
    fn the_arc_length_is_that_of_the_nearest_point() {
        let points = vec![DVec3::ZERO, DVec3::X * 10.0, DVec3::new(10.0, 5.0, 0.0)];
        let tubes = Tubes::new(&[
            Path::uniform(vec![DVec3::Z * 30.0, DVec3::Z * 40.0], 1.0),
            Path::uniform(points, 1.0),
        ])
        .unwrap();
        let nearest = tubes.nearest(DVec3::new(11.0, 3.0, 0.5));
        assert_eq!(nearest.path, 1);
        assert!((nearest.arc_length - 13.0).abs() < 1e-12);
        assert!((nearest.distance - (1.25f64.sqrt() - 1.0)).abs() < 1e-12);
    }

    #[test]
    fn a_tapered_tube_is_a_bound_with_the_exact_sign() {
        let path = Path {
            points: vec![DVec3::ZERO, DVec3::Z * 10.0],
            radii: vec![3.0, 1.0],
        };
        let tubes = Tubes::new(&[path]).unwrap();
        assert!(tubes.distance(DVec3::new(2.0, 0.0, 5.0)).abs() < 1e-12);
        assert!(tubes.distance(DVec3::new(1.9, 0.0, 5.0)) < 0.0);
        assert!(tubes.distance(DVec3::new(2.1, 0.0, 5.0)) > 0.0);
        let mut rng = SplitMix64::new(4);
        for _ in 0..2000 {
            let p = rng.direction() * rng.uniform(0.0, 12.0) + DVec3::Z * 5.0;
            let q = p + rng.direction() * rng.uniform(0.0, 1.0);
            let change = (tubes.distance(p) - tubes.distance(q)).abs();
            assert!(change <= p.distance(q) * (1.0 + 1e-9));
        }
    }

    #[test]
    fn malformed_paths_are_errors() {
        assert!(Tubes::new(&[]).is_err());
        assert!(Tubes::new(&[Path::uniform(vec![DVec3::ZERO], 1.0)]).is_err());
        assert!(Tubes::new(&[Path::uniform(vec![DVec3::ZERO, DVec3::ZERO], 1.0)]).is_err());
        assert!(Tubes::new(&[Path::uniform(vec![DVec3::ZERO, DVec3::X], -1.0)]).is_err());
        assert!(Tubes::new(&[Path::uniform(vec![DVec3::ZERO, DVec3::NAN], 1.0)]).is_err());
    }
}
