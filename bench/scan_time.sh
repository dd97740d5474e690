#!/usr/bin/env bash
# Per-scan estimator time on Mid-360-like scans (~20k points): runs fuse-run REPEATS times on the
# same recording and prints the median over the repeats of the per-run mean / P95 / max.
# Single thread; the machine is noisy, so only medians over repeats are reported.
#
#   bench/scan_time.sh [RECORDING] [REPEATS] [CONFIG]
set -euo pipefail
cd "$(dirname "$0")/.."
REC=${1:-out/bench/sim-corridor-mid360-1/recording.mcap}
REPEATS=${2:-5}
CONFIG=${3:-config/mid360.yaml}
if [ ! -f "$REC" ]; then
  mkdir -p "$(dirname "$REC")"
  ./build/bin/fuse-sim --scenario corridor --seed 1 --out "$(dirname "$REC")" > /dev/null 2>&1
fi
tmp=$(mktemp -d)
for i in $(seq "$REPEATS"); do
  ./build/bin/fuse-run --config "$CONFIG" --input "$REC" --out "$tmp/run" --log-level off > "$tmp/out$i.txt"
  grep -E "scan_time_(mean|p95|max)_ms" "$tmp/out$i.txt" | awk '{print $2}' | paste -sd' ' >> "$tmp/all.txt"
done
median() { sort -g | awk '{a[NR]=$1} END{print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
echo "recording: $REC"
echo "repeats: $REPEATS"
echo "scan_time_mean_ms_median: $(awk '{print $1}' "$tmp/all.txt" | median)"
echo "scan_time_p95_ms_median: $(awk '{print $2}' "$tmp/all.txt" | median)"
echo "scan_time_max_ms_median: $(awk '{print $3}' "$tmp/all.txt" | median)"
echo "points_in_mean: $(awk -F, 'NR>1{s+=$3; n++} END{printf "%.0f", s/n}' "$tmp/run/timing.csv")"
echo "points_kept_mean: $(awk -F, 'NR>1{s+=$4; n++} END{printf "%.0f", s/n}' "$tmp/run/timing.csv")"
rm -rf "$tmp"
