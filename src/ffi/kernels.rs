//! The geometry kernels on their own: marching cubes and error-bounded simplification into a
//! library-owned `BalloonTriMesh`, the mesh checks, and the self-intersection search, which
//! copies its pairs into the caller's array with the size-query protocol
//! (`BALLOON_BUFFER_TOO_SMALL` with the total).

use std::ffi::c_void;
use std::mem::size_of;

use super::boundary::{require, run, run_infallible, Failure};
use super::mesh::{mesh_from_c, view, BalloonMesh};
use super::params::check_struct_size;
use super::segmenter::{progress_from_c, BalloonProgressCallback};
use super::status::BalloonStatus;
use super::volume::{volume_from_c, BalloonVolume};
use crate::balloon::params::check_threads;
use crate::balloon::Phase;
use crate::marching_cubes::marching_cubes;
use crate::mesh::TriMesh;
use crate::mesh_checks;
use crate::self_intersection::{count_self_intersections, self_intersections};
use crate::simplification::{simplify_with_progress, Simplified};
use crate::thread_pool::ThreadPool;

/// In the vertex map of a simplified mesh (balloon_trimesh_vertex_map): an input point that no
/// triangle uses.
pub const BALLOON_NO_VERTEX: u32 = 0xFFFFFFFF;

// Written as a literal for cbindgen, which does not evaluate paths.
const _: () = assert!(BALLOON_NO_VERTEX == crate::simplification::NO_VERTEX);

/// A mesh made by a kernel (opaque), owned by the caller until balloon_trimesh_free.
pub struct BalloonTriMesh {
    mesh: TriMesh,
    /// For balloon_simplify's result, the output vertex of each input point; empty otherwise.
    vertex_map: Vec<u32>,
}

/// What balloon_mesh_check measures about a mesh.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BalloonMeshReport {
    /// The caller sets it to sizeof(BalloonMeshReport).
    pub struct_size: usize,
    /// Every edge has exactly two triangles (0/1).
    pub closed: u8,
    /// Edge- and vertex-manifold, no degenerate triangles (0/1).
    pub manifold: u8,
    /// The two triangles of every edge traverse it in opposite directions (0/1).
    pub oriented: u8,
    /// Closed, oriented and every component encloses a positive volume (0/1).
    pub outward: u8,
    /// Pairs of intersecting triangles (a degenerate triangle counts as a pair with itself),
    /// counted up to 16 per triangle plus 1,024: a count past that limit reads as the limit
    /// plus one (the search stops there; triangles piled into one place pair up
    /// quadratically).
    pub self_intersecting_pairs: usize,
    pub euler_characteristic: i64,
    /// -1 when the mesh is not a closed oriented manifold (the genus is then undefined).
    pub genus: i64,
    pub components: usize,
    pub area_mm2: f64,
    /// Enclosed signed volume, positive for outward normals.
    pub volume_mm3: f64,
}

/// The isosurface `value = level` of `volume` (normals towards increasing values, world mm),
/// computed on a pool of `threads` threads (0 = all cores; the mesh does not depend on it).
/// On success `*out` receives a mesh to release with balloon_trimesh_free.
///
/// # Safety
/// `volume` describes valid voxels (read during the call only); `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_marching_cubes(
    volume: *const BalloonVolume,
    level: f64,
    threads: u32,
    out: *mut *mut BalloonTriMesh,
) -> BalloonStatus {
    run(|| {
        require(out, "out")?;
        // SAFETY: by the caller's promise.
        let volume = unsafe { volume_from_c(volume)? };
        check_threads(threads as usize)?;
        let pool = ThreadPool::new(threads as usize)?;
        let mesh = pool.install(|| marching_cubes(&volume, level))?;
        let owned = Box::new(BalloonTriMesh {
            mesh,
            vertex_map: Vec::new(),
        });
        // SAFETY: non-NULL and writable.
        unsafe { out.write(Box::into_raw(owned)) };
        Ok(())
    })
}

/// A view of a kernel mesh (vertex_state is NULL), valid until balloon_trimesh_free.
///
/// # Safety
/// `m` is a live BalloonTriMesh; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_trimesh_view(
    m: *const BalloonTriMesh,
    out: *mut BalloonMesh,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let m = unsafe { m.as_ref() }.ok_or_else(|| Failure::null("m"))?;
        require(out, "out")?;
        // SAFETY: non-NULL and writable.
        unsafe { out.write(view(&m.mesh, std::ptr::null())) };
        Ok(())
    })
}

