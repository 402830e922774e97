#!/usr/bin/env python3
"""Error-bounded simplification against the peers, in one run on the same meshes (issue 17).

For each MESH:BOUND given, `balloonseg simplify` reduces the mesh within BOUND mm (both ways);
then each peer is asked for the same triangle count: vtkQuadricDecimation, pyvista's
fast-simplification, meshoptimizer's simplifier and OpenMesh's decimater (C++, ModQuadricT;
built from cpp_tests/openmesh_decimate.cpp with g++ and libopenmesh-dev). Every result is measured the same way:
time of the simplification call alone (ours: the time the command reports, without reading and
writing), `balloonseg hausdorff` both ways (exact point-to-triangle distances from a lattice of
samples), and `balloonseg check` (self-intersecting pairs, closed, manifold, genus).
Prints a markdown table; the time ratio is the peer's time over ours.

    .venv/bin/pip install fast-simplification meshoptimizer
    .venv/bin/python scripts/simplify_peers.py aorta.vtp:0.1 aorta.vtp:0.25

Without arguments: the aorta's balloon from BALLOONSEG_DATA (or ../shared/data) at 0.1 and
0.25 mm, and isosurfaces of the double-torus phantom with about 320k and 1.3M triangles at 0.1 mm.
"""
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import vtk
from vtk.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray, vtk_to_numpy

ROOT = Path(__file__).resolve().parent.parent
BIN = os.environ.get("BALLOONSEG_BIN", str(ROOT / "target/release/balloonseg"))


def run(*args):
    done = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True)
    if done.returncode != 0 and args[0] != "check":
        sys.exit(f"balloonseg {' '.join(map(str, args))} failed: {done.stderr}")
    return done


def read(path):
    reader = vtk.vtkXMLPolyDataReader() if str(path).endswith(".vtp") else vtk.vtkPLYReader()
    reader.SetFileName(str(path))
    reader.Update()
    poly = reader.GetOutput()
    points = vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64)
    faces = vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).reshape(-1, 3)
    return points, faces.astype(np.int64)


def to_polydata(points, faces):
    poly = vtk.vtkPolyData()
    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(points, dtype=np.float64), deep=True))
    poly.SetPoints(pts)
    cells = vtk.vtkCellArray()
    offsets = np.arange(0, 3 * len(faces) + 1, 3, dtype=np.int64)
    cells.SetData(
        numpy_to_vtkIdTypeArray(offsets, deep=True),
        numpy_to_vtkIdTypeArray(np.ascontiguousarray(faces.ravel(), dtype=np.int64), deep=True),
    )
    poly.SetPolys(cells)
    return poly


def write(path, points, faces):
    writer = vtk.vtkXMLPolyDataWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(to_polydata(points, faces))
    writer.Write()


def vtk_quadric(points, faces, count):
    dec = vtk.vtkQuadricDecimation()
    dec.SetInputData(to_polydata(points, faces))
    dec.SetTargetReduction(1.0 - count / len(faces))
    start = time.perf_counter()
    dec.Update()
    seconds = time.perf_counter() - start
    out = dec.GetOutput()
    return (
        vtk_to_numpy(out.GetPoints().GetData()).astype(np.float64),
        vtk_to_numpy(out.GetPolys().GetConnectivityArray()).reshape(-1, 3),
        seconds,
    )


def fast_simplification(points, faces, count):
    import fast_simplification as fs

    start = time.perf_counter()
    p, f = fs.simplify(points, faces, target_reduction=1.0 - count / len(faces))
    return p, f, time.perf_counter() - start


def meshoptimizer(points, faces, count):
    import meshoptimizer as mo

    indices = np.ascontiguousarray(faces.ravel(), dtype=np.uint32)
    positions = np.ascontiguousarray(points, dtype=np.float32)
    destination = np.zeros_like(indices)
    start = time.perf_counter()
    n = mo.simplify(destination, indices, positions, target_index_count=3 * count, target_error=1.0)
    seconds = time.perf_counter() - start
    kept = destination[:n].reshape(-1, 3)
    used, remap = np.unique(kept, return_inverse=True)
    return points[used], remap.reshape(-1, 3), seconds


OPENMESH_SRC = ROOT / "cpp_tests/openmesh_decimate.cpp"
OPENMESH_BIN = ROOT / "target/openmesh_decimate"


def write_off(path, points, faces):
    with open(path, "w") as f:
        f.write(f"OFF\n{len(points)} {len(faces)} 0\n")
        np.savetxt(f, points, fmt="%.17g")
        np.savetxt(f, np.hstack([np.full((len(faces), 1), 3), faces]), fmt="%d")


