#!/usr/bin/env bash
# Chaos soak of the deployed system (docs/chaos.md): fuse-launch --restart replays a recording in
# real time while fuse-bench-chaos SIGKILLs random services (one, or two at once) every 3-8 s,
# fills the map disk and makes it read-only for a while, and a planner client stays connected.
#
#   bench/chaos.sh [long|mid|short]      long (default): 2 laps of the corridor (630 s, ~110 kills)
#                                    mid: 180 s, ~30 kills (the issue's corridor replay)
#                                    short: 90 s, ~15 kills (what CI runs, test/system)
#   environment: FUSE_BIN (binaries, default build/bin), CONFIG (default config/mid360.yaml),
#                SEED (kill schedule, default 1), DOMAIN (default 36; the run without kills uses
#                DOMAIN + 1), OUT (work directory, default out/chaos-<mode>), REPORT (Markdown
#                file the figures are appended to; default OUT/report.md), MAP_TMPFS_MB (size of
#                the map disk, a tmpfs: needs root; 0 skips the disk faults), CHECK=1 (exit 1
#                unless the figures meet the issue's bounds: poses >= 95 % of scans, no
#                acknowledged observation missing, ATE <= 1.5x the run without kills + 1 cm,
#                fuse-launch non-zero when something was lost and not failed, the whole
#                recording replayed)
set -euo pipefail
cd "$(dirname "$0")/.."
MODE=${1:-long}
BIN=${FUSE_BIN:-build/bin}
CONFIG=${CONFIG:-config/mid360.yaml}
SEED=${SEED:-1}
DOMAIN=${DOMAIN:-36}
OUT=${OUT:-out/chaos-$MODE}
MAP_TMPFS_MB=${MAP_TMPFS_MB:-64}
for b in fuse-sim fuse-launch fuse-map fuse-state fuse-update fuse-ingest fuse-bench-chaos; do
  [ -x "$BIN/$b" ] || { echo "missing $BIN/$b (build it, or set FUSE_BIN)" >&2; exit 2; }
done

case "$MODE" in
  long)  SIM=(--scenario corridor --seed 5 --laps 2); DISK_FULL=200:30; READ_ONLY=420:30 ;;
  mid)   SIM=(--scenario corridor --seed 3 --duration 180); DISK_FULL=50:15; READ_ONLY=110:15 ;;
  short) SIM=(--scenario corridor --seed 2 --duration 90); DISK_FULL=25:10; READ_ONLY=55:10 ;;
  *) echo "usage: bench/chaos.sh [long|mid|short]" >&2; exit 2 ;;
esac
DATA=out/chaos-data/${MODE}
if [ ! -f "$DATA/recording.mcap" ]; then
  mkdir -p "$DATA"
  "$BIN/fuse-sim" "${SIM[@]}" --out "$DATA" > "$DATA/sim.log" 2>&1
fi
mkdir -p "$OUT"
REPORT=${REPORT:-$OUT/report.md}
ARGS=(--config "$CONFIG" --input "$DATA/recording.mcap" --gt "$DATA/groundtruth.tum" --out "$OUT"
      --domain "$DOMAIN" --seed "$SEED" --kill-every 3:8 --double-fraction 0.3 --query-hz 20
      --bin-dir "$BIN" --report "$REPORT" --label "chaos $MODE, seed $SEED, $(date -u +%Y-%m-%d)")
if [ "$MAP_TMPFS_MB" -gt 0 ]; then
  ARGS+=(--map-tmpfs-mb "$MAP_TMPFS_MB" --disk-full-at "$DISK_FULL" --read-only-at "$READ_ONLY")
fi
[ "${CHECK:-0}" = 1 ] && ARGS+=(--check)
exec "$BIN/fuse-bench-chaos" "${ARGS[@]}"
