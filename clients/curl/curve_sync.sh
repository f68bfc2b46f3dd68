#!/usr/bin/env bash
# Usage: curve_sync.sh MESH OUTPUT.msh [option=value ...]   Synchronous POST /v1/curve (small meshes).
# The answer goes to OUTPUT.msh.part, renamed once it has the full length. A POST is not resumed:
# an answer cut short (curl exit 18, or fewer bytes than its Content-Length) is an error, exit 1,
# and OUTPUT.msh is not written; retry, or use submit.sh + poll.sh + download.sh, which resumes.
set -euo pipefail
. "$(dirname "$0")/common.sh"
[ $# -ge 2 ] || { echo "usage: $0 MESH OUTPUT.msh [option=value ...]" >&2; exit 2; }
mesh="$1"; out="$2"; shift 2
query=$(IFS='&'; echo "$*")
url="${HOCURVE_URL}/v1/curve?${query}"
hdr=$(mktemp)
trap 'rm -f "$hdr" "$out.part"' EXIT
rc=0
status=$(request "$out.part" -D "$hdr" -H "Content-Type: application/octet-stream" --data-binary "@${mesh}" \
         "$url") || rc=$?
if [ "$status" != 200 ]; then
  [ "$rc" = 0 ] || exit "$rc"  # no answer: curl said why
  f=$(mktemp); mv "$out.part" "$f"; fail_with_problem "$f" "$status"
fi
if [ "$rc" != 0 ] || ! body_complete "$out.part" "$hdr"; then
  length=$(full_length "$hdr")
  echo "error: POST $url: the answer ended early (curl exit $rc: $(stat -c %s "$out.part")${length:+ of $length}" \
       "bytes); $out not written; a POST is not resumed: retry, or use the job API (submit.sh, poll.sh," \
       "download.sh), whose download resumes" >&2
  exit 1
fi
mv "$out.part" "$out"
echo "wrote $out" >&2
