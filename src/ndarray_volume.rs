//! Volumes from ndarray views (feature `ndarray`): an [`ArrayView3`] of any supported scalar is
//! read in place as a [`TypedVolume`] or [`Volume`], its strides (negative, stepped, C or
//! Fortran order) passed through, never copied.
//!
//! ```
//! use balloonseg::balloon::{BalloonParams, Segmenter};
//! use balloonseg::{AxisOrder, Geometry, Volume};
//! use glam::DVec3;
//! use ndarray::{s, Array3};
//!
//! // volume[[k, j, i]], C order, as SimpleITK gives it: a bright ball of radius 6 mm in
//! // 1 mm voxels.
//! let voxels = Array3::from_shape_fn((24, 24, 24), |(k, j, i)| {
//!     let r = DVec3::new(i as f64, j as f64, k as f64).distance(DVec3::splat(11.5));
//!     if r < 6.0 { 1000i16 } else { 0 }
//! });
//! // The volume read from k = 23 down to 0, in place.
//! let flipped = voxels.slice(s![..;-1, .., ..]);
//! let volume = Volume::from_ndarray(flipped, AxisOrder::Zyx, Geometry::identity())?;
//! let seed = DVec3::splat(11.5); // world mm
//! let (mesh, _states) = Segmenter::new(volume, BalloonParams::default(), seed)?.segment()?;
//! assert!(balloonseg::mesh_checks::check(&mesh).is_valid_closed_surface());
//! # Ok::<(), balloonseg::Error>(())
//! ```

use ndarray::ArrayView3;

use crate::error::Result;
use crate::geometry::Geometry;
use crate::volume::{address_range, Scalar, TypedVolume, Volume};

/// Which array index is which volume axis, as the Python package's `axes`. Volume index i is
/// x, the fastest axis of VTK and ITK; spacing, origin and direction are always (x, y, z).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AxisOrder {
    /// `array[[k, j, i]]`, as numpy, SimpleITK's `GetArrayFromImage` and VTK's `vtk_to_numpy`
    /// give a volume in C order (`axes="zyx"`).
    Zyx,
    /// `array[[i, j, k]]`, as nibabel gives it (`axes="xyz"`).
    Xyz,
}

impl AxisOrder {
    /// The array axis that holds volume axis `a` (0 = i, 1 = j, 2 = k).
    fn array_axis(self, a: usize) -> usize {
        match self {
            AxisOrder::Zyx => 2 - a,
            AxisOrder::Xyz => a,
        }
    }
}

impl<'a, T: Scalar> TypedVolume<'a, T> {
    /// The voxels of `array`, read in place for `'a`, with `axes` saying which array index is
    /// which volume axis. An empty array is an invalid-volume error.
    pub fn from_ndarray(
        array: ArrayView3<'a, T>,
        axes: AxisOrder,
        geometry: Geometry,
    ) -> Result<Self> {
        let dims = [0, 1, 2].map(|a| array.shape()[axes.array_axis(a)]);
        let strides = [0, 1, 2].map(|a| array.strides()[axes.array_axis(a)]);
        address_range(dims, strides).map_err(|e| {
            e.context(format!(
                "an ndarray view of shape {:?} read as {axes:?}",
                array.shape()
            ))
        })?;
        // SAFETY: `address_range` accepted the layout, and an ArrayView3 promises that every
        // element its shape and strides address from `as_ptr` is an initialised, aligned T
        // inside one allocation, readable and not written for 'a; the volume addresses the
        // same elements, its axes permuted.
        Ok(unsafe { TypedVolume::from_raw_parts(array.as_ptr(), dims, strides, geometry) })
    }
}

impl<'a> Volume<'a> {
    /// [`TypedVolume::from_ndarray`] for any of the supported scalar types.
    pub fn from_ndarray<T: Scalar>(
        array: ArrayView3<'a, T>,
        axes: AxisOrder,
        geometry: Geometry,
    ) -> Result<Self>
    where
        Volume<'a>: From<TypedVolume<'a, T>>,
    {
        TypedVolume::from_ndarray(array, axes, geometry).map(Volume::from)
    }
}

#[cfg(test)]
mod tests {
    use ndarray::{s, Array3, ShapeBuilder};

    use super::*;
    use crate::error::ErrorKind;
    use crate::marching_cubes::marching_cubes;
    use crate::mesh::TriMesh;
    use crate::volume::ScalarType;

