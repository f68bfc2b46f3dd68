#!/usr/bin/env bash
# Installs every Debian 12 package hocurve needs to build, test and run. Idempotent: does
# nothing (and needs no network) when everything is already installed.
set -euo pipefail
PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libgmsh-dev           # Gmsh SDK: reference element tables, read-back checks, OCC test shapes
  libeigen3-dev         # dense linear algebra for the local fits (QR with pivoting)
  libtbb-dev            # parallel loops over vertices, edges and faces
  nlohmann-json3-dev    # stats, job model, HTTP API bodies
  libcpp-httplib-dev    # the daemon's HTTP server
  doctest-dev           # unit tests
  zlib1g-dev            # gzip-compressed inputs
  python3 python3-gmsh python3-numpy python3-meshio  # test-shape generation, independent read-back
  curl                  # curl client and daemon tests
  nginx-light           # the container's reverse proxy (docker/nginx.conf), run on loopback by tests/python/test_server_front.py
  clang-14 libclang-rt-14-dev  # `make fuzz`: libFuzzer and the sanitizers' runtimes for clang
)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
