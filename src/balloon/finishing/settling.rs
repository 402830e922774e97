//! Settling the finished surface onto the local half level: half-way between the structure
//! right behind each vertex and the background right ahead.
//!
//! The window's lower end is one level for the whole balloon, drawn from the seed's
//! surroundings, and the balloon stops where the image first falls below it. The structure's
//! own edge is elsewhere wherever the structure or its surroundings differ from the seed's:
//! - **CT**: the lower end is at least half-way to the soft tissue around the seed
//!   (`hounsfield`): a vessel that meets fat around the seed runs against enhanced parenchyma
//!   and muscle a few centimetres on, and a window half-way to fat would take those in. Where
//!   the vessel does meet fat (or lung), its edge — half-way between the structure and the fat,
//!   as the window's ends are drawn everywhere else (full width at half maximum) — lies below
//!   that lower end (every one of the CT phantom family's balloons came out smaller than its
//!   truth: 0.85–1.00 of its volume, median 0.95).
//! - **MR, no fixed units**: the bolus and the coil's bias drift along a vessel. Where a vessel
//!   is dimmer than at the seed its half level lies below the lower end, and its surface sat up
//!   to a third of a voxel inside (thin tortuous vessels whose contrast drifts to half: 0.6–0.9
//!   of their volume); where it is brighter, its half level lies above the lower end, and the
//!   surface sat outside on the ramp down to the background (rings up to twice as bright as
//!   the trunk: up to 1.09 of the volume).
//!
//! So once the surface is final, each vertex frozen at the border looks along its outward
//! normal: the structure's level is the highest within 2.5 voxels behind it, the tissue ahead
//! the lowest within 2.5 voxels ahead (at the scale of local steps, `ImageScales::mid`). Where
//! that tissue is background — in CT darker than the soft tissue by a quarter of the
//! structure's contrast to it (fat or lung); otherwise below the window — the vertex moves to
//! where the fine image crosses the half level between the two, at most a voxel: out where
//! the half level lies below the window's lower end, in where the vertex lies beyond it. In MR
//! the structure's level is read on the fine image: a tube two or three voxels across loses a
//! third of its peak at the scale of local steps, which would put its half level too low. The
//! lower end still decides where the balloon may go while it grows, so it never enters tissue
//! at the vessel's own level; only the place of the surface on an edge it already stopped at
//! changes. The fine image's half level of a curved edge lies inside the edge by its
//! smoothing's variance times the mean curvature; `curvature_offset` moves it back.
//!
//! First, though, a vertex stopped near the crest of a thin bright layer on the structure's
//! wall (`thin_layer`: a stent's struts) moves onto it, looked for as far as the layer's
//! reach, two voxels, on either side. While the balloon grows a vertex may only step onto a
//! crest one step ahead (farther, and the front was carried over bone cortex and bright
//! slivers into what lies beyond), so where dense struts bloom into a ring a voxel or two wide
//! the upper end stopped it on the ring's near flank, a voxel inside the wires: a stent's
//! lumen came out with Dice 0.85. Once the surface is final no vertex grows on from there.
//! Between struts no crest is found and the surface would stay a voxel inside, in a sawtooth:
//! the vertices moved onto crests and their neighbours are faired again (`segmenter`).

use glam::DVec3;
use rayon::prelude::*;

use crate::balloon::image_model::border::{Border, ImageScales, STEP_SAMPLES};
use crate::balloon::surface::{Surface, VertexState};

/// Tissue ahead darker than the soft tissue by this share of the structure's contrast to it is
/// fat or lung, not soft tissue at a level the window's lower end was raised to keep out.
const DARKER_THAN_SOFT: f64 = 0.25;
/// Steps per voxel in which the half level's crossing is looked for, up to a voxel either way.
const STEPS_PER_VOXEL: usize = 8;

/// What [`settle`] did.
pub(in crate::balloon) struct Settled {
    /// The vertices moved onto crests.
    pub crested: Vec<u32>,
    /// By slot: whether the vertex lies on an edge against tissue darker than the window's
    /// lower end, where the fine image placed it (`curvature_offset`), rather than on a crest,
    /// or against tissue at the structure's own level (a neighbour it was cut from).
    pub on_darker_edge: Vec<bool>,
}