    const DIMS: [usize; 3] = [7, 6, 5];

    /// A closed, wobbly surface through many cubes at level 0, at voxel (i, j, k).
    fn field(i: usize, j: usize, k: usize) -> f64 {
        let (x, y, z) = (i as f64 - 3.1, j as f64 - 2.6, k as f64 - 2.2);
        (x * x + y * y + z * z).sqrt() - 1.9 + 0.3 * (1.7 * x).sin() * (1.3 * y).cos()
    }

    /// The field as a contiguous buffer, i fastest.
    fn contiguous_field() -> Vec<f64> {
        let [nx, ny, nz] = DIMS;
        (0..nx * ny * nz)
            .map(|n| field(n % nx, n / nx % ny, n / (nx * ny)))
            .collect()
    }

    /// The field as `array[[k, j, i]]`, C order.
    fn zyx() -> Array3<f64> {
        let [nx, ny, nz] = DIMS;
        Array3::from_shape_fn((nz, ny, nx), |(k, j, i)| field(i, j, k))
    }

    fn geometry() -> Geometry {
        Geometry::with_spacing([0.7, 1.2, 2.0], [1.0, 2.0, 3.0]).unwrap()
    }

    fn expected_mesh() -> TriMesh {
        let data = contiguous_field();
        let volume = TypedVolume::contiguous(&data, DIMS, geometry()).unwrap();
        marching_cubes(&volume.into(), 0.0).unwrap()
    }

    /// Checks every voxel against the field, then that marching cubes gives the contiguous
    /// buffer's mesh.
    fn assert_same_as_contiguous(volume: TypedVolume<'_, f64>) {
        assert_eq!(volume.dims(), DIMS);
        for k in 0..DIMS[2] {
            for j in 0..DIMS[1] {
                for i in 0..DIMS[0] {
                    assert_eq!(volume.get(i, j, k), field(i, j, k), "voxel {i}, {j}, {k}");
                }
            }
        }
        let mesh = marching_cubes(&volume.into(), 0.0).unwrap();
        assert!(!mesh.is_empty());
        assert_eq!(mesh, expected_mesh());
    }

    #[test]
    fn c_order_zyx_is_read_in_place_with_i_rows_as_slices() {
        let array = zyx();
        let volume = TypedVolume::from_ndarray(array.view(), AxisOrder::Zyx, geometry()).unwrap();
        assert_eq!(volume.strides(), [1, 7, 42]);
        assert_eq!(volume.row(0, 0).unwrap().as_ptr(), array.as_ptr());
        assert_same_as_contiguous(volume);
    }

    #[test]
    fn fortran_order_reads_as_xyz_or_through_reversed_axes() {
        let [nx, ny, nz] = DIMS;
        let fortran = Array3::from_shape_fn((nx, ny, nz).f(), |(i, j, k)| field(i, j, k));
        let volume = TypedVolume::from_ndarray(fortran.view(), AxisOrder::Xyz, geometry());
        assert_same_as_contiguous(volume.unwrap());
        // A C-ordered xyz array with its axes reversed is Fortran-ordered zyx: k fastest.
        let xyz = Array3::from_shape_fn((nx, ny, nz), |(i, j, k)| field(i, j, k));
        let reversed = xyz.view().reversed_axes();
        let volume = TypedVolume::from_ndarray(reversed, AxisOrder::Zyx, geometry()).unwrap();
        assert_eq!(volume.strides(), [(ny * nz) as isize, nz as isize, 1]);
        assert!(volume.row(0, 0).is_none());
        assert_same_as_contiguous(volume);
    }

    #[test]
    fn negative_strides_are_passed_through() {
        let [nx, ny, nz] = DIMS;
        // Stored with k and i reversed; the view flips them back.
        let stored =
            Array3::from_shape_fn((nz, ny, nx), |(k, j, i)| field(nx - 1 - i, j, nz - 1 - k));
        let view = stored.slice(s![..;-1, .., ..;-1]);
        let volume = TypedVolume::from_ndarray(view, AxisOrder::Zyx, geometry()).unwrap();
        assert_eq!(volume.strides(), [-1, 7, -42]);
        assert_same_as_contiguous(volume);
    }

