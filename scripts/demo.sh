#!/usr/bin/env bash
# The main job on built-in simulated data: simulate the 418 m corridor loop (seed 1), run the four
# FUSE services on it (fuse-map, fuse-state, fuse-update, fuse-ingest over DDS on loopback, in
# lockstep), ask fuse-query for the state while they run, and print the trajectory error; then
# the same recording through the single-process fuse-run for the per-scan time and a check that
# both give the same trajectory; last, figures of the run (fuse-eval --plot) in $OUT/plots.
set -euo pipefail
cd "$(dirname "$0")/.."
SCENARIO=${SCENARIO:-corridor}
SEED=${SEED:-1}
OUT=${OUT:-out/demo-$SCENARIO-$SEED}
CONFIG=${CONFIG:-config/mid360.yaml}
DOMAIN=${DOMAIN:-7}
BIN=./build/bin
mkdir -p "$OUT"
echo "== simulating $SCENARIO (seed $SEED) into $OUT/sim"
$BIN/fuse-sim --scenario "$SCENARIO" --seed "$SEED" --out "$OUT/sim" ${DURATION:+--duration "$DURATION"}

echo "== running the four FUSE services (lockstep replay, DDS domain $DOMAIN); logs in $OUT/system/logs"
rm -rf "$OUT/system"
$BIN/fuse-launch --config "$CONFIG" --input "$OUT/sim/recording.mcap" --mode lockstep --out "$OUT/system" \
  --domain "$DOMAIN" &
LAUNCH=$!
trap 'kill $LAUNCH 2>/dev/null || true' EXIT
# A planner's view while the system runs: the latest state, twice, a few seconds apart.
for wait in 5 10 10; do
  sleep "$wait"
  kill -0 $LAUNCH 2>/dev/null || break
  echo "-- fuse-query --latest (while replaying):"
  $BIN/fuse-query --latest --set transport.domain_id="$DOMAIN" --deadline-ms 5000 || true
done
wait $LAUNCH
trap - EXIT
echo "== trajectory error of the multi-process run against the simulator's ground truth"
$BIN/fuse-eval --gt "$OUT/sim/groundtruth.tum" --est "$OUT/system/trajectory.tum" --delta 10 | tee "$OUT/eval-system.txt"

echo "== the same recording through the single-process fuse-run"
$BIN/fuse-run --config "$CONFIG" --input "$OUT/sim/recording.mcap" --out "$OUT/run" --log-level warn > "$OUT/run.txt" 2> "$OUT/run.log"
$BIN/fuse-eval --gt "$OUT/sim/groundtruth.tum" --est "$OUT/run/trajectory.tum" --delta 10 > "$OUT/eval-run.txt"
# Largest position difference between the two trajectories at common scan times.
MAXDIFF=$(awk 'NR==FNR { if ($1 !~ /^#/) p[sprintf("%.6f", $1)] = $2 " " $3 " " $4; next }
  $1 !~ /^#/ { k = sprintf("%.6f", $1); if (k in p) { split(p[k], a, " ");
    d = sqrt(($2-a[1])^2 + ($3-a[2])^2 + ($4-a[3])^2); if (d > m) m = d; n++ } }
  END { printf "%.6f m over %d scans", m, n }' "$OUT/run/trajectory.tum" "$OUT/system/trajectory.tum")

get() { grep "^$1:" "$2" | head -1 | awk '{print $2}'; }
echo "== summary ($SCENARIO, seed $SEED)"
echo "path length:                     $(get path_length_m "$OUT/eval-system.txt") m"
echo "four services: loop end-to-end error $(get end_to_end_m "$OUT/eval-system.txt") m, ATE RMSE $(get ate_rmse_m "$OUT/eval-system.txt") m"
echo "fuse-run:      loop end-to-end error $(get end_to_end_m "$OUT/eval-run.txt") m, ATE RMSE $(get ate_rmse_m "$OUT/eval-run.txt") m"
echo "largest difference services vs fuse-run: $MAXDIFF"
echo "per-scan time (fuse-run): mean $(get scan_time_mean_ms "$OUT/run.txt") ms, P95 $(get scan_time_p95_ms "$OUT/run.txt") ms, max $(get scan_time_max_ms "$OUT/run.txt") ms"
# Figures of the services' run against the ground truth, with fuse-run's per-scan time.
$BIN/fuse-eval --gt "$OUT/sim/groundtruth.tum" --est "$OUT/system/trajectory.tum" --delta 10 \
  --plot "$OUT/plots" --timing "$OUT/run/timing.csv" > /dev/null 2> "$OUT/plots.log"
echo "plots (SVG: top and side view, APE and RPE over distance, per-scan time): $OUT/plots/"
