#!/usr/bin/env python3
"""Compare balloonseg's marching cubes with VTK's vtkFlyingEdges3D, for speed and for output.

Runs both on the same float32 fields in the same process run: a torus distance field and a
gyroid (N^3, default 512), small versions of both plus a field with many samples exactly at the
level (correctness only), and the vmtk aorta reference level set at level 0. For each case it
checks that

* the vertex positions are the same set (VTK stores float32 points, so ours are rounded to
  float32 first; in index space they must then be identical, in world space equal to a few float32
  ulps),
* the triangles are the same set of position triples (VTK's normals point towards decreasing
  values in index space, and it does not rewind them for a left-handed geometry; ours point
  towards increasing values in world space),
* area and signed volume agree to 1e-6 relative (volume: relative to area x grid diagonal, since an
  open surface can enclose almost nothing),

and prints a table: case, VTK seconds, ours seconds, ratio (ours/VTK), counts, errors, whether
the triangle sets matched (skipped above 3 M triangles, too slow in numpy) and whether all checks
passed. Timings are the best of --repeat runs; both use --threads threads (VTK through
vtkSMPTools' STDThread backend; VTK's default backend here is Sequential).

    /tmp/venv/bin/python scripts/compare_marching_cubes.py [--size 512] [--threads 2] [--repeat 5]

Build the example first: cargo build --release --example isosurface_raw
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import vtk
from vtk.util import numpy_support

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXAMPLE = os.path.join(ROOT, "target", "release", "examples", "isosurface_raw")
DATA = os.environ.get("BALLOONSEG_DATA", os.path.join(ROOT, "..", "shared", "data"))
AORTA = os.path.join(DATA, "vmtk-aorta", "aorta-reference-levelset.mha")
IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


class Case:
    """A float32 field indexed [k, j, i] with its geometry and level."""

    def __init__(self, name, field, level=0.0, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0),
                 direction=IDENTITY, timed=True):
        self.name = name
        self.field = np.ascontiguousarray(field, dtype=np.float32)
        self.level = level
        self.spacing = tuple(float(s) for s in spacing)
        self.origin = tuple(float(o) for o in origin)
        self.direction = tuple(float(d) for d in direction)
        self.timed = timed

    @property
    def dims(self):
        nz, ny, nx = self.field.shape
        return nx, ny, nz

    @property
    def index_space(self):
        return (self.spacing == (1.0, 1.0, 1.0) and self.origin == (0.0, 0.0, 0.0)
                and self.direction == IDENTITY)


def coordinates(n, lo, hi):
    x = np.linspace(lo, hi, n, dtype=np.float64)
    return x[None, None, :], x[None, :, None], x[:, None, None]


def torus(n):
    x, y, z = coordinates(n, -1.0, 1.0)
    return np.sqrt((np.sqrt(x * x + y * y) - 0.55) ** 2 + z * z) - 0.25


def gyroid(n, periods=8):
    x, y, z = coordinates(n, 0.0, 2.0 * math.pi * periods)
    return np.sin(x) * np.cos(y) + np.sin(y) * np.cos(z) + np.sin(z) * np.cos(x)


def exact_hits(n):
    """Integer-valued squared distance: many samples exactly on the level (the skimage #8116 case)."""
    i = np.arange(n) - (n - 1) // 2
    return (i[None, None, :] ** 2 + i[None, :, None] ** 2 + i[:, None, None] ** 2).astype(np.float64)


def aorta_case():
    reader = vtk.vtkMetaImageReader()
    reader.SetFileName(AORTA)
    reader.Update()
    image = reader.GetOutput()
    nx, ny, nz = image.GetDimensions()
    field = numpy_support.vtk_to_numpy(image.GetPointData().GetScalars()).reshape(nz, ny, nx)
    m = image.GetDirectionMatrix()
    direction = tuple(m.GetElement(r, c) for r in range(3) for c in range(3))
    world = Case("aorta", field, 0.0, image.GetSpacing(), image.GetOrigin(), direction)
    return [Case("aorta (index)", field, 0.0, timed=False), world]


def vtk_image(case):
    nx, ny, nz = case.dims
    image = vtk.vtkImageData()
    image.SetDimensions(nx, ny, nz)
    image.SetSpacing(case.spacing)
    image.SetOrigin(case.origin)
    image.SetDirectionMatrix(case.direction)
    scalars = numpy_support.numpy_to_vtk(case.field.ravel(), deep=1)
    image.GetPointData().SetScalars(scalars)
    return image


def run_vtk(case, repeat):
    contour = vtk.vtkFlyingEdges3D()
    contour.SetInputData(vtk_image(case))
    contour.SetValue(0, case.level)
    contour.ComputeNormalsOff()
    contour.ComputeGradientsOff()
    contour.ComputeScalarsOff()
    best = math.inf
    for _ in range(repeat):
        contour.Modified()
        start = time.perf_counter()
        contour.Update()
        best = min(best, time.perf_counter() - start)
    output = contour.GetOutput()
    if output.GetNumberOfPoints() == 0:
        return best, np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int64)
    points = numpy_support.vtk_to_numpy(output.GetPoints().GetData()).copy()
    cells = output.GetPolys()
    triangles = numpy_support.vtk_to_numpy(cells.GetConnectivityArray()).reshape(-1, 3).copy()
    return best, points, triangles


