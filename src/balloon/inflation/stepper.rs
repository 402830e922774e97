//! One step of the balloon's evolution: explicit integration of the forces (`forces`) in the
//! overdamped limit — a vertex's velocity is its force, there is no momentum to overshoot —
//! with every displacement clamped to a fraction of a voxel, so that the balloon cannot jump
//! through a wall thinner than a voxel.
//!
//! A vertex whose step crosses the border (`border`: where the smoothed image stops the
//! balloon) or the volume's edge is put on the crossing, found by bisection on the trilinear
//! intensity, and frozen there: the border is located to a small fraction of the step, not to
//! the step itself. Where the border is the flank of a thin bright layer (a stent's struts),
//! the vertex freezes on the layer's crest instead (`thin_layer`). Frozen vertices no longer
//! move (paper, section 2).
//!
//! Each vertex's new position depends only on the surface before the step, so vertices are
//! updated in parallel with the same result for any thread count.

use glam::DVec3;
use rayon::prelude::*;

use crate::balloon::image_model::border::{Border, ImageScales};
use crate::balloon::inflation::forces::{internal_forces, ForceScratch, ForceWeights};
use crate::balloon::surface::front::Front;
use crate::balloon::surface::{Surface, VertexState};

/// What a step needs besides the surface.
pub(crate) struct Stepper<'a, 'v> {
    pub image: &'a ImageScales<'v>,
    pub border: Border,
    pub weights: ForceWeights,
    pub edge_length: f64,
    pub max_step: f64,
}

/// Buffers reused from step to step.
#[derive(Default)]
pub(crate) struct Scratch {
    front: Front,
    normals: Vec<DVec3>,
    sums: ForceScratch,
    forces: Vec<DVec3>,
}

/// What one step did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct StepReport {
    /// Vertices still moving after the step.
    pub moving: usize,
    /// The largest displacement in the step (mm): near zero at equilibrium, where the internal
    /// forces balance the inflation of the vertices that have not frozen.
    pub largest_move: f64,
}

/// Bisection halvings on a crossing step: locates the border to 2⁻¹⁶ of the step.
const BISECTIONS: u32 = 16;

impl Stepper<'_, '_> {
    /// Moves every moving vertex once; the work is on the moving front only.
    pub fn step(&self, surface: &mut Surface, scratch: &mut Scratch) -> StepReport {
        let Scratch {
            front,
            normals,
            sums,
            forces,
        } = scratch;
        front.update(surface);
        surface.front_vertex_normals_into(front, normals);
        internal_forces(
            surface,
            front,
            normals,
            &self.weights,
            self.edge_length,
            sums,
            forces,
        );
        let positions = surface.positions();
        let updates: Vec<(DVec3, VertexState)> = front
            .vertices
            .par_iter()
            .zip(forces.par_iter())
            .with_min_len(256)
            .map(|(&v, &force)| self.move_vertex(positions[v as usize], normals[v as usize], force))
            .collect();
        let mut report = StepReport::default();
        let (positions, states) = surface.positions_and_states_mut();
        for (&v, (p, state)) in front.vertices.iter().zip(updates) {
            let v = v as usize;
            report.largest_move = report.largest_move.max((p - positions[v]).length());
            positions[v] = p;
            states[v] = state;
            report.moving += usize::from(state == VertexState::Moving);
        }
        report
    }

