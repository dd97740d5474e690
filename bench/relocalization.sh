#!/usr/bin/env bash
# Global localization (issue 17): per scene, a map from one walk; then WALKS further walks of the
# same world (--world-seed) that start at rest at random places along the mapped path (their own
# --seed: motion and noise), localized on the saved map by fuse-run --load-map without an initial
# pose. Per walk: localized or not, data seconds until the location was confirmed, the searches'
# CPU seconds (their own thread's wall time: one core), and the error of its map-frame trajectory
# against its truth brought into the map frame by the mapping walk's SE(3) alignment (fuse-eval
# --frame-of: the walk itself is not aligned). A location whose largest position error exceeds
# 0.5 m is a false localization.
#
# Kidnapped (lost and found): KIDNAPS further walks of KIDNAP_SECONDS whose data from 15 s to 45 s
# are cut out (IMU and scans: the sensor reappears further along, as if carried). Per walk: whether
# the run located itself again after the cut (a search started by the lost track), data seconds
# from the end of the cut to that location, and the unaligned error of the poses after it.
#
#   bench/relocalization.sh [WALKS] [SCENES...]   (defaults: 20; corridor campus stairs)
#   environment: FUSE_BIN (default build/bin), CONFIG (config/mid360.yaml), OUT (out/bench/reloc),
#                MAP_SECONDS (150), WALK_SECONDS (30), SEED (1: picks the starts),
#                KIDNAPS (5), KIDNAP_SECONDS (75)
set -euo pipefail
cd "$(dirname "$0")/.."
WALKS=${1:-20}; shift || true
SCENES=${*:-corridor campus stairs}
BIN=${FUSE_BIN:-build/bin}; CONFIG=${CONFIG:-config/mid360.yaml}; OUT=${OUT:-out/bench/reloc}
MAP_SECONDS=${MAP_SECONDS:-150}; WALK_SECONDS=${WALK_SECONDS:-30}; SEED=${SEED:-1}
KIDNAPS=${KIDNAPS:-5}; KIDNAP_SECONDS=${KIDNAP_SECONDS:-75}
CUT_FROM=15; CUT_TO=45
WORLD=3
mkdir -p "$OUT"
get() { awk -v k="$1:" '$1==k {print $2; exit}' "$2"; }
median_max() {  # prints "median / max" of the numbers on stdin, or "-" when there are none
  sort -g | awk '{v[NR]=$1} END {if (NR==0) {print "-"; exit} m=(NR%2)?v[(NR+1)/2]:(v[NR/2]+v[NR/2+1])/2; printf "%.1f / %.1f", m, v[NR]}'
}
median_max3() {
  sort -g | awk '{v[NR]=$1} END {if (NR==0) {print "-"; exit} m=(NR%2)?v[(NR+1)/2]:(v[NR/2]+v[NR/2+1])/2; printf "%.3f / %.3f", m, v[NR]}'
}
# A start along the mapped part of the path that leaves room for a walk of W s (about 1.3 m/s on
# foot, more on the campus: the margin is the walk's length at 3 m/s, capped at half the map).
start_for() {  # INDEX WALK_SECONDS MAPPED_LENGTH
  awk -v s="$SEED" -v i="$1" -v L="$3" -v w="$2" 'BEGIN {srand(s * 1000 + i);
    m = w * 3; if (m > L / 2) m = L / 2; printf "%.1f", rand() * (L - m)}'
}
localize() {  # WALK_DIR INPUT MAP: fuse-run on the saved map, prints its exit code
  set +e
  "$BIN/fuse-run" --config "$CONFIG" --input "$2" --out "$1/run" --log-level warn --load-map "$3" \
    --set estimator.map.mode=localization --set estimator.global_localization.blocking=true \
    > "$1/run.txt" 2> "$1/run.log"
  local rc=$?
  set -e
  echo "$rc"
}
echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ); $WALKS walks per scene of $WALK_SECONDS s; maps from $MAP_SECONDS s;" \
  "$KIDNAPS kidnapped walks of $KIDNAP_SECONDS s, data from $CUT_FROM to $CUT_TO s cut out"
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
  ok=0; false_loc=0; data_s=""; cpu_s=""; errors=""
  for i in $(seq 1 "$WALKS"); do
    start=$(start_for "$i" "$WALK_SECONDS" "$mapped")
    walk="$OUT/$scene-walk$i"
    [ -f "$walk/recording.mcap" ] || "$BIN/fuse-sim" --scenario "$scene" --seed $((100 + i)) --world-seed "$WORLD" \
      --start-at "$start" --duration "$WALK_SECONDS" --out "$walk" > "$walk.log" 2>&1
    rc=$(localize "$walk" "$walk/recording.mcap" "$map_dir/map.snap")
    verdict=$(awk '$1=="localization:" {print $2 == "localized" ? "localized" : "not"; exit}' "$walk/run.txt")
    cpu_s="$cpu_s $(get localization_search_s "$walk/run.txt")"
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
  printf "%s: localized %d of %d, false %d; data s to localize median / max %s; search CPU s per walk median / max %s; unaligned error rmse median / max %s m (map walk ATE %s m)\n" \
    "$scene" "$ok" "$WALKS" "$false_loc" "$(echo $data_s | tr ' ' '\n' | grep . | median_max)" \
    "$(echo $cpu_s | tr ' ' '\n' | grep . | median_max)" "$(echo $errors | tr ' ' '\n' | grep . | median_max3)" "$map_ate"

  k_ok=0; k_false=0; k_data=""; k_errors=""
  for i in $(seq 1 "$KIDNAPS"); do
    start=$(start_for $((500 + i)) "$KIDNAP_SECONDS" "$mapped")
    walk="$OUT/$scene-kidnap$i"
    if [ ! -f "$walk/cut/scans.csv" ]; then
      "$BIN/fuse-sim" --scenario "$scene" --seed $((300 + i)) --world-seed "$WORLD" --start-at "$start" \
        --duration "$KIDNAP_SECONDS" --format seqdir --out "$walk/seq" > "$walk.log" 2>&1
      # The cut: IMU rows (ns) and scans (by their start) from CUT_FROM to CUT_TO s after the first
      # sample; raw/ and the calibration are shared.
      mkdir -p "$walk/cut"
      t0=$(awk -F, 'NR==2 {printf "%.9f", $1 * 1e-9; exit}' "$walk/seq/imu.csv")
      awk -F, -v a="$t0" -v f="$CUT_FROM" -v t="$CUT_TO" 'NR==1 || $1 * 1e-9 < a + f || $1 * 1e-9 >= a + t' \
        "$walk/seq/imu.csv" > "$walk/cut/imu.csv"
      awk -F, -v a="$t0" -v f="$CUT_FROM" -v t="$CUT_TO" 'NR==1 || $2 < a + f || $2 >= a + t' \
        "$walk/seq/scans.csv" > "$walk/cut/scans.csv"
      for f in calib.yaml groundtruth.tum scenario.yaml; do [ -f "$walk/seq/$f" ] && cp "$walk/seq/$f" "$walk/cut/"; done
      ln -sfn "$(cd "$walk/seq" && pwd)/raw" "$walk/cut/raw"
    fi
    t0=$(awk -F, 'NR==2 {printf "%.9f", $1 * 1e-9; exit}' "$walk/seq/imu.csv")
    cut_end=$(awk -v a="$t0" -v t="$CUT_TO" 'BEGIN {printf "%.3f", a + t}')
    rc=$(localize "$walk" "$walk/cut" "$map_dir/map.snap")
    lost_search=$(get estimator_lost_search "$walk/run.txt"); lost_search=${lost_search:-0}
    verdict=$(awk '$1=="localization:" {print $2 == "localized" ? "localized" : "not"; exit}' "$walk/run.txt")
    loc_t=$(get localization_t "$walk/run.txt"); loc_t=${loc_t:-0}
    line="$scene kidnap $i: start $start m, rc $rc, lost searches $lost_search"
    if [ "$verdict" = localized ] && awk -v l="$loc_t" -v c="$cut_end" 'BEGIN {exit !(l > c)}'; then
      # The poses from the location after the cut on, unaligned in the map frame.
      awk -v l="$loc_t" '/^#/ || $1 >= l' "$walk/run/trajectory.tum" > "$walk/run/after.tum"
      "$BIN/fuse-eval" --gt "$walk/seq/groundtruth.tum" --est "$walk/run/after.tum" \
        --frame-of "$map_dir/groundtruth.tum" "$map_dir/run/trajectory.tum" > "$walk/eval.txt"
      err_max=$(get ate_max_m "$walk/eval.txt"); err_rmse=$(get ate_rmse_m "$walk/eval.txt")
      after=$(awk -v l="$loc_t" -v c="$cut_end" 'BEGIN {printf "%.1f", l - c}')
      line="$line, located again $after s after the cut, unaligned error rmse $err_rmse m, max $err_max m"
      if awk -v e="$err_max" 'BEGIN {exit !(e > 0.5)}'; then
        k_false=$((k_false + 1)); line="$line: FALSE LOCALIZATION"
      else
        k_ok=$((k_ok + 1)); k_data="$k_data $after"; k_errors="$k_errors $err_rmse"
      fi
    else
      line="$line, not located again after the cut ($(awk '$1=="localization:" {$1=""; print; exit}' "$walk/run.txt"))"
    fi
    echo "$line"
  done
  if [ "$KIDNAPS" -gt 0 ]; then
    printf "%s kidnapped: located again %d of %d, false %d; data s from the cut's end median / max %s; unaligned error rmse median / max %s m\n" \
      "$scene" "$k_ok" "$KIDNAPS" "$k_false" "$(echo $k_data | tr ' ' '\n' | grep . | median_max)" \
      "$(echo $k_errors | tr ' ' '\n' | grep . | median_max3)"
  fi
done
