//! A layered scene and its rendering: an ordered list of layers, each a solid and an intensity
//! (constant or a function of position), painted over a background like a painter's algorithm
//! — at any point the topmost layer that contains it gives the intensity — and composited
//! with partial-volume voxels: a voxel that a layer's surface may cross (the signed distance at
//! its centre is smaller than half its diagonal) is the mean of 4×4×4 sub-samples, every other
//! voxel its centre's value. Then `Imaging` blurs, biases, adds noise and rounds.
//!
//! What a layer shows is the layer minus all the layers above it (`visible`): the truth of a
//! phantom is that region of its object's layer, so that the rendering and the truth cannot
//! disagree.

use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;

use super::grid::Grid;
use super::imaging::Imaging;
use super::sdf::Solid;
use crate::error::Result;
use crate::volume::Image;

/// A layer's intensity.
#[derive(Clone)]
pub enum Intensity {
    Constant(f64),
    /// Varying with the world position (mm), e.g. a contrast that drifts along a vessel.
    Field(Arc<dyn Fn(DVec3) -> f64 + Send + Sync>),
}

impl Intensity {
    pub fn at(&self, p: DVec3) -> f64 {
        match self {
            Intensity::Constant(v) => *v,
            Intensity::Field(f) => f(p),
        }
    }
}

#[derive(Clone)]
pub struct Layer {
    pub solid: Solid,
    pub intensity: Intensity,
}

/// Layers painted in order over a background.
#[derive(Clone)]
pub struct Scene {
    pub background: f64,
    pub layers: Vec<Layer>,
}

/// Sub-samples per axis for partial-volume voxels near a surface.
const SUPERSAMPLING: usize = 4;

/// Where a voxel stands with respect to one layer, judged from its centre.
#[derive(Clone, Copy, PartialEq)]
enum Side {
    Outside,
    Inside,
    /// The surface may cross the voxel: every sub-sample asks.
    Near,
}

impl Scene {
    /// Signed distance (bound) of what layer `index` shows: the layer minus the layers above.
    pub fn visible(&self, index: usize, p: DVec3) -> f64 {
        let above = self.layers[index + 1..]
            .iter()
            .map(|l| l.solid.distance(p))
            .fold(f64::INFINITY, f64::min);
        self.layers[index].solid.distance(p).max(-above)
    }

    /// The ideal intensity at `p`: the topmost layer containing it, or the background.
    #[cfg(test)]
    pub fn paint(&self, p: DVec3) -> f64 {
        self.layers
            .iter()
            .rev()
            .find(|l| l.solid.distance(p) < 0.0)
            .map_or(self.background, |l| l.intensity.at(p))
    }

    /// The topmost layer containing `p` among those `sides` leaves open, and its intensity.
    fn paint_sample(&self, sides: &[Side], p: DVec3) -> f64 {
        self.layers
            .iter()
            .zip(sides)
            .rev()
            .find(|(l, side)| match side {
                Side::Outside => false,
                Side::Inside => true,
                Side::Near => l.solid.distance(p) < 0.0,
            })
            .map_or(self.background, |(l, _)| l.intensity.at(p))
    }

    /// The partial-volume image of the scene on `grid`, before imaging.
    pub fn composite(&self, grid: &Grid) -> Vec<f32> {
        let (geometry, dims) = (&grid.geometry, grid.dims);
        let reach = 0.5 * DVec3::from(geometry.spacing()).length();
        let n = SUPERSAMPLING;
        let offsets: Vec<DVec3> = (0..n * n * n)
            .map(|s| {
                let abc = DVec3::new((s % n) as f64, (s / n % n) as f64, (s / (n * n)) as f64);
                (abc + 0.5) / n as f64 - 0.5
            })
            .collect();
        let mut voxels = vec![0.0f32; grid.voxels()];
        voxels
            .par_chunks_mut(dims[0] * dims[1])
            .enumerate()
            .for_each(|(k, slab)| {
                let mut sides = vec![Side::Outside; self.layers.len()];
                for (m, v) in slab.iter_mut().enumerate() {
                    let centre = DVec3::new((m % dims[0]) as f64, (m / dims[0]) as f64, k as f64);
                    let world = geometry.index_to_world(centre);
                    for (side, layer) in sides.iter_mut().zip(&self.layers) {
                        let d = layer.solid.distance(world);
                        *side = if d > reach {
                            Side::Outside
                        } else if d < -reach {
                            Side::Inside
                        } else {
                            Side::Near
                        };
                    }
                    let value = if sides.contains(&Side::Near) {
                        let sum: f64 = offsets
                            .iter()
                            .map(|&o| {
                                self.paint_sample(&sides, geometry.index_to_world(centre + o))
                            })
                            .sum();
                        sum / offsets.len() as f64
                    } else {
                        self.paint_sample(&sides, world)
                    };
                    *v = value as f32;
                }
            });
        voxels
    }

    /// The scene on `grid`, through `imaging`.
    pub fn render(&self, grid: &Grid, imaging: &Imaging) -> Result<Image> {
        imaging.apply(self.composite(grid), grid.dims, grid.geometry)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Geometry;
    use crate::phantom::sdf::Capsule;
    use crate::volume::VoxelBuffer;

    fn ball(centre: DVec3, radius: f64) -> Solid {
        Arc::new(Capsule {
            a: centre,
            b: centre,
            radius,
        })
    }

    #[test]
    fn upper_layers_hide_lower_ones() {
        let scene = Scene {
            background: 0.0,
            layers: vec![
                Layer {
                    solid: ball(DVec3::ZERO, 5.0),
                    intensity: Intensity::Constant(10.0),
                },
                Layer {
                    solid: ball(DVec3::X * 5.0, 2.0),
                    intensity: Intensity::Field(Arc::new(|p: DVec3| p.y)),
                },
            ],
        };
        assert_eq!(scene.paint(DVec3::ZERO), 10.0);
        assert_eq!(scene.paint(DVec3::new(4.0, 1.0, 0.0)), 1.0);
        assert_eq!(scene.paint(DVec3::X * 8.0), 0.0);
        // The first layer shows itself minus the second.
        assert!(scene.visible(0, DVec3::new(4.0, 0.0, 0.0)) > 0.0);
        assert!(scene.visible(0, DVec3::new(-4.0, 0.0, 0.0)) < 0.0);
        assert!(scene.visible(1, DVec3::new(4.0, 0.0, 0.0)) < 0.0);
    }

    #[test]
    fn partial_volumes_add_up_to_the_volume() {
        let scene = Scene {
            background: 0.0,
            layers: vec![Layer {
                solid: ball(DVec3::new(0.3, -0.2, 0.1), 6.0),
                intensity: Intensity::Constant(1.0),
            }],
        };
        let grid = Grid {
            geometry: Geometry::with_spacing([0.9, 0.9, 1.7], [-10.0; 3]).unwrap(),
            dims: [24, 24, 13],
        };
        let voxels = scene.composite(&grid);
        let volume: f64 = voxels.iter().map(|&v| f64::from(v)).sum::<f64>() * 0.9 * 0.9 * 1.7;
        let exact = 4.0 / 3.0 * std::f64::consts::PI * 216.0;
        assert!((volume - exact).abs() / exact < 0.003, "{volume} {exact}");
        let imaging = Imaging {
            blur_mm: 0.0,
            bias: None,
            noise_sigma: 0.0,
            noise_seed: 0,
            output: crate::volume::ScalarType::F32,
        };
        let image = scene.render(&grid, &imaging).unwrap();
        assert_eq!(image.buffer(), &VoxelBuffer::F32(voxels));
    }
}
