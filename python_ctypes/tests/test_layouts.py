"""Any memory layout and scalar type of the same voxels gives the identical mesh: the volume is
read in place through its strides (C, Fortran, negative, non-unit) and axis order."""

import numpy as np
import pytest
from conftest import assert_same_mesh, read_image

import balloonseg
from balloonseg._volume import volume_view

GEOMETRY = dict(spacing=(0.9, 1.0, 1.2), origin=(-3.0, 5.0, 7.5))


@pytest.fixture(scope="module")
def voxels_zyx(phantom):
    """The y-vessel phantom as small integers (0..100), which every scalar type holds exactly."""
    path, _ = phantom("y-vessel")
    image, voxels, _ = read_image(path)  # the view is valid while `image` lives
    v = np.array(voxels, dtype=np.float64)
    return np.round(100 * (v - v.min()) / (v.max() - v.min()))


@pytest.fixture(scope="module")
def seed(phantom):
    """The phantom's seed voxel, in the test's geometry."""
    path, world = phantom("y-vessel")
    image, _, _ = read_image(path)
    index = image.TransformPhysicalPointToContinuousIndex(world)
    return tuple(o + s * i for o, s, i in zip(GEOMETRY["origin"], GEOMETRY["spacing"], index))


@pytest.fixture(scope="module")
def reference(voxels_zyx, seed):
    return balloonseg.segment(voxels_zyx, seed, **GEOMETRY)


def negative_strides(a):
    """The same logical array, stored backwards along every axis."""
    backwards = np.ascontiguousarray(a[::-1, ::-1, ::-1])
    return backwards[::-1, ::-1, ::-1]


def spread(a):
    """The same logical array inside a bigger buffer: strides of 2 and 3 elements."""
    big = np.zeros((a.shape[0] * 2, a.shape[1] * 3, a.shape[2] + 1), dtype=a.dtype)
    big[::2, ::3, :-1] = a
    return big[::2, ::3, :-1]


LAYOUTS = {
    "c_order": (lambda a: np.ascontiguousarray(a), "zyx"),
    "fortran_order": (lambda a: np.asfortranarray(a), "zyx"),
    "negative_strides": (negative_strides, "zyx"),
    "non_unit_strides": (spread, "zyx"),
    "fortran_negative": (lambda a: negative_strides(np.asfortranarray(a)), "zyx"),
    "xyz_copy": (lambda a: np.ascontiguousarray(a.transpose(2, 1, 0)), "xyz"),
    "xyz_view": (lambda a: a.transpose(2, 1, 0), "xyz"),
    "yxz_view": (lambda a: a.transpose(1, 2, 0), "yxz"),
}


@pytest.mark.parametrize("layout", LAYOUTS)
def test_every_layout_gives_the_identical_mesh(layout, voxels_zyx, seed, reference):
    make, axes = LAYOUTS[layout]
    volume = make(voxels_zyx)
    assert np.shares_memory(volume, volume_view(volume, **GEOMETRY, direction=None, axes=axes)[1])
    mesh = balloonseg.segment(volume, seed, axes=axes, **GEOMETRY)
    assert_same_mesh(mesh, reference.points, reference.triangles, reference.vertex_state)


@pytest.mark.parametrize(
    "dtype", ["uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64"]
)
def test_every_scalar_type_gives_the_identical_mesh(dtype, voxels_zyx, seed, reference):
    volume = voxels_zyx.astype(dtype)
    mesh = balloonseg.segment(volume, seed, **GEOMETRY)
    assert_same_mesh(mesh, reference.points, reference.triangles, reference.vertex_state)


def test_the_view_points_at_element_zero_with_element_strides():
    a = np.arange(4 * 5 * 6, dtype=np.int16).reshape(4, 5, 6)
    view, kept = volume_view(a[::-1, :, ::2], (1, 1, 1), (0, 0, 0), None, "zyx")
    assert np.shares_memory(kept, a)
    assert list(view.dims) == [3, 5, 4]
    assert list(view.strides) == [2, 6, -30]
    assert view.data == a.__array_interface__["data"][0] + 3 * 30 * a.itemsize


def test_the_volume_is_not_copied_and_stays_alive(voxels_zyx, seed, reference):
    volume = np.ascontiguousarray(voxels_zyx, dtype=np.float32)
    segmenter = balloonseg.Segmenter(volume, seed, **GEOMETRY)
    del volume  # the segmenter keeps the array alive
    mesh = segmenter.segment()
    segmenter.close()
    assert_same_mesh(mesh, reference.points, reference.triangles)
