//! The C ABI of balloonseg (`include/balloonseg.h`, generated from this module by cbindgen;
//! docs/interfaces.md, "C API"), a thin layer over the safe API modelled on rustls-ffi and
//! libimagequant.
//!
//! Conventions, for every function:
//! - **Status.** Every fallible function returns a [`BalloonStatus`] (`BALLOON_OK` = 0) and
//!   writes its outputs only on success. The one exception: `balloon_self_intersections`
//!   writes the pair count with `BALLOON_BUFFER_TOO_SMALL` too, so callers can size their
//!   buffer. The values never change meaning and are never reused.
//! - **Messages.** A failure's message (what is wrong and what to change) is kept per thread
//!   until the next failure on that thread; `balloon_last_error_message` copies it
//!   snprintf-style. `balloon_status_string` describes a status statically.
//! - **Panics** never cross the boundary: every body runs in `boundary::run`, which turns a panic
//!   into `BALLOON_PANIC`. After it, only `balloon_free` is safe on the handle.
//! - **Ownership and lifetimes.** `BalloonSegmenter`, `BalloonTriMesh` and `BalloonObjects` are
//!   opaque, made by `balloon_init` / `balloon_marching_cubes` or `balloon_simplify` /
//!   `balloon_segment_objects`,
//!   released once by `balloon_free` / `balloon_trimesh_free` / `balloon_objects_free` (all
//!   accept NULL); never by `free()`. The voxels of a
//!   `BalloonVolume` are borrowed, not copied: until `balloon_free` for a segmenter, for the
//!   duration of the call for a kernel or `balloon_segment_objects`. `BalloonMesh` views point into library memory and
//!   stay valid until the next call that changes their owner, or until it is freed. Mesh
//!   arrays given to kernels are read during the call only.
//! - **Layouts.** Structs the caller fills or receives start with `struct_size`, checked
//!   against this library's size (`BALLOON_PARAMS_SIZE_MISMATCH`) before anything else is read
//!   or written.
//! - **Threads.** A handle is used by one thread at a time; distinct handles are independent
//!   and may run concurrently. Each segmenter (and each marching-cubes call) computes on its
//!   own pool of the requested size, never the caller's; the mesh checks use the library's
//!   global pool. The result does not depend on the number of threads.
//! - **Progress.** The callback runs only on the thread that called the library; it returns
//!   non-zero to cancel, and the call then returns `BALLOON_CANCELLED` with the handle still
//!   usable: `balloon_mesh` gives the balloon of the last completed step.

mod boundary;
mod kernels;
mod mesh;
mod objects;
mod param_info;
mod params;
mod segmenter;
mod status;
mod version;
mod volume;

pub use boundary::balloon_last_error_message;
pub use kernels::{
    balloon_marching_cubes, balloon_mesh_check, balloon_self_intersections, balloon_simplify,
    balloon_simplify_with_progress, balloon_trimesh_free, balloon_trimesh_vertex_map,
    balloon_trimesh_view, BalloonMeshReport, BalloonTriMesh, BALLOON_NO_VERTEX,
};
pub use mesh::BalloonMesh;
pub use objects::{
    balloon_objects_count, balloon_objects_free, balloon_objects_label, balloon_objects_mesh,
    balloon_objects_stats, balloon_segment_objects, BalloonObjectSeeds, BalloonObjects,
};
pub use param_info::{
    balloon_param_count, balloon_param_info, balloon_params_get, balloon_params_set,
    BalloonParamInfo, BalloonParamKind,
};
pub use params::{balloon_params_default, BalloonParams};
pub use segmenter::{
    balloon_add_seed, balloon_free, balloon_freeze_self_intersections, balloon_init, balloon_mesh,
    balloon_reparametrize, balloon_segment, balloon_set_progress_callback, balloon_stats,
    balloon_step, BalloonProgressCallback, BalloonSegmenter, BalloonStats, BalloonVertexState,
};
pub use status::{balloon_status_string, BalloonStatus};
pub use version::{
    balloon_version, BALLOON_VERSION_MAJOR, BALLOON_VERSION_MINOR, BALLOON_VERSION_PATCH,
};
pub use volume::{BalloonScalarType, BalloonVolume};
