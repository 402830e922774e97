#!/usr/bin/env python3
"""Issue 18's reading speed: a full-size CT-like volume (default 512x512x600 int16: air, a body of
soft tissue and fat with noise, a contrast-filled aorta) written by SimpleITK as .nii.gz, .mha
and .nrrd (both compressed) and .nii, then read by SimpleITK (``sitk.ReadImage``) and by
``balloonseg info`` (its own ``read_seconds``, the read alone, and the whole process's wall
clock), best of ``--repeat`` runs each, interleaved. Prints a Markdown table.

    .venv/bin/python scripts/read_speed.py [--binary target/release/balloonseg] [--dims 512,512,600]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import SimpleITK as sitk


def ct_volume(dims, seed=18):
    """A CT-like int16 volume (z, y, x): air at -1000, an elliptic body of soft tissue (40 HU)
    with a fat rim (-100 HU), an aorta of 300 HU, noise of 12 HU."""
    nx, ny, nz = dims
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:ny, 0:nx].astype(np.float32)
    ex, ey = (x - nx / 2) / (0.42 * nx), (y - ny / 2) / (0.33 * ny)
    r = np.sqrt(ex**2 + ey**2)
    plane = np.where(r < 1.0, np.where(r > 0.9, -100.0, 40.0), -1000.0).astype(np.float32)
    volume = np.empty((nz, ny, nx), np.int16)
    for z in range(nz):
        cx = nx / 2 + 0.05 * nx * np.sin(z / 80.0)
        aorta = (x - cx) ** 2 + (y - 0.45 * ny) ** 2 < (0.025 * nx) ** 2
        noise = rng.normal(0.0, 12.0, (ny, nx)).astype(np.float32)
        volume[z] = np.clip(np.where(aorta, 300.0, plane) + noise, -1024, 3071)
    return volume


def best(runs):
    return min(runs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", default="target/release/balloonseg")
    parser.add_argument("--dims", default="512,512,600")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    dims = tuple(int(v) for v in args.dims.split(","))
    with tempfile.TemporaryDirectory() as folder:
        image = sitk.GetImageFromArray(ct_volume(dims))
        image.SetSpacing((0.7, 0.7, 0.8))
        image.SetOrigin((-180.0, -180.0, -400.0))
        files = []
        for suffix, compress in ((".nii.gz", True), (".mha", True), (".nrrd", True), (".nii", False)):
            path = Path(folder) / f"cta{suffix}"
            sitk.WriteImage(image, str(path), useCompression=compress)
            files.append(path)
        voxel_mb = np.prod(dims) * 2 / 1e6
        print(f"{dims[0]}x{dims[1]}x{dims[2]} int16 ({voxel_mb:.0f} MB of voxels), "
              f"best of {args.repeat}\n")
        print("| file | MB on disk | SimpleITK s | balloonseg read s | balloonseg process s "
              "| SimpleITK / balloonseg read |")
        print("|---|---|---|---|---|---|")
        for path in files:
            ours, process, theirs = [], [], []
            for _ in range(args.repeat):
                start = time.perf_counter()
                sitk.ReadImage(str(path))
                theirs.append(time.perf_counter() - start)
                start = time.perf_counter()
                out = subprocess.run([args.binary, "info", str(path)], capture_output=True,
                                     text=True, check=True)
                process.append(time.perf_counter() - start)
                ours.append(json.loads(out.stdout)["read_seconds"])
            print(f"| {path.name} | {path.stat().st_size / 1e6:.0f} | {best(theirs):.3f} | "
                  f"{best(ours):.3f} | {best(process):.3f} | {best(theirs) / best(ours):.2f} |")


if __name__ == "__main__":
    main()
