"""Builds libballoonseg with cargo and bundles it in the package, so that
``pip install ./python_ctypes`` (or ``pip wheel ./python_ctypes``) gives a working package
without setting ``BALLOONSEG_LIBRARY``. Needs a Rust toolchain (``cargo`` on the path or in
``~/.cargo/bin``) and the repository around this folder; everything else is in pyproject.toml.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import setup
from setuptools.command.bdist_wheel import bdist_wheel
from setuptools.command.build_py import build_py
from setuptools.dist import Distribution

HERE = Path(__file__).resolve().parent
REPOSITORY = HERE.parent
LIBRARY = {"darwin": "libballoonseg.dylib", "win32": "balloonseg.dll"}.get(
    sys.platform, "libballoonseg.so"
)


def cargo() -> str:
    found = shutil.which("cargo") or str(Path.home() / ".cargo" / "bin" / "cargo")
    if not Path(found).exists():
        raise SystemExit(
            "balloonseg: building the package builds libballoonseg with cargo, which was not "
            "found; install Rust (https://rustup.rs) or put cargo on the PATH"
        )
    return found


class BuildWithLibrary(build_py):
    """The package's Python files, plus the C library built by cargo next to them."""

    def run(self):
        super().run()
        manifest = REPOSITORY / "Cargo.toml"
        if not manifest.exists():
            raise SystemExit(
                f"balloonseg: {manifest} not found; build the package from the repository's "
                "python_ctypes folder"
            )
        target = Path(os.environ.get("CARGO_TARGET_DIR", REPOSITORY / "target"))
        command = [cargo(), "build", "--release", "--lib", "--locked", "--manifest-path",
                   str(manifest), "--target-dir", str(target)]
        self.announce(" ".join(command), level=2)
        subprocess.run(command, check=True)
        destination = Path(self.build_lib) / "balloonseg"
        destination.mkdir(parents=True, exist_ok=True)
        bundled = destination / LIBRARY
        shutil.copy2(target / "release" / LIBRARY, bundled)
        # The release profile keeps debug information (30 MB of the 34 MB) for profiling; a
        # user's package does not need it.
        strip = shutil.which("strip")
        if strip and sys.platform.startswith("linux"):
            subprocess.run([strip, "--strip-debug", str(bundled)], check=True)


class BinaryDistribution(Distribution):
    """A wheel with a native library: tagged for this platform, not py3-none-any."""

    def has_ext_modules(self):
        return True


class AnyPythonWheel(bdist_wheel):
    """The library is loaded by ctypes, not compiled against Python: one wheel serves every
    Python 3 on the platform (py3-none-<platform>)."""

    def get_tag(self):
        _, _, platform = super().get_tag()
        return "py3", "none", platform


setup(
    cmdclass={"build_py": BuildWithLibrary, "bdist_wheel": AnyPythonWheel},
    distclass=BinaryDistribution,
)
