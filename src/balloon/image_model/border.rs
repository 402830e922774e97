//! Where the balloon may go, and how fast it inflates there (paper, section 2: the inflation is
//! "inversely proportional to the difference between the local gray level and the reference
//! value" and zero once that difference exceeds a threshold).
//!
//! The balloon reads the image at three scales (`ImageScales`), all Gaussian-smoothed
//! (`SmoothedVolume`): a fine one, half a voxel, at the scale of its triangles; a mid one, a
//! voxel, where local steps are measured; and a coarse one, two voxels, for where the fine one
//! shows no edge.
//! - **The window**: where the fine image is inside `[lower, upper]` the balloon inflates with
//!   speed `1 − ½d²`, `d` the intensity's distance from the reference in half-widths of its
//!   side: slower towards the border but never stalling before it. Either end may be open.
//! - **Local steps**: the window is one interval for the whole structure, set by the tissue
//!   around the seed; elsewhere the structure may run against tissue inside it (muscle where
//!   fat was, a wall a voxel thick). A vertex also stops where the image steps from the
//!   structure it comes from to the tissue just ahead by a share of the structure's contrast
//!   (`Border::step_ahead`): the window's border drawn locally, half-way between the two.
//! - **Thin dark walls**: a wall under a voxel thick survives blurring only as a dip of a
//!   fraction of the contrast, less than a local step, the more so for a vertex that remeshing
//!   put on the wall's near ramp. Two edges a voxel or two apart, down and up again, are an edge
//!   at a smaller depth (`Border::valley`): far above the image's texture inside the structure,
//!   which the slow undulations of a thin tortuous vessel also reach.
//! - **Thin bright layers**: where the border a vertex stops at is the flank of a ridge a voxel
//!   or two wide on the structure's wall (a stent's struts), it stops on the ridge's crest
//!   (`thin_layer`).
//! - **Edges**: the intensity also leaves the window inside real structures, without an edge:
//!   contrast mixing in a lumen, a bolus fading along a vessel, noise. The vmtk aorta's lumen
//!   fades from 1600 to 450 over its last 12 cm, and where it crosses the border its bright part
//!   is a ring around a darker core; followed literally, the window made the balloon wrap around
//!   such dips and come out with handles. So leaving the window stops the balloon only across an
//!   edge. Where the fine image leaves it, the coarse image decides: if its gradient there is
//!   under a quarter of the structure's edge strength (the median steepest slope on the seed's
//!   rays at the same scale, `seed_statistics`) and its intensity is within a window half as
//!   wide again, there is no edge and the balloon goes on at the border's speed — the low
//!   threshold of a hysteresis, as in Canny's edge linking. Without an edge no place is better
//!   than its neighbours for the balloon to stop, and on the fine image the noise would choose,
//!   voxel by voxel (a noisy fading tube came out with up to 8 handles); two voxels of
//!   smoothing leave a tenth of the noise, and the balloon stops in one smooth cap.
//! - **Fading thin vessels** (outside CT, `Border::fading`): two voxels of smoothing keep only
//!   0.4 of a 2-voxel vessel's contrast at its axis, so an MR vessel that fades towards half
//!   its contrast ([`MAX_DRIFT`]) fails the coarse test and the balloon stalled in it, leaving
//!   rings open. On the mid image such a vessel's axis still stands out: the balloon goes on
//!   where that image is at least the half level of a vessel at half the contrast, is not on
//!   an edge's slope, and stands above the image two voxels away on every axis by a share of
//!   the contrast that a vessel of up to two voxels in radius at half the contrast reaches
//!   (2.5 voxels at two thirds; thicker ones keep enough of their contrast for the coarse
//!   test).
//! - **Beyond the border** the speed is negative (the paper's containing force); NaN (unknown
//!   intensity) is beyond the border, and so are the voxels of structures cut off as leaks.

use std::collections::HashSet;
use std::sync::Arc;

use glam::DVec3;

use crate::balloon::fast_hash::FastHash;
use crate::balloon::image_model::region::Region;
use crate::balloon::objects::obstacle::Obstacle;
use crate::smoothed_volume::SmoothedVolume;
use crate::volume::Volume;

