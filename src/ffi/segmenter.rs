//! The opaque `BalloonSegmenter` handle: a [`Segmenter`] over the caller's voxels plus the
//! mesh that `balloon_mesh` hands out as a view into it. Every call that changes the balloon
//! drops that mesh — also a failed or cancelled one, after which the balloon is still the
//! consistent mesh of the last completed step — and the next `balloon_mesh` makes it once, so
//! that stepping costs no copy of the mesh and a `const` handle gives out pointers that stay
//! valid until the next mutating call. `balloon_segment` keeps the mesh `segment` returned.

use std::cell::OnceCell;
use std::ffi::{c_char, c_int, c_void, CString};
use std::mem::size_of;

use glam::DVec3;

use super::boundary::{require, run, run_infallible, Failure};
use super::mesh::{view, BalloonMesh};
use super::params::{check_struct_size, params_from_c, BalloonParams};
use super::status::BalloonStatus;
use super::volume::{volume_from_c, BalloonVolume};
use crate::balloon::{Phase, ProgressCallback, SegmentationStats, Segmenter, VertexState};
use crate::error::Result;
use crate::mesh::TriMesh;

/// The state of a vertex of the balloon, as in `BalloonMesh::vertex_state`.
#[repr(C)]
#[allow(non_camel_case_types)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BalloonVertexState {
    /// Still moved by the forces.
    BALLOON_VERTEX_MOVING = 0,
    /// Reached the structure's border.
    BALLOON_VERTEX_FROZEN_AT_BORDER = 1,
    /// Belongs to a self-intersecting triangle (until the next re-parametrisation).
    BALLOON_VERTEX_FROZEN_BY_SELF_INTERSECTION = 2,
}

impl From<VertexState> for BalloonVertexState {
    fn from(state: VertexState) -> Self {
        match state {
            VertexState::Moving => BalloonVertexState::BALLOON_VERTEX_MOVING,
            VertexState::FrozenAtBorder => BalloonVertexState::BALLOON_VERTEX_FROZEN_AT_BORDER,
            VertexState::FrozenBySelfIntersection => {
                BalloonVertexState::BALLOON_VERTEX_FROZEN_BY_SELF_INTERSECTION
            }
        }
    }
}

/// What a segmentation did, besides the mesh.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BalloonStats {
    /// The caller sets it to sizeof(BalloonStats) before calling balloon_stats.
    pub struct_size: usize,
    /// The reference intensity and tolerance in use (given or estimated).
    pub reference_intensity: f64,
    pub tolerance: f64,
    pub edge_length_mm: f64,
    /// Steps of deformation so far (inflation and refinement).
    pub iterations: u32,
    pub reparametrizations: u32,
    pub seconds_inflation: f64,
    pub seconds_self_intersection: f64,
    pub seconds_reparametrization: f64,
    pub seconds_refinement: f64,
    pub seconds_validation: f64,
    /// Only with simplify_error_mm set.
    pub seconds_simplification: f64,
    pub seconds_total: f64,
}

impl From<&SegmentationStats> for BalloonStats {
    fn from(stats: &SegmentationStats) -> Self {
        let seconds = stats.seconds;
        BalloonStats {
            struct_size: size_of::<BalloonStats>(),
            reference_intensity: stats.reference_intensity,
            tolerance: stats.tolerance,
            edge_length_mm: stats.edge_length,
            iterations: stats.iterations,
            reparametrizations: stats.reparametrizations,
            seconds_inflation: seconds.inflation,
            seconds_self_intersection: seconds.self_intersection,
            seconds_reparametrization: seconds.reparametrization,
            seconds_refinement: seconds.refinement,
            seconds_validation: seconds.validation,
            seconds_simplification: seconds.simplification,
            seconds_total: seconds.total(),
        }
    }
}

/// Returns non-zero to cancel the running call, which then returns BALLOON_CANCELLED. It is
/// called only from the thread that called the library, with the fraction done (0 to 1) and
/// the phase's name ("inflation", "self-intersection", "reparametrization", "refinement",
/// "validation", and "simplification" with simplify_error_mm set, for the second half of the
/// run), a string valid during the call only. It must not unwind (throw) into the
/// library, nor call the library with the same handle.
pub type BalloonProgressCallback = Option<
    unsafe extern "C" fn(fraction: f64, phase: *const c_char, user_data: *mut c_void) -> c_int,
>;

/// The library's progress callback calling `cb` (None when `cb` is NULL): `true` (go on)
/// while `cb` returns 0.
///
/// # Safety
/// `cb` and `user_data` must stay valid for as long as the callback is used.
pub(super) unsafe fn progress_from_c(
    cb: BalloonProgressCallback,
    user_data: *mut c_void,
) -> Option<ProgressCallback<'static>> {
    cb.map(|cb| {
        Box::new(move |fraction: f64, phase: Phase| {
            let name = CString::new(phase.name()).unwrap_or_default();
            // SAFETY: by the promise of progress_from_c's caller.
            unsafe { cb(fraction, name.as_ptr(), user_data) == 0 }
        }) as ProgressCallback<'static>
    })
}