    fn move_vertex(&self, x: DVec3, normal: DVec3, internal: DVec3) -> (DVec3, VertexState) {
        let Some(here) = self.border.place(self.image, x) else {
            return (x, VertexState::FrozenAtBorder);
        };
        let inflation = self.weights.inflation * here.speed;
        let mut dx = self.max_step * (inflation * normal + internal);
        let length = dx.length();
        if length > self.max_step {
            dx *= self.max_step / length;
        }
        if !dx.is_finite() {
            return (x, VertexState::FrozenAtBorder);
        }
        let same_side = |p: DVec3| {
            self.border
                .place(self.image, p)
                .is_some_and(|place| place.passable == here.passable)
        };
        // Another object or the region's edge ahead: the step ends short of it, frozen there,
        // unless the image stops the vertex first. The window's border is no guide to where
        // the obstacle begins.
        let mut arrived = VertexState::Moving;
        if here.passable && self.image.is_blocked(x + dx) {
            let (mut lo, mut hi) = (0.0, 1.0);
            bisect(&mut lo, &mut hi, |t| !self.image.is_blocked(x + t * dx));
            dx *= lo;
            arrived = VertexState::FrozenAtBorder;
        }
        let target = x + dx;
        if here.passable {
            if let Some(step) = self.border.step_ahead(self.image, x, target) {
                let (mut lo, mut hi) = (0.0, 1.0);
                bisect(&mut lo, &mut hi, |t| {
                    self.image
                        .fine
                        .sample_world(x + t * dx)
                        .is_some_and(|v| !step.crossed(v))
                });
                return self.stop(x, lo, dx);
            }
        }
        if same_side(target) {
            return (target, arrived);
        }
        // The border (or the volume's edge) lies in (x, target]: bisect onto it. From inside
        // the window, first onto where the fine image leaves it, which needs no coarse sample
        // (most crossings are edges and end there); only if that is no edge, on beyond it.
        let window = self.border.window;
        let in_window = |p: DVec3| {
            self.image
                .fine
                .sample_world(p)
                .is_some_and(|v| window.contains(v))
        };
        let (mut lo, mut hi) = (0.0, 1.0);
        if here.in_window {
            bisect(&mut lo, &mut hi, |t| in_window(x + t * dx));
            if !self.border.passable(self.image, x + hi * dx) {
                return self.stop(x, lo, dx);
            }
            lo = hi;
            hi = 1.0;
        }
        bisect(&mut lo, &mut hi, |t| same_side(x + t * dx));
        self.stop(x, lo, dx)
    }

    /// Freezes a vertex on the border it meets at `x + t dx`, or on the crest of a thin bright
    /// layer there (`thin_layer`) unless another object or the region's edge is in the way.
    fn stop(&self, x: DVec3, t: f64, dx: DVec3) -> (DVec3, VertexState) {
        let crossing = x + t * dx;
        // Beyond the border, no farther than a step would take the vertex: a crest farther
        // ahead may be a bright neighbour's, reached through it.
        let stop = self
            .border
            .thin_layer_crest(self.image, crossing, dx.normalize(), self.max_step)
            .filter(|&crest| !self.image.is_blocked(crest))
            .unwrap_or(crossing);
        (stop, VertexState::FrozenAtBorder)
    }
}