/// Moves the vertices of `surface` frozen at the border onto the crest of a thin bright layer
/// within its reach, or else onto the local half level where the tissue ahead is
/// background: in CT (`soft`, the soft tissue's HU) darker than the soft tissue, otherwise
/// below the window (see the module's comment). The same result for any thread count.
pub(in crate::balloon) fn settle(
    surface: &mut Surface,
    image: &ImageScales<'_>,
    border: &Border,
    soft: Option<f64>,
) -> Settled {
    let normals = surface.vertex_normals();
    let live: Vec<u32> = surface.live_vertices().collect();
    let (positions, states) = (surface.positions(), surface.states());
    let outcomes: Vec<(u32, Option<DVec3>, bool, bool)> = live
        .par_iter()
        .filter(|&&v| states[v as usize] == VertexState::FrozenAtBorder)
        .map(|&v| {
            let (x, n) = (positions[v as usize], normals[v as usize]);
            if let Some(crest) = on_crest(image, border, x, n) {
                return (v, Some(crest), true, false);
            }
            let ahead = darkest_ahead(image, border, x, n);
            let moved = settled(image, border, soft, x, n, ahead);
            (v, moved, false, ahead < border.window.lower)
        })
        .collect();
    let mut on_darker_edge = vec![false; surface.vertex_slots()];
    let positions = surface.positions_mut();
    let mut crested = Vec::new();
    for (v, moved, onto_crest, darker) in outcomes {
        if let Some(p) = moved {
            positions[v as usize] = p;
        }
        if onto_crest {
            crested.push(v);
        }
        on_darker_edge[v as usize] = darker;
    }
    Settled {
        crested,
        on_darker_edge,
    }
}

/// The lowest of the image at the scale of local steps within 2.5 voxels ahead of `x` along
/// `n`, as far as a local step's level ahead is read: a blurred edge's ramp.
fn darkest_ahead(image: &ImageScales<'_>, border: &Border, x: DVec3, n: DVec3) -> f64 {
    (1..=STEP_SAMPLES)
        .filter_map(|k| {
            image
                .mid
                .sample_world(x + (k as f64 * 0.5 * border.voxel) * n)
        })
        .fold(f64::INFINITY, f64::min)
}

/// The crest of a thin bright layer the vertex at `x` with outward unit normal `n` moves
/// onto, if there is one.
fn on_crest(image: &ImageScales<'_>, border: &Border, x: DVec3, n: DVec3) -> Option<DVec3> {
    if n == DVec3::ZERO {
        return None;
    }
    border.thin_layer_crest(image, x, n, border.thin_layer_reach())
}