/// The widest clearance from other objects (`ImageScales::widen_clearance`), in voxels of the
/// largest spacing: a marching-cubes cell's half diagonal, beyond which its surface no longer
/// depends on where inside the cell another surface runs.
const WIDEST_CLEARANCE: f64 = 0.9;
/// σ of the three smoothings, in smallest spacings.
const FINE_VOXELS: f64 = 0.5;
const MID_VOXELS: f64 = 1.0;
const COARSE_VOXELS: f64 = 2.0;

/// The gradient that makes leaving the window an edge, as a fraction of the edge strength.
const EDGE_FRACTION: f64 = 0.25;
/// How far behind a vertex and ahead of its target a local step's two levels are measured, in
/// samples every half voxel: two and a half voxels, the width of a blurred edge's ramp.
pub(in crate::balloon) const STEP_SAMPLES: usize = 5;
/// A local step happens within this many voxels at its steepest slope.
const STEEP_VOXELS: f64 = 3.0;
/// The hysteresis window's half-width, in tolerances.
const WIDE_WINDOW: f64 = 1.5;
/// How many times its contrast over the darker surroundings a vessel's signal may reach
/// along it in MR (the inflow and coil drifts of a TOF or phase-contrast angiogram).
const MAX_DRIFT: f64 = 2.0;
/// How far around a point (voxels) the mid image is read to tell a thin vessel's axis
/// (`Border::fading`).
const FADING_REACH_VOXELS: f64 = 2.0;
/// How far a thin vessel's axis stands above the mean of the mid image [`FADING_REACH_VOXELS`]
/// away on the three axes, as a share of the structure's contrast. Two voxels off the axis of
/// a vessel of radius R voxels the mid image lies 0.45 (R = 1.5–2), 0.34 (2.5) and 0.22 (3) of
/// the vessel's own contrast below the axis, on four of the six samples: this share takes in
/// vessels of up to two voxels at half the structure's contrast and of 2.5 voxels at two
/// thirds. Thicker ones keep enough of their contrast on the coarse image (a 2.5-voxel vessel
/// at half the contrast keeps 0.27 of it at its axis, within the wide window). The inside of a
/// thick structure is flat two voxels around, and an edge's foot is no ridge.
const FADING_RIDGE: f64 = 0.15;
/// Inflation speed at the window's border, kept beyond it where there is no edge.
const BORDER_SPEED: f64 = 0.5;
/// Inflation speed beyond the border: the containing force.
const CONTAINING_SPEED: f64 = -0.5;

/// The structure's intensities: `[lower, upper]` around its `reference` level. An end may be
/// infinite: a structure with no brighter (darker) neighbours has no upper (lower) end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntensityWindow {
    pub reference: f64,
    pub lower: f64,
    pub upper: f64,
}

impl IntensityWindow {
    pub fn new(reference: f64, lower: f64, upper: f64) -> Self {
        IntensityWindow {
            reference,
            lower,
            upper,
        }
    }

    /// `reference ± tolerance`, as a user gives it.
    pub fn symmetric(reference: f64, tolerance: f64) -> Self {
        Self::new(reference, reference - tolerance, reference + tolerance)
    }

    /// The half-width towards the darker side (towards the brighter one if that is open): the
    /// one number that stands for the window where a single tolerance is reported.
    pub fn tolerance(&self) -> f64 {
        let below = self.reference - self.lower;
        if below.is_finite() {
            below
        } else {
            self.upper - self.reference
        }
    }

    /// The intensity's distance from the reference in half-widths of its side.
    fn offset(&self, intensity: f64) -> f64 {
        if intensity < self.reference {
            (self.reference - intensity) / (self.reference - self.lower)
        } else {
            (intensity - self.reference) / (self.upper - self.reference)
        }
    }

    /// Inflation speed for an intensity: positive inside the window, negative outside, NaN
    /// (unknown intensity) counts as outside.
    pub fn inflation(&self, intensity: f64) -> f64 {
        let d = self.offset(intensity);
        if d <= 1.0 {
            1.0 - 0.5 * d * d
        } else {
            CONTAINING_SPEED
        }
    }

    pub fn contains(&self, intensity: f64) -> bool {
        self.offset(intensity) <= 1.0
    }

