#!/usr/bin/env bash
# The main job. Until the daemon lands this curves the bundled example with the CLI and says
# where the .msh went; with hocurved built it starts the daemon on 127.0.0.1:8080 with ./var.
set -euo pipefail
BUILD=${1:-build}
cd "$(dirname "$0")/.."
if [ -x "$BUILD/hocurved" ] && [ "${HOCURVE_RUN:-daemon}" = daemon ]; then
  mkdir -p var
  exec "$BUILD/hocurved" --host 127.0.0.1 --port "${HOCURVE_PORT:-8080}" --data-dir var \
       --hocurve-bin "$BUILD/hocurve"
fi
mkdir -p out
"$BUILD/hocurve" info examples/torus.stl
"$BUILD/hocurve" curve examples/torus.stl -o out/torus_p4.msh --order 4 --stats out/torus_p4.json
echo "wrote $(pwd)/out/torus_p4.msh (P4, Gmsh type 23) and its stats out/torus_p4.json"
