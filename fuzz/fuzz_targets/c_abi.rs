//! The C ABI as a C host drives it: volumes with random sizes, strides (negative and padded
//! too), scalar types, spacing, origin and direction (zero, negative, NaN, singular), NaN
//! voxels, parameters set by name to random values, and a random sequence of calls on one
//! handle; then marching cubes of the volume and balloon_simplify_with_progress of its mesh,
//! with a random bound and a callback that may cancel. Every call returns a status; nothing
//! panics, aborts or hangs, and a mesh handed out is closed, 2-manifold and oriented (outward
//! for the balloon's).

#![no_main]

#[path = "bytes.rs"]
mod bytes;

use std::ffi::c_void;
use std::ptr;

use balloonseg::ffi::*;
use bytes::Bytes;
use libfuzzer_sys::fuzz_target;

/// A number as a C host might pass it: ordinary, zero, negative, huge, tiny or NaN.
fn number(bytes: &mut Bytes, typical: f64) -> f64 {
    match bytes.byte() % 16 {
        0 => 0.0,
        1 => -typical,
        2 => f64::NAN,
        3 => f64::INFINITY,
        4 => typical * 1e9,
        5 => typical * 1e-9,
        _ => typical * (0.25 + f64::from(bytes.byte()) / 64.0),
    }
}

/// Voxels held for the volume's lifetime, in the layout its strides describe.
struct Voxels {
    _storage: Vec<f64>,
    volume: BalloonVolume,
}

fn volume(bytes: &mut Bytes) -> Voxels {
    let dims = [0; 3].map(|_| 1 + bytes.byte() as usize % 12);
    // Axes in a random memory order, each possibly reversed or padded.
    let order = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ][bytes.byte() as usize % 6];
    let mut strides = [0isize; 3];
    let mut run = 1isize;
    for &axis in &order {
        strides[axis] = run;
        run *= dims[axis] as isize + isize::from(bytes.byte() % 3 == 0);
    }
    let elements = run as usize;
    let mut first = 0isize;
    for axis in 0..3 {
        if bytes.byte() % 2 == 1 {
            first += strides[axis] * (dims[axis] as isize - 1);
            strides[axis] = -strides[axis];
        }
    }
    // f64 storage is aligned for every scalar type; a type of w bytes sees 8 / w elements per f64.
    let scalar_type = u32::from(bytes.byte() % 9);
    let width = [1, 1, 2, 2, 4, 4, 4, 8, 8][scalar_type as usize];
    let mut storage = vec![0.0f64; (elements * width).div_ceil(8)];
    let raw = storage.as_mut_ptr().cast::<u8>();
    for i in 0..elements * width {
        // SAFETY: within the storage just allocated.
        unsafe { raw.add(i).write(bytes.byte()) };
    }
    if scalar_type == 7 && bytes.byte() % 4 == 0 {
        storage[0] = f64::NAN;
    }
    let spacing = [0; 3].map(|_| number(bytes, 1.0));
    let origin = [0; 3].map(|_| number(bytes, 10.0));
    let mut direction = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    if bytes.byte() % 4 == 0 {
        direction = direction.map(|_| number(bytes, 1.0));
    }
    // SAFETY: `first` elements into the storage, where the strides' offsets start.
    let data = unsafe { raw.add(first as usize * width) }.cast::<c_void>();
    Voxels {
        volume: BalloonVolume {
            data,
            scalar_type,
            dims,
            strides,
            spacing,
            origin,
            direction,
        },
        _storage: storage,
    }
}

/// Whether `status` is success; a panic caught at the boundary is a finding.
fn ok(status: BalloonStatus) -> bool {
    if status == BalloonStatus::BALLOON_PANIC {
        let mut message = [0u8; 512];
        // SAFETY: 512 writable bytes.
        let n = unsafe { balloon_last_error_message(message.as_mut_ptr().cast(), 512) };
        panic!(
            "a panic reached the C ABI: {}",
            String::from_utf8_lossy(&message[..n.min(511)])
        );
    }
    status == BalloonStatus::BALLOON_OK
}

fn assert_valid(mesh: &BalloonMesh) {
    if let Some(report) = report(mesh) {
        assert!(report.is_valid_closed_surface(), "{report:?}");
    }
}

/// The mesh checks of a view; `None` for an empty mesh.
fn report(mesh: &BalloonMesh) -> Option<balloonseg::mesh_checks::MeshReport> {
    if mesh.triangle_count == 0 {
        return None;
    }
    // SAFETY: the library's view, valid until the next call on its handle.
    let (points, triangles) = unsafe {
        (
            std::slice::from_raw_parts(mesh.points, 3 * mesh.point_count),
            std::slice::from_raw_parts(mesh.triangles, 3 * mesh.triangle_count),
        )
    };
    let points = points
        .chunks(3)
        .map(|p| glam::DVec3::new(p[0], p[1], p[2]))
        .collect();
    let triangles = triangles.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
    let mesh = balloonseg::TriMesh::new(points, triangles).expect("a mesh of valid indices");
    Some(balloonseg::mesh_checks::check(&mesh))
}

