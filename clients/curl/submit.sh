#!/usr/bin/env bash
# Usage: submit.sh MESH [option=value ...]   e.g. submit.sh part.stl order=4 format=msh22
# Uploads MESH as the raw body (streamed by the server to disk) and prints the new job id.
# IDEMPOTENCY_KEY=... makes retries safe (same key and body -> same job).
set -euo pipefail
. "$(dirname "$0")/common.sh"
[ $# -ge 1 ] || { echo "usage: $0 MESH [option=value ...]" >&2; exit 2; }
mesh="$1"; shift
query=$(IFS='&'; echo "$*")
headers=(-H "Content-Type: application/octet-stream")
if [ -n "${IDEMPOTENCY_KEY:-}" ]; then headers+=(-H "Idempotency-Key: ${IDEMPOTENCY_KEY}"); fi
body=$(mktemp); trap 'rm -f "$body"' EXIT
status=$(request "$body" "${headers[@]}" --data-binary "@${mesh}" "${HOCURVE_URL}/v1/jobs?${query}")
[ "$status" = 202 ] || fail_with_problem "$body" "$status"
json_string id < "$body"