    fn wide_contains(&self, intensity: f64) -> bool {
        self.offset(intensity) <= WIDE_WINDOW
    }
}

impl std::fmt::Display for IntensityWindow {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "[{:.4}, {:.4}] around {:.4}",
            self.lower, self.upper, self.reference
        )
    }
}

/// The image at the three scales the balloon reads it at, and where it may not go whatever
/// the image: voxels cut off as leaks, beyond the region of interest, into other objects.
pub(crate) struct ImageScales<'v> {
    pub fine: SmoothedVolume<'v>,
    /// Where local steps are measured (`Border::step_ahead`): a voxel of smoothing leaves a
    /// quarter of the noise of the fine scale and most of a wall a voxel thick.
    pub mid: SmoothedVolume<'v>,
    pub coarse: SmoothedVolume<'v>,
    /// Voxels of structures cut off as leaks (`touching`): the balloon found its way into them
    /// once through a neck, and would again.
    excluded: HashSet<[i64; 3], FastHash>,
    region: Option<Region>,
    /// The other objects' surfaces, and the distance (mm) the balloon keeps from them.
    obstacles: Vec<Arc<Obstacle>>,
    clearance: f64,
}

impl<'v> ImageScales<'v> {
    pub fn new(volume: Volume<'v>) -> Self {
        let voxel = volume.geometry().min_spacing();
        ImageScales {
            fine: SmoothedVolume::new(volume, FINE_VOXELS * voxel),
            mid: SmoothedVolume::new(volume, MID_VOXELS * voxel),
            // The border rule reads gradients here, and the structure's edge strength is
            // measured at the same scale (`seed_statistics`).
            coarse: SmoothedVolume::new(volume, COARSE_VOXELS * voxel),
            excluded: HashSet::default(),
            region: None,
            obstacles: Vec::new(),
            clearance: 0.0,
        }
    }

    /// Keeps the balloon inside `region` from now on.
    pub fn restrict_to(&mut self, region: Option<Region>) {
        self.region = region;
    }

    pub fn region(&self) -> Option<Region> {
        self.region
    }

    /// Keeps the balloon `clearance` (mm) away from `obstacles`, instead of those before.
    pub fn set_obstacles(&mut self, obstacles: Vec<Arc<Obstacle>>, clearance: f64) {
        self.obstacles = obstacles;
        self.clearance = clearance;
    }

    /// The distance (mm) the balloon keeps from the other objects.
    pub fn clearance(&self) -> f64 {
        self.clearance
    }

    /// Doubles the clearance from the other objects, up to [`WIDEST_CLEARANCE`] voxels;
    /// whether it could.
    pub fn widen_clearance(&mut self) -> bool {
        let widest = WIDEST_CLEARANCE * self.fine.geometry().max_spacing();
        if self.obstacles.is_empty() || self.clearance >= widest {
            return false;
        }
        self.clearance = (2.0 * self.clearance).min(widest);
        true
    }

    /// Whether a region or other objects bound the balloon besides the image.
    pub fn is_constrained(&self) -> bool {
        self.region.is_some() || !self.obstacles.is_empty()
    }

    /// How far (mm) `x` is inside the space the region and the other objects leave to the
    /// balloon, negative outside it; `None` where neither is near (within an obstacle's reach,
    /// or with a region at all).
    pub fn free_depth(&self, x: DVec3) -> Option<f64> {
        let region = self.region.map(|r| r.depth(x));
        self.obstacles
            .iter()
            .filter_map(|o| o.signed_distance(x))
            .map(|d| d - self.clearance)
            .chain(region)
            .reduce(f64::min)
    }

    /// Keeps the balloon out of these voxels (indices of the volume's grid) from now on.
    pub fn exclude(&mut self, voxels: impl IntoIterator<Item = [i64; 3]>) {
        self.excluded.extend(voxels);
    }

    /// The voxels excluded so far (indices of the volume's grid).
    pub fn excluded(&self) -> &HashSet<[i64; 3], FastHash> {
        &self.excluded
    }

