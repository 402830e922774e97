"""Shared fixtures: the CLI (the reference the Python results must equal), its phantoms, the
real scans (``$BALLOONSEG_DATA``, default ../shared/data from the repository; skipped loudly
when absent, mandatory when ``CI=true``) and readers for the meshes the CLI writes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "python_ctypes"))

import balloonseg  # noqa: E402

CLI = REPO / "target" / "release" / "balloonseg"
IN_CI = os.environ.get("CI") == "true"
PHANTOMS = ("sphere", "torus", "double-torus", "y-vessel", "touching-tubes")
AORTA_SEED = (-221.484, -156.445, 22.501)


def missing(reason: str):
    """Fails under CI, else skips with a loud reason."""
    if IN_CI:
        pytest.fail(f"{reason} (mandatory because CI=true)")
    warnings.warn(f"SKIPPED: {reason}", stacklevel=2)
    pytest.skip(f"SKIPPED: {reason}")


@pytest.fixture(scope="session")
def cli() -> Path:
    if not CLI.exists():
        missing(f"{CLI} is not built; run `cargo build --release --features cli`")
    return CLI


def run_cli(cli: Path, *args) -> str:
    done = subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True)
    assert done.returncode == 0, f"balloonseg {' '.join(map(str, args))}: {done.stderr}"
    return done.stdout


def cli_segment(cli: Path, image, seed, out: Path, *options):
    """The CLI's segmentation (written as .vtp, Float64 points) read back."""
    run_cli(cli, "segment", image, f"--seed={','.join(map(repr, seed))}", "-o", out, *options)
    return read_vtp(out)


@pytest.fixture(scope="session")
def phantom(cli, tmp_path_factory):
    """phantom(name, *options) -> (path of the .mha, world seed); made once per session."""
    folder = tmp_path_factory.mktemp("phantoms")
    made = {}

    def make(name: str, *options: str):
        key = (name, options)
        if key not in made:
            path = folder / f"{name}{''.join(options).replace(',', '_')}.mha"
            summary = json.loads(run_cli(cli, "phantom", name, *options, "-o", path))
            made[key] = (path, tuple(summary["seed_world"]))
        return made[key]

    return make


@pytest.fixture(scope="session")
def data_dir() -> Path:
    data = Path(os.environ.get("BALLOONSEG_DATA", REPO.parent / "shared" / "data"))
    if not (data / "vmtk-aorta" / "aorta.mha").exists():
        missing(f"the real scans are not in {data} (set BALLOONSEG_DATA)")
    return data


@pytest.fixture(scope="session")
def aorta(cli, data_dir, tmp_path_factory):
    """The aorta scan's path and the CLI's mesh of it from the README seed (made once)."""
    path = data_dir / "vmtk-aorta" / "aorta.mha"
    out = tmp_path_factory.mktemp("aorta") / "cli.vtp"
    return path, cli_segment(cli, path, AORTA_SEED, out)


def read_vtp(path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Points (float64, as written), triangles and the vertex_state array of a .vtp file."""
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

    reader = vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    return polydata_arrays(reader.GetOutput())


def polydata_arrays(poly) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    from vtkmodules.util.numpy_support import vtk_to_numpy

    points = (
        vtk_to_numpy(poly.GetPoints().GetData()) if poly.GetNumberOfPoints() else np.zeros((0, 3))
    )
    polys = poly.GetPolys()
    offsets = vtk_to_numpy(polys.GetOffsetsArray())
    assert np.all(np.diff(offsets) == 3), "only triangles expected"
    triangles = vtk_to_numpy(polys.GetConnectivityArray()).reshape(-1, 3)
    states = poly.GetPointData().GetArray("vertex_state")
    return points, triangles, None if states is None else vtk_to_numpy(states)


def read_image(path):
    """A SimpleITK image, a numpy view of its voxels (valid only while the image lives: SimpleITK's
    views do not keep it alive) and the keyword arguments that give its geometry to balloonseg."""
    import SimpleITK as sitk

    image = sitk.ReadImage(str(path))
    geometry = dict(
        spacing=image.GetSpacing(), origin=image.GetOrigin(), direction=image.GetDirection()
    )
    return image, sitk.GetArrayViewFromImage(image), geometry


def assert_same_mesh(mesh: balloonseg.Mesh, points, triangles, states=None) -> None:
    assert mesh.points.shape == points.shape, f"{mesh.points.shape} != {points.shape}"
    assert np.array_equal(mesh.triangles, triangles), "triangles differ"
    assert np.array_equal(mesh.points, points), (
        f"points differ by up to {np.abs(mesh.points - points).max()} mm"
    )
    if states is not None:
        assert np.array_equal(mesh.vertex_state, states), "vertex states differ"


def assert_valid_surface(mesh: balloonseg.Mesh) -> None:
    s = mesh.stats
    assert s["closed"] and s["manifold"] and s["outward"], s
    assert s["self_intersecting_pairs"] == 0, s
    assert s["volume_mm3"] > 0 and s["genus"] is not None, s
