#!/usr/bin/env bash
# The command-line convention (README "fuse-launch"): each binary answers --help and --version
# with exit 0 (the version line names it and the project version), and a flag it does not know
# with exit 2 and the flag's name on stderr; the binaries that talk DDS (before "--") also take
# --domain N and --vendor V.
#   cli_test.sh VERSION DDS_BIN... [-- OTHER_BIN...]
set -uo pipefail
version=$1; shift
failed=0
dds=1
for bin in "$@"; do
  if [ "$bin" = "--" ]; then dds=0; continue; fi
  name=$(basename "$bin")
  out=$("$bin" --help 2>&1); rc=$?
  { [ "$rc" -eq 0 ] && grep -q "Usage: $name" <<< "$out"; } || { echo "FAILED: $name --help: exit $rc: $out"; failed=1; }
  out=$("$bin" --version 2>&1); rc=$?
  { [ "$rc" -eq 0 ] && [ "$out" = "$name (FUSE-SLAM) $version" ]; } || { echo "FAILED: $name --version: exit $rc: $out"; failed=1; }
  if [ "$dds" -eq 1 ]; then out=$("$bin" --config /dev/null --no-such-flag 2>&1); rc=$?
  else out=$("$bin" --no-such-flag 2>&1); rc=$?; fi
  { [ "$rc" -eq 2 ] && grep -q -- "--no-such-flag" <<< "$out"; } || { echo "FAILED: $name --no-such-flag: exit $rc: $out"; failed=1; }
  if [ "$dds" -eq 0 ]; then
    [ "$failed" -eq 0 ] && echo "$name: --help, --version, a wrong flag: as the convention says"
    continue
  fi
  out=$("$bin" --config /dev/null --domain x 2>&1); rc=$?
  { [ "$rc" -eq 2 ] && grep -q -- "--domain" <<< "$out"; } || { echo "FAILED: $name --domain x: exit $rc: $out"; failed=1; }
  # Valid flags reach the config check (an empty config file is refused, naming it).
  out=$("$bin" --config /dev/null --domain 85 --vendor cyclonedds 2>&1); rc=$?
  { [ "$rc" -eq 2 ] && ! grep -q -- "not expected" <<< "$out"; } || { echo "FAILED: $name --domain 85 --vendor cyclonedds: exit $rc: $out"; failed=1; }
  [ "$failed" -eq 0 ] && echo "$name: --help, --version, a wrong flag, --domain, --vendor: as the convention says"
done
exit $failed
