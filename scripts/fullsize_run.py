#!/usr/bin/env python3
"""Issue 18's whole run on a full-size CT angiogram: the synthetic CTA of ``synthetic_cta.py``
(default 512x512x600 int16) written as .nii.gz, then ``balloonseg segment`` from a seed in its
aorta under ``/usr/bin/time``: wall-clock, peak RSS against the voxel bytes (the issue's bound is
1.25x the voxels plus the mesh), the mesh's size, and the time per phase from ``--stats``. The
synthetic aorta is a plain winding tube (no branches yet); prints a Markdown table row.

    .venv/bin/python scripts/fullsize_run.py [--binary target/release/balloonseg] [--dims 512,512,600]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import SimpleITK as sitk
from synthetic_cta import ORIGIN, SPACING, aorta_centre, ct_volume


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", default="target/release/balloonseg")
    parser.add_argument("--dims", default="512,512,600")
    parser.add_argument("--threads", type=int, default=0)
    args = parser.parse_args()
    dims = tuple(int(v) for v in args.dims.split(","))
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        image = sitk.GetImageFromArray(ct_volume(dims))
        image.SetSpacing(SPACING)
        image.SetOrigin(ORIGIN)
        volume = folder / "cta.nii.gz"
        sitk.WriteImage(image, str(volume), useCompression=True)
        del image
        z = dims[2] // 2
        x, y = aorta_centre(dims, z)
        seed = f"{round(x)},{round(y)},{z}"
        timing = folder / "time"
        done = subprocess.run(
            ["/usr/bin/time", "-f", "%e %M", "-o", str(timing), args.binary,
             "--threads", str(args.threads), "segment", str(volume), "--index", "--seed", seed,
             "-o", str(folder / "aorta.vtp"), "--stats", str(folder / "stats.json")],
            capture_output=True, text=True,
        )
        if done.returncode != 0:
            raise SystemExit(f"segment failed: {done.stderr}")
        seconds, kb = timing.read_text().split()
        stats = json.loads((folder / "stats.json").read_text())
        voxel_mb = np.prod(dims) * 2 / 2**20
        rss_mb = int(kb) / 1024
        phases = ", ".join(f"{k} {v:.1f}" for k, v in stats["seconds"].items() if k != "total")
        print("| dims | voxel MiB | wall s | peak RSS MiB | RSS / voxels | triangles | genus "
              "| seconds by phase |")
        print("|---|---|---|---|---|---|---|---|")
        print(f"| {'x'.join(map(str, dims))} | {voxel_mb:.0f} | {float(seconds):.1f} | "
              f"{rss_mb:.0f} | {rss_mb / voxel_mb:.2f} | {stats['triangles']} | "
              f"{stats['genus']} | {phases} |")


if __name__ == "__main__":
    main()
