#!/usr/bin/env bash
# Smoke test of the image: run it on a loopback port, wait for /readyz, curve a small mesh through
# POST /v1/jobs with the curl client scripts, check /metrics, stop with SIGTERM.
# Usage: docker/smoke_test.sh [IMAGE] [MESH]
set -euo pipefail
cd "$(dirname "$0")/.."
IMAGE="${1:-localhost/hocurve:latest}"
MESH="${2:-../shared/meshes/sphere_surf_gmsh.stl}"
ENGINE="${ENGINE:-podman}"
PORT="${PORT:-18080}"
name="hocurve-smoke-$$"
"$ENGINE" run -d --rm --name "$name" -p "127.0.0.1:${PORT}:8080" "$IMAGE" >/dev/null
trap '"$ENGINE" stop -t 30 "$name" >/dev/null 2>&1 || true' EXIT
export HOCURVE_URL="http://127.0.0.1:${PORT}"
for _ in $(seq 1 100); do
  curl -fsS "$HOCURVE_URL/readyz" >/dev/null 2>&1 && break
  sleep 0.1
done
curl -fsS "$HOCURVE_URL/v1/info"; echo
id=$(clients/curl/submit.sh "$MESH" order=3)
clients/curl/poll.sh "$id" 120 >/dev/null
clients/curl/download.sh "$id" "/tmp/$name.msh"
head -c 11 "/tmp/$name.msh" | grep -q '\$MeshFormat' || { echo "smoke: result is not a .msh" >&2; exit 1; }
curl -fsS "$HOCURVE_URL/metrics" | grep -q 'hocurve_jobs_finished_total{state="succeeded"} 1' \
  || { echo "smoke: metrics do not show the finished job" >&2; exit 1; }
rm -f "/tmp/$name.msh"
echo "smoke: OK"
