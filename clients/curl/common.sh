# Shared settings of the curl client scripts (sourced). HOCURVE_URL: server base URL;
# HOCURVE_TOKEN: optional bearer token. Errors are RFC 9457 problem+json, printed to stderr.
HOCURVE_URL="${HOCURVE_URL:-http://127.0.0.1:8080}"
AUTH=()
if [ -n "${HOCURVE_TOKEN:-}" ]; then AUTH=(-H "Authorization: Bearer ${HOCURVE_TOKEN}"); fi
CURL=(curl -sS --connect-timeout 10 --max-time 600 "${AUTH[@]}")

# json_field NAME: the first string or number value of "NAME" in the JSON on stdin (flat fields only).
json_field() {
  grep -o "\"$1\":[[:space:]]*\(\"[^\"]*\"\|[-0-9.eE+]*\)" | head -n1 | sed -e "s/^\"$1\":[[:space:]]*//" -e 's/^"//' -e 's/"$//'
}

# json_string NAME: the first string value of "NAME" (skips numbers, e.g. a problem's numeric status).
json_string() {
  grep -o "\"$1\":[[:space:]]*\"[^\"]*\"" | head -n1 | sed -e "s/^\"$1\":[[:space:]]*\"//" -e 's/"$//'
}

# request OUTFILE CURL_ARGS...: runs curl, writes the body to OUTFILE, prints the HTTP status.
request() {
  local out="$1"; shift
  "${CURL[@]}" -o "$out" -w '%{http_code}' "$@"
}

# fail_with_problem FILE STATUS: shows a problem document and exits 1.
fail_with_problem() {
  echo "error: HTTP $2" >&2
  cat "$1" >&2
  echo >&2
  exit 1
}

# header_value FILE NAME: the value of the last NAME header in a curl -D dump (empty if none).
header_value() {
  { grep -i "^$2:" "$1" || true; } | tail -n1 | sed -e 's/^[^:]*:[[:space:]]*//' -e 's/\r$//'
}

# full_length FILE: the full length of the answer in a curl -D dump: Content-Range's total for a
# part, else Content-Length.
full_length() {
  local range
  range=$(header_value "$1" Content-Range)
  if [ -n "$range" ]; then echo "${range##*/}"; else header_value "$1" Content-Length; fi
}

# body_complete FILE HEADERS: true if FILE holds the full length announced in the curl -D dump
# HEADERS (always, if it announced none: a chunked answer's end is curl's to check, exit 18).
body_complete() {
  local length
  length=$(full_length "$2")
  [ -z "$length" ] || [ "$(stat -c %s "$1")" = "$length" ]
}
