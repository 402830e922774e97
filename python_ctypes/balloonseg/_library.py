"""Loads libballoonseg and declares its C ABI (include/balloonseg.h) for ctypes.

The library is looked up, in order, at ``$BALLOONSEG_LIBRARY``, in the repository's
``target/release`` next to this package (a checkout, or an editable install), as the copy
bundled in the package by ``pip install ./python_ctypes`` (setup.py), and on the system path
(``ctypes.util.find_library``).
Its major version must equal this package's. Every function gets its argtypes and restype here,
so a wrong call is a Python TypeError, never a crash.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os
import sys
from ctypes import (
    CFUNCTYPE,
    POINTER,
    Structure,
    c_char_p,
    c_double,
    c_int,
    c_int64,
    c_size_t,
    c_ssize_t,
    c_uint8,
    c_uint32,
    c_uint64,
    c_void_p,
)
from pathlib import Path

from .errors import BalloonError, error_for_status

#: The version of the C ABI this package is written against.
ABI_VERSION = (0, 3, 0)

OK = 0

#: BalloonParamKind's values.
PARAM_REAL = 0
PARAM_INTEGER = 1
BUFFER_TOO_SMALL = 6
CANCELLED = 7

SCALAR_TYPES = {
    "uint8": 0,
    "int8": 1,
    "uint16": 2,
    "int16": 3,
    "uint32": 4,
    "int32": 5,
    "float32": 6,
    "float64": 7,
}


class BalloonVolume(Structure):
    _fields_ = [
        ("data", c_void_p),
        ("scalar_type", c_uint32),
        ("dims", c_size_t * 3),
        ("strides", c_ssize_t * 3),
        ("spacing", c_double * 3),
        ("origin", c_double * 3),
        ("direction", c_double * 9),
    ]


class BalloonParams(Structure):
    _fields_ = [
        ("struct_size", c_size_t),
        ("reference_intensity", c_double),
        ("tolerance", c_double),
        ("edge_length_mm", c_double),
        ("elastic_weight", c_double),
        ("bending_weight", c_double),
        ("inflation_weight", c_double),
        ("step_fraction", c_double),
        ("max_iterations", c_uint32),
        ("self_intersection_interval", c_uint32),
        ("refinement_iterations", c_uint32),
        ("max_reparametrizations", c_uint32),
        ("max_vertices", c_uint64),
        ("threads", c_uint32),
        ("simplify_error_mm", c_double),
    ]


class BalloonParamInfo(Structure):
    _fields_ = [
        ("struct_size", c_size_t),
        ("name", c_char_p),
        ("flag", c_char_p),
        ("kind", c_uint32),
        ("optional", c_uint8),
        ("default_value", c_double),
        ("minimum", c_double),
        ("minimum_inclusive", c_uint8),
        ("maximum", c_double),
        ("maximum_inclusive", c_uint8),
        ("unset", c_char_p),
        ("doc", c_char_p),
        ("allowed", c_char_p),
    ]


class BalloonMesh(Structure):
    _fields_ = [
        ("points", POINTER(c_double)),
        ("point_count", c_size_t),
        ("triangles", POINTER(c_uint32)),
        ("triangle_count", c_size_t),
        ("vertex_state", POINTER(c_uint8)),
    ]


class BalloonObjectSeeds(Structure):
    _fields_ = [
        ("label", c_uint32),
        ("points", POINTER(c_double)),
        ("point_count", c_size_t),
    ]


class BalloonStats(Structure):
    _fields_ = [
        ("struct_size", c_size_t),
        ("reference_intensity", c_double),
        ("tolerance", c_double),
        ("edge_length_mm", c_double),
        ("iterations", c_uint32),
        ("reparametrizations", c_uint32),
        ("seconds_inflation", c_double),
        ("seconds_self_intersection", c_double),
        ("seconds_reparametrization", c_double),
        ("seconds_refinement", c_double),
        ("seconds_validation", c_double),
        ("seconds_simplification", c_double),
        ("seconds_total", c_double),
    ]


class BalloonMeshReport(Structure):
    _fields_ = [
        ("struct_size", c_size_t),
        ("closed", c_uint8),
        ("manifold", c_uint8),
        ("oriented", c_uint8),
        ("outward", c_uint8),
        ("self_intersecting_pairs", c_size_t),
        ("euler_characteristic", c_int64),
        ("genus", c_int64),
        ("components", c_size_t),
        ("area_mm2", c_double),
        ("volume_mm3", c_double),
    ]


PROGRESS_CALLBACK = CFUNCTYPE(c_int, c_double, c_char_p, c_void_p)

_Status = c_int
_Segmenter = c_void_p
_TriMesh = c_void_p
_Objects = c_void_p
_Triple = POINTER(c_double)

_SIGNATURES = {
    "balloon_params_default": (_Status, [POINTER(BalloonParams)]),
    "balloon_param_count": (c_size_t, []),
    "balloon_param_info": (_Status, [c_size_t, POINTER(BalloonParamInfo)]),
    "balloon_params_get": (_Status, [POINTER(BalloonParams), c_char_p, POINTER(c_double)]),
    "balloon_params_set": (_Status, [POINTER(BalloonParams), c_char_p, c_double]),
    "balloon_init": (
        _Status,
        [POINTER(BalloonVolume), POINTER(BalloonParams), _Triple, POINTER(_Segmenter)],
    ),
    "balloon_add_seed": (_Status, [_Segmenter, _Triple]),
    "balloon_step": (_Status, [_Segmenter, c_uint32, POINTER(c_uint32)]),
    "balloon_freeze_self_intersections": (_Status, [_Segmenter, POINTER(c_size_t)]),
    "balloon_reparametrize": (_Status, [_Segmenter]),
    "balloon_segment": (_Status, [_Segmenter]),
    "balloon_mesh": (_Status, [_Segmenter, POINTER(BalloonMesh)]),
    "balloon_stats": (_Status, [_Segmenter, POINTER(BalloonStats)]),
    "balloon_set_progress_callback": (_Status, [_Segmenter, PROGRESS_CALLBACK, c_void_p]),
    "balloon_free": (None, [_Segmenter]),
    "balloon_marching_cubes": (
        _Status,
        [POINTER(BalloonVolume), c_double, c_uint32, POINTER(_TriMesh)],
    ),
    "balloon_trimesh_view": (_Status, [_TriMesh, POINTER(BalloonMesh)]),
    "balloon_simplify": (
        _Status,
        [POINTER(c_double), c_size_t, POINTER(c_uint32), c_size_t, c_double, POINTER(_TriMesh)],
    ),
    "balloon_simplify_with_progress": (
        _Status,
        [
            POINTER(c_double),
            c_size_t,
            POINTER(c_uint32),
            c_size_t,
            c_double,
            PROGRESS_CALLBACK,
            c_void_p,
            POINTER(_TriMesh),
        ],
    ),
    "balloon_trimesh_vertex_map": (
        _Status,
        [_TriMesh, POINTER(POINTER(c_uint32)), POINTER(c_size_t)],
    ),
    "balloon_trimesh_free": (None, [_TriMesh]),
    "balloon_mesh_check": (
        _Status,
        [POINTER(c_double), c_size_t, POINTER(c_uint32), c_size_t, POINTER(BalloonMeshReport)],
    ),
    "balloon_self_intersections": (
        _Status,
        [
            POINTER(c_double),
            c_size_t,
            POINTER(c_uint32),
            c_size_t,
            POINTER(c_uint32),
            c_size_t,
            POINTER(c_size_t),
        ],
    ),
    "balloon_segment_objects": (
        _Status,
        [
            POINTER(BalloonVolume),
            POINTER(BalloonParams),
            POINTER(BalloonObjectSeeds),
            c_size_t,
            POINTER(c_double),
            c_size_t,
            POINTER(c_double),
            PROGRESS_CALLBACK,
            c_void_p,
            POINTER(_Objects),
        ],
    ),
    "balloon_objects_count": (_Status, [_Objects, POINTER(c_size_t)]),
    "balloon_objects_label": (_Status, [_Objects, c_size_t, POINTER(c_uint32)]),
    "balloon_objects_mesh": (_Status, [_Objects, c_size_t, POINTER(BalloonMesh)]),
    "balloon_objects_stats": (_Status, [_Objects, c_size_t, POINTER(BalloonStats)]),
    "balloon_objects_free": (None, [_Objects]),
    "balloon_status_string": (c_char_p, [_Status]),
    "balloon_last_error_message": (c_size_t, [c_char_p, c_size_t]),
    "balloon_version": (c_char_p, []),
}

_FILE_NAME = {"darwin": "libballoonseg.dylib", "win32": "balloonseg.dll"}.get(
    sys.platform, "libballoonseg.so"
)


def _candidates() -> list[str]:
    env = os.environ.get("BALLOONSEG_LIBRARY")
    if env:
        return [env]
    found = []
    here = Path(__file__).resolve().parent
    repo_build = here.parent.parent / "target" / "release" / _FILE_NAME
    bundled = here / _FILE_NAME
    for path in (repo_build, bundled):
        if path.exists():
            found.append(str(path))
    system = ctypes.util.find_library("balloonseg")
    if system:
        found.append(system)
    return found


@functools.lru_cache(maxsize=None)
def library() -> ctypes.CDLL:
    """The loaded library with every function declared (loaded on first use)."""
    candidates = _candidates()
    if not candidates:
        raise OSError(
            "libballoonseg not found: set BALLOONSEG_LIBRARY to the library file, or build it in "
            "the repository with `cargo build --release --lib` (target/release/"
            f"{_FILE_NAME}), or install it on the system library path"
        )
    path = candidates[0]
    try:
        lib = ctypes.CDLL(path)
    except OSError as e:
        raise OSError(f"cannot load libballoonseg from {path}: {e}") from e
    for name, (restype, argtypes) in _SIGNATURES.items():
        try:
            function = getattr(lib, name)
        except AttributeError as e:
            raise OSError(
                f"{path} has no function {name}: it is not a libballoonseg of C ABI "
                f"{'.'.join(map(str, ABI_VERSION))}; rebuild it"
            ) from e
        function.restype = restype
        function.argtypes = argtypes
    version = lib.balloon_version().decode()
    if version.split(".")[0] != str(ABI_VERSION[0]):
        raise OSError(
            f"{path} is libballoonseg {version}, but this Python package needs major version "
            f"{ABI_VERSION[0]}; rebuild the library or install the matching package"
        )
    return lib


def version() -> str:
    """The version string of the loaded library."""
    return library().balloon_version().decode()


def last_error_message() -> str:
    lib = library()
    length = lib.balloon_last_error_message(None, 0)
    buffer = ctypes.create_string_buffer(length + 1)
    lib.balloon_last_error_message(buffer, length + 1)
    return buffer.value.decode("utf-8", errors="replace")


def error(status: int) -> BalloonError:
    """The exception for a failing call, with the library's message for this thread."""
    message = last_error_message()
    if not message:
        message = library().balloon_status_string(status).decode()
    return error_for_status(status, message)


def check(status: int) -> None:
    """Raises the matching BalloonError unless ``status`` is BALLOON_OK."""
    if status != OK:
        raise error(status)
