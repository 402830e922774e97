//! Indexed triangle meshes in world millimetres: points shared between triangles (welded), and
//! the measures every caller needs (area, enclosed volume, bounds).
//!
//! Topological checks (closed, manifold, oriented, genus) live in `mesh_checks`; this module
//! only owns the data and its invariants: every index is in range and every point finite.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{Error, Result};

/// A triangle mesh with shared vertices. Triangles are counter-clockwise seen from outside
/// (the right-hand normal points out) when the mesh is oriented outward.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    points: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Validates that every index is in range and every point finite.
    pub fn new(points: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<Self> {
        if points.len() > u32::MAX as usize {
            return Err(Error::invalid_mesh(format!(
                "{} points exceed the 32-bit index range",
                points.len()
            )));
        }
        // Parallel because marching cubes hands over tens of millions of elements.
        if let Some(i) = points.par_iter().position_first(|p| !p.is_finite()) {
            return Err(Error::invalid_mesh(format!(
                "point {i} is {:?}; every point must be finite",
                points[i]
            )));
        }
        let n = points.len() as u32;
        if let Some(t) = triangles
            .par_iter()
            .position_first(|t| t.iter().any(|&v| v >= n))
        {
            return Err(Error::invalid_mesh(format!(
                "triangle {t} is {:?} but the mesh has {n} points",
                triangles[t]
            )));
        }
        Ok(TriMesh { points, triangles })
    }

    /// Builds a welded mesh from a triangle soup (three points per triangle, as STL stores
    /// them): bit-identical points become one vertex. Negative and positive zero are merged.
    pub fn from_soup(corners: &[[DVec3; 3]]) -> Result<Self> {
        let mut index: HashMap<[u64; 3], u32, BuildHasherDefault<BitsHasher>> =
            HashMap::with_capacity_and_hasher(corners.len() / 2 + 3, Default::default());
        let mut points = Vec::with_capacity(corners.len() / 2 + 3);
        let mut triangles = Vec::with_capacity(corners.len());
        for tri in corners {
            let mut t = [0u32; 3];
            for (slot, p) in t.iter_mut().zip(tri) {
                // +0.0 and -0.0 are the same point; adding 0.0 turns -0.0 into +0.0.
                let key = [
                    (p.x + 0.0).to_bits(),
                    (p.y + 0.0).to_bits(),
                    (p.z + 0.0).to_bits(),
                ];
                *slot = *index.entry(key).or_insert_with(|| {
                    points.push(*p);
                    (points.len() - 1) as u32
                });
            }
            triangles.push(t);
        }
        TriMesh::new(points, triangles)
    }

    /// A geodesic sphere, outward-oriented: an icosahedron whose triangles are each divided
    /// into four `levels` times, vertices projected onto the sphere: `10·4^levels + 2` points
    /// (the icosahedron's 12 first, then edge midpoints) and `20·4^levels` triangles. The
    /// caller keeps `levels` small (10 gives 21 M triangles).
    pub fn icosphere(centre: DVec3, radius: f64, levels: u32) -> TriMesh {
        let t = (1.0 + 5f64.sqrt()) / 2.0;
        let mut points: Vec<DVec3> = [
            (-1.0, t, 0.0),
            (1.0, t, 0.0),
            (-1.0, -t, 0.0),
            (1.0, -t, 0.0),
            (0.0, -1.0, t),
            (0.0, 1.0, t),
            (0.0, -1.0, -t),
            (0.0, 1.0, -t),
            (t, 0.0, -1.0),
            (t, 0.0, 1.0),
            (-t, 0.0, -1.0),
            (-t, 0.0, 1.0),
        ]
        .iter()
        .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
        .collect();
        let mut triangles: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..levels {
            let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
            let mut mid = |a: u32, b: u32, points: &mut Vec<DVec3>| {
                *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    points.push((points[a as usize] + points[b as usize]).normalize());
                    (points.len() - 1) as u32
                })
            };
            let mut next = Vec::with_capacity(triangles.len() * 4);
            for [a, b, c] in triangles {
                let ab = mid(a, b, &mut points);
                let bc = mid(b, c, &mut points);
                let ca = mid(c, a, &mut points);
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            triangles = next;
        }
        let points = points.into_iter().map(|p| centre + radius * p).collect();
        TriMesh { points, triangles }
    }

    /// Adds `other`'s points and triangles after this mesh's, as separate components.
    pub fn append(&mut self, other: &TriMesh) -> Result<()> {
        let offset = self.points.len();
        if offset + other.points.len() > u32::MAX as usize {
            return Err(Error::invalid_mesh(format!(
                "{} + {} points exceed the 32-bit index range",
                offset,
                other.points.len()
            )));
        }
        self.points.extend_from_slice(&other.points);
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|v| v + offset as u32)));
        Ok(())
    }

    pub fn points(&self) -> &[DVec3] {
        &self.points
    }

    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    pub fn into_parts(self) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        (self.points, self.triangles)
    }

    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The three corners of triangle `t`.
    #[inline]
    pub fn corners(&self, t: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[t];
        [
            self.points[a as usize],
            self.points[b as usize],
            self.points[c as usize],
        ]
    }

    /// Sum of triangle areas (mm²).
    pub fn area(&self) -> f64 {
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    /// Signed enclosed volume (mm³) by the divergence theorem: positive for a closed mesh whose
    /// normals point outward. Computed relative to the bounding-box centre so that meshes far
    /// from the origin lose no precision.
    pub fn signed_volume(&self) -> f64 {
        let Some((lo, hi)) = self.bounds() else {
            return 0.0;
        };
        let centre = 0.5 * (lo + hi);
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                (a - centre).dot((b - centre).cross(c - centre))
            })
            .sum::<f64>()
            / 6.0
    }

    /// Axis-aligned bounds of the points, `None` when there are none.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let first = *self.points.first()?;
        Some(
            self.points
                .iter()
                .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p))),
        )
    }

    /// The same surface with every triangle's winding reversed (normals flipped).
    pub fn flipped(mut self) -> Self {
        for t in &mut self.triangles {
            t.swap(1, 2);
        }
        self
    }

    /// The same connectivity with every point mapped by `f`.
    pub fn map_points(mut self, f: impl Fn(DVec3) -> DVec3) -> Result<Self> {
        for p in &mut self.points {
            *p = f(*p);
        }
        TriMesh::new(self.points, self.triangles)
    }
}

