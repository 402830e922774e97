//! Where the balloon stops at a thin bright layer on the structure's wall: a stent's struts, a
//! guide wire, a sliver of calcium on a lumen.
//!
//! A wire a fraction of a voxel thick comes out of the scanner as a blooming ridge a voxel or
//! two wide, a few hundred HU above the lumen, with the lumen's own fall to the tissue beyond
//! it. Neither of the window's borders is the wall there: the upper end (or a local step up)
//! stops a vertex half-way up the ridge's near flank, a voxel inside the wires (one stent's
//! lumen came out a third too small), and where the ridge stays inside the window the fall beyond
//! it is pushed out by the ridge's tail, a voxel outside them. The wires lie on the ridge's
//! crest: a blurred line's profile peaks at its centre.
//!
//! So where a vertex is about to stop at any border, the fine image along its way is read
//! around the crossing. The vertex stops on a crest instead if the image shows:
//! - the structure behind it: a plateau [`REACH_VOXELS`] to twice that behind the crest, flat
//!   (its halves' means within [`FLATNESS`] of a local step) and in the window's lower half or
//!   above, with nothing darker than the structure between it and the crest;
//! - a crest at least `Border::crest` above the plateau (a local step, and well above the fine
//!   image's noise);
//! - darker tissue, below the window, within [`REACH_VOXELS`] beyond the crest.
//!
//! The crest may lie behind the crossing (a vertex that went over a ridge inside the window
//! goes back onto it) or ahead of it by at most one step (`inflation`): farther ahead, a jump
//! onto a crest beyond a border let a noisy MR balloon into every bright sliver around the
//! heart, and a CT aorta over the vertebra's cortex into its marrow. Once the surface is final,
//! settling (`settling`) looks for a crest as far ahead as the reach: no vertex grows on from
//! there. A bright neighbour thicker than the reach (bone, a second vessel) has no dark tissue
//! that close behind its crest and keeps stopping the balloon at its border; a thin vessel seen
//! across or along a chord has no flat plateau behind its crest, only its own far wall.

use glam::DVec3;

use crate::balloon::image_model::border::{Border, ImageScales};
use crate::balloon::image_model::seed_statistics::SeedStatistics;

/// How far on either side of the crossing the crest is looked for, and how far behind the
/// crest the plateau and beyond it the darker tissue must lie, in voxels: a blurred wire's
/// ridge is a voxel or two wide.
const REACH_VOXELS: f64 = 2.0;
/// The plateau behind a crest changes by at most this share of a local step over its length:
/// the lumen behind a strut is flat, the chord of a thin vessel behind a crest is not.
const FLATNESS: f64 = 0.25;
/// Samples per voxel along the vertex's way.
const SAMPLES_PER_VOXEL: f64 = 4.0;

/// The smallest crest, in σ of the fine image inside the structure: the highest of a few dozen
/// noisy samples beside a plateau's mean is about 2σ above it.
const CREST_TEXTURE: f64 = 4.0;

/// The smallest crest of a thin bright layer above the structure (`Border::crest`): a local
/// step (`step`), and well above the fine image's noise and texture inside the structure.
pub(crate) fn smallest_crest(step: f64, estimate: Option<&SeedStatistics>) -> f64 {
    step.max(CREST_TEXTURE * estimate.map_or(0.0, |s| s.fine_texture))
}

impl Border {
    /// How far (mm) on either side of a stop a thin layer's crest is looked for.
    pub(crate) fn thin_layer_reach(&self) -> f64 {
        REACH_VOXELS * self.voxel
    }

    /// The crest of a thin bright layer near `crossing` (world mm), where a vertex moving along
    /// `direction` (unit) was about to stop, if there is one: behind the crossing, or at most
    /// `ahead` mm beyond it.
    pub(crate) fn thin_layer_crest(
        &self,
        image: &ImageScales<'_>,
        crossing: DVec3,
        direction: DVec3,
        ahead: f64,
    ) -> Option<DVec3> {
        let window = &self.window;
        if self.crest <= 0.0 || !window.lower.is_finite() {
            return None;
        }
        let h = self.voxel / SAMPLES_PER_VOXEL;
        let reach = (REACH_VOXELS * SAMPLES_PER_VOXEL).round() as usize;
        let centre = 3 * reach;
        // Sample k lies (k − centre) h along the way from the crossing: from the plateau
        // behind the farthest crest behind to a reach beyond the farthest crest ahead. Most
        // stops have no crest near, so the samples are read as the tests need them.
        let at = |k: usize| {
            let along = (k as f64 - centre as f64) * h;
            image.fine.sample_world(crossing + along * direction)
        };
        let read = |range: std::ops::RangeInclusive<usize>| -> Option<Vec<f64>> {
            range.map(at).collect()
        };
        let farthest = centre + ((ahead / h).floor().max(0.0) as usize).min(reach);
        let near = read(centre - reach..=farthest + 1)?;
        let (offset, top) = near[..near.len() - 1]
            .iter()
            .copied()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))?;
        let crest = centre - reach + offset;
        // The search's end on a rising flank is no crest, and a crest stands at least
        // `Border::crest` above a plateau in the window's lower half or above.
        let plateau_floor = 0.5 * (window.reference + window.lower);
        if near[offset + 1] > top || top < plateau_floor + self.crest {
            return None;
        }
        let beyond = read(crest + 1..=crest + reach)?;
        if !beyond.iter().any(|&v| v < window.lower) {
            return None;
        }
        let behind = read(crest - 2 * reach..=crest)?;
        // The plateau's level and its slope, from the means of its halves: noise makes the
        // range of a few samples wide where their means hardly move.
        let plateau = &behind[..reach];
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let (far, close) = plateau.split_at(plateau.len() / 2);
        let level = mean(plateau);
        let flat =
            (mean(close) - mean(far)).abs() <= FLATNESS * self.step && level >= plateau_floor;
        // Nothing darker than the structure between the plateau and the crest: a vertex never
        // moves onto a crest across a wall.
        let joined = behind.iter().all(|&v| v >= window.lower);
        (flat && joined && top - level >= self.crest).then(|| {
            let offset = parabolic_peak(behind[2 * reach - 1], top, beyond[0]);
            crossing + ((crest as f64 - centre as f64 + offset) * h) * direction
        })
    }
}

