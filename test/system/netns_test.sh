#!/usr/bin/env bash
# The services split over two computers (issue 16): two network namespaces joined by a veth pair
# this test creates (10.77.0.1 and 10.77.0.2, its own addresses; multicast off on the link, so
# discovery is by unicast peers only). fuse-map and fuse-ingest run in one, fuse-state and
# fuse-update in the other; a lockstep replay on each vendor, without and with DDS Security, must
# give the single-process trajectory (fuse-run) at every scan.
#   netns_test.sh BIN_DIR CONFIG RECORDING OUT_DIR
# Needs root for `ip netns`; exits 77 (skipped, said why) without it.
set -uo pipefail
bin=$1 config=$2 rec=$3 out=$4
fail() { echo "FAILED: $*"; exit 1; }
if [ "$(id -u)" -ne 0 ] || ! command -v ip > /dev/null; then
  echo "SKIPPED: two network namespaces need root and ip (iproute2)"
  exit 77
fi
[ -f "$rec" ] || fail "no recording $rec (ctest fixture fuse_sim_data)"
tag="fuse$$"
ns_a="${tag}a" ns_b="${tag}b"
cleanup() {
  for ns in "$ns_a" "$ns_b"; do
    ip netns pids "$ns" 2> /dev/null | xargs -r kill -9 2> /dev/null
    ip netns del "$ns" 2> /dev/null
  done
}
trap cleanup EXIT
if ! ip netns add "$ns_a" 2> /dev/null || ! ip netns add "$ns_b" 2> /dev/null; then
  echo "SKIPPED: cannot create network namespaces here (no CAP_SYS_ADMIN)"
  exit 77
fi
ip link add "${tag}x" netns "$ns_a" type veth peer name "${tag}y" netns "$ns_b" || fail "veth pair"
ip -n "$ns_a" addr add 10.77.0.1/24 dev "${tag}x"
ip -n "$ns_b" addr add 10.77.0.2/24 dev "${tag}y"
for ns in "$ns_a" "$ns_b"; do ip -n "$ns" link set lo up; done
ip -n "$ns_a" link set "${tag}x" multicast off up
ip -n "$ns_b" link set "${tag}y" multicast off up
# The kernel brings a link's state up asynchronously (its link watch may take a second, longer on
# a loaded machine), and the services read their interfaces once, when they start: a service
# started before then filters its only interface out. So both ends must be up first.
wait_up() {  # NS DEV
  local deadline=$((SECONDS + 30))
  until ip -n "$1" -o link show dev "$2" | grep -q "state UP"; do
    [ "$SECONDS" -lt "$deadline" ] || fail "link $2 in $1 not up within 30 s: $(ip -n "$1" -o link show dev "$2")"
    sleep 0.1
  done
}
wait_up "$ns_a" "${tag}x"
wait_up "$ns_b" "${tag}y"

rm -rf "$out"
mkdir -p "$out"
"$bin/fuse-run" --config "$config" --input "$rec" --out "$out/single" > "$out/single.log" 2>&1 ||
  { cat "$out/single.log"; fail "fuse-run"; }
"$bin/fuse-keystore" init "$out/keystore" > /dev/null || fail "fuse-keystore init"

# run NAME VENDOR SECURE: the split pipeline; its trajectory in $out/NAME/trajectory.tum
run() {
  local d="$out/$1"
  mkdir -p "$d/logs"
  local common=(--config "$config" --vendor "$2" --domain 7 --set transport.loopback_only=false
                --set "transport.peers=[10.77.0.1,10.77.0.2]" --set ingest.lockstep_timeout_s=3
                --set update.map_sync_timeout_s=5)
  if [ "$3" = 1 ]; then
    common+=(--set transport.security.enabled=true --set "transport.security.keystore=$out/keystore")
  fi
  local on_a=(--set "transport.interfaces=[10.77.0.1]") on_b=(--set "transport.interfaces=[10.77.0.2]")
  ip netns exec "$ns_a" "$bin/fuse-map" "${common[@]}" "${on_a[@]}" --map-dir "$d/map" > "$d/logs/fuse-map.log" 2>&1 &
  local map=$!
  ip netns exec "$ns_b" "$bin/fuse-state" "${common[@]}" "${on_b[@]}" --trajectory "$d/trajectory.tum" \
    --calibration-from "$rec" > "$d/logs/fuse-state.log" 2>&1 &
  local state=$!
  ip netns exec "$ns_b" "$bin/fuse-update" "${common[@]}" "${on_b[@]}" > "$d/logs/fuse-update.log" 2>&1 &
  local update=$!
  timeout 300 ip netns exec "$ns_a" "$bin/fuse-ingest" "${common[@]}" "${on_a[@]}" --input "$rec" --mode lockstep \
    > "$d/logs/fuse-ingest.log" 2>&1
  local rc=$?
  kill -TERM "$update" "$state" "$map" 2> /dev/null
  wait "$update" "$state" "$map"
  [ "$rc" -eq 0 ] || { tail -n 20 "$d"/logs/*.log; fail "$1: fuse-ingest exited with $rc"; }
  python3 - "$out/single/trajectory.tum" "$d/trajectory.tum" "$1" << 'PY' || fail "$1: not the single-process trajectory"
import sys
def read(path):
    poses = {}
    for line in open(path):
        f = line.split()
        if f and not f[0].startswith('#'):
            poses[round(float(f[0]) * 1e6)] = tuple(map(float, f[1:4]))
    return poses
single, split = read(sys.argv[1]), read(sys.argv[2])
common = [t for t in split if t in single]
worst = max((sum((a - b) ** 2 for a, b in zip(single[t], split[t])) ** 0.5 for t in common), default=float("inf"))
print(f"{sys.argv[3]}: {len(common)} of {len(single)} scans, largest position difference {worst:.2e} m")
sys.exit(0 if len(common) + 2 >= len(single) and worst <= 1e-3 else 1)
PY
}

run fastdds fastdds 0
run fastdds-secured fastdds 1
run cyclonedds cyclonedds 0
run cyclonedds-secured cyclonedds 1
echo "the services split over two network namespaces give the single-process trajectory, both vendors, with and without security"
