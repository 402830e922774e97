"""Several objects at once through ``segment(seed={label: points}, stop=..., roi=...)`` and
``segment_objects``, on synthetic numpy volumes: labels, the one-object case, stop seeds, the
region of interest, progress, and bad input."""

import numpy as np
import pytest
from conftest import assert_same_mesh, assert_valid_surface

import balloonseg
from balloonseg import _library

#: The window is given, so that nothing is estimated.
WINDOW = dict(reference_intensity=200.0, tolerance=100.0)
SPACING = (1.0, 1.25, 0.8)
ORIGIN = (-10.0, 5.0, 2.5)


def world(i, j, k):
    return tuple(o + s * v for o, s, v in zip(ORIGIN, SPACING, (i, j, k)))


@pytest.fixture(scope="module")
def balls():
    """Two bright balls of radius 4.5 voxels, apart, in a (k, j, i) = (24, 24, 30) volume."""
    k, j, i = np.mgrid[:24, :24, :30]
    inside = lambda c: (i - c) ** 2 + (j - 12) ** 2 + (k - 12) ** 2 <= 4.5**2  # noqa: E731
    return ((inside(8) | inside(21)) * 200).astype(np.int16), world(8, 12, 12), world(21, 12, 12)


@pytest.fixture(scope="module")
def bar():
    """One bright bar along i (i = 4..25): two seeds in it give two objects that meet."""
    bar = np.zeros((16, 16, 30), np.float32)
    bar[4:12, 4:12, 4:26] = 200
    return bar, world(8, 7.5, 7.5), world(21, 7.5, 7.5)


def run(volume, seed, **kwargs):
    return balloonseg.segment(volume, seed, SPACING, ORIGIN, **WINDOW, **kwargs)


def x_range(mesh):
    return mesh.points[:, 0].min(), mesh.points[:, 0].max()


def test_two_labels_give_a_dict_of_valid_meshes_in_the_order_given(balls):
    volume, a, b = balls
    meshes = run(volume, {7: b, 3: [a]})
    assert list(meshes) == [7, 3]
    for label, centre in ((7, b), (3, a)):
        mesh = meshes[label]
        assert isinstance(mesh, balloonseg.Mesh)
        assert_valid_surface(mesh)
        assert mesh.stats["label"] == label and mesh.stats["components"] == 1
        assert mesh.stats["iterations"] > 0 and mesh.stats["reference_intensity"] == 200.0
        lo, hi = x_range(mesh)
        assert lo < centre[0] < hi and hi - lo < 11, (label, lo, hi)
        assert mesh.vertex_state is not None and len(mesh.vertex_state) == len(mesh.points)
    volumes = [m.stats["volume_mm3"] for m in meshes.values()]
    assert abs(volumes[0] - volumes[1]) < 0.05 * volumes[0], volumes


def test_one_object_is_a_mesh_and_the_same_as_a_plain_seed(balls):
    volume, a, _ = balls
    plain = run(volume, a)
    one_label = run(volume, {5: a})
    assert isinstance(one_label, balloonseg.Mesh)
    assert_same_mesh(one_label, plain.points, plain.triangles, plain.vertex_state)
    assert one_label.stats["label"] == 5
    as_dict = balloonseg.segment_objects(volume, np.array([a]), SPACING, ORIGIN, **WINDOW)
    assert list(as_dict) == [1]
    assert_same_mesh(as_dict[1], plain.points, plain.triangles, plain.vertex_state)


def test_two_objects_in_one_structure_meet_without_crossing(bar):
    volume, a, b = bar
    meshes = run(volume, {1: a, 2: b})
    left, right = meshes[1], meshes[2]
    for mesh in (left, right):
        assert_valid_surface(mesh)
    # Together they fill the bar, each its own side of the contact.
    assert x_range(left)[1] < x_range(right)[0] + 2.0
    assert x_range(left)[0] < world(5, 0, 0)[0] and x_range(right)[1] > world(24, 0, 0)[0]
    points = np.vstack([left.points, right.points])
    triangles = np.vstack([left.triangles, right.triangles + len(left.points)])
    assert len(balloonseg.self_intersections(points, triangles)) == 0, "the objects cross"
    bar_volume = 8 * 8 * 22 * np.prod(SPACING)
    total = left.stats["volume_mm3"] + right.stats["volume_mm3"]
    assert 0.8 * bar_volume < total < 1.1 * bar_volume, (total, bar_volume)


