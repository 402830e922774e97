//! Topological and geometric checks of a triangle mesh: closed, edge- and vertex-manifold,
//! consistently oriented, outward, Euler characteristic, genus, connected components, area and
//! enclosed volume — the guarantees the segmentation output must meet, measured rather than
//! assumed.
//!
//! Definitions follow the usual half-edge conventions (as OpenMesh and CGAL's
//! `is_closed` / `is_valid_polygon_mesh` use them): an undirected edge is *closed* when exactly
//! two triangles use it, *manifold* when at most two do, and *consistently oriented* when its two
//! triangles traverse it in opposite directions. A vertex is manifold when its incident triangles
//! form one fan (its link is one path or one cycle).

use crate::disjoint_sets::DisjointSets;
use rayon::prelude::*;

use crate::mesh::TriMesh;

/// Everything [`check`] measures about a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshReport {
    /// Vertices used by at least one triangle.
    pub vertices: usize,
    /// Points that no triangle uses (they do not count in the Euler characteristic).
    pub unreferenced_vertices: usize,
    pub triangles: usize,
    /// Undirected edges.
    pub edges: usize,
    /// Triangles with a repeated vertex index.
    pub degenerate_triangles: usize,
    /// Edges used by one triangle only.
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: usize,
    /// Vertices whose incident triangles form more than one fan.
    pub non_manifold_vertices: usize,
    /// Two-triangle edges traversed twice in the same direction.
    pub inconsistently_oriented_edges: usize,
    /// Connected components (triangles connected through shared vertices).
    pub components: usize,
    pub euler_characteristic: i64,
    pub area: f64,
    pub signed_volume: f64,
    /// Components whose signed volume is not positive.
    pub inward_components: usize,
}

impl MeshReport {
    /// Every edge has exactly two triangles.
    pub fn closed(&self) -> bool {
        self.boundary_edges == 0 && self.non_manifold_edges == 0
    }

    pub fn edge_manifold(&self) -> bool {
        self.non_manifold_edges == 0
    }

    pub fn vertex_manifold(&self) -> bool {
        self.non_manifold_vertices == 0
    }

    /// Edge- and vertex-manifold, and no degenerate triangles.
    pub fn manifold(&self) -> bool {
        self.edge_manifold() && self.vertex_manifold() && self.degenerate_triangles == 0
    }

    pub fn consistently_oriented(&self) -> bool {
        self.edge_manifold() && self.inconsistently_oriented_edges == 0
    }

    /// Closed, oriented, and every component encloses a positive volume (normals point out).
    pub fn outward(&self) -> bool {
        self.closed() && self.consistently_oriented() && self.inward_components == 0
    }

    /// Genus of a closed orientable 2-manifold: χ = Σ (2 − 2gᵢ), so g = Σ gᵢ = C − χ/2.
    /// `None` when the mesh is not a closed oriented manifold (genus is then undefined).
    pub fn genus(&self) -> Option<i64> {
        (self.closed() && self.manifold() && self.consistently_oriented() && self.triangles > 0)
            .then(|| self.components as i64 - self.euler_characteristic / 2)
    }

    /// Closed, manifold, consistently oriented and outward: the segmentation output guarantee
    /// (self-intersections are checked separately).
    pub fn is_valid_closed_surface(&self) -> bool {
        self.closed() && self.manifold() && self.outward()
    }
}

/// One directed use of an undirected edge: the key packs (min, max) vertex ids; `forward`
/// tells whether the triangle traverses it from min to max.
#[derive(Clone, Copy)]
struct EdgeUse {
    key: u64,
    forward: bool,
}

/// Measures `mesh`. Linear in its size apart from one parallel sort of the edge uses.
pub fn check(mesh: &TriMesh) -> MeshReport {
    let tris = mesh.triangles();
    let n_points = mesh.points().len();

    let degenerate_triangles = tris
        .iter()
        .filter(|[a, b, c]| a == b || b == c || a == c)
        .count();

    let mut uses: Vec<EdgeUse> = tris
        .par_iter()
        .flat_map_iter(|&[a, b, c]| [(a, b), (b, c), (c, a)])
        .filter(|(u, v)| u != v)
        .map(|(u, v)| EdgeUse {
            key: (u64::from(u.min(v)) << 32) | u64::from(u.max(v)),
            forward: u < v,
        })
        .collect();
    uses.par_sort_unstable_by_key(|e| e.key);

    let (mut edges, mut boundary_edges, mut non_manifold_edges, mut inconsistent) = (0, 0, 0, 0);
    for group in uses.chunk_by(|a, b| a.key == b.key) {
        edges += 1;
        match group {
            [_] => boundary_edges += 1,
            [a, b] => inconsistent += usize::from(a.forward == b.forward),
            _ => non_manifold_edges += 1,
        }
    }

    let mut referenced = vec![false; n_points];
    for t in tris {
        for &v in t {
            referenced[v as usize] = true;
        }
    }
    let vertices = referenced.iter().filter(|&&r| r).count();

    let (_, component_volume) = component_volumes(mesh);

    MeshReport {
        vertices,
        unreferenced_vertices: n_points - vertices,
        triangles: tris.len(),
        edges,
        degenerate_triangles,
        boundary_edges,
        non_manifold_edges,
        non_manifold_vertices: non_manifold_vertex_count(tris, n_points),
        inconsistently_oriented_edges: inconsistent,
        components: component_volume.len(),
        euler_characteristic: vertices as i64 - edges as i64 + tris.len() as i64,
        area: mesh.area(),
        signed_volume: component_volume.iter().sum(),
        inward_components: component_volume.iter().filter(|&&v| v <= 0.0).count(),
    }
}

