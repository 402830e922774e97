//! Several objects at once (docs/interfaces.md, "Several objects"): labelled seeds, stop seeds
//! and a region of interest in, one call to [`segment_objects`], and the objects out in an
//! opaque `BalloonObjects` that hands out each object's label, mesh view (the same
//! `BalloonMesh` as `balloon_mesh`, vertex states included) and statistics. Only pointers and
//! sizes are checked here; labels, seed voxels and the region are the safe API's to check.

use std::ffi::c_void;

use glam::DVec3;

use super::boundary::{require, run, run_infallible, Failure};
use super::mesh::{items, triples, BalloonMesh};
use super::params::{check_struct_size, params_from_c, BalloonParams};
use super::segmenter::{progress_from_c, BalloonProgressCallback, BalloonStats, ShownMesh};
use super::status::BalloonStatus;
use super::volume::{volume_from_c, BalloonVolume};
use crate::balloon::{segment_objects, ObjectSeeds, ObjectsRequest, Region};
use crate::error::Error;

/// The seeds of one object for balloon_segment_objects: `point_count` points, x, y, z
/// interleaved in world mm (3 * point_count doubles), that grow as one object named `label`
/// (1 to 2^31 - 1, distinct between objects).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct BalloonObjectSeeds {
    pub label: u32,
    pub points: *const f64,
    pub point_count: usize,
}

/// The objects segmented by balloon_segment_objects (opaque), in the order they were given,
/// without the stop seeds' balloons. Owned by the caller until balloon_objects_free; it does
/// not borrow the volume.
pub struct BalloonObjects {
    objects: Vec<Object>,
}

struct Object {
    label: u32,
    shown: ShownMesh,
    stats: BalloonStats,
}

/// The request `objects`, `stops` and `roi` describe (world mm).
///
/// # Safety
/// As [`balloon_segment_objects`]'s arguments of the same names.
unsafe fn request_from_c(
    objects: *const BalloonObjectSeeds,
    object_count: usize,
    stops: *const f64,
    stop_count: usize,
    roi: *const f64,
) -> Result<ObjectsRequest, Failure> {
    // SAFETY: by the caller's promise, `objects` holds `object_count` items.
    let given = unsafe { items(objects, object_count, 1, "objects")? };
    let mut request = ObjectsRequest::default();
    for (i, object) in given.iter().enumerate() {
        // SAFETY: by the caller's promise, each object's points hold `point_count` triples.
        let points = unsafe {
            triples(
                object.points,
                object.point_count,
                &format!("objects[{i}].points"),
            )?
        };
        request.objects.push(ObjectSeeds {
            label: object.label,
            seeds: points.chunks_exact(3).map(DVec3::from_slice).collect(),
        });
    }
    // SAFETY: by the caller's promise, `stops` holds `stop_count` triples.
    let stops = unsafe { triples(stops, stop_count, "stops")? };
    request.stops = stops.chunks_exact(3).map(DVec3::from_slice).collect();
    if !roi.is_null() {
        // SAFETY: non-NULL, 6 doubles by the caller's promise.
        let b = unsafe { roi.cast::<[f64; 6]>().read_unaligned() };
        let corner = |c: &[f64]| DVec3::from_slice(c);
        request.region = Some(Region::new(corner(&b[..3]), corner(&b[3..]))?);
    }
    Ok(request)
}

