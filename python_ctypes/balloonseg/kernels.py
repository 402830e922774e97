"""The library's kernels on their own: mesh checks, self-intersections, marching cubes and
error-bounded simplification."""

from __future__ import annotations

import ctypes
import numbers

import numpy as np

from . import _library as L
from ._progress import Progress
from ._volume import unsigned, volume_view
from .errors import InvalidArgumentError, InvalidMeshError


def mesh_arrays(points, triangles) -> tuple[np.ndarray, np.ndarray]:
    """C-contiguous float64 (N, 3) points and uint32 (M, 3) triangles (copied only if needed)."""
    p = np.ascontiguousarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InvalidMeshError(f"points must be an (N, 3) array, got shape {p.shape}")
    t = np.asarray(triangles)
    if t.ndim != 2 or t.shape[1] != 3:
        raise InvalidMeshError(f"triangles must be an (M, 3) array, got shape {t.shape}")
    if t.size and t.dtype.kind not in "ui":
        raise InvalidMeshError(f"triangles must hold integer vertex indices, got dtype {t.dtype}")
    if t.size and (t.min() < 0 or t.max() > np.iinfo(np.uint32).max):
        raise InvalidMeshError(
            f"triangle vertex indices must be in 0..{len(p) - 1}, found {t.min()}..{t.max()}"
        )
    return p, np.ascontiguousarray(t, dtype=np.uint32)


def _pointers(p: np.ndarray, t: np.ndarray):
    return (
        p.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
        len(p),
        t.ctypes.data_as(ctypes.POINTER(ctypes.c_uint32)),
        len(t),
    )


def check(points, triangles) -> dict:
    """Topology and geometry of a triangle mesh: ``vertices``, ``triangles``, ``closed``,
    ``manifold``, ``oriented``, ``outward``, ``self_intersecting_pairs`` (counted up to 16 per
    triangle plus 1,024, where the search stops; more reads as that limit plus one),
    ``euler_characteristic``, ``genus`` (None unless closed and manifold), ``components``,
    ``area_mm2``, ``volume_mm3`` (signed: positive when the triangles face outward)."""
    p, t = mesh_arrays(points, triangles)
    report = L.BalloonMeshReport(struct_size=ctypes.sizeof(L.BalloonMeshReport))
    L.check(L.library().balloon_mesh_check(*_pointers(p, t), ctypes.byref(report)))
    return {
        "vertices": len(p),
        "triangles": len(t),
        "closed": bool(report.closed),
        "manifold": bool(report.manifold),
        "oriented": bool(report.oriented),
        "outward": bool(report.outward),
        "self_intersecting_pairs": int(report.self_intersecting_pairs),
        "euler_characteristic": int(report.euler_characteristic),
        "genus": None if report.genus < 0 else int(report.genus),
        "components": int(report.components),
        "area_mm2": float(report.area_mm2),
        "volume_mm3": float(report.volume_mm3),
    }


def self_intersections(points, triangles) -> np.ndarray:
    """The pairs of triangles that intersect, as a (K, 2) uint32 array of triangle indices
    (t0 < t1, sorted); neighbours count as CGAL's ``self_intersections`` defines it."""
    p, t = mesh_arrays(points, triangles)
    lib = L.library()
    count = ctypes.c_size_t()
    status = lib.balloon_self_intersections(*_pointers(p, t), None, 0, ctypes.byref(count))
    if status not in (L.OK, L.BUFFER_TOO_SMALL):
        raise L.error(status)
    pairs = np.zeros((count.value, 2), dtype=np.uint32)
    if count.value:
        out = pairs.ctypes.data_as(ctypes.POINTER(ctypes.c_uint32))
        L.check(
            lib.balloon_self_intersections(*_pointers(p, t), out, count.value, ctypes.byref(count))
        )
    return pairs


