#!/usr/bin/env bash
# Localization on a saved map over the full corridor loop (issue 4, functional role): mapping on
# one traversal saves its map; a second traversal of the same world (same --world-seed, another
# --seed) is run twice — mapping from scratch, and localization on the saved map (frozen) — and
# both are scored against the truth. Prints ATE / end-to-end / drift of each, and whether the
# map file is byte-identical after the localization run.
#
#   bench/localization.sh [MAP_SEED] [SECOND_SEED] [WORLD_SEED]   (defaults 1 2 1)
#   environment: FUSE_BIN (default build/bin), CONFIG (default config/mid360.yaml), OUT (out/bench)
set -euo pipefail
cd "$(dirname "$0")/.."
MAP_SEED=${1:-1}; SECOND_SEED=${2:-2}; WORLD_SEED=${3:-1}
BIN=${FUSE_BIN:-build/bin}; CONFIG=${CONFIG:-config/mid360.yaml}; OUT=${OUT:-out/bench}
mkdir -p "$OUT"
sim() {  # sim DIR SEED WORLD
  [ -f "$1/recording.mcap" ] || "$BIN/fuse-sim" --scenario corridor --seed "$2" --world-seed "$3" --out "$1" > "$1.log" 2>&1
}
first="$OUT/loc-sim-$MAP_SEED-w$WORLD_SEED"; second="$OUT/loc-sim-$SECOND_SEED-w$WORLD_SEED"
sim "$first" "$MAP_SEED" "$WORLD_SEED"
sim "$second" "$SECOND_SEED" "$WORLD_SEED"
map="$OUT/loc-map-$MAP_SEED-w$WORLD_SEED.pb"
rm -f "$map"
run() {  # run NAME INPUT ARGS...
  local name=$1 input=$2; shift 2
  "$BIN/fuse-run" --config "$CONFIG" --input "$input/recording.mcap" --out "$OUT/$name" --log-level off "$@" > "$OUT/$name.txt"
  "$BIN/fuse-eval" --gt "$input/groundtruth.tum" --est "$OUT/$name/trajectory.tum" > "$OUT/$name.eval"
}
get() { awk -v k="$1:" '$1==k {print $2; exit}' "$2"; }
report() {  # report LABEL NAME
  printf "%s: ATE %.3f m, end-to-end %.3f m, drift x/y/z %s / %s / %s m, scan ms mean/P95/max %s / %s / %s\n" "$1" \
    "$(get ate_rmse_m "$OUT/$2.eval")" "$(get end_to_end_m "$OUT/$2.eval")" "$(get drift_x_m "$OUT/$2.eval")" \
    "$(get drift_y_m "$OUT/$2.eval")" "$(get drift_z_m "$OUT/$2.eval")" "$(get scan_time_mean_ms "$OUT/$2.txt")" \
    "$(get scan_time_p95_ms "$OUT/$2.txt")" "$(get scan_time_max_ms "$OUT/$2.txt")"
}
run loc-mapping-first "$first" --save-map "$map"
before=$(sha256sum "$map" | cut -d' ' -f1)
run loc-mapping-second "$second"
run loc-localization-second "$second" --load-map "$map" --set estimator.map.mode=localization \
  --set estimator.global_localization.enabled=false  # both traversals start at the same place: the map's origin
after=$(sha256sum "$map" | cut -d' ' -f1)
echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo "world seed $WORLD_SEED; map from seed $MAP_SEED; second traversal seed $SECOND_SEED"
report "mapping, first traversal (the map)" loc-mapping-first
report "mapping, second traversal" loc-mapping-second
report "localization on the map, second traversal" loc-localization-second
echo "map file byte-identical after localization: $([ "$before" = "$after" ] && echo yes || echo NO)"
