//! A synthetic stand-in for step 6 on the vmtk aorta scan, shared by the signed-distance bench
//! and the libigl comparison example: the scan's grid (157×393×34 voxels, spacing 0.878906 ×
//! 0.878906 × 1.50009 mm, direction diag(−1, −1, 1)) and a closed, outward, bent tube of elliptic
//! section with blunt ends and 12,928 triangles, about the size and triangle count of the
//! reference aorta surface (12,932 triangles, 13,184 mm³).

use balloonseg::{Geometry, TriMesh};
use glam::DVec3;

pub const DIMS: [usize; 3] = [157, 393, 34];

pub fn aorta_grid() -> Geometry {
    Geometry::new(
        [0.878906, 0.878906, 1.50009],
        [-156.445, -24.6094, 0.0],
        [-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0],
    )
    .expect("the aorta grid is valid")
}

/// Rings of vertices from pole to pole along world y, `AROUND` vertices per ring.
const AROUND: u32 = 64;
const RINGS: u32 = 101;

pub fn aorta_like_tube(geometry: &Geometry) -> TriMesh {
    let centre = geometry.index_to_world(DVec3::new(78.0, 196.0, 16.5));
    let (half_length, radius_x, radius_z) = (45.0, 9.0, 7.0);
    let point = |ring: u32, around: u32| {
        let theta = std::f64::consts::PI * ring as f64 / (RINGS + 1) as f64;
        let phi = std::f64::consts::TAU * around as f64 / AROUND as f64;
        let along = -half_length * theta.cos();
        // sin^0.3 keeps the section nearly constant, closing only near the poles: a tube.
        let section = theta.sin().powf(0.3);
        let bend = DVec3::new(6.0 * (along / 25.0).sin(), 0.0, 2.0 * (along / 40.0).cos());
        centre
            + bend
            + DVec3::new(
                radius_x * section * phi.cos(),
                along,
                radius_z * section * phi.sin(),
            )
    };
    pole_to_pole_tube(RINGS, AROUND, point)
}

/// The closed, outward mesh of a tube given as `rings` rings of `around` vertices, `point(ring,
/// around)` for rings 1..=rings, between the poles `point(0, 0)` and `point(rings + 1, 0)`:
/// counter-clockwise seen from outside when the rings run along the tube's axis with `around`
/// turning counter-clockwise about it, so that the first cap faces backwards.
pub fn pole_to_pole_tube(rings: u32, around: u32, point: impl Fn(u32, u32) -> DVec3) -> TriMesh {
    let mut points = vec![point(0, 0)];
    for ring in 1..=rings {
        points.extend((0..around).map(|a| point(ring, a)));
    }
    points.push(point(rings + 1, 0));
    let id = |ring: u32, a: u32| 1 + (ring - 1) * around + a % around;
    let last = points.len() as u32 - 1;
    let mut triangles = Vec::new();
    for a in 0..around {
        triangles.push([0, id(1, a), id(1, a + 1)]);
        triangles.push([last, id(rings, a + 1), id(rings, a)]);
    }
    for ring in 1..rings {
        for a in 0..around {
            let (p, q) = (id(ring, a), id(ring, a + 1));
            let (r, s) = (id(ring + 1, a + 1), id(ring + 1, a));
            triangles.extend([[p, s, r], [p, r, q]]);
        }
    }
    TriMesh::new(points, triangles).expect("the tube is a valid mesh")
}
