#!/usr/bin/env bash
# Usage: runtime-packages.sh PROGRAM...
# Prints, one a line, the Debian packages that own the shared libraries PROGRAM... load (as ldd
# resolves them), so the runtime image installs exactly those. Fails when a library belongs to no
# package (a locally built library would be missing from the image).
# Debian 12 has a merged /usr but dpkg still records some libraries under /lib (libc6, zlib1g...)
# and others under /usr/lib: each library is looked up under its ldd path, that path with /usr added
# or removed, and its resolved real path.
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: $0 PROGRAM..." >&2; exit 2; }
libs=$(ldd "$@" | awk '$2 == "=>" && $3 ~ /^\// {print $3} $1 ~ /^\// && $2 ~ /^\(/ {print $1}' | sort -u)
[ -n "$libs" ] || { echo "runtime-packages: ldd found no shared library in $*" >&2; exit 1; }
for lib in $libs; do
  real=$(readlink -f "$lib")
  owner=""
  for p in "$lib" "${lib#/usr}" "/usr$lib" "$real" "${real#/usr}"; do
    if owner=$(dpkg-query -S "$p" 2>/dev/null); then break; fi
  done
  [ -n "$owner" ] || { echo "runtime-packages: no Debian package owns $lib" >&2; exit 1; }
  # "libc6:amd64: /lib/x86_64-linux-gnu/libc.so.6" -> libc6
  echo "${owner%%:*}"
done | sort -u
