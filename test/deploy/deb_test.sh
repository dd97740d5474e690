#!/usr/bin/env bash
# Builds the .deb with CPack, unpacks it into a scratch root (dpkg -x: no maintainer scripts, no
# root needed) and runs the unpacked binaries there: each service starts on the installed
# config, reports READY, and stops with exit code 0 on SIGTERM.
#   deb_test.sh BUILD_DIR SCRATCH_DIR DEPLOY_DATA DDS_DOMAIN     exit 77: skipped (no dpkg)
set -euo pipefail
build=$1 scratch=$2 data=$3 domain=$4
for tool in cpack dpkg dpkg-deb; do
  command -v "$tool" >/dev/null 2>&1 || { echo "SKIPPED: $tool is not installed"; exit 77; }
done
fail() { echo "FAILED: $*"; exit 1; }
rm -rf "$scratch"
mkdir -p "$scratch/root"
(cd "$scratch" && cpack -G DEB --config "$build/CPackConfig.cmake" -B "$scratch/out" >cpack.log 2>&1) ||
  { cat "$scratch/cpack.log"; fail "cpack -G DEB"; }
deb=$(ls "$scratch"/out/fuse_*.deb)
[ -f "$deb" ] || fail "no fuse_*.deb in $scratch/out"
echo "built $(basename "$deb") ($(du -k "$deb" | cut -f1) KiB)"

dpkg-deb --field "$deb" Package | grep -qx fuse || fail "package name is not fuse"
depends=$(dpkg-deb --field "$deb" Depends)
echo "Depends: $depends"
for lib in libfastrtps libddsc libyaml-cpp libprotobuf; do
  echo "$depends" | grep -q "$lib" || fail "Depends lacks $lib"
done
dpkg-deb --info "$deb" conffiles | grep -qx /etc/fuse/fuse.yaml || fail "/etc/fuse/fuse.yaml is not a conffile"
dpkg-deb --info "$deb" postinst >/dev/null || fail "no postinst"

root="$scratch/root"
dpkg -x "$deb" "$root"
for f in usr/bin/fuse-map usr/bin/fuse-state usr/bin/fuse-update usr/bin/fuse-ingest usr/bin/fuse-query \
         usr/bin/fuse-map-ctl usr/lib/systemd/system/fuse.target usr/lib/systemd/system/fuse-map.service \
         usr/lib/sysusers.d/fuse.conf usr/lib/sysctl.d/60-fuse-dds.conf usr/lib/udev/rules.d/60-fuse-cpu-latency.rules etc/fuse/fuse.yaml etc/fuse/ingest.env \
         usr/include/fuse/query/client.hpp; do
  [ -e "$root/$f" ] || fail "/$f is not in the package"
done
# lib/ or lib/<multiarch>/ (GNUInstallDirs' LIBDIR of the configured prefix): both on ld.so's path.
find "$root/usr/lib" -name 'libfuse_query.so.*' | grep -q . || fail "libfuse_query.so.* is not in the package"

# The unpacked services, on the unpacked config, on their own DDS domain.
run_service() {  # name, extra args...
  local name=$1; shift
  local sock="$scratch/$name.notify" log="$scratch/$name.log"
  python3 - "$sock" >"$scratch/$name.notifications" 2>&1 <<'PY' &
import socket, sys, time
s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
s.bind(sys.argv[1]); s.settimeout(40)
end = time.time() + 40
while time.time() < end:
    try:
        m = s.recv(4096).decode()
    except socket.timeout:
        break
    print(m.replace("\n", " | "), flush=True)
    if m.startswith("STOPPING=1"):
        break
PY
  local listener=$!
  while [ ! -S "$sock" ]; do sleep 0.05; done
  NOTIFY_SOCKET="$sock" "$root/usr/bin/$name" --config "$root/etc/fuse/fuse.yaml" \
    --set transport.domain_id="$domain" "$@" >"$log" 2>&1 &
  local pid=$!
  local waited=0
  until grep -q "^READY=1" "$scratch/$name.notifications"; do
    sleep 0.1; waited=$((waited + 1))
    if [ "$waited" -ge 300 ] || ! kill -0 "$pid" 2>/dev/null; then cat "$log"; fail "$name: no READY=1"; fi
  done
  kill -TERM "$pid"
  local code=0
  wait "$pid" || code=$?
  wait "$listener" || true
  [ "$code" -eq 0 ] || { cat "$log"; fail "$name exited with $code after SIGTERM"; }
  grep -q "^STOPPING=1" "$scratch/$name.notifications" || fail "$name: no STOPPING=1"
  echo "$name (unpacked): READY, SIGTERM, STOPPING, exit 0"
}
run_service fuse-map --map-dir "$scratch/map"
run_service fuse-state
run_service fuse-update
if [ -f "$data/recording.mcap" ]; then
  run_service fuse-ingest --input "$data/recording.mcap" --mode realtime --set ingest.start_wait_s=30
else
  echo "fuse-ingest not run: no recording at $data (ctest fixture fuse_deploy_data)"
fi
"$root/usr/bin/fuse-query" --help >"$scratch/query.log" 2>&1 || true
grep -qi "usage" "$scratch/query.log" || { cat "$scratch/query.log"; fail "fuse-query (unpacked) did not run"; }
echo "fuse-query (unpacked) runs against the unpacked libfuse_query"
