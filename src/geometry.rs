//! Physical space of a voxel grid: spacing, origin and direction, and the affine maps between
//! continuous voxel indices and world millimetres.
//!
//! The convention is ITK's (and VTK 9's): `world = origin + D · (spacing ⊙ index)`, where the
//! columns of the direction matrix `D` are the world directions of the i, j and k axes and `D` is
//! stored row-major. Algorithms work in index space and call these maps once, at the edge.

use glam::{DMat3, DVec3};

use crate::error::{Error, Result};

/// Spacing, origin and direction of a grid, with the index↔world maps precomputed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    spacing: [f64; 3],
    origin: [f64; 3],
    direction: [f64; 9],
    index_to_world: DMat3,
    world_to_index: DMat3,
}

/// Relative size of `|det D|` against the product of its column lengths below which a direction
/// matrix is treated as singular: the axes would be (nearly) coplanar and indices not recoverable.
const SINGULAR_DIRECTION: f64 = 1e-9;

impl Geometry {
    /// Validates and builds a geometry. `direction` is row-major, as VTK and ITK store it.
    pub fn new(spacing: [f64; 3], origin: [f64; 3], direction: [f64; 9]) -> Result<Self> {
        for (axis, &s) in spacing.iter().enumerate() {
            if !s.is_finite() || s <= 0.0 {
                return Err(Error::invalid_volume(format!(
                    "spacing[{axis}] is {s}; every spacing must be a finite positive number of \
                     millimetres (put axis flips into the direction matrix instead)"
                )));
            }
        }
        if let Some(axis) = origin.iter().position(|o| !o.is_finite()) {
            return Err(Error::invalid_volume(format!(
                "origin[{axis}] is {}; the origin must be finite",
                origin[axis]
            )));
        }
        if let Some(i) = direction.iter().position(|d| !d.is_finite()) {
            return Err(Error::invalid_volume(format!(
                "direction[{i}] is {}; the direction matrix must be finite",
                direction[i]
            )));
        }
        let d = DMat3::from_cols_array(&direction).transpose();
        let scale = d.x_axis.length() * d.y_axis.length() * d.z_axis.length();
        let det = d.determinant();
        if scale == 0.0 || det.abs() <= SINGULAR_DIRECTION * scale {
            return Err(Error::invalid_volume(format!(
                "the direction matrix {direction:?} is singular (determinant {det:e}); its columns \
                 must be three independent axis directions, e.g. the identity"
            )));
        }
        let index_to_world = d * DMat3::from_diagonal(DVec3::from(spacing));
        Ok(Geometry {
            spacing,
            origin,
            direction,
            index_to_world,
            world_to_index: index_to_world.inverse(),
        })
    }

    /// Unit spacing, zero origin, identity direction.
    pub fn identity() -> Self {
        Self::with_spacing([1.0; 3], [0.0; 3]).expect("the identity geometry is valid")
    }

