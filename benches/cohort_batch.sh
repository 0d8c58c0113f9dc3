#!/usr/bin/env bash
# The cohort bench (issue 19): 100 synthetic placentas of 7,200 tets with
# one 3D image each (and the demo's 6 ventricles and 6 valves), batch +
# cohort (every subject's figures and the report page OUT/index.html
# included), timed; target under 2 minutes on 2 cores. The batch process's own
# peak memory (VmHWM, UNFOLD_PEAK_FILE) is printed for 20 and for 100
# placentas: the statistics are accumulated in one pass, so it stays flat.
#
#   benches/cohort_batch.sh            (builds the release binary first)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --bin unfold >/dev/null
bin=target/release/unfold
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for n in 20 100; do
  start=$(date +%s.%N)
  UNFOLD_PEAK_FILE="$work/peak$n" "$bin" demo --cohort --placentas "$n" -o "$work/c$n" \
    | tail -1
  end=$(date +%s.%N)
  peak=$(cat "$work/peak$n")
  awk -v n="$n" -v s="$start" -v e="$end" -v p="$peak" 'BEGIN {
    printf "cohort bench: %d placentas + 6 ventricles + 6 valves: %.1f s, batch process peak %.1f MiB\n",
      n, e - s, p / 1048576 }'
done
