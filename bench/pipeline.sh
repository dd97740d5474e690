#!/usr/bin/env bash
# Performance of the multi-process pipeline against the single-process runner (docs/performance.md).
#
#   bench/pipeline.sh [DURATION_S] [REALTIME_REPEATS] [LOCKSTEP_REPEATS] [RUN_REPEATS]
#                     (defaults 60 1 3 3)
#   environment: FUSE_BIN (binaries, default build-bench/bin), CONFIG (default config/mid360.yaml),
#                VENDOR (fastdds | cyclonedds, default fastdds), KEEP=1 keeps the work directory,
#                BENCH_ARGS (extra fuse-bench-pipeline options for the real-time runs, e.g.
#                --observe-scan for the scan's own hop, which adds a second scan reader),
#                SETS (space-separated key=value config overrides for every run, e.g.
#                "transport.shared_memory=true"), SECURE=1 (DDS Security on: a keystore made with
#                fuse-keystore in the work directory), UPDATE_NICE / STATE_NICE / CLIENT_NICE (niceness
#                of fuse-update, fuse-state and the bench client in the real-time runs, default 0;
#                negative values need root), STATE_RT / CLIENT_RT (SCHED_FIFO priority 1-99 for
#                fuse-state and the bench client instead of their niceness, as deploy/ can with
#                CPUSchedulingPolicy=fifo; needs root or CAP_SYS_NICE), VIZ (off | connected | paused |
#                killed, default off: fuse-viz runs beside the services in the real-time runs with a
#                Foxglove client subscribed to every channel (VIZ_CLIENT, default
#                build/test/viz/client/viz_client.mjs, its npm packages installed by the tests), which
#                stays connected, is stopped with SIGSTOP from 20 s to 30 s, or is SIGKILLed at 20 s;
#                fuse-viz's RSS is printed at 5 s and at the end), VIZ_CLIENT_NICE (the viewer client
#                at that niceness; unset, it runs in the idle scheduling class, SCHED_IDLE, which
#                stands in for a viewer on another computer: on a vehicle the operator's Foxglove
#                does not share the estimator's cores)
#
# 1. Simulates a corridor recording of DURATION_S (cached under out/bench/).
# 2. fuse-run RUN_REPEATS times: per-scan time (mean / p95) and wall time, scans/s.
# 3. The four services in real time (rate 1) with fuse-bench-pipeline attached, REALTIME_REPEATS
#    times: query RPC round trip at 1 kHz, IMU -> odometry and scan -> correction latency.
# 4. fuse-launch --mode lockstep LOCKSTEP_REPEATS times, with fuse-bench-pipeline timing the
#    corrections: scans/s and wall time against fuse-run's, and the ratio.
# Every figure printed is the median over the repeats. Domain ids 90..99 (one per run, cycling).
# The machine is shared and noisy: check `uptime` first and read figures as medians.
set -euo pipefail
cd "$(dirname "$0")/.."
DURATION=${1:-60}
RT_REPEATS=${2:-1}
LS_REPEATS=${3:-3}
RUN_REPEATS=${4:-3}
BIN=${FUSE_BIN:-build-bench/bin}
CONFIG=${CONFIG:-config/mid360.yaml}
VENDOR=${VENDOR:-fastdds}
LEAD_S=8  # start-wall lead: the services start, discover each other and sync before the first sample

[ "$RUN_REPEATS" -ge 1 ] || { echo "RUN_REPEATS must be at least 1 (the scan count comes from fuse-run)" >&2; exit 2; }
for b in fuse-sim fuse-run fuse-map fuse-state fuse-update fuse-ingest fuse-launch fuse-bench-pipeline; do
  [ -x "$BIN/$b" ] || { echo "missing $BIN/$b (build it, or set FUSE_BIN)" >&2; exit 2; }
done

SIM_DIR=out/bench/sim-corridor-mid360-1-${DURATION}s
REC=$SIM_DIR/recording.mcap
if [ ! -f "$REC" ]; then
  mkdir -p "$SIM_DIR"
  "$BIN/fuse-sim" --scenario corridor --seed 1 --duration "$DURATION" --out "$SIM_DIR" > "$SIM_DIR.log" 2>&1
fi

WORK=$(mktemp -d)
PIDS=()
cleanup() {
  for p in "${PIDS[@]:-}"; do [ -n "$p" ] && kill -TERM "$p" 2> /dev/null || true; done
  wait 2> /dev/null || true
  if [ "${KEEP:-0}" = 1 ]; then echo "work directory: $WORK"; else rm -rf "$WORK"; fi
}
trap cleanup EXIT

