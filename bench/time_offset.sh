#!/usr/bin/env bash
# Sensitivity to a LiDAR-IMU time offset (issue "what real vehicles bring"): each scene is
# simulated with its IMU stamped late by each offset (fuse-sim --imu-time-offset), FUSE runs with
# the config as given, and one markdown row per run prints the ATE against the simulator's truth
# and its ratio to the same scene without an offset.
#
#   bench/time_offset.sh [-c CONFIG] [-l LIDAR] [-o OUTDIR] [-s SEED] [-d DURATION_S] [-t "OFFSETS_MS"]
#                        [-v "KEY V1 V2 ..."] SCENARIO... [-- --set k=v ...]
#   defaults: config/mid360.yaml, lidar mid360 (spinning32: pass -c config/spinning.yaml too), out/bench,
#   seed 1, the whole scenario, offsets "-50 -20 -5 0 5 20 50"
#
# -v runs every offset once per value of config key KEY (--set KEY=V) and reports the median ATE
# and its ratio to the median without an offset. A run's ATE can move by tens of per cent with a
# change of a key's value by 1 % (the map's points fall differently, and the run's error with
# them): a ratio of single runs then measures that, not the offset. For example
# -v "estimator.map.min_point_distance 0.148 0.15 0.152".
#
# Simulations are cached in OUTDIR/sim-<scenario>-<seed>-<duration>-off<ms> (fuse-sim is
# deterministic); a whole scenario takes 0.2-1.7 GB per offset for the Mid-360 and 2-4 GB for
# spinning32 (-d limits it). FUSE_BIN: binaries (default build/bin).
set -euo pipefail
cd "$(dirname "$0")/.."
CONFIG=config/mid360.yaml; LIDAR=mid360; OUT=out/bench; SEED=1; DURATION=""; OFFSETS="-50 -20 -5 0 5 20 50"; SCENARIOS=(); EXTRA=()
VARY_KEY=""; VARY_VALUES=("")
while [ $# -gt 0 ]; do
  case "$1" in
    -c) CONFIG=$2; shift 2 ;;
    -l) LIDAR=$2; shift 2 ;;
    -o) OUT=$2; shift 2 ;;
    -s) SEED=$2; shift 2 ;;
    -d) DURATION=$2; shift 2 ;;
    -t) OFFSETS=$2; shift 2 ;;
    -v) read -r VARY_KEY rest <<< "$2"; read -r -a VARY_VALUES <<< "$rest"; shift 2
        [ -n "$VARY_KEY" ] && [ ${#VARY_VALUES[@]} -gt 0 ] || { echo "-v needs \"KEY V1 V2 ...\"" >&2; exit 2; } ;;
    --) shift; EXTRA=("$@"); break ;;
    *) SCENARIOS+=("$1"); shift ;;
  esac
done
[ ${#SCENARIOS[@]} -gt 0 ] || { echo "usage: $0 [-c CONFIG] [-l LIDAR] [-o OUTDIR] [-s SEED] [-d DURATION_S] [-t \"OFFSETS_MS\"] [-v \"KEY V1 V2 ...\"] SCENARIO... [-- --set k=v ...]" >&2; exit 2; }
BIN=${FUSE_BIN:-build/bin}
SUFFIX=""; [ "$LIDAR" = mid360 ] || SUFFIX="-$LIDAR"  # mid360 keeps the cache names it had
mkdir -p "$OUT"
get() { grep "^$1:" "$2" | head -1 | awk '{print $2}'; }
# The median of a list of numbers ("nan" when any is nan).
median() { tr ' ' '\n' | grep -v '^$' | sort -g | awk '{ v[++n] = $1; if ($1 == "nan") bad = 1 }
  END { if (bad || n == 0) { print "nan"; exit } printf "%.6f", n % 2 ? v[(n + 1) / 2] : (v[n / 2] + v[n / 2 + 1]) / 2 }'; }
echo "| scenario | seed | IMU offset ms | ATE m | ATE / offset 0 | runs' ATE m | scan ms mean / P95 / max | status |"
echo "|---|---|---|---|---|---|---|---|"
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
    st=ok; runs=""; times=""
    for v in "${VARY_VALUES[@]}"; do
      run="$OUT/run-$sc-$SEED-${DURATION:-all}-off$ms$SUFFIX-$(basename "$CONFIG" .yaml)${v:+-$v}"
      vary=(); [ -z "$v" ] || vary=(--set "$VARY_KEY=$v")
      $BIN/fuse-run --config "$CONFIG" --input "$sim/recording.mcap" --out "$run" --log-level off "${vary[@]}" "${EXTRA[@]}" \
        > "$run.txt" 2>&1 || st="exit $?"
      if $BIN/fuse-eval --gt "$sim/groundtruth.tum" --est "$run/trajectory.tum" > "$run.eval" 2>&1; then
        runs="$runs $(get ate_rmse_m "$run.eval")"
      else
        runs="$runs nan"
        st="$st; evaluation failed"
      fi
      times="$times${times:+, }$(get scan_time_mean_ms "$run.txt") / $(get scan_time_p95_ms "$run.txt") / $(get scan_time_max_ms "$run.txt")"
    done
    ate[$ms]=$(median <<< "$runs")
    status+=("$ms|$st|$times|${runs# }")
  done
  zero=${ate[0]:-nan}
  for row in "${status[@]}"; do
    IFS='|' read -r ms st times runs <<< "$row"
    ratio=$(awk -v a="${ate[$ms]}" -v z="$zero" 'BEGIN{ if (z == "nan" || a == "nan" || z + 0 == 0) print "nan"; else printf "%.2f", a / z }')
    printf "| %s | %s | %s | %s | %s | %s | %s | %s |\n" "$sc" "$SEED" "$ms" "${ate[$ms]}" "$ratio" "$runs" "$times" "$st"
  done
  unset ate
done
