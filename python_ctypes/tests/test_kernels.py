"""The kernels on their own: marching cubes, mesh checks, self-intersections."""

import numpy as np
import pytest

import balloonseg


def ball_distance(n=24, radius=8.0):
    z, y, x = np.mgrid[:n, :n, :n].astype(np.float64)
    c = (n - 1) / 2
    return radius - np.sqrt((x - c) ** 2 + (y - c) ** 2 + (z - c) ** 2)


def tetrahedron(shift=(0.0, 0.0, 0.0)):
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64) + shift
    triangles = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.uint32)
    return points, triangles


def test_marching_cubes_of_a_ball():
    spacing = (0.5, 0.5, 0.5)
    mesh = balloonseg.marching_cubes(ball_distance(), 0.0, spacing=spacing)
    assert mesh.vertex_state is None
    s = mesh.stats
    assert s["closed"] and s["manifold"]
    assert s["genus"] == 0 and s["components"] == 1 and s["self_intersecting_pairs"] == 0
    # Normals point towards higher values (the inside here), so the signed volume is negative.
    assert abs(abs(s["volume_mm3"]) - 4 / 3 * np.pi * 4.0**3) < 0.05 * 4 / 3 * np.pi * 4.0**3


@pytest.mark.parametrize("dtype", ["float32", "int16"])
def test_marching_cubes_reads_any_layout(dtype):
    volume = np.round(ball_distance() * 10).astype(dtype)
    geometry = dict(spacing=(0.7, 1.0, 1.3), origin=(1.0, 2.0, 3.0), direction=np.diag([-1, -1, 1]))
    reference = balloonseg.marching_cubes(np.ascontiguousarray(volume), 0.5, **geometry)
    for view, axes in [
        (np.asfortranarray(volume), "zyx"),
        (volume.transpose(2, 1, 0), "xyz"),
        (np.ascontiguousarray(volume[::-1])[::-1], "zyx"),
    ]:
        mesh = balloonseg.marching_cubes(view, 0.5, axes=axes, threads=1, **geometry)
        assert np.array_equal(mesh.points, reference.points)
        assert np.array_equal(mesh.triangles, reference.triangles)
    # world = origin + D (spacing * index): the first axis is flipped by the direction.
    assert reference.points[:, 0].max() < 1.0 and reference.points[:, 2].min() > 3.0


def test_check_of_a_tetrahedron():
    report = balloonseg.check(*tetrahedron())
    assert report == {
        "vertices": 4,
        "triangles": 4,
        "closed": True,
        "manifold": True,
        "oriented": True,
        "outward": True,
        "self_intersecting_pairs": 0,
        "euler_characteristic": 2,
        "genus": 0,
        "components": 1,
        "area_mm2": pytest.approx(1.5 + np.sqrt(3) / 2),
        "volume_mm3": pytest.approx(1 / 6),
    }


def test_check_of_an_open_mesh_has_no_genus():
    points, triangles = tetrahedron()
    report = balloonseg.check(points, triangles[:3])
    assert not report["closed"] and report["genus"] is None


def test_self_intersections_of_two_overlapping_tetrahedra():
    p0, t0 = tetrahedron()
    p1, t1 = tetrahedron((0.2, 0.2, 0.2))
    points = np.vstack([p0, p1])
    triangles = np.vstack([t0, t1 + 4]).astype(np.int64)
    pairs = balloonseg.self_intersections(points, triangles)
    assert pairs.dtype == np.uint32 and pairs.ndim == 2 and pairs.shape[1] == 2
    assert len(pairs) > 0
    assert np.all(pairs[:, 0] < pairs[:, 1])
    assert np.all(pairs[:, 0] < 4) and np.all(pairs[:, 1] >= 4)
    assert balloonseg.check(points, triangles)["self_intersecting_pairs"] == len(pairs)
    none = balloonseg.self_intersections(*tetrahedron())
    assert none.shape == (0, 2)


@pytest.mark.parametrize(
    "points, triangles",
    [
        (np.zeros((4, 2)), [[0, 1, 2]]),
        (np.zeros((4, 3)), [[0, 1]]),
        (np.zeros((4, 3)), [[0, -1, 2]]),
        (np.zeros((4, 3)), [[0.5, 1, 2]]),
    ],
)
def test_malformed_arrays(points, triangles):
    with pytest.raises(balloonseg.InvalidMeshError):
        balloonseg.check(points, triangles)
