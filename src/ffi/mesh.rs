//! Meshes at the boundary: flat `double` xyz and `uint32_t` triangle arrays, handed out as
//! borrowed `BalloonMesh` views of the library's own `TriMesh` (no copy), or read from the
//! caller's arrays.

use glam::DVec3;

use super::boundary::{require, Failure};
use crate::error::Error;
use crate::mesh::TriMesh;

/// A borrowed view of a mesh owned by the library: valid until the next call that changes
/// its owner (the segmenter or the BalloonTriMesh), or until the owner is freed.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct BalloonMesh {
    /// x, y, z interleaved, world mm; 3 * point_count doubles.
    pub points: *const f64,
    pub point_count: usize,
    /// 3 point indices per triangle, counter-clockwise seen from outside (normals outward).
    pub triangles: *const u32,
    pub triangle_count: usize,
    /// One BalloonVertexState per point; NULL for kernel meshes.
    pub vertex_state: *const u8,
}

// A view points straight into a `TriMesh`: its points are `DVec3`s, three `f64`s in a row.
const _: () = assert!(
    std::mem::size_of::<DVec3>() == 3 * std::mem::size_of::<f64>()
        && std::mem::align_of::<DVec3>() == std::mem::align_of::<f64>()
);

/// A view of `mesh`, with `vertex_state` (one per point, or NULL), without a copy.
pub(crate) fn view(mesh: &TriMesh, vertex_state: *const u8) -> BalloonMesh {
    BalloonMesh {
        points: mesh.points().as_ptr().cast::<f64>(),
        point_count: mesh.points().len(),
        triangles: mesh.triangles().as_ptr().cast::<u32>(),
        triangle_count: mesh.triangles().len(),
        vertex_state,
    }
}

/// `count` items of `what` at `ptr`, three elements each; NULL is fine when `count` is 0.
///
/// # Safety
/// `ptr` must be NULL or point to `3 * count` readable `T`s.
pub(crate) unsafe fn triples<'a, T>(
    ptr: *const T,
    count: usize,
    what: &str,
) -> Result<&'a [T], Failure> {
    // SAFETY: forwarded from the caller.
    unsafe { items(ptr, count, 3, what) }
}

/// `count` items of `what` at `ptr`, `per_item` elements each; NULL is fine when `count` is 0.
///
/// # Safety
/// `ptr` must be NULL or point to `per_item * count` readable `T`s.
pub(crate) unsafe fn items<'a, T>(
    ptr: *const T,
    count: usize,
    per_item: usize,
    what: &str,
) -> Result<&'a [T], Failure> {
    if count == 0 {
        return Ok(&[]);
    }
    require(ptr, what)?;
    let len = count
        .checked_mul(per_item)
        .filter(|&n| {
            n.checked_mul(size_of::<T>())
                .is_some_and(|b| b <= isize::MAX as usize)
        })
        .ok_or_else(|| {
            Error::invalid_argument(format!(
                "{count} items of {what} overflow the address space"
            ))
        })?;
    if ptr as usize % align_of::<T>() != 0 {
        return Err(Error::invalid_argument(format!(
            "{what} ({ptr:p}) is not aligned to {} bytes",
            align_of::<T>()
        ))
        .into());
    }
    // SAFETY: non-NULL, aligned, and `len` elements by the caller's promise.
    Ok(unsafe { std::slice::from_raw_parts(ptr, len) })
}

/// The caller's mesh, copied and validated (indices in range, points finite).
///
/// # Safety
/// `points` must be NULL or hold `3 * point_count` doubles, `triangles` NULL or hold
/// `3 * triangle_count` indices.
pub(crate) unsafe fn mesh_from_c(
    points: *const f64,
    point_count: usize,
    triangles: *const u32,
    triangle_count: usize,
) -> Result<TriMesh, Failure> {
    // SAFETY: forwarded from the caller.
    let (p, t) = unsafe {
        (
            triples(points, point_count, "points")?,
            triples(triangles, triangle_count, "triangles")?,
        )
    };
    let points = p.chunks_exact(3).map(DVec3::from_slice).collect();
    let triangles = t.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    Ok(TriMesh::new(points, triangles)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ffi::status::BalloonStatus;

    #[test]
    fn meshes_cross_the_boundary_unchanged_and_bad_ones_are_named() {
        let cube = crate::mesh::test_shapes::cube(DVec3::ZERO, DVec3::ONE);
        let view = view(&cube, std::ptr::null());
        let back = unsafe {
            mesh_from_c(
                view.points,
                view.point_count,
                view.triangles,
                view.triangle_count,
            )
        };
        assert_eq!(back.unwrap(), cube);
        let null = unsafe { mesh_from_c(std::ptr::null(), 8, view.triangles, 12) }.unwrap_err();
        assert_eq!(null.status, BalloonStatus::BALLOON_NULL_POINTER);
        let short = unsafe { mesh_from_c(view.points, 7, view.triangles, 12) }.unwrap_err();
        assert_eq!(short.status, BalloonStatus::BALLOON_INVALID_MESH);
        let huge = unsafe { mesh_from_c(view.points, usize::MAX / 2, view.triangles, 12) };
        assert_eq!(
            huge.unwrap_err().status,
            BalloonStatus::BALLOON_INVALID_ARGUMENT
        );
        let empty = unsafe { mesh_from_c(std::ptr::null(), 0, std::ptr::null(), 0) };
        assert!(empty.unwrap().is_empty());
    }
}