def run_ours(case, repeat, threads, workdir):
    raw = os.path.join(workdir, "field.raw")
    points_file = os.path.join(workdir, "points.f64")
    triangles_file = os.path.join(workdir, "triangles.u32")
    case.field.astype("<f4").tofile(raw)
    command = [EXAMPLE, raw, *map(str, case.dims), "--level", repr(case.level),
               "--spacing", *map(repr, case.spacing), "--origin", *map(repr, case.origin),
               "--direction", *map(repr, case.direction), "--threads", str(threads),
               "--repeat", str(repeat), "--points", points_file, "--triangles", triangles_file]
    result = json.loads(subprocess.run(command, check=True, capture_output=True, text=True).stdout)
    points = np.fromfile(points_file, dtype="<f8").reshape(-1, 3)
    triangles = np.fromfile(triangles_file, dtype="<u4").reshape(-1, 3).astype(np.int64)
    return result, points, triangles


def area(points, triangles):
    a, b, c = (points[triangles[:, n]] for n in range(3))
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum()


def signed_volume(points, triangles):
    """As TriMesh::signed_volume: divergence theorem about the bounding-box centre."""
    if len(triangles) == 0:
        return 0.0
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    a, b, c = (points[triangles[:, n]] - centre for n in range(3))
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0


def unique_rows(a):
    return np.unique(a, axis=0)


def same_point_sets(ours32, theirs, index_space):
    """Unique float32 positions: identical in index space, else within a few float32 ulps."""
    u, v = unique_rows(ours32), unique_rows(theirs)
    if index_space:
        return u.shape == v.shape and bool(np.array_equal(u, v)), 0.0
    from scipy.spatial import cKDTree

    scale = np.abs(v).max() if len(v) else 1.0
    d1, _ = cKDTree(v.astype(np.float64)).query(u.astype(np.float64))
    d2, _ = cKDTree(u.astype(np.float64)).query(v.astype(np.float64))
    worst = max(d1.max(initial=0.0), d2.max(initial=0.0))
    return bool(worst <= 8 * np.finfo(np.float32).eps * scale), float(worst)


def lexicographic_less(a, b):
    """Row-wise a < b for (n, 3) integer arrays."""
    return (a[:, 0] < b[:, 0]) | ((a[:, 0] == b[:, 0]) & (
        (a[:, 1] < b[:, 1]) | ((a[:, 1] == b[:, 1]) & (a[:, 2] < b[:, 2]))))


def same_triangles(ours32, our_triangles, theirs, their_triangles, reverse_theirs):
    """Same multiset of triangles, each as its three float32 corners up to rotation."""
    if len(our_triangles) != len(their_triangles):
        return False
    if len(our_triangles) > 3_000_000:
        return None  # too slow in numpy; counts, point sets, area and volume are still checked
    if reverse_theirs:
        their_triangles = their_triangles[:, [0, 2, 1]]
    corners = np.concatenate([ours32[our_triangles].reshape(-1, 3),
                              theirs[their_triangles].reshape(-1, 3)])
    _, ids = np.unique(corners, axis=0, return_inverse=True)
    ids = ids.reshape(-1, 3)
    best = ids
    for shift in (1, 2):
        rotated = np.roll(ids, -shift, axis=1)
        best = np.where(lexicographic_less(rotated, best)[:, None], rotated, best)
    n = len(our_triangles)
    a, b = (np.unique(x, axis=0, return_counts=True) for x in (best[:n], best[n:]))
    return all(np.array_equal(x, y) for x, y in zip(a, b))


def snap(ours32, theirs):
    """Our points replaced by the nearest of VTK's (world space: VTK transforms in float32)."""
    from scipy.spatial import cKDTree

    if len(theirs) == 0:
        return ours32
    _, nearest = cKDTree(theirs.astype(np.float64)).query(ours32.astype(np.float64))
    return theirs[nearest]


