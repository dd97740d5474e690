#!/usr/bin/env bash
# Simulates scenarios x seeds, runs FUSE on each and prints one markdown table row per run:
# end-to-end error, terminal drift, ATE, RPE(10 m), per-scan wall time mean / P95 / max, and the
# tail of the per-scan CPU time of the processing thread: median / P99 / max and P99 and max over
# the median (the stall goal: P99 <= 2x, max <= 3x the median).
#
#   bench/run_scenarios.sh [-c CONFIG] [-o OUTDIR] [-s "1 2 3"] [-l mid360|spinning32] [-r REPEATS] SCENARIO... [-- --set k=v ...]
#
# With -r N each run is repeated N times (the estimate is deterministic; the times are not): every
# time figure is then the median over the repeats. Simulations are cached in
# OUTDIR/sim-<scenario>-<lidar>-<seed> (fuse-sim is deterministic).
set -euo pipefail
cd "$(dirname "$0")/.."
CONFIG=config/mid360.yaml; OUT=out/bench; SEEDS="1"; LIDAR=mid360; REPEATS=1; SCENARIOS=(); EXTRA=()
while [ $# -gt 0 ]; do
  case "$1" in
    -c) CONFIG=$2; shift 2 ;;
    -o) OUT=$2; shift 2 ;;
    -s) SEEDS=$2; shift 2 ;;
    -l) LIDAR=$2; shift 2 ;;
    -r) REPEATS=$2; shift 2 ;;
    --) shift; EXTRA=("$@"); break ;;
    *) SCENARIOS+=("$1"); shift ;;
  esac
done
[ ${#SCENARIOS[@]} -gt 0 ] || { echo "usage: $0 [-c CONFIG] [-o OUTDIR] [-s SEEDS] [-l LIDAR] SCENARIO... [-- --set k=v ...]" >&2; exit 2; }
BIN=./build/bin
mkdir -p "$OUT"
echo "| scenario | lidar | seed | path m | end-to-end m | drift m (x / y / z) | drift % | ATE m | RPE(10 m) m | scan ms mean / P95 / max | CPU ms median / P99 / max | P99 / max over median | status |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
median() { sort -g | awk '{a[NR]=$1} END{print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
for sc in "${SCENARIOS[@]}"; do
  for seed in $SEEDS; do
    sim="$OUT/sim-$sc-$LIDAR-$seed"
    if [ ! -f "$sim/recording.mcap" ]; then
      $BIN/fuse-sim --scenario "$sc" --seed "$seed" --lidar "$LIDAR" --out "$sim" > "$sim.log" 2>&1
    fi
    run="$OUT/run-$sc-$LIDAR-$seed-$(basename "$CONFIG" .yaml)"
    status=ok
    get() { grep "^$1:" "$2" | head -1 | awk '{print $2}'; }
    keys=(scan_time_mean_ms scan_time_p95_ms scan_time_max_ms scan_cpu_median_ms scan_cpu_p99_ms scan_cpu_max_ms)
    : > "$run.times"
    for r in $(seq "$REPEATS"); do
      $BIN/fuse-run --config "$CONFIG" --input "$sim/recording.mcap" --out "$run" --log-level off "${EXTRA[@]}" > "$run.txt" 2>&1 || status="failed ($(grep '^error' "$run.txt" | head -1))"
      for k in "${keys[@]}"; do printf '%s ' "$(get "$k" "$run.txt")"; done >> "$run.times"
      echo >> "$run.times"
    done
    tm=(); for i in "${!keys[@]}"; do tm+=("$(awk -v c=$((i + 1)) '{print $c}' "$run.times" | median)"); done
    if $BIN/fuse-eval --gt "$sim/groundtruth.tum" --est "$run/trajectory.tum" --delta 10 > "$run.eval" 2>&1; then
      ate=$(get ate_rmse_m "$run.eval"); awk -v a="$ate" 'BEGIN{exit !(a > 1.0)}' && status="diverged (ATE > 1 m)"
      printf "| %s | %s | %s | %.1f | %.3f | %.3f / %.3f / %.3f | %.3f | %.3f | %.3f | %.2f / %.2f / %.2f | %.2f / %.2f / %.2f | %.2f / %.2f | %s |\n" \
        "$sc" "$LIDAR" "$seed" "$(get path_length_m "$run.eval")" "$(get end_to_end_m "$run.eval")" \
        "$(get drift_x_m "$run.eval")" "$(get drift_y_m "$run.eval")" "$(get drift_z_m "$run.eval")" \
        "$(get drift_percent "$run.eval")" "$ate" "$(get rpe_trans_rmse_m "$run.eval")" \
        "${tm[0]}" "${tm[1]}" "${tm[2]}" "${tm[3]}" "${tm[4]}" "${tm[5]}" \
        "$(awk -v a="${tm[4]}" -v m="${tm[3]}" 'BEGIN{print a / m}')" "$(awk -v a="${tm[5]}" -v m="${tm[3]}" 'BEGIN{print a / m}')" "$status"
    else
      echo "| $sc | $LIDAR | $seed | | | | | | | | | | $status; evaluation failed |"
    fi
  done
done
