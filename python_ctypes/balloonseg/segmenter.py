"""``Segmenter``: the balloon of libballoonseg on a numpy volume, step by step or to the end,
with a progress callback that may cancel; ``segment`` for the one-call case."""

from __future__ import annotations

import ctypes
import functools
from typing import NamedTuple

import numpy as np

from . import _library as L
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


def _seeds(seed) -> np.ndarray:
    try:
        seeds = np.asarray(seed, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentError(f"seed must be numbers (x, y, z) in mm, got {seed!r}") from e
    if seeds.ndim == 1:
        seeds = seeds[None, :]
    if seeds.ndim != 2 or seeds.shape[1] != 3 or len(seeds) == 0:
        raise InvalidArgumentError(
            f"seed must be one point (x, y, z) or K points as a (K, 3) array in world mm, got "
            f"shape {np.shape(seed)}"
        )
    return seeds


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
        if callback is not None and not callable(callback):
            raise InvalidArgumentError(f"progress must be callable or None, got {callback!r}")
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
                "total": s.seconds_total,
            },
        }


def segment(
    volume,
    seed,
    spacing=(1.0, 1.0, 1.0),
    origin=(0.0, 0.0, 0.0),
    direction=None,
    axes: str = "zyx",
    progress=None,
    **params,
) -> Mesh:
    """Segments the structure around ``seed`` (see :class:`Segmenter` for the arguments) and
    returns its surface."""
    with Segmenter(volume, seed, spacing, origin, direction, axes, progress, **params) as s:
        return s.segment()
