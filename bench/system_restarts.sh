#!/usr/bin/env bash
# The multi-process system tests on a full scenario: lockstep equivalence with fuse-run (Fast DDS,
# Cyclone DDS, mixed vendors) and SIGKILL + restart of fuse-map, fuse-update and fuse-state, then
# fuse-ingest in real time (on the first DURATION_SHORT seconds). CI runs the same tests on 60 s /
# 20 s corridors.
#   usage: bench/system_restarts.sh [SCENARIO] [SEED] [DURATION_SHORT]
set -euo pipefail
cd "$(dirname "$0")/.."
SCENARIO=${1:-corridor}
SEED=${2:-1}
SHORT=${3:-30}
OUT=out/bench
SIM=$OUT/sim-$SCENARIO-mid360-$SEED
SIM_SHORT=$OUT/sim-$SCENARIO-mid360-$SEED-${SHORT}s
[ -f "$SIM/recording.mcap" ] || ./build/bin/fuse-sim --scenario "$SCENARIO" --seed "$SEED" --out "$SIM" > "$SIM.log" 2>&1
[ -f "$SIM_SHORT/recording.mcap" ] || ./build/bin/fuse-sim --scenario "$SCENARIO" --seed "$SEED" --duration "$SHORT" \
  --out "$SIM_SHORT" > "$SIM_SHORT.log" 2>&1
echo "== $SCENARIO seed $SEED ($SIM), real-time ingest restart on the first $SHORT s"
FUSE_SYSTEM_TEST_DATA=$SIM FUSE_SYSTEM_TEST_SHORT_DATA=$SIM_SHORT FUSE_SYSTEM_TEST_REPLAY_TIMEOUT_S=3600 \
  ./build/bin/system_multiprocess_test \
  2>&1 | grep -E '^\[ |Failure|Expected|actual|Which'
