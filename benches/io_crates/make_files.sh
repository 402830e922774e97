#!/bin/bash
# Writes the files that `io_crates speed` and fuzz.sh read into $1 (default
# /tmp/io_crates_files): VTK's writers (make_files.py, with the VTK of $PYTHON, by default the
# project's .venv), our writers (the aorta segmented from its seed, a small isosurface) and
# NIfTI volumes of the shared data.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
data=$root/../shared/data
out=${1:-/tmp/io_crates_files}
mkdir -p "$out/small"
(cd "$root" && CARGO_BUILD_JOBS=1 cargo build --release --features io,cli --bin balloonseg)
bin=$root/target/release/balloonseg
"${PYTHON:-$root/.venv/bin/python}" "$(dirname "$0")/make_files.py" "$data" "$out"
for ext in vtp vtk stl ply; do
    "$bin" segment "$data/vmtk-aorta/aorta.mha" --seed 74,150,15 --index -o "$out/aorta.$ext" >/dev/null
done
cp "$data/ts_abdomen_slab_ct/image.nii.gz" "$out/ts.nii.gz"
gunzip -c "$out/ts.nii.gz" >"$out/ts.nii"
cp "$data/avf_arm_mra/image.nii.gz" "$out/avf.nii.gz"
"$bin" phantom sphere --spacing 4,4,4 -o "$out/small/s.nii.gz" >/dev/null
gunzip -c "$out/small/s.nii.gz" >"$out/small/s.nii"
for ext in vtp vtk stl ply; do
    "$bin" isosurface "$out/small/s.nii.gz" --level 300 -o "$out/small/ours.$ext" >/dev/null
done