/// Segments several objects at once: each object of `objects` (`object_count` of them) is a
/// balloon grown from its seeds, all grow together and stop at each other's surfaces
/// (docs/interfaces.md, "Several objects"). `stops` (x, y, z world mm, `stop_count` points; NULL
/// with 0) seeds competitors: balloons that only keep the objects out of their structure and
/// are left out of the result. `roi` is NULL or 6 doubles x0, y0, z0, x1, y1, z1: two opposite
/// corners (world mm) of a box that no balloon grows beyond. `params` may be NULL for the
/// defaults; the window of each object comes from its first seed unless given.
///
/// `progress` (NULL = none) is called with `user_data` on this thread with the mean fraction
/// of all balloons; returning non-zero cancels the call (BALLOON_CANCELLED, no result).
/// On success `*out` receives the objects, to release with balloon_objects_free. Bad labels
/// (0, above 2^31 - 1, given twice), an object without points, non-finite seeds, seeds of two
/// objects (or a stop seed) in one voxel, more than 256 balloons, a flat or non-finite region
/// and a seed outside it are BALLOON_INVALID_ARGUMENT with a message naming the seed.
///
/// # Safety
/// `volume` describes valid voxels, read during the call only. `objects` holds `object_count`
/// BalloonObjectSeeds (NULL only with 0), each with `3 * point_count` readable doubles;
/// `stops` holds `3 * stop_count` doubles (NULL only with 0); `roi` is NULL or holds 6
/// doubles; `params` is NULL or filled by balloon_params_default; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_segment_objects(
    volume: *const BalloonVolume,
    params: *const BalloonParams,
    objects: *const BalloonObjectSeeds,
    object_count: usize,
    stops: *const f64,
    stop_count: usize,
    roi: *const f64,
    progress: BalloonProgressCallback,
    user_data: *mut c_void,
    out: *mut *mut BalloonObjects,
) -> BalloonStatus {
    run(|| {
        require(out, "out")?;
        // SAFETY: by the caller's promises above.
        let (volume, params, request) = unsafe {
            (
                volume_from_c(volume)?,
                params_from_c(params)?,
                request_from_c(objects, object_count, stops, stop_count, roi)?,
            )
        };
        // SAFETY: `progress` and `user_data` are used during this call only.
        let progress = unsafe { progress_from_c(progress, user_data) };
        let segmented = segment_objects(volume, params, &request, progress)?;
        let objects = segmented
            .into_iter()
            .map(|o| Object {
                label: o.label,
                stats: BalloonStats::from(&o.stats),
                shown: ShownMesh::new((o.mesh, o.states)),
            })
            .collect();
        let owned = Box::new(BalloonObjects { objects });
        // SAFETY: non-NULL and writable.
        unsafe { out.write(Box::into_raw(owned)) };
        Ok(())
    })
}

/// # Safety
/// `r` must be NULL or point to a live BalloonObjects.
unsafe fn result<'a>(r: *const BalloonObjects) -> Result<&'a BalloonObjects, Failure> {
    // SAFETY: by the caller's promise.
    unsafe { r.as_ref() }.ok_or_else(|| Failure::null("r"))
}

impl BalloonObjects {
    fn get(&self, index: usize) -> Result<&Object, Failure> {
        self.objects.get(index).ok_or_else(|| {
            Error::invalid_argument(format!(
                "object index {index} is out of range: the result holds {} objects; give an \
                 index below balloon_objects_count",
                self.objects.len()
            ))
            .into()
        })
    }
}

/// `*count_out` receives the number of objects (stop seeds are not counted).
///
/// # Safety
/// `r` is a live BalloonObjects; `count_out` is writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_objects_count(
    r: *const BalloonObjects,
    count_out: *mut usize,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let r = unsafe { result(r)? };
        require(count_out, "count_out")?;
        // SAFETY: non-NULL and writable.
        unsafe { count_out.write(r.objects.len()) };
        Ok(())
    })
}

/// `*label_out` receives the label of object `index` (0 to count - 1, in the order given).
///
/// # Safety
/// `r` is a live BalloonObjects; `label_out` is writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_objects_label(
    r: *const BalloonObjects,
    index: usize,
    label_out: *mut u32,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let r = unsafe { result(r)? };
        require(label_out, "label_out")?;
        let label = r.get(index)?.label;
        // SAFETY: non-NULL and writable.
        unsafe { label_out.write(label) };
        Ok(())
    })
}

/// A view of the mesh of object `index`: closed, 2-manifold, outward, free of
/// self-intersections and of crossings with the other objects, with its vertex states. The
/// arrays belong to `r` and stay valid until balloon_objects_free.
///
/// # Safety
/// `r` is a live BalloonObjects; `out` is writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_objects_mesh(
    r: *const BalloonObjects,
    index: usize,
    out: *mut BalloonMesh,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let r = unsafe { result(r)? };
        require(out, "out")?;
        let view = r.get(index)?.shown.view();
        // SAFETY: non-NULL and writable.
        unsafe { out.write(view) };
        Ok(())
    })
}