def test_a_stop_seed_keeps_the_object_out_and_is_not_returned(bar):
    volume, a, b = bar
    alone = run(volume, a)
    stopped = run(volume, a, stop=b)
    assert isinstance(stopped, balloonseg.Mesh)
    assert_valid_surface(stopped)
    assert x_range(alone)[1] > world(24, 0, 0)[0], "without a stop seed it fills the bar"
    assert x_range(stopped)[1] < b[0], "the stop seed's balloon holds it back"
    several = balloonseg.segment_objects(volume, {2: a}, SPACING, ORIGIN, stop=[b], **WINDOW)
    assert list(several) == [2]
    assert_same_mesh(several[2], stopped.points, stopped.triangles, stopped.vertex_state)


def test_a_region_of_interest_cuts_the_object(balls):
    volume, a, _ = balls
    end = a[0] + 1.0
    roi = (ORIGIN[0], ORIGIN[1], ORIGIN[2], end, ORIGIN[1] + 30, ORIGIN[2] + 20)
    cut = run(volume, a, roi=roi)
    assert_valid_surface(cut)
    assert x_range(cut)[1] < end + 0.6 and x_range(cut)[0] < a[0] - 3
    # The corners may come in any order; the same box gives the same mesh.
    swapped = run(volume, a, roi=np.array(roi[3:] + roi[:3]))
    assert_same_mesh(swapped, cut.points, cut.triangles)


def test_progress_reports_the_objects_and_may_cancel(balls):
    volume, a, b = balls
    calls = []
    run(volume, {1: a, 2: b}, progress=lambda f, p: calls.append((f, p)))
    assert calls and all(0.0 <= f <= 1.0 for f, _ in calls)
    with pytest.raises(balloonseg.CancelledError):
        run(volume, {1: a, 2: b}, progress=lambda f, p: True)

    class Boom(RuntimeError):
        pass

    def explode(fraction, phase):
        raise Boom(phase)

    with pytest.raises(Boom):
        run(volume, {1: a, 2: b}, progress=explode)
    with pytest.raises(balloonseg.InvalidArgumentError, match="callable"):
        run(volume, {1: a}, progress=3)


def library_error(call, *words):
    """The call raises InvalidArgumentError with the library's own message."""
    with pytest.raises(balloonseg.InvalidArgumentError) as caught:
        call()
    assert str(caught.value) == _library.last_error_message(), "not the library's message"
    for word in words:
        assert word in str(caught.value), f"{word!r} not in {caught.value}"


def test_bad_labels_seeds_stops_and_regions_are_named(balls):
    volume, a, b = balls
    library_error(lambda: run(volume, {0: a, 1: b}), "label 0")
    library_error(lambda: run(volume, {2**31: a}), "label 2147483648")
    library_error(lambda: run(volume, {1: a, 2: a}), "voxel", "object 1", "object 2")
    library_error(lambda: run(volume, {1: a}, stop=a), "stop seed")
    library_error(lambda: run(volume, {1: [np.nan, 0, 0]}), "not finite")
    library_error(lambda: run(volume, a, roi=(0, 0, 0, 1, 1, 0)), "flat")
    library_error(lambda: run(volume, {}), "no object")
    for label in (-1, 2**32, 1.5, "1", True, None):
        with pytest.raises(balloonseg.InvalidArgumentError, match="label"):
            run(volume, {label: a})
    with pytest.raises(balloonseg.InvalidArgumentError, match=r"seed\[1\]"):
        run(volume, {1: [[1, 2]]})
    with pytest.raises(balloonseg.InvalidArgumentError, match="stop"):
        run(volume, a, stop=[1, 2])
    with pytest.raises(balloonseg.InvalidArgumentError, match="roi"):
        run(volume, a, roi=(0, 0, 0, 1, 1))
    with pytest.raises(balloonseg.InvalidArgumentError, match="roi"):
        run(volume, a, roi="box")
