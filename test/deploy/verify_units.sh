#!/usr/bin/env bash
# Installs the runtime component into a scratch root (DESTDIR, prefix /usr, as the .deb does) and
# runs `systemd-analyze verify` on the installed units there: unit syntax, ExecStart binaries
# present and executable, the dependencies of fuse-slam.target resolvable.
#   verify_units.sh CMAKE BUILD_DIR SCRATCH_ROOT        exit 77: skipped (no systemd-analyze)
set -euo pipefail
cmake_command=$1 build=$2 root=$3
if ! command -v systemd-analyze >/dev/null 2>&1; then
  echo "SKIPPED: systemd-analyze is not installed (Debian package systemd)"
  exit 77
fi
rm -rf "$root"
DESTDIR="$root" "$cmake_command" --install "$build" --prefix /usr --component runtime >/dev/null
units="$root/usr/lib/systemd/system"
for f in fuse-slam.target fuse-slam-map.service fuse-slam-state.service fuse-slam-update.service fuse-slam-ingest.service \
         fuse-slam-viz.service; do
  [ -f "$units/$f" ] || { echo "FAILED: $f was not installed to $units"; exit 1; }
done
for f in usr/lib/sysusers.d/fuse-slam.conf usr/lib/sysctl.d/60-fuse-slam-dds.conf etc/fuse-slam/fuse-slam.yaml etc/fuse-slam/ingest.env \
         usr/bin/fuse-map usr/bin/fuse-state usr/bin/fuse-update usr/bin/fuse-ingest; do
  [ -e "$root/$f" ] || { echo "FAILED: /$f missing from the install tree"; exit 1; }
done
# The units name the installed binaries and config, not the build tree.
if grep -n "$build" "$units"/fuse-slam-*.service; then echo "FAILED: a unit names the build tree"; exit 1; fi
grep -q '^ExecStart=/usr/bin/fuse-map --config /etc/fuse-slam/fuse-slam.yaml --map-dir /var/lib/fuse-slam/map --set map_server.spill_directory=/run/fuse-slam-map/spill --set transport.security.private_key=%d/dds-key.pem$' "$units/fuse-slam-map.service" ||
  { echo "FAILED: fuse-slam-map.service ExecStart"; cat "$units/fuse-slam-map.service"; exit 1; }

# Every unit fuse-slam.target wants is installed (verify does not report a missing one).
for wanted in $(sed -n 's/^Wants=//p' "$units/fuse-slam.target"); do
  [ -f "$units/$wanted" ] || { echo "FAILED: fuse-slam.target wants $wanted, which is not installed"; exit 1; }
done

# Under --root, verify loads the units' default dependencies (sysinit.target, ...) from the tree:
# the host's unit files are copied in beside ours (never over them).
cp -rn /usr/lib/systemd/system/. "$units/"

# systemd-analyze verify prints warnings and errors on stderr; any output about our units fails.
log=$(mktemp)
trap 'rm -f "$log"' EXIT
status=0
SYSTEMD_LOG_LEVEL=notice systemd-analyze verify --root="$root" --man=no \
  "$units/fuse-slam.target" "$units/fuse-slam-map.service" "$units/fuse-slam-state.service" \
  "$units/fuse-slam-update.service" "$units/fuse-slam-ingest.service" "$units/fuse-slam-viz.service" >"$log" 2>&1 || status=$?
cat "$log"
if [ "$status" -ne 0 ]; then echo "FAILED: systemd-analyze verify exited with $status"; exit 1; fi
if grep -E "fuse[-.a-z]*\.(service|target)" "$log"; then echo "FAILED: systemd-analyze verify reported problems in our units"; exit 1; fi

# The sysusers.d entry creates the user the units run as (in the scratch root's /etc).
if command -v systemd-sysusers >/dev/null 2>&1; then
  systemd-sysusers --root="$root" fuse-slam.conf >/dev/null 2>&1 || { echo "FAILED: systemd-sysusers fuse-slam.conf"; exit 1; }
  user=$(sed -n 's/^User=//p' "$units/fuse-slam-map.service")
  grep -q "^$user:" "$root/etc/passwd" || { echo "FAILED: sysusers.d/fuse-slam.conf does not create $user"; exit 1; }
fi
# The sysctl drop-in holds only keys the kernel has.
while IFS='=' read -r key value; do
  key=$(echo "$key" | tr -d ' ')
  [ -e "/proc/sys/${key//.//}" ] || { echo "FAILED: 60-fuse-slam-dds.conf sets unknown key $key"; exit 1; }
done < <(grep -v '^#' "$root/usr/lib/sysctl.d/60-fuse-slam-dds.conf" | grep '=')
echo "systemd-analyze verify --root: fuse-slam.target and the four services pass; sysusers creates $user; sysctl keys exist"
