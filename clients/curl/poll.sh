#!/usr/bin/env bash
# Usage: poll.sh JOB_ID [TIMEOUT_SECONDS]
# Polls GET /v1/jobs/JOB_ID until the job is succeeded, failed or cancelled; prints the final job
# JSON. Exit 0 when succeeded, 1 otherwise.
set -euo pipefail
. "$(dirname "$0")/common.sh"
[ $# -ge 1 ] || { echo "usage: $0 JOB_ID [TIMEOUT]" >&2; exit 2; }
deadline=$(( $(date +%s) + ${2:-600} ))
body=$(mktemp); trap 'rm -f "$body"' EXIT
while :; do
  status=$(request "$body" "${HOCURVE_URL}/v1/jobs/$1")
  [ "$status" = 200 ] || fail_with_problem "$body" "$status"
  state=$(json_string status < "$body")
  case "$state" in
    succeeded) cat "$body"; exit 0 ;;
    failed|cancelled) cat "$body"; exit 1 ;;
  esac
  # Progress as a whole percentage (the fraction is a double, e.g. 0.30000000000000004) and the stage.
  percent=$(json_field fraction < "$body" | LC_ALL=C awk '{ f = $1 + 0; if (f < 0) f = 0; if (f > 1) f = 1; printf "%d", f * 100 + 0.5 }')
  printf '\r%s %s%% %-16s' "$state" "${percent:-0}" "$(json_string stage < "$body")" >&2
  [ "$(date +%s)" -lt "$deadline" ] || { echo "error: timeout waiting for $1" >&2; exit 1; }
  sleep 0.5
done
