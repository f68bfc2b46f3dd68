#!/usr/bin/env bash
# Smoke test of the built image: runs its daemon, curves one mesh through it and checks the result.
# Usage: docker/smoke_test.sh [IMAGE] [MESH] [ORDER]
#   IMAGE  default localhost/hocurve:latest (docker/build.sh)
#   MESH   default examples/torus.stl (a closed torus, R = 1, r = 0.4, z axis)
#   ORDER  default 3
# Environment: MODE=auto|run|chroot (auto: `podman run`, and when the OCI runtime cannot start a
# container on this machine — e.g. it may not set rlimits — the image's exported filesystem in a
# chroot), PORT (loopback port; default: a free one), KEEP=1 keeps the work directory,
# RUN_OPTS (extra `podman run` options, word-split; e.g. where crun refuses a hybrid cgroup tree and
# rlimits cannot be raised: RUN_OPTS="--runtime runc --ulimit nofile=20000:20000 --ulimit nproc=4096:4096",
# and "--read-only --tmpfs /tmp --cap-drop ALL --security-opt no-new-privileges" to run the image
# hardened as docker/compose.yaml and docker/k8s/ do).
# The daemon runs as the image says (entrypoint, user, environment, working directory) except that
# it listens on 127.0.0.1:PORT. Steps: /readyz, /healthz, /v1/info; POST /v1/jobs with the curl
# client scripts, poll, download; the .msh read back with Gmsh (/usr/bin/python3) and checked against
# the input's own topology and geometry; /metrics; the image's HEALTHCHECK; SIGTERM (clean exit);
# a restart on the same data directory still serves the finished job. Exits non-zero on any failure.
# Needs root, podman, curl, util-linux (unshare, nsenter) and /usr/bin/python3 with gmsh and numpy.
set -euo pipefail
cd "$(dirname "$0")/.."
IMAGE="${1:-localhost/hocurve:latest}"
MESH="${2:-examples/torus.stl}"
ORDER="${3:-3}"
MODE="${MODE:-auto}"
read -r -a RUN_OPTS <<<"${RUN_OPTS:-}"
PY=/usr/bin/python3
name="hocurve-smoke-$$"
WORK=$(mktemp -d /tmp/hocurve-smoke.XXXXXX)
LOG="$WORK/daemon.log"
daemon_pid=""   # host pid of hocurved
holder_pid=""   # chroot mode: the unshare process holding the daemon's namespaces
container=""    # run mode: the container name

say() { echo "smoke: $*"; }
since() { "$PY" -c 'import sys, time; print(f"{time.time() - float(sys.argv[1]):.2f}")' "$1"; }
fail() {
  echo "smoke: FAIL: $*" >&2
  if [ -s "$LOG" ]; then echo "smoke: last daemon log lines:" >&2; tail -n 20 "$LOG" >&2; fi
  exit 1
}
cleanup() {
  if [ -n "$container" ]; then
    podman rm -f -t 5 "$container" >/dev/null 2>&1 || true
    podman volume rm -f "$name-data" >/dev/null 2>&1 || true
  fi
  if [ -n "$holder_pid" ] && kill -0 "$holder_pid" 2>/dev/null; then
    [ -n "$daemon_pid" ] && kill -KILL "$daemon_pid" 2>/dev/null || true
    wait "$holder_pid" 2>/dev/null || true
  fi
  if [ "${KEEP:-0}" = 1 ]; then say "work directory kept: $WORK"; else rm -rf "$WORK"; fi
}
trap cleanup EXIT

for tool in podman curl unshare nsenter; do
  command -v "$tool" >/dev/null || fail "'$tool' is not installed"
done
[ -r "$MESH" ] || fail "no mesh '$MESH'"
"$PY" -c 'import gmsh, numpy' 2>/dev/null || fail "$PY has no gmsh/numpy (apt-get install python3-gmsh python3-numpy)"
podman image exists "$IMAGE" || fail "no image '$IMAGE' (run docker/build.sh)"
PORT="${PORT:-$("$PY" -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')}"
export HOCURVE_URL="http://127.0.0.1:$PORT"

