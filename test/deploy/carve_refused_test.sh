#!/usr/bin/env bash
# Free-space carving needs each ray's origin, which the services' observations do not carry: a
# service started with estimator.map.carve_s other than 0 stops at start-up with exit 2, naming
# the key (docs/architecture.md, "Moving objects and the map"); the shipped config starts.
#   carve_refused_test.sh CONFIG SERVICE_BIN...
set -uo pipefail
config=$1; shift
dir=$(mktemp -d); trap 'rm -rf "$dir"' EXIT
sed 's/^\(    carve_s:\) 0\.0/\1 2.0/' "$config" > "$dir/carve.yaml"
grep -q '^    carve_s: 2.0' "$dir/carve.yaml" || { echo "FAILED: no carve_s key to change in $config"; exit 1; }
failed=0
for bin in "$@"; do
  name=$(basename "$bin")
  out=$(timeout 60 "$bin" --config "$dir/carve.yaml" --domain 89 2>&1); rc=$?
  { [ "$rc" -eq 2 ] && grep -q "estimator.map.carve_s" <<< "$out"; } ||
    { echo "FAILED: $name with carve_s 2: exit $rc: $out"; failed=1; }
done
[ "$failed" -eq 0 ] && echo "every service refused estimator.map.carve_s 2 naming the key"
exit $failed
