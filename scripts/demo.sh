#!/usr/bin/env bash
# The main job on built-in simulated data: simulate the 418 m corridor loop (seed 1), run FUSE
# on it in one process, and print the trajectory error and the per-scan timing.
set -euo pipefail
cd "$(dirname "$0")/.."
SCENARIO=${SCENARIO:-corridor}
SEED=${SEED:-1}
OUT=${OUT:-out/demo-$SCENARIO-$SEED}
CONFIG=${CONFIG:-config/mid360.yaml}
mkdir -p "$OUT"
echo "== simulating $SCENARIO (seed $SEED) into $OUT/sim"
./build/bin/fuse-sim --scenario "$SCENARIO" --seed "$SEED" --out "$OUT/sim" ${DURATION:+--duration "$DURATION"}
echo "== running FUSE ($CONFIG)"
./build/bin/fuse-run --config "$CONFIG" --input "$OUT/sim/recording.mcap" --out "$OUT/run" --log-level warn | tee "$OUT/run.txt"
echo "== trajectory error against the simulator's ground truth"
./build/bin/fuse-eval --gt "$OUT/sim/groundtruth.tum" --est "$OUT/run/trajectory.tum" --delta 10 | tee "$OUT/eval.txt"
get() { grep "^$1:" "$2" | head -1 | awk '{print $2}'; }
echo "== summary ($SCENARIO, seed $SEED)"
echo "path length:            $(get path_length_m "$OUT/eval.txt") m"
echo "end-to-end (loop) error: $(get end_to_end_m "$OUT/eval.txt") m (ground truth: $(get gt_end_to_end_m "$OUT/eval.txt") m)"
echo "ATE RMSE:               $(get ate_rmse_m "$OUT/eval.txt") m"
echo "per-scan time:          mean $(get scan_time_mean_ms "$OUT/run.txt") ms, P95 $(get scan_time_p95_ms "$OUT/run.txt") ms, max $(get scan_time_max_ms "$OUT/run.txt") ms"