/// A balloon in a volume (opaque). Created by balloon_init, released by balloon_free. Used by
/// one thread at a time; distinct handles are independent.
pub struct BalloonSegmenter {
    // Borrows the caller's voxels for 'static: balloon_init's contract keeps them alive until
    // balloon_free drops this.
    segmenter: Segmenter<'static, 'static>,
    /// The balloon as balloon_mesh hands it out; empty after a change until asked for.
    shown: OnceCell<ShownMesh>,
}

/// A mesh and its vertex states in the layout of the C views.
pub(super) struct ShownMesh {
    pub mesh: TriMesh,
    pub states: Vec<u8>,
}

impl ShownMesh {
    /// A view of the mesh with its vertex states, valid while `self` lives unchanged.
    pub(super) fn view(&self) -> BalloonMesh {
        view(&self.mesh, self.states.as_ptr())
    }

    pub(super) fn new((mesh, states): (TriMesh, Vec<VertexState>)) -> Self {
        let states = states
            .into_iter()
            .map(|s| BalloonVertexState::from(s) as u8)
            .collect();
        ShownMesh { mesh, states }
    }
}

impl BalloonSegmenter {
    fn new(segmenter: Segmenter<'static, 'static>) -> Self {
        BalloonSegmenter {
            segmenter,
            shown: OnceCell::new(),
        }
    }

    /// Runs a call that changes the balloon; the shown mesh is made again on demand, whatever
    /// the outcome.
    fn mutate<T>(
        &mut self,
        call: impl FnOnce(&mut Segmenter<'static, 'static>) -> Result<T>,
    ) -> Result<T> {
        self.shown = OnceCell::new();
        call(&mut self.segmenter)
    }

    fn shown(&self) -> &ShownMesh {
        self.shown
            .get_or_init(|| ShownMesh::new(self.segmenter.mesh()))
    }
}

/// # Safety
/// `ptr` must be NULL or point to a live handle not used elsewhere during the call.
unsafe fn handle<'a>(
    ptr: *mut BalloonSegmenter,
) -> std::result::Result<&'a mut BalloonSegmenter, Failure> {
    // SAFETY: by the caller's promise.
    unsafe { ptr.as_mut() }.ok_or_else(|| Failure::null("s"))
}

/// # Safety
/// `seed` must be NULL or point to 3 readable doubles.
unsafe fn seed_from_c(seed: *const f64) -> std::result::Result<DVec3, Failure> {
    require(seed, "seed_world")?;
    // SAFETY: 3 doubles by the caller's promise.
    Ok(DVec3::from_array(unsafe {
        seed.cast::<[f64; 3]>().read_unaligned()
    }))
}

/// Starts a balloon of about one voxel's radius at `seed_world` (x, y, z world mm).
/// `params` may be NULL for the defaults. On success `*out` receives a new handle to release
/// with balloon_free.
///
/// # Safety
/// The voxels `volume` describes are borrowed, not copied: they must stay valid and unchanged
/// until balloon_free. `seed_world` points to 3 doubles; `params` is NULL or filled by
/// balloon_params_default; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_init(
    volume: *const BalloonVolume,
    params: *const BalloonParams,
    seed_world: *const f64,
    out: *mut *mut BalloonSegmenter,
) -> BalloonStatus {
    run(|| {
        require(out, "out")?;
        // SAFETY: by the caller's promises above.
        let (volume, params, seed) = unsafe {
            (
                volume_from_c(volume)?,
                params_from_c(params)?,
                seed_from_c(seed_world)?,
            )
        };
        let handle = BalloonSegmenter::new(Segmenter::new(volume, params, seed)?);
        // SAFETY: non-NULL and writable.
        unsafe { out.write(Box::into_raw(Box::new(handle))) };
        Ok(())
    })
}

/// Adds a seed sphere at `seed_world` (world mm), for a part the first seed does not reach.
///
/// # Safety
/// `s` is a live handle; `seed_world` points to 3 doubles.
#[no_mangle]
pub unsafe extern "C" fn balloon_add_seed(
    s: *mut BalloonSegmenter,
    seed_world: *const f64,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promises.
        let (h, seed) = unsafe { (handle(s)?, seed_from_c(seed_world)?) };
        Ok(h.mutate(|segmenter| segmenter.add_seed(seed))?)
    })
}