fuzz_target!(|data: &[u8]| {
    let mut bytes = Bytes(data);
    let voxels = volume(&mut bytes);
    let mut params = std::mem::MaybeUninit::<BalloonParams>::uninit();
    // SAFETY: writable.
    unsafe { balloon_params_default(params.as_mut_ptr()) };
    // SAFETY: filled by balloon_params_default.
    let mut params = unsafe { params.assume_init() };
    params.max_vertices = 20_000;
    params.max_iterations = 40;
    params.threads = 1;
    let count = balloon_param_count();
    for _ in 0..bytes.byte() % 4 {
        // SAFETY: all-zero is a valid BalloonParamInfo (NULL names, kind 0).
        let mut info: BalloonParamInfo = unsafe { std::mem::zeroed() };
        info.struct_size = std::mem::size_of::<BalloonParamInfo>();
        // SAFETY: writable, of this library's size.
        let status = unsafe { balloon_param_info(bytes.byte() as usize % count, &mut info) };
        if ok(status) {
            let value = number(&mut bytes, 50.0);
            // SAFETY: a writable BalloonParams; the name is the library's static string.
            ok(unsafe { balloon_params_set(&mut params, info.name, value) });
        }
    }
    params.max_vertices = params.max_vertices.min(20_000);
    params.max_iterations = params.max_iterations.min(60);
    let seed = [0; 3].map(|_| number(&mut bytes, 5.0));
    let mut handle = ptr::null_mut();
    // SAFETY: the volume's voxels live in `voxels` until the handle is freed below.
    let status = unsafe { balloon_init(&voxels.volume, &params, seed.as_ptr(), &mut handle) };
    if !ok(status) {
        assert!(handle.is_null());
        // SAFETY: NULL asks for the length only.
        assert!(unsafe { balloon_last_error_message(ptr::null_mut(), 0) } > 0);
        return;
    }
    for _ in 0..1 + bytes.byte() % 6 {
        // SAFETY: `handle` is live; every out-pointer is writable.
        unsafe {
            match bytes.byte() % 7 {
                0 => {
                    let seed = [0; 3].map(|_| number(&mut bytes, 5.0));
                    ok(balloon_add_seed(handle, seed.as_ptr()));
                }
                1 => {
                    let mut moving = 0;
                    ok(balloon_step(
                        handle,
                        u32::from(bytes.byte() % 20),
                        &mut moving,
                    ));
                }
                2 => {
                    let mut frozen = 0;
                    ok(balloon_freeze_self_intersections(handle, &mut frozen));
                }
                3 => {
                    ok(balloon_reparametrize(handle));
                }
                4 => {
                    if ok(balloon_segment(handle)) {
                        let mut mesh = std::mem::zeroed();
                        assert!(ok(balloon_mesh(handle, &mut mesh)));
                        assert_valid(&mesh);
                    }
                }
                5 => {
                    let mut mesh = std::mem::zeroed();
                    ok(balloon_mesh(handle, &mut mesh));
                }
                _ => {
                    let mut stats: BalloonStats = std::mem::zeroed();
                    stats.struct_size = std::mem::size_of::<BalloonStats>();
                    ok(balloon_stats(handle, &mut stats));
                }
            }
        }
    }
    // SAFETY: live, freed once.
    unsafe { balloon_free(handle) };
    let mut mesh = ptr::null_mut();
    // SAFETY: the volume is valid during the call; `mesh` is writable.
    if ok(unsafe {
        balloon_marching_cubes(&voxels.volume, number(&mut bytes, 100.0), 1, &mut mesh)
    }) {
        simplify(mesh, &mut bytes);
        // SAFETY: the kernel's mesh, freed once.
        unsafe { balloon_trimesh_free(mesh) };
    }
    drop(voxels);
});

/// Counts the progress calls and cancels at the `cancel_at`-th (never when 0).
unsafe extern "C" fn count_calls(
    fraction: f64,
    _phase: *const std::ffi::c_char,
    user_data: *mut c_void,
) -> std::ffi::c_int {
    assert!((0.0..=1.0).contains(&fraction), "fraction {fraction}");
    // SAFETY: the [calls, cancel_at] pair the caller passed, live during the call.
    let [calls, cancel_at] = unsafe { &mut *user_data.cast::<[u32; 2]>() };
    *calls += 1;
    std::ffi::c_int::from(*calls == *cancel_at)
}

/// balloon_simplify_with_progress on a marching-cubes mesh (open where the surface leaves the
/// grid, so often refused), with a random bound and a callback that may cancel: a status, and
/// a valid mesh on success.
fn simplify(mesh: *mut BalloonTriMesh, bytes: &mut Bytes) {
    let mut view = BalloonMesh {
        points: ptr::null(),
        point_count: 0,
        triangles: ptr::null(),
        triangle_count: 0,
        vertex_state: ptr::null(),
    };
    // SAFETY: a live kernel mesh and a writable view.
    assert!(ok(unsafe { balloon_trimesh_view(mesh, &mut view) }));
    let mut counter = [0u32, u32::from(bytes.byte() % 4)];
    let mut simplified = ptr::null_mut();
    // SAFETY: the view's arrays live until `mesh` is freed; the counter outlives the call.
    let status = unsafe {
        balloon_simplify_with_progress(
            view.points,
            view.point_count,
            view.triangles,
            view.triangle_count,
            number(bytes, 0.2),
            Some(count_calls),
            counter.as_mut_ptr().cast(),
            &mut simplified,
        )
    };
    if ok(status) {
        let mut out = view;
        // SAFETY: the simplified mesh and a writable view.
        assert!(ok(unsafe { balloon_trimesh_view(simplified, &mut out) }));
        // Marching cubes turns its normals towards higher values, often inward; kept so.
        let report = report(&out).expect("a simplified mesh has triangles");
        assert!(
            report.closed() && report.manifold() && report.consistently_oriented(),
            "{report:?}"
        );
        // SAFETY: freed once.
        unsafe { balloon_trimesh_free(simplified) };
    } else {
        assert!(simplified.is_null(), "*out written on {status:?}");
    }
}
