#!/usr/bin/env bash
# The Debian packages (debian/, docs/packaging.md), built by debhelper from the tree just built
# (debian/rules FUSE_PREBUILT), and checked as a vehicle team would meet them:
#   1. the five packages are built; lintian reports no error and no warning (overrides carry a reason);
#   2. no package pulls PCL or VTK (the map export writes PCD and PLY itself); a man page for
#      every binary;
#   3. `apt-get -s install` of every package with fuse3 resolves (Debian's fuse3 beside us);
#   4. maintainer scripts in a scratch root (dpkg --root, chrootless, DPKG_ROOT): the user is
#      created, an old "fuse" 0.1 installation is migrated (edited config kept, map moved, target
#      enabled), a reinstall keeps the config, remove keeps config and map, purge deletes both;
#   5. the unpacked services start on the packaged config, report READY and stop with 0 on SIGTERM.
#   deb_test.sh SOURCE_DIR BUILD_DIR SCRATCH_DIR DEPLOY_DATA DDS_DOMAIN     exit 77: skipped
set -euo pipefail
source_dir=$1 build=$2 scratch=$3 data=$4 domain=$5
for tool in dpkg-buildpackage dh dh_installsysusers dh_python3 lintian help2man chrpath dpkg dpkg-deb; do
  command -v "$tool" >/dev/null 2>&1 || { echo "SKIPPED: $tool is not installed (scripts/setup-deps.sh installs it)"; exit 77; }
done
fail() { echo "FAILED: $*"; exit 1; }
rm -rf "$scratch"
mkdir -p "$scratch/src"

# ---- 1. build (debian/ only: the tree is prebuilt; -nc: nothing to clean) -----------------
cp -rL "$source_dir/debian" "$scratch/src/debian"
(cd "$scratch/src" && FUSE_PREBUILT="$build" dpkg-buildpackage -b -us -uc -nc >"$scratch/build.log" 2>&1) ||
  { tail -60 "$scratch/build.log"; fail "dpkg-buildpackage"; }
version=$(dpkg-parsechangelog -l "$source_dir/debian/changelog" -S Version)
arch=$(dpkg --print-architecture)
deb() { echo "$scratch/${1}_${version}_${arch}.deb"; }
for p in fuse-slam fuse-slam-tools libfuse-slam-query3 libfuse-slam-query-dev python3-fuse-slam; do
  [ -f "$(deb $p)" ] || { ls "$scratch"; fail "$(basename "$(deb $p)") was not built"; }
  echo "built $(basename "$(deb $p)") ($(du -k "$(deb $p)" | cut -f1) KiB)"
done