/// Up to `iterations` steps of inflation (stops early at equilibrium). `active_vertices_out`
/// may be NULL; otherwise it receives the number of vertices still moving.
///
/// # Safety
/// `s` is a live handle; `active_vertices_out` is NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_step(
    s: *mut BalloonSegmenter,
    iterations: u32,
    active_vertices_out: *mut u32,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let h = unsafe { handle(s)? };
        let moving = h.mutate(|segmenter| segmenter.step(iterations))?;
        if !active_vertices_out.is_null() {
            // SAFETY: non-NULL and writable. Vertex ids are u32, so the count fits.
            unsafe { active_vertices_out.write(u32::try_from(moving).unwrap_or(u32::MAX)) };
        }
        Ok(())
    })
}

/// Freezes the vertices of every self-intersecting triangle (state
/// `BALLOON_VERTEX_FROZEN_BY_SELF_INTERSECTION`) and the rest of each moving front that touched
/// the balloon (`BALLOON_VERTEX_FROZEN_AT_BORDER`, until `balloon_reparametrize` merges the
/// lobes); `*frozen_vertices_out` receives how many were newly frozen.
///
/// # Safety
/// `s` is a live handle; `frozen_vertices_out` is writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_freeze_self_intersections(
    s: *mut BalloonSegmenter,
    frozen_vertices_out: *mut usize,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let h = unsafe { handle(s)? };
        require(frozen_vertices_out, "frozen_vertices_out")?;
        let frozen = h.mutate(|segmenter| segmenter.freeze_self_intersections())?;
        // SAFETY: non-NULL and writable.
        unsafe { frozen_vertices_out.write(frozen) };
        Ok(())
    })
}

/// Replaces the balloon by the zero isosurface of its signed distance map, without its
/// self-intersecting triangles (the method's re-parametrisation). Its vertices inside the
/// intensity window move again; those outside it are frozen at the border.
///
/// # Safety
/// `s` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn balloon_reparametrize(s: *mut BalloonSegmenter) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let h = unsafe { handle(s)? };
        Ok(h.mutate(|segmenter| segmenter.reparametrize())?)
    })
}

/// The whole method to completion; balloon_mesh then gives the closed, 2-manifold, outward
/// surface without self-intersections.
///
/// Memory (the voxels are borrowed): about 10 bytes per voxel of a grid laid over the
/// balloon's bounding box at the volume's finest spacing, plus the balloon, which max_vertices
/// caps. A buffer
/// that cannot be allocated gives BALLOON_OUT_OF_MEMORY; the handle keeps its last completed
/// step and stays usable.
///
/// # Safety
/// `s` is a live handle.
#[no_mangle]
pub unsafe extern "C" fn balloon_segment(s: *mut BalloonSegmenter) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let h = unsafe { handle(s)? };
        let result = h.mutate(|segmenter| segmenter.segment())?;
        h.shown = OnceCell::from(ShownMesh::new(result));
        Ok(())
    })
}

/// A view of the current balloon (also after a failed or cancelled call: the mesh of the
/// last completed step). The arrays belong to the handle and stay valid until the next call
/// that changes it, or balloon_free.
///
/// # Safety
/// `s` is a live handle; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_mesh(
    s: *const BalloonSegmenter,
    out: *mut BalloonMesh,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let h = unsafe { s.as_ref() }.ok_or_else(|| Failure::null("s"))?;
        require(out, "out")?;
        // SAFETY: non-NULL and writable.
        unsafe { out.write(h.shown().view()) };
        Ok(())
    })
}

/// Statistics of the run so far. The caller sets `out->struct_size` to sizeof(BalloonStats).
///
/// # Safety
/// `s` is a live handle; `out` is a writable BalloonStats.
#[no_mangle]
pub unsafe extern "C" fn balloon_stats(
    s: *const BalloonSegmenter,
    out: *mut BalloonStats,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let h = unsafe { s.as_ref() }.ok_or_else(|| Failure::null("s"))?;
        require(out, "out")?;
        // SAFETY: non-NULL; the leading size is read before the rest is trusted.
        unsafe { check_struct_size(out, "BalloonStats")? };
        let c = BalloonStats::from(h.segmenter.stats());
        // SAFETY: writable, and of this library's size.
        unsafe { out.write_unaligned(c) };
        Ok(())
    })
}

/// Reports progress to `cb` (NULL = none) with `user_data`, during the calls that follow on
/// this handle; `cb` returning non-zero cancels the running call (BALLOON_CANCELLED), leaving
/// the handle usable.
///
/// # Safety
/// `s` is a live handle; `cb` and `user_data` stay valid while they are set.
#[no_mangle]
pub unsafe extern "C" fn balloon_set_progress_callback(
    s: *mut BalloonSegmenter,
    cb: BalloonProgressCallback,
    user_data: *mut c_void,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let h = unsafe { handle(s)? };
        // SAFETY: the caller keeps `cb` and `user_data` valid while they are set.
        h.segmenter
            .set_progress(unsafe { progress_from_c(cb, user_data) });
        Ok(())
    })
}

