//! What follows the paper's steps: structures entered through a contact are cut off
//! (`touching`), the surface is faired (`fairing`), settled onto the local half level
//! (`settling`) and moved out by its curvature biases (`curvature_offset`), and `validation`
//! checks the guarantees before anything is returned.

pub(in crate::balloon) mod curvature_offset;
pub(in crate::balloon) mod fairing;
pub(in crate::balloon) mod settling;
pub(in crate::balloon) mod touching;
mod validation;

use glam::DVec3;

use crate::balloon::progress::Phase;
use crate::balloon::reparametrization::AfterReparametrization;
use crate::balloon::segmenter::Segmenter;
use crate::balloon::surface::{Surface, VertexState};
use crate::error::Result;
use crate::mesh::TriMesh;
use curvature_offset::offset_by_curvature;
use touching::cut_touching;

/// Radius, in target edge lengths, of the ball whose erosion finds the thick parts of the
/// balloon when looking for structures that touch: thinner parts have no core of their own.
/// At 2.5, two tubes of radius 3.2 mm on 1.92 mm slices (a mean spacing of 1.29 mm) had none,
/// and the second was taken in.
pub(in crate::balloon) const TOUCHING_EDGE_LENGTHS: f64 = 2.0;
/// The largest move of a vertex by its mean curvature (`curvature_offset`), in voxels: on a
/// vessel a voxel and a half in radius, triangles a voxel across and the fine image's blur
/// move it by about 0.15 voxel, so only a structure well under a voxel reaches the cap.
const CURVATURE_OFFSET_VOXELS: f64 = 0.25;
/// Rounds of undoing each finishing step (curvature offset, settling, fairing) around contacts,
/// and the rings around each contact's triangles that each round puts back.
const UNFAIR_ROUNDS: u32 = 3;
const UNFAIR_RINGS: usize = 2;

impl Segmenter<'_, '_> {
    /// Cuts off the structures the balloon entered through an elongated contact with the
    /// seeds' structure (`touching`), with cores eroded by `TOUCHING_EDGE_LENGTHS` target edge
    /// lengths: the paper ties the triangle size to the scale of the smallest structure.
    /// Returns whether it cut anything off.
    pub(super) fn cut_touching(&mut self, next: AfterReparametrization) -> Result<bool> {
        self.timed(Phase::Reparametrization, |s| {
            s.report(0.9, Phase::Reparametrization)?;
            let (mesh, _) = s.mesh();
            let geometry = *s.volume.geometry();
            let radius = TOUCHING_EDGE_LENGTHS * s.edge_length;
            let (seeds, image) = (&s.seeds, &s.image);
            let free_depth = |p| image.free_depth(p);
            let free_depth = image.is_constrained().then_some(&free_depth as _);
            if let Some(cut) = s.pool.install(|| {
                cut_touching(
                    &mesh,
                    &geometry,
                    seeds,
                    radius,
                    image.excluded(),
                    free_depth,
                )
            })? {
                s.image.exclude(cut.removed);
                let mut surface = Surface::from_mesh(&cut.mesh)?;
                match next {
                    AfterReparametrization::Nothing => {
                        surface.states_mut().fill(VertexState::FrozenAtBorder)
                    }
                    AfterReparametrization::Refinement => s.freeze_outside_window(&mut surface),
                }
                s.replace_surface(surface);
                return Ok(true);
            }
            Ok(false)
        })
    }

    /// Fairs the final surface (`fairing`) and settles it onto thin layers' crests and the
    /// structure's edge where background lies ahead (`settling`), fairing the vertices moved
    /// onto crests or steepest descents and their neighbours once more, then moves the
    /// vertices out by the biases of their triangles and of the fine image on a curved surface
    /// (`curvature_offset`), unless it stopped with contacts (re-parametrised next, in
    /// `validated`). Returns the positions, by slot, before that move, before settling and
    /// before fairing, for `validated` to put back in that order where any made the surface
    /// meet itself: a settled vertex may move two voxels, onto a crest.
    pub(super) fn fair(&mut self) -> Vec<Vec<DVec3>> {
        if self.has_self_intersections() {
            return Vec::new();
        }
        self.timed(Phase::Refinement, |s| {
            let surface = &mut s.surface;
            let unfaired = s.pool.install(|| fairing::fair(surface));
            let unsettled = s.surface.positions().to_vec();
            let soft_tissue = s.stats.seed_statistics.as_ref().and_then(|s| {
                s.soft_tissue.map(|level| settling::SoftTissue {
                    level,
                    texture: s.texture,
                })
            });
            let (surface, image, border) = (&mut s.surface, &s.image, &s.border);
            let settled = s
                .pool
                .install(|| settling::settle(surface, image, border, soft_tissue));
            let around: Vec<u32> = s
                .surface
                .neighbourhood(settled.refair, 1)
                .into_iter()
                .collect();
            let surface = &mut s.surface;
            s.pool.install(|| fairing::fair_vertices(surface, &around));
            let variance = s.image.fine.blur_variances().iter().sum::<f64>() / 3.0;
            let on_edge = settled.on_darker_edge;
            let smoothing = |v: u32| if on_edge[v as usize] { variance } else { 0.0 };
            let largest = CURVATURE_OFFSET_VOXELS * s.border.voxel;
            let surface = &mut s.surface;
            let unmoved = s
                .pool
                .install(|| offset_by_curvature(surface, smoothing, largest));
            s.index_surface();
            vec![unmoved, unsettled, unfaired]
        })
    }

    /// Puts the corners of the triangles in `pairs` (of `mesh`, the current surface as
    /// [`Self::mesh`] gave it) and [`UNFAIR_RINGS`] rings around them back where they were
    /// `before` (the curvature offset, settling or fairing); every vertex when `pairs` is
    /// empty.
    pub(super) fn unfair(&mut self, before: &[DVec3], mesh: &TriMesh, pairs: &[(u32, u32)]) {
        if pairs.is_empty() {
            self.surface.positions_mut().copy_from_slice(before);
        } else {
            let triangles = pairs.iter().flat_map(|&(a, b)| [a, b]);
            let corners = self.corner_slots(mesh, triangles);
            fairing::restore(&mut self.surface, before, corners, UNFAIR_RINGS);
        }
        self.index_surface();
    }

    /// The surface's slots of the corners of `triangles` of `mesh` (the current surface as
    /// [`Self::mesh`] gave it), repeated where triangles share a corner.
    fn corner_slots(&self, mesh: &TriMesh, triangles: impl Iterator<Item = u32>) -> Vec<u32> {
        // The mesh numbers the live slots densely, in slot order.
        let slots: Vec<u32> = self.surface.live_vertices().collect();
        triangles
            .flat_map(|t| mesh.triangles()[t as usize])
            .map(|v| slots[v as usize])
            .collect()
    }
}
