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
