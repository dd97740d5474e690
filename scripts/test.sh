#!/usr/bin/env bash
# Runs every test (unit, accuracy on short simulated scenarios, file-format and fault tests).
# Tests that need ../shared/data skip with a message when it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
ctest --test-dir build --output-on-failure -j2 "$@"
