"""Cohorts from Python: the manifest of ``balloonseg batch`` (a CSV file, one case per row) read,
run case by case, and summed up in the same results table (``results.csv``, ``results.json``).

Each case reads its image with SimpleITK (the ``io`` extra) and runs :func:`balloonseg.segment`
with the row's seeds and parameters: its mesh has the same points and triangles, bit for bit, as
the mesh ``balloonseg segment`` (and ``balloonseg batch``) makes from that row. A case that fails
becomes a failed :class:`CaseResult` with its error, never an exception, so that one bad scan
does not stop a cohort. :func:`run_manifest` takes any ``map``; :mod:`balloonseg.dask` runs the
cases on a Dask cluster. Cases, results, meshes and errors all pickle.

>>> from balloonseg import cohort
>>> results = cohort.run_manifest("cohort.csv", "out/")
>>> [r.status for r in results]
['ok', 'ok', 'failed']
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from .errors import BalloonError, InvalidArgumentError
from .mesh import MESH_FORMATS
from .segmenter import _params_struct, parameter_info, segment_objects

#: The manifest's columns other than the parameters, as ``balloonseg batch`` reads them.
COLUMNS = ("id", "image", "seeds", "stops", "roi", "series", "coordinates")
#: The results table's columns, as ``balloonseg batch`` writes them.
RESULT_COLUMNS = (
    "id",
    "status",
    "seconds",
    "objects",
    "vertices",
    "triangles",
    "genus",
    "volume_mm3",
    "out_of_steps",
    "mesh",
    "error",
)
_ID = re.compile(r"[A-Za-z0-9_\-][A-Za-z0-9._\-]*")


@dataclass(frozen=True)
class Case:
    """One row of a manifest, checked: seeds by label and stops as given (world mm, voxel
    indices or RAS, after ``coordinates``), the parameters by their Python names."""

    id: str
    line: int
    image: str
    seeds: dict
    stops: tuple = ()
    roi: tuple | None = None
    coordinates: str = "world"
    params: dict = field(default_factory=dict)
    series: str | None = None


@dataclass
class CaseResult:
    """What a case gave: ``status`` "ok" or "failed", the mesh files written, their sizes, and
    for a failed case the error's class name and message. ``meshes`` holds the :class:`Mesh` of
    each object by label (empty for a failed case)."""

    id: str
    line: int
    status: str
    seconds: float
    mesh: list = field(default_factory=list)
    objects: int | None = None
    vertices: int | None = None
    triangles: int | None = None
    genus: list | None = None
    volume_mm3: float | None = None
    out_of_steps: bool | None = None
    error: str | None = None
    error_type: str | None = None
    meshes: dict = field(default_factory=dict, repr=False)


def _manifest_error(path, line, message) -> InvalidArgumentError:
    place = f", line {line}" if line is not None else ""
    return InvalidArgumentError(f"{path}{place}: {message}")


def _triples(text: str, what: str, path, line) -> list:
    points = []
    for item in filter(None, (t.strip() for t in text.split(";"))):
        label, _, point = item.rpartition(":")
        try:
            values = tuple(float(v) for v in point.split(","))
            label = int(label) if label else 1
        except ValueError as e:
            raise _manifest_error(path, line, f"'{item}' is not a {what}: {e}") from None
        if len(values) != 3 or label < 1:
            raise _manifest_error(path, line, f"'{item}' is not a {what} ([L:]x,y,z)")
        points.append((label, values))
    return points


def read_manifest(path) -> list[Case]:
    """Every row of the manifest as a :class:`Case`, checked as ``balloonseg batch`` checks it:
    the columns known, ids unique and fit for file names, images there, points of three numbers
    and parameters in range. Raises InvalidArgumentError naming the line."""
    path = Path(path)
    flags = {info.flag: name for name, info in parameter_info().items() if name != "threads"}
    try:
        text = path.read_text(encoding="utf-8-sig")
    except OSError as e:
        raise _manifest_error(path, None, f"cannot read it: {e}") from None
    rows = [
        (number, row)
        for number, row in enumerate(csv.reader(text.splitlines()), start=1)
        if row and not row[0].lstrip().startswith("#")
    ]
    if not rows:
        raise _manifest_error(path, None, "no header row")
    header = [h.strip() for h in rows[0][1]]
    for column in header:
        if column not in COLUMNS and column not in flags:
            raise _manifest_error(
                path,
                1,
                f"unknown column '{column}'; the columns are {', '.join(COLUMNS)} and the "
                f"parameters {', '.join(flags)}",
            )
    for required in ("id", "image", "seeds"):
        if required not in header:
            raise _manifest_error(path, 1, f"no '{required}' column")
    cases, ids = [], set()
    for line, row in rows[1:]:
        cells = {h: v.strip() for h, v in zip(header, row) if v.strip()}
        case_id = cells.get("id", "")
        if not _ID.fullmatch(case_id) or case_id == "results":
            raise _manifest_error(
                path, line, f"the id '{case_id}' cannot name the case's files"
            )
        if case_id in ids:
            raise _manifest_error(path, line, f"the id '{case_id}' is used twice")
        ids.add(case_id)
        image = path.parent / cells.get("image", "")
        if "image" not in cells or not image.exists():
            raise _manifest_error(path, line, f"the image {image} is not there")
        seeds: dict = {}
        for label, point in _triples(cells.get("seeds", ""), "seed", path, line):
            seeds.setdefault(label, []).append(point)
        if not seeds:
            raise _manifest_error(path, line, "no seed")
        stops = tuple(p for _, p in _triples(cells.get("stops", ""), "stop seed", path, line))
        roi = None
        if "roi" in cells:
            try:
                roi = tuple(float(v) for v in cells["roi"].split(","))
            except ValueError:
                roi = ()
            if len(roi) != 6:
                raise _manifest_error(path, line, f"roi '{cells['roi']}' is not 6 numbers")
        coordinates = cells.get("coordinates", "world")
        if coordinates not in ("world", "index", "ras"):
            raise _manifest_error(
                path, line, f"coordinates '{coordinates}' is not world, index or ras"
            )
        params = {}
        for flag, name in flags.items():
            if flag in cells:
                try:
                    params[name] = float(cells[flag])
                except ValueError:
                    raise _manifest_error(
                        path, line, f"{flag} '{cells[flag]}' is not a number"
                    ) from None
        try:
            _params_struct(params)
        except BalloonError as e:
            raise _manifest_error(path, line, e.message) from None
        cases.append(
            Case(
                id=case_id,
                line=line,
                image=str(image.resolve()),
                seeds={label: tuple(points) for label, points in seeds.items()},
                stops=stops,
                roi=roi,
                coordinates=coordinates,
                params=params,
                series=cells.get("series"),
            )
        )
    if not cases:
        raise _manifest_error(path, None, "no cases (rows after the header)")
    return cases


def _to_world(point, coordinates, geometry):
    """A point of the manifest in world mm, computed as the library computes it (origin plus
    the direction's columns scaled by the spacing, summed in axis order), so that the seed, and
    with it the mesh, is the command line's to the bit."""
    p = np.asarray(point, dtype=np.float64)
    if coordinates == "ras":
        return (-p[0], -p[1], p[2])
    if coordinates == "world":
        return tuple(p)
    columns = geometry["direction"] * np.asarray(geometry["spacing"])[None, :]
    world = columns[:, 0] * p[0] + columns[:, 1] * p[1] + columns[:, 2] * p[2]
    return tuple(np.asarray(geometry["origin"]) + world)


def _mesh_suffix(format: str) -> str:
    suffix = "." + format.lstrip(".").lower()
    if suffix not in MESH_FORMATS:
        raise InvalidArgumentError(f"format '{format}' is not one of {', '.join(MESH_FORMATS)}")
    return suffix


def _is_case_mesh(name: str, case_id: str, suffix: str) -> bool:
    """Whether a file name is one of the case's meshes: ID.EXT, or ID_L.EXT for label L."""
    if not (name.startswith(case_id) and name.endswith(suffix)):
        return False
    label = name[len(case_id) : len(name) - len(suffix)]
    return label == "" or (label.startswith("_") and label[1:].isdigit())


def _image_clash(case: Case, output_dir: Path, suffix: str) -> str | None:
    """Why the case's meshes would replace its own image (a .vtk volume beside ID.vtk), or None."""
    image = Path(case.image).resolve()
    if image.parent == output_dir.resolve() and _is_case_mesh(image.name, case.id, suffix):
        return (
            f"case {case.id} (line {case.line}) would write {image} over its own image; give "
            "another id, format or output folder"
        )
    return None


def check_outputs(cases, output_dir, format: str = "vtp") -> None:
    """Raises InvalidArgumentError when a case's meshes would replace its own image, before
    anything runs (``balloonseg batch`` refuses such a manifest too)."""
    suffix = _mesh_suffix(format)
    for case in cases:
        clash = _image_clash(case, Path(output_dir), suffix)
        if clash:
            raise InvalidArgumentError(clash)


def _read_image(path: str, series: str | None):
    """The volume as the CLI reads it: a file, or a folder holding a DICOM series (the one it
    holds, or ``series``, a SeriesInstanceUID) read by SimpleITK's ImageSeriesReader, sorted along
    the slice normal by GDCM as the CLI sorts it. The CLI's checks (unequal gaps, a tilted
    gantry) are not repeated here; ITK only warns about them."""
    import SimpleITK as sitk

    if not Path(path).is_dir():
        if series is not None:
            raise InvalidArgumentError(f"{path}: a DICOM series can only be chosen in a folder")
        return sitk.ReadImage(path)
    uids = sitk.ImageSeriesReader.GetGDCMSeriesIDs(path)
    if series is None and len(uids) != 1:
        listed = ", ".join(uids) if uids else "none"
        raise InvalidArgumentError(
            f"{path}: the folder holds {len(uids)} DICOM series ({listed}); choose one with the "
            "manifest's series column"
        )
    uid = uids[0] if series is None else series
    if uid not in uids:
        raise InvalidArgumentError(f"{path}: no DICOM series {uid} in this folder")
    reader = sitk.ImageSeriesReader()
    reader.SetFileNames(sitk.ImageSeriesReader.GetGDCMSeriesFileNames(path, uid))
    return reader.Execute()


def run_case(case: Case, output_dir, format: str = "vtp", threads: int = 0) -> CaseResult:
    """Runs one case and writes its meshes to ``output_dir`` (``ID.FORMAT``, or ``ID_L.FORMAT``
    for each label L of a case with several), after removing what an earlier run of the case
    left there. Returns its :class:`CaseResult`; a failure is recorded in it, not raised."""
    import SimpleITK as sitk

    output_dir = Path(output_dir)
    suffix = _mesh_suffix(format)
    start = time.perf_counter()
    clash = _image_clash(case, output_dir, suffix)
    if clash:
        return CaseResult(
            id=case.id,
            line=case.line,
            status="failed",
            seconds=0.0,
            error=clash,
            error_type="InvalidArgumentError",
        )
    # Only the case's own meshes: the folder may also hold the images (scan1.mha beside
    # scan1.vtp).
    for old in output_dir.glob(f"{case.id}*{suffix}"):
        if _is_case_mesh(old.name, case.id, suffix):
            old.unlink()
    try:
        image = _read_image(case.image, case.series)
        geometry = {
            "spacing": image.GetSpacing(),
            "origin": image.GetOrigin(),
            "direction": np.reshape(image.GetDirection(), (3, 3)),
        }
        world = {
            label: np.array([_to_world(p, case.coordinates, geometry) for p in points])
            for label, points in sorted(case.seeds.items())
        }
        stops = [_to_world(p, case.coordinates, geometry) for p in case.stops]
        roi = case.roi
        if roi is not None and case.coordinates == "ras":
            roi = (-roi[0], -roi[1], roi[2], -roi[3], -roi[4], roi[5])
        meshes = segment_objects(
            sitk.GetArrayViewFromImage(image),
            world,
            spacing=geometry["spacing"],
            origin=geometry["origin"],
            direction=geometry["direction"].ravel(),
            stop=np.array(stops) if stops else None,
            roi=roi,
            threads=threads,
            **case.params,
        )
        paths = []
        for label, mesh in meshes.items():
            name = case.id if len(meshes) == 1 else f"{case.id}_{label}"
            paths.append(str(output_dir / f"{name}{suffix}"))
            mesh.save(paths[-1])
    except (BalloonError, OSError, RuntimeError) as e:
        return CaseResult(
            id=case.id,
            line=case.line,
            status="failed",
            seconds=time.perf_counter() - start,
            error=getattr(e, "message", str(e)),
            error_type=type(e).__name__,
        )
    stats = [m.stats for m in meshes.values()]
    return CaseResult(
        id=case.id,
        line=case.line,
        status="ok",
        seconds=time.perf_counter() - start,
        mesh=paths,
        objects=len(meshes),
        vertices=sum(s["vertices"] for s in stats),
        triangles=sum(s["triangles"] for s in stats),
        genus=[s["genus"] for s in stats],
        volume_mm3=sum(s["volume_mm3"] for s in stats),
        meshes=meshes,
    )


def write_results(results, output_dir) -> None:
    """``results.json`` and ``results.csv`` in ``output_dir``, in the layout of
    ``balloonseg batch`` (the meshes themselves are not in them)."""
    output_dir = Path(output_dir)
    rows = [{k: v for k, v in asdict(r).items() if k != "meshes"} for r in results]
    _replace(output_dir / "results.json", json.dumps({"cases": rows}, indent=2))
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(RESULT_COLUMNS)
    for row in rows:
        cells = []
        for column in RESULT_COLUMNS:
            value = row.get(column)
            if value is None:
                cells.append("")
            elif isinstance(value, list):
                cells.append(";".join(map(str, value)))
            elif isinstance(value, bool):
                cells.append(str(value).lower())
            else:
                cells.append(str(value))
        writer.writerow(cells)
    _replace(output_dir / "results.csv", text.getvalue())


def _replace(path: Path, text: str) -> None:
    partial = path.with_suffix(".partial")
    partial.write_text(text)
    os.replace(partial, path)


def run_manifest(manifest, output_dir, *, format: str = "vtp", map=map, threads: int = 0):
    """Reads ``manifest``, runs every case through ``map`` (the built-in one: one after
    another; any map-like callable, e.g. a process pool's) and writes the results table.
    Returns the :class:`CaseResult` of each case in the manifest's order."""
    cases = read_manifest(manifest)
    check_outputs(cases, output_dir, format)
    output_dir = Path(output_dir)
    output_dir.mkdir(parents=True, exist_ok=True)
    results = list(
        map(
            run_case,
            cases,
            [output_dir] * len(cases),
            [format] * len(cases),
            [threads] * len(cases),
        )
    )
    write_results(results, output_dir)
    return results
