#!/usr/bin/env bash
# The CMake side of balloonseg, end to end: configures cmake/ (Release), builds the Rust library
# through cargo, the VTK filter and cpp_tests/ (BUILD_TESTING), installs the package into a fresh
# prefix, checks the installed files (SONAME symlinks), builds and runs the consumer project in
# cmake/consumer against that prefix, then runs ctest in the package's build tree. Prints the
# ours/peer timing ratios the tests logged.
#
# Needs the Debian packages cmake libvtk9-dev libopenmesh-dev libgtest-dev libcgal-dev libgmp-dev
# libmpfr-dev (scripts/test.sh installs them). Real scans from $BALLOONSEG_DATA (default
# ../shared/data); the tests that need them skip loudly when they are absent, and fail with CI=true.
#
#   bash scripts/test_cmake.sh          # build dirs under target/cmake, reusing target/ for cargo
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
build="$root/target/cmake"
prefix="$build/prefix"
jobs="${JOBS:-2}"
export BALLOONSEG_DATA="${BALLOONSEG_DATA:-$(cd "$root/.." && pwd)/shared/data}"

step() { printf '\n=== %s\n' "$*"; }

step "configure and build cmake/ (cargo + vtkBalloonSegmentation)"
cmake -S cmake -B "$build/package" -DCMAKE_BUILD_TYPE=Release \
  -DBALLOONSEG_CARGO_TARGET_DIR="$root/target"
cmake --build "$build/package" -j "$jobs"

step "install into $prefix"
rm -rf "$prefix"
cmake --install "$build/package" --prefix "$prefix"
lib="$prefix/lib"
[ "$(readlink "$lib/libballoonseg.so")" = libballoonseg.so.0 ]
version=$(sed -n 's/^version = "\(.*\)"$/\1/p' Cargo.toml | head -1)
[ "$(readlink "$lib/libballoonseg.so.0")" = "libballoonseg.so.$version" ]
[ -f "$lib/libballoonseg.so.$version" ] && [ -f "$lib/libballoonseg.a" ]
[ -f "$prefix/include/balloonseg.h" ] && [ -f "$prefix/include/vtkBalloonSegmentation.h" ]
[ -f "$lib/cmake/BalloonSeg/BalloonSegConfig.cmake" ]
[ -f "$lib/cmake/BalloonSeg/BalloonSegConfigVersion.cmake" ]
soname=$(objdump -p "$lib/libballoonseg.so.$version" | awk '/SONAME/ {print $2}')
[ "$soname" = libballoonseg.so.0 ] || { echo "SONAME is '$soname', expected libballoonseg.so.0" >&2; exit 1; }
needed=$(objdump -p "$lib/libvtkBalloonSegmentation.so" | awk '/NEEDED.*balloonseg/ {print $2}')
[ "$needed" = libballoonseg.so.0 ] || { echo "the filter needs '$needed'" >&2; exit 1; }
echo "installed: $(cd "$prefix" && find . -type f -o -type l | sort | tr '\n' ' ')"

step "consumer project (find_package(BalloonSeg CONFIG REQUIRED COMPONENTS vtk))"
consumer=$(mktemp -d)
trap 'rm -rf "$consumer"' EXIT
cmake -S cmake/consumer -B "$consumer" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix"
cmake --build "$consumer" -j "$jobs"
"$consumer/consumer_vtk"
"$consumer/consumer_static"
if objdump -p "$consumer/consumer_static" | grep -q 'NEEDED.*balloonseg'; then
  echo "consumer_static is linked to the shared library" >&2
  exit 1
fi

step "cpp_tests: ctest in the package's build tree (BUILD_TESTING)"
listed=$(ctest --test-dir "$build/package" -N | awk '/Total Tests:/ {print $3}')
[ "$listed" = 3 ] || { echo "ctest in $build/package lists '$listed' tests, expected 3" >&2; exit 1; }
status=0
ctest --test-dir "$build/package" --output-on-failure || status=$?

step "ours / peer timing ratios (wall clock, this run; no thresholds)"
log="$build/package/Testing/Temporary/LastTest.log"
grep -hE '^(RATIO|VTK SMP)' "$log" || true
grep -h 'SKIPPED' "$log" || true
exit "$status"