/// The component label of every triangle (triangles connected through shared vertices,
/// numbered in order of first appearance) and the signed volume each component encloses,
/// relative to the bounding-box centre so that meshes far from the origin keep their precision.
pub fn component_volumes(mesh: &TriMesh) -> (Vec<u32>, Vec<f64>) {
    let labels = triangle_components(mesh.triangles(), mesh.points().len());
    let components = labels.iter().copied().max().map_or(0, |m| m as usize + 1);
    let mut volumes = vec![0.0f64; components];
    let centre = mesh
        .bounds()
        .map_or(glam::DVec3::ZERO, |(lo, hi)| 0.5 * (lo + hi));
    for (t, &label) in labels.iter().enumerate() {
        let [a, b, c] = mesh.corners(t);
        volumes[label as usize] += (a - centre).dot((b - centre).cross(c - centre)) / 6.0;
    }
    (labels, volumes)
}

/// Component label of every triangle, numbered 0.. in order of first appearance.
fn triangle_components(tris: &[[u32; 3]], n_points: usize) -> Vec<u32> {
    let mut sets = DisjointSets::new(n_points);
    for &[a, b, c] in tris {
        sets.union(a, b);
        sets.union(b, c);
    }
    let mut label_of_root = vec![u32::MAX; n_points];
    let mut next = 0;
    tris.iter()
        .map(|t| {
            let root = sets.find(t[0]) as usize;
            if label_of_root[root] == u32::MAX {
                label_of_root[root] = next;
                next += 1;
            }
            label_of_root[root]
        })
        .collect()
}

