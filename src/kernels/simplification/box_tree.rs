//! A bounding-box tree over a fixed set of boxes (the input surface's triangles): which boxes
//! overlap a query box, in time that grows with the answer and the tree's depth, not with the
//! query's size. The simplifier's `TriangleGrid` serves the output, whose triangles move. A
//! single uniform grid answered a box many cells wide by scanning everything, and late in a far
//! simplification every output triangle is that wide against the input's fine cells (on a
//! 158k-triangle isosurface reduced a hundredfold, 41 of 58 s went to those scans).
//!
//! Built top down: each node's boxes split at the median centre along the node's longest
//! axis, down to leaves of at most `LEAF` boxes. Deterministic (ties broken by index).

use super::triangle_grid::Bounds;
use crate::allocation;
use crate::error::Result;

/// The most boxes in a leaf.
const LEAF: usize = 8;

pub(super) struct BoxTree {
    nodes: Vec<Node>,
    /// The boxes' indices, each leaf's a contiguous run.
    order: Vec<u32>,
    boxes: Vec<Bounds>,
}

struct Node {
    bounds: Bounds,
    /// Leaf: the run `start..end` of `order`. Inner: the children at `start` and `end`.
    start: u32,
    end: u32,
    leaf: bool,
}

impl BoxTree {
    pub(super) fn new(boxes: Vec<Bounds>) -> Result<BoxTree> {
        let mut order = allocation::collect(0..boxes.len() as u32, "the box tree's order")?;
        let mut nodes =
            allocation::with_capacity((2 * boxes.len() / LEAF + 1).max(1), "the box tree's nodes")?;
        if !boxes.is_empty() {
            build(&boxes, &mut order, 0, &mut nodes);
        }
        Ok(BoxTree {
            nodes,
            order,
            boxes,
        })
    }

    /// The indices of the boxes that overlap `query`, ascending, in `out`.
    pub(super) fn query(&self, query: &Bounds, out: &mut Vec<u32>) {
        out.clear();
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = vec![0u32];
        while let Some(k) = stack.pop() {
            let node = &self.nodes[k as usize];
            if !node.bounds.overlaps(query) {
                continue;
            }
            if node.leaf {
                out.extend(
                    self.order[node.start as usize..node.end as usize]
                        .iter()
                        .filter(|&&b| self.boxes[b as usize].overlaps(query)),
                );
            } else {
                stack.extend([node.start, node.end]);
            }
        }
        out.sort_unstable();
    }
}

/// Builds the subtree over `order` (which starts at `offset` in the whole order) and returns
/// its node's index.
fn build(boxes: &[Bounds], order: &mut [u32], offset: usize, nodes: &mut Vec<Node>) -> u32 {
    let bounds = order
        .iter()
        .map(|&b| boxes[b as usize])
        .reduce(|u, v| Bounds {
            lo: u.lo.min(v.lo),
            hi: u.hi.max(v.hi),
        })
        .expect("a subtree has boxes");
    let index = nodes.len() as u32;
    nodes.push(Node {
        bounds,
        start: offset as u32,
        end: (offset + order.len()) as u32,
        leaf: true,
    });
    if order.len() <= LEAF {
        return index;
    }
    let extent = bounds.hi - bounds.lo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let centre = |b: u32| {
        let b = &boxes[b as usize];
        b.lo[axis] + b.hi[axis]
    };
    let half = order.len() / 2;
    order.select_nth_unstable_by(half, |&p, &q| {
        centre(p).total_cmp(&centre(q)).then(p.cmp(&q))
    });
    let (left, right) = order.split_at_mut(half);
    let first = build(boxes, left, offset, nodes);
    let second = build(boxes, right, offset + half, nodes);
    let node = &mut nodes[index as usize];
    node.start = first;
    node.end = second;
    node.leaf = false;
    index
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn a_query_finds_exactly_the_overlapping_boxes_whatever_its_size() {
        // Boxes of varied sizes along a helix, against queries from tiny to everything.
        let boxes: Vec<Bounds> = (0..500)
            .map(|k| {
                let t = k as f64 * 0.1;
                let centre = DVec3::new(t.cos() * 10.0, t.sin() * 10.0, t);
                let half = DVec3::splat(0.05 + 0.3 * ((k * 7) % 5) as f64);
                Bounds {
                    lo: centre - half,
                    hi: centre + half,
                }
            })
            .collect();
        let tree = BoxTree::new(boxes.clone()).unwrap();
        let mut found = Vec::new();
        for (k, size) in [0.01, 0.5, 3.0, 15.0, 100.0].iter().enumerate() {
            let centre = DVec3::new(k as f64 - 5.0, 3.0, 10.0 + k as f64);
            let query = Bounds {
                lo: centre - DVec3::splat(*size),
                hi: centre + DVec3::splat(*size),
            };
            tree.query(&query, &mut found);
            let expected: Vec<u32> = (0..boxes.len() as u32)
                .filter(|&b| boxes[b as usize].overlaps(&query))
                .collect();
            assert_eq!(found, expected, "query of half-size {size}");
        }
        let empty = BoxTree::new(Vec::new()).unwrap();
        empty.query(&boxes[0], &mut found);
        assert!(found.is_empty());
    }
}
