#!/usr/bin/env bash
# Every test of the project, on a fresh machine: installs what it needs (Debian packages when
# run as root, a Python venv in .venv), then lint, Rust tests, benchmark builds, and the peer
# comparisons against VTK and CGAL.
#
# Real scans are read from $BALLOONSEG_DATA (default: ../shared/data). When they are absent the
# tests that need them say SKIPPED loudly; with CI=true they fail instead.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

step() { printf '\n=== %s\n' "$*"; }

step "system packages"
missing=()
for pkg in g++ cmake valgrind libcgal-dev libgmp-dev libmpfr-dev libvtk9-dev libopenmesh-dev libgtest-dev; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
done
if ((${#missing[@]})); then
  if [ "$(id -u)" -eq 0 ]; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}"
  else
    echo "missing Debian packages: ${missing[*]} (run: sudo apt-get install ${missing[*]})" >&2
    exit 1
  fi
fi

step "Python venv (.venv)"
[ -x .venv/bin/python ] || python3 -m venv .venv
.venv/bin/python -m pip install -q --disable-pip-version-check -r scripts/requirements-test.txt

export BALLOONSEG_DATA="${BALLOONSEG_DATA:-$(cd "$root/.." && pwd)/shared/data}"
echo "BALLOONSEG_DATA=$BALLOONSEG_DATA"

step "format and lint"
cargo fmt --all -- --check
cargo clippy --all-targets --all-features --locked -- -D warnings

step "Rust tests"
cargo test --all-features --locked --release

step "benchmarks compile"
cargo bench --all-features --locked --no-run

step "peer comparisons (VTK, CGAL, libigl)"
cargo build --release --all-features --locked --bins --examples
.venv/bin/python -m pytest -q tests/peers
