#!/usr/bin/env python3
"""Issue 18's whole run on a full-size CT angiogram: ``balloonseg phantom angiogram`` (an aorta
with its renal and iliac branches in a CT abdomen, default 512x512x600 int16) written as
.nii.gz, then ``balloonseg segment`` from the phantom's seed under ``/usr/bin/time``: wall clock,
peak RSS against the voxel bytes (the issue's bound is 1.25x the voxels plus the mesh), the
mesh's size, the time per phase from ``--stats``, and the mesh scored against the analytic tree
(``examples/angiogram_score.rs``: Dice, genus). Prints a Markdown table row.

    .venv/bin/python scripts/fullsize_run.py [--binary target/release/balloonseg] \\
        [--score target/release/examples/angiogram_score] [--dims 512,512,600] [--variant 0]

Build the scorer first: ``cargo build --release --features io --example angiogram_score``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", default="target/release/balloonseg")
    parser.add_argument("--score", default="target/release/examples/angiogram_score")
    parser.add_argument("--dims", default="512,512,600")
    parser.add_argument("--variant", type=int, default=0)
    parser.add_argument("--threads", type=int, default=0)
    args = parser.parse_args()
    dims = tuple(int(v) for v in args.dims.split(","))
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        volume = folder / "cta.nii.gz"
        made = subprocess.run(
            [args.binary, "phantom", "angiogram", "--variant", str(args.variant), "--dims",
             args.dims, "-o", str(volume)],
            capture_output=True, text=True, check=True,
        )
        seed = ",".join(repr(v) for v in json.loads(made.stdout)["seed_world"])
        timing = folder / "time"
        mesh = folder / "tree.vtp"
        done = subprocess.run(
            ["/usr/bin/time", "-f", "%e %M", "-o", str(timing), args.binary,
             "--threads", str(args.threads), "segment", str(volume), "--seed", seed,
             "-o", str(mesh), "--stats", str(folder / "stats.json")],
            capture_output=True, text=True,
        )
        if done.returncode != 0:
            raise SystemExit(f"segment failed: {done.stderr}")
        seconds, kb = timing.read_text().split()
        stats = json.loads((folder / "stats.json").read_text())
        scored = subprocess.run(
            [args.score, "--variant", str(args.variant), "--dims", args.dims, str(mesh)],
            capture_output=True, text=True, check=True,
        )
        score = json.loads(scored.stdout)
        voxel_mb = np.prod(dims) * 2 / 2**20
        rss_mb = int(kb) / 1024
        phases = ", ".join(f"{k} {v:.1f}" for k, v in stats["seconds"].items() if k != "total")
        print("| dims | variant | voxel MiB | wall s | peak RSS MiB | RSS / voxels | triangles "
              "| genus | Dice | seconds by phase |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        print(f"| {'x'.join(map(str, dims))} | {args.variant} | {voxel_mb:.0f} | "
              f"{float(seconds):.1f} | {rss_mb:.0f} | {rss_mb / voxel_mb:.2f} | "
              f"{stats['triangles']} | {stats['genus']} | {score['dice']:.4f} | {phases} |")


if __name__ == "__main__":
    main()
