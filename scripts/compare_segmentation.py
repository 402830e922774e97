#!/usr/bin/env python3
"""Same-run comparison of the balloon with two peers on the real aorta, from the same seed.

- ours: `balloonseg segment` with defaults and only the seed (reference and tolerance estimated);
- ITK's threshold level set (SimpleITK `ThresholdSegmentationLevelSetImageFilter`), started from a
  small sphere at the seed, with thresholds, curvature and iterations hand-tuned against the
  reference (the values below; ITK cannot estimate them);
- scikit-image's morphological balloon (`morphological_geodesic_active_contour`, balloon force +1)
  on the inverse-Gaussian-gradient image, started from the same sphere. It works in index space, so
  the scan's anisotropic spacing is ignored, as a user of it would have it.

Each result becomes a voxel mask on the scan's grid (ours: the sign of `balloonseg distance`;
the level set's sign; skimage's mask) and is compared with vmtk's reference level set by Dice
inside the reference's rows y = 89...176 (all x, all z; the reference covers only that stretch).
The surface of each result is checked too: ours as written, the peers' as marching cubes of their
level set, through `balloonseg check` (components and genus: a leak or a hole shows up there).

Usage: python scripts/compare_segmentation.py [--data DIR] [--quick] [--json OUT]
  --quick skips scikit-image (about a minute on 2 cores).
Needs numpy, SimpleITK, scikit-image and our release binary (cargo build --release --features cli).
Times are wall-clock seconds of one run on the same machine: compare them as ratios.
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
BINARY = os.path.join(ROOT, "target", "release", "balloonseg")
SEED_INDEX = (74, 150, 15)
SEED_WORLD = (-221.484, -156.445, 22.501)  # the data README's, for that voxel
ROWS = (89, 176)
INITIAL_RADIUS_VOXELS = 3.0


def run(*args):
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(map(str, args))} failed:\n{done.stderr}")
    return done.stdout


def dice(a, b):
    a = a[:, ROWS[0] : ROWS[1] + 1, :]
    b = b[:, ROWS[0] : ROWS[1] + 1, :]
    return 2.0 * np.count_nonzero(a & b) / (np.count_nonzero(a) + np.count_nonzero(b))


def surface_check(workdir, name, volume_path, level):
    """Components and genus of the level surface of a scalar volume (marching cubes)."""
    mesh = os.path.join(workdir, f"{name}.ply")
    run(BINARY, "isosurface", volume_path, "--level", level, "-o", mesh)
    return json.loads(run(BINARY, "check", mesh))


def initial_sphere(image):
    import SimpleITK as sitk

    k, j, i = np.ogrid[: image.GetSize()[2], : image.GetSize()[1], : image.GetSize()[0]]
    r2 = (i - SEED_INDEX[0]) ** 2 + (j - SEED_INDEX[1]) ** 2 + (k - SEED_INDEX[2]) ** 2
    mask = sitk.GetImageFromArray((r2 <= INITIAL_RADIUS_VOXELS**2).astype(np.uint8))
    mask.CopyInformation(image)
    return mask


def ours(workdir, image_path, image):
    import SimpleITK as sitk

    mesh = os.path.join(workdir, "ours.vtp")
    stats_path = os.path.join(workdir, "ours.json")
    start = time.perf_counter()
    run(BINARY, "segment", image_path, "--seed", ",".join(map(str, SEED_WORLD)), "-o", mesh,
        "--stats", stats_path)
    seconds = time.perf_counter() - start
    stats = json.load(open(stats_path))
    distance = os.path.join(workdir, "ours-distance.mha")
    run(BINARY, "distance", mesh, "--like", image_path, "-o", distance)
    mask = sitk.GetArrayFromImage(sitk.ReadImage(distance)) < 0
    return {
        "seconds": seconds,
        "mask": mask,
        "components": stats["components"],
        "genus": stats["genus"],
        "notes": f"reference {stats['reference_intensity']:.0f} ± {stats['tolerance']:.0f} "
        "(estimated)",
    }


def itk_threshold_level_set(workdir, image):
    import SimpleITK as sitk

    lower, upper = 1150.0, 2600.0
    start = time.perf_counter()
    initial = sitk.SignedMaurerDistanceMap(
        initial_sphere(image), insideIsPositive=True, useImageSpacing=True
    )
    level_set = sitk.ThresholdSegmentationLevelSetImageFilter()
    level_set.SetLowerThreshold(lower)
    level_set.SetUpperThreshold(upper)
    level_set.SetMaximumRMSError(0.02)
    level_set.SetNumberOfIterations(1000)
    level_set.SetCurvatureScaling(0.5)
    level_set.SetPropagationScaling(1.0)
    level_set.ReverseExpansionDirectionOn()
    result = level_set.Execute(initial, sitk.Cast(image, sitk.sitkFloat32))
    seconds = time.perf_counter() - start
    path = os.path.join(workdir, "itk-level-set.mha")
    sitk.WriteImage(result, path)
    check = surface_check(workdir, "itk", path, 0.0)
    return {
        "seconds": seconds,
        "mask": sitk.GetArrayFromImage(result) > 0,
        "components": check["components"],
        "genus": check["genus"],
        "notes": f"thresholds {lower:.0f}..{upper:.0f}, curvature 0.5, "
        f"{level_set.GetElapsedIterations()} iterations",
    }


def skimage_morphological_balloon(workdir, image):
    import SimpleITK as sitk
    from skimage.segmentation import (
        inverse_gaussian_gradient,
        morphological_geodesic_active_contour,
    )

    iterations = 100
    voxels = sitk.GetArrayFromImage(image).astype(np.float64)
    start = time.perf_counter()
    edges = inverse_gaussian_gradient(voxels / voxels.max(), alpha=100.0, sigma=1.0)
    mask = morphological_geodesic_active_contour(
        edges,
        iterations,
        init_level_set=sitk.GetArrayFromImage(initial_sphere(image)),
        smoothing=1,
        threshold=0.45,
        balloon=1,
    ).astype(bool)
    seconds = time.perf_counter() - start
    out = sitk.GetImageFromArray(mask.astype(np.float32))
    out.CopyInformation(image)
    path = os.path.join(workdir, "skimage-mask.mha")
    sitk.WriteImage(out, path)
    check = surface_check(workdir, "skimage", path, 0.5)
    return {
        "seconds": seconds,
        "mask": mask,
        "components": check["components"],
        "genus": check["genus"],
        "notes": f"alpha 100, sigma 1, threshold 0.45, {iterations} iterations, index space",
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", default=os.environ.get("BALLOONSEG_DATA")
                        or os.path.join(ROOT, "..", "shared", "data"))
    parser.add_argument("--quick", action="store_true", help="skip scikit-image")
    parser.add_argument("--json", help="write the table as JSON here")
    args = parser.parse_args()

    import SimpleITK as sitk

    if not os.path.exists(BINARY):
        sys.exit(f"{BINARY} is missing: cargo build --release --features cli")
    folder = os.path.join(args.data, "vmtk-aorta")
    image_path = os.path.join(folder, "aorta.mha")
    image = sitk.ReadImage(image_path)
    reference = sitk.GetArrayFromImage(
        sitk.ReadImage(os.path.join(folder, "aorta-reference-levelset.mha"))) < 0

    methods = [("balloonseg (defaults, seed only)", ours, (image_path, image)),
               ("ITK threshold level set (tuned)", itk_threshold_level_set, (image,))]
    if not args.quick:
        methods.append(("scikit-image morphological balloon", skimage_morphological_balloon,
                        (image,)))
    rows = []
    with tempfile.TemporaryDirectory() as workdir:
        for name, method, method_args in methods:
            result = method(workdir, *method_args)
            rows.append({
                "method": name,
                "dice": dice(result["mask"], reference),
                "seconds": result["seconds"],
                "components": result["components"],
                "genus": result["genus"],
                "notes": result["notes"],
            })

    ours_seconds = rows[0]["seconds"]
    print(f"aorta, seed index {SEED_INDEX}, Dice inside reference rows y = {ROWS[0]}..{ROWS[1]}")
    print(f"{'method':38} {'Dice':>6} {'seconds':>8} {'vs ours':>8} {'comp.':>5} {'genus':>5}  notes")
    for row in rows:
        print(f"{row['method']:38} {row['dice']:6.3f} {row['seconds']:8.2f} "
              f"{row['seconds'] / ours_seconds:7.1f}x {row['components']:>5} "
              f"{'open' if row['genus'] is None else row['genus']:>5}  {row['notes']}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
