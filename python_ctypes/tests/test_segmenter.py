"""The Segmenter step by step, its progress callback (which may cancel, or raise), several seeds,
and the lifetime of the meshes it hands out."""

import numpy as np
import pytest
from conftest import assert_same_mesh, assert_valid_surface, read_image

import balloonseg

PHASES = {"inflation", "self-intersection", "reparametrization", "refinement", "validation"}


@pytest.fixture(scope="module")
def torus(phantom):
    path, seed = phantom("torus")
    image, voxels, geometry = read_image(path)
    return image, voxels, geometry, seed


@pytest.fixture(scope="module")
def y_vessel(phantom):
    path, seed = phantom("y-vessel")
    image, voxels, geometry = read_image(path)
    return image, voxels, geometry, seed


def test_step_by_step(torus):
    _, voxels, geometry, seed = torus
    with balloonseg.Segmenter(voxels, seed, **geometry) as s:
        start = s.mesh
        assert start.vertex_state is not None and len(start.vertex_state) == len(start.points)
        moving = s.step(20)
        assert 0 < moving <= len(s.mesh.points)
        grown = s.mesh
        s.step(400)
        assert len(s.mesh.points) > len(grown.points)
        assert len(grown.points) > len(start.points)
        assert s.stats["iterations"] >= 20
        frozen = s.freeze_self_intersections()
        assert frozen >= 0
        s.reparametrize()
        assert s.stats["reparametrizations"] == 1
        assert s.mesh.stats["closed"]


def test_a_mesh_is_a_copy_that_stays_valid(y_vessel):
    _, voxels, geometry, seed = y_vessel
    s = balloonseg.Segmenter(voxels, seed, **geometry)
    s.step(5)
    mesh = s.mesh
    points = mesh.points.copy()
    s.step(50)
    s.close()
    assert np.array_equal(mesh.points, points)
    assert mesh.points.flags.owndata or mesh.points.base is not None


def test_progress_is_reported_with_fractions_and_phases(y_vessel):
    _, voxels, geometry, seed = y_vessel
    calls = []
    mesh = balloonseg.segment(voxels, seed, progress=lambda f, p: calls.append((f, p)), **geometry)
    assert calls, "the callback was never called"
    assert {p for _, p in calls} <= PHASES
    assert all(0.0 <= f <= 1.0 for f, _ in calls)
    assert calls[-1] == (1.0, "validation")
    assert_same_mesh(mesh, *_plain(voxels, seed, geometry))


def test_a_simplification_reports_the_second_half_of_the_run(y_vessel):
    _, voxels, geometry, seed = y_vessel
    calls = []
    mesh = balloonseg.segment(
        voxels, seed, progress=lambda f, p: calls.append((f, p)), simplify_mm=0.1, **geometry
    )
    method = [f for f, p in calls if p != "simplification"]
    simplification = [f for f, p in calls if p == "simplification"]
    assert method and simplification, calls
    assert {p for _, p in calls} <= PHASES | {"simplification"}
    assert all(0.0 <= f <= 0.5 for f in method)
    assert all(0.5 <= f <= 1.0 for f in simplification)
    assert calls[-1][1] == "simplification"
    assert mesh.stats["seconds"]["simplification"] > 0.0


def _plain(voxels, seed, geometry):
    m = balloonseg.segment(voxels, seed, **geometry)
    return m.points, m.triangles, m.vertex_state


def test_returning_true_cancels_and_the_segmenter_stays_usable(y_vessel):
    _, voxels, geometry, seed = y_vessel
    calls = []

    def cancel_at_the_tenth_call(fraction, phase):
        calls.append(phase)
        return len(calls) >= 10

    s = balloonseg.Segmenter(voxels, seed, progress=cancel_at_the_tenth_call, **geometry)
    with pytest.raises(balloonseg.CancelledError, match="cancel") as caught:
        s.segment()
    assert caught.value.status == 7
    assert len(calls) == 10
    s.progress = None
    mesh = s.segment()
    assert_valid_surface(mesh)
    assert len(calls) == 10, "the callback was removed"
    s.close()


class Boom(RuntimeError):
    pass


def test_an_exception_in_the_callback_cancels_and_is_raised_after_the_call(y_vessel):
    _, voxels, geometry, seed = y_vessel

    def explode(fraction, phase):
        raise Boom(f"at {phase}")

    with balloonseg.Segmenter(voxels, seed, progress=explode, **geometry) as s:
        with pytest.raises(Boom, match="at inflation"):
            s.step(10)
        with pytest.raises(Boom):
            s.segment()
        s.progress = lambda f, p: None
        assert_valid_surface(s.segment())


def test_several_seeds(y_vessel):
    _, voxels, geometry, seed = y_vessel
    image, *_ = y_vessel
    index = np.array(image.TransformPhysicalPointToContinuousIndex(seed))
    second = image.TransformContinuousIndexToPhysicalPoint(tuple(index + [0, 0, 1]))
    one_call = balloonseg.segment(voxels, [seed, second], **geometry)
    with balloonseg.Segmenter(voxels, seed, **geometry) as s:
        s.add_seed(second)
        assert_same_mesh(one_call, *(lambda m: (m.points, m.triangles))(s.segment()))
    assert_valid_surface(one_call)


def test_default_params_and_parameter_names():
    defaults = balloonseg.default_params()
    assert set(defaults) == set(balloonseg.PARAMETERS)
    assert np.isnan(defaults["tolerance"]) and defaults["max_iterations"] > 0
    assert balloonseg.version().split(".")[0] == balloonseg.__version__.split(".")[0]


def test_the_thread_count_does_not_change_the_mesh(y_vessel):
    _, voxels, geometry, seed = y_vessel
    one = balloonseg.segment(voxels, seed, threads=1, **geometry)
    two = balloonseg.segment(voxels, seed, threads=2, **geometry)
    assert_same_mesh(one, two.points, two.triangles, two.vertex_state)


def test_segmenters_in_parallel_python_threads(y_vessel, torus):
    """ctypes releases the GIL during calls: two segmenters run at once, each as alone."""
    from concurrent.futures import ThreadPoolExecutor

    cases = [(c[1], c[3], c[2]) for c in (y_vessel, torus, y_vessel)]

    def run(case):
        volume, seed, geometry = case
        return balloonseg.segment(volume, seed, threads=1, **geometry)

    alone = [run(c) for c in cases]
    with ThreadPoolExecutor(3) as pool:
        together = list(pool.map(run, cases))
    for a, b in zip(alone, together):
        assert_same_mesh(a, b.points, b.triangles, b.vertex_state)
