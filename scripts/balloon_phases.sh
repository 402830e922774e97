#!/usr/bin/env bash
# Seconds per phase of the balloon (`balloonseg segment --stats`) on the six phantoms (10%
# noise, 0.8 x 0.8 x 1.5 mm voxels, oblique grid) and the two real scans, for each of the given
# `balloonseg` binaries (e.g. an older build and the current one), alternating, best of 3 totals
# per case and binary. Prints the rows of BENCHMARKS.md's phase table.
#
# Usage: scripts/balloon_phases.sh LABEL=BINARY [LABEL=BINARY ...]
#   e.g. scripts/balloon_phases.sh before=/tmp/old/target/release/balloonseg now=target/release/balloonseg
set -euo pipefail
cd "$(dirname "$0")/.."
data="${BALLOONSEG_DATA:-../shared/data}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
[ $# -gt 0 ] || { echo "usage: $0 LABEL=BINARY [LABEL=BINARY ...]" >&2; exit 2; }
first="${1#*=}"
cases=(sphere:0,0,0 torus:0,12,0 double-torus:12,12,0 y-vessel:0,0,-10 touching-tubes:-4,0,0
       fading-tube:0,-20,0 aorta:-221.484,-156.445,22.501 carotid:117,103,9)
for c in "${cases[@]:0:6}"; do
  "$first" phantom "${c%%:*}" -o "$work/${c%%:*}.mha" --spacing 0.8,0.8,1.5 --oblique --noise 0.1 >/dev/null
done
total() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['seconds']['total'])" "$1"; }
for c in "${cases[@]}"; do
  name=${c%%:*}; seed=${c#*:}
  case $name in
    aorta) input="$data/vmtk-aorta/aorta.mha" ;;
    carotid) input="$data/vtk-carotid/carotid.mha" ;;
    *) input="$work/$name.mha" ;;
  esac
  for round in 1 2 3; do
    for spec in "$@"; do
      label=${spec%%=*}; binary=${spec#*=}
      "$binary" segment "$input" --seed "$seed" -o "$work/out.vtp" --stats "$work/run.json" >/dev/null 2>&1
      best="$work/best_${label}_$name.json"
      if [ ! -f "$best" ] || python3 -c "import sys; sys.exit(0 if float(sys.argv[1]) < float(sys.argv[2]) else 1)" \
          "$(total "$work/run.json")" "$(total "$best")"; then
        cp "$work/run.json" "$best"
      fi
    done
  done
  for spec in "$@"; do
    python3 - "$name" "${spec%%=*}" "$work/best_${spec%%=*}_$name.json" <<'PY'
import json, sys
name, label, path = sys.argv[1:]
d = json.load(open(path))
s = d["seconds"]
print(f"| {name} | {label} | {d['genus']} | {d['iterations']:,} | {d['vertices']:,} | "
      f"{s['inflation']:.2f} | {s['self_intersection']:.2f} | {s['reparametrization']:.2f} | "
      f"{s['refinement']:.2f} | {s['validation']:.2f} | {s['total']:.2f} |")
PY
  done
done
