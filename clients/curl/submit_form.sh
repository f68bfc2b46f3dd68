#!/usr/bin/env bash
# Usage: submit_form.sh MESH '{"order":4,"mode":"curve"}'
# The multipart variant (curl -F): parts "mesh" (the file) and "options" (JSON). Prints the job id.
set -euo pipefail
. "$(dirname "$0")/common.sh"
[ $# -ge 1 ] || { echo "usage: $0 MESH [OPTIONS_JSON]" >&2; exit 2; }
body=$(mktemp); trap 'rm -f "$body"' EXIT
status=$(request "$body" -F "mesh=@$1" -F "options=${2:-{\}};type=application/json" "${HOCURVE_URL}/v1/jobs")
[ "$status" = 202 ] || fail_with_problem "$body" "$status"
json_string id < "$body"