/// Releases a handle made by balloon_init; NULL is fine. Afterwards the caller's voxels are
/// no longer used.
///
/// # Safety
/// `s` is NULL or a live handle, not used again afterwards.
#[no_mangle]
pub unsafe extern "C" fn balloon_free(s: *mut BalloonSegmenter) {
    run_infallible((), || {
        if !s.is_null() {
            // SAFETY: made by Box::into_raw in balloon_init, released once by the caller's promise.
            drop(unsafe { Box::from_raw(s) });
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::{self, PhantomOptions, Shape};
    use crate::volume::VoxelBuffer;

    unsafe extern "C" fn cancel_third(_: f64, _: *const c_char, calls: *mut c_void) -> c_int {
        let calls = unsafe { &mut *calls.cast::<c_int>() };
        *calls += 1;
        c_int::from(*calls == 3)
    }

    fn flat(view: &BalloonMesh) -> (Vec<f64>, Vec<u32>, Vec<u8>) {
        unsafe {
            (
                std::slice::from_raw_parts(view.points, 3 * view.point_count).to_vec(),
                std::slice::from_raw_parts(view.triangles, 3 * view.triangle_count).to_vec(),
                std::slice::from_raw_parts(view.vertex_state, view.point_count).to_vec(),
            )
        }
    }

    #[test]
    fn a_cancelled_handle_keeps_a_valid_mesh_and_finishes_like_the_safe_api() {
        let p = phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap();
        let VoxelBuffer::F32(voxels) = p.image.buffer() else {
            panic!("phantoms are float32")
        };
        let [ni, nj, _] = p.image.dims();
        let g = p.image.geometry();
        let volume = BalloonVolume {
            data: voxels.as_ptr().cast(),
            scalar_type: 6,
            dims: p.image.dims(),
            strides: [1, ni as isize, (ni * nj) as isize],
            spacing: g.spacing(),
            origin: g.origin(),
            direction: g.direction(),
        };
        let seed = p.seed_world().to_array();
        let mut s = std::ptr::null_mut();
        let mut view = std::mem::MaybeUninit::<BalloonMesh>::uninit();
        let mut calls: c_int = 0;
        unsafe {
            assert_eq!(
                balloon_init(&volume, std::ptr::null(), seed.as_ptr(), &mut s),
                BalloonStatus::BALLOON_OK
            );
            let calls_ptr = (&mut calls as *mut c_int).cast();
            balloon_set_progress_callback(s, Some(cancel_third), calls_ptr);
            assert_eq!(balloon_segment(s), BalloonStatus::BALLOON_CANCELLED);
            assert_eq!(calls, 3);
            assert_eq!(
                balloon_mesh(s, view.as_mut_ptr()),
                BalloonStatus::BALLOON_OK
            );
            let (points, triangles, _) = flat(&view.assume_init());
            let cancelled = TriMesh::new(
                points.chunks_exact(3).map(DVec3::from_slice).collect(),
                triangles
                    .chunks_exact(3)
                    .map(|t| [t[0], t[1], t[2]])
                    .collect(),
            )
            .unwrap();
            assert!(crate::mesh_checks::check(&cancelled).is_valid_closed_surface());

            balloon_set_progress_callback(s, None, std::ptr::null_mut());
            assert_eq!(balloon_segment(s), BalloonStatus::BALLOON_OK);
            assert_eq!(
                balloon_mesh(s, view.as_mut_ptr()),
                BalloonStatus::BALLOON_OK
            );
        }
        let from_c = flat(unsafe { &view.assume_init() });
        unsafe { balloon_free(s) };

        // The safe API, cancelled at the same point and resumed, gives the same mesh.
        let mut safe = Segmenter::new(
            p.image.view(),
            crate::balloon::BalloonParams::default(),
            p.seed_world(),
        )
        .unwrap();
        let mut calls = 0;
        safe.set_progress(Some(Box::new(move |_, _| {
            calls += 1;
            calls != 3
        })));
        assert!(safe.segment().is_err());
        safe.set_progress(None);
        let (mesh, states) = safe.segment().unwrap();
        let points: Vec<f64> = mesh.points().iter().flat_map(|p| p.to_array()).collect();
        let triangles: Vec<u32> = mesh.triangles().iter().flatten().copied().collect();
        assert_eq!(from_c.0, points);
        assert_eq!(from_c.1, triangles);
        assert_eq!(
            from_c.2,
            states.iter().map(|&s| s as u8).collect::<Vec<_>>()
        );
    }
}
