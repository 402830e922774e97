//! The voxel grid a phantom is rendered on: the smallest grid of a given spacing and direction
//! whose voxel centres cover a region — a box around the origin for the shapes, a set of balls
//! (what matters, with its margin) for the families — and the solid the grid's voxels fill, which
//! clips what a phantom can show.

use glam::{DMat3, DVec3};

use super::sdf::RoundedBox;
use crate::error::{Error, Result};
use crate::geometry::Geometry;

/// A ball in world mm; a set of them outlines a region.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    pub centre: DVec3,
    pub radius: f64,
}

/// A grid of voxels: its geometry and size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    pub geometry: Geometry,
    pub dims: [usize; 3],
}

impl Grid {
    /// The smallest grid with this spacing and direction (row-major) that covers every ball.
    pub fn around(balls: &[Ball], spacing: [f64; 3], direction: [f64; 9]) -> Result<Grid> {
        let axes = Geometry::new(spacing, [0.0; 3], direction)?;
        let to_index = axes.world_to_index_matrix();
        // The index coordinate a is a linear function (a row of the matrix) of world space,
        // so over a ball it spans the centre's value ± radius · |row|.
        let reach = DVec3::new(
            to_index.row(0).length(),
            to_index.row(1).length(),
            to_index.row(2).length(),
        );
        let mut lo = DVec3::INFINITY;
        let mut hi = DVec3::NEG_INFINITY;
        for ball in balls {
            let centre = to_index * ball.centre;
            lo = lo.min(centre - ball.radius * reach);
            hi = hi.max(centre + ball.radius * reach);
        }
        let (origin, dims) = covering(lo, hi, &axes)?;
        Ok(Grid {
            geometry: Geometry::new(spacing, origin.to_array(), direction)?,
            dims,
        })
    }

    pub fn voxels(&self) -> usize {
        self.dims.iter().product()
    }

    /// The box the voxels fill (half a voxel beyond the outer centres): what the volume shows.
    pub fn extent(&self) -> RoundedBox {
        let g = &self.geometry;
        let size = DVec3::from(self.dims.map(|d| d as f64));
        let axes = DMat3::from_cols_array(&g.direction()).transpose();
        RoundedBox {
            centre: g.index_to_world(0.5 * (size - 1.0)),
            axes,
            half: 0.5 * size * DVec3::from(g.spacing()),
            rounding: 0.0,
        }
    }
}

/// Origin and dims of the smallest grid with these axes (origin zero) whose voxel centres cover
/// the continuous indices `lo..=hi`.
pub fn covering(lo: DVec3, hi: DVec3, axes: &Geometry) -> Result<(DVec3, [usize; 3])> {
    let lo = lo.floor();
    let size = hi.ceil() - lo + 1.0;
    if size.max_element() > 4096.0 {
        return Err(Error::invalid_argument(format!(
            "the phantom would need {size} voxels; use a spacing of at least 0.05 mm"
        )));
    }
    let dims = [size.x as usize, size.y as usize, size.z as usize];
    Ok((axes.index_to_world(lo), dims))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::random::SplitMix64;
    use crate::phantom::sdf::Sdf;

    #[test]
    fn an_oblique_grid_covers_its_balls_and_little_more() {
        let mut rng = SplitMix64::new(3);
        let direction = rng.rotation().transpose().to_cols_array();
        let balls = [
            Ball {
                centre: DVec3::new(10.0, -4.0, 2.0),
                radius: 5.0,
            },
            Ball {
                centre: DVec3::new(-20.0, 8.0, 30.0),
                radius: 3.0,
            },
        ];
        let grid = Grid::around(&balls, [0.7, 0.7, 1.6], direction).unwrap();
        let extent = grid.extent();
        for _ in 0..5000 {
            let ball = balls[rng.integer(0, 1) as usize];
            let p = ball.centre + rng.direction() * rng.uniform(0.0, ball.radius);
            let index = grid.geometry.world_to_index(p);
            let top = DVec3::from(grid.dims.map(|d| (d - 1) as f64));
            assert!(
                index.cmpge(DVec3::ZERO).all() && index.cmple(top).all(),
                "{index}"
            );
            assert!(extent.distance(p) < 0.0);
        }
        // Each face of the grid is within a voxel of some ball.
        let corner = grid.geometry.index_to_world(DVec3::ZERO);
        assert!(extent.distance(corner).abs() < 1.0);
    }
}