def read_off(path):
    with open(path) as f:
        words = f.read().split()
    assert words[0] == "OFF", path
    n, m = int(words[1]), int(words[2])
    numbers = words[4 : 4 + 3 * n]
    points = np.array(numbers, dtype=np.float64).reshape(n, 3)
    faces = np.array(words[4 + 3 * n : 4 + 3 * n + 4 * m], dtype=np.int64).reshape(m, 4)
    assert (faces[:, 0] == 3).all(), "OpenMesh wrote a face that is not a triangle"
    return points, faces[:, 1:]


def openmesh(points, faces, count):
    """OpenMesh's DecimaterT with ModQuadricT (cpp_tests/openmesh_decimate.cpp, compiled on
    first use against the system's OpenMesh); the time is the program's own, decimation alone."""
    if not OPENMESH_BIN.exists() or OPENMESH_BIN.stat().st_mtime < OPENMESH_SRC.stat().st_mtime:
        subprocess.run(
            ["g++", "-O2", "-DNDEBUG", "-std=c++17", str(OPENMESH_SRC), "-lOpenMeshTools",
             "-lOpenMeshCore", "-o", str(OPENMESH_BIN)],
            check=True,
        )
    with tempfile.TemporaryDirectory() as folder:
        source, result = Path(folder) / "in.off", Path(folder) / "out.off"
        write_off(source, points, faces)
        done = subprocess.run([str(OPENMESH_BIN), source, result, str(count)],
                              capture_output=True, text=True, check=True)
        p, f = read_off(result)
    return p, f, float(done.stdout)


PEERS = [
    ("vtkQuadricDecimation", vtk_quadric),
    ("fast-simplification", fast_simplification),
    ("meshoptimizer", meshoptimizer),
    ("OpenMesh DecimaterT", openmesh),
]


def measure(reference, path):
    distances = json.loads(run("hausdorff", reference, path).stdout)
    report = json.loads(run("check", path).stdout)
    return distances, report


def row(name, mesh, bound, triangles, seconds, ours_seconds, distances, report):
    valid = report["closed"] and report["manifold"] and report["oriented"]
    return (
        f"| {name} | {Path(mesh).name} @ {bound} mm | {triangles:,} | {seconds:.3f} s | "
        f"{seconds / ours_seconds:.3f} | {distances['a_to_b_mm']:.4f} / {distances['b_to_a_mm']:.4f} | "
        f"{report['self_intersecting_pairs']} | {report['genus']} | {'yes' if valid else 'no'} |"
    )


def default_cases(scratch):
    data = Path(os.environ.get("BALLOONSEG_DATA", ROOT.parent / "shared/data"))
    aorta = scratch / "aorta.vtp"
    run("segment", data / "vmtk-aorta/aorta.mha", "--seed", "74,150,15", "--index", "-o", aorta)
    cases = [(aorta, 0.1), (aorta, 0.25)]
    for spacing, name in [("0.175,0.175,0.175", "iso320k.vtp"), ("0.087,0.087,0.087", "iso1300k.vtp")]:
        volume = scratch / f"{name}.mha"
        run("phantom", "double-torus", "--blur", "1.5", "--spacing", spacing, "-o", volume)
        run("isosurface", volume, "--level", "500", "-o", scratch / name)
        cases.append((scratch / name, 0.1))
    return cases


def main():
    scratch = Path(tempfile.mkdtemp(prefix="simplify-peers-"))
    cases = [(Path(a.rsplit(":", 1)[0]), float(a.rsplit(":", 1)[1])) for a in sys.argv[1:]]
    cases = cases or default_cases(scratch)
    print("| simplifier | mesh @ bound | triangles | time | time / ours | Hausdorff in→out / out→in (mm) "
          "| self-intersecting pairs | genus | closed, manifold, oriented |")
    print("|---|---|---|---|---|---|---|---|---|")
    for mesh, bound in cases:
        points, faces = read(mesh)
        ours = scratch / f"{mesh.stem}-{bound}-ours.vtp"
        done = run("simplify", mesh, "--max-error", bound, "-o", ours)
        ours_seconds = float(re.search(r"\(([0-9.]+) s\)", done.stderr).group(1))
        count = len(read(ours)[1])
        print(row("balloonseg", mesh, bound, count, ours_seconds, ours_seconds, *measure(mesh, ours)))
        for name, simplify in PEERS:
            p, f, seconds = simplify(points, faces, count)
            out = scratch / f"{mesh.stem}-{bound}-{name}.vtp"
            write(out, p, f)
            print(row(name, mesh, bound, len(f), seconds, ours_seconds, *measure(mesh, out)))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