    /// Whether the balloon may not go to `x` (world mm) whatever the image: the voxel nearest
    /// to it was excluded, or it lies beyond the region or too close to another object.
    fn is_excluded(&self, x: DVec3) -> bool {
        if self.is_blocked(x) {
            return true;
        }
        if self.excluded.is_empty() {
            return false;
        }
        let i = self.fine.geometry().world_to_index(x).round();
        self.excluded
            .contains(&[i.x as i64, i.y as i64, i.z as i64])
    }

    /// Whether another object or the region's edge keeps the balloon from `x`.
    pub fn is_blocked(&self, x: DVec3) -> bool {
        self.free_depth(x).is_some_and(|d| d < 0.0)
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

/// The border rule: the intensity window, the structure's edge strength and the smallest
/// local step that is an edge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Border {
    pub window: IntensityWindow,
    /// Intensity per mm; 0 takes the window literally (every exit from it is an edge).
    pub edge_strength: f64,
    /// A step of the image at the scale of local steps at least this high is an edge even
    /// inside the window (`Border::step_ahead`; 0: none is).
    pub step: f64,
    /// The crest of a thin bright layer stands at least this high above the structure behind
    /// it (`thin_layer`; 0: no layer is thin).
    pub crest: f64,
    /// A thin wall of darker tissue: where the image at the scale of local steps dips at least
    /// this far below the structure and rises again beyond by half as much, the dip is an edge
    /// even where it is less than a local step (`Border::step_ahead`; 0: no dip is).
    pub valley: f64,
    /// A voxel (mm): local steps are measured within [`STEP_SAMPLES`] half voxels.
    pub voxel: f64,
    /// The intensities are Hounsfield units (`hounsfield::is_ct`): a step up is measured
    /// from the darkest of the structure behind ([`Border::level_to_step_up_from`]).
    pub hounsfield: bool,
    /// In an image without fixed units (MR), the level of the darker tissue around the
    /// structure: a vessel's signal may drift along it to [`MAX_DRIFT`] times its contrast over
    /// that level, so a step up is an edge only where it rises beyond (`Border::step_ahead`),
    /// and a thin vessel fading to half of it is followed (`Border::fading`). `None` in a CT,
    /// whose contrast does not rise along a vessel, or without the level.
    pub surroundings: Option<f64>,
}

/// Where a vertex meets a local step ([`Border::step_ahead`]): it stops where the fine image
/// crosses `level`, from above when `falling`. The levels come from the scale of local steps,
/// where noise is low; the crossing from the fine scale, whose smoothing barely shifts a
/// curved edge (a Gaussian of σ moves the half level of a ball of radius R inwards by σ²/R).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Step {
    pub level: f64,
    pub falling: bool,
}

impl Step {
    /// Whether `intensity` is on the far side of the step.
    pub fn crossed(&self, intensity: f64) -> bool {
        if self.falling {
            intensity <= self.level
        } else {
            intensity >= self.level
        }
    }
}

