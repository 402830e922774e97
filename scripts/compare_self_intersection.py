#!/usr/bin/env python3
"""Peer comparison of balloonseg's self-intersection search against CGAL.

Generates test meshes (icospheres with a cap pushed through the opposite side, two overlapping
spheres, coplanar and touching grids, clean spheres), writes them as OFF, runs
`cpp_tests/cgal_self_intersections.cpp` (CGAL Polygon_mesh_processing::self_intersections,
sequential) and `examples/self_intersections_off.rs` (ours, rayon with 2 threads unless
`--threads` says otherwise) on each,
asserts that both report the same set of face pairs, and prints a table of the best-of-N
times and the speed-up.

Usage: /tmp/venv/bin/python scripts/compare_self_intersection.py [--quick] [--repeats N]
       [--rounds N] [--work DIR] [--cases NAME,...] [--threads N]
Builds both programs if needed (CGAL with -O2 -DNDEBUG, ours with cargo --release). Each program
reports its best of `repeats` runs; the two programs are run alternately `rounds` times and the
best of each is kept, so that a burst of load on a shared machine hits both alike. Read the
ratio, not the seconds.
"""

import argparse
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CGAL_BIN = os.path.join(ROOT, "target", "cgal_self_intersections")
CGAL_SRC = os.path.join(ROOT, "cpp_tests", "cgal_self_intersections.cpp")
OURS_BIN = os.path.join(ROOT, "target", "release", "examples", "self_intersections_off")


# ---------------------------------------------------------------------------------------------
# Mesh generators. Every mesh is manifold and consistently oriented, so that CGAL's
# Surface_mesh accepts its faces in file order.


def icosphere(levels, centre=(0.0, 0.0, 0.0), radius=1.0):
    """An icosahedron subdivided `levels` times (20 * 4^levels triangles), on the sphere."""
    t = (1.0 + 5.0 ** 0.5) / 2.0
    v = np.array(
        [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]],
        dtype=np.float64,
    )
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    f = np.array(
        [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]],
        dtype=np.int64,
    )
    for _ in range(levels):
        n = len(v)
        a, b, c = f[:, 0], f[:, 1], f[:, 2]
        edges = np.concatenate([np.stack([a, b], 1), np.stack([b, c], 1), np.stack([c, a], 1)])
        lo, hi = edges.min(axis=1), edges.max(axis=1)
        keys, inverse = np.unique(lo * n + hi, return_inverse=True)
        mids = v[keys // n] + v[keys % n]
        mids /= np.linalg.norm(mids, axis=1, keepdims=True)
        m = inverse.reshape(3, -1) + n
        ab, bc, ca = m[0], m[1], m[2]
        v = np.concatenate([v, mids])
        f = np.concatenate([
            np.stack([a, ab, ca], 1), np.stack([b, bc, ab], 1),
            np.stack([c, ca, bc], 1), np.stack([ab, bc, ca], 1),
        ])
    return v * radius + np.asarray(centre), f


def rotation(seed):
    """A fixed pseudo-random rotation, so that no coordinate plane is special."""
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def pushed_cap(levels, rotated=False):
    """A unit icosphere whose cap above z = 0.7 is pushed 2.4 down, through the other side.

    The ring of triangles around the cap becomes long slivers along z. Rotated, their bounding
    boxes grow fat in all three axes and overlap a large part of the mesh: a stress case for any
    bounding-box broad phase (ours and CGAL's alike)."""
    v, f = icosphere(levels)
    cap = v[:, 2] > 0.7
    v[cap, 2] -= 2.4
    return (v @ rotation(levels).T if rotated else v), f


def merged(*meshes):
    points, faces, offset = [], [], 0
    for v, f in meshes:
        points.append(v)
        faces.append(f + offset)
        offset += len(v)
    return np.concatenate(points), np.concatenate(faces)


def grid(nx, ny, origin=(0.0, 0.0, 0.0), step=1.0):
    """A flat nx-by-ny grid of squares in a plane z = const, two triangles per square."""
    ii, jj = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), indexing="ij")
    v = np.stack([ii.ravel() * step, jj.ravel() * step, np.zeros(ii.size)], 1) + np.asarray(origin)
    idx = lambda i, j: i * (ny + 1) + j
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    i, j = i.ravel(), j.ravel()
    f = np.concatenate([
        np.stack([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)], 1),
        np.stack([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)], 1),
    ])
    return v, f


def coplanar_grids():
    """Two coplanar grids, the second shifted by (0.5, 0.25): coplanar overlaps everywhere, and
    edges along common lines."""
    return merged(grid(60, 60), grid(60, 60, origin=(0.5, 0.25, 0.0)))


def touching_grids():
    """Coplanar grids meeting along a line (distinct vertices at the same places), a grid whose
    vertices coincide with another's (shifted by whole cells: duplicate geometry, distinct
    indices), and one standing vertically on it."""
    a = grid(40, 40)
    beside = grid(40, 40, origin=(40.0, 0.0, 0.0))
    on_top = grid(20, 20, origin=(10.0, 10.0, 0.0))
    standing_v, standing_f = grid(20, 10, origin=(0.0, 0.0, 0.0))
    standing_v = standing_v[:, [0, 2, 1]] + np.array([5.0, 20.5, 0.0])
    return merged(a, beside, on_top, (standing_v, standing_f))


