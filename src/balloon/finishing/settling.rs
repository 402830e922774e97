//! Settling the finished surface onto the structure's own edge with the background right ahead
//! of each vertex: in CT its steepest descent, otherwise the local half level.
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
//! So once the surface is final, each vertex frozen at the border where the tissue ahead is
//! background — the lowest of the image within 2.5 voxels ahead along its outward normal, at
//! the scale of local steps (`ImageScales::mid`), below the window — moves along the normal,
//! at most a voxel:
//! - **in CT**, where that tissue is darker than the soft tissue around the seed (by a tenth
//!   of the structure's contrast to it, and by three σ of the structure's texture), onto the
//!   steepest descent of the fine image beyond the vertex: the edge of a blurred step,
//!   whatever lies past it. Against thick fat or lung that is half-way to them. A sheath of
//!   fat a millimetre or two thick, though, never reads its own level once blurred: the
//!   angiogram phantom's 1.7 mm of retroperitoneal fat (−100 HU) read 40–60 HU below the soft
//!   tissue ahead, a seventh of the lumen's contrast. The half level read from that, and the
//!   earlier test for fat (a quarter of the contrast below the soft tissue), left those
//!   vertices on the lower end, a third of a voxel inside the lumen's edge with the fat
//!   (Dice 0.969 at full size). Each vertex finds its steepest point on its own, so the
//!   surface ripples by the noise of the fine image's slope: those vertices are faired again.
//!   Where the steepest descent lies behind the vertex (a lumen brighter than at the seed, or
//!   a two-stage ramp of real scans' partial volume), the vertex takes the half level
//!   instead, read as below. Against soft tissue the vertex stays: the lower end is half-way
//!   to it already.
//! - **otherwise**, onto where the fine image crosses the half level between the structure's
//!   level (the highest within 2.5 voxels behind; outside CT on the fine image, since a tube
//!   two or three voxels across loses a third of its peak at the scale of local steps, which
//!   would put its half level too low) and the tissue ahead: out where that half level lies
//!   below the window's lower end, in where the vertex lies beyond it.
//!
//! The lower end still decides where the balloon may go while it grows, so it never enters
//! tissue at the vessel's own level; only the place of the surface on an edge it already
//! stopped at changes. The fine image's edge of a curved surface lies inside it by its
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
use crate::smoothed_volume::SmoothedVolume;

/// Tissue ahead darker than the soft tissue around the seed by this share of the structure's
/// contrast to it is background: fat, fluid, lung, or soft tissue darker than the seed's (the
/// module's comment: 1.7 mm of fat read 0.11–0.17 of the contrast below the soft tissue)...
const DARKER_SHARE: f64 = 0.1;
/// ...and by this many σ of the structure's texture at the scale of local steps, so that a
/// faint structure's noisy soft tissue is not read as darker.
const DARKER_TEXTURES: f64 = 3.0;
/// Steps per voxel in which the half level's crossing is looked for, up to a voxel either way.
const STEPS_PER_VOXEL: usize = 8;

/// What CT's calibration tells of the tissue around the structure.
#[derive(Debug, Clone, Copy)]
pub(in crate::balloon) struct SoftTissue {
    /// Its level (HU) around the seed (`hounsfield`).
    pub level: f64,
    /// σ of the image at the scale of local steps inside the structure
    /// (`SeedStatistics::texture`).
    pub texture: f64,
}

impl SoftTissue {
    /// Below this level tissue ahead of a structure at `reference` is darker than the soft
    /// tissue around the seed.
    fn darker_than(&self, reference: f64) -> f64 {
        let margin = DARKER_SHARE * (reference - self.level);
        self.level - margin.max(DARKER_TEXTURES * self.texture)
    }
}

/// Where a vertex moves, and whether it is faired again afterwards ([`Settled::refair`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Move {
    to: DVec3,
    refair: bool,
}

impl Move {
    /// Onto a level crossing, where neighbours cross it too: not faired again.
    fn held(to: DVec3) -> Self {
        Move { to, refair: false }
    }
}

/// What [`settle`] did.
pub(in crate::balloon) struct Settled {
    /// The vertices moved onto crests or onto a steepest descent: each on its own, from a
    /// reading of the image along its own normal, so they are faired again.
    pub refair: Vec<u32>,
    /// By slot: whether the vertex lies on an edge against tissue darker than the window's
    /// lower end, where the fine image placed it (`curvature_offset`), rather than on a crest,
    /// or against tissue at the structure's own level (a neighbour it was cut from).
    pub on_darker_edge: Vec<bool>,
}

