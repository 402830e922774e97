"""``Segmenter``: the balloon of libballoonseg on a numpy volume, step by step or to the end,
with a progress callback that may cancel; ``segment`` for the one-call case."""

from __future__ import annotations

import ctypes
import functools
import numbers
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from . import _library as L
from ._progress import Progress, check_progress
from ._volume import triple, unsigned, volume_view
from .errors import InvalidArgumentError, PanicError, UnknownParameterError
from .kernels import mesh_from_view
from .mesh import Mesh

#: The balloon's parameters (BalloonParams' fields) and their Python types; what each one
#: means, its default and its range: :func:`parameter_info`.
PARAMETERS = {
    name: (float if ctype is ctypes.c_double else int)
    for name, ctype in L.BalloonParams._fields_
    if name != "struct_size"
}


class ParameterInfo(NamedTuple):
    """One parameter as the library's table describes it (``balloon_param_info``)."""

    name: str
    #: The command line's flag, without the leading ``--``.
    flag: str
    #: ``float`` or ``int``.
    type: type
    #: Whether it may be left unset (None), meaning what ``unset`` says.
    optional: bool
    #: The default; NaN when it is unset by default.
    default: float
    minimum: float
    minimum_inclusive: bool
    maximum: float
    maximum_inclusive: bool
    unset: str
    doc: str
    #: The values it takes, in words.
    allowed: str


@functools.lru_cache(maxsize=None)
def parameter_info() -> dict[str, ParameterInfo]:
    """Every parameter, by name, in the order of BalloonParams' fields: its meaning, default and
    range from the library itself."""
    lib = L.library()
    table = {}
    for index in range(lib.balloon_param_count()):
        info = L.BalloonParamInfo(struct_size=ctypes.sizeof(L.BalloonParamInfo))
        L.check(lib.balloon_param_info(index, ctypes.byref(info)))
        name = info.name.decode()
        table[name] = ParameterInfo(
            name=name,
            flag=info.flag.decode(),
            type=float if info.kind == L.PARAM_REAL else int,
            optional=bool(info.optional),
            default=info.default_value,
            minimum=info.minimum,
            minimum_inclusive=bool(info.minimum_inclusive),
            maximum=info.maximum,
            maximum_inclusive=bool(info.maximum_inclusive),
            unset=info.unset.decode(),
            doc=info.doc.decode(),
            allowed=info.allowed.decode(),
        )
    return table


def default_params() -> dict:
    """The library's defaults; NaN means "estimated" (reference_intensity, tolerance) or "from
    the volume" (edge_length_mm: the mean spacing)."""
    params = L.BalloonParams()
    L.check(L.library().balloon_params_default(ctypes.byref(params)))
    return {name: getattr(params, name) for name in PARAMETERS}


def _params_struct(overrides: dict) -> L.BalloonParams:
    """The defaults with ``overrides`` set by name through the library, which checks each value
    against its range (None keeps the default)."""
    unknown = sorted(set(overrides) - set(PARAMETERS))
    if unknown:
        raise UnknownParameterError(
            f"unknown balloon parameter{'s' if len(unknown) > 1 else ''} {', '.join(unknown)}; "
            f"the parameters are {', '.join(PARAMETERS)}"
        )
    lib = L.library()
    params = L.BalloonParams()
    L.check(lib.balloon_params_default(ctypes.byref(params)))
    for name, value in overrides.items():
        if value is not None:
            number = _number(name, value)
            L.check(lib.balloon_params_set(ctypes.byref(params), name.encode(), number))
    return params