/// Halves `[lo, hi]` [`BISECTIONS`] times, keeping `on_side(lo)` true and `on_side(hi)` false.
fn bisect(lo: &mut f64, hi: &mut f64, on_side: impl Fn(f64) -> bool) {
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (*lo + *hi);
        if on_side(mid) {
            *lo = mid;
        } else {
            *hi = mid;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::balloon::image_model::border::IntensityWindow;
    use crate::geometry::Geometry;
    use crate::volume::{Image, VoxelBuffer};

    /// A stepper with unit edge length and quarter-voxel steps, with the window taken
    /// literally.
    fn stepper<'a, 'v>(
        image: &'a ImageScales<'v>,
        reference: f64,
        tolerance: f64,
        weights: ForceWeights,
    ) -> Stepper<'a, 'v> {
        Stepper {
            image,
            border: Border {
                window: IntensityWindow::symmetric(reference, tolerance),
                edge_strength: 0.0,
                step: 0.0,
                crest: 0.0,
                valley: 0.0,
                voxel: 1.0,
                hounsfield: false,
                surroundings: None,
            },
            weights,
            edge_length: 1.0,
            max_step: 0.25,
        }
    }

    /// A bright ball of radius 6 around (10, 10, 10) on a dark background, with a linear ramp
    /// of one voxel across its surface.
    fn ball() -> Image {
        let n = 21;
        let values = (0..n * n * n)
            .map(|i| {
                let p = DVec3::new((i % n) as f64, (i / n % n) as f64, (i / (n * n)) as f64);
                let d = (p - DVec3::splat(10.0)).length() - 6.0;
                (100.0 + 1000.0 * (0.5 - d).clamp(0.0, 1.0)) as f32
            })
            .collect();
        Image::new(VoxelBuffer::F32(values), [n, n, n], Geometry::identity()).unwrap()
    }

    #[test]
    fn a_seed_sphere_inflates_to_the_border_and_freezes_on_it() {
        let image = ball();
        let volume = image.view();
        let smoothed = ImageScales::new(volume);
        let stepper = stepper(&smoothed, 1100.0, 500.0, ForceWeights::default());
        let mut surface = Surface::icosphere(DVec3::splat(10.0), 1.0, 3).unwrap();
        let mut scratch = Scratch::default();
        let mut steps = 0;
        loop {
            let report = stepper.step(&mut surface, &mut scratch);
            if report.moving == 0 || report.largest_move < 1e-6 {
                break;
            }
            steps += 1;
            assert!(steps < 200, "still moving after 200 steps: {report:?}");
        }
        // The window's border (600) is where the ramp crosses its middle: radius 6 (up to the
        // trilinear interpolation of a radial ramp). Vertices that froze sit on it; a few may
        // rest just inside, where the internal forces balance the inflation.
        let mut frozen = 0;
        for v in surface.live_vertices() {
            let p = surface.positions()[v as usize];
            let r = (p - DVec3::splat(10.0)).length();
            assert!((r - 6.0).abs() < 0.15, "vertex {v} stopped at radius {r}");
            if surface.states()[v as usize] == VertexState::FrozenAtBorder {
                let value = smoothed.fine.sample_world(p).unwrap();
                assert!((value - 600.0).abs() < 1.0, "{value}");
                frozen += 1;
            }
        }
        assert!(frozen * 10 > surface.vertex_count() * 9, "{frozen} frozen");
    }

    #[test]
    fn no_vertex_moves_more_than_the_step() {
        let image = ball();
        let smoothed = ImageScales::new(image.view());
        let stepper = stepper(
            &smoothed,
            1100.0,
            500.0,
            ForceWeights {
                inflation: 50.0,
                ..ForceWeights::default()
            },
        );
        let mut surface = Surface::icosphere(DVec3::splat(10.0), 2.0, 2).unwrap();
        let before = surface.positions().to_vec();
        stepper.step(&mut surface, &mut Scratch::default());
        for (a, b) in before.iter().zip(surface.positions()) {
            assert!((*a - *b).length() <= 0.25 + 1e-12);
        }
    }

    #[test]
    fn vertices_at_the_volume_edge_freeze_inside_it() {
        // Everything is foreground: the balloon stops at the volume's faces, half a voxel
        // beyond the outermost voxel centres, so that those voxels are inside it.
        let image = Image::new(
            VoxelBuffer::U8(vec![200; 8 * 8 * 8]),
            [8, 8, 8],
            Geometry::identity(),
        )
        .unwrap();
        let smoothed = ImageScales::new(image.view());
        let stepper = stepper(&smoothed, 200.0, 10.0, ForceWeights::default());
        let mut surface = Surface::icosphere(DVec3::splat(3.5), 1.0, 2).unwrap();
        let mut scratch = Scratch::default();
        for _ in 0..100 {
            stepper.step(&mut surface, &mut scratch);
        }
        assert!(surface
            .states()
            .iter()
            .all(|s| *s == VertexState::FrozenAtBorder));
        for p in surface.positions() {
            assert!(p.min_element() >= -0.5 && p.max_element() <= 7.5, "{p}");
            assert!(
                p.min_element() < 0.0 || p.max_element() > 7.0,
                "{p} stopped short of the faces"
            );
        }
    }
}