def compare(case, repeat, threads, workdir):
    vtk_seconds, vtk_points, vtk_triangles = run_vtk(case, repeat if case.timed else 1)
    ours, our_points, our_triangles = run_ours(case, repeat if case.timed else 1, threads, workdir)
    ours32 = our_points.astype(np.float32)
    points_ok, worst = same_point_sets(ours32, vtk_points, case.index_space)
    # VTK's right-hand normals point towards decreasing values in index space; it does not
    # reverse the winding for a left-handed geometry, we do (normals towards increasing values).
    vtk_reversed = np.linalg.det(np.array(case.direction).reshape(3, 3)) > 0
    matched = ours32 if case.index_space else snap(ours32, vtk_points)
    triangles_ok = same_triangles(matched, our_triangles, vtk_points, vtk_triangles, vtk_reversed)
    vtk64 = vtk_points.astype(np.float64)
    vtk_area, our_area = area(vtk64, vtk_triangles), area(our_points, our_triangles)
    vtk_volume = (-1.0 if vtk_reversed else 1.0) * signed_volume(vtk64, vtk_triangles)
    our_volume = signed_volume(our_points, our_triangles)
    diagonal = np.linalg.norm(np.array(case.dims) * np.array(case.spacing))
    area_error = abs(our_area - vtk_area) / max(vtk_area, 1e-300)
    volume_error = abs(our_volume - vtk_volume) / max(abs(vtk_volume), vtk_area * diagonal, 1e-300)
    # The example's own area and volume, computed in Rust, must agree with numpy's on its output.
    self_check = (abs(ours["area"] - our_area) <= 1e-9 * max(our_area, 1.0)
                  and abs(ours["volume"] - our_volume) <= 1e-9 * max(abs(our_volume), 1.0))
    ok = (points_ok and triangles_ok is not False and area_error <= 1e-6
          and volume_error <= 1e-6 and self_check
          and len(our_points) == len(vtk_points) and len(our_triangles) == len(vtk_triangles))
    return {
        "case": case.name, "dims": "x".join(map(str, case.dims)), "timed": case.timed,
        "vtk_s": vtk_seconds, "ours_s": ours["seconds"],
        "vtk_points": len(vtk_points), "our_points": len(our_points),
        "vtk_triangles": len(vtk_triangles), "our_triangles": len(our_triangles),
        "points_ok": bool(points_ok), "worst_distance": worst, "triangles_ok": triangles_ok,
        "area": our_area, "area_error": area_error, "volume": our_volume,
        "volume_error": volume_error, "ok": bool(ok),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=512, help="N of the N^3 torus and gyroid")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--no-aorta", action="store_true")
    args = parser.parse_args()
    if not os.path.exists(EXAMPLE):
        sys.exit(f"{EXAMPLE} is missing: cargo build --release --example isosurface_raw")
    vtk.vtkSMPTools.SetBackend("STDThread")
    vtk.vtkSMPTools.Initialize(args.threads)
    print(f"VTK {vtk.vtkVersion.GetVTKVersion()}, SMP backend {vtk.vtkSMPTools.GetBackend()}, "
          f"{vtk.vtkSMPTools.GetEstimatedNumberOfThreads()} threads; ours {args.threads} threads")

    n = args.size
    cases = [
        Case("torus small", torus(41), timed=False),
        Case("gyroid small", gyroid(37, 2), timed=False),
        Case("exact hits", exact_hits(23), level=49.0, timed=False),
        Case("gyroid oblique", gyroid(30, 2), spacing=(0.7, 1.1, 1.9), origin=(3.0, -2.0, 5.0),
             direction=(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0), timed=False),
        Case(f"torus {n}", torus(n)),
        Case(f"gyroid {n}", gyroid(n)),
    ]
    if not args.no_aorta:
        if os.path.exists(AORTA):
            cases += aorta_case()
        else:
            print(f"skipping the aorta: {AORTA} not found")

    rows = []
    with tempfile.TemporaryDirectory() as workdir:
        for case in cases:
            rows.append(compare(case, args.repeat, args.threads, workdir))
            r = rows[-1]
            print(json.dumps(r, default=str), file=sys.stderr)

    header = (f"{'case':<16} {'dims':<12} {'VTK s':>8} {'ours s':>8} {'ratio':>6} "
              f"{'points':>10} {'triangles':>10} {'area rel':>9} {'vol rel':>9} {'tri set':>7} {'same':>5}")
    print(header)
    print("-" * len(header))
    for r in rows:
        ratio = r["ours_s"] / r["vtk_s"] if r["vtk_s"] > 0 else math.nan
        print(f"{r['case']:<16} {r['dims']:<12} {r['vtk_s']:>8.4f} {r['ours_s']:>8.4f} "
              f"{ratio:>6.2f} {r['our_points']:>10} {r['our_triangles']:>10} "
              f"{r['area_error']:>9.1e} {r['volume_error']:>9.1e} "
              f"{ {True: 'yes', False: 'NO', None: 'skipped'}[r['triangles_ok']]:>7} "
              f"{'yes' if r['ok'] else 'NO':>5}")
        if r["vtk_points"] != r["our_points"] or r["vtk_triangles"] != r["our_triangles"]:
            print(f"  VTK counts: {r['vtk_points']} points, {r['vtk_triangles']} triangles")
    failed = [r["case"] for r in rows if not r["ok"]]
    if failed:
        sys.exit(f"mismatch in: {', '.join(failed)}")


if __name__ == "__main__":
    main()