/// Where the parabola through three equally spaced samples peaks, in samples from the middle
/// one (which is the largest), within ±½.
fn parabolic_peak(before: f64, middle: f64, after: f64) -> f64 {
    let curvature = before - 2.0 * middle + after;
    if curvature < 0.0 {
        (0.5 * (before - after) / curvature).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::balloon::image_model::border::IntensityWindow;
    use crate::volume::Image;

    fn border() -> Border {
        Border {
            window: IntensityWindow::new(300.0, 170.0, 420.0),
            edge_strength: 0.0,
            step: 60.0,
            crest: 60.0,
            valley: 0.0,
            voxel: 1.0,
            hounsfield: false,
            surroundings: None,
        }
    }

    /// A lumen at 300 up to x = 16, tissue at 40 beyond, and a Gaussian ridge of `height` and
    /// σ `width` centred at x = 16 (a blurred wire on the wall).
    fn wall_with_wire(height: f64, width: f64) -> Image {
        Image::along_x(32, |x| {
            let wall = 40.0 + 260.0 * smooth_step(16.0 - x);
            wall + height * (-0.5 * ((x - 16.0) / width).powi(2)).exp()
        })
    }

    /// A blurred step from 0 to 1 at 0, about a voxel wide.
    fn smooth_step(x: f64) -> f64 {
        0.5 * (1.0 + (x / 0.5).tanh())
    }

    #[test]
    fn a_vertex_stopped_on_a_wires_flank_or_beyond_it_moves_to_its_crest() {
        let image = wall_with_wire(300.0, 0.7);
        let image = ImageScales::new(image.view());
        let border = border();
        let at = |x: f64| DVec3::new(x, 16.0, 16.0);
        let crest = |x: f64, ahead: f64| border.thin_layer_crest(&image, at(x), DVec3::X, ahead);
        for stop in [14.8, 15.3, 16.9, 17.4] {
            let c = crest(stop, 2.0).unwrap_or_else(|| panic!("no crest near {stop}"));
            assert!((c.x - 15.9).abs() < 0.25, "from {stop}: {c}");
        }
        // Never farther ahead than it is allowed to go.
        assert_eq!(crest(14.8, 0.5), None);
    }

    #[test]
    fn a_thick_bright_neighbour_or_a_plain_wall_keeps_its_border() {
        let border = border();
        let at = |x: f64| DVec3::new(x, 16.0, 16.0);
        // Bone: bright from x = 16 on, for far more than the reach.
        let bone = Image::along_x(32, |x| 300.0 + 600.0 * smooth_step(x - 16.0));
        let image = ImageScales::new(bone.view());
        assert_eq!(
            border.thin_layer_crest(&image, at(15.4), DVec3::X, 2.0),
            None
        );
        // A wall with no wire: its noise-free shoulder is no crest.
        let wall = wall_with_wire(0.0, 0.7);
        let image = ImageScales::new(wall.view());
        assert_eq!(
            border.thin_layer_crest(&image, at(16.0), DVec3::X, 2.0),
            None
        );
    }

    #[test]
    fn a_thin_vessel_seen_across_is_no_thin_layer() {
        // A vessel 3 voxels wide at 400 on tissue at 40: its crest has its far wall behind it.
        let vessel = Image::along_x(32, |x| {
            40.0 + 360.0 * (-0.5 * ((x - 16.0) / 1.2).powi(2)).exp()
        });
        let image = ImageScales::new(vessel.view());
        let border = Border {
            window: IntensityWindow::new(400.0, 220.0, f64::INFINITY),
            ..border()
        };
        let at = |x: f64| DVec3::new(x, 16.0, 16.0);
        assert_eq!(
            border.thin_layer_crest(&image, at(17.4), DVec3::X, 2.0),
            None
        );
    }
}
