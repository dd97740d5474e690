#!/usr/bin/env bash
# Global localization (issue 17): per scene, a map from one walk; then WALKS further walks of the
# same world (--world-seed) that start at rest at random places along the mapped path (their own
# --seed: motion and noise), localized on the saved map by fuse-run --load-map without an initial
# pose. Per walk: localized or not, data seconds until the location was confirmed, the searches'
# wall time, and the error of its map-frame trajectory against its truth brought into the map
# frame by the mapping walk's SE(3) alignment (fuse-eval --frame-of: the walk itself is not
# aligned). A location whose largest position error exceeds 0.5 m is a false localization.
#
#   bench/relocalization.sh [WALKS] [SCENES...]   (defaults: 5; corridor campus stairs)
#   environment: FUSE_BIN (default build/bin), CONFIG (config/mid360.yaml), OUT (out/bench/reloc),
#                MAP_SECONDS (150), WALK_SECONDS (30), SEED (1: picks the starts)
set -euo pipefail
cd "$(dirname "$0")/.."
WALKS=${1:-5}; shift || true
SCENES=${*:-corridor campus stairs}
BIN=${FUSE_BIN:-build/bin}; CONFIG=${CONFIG:-config/mid360.yaml}; OUT=${OUT:-out/bench/reloc}
MAP_SECONDS=${MAP_SECONDS:-150}; WALK_SECONDS=${WALK_SECONDS:-30}; SEED=${SEED:-1}
WORLD=3
mkdir -p "$OUT"
get() { awk -v k="$1:" '$1==k {print $2; exit}' "$2"; }
median_max() {  # prints "median / max" of the numbers on stdin, or "-" when there are none
  sort -g | awk '{v[NR]=$1} END {if (NR==0) {print "-"; exit} m=(NR%2)?v[(NR+1)/2]:(v[NR/2]+v[NR/2+1])/2; printf "%.1f / %.1f", m, v[NR]}'
}
echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ); $WALKS walks per scene of $WALK_SECONDS s; maps from $MAP_SECONDS s"
for scene in $SCENES; do
  map_dir="$OUT/$scene-map"
  [ -f "$map_dir/recording.mcap" ] || "$BIN/fuse-sim" --scenario "$scene" --seed "$WORLD" --duration "$MAP_SECONDS" \
    --out "$map_dir" > "$map_dir.log" 2>&1
  if [ ! -f "$map_dir/map.snap" ]; then
    "$BIN/fuse-run" --config "$CONFIG" --input "$map_dir/recording.mcap" --out "$map_dir/run" --log-level off \
      --save-map "$map_dir/map.snap" > "$map_dir/run.txt"
  fi
  mapped=$(awk '$1=="travelled_length_m:" {print $2; exit}' "$map_dir/scenario.yaml")
  map_ate=$("$BIN/fuse-eval" --gt "$map_dir/groundtruth.tum" --est "$map_dir/run/trajectory.tum" | awk '$1=="ate_rmse_m:" {print $2}')
  ok=0; false_loc=0; data_s=""; search_s=""; errors=""
  for i in $(seq 1 "$WALKS"); do
    # A start along the mapped part of the path that leaves room for the walk (about 1.3 m/s on
    # foot, more on the campus: the margin is the walk's length at 3 m/s, capped at half the map).
    start=$(awk -v s="$SEED" -v i="$i" -v L="$mapped" -v w="$WALK_SECONDS" 'BEGIN {srand(s * 1000 + i);
      m = w * 3; if (m > L / 2) m = L / 2; printf "%.1f", rand() * (L - m)}')
    walk="$OUT/$scene-walk$i"
    [ -f "$walk/recording.mcap" ] || "$BIN/fuse-sim" --scenario "$scene" --seed $((100 + i)) --world-seed "$WORLD" \
      --start-at "$start" --duration "$WALK_SECONDS" --out "$walk" > "$walk.log" 2>&1
    set +e
    "$BIN/fuse-run" --config "$CONFIG" --input "$walk/recording.mcap" --out "$walk/run" --log-level warn \
      --load-map "$map_dir/map.snap" --set estimator.map.mode=localization \
      --set estimator.global_localization.blocking=true > "$walk/run.txt" 2> "$walk/run.log"
    rc=$?
    set -e
    verdict=$(awk '$1=="localization:" {print $2 == "localized" ? "localized" : "not"; exit}' "$walk/run.txt")
    search_s="$search_s $(get localization_search_s "$walk/run.txt")"
    line="$scene walk $i: start $start m, rc $rc, $verdict"
    if [ "$verdict" = localized ]; then
      "$BIN/fuse-eval" --gt "$walk/groundtruth.tum" --est "$walk/run/trajectory.tum" \
        --frame-of "$map_dir/groundtruth.tum" "$map_dir/run/trajectory.tum" > "$walk/eval.txt"
      err_max=$(get ate_max_m "$walk/eval.txt"); err_rmse=$(get ate_rmse_m "$walk/eval.txt")
      after=$(get localization_after_s "$walk/run.txt")
      line="$line after $after s of data, unaligned error rmse $err_rmse m, max $err_max m"
      if awk -v e="$err_max" 'BEGIN {exit !(e > 0.5)}'; then
        false_loc=$((false_loc + 1)); line="$line: FALSE LOCALIZATION"
      else
        ok=$((ok + 1)); data_s="$data_s $after"; errors="$errors $err_rmse"
      fi
    fi
    echo "$line"
  done
  printf "%s: localized %d of %d, false %d; data s to localize median / max %s; search wall s per walk median / max %s; unaligned error rmse median / max %s m (map walk ATE %s m)\n" \
    "$scene" "$ok" "$WALKS" "$false_loc" "$(echo $data_s | tr ' ' '\n' | grep . | median_max)" \
    "$(echo $search_s | tr ' ' '\n' | grep . | median_max)" "$(echo $errors | tr ' ' '\n' | grep . | awk '{printf "%.3f\n", $1}' | sort -g | awk '{v[NR]=$1} END {if (NR==0) {print "-"; exit} printf "%.3f / %.3f", v[int((NR+1)/2)], v[NR]}')" "$map_ate"
done
