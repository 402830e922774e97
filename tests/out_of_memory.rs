//! Allocation failure at the C ABI. This test binary's global allocator refuses, on demand,
//! the n-th allocation of at least `LARGE` bytes — the size of the buffers that grow with a
//! volume or a grid, well above anything the small test mesh needs. For every n a call
//! makes, the call must return `BALLOON_OUT_OF_MEMORY` with a message (never abort the host)
//! and leave the handle usable: the same call then succeeds with the same mesh as a run
//! that was never refused.

#![cfg(target_os = "linux")]

use std::alloc::{GlobalAlloc, Layout, System};
use std::ffi::{c_char, c_int, c_void};
use std::ptr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use balloonseg::ffi::*;

const LARGE: usize = 256 * 1024;
const NEVER: usize = usize::MAX;

/// Counts the large allocations and refuses the one numbered `REFUSE` (from 0).
struct Refusing;

static LARGE_SEEN: AtomicUsize = AtomicUsize::new(0);
static REFUSE: AtomicUsize = AtomicUsize::new(NEVER);
static REFUSED: AtomicUsize = AtomicUsize::new(0);

impl Refusing {
    fn refuses(size: usize) -> bool {
        if size < LARGE {
            return false;
        }
        let n = LARGE_SEEN.fetch_add(1, Ordering::SeqCst);
        let refuse = n == REFUSE.load(Ordering::SeqCst);
        if refuse {
            REFUSED.fetch_add(1, Ordering::SeqCst);
        }
        refuse
    }
}

