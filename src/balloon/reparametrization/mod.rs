//! Step 3 of the paper (section 3), re-parametrisation: the balloon without its
//! self-intersecting triangles becomes a signed distance map whose zero isosurface
//! (`isosurface`) is the new surface, with the topology the contacts implied; its vertices
//! inside the window move on (refinement, step 4: `inflation` again).

pub(in crate::balloon) mod isosurface;

use glam::DVec3;

use crate::balloon::progress::Phase;
use crate::balloon::segmenter::Segmenter;
use crate::balloon::surface::{Surface, VertexState};
use crate::error::Result;
use isosurface::{inherited_states, reparametrize, Keep};

/// Whether the balloon is refined after a re-parametrisation, or the new surface is final.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum AfterReparametrization {
    Refinement,
    Nothing,
}

impl Segmenter<'_, '_> {
    /// Replaces the balloon by the zero isosurface of its signed distance map, without the
    /// self-intersecting triangles (paper, section 3). Its vertices inside the intensity window
    /// move again afterwards; those outside it stay (`freeze_outside_window`).
    pub fn reparametrize(&mut self) -> Result<()> {
        self.replace_by_isosurface(AfterReparametrization::Refinement)?;
        self.remesh()
    }

    /// [`Self::reparametrize`] without the remeshing, whose splits and collapses could make
    /// new contacts: the marching-cubes surface as it is. Before a refinement the vertices
    /// inside the window move; a final surface keeps the states of the balloon it replaces
    /// (`inherited_states`), so that what was still moving says so.
    pub(super) fn replace_by_isosurface(&mut self, next: AfterReparametrization) -> Result<()> {
        self.timed(Phase::Reparametrization, |s| {
            s.report(0.75, Phase::Reparametrization)?;
            let (mesh, states) = s.mesh();
            let geometry = *s.volume.geometry();
            let (image, border) = (&s.image, s.border);
            let free_depth = |p| image.free_depth(p);
            let keep = Keep {
                seeds: &s.seeds,
                passable: &|p| border.passable(image, p),
                free_depth: image.is_constrained().then_some(&free_depth as _),
            };
            let repaired = s
                .pool
                .install(|| reparametrize(&mesh, &states, &geometry, &keep))?;
            let mut surface = Surface::from_mesh(&repaired)?;
            match next {
                AfterReparametrization::Nothing => {
                    let reach = 2.0 * geometry.max_spacing();
                    let inherited = inherited_states(&mesh, &states, &repaired, reach);
                    surface.states_mut().copy_from_slice(&inherited);
                }
                AfterReparametrization::Refinement => s.freeze_outside_window(&mut surface),
            }
            s.replace_surface(surface);
            s.stats.reparametrizations += 1;
            Ok(())
        })
    }

    /// Freezes the vertices of a new surface where the balloon may not go (`border`), or where
    /// a vertex coming from a voxel inside would have stopped at a local step
    /// (`Border::step_ahead`): the balloon stopped there at muscle or a thin wall inside the
    /// window, and released, the new surface would walk into it. The others move on to the
    /// border. Where two lumens meet across a saddle below the border (the aorta's renal
    /// arteries), the merged surface bridges the saddle: pulled in, the bridge deflated from
    /// both sides until they passed through each other, and the same contact came back after
    /// every re-parametrisation.
    pub(super) fn freeze_outside_window(&self, surface: &mut Surface) {
        let normals = surface.vertex_normals();
        let (positions, states) = surface.positions_and_states_mut();
        for ((&p, n), state) in positions.iter().zip(normals).zip(states) {
            if !self.may_move_on(p, n) {
                *state = VertexState::FrozenAtBorder;
            }
        }
    }

    /// Lets the vertices frozen at the border move on where they may (`may_move_on`): after
    /// another object gave up a structure it had entered, the border it kept this balloon at
    /// is gone. Returns how many it let go.
    pub(in crate::balloon) fn release_frozen(&mut self) -> usize {
        let normals = self.surface.vertex_normals();
        let released: Vec<u32> = self
            .surface
            .live_vertices()
            .filter(|&v| {
                self.surface.states()[v as usize] == VertexState::FrozenAtBorder
                    && self.may_move_on(self.surface.positions()[v as usize], normals[v as usize])
            })
            .collect();
        for &v in &released {
            self.surface.states_mut()[v as usize] = VertexState::Moving;
        }
        released.len()
    }

    /// Whether a vertex of a new surface at `p` with outward normal `n` may move on: where the
    /// balloon may go, and not past a local step that a vertex coming from a voxel inside
    /// would have stopped at.
    pub(super) fn may_move_on(&self, p: DVec3, n: DVec3) -> bool {
        self.border.passable(&self.image, p)
            && self
                .border
                .step_ahead(&self.image, p - self.border.voxel * n, p)
                .is_none()
    }
}
