//! Settling the finished surface onto the local half level in CT, where the tissue right outside
//! is darker than the tissue the window's lower end guards against.
//!
//! In CT the window's lower end is at least half-way to the soft tissue around the seed
//! (`hounsfield`): a vessel that meets fat around the seed runs against enhanced parenchyma and
//! muscle a few centimetres on, and a window half-way to fat would take those in. Where the
//! vessel does meet fat (or lung), its edge — half-way between the structure and the fat, as
//! the window's ends are drawn everywhere else (full width at half maximum) — lies below that
//! lower end, so the balloon stops a few tenths of a millimetre inside it (every one of the
//! CT phantom family's balloons came out smaller than its truth: 0.85–1.00 of its volume,
//! median 0.95).
//!
//! So once the surface is final, each vertex looks along its outward normal, at the scale of
//! local steps (`ImageScales::mid`): the structure's level is the highest within 2.5 voxels
//! behind it, the tissue ahead the lowest within 2.5 voxels ahead. Where that tissue is darker
//! than the soft tissue by a quarter of the structure's contrast to it, and the half level
//! between the two lies below the window's lower end, the vertex moves out to where the fine
//! image crosses the half level, at most a voxel. The lower end still decides where the balloon
//! may go while it grows, so it never enters soft tissue at the vessel's own level; only the
//! place of the surface on an edge it already stopped at changes.

use glam::DVec3;
use rayon::prelude::*;

use super::border::{Border, ImageScales, STEP_SAMPLES};
use super::surface::{Surface, VertexState};

/// Tissue ahead darker than the soft tissue by this share of the structure's contrast to it is
/// fat or lung, not soft tissue at a level the window's lower end was raised to keep out.
const DARKER_THAN_SOFT: f64 = 0.25;
/// Steps per voxel in which the half level's crossing is looked for, up to a voxel out.
const STEPS_PER_VOXEL: usize = 8;

/// Moves the vertices of `surface` frozen at the border out to the local half level where the
/// tissue ahead is darker than the soft tissue at `soft` (HU; see the module's comment). The
/// same result for any thread count.
pub(super) fn settle(surface: &mut Surface, image: &ImageScales<'_>, border: &Border, soft: f64) {
    let normals = surface.vertex_normals();
    let live: Vec<u32> = surface.live_vertices().collect();
    let (positions, states) = (surface.positions(), surface.states());
    let moved: Vec<(u32, DVec3)> = live
        .par_iter()
        .filter(|&&v| states[v as usize] == VertexState::FrozenAtBorder)
        .filter_map(|&v| {
            let (x, n) = (positions[v as usize], normals[v as usize]);
            settled(image, border, soft, x, n).map(|p| (v, p))
        })
        .collect();
    let positions = surface.positions_mut();
    for (v, p) in moved {
        positions[v as usize] = p;
    }
}

/// Where the vertex at `x` with outward unit normal `n` settles, if it moves.
fn settled(
    image: &ImageScales<'_>,
    border: &Border,
    soft: f64,
    x: DVec3,
    n: DVec3,
) -> Option<DVec3> {
    let window = border.window;
    if !window.lower.is_finite() || n == DVec3::ZERO {
        return None;
    }
    let half_voxel = 0.5 * border.voxel;
    let mid = |k: f64| image.mid.sample_world(x + k * half_voxel * n);
    // As far behind and ahead as a local step's two levels are read: a blurred edge's ramp.
    let inside = (0..=STEP_SAMPLES)
        .filter_map(|k| mid(-(k as f64)))
        .fold(f64::NEG_INFINITY, f64::max);
    let ahead = (1..=STEP_SAMPLES)
        .filter_map(|k| mid(k as f64))
        .fold(f64::INFINITY, f64::min);
    if ahead >= soft - DARKER_THAN_SOFT * (window.reference - soft) {
        return None;
    }
    let level = 0.5 * (inside + ahead);
    let fine = |t: f64| image.fine.sample_world(x + t * n);
    if level >= window.lower || fine(0.0)? <= level {
        return None;
    }
    let h = border.voxel / STEPS_PER_VOXEL as f64;
    let mut before = (0.0, fine(0.0)?);
    for k in 1..=STEPS_PER_VOXEL {
        let t = k as f64 * h;
        let value = fine(t)?;
        if value <= level {
            let share = (before.1 - level) / (before.1 - value);
            return Some(x + (before.0 + share * h) * n);
        }
        before = (t, value);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::balloon::border::IntensityWindow;
    use crate::geometry::Geometry;
    use crate::volume::{Image, VoxelBuffer};

    /// A contrast-filled structure at 200 HU for x < 12 against `outside` beyond (1 mm voxels).
    fn edge(outside: f64) -> Image {
        let n = 24;
        let values = (0..n * n * n)
            .map(|i| if i % n < 12 { 200.0 } else { outside })
            .collect();
        Image::new(VoxelBuffer::F64(values), [n, n, n], Geometry::identity()).unwrap()
    }

    /// The window of a 200 HU structure in CT with soft tissue at 40: its lower end half-way
    /// to the soft tissue.
    fn border() -> Border {
        Border {
            window: IntensityWindow::new(200.0, 120.0, 450.0),
            edge_strength: 0.0,
            step: 60.0,
            crest: 0.0,
            valley: 0.0,
            voxel: 1.0,
        }
    }

    /// Where the fine image crosses `level` along x at y = z = 12.
    fn crossing(image: &ImageScales<'_>, level: f64) -> f64 {
        let at = |x: f64| image.fine.sample_world(DVec3::new(x, 12.0, 12.0)).unwrap();
        let (mut lo, mut hi) = (8.0, 16.0);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if at(mid) > level {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    #[test]
    fn against_fat_a_vertex_stopped_at_the_lower_end_settles_on_the_half_level() {
        let fat = edge(-100.0);
        let image = ImageScales::new(fat.view());
        let stop = crossing(&image, 120.0);
        let x = DVec3::new(stop, 12.0, 12.0);
        let settled = settled(&image, &border(), 40.0, x, DVec3::X).expect("fat ahead");
        // Half-way between the structure and the fat: 50 HU, further out.
        let half = crossing(&image, 50.0);
        assert!(
            settled.x > stop && (settled.x - half).abs() < 0.02,
            "{settled}"
        );
        assert!((settled - DVec3::new(settled.x, 12.0, 12.0)).length() < 1e-12);
    }

    #[test]
    fn against_soft_tissue_the_lower_end_stays_the_border() {
        let muscle = edge(40.0);
        let image = ImageScales::new(muscle.view());
        let x = DVec3::new(crossing(&image, 120.0), 12.0, 12.0);
        assert_eq!(settled(&image, &border(), 40.0, x, DVec3::X), None);
        // A vertex without a normal does not move either.
        let fat = edge(-100.0);
        let image = ImageScales::new(fat.view());
        assert_eq!(settled(&image, &border(), 40.0, x, DVec3::ZERO), None);
    }
}