/// Moves the vertices of `surface` frozen at the border onto the crest of a thin bright layer
/// within its reach, or else, where the tissue ahead is background, onto the edge: in CT
/// (`soft`, the soft tissue's HU, is known) the steepest descent, otherwise the local half
/// level (see the module's comment). The same result for any thread count.
pub(in crate::balloon) fn settle(
    surface: &mut Surface,
    image: &ImageScales<'_>,
    border: &Border,
    soft: Option<SoftTissue>,
) -> Settled {
    let normals = surface.vertex_normals();
    let live: Vec<u32> = surface.live_vertices().collect();
    let (positions, states) = (surface.positions(), surface.states());
    let outcomes: Vec<(u32, Option<Move>, bool)> = live
        .par_iter()
        .filter(|&&v| states[v as usize] == VertexState::FrozenAtBorder)
        .map(|&v| {
            let (x, n) = (positions[v as usize], normals[v as usize]);
            if let Some(crest) = on_crest(image, border, x, n) {
                let onto_crest = Move {
                    to: crest,
                    refair: true,
                };
                return (v, Some(onto_crest), false);
            }
            let ahead = darkest_ahead(&image.mid, border, x, n);
            let moved = settled(image, border, soft, x, n, ahead);
            (v, moved, ahead < border.window.lower)
        })
        .collect();
    let mut on_darker_edge = vec![false; surface.vertex_slots()];
    let positions = surface.positions_mut();
    let mut refair = Vec::new();
    for (v, moved, darker) in outcomes {
        if let Some(moved) = moved {
            positions[v as usize] = moved.to;
            if moved.refair {
                refair.push(v);
            }
        }
        on_darker_edge[v as usize] = darker;
    }
    Settled {
        refair,
        on_darker_edge,
    }
}

/// The lowest of `image` within 2.5 voxels ahead of `x` along `n`, as far as a local step's
/// level ahead is read: a blurred edge's ramp.
fn darkest_ahead(image: &SmoothedVolume<'_>, border: &Border, x: DVec3, n: DVec3) -> f64 {
    (1..=STEP_SAMPLES)
        .filter_map(|k| image.sample_world(x + (k as f64 * 0.5 * border.voxel) * n))
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
    soft: Option<SoftTissue>,
    x: DVec3,
    n: DVec3,
    ahead: f64,
) -> Option<Move> {
    let window = border.window;
    if !window.lower.is_finite() || n == DVec3::ZERO || ahead >= window.lower {
        return None;
    }
    match soft {
        Some(soft) if ahead < soft.darker_than(window.reference) => {
            match onto_steepest_descent(image, border, x, n) {
                Some(to) if (to - x).dot(n) > 0.0 => Some(Move { to, refair: true }),
                _ => onto_half_level(image, &image.mid, border, x, n, ahead).map(Move::held),
            }
        }
        Some(_) => None,
        None => onto_half_level(image, &image.fine, border, x, n, ahead).map(Move::held),
    }
}

/// In CT: where the fine image falls most steeply along `n` within a voxel of `x`.
fn onto_steepest_descent(
    image: &ImageScales<'_>,
    border: &Border,
    x: DVec3,
    n: DVec3,
) -> Option<DVec3> {
    let h = border.voxel / STEPS_PER_VOXEL as f64;
    let reach = STEPS_PER_VOXEL as i64;
    // Each slope spans a voxel: the fine image is interpolated linearly between voxels, so a
    // shorter difference would be constant across each voxel and place the edge only to one.
    let span = reach / 2;
    let profile: Vec<f64> = (-reach - span..=reach + span)
        .map(|k| image.fine.sample_world(x + (k as f64 * h) * n))
        .collect::<Option<_>>()?;
    let slope = |k: i64| profile[(k + reach + 2 * span) as usize] - profile[(k + reach) as usize];
    let steepest = (-reach..=reach).min_by(|&a, &b| slope(a).total_cmp(&slope(b)))?;
    // Steepest at the end of the reach: the edge lies beyond it, farther than a settled vertex
    // may move.
    if steepest.abs() == reach || slope(steepest) >= 0.0 {
        return None;
    }
    let (before, at, after) = (slope(steepest - 1), slope(steepest), slope(steepest + 1));
    let curvature = before - 2.0 * at + after;
    let share = if curvature > 0.0 {
        0.5 * (before - after) / curvature
    } else {
        0.0
    };
    Some(x + ((steepest as f64 + share) * h) * n)
}