/// Where the vertex at `x` with outward unit normal `n` settles, if it moves; `ahead` is the
/// tissue ahead of it ([`darkest_ahead`]).
fn settled(
    image: &ImageScales<'_>,
    border: &Border,
    soft: Option<f64>,
    x: DVec3,
    n: DVec3,
    ahead: f64,
) -> Option<DVec3> {
    let window = border.window;
    if !window.lower.is_finite() || n == DVec3::ZERO {
        return None;
    }
    let half_voxel = 0.5 * border.voxel;
    let structure = if soft.is_some() {
        &image.mid
    } else {
        &image.fine
    };
    let along = |k: f64| x + k * half_voxel * n;
    // As far behind as a local step's level is read: a blurred edge's ramp.
    let inside = (0..=STEP_SAMPLES)
        .filter_map(|k| structure.sample_world(along(-(k as f64))))
        .fold(f64::NEG_INFINITY, f64::max);
    let dark = match soft {
        Some(soft) => soft - DARKER_THAN_SOFT * (window.reference - soft),
        None => window.lower,
    };
    if ahead >= dark {
        return None;
    }
    let level = 0.5 * (inside + ahead);
    let here = image.fine.sample_world(x)?;
    // Out to the half level where it lies below the lower end, in where the vertex lies
    // beyond it (the structure brighter here than at the seed).
    let outwards = if here > level && level < window.lower {
        1.0
    } else if here < level {
        -1.0
    } else {
        return None;
    };
    let h = border.voxel / STEPS_PER_VOXEL as f64;
    let mut before = (0.0, here);
    for k in 1..=STEPS_PER_VOXEL {
        let t = outwards * k as f64 * h;
        let value = image.fine.sample_world(x + t * n)?;
        if (value - level) * (before.1 - level) <= 0.0 {
            let share = (before.1 - level) / (before.1 - value);
            return Some(x + (before.0 + outwards * share * h) * n);
        }
        before = (t, value);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::balloon::image_model::border::IntensityWindow;
    use crate::volume::Image;

    /// A structure at `inside` for x < 12 against `outside` beyond (1 mm voxels).
    fn edge(inside: f64, outside: f64) -> Image {
        Image::along_x(24, |x| if x < 12.0 { inside } else { outside })
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
            hounsfield: false,
            surroundings: None,
        }
    }

    /// Where the vertex at `x` with normal `n` settles, reading the tissue ahead as `settle` does.
    fn settle_one(
        image: &ImageScales<'_>,
        border: &Border,
        soft: Option<f64>,
        x: DVec3,
        n: DVec3,
    ) -> Option<DVec3> {
        settled(
            image,
            border,
            soft,
            x,
            n,
            darkest_ahead(image, border, x, n),
        )
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
        let fat = edge(200.0, -100.0);
        let image = ImageScales::new(fat.view());
        let stop = crossing(&image, 120.0);
        let x = DVec3::new(stop, 12.0, 12.0);
        let settled = settle_one(&image, &border(), Some(40.0), x, DVec3::X).expect("fat ahead");
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
        let muscle = edge(200.0, 40.0);
        let image = ImageScales::new(muscle.view());
        let x = DVec3::new(crossing(&image, 120.0), 12.0, 12.0);
        assert_eq!(settle_one(&image, &border(), Some(40.0), x, DVec3::X), None);
        // A vertex without a normal does not move either.
        let fat = edge(200.0, -100.0);
        let image = ImageScales::new(fat.view());
        assert_eq!(
            settle_one(&image, &border(), Some(40.0), x, DVec3::ZERO),
            None
        );
    }

    /// An MR window around 300 whose lower end, 200, is half-way to a background at 100.
    fn mr_border() -> Border {
        Border {
            window: IntensityWindow::new(300.0, 200.0, f64::INFINITY),
            ..border()
        }
    }

    #[test]
    fn in_mr_a_vessel_dimmer_than_at_the_seed_settles_on_its_own_half_level() {
        // The vessel has drifted to 260 against a background of 60: its edge is at 160, below
        // the lower end drawn from the seed's contrast.
        let dim = edge(260.0, 60.0);
        let image = ImageScales::new(dim.view());
        let stop = crossing(&image, 200.0);
        let x = DVec3::new(stop, 12.0, 12.0);
        let settled =
            settle_one(&image, &mr_border(), None, x, DVec3::X).expect("background ahead");
        let half = crossing(&image, 160.0);
        assert!(
            settled.x > stop && (settled.x - half).abs() < 0.02,
            "{settled}"
        );
    }

    #[test]
    fn in_mr_a_vessel_brighter_than_at_the_seed_settles_in_on_its_own_half_level() {
        // The vessel has drifted to 560 against a background of 60: its edge is at 310, and
        // the balloon stopped further out, where the image falls to the lower end, 200.
        let bright = edge(560.0, 60.0);
        let image = ImageScales::new(bright.view());
        let stop = crossing(&image, 200.0);
        let x = DVec3::new(stop, 12.0, 12.0);
        let moved = settle_one(&image, &mr_border(), None, x, DVec3::X).expect("background ahead");
        let half = crossing(&image, 310.0);
        assert!(
            moved.x < stop && (moved.x - half).abs() < 0.02,
            "{moved} vs {half}"
        );
        // On its half level already, it stays.
        let on_edge = DVec3::new(half, 12.0, 12.0);
        let again = settle_one(&image, &mr_border(), None, on_edge, DVec3::X);
        assert!(again.is_none_or(|p| (p.x - half).abs() < 0.02), "{again:?}");
    }

    #[test]
    fn a_vertex_stopped_low_on_a_thin_bright_layer_settles_on_its_crest() {
        // A lumen at 300 up to x = 12, tissue at 40 beyond, and a blurred wire on the wall
        // 600 above the lumen: the window's upper end stops a vertex on the ridge's near
        // flank, a voxel below its crest, farther than a step of the balloon (¾ voxel).
        let wired = Image::along_x(24, |x| {
            let wall = if x < 12.0 { 300.0 } else { 40.0 };
            wall + 600.0 * (-0.5 * ((x - 12.0) / 0.6).powi(2)).exp()
        });
        let image = ImageScales::new(wired.view());
        let border = Border {
            crest: 60.0,
            ..border()
        };
        let at = |x: f64| image.fine.sample_world(DVec3::new(x, 12.0, 12.0)).unwrap();
        let stop = (0..400)
            .map(|k| 8.0 + 0.01 * k as f64)
            .find(|&x| at(x) >= border.window.upper)
            .unwrap();
        assert!(stop < 11.1, "{stop}");
        let x = DVec3::new(stop, 12.0, 12.0);
        let crest = on_crest(&image, &border, x, DVec3::X).expect("a crest ahead");
        assert!((crest.x - 12.0).abs() < 0.3, "{crest}");
        // Without a wire the same stop is the border: nothing moves it.
        let plain = Image::along_x(24, |x| if x < 12.0 { 300.0 } else { 40.0 });
        let image = ImageScales::new(plain.view());
        assert_eq!(on_crest(&image, &border, x, DVec3::X), None);
    }

    #[test]
    fn in_mr_tissue_inside_the_window_ahead_is_not_background() {
        let neighbour = edge(260.0, 220.0);
        let image = ImageScales::new(neighbour.view());
        let x = DVec3::new(crossing(&image, 240.0), 12.0, 12.0);
        assert_eq!(settle_one(&image, &mr_border(), None, x, DVec3::X), None);
    }
}
