#!/usr/bin/env bash
# Usage: curve_sync.sh MESH OUTPUT.msh [option=value ...]   Synchronous POST /v1/curve (small meshes).
set -euo pipefail
. "$(dirname "$0")/common.sh"
[ $# -ge 2 ] || { echo "usage: $0 MESH OUTPUT.msh [option=value ...]" >&2; exit 2; }
mesh="$1"; out="$2"; shift 2
query=$(IFS='&'; echo "$*")
status=$(request "$out.part" -H "Content-Type: application/octet-stream" --data-binary "@${mesh}" \
         "${HOCURVE_URL}/v1/curve?${query}")
if [ "$status" != 200 ]; then f=$(mktemp); mv "$out.part" "$f"; fail_with_problem "$f" "$status"; fi
mv "$out.part" "$out"
echo "wrote $out" >&2
