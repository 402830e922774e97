//! Where the balloon may go, and how fast it inflates there (paper, section 2: the inflation is
//! "inversely proportional to the difference between the local gray level and the reference
//! value" and zero once that difference exceeds a threshold).
//!
//! The balloon reads the image at two scales (`ImageScales`), both Gaussian-smoothed
//! (`SmoothedVolume`): a fine one, half a voxel, at the scale of its triangles, and a coarse
//! one, two voxels, for where the fine one shows no edge.
//! - **The window**: where the fine image is inside `reference ± tolerance` the balloon
//!   inflates with speed `1 − ½(d/tol)²`, `d` the intensity's distance from the reference:
//!   slower towards the border but never stalling before it.
//! - **Edges**: the intensity also leaves the window inside real structures, without an edge:
//!   contrast mixing in a lumen, a bolus fading along a vessel, noise. The vmtk aorta's lumen
//!   fades from 1600 to 450 over its last 12 cm, and where it crosses the border its bright part
//!   is a ring around a darker core; followed literally, the window made the balloon wrap around
//!   such dips and come out with handles. So leaving the window stops the balloon only across an
//!   edge. Where the fine image leaves it, the coarse image decides: if its gradient there is
//!   under a quarter of the structure's edge strength (the median steepest slope on the seed's
//!   rays at the same scale, `seed_statistics`) and its intensity is within a window half as wide again, there is no edge and the
//!   balloon goes on at the border's speed — the low threshold of a hysteresis, as in Canny's
//!   edge linking. Without an edge no place is better than its neighbours for the balloon to
//!   stop, and on the fine image the noise would choose, voxel by voxel (a noisy fading tube
//!   came out with up to 8 handles); two voxels of smoothing leave a tenth of the noise, and
//!   the balloon stops in one smooth cap.
//! - **Beyond the border** the speed is negative (the paper's containing force); NaN (unknown
//!   intensity) is beyond the border.

use glam::DVec3;

use crate::smoothed_volume::SmoothedVolume;
use crate::volume::Volume;

/// σ of the two smoothings, in smallest spacings.
const FINE_VOXELS: f64 = 0.5;
const COARSE_VOXELS: f64 = 2.0;

/// The scale (Gaussian σ, mm) of the coarse image, where the border rule reads gradients: the
/// structure's edge strength is measured at the same scale (`seed_statistics`).
pub(crate) fn edge_scale_mm(volume: &Volume<'_>) -> f64 {
    COARSE_VOXELS * volume.geometry().min_spacing()
}
/// The gradient that makes leaving the window an edge, as a fraction of the edge strength.
const EDGE_FRACTION: f64 = 0.25;
/// The hysteresis window's half-width, in tolerances.
const WIDE_WINDOW: f64 = 1.5;
/// Inflation speed at the window's border, kept beyond it where there is no edge.
const BORDER_SPEED: f64 = 0.5;
/// Inflation speed beyond the border: the containing force.
const CONTAINING_SPEED: f64 = -0.5;

/// The structure's intensities: `reference ± tolerance`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntensityWindow {
    pub reference: f64,
    pub tolerance: f64,
}

impl IntensityWindow {
    /// Inflation speed for an intensity: positive inside the window, negative outside, NaN
    /// (unknown intensity) counts as outside.
    pub fn inflation(&self, intensity: f64) -> f64 {
        let d = (intensity - self.reference).abs() / self.tolerance;
        if d <= 1.0 {
            1.0 - 0.5 * d * d
        } else {
            CONTAINING_SPEED
        }
    }

    pub fn contains(&self, intensity: f64) -> bool {
        (intensity - self.reference).abs() <= self.tolerance
    }

    fn wide_contains(&self, intensity: f64) -> bool {
        (intensity - self.reference).abs() <= WIDE_WINDOW * self.tolerance
    }
}

/// The image at the two scales the balloon reads it at.
pub(crate) struct ImageScales<'v> {
    pub fine: SmoothedVolume<'v>,
    pub coarse: SmoothedVolume<'v>,
}