/// Onto the half level between the structure behind `x` (the highest of `structure`) and the
/// tissue `ahead`, out where it lies below the window's lower end, in where the vertex lies
/// beyond it.
fn onto_half_level(
    image: &ImageScales<'_>,
    structure: &SmoothedVolume<'_>,
    border: &Border,
    x: DVec3,
    n: DVec3,
    ahead: f64,
) -> Option<DVec3> {
    let half_voxel = 0.5 * border.voxel;
    let along = |k: f64| x + k * half_voxel * n;
    // As far behind as a local step's level is read: a blurred edge's ramp.
    let inside = (0..=STEP_SAMPLES)
        .filter_map(|k| structure.sample_world(along(-(k as f64))))
        .fold(f64::NEG_INFINITY, f64::max);
    let level = 0.5 * (inside + ahead);
    let here = image.fine.sample_world(x)?;
    let outwards = if here > level && level < border.window.lower {
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
        let soft = soft.map(|level| SoftTissue {
            level,
            texture: 0.0,
        });
        let ahead = darkest_ahead(&image.mid, border, x, n);
        settled(image, border, soft, x, n, ahead).map(|moved| moved.to)
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
    fn against_fat_a_vertex_stopped_at_the_lower_end_settles_on_the_edge() {
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

    #[test]
    fn regression_a_vessel_in_a_thin_fat_sheath_kept_the_lower_end_inside_its_edge() {
        // A 400 HU lumen up to x = 11.5, two voxels of fat, then soft tissue at 40. Blurred,
        // the fat never read darker than the soft tissue by a quarter of the contrast, the
        // test that once told fat: the vertex kept the lower end, half-way to the soft tissue
        // (220), inside the lumen's edge with the fat.
        let sheathed = Image::along_x(24, |x| match x {
            x if x < 12.0 => 400.0,
            x if x < 14.0 => -100.0,
            _ => 40.0,
        });
        let image = ImageScales::new(sheathed.view());
        let border = Border {
            window: IntensityWindow::new(400.0, 220.0, 650.0),
            ..border()
        };
        let stop = crossing(&image, 220.0);
        let x = DVec3::new(stop, 12.0, 12.0);
        let ahead = darkest_ahead(&image.mid, &border, x, DVec3::X);
        assert!(ahead > 40.0 - 0.25 * (400.0 - 40.0), "{ahead}");
        let settled = settle_one(&image, &border, Some(40.0), x, DVec3::X).expect("fat ahead");
        assert!(stop < 11.4, "{stop}");
        assert!((settled.x - 11.5).abs() < 0.05, "{settled} from {stop}");
    }

    #[test]
    fn against_tissue_darker_than_around_the_seed_a_vertex_settles_on_the_edge() {
        // A portal-venous lumen at 150 HU against muscle at 70, the soft tissue around the
        // seed (liver) at 97, the lower end half-way to it: the edge is half-way to the muscle.
        let muscle = edge(150.0, 70.0);
        let image = ImageScales::new(muscle.view());
        let border = Border {
            window: IntensityWindow::new(150.0, 123.0, 300.0),
            ..border()
        };
        let x = DVec3::new(crossing(&image, 123.0), 12.0, 12.0);
        let moved = settle_one(&image, &border, Some(97.0), x, DVec3::X).expect("an edge");
        assert!((moved.x - crossing(&image, 110.0)).abs() < 0.02, "{moved}");
        // Unless the structure's texture says that so small a dip may be noise.
        let ahead = darkest_ahead(&image.mid, &border, x, DVec3::X);
        let noisy = SoftTissue {
            level: 97.0,
            texture: 10.0,
        };
        assert_eq!(
            settled(&image, &border, Some(noisy), x, DVec3::X, ahead),
            None
        );
    }

    #[test]
    fn a_steepest_descent_behind_the_vertex_is_not_its_edge() {
        // A lumen at 400 up to x = 10.5, brighter than at the seed (250), a voxel-thick rim at
        // 150, then tissue at 60: the lumen's own step, behind the vertex, is the steepest. The
        // vertex takes the half level between the lumen and the tissue instead.
        let rimmed = Image::along_x(24, |x| match x {
            x if x < 11.0 => 400.0,
            x if x < 12.0 => 150.0,
            _ => 60.0,
        });
        let image = ImageScales::new(rimmed.view());
        let border = Border {
            window: IntensityWindow::new(250.0, 175.0, 600.0),
            ..border()
        };
        let x = DVec3::new(crossing(&image, 175.0), 12.0, 12.0);
        let steepest = onto_steepest_descent(&image, &border, x, DVec3::X).expect("a descent");
        assert!(steepest.x < x.x, "{steepest} behind {x}");
        let ahead = darkest_ahead(&image.mid, &border, x, DVec3::X);
        let half = onto_half_level(&image, &image.mid, &border, x, DVec3::X, ahead).expect("moved");
        let soft = SoftTissue {
            level: 97.0,
            texture: 0.0,
        };
        let moved = settled(&image, &border, Some(soft), x, DVec3::X, ahead);
        assert_eq!(moved, Some(Move::held(half)));
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
