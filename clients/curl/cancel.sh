#!/usr/bin/env bash
# Usage: cancel.sh JOB_ID   DELETE: cancels a queued or running job (202 + job), or deletes a
# finished job and its files (204).
set -euo pipefail
. "$(dirname "$0")/common.sh"
[ $# -eq 1 ] || { echo "usage: $0 JOB_ID" >&2; exit 2; }
body=$(mktemp); trap 'rm -f "$body"' EXIT
status=$(request "$body" -X DELETE "${HOCURVE_URL}/v1/jobs/$1")
case "$status" in
  202) cat "$body" ;;
  204) echo "deleted $1" ;;
  *) fail_with_problem "$body" "$status" ;;
esac
