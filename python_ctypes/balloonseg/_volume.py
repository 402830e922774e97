"""numpy arrays as ``BalloonVolume`` views, without copying the voxels.

Any of the eight scalar types in native byte order, with any strides (C or Fortran order,
negative, non-unit): the library gets the address of element [0, 0, 0] and the strides in
elements along i, j, k. ``axes`` names the world axis of each numpy axis: ``"zyx"`` for
``volume[k, j, i]`` (SimpleITK, ``vtk_to_numpy`` reshaped), ``"xyz"`` for ``volume[i, j, k]``
(nibabel); any other permutation of x, y, z works the same way.
"""

from __future__ import annotations

import numpy as np

from ._library import SCALAR_TYPES, BalloonVolume
from .errors import InvalidArgumentError, InvalidVolumeError, UnsupportedScalarTypeError


def triple(name: str, value) -> tuple[float, float, float]:
    """Three floats (x, y, z) from any sequence or array of three numbers."""
    try:
        values = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentError(f"{name} must be three numbers (x, y, z), got {value!r}") from e
    if values.shape != (3,):
        raise InvalidArgumentError(
            f"{name} must be three numbers (x, y, z), got an array of shape {values.shape}"
        )
    return tuple(float(v) for v in values)


def unsigned(name: str, value, limit: int = 2**32) -> int:
    """``value`` as an integer in 0..limit-1 (a bool or a fractional number is refused)."""
    try:
        converted = int(value)
        exact = converted == value and not isinstance(value, bool)
    except (TypeError, ValueError, OverflowError):
        exact = False
    if not exact or not 0 <= converted < limit:
        raise InvalidArgumentError(f"{name} must be an integer in 0..{limit - 1}, got {value!r}")
    return converted


def direction_matrix(direction) -> tuple[float, ...]:
    """Nine floats, row-major, from a 3x3 matrix or nine numbers (None = identity). Columns are
    the directions of the i, j, k axes, as ITK's and VTK's direction matrices."""
    if direction is None:
        return (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    try:
        d = np.asarray(direction, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentError(
            f"direction must be a 3x3 matrix or nine numbers (row-major), got {direction!r}"
        ) from e
    if d.shape not in ((3, 3), (9,)):
        raise InvalidArgumentError(
            "direction must be a 3x3 matrix or nine numbers (row-major), got an array of shape "
            f"{d.shape}"
        )
    return tuple(float(v) for v in d.reshape(9))


def axis_order(axes: str) -> tuple[int, int, int]:
    """For i, j, k (x, y, z): which numpy axis holds it."""
    if not isinstance(axes, str) or sorted(axes.lower()) != ["x", "y", "z"]:
        raise InvalidArgumentError(
            f'axes must name the world axis of each numpy axis, e.g. "zyx" for volume[k, j, i] '
            f'(SimpleITK) or "xyz" for volume[i, j, k] (nibabel); got {axes!r}'
        )
    axes = axes.lower()
    return tuple(axes.index(a) for a in "xyz")


def scalar_type(dtype: np.dtype) -> int:
    supported = ", ".join(SCALAR_TYPES)
    if not dtype.isnative:
        raise UnsupportedScalarTypeError(
            f"the volume's dtype {dtype.str} is not in native byte order; convert it with "
            f"volume.astype(volume.dtype.newbyteorder('=')) (supported types: {supported})"
        )
    code = SCALAR_TYPES.get(dtype.name) if dtype.kind in "uif" else None
    if code is None:
        raise UnsupportedScalarTypeError(
            f"volume dtype {dtype} is not supported; use one of {supported}"
        )
    return code


def volume_view(volume, spacing, origin, direction, axes) -> tuple[BalloonVolume, np.ndarray]:
    """The ``BalloonVolume`` over ``volume``'s memory and the array that owns it (keep it alive
    as long as the library may read the voxels)."""
    if not isinstance(volume, np.ndarray):
        raise UnsupportedScalarTypeError(
            f"volume must be a numpy array, got {type(volume).__name__}; wrap it with "
            "numpy.asarray (the voxels are read in place, not copied)"
        )
    code = scalar_type(volume.dtype)
    if volume.ndim != 3:
        raise InvalidVolumeError(
            f"volume must be a 3-D array, got {volume.ndim} dimensions (shape {volume.shape})"
        )
    if not volume.flags.aligned:
        raise InvalidVolumeError(
            "the volume's memory is not aligned for its dtype; pass numpy.ascontiguousarray(volume)"
        )
    itemsize = volume.dtype.itemsize
    for stride in volume.strides:
        if stride % itemsize:
            raise InvalidVolumeError(
                f"the volume's strides {volume.strides} (bytes) are not multiples of its item size "
                f"{itemsize}; pass numpy.ascontiguousarray(volume)"
            )
    order = axis_order(axes)
    view = BalloonVolume()
    view.data = volume.__array_interface__["data"][0]
    view.scalar_type = code
    view.dims[:] = [volume.shape[a] for a in order]
    view.strides[:] = [volume.strides[a] // itemsize for a in order]
    view.spacing[:] = triple("spacing", spacing)
    view.origin[:] = triple("origin", origin)
    view.direction[:] = direction_matrix(direction)
    return view, volume