/// Counts vertices whose link (the opposite edges of their triangles) is not connected, i.e.
/// whose triangles form several fans that only touch at the vertex.
fn non_manifold_vertex_count(tris: &[[u32; 3]], n_points: usize) -> usize {
    // Vertex → incident triangles, as compressed rows.
    let mut start = vec![0u32; n_points + 1];
    for t in tris {
        for &v in t {
            start[v as usize + 1] += 1;
        }
    }
    for v in 0..n_points {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut incident = vec![0u32; tris.len() * 3];
    for (ti, t) in tris.iter().enumerate() {
        for &v in t {
            incident[fill[v as usize] as usize] = ti as u32;
            fill[v as usize] += 1;
        }
    }

    (0..n_points)
        .into_par_iter()
        .with_min_len(4096)
        .map_init(Vec::new, |link: &mut Vec<(u32, u32)>, v| {
            let fan = &incident[start[v] as usize..start[v + 1] as usize];
            if fan.len() < 2 {
                return 0;
            }
            link.clear();
            link.extend(fan.iter().filter_map(|&t| {
                let [a, b, c] = tris[t as usize];
                let v = v as u32;
                match (a == v, b == v, c == v) {
                    (true, false, false) => Some((b, c)),
                    (false, true, false) => Some((c, a)),
                    (false, false, true) => Some((a, b)),
                    _ => None,
                }
            }));
            usize::from(link_components(link) > 1)
        })
        .sum()
}

/// Connected components of a vertex link given as its edges (a handful, so quadratic is fine).
fn link_components(link: &[(u32, u32)]) -> usize {
    let mut ids: Vec<u32> = link.iter().flat_map(|&(a, b)| [a, b]).collect();
    ids.sort_unstable();
    ids.dedup();
    let local = |x: u32| ids.binary_search(&x).expect("the id is in the link") as u32;
    let mut sets = DisjointSets::new(ids.len());
    for &(a, b) in link {
        sets.union(local(a), local(b));
    }
    (0..ids.len() as u32).filter(|&i| sets.find(i) == i).count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_shapes::{cube, icosphere, torus};
    use glam::DVec3;

    #[test]
    fn sphere_is_a_valid_closed_surface_of_genus_zero() {
        let r = check(&icosphere(DVec3::ZERO, 1.0, 2));
        assert!(r.is_valid_closed_surface(), "{r:?}");
        assert_eq!(r.euler_characteristic, 2);
        assert_eq!(r.genus(), Some(0));
        assert_eq!(r.components, 1);
    }

    #[test]
    fn torus_has_genus_one_and_positive_volume() {
        let r = check(&torus(DVec3::ZERO, 3.0, 1.0, 48, 24));
        assert!(r.is_valid_closed_surface(), "{r:?}");
        assert_eq!(r.euler_characteristic, 0);
        assert_eq!(r.genus(), Some(1));
        let exact = 2.0 * std::f64::consts::PI.powi(2) * 3.0;
        // A 24-gon cross-section and 48 segments lose about 1.4% of the volume.
        assert!((r.signed_volume - exact).abs() / exact < 0.02);
    }

    #[test]
    fn flipped_mesh_is_oriented_but_not_outward() {
        let r = check(&cube(DVec3::ZERO, DVec3::ONE).flipped());
        assert!(r.closed() && r.consistently_oriented());
        assert!(!r.outward());
        assert_eq!(r.inward_components, 1);
    }

    #[test]
    fn one_flipped_triangle_breaks_orientation() {
        let (points, mut tris) = cube(DVec3::ZERO, DVec3::ONE).into_parts();
        tris[3].swap(1, 2);
        let r = check(&TriMesh::new(points, tris).unwrap());
        assert!(r.closed());
        assert_eq!(r.inconsistently_oriented_edges, 3);
        assert!(!r.consistently_oriented() && !r.outward());
        assert_eq!(r.genus(), None);
    }

    #[test]
    fn removing_a_triangle_opens_three_boundary_edges() {
        let (points, mut tris) = icosphere(DVec3::ZERO, 1.0, 1).into_parts();
        tris.pop();
        let r = check(&TriMesh::new(points, tris).unwrap());
        assert_eq!(r.boundary_edges, 3);
        assert!(!r.closed() && r.manifold());
        assert_eq!(r.genus(), None);
    }

    #[test]
    fn two_cubes_sharing_a_vertex_are_one_component_with_a_non_manifold_vertex() {
        let a = cube(DVec3::ZERO, DVec3::ONE);
        let (mut points, mut tris) = a.into_parts();
        let b = cube(DVec3::ONE, DVec3::splat(2.0));
        // b's corner 0 is (1,1,1), which is a's corner 6: glue them there.
        let offset = points.len() as u32;
        points.extend_from_slice(&b.points()[1..]);
        tris.extend(
            b.triangles()
                .iter()
                .map(|t| t.map(|v| if v == 0 { 6 } else { v - 1 + offset })),
        );
        let r = check(&TriMesh::new(points, tris).unwrap());
        assert_eq!(r.components, 1);
        assert_eq!(r.non_manifold_vertices, 1);
        assert!(r.closed() && r.edge_manifold() && !r.vertex_manifold());
        assert_eq!(r.genus(), None);
    }

    #[test]
    fn three_triangles_on_one_edge_are_non_manifold() {
        let points = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, -DVec3::Y];
        let tris = vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]];
        let r = check(&TriMesh::new(points, tris).unwrap());
        assert_eq!(r.non_manifold_edges, 1);
        assert!(!r.closed() && !r.edge_manifold());
    }

    #[test]
    fn separate_shapes_count_as_components_and_genus_adds_up() {
        let mut shapes = torus(DVec3::ZERO, 3.0, 1.0, 16, 8);
        shapes
            .append(&icosphere(DVec3::new(10.0, 0.0, 0.0), 1.0, 1))
            .unwrap();
        let (mut points, tris) = shapes.into_parts();
        points.push(DVec3::splat(100.0));
        let r = check(&TriMesh::new(points, tris).unwrap());
        assert_eq!(r.components, 2);
        assert_eq!(r.unreferenced_vertices, 1);
        assert_eq!(r.euler_characteristic, 2);
        assert_eq!(r.genus(), Some(1));
        assert!(r.outward());
    }

    #[test]
    fn degenerate_triangle_is_reported_not_fatal() {
        let points = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
        let r = check(&TriMesh::new(points, vec![[0, 1, 1], [0, 1, 2]]).unwrap());
        assert_eq!(r.degenerate_triangles, 1);
        assert!(!r.manifold());
    }

    #[test]
    fn empty_mesh_has_no_genus() {
        let r = check(&TriMesh::default());
        assert_eq!(r.components, 0);
        assert_eq!(r.genus(), None);
        assert!(!r.outward() || r.triangles == 0);
    }
}
