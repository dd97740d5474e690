#!/usr/bin/env bash
# NANO's per-scan cost against the IESKF's (issue 4: at most 1.5x), per spatial index: fuse-run
# with update.backend=ieskf and =nano, alternated REPEATS times on the same recording (so that
# the machine's drift hits both alike); prints the median per-scan mean of each and their ratio.
#
#   bench/nano_cost.sh [RECORDING] [REPEATS] [CONFIG]
#     (defaults: the seed-3 corridor loop, 3, config/mid360.yaml)
set -euo pipefail
cd "$(dirname "$0")/.."
REC=${1:-out/bench/sim-corridor-mid360-3/recording.mcap}
REPEATS=${2:-3}
CONFIG=${3:-config/mid360.yaml}
BIN=${FUSE_BIN:-build/bin}
if [ ! -f "$REC" ]; then
  mkdir -p "$(dirname "$REC")"
  "$BIN/fuse-sim" --scenario corridor --seed 3 --out "$(dirname "$REC")" > /dev/null 2>&1
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
median() { sort -g | awk '{a[NR]=$1} END{print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
echo "recording: $REC; repeats: $REPEATS; load before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "| index | ieskf ms (median of means) | nano ms | nano / ieskf |"
echo "|---|---|---|---|"
for index in ivox kdtree voxel_grid; do
  for i in $(seq "$REPEATS"); do
    for backend in ieskf nano; do
      "$BIN/fuse-run" --config "$CONFIG" --input "$REC" --out "$tmp/run" --log-level off \
        --set estimator.spatial_index.type="$index" --set estimator.update.backend="$backend" > "$tmp/out.txt"
      awk '$1=="scan_time_mean_ms:" {print $2}' "$tmp/out.txt" >> "$tmp/$index-$backend"
    done
  done
  a=$(median < "$tmp/$index-ieskf"); b=$(median < "$tmp/$index-nano")
  printf "| %s | %.2f | %.2f | %.2f |\n" "$index" "$a" "$b" "$(awk -v a="$a" -v b="$b" 'BEGIN{print b/a}')"
done
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
