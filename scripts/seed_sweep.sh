#!/usr/bin/env bash
# The balloon from many seeds (voxel indices) on the real scans, defaults only: the estimated
# border, genus, components, re-parametrisations, steps, volume and seconds of each run, and a
# summary line per scan. The aorta's 20 seeds lie all along its lumen (the README's, its six
# neighbours, and thirteen drawn at random where the lumen is more than 4 mm deep); the
# carotid's are the README's and its six neighbours but one.
#
# Usage: scripts/seed_sweep.sh [BINARY]   (default target/release/balloonseg)
set -euo pipefail
cd "$(dirname "$0")/.."
binary="${1:-target/release/balloonseg}"
data="${BALLOONSEG_DATA:-../shared/data}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
aorta=(74,150,15 73,150,15 75,150,15 74,149,15 74,151,15 74,150,14 74,150,16 74,180,15
       70,228,16 75,154,13 72,188,15 72,136,16 77,132,15 72,168,14 73,199,14 75,171,13
       73,140,16 72,196,16 74,146,17 76,136,14)
carotid=(17,23,8 16,23,8 18,23,8 17,22,8 17,23,7 17,23,9)
sweep() {
  local name=$1 input=$2; shift 2
  echo "| scan | seed (index) | border | genus | components | re-parametrisations | steps | volume mm³ | s |"
  echo "|---|---|---|---|---|---|---|---|---|"
  for seed in "$@"; do
    "$binary" segment "$input" --index --seed "$seed" -o "$work/out.vtp" --stats "$work/run.json" \
      >/dev/null 2>"$work/err" || { cat "$work/err" >&2; exit 1; }
    python3 - "$name" "$seed" "$work/run.json" <<'PY'
import json, sys
name, seed, path = sys.argv[1:]
d = json.load(open(path))
print(f"| {name} | {seed} | {d['reference_intensity'] - d['tolerance']:.0f} | {d['genus']} | "
      f"{d['components']} | {d['reparametrizations']} | {d['iterations']} | "
      f"{d['volume_mm3']:,.0f} | {d['seconds']['total']:.2f} |")
PY
  done
}
sweep aorta "$data/vmtk-aorta/aorta.mha" "${aorta[@]}" | tee "$work/aorta.md"
sweep carotid "$data/vtk-carotid/carotid.mha" "${carotid[@]}" | tee "$work/carotid.md"
for scan in aorta carotid; do
  python3 - "$scan" "$work/$scan.md" <<'PY'
import collections, sys
scan, path = sys.argv[1:]
rows = [l.split("|")[1:-1] for l in open(path) if l.startswith(f"| {scan} ")]
genus = collections.Counter(int(r[3]) for r in rows)
one = sum(int(r[4]) == 1 for r in rows)
print(f"{scan}: {len(rows)} seeds, genus {dict(sorted(genus.items()))}, one component {one}")
PY
done
