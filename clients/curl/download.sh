#!/usr/bin/env bash
# Usage: download.sh JOB_ID OUTPUT.msh   Streams the result of a succeeded job to OUTPUT.msh.
set -euo pipefail
. "$(dirname "$0")/common.sh"
[ $# -eq 2 ] || { echo "usage: $0 JOB_ID OUTPUT.msh" >&2; exit 2; }
tmp="$2.part"
status=$(request "$tmp" "${HOCURVE_URL}/v1/jobs/$1/result")
if [ "$status" != 200 ]; then s="$status"; f=$(mktemp); mv "$tmp" "$f"; fail_with_problem "$f" "$s"; fi
mv "$tmp" "$2"
echo "wrote $2" >&2