unsafe impl GlobalAlloc for Refusing {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if Self::refuses(layout.size()) {
            return ptr::null_mut();
        }
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if Self::refuses(layout.size()) {
            return ptr::null_mut();
        }
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        unsafe { System.dealloc(p, layout) }
    }

    unsafe fn realloc(&self, p: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > layout.size() && Self::refuses(new_size) {
            return ptr::null_mut();
        }
        unsafe { System.realloc(p, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Refusing = Refusing;

/// One test at a time: the refusal counters are global.
static SERIAL: Mutex<()> = Mutex::new(());

/// Runs `call` with the `n`-th large allocation refused; returns its status and whether a
/// refusal happened.
fn refusing_the(n: usize, call: impl FnOnce() -> BalloonStatus) -> (BalloonStatus, bool) {
    LARGE_SEEN.store(0, Ordering::SeqCst);
    REFUSED.store(0, Ordering::SeqCst);
    REFUSE.store(n, Ordering::SeqCst);
    let status = call();
    REFUSE.store(NEVER, Ordering::SeqCst);
    (status, REFUSED.load(Ordering::SeqCst) > 0)
}

fn last_error() -> String {
    let mut buffer = vec![0u8; 1024];
    let n = unsafe { balloon_last_error_message(buffer.as_mut_ptr().cast(), buffer.len()) };
    buffer.truncate(n.min(1023));
    String::from_utf8_lossy(&buffer).into_owned()
}

const IDENTITY: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
const DIMS: [usize; 3] = [72, 64, 60];
const SPACING: [f64; 3] = [1.0, 1.0, 1.25];
const CENTRE: [f64; 3] = [36.0, 32.0, 37.5];

/// A bright ball of radius 16 mm with a one-millimetre ramp at its border, in anisotropic
/// voxels: about 280k voxels, so that every voxel-sized buffer is large, and a balloon of a
/// few thousand vertices, so that no mesh-sized one is.
fn ball() -> Vec<f32> {
    let mut voxels = Vec::with_capacity(DIMS.iter().product());
    for k in 0..DIMS[2] {
        for j in 0..DIMS[1] {
            for i in 0..DIMS[0] {
                let p = [i, j, k].map(|n| n as f64);
                let r = (0..3)
                    .map(|a| (p[a] * SPACING[a] - CENTRE[a]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                voxels.push((100.0 + 100.0 * (16.0 - r).clamp(-1.0, 1.0)) as f32);
            }
        }
    }
    voxels
}

const WAVES: usize = 80;

/// A field whose isosurfaces wind through the whole grid: a large mesh from a small volume.
fn waves() -> Vec<f32> {
    (0..WAVES.pow(3))
        .map(|n| {
            let [i, j, k] = [n % WAVES, n / WAVES % WAVES, n / WAVES / WAVES].map(|x| x as f32);
            (0.45 * i).sin() + (0.45 * j).sin() + (0.45 * k).sin()
        })
        .collect()
}

fn described(voxels: &[f32]) -> BalloonVolume {
    BalloonVolume {
        data: voxels.as_ptr().cast::<c_void>(),
        scalar_type: BalloonScalarType::BALLOON_SCALAR_F32 as u32,
        dims: DIMS,
        strides: [1, DIMS[0] as isize, (DIMS[0] * DIMS[1]) as isize],
        spacing: SPACING,
        origin: [0.0; 3],
        direction: IDENTITY,
    }
}

/// The balloon's points and triangles as the handle shows them.
fn shown(s: *const BalloonSegmenter) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let mut mesh = std::mem::MaybeUninit::<BalloonMesh>::zeroed();
    let status = unsafe { balloon_mesh(s, mesh.as_mut_ptr()) };
    assert_eq!(status, BalloonStatus::BALLOON_OK, "{}", last_error());
    let mesh = unsafe { mesh.assume_init() };
    let points = unsafe { std::slice::from_raw_parts(mesh.points, 3 * mesh.point_count) };
    let triangles = unsafe { std::slice::from_raw_parts(mesh.triangles, 3 * mesh.triangle_count) };
    (
        points.chunks(3).map(|p| [p[0], p[1], p[2]]).collect(),
        triangles.chunks(3).map(|t| [t[0], t[1], t[2]]).collect(),
    )
}

fn init(volume: &BalloonVolume) -> *mut BalloonSegmenter {
    let mut s = ptr::null_mut();
    let status = unsafe { balloon_init(volume, ptr::null(), CENTRE.as_ptr(), &mut s) };
    assert_eq!(status, BalloonStatus::BALLOON_OK, "{}", last_error());
    s
}

/// Checks what a refused call reported.
fn assert_refused(status: BalloonStatus, n: usize) {
    let message = last_error();
    assert_eq!(
        status,
        BalloonStatus::BALLOON_OUT_OF_MEMORY,
        "large allocation {n} was refused: {message}"
    );
    assert!(message.contains("could not allocate"), "{message}");
}

/// The mesh `s` shows is closed, 2-manifold and outward.
fn assert_valid(s: *const BalloonSegmenter) {
    let (points, triangles) = shown(s);
    let flat_points: Vec<f64> = points.concat();
    let flat_triangles: Vec<u32> = triangles.concat();
    let mut report: BalloonMeshReport = unsafe { std::mem::zeroed() };
    report.struct_size = std::mem::size_of::<BalloonMeshReport>();
    let status = unsafe {
        balloon_mesh_check(
            flat_points.as_ptr(),
            points.len(),
            flat_triangles.as_ptr(),
            triangles.len(),
            &mut report,
        )
    };
    assert_eq!(status, BalloonStatus::BALLOON_OK, "{}", last_error());
    assert!(
        report.closed != 0 && report.manifold != 0 && report.outward != 0,
        "{report:?}"
    );
    assert_eq!(report.self_intersecting_pairs, 0);
}

#[test]
fn every_large_allocation_of_a_segmentation_can_fail_without_harm() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let voxels = ball();
    let volume = described(&voxels);
    let reference = {
        let s = init(&volume);
        assert_eq!(unsafe { balloon_segment(s) }, BalloonStatus::BALLOON_OK);
        let mesh = shown(s);
        unsafe { balloon_free(s) };
        mesh
    };
    assert!(reference.1.len() > 1000, "{} triangles", reference.1.len());

    let mut refused_inits = 0;
    loop {
        let mut s = ptr::null_mut();
        let (status, refused) = refusing_the(refused_inits, || unsafe {
            balloon_init(&volume, ptr::null(), CENTRE.as_ptr(), &mut s)
        });
        if !refused {
            assert_eq!(status, BalloonStatus::BALLOON_OK, "{}", last_error());
            unsafe { balloon_free(s) };
            break;
        }
        assert_refused(status, refused_inits);
        assert!(s.is_null(), "a failed balloon_init handed out a handle");
        refused_inits += 1;
    }

    // The handle stays usable: it shows the last completed step, and goes on to a valid
    // result.
    let refused_runs = refuse_each_on_a_handle(
        || init(&volume),
        |s| unsafe { balloon_segment(s) },
        &reference,
        |s, _| assert_valid(s),
        |s| assert_valid(s),
    );
    eprintln!(
        "large allocations refused one at a time: {refused_inits} in balloon_init, \
         {refused_runs} in balloon_segment"
    );
    assert!(
        refused_runs > 0,
        "no allocation of {LARGE} bytes: the test proves nothing"
    );
}

/// Until the signed distance field was allocated fallibly, refusing it aborted the process
/// ("memory allocation of 339512 bytes failed") inside `balloon_reparametrize`.
#[test]
fn every_large_allocation_of_a_reparametrisation_can_fail_without_harm() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let voxels = ball();
    let volume = described(&voxels);
    // Inflated to the ball's wall: the grid over the balloon then needs a signed distance field
    // above `LARGE` (its masks, a byte a voxel, and the new balloon stay below it).
    let inflated = || {
        let s = init(&volume);
        let mut active = 0;
        let status = unsafe { balloon_step(s, 200, &mut active) };
        assert_eq!(status, BalloonStatus::BALLOON_OK, "{}", last_error());
        s
    };
    let s = inflated();
    assert_eq!(
        unsafe { balloon_reparametrize(s) },
        BalloonStatus::BALLOON_OK,
        "{}",
        last_error()
    );
    let reference = shown(s);
    unsafe { balloon_free(s) };

    let refused_runs = refuse_each_on_a_handle(
        inflated,
        |s| unsafe { balloon_reparametrize(s) },
        &reference,
        |s, before| {
            assert!(
                shown(s) == *before,
                "a refused re-parametrisation changed the balloon"
            )
        },
        |s| assert!(shown(s) == reference),
    );
    eprintln!("large allocations refused one at a time in balloon_reparametrize: {refused_runs}");
    assert!(
        refused_runs > 0,
        "no allocation of {LARGE} bytes: the test proves nothing"
    );
}

type Shown = (Vec<[f64; 3]>, Vec<[u32; 3]>);

/// Runs `call` on a handle from `make` with each of its large allocations refused in turn,
/// until a call refuses none: it must then succeed with `reference`. After each refusal,
/// `after_refusal` checks the handle (given the mesh shown before the call), the call is made
/// again and must succeed, and `after_retry` checks the handle. Returns how many large
/// allocations the call makes.
fn refuse_each_on_a_handle(
    make: impl Fn() -> *mut BalloonSegmenter,
    call: impl Fn(*mut BalloonSegmenter) -> BalloonStatus,
    reference: &Shown,
    after_refusal: impl Fn(*mut BalloonSegmenter, &Shown),
    after_retry: impl Fn(*mut BalloonSegmenter),
) -> usize {
    for n in 0.. {
        let s = make();
        let before = shown(s);
        let (status, refused) = refusing_the(n, || call(s));
        if !refused {
            assert_eq!(status, BalloonStatus::BALLOON_OK, "{}", last_error());
            assert!(
                shown(s) == *reference,
                "the counting allocator changed the result"
            );
            unsafe { balloon_free(s) };
            return n;
        }
        assert_refused(status, n);
        after_refusal(s, &before);
        assert_eq!(call(s), BalloonStatus::BALLOON_OK, "{}", last_error());
        after_retry(s);
        unsafe { balloon_free(s) };
    }
    unreachable!()
}

/// Calls `call` with each of its large allocations refused in turn, until a call refuses none
/// and succeeds; `out` is the handle the call writes, which a refused call must leave NULL.
/// Returns how many large allocations the call makes.
fn refuse_each<T>(
    mut call: impl FnMut(&mut *mut T) -> BalloonStatus,
    free: impl Fn(*mut T),
) -> usize {
    for n in 0.. {
        let mut out = ptr::null_mut();
        let (status, refused) = refusing_the(n, || call(&mut out));
        if !refused {
            assert_eq!(status, BalloonStatus::BALLOON_OK, "{}", last_error());
            free(out);
            return n;
        }
        assert_refused(status, n);
        assert!(out.is_null(), "a refused call handed out a result");
    }
    unreachable!()
}

/// A progress callback that counts its calls in `*user_data` (a `usize`) and never cancels.
unsafe extern "C" fn count_calls(
    _fraction: f64,
    _phase: *const c_char,
    user_data: *mut c_void,
) -> c_int {
    unsafe { *user_data.cast::<usize>() += 1 };
    0
}

#[test]
fn every_large_allocation_of_the_kernels_can_fail_without_harm() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let voxels = ball();
    let volume = described(&voxels);
    let s = init(&volume);
    assert_eq!(unsafe { balloon_segment(s) }, BalloonStatus::BALLOON_OK);
    let (points, triangles) = shown(s);
    unsafe { balloon_free(s) };
    let points: Vec<f64> = points.concat();
    let triangles: Vec<u32> = triangles.concat();
    let (np, nt) = (points.len() / 3, triangles.len() / 3);

    let waves = waves();
    let waves_volume = BalloonVolume {
        dims: [WAVES; 3],
        strides: [1, WAVES as isize, (WAVES * WAVES) as isize],
        ..described(&waves)
    };
    let isosurface = refuse_each(
        |out| unsafe { balloon_marching_cubes(&waves_volume, 0.1, 2, out) },
        |m| unsafe { balloon_trimesh_free(m) },
    );
    let simplified = refuse_each(
        |out| unsafe { balloon_simplify(points.as_ptr(), np, triangles.as_ptr(), nt, 0.2, out) },
        |m| unsafe { balloon_trimesh_free(m) },
    );
    // With a callback: the refusal must pass through a call that reports progress too.
    let mut calls = 0usize;
    let simplified_with_progress = refuse_each(
        |out| unsafe {
            balloon_simplify_with_progress(
                points.as_ptr(),
                np,
                triangles.as_ptr(),
                nt,
                0.2,
                Some(count_calls),
                (&mut calls as *mut usize).cast(),
                out,
            )
        },
        |m| unsafe { balloon_trimesh_free(m) },
    );
    assert!(calls > 0, "the simplification never reported progress");
    let pairs = refuse_each(
        |_: &mut *mut u8| {
            let mut count = 0;
            unsafe {
                balloon_self_intersections(
                    points.as_ptr(),
                    np,
                    triangles.as_ptr(),
                    nt,
                    ptr::null_mut(),
                    0,
                    &mut count,
                )
            }
        },
        |_| {},
    );
    let seed = BalloonObjectSeeds {
        label: 1,
        points: CENTRE.as_ptr(),
        point_count: 1,
    };
    let objects = refuse_each(
        |out| unsafe {
            balloon_segment_objects(
                &volume,
                ptr::null(),
                &seed,
                1,
                ptr::null(),
                0,
                ptr::null(),
                None,
                ptr::null_mut(),
                out,
            )
        },
        |r| unsafe { balloon_objects_free(r) },
    );
    eprintln!(
        "large allocations refused one at a time: {isosurface} in balloon_marching_cubes, \
         {simplified} in balloon_simplify, {simplified_with_progress} in \
         balloon_simplify_with_progress, {pairs} in balloon_self_intersections, {objects} in \
         balloon_segment_objects"
    );
    assert!(isosurface > 0 && simplified > 0 && pairs > 0 && objects > 0);
    assert_eq!(simplified_with_progress, simplified);
}