/// The caller's closed mesh (points: 3 doubles each, triangles: 3 indices each, read during the
/// call only) reduced to as few triangles as edge collapses can reach while the two-sided
/// Hausdorff distance to it stays at most `max_error_mm`: every point of the result lies within
/// `max_error_mm` of the input surface and every point of the input surface within
/// `max_error_mm` of the result (proved for every point, not sampled). The result stays closed,
/// 2-manifold, oriented as the input (outward stays outward), free of self-intersections, with
/// the same genus and number of components; no triangle it makes has an angle under 10 degrees.
/// Deterministic; runs on the calling thread. balloon_simplify_with_progress reports its
/// progress and may be cancelled.
///
/// Errors: BALLOON_NULL_POINTER for a NULL `out`, or NULL arrays with non-zero counts;
/// BALLOON_INVALID_ARGUMENT when `max_error_mm` is not a positive finite distance;
/// BALLOON_INVALID_MESH for a malformed mesh (index out of range, non-finite point) or one the
/// bound cannot be kept on: empty, open, non-manifold, inconsistently oriented, or with
/// self-intersecting or degenerate triangles (the message says which). On success `*out`
/// receives a mesh to view with balloon_trimesh_view (vertex_state NULL) and
/// balloon_trimesh_vertex_map, and to release with balloon_trimesh_free; on failure `*out` is
/// not written.
///
/// # Safety
/// The arrays hold the counts given; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_simplify(
    points: *const f64,
    point_count: usize,
    triangles: *const u32,
    triangle_count: usize,
    max_error_mm: f64,
    out: *mut *mut BalloonTriMesh,
) -> BalloonStatus {
    // SAFETY: by the caller's promise, which is balloon_simplify_with_progress's without a
    // callback.
    unsafe {
        balloon_simplify_with_progress(
            points,
            point_count,
            triangles,
            triangle_count,
            max_error_mm,
            None,
            std::ptr::null_mut(),
            out,
        )
    }
}

/// balloon_simplify, calling `progress` (NULL = none) with `user_data` on this thread now and
/// then with the fraction done (0 to 1, never decreasing; an estimate, as the number of
/// collapses is not known in advance) and the phase "simplification". Returning non-zero
/// cancels: BALLOON_CANCELLED, and `*out` is not written. The result does not depend on the
/// callback.
///
/// # Safety
/// As balloon_simplify; `progress` and `user_data` are used during this call only.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn balloon_simplify_with_progress(
    points: *const f64,
    point_count: usize,
    triangles: *const u32,
    triangle_count: usize,
    max_error_mm: f64,
    progress: BalloonProgressCallback,
    user_data: *mut c_void,
    out: *mut *mut BalloonTriMesh,
) -> BalloonStatus {
    run(|| {
        require(out, "out")?;
        // SAFETY: by the caller's promise.
        let mesh = unsafe { mesh_from_c(points, point_count, triangles, triangle_count)? };
        // SAFETY: `progress` and `user_data` are used during this call only.
        let mut progress = unsafe { progress_from_c(progress, user_data) };
        let Simplified { mesh, vertex_map } = simplify_with_progress(&mesh, max_error_mm, |f| {
            progress
                .as_mut()
                .map_or(true, |p| p(f, Phase::Simplification))
        })?;
        let owned = Box::new(BalloonTriMesh { mesh, vertex_map });
        // SAFETY: non-NULL and writable.
        unsafe { out.write(Box::into_raw(owned)) };
        Ok(())
    })
}

/// Where the input points of balloon_simplify went: `*map_out` receives `*count_out` indices,
/// one per input point, each the vertex of `m` that point was merged into, or
/// BALLOON_NO_VERTEX for a point no input triangle used; for carrying per-point data (labels,
/// states, scalars) over to the simplified mesh. A mesh made by another kernel has no map
/// (NULL and 0). The array belongs to `m` and stays valid until balloon_trimesh_free.
///
/// # Safety
/// `m` is a live BalloonTriMesh; `map_out` and `count_out` are writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_trimesh_vertex_map(
    m: *const BalloonTriMesh,
    map_out: *mut *const u32,
    count_out: *mut usize,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let m = unsafe { m.as_ref() }.ok_or_else(|| Failure::null("m"))?;
        require(map_out, "map_out")?;
        require(count_out, "count_out")?;
        let map = match m.vertex_map.as_slice() {
            [] => std::ptr::null(),
            map => map.as_ptr(),
        };
        // SAFETY: both non-NULL and writable.
        unsafe {
            map_out.write(map);
            count_out.write(m.vertex_map.len());
        }
        Ok(())
    })
}

