"""Error-bounded simplification from Python: ``Mesh.simplify``, ``balloonseg.simplify`` with its
vertex map, and ``segment(..., simplify_mm=...)``. The bound is measured here, independently of
the library, with exact point-to-triangle distances (brute force in numpy) from points of each
mesh to the other mesh's triangles; the topology with the library's check kernel."""

import math

import numpy as np
import pytest

import balloonseg
from balloonseg.kernels import NO_VERTEX

GEOMETRY = dict(spacing=(0.9, 1.1, 1.0), origin=(-3.0, 2.0, 5.0))


def grid(n):
    z, y, x = np.mgrid[:n, :n, :n].astype(np.float64)
    c = (n - 1) / 2
    return x - c, y - c, z - c


def ball(n=22, radius=7.3):
    x, y, z = grid(n)
    return radius - np.sqrt(x**2 + y**2 + z**2)


def torus(n=26, major=7.0, minor=2.8):
    x, y, z = grid(n)
    return minor - np.sqrt((np.sqrt(x**2 + y**2) - major) ** 2 + z**2)


def point_triangle_distances(points, corners):
    """The exact distance from each point (N, 3) to the nearest of the triangles (M, 3, 3): the
    distance to the plane where the point projects inside a triangle, else to its nearest edge."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    normal = np.cross(b - a, c - a)
    unit = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    edges = [(u, v - u) for u, v in ((a, b), (b, c), (c, a))]
    # Pointing into the triangle, in its plane: a point projects inside when it is on the
    # inner side of all three edges (the plane offset does not change these dot products).
    inward = [np.cross(normal, e) for _, e in edges]
    best = np.full(len(points), np.inf)
    chunk = max(1, 300_000 // len(corners))
    for start in range(0, len(points), chunk):
        p = points[start : start + chunk, None, :]
        height = np.einsum("pmk,mk->pm", p - a, unit)
        inside = np.ones(height.shape, dtype=bool)
        for (u, _), towards in zip(edges, inward):
            inside &= np.einsum("pmk,mk->pm", p - u, towards) >= 0
        d = np.where(inside, np.abs(height), np.inf)
        for u, e in edges:
            t = np.clip(np.einsum("pmk,mk->pm", p - u, e) / np.sum(e * e, axis=1), 0, 1)
            d = np.minimum(d, np.linalg.norm(p - (u + t[..., None] * e), axis=2))
        best[start : start + chunk] = d.min(axis=1)
    return best


def surface_samples(mesh):
    """The vertices and, on every triangle, its edge midpoints and its centroid."""
    corners = mesh.points[mesh.triangles.astype(np.int64)]
    weights = np.array([[0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5], [1 / 3, 1 / 3, 1 / 3]])
    inner = np.einsum("wc,mck->mwk", weights, corners).reshape(-1, 3)
    return np.vstack([mesh.points, inner])


def hausdorff_both_ways(first, second):
    def one_way(source, target):
        corners = target.points[target.triangles.astype(np.int64)]
        return point_triangle_distances(surface_samples(source), corners).max()

    return one_way(first, second), one_way(second, first)


def test_the_distance_helper_is_exact_on_a_triangle():
    corners = np.array([[[0.0, 0, 0], [2, 0, 0], [0, 2, 0]]])
    points = np.array([[0.5, 0.5, 3], [3, 0, 0], [-1, -1, 0], [2, 2, 1], [0.25, 0.25, 0]])
    expected = [3, 1, math.sqrt(2), math.sqrt(3), 0]
    assert np.allclose(point_triangle_distances(points, corners), expected)


@pytest.mark.parametrize("shape, genus", [(ball, 0), (torus, 1)])
@pytest.mark.parametrize("bound", [0.1, 0.3])
def test_the_bound_holds_and_the_topology_is_kept(shape, genus, bound):
    mesh = balloonseg.marching_cubes(shape(), 0.0, **GEOMETRY)
    before = mesh.stats
    assert before["closed"] and before["genus"] == genus
    reduced = mesh.simplify(bound)
    assert isinstance(reduced, balloonseg.Mesh) and reduced is not mesh
    assert reduced.vertex_state is None
    after = balloonseg.check(reduced.points, reduced.triangles)
    assert after["closed"] and after["manifold"] and after["oriented"]
    assert after["self_intersecting_pairs"] == 0
    assert after["genus"] == genus and after["components"] == before["components"] == 1
    # Marching cubes orients normals towards higher values, inward here; that is kept.
    assert after["outward"] == before["outward"] and after["volume_mm3"] < 0
    assert after["triangles"] < 0.7 * before["triangles"]
    there, back = hausdorff_both_ways(reduced, mesh)
    assert there <= bound + 1e-9 and back <= bound + 1e-9, (there, back, bound)
    # A bound that large is nearly used up: the measurement sees real distances.
    assert max(there, back) > 0.3 * bound


def test_a_larger_bound_keeps_fewer_triangles_and_the_input_is_not_changed():
    mesh = balloonseg.marching_cubes(torus(), 0.0, **GEOMETRY)
    points, triangles = mesh.points.copy(), mesh.triangles.copy()
    fine, coarse = mesh.simplify(0.05), mesh.simplify(0.4)
    assert len(coarse.triangles) < len(fine.triangles) < len(mesh.triangles)
    assert np.array_equal(mesh.points, points) and np.array_equal(mesh.triangles, triangles)


def test_the_vertex_map_sends_every_input_point_to_its_output_vertex():
    mesh = balloonseg.marching_cubes(ball(), 0.0, **GEOMETRY)
    # An extra point that no triangle uses.
    points = np.vstack([mesh.points, [[100.0, 100.0, 100.0]]])
    reduced, vertex_map = balloonseg.simplify(points, mesh.triangles, 0.2)
    assert vertex_map.dtype == np.uint32 and len(vertex_map) == len(points)
    assert vertex_map[-1] == NO_VERTEX
    used = vertex_map[:-1]
    assert used.max() < len(reduced.points)
    assert np.array_equal(np.unique(used), np.arange(len(reduced.points)))
    # Collapses place a merged vertex anew, but a vertex no collapse reached keeps its input
    # position, so some input points are exactly where their output vertex is.
    assert np.all(reduced.points[used] == mesh.points, axis=1).any()


def test_progress_rises_in_the_simplification_phase_and_may_cancel():
    mesh = balloonseg.marching_cubes(torus(40, 12.0, 4.0), 0.0, **GEOMETRY)
    seen = []
    reduced = mesh.simplify(0.1, progress=lambda fraction, phase: seen.append((fraction, phase)))
    assert np.array_equal(reduced.points, mesh.simplify(0.1).points)
    assert np.array_equal(reduced.triangles, mesh.simplify(0.1).triangles)
    fractions = [f for f, _ in seen]
    assert len(seen) >= 2 and {phase for _, phase in seen} == {"simplification"}
    assert fractions == sorted(fractions) and 0 < fractions[0] and fractions[-1] <= 1
    calls = []
    with pytest.raises(balloonseg.CancelledError, match="cancelled"):
        balloonseg.simplify(mesh.points, mesh.triangles, 0.1, lambda f, p: calls.append(f) or True)
    assert len(calls) == 1

    class Stop(Exception):
        pass

    def raising(_fraction, _phase):
        raise Stop

    with pytest.raises(Stop):
        mesh.simplify(0.1, progress=raising)
    with pytest.raises(balloonseg.InvalidArgumentError, match="progress must be callable"):
        mesh.simplify(0.1, progress=3)


def test_segment_simplify_mm_bounds_the_balloon_and_keeps_its_states():
    volume = np.where(ball(n=24, radius=7.0) > 0, 200.0, 0.0)
    seed = (-3.0 + 0.9 * 11.5, 2.0 + 1.1 * 11.5, 5.0 + 11.5)
    window = dict(reference_intensity=200.0, tolerance=100.0, threads=2)
    full = balloonseg.segment(volume, seed, **GEOMETRY, **window)
    reduced = balloonseg.segment(volume, seed, **GEOMETRY, **window, simplify_mm=0.3)
    assert len(reduced.triangles) < len(full.triangles)
    s = reduced.stats
    assert s["closed"] and s["manifold"] and s["outward"] and s["genus"] == 0
    assert s["self_intersecting_pairs"] == 0 and s["components"] == 1
    assert reduced.vertex_state is not None and len(reduced.vertex_state) == len(reduced.points)
    assert set(np.unique(reduced.vertex_state)) <= set(np.unique(full.vertex_state))
    there, back = hausdorff_both_ways(reduced, full)
    assert there <= 0.3 + 1e-9 and back <= 0.3 + 1e-9, (there, back)
    # The parameter by its own name is the same thing; 0 is no simplification.
    same = balloonseg.segment(volume, seed, **GEOMETRY, **window, simplify_error_mm=0.3)
    assert np.array_equal(same.points, reduced.points)
    assert np.array_equal(same.triangles, reduced.triangles)
    off = balloonseg.segment(volume, seed, **GEOMETRY, **window, simplify_mm=0)
    assert np.array_equal(off.points, full.points)
    assert np.array_equal(off.triangles, full.triangles)


@pytest.mark.parametrize("bound", [0, -1, math.nan, math.inf, -math.inf])
def test_a_bound_that_is_not_a_positive_distance_is_refused(bound):
    mesh = balloonseg.marching_cubes(ball(), 0.0)
    with pytest.raises(balloonseg.InvalidArgumentError, match="positive distance"):
        mesh.simplify(bound)


@pytest.mark.parametrize("bound", [None, "0.1", True])
def test_a_bound_that_is_not_a_number_is_refused(bound):
    mesh = balloonseg.marching_cubes(ball(), 0.0)
    with pytest.raises(balloonseg.InvalidArgumentError, match="max_error_mm"):
        mesh.simplify(bound)


def test_meshes_it_cannot_simplify_are_refused_with_the_reason():
    mesh = balloonseg.marching_cubes(ball(), 0.0)
    with pytest.raises(balloonseg.InvalidMeshError, match="not closed"):
        balloonseg.Mesh(mesh.points, mesh.triangles[:-1]).simplify(0.1)
    with pytest.raises(balloonseg.InvalidMeshError, match="no triangles"):
        balloonseg.Mesh(np.zeros((0, 3)), np.zeros((0, 3))).simplify(0.1)
    flipped = mesh.triangles.copy()
    flipped[0] = flipped[0, ::-1]
    with pytest.raises(balloonseg.InvalidMeshError, match="consistently oriented"):
        balloonseg.Mesh(mesh.points, flipped).simplify(0.1)
    # Two copies of the sphere, one shifted into the other: closed and oriented, but crossing.
    n = len(mesh.points)
    two = balloonseg.Mesh(
        np.vstack([mesh.points, mesh.points + 1.0]),
        np.vstack([mesh.triangles, mesh.triangles + n]),
    )
    with pytest.raises(balloonseg.InvalidMeshError, match="intersect"):
        two.simplify(0.1)
    with pytest.raises(balloonseg.InvalidMeshError, match="but the mesh has"):
        balloonseg.simplify(mesh.points[:-1], mesh.triangles, 0.1)


def test_segment_refuses_a_bad_simplify_mm_before_it_runs():
    volume = np.where(ball(n=24, radius=7.0) > 0, 200.0, 0.0)
    seed = (11.5, 11.5, 11.5)
    for bad in (-0.1, math.nan, math.inf):
        with pytest.raises(balloonseg.InvalidArgumentError, match="simplify_error_mm is"):
            balloonseg.segment(volume, seed, simplify_mm=bad)
    with pytest.raises(balloonseg.InvalidArgumentError, match="same parameter"):
        balloonseg.segment(volume, seed, simplify_mm=0.1, simplify_error_mm=0.2)


def test_objects_meeting_in_one_bar_are_simplified_together_without_crossing():
    """Two objects seeded in one bar meet 0.12 mm apart; simplified in one pass, each stays
    valid, the two surfaces still do not cross, and each object keeps the bound to its own
    balloon (before the kernel's bound was per component, object 1's result had a point 0.212
    mm from its own balloon for a 0.2 mm bound)."""
    bar = np.zeros((16, 16, 30), np.float32)
    bar[4:12, 4:12, 4:26] = 200
    spacing, origin = (1.0, 1.25, 0.8), (-10.0, 5.0, 2.5)

    def world(i, j, k):
        return tuple(o + s * v for o, s, v in zip(origin, spacing, (i, j, k)))

    seeds = {1: world(8, 7.5, 7.5), 2: world(21, 7.5, 7.5)}
    window = dict(reference_intensity=200.0, tolerance=100.0, threads=2)
    full = balloonseg.segment(bar, seeds, spacing, origin, **window)
    reduced = balloonseg.segment(bar, seeds, spacing, origin, **window, simplify_mm=0.2)
    assert list(reduced) == [1, 2]
    for label, mesh in reduced.items():
        s = mesh.stats
        assert s["closed"] and s["manifold"] and s["outward"] and s["components"] == 1
        assert s["self_intersecting_pairs"] == 0 and s["genus"] == 0
        assert len(mesh.triangles) < len(full[label].triangles)
        assert len(mesh.vertex_state) == len(mesh.points)

    def together(meshes):
        first, second = meshes[1], meshes[2]
        return balloonseg.Mesh(
            np.vstack([first.points, second.points]),
            np.vstack([first.triangles, second.triangles + len(first.points)]),
        )

    both = together(reduced)
    assert len(balloonseg.self_intersections(both.points, both.triangles)) == 0
    there, back = hausdorff_both_ways(both, together(full))
    assert there <= 0.2 + 1e-9 and back <= 0.2 + 1e-9, (there, back)
    for label in (1, 2):
        there, back = hausdorff_both_ways(reduced[label], full[label])
        assert there <= 0.2 + 1e-9 and back <= 0.2 + 1e-9, (label, there, back)