impl Border {
    /// The place at `x` (world mm); `None` outside the volume.
    pub fn place(&self, image: &ImageScales<'_>, x: DVec3) -> Option<Place> {
        let intensity = image.fine.sample_world(x)?;
        if image.is_excluded(x) {
            return Some(Place {
                passable: false,
                in_window: false,
                speed: CONTAINING_SPEED,
            });
        }
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
                || self.fading(image, x, intensity)
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

    /// Whether `x` (world mm) lies on the axis of a thin vessel that fades below the window
    /// (see the module's comment), where the structure's darker surroundings are known
    /// ([`Border::surroundings`]): the mid image there is at least the half level of a vessel
    /// at 1 / [`MAX_DRIFT`] of the contrast, its gradient is under the edge strength, and it
    /// stands [`FADING_RIDGE`] of the contrast above the mean of the mid image
    /// [`FADING_REACH_VOXELS`] away along the three axes. `fine` is the fine image at `x`:
    /// on a thin vessel's axis it stands above the mid image, so below the half level it
    /// rules the place out before the mid image is read (most places a vertex's bisection
    /// tries beyond a border are background).
    fn fading(&self, image: &ImageScales<'_>, x: DVec3, fine: f64) -> bool {
        let Some(surroundings) = self.surroundings else {
            return false;
        };
        let contrast = self.window.reference - surroundings;
        let half_level = surroundings + contrast / (2.0 * MAX_DRIFT);
        if fine < half_level {
            return false;
        }
        let Some((here, gradient)) = image.mid.sample_with_gradient_world(x) else {
            return false;
        };
        if here < half_level || gradient.length() >= self.edge_strength {
            return false;
        }
        let reach = FADING_REACH_VOXELS * self.voxel;
        let around: Option<f64> = [DVec3::X, DVec3::Y, DVec3::Z]
            .into_iter()
            .flat_map(|axis| [axis, -axis])
            .map(|d| image.mid.sample_world(x + reach * d))
            .sum();
        around.is_some_and(|sum| sum / 6.0 < here - FADING_RIDGE * contrast)
    }

    /// The local step a vertex meets on its way from `x` to `target` (world mm), if any: the
    /// image at the scale of local steps (`ImageScales::mid`) within [`STEP_SAMPLES`] half voxels
    /// behind `x` (the structure the vertex comes from) differs from the image within as far
    /// ahead of `target` by at least [`Border::step`], and the fine image at `target` is past
    /// the half-way between the two. This is the window's border drawn locally, between the structure and
    /// the tissue right ahead: a wall of darker tissue a voxel thick, or muscle inside a window
    /// that fat and lung set elsewhere, stops the balloon although the window holds them, and
    /// so does bone or a stent strut above an open upper end; a bolus fading along a vessel is
    /// no step, however far it fades, nor in MR a vessel brightening within its drift
    /// ([`Border::surroundings`]). The way a vertex comes tells which side the structure is
    /// on; looking as far behind as ahead keeps the level the same all along the step's ramp,
    /// and lets a vertex that remeshing put just past a step see it. It is looked for only
    /// where `target` is half a step from the reference, which inside the structure noise and
    /// texture seldom reach.
    pub fn step_ahead(&self, image: &ImageScales<'_>, x: DVec3, target: DVec3) -> Option<Step> {
        if self.step <= 0.0 {
            return None;
        }
        let mid = &image.mid;
        let there = mid.sample_world(target)?;
        let falling = there < self.window.reference;
        if (there - self.window.reference).abs() < 0.5 * self.step {
            return None;
        }
        let direction = (target - x).normalize_or_zero();
        let further = |a: f64, b: f64| if falling { a.min(b) } else { a.max(b) };
        // Half a voxel apart, from the farthest behind `x` to the farthest ahead of `target`.
        let at = |from: DVec3, k: f64| mid.sample_world(from + (k * self.voxel / 2.0) * direction);
        let behind: Vec<f64> = (1..=STEP_SAMPLES)
            .rev()
            .filter_map(|k| at(x, -(k as f64)))
            .chain([mid.sample_world(x)?])
            .collect();
        let ahead: Vec<f64> = [there]
            .into_iter()
            .chain((1..=STEP_SAMPLES).filter_map(|k| at(target, k as f64)))
            .collect();
        let inside = if falling {
            behind.iter().copied().reduce(f64::max)?
        } else {
            self.level_to_step_up_from(&behind)?
        };
        let ahead_level = ahead.iter().copied().fold(there, further);
        // A step is steep: most of it within a few voxels. A bolus fading along a vessel
        // changes as much over the look's five voxels, but never that fast.
        let steepest = behind
            .iter()
            .chain(&ahead)
            .collect::<Vec<_>>()
            .windows(3)
            .map(|w| (w[2] - w[0]).abs())
            .fold(0.0, f64::max);
        let depth = (inside - ahead_level).abs();
        let steep = STEEP_VOXELS * steepest >= depth;
        let high_enough = depth >= self.step
            || (falling
                && self.valley > 0.0
                && depth >= self.valley
                && self.rise_beyond(image, target, direction, &ahead) >= 0.5 * self.valley);
        let ahead = ahead_level;
        let drifts = !falling
            && self
                .surroundings
                .is_some_and(|level| ahead - level <= MAX_DRIFT * (inside - level));
        let step = Step {
            level: 0.5 * (inside + ahead),
            falling,
        };
        // A step at the window's end only repeats it: the window stops the vertex there, on
        // the fine image, without the coarser scale's shift of a curved edge.
        let margin = if falling { 0.25 } else { -0.25 } * self.step;
        let tightens = self.window.contains(step.level - margin);
        let crossed = image
            .fine
            .sample_world(target)
            .is_some_and(|v| step.crossed(v));
        (high_enough && steep && tightens && crossed && !drifts).then_some(step)
    }

    /// The structure's level behind a vertex that may meet a step up, from the samples
    /// `behind` it that lie in the window; `None` if none does. Across a thin vessel the look
    /// behind reaches the darker tissue on its far side, out of the window, and the
    /// partial-volume rim on the way, in it. In MR, measured from the darkest sample, a vessel
    /// that brightens along its length (inflow in a TOF angiogram, a coil's sensitivity) met
    /// its own brighter core as a step and stopped short of closing its loops: there it is
    /// the median, the core's level wherever most of the look runs along the structure. In
    /// CT a vessel does not brighten along its length, and what lies above contrast blood is
    /// bone, marrow or calcium, a step of only a few tens of HU above the blood's own
    /// brightest voxels: measured from the median, the aorta went into the vertebral marrow.
    /// There it stays the darkest.
    fn level_to_step_up_from(&self, behind: &[f64]) -> Option<f64> {
        let mut inside: Vec<f64> = behind
            .iter()
            .copied()
            .filter(|&v| self.window.contains(v))
            .collect();
        inside.sort_unstable_by(f64::total_cmp);
        let at = if self.hounsfield { 0 } else { inside.len() / 2 };
        inside.get(at).copied()
    }

    /// How far the image at the scale of local steps rises again within [`STEP_SAMPLES`] half
    /// voxels beyond the lowest of `ahead` (its samples every half voxel from `target` along
    /// `direction`): a thin wall's far side.
    fn rise_beyond(
        &self,
        image: &ImageScales<'_>,
        target: DVec3,
        direction: DVec3,
        ahead: &[f64],
    ) -> f64 {
        let Some((lowest_at, lowest)) = ahead
            .iter()
            .copied()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))
        else {
            return 0.0;
        };
        (1..=STEP_SAMPLES)
            .filter_map(|k| {
                let along = (lowest_at + k) as f64 * self.voxel / 2.0;
                image.mid.sample_world(target + along * direction)
            })
            .fold(lowest, f64::max)
            - lowest
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
    use crate::volume::Image;