impl<'v> ImageScales<'v> {
    pub fn new(volume: Volume<'v>) -> Self {
        let voxel = volume.geometry().min_spacing();
        ImageScales {
            fine: SmoothedVolume::new(volume, FINE_VOXELS * voxel),
            coarse: SmoothedVolume::new(volume, edge_scale_mm(&volume)),
        }
    }
}

/// What a place is to the balloon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Place {
    /// Whether the balloon may go there.
    pub passable: bool,
    /// Whether the fine image is inside the window there.
    pub in_window: bool,
    /// Inflation speed there (before the inflation weight).
    pub speed: f64,
}

/// The border rule: the intensity window and the structure's edge strength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Border {
    pub window: IntensityWindow,
    /// Intensity per mm; 0 takes the window literally (every exit from it is an edge).
    pub edge_strength: f64,
}

impl Border {
    /// The place at `x` (world mm); `None` outside the volume.
    pub fn place(&self, image: &ImageScales<'_>, x: DVec3) -> Option<Place> {
        let intensity = image.fine.sample_world(x)?;
        if self.window.contains(intensity) {
            return Some(Place {
                passable: true,
                in_window: true,
                speed: self.window.inflation(intensity),
            });
        }
        let no_edge = || {
            image
                .coarse
                .sample_with_gradient_world(x)
                .is_some_and(|(v, g)| {
                    self.window.wide_contains(v) && g.length() < EDGE_FRACTION * self.edge_strength
                })
        };
        Some(if no_edge() {
            Place {
                passable: true,
                in_window: false,
                speed: BORDER_SPEED,
            }
        } else {
            Place {
                passable: false,
                in_window: false,
                speed: CONTAINING_SPEED,
            }
        })
    }

    /// Whether the balloon may go to `x`: [`Border::place`]'s verdict, `false` outside.
    pub fn passable(&self, image: &ImageScales<'_>, x: DVec3) -> bool {
        self.place(image, x).is_some_and(|p| p.passable)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Geometry;
    use crate::volume::{Image, VoxelBuffer};

    #[test]
    fn inflation_slows_towards_the_border_and_reverses_beyond() {
        let w = IntensityWindow {
            reference: 1000.0,
            tolerance: 400.0,
        };
        assert_eq!(w.inflation(1000.0), 1.0);
        assert!((w.inflation(600.0) - 0.5).abs() < 1e-12);
        assert!(w.inflation(599.0) < 0.0);
        assert!(w.inflation(f64::NAN) < 0.0);
        assert!(w.contains(1400.0) && !w.contains(1400.5));
    }

    /// Intensity falling along x: from 1000 by `slope` per voxel (1 mm).
    fn ramp(slope: f64) -> Image {
        let n = 40;
        let values = (0..n * n * n)
            .map(|i| 1000.0 - slope * (i % n) as f64)
            .collect();
        Image::new(VoxelBuffer::F64(values), [n, n, n], Geometry::identity()).unwrap()
    }

    #[test]
    fn leaving_the_window_stops_the_balloon_only_across_an_edge() {
        let border = Border {
            window: IntensityWindow {
                reference: 1000.0,
                tolerance: 100.0,
            },
            edge_strength: 200.0,
        };
        let at = |x: f64| DVec3::new(x, 20.0, 20.0);
        // A steep edge (100 per mm): beyond the border at x = 1, nothing is passable.
        let steep = ramp(100.0);
        let image = ImageScales::new(steep.view());
        assert!(border.passable(&image, at(0.9)));
        assert!(!border.passable(&image, at(1.1)));
        // A fade (10 per mm, under a quarter of the edge strength): passable at the border's
        // speed down to the hysteresis window's end at x = 15.
        let fade = ramp(10.0);
        let image = ImageScales::new(fade.view());
        let p = border.place(&image, at(12.0)).unwrap();
        assert!(p.passable && p.speed == BORDER_SPEED, "{p:?}");
        assert!(!border.passable(&image, at(15.5)));
        // Taken literally, the window stops it at the border in the fade too.
        let literal = Border {
            edge_strength: 0.0,
            ..border
        };
        assert!(!literal.passable(&image, at(10.1)));
        assert!(border.place(&image, at(-1.0)).is_none());
    }
}