lintian --fail-on error,warning "$scratch"/*.changes >"$scratch/lintian.log" 2>&1 ||
  { cat "$scratch/lintian.log"; fail "lintian reports errors or warnings"; }
echo "lintian: $(grep -c . "$scratch/lintian.log" || true) line(s), no error or warning"

# ---- 2. dependencies, conffiles, man pages ---------------------------------------------------
services_depends=$(dpkg-deb --field "$(deb fuse-slam)" Depends)
echo "fuse-slam Depends: $services_depends"
if echo "$services_depends" | grep -Eq "libpcl|libvtk"; then fail "fuse-slam depends on PCL or VTK"; fi
for lib in libfastrtps libddsc libyaml-cpp libprotobuf libfuse-slam-query3; do
  grep -q "$lib" <<< "$services_depends" || fail "fuse-slam's Depends lacks $lib"
done
if dpkg-deb --field "$(deb fuse-slam-tools)" Depends | grep -Eq "libpcl|libvtk"; then fail "fuse-slam-tools depends on PCL or VTK"; fi
python_depends=$(dpkg-deb --field "$(deb python3-fuse-slam)" Depends)
echo "python3-fuse-slam Depends: $python_depends"
for dep in "python3 (" libfuse-slam-query3; do
  grep -qF "$dep" <<< "$python_depends" || fail "python3-fuse-slam's Depends lacks $dep"
done
dpkg-deb --info "$(deb fuse-slam)" conffiles | sort | tr '\n' ' ' |
  grep -qx "/etc/fuse-slam/fuse-slam.yaml /etc/fuse-slam/ingest.env " || fail "conffiles are not the config and ingest.env"
for p in fuse-slam fuse-slam-tools; do
  contents=$(dpkg-deb --contents "$(deb $p)")
  for b in $(echo "$contents" | awk '$6 ~ /^\.\/usr\/bin\// { sub("./usr/bin/", "", $6); print $6 }'); do
    grep -q "usr/share/man/man1/$b.1.gz" <<< "$contents" || fail "no man page for $b in $p"
  done
done
echo "no package pulls PCL or VTK; a man page for every binary"

# ---- 3. apt resolves us beside Debian's fuse3 --------------------------------------------
if apt-cache show fuse3 >/dev/null 2>&1; then
  apt-get -s -q install "$(deb libfuse-slam-query3)" "$(deb fuse-slam)" "$(deb python3-fuse-slam)" \
    "$(deb fuse-slam-tools)" "$(deb libfuse-slam-query-dev)" fuse3 >"$scratch/apt.log" 2>&1 ||
    { cat "$scratch/apt.log"; fail "apt-get -s install fuse-slam fuse3 does not resolve"; }
  echo "apt-get -s install of all five packages beside fuse3: resolves"
else
  echo "SKIPPED (part 3): no apt package lists with fuse3 (apt-get update)"
fi

# ---- 4. maintainer scripts in a scratch root -----------------------------------------------
if [ "$(id -u)" -eq 0 ] && command -v systemd-sysusers >/dev/null 2>&1; then
  root="$scratch/root"
  mkdir -p "$root/var/lib/dpkg/info" "$root/var/lib/dpkg/updates" "$root/etc" "$root/tmp"
  : >"$root/var/lib/dpkg/status"
  # What the old package "fuse" 0.1 left after `apt-get remove fuse`: its edited conffiles,
  # the map and checkpoint its services wrote, the enabled target's link.
  mkdir -p "$root/etc/fuse" "$root/var/lib/fuse/map" "$root/etc/systemd/system/multi-user.target.wants"
  { cat "$source_dir/config/mid360.yaml"; printf 'transport:\n  domain_id: 17  # edited on the vehicle\n'; } >"$root/etc/fuse/fuse.yaml"
  echo "FUSE_INGEST_ARGS=--livox-udp 192.0.2.1:56301:56401" >"$root/etc/fuse/ingest.env"
  echo "old map" >"$root/var/lib/fuse/map/snapshot.bin"
  echo "old checkpoint" >"$root/var/lib/fuse/state.checkpoint"
  ln -s /usr/lib/systemd/system/fuse.target "$root/etc/systemd/system/multi-user.target.wants/fuse.target"

  dpkgr() { dpkg --root="$root" --force-script-chrootless --force-depends --log=/dev/null "$@" >>"$scratch/dpkg.log" 2>&1 ||
              { cat "$scratch/dpkg.log"; fail "dpkg $*"; }; }
  dpkgr -i "$(deb libfuse-slam-query3)" "$(deb fuse-slam)"
  grep -q "^_fuse-slam:" "$root/etc/passwd" || fail "the user _fuse-slam was not created"
  [ -f "$root/etc/fuse-slam/keystore/identities/fuse-state/key.pem" ] || fail "the postinst made no DDS Security keystore"
  [ "$(stat -c %a "$root/etc/fuse-slam/keystore/identities/fuse-state/key.pem")" = 600 ] || fail "a private key is readable by others"
  grep -q "edited on the vehicle" "$root/etc/fuse-slam/fuse-slam.yaml" || fail "the edited old config was not kept"
  [ -f "$root/etc/fuse-slam/fuse-slam.yaml.dpkg-dist" ] || fail "the packaged config was not kept as .dpkg-dist"
  grep -q "192.0.2.1" "$root/etc/fuse-slam/ingest.env" || fail "the old ingest.env was not kept"
  [ "$(cat "$root/var/lib/fuse-slam/map/snapshot.bin")" = "old map" ] || fail "the old map was not moved"
  [ -f "$root/var/lib/fuse-slam/state.checkpoint" ] || fail "the old checkpoint was not moved"
  grep -q "^StateDirectory=fuse-slam$" "$root/lib/systemd/system/fuse-slam-map.service" ||
    fail "fuse-slam-map.service has no StateDirectory=fuse-slam (which gives the moved map to _fuse-slam)"
  [ -L "$root/etc/systemd/system/multi-user.target.wants/fuse-slam.target" ] || fail "fuse-slam.target was not enabled"
  [ ! -e "$root/etc/systemd/system/multi-user.target.wants/fuse.target" ] && \
    [ ! -L "$root/etc/systemd/system/multi-user.target.wants/fuse.target" ] || fail "the old target link is left"
  echo "install in a scratch root: user created, old config kept (packaged one as .dpkg-dist), map moved, target enabled"

  # Reinstall (an upgrade to the same version): the edited config stays, nothing migrates again.
  dpkgr -i "$(deb fuse-slam)"
  grep -q "edited on the vehicle" "$root/etc/fuse-slam/fuse-slam.yaml" || fail "reinstall replaced the edited config"
  # Remove: config and map stay.  Purge: both go; the user stays.
  dpkgr -r fuse-slam
  [ -f "$root/etc/fuse-slam/fuse-slam.yaml" ] || fail "remove deleted the config"
  [ -f "$root/var/lib/fuse-slam/map/snapshot.bin" ] || fail "remove deleted the map"
  [ ! -e "$root/usr/bin/fuse-map" ] || fail "remove left the binaries"
  dpkgr -P fuse-slam
  [ ! -e "$root/etc/fuse-slam" ] || { ls -la "$root/etc/fuse-slam"; fail "purge left /etc/fuse-slam"; }
  [ ! -e "$root/var/lib/fuse-slam" ] || fail "purge left /var/lib/fuse-slam"
  grep -q "^_fuse-slam:" "$root/etc/passwd" || fail "purge deleted the system user"
  echo "reinstall keeps the edited config; remove keeps config and map; purge deletes both, keeps the user"
else
  echo "SKIPPED (part 4): maintainer scripts need root and systemd-sysusers"
fi

# ---- 5. the unpacked services run -----------------------------------------------------------
unpacked="$scratch/unpacked"
for p in fuse-slam libfuse-slam-query3 python3-fuse-slam; do dpkg -x "$(deb $p)" "$unpacked"; done
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
  NOTIFY_SOCKET="$sock" "$unpacked/usr/bin/$name" --config "$unpacked/etc/fuse-slam/fuse-slam.yaml" \
    --domain "$domain" --set transport.security.keystore="$scratch/keystore" "$@" >"$log" 2>&1 &
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
# The installed config secures the bus: a keystore made by the unpacked fuse-keystore.
grep -q "^    enabled: true" "$unpacked/etc/fuse-slam/fuse-slam.yaml" || fail "the installed config does not enable DDS Security"
"$unpacked/usr/bin/fuse-keystore" init "$scratch/keystore" >"$scratch/keystore.log" 2>&1 ||
  { cat "$scratch/keystore.log"; fail "fuse-keystore init (unpacked)"; }
run_service fuse-map --map-dir "$scratch/map"
run_service fuse-state
run_service fuse-update
if [ -f "$data/recording.mcap" ]; then
  run_service fuse-ingest --input "$data/recording.mcap" --mode realtime --set ingest.start_wait_s=30
else
  echo "fuse-ingest not run: no recording at $data (ctest fixture fuse_deploy_data)"
fi
LD_LIBRARY_PATH="$(dirname "$(find "$unpacked/usr/lib" -name 'libfuse_slam_query.so.*' | head -1)")" \
  "$unpacked/usr/bin/fuse-query" --help >"$scratch/query.log" 2>&1 || { cat "$scratch/query.log"; fail "fuse-query --help (unpacked)"; }
grep -qi "usage" "$scratch/query.log" || { cat "$scratch/query.log"; fail "fuse-query (unpacked) did not run"; }
echo "fuse-query (unpacked) runs against the unpacked libfuse_slam_query"
# The Python module loads the unpacked library and asks a (absent) server: unavailable, not a crash.
LD_LIBRARY_PATH="$(dirname "$(find "$unpacked/usr/lib" -name 'libfuse_slam_query.so.*' | head -1)")" \
PYTHONPATH="$unpacked/usr/lib/python3/dist-packages" python3 - "$domain" >"$scratch/python.log" 2>&1 <<'PY' ||
import sys, fuse_slam
c = fuse_slam.Client(fuse_slam.ClientOptions(domain_id=int(sys.argv[1]), deadline_ms=200))
r = c.latest()
assert r.error == fuse_slam.Error.unavailable, r
print("python3-fuse-slam:", fuse_slam.__file__, r.error.name)
PY
  { cat "$scratch/python.log"; fail "the unpacked fuse_slam module"; }
cat "$scratch/python.log"
