#!/usr/bin/env bash
# The balloon on the phantom families (examples/family_sweep.rs): 20 variants of each family,
# from the seed alone with the default parameters. Writes a markdown table per family (valid,
# genus, Dice, share of the other object inside, volumes, seconds) and a summary line per
# family (pass = valid, right genus and Dice >= 0.95; pass rate; median Dice), for
# BENCHMARKS.md.
#
# Usage: scripts/family_sweep.sh [OUT.md]   (default family_sweep.md; SAVE=DIR also keeps every
# variant's volume, mesh and JSON row; THREADS=N, default 0 = all cores)
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-family_sweep.md}"
cargo build --release --locked --features io --example family_sweep
{
  echo "Phantom families, 20 variants each, commit $(git rev-parse --short HEAD):"
  echo "\`scripts/family_sweep.sh\` (\`family_sweep --variants 20\`)."
  target/release/examples/family_sweep --variants 20 --threads "${THREADS:-0}" \
    ${SAVE:+--save "$SAVE"}
} | tee "$out"
