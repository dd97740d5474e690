#!/usr/bin/env bash
# Every spatial index × update backend on the simulated corridor, over several seeds: one markdown
# row per (index, backend, seed) with end-to-end error, drift, ATE and per-scan time mean/P95/max.
# A run has diverged when it errors out, reports NaN or its ATE exceeds 1 m.
#
#   bench/matrix.sh [-s "1 2 3"] [-d DURATION_S] [-o OUTDIR] [-c CONFIG]
set -euo pipefail
cd "$(dirname "$0")/.."
SEEDS="1 2 3"; OUT=out/bench; CONFIG=config/mid360.yaml; DURATION=""
while [ $# -gt 0 ]; do
  case "$1" in
    -s) SEEDS=$2; shift 2 ;;
    -d) DURATION=$2; shift 2 ;;
    -o) OUT=$2; shift 2 ;;
    -c) CONFIG=$2; shift 2 ;;
    *) echo "usage: $0 [-s SEEDS] [-d DURATION_S] [-o OUTDIR] [-c CONFIG]" >&2; exit 2 ;;
  esac
done
mkdir -p "$OUT"
get() { grep "^$1:" "$2" | head -1 | awk '{print $2}'; }
echo "| index | backend | seed | end-to-end m | drift x / y / z m | ATE m | scan ms mean / P95 / max | status |"
echo "|---|---|---|---|---|---|---|---|"
for index in ivox kdtree voxel_grid; do
  for backend in ekf eskf ieskf nano; do
    for seed in $SEEDS; do
      sim="$OUT/sim-corridor-mid360-$seed${DURATION:+-${DURATION}s}"
      [ -f "$sim/recording.mcap" ] || ./build/bin/fuse-sim --scenario corridor --seed "$seed" ${DURATION:+--duration "$DURATION"} \
        --out "$sim" > "$sim.log" 2>&1
      run="$OUT/matrix-$index-$backend-$seed${DURATION:+-${DURATION}s}"
      status=ok
      ./build/bin/fuse-run --config "$CONFIG" --input "$sim/recording.mcap" --out "$run" --log-level off \
        --set estimator.spatial_index.type="$index" --set estimator.update.backend="$backend" > "$run.txt" 2>&1 \
        || status="failed: $(grep '^error' "$run.txt" | head -1 | cut -c1-60)"
      if [ "$status" = ok ] && ./build/bin/fuse-eval --gt "$sim/groundtruth.tum" --est "$run/trajectory.tum" > "$run.eval" 2>&1; then
        ate=$(get ate_rmse_m "$run.eval")
        awk -v a="$ate" 'BEGIN{exit !(a > 1.0 || a != a)}' && status="diverged (ATE > 1 m)"
        printf "| %s | %s | %s | %.3f | %.3f / %.3f / %.3f | %.3f | %.2f / %.2f / %.2f | %s |\n" "$index" "$backend" "$seed" \
          "$(get end_to_end_m "$run.eval")" "$(get drift_x_m "$run.eval")" "$(get drift_y_m "$run.eval")" \
          "$(get drift_z_m "$run.eval")" "$ate" "$(get scan_time_mean_ms "$run.txt")" "$(get scan_time_p95_ms "$run.txt")" \
          "$(get scan_time_max_ms "$run.txt")" "$status"
      else
        [ "$status" = ok ] && status="failed: evaluation"
        echo "| $index | $backend | $seed | | | | | $status |"
      fi
    done
  done
done