    #[test]
    fn inflation_slows_towards_the_border_and_reverses_beyond() {
        let w = IntensityWindow::symmetric(1000.0, 400.0);
        assert_eq!(w.inflation(1000.0), 1.0);
        assert!((w.inflation(600.0) - 0.5).abs() < 1e-12);
        assert!(w.inflation(599.0) < 0.0);
        assert!(w.inflation(f64::NAN) < 0.0);
        assert!(w.contains(1400.0) && !w.contains(1400.5));
    }

    /// Intensity falling along x: from 1000 by `slope` per voxel (1 mm).
    fn ramp(slope: f64) -> Image {
        Image::along_x(40, |x| 1000.0 - slope * x)
    }

    #[test]
    fn leaving_the_window_stops_the_balloon_only_across_an_edge() {
        let border = Border {
            window: IntensityWindow::symmetric(1000.0, 100.0),
            edge_strength: 200.0,
            step: 0.0,
            crest: 0.0,
            valley: 0.0,
            voxel: 1.0,
            hounsfield: false,
            surroundings: None,
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

    /// Intensity along x: `levels` on `[0, 8)`, `[8, 10)` and from 10 on (1 mm voxels).
    fn bands(levels: [f64; 3]) -> Image {
        Image::along_x(24, |x| match x {
            x if x < 8.0 => levels[0],
            x if x < 10.0 => levels[1],
            _ => levels[2],
        })
    }

    #[test]
    fn a_wall_thinner_than_a_voxel_stops_a_vertex_on_its_near_ramp_although_it_dips_less_than_a_step(
    ) {
        // A structure at 1000 with a wall of tissue at 100 from x = 11.7 to 12.3 (0.6 voxel, as
        // partial volume leaves it: a dip of about 215 on the scale of local steps), and more
        // of the structure beyond; a step is 400, under half the contrast.
        let wall = Image::along_x(24, |x| {
            let covered = ((x + 0.5).min(12.3) - (x - 0.5).max(11.7)).max(0.0);
            1000.0 - 900.0 * covered
        });
        let image = ImageScales::new(wall.view());
        let border = Border {
            window: IntensityWindow::new(1000.0, 550.0, f64::INFINITY),
            edge_strength: 0.0,
            step: 400.0,
            crest: 0.0,
            valley: 200.0,
            voxel: 1.0,
            hounsfield: false,
            surroundings: None,
        };
        let at = |x: f64| DVec3::new(x, 12.0, 12.0);
        // A vertex that remeshing put on the wall's near ramp, half a voxel from its centre.
        let (x, target) = (at(11.4), at(11.9));
        let step = border
            .step_ahead(&image, x, target)
            .expect("the wall stops it");
        assert!(
            step.falling && (550.0..1000.0).contains(&step.level),
            "{step:?}"
        );
        // As a step alone (no valleys) the dip is not deep enough.
        let steps_only = Border {
            valley: 0.0,
            ..border
        };
        assert_eq!(steps_only.step_ahead(&image, x, target), None);
        // The same fall with nothing beyond it (one edge, not two) is no edge either.
        let fall = Image::along_x(24, |x| {
            let covered = ((x + 0.5).min(23.0) - (x - 0.5).max(11.7)).clamp(0.0, 1.0);
            1000.0 - 300.0 * covered
        });
        let image = ImageScales::new(fall.view());
        assert_eq!(border.step_ahead(&image, x, target), None);
    }

    #[test]
    fn a_step_up_from_a_thin_structure_is_measured_from_it_not_from_the_tissue_behind_it() {
        // A structure two voxels wide at 200 between dark tissue (100) and bright tissue
        // (600), with no upper end: the look behind a vertex in it reaches the dark side.
        let image = bands([100.0, 200.0, 600.0]);
        let image = ImageScales::new(image.view());
        let window = IntensityWindow::new(200.0, 150.0, f64::INFINITY);
        let border = Border {
            window,
            edge_strength: 0.0,
            step: 25.0,
            crest: 0.0,
            valley: 0.0,
            voxel: 1.0,
            hounsfield: false,
            surroundings: None,
        };
        let at = |x: f64| DVec3::new(x, 12.0, 12.0);
        let step = border.step_ahead(&image, at(9.0), at(10.2)).unwrap();
        assert!(!step.falling);
        // Half-way between the structure and the bright tissue (400; the smoothing of a
        // structure two voxels wide lifts its median level behind), not nearer the dark
        // tissue (360 before the look behind counted only what lies in the window).
        assert!((380.0..=440.0).contains(&step.level), "{step:?}");
    }

    #[test]
    fn a_vessel_brightening_along_its_length_is_no_step_up_from_its_partial_volume_rim() {
        // Along x: tissue (100), the partial-volume rim a look behind crosses where it runs
        // obliquely out of a thin vessel (300, in the window), the vessel's core (500) and
        // its brighter far part (750: a TOF vessel's inflow, 1.5 times the core). The look
        // spans 2 mm voxels, twice the image's, so that the scale of local steps keeps the
        // three levels apart.
        let profile = |far: f64| {
            Image::along_x(32, move |x| match x {
                x if x < 4.0 => 100.0,
                x if x < 7.0 => 300.0,
                x if x < 11.0 => 500.0,
                _ => far,
            })
        };
        let border = Border {
            window: IntensityWindow::new(500.0, 250.0, f64::INFINITY),
            edge_strength: 0.0,
            step: 350.0,
            crest: 0.0,
            valley: 0.0,
            voxel: 2.0,
            hounsfield: false,
            surroundings: None,
        };
        let at = |x: f64| DVec3::new(x, 12.0, 12.0);
        let (x, target) = (at(10.0), at(11.2));
        let image = profile(750.0);
        let image = ImageScales::new(image.view());
        assert_eq!(border.step_ahead(&image, x, target), None);
        // In Hounsfield units it stays one, measured from the rim: what is brighter than
        // contrast blood in CT is bone, marrow or calcium.
        let hounsfield = Border {
            hounsfield: true,
            ..border
        };
        assert!(hounsfield.step_ahead(&image, x, target).is_some());
        // Measured from the core, a brightening of twice the step is one.
        let image = profile(1200.0);
        let image = ImageScales::new(image.view());
        assert!(border.step_ahead(&image, x, target).is_some());
    }

    #[test]
    fn in_mr_a_vessel_brightening_within_its_drift_is_no_step_up() {
        // Along x: tissue (100), a vessel (500) and its brighter continuation from x = 14.
        let vessel = |far: f64| {
            Image::along_x(32, move |x| match x {
                x if x < 4.0 => 100.0,
                x if x < 14.0 => 500.0,
                _ => far,
            })
        };
        let border = Border {
            window: IntensityWindow::new(500.0, 300.0, f64::INFINITY),
            edge_strength: 0.0,
            step: 200.0,
            crest: 0.0,
            valley: 0.0,
            voxel: 1.0,
            hounsfield: false,
            surroundings: Some(100.0),
        };
        let at = |x: f64| DVec3::new(x, 12.0, 12.0);
        let (x, target) = (at(13.2), at(14.2));
        let steps = |border: &Border, far: f64| {
            let image = vessel(far);
            border.step_ahead(&ImageScales::new(image.view()), x, target)
        };
        // 1.75 times the contrast over the surroundings: the vessel's own drift.
        assert_eq!(steps(&border, 800.0), None);
        // Without the surroundings' level it was a step, as it still is in a CT.
        let unknown = Border {
            surroundings: None,
            ..border
        };
        assert!(steps(&unknown, 800.0).is_some_and(|s| !s.falling));
        // 2.75 times: brighter tissue beyond the vessel (fat on a T1 image).
        assert!(steps(&border, 1200.0).is_some_and(|s| !s.falling));
    }

    #[test]
    fn in_mr_a_thin_vessel_fading_below_the_window_is_no_edge_and_a_thick_ones_foot_is() {
        // On a 1 mm grid: tissue at 100 and a vessel of radius 2 running along z through
        // (12, 12), faded to 360, 0.65 of the contrast of 400 at the seed and below the
        // window's lower end; a thick structure at the same faded level fills x ≥ 24.
        let n = 40;
        let image = Image::from_fn([n, n, n], Geometry::identity(), |i, j, _| {
            let (x, y) = (i as f64, j as f64);
            let in_vessel = (x - 12.0).hypot(y - 12.0) <= 2.0;
            if in_vessel || x >= 24.0 {
                360.0
            } else {
                100.0
            }
        })
        .unwrap();
        let image = ImageScales::new(image.view());
        let border = Border {
            window: IntensityWindow::new(500.0, 400.0, f64::INFINITY),
            edge_strength: 150.0,
            step: 100.0,
            crest: 0.0,
            valley: 0.0,
            voxel: 1.0,
            hounsfield: false,
            surroundings: Some(100.0),
        };
        let at = |x: f64, y: f64| DVec3::new(x, y, 20.0);
        let fine = |p: DVec3| image.fine.sample_world(p).unwrap();
        // The faded vessel's axis: below the window, but no edge.
        assert!(!border.window.contains(fine(at(12.0, 12.0))));
        assert!(border.fading(&image, at(12.0, 12.0), fine(at(12.0, 12.0))));
        assert!(border.passable(&image, at(12.0, 12.0)));
        // Beside it, inside the thick structure (flat) and on the foot of its edge, above the
        // half level but below the window and on a slope, it is not.
        assert!(!border.fading(&image, at(14.5, 12.0), fine(at(14.5, 12.0))));
        assert!(!border.fading(&image, at(30.0, 12.0), fine(at(30.0, 12.0))));
        let foot = at(23.6, 12.0);
        assert!((200.0..400.0).contains(&fine(foot)), "{}", fine(foot));
        assert!(!border.fading(&image, foot, fine(foot)));
        // Without the surroundings' level (a CT) there is no such rule.
        let ct = Border {
            surroundings: None,
            ..border
        };
        assert!(!ct.fading(&image, at(12.0, 12.0), fine(at(12.0, 12.0))));
    }
}
