#!/usr/bin/env bash
# Genus of the balloon on every phantom over several noise seeds (10% noise, oblique grid,
# anisotropic and isotropic spacing), against the phantom's analytic genus: a handle made of
# noise, or a loop filled over, shows up as a mismatch.
#
#   scripts/phantom_genus_sweep.sh BALLOONSEG [WORK_DIR]
#
# Prints one line per volume (shape, spacing, noise seed, analytic genus, balloon genus,
# re-parametrisations) and a count of mismatches; exits 1 if there is any.
set -euo pipefail
bin=${1:?usage: $0 BALLOONSEG [WORK_DIR]}
work=${2:-$(mktemp -d)}
mkdir -p "$work"
field() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))$2)" "$1"; }
mismatches=0
printf '%-15s %-12s %5s %6s %6s %8s\n' shape spacing noise wanted genus reparams
for shape in sphere torus double-torus y-vessel touching-tubes; do
  for spacing in 0.8,0.8,1.5 1,1,1; do
    for noise_seed in 1 2 3 4 5 6; do
      volume="$work/$shape-$spacing-$noise_seed.mha"
      "$bin" phantom "$shape" --noise 0.1 --oblique --spacing "$spacing" \
        --noise-seed "$noise_seed" -o "$volume" >"$volume.json"
      seed=$(field "$volume.json" "['seed_world']" | tr -d '[] ')
      wanted=$(field "$volume.json" "['genus']")
      "$bin" segment "$volume" --seed="$seed" -o "$work/$shape-$spacing-$noise_seed.vtp" \
        --stats "$volume.stats.json" >/dev/null 2>&1
      genus=$(field "$volume.stats.json" "['genus']")
      reparams=$(field "$volume.stats.json" "['reparametrizations']")
      printf '%-15s %-12s %5s %6s %6s %8s\n' "$shape" "$spacing" "$noise_seed" "$wanted" \
        "$genus" "$reparams"
      [ "$genus" = "$wanted" ] || mismatches=$((mismatches + 1))
    done
  done
done
echo "mismatches: $mismatches"
[ "$mismatches" -eq 0 ]