now() { date +%s.%N; }
# prio RT NICE: the command prefix that runs a process at SCHED_FIFO priority RT if RT is set,
# else at niceness NICE
prio() { if [ -n "$1" ]; then echo chrt -f "$1"; else echo nice -n "${2:-0}"; fi; }
median() { sort -g | awk '{a[NR]=$1} END{if (NR==0) {print "nan"} else {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}}'; }
# value KEY FILE: the value of "KEY: value" in FILE
value() { awk -v k="$1:" '$1==k {print $2; exit}' "$2"; }
DOMAIN_SLOT=0
next_domain() { DOMAIN=$((90 + DOMAIN_SLOT % 10)); DOMAIN_SLOT=$((DOMAIN_SLOT + 1)); }
COMMON=(--config "$CONFIG" --set "transport.vendor=$VENDOR")
SET_ARGS=()
for kv in ${SETS:-}; do SET_ARGS+=(--set "$kv"); done
# SECURE=1: DDS Security on, with a keystore of its own (the bench's two participants join as a
# recorder and a planner).
if [ "${SECURE:-0}" = 1 ]; then
  KEYSTORE="$WORK/keystore"
  rm -rf "$KEYSTORE"
  "$BIN/fuse-keystore" init "$KEYSTORE"
  "$BIN/fuse-keystore" add-identity "$KEYSTORE" fuse-bench-pipeline --role recorder
  "$BIN/fuse-keystore" add-identity "$KEYSTORE" fuse-bench-pipeline-query --role planner
  SET_ARGS+=(--set transport.security.enabled=true --set "transport.security.keystore=$KEYSTORE")
fi
COMMON+=("${SET_ARGS[@]}")

echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo "load_before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "recording: $REC"
echo "vendor: $VENDOR"
echo "overrides: ${SETS:-none}"
echo "security: ${SECURE:-0}"
echo "update_nice: ${UPDATE_NICE:-0}"
echo "state_nice: ${STATE_NICE:-0}"
echo "client_nice: ${CLIENT_NICE:-0}"
echo "state_rt: ${STATE_RT:-none}"
echo "client_rt: ${CLIENT_RT:-none}"
echo "viz: ${VIZ:-off}"
if [ -n "${VIZ_CLIENT_NICE:-}" ]; then echo "viz_client_priority: nice $VIZ_CLIENT_NICE"; else echo "viz_client_priority: idle"; fi
VIZ_CLIENT=${VIZ_CLIENT:-build/test/viz/client/viz_client.mjs}
rss_kb() { awk '/^VmRSS:/ {print $2}' "/proc/$1/status" 2> /dev/null || echo nan; }
# CPU seconds (user + system) a live process used so far.
cpu_s() { awk -v hz="$(getconf CLK_TCK)" '{ printf "%.2f\n", ($14 + $15) / hz }' "/proc/$1/stat" 2> /dev/null || echo nan; }

# ---- 2. single process -----------------------------------------------------------------------
for i in $(seq "$RUN_REPEATS"); do
  a=$(now)
  "$BIN/fuse-run" --config "$CONFIG" "${SET_ARGS[@]}" --input "$REC" --out "$WORK/run$i" --log-level off > "$WORK/run$i.txt"
  b=$(now)
  echo "$a $b" | awk '{print $2-$1}' > "$WORK/run$i.wall"
done
SCANS=$(value scans "$WORK/run1.txt")
RUN_WALL=$(cat "$WORK"/run*.wall | median)
echo "run_repeats: $RUN_REPEATS"
echo "run_scans: $SCANS"
echo "run_scan_time_mean_ms: $(for f in "$WORK"/run[0-9]*.txt; do value scan_time_mean_ms "$f"; done | median)"
echo "run_scan_time_p95_ms: $(for f in "$WORK"/run[0-9]*.txt; do value scan_time_p95_ms "$f"; done | median)"
echo "run_wall_s: $RUN_WALL"
RUN_RATE=$(awk -v n="$SCANS" -v w="$RUN_WALL" 'BEGIN{printf "%.2f", n/w}')
echo "run_scans_per_s: $RUN_RATE"

# The CPU part of a scan's way ingest -> update (conversions and CDR, no transport).
"$BIN/fuse-bench-pipeline" --codec --input "$REC" > "$WORK/codec.txt"
cat "$WORK/codec.txt"

