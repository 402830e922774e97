"""Shared fixtures for the peer comparisons: our release binaries, the real scans, VTK helpers.

Run through `bash scripts/test.sh`, which builds the binaries (`cargo build --release
--all-features --bins --examples`) and makes a venv with VTK, libigl and pytest.
"""

import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
RELEASE = ROOT / "target" / "release"


def binary(name: str) -> pathlib.Path:
    """A release binary or example of ours; fails with the command that builds it."""
    for path in (RELEASE / name, RELEASE / "examples" / name):
        if path.exists():
            return path
    pytest.fail(f"{name} is not built: run cargo build --release --all-features --bins --examples")


def run(*args) -> str:
    """Runs one of our programs; a failure shows its stderr."""
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if done.returncode != 0:
        pytest.fail(f"{' '.join(map(str, args))} failed ({done.returncode}):\n{done.stderr}")
    return done.stdout


@pytest.fixture(scope="session")
def data_dir() -> pathlib.Path:
    """The real scans; skipped loudly when absent, an error on CI (CI=true)."""
    path = pathlib.Path(os.environ.get("BALLOONSEG_DATA") or ROOT.parent / "shared" / "data")
    if not path.is_dir():
        message = f"the real scans are not at {path}; set BALLOONSEG_DATA"
        if os.environ.get("CI") == "true":
            pytest.fail(message + " (CI must run the tests on the real scans)")
        print(f"\n*** SKIPPED: {message} ***", file=sys.stderr)
        pytest.skip(message)
    return path


def itk_world_of_indices(dims, spacing, origin, direction, indices):
    """World coordinates (ITK convention) of integer voxel indices (N, 3) in i, j, k order."""
    d = np.asarray(direction, dtype=float).reshape(3, 3)
    return np.asarray(origin, dtype=float) + (np.asarray(indices, float) * spacing) @ d.T


def read_metaimage(path: pathlib.Path):
    """A minimal MetaImage reader (the header fields ITK writes, raw or zlib data): returns the
    voxels as a (k, j, i) array and the geometry in ITK's meaning, independent of our readers and
    of VTK's (which reads TransformMatrix transposed or not at all, depending on its version)."""
    import zlib

    raw = path.read_bytes()
    end = raw.index(b"ElementDataFile")
    end = raw.index(b"\n", end) + 1
    header = {}
    for line in raw[:end].decode().splitlines():
        key, _, value = line.partition("=")
        header[key.strip()] = value.strip()
    dims = [int(v) for v in header["DimSize"].split()]
    spacing = [float(v) for v in header["ElementSpacing"].split()]
    origin = [float(v) for v in header.get("Offset", "0 0 0").split()]
    columns = np.array([float(v) for v in header.get("TransformMatrix", "1 0 0 0 1 0 0 0 1").split()])
    direction = columns.reshape(3, 3).T  # listed column by column
    dtype = {"MET_FLOAT": "<f4", "MET_DOUBLE": "<f8", "MET_UCHAR": "u1", "MET_SHORT": "<i2"}[header["ElementType"]]
    data = raw[end:]
    if header.get("CompressedData", "False") == "True":
        data = zlib.decompress(data)
    voxels = np.frombuffer(data, dtype=dtype).reshape(dims[2], dims[1], dims[0])
    return voxels, dims, spacing, origin, direction
