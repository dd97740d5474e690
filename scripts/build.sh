#!/usr/bin/env bash
# Configures and builds FUSE (Release) into ./build with two parallel jobs.
set -euo pipefail
cd "$(dirname "$0")/.."
# The library directory is the multiarch one Debian uses (lib/x86_64-linux-gnu), so that the
# packages can be built from this tree (debian/rules FUSE_PREBUILT) and `cmake --install` to
# /usr/local puts the planner library on ld.so's path as well.
LIBDIR=lib
if MULTIARCH=$(gcc -print-multiarch 2>/dev/null) && [ -n "$MULTIARCH" ]; then LIBDIR=lib/$MULTIARCH; fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_LIBDIR="$LIBDIR"
cmake --build build -j2