def _number(name: str, value) -> float:
    if isinstance(value, bool):
        raise InvalidArgumentError(f"{name} must be a number, got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError) as e:
        raise InvalidArgumentError(f"{name} must be a number, got {value!r}") from e


def _seeds(seed, name: str = "seed", empty: bool = False) -> np.ndarray:
    """One point or K points (world mm) as a C-contiguous (K, 3) float64 array; K = 0 only when
    ``empty`` allows it."""
    try:
        seeds = np.ascontiguousarray(seed, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentError(f"{name} must be numbers (x, y, z) in mm, got {seed!r}") from e
    if empty and seeds.size == 0:
        return np.zeros((0, 3))
    if seeds.ndim == 1:
        seeds = seeds[None, :]
    if seeds.ndim != 2 or seeds.shape[1] != 3 or len(seeds) == 0:
        raise InvalidArgumentError(
            f"{name} must be one point (x, y, z) or K points as a (K, 3) array in world mm, got "
            f"shape {np.shape(seed)}"
        )
    return seeds


#: Labels cross the C ABI as uint32_t; the library takes 1 to 2**31 - 1 and names the others.
_LABEL_LIMIT = 2**32


def _objects(seed) -> list[tuple[int, np.ndarray]]:
    """(label, (K, 3) seeds) per object: a dict ``{label: points}``, or label 1 for a point or
    a (K, 3) array. Labels the C ABI cannot carry are refused here; the library checks the
    rest (0, too large, seeds of two objects in one voxel)."""
    if not isinstance(seed, Mapping):
        return [(1, _seeds(seed))]
    objects = []
    for label, points in seed.items():
        if (
            isinstance(label, bool)
            or not isinstance(label, numbers.Integral)
            or not 0 <= label < _LABEL_LIMIT
        ):
            raise InvalidArgumentError(
                f"seed label {label!r} is not a label: the keys of a seed dict are object labels, "
                "integers from 1 to 2147483647"
            )
        objects.append((int(label), _seeds(points, f"seed[{label!r}]")))
    return objects


def _roi(roi):
    """The region of interest as 6 C doubles (x0, y0, z0, x1, y1, z1), or None."""
    if roi is None:
        return None
    try:
        values = np.asarray(roi, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentError(
            "roi must be 6 numbers x0, y0, z0, x1, y1, z1 (two opposite corners, world mm), "
            f"got {roi!r}"
        ) from e
    if values.shape != (6,):
        raise InvalidArgumentError(
            "roi must be 6 numbers x0, y0, z0, x1, y1, z1 (two opposite corners, world mm), got "
            f"an array of shape {values.shape}"
        )
    return (ctypes.c_double * 6)(*values)


def _stats_dict(s: L.BalloonStats) -> dict:
    """A BalloonStats as the ``stats`` of a Segmenter."""
    return {
        "reference_intensity": s.reference_intensity,
        "tolerance": s.tolerance,
        "edge_length_mm": s.edge_length_mm,
        "iterations": s.iterations,
        "reparametrizations": s.reparametrizations,
        "seconds": {
            "inflation": s.seconds_inflation,
            "self_intersection": s.seconds_self_intersection,
            "reparametrization": s.seconds_reparametrization,
            "refinement": s.seconds_refinement,
            "validation": s.seconds_validation,
            "simplification": s.seconds_simplification,
            "total": s.seconds_total,
        },
    }


def _as_c_triple(point) -> ctypes.Array:
    return (ctypes.c_double * 3)(*triple("seed", point))


class Segmenter:
    """A balloon inflating in ``volume`` (numpy, read in place: keep it unchanged while the
    segmenter lives) from ``seed`` (world mm, one (3,) point or (K, 3) points).

    ``spacing``, ``origin`` (x, y, z) and ``direction`` (3x3, columns = the i, j, k axes) give
    the world coordinates as ITK does; ``axes`` names the world axis of each numpy axis
    ("zyx" for SimpleITK's ``volume[k, j, i]``, "xyz" for nibabel's ``volume[i, j, k]``).
    ``progress(fraction, phase)`` is called during long calls; returning True (or raising)
    cancels the call with :class:`~balloonseg.errors.CancelledError` (or the raised exception).
    The other keywords are the balloon's parameters (see :data:`PARAMETERS`).
    """

    def __init__(
        self,
        volume,
        seed,
        spacing=(1.0, 1.0, 1.0),
        origin=(0.0, 0.0, 0.0),
        direction=None,
        axes: str = "zyx",
        progress=None,
        **params,
    ):
        self._handle = None
        self._panic = None
        self._lib = L.library()
        seeds = _seeds(seed)
        params_struct = _params_struct(params)
        self._volume, self._array = volume_view(volume, spacing, origin, direction, axes)
        handle = ctypes.c_void_p()
        L.check(
            self._lib.balloon_init(
                ctypes.byref(self._volume),
                ctypes.byref(params_struct),
                _as_c_triple(seeds[0]),
                ctypes.byref(handle),
            )
        )
        self._handle = handle
        self._progress = None
        self._trampoline = None
        self._callback_error = None
        for extra in seeds[1:]:
            self.add_seed(extra)
        self.progress = progress

    # --- lifetime ---------------------------------------------------------------------------
    def close(self) -> None:
        """Frees the library's segmenter (also done by ``with`` and by garbage collection)."""
        if self._handle is not None:
            self._lib.balloon_free(self._handle)
            self._handle = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        if getattr(self, "_handle", None) is not None:
            self.close()

    def _live(self) -> ctypes.c_void_p:
        if self._handle is None:
            raise InvalidArgumentError("this Segmenter was closed; create a new one")
        return self._handle

    # --- progress ---------------------------------------------------------------------------
    @property
    def progress(self):
        """The progress callable ``progress(fraction, phase) -> bool | None`` or None."""
        return self._progress

    @progress.setter
    def progress(self, callback) -> None:
        check_progress(callback)
        trampoline = L.PROGRESS_CALLBACK(self._on_progress) if callback else L.PROGRESS_CALLBACK()
        self._call(self._lib.balloon_set_progress_callback, trampoline, None)
        self._progress = callback
        self._trampoline = trampoline  # ctypes frees the C thunk with this object

    def _on_progress(self, fraction: float, phase: bytes, _user_data) -> int:
        # An exception must not unwind through the library: keep it, cancel, raise it later.
        try:
            return 1 if self._progress(fraction, phase.decode()) else 0
        except BaseException as e:  # noqa: BLE001 - re-raised by _call
            self._callback_error = e
            return 1

    def _call(self, function, *args) -> None:
        """Calls ``function(handle, *args)``; raises the callback's exception if it raised one,
        else the status's. After a panic only ``close()`` is allowed (the C ABI's rule)."""
        if self._panic is not None:
            raise PanicError(
                f"a previous call failed with a caught panic ({self._panic}); only close() is "
                "possible now: create a new Segmenter",
                PanicError.default_status,
            )
        self._callback_error = None
        status = function(self._live(), *args)
        error, self._callback_error = self._callback_error, None
        if error is not None:
            raise error
        try:
            L.check(status)
        except PanicError as e:
            self._panic = str(e)
            raise

    # --- the method -------------------------------------------------------------------------
    def add_seed(self, seed) -> None:
        """Another seed sphere (world mm), e.g. in a branch the first one cannot reach."""
        self._call(self._lib.balloon_add_seed, _as_c_triple(seed))

    def step(self, iterations: int = 1) -> int:
        """Up to ``iterations`` steps of inflation (stops early at equilibrium); returns the
        number of vertices still moving."""
        iterations = unsigned("iterations", iterations)
        active = ctypes.c_uint32()
        self._call(self._lib.balloon_step, iterations, ctypes.byref(active))
        return active.value

    def freeze_self_intersections(self) -> int:
        """Searches self-intersections now and freezes their vertices; returns how many."""
        frozen = ctypes.c_size_t()
        self._call(self._lib.balloon_freeze_self_intersections, ctypes.byref(frozen))
        return frozen.value

    def reparametrize(self) -> None:
        """Signed distance + marching cubes now (step 6 of the method)."""
        self._call(self._lib.balloon_reparametrize)

    def segment(self) -> Mesh:
        """The whole method to completion: a closed, 2-manifold, outward mesh without
        self-intersections, in world mm."""
        self._call(self._lib.balloon_segment)
        return self.mesh

    @property
    def mesh(self) -> Mesh:
        """A copy of the current balloon (stays valid after further steps)."""
        view = L.BalloonMesh()
        self._call(self._lib.balloon_mesh, ctypes.byref(view))
        points, triangles, states = mesh_from_view(view)
        return Mesh(points, triangles, states, self.stats)

    @property
    def stats(self) -> dict:
        """What the run did so far: reference_intensity, tolerance, edge_length_mm, iterations,
        reparametrizations, seconds (per phase and total)."""
        s = L.BalloonStats(struct_size=ctypes.sizeof(L.BalloonStats))
        self._call(self._lib.balloon_stats, ctypes.byref(s))
        return _stats_dict(s)


def segment(
    volume,
    seed,
    spacing=(1.0, 1.0, 1.0),
    origin=(0.0, 0.0, 0.0),
    direction=None,
    axes: str = "zyx",
    progress=None,
    *,
    stop=None,
    roi=None,
    simplify_mm=None,
    **params,
):
    """Segments the structure around ``seed`` (see :class:`Segmenter` for the arguments) and
    returns its surface.

    ``seed`` is one point (x, y, z), a (K, 3) array (one object grown from all of them), or a
    dict ``{label: point or (K, 3) array}`` of objects that grow together and stop at each other
    (labels 1 to 2**31 - 1). ``stop`` (a point or a (K, 3) array) seeds competitors: balloons
    that keep the objects out of their structure and are not returned. ``roi`` is a box no
    balloon grows beyond, 6 numbers x0, y0, z0, x1, y1, z1 (two opposite corners). All in world
    mm. Returns the :class:`Mesh` of the only object, or a dict ``{label: Mesh}`` when ``seed``
    is a dict of several labels (:func:`segment_objects` always gives the dict).

    ``simplify_mm`` (the parameter ``simplify_error_mm``; None or 0: not simplified) returns the
    surface simplified so that it lies within that many mm of the balloon's surface both ways
    (the two-sided Hausdorff distance), keeping every guarantee of the output; each vertex's
    ``vertex_state`` is the least settled of those merged into it. Several objects are
    simplified together, so their surfaces still do not cross, and each keeps the bound to its
    own balloon.
    """
    if simplify_mm is not None:
        if params.get("simplify_error_mm") is not None:
            raise InvalidArgumentError(
                "simplify_mm and simplify_error_mm are the same parameter; give one of them"
            )
        params["simplify_error_mm"] = simplify_mm
    if not isinstance(seed, Mapping) and stop is None and roi is None:
        with Segmenter(volume, seed, spacing, origin, direction, axes, progress, **params) as s:
            return s.segment()
    meshes = segment_objects(
        volume, seed, spacing, origin, direction, axes, progress, stop=stop, roi=roi, **params
    )
    if isinstance(seed, Mapping) and len(meshes) > 1:
        return meshes
    (mesh,) = meshes.values()
    return mesh


def segment_objects(
    volume,
    seed,
    spacing=(1.0, 1.0, 1.0),
    origin=(0.0, 0.0, 0.0),
    direction=None,
    axes: str = "zyx",
    progress=None,
    *,
    stop=None,
    roi=None,
    **params,
) -> dict:
    """Several objects at once (``balloon_segment_objects``), with the arguments of
    :func:`segment`: always a dict ``{label: Mesh}``, in the order of ``seed`` (label 1 for a
    point or a (K, 3) array). Each mesh is closed, 2-manifold, outward and apart from the
    others; its ``stats`` add the object's ``label`` and its balloon's run. ``progress(fraction,
    phase)`` gets the mean fraction of all balloons; returning True cancels the call with
    CancelledError."""
    objects = _objects(seed)
    stops = _seeds(np.zeros((0, 3)) if stop is None else stop, "stop", empty=True)
    region = _roi(roi)
    callback = Progress(progress)
    params_struct = _params_struct(params)
    lib = L.library()
    c_volume, array = volume_view(volume, spacing, origin, direction, axes)
    c_objects = (L.BalloonObjectSeeds * max(len(objects), 1))()
    for c, (label, points) in zip(c_objects, objects):
        c.label = label
        c.points = points.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
        c.point_count = len(points)
    handle = ctypes.c_void_p()
    status = lib.balloon_segment_objects(
        ctypes.byref(c_volume),
        ctypes.byref(params_struct),
        c_objects,
        len(objects),
        stops.ctypes.data_as(ctypes.POINTER(ctypes.c_double)) if len(stops) else None,
        len(stops),
        region,
        callback.c,
        None,
        ctypes.byref(handle),
    )
    del array, objects  # the voxels and seeds are read during the call only
    callback.check(status)
    try:
        count = ctypes.c_size_t()
        L.check(lib.balloon_objects_count(handle, ctypes.byref(count)))
        meshes = {}
        for index in range(count.value):
            label = ctypes.c_uint32()
            L.check(lib.balloon_objects_label(handle, index, ctypes.byref(label)))
            view = L.BalloonMesh()
            L.check(lib.balloon_objects_mesh(handle, index, ctypes.byref(view)))
            stats = L.BalloonStats(struct_size=ctypes.sizeof(L.BalloonStats))
            L.check(lib.balloon_objects_stats(handle, index, ctypes.byref(stats)))
            points, triangles, states = mesh_from_view(view)
            run_stats = {"label": label.value, **_stats_dict(stats)}
            meshes[label.value] = Mesh(points, triangles, states, run_stats)
        return meshes
    finally:
        lib.balloon_objects_free(handle)