/// Releases a kernel mesh; NULL is fine.
///
/// # Safety
/// `m` is NULL or a live BalloonTriMesh, not used again afterwards.
#[no_mangle]
pub unsafe extern "C" fn balloon_trimesh_free(m: *mut BalloonTriMesh) {
    run_infallible((), || {
        if !m.is_null() {
            // SAFETY: made by Box::into_raw, released once by the caller's promise.
            drop(unsafe { Box::from_raw(m) });
        }
    })
}

/// Checks a mesh (points: 3 doubles each, triangles: 3 indices each; NULL only with a count
/// of 0). The caller sets `out->struct_size` to sizeof(BalloonMeshReport).
///
/// # Safety
/// The arrays hold the counts given; `out` is a writable BalloonMeshReport.
#[no_mangle]
pub unsafe extern "C" fn balloon_mesh_check(
    points: *const f64,
    point_count: usize,
    triangles: *const u32,
    triangle_count: usize,
    out: *mut BalloonMeshReport,
) -> BalloonStatus {
    run(|| {
        require(out, "out")?;
        // SAFETY: non-NULL; the leading size is read before the rest is trusted.
        unsafe { check_struct_size(out, "BalloonMeshReport")? };
        // SAFETY: by the caller's promise.
        let mesh = unsafe { mesh_from_c(points, point_count, triangles, triangle_count)? };
        let r = mesh_checks::check(&mesh);
        let report = BalloonMeshReport {
            struct_size: size_of::<BalloonMeshReport>(),
            closed: r.closed().into(),
            manifold: r.manifold().into(),
            oriented: r.consistently_oriented().into(),
            outward: r.outward().into(),
            self_intersecting_pairs: count_self_intersections(&mesh)?.saturated(),
            euler_characteristic: r.euler_characteristic,
            genus: r.genus().unwrap_or(-1),
            components: r.components,
            area_mm2: r.area,
            volume_mm3: r.signed_volume,
        };
        // SAFETY: writable, and of this library's size.
        unsafe { out.write_unaligned(report) };
        Ok(())
    })
}

/// The pairs of intersecting triangles, 2 indices per pair (t0 < t1, or t0 == t1 for a
/// degenerate triangle), sorted, copied into `pairs_out` (room for `pairs_capacity` pairs).
/// `*pair_count_out` receives the number of pairs both on success and with
/// BALLOON_BUFFER_TOO_SMALL (then nothing is copied): call first with pairs_out NULL and
/// capacity 0 to size the buffer. A mesh with more than 16 pairs per triangle plus 1,024 is
/// BALLOON_INVALID_MESH, and `*pair_count_out` is left alone: the search stops there, since
/// triangles piled into one place pair up quadratically (`balloon_mesh_check` counts up to
/// that limit).
///
/// # Safety
/// The mesh arrays hold the counts given; `pairs_out` is NULL or has room for
/// `2 * pairs_capacity` indices; `pair_count_out` is writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_self_intersections(
    points: *const f64,
    point_count: usize,
    triangles: *const u32,
    triangle_count: usize,
    pairs_out: *mut u32,
    pairs_capacity: usize,
    pair_count_out: *mut usize,
) -> BalloonStatus {
    run(|| {
        require(pair_count_out, "pair_count_out")?;
        if pairs_out.is_null() && pairs_capacity > 0 {
            return Err(Failure::null("pairs_out (with a non-zero pairs_capacity)"));
        }
        // SAFETY: by the caller's promise.
        let mesh = unsafe { mesh_from_c(points, point_count, triangles, triangle_count)? };
        let pairs = self_intersections(&mesh)?;
        // SAFETY: non-NULL and writable; the count is written with BUFFER_TOO_SMALL too.
        unsafe { pair_count_out.write(pairs.len()) };
        if pairs.len() > pairs_capacity {
            return Err(Failure::new(
                BalloonStatus::BALLOON_BUFFER_TOO_SMALL,
                format!(
                    "the mesh has {} self-intersecting pairs but pairs_out has room for {}; \
                     pass a buffer of 2 * {} uint32_t",
                    pairs.len(),
                    pairs_capacity,
                    pairs.len()
                ),
            ));
        }
        if !pairs.is_empty() {
            // SAFETY: non-NULL (capacity ≥ pairs > 0) with room for 2 * capacity indices.
            let dst = unsafe { std::slice::from_raw_parts_mut(pairs_out, 2 * pairs.len()) };
            for (d, (a, b)) in dst.chunks_exact_mut(2).zip(pairs) {
                d.copy_from_slice(&[a, b]);
            }
        }
        Ok(())
    })
}