# ---- 3. real time with the bench attached ----------------------------------------------------
stop_services() {
  for p in "$@"; do kill -TERM "$p" 2> /dev/null || true; done
  for p in "$@"; do wait "$p" 2> /dev/null || true; done
  PIDS=()
}
for i in $(seq "$RT_REPEATS"); do
  next_domain
  d="$WORK/rt$i"
  mkdir -p "$d/logs"
  S=("${COMMON[@]}" --set "transport.domain_id=$DOMAIN")
  "$BIN/fuse-map" "${S[@]}" --map-dir "$d/map" > "$d/logs/fuse-map.log" 2>&1 &
  m=$!
  $(prio "${STATE_RT:-}" "${STATE_NICE:-0}") "$BIN/fuse-state" "${S[@]}" --trajectory "$d/trajectory.tum" --calibration-from "$REC" > "$d/logs/fuse-state.log" 2>&1 &
  s=$!
  nice -n "${UPDATE_NICE:-0}" "$BIN/fuse-update" "${S[@]}" > "$d/logs/fuse-update.log" 2>&1 &
  u=$!
  PIDS=("$m" "$s" "$u")
  if [ "${VIZ:-off}" != off ]; then
    "$BIN/fuse-viz" "${S[@]}" --set viz.port=0 > "$d/logs/fuse-viz.log" 2>&1 &
    v=$!
    PIDS+=("$v")
    for _ in $(seq 100); do grep -q "on ws://" "$d/logs/fuse-viz.log" && break; sleep 0.1; done
    url=$(grep -o "ws://[0-9.]*:[0-9]*" "$d/logs/fuse-viz.log" | head -1)
    if [ -n "${VIZ_CLIENT_NICE:-}" ]; then viz_prio=(nice -n "$VIZ_CLIENT_NICE"); else viz_prio=(chrt -i 0); fi
    "${viz_prio[@]}" node "$VIZ_CLIENT" "$url" "$d/viz-client.jsonl" > "$d/logs/viz-client.log" 2>&1 &
    vc=$!
    PIDS+=("$vc")
    ( sleep "$LEAD_S"; sleep 5; rss_kb "$v" > "$d/viz_rss_start"
      case "$VIZ" in
        paused) sleep 15; kill -STOP "$vc"; sleep 10; kill -CONT "$vc" ;;
        killed) sleep 15; kill -KILL "$vc" ;;
      esac ) &
  fi
  START=$(awk -v t="$(now)" -v l="$LEAD_S" 'BEGIN{printf "%.6f", t+l}')
  $(prio "${CLIENT_RT:-}" "${CLIENT_NICE:-0}") "$BIN/fuse-bench-pipeline" "${S[@]}" --input "$REC" --start-wall "$START" --rate 1 --csv "$d/bench" ${BENCH_ARGS:-} > "$d/bench.txt" 2> "$d/logs/bench.log" &
  bp=$!
  PIDS+=("$bp")
  "$BIN/fuse-ingest" "${S[@]}" --input "$REC" --mode realtime --rate 1 --start-wall "$START" > "$d/logs/fuse-ingest.log" 2>&1 || true
  wait "$bp" || echo "realtime run $i: fuse-bench-pipeline failed (see $d/logs/bench.log)" >&2
  if [ "${VIZ:-off}" != off ]; then
    rss_kb "$v" > "$d/viz_rss_end"
    cpu_s "$v" > "$d/viz_cpu"
    cpu_s "$vc" > "$d/viz_client_cpu"
    kill -TERM "$vc" 2> /dev/null || true
    stop_services "$v"
  fi
  cpu_s "$u" > "$d/update_cpu"
  cpu_s "$s" > "$d/state_cpu"
  stop_services "$u" "$s" "$m"
