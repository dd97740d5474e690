#!/usr/bin/env bash
# The mechanisms' ablation on the simulated corridor: the full configuration and one switch off at
# a time, over several seeds. Prints one markdown row per (variant, seed) and the mean per variant.
#
#   bench/ablation.sh [-s "1 2 3"] [-o OUTDIR] [-c CONFIG]
set -euo pipefail
cd "$(dirname "$0")/.."
SEEDS="1 2 3"; OUT=out/bench; CONFIG=config/mid360.yaml
while [ $# -gt 0 ]; do
  case "$1" in
    -s) SEEDS=$2; shift 2 ;;
    -o) OUT=$2; shift 2 ;;
    -c) CONFIG=$2; shift 2 ;;
    *) echo "usage: $0 [-s SEEDS] [-o OUTDIR] [-c CONFIG]" >&2; exit 2 ;;
  esac
done
declare -A VARIANTS=(
  [full]=""
  [no_degeneracy_aware_update]="estimator.update.degeneracy.enabled=false"
  [no_residual_screening]="estimator.association.screening=false"
  [no_covariance_propagation]="estimator.imu_noise.propagate_covariance=false"
  [no_deskew]="estimator.preprocess.deskew=false"
)
ORDER=(full no_degeneracy_aware_update no_residual_screening no_covariance_propagation no_deskew)
mkdir -p "$OUT"
echo "| variant | seed | end-to-end m | ATE m | RPE(10 m) m | scan ms mean | status |"
echo "|---|---|---|---|---|---|---|"
for v in "${ORDER[@]}"; do
  for seed in $SEEDS; do
    sim="$OUT/sim-corridor-mid360-$seed"
    [ -f "$sim/recording.mcap" ] || ./build/bin/fuse-sim --scenario corridor --seed "$seed" --out "$sim" > "$sim.log" 2>&1
    run="$OUT/ablation-$v-$seed"
    set_args=(); [ -n "${VARIANTS[$v]}" ] && set_args=(--set "${VARIANTS[$v]}")
    status=ok
    ./build/bin/fuse-run --config "$CONFIG" --input "$sim/recording.mcap" --out "$run" --log-level off "${set_args[@]}" > "$run.txt" 2>&1 \
      || status="failed: $(grep '^error' "$run.txt" | head -1 | cut -c1-80)"
    get() { grep "^$1:" "$2" | head -1 | awk '{print $2}'; }
    if [ "$status" = ok ] && ./build/bin/fuse-eval --gt "$sim/groundtruth.tum" --est "$run/trajectory.tum" --delta 10 > "$run.eval" 2>&1; then
      ate=$(get ate_rmse_m "$run.eval"); awk -v a="$ate" 'BEGIN{exit !(a > 1.0)}' && status="diverged (ATE > 1 m)"
      printf "| %s | %s | %.3f | %.3f | %.3f | %.2f | %s |\n" "$v" "$seed" "$(get end_to_end_m "$run.eval")" "$ate" \
        "$(get rpe_trans_rmse_m "$run.eval")" "$(get scan_time_mean_ms "$run.txt")" "$status"
    else
      echo "| $v | $seed | | | | | $status |"
    fi
  done
done