    /// Axis-aligned geometry with the given spacing and origin.
    pub fn with_spacing(spacing: [f64; 3], origin: [f64; 3]) -> Result<Self> {
        Self::new(
            spacing,
            origin,
            [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        )
    }

    pub fn spacing(&self) -> [f64; 3] {
        self.spacing
    }

    pub fn origin(&self) -> [f64; 3] {
        self.origin
    }

    /// Row-major direction matrix.
    pub fn direction(&self) -> [f64; 9] {
        self.direction
    }

    /// The linear part of the index→world map, `D · diag(spacing)`.
    pub fn index_to_world_matrix(&self) -> DMat3 {
        self.index_to_world
    }

    /// The linear part of the world→index map.
    pub fn world_to_index_matrix(&self) -> DMat3 {
        self.world_to_index
    }

    /// World position (mm) of a continuous index.
    pub fn index_to_world(&self, index: DVec3) -> DVec3 {
        DVec3::from(self.origin) + self.index_to_world * index
    }

    /// Continuous index of a world position (mm).
    pub fn world_to_index(&self, world: DVec3) -> DVec3 {
        self.world_to_index * (world - DVec3::from(self.origin))
    }

    /// A world-space displacement for an index-space displacement (no origin).
    pub fn index_vector_to_world(&self, v: DVec3) -> DVec3 {
        self.index_to_world * v
    }

    /// Whether `D` flips handedness; marching cubes and orientation checks must then swap
    /// triangle winding to keep normals pointing the same way in world space.
    pub fn is_left_handed(&self) -> bool {
        self.index_to_world.determinant() < 0.0
    }

    /// Mean of the three spacings, the default scale for edge lengths.
    pub fn mean_spacing(&self) -> f64 {
        (self.spacing[0] + self.spacing[1] + self.spacing[2]) / 3.0
    }

    pub fn min_spacing(&self) -> f64 {
        self.spacing[0].min(self.spacing[1]).min(self.spacing[2])
    }

    pub fn max_spacing(&self) -> f64 {
        self.spacing[0].max(self.spacing[1]).max(self.spacing[2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn oblique() -> Geometry {
        let (s, c) = 0.5f64.sin_cos();
        // Rotation about z, then a flip of the k axis: left-handed on purpose.
        Geometry::new(
            [0.8, 0.8, 1.5],
            [-10.0, 5.0, 2.0],
            [c, -s, 0.0, s, c, 0.0, 0.0, 0.0, -1.0],
        )
        .unwrap()
    }

    #[test]
    fn index_world_round_trip_with_oblique_anisotropic_geometry() {
        let g = oblique();
        let p = DVec3::new(3.25, -1.5, 7.0);
        let back = g.world_to_index(g.index_to_world(p));
        assert!((back - p).length() < 1e-12);
        assert!(g.is_left_handed());
    }

    #[test]
    fn direction_columns_are_axis_directions() {
        // diag(-1,-1,1) as in the aorta scan: index i grows towards -x.
        let g = Geometry::new(
            [2.0, 3.0, 4.0],
            [1.0, 1.0, 1.0],
            [-1., 0., 0., 0., -1., 0., 0., 0., 1.],
        )
        .unwrap();
        assert_eq!(g.index_to_world(DVec3::X), DVec3::new(-1.0, 1.0, 1.0));
        assert_eq!(g.index_to_world(DVec3::Y), DVec3::new(1.0, -2.0, 1.0));
        assert_eq!(g.index_to_world(DVec3::Z), DVec3::new(1.0, 1.0, 5.0));
        // A non-symmetric matrix tells rows from columns: column 0 is where i points.
        let g = Geometry::new([1.0; 3], [0.0; 3], [0., 1., 0., 1., 0., 0., 0., 0., 1.]).unwrap();
        let h = Geometry::new([1.0; 3], [0.0; 3], [0., -1., 0., 1., 0., 0., 0., 0., 1.]).unwrap();
        assert_eq!(g.index_to_world(DVec3::X), DVec3::Y);
        assert_eq!(h.index_to_world(DVec3::X), DVec3::Y);
        assert_eq!(h.index_to_world(DVec3::Y), -DVec3::X);
    }

    #[test]
    fn rejects_bad_spacing_origin_and_direction_with_a_reason() {
        let id = [1., 0., 0., 0., 1., 0., 0., 0., 1.];
        let e = Geometry::new([1.0, f64::NAN, 1.0], [0.0; 3], id).unwrap_err();
        assert!(e.message().contains("spacing[1]"), "{e}");
        assert!(Geometry::new([1.0, 0.0, 1.0], [0.0; 3], id).is_err());
        assert!(Geometry::new([1.0, -1.0, 1.0], [0.0; 3], id).is_err());
        assert!(Geometry::new([1.0; 3], [0.0, f64::INFINITY, 0.0], id).is_err());
        let e =
            Geometry::new([1.0; 3], [0.0; 3], [1., 0., 0., 1., 0., 0., 0., 0., 1.]).unwrap_err();
        assert!(e.message().contains("singular"), "{e}");
        assert!(Geometry::new([1.0; 3], [0.0; 3], [0.0; 9]).is_err());
    }
}
