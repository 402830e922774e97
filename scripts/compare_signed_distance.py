#!/usr/bin/env python3
"""Same-run comparison of balloonseg's signed distance with libigl's, on the aorta scan's grid.

For two closed surfaces — the synthetic 12,928-triangle tube of `benches/signed_distance.rs`, and
vmtk's reference aorta surface (12,932 triangles) if the shared data folder is present — it times
`balloonseg::signed_distance` (band of 3 voxels + sign everywhere, through
`examples/signed_distance_case.rs`) and `igl.signed_distance` with the fast winding number sign
(on all 157x393x34 voxel centres, as the C++ pipeline it replaces did; also with libigl's
`upper_bound` set to the band, the closest it has to a narrow band), and checks the result: the
same sign as libigl's away from the surface, and |field| = min(exact distance, band) everywhere
(exact distance from libigl's point_mesh_squared_distance).

Usage: python scripts/compare_signed_distance.py [--repeats N] [--data DIR]
Needs numpy and libigl (and vtk for the reference surface). Timings from one run on the same
machine; compare them as ratios.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXAMPLE = os.path.join(ROOT, "target", "release", "examples", "signed_distance_case")


def run_example(*args):
    out = subprocess.run([EXAMPLE, *args], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def read_mesh(folder):
    points = np.fromfile(os.path.join(folder, "points.f64"), dtype="<f8").reshape(-1, 3)
    triangles = np.fromfile(os.path.join(folder, "triangles.u32"), dtype="<u4").reshape(-1, 3)
    return points, triangles


def write_mesh(folder, points, triangles):
    np.ascontiguousarray(points, dtype="<f8").tofile(os.path.join(folder, "points.f64"))
    np.ascontiguousarray(triangles, dtype="<u4").tofile(os.path.join(folder, "triangles.u32"))


def voxel_centres(grid):
    """World positions of every voxel centre, i fastest (ITK: origin + D (spacing * index))."""
    ni, nj, nk = grid["dims"]
    k, j, i = np.meshgrid(np.arange(nk), np.arange(nj), np.arange(ni), indexing="ij")
    index = np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1).astype(np.float64)
    direction = np.array(grid["direction"], dtype=np.float64).reshape(3, 3)
    linear = direction * np.array(grid["spacing"])[None, :]
    return np.array(grid["origin"]) + index @ linear.T


def reference_aorta(data):
    """vmtk's reference surface in the image's world space, outward (see the data README)."""
    path = os.path.join(data, "vmtk-aorta", "aorta-reference-surface.vtp")
    if not os.path.exists(path):
        return None
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy

    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(path)
    reader.Update()
    poly = reader.GetOutput()
    points = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64)
    cells = vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).reshape(-1, 3)
    # Its x and y are the image's negated; its triangles face inward.
    points[:, :2] *= -1.0
    return points, cells[:, [0, 2, 1]].astype(np.uint32)


def compare(name, folder, grid, repeats):
    import igl

    points, triangles = read_mesh(folder)
    ours = run_example("time", folder, str(repeats))
    field = np.fromfile(os.path.join(folder, "field.f64"), dtype="<f8")
    band = ours["band_mm"]
    centres = voxel_centres(grid)
    faces = triangles.astype(np.int64)
    fwn = igl.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER

    start = time.perf_counter()
    full, _, _, _ = igl.signed_distance(centres, points, faces, sign_type=fwn)
    igl_full = time.perf_counter() - start
    start = time.perf_counter()
    banded, _, _, _ = igl.signed_distance(
        centres, points, faces, sign_type=fwn, lower_bound=-band, upper_bound=band
    )
    igl_banded = time.perf_counter() - start

    # libigl's fast-winding-number distance is |d|·(1 − 2|w|) with an approximate w, so its
    # magnitude is off by up to a few percent: distances are checked against its exact unsigned
    # point-to-mesh distance instead (not timed), signs against its sign away from the surface.
    exact = np.sqrt(igl.point_mesh_squared_distance(centres, points, faces)[0])
    away = exact > 0.05
    sign_mismatch = int(np.count_nonzero((field[away] < 0) != (full[away] < 0)))
    distance_error = float(np.max(np.abs(np.abs(field) - np.minimum(exact, band))))
    return {
        "case": name,
        "triangles": int(len(triangles)),
        "voxels": int(field.size),
        "voxels_within_band": int(np.count_nonzero(exact < band)),
        "balloonseg_s_min": ours["seconds_min"],
        "balloonseg_s_median": ours["seconds_median"],
        "balloonseg_threads": ours["threads"],
        "igl_fwn_full_s": igl_full,
        "igl_fwn_band_bounded_s": igl_banded,
        "ratio_igl_full_over_ours_median": igl_full / ours["seconds_median"],
        "ratio_igl_bounded_over_ours_median": igl_banded / ours["seconds_median"],
        "sign_mismatches_beyond_0.05mm": sign_mismatch,
        "max_difference_from_min_exact_band_mm": distance_error,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=10, help="timed runs of balloonseg")
    parser.add_argument(
        "--data",
        default=os.environ.get("BALLOONSEG_DATA", os.path.join(ROOT, "..", "shared", "data")),
        help="the shared data folder (for the reference aorta surface)",
    )
    args = parser.parse_args()
    subprocess.run(
        ["cargo", "build", "--release", "--quiet", "--example", "signed_distance_case"],
        cwd=ROOT,
        check=True,
    )
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        tube = os.path.join(tmp, "tube")
        os.mkdir(tube)
        grid = run_example("export", tube)
        results.append(compare("synthetic tube", tube, grid, args.repeats))
        aorta = reference_aorta(args.data)
        if aorta is None:
            print("reference aorta surface not found under --data; skipped", file=sys.stderr)
        else:
            folder = os.path.join(tmp, "aorta")
            os.mkdir(folder)
            write_mesh(folder, *aorta)
            results.append(compare("vmtk reference aorta", folder, grid, args.repeats))
    print(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
