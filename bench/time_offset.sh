#!/usr/bin/env bash
# Sensitivity to a LiDAR-IMU time offset (issue "what real vehicles bring"): each scene is
# simulated with its IMU stamped late by each offset (fuse-sim --imu-time-offset), FUSE runs with
# the config as given, and one markdown row per run prints the ATE against the simulator's truth
# and its ratio to the same scene without an offset.
#
#   bench/time_offset.sh [-c CONFIG] [-l LIDAR] [-o OUTDIR] [-s SEED] [-d DURATION_S] [-t "OFFSETS_MS"]
#                        SCENARIO... [-- --set k=v ...]
#   defaults: config/mid360.yaml, lidar mid360 (spinning32: pass -c config/spinning.yaml too), out/bench,
#   seed 1, the whole scenario, offsets "-50 -20 -5 0 5 20 50"
#
# Simulations are cached in OUTDIR/sim-<scenario>-<seed>-<duration>-off<ms> (fuse-sim is
# deterministic). FUSE_BIN: binaries (default build/bin).
set -euo pipefail
cd "$(dirname "$0")/.."
CONFIG=config/mid360.yaml; LIDAR=mid360; OUT=out/bench; SEED=1; DURATION=""; OFFSETS="-50 -20 -5 0 5 20 50"; SCENARIOS=(); EXTRA=()
while [ $# -gt 0 ]; do
  case "$1" in
    -c) CONFIG=$2; shift 2 ;;
    -l) LIDAR=$2; shift 2 ;;
    -o) OUT=$2; shift 2 ;;
    -s) SEED=$2; shift 2 ;;
    -d) DURATION=$2; shift 2 ;;
    -t) OFFSETS=$2; shift 2 ;;
    --) shift; EXTRA=("$@"); break ;;
    *) SCENARIOS+=("$1"); shift ;;
  esac
done
[ ${#SCENARIOS[@]} -gt 0 ] || { echo "usage: $0 [-c CONFIG] [-l LIDAR] [-o OUTDIR] [-s SEED] [-d DURATION_S] [-t \"OFFSETS_MS\"] SCENARIO... [-- --set k=v ...]" >&2; exit 2; }
BIN=${FUSE_BIN:-build/bin}
SUFFIX=""; [ "$LIDAR" = mid360 ] || SUFFIX="-$LIDAR"  # mid360 keeps the cache names it had
mkdir -p "$OUT"
get() { grep "^$1:" "$2" | head -1 | awk '{print $2}'; }
echo "| scenario | seed | IMU offset ms | ATE m | ATE / offset 0 | scan ms mean / P95 / max | status |"
echo "|---|---|---|---|---|---|---|"
for sc in "${SCENARIOS[@]}"; do
  declare -A ate=()
  status=()
  for ms in $OFFSETS; do
    s=$(awk -v m="$ms" 'BEGIN{printf "%.6f", m / 1000}')
    sim="$OUT/sim-$sc-$SEED-${DURATION:-all}-off$ms$SUFFIX"
    if [ ! -f "$sim/recording.mcap" ]; then
      $BIN/fuse-sim --scenario "$sc" --seed "$SEED" --lidar "$LIDAR" ${DURATION:+--duration "$DURATION"} --imu-time-offset "$s" \
        --out "$sim" > "$sim.log" 2>&1
    fi
    run="$OUT/run-$sc-$SEED-${DURATION:-all}-off$ms$SUFFIX-$(basename "$CONFIG" .yaml)"
    st=ok
    $BIN/fuse-run --config "$CONFIG" --input "$sim/recording.mcap" --out "$run" --log-level off "${EXTRA[@]}" \
      > "$run.txt" 2>&1 || st="exit $?"
    if $BIN/fuse-eval --gt "$sim/groundtruth.tum" --est "$run/trajectory.tum" > "$run.eval" 2>&1; then
      ate[$ms]=$(get ate_rmse_m "$run.eval")
    else
      ate[$ms]=nan
      st="$st; evaluation failed"
    fi
    status+=("$ms|$st|$(get scan_time_mean_ms "$run.txt") / $(get scan_time_p95_ms "$run.txt") / $(get scan_time_max_ms "$run.txt")")
  done
  zero=${ate[0]:-nan}
  for row in "${status[@]}"; do
    IFS='|' read -r ms st times <<< "$row"
    ratio=$(awk -v a="${ate[$ms]}" -v z="$zero" 'BEGIN{ if (z == "nan" || a == "nan" || z + 0 == 0) print "nan"; else printf "%.2f", a / z }')
    printf "| %s | %s | %s | %s | %s | %s | %s |\n" "$sc" "$SEED" "$ms" "${ate[$ms]}" "$ratio" "$times" "$st"
  done
  unset ate
done