# ---- the image's own run configuration ------------------------------------------------------------
fmt() { podman image inspect --format "$1" "$IMAGE"; }
IMG_USER=$(fmt '{{.Config.User}}')
IMG_WORKDIR=$(fmt '{{.Config.WorkingDir}}')
mapfile -t IMG_ENV < <(fmt '{{range .Config.Env}}{{println .}}{{end}}' | sed '/^$/d')
mapfile -t IMG_ENTRY < <(fmt '{{range .Config.Entrypoint}}{{println .}}{{end}}' | sed '/^$/d')
mapfile -t IMG_HEALTH < <(fmt '{{if .Config.Healthcheck}}{{range .Config.Healthcheck.Test}}{{println .}}{{end}}{{end}}' | sed '/^$/d')
IMG_PORT=$(fmt '{{range $p, $_ := .Config.ExposedPorts}}{{$p}}{{end}}'); IMG_PORT="${IMG_PORT%%/*}"
[ -n "$IMG_USER" ] && [ "${IMG_USER%%:*}" != 0 ] && [ "${IMG_USER%%:*}" != root ] || fail "image runs as root (User='$IMG_USER')"
[ ${#IMG_ENTRY[@]} -ge 1 ] || fail "image has no entrypoint"
[ ${#IMG_HEALTH[@]} -ge 2 ] || fail "image has no HEALTHCHECK (built without --format docker?)"
[ -n "$IMG_PORT" ] || fail "image exposes no port"
say "image $IMAGE: user $IMG_USER, entrypoint ${IMG_ENTRY[*]}, port $IMG_PORT, healthcheck ${IMG_HEALTH[*]}"

# ---- starting and stopping the daemon -------------------------------------------------------------
# podman without systemd (as here) cannot add the transient timer that runs the HEALTHCHECK
# periodically and says so on every start/stop; those lines are dropped, everything else is shown.
pm() {
  local rc=0
  podman "$@" 2>"$WORK/podman.err" || rc=$?
  grep -v 'unable to get systemd connection' "$WORK/podman.err" >&2 || true
  return $rc
}
start_run() {  # podman run; returns non-zero when the OCI runtime cannot start the container
  container="$name"
  podman rm -f "$container" >/dev/null 2>&1 || true
  pm run -d --name "$container" -p "127.0.0.1:$PORT:$IMG_PORT" -v "$name-data:/var/lib/hocurve" \
    "${RUN_OPTS[@]}" "$IMAGE" >/dev/null || return 1
  daemon_pid=$(podman inspect --format '{{.State.Pid}}' "$container")
  podman logs -f "$container" >"$LOG" 2>&1 &
}
restart_run() {
  pm start "$container" >/dev/null
  daemon_pid=$(podman inspect --format '{{.State.Pid}}' "$container")
  podman logs -f --since 1s "$container" >>"$LOG" 2>&1 &
}
stop_run() {  # SIGTERM (podman stop), exit status of the daemon in $stop_status
  pm stop -t 40 "$container" >/dev/null
  stop_status=$(podman inspect --format '{{.State.ExitCode}}' "$container")
}

ROOTFS="$WORK/rootfs"
export_rootfs() {
  mkdir -p "$ROOTFS"
  local cid
  cid=$(podman create "$IMAGE")
  podman export "$cid" | tar -C "$ROOTFS" --numeric-owner -xpf -
  pm rm -v "$cid" >/dev/null   # -v: also the anonymous volume of the image's VOLUME
  say "exported the image filesystem to $ROOTFS ($(du -sh "$ROOTFS" | cut -f1))"
}
start_chroot() {
  # Private mount and pid namespaces (the daemon is pid 1 there, as in a container; everything is
  # unmounted and killed when it exits); the host network, so it listens on host loopback.
  cat >"$WORK/enter.sh" <<'EOF'
set -e
root="$1" userspec="$2" workdir="$3"; shift 3
mount -t proc proc "$root/proc"
mount -t tmpfs -o mode=0755,size=64k tmpfs "$root/dev"
for d in null:3 zero:5 full:7 random:8 urandom:9; do mknod -m 0666 "$root/dev/${d%%:*}" c 1 "${d##*:}"; done
mount -t tmpfs -o mode=1777 tmpfs "$root/tmp"
exec chroot --userspec="$userspec" "$root" /usr/bin/env -i -C "${workdir:-/}" "$@"
EOF
  unshare --mount --propagation private --pid --fork \
    bash "$WORK/enter.sh" "$ROOTFS" "$IMG_USER" "$IMG_WORKDIR" "${IMG_ENV[@]}" \
    "${IMG_ENTRY[@]}" --host 127.0.0.1 --port "$PORT" >>"$LOG" 2>&1 &
  holder_pid=$!
  for _ in $(seq 1 50); do
    daemon_pid=$(pgrep -P "$holder_pid" || true)
    [ -n "$daemon_pid" ] && break
    sleep 0.1
  done
  [ -n "$daemon_pid" ] || fail "the chrooted daemon did not start"
}
stop_chroot() {
  kill -TERM "$daemon_pid"
  stop_status=0
  wait "$holder_pid" || stop_status=$?
  holder_pid=""
}

start() { if [ "$MODE" = run ]; then start_run || fail "podman run failed"; else start_chroot; fi; }
restart() { if [ "$MODE" = run ]; then restart_run; else start_chroot; fi; }
stop() { if [ "$MODE" = run ]; then stop_run; else stop_chroot; fi; }

wait_ready() {
  local code=""
  for _ in $(seq 1 300); do
    code=$(curl -s -o /dev/null -w '%{http_code}' "$HOCURVE_URL/readyz" || true)
    [ "$code" = 200 ] && return 0
    if [ "$MODE" = chroot ]; then kill -0 "$holder_pid" 2>/dev/null || fail "the daemon exited"; fi
    sleep 0.1
  done
  fail "/readyz did not answer 200 within 30 s (last status '$code')"
}

case "$MODE" in
  auto)
    if start_run; then MODE=run
    else
      say "podman run cannot start the container here; falling back to a chroot into the exported image"
      podman rm -f "$container" >/dev/null 2>&1 || true
      podman volume rm -f "$name-data" >/dev/null 2>&1 || true
      container=""
      MODE=chroot
      export_rootfs
      start_chroot
    fi ;;
  run) start ;;
  chroot) export_rootfs; start ;;
  *) fail "MODE must be auto, run or chroot" ;;