/// The statistics of object `index`'s balloon, as balloon_stats gives them for a segmenter.
/// The caller sets `out->struct_size` to sizeof(BalloonStats).
///
/// # Safety
/// `r` is a live BalloonObjects; `out` is a writable BalloonStats.
#[no_mangle]
pub unsafe extern "C" fn balloon_objects_stats(
    r: *const BalloonObjects,
    index: usize,
    out: *mut BalloonStats,
) -> BalloonStatus {
    run(|| {
        // SAFETY: by the caller's promise.
        let r = unsafe { result(r)? };
        require(out, "out")?;
        // SAFETY: non-NULL; the leading size is read before the rest is trusted.
        unsafe { check_struct_size(out, "BalloonStats")? };
        let stats = r.get(index)?.stats;
        // SAFETY: writable, and of this library's size.
        unsafe { out.write_unaligned(stats) };
        Ok(())
    })
}

/// Releases the objects of balloon_segment_objects; NULL is fine.
///
/// # Safety
/// `r` is NULL or a live BalloonObjects, not used again afterwards.
#[no_mangle]
pub unsafe extern "C" fn balloon_objects_free(r: *mut BalloonObjects) {
    run_infallible((), || {
        if !r.is_null() {
            // SAFETY: made by Box::into_raw, released once by the caller's promise.
            drop(unsafe { Box::from_raw(r) });
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::balloon::BalloonParams as RustParams;

    const N: usize = 20;

    /// Two bright balls of radius 4 voxels at i = 5 and i = 14 (touching nothing), spacing 1.
    fn two_balls() -> Vec<f32> {
        let mut v = vec![0f32; N * N * N];
        for k in 0..N {
            for j in 0..N {
                for i in 0..N {
                    let d = |c: f64| {
                        ((i as f64 - c).powi(2)
                            + (j as f64 - 10.0).powi(2)
                            + (k as f64 - 10.0).powi(2))
                        .sqrt()
                    };
                    if d(5.0) <= 3.5 || d(14.0) <= 3.5 {
                        v[i + N * j + N * N * k] = 200.0;
                    }
                }
            }
        }
        v
    }

    fn described(voxels: &[f32]) -> BalloonVolume {
        BalloonVolume {
            data: voxels.as_ptr().cast(),
            scalar_type: 6,
            dims: [N; 3],
            strides: [1, N as isize, (N * N) as isize],
            spacing: [1.0; 3],
            origin: [0.0; 3],
            direction: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        }
    }

    fn params() -> BalloonParams {
        let mut p = BalloonParams::from(&RustParams::default());
        p.reference_intensity = 200.0;
        p.tolerance = 100.0;
        p.threads = 1;
        p
    }

    const A: [f64; 3] = [5.0, 10.0, 10.0];
    const B: [f64; 3] = [14.0, 10.0, 10.0];

    unsafe fn call(
        voxels: &[f32],
        objects: &[BalloonObjectSeeds],
        stops: &[f64],
        roi: Option<&[f64; 6]>,
    ) -> (BalloonStatus, *mut BalloonObjects) {
        let mut out = std::ptr::null_mut();
        let status = unsafe {
            balloon_segment_objects(
                &described(voxels),
                &params(),
                objects.as_ptr(),
                objects.len(),
                stops.as_ptr(),
                stops.len() / 3,
                roi.map_or(std::ptr::null(), |r| r.as_ptr()),
                None,
                std::ptr::null_mut(),
                &mut out,
            )
        };
        (status, out)
    }

    fn seeds(label: u32, points: &[f64]) -> BalloonObjectSeeds {
        BalloonObjectSeeds {
            label,
            points: points.as_ptr(),
            point_count: points.len() / 3,
        }
    }

    fn message() -> String {
        let n = unsafe { crate::ffi::balloon_last_error_message(std::ptr::null_mut(), 0) };
        let mut buffer = vec![0 as std::ffi::c_char; n + 1];
        unsafe { crate::ffi::balloon_last_error_message(buffer.as_mut_ptr(), n + 1) };
        let bytes: Vec<u8> = buffer[..n].iter().map(|&c| c as u8).collect();
        String::from_utf8(bytes).unwrap()
    }

    #[test]
    fn two_objects_come_back_in_order_like_the_safe_api() {
        let voxels = two_balls();
        let objects = [seeds(7, &B), seeds(3, &A)];
        let (status, r) = unsafe { call(&voxels, &objects, &[], None) };
        assert_eq!(status, BalloonStatus::BALLOON_OK, "{}", message());
        let volume = unsafe { volume_from_c(&described(&voxels)) }.unwrap();
        let safe = segment_objects(
            volume,
            params().to_rust().unwrap(),
            &ObjectsRequest {
                objects: vec![
                    ObjectSeeds {
                        label: 7,
                        seeds: vec![DVec3::from(B)],
                    },
                    ObjectSeeds {
                        label: 3,
                        seeds: vec![DVec3::from(A)],
                    },
                ],
                ..ObjectsRequest::default()
            },
            None,
        )
        .unwrap();
        let mut count = 0;
        unsafe {
            assert_eq!(
                balloon_objects_count(r, &mut count),
                BalloonStatus::BALLOON_OK
            );
            assert_eq!(count, 2);
            for (i, expected) in safe.iter().enumerate() {
                let mut label = 0;
                assert_eq!(
                    balloon_objects_label(r, i, &mut label),
                    BalloonStatus::BALLOON_OK
                );
                assert_eq!(label, expected.label);
                let mut view = std::mem::MaybeUninit::<BalloonMesh>::uninit();
                assert_eq!(
                    balloon_objects_mesh(r, i, view.as_mut_ptr()),
                    BalloonStatus::BALLOON_OK
                );
                let view = view.assume_init();
                let points = std::slice::from_raw_parts(view.points, 3 * view.point_count);
                let flat: Vec<f64> = expected
                    .mesh
                    .points()
                    .iter()
                    .flat_map(|p| p.to_array())
                    .collect();
                assert_eq!(points, &flat[..]);
                let states = std::slice::from_raw_parts(view.vertex_state, view.point_count);
                assert!(states
                    .iter()
                    .zip(&expected.states)
                    .all(|(&c, &s)| c == crate::ffi::BalloonVertexState::from(s) as u8));
                let mut stats = BalloonStats::from(&expected.stats);
                stats.iterations = u32::MAX;
                assert_eq!(
                    balloon_objects_stats(r, i, &mut stats),
                    BalloonStatus::BALLOON_OK
                );
                assert_eq!(stats.iterations, expected.stats.iterations);
            }
            let mut label = 0;
            assert_eq!(
                balloon_objects_label(r, 2, &mut label),
                BalloonStatus::BALLOON_INVALID_ARGUMENT
            );
            assert!(message().contains("index 2"), "{}", message());
            balloon_objects_free(r);
            balloon_objects_free(std::ptr::null_mut());
        }
    }

    /// Objects, stop seeds, region, and the status and a word of the message they give.
    type Case = (
        Vec<BalloonObjectSeeds>,
        Vec<f64>,
        Option<[f64; 6]>,
        BalloonStatus,
        &'static str,
    );

    #[test]
    fn pointers_and_counts_are_checked_and_the_core_names_bad_seeds() {
        let voxels = two_balls();
        let nan = [f64::NAN, 10.0, 10.0];
        let null_points = BalloonObjectSeeds {
            label: 1,
            points: std::ptr::null(),
            point_count: 1,
        };
        let flat_roi = [0.0, 0.0, 0.0, 10.0, 0.0, 10.0];
        let cases: Vec<Case> = vec![
            (
                vec![],
                vec![],
                None,
                BalloonStatus::BALLOON_INVALID_ARGUMENT,
                "no object",
            ),
            (
                vec![null_points],
                vec![],
                None,
                BalloonStatus::BALLOON_NULL_POINTER,
                "objects[0].points",
            ),
            (
                vec![seeds(0, &A)],
                vec![],
                None,
                BalloonStatus::BALLOON_INVALID_ARGUMENT,
                "label 0",
            ),
            (
                vec![seeds(1, &[])],
                vec![],
                None,
                BalloonStatus::BALLOON_INVALID_ARGUMENT,
                "no seed",
            ),
            (
                vec![seeds(1, &nan)],
                vec![],
                None,
                BalloonStatus::BALLOON_INVALID_ARGUMENT,
                "not finite",
            ),
            (
                vec![seeds(1, &A), seeds(1, &B)],
                vec![],
                None,
                BalloonStatus::BALLOON_INVALID_ARGUMENT,
                "twice",
            ),
            (
                vec![seeds(1, &A)],
                A.to_vec(),
                None,
                BalloonStatus::BALLOON_INVALID_ARGUMENT,
                "stop seed",
            ),
            (
                vec![seeds(1, &A)],
                vec![],
                Some(flat_roi),
                BalloonStatus::BALLOON_INVALID_ARGUMENT,
                "flat",
            ),
        ];
        for (objects, stops, roi, status, needle) in cases {
            let (got, r) = unsafe { call(&voxels, &objects, &stops, roi.as_ref()) };
            assert_eq!(got, status, "{needle}: {}", message());
            assert!(r.is_null(), "no result on failure");
            assert!(message().contains(needle), "{needle}: {}", message());
        }
        let objects = [seeds(1, &A)];
        let mut out = std::ptr::null_mut();
        let out_ptr: *mut *mut BalloonObjects = &mut out;
        let volume = described(&voxels);
        let nulls = [
            (std::ptr::null(), 0, out_ptr, "objects is NULL"),
            (objects.as_ptr(), 2, out_ptr, "stops is NULL"),
            (objects.as_ptr(), 0, std::ptr::null_mut(), "out is NULL"),
        ];
        for (objects, stop_count, out, needle) in nulls {
            let status = unsafe {
                balloon_segment_objects(
                    &volume,
                    std::ptr::null(),
                    objects,
                    1,
                    std::ptr::null(),
                    stop_count,
                    std::ptr::null(),
                    None,
                    std::ptr::null_mut(),
                    out,
                )
            };
            assert_eq!(status, BalloonStatus::BALLOON_NULL_POINTER, "{needle}");
            assert!(message().starts_with(needle), "{}", message());
        }
        let mut count = 0;
        assert_eq!(
            unsafe { balloon_objects_count(std::ptr::null(), &mut count) },
            BalloonStatus::BALLOON_NULL_POINTER
        );
    }

    unsafe extern "C" fn cancel_at_once(
        _: f64,
        _: *const std::ffi::c_char,
        calls: *mut c_void,
    ) -> std::ffi::c_int {
        unsafe { *calls.cast::<u32>() += 1 };
        1
    }

    #[test]
    fn a_stop_seed_and_a_region_are_honoured_and_progress_may_cancel() {
        let voxels = two_balls();
        let objects = [seeds(2, &A)];
        let (status, r) = unsafe { call(&voxels, &objects, &B, None) };
        assert_eq!(status, BalloonStatus::BALLOON_OK, "{}", message());
        let (mut count, mut label) = (0, 0);
        unsafe {
            balloon_objects_count(r, &mut count);
            balloon_objects_label(r, 0, &mut label);
            balloon_objects_free(r);
        }
        assert_eq!(
            (count, label),
            (1, 2),
            "the stop seed's balloon is left out"
        );
        // The region cuts the ball at x = 6: the object ends there.
        let roi = [0.0, 0.0, 0.0, 6.0, 19.0, 19.0];
        let (status, r) = unsafe { call(&voxels, &objects, &[], Some(&roi)) };
        assert_eq!(status, BalloonStatus::BALLOON_OK, "{}", message());
        let mut view = std::mem::MaybeUninit::<BalloonMesh>::uninit();
        unsafe {
            assert_eq!(
                balloon_objects_mesh(r, 0, view.as_mut_ptr()),
                BalloonStatus::BALLOON_OK
            );
            let view = view.assume_init();
            let points = std::slice::from_raw_parts(view.points, 3 * view.point_count);
            let max_x = points
                .chunks_exact(3)
                .map(|p| p[0])
                .fold(f64::MIN, f64::max);
            // The ball alone reaches x = 8.5; the region's face stops it as a volume's would.
            assert!(max_x < 6.6, "the mesh reaches x = {max_x}");
            balloon_objects_free(r);
        }
        let (status, r) = unsafe { call(&voxels, &objects, &B, Some(&roi)) };
        assert_eq!(status, BalloonStatus::BALLOON_INVALID_ARGUMENT);
        assert!(
            r.is_null() && message().contains("outside the region"),
            "{}",
            message()
        );
        let mut calls = 0u32;
        let mut out = std::ptr::null_mut();
        let status = unsafe {
            balloon_segment_objects(
                &described(&voxels),
                &params(),
                objects.as_ptr(),
                1,
                B.as_ptr(),
                1,
                std::ptr::null(),
                Some(cancel_at_once),
                (&mut calls as *mut u32).cast(),
                &mut out,
            )
        };
        assert_eq!(status, BalloonStatus::BALLOON_CANCELLED);
        assert!(out.is_null() && calls >= 1);
    }
}
