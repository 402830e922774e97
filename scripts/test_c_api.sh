#!/usr/bin/env bash
# Tests the C API as a C or C++ user sees it: cpp_tests/c_api/*.c* compiled against
# include/balloonseg.h and linked with target/release/libballoonseg.so, never the Rust sources.
# Each test is built twice and run twice: with AddressSanitizer + UBSan (leak detection on;
# the Rust library itself is not instrumented), and plainly under valgrind memcheck. Any
# error fails the script. Needs cc, c++ (with libasan/libubsan) and valgrind.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
cargo build --release --lib --locked

lib_dir="$root/target/release"
out="$root/target/c_api_tests"
mkdir -p "$out/lib"
# Programs record the SONAME, libballoonseg.so.0, which cargo does not create: link it here.
ln -sf "$lib_dir/libballoonseg.so" "$out/lib/libballoonseg.so.0"
src="$root/cpp_tests/c_api"
warnings=(-Wall -Wextra -Werror -g -I"$root/include")
link=(-L"$lib_dir" -Wl,-rpath,"$out/lib" -lballoonseg -lm -lpthread)
sanitize=(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)

build() { # name compiler std source extra-flags...
  local name=$1 compiler=$2 std=$3 source=$4
  shift 4
  "$compiler" "-std=$std" "${warnings[@]}" "$@" "$source" -o "$out/$name" "${link[@]}"
}

build test_c_api_asan cc c99 "$src/test_c_api.c" "${sanitize[@]}"
build test_cpp_api_asan c++ c++14 "$src/test_cpp_api.cpp" "${sanitize[@]}"
build test_c_api cc c99 "$src/test_c_api.c" -O1
build test_cpp_api c++ c++14 "$src/test_cpp_api.cpp" -O1

for test in test_c_api test_cpp_api; do
  echo "== $test (ASan + UBSan)"
  ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    "$out/${test}_asan"
  echo "== $test (valgrind)"
  # Rayon's worker threads (the global pool of the mesh checks) outlive main by design: their
  # stacks are "possibly lost". Definite and indirect leaks, and every memory error, fail.
  valgrind --error-exitcode=1 --leak-check=full --show-leak-kinds=definite,indirect \
    --errors-for-leak-kinds=definite,indirect --quiet "$out/$test"
done
echo "C API tests passed"