esac
t0=$(date +%s.%N)
wait_ready
say "mode $MODE: daemon pid $daemon_pid ready on $HOCURVE_URL after $(since "$t0") s"
uid=$(awk '/^Uid:/{print $2}' "/proc/$daemon_pid/status")
[ "$uid" = "${IMG_USER%%:*}" ] || fail "the daemon runs as uid $uid, not ${IMG_USER%%:*}"

# ---- probes and info --------------------------------------------------------------------------------
curl -fsS "$HOCURVE_URL/healthz" | grep -q '"ok"' || fail "/healthz"
curl -fsS "$HOCURVE_URL/v1/info" >"$WORK/info.json" || fail "/v1/info"
say "/healthz ok, /readyz 200, /v1/info: $(head -c 160 "$WORK/info.json")..."

# ---- one job through the curl client scripts ------------------------------------------------------
t_submit=$(date +%s.%N)
id=$(clients/curl/submit.sh "$MESH" "order=$ORDER") || fail "submit"
clients/curl/poll.sh "$id" 300 >"$WORK/job.json" 2>>"$WORK/poll.err" || fail "job $id did not succeed: $(cat "$WORK/job.json")"
job_seconds=$(since "$t_submit")
clients/curl/download.sh "$id" "$WORK/result.msh" 2>/dev/null || fail "download of $id"
result_bytes=$(stat -c %s "$WORK/result.msh")
say "job $id: succeeded, submit-to-succeeded ${job_seconds} s (polled every 0.5 s), result $result_bytes bytes"

# ---- the result, read back with Gmsh and checked against the input mesh --------------------------
"$PY" - "$MESH" "$WORK/result.msh" "$ORDER" <<'EOF' || fail "result check"
import struct, sys
import numpy as np
import gmsh

