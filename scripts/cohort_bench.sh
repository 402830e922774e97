#!/usr/bin/env bash
# scripts/cohort_bench.sh [N] [BINARY]: issue 18's cohort numbers. Writes N (default 20) variants
# of the ct-scene phantom (CT-like body, soft tissue, a contrast-filled vessel), a manifest with
# their seeds, and runs `balloonseg batch` on it with --jobs 1 and --jobs 2 (two threads in all),
# each into a fresh folder; prints the wall-clock time and peak RSS of each run, the cases that
# failed, and whether the two runs' meshes are byte for byte the same.
set -euo pipefail
n=${1:-20}
cli=${2:-target/release/balloonseg}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
{
  echo "id,image,seeds"
  for v in $(seq 0 $((n - 1))); do
    seed=$("$cli" phantom ct-scene --variant "$v" -o "$work/scan$v.mha" |
      python3 -c 'import json, sys; print(",".join(map(repr, json.load(sys.stdin)["seed_world"])))')
    echo "scan$v,scan$v.mha,\"$seed\""
  done
} > "$work/cohort.csv"
echo "| jobs | cases | failed | wall s | s per case | peak RSS MB |"
echo "|---|---|---|---|---|---|"
for jobs in 1 2; do
  /usr/bin/time -f "%e %M" -o "$work/time$jobs" \
    "$cli" --threads 2 batch "$work/cohort.csv" -o "$work/out$jobs" --jobs "$jobs" \
    2> "$work/log$jobs" || true
  read -r seconds kb < "$work/time$jobs"
  failed=$(grep -c ',failed,' "$work/out$jobs/results.csv" || true)
  echo "| $jobs | $n | $failed | $seconds | $(python3 -c "print(f'{$seconds / $n:.2f}')") | $((kb / 1024)) |"
done
same=yes
for v in $(seq 0 $((n - 1))); do
  cmp -s "$work/out1/scan$v.vtp" "$work/out2/scan$v.vtp" || same="no (scan$v differs)"
done
echo
echo "meshes of --jobs 1 and --jobs 2 byte for byte the same: $same"
grep ',failed,' "$work/out1/results.csv" || true
