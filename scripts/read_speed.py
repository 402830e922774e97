#!/usr/bin/env python3
"""Issue 18's reading speed: the full-size CT angiogram (``balloonseg phantom angiogram``, default
512x512x600 int16) written by SimpleITK as .nii.gz, .mha and .nrrd (both compressed) and .nii,
then read by SimpleITK (``sitk.ReadImage``) and by
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
        generated = Path(folder) / "generated.mha"
        subprocess.run([args.binary, "phantom", "angiogram", "--dims", args.dims, "-o",
                        str(generated)], capture_output=True, check=True)
        image = sitk.ReadImage(str(generated))
        generated.unlink()
        files = []
        for suffix, compress in ((".nii.gz", True), (".mha", True), (".nrrd", True), (".nii", False)):
            # A stem of its own: given cta.nii.gz, ITK's NIfTI reader takes cta.nii when both
            # are there.
            path = Path(folder) / f"cta-{suffix.strip('.').replace('.', '-')}{suffix}"
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