stl, msh, order = sys.argv[1], sys.argv[2], int(sys.argv[3])
data = open(stl, "rb").read()
nf = struct.unpack_from("<I", data, 80)[0]
assert len(data) == 84 + 50 * nf, "the smoke test expects a binary STL"
facets = np.frombuffer(data, np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]), nf, 84)
verts, tri = np.unique(facets["v"].reshape(-1, 3).astype(float), axis=0, return_inverse=True)
tri = tri.reshape(-1, 3)
edges = {tuple(sorted(e)) for t in tri for e in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
V, E, F = len(verts), len(edges), nf
want_nodes = V + (order - 1) * E + (order - 1) * (order - 2) // 2 * F

gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.open(msh)
types, _, conn = gmsh.model.mesh.getElements(2)
assert len(types) == 1, f"expected one triangle type, got {list(types)}"
_, dim, el_order, nn, _, _ = gmsh.model.mesh.getElementProperties(types[0])
assert dim == 2 and el_order == order and nn == (order + 1) * (order + 2) // 2, (dim, el_order, nn)
conn = np.asarray(conn[0], dtype=np.int64).reshape(-1, nn)
assert len(conn) == F, f"{len(conn)} triangles, the input has {F}"
used = np.unique(conn)
assert len(used) == want_nodes, f"{len(used)} nodes, a conforming P{order} mesh of V={V} E={E} F={F} has {want_nodes}"
tags, xyz, _ = gmsh.model.mesh.getNodes()
pos = np.zeros((int(tags.max()) + 1, 3))
pos[tags] = np.asarray(xyz).reshape(-1, 3)
gmsh.finalize()

# Edge-interior nodes (Gmsh order: corners, then edges 0-1, 1-2, 2-0) against their straight chord.
a, b = pos[conn[:, [0, 1, 2]]], pos[conn[:, [1, 2, 0]]]
k = order - 1
mid = pos[conn[:, 3:3 + 3 * k]].reshape(-1, 3, k, 3)
d = b - a
t = np.einsum("fekx,fex->fek", mid - a[:, :, None], d) / np.einsum("fex,fex->fe", d, d)[:, :, None]
chord = a[:, :, None] + t[..., None] * d[:, :, None]
off = np.linalg.norm(mid - chord, axis=-1) / np.linalg.norm(d, axis=-1)[:, :, None]
assert off.max() > 1e-3, f"edge nodes lie on the chords (max offset {off.max():.2e}): nothing was curved"
assert off.max() < 0.5, f"edge node {off.max():.2f} edge lengths off its chord"
print(f"smoke: result: P{order}, {len(conn)} triangles, {len(used)} nodes (= V + {k}E + "
      f"{k * (k - 1) // 2}F), edge nodes up to {off.max():.3f} edge lengths off their chords")

# When the input samples a z-axis torus around the origin (examples/torus.stl), the curved nodes
# must lie closer to it than the straight chord points they replace.
rho = np.hypot(verts[:, 0], verts[:, 1])
sol = np.linalg.lstsq(np.c_[rho, np.ones_like(rho)], rho**2 + verts[:, 2]**2, rcond=None)[0]
R = sol[0] / 2
r = np.sqrt(max(sol[1] + R * R, 0.0))
dist = lambda p: np.abs(np.hypot(np.hypot(p[..., 0], p[..., 1]) - R, p[..., 2]) - r)
if r > 0 and dist(verts).max() < 1e-6 * R:
    on, straight = dist(mid).mean(), dist(chord).mean()
    assert on < 0.1 * straight, f"curved edge nodes {on:.2e} from the torus, chords {straight:.2e}"
    print(f"smoke: torus R={R:.4f} r={r:.4f}: mean distance of edge nodes {on:.2e}, of straight chord points {straight:.2e}")
EOF

# ---- metrics --------------------------------------------------------------------------------------
curl -fsS "$HOCURVE_URL/metrics" >"$WORK/metrics.txt" || fail "/metrics"
metric() { awk -v m="$1" '$1 == m {print $2}' "$WORK/metrics.txt"; }
[ "$(metric 'hocurve_jobs_finished_total{state="succeeded"}')" = 1 ] || fail "metrics do not count the succeeded job"
[ "$(metric hocurve_ready)" = 1 ] || fail "metrics: hocurve_ready is not 1"
[ "$(metric hocurve_upload_bytes_total)" = "$(stat -c %s "$MESH")" ] || fail "metrics: upload bytes != mesh size"
[ "$(metric hocurve_download_bytes_total)" -ge "$result_bytes" ] || fail "metrics: download bytes < result size"
say "/metrics: succeeded 1, ready 1, upload $(metric hocurve_upload_bytes_total) B, download $(metric hocurve_download_bytes_total) B"

# ---- the image's HEALTHCHECK, run inside the container (or the chroot, on the test port) ----------
if [ "$MODE" = run ]; then
  podman healthcheck run "$container" >/dev/null || fail "HEALTHCHECK reports unhealthy"
else
  case "${IMG_HEALTH[0]}" in
    CMD-SHELL) hc=(/bin/sh -c "${IMG_HEALTH[1]//:$IMG_PORT/:$PORT}") ;;
    CMD) hc=("${IMG_HEALTH[@]:1}"); hc=("${hc[@]//:$IMG_PORT/:$PORT}") ;;
    *) fail "unexpected HEALTHCHECK ${IMG_HEALTH[*]}" ;;
  esac
  nsenter --target "$daemon_pid" --mount --root --wd --setuid "${IMG_USER%%:*}" --setgid "${IMG_USER##*:}" \
    "${hc[@]}" >/dev/null || fail "HEALTHCHECK '${hc[*]}' failed inside the chroot"
fi
say "HEALTHCHECK passes"

# ---- SIGTERM, then a restart on the same data directory ----------------------------------------
t_stop=$(date +%s.%N)
stop
[ "$stop_status" = 0 ] || fail "the daemon exited with status $stop_status after SIGTERM"
say "SIGTERM: clean exit in $(since "$t_stop") s"
restart
wait_ready
curl -fsS "$HOCURVE_URL/v1/jobs/$id" | grep -q '"status": *"succeeded"' || fail "job $id is not listed as succeeded after the restart"
curl -fsS -o "$WORK/again.msh" "$HOCURVE_URL/v1/jobs/$id/result" || fail "result of $id after the restart"
cmp -s "$WORK/result.msh" "$WORK/again.msh" || fail "the result changed across the restart"
stop
[ "$stop_status" = 0 ] || fail "the daemon exited with status $stop_status after the second SIGTERM"
say "restart on the same data directory: job $id still succeeded, same result"
say "OK (mode $MODE, P$ORDER $(basename "$MESH"): job ${job_seconds} s, result $result_bytes bytes)"
