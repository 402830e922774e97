"""Finding and checking the library."""

import os
import subprocess
import sys
from pathlib import Path

import balloonseg

PACKAGE = Path(balloonseg.__file__).resolve().parents[1]


def run(code: str, **env) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        cwd=PACKAGE,
        env={**os.environ, **env},
    )


def test_balloonseg_library_overrides_the_lookup(tmp_path):
    missing = tmp_path / "libnothing.so"
    done = run("import balloonseg; balloonseg.version()", BALLOONSEG_LIBRARY=str(missing))
    assert done.returncode != 0
    assert f"cannot load libballoonseg from {missing}" in done.stderr


def test_a_library_without_the_api_is_refused():
    libm = "libm.so.6"
    done = run("import balloonseg; balloonseg.version()", BALLOONSEG_LIBRARY=libm)
    assert done.returncode != 0 and "has no function balloon_" in done.stderr


def test_the_repository_build_is_found_and_versions_match():
    assert balloonseg.version() == ".".join(map(str, balloonseg._library.ABI_VERSION))
    assert balloonseg.__version__.split(".")[0] == balloonseg.version().split(".")[0]


def test_pip_builds_and_bundles_the_library(tmp_path):
    """`pip wheel ./python_ctypes` builds libballoonseg with cargo and bundles it in a wheel for
    any Python 3 on this platform; installed outside the repository, with no
    BALLOONSEG_LIBRARY, the package loads its own copy."""
    wheels, site = tmp_path / "wheels", tmp_path / "site"
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    subprocess.run([*pip, "wheel", "--no-deps", str(PACKAGE), "-w", str(wheels)], check=True)
    (wheel,) = wheels.glob("balloonseg-*.whl")
    assert "-py3-none-" in wheel.name and not wheel.name.endswith("-any.whl"), wheel.name
    subprocess.run([*pip, "install", "--no-deps", "--target", str(site), str(wheel)], check=True)
    env = {k: v for k, v in os.environ.items() if k != "BALLOONSEG_LIBRARY"}
    env["PYTHONPATH"] = str(site)
    done = subprocess.run(
        [sys.executable, "-c",
         "import balloonseg; print(balloonseg._library._candidates()[0], balloonseg.version())"],
        capture_output=True, text=True, cwd=tmp_path, env=env,
    )
    assert done.returncode == 0, done.stderr
    path, version = done.stdout.split()
    assert Path(path).parent == site / "balloonseg"
    assert version == ".".join(map(str, balloonseg._library.ABI_VERSION))
