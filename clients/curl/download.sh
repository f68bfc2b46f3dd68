#!/usr/bin/env bash
# Usage: download.sh JOB_ID OUTPUT.msh   Streams the result of a succeeded job to OUTPUT.msh.
# It goes to OUTPUT.msh.part, renamed once it has the full length. A dropped connection or a short
# read is resumed (curl -C -: Range: bytes=N-, with If-Range: the first answer's ETag), up to
# HOCURVE_DOWNLOAD_ATTEMPTS tries (5) with backoff (1, 2, 4, 8 s); a 200 to a resumed request (the
# result changed) starts over. curl's own --retry repeats transient answers (429, 5xx) in a try.
set -euo pipefail
. "$(dirname "$0")/common.sh"
[ $# -eq 2 ] || { echo "usage: $0 JOB_ID OUTPUT.msh" >&2; exit 2; }
tmp="$2.part"
hdr=$(mktemp)
trap 'rm -f "$hdr"' EXIT
: > "$tmp"
etag="" delay=1 rc=0
for attempt in $(seq "${HOCURVE_DOWNLOAD_ATTEMPTS:-5}"); do
  if [ "$attempt" -gt 1 ]; then sleep "$delay"; delay=$((delay * 2)); fi
  had=$(stat -c %s "$tmp")
  if_range=()
  if [ "$had" -gt 0 ]; then if_range=(-H "If-Range: $etag"); fi
  rc=0
  status=$(request "$tmp" -C - --retry 2 -D "$hdr" "${if_range[@]}" "${HOCURVE_URL}/v1/jobs/$1/result") || rc=$?
  if [ "$rc" = 33 ] || { [ "$had" -gt 0 ] && [ "$status" -ge 300 ]; }; then
    : > "$tmp"  # not a part of the version we hold (curl refuses a 200 to a resume): start over
    continue
  fi
  if [ "$rc" = 0 ] && [ "$status" -ge 300 ]; then f=$(mktemp); mv "$tmp" "$f"; fail_with_problem "$f" "$status"; fi
  if [ "$status" -ge 200 ]; then etag=$(header_value "$hdr" ETag); fi
  if [ -z "$etag" ]; then : > "$tmp"; fi  # no version to resume against
  if [ "$rc" = 0 ] && body_complete "$tmp" "$hdr"; then
    mv "$tmp" "$2"
    echo "wrote $2" >&2
    exit 0
  fi
done
rm -f "$tmp"
echo "error: download of $1 failed after ${HOCURVE_DOWNLOAD_ATTEMPTS:-5} attempts (curl exit $rc)" >&2
exit 1