done
rt() { for i in $(seq "$RT_REPEATS"); do value "$1" "$WORK/rt$i/bench.txt"; done | median; }
if [ "$RT_REPEATS" -gt 0 ]; then
  echo "realtime_repeats: $RT_REPEATS"
  for k in query_calls query_rate_hz query_errors query_rtt_median_ms query_rtt_p99_ms query_rtt_max_ms \
           query_latest_rtt_median_ms query_latest_rtt_p99_ms query_at_rtt_median_ms query_at_rtt_p99_ms \
           query_idle_rtt_median_ms query_idle_rtt_p99_ms query_idle_rtt_max_ms query_idle_errors \
           query_rtt_over_1ms_fraction query_slow_calls query_slow_during_scan_in_work_fraction scan_in_work_time_fraction \
           query_slow_during_scan_transfer_fraction scan_transfer_time_fraction query_slow_during_scan_history_fraction \
           scan_history_time_fraction query_slow_during_scan_update_fraction scan_update_time_fraction \
           odometry_expected odometry_latency_count odometry_latency_median_ms odometry_latency_p99_ms odometry_latency_max_ms \
           scans_expected corrections_updated corrections_prior_only corrections_skipped \
           correction_latency_median_ms correction_latency_p95_ms correction_latency_max_ms \
           update_ms_median_ms update_ms_p95_ms imu_hop_latency_median_ms imu_hop_latency_p99_ms \
           scan_to_history_request_median_ms scan_to_history_request_p95_ms history_rpc_median_ms history_rpc_p95_ms \
           history_not_ready_per_scan_mean history_reply_to_correction_median_ms history_reply_to_correction_p95_ms \
           $(case "${BENCH_ARGS:-}" in *--observe-scan*) echo scan_hop_latency_median_ms scan_hop_latency_p95_ms ;; esac); do
    echo "$k: $(rt "$k")"
  done
  echo "update_cpu_s: $(for i in $(seq "$RT_REPEATS"); do cat "$WORK/rt$i/update_cpu"; done | median)"
  echo "state_cpu_s: $(for i in $(seq "$RT_REPEATS"); do cat "$WORK/rt$i/state_cpu"; done | median)"
  if [ "${VIZ:-off}" != off ]; then
    echo "viz_rss_start_kb: $(for i in $(seq "$RT_REPEATS"); do cat "$WORK/rt$i/viz_rss_start"; done | median)"
    echo "viz_rss_end_kb: $(for i in $(seq "$RT_REPEATS"); do cat "$WORK/rt$i/viz_rss_end"; done | median)"
    echo "viz_cpu_s: $(for i in $(seq "$RT_REPEATS"); do cat "$WORK/rt$i/viz_cpu"; done | median)"
    echo "viz_client_cpu_s: $(for i in $(seq "$RT_REPEATS"); do cat "$WORK/rt$i/viz_client_cpu"; done | median)"
    echo "viz_client_messages: $(for i in $(seq "$RT_REPEATS"); do grep -c '"topic"' "$WORK/rt$i/viz-client.jsonl" || true; done | median)"
  fi
fi

# ---- 4. lockstep throughput ------------------------------------------------------------------
for i in $(seq "$LS_REPEATS"); do
  next_domain
  d="$WORK/ls$i"
  mkdir -p "$d"
  S=("${COMMON[@]}" --set "transport.domain_id=$DOMAIN")
  "$BIN/fuse-bench-pipeline" "${S[@]}" --lockstep-scans "$SCANS" > "$d/bench.txt" 2> "$d/bench.log" &
  bp=$!
  PIDS=("$bp")
  sleep 2  # the bench is listening before the first correction
  a=$(now)
  "$BIN/fuse-launch" --config "$CONFIG" --input "$REC" --mode lockstep --domain "$DOMAIN" --vendor "$VENDOR" \
    "${SET_ARGS[@]}" --out "$d/out" > "$d/launch.txt" 2>&1 || echo "lockstep run $i: fuse-launch failed (see $d/launch.txt)" >&2
  b=$(now)
  echo "$a $b" | awk '{print $2-$1}' > "$d/wall"
  sleep 1
  kill -TERM "$bp" 2> /dev/null || true
  wait "$bp" || true
  PIDS=()
done
if [ "$LS_REPEATS" -gt 0 ]; then
  ls_() { for i in $(seq "$LS_REPEATS"); do value "$1" "$WORK/ls$i/bench.txt"; done | median; }
  LS_RATE=$(ls_ lockstep_scans_per_s)
  LS_WALL=$(for i in $(seq "$LS_REPEATS"); do cat "$WORK/ls$i/wall"; done | median)
  echo "lockstep_repeats: $LS_REPEATS"
  echo "lockstep_corrections: $(ls_ lockstep_corrections)"
  echo "lockstep_replay_s: $(ls_ lockstep_replay_s)"
  echo "lockstep_scans_per_s: $LS_RATE"
  echo "lockstep_launch_wall_s: $LS_WALL"
  echo "lockstep_launch_scans_per_s: $(awk -v n="$SCANS" -v w="$LS_WALL" 'BEGIN{printf "%.2f", n/w}')"
  echo "lockstep_vs_run_throughput_ratio: $(awk -v a="$LS_RATE" -v b="$RUN_RATE" 'BEGIN{printf "%.3f", a/b}')"
  echo "lockstep_vs_run_wall_ratio: $(awk -v a="$LS_WALL" -v b="$RUN_WALL" 'BEGIN{printf "%.3f", a/b}')"
fi
echo "load_after: $(cut -d' ' -f1-3 /proc/loadavg)"