def mesh_from_view(view: L.BalloonMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Copies a borrowed ``BalloonMesh`` into numpy arrays that outlive it."""

    def copy(pointer, count, columns, dtype):
        if count == 0:
            return np.zeros((0, columns) if columns else (0,), dtype=dtype)
        shape = (count, columns) if columns else (count,)
        return np.ctypeslib.as_array(pointer, shape=shape).astype(dtype, copy=True)

    points = copy(view.points, view.point_count, 3, np.float64)
    triangles = copy(view.triangles, view.triangle_count, 3, np.uint32)
    states = copy(view.vertex_state, view.point_count, 0, np.uint8) if view.vertex_state else None
    return points, triangles, states


def marching_cubes(
    volume,
    level: float,
    spacing=(1.0, 1.0, 1.0),
    origin=(0.0, 0.0, 0.0),
    direction=None,
    axes: str = "zyx",
    threads: int = 0,
):
    """The isosurface of ``volume`` at ``level`` (world mm; closed, welded, normals towards
    higher values) as a :class:`~balloonseg.mesh.Mesh`. The volume is read in place."""
    from .mesh import Mesh

    view, _array = volume_view(volume, spacing, origin, direction, axes)
    lib = L.library()
    handle = ctypes.c_void_p()
    L.check(
        lib.balloon_marching_cubes(
            ctypes.byref(view), float(level), unsigned("threads", threads), ctypes.byref(handle)
        )
    )
    try:
        mesh = L.BalloonMesh()
        L.check(lib.balloon_trimesh_view(handle, ctypes.byref(mesh)))
        points, triangles, _ = mesh_from_view(mesh)
    finally:
        lib.balloon_trimesh_free(handle)
    return Mesh(points, triangles)


def simplify(points, triangles, max_error_mm: float, progress=None):
    """A closed, 2-manifold, consistently oriented mesh without self-intersections reduced to as
    few triangles as the library's edge collapses reach while every point of the result lies
    within ``max_error_mm`` of the input surface and every point of the input surface within
    ``max_error_mm`` of the result (the two-sided Hausdorff distance, proved for every point).
    The result keeps the orientation, genus and components and has no self-intersections.

    Returns ``(mesh, vertex_map)``: a :class:`~balloonseg.mesh.Mesh` and, for each input point,
    the index of the output vertex it was merged into (``NO_VERTEX`` for a point no triangle
    uses), to carry per-point data over. ``progress(fraction, phase)`` (phase
    ``"simplification"``) is called now and then with an estimate of the fraction done;
    returning True (or raising) cancels with CancelledError (or the raised exception). Raises
    InvalidArgumentError for a bound that is not a positive finite number, InvalidMeshError
    (with the reason) for a mesh it cannot simplify."""
    from .mesh import Mesh

    if isinstance(max_error_mm, bool) or not isinstance(max_error_mm, numbers.Real):
        raise InvalidArgumentError(
            f"max_error_mm must be a distance in mm (a number), got {max_error_mm!r}"
        )
    p, t = mesh_arrays(points, triangles)
    callback = Progress(progress)
    lib = L.library()
    handle = ctypes.c_void_p()
    status = lib.balloon_simplify_with_progress(
        *_pointers(p, t), float(max_error_mm), callback.c, None, ctypes.byref(handle)
    )
    callback.check(status)
    try:
        view = L.BalloonMesh()
        L.check(lib.balloon_trimesh_view(handle, ctypes.byref(view)))
        out_points, out_triangles, _ = mesh_from_view(view)
        entries = ctypes.POINTER(ctypes.c_uint32)()
        count = ctypes.c_size_t()
        L.check(
            lib.balloon_trimesh_vertex_map(handle, ctypes.byref(entries), ctypes.byref(count))
        )
        vertex_map = np.zeros(count.value, dtype=np.uint32)
        if count.value:
            vertex_map[:] = np.ctypeslib.as_array(entries, shape=(count.value,))
    finally:
        lib.balloon_trimesh_free(handle)
    return Mesh(out_points, out_triangles), vertex_map


#: In :func:`simplify`'s vertex map: an input point that no triangle uses.
NO_VERTEX = np.iinfo(np.uint32).max
