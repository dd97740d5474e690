#!/usr/bin/env bash
# Installs every build and test dependency of FUSE from Debian 12 packages.
# Safe to run again: apt-get skips what is already installed.
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends \
  build-essential cmake pkg-config git ca-certificates \
  libeigen3-dev libpcl-dev \
  libfastrtps-dev libfastcdr-dev fastddsgen fastdds-tools \
  cyclonedds-dev cyclonedds-tools \
  libprotobuf-dev protobuf-compiler \
  libspdlog-dev libfmt-dev libyaml-cpp-dev libjsoncpp-dev \
  libgtest-dev libgmock-dev libbenchmark-dev libboost-dev \
  liblz4-dev libzstd-dev libbz2-dev libsqlite3-dev libcli11-dev \
  systemd openssl iproute2 gnuplot-nox \
  pybind11-dev python3-dev dh-python \
  debhelper lintian help2man chrpath dpkg-dev
# Node.js is only used by the interoperability test (npm packages that read our MCAP files).
# Some images ship a Node.js build that bundles npm and conflicts with Debian's npm package.
if ! command -v node >/dev/null 2>&1; then
  $SUDO apt-get install -y -q --no-install-recommends nodejs
fi
if ! command -v npm >/dev/null 2>&1; then
  $SUDO apt-get install -y -q --no-install-recommends npm
fi
