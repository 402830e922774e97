"""The example renders a segmentation to a PNG (on a phantom here; the aorta in the README)."""

import subprocess
import sys
from pathlib import Path

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkPNGReader

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "segment_aorta_png.py"


def test_the_example_renders_the_mesh_over_the_slices(phantom, tmp_path):
    path, seed = phantom("y-vessel", "--oblique")
    out = tmp_path / "picture.png"
    command = [sys.executable, str(EXAMPLE), "--image", str(path), "-o", str(out)]
    done = subprocess.run(
        [*command, "--seed", *map(repr, seed)],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert "genus 0" in done.stdout
    reader = vtkPNGReader()
    reader.SetFileName(str(out))
    reader.Update()
    width, height, _ = reader.GetOutput().GetDimensions()
    pixels = vtk_to_numpy(reader.GetOutput().GetPointData().GetScalars())[:, :3].astype(int)
    assert (width, height) == (1000, 1200)
    red = (pixels[:, 0] > 150) & (pixels[:, 1] < 120) & (pixels[:, 2] < 120)
    background = np.all(np.abs(pixels - [26, 26, 31]) <= 1, axis=1)
    grey = (np.ptp(pixels, axis=1) < 4) & ~background
    assert red.mean() > 0.01, "the mesh is not in the picture"
    assert grey.mean() > 0.05, "the slices are not in the picture"
