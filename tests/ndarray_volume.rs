//! The balloon and marching cubes read an ndarray view in place (feature `ndarray`): whatever
//! its layout, the mesh is the one from the same voxels as a contiguous buffer. Run in release
//! mode (`cargo test --release --features ndarray`).

use balloonseg::balloon::{BalloonParams, Segmenter};
use balloonseg::marching_cubes::marching_cubes;
use balloonseg::phantom::{self, Phantom, PhantomOptions, Shape};
use balloonseg::{AxisOrder, TriMesh, Volume, VoxelBuffer};
use ndarray::{s, Array3, ArrayView3, ShapeBuilder};

/// A noisy torus on an oblique, anisotropic grid, as in the phantom tests.
fn torus() -> Phantom {
    phantom::render(
        Shape::Torus,
        &PhantomOptions {
            spacing: [0.8, 0.8, 1.5],
            direction: phantom::oblique_direction(),
            noise: 0.1,
            ..PhantomOptions::default()
        },
    )
    .unwrap()
}

/// The balloon's mesh and the isosurface halfway between background and foreground.
fn meshes(volume: Volume<'_>, phantom: &Phantom) -> (TriMesh, TriMesh) {
    let mut segmenter =
        Segmenter::new(volume, BalloonParams::default(), phantom.seed_world()).unwrap();
    let (balloon, _) = segmenter.segment().unwrap();
    (balloon, marching_cubes(&volume, 600.0).unwrap())
}

/// Checks the view's meshes against the contiguous image's.
fn assert_same_meshes(view: ArrayView3<'_, f32>, axes: AxisOrder, phantom: &Phantom) {
    let expected = meshes(phantom.image.view(), phantom);
    let volume = Volume::from_ndarray(view, axes, *phantom.image.geometry()).unwrap();
    assert_eq!(volume.dims(), phantom.image.dims());
    let (balloon, isosurface) = meshes(volume, phantom);
    assert!(!balloon.is_empty() && !isosurface.is_empty());
    assert!(balloon == expected.0, "the balloon differs");
    assert!(isosurface == expected.1, "the isosurface differs");
}

/// The phantom's voxels and dims (x, y, z).
fn voxels(phantom: &Phantom) -> (&[f32], [usize; 3]) {
    let VoxelBuffer::F32(values) = phantom.image.buffer() else {
        unreachable!("phantoms are float32")
    };
    (values, phantom.image.dims())
}

#[test]
fn c_order_zyx() {
    let phantom = torus();
    let (values, [nx, ny, nz]) = voxels(&phantom);
    let array = ArrayView3::from_shape((nz, ny, nx), values).unwrap();
    assert_same_meshes(array, AxisOrder::Zyx, &phantom);
}

#[test]
fn fortran_order_xyz_and_reversed_axes() {
    let phantom = torus();
    let (values, [nx, ny, nz]) = voxels(&phantom);
    // The same buffer, i fastest, is a Fortran-ordered xyz array.
    let fortran = ArrayView3::from_shape((nx, ny, nz).f(), values).unwrap();
    assert_same_meshes(fortran, AxisOrder::Xyz, &phantom);
    // A copy with k fastest, read as zyx through reversed axes.
    let xyz = fortran.as_standard_layout().into_owned();
    assert_same_meshes(xyz.view().reversed_axes(), AxisOrder::Zyx, &phantom);
}

#[test]
fn negative_strides() {
    let phantom = torus();
    let (values, [nx, ny, nz]) = voxels(&phantom);
    let zyx = ArrayView3::from_shape((nz, ny, nx), values).unwrap();
    // Stored upside down and mirrored in x; the view flips both back.
    let flipped = zyx
        .slice(s![..;-1, .., ..;-1])
        .as_standard_layout()
        .into_owned();
    assert_same_meshes(
        flipped.slice(s![..;-1, .., ..;-1]),
        AxisOrder::Zyx,
        &phantom,
    );
}

#[test]
fn stepped_view() {
    let phantom = torus();
    let (values, [nx, ny, nz]) = voxels(&phantom);
    let zyx = ArrayView3::from_shape((nz, ny, nx), values).unwrap();
    // The voxels on every other row of a twice-as-tall array, NaN on the rest.
    let mut sparse = Array3::from_elem((nz, 2 * ny, nx), f32::NAN);
    sparse.slice_mut(s![.., ..;2, ..]).assign(&zyx);
    assert_same_meshes(sparse.slice(s![.., ..;2, ..]), AxisOrder::Zyx, &phantom);
}

#[test]
fn one_half_of_an_interleaved_array_while_the_other_half_is_written() {
    let phantom = torus();
    let (values, [nx, ny, nz]) = voxels(&phantom);
    let zyx = ArrayView3::from_shape((nz, ny, nx), values).unwrap();
    let mut both = Array3::zeros((2 * nz, ny, nx));
    both.slice_mut(s![..;2, .., ..]).assign(&zyx);
    let (even, mut odd) = both.multi_slice_mut((s![..;2, .., ..], s![1..;2, .., ..]));
    std::thread::scope(|scope| {
        scope.spawn(|| {
            for round in 0..1000 {
                odd.fill(round as f32);
            }
        });
        assert_same_meshes(even.view(), AxisOrder::Zyx, &phantom);
    });
    assert!(both.slice(s![1..;2, .., ..]).iter().all(|&v| v == 999.0));
}