    #[test]
    fn stepped_views_are_read_without_copying() {
        let [nx, ny, nz] = DIMS;
        // The field on every second k and every third i, NaN between.
        let sparse = Array3::from_shape_fn((2 * nz, ny, 3 * nx), |(k, j, i)| {
            if k % 2 == 0 && i % 3 == 0 {
                field(i / 3, j, k / 2)
            } else {
                f64::NAN
            }
        });
        let view = sparse.slice(s![..;2, .., ..;3]);
        let volume = TypedVolume::from_ndarray(view, AxisOrder::Zyx, geometry()).unwrap();
        assert_eq!(
            volume.strides(),
            [3, 3 * nx as isize, 6 * (nx * ny) as isize]
        );
        assert_same_as_contiguous(volume);
    }

    #[test]
    fn the_other_half_of_an_interleaved_array_can_be_written_meanwhile() {
        let [nx, ny, nz] = DIMS;
        let mut both = Array3::from_shape_fn((2 * nz, ny, nx), |(k, j, i)| {
            if k % 2 == 0 {
                field(i, j, k / 2)
            } else {
                0.0
            }
        });
        let expected = expected_mesh();
        let (even, mut odd) = both.multi_slice_mut((s![..;2, .., ..], s![1..;2, .., ..]));
        let volume = TypedVolume::from_ndarray(even.view(), AxisOrder::Zyx, geometry()).unwrap();
        std::thread::scope(|scope| {
            scope.spawn(|| {
                for round in 0..100 {
                    odd.fill(f64::from(round));
                }
            });
            assert_eq!(marching_cubes(&volume.into(), 0.0).unwrap(), expected);
        });
        assert!(both.slice(s![1..;2, .., ..]).iter().all(|&v| v == 99.0));
    }

    #[test]
    fn every_scalar_type_makes_a_volume_of_its_type() {
        fn check<T: Scalar>(expected: ScalarType)
        where
            for<'a> Volume<'a>: From<TypedVolume<'a, T>>,
        {
            let array = Array3::from_shape_fn((2, 3, 4), |(k, j, i)| {
                T::from_f64((i + 4 * j + 12 * k) as f64)
            });
            let volume = Volume::from_ndarray(array.view(), AxisOrder::Zyx, geometry()).unwrap();
            assert_eq!(volume.scalar_type(), expected);
            assert_eq!(volume.dims(), [4, 3, 2]);
            assert_eq!(volume.get_f64(3, 1, 1), 19.0);
            let volume = Volume::from_ndarray(array.view(), AxisOrder::Xyz, geometry()).unwrap();
            assert_eq!(volume.dims(), [2, 3, 4]);
            assert_eq!(volume.get_f64(1, 1, 3), 19.0);
        }
        check::<u8>(ScalarType::U8);
        check::<i8>(ScalarType::I8);
        check::<u16>(ScalarType::U16);
        check::<i16>(ScalarType::I16);
        check::<u32>(ScalarType::U32);
        check::<i32>(ScalarType::I32);
        check::<f32>(ScalarType::F32);
        check::<f64>(ScalarType::F64);
    }

    #[test]
    fn empty_arrays_are_invalid_volumes() {
        for shape in [(0, 3, 4), (2, 0, 4), (2, 3, 0)] {
            let array = Array3::<u8>::zeros(shape);
            let e = Volume::from_ndarray(array.view(), AxisOrder::Zyx, geometry()).unwrap_err();
            assert_eq!(e.kind(), ErrorKind::InvalidVolume);
            assert!(
                e.message().contains("ndarray view of shape") && e.message().contains("is 0"),
                "{e}"
            );
        }
        let sliced = Array3::<i16>::zeros((2, 3, 4));
        let e = Volume::from_ndarray(sliced.slice(s![.., 1..1, ..]), AxisOrder::Xyz, geometry());
        assert_eq!(e.unwrap_err().kind(), ErrorKind::InvalidVolume);
    }

    #[test]
    fn broadcast_views_repeat_voxels() {
        let plane = Array3::from_shape_fn((1, 6, 7), |(_, j, i)| field(i, j, 0));
        let view = plane.broadcast((5, 6, 7)).unwrap();
        let volume = TypedVolume::from_ndarray(view, AxisOrder::Zyx, geometry()).unwrap();
        assert_eq!(volume.strides(), [1, 7, 0]);
        assert_eq!(volume.get(2, 3, 4), field(2, 3, 0));
    }
}