def folded_grid():
    """A flat grid with some vertices slid within the plane across their neighbours: coplanar
    fold-overs of triangles sharing an edge or a vertex; plus some slid out of the plane
    (dihedral folds, which do not count)."""
    v, f = grid(80, 80)
    rng = np.random.default_rng(5)
    chosen = rng.choice(len(v), size=300, replace=False)
    v[chosen[:200], 0] += rng.choice([-1.5, 1.5, 0.75], size=200)
    v[chosen[200:], 2] += 0.5
    return v, f


def degenerate_and_duplicate():
    """A pillow (one triangle twice, opposite windings: a closed two-face mesh), and a grid in
    which one vertex is moved onto the line through two neighbours, making degenerate faces
    (reported alone, as (f, f)) whose neighbours fold over."""
    pillow_v = np.array([[0.0, 0.0, 5.0], [3.0, 0.0, 5.0], [0.0, 3.0, 5.0]])
    pillow_f = np.array([[0, 1, 2], [0, 2, 1]])
    v, f = grid(6, 6)
    v[1 * 7 + 0] = [0.5, 0.5, 0.0]  # vertex (1, 0) onto the diagonal from (0, 0) to (1, 1)
    return merged((pillow_v, pillow_f), (v, f))


def cases(quick):
    out = [
        ("cap_20k", lambda: pushed_cap(5)),
        ("cap_20k_rotated", lambda: pushed_cap(5, rotated=True)),
        ("two_spheres_40k", lambda: merged(
            icosphere(5), icosphere(5, centre=(0.9, 0.3, 0.1)))),
        ("coplanar_grids", coplanar_grids),
        ("touching_grids", touching_grids),
        ("folded_grid", folded_grid),
        ("degenerate_and_duplicate", degenerate_and_duplicate),
    ]
    if not quick:
        out += [
            ("cap_328k", lambda: pushed_cap(7)),
            ("cap_1.3M", lambda: pushed_cap(8)),
            ("clean_328k", lambda: icosphere(7)),
            ("clean_1.3M", lambda: icosphere(8)),
        ]
    return out


# ---------------------------------------------------------------------------------------------


def write_off(path, v, f):
    with open(path, "w") as out:
        out.write(f"OFF\n{len(v)} {len(f)} 0\n")
        # %.17g reads back to the same double in both C++ and Rust.
        np.savetxt(out, v, fmt="%.17g")
        np.savetxt(out, np.concatenate([np.full((len(f), 1), 3), f], 1), fmt="%d")


def read_pairs(path):
    with open(path) as f:
        return {tuple(map(int, line.split())) for line in f if line.strip()}


def run(cmd):
    result = subprocess.run(cmd, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{result.stdout}{result.stderr}")
    fields = result.stdout.split()
    return float(fields[1]), result.stdout.strip()


def build():
    newer = lambda a, b: os.path.exists(a) and os.path.getmtime(a) >= os.path.getmtime(b)
    if not newer(CGAL_BIN, CGAL_SRC):
        print("building the CGAL program...", flush=True)
        os.makedirs(os.path.dirname(CGAL_BIN), exist_ok=True)
        subprocess.run(["g++", "-O2", "-DNDEBUG", "-std=c++17", CGAL_SRC, "-lgmp", "-lmpfr",
                        "-o", CGAL_BIN], check=True)
    subprocess.run(["cargo", "build", "--release", "--quiet", "--features", "io",
                    "--example", "self_intersections_off"], check=True, cwd=ROOT)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="small cases only")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--work", default="/tmp/balloonseg-si-compare")
    parser.add_argument("--cases", default="", help="comma-separated case names")
    parser.add_argument("--threads", type=int, default=2,
                        help="rayon threads for ours (CGAL is sequential); 1 compares like with "
                             "like on a loaded machine")
    args = parser.parse_args()
    build()
    os.makedirs(args.work, exist_ok=True)
    wanted = set(filter(None, args.cases.split(",")))
    rows, failures = [], []
    for name, make in cases(args.quick):
        if wanted and name not in wanted:
            continue
        v, f = make()
        off = os.path.join(args.work, f"{name}.off")
        write_off(off, v, f)
        cgal_pairs, ours_pairs = off + ".cgal.txt", off + ".ours.txt"
        cgal_s = ours_s = float("inf")
        for _ in range(args.rounds):
            cgal_s = min(cgal_s, run([CGAL_BIN, off, cgal_pairs, str(args.repeats)])[0])
            ours_s = min(ours_s, run([OURS_BIN, off, ours_pairs, str(args.repeats),
                                      str(args.threads)])[0])
        a, b = read_pairs(cgal_pairs), read_pairs(ours_pairs)
        same = a == b
        if not same:
            failures.append(name)
            print(f"{name}: MISMATCH: {len(a - b)} pairs only in CGAL (e.g. {sorted(a - b)[:5]}),"
                  f" {len(b - a)} only in ours (e.g. {sorted(b - a)[:5]})")
        rows.append((name, len(f), len(a), cgal_s, ours_s, same))
        print(f"{name}: {len(f)} triangles, {len(a)} pairs, CGAL {cgal_s:.4f} s, "
              f"ours {ours_s:.4f} s", flush=True)

    print()
    print(f"{'case':<26}{'triangles':>11}{'pairs':>9}{'CGAL s':>10}{'ours s':>10}"
          f"{'speed-up':>10}  same")
    for name, nf, np_, c, o, same in rows:
        print(f"{name:<26}{nf:>11}{np_:>9}{c:>10.4f}{o:>10.4f}{c / o:>9.1f}x  {same}")
    if failures:
        sys.exit(f"pair sets differ for: {', '.join(failures)}")


if __name__ == "__main__":
    main()
