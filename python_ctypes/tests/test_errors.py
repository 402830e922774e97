"""Each kind of bad input raises its exception, with the library's own message when the library
found the problem."""

import numpy as np
import pytest

import balloonseg
from balloonseg import _library

SEED = (10.0, 10.0, 10.0)


@pytest.fixture
def ball():
    """A bright ball of radius 6 voxels in a 21^3 float32 volume."""
    z, y, x = np.mgrid[:21, :21, :21]
    return (np.sqrt((x - 10) ** 2 + (y - 10) ** 2 + (z - 10) ** 2) < 6).astype(np.float32) * 100


def library_error(cls, call, *words):
    with pytest.raises(cls) as caught:
        call()
    e = caught.value
    assert str(e) == _library.last_error_message(), "not the library's message"
    assert e.status == cls.default_status
    for word in words:
        assert word in str(e).lower(), f"{word!r} not in {str(e)!r}"
    return e


def test_a_seed_outside_the_volume(ball):
    library_error(
        balloonseg.InvalidArgumentError,
        lambda: balloonseg.segment(ball, (50.0, 10.0, 10.0)),
        "seed",
    )


def test_nan_spacing(ball):
    e = library_error(
        balloonseg.InvalidVolumeError,
        lambda: balloonseg.segment(ball, SEED, spacing=(1.0, float("nan"), 1.0)),
        "spacing",
    )
    assert isinstance(e, ValueError)


def test_singular_direction(ball):
    library_error(
        balloonseg.InvalidVolumeError,
        lambda: balloonseg.segment(ball, SEED, direction=[[1, 0, 0], [1, 0, 0], [0, 0, 1]]),
        "direction",
    )


def test_a_bad_parameter_value(ball):
    library_error(
        balloonseg.InvalidArgumentError,
        lambda: balloonseg.segment(ball, SEED, tolerance=-1.0),
        "tolerance",
    )


def test_a_leak_past_max_vertices(ball):
    library_error(
        balloonseg.LeakError,
        lambda: balloonseg.segment(
            np.full((40, 40, 40), 7.0, np.float32),
            (20, 20, 20),
            reference_intensity=7.0,
            tolerance=1.0,
            max_vertices=500,
        ),
        "max_vertices",
    )


def test_a_malformed_mesh_in_a_kernel():
    points = np.eye(3)
    library_error(balloonseg.InvalidMeshError, lambda: balloonseg.check(points, [[0, 1, 7]]))


@pytest.mark.parametrize("dtype", ["int64", "uint64", "bool", "complex64", "float16", ">f4", ">i2"])
def test_unsupported_dtypes_are_type_errors_listing_the_supported_ones(ball, dtype):
    with pytest.raises(TypeError) as caught:
        balloonseg.segment(ball.astype(dtype), SEED)
    assert isinstance(caught.value, balloonseg.UnsupportedScalarTypeError)
    message = str(caught.value)
    assert "uint8" in message and "float64" in message
    if dtype.startswith(">"):
        assert "byte order" in message and np.dtype(dtype).str in message


def test_not_an_array(ball):
    with pytest.raises(TypeError, match="numpy"):
        balloonseg.segment(ball.tolist(), SEED)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(volume=np.zeros((4, 4), np.float32)), "3-d"),
        (dict(seed=(1.0, 2.0)), "seed"),
        (dict(seed=np.zeros((2, 2))), "seed"),
        (dict(spacing=(1.0, 1.0)), "spacing"),
        (dict(origin="abc"), "origin"),
        (dict(direction=np.eye(2)), "direction"),
        (dict(axes="zyy"), "axes"),
        (dict(max_iterations=2.5), "max_iterations"),
        (dict(threads=-1), "threads"),
    ],
)
def test_wrong_shapes_and_values_are_value_errors(ball, kwargs, words):
    args = dict(volume=ball, seed=SEED)
    args.update(kwargs)
    with pytest.raises(ValueError, match="(?i)" + words) as caught:
        balloonseg.segment(**args)
    assert isinstance(caught.value, balloonseg.InvalidArgumentError)


def test_unaligned_or_odd_strides_are_refused(ball):
    raw = np.zeros(21 * 21 * 21 * 4 + 1, np.uint8)
    unaligned = raw[1:].view(np.float32).reshape(21, 21, 21)
    with pytest.raises(balloonseg.InvalidVolumeError, match="aligned"):
        balloonseg.segment(unaligned, SEED)
    record = np.zeros((21, 21, 21), dtype=[("a", np.uint8), ("v", np.float32)])
    with pytest.raises(balloonseg.InvalidVolumeError, match="strides|aligned"):
        balloonseg.segment(record["v"], SEED)


def test_an_unknown_parameter_names_the_valid_ones(ball):
    with pytest.raises(TypeError) as caught:
        balloonseg.segment(ball, SEED, toleranse=3.0)
    message = str(caught.value)
    assert "toleranse" in message
    for name in balloonseg.PARAMETERS:
        assert name in message


def test_a_closed_segmenter_refuses_calls(ball):
    s = balloonseg.Segmenter(ball, SEED)
    s.close()
    s.close()
    with pytest.raises(balloonseg.InvalidArgumentError, match="closed"):
        s.step(1)


def test_the_hierarchy():
    for cls in (
        balloonseg.CancelledError,
        balloonseg.LeakError,
        balloonseg.InvalidVolumeError,
        balloonseg.PanicError,
        balloonseg.UnknownParameterError,
    ):
        assert issubclass(cls, balloonseg.BalloonError)
    assert issubclass(balloonseg.PanicError, balloonseg.InternalError)
    e = balloonseg.errors.error_for_status(8, "leaked")
    assert type(e) is balloonseg.LeakError and e.status == 8 and str(e) == "leaked"
    # Code that handles running out of memory the Python way catches the library's too.
    e = balloonseg.errors.error_for_status(11, "could not allocate 9000.0 MiB for a distance map")
    assert type(e) is balloonseg.OutOfMemoryError and e.status == 11
    assert isinstance(e, MemoryError) and isinstance(e, balloonseg.BalloonError)


def test_kernel_and_step_arguments_are_checked(ball):
    with pytest.raises(balloonseg.InvalidArgumentError, match="threads"):
        balloonseg.marching_cubes(ball, 50.0, threads=-1)
    with balloonseg.Segmenter(ball, SEED) as s, pytest.raises(ValueError, match="iterations"):
        s.step(True)
    with pytest.raises(balloonseg.InvalidArgumentError, match="seed"):
        balloonseg.segment(ball, ("a", "b", "c"))
