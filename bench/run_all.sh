#!/usr/bin/env bash
# `make bench`: runs the main benchmarks from one build, in one go, and writes what each printed to
# bench/results/NAME.md (with its command, the commit and the seconds it took; stderr in NAME.log).
# Then the section between the "results" markers of bench/README.md is rewritten from those files:
# the tables shown there come from this one run.
#
# Usage: bench/run_all.sh [BUILD_DIR] [--all] [--no-readme]
#   --all        also the long sweeps (transform_sweep.py, fillets.py, isosurface.py, bench_coarse)
#   --no-readme  leave bench/README.md alone
# Environment: BENCH_ONLY="accuracy speed" runs only the benchmarks named.
set -uo pipefail
cd "$(dirname "$0")/.."
BUILD=build ALL=0 README=1
for a in "$@"; do
  case "$a" in
    --all) ALL=1 ;;
    --no-readme) README=0 ;;
    -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
    *) BUILD=$a ;;
  esac
done
PY=/usr/bin/python3  # Debian's interpreter: it has gmsh, numpy and meshio
OUT=bench/results
HOCURVE=$BUILD/hocurve
[ -x "$HOCURVE" ] || { echo "bench: no $HOCURVE (make build first)" >&2; exit 2; }
mkdir -p "$OUT"
COMMIT=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
git diff --quiet 2>/dev/null || COMMIT="$COMMIT (modified)"
FAILED=0
RAN=""  # the benchmarks of this run: only their tables go into bench/README.md

# run NAME KIND COMMAND...: KIND "tables" (markdown tables on stdout) or "text" (kept as a code block).
run() {
  local name=$1 kind=$2; shift 2
  case " ${BENCH_ONLY:-$name} " in *" $name "*) ;; *) return 0 ;; esac
  local file="$OUT/$name.md" start rc secs
  {
    echo "### $name"
    echo
    echo "\`$*\` — hocurve $COMMIT, $(nproc) cores"
    echo
    [ "$kind" = text ] && echo '```'
  } >"$file"
  echo "bench: $name ..." >&2
  RAN="$RAN $name"
  start=$(date +%s)
  nice -n 10 "$@" >>"$file" 2>"$OUT/$name.log"
  rc=$?
  secs=$(($(date +%s) - start))
  {
    [ "$kind" = text ] && echo '```'
    echo
    if [ $rc -eq 0 ]; then echo "(took $secs s)"; else echo "(FAILED with exit code $rc after $secs s: see $name.log)"; fi
  } >>"$file"
  [ $rc -eq 0 ] || FAILED=1
  echo "bench: $name rc $rc, $secs s -> $file" >&2
}

# The main benchmarks.
run read text "$BUILD/bench_read" /tmp/hocurve-bench-read 200000,2400000
run accuracy tables $PY bench/accuracy.py --hocurve "$HOCURVE" --orders 1,2,3,4,6
run speed tables $PY bench/speed.py --hocurve "$HOCURVE"
run cad_sweep tables $PY bench/cad_sweep.py --hocurve "$HOCURVE"
[ -f bench/cad_bench.py ] && run cad_bench tables $PY bench/cad_bench.py --hocurve "$HOCURVE"
[ -f bench/volume.py ] && run volume tables $PY bench/volume.py --hocurve "$HOCURVE"
run lift text "$BUILD/bench_lift" all
run load text $PY bench/load.py "$BUILD"
# The long sweeps.
if [ $ALL = 1 ]; then
  run transform_sweep tables $PY bench/transform_sweep.py --hocurve "$HOCURVE"
  run fillets tables $PY bench/fillets.py --hocurve "$HOCURVE"
  run isosurface tables $PY bench/isosurface.py --hocurve "$HOCURVE" --orders 2,4,6
  run coarse text "$BUILD/bench_coarse"
fi

# bench/README.md: the section between the markers, from this run's files (tables only for the
# table benchmarks: their progress lines stay in bench/results).
if [ $README = 1 ]; then
  $PY - "$OUT" "$COMMIT" $RAN <<'EOF'
import os, re, sys
out, commit, ran = sys.argv[1], sys.argv[2], set(sys.argv[3:])
order = ["read", "accuracy", "speed", "cad_sweep", "cad_bench", "volume", "lift", "load",
         "transform_sweep", "fillets", "isosurface", "coarse"]
parts = []
for name in order:
    path = os.path.join(out, name + ".md")
    if name not in ran or not os.path.exists(path):
        continue
    lines = open(path).read().splitlines()
    head, body = lines[:4], lines[4:]
    if "```" in body:  # a text benchmark: kept whole
        parts.append("\n".join(head + body))
        continue
    kept, last = [], None
    for l in body:
        if l.startswith("|"):
            if last is not None and not last.startswith("|"):
                kept.append("")
            kept.append(l)
        elif l.startswith("(took") or l.startswith("(FAILED"):
            kept += ["", l]
        last = l
    parts.append("\n".join(head + kept))
readme = "bench/README.md"
text = open(readme).read()
begin, end = "<!-- results:begin -->", "<!-- results:end -->"
if begin not in text or end not in text:
    sys.exit("bench: no results markers in bench/README.md")
intro = "From one run of `make bench` (bench/run_all.sh) at hocurve %s; its outputs are in bench/results/." % commit
new = text[: text.index(begin) + len(begin)] + "\n\n" + intro + "\n\n" + "\n\n".join(parts) + "\n\n" + text[text.index(end):]
open(readme, "w").write(new)
print("bench: bench/README.md results section rewritten", file=sys.stderr)
EOF
fi
exit $FAILED
