#!/usr/bin/env bash
# The evaluation table of docs/evaluation.md (issue 4): on the simulated 418 m corridor loop, over
# several seeds, every spatial index × update backend and the paper's ablation (the default
# ivox + ieskf with one mechanism off at a time). One markdown row per (configuration, seed):
# end-to-end error, drift components, ATE, per-scan time mean / P95 / max, status. A run has
# diverged when it errors out, reports NaN, or its ATE exceeds 1 m.
#
#   bench/evaluation.sh [-s "1 2 3"] [-o OUTDIR] [-c CONFIG] [-w FILE]
#     -w FILE   also write the table into FILE between the lines
#               <!-- evaluation-table:begin --> and <!-- evaluation-table:end -->
#   environment: FUSE_BIN (binaries, default build/bin)
#
# Runs one after another on one core each; per-scan times are only comparable when the machine is
# otherwise idle (the script prints the load average before and after).
set -euo pipefail
cd "$(dirname "$0")/.."
SEEDS="1 2 3"; OUT=out/bench; CONFIG=config/mid360.yaml; WRITE=""
BIN=${FUSE_BIN:-build/bin}
while [ $# -gt 0 ]; do
  case "$1" in
    -s) SEEDS=$2; shift 2 ;;
    -o) OUT=$2; shift 2 ;;
    -c) CONFIG=$2; shift 2 ;;
    -w) WRITE=$2; shift 2 ;;
    *) echo "usage: $0 [-s SEEDS] [-o OUTDIR] [-c CONFIG] [-w FILE]" >&2; exit 2 ;;
  esac
done
mkdir -p "$OUT"

# name|overrides (space-separated key=value)
CONFIGS=()
for index in ivox kdtree voxel_grid; do
  for backend in ekf eskf ieskf nano; do
    CONFIGS+=("$index + $backend|estimator.spatial_index.type=$index estimator.update.backend=$backend")
  done
done
CONFIGS+=("ivox + ieskf, no degeneracy-aware update|estimator.update.degeneracy.enabled=false")
CONFIGS+=("ivox + ieskf, no residual screening|estimator.association.screening=false")
CONFIGS+=("ivox + ieskf, no covariance propagation|estimator.imu_noise.propagate_covariance=false")
CONFIGS+=("ivox + ieskf, no deskew|estimator.preprocess.deskew=false")

get() { awk -v k="$1:" '$1==k {print $2; exit}' "$2"; }
table=$(mktemp)
trap 'rm -f "$table"' EXIT
{
  echo "| configuration | seed | end-to-end m | drift x / y / z m | ATE m | scan ms mean / P95 / max | status |"
  echo "|---|---|---|---|---|---|---|"
} > "$table"
echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ); load before: $(cut -d' ' -f1-3 /proc/loadavg)" >&2
for entry in "${CONFIGS[@]}"; do
  name=${entry%%|*}
  sets=()
  for kv in ${entry#*|}; do sets+=(--set "$kv"); done
  slug=$(echo "$name" | tr -c 'a-z0-9\n' '-' | tr -s '-')
  for seed in $SEEDS; do
    sim="$OUT/sim-corridor-mid360-$seed"
    [ -f "$sim/recording.mcap" ] || "$BIN/fuse-sim" --scenario corridor --seed "$seed" --out "$sim" > "$sim.log" 2>&1
    run="$OUT/eval-$slug-$seed"
    status=ok
    "$BIN/fuse-run" --config "$CONFIG" --input "$sim/recording.mcap" --out "$run" --log-level off "${sets[@]}" > "$run.txt" 2>&1 ||
      status="failed: $(grep '^error' "$run.txt" | head -1 | cut -c1-90)"
    if [ "$status" = ok ] && "$BIN/fuse-eval" --gt "$sim/groundtruth.tum" --est "$run/trajectory.tum" > "$run.eval" 2>&1; then
      ate=$(get ate_rmse_m "$run.eval")
      awk -v a="$ate" 'BEGIN{exit !(a > 1.0 || a != a)}' && status="diverged (ATE > 1 m)"
      printf "| %s | %s | %.3f | %.3f / %.3f / %.3f | %.3f | %.2f / %.2f / %.2f | %s |\n" "$name" "$seed" \
        "$(get end_to_end_m "$run.eval")" "$(get drift_x_m "$run.eval")" "$(get drift_y_m "$run.eval")" \
        "$(get drift_z_m "$run.eval")" "$ate" "$(get scan_time_mean_ms "$run.txt")" "$(get scan_time_p95_ms "$run.txt")" \
        "$(get scan_time_max_ms "$run.txt")" "$status" >> "$table"
    else
      [ "$status" = ok ] && status="failed: evaluation"
      echo "| $name | $seed | | | | | $status |" >> "$table"
    fi
    tail -1 "$table" >&2
  done
done
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)" >&2
cat "$table"
if [ -n "$WRITE" ]; then
  grep -q '^<!-- evaluation-table:begin -->$' "$WRITE" && grep -q '^<!-- evaluation-table:end -->$' "$WRITE" ||
    { echo "$WRITE has no evaluation-table markers" >&2; exit 1; }
  awk -v t="$table" '
    /^<!-- evaluation-table:begin -->$/ {print; while ((getline l < t) > 0) print l; skip=1; next}
    /^<!-- evaluation-table:end -->$/ {skip=0}
    !skip {print}' "$WRITE" > "$WRITE.new" && mv "$WRITE.new" "$WRITE"
  echo "written into $WRITE" >&2
fi
