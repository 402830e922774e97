#!/usr/bin/env bash
# scripts/fuzz.sh TARGET SECONDS: runs one cargo-fuzz target (fuzz/fuzz_targets: volume_readers,
# dicom, mesh_readers, segment, c_abi) for SECONDS with libFuzzer on the nightly toolchain,
# installing cargo-fuzz when it is missing. The corpus grows in fuzz/corpus/TARGET (seeded with
# small files of every format the CLI writes, and for dicom with fuzz/seeds/dicom) and findings
# land in fuzz/artifacts/TARGET; the script fails
# when libFuzzer reports one: a panic, an abort, an allocation over 2 GiB or a run over 20 s.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
target=${1:?usage: scripts/fuzz.sh TARGET SECONDS}
seconds=${2:?usage: scripts/fuzz.sh TARGET SECONDS}

rustup toolchain list | grep -q '^nightly' || rustup toolchain install nightly --profile minimal
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked

corpus="$root/fuzz/corpus/$target"
mkdir -p "$corpus" "$root/fuzz/artifacts/$target"
if [ -z "$(ls -A "$corpus")" ] && [ "$target" = dicom ]; then
  # The CLI writes no DICOM: checked-in slices, one per transfer syntax the reader decodes.
  cp "$root"/fuzz/seeds/dicom/*.dcm "$corpus"/
elif [ -z "$(ls -A "$corpus")" ] && [ "$target" != segment ]; then
  cargo build --release --all-features --bin balloonseg --locked -q
  cli="$root/target/release/balloonseg"
  scratch=$(mktemp -d)
  trap 'rm -rf "$scratch"' EXIT
  "$cli" phantom torus --spacing 3,3,3 -o "$scratch/v.mha" >/dev/null
  # Each seed is the target's format byte (its place in the target's list) and a file.
  seed() { { printf "\\x$(printf %02x "$1")"; cat "$2"; } > "$corpus/seed-$3"; }
  case "$target" in
    volume_readers)
      for f in mha nrrd nii.gz; do "$cli" phantom torus --spacing 3,3,3 -o "$scratch/v.$f" >/dev/null; done
      gzip -dc "$scratch/v.nii.gz" > "$scratch/v.nii"
      seed 0 "$scratch/v.mha" mha; seed 1 "$scratch/v.nrrd" nrrd
      seed 2 "$scratch/v.nii" nii; seed 3 "$scratch/v.nii.gz" nii.gz ;;
    mesh_readers)
      n=0
      for f in vtp vtk ply stl obj off; do
        "$cli" isosurface "$scratch/v.mha" --level 500 -o "$scratch/m.$f" >/dev/null
        seed "$n" "$scratch/m.$f" "$f"; n=$((n + 1))
      done ;;
  esac
fi

# Volumes for `segment` and the C ABI come from the bytes themselves: long inputs from the start.
case "$target" in
  segment | c_abi) length=(-max_len=16384 -len_control=0) ;;
  *) length=(-max_len=65536) ;;
esac
cd fuzz
cargo +nightly fuzz run "$target" "$corpus" -- "${length[@]}" \
  -max_total_time="$seconds" -timeout=20 -rss_limit_mb=4096 -malloc_limit_mb=2048 \
  -artifact_prefix="$root/fuzz/artifacts/$target/" -print_final_stats=1