/// Welding hashes the bit patterns of coordinates, which come from files, not from an
/// adversary: a multiply–rotate mix (as in rustc's FxHash) is enough and several times faster
/// than the default SipHash.
#[derive(Default)]
struct BitsHasher(u64);

impl Hasher for BitsHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }

    fn write_u64(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

#[cfg(test)]
pub(crate) mod test_shapes {
    //! Small analytic meshes shared by the tests of several kernels.
    use super::*;

    pub fn icosphere(centre: DVec3, radius: f64, levels: u32) -> TriMesh {
        TriMesh::icosphere(centre, radius, levels)
    }

    /// A torus of `n × m` quads around the z axis through `c`, outward-oriented, genus 1.
    pub fn torus(c: DVec3, major: f64, minor: f64, n: u32, m: u32) -> TriMesh {
        let mut points = Vec::new();
        for a in 0..n {
            let (sa, ca) = (std::f64::consts::TAU * a as f64 / n as f64).sin_cos();
            for b in 0..m {
                let (sb, cb) = (std::f64::consts::TAU * b as f64 / m as f64).sin_cos();
                let ring = major + minor * cb;
                points.push(c + DVec3::new(ring * ca, ring * sa, minor * sb));
            }
        }
        let id = |a: u32, b: u32| (a % n) * m + b % m;
        let mut triangles = Vec::new();
        for a in 0..n {
            for b in 0..m {
                let (p, q, r, s) = (id(a, b), id(a + 1, b), id(a + 1, b + 1), id(a, b + 1));
                triangles.extend([[p, q, r], [p, r, s]]);
            }
        }
        TriMesh::new(points, triangles).unwrap()
    }

    /// An axis-aligned box, outward-oriented, 12 triangles.
    pub fn cube(lo: DVec3, hi: DVec3) -> TriMesh {
        let p = |x: bool, y: bool, z: bool| {
            DVec3::new(
                if x { hi.x } else { lo.x },
                if y { hi.y } else { lo.y },
                if z { hi.z } else { lo.z },
            )
        };
        let points = vec![
            p(false, false, false),
            p(true, false, false),
            p(true, true, false),
            p(false, true, false),
            p(false, false, true),
            p(true, false, true),
            p(true, true, true),
            p(false, true, true),
        ];
        let triangles = vec![
            [0, 2, 1],
            [0, 3, 2],
            [4, 5, 6],
            [4, 6, 7],
            [0, 1, 5],
            [0, 5, 4],
            [1, 2, 6],
            [1, 6, 5],
            [2, 3, 7],
            [2, 7, 6],
            [3, 0, 4],
            [3, 4, 7],
        ];
        TriMesh::new(points, triangles).unwrap()
    }
}

#[cfg(test)]
mod tests {
    use super::test_shapes::*;
    use super::*;

    #[test]
    fn cube_area_and_volume_are_exact_and_outward_positive() {
        let m = cube(DVec3::new(1.0, 2.0, 3.0), DVec3::new(3.0, 5.0, 7.0));
        assert!((m.area() - 2.0 * (6.0 + 8.0 + 12.0)).abs() < 1e-12);
        assert!((m.signed_volume() - 24.0).abs() < 1e-12);
        assert!((m.flipped().signed_volume() + 24.0).abs() < 1e-12);
    }

    #[test]
    fn volume_far_from_the_origin_keeps_its_precision() {
        let o = DVec3::splat(1e7);
        let hi = o + DVec3::splat(1e-3);
        let m = cube(o, hi);
        let stored = (hi - o).x * (hi - o).y * (hi - o).z;
        // Relative to the origin the products would cancel catastrophically (1e21 terms).
        assert!((m.signed_volume() - stored).abs() < 1e-12 * stored);
    }

    #[test]
    fn icosphere_volume_converges_to_the_ball() {
        let m = icosphere(DVec3::ZERO, 2.0, 4);
        let ball = 4.0 / 3.0 * std::f64::consts::PI * 8.0;
        assert!(m.signed_volume() > 0.0);
        assert!((m.signed_volume() - ball).abs() / ball < 0.01);
        assert_eq!(m.triangles().len(), 20 * 4usize.pow(4));
    }

    #[test]
    fn soup_welding_merges_identical_points_and_signed_zeros() {
        let a = DVec3::new(0.0, 0.0, 0.0);
        let a_neg = DVec3::new(-0.0, 0.0, -0.0);
        let b = DVec3::X;
        let c = DVec3::Y;
        let d = DVec3::new(1.0, 1.0, 0.0);
        let m = TriMesh::from_soup(&[[a, b, c], [b, d, c], [a_neg, c, b]]).unwrap();
        assert_eq!(m.points().len(), 4);
        assert_eq!(m.triangles(), &[[0, 1, 2], [1, 3, 2], [0, 2, 1]]);
    }

    #[test]
    fn append_keeps_both_meshes_as_components() {
        let mut m = cube(DVec3::ZERO, DVec3::ONE);
        m.append(&cube(DVec3::splat(2.0), DVec3::splat(3.0)))
            .unwrap();
        assert_eq!(m.points().len(), 16);
        assert_eq!(m.triangles()[12], [8, 10, 9]);
        assert!((m.signed_volume() - 2.0).abs() < 1e-12);
    }

    #[test]
    fn invalid_indices_and_points_are_rejected_with_their_position() {
        let e = TriMesh::new(vec![DVec3::ZERO; 3], vec![[0, 1, 3]]).unwrap_err();
        assert!(e.message().contains("triangle 0"), "{e}");
        let e = TriMesh::new(vec![DVec3::ZERO, DVec3::NAN, DVec3::ONE], vec![]).unwrap_err();
        assert!(e.message().contains("point 1"), "{e}");
    }
}
