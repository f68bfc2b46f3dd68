#!/usr/bin/python3
"""End-to-end check of `hocurve coarsen`, read back independently with Gmsh's Python module.

Input: the shared exact torus (axis y, R=1, r=0.25, 4608 triangles, every vertex on the torus).
Runs the command exactly as the daemon does for mode=coarsen (INPUT -o OUT --order P --faces N
--stats S --progress), then asserts: exit code 0; progress lines are JSON {stage, fraction} with
fractions non-decreasing up to 1; the .msh holds one element type, Gmsh's P4 triangle (23), as
many elements as the stats report and close to the target; watertight/conforming (every element
edge's node set is shared by exactly two elements, since the torus is closed); every node lies on
the exact torus closer than the dense input's own facets do (facet-centre distance); the stats
report 0 invalid elements. Also --ratio with msh22 binary, a raw Thingi10K file with non-manifold
vertices (split and coarsened), a cube with an inner wall (non-manifold edges: cut, coarsened,
joined again), and usage errors (exit 2) / refused input (exit 3: empty, a Moebius band) leave no
output file.

Usage: test_coarsen_cli.py BUILD_DIR
"""
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

import gmsh
import numpy as np

failures = []


def check(cond, what):
    print(("ok    " if cond else "FAIL  ") + what, flush=True)
    if not cond:
        failures.append(what)


def torus_distance(p, R=1.0, r=0.25):
    """Distance to the shared torus: axis y (its bounding box is 2.5 x 0.5 x 2.5)."""
    q = np.hypot(p[:, 0], p[:, 2]) - R
    return np.abs(np.hypot(q, p[:, 1]) - r)


def read_msh(path):
    """Element types, connectivity of the triangle elements and node coordinates by tag."""
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(path)
        types, _, conns = gmsh.model.mesh.getElements(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        xyz = dict(zip(tags.tolist(), np.asarray(coords).reshape(-1, 3)))
        return list(types), conns, xyz
    finally:
        gmsh.finalize()


def coarsen_p4(hoc, src, work, name, ratio):
    """`hocurve coarsen SRC --order 4 --ratio RATIO --stats`: (process, stats, element types, connectivity);
    the last three None when it failed."""
    out, stats = os.path.join(work, name + ".msh"), os.path.join(work, name + ".json")
    r = subprocess.run([hoc, "coarsen", src, "-o", out, "--order", "4", "--ratio", str(ratio), "--stats", stats],
                       capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        return r, None, None, None
    types, conns, _ = read_msh(out)
    with open(stats) as f:
        return r, json.load(f), types, conns


def edge_sets(conn, p):
    """For each element edge, the frozenset of its p+1 node tags (Gmsh order: 3 corners, then the
    p-1 nodes of edges 0-1, 1-2, 2-0)."""
    counts = {}
    for el in conn:
        for j in range(3):
            key = frozenset([el[j], el[(j + 1) % 3]] + list(el[3 + j * (p - 1):3 + (j + 1) * (p - 1)]))
            counts[key] = counts.get(key, 0) + 1
    return counts


def main(argv):
    build = argv[1] if len(argv) > 1 else os.environ.get("HOCURVE_BUILD_DIR", "build")
    hoc = os.path.join(build, "hocurve")
    shared = os.environ.get("HOCURVE_SHARED_DIR", os.path.join(os.path.dirname(__file__), "../../../shared"))
    src = os.path.join(shared, "meshes", "torus.obj")
    if not os.access(hoc, os.X_OK):
        print("FAIL  hocurve binary not found at %s (build the 'hocurve' target)" % hoc)
        return 1
    work = tempfile.mkdtemp(prefix="hocurve-coarsen-")
    out, stats = os.path.join(work, "t.msh"), os.path.join(work, "t.json")
    # The daemon's argv for {mode: coarsen, order: 4, faces: 300} (server/job_options.cpp worker_argv).
    r = subprocess.run([hoc, "coarsen", src, "-o", out, "--order", "4", "--faces", "300", "--stats", stats,
                        "--progress"], capture_output=True, text=True, timeout=300)
    check(r.returncode == 0, "coarsen exits 0 (stderr: %s)" % r.stderr.strip())
    if r.returncode != 0:
        return 1
    lines = [json.loads(x) for x in r.stdout.splitlines() if x.strip()]
    fr = [x["fraction"] for x in lines]
    check(all("stage" in x for x in lines) and fr == sorted(fr) and fr[-1] == 1.0,
          "progress: %d JSON lines, fractions non-decreasing to 1" % len(lines))
    s = json.load(open(stats))
    faces = s["lifting"]["faces"]
    check(s["lifting"]["validity"]["invalid_after"] == 0, "stats: 0 invalid elements")
    check(abs(faces - 300) <= 30, "coarse count %d near the 300 target (%s)" % (faces, s["decimation"]["message"]))

    types, conns, xyz = read_msh(out)
    check(types == [23], "one element type, Gmsh's P4 triangle (23): %s" % types)
    conn = np.asarray(conns[0], dtype=np.int64).reshape(-1, 15)
    check(len(conn) == faces, "%d elements read back, stats say %d" % (len(conn), faces))
    counts = edge_sets(conn, 4)
    check(all(c == 2 for c in counts.values()), "watertight: all %d element edges shared by exactly 2 elements"
          % len(counts))
    used = np.unique(conn)
    P = np.array([xyz[t] for t in used.tolist()])
    dn = torus_distance(P).max()
    # The dense input's own error: distance of its facet centres to the exact torus.
    V, T = [], []
    for line in open(src):
        w = line.split()
        if w and w[0] == "v":
            V.append([float(x) for x in w[1:4]])
        elif w and w[0] == "f":
            T.append([int(x.split("/")[0]) - 1 for x in w[1:4]])
    V, T = np.array(V), np.array(T)
    cent = (V[T[:, 0]] + V[T[:, 1]] + V[T[:, 2]]) / 3
    dd = torus_distance(cent).max()
    check(dn < dd, "coarse P4 nodes within %.2e of the exact torus, below the dense facets' %.2e" % (dn, dd))

    # --ratio, msh22 binary.
    out2 = os.path.join(work, "t22.msh")
    r = subprocess.run([hoc, "coarsen", src, "-o", out2, "--order", "3", "--ratio", "0.1", "--format", "msh22",
                        "--binary", "--threads", "1"], capture_output=True, text=True, timeout=300)
    check(r.returncode == 0, "coarsen --ratio 0.1 --format msh22 --binary exits 0 (%s)" % r.stderr.strip())
    if r.returncode == 0:
        types, conns, _ = read_msh(out2)
        n = len(conns[0]) // 10 if types == [21] else -1
        check(types == [21] and abs(n - 461) <= 46, "msh22 binary: P3 triangles (21), %d elements (~461)" % n)

    # Non-manifold vertices (raw Thingi10K part touching itself at 2 points): split, pinned, coarsened.
    nm = os.path.join(shared, "meshes", "thingi10k_449816.stl")
    r, s3, types, conns = coarsen_p4(hoc, nm, work, "nm", 0.3)
    check(r.returncode == 0, "non-manifold vertices: coarsen exits 0 (%s)" % r.stderr.strip())
    if r.returncode == 0:
        n = len(conns[0]) // 15 if types == [23] else -1
        check(s3["decimation"]["split_vertices"] == 2 and s3["lifting"]["validity"]["invalid_after"] == 0
              and n == s3["decimation"]["faces"] and n < 202,
              "non-manifold vertices: 2 split, %d P4 elements of 202 read back, 0 invalid" % n)
        # Its faces overlap at a pinch point: no collapse may give an edge a second pair of faces there.
        conn = np.asarray(conns[0]).reshape(-1, 15) if types == [23] else np.zeros((0, 15))
        uses = sorted(set(edge_sets(conn, 4).values()))
        check(uses == [2], "non-manifold vertices: every edge of the coarse mesh has two elements (uses %s)" % uses)

    # Non-manifold edges: a cube with an inner wall at z = 0.5, written one face at a time (every face
    # its own vertices: welded on reading). The wall's rim has three faces per edge: cut open into
    # pinned copies, coarsened, and joined again into one curve of three-element edges.
    wall, n = os.path.join(work, "wall.obj"), 8
    with open(wall, "w") as f:
        quads = []
        for axis in range(3):
            for side in (0.0, 1.0):
                for i in range(n):
                    for j in range(n):
                        c = [[(i + a) / n, (j + b) / n] for a, b in ((0, 0), (1, 0), (1, 1), (0, 1))]
                        quads.append([x[:axis] + [side] + x[axis:] for x in c])
        quads += [[[(i + a) / n, (j + b) / n, 0.5] for a, b in ((0, 0), (1, 0), (1, 1), (0, 1))]
                  for i in range(n) for j in range(n)]
        k = 0
        for q in quads:
            for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3])):
                f.write("".join("v %r %r %r\n" % tuple(x) for x in t) + "f %d %d %d\n" % (k + 1, k + 2, k + 3))
                k += 3
    r, s4, types, conns = coarsen_p4(hoc, wall, work, "wall", 0.3)
    check(r.returncode == 0, "non-manifold edges: coarsen exits 0 (%s)" % r.stderr.strip())
    if r.returncode == 0:
        conn = np.asarray(conns[0]).reshape(-1, 15) if types == [23] else np.zeros((0, 15))
        three = sum(1 for c in edge_sets(conn, 4).values() if c == 3)
        open_edges = sum(1 for c in edge_sets(conn, 4).values() if c == 1)
        check(s4["decimation"]["nonmanifold_edges"] == 4 * n and s4["rejoin"]["vertices"] == 8 * n
              and s4["rejoin"]["invalid_after"] == 0 and s4["lifting"]["validity"]["invalid_after"] == 0
              and three == 4 * n and open_edges == 0 and len(conn) < 8 * n * n,
              "non-manifold edges: %d three-element edges (want %d), %d open, %d P4 elements of %d, 0 invalid"
              % (three, 4 * n, open_edges, len(conn), 14 * n * n))

    # --max-deviation: bunny at 2% would cut the ears off; the limit stops early and says so.
    bunny = os.path.join(shared, "meshes", "bunny_closed.obj")
    counts = {}
    for dev in ("0.015", "0"):
        o, st = os.path.join(work, "b%s.msh" % dev), os.path.join(work, "b%s.json" % dev)
        r = subprocess.run([hoc, "coarsen", bunny, "-o", o, "--order", "4", "--ratio", "0.02", "--max-deviation", dev,
                            "--stats", st], capture_output=True, text=True, timeout=300)
        check(r.returncode == 0, "bunny 2%%, --max-deviation %s: exit 0 (%s)" % (dev, r.stderr.strip()))
        if r.returncode == 0:
            d = json.load(open(st))["decimation"]
            counts[dev] = (d["faces"], d["target_faces"], d["rejected"]["deviation"], d["reached_target"], r.stderr)
    if len(counts) == 2:
        f, t, nd, reached, err = counts["0.015"]
        check(not reached and f > t and nd > 0 and "warning: target not reached" in err and "deviation %d" % nd in err,
              "limit 0.015: stopped at %d faces (target %d), %d refused for deviation, warned on stderr" % (f, t, nd))
        f, t, nd, reached, err = counts["0"]
        check(reached and f <= t and nd == 0 and err == "", "no limit: %d faces (target %d), no warning" % (f, t))

    # --tolerance --redecimate 0: the elements furthest from the input split until within it (or the
    # faces run out).
    o, st = os.path.join(work, "btol.msh"), os.path.join(work, "btol.json")
    cap = int(0.05 * 6598)
    r = subprocess.run([hoc, "coarsen", bunny, "-o", o, "--order", "4", "--ratio", "0.04", "--tolerance", "0.005",
                        "--max-faces", str(cap), "--redecimate", "0", "--stats", st, "--progress"],
                       capture_output=True, text=True, timeout=300)
    check(r.returncode == 0, "bunny 4%%, --tolerance 0.005 --redecimate 0: exit 0 (%s)" % r.stderr.strip())
    if r.returncode == 0:
        fr = [json.loads(l)["fraction"] for l in r.stdout.splitlines() if l.startswith("{")]
        rounds = [l for l in r.stdout.splitlines() if "refine round" in l]
        check(len(rounds) > 0 and all(a <= b for a, b in zip(fr, fr[1:])) and fr[-1] == 1,
              "--tolerance --progress: %d refine rounds reported, fractions non-decreasing to 1" % len(rounds))
        s = json.load(open(st))
        rf, d = s["refinement"], s["decimation"]
        types, conns, _ = read_msh(o)
        conn = np.asarray(conns[0], dtype=np.int64).reshape(-1, 15)
        n_el = len(conn)
        open_edges = sum(1 for k in edge_sets(conn, 4).values() if k != 2)
        check(types == [23] and rf["splits"] > 0 and d["faces"] < n_el <= cap and n_el == s["lifting"]["faces"]
              and rf["deviation_after_relative"] < rf["deviation_before_relative"]
              and s["lifting"]["validity"]["invalid_after"] == 0 and open_edges == 0,
              "--tolerance: %d -> %d elements (cap %d), %d splits, largest deviation %.3f%% -> %.3f%%, watertight, 0 invalid"
              % (d["faces"], n_el, cap, rf["splits"], 100 * rf["deviation_before_relative"],
                 100 * rf["deviation_after_relative"]))

    # The default re-decimation: the same face count spent where the curved mesh strays; with the
    # tolerance the count grows (re-decimated) until it is met, within the cap.
    for extra, what in [([], "4%, re-decimated"), (["--tolerance", "0.005", "--max-faces", str(cap)], "4%, --tolerance")]:
        o, st = os.path.join(work, "brd.msh"), os.path.join(work, "brd.json")
        r = subprocess.run([hoc, "coarsen", bunny, "-o", o, "--order", "4", "--ratio", "0.04", "--stats", st,
                            "--progress"] + extra, capture_output=True, text=True, timeout=300)
        check(r.returncode == 0, "bunny %s: exit 0 (%s)" % (what, r.stderr.strip()))
        if r.returncode != 0:
            continue
        fr = [json.loads(l)["fraction"] for l in r.stdout.splitlines() if l.startswith("{")]
        s = json.load(open(st))
        rd, n_el = s["redecimation"], s["lifting"]["faces"]
        types, conns, _ = read_msh(o)
        conn = np.asarray(conns[0], dtype=np.int64).reshape(-1, 15)
        tol = 0.005 if extra else 0
        check(rd["rounds"] > 0 and rd["deviation_kept_relative"] < 0.8 * rd["deviation_first_relative"]
              and (n_el == 264 if not extra else 264 <= n_el <= cap and rd["deviation_kept_relative"] <= tol)
              and len(conn) == n_el and s["lifting"]["validity"]["invalid_after"] == 0
              and sum(1 for k in edge_sets(conn, 4).values() if k != 2) == 0
              and all(a <= b for a, b in zip(fr, fr[1:])) and fr[-1] == 1,
              "bunny %s: %d rounds, kept %d, largest deviation %.3f%% -> %.3f%%, %d elements, watertight, 0 invalid"
              % (what, rd["rounds"], rd["kept_round"], 100 * rd["deviation_first_relative"],
                 100 * rd["deviation_kept_relative"], n_el))

    # --min-jacobian: no coarse element nearer folding than the floor (certified Bezier bound).
    o, st = os.path.join(work, "bq.msh"), os.path.join(work, "bq.json")
    r = subprocess.run([hoc, "coarsen", bunny, "-o", o, "--order", "4", "--ratio", "0.04", "--min-jacobian", "0.1",
                        "--stats", st], capture_output=True, text=True, timeout=300)
    check(r.returncode == 0, "bunny 4%%, --min-jacobian 0.1: exit 0 (%s)" % r.stderr.strip())
    if r.returncode == 0:
        v = json.load(open(st))["lifting"]["validity"]
        check(v["invalid_after"] == 0 and v["min_scaled_jacobian"] > 0.1 and v["below_min_jacobian"] > 0,
              "--min-jacobian 0.1: %d elements below it moved, min J/J_straight %.3f" % (
                  v["below_min_jacobian"], v["min_scaled_jacobian"]))

    # Refusals: exit 2 (usage) and 3 (input), no output file left behind.
    bad = os.path.join(work, "bad.msh")
    for args, code, what in [(["--order", "4"], 2, "neither --faces nor --ratio"),
                             (["--order", "4", "--faces", "10", "--ratio", "0.1"], 2, "both --faces and --ratio"),
                             (["--order", "7", "--faces", "100"], 2, "order 7"),
                             (["--order", "0", "--faces", "100"], 2, "order 0"),
                             (["--order", "4", "--faces", "100", "--max-deviation", "-0.1"], 2, "negative deviation"),
                             (["--order", "4", "--faces", "100", "--tolerance", "-0.1"], 2, "negative tolerance"),
                             (["--order", "4", "--faces", "100", "--redecimate", "-1"], 2, "negative re-decimations"),
                             (["--order", "4", "--faces", "100", "--max-faces", "200"], 2, "--max-faces alone")]:
        r = subprocess.run([hoc, "coarsen", src, "-o", bad] + args, capture_output=True, text=True, timeout=60)
        check(r.returncode == code and not os.path.exists(bad), "%s: exit %d, no output" % (what, r.returncode))
    for args, what in [(["-o", os.path.join(work, "no-such-folder", "x.msh")], "-o in a missing folder"),
                       (["-o", work], "-o a folder"),
                       (["-o", bad, "--stats", os.path.join(work, "no-such-folder", "s.json")], "--stats in a missing folder"),
                       (["-o", bad, "--ratio", "1.5"], "--ratio 1.5")]:
        r = subprocess.run([hoc, "coarsen", src, "--order", "4"] + (["--faces", "100"] if "--ratio" not in args else [])
                           + args, capture_output=True, text=True, timeout=60)
        check(r.returncode == 2 and not os.path.exists(bad) and r.stderr.count("\n") == 1,
              "%s: exit %d before any work, one line: %s" % (what, r.returncode, r.stderr.strip()))
    empty = os.path.join(work, "empty.obj")
    open(empty, "w").write("# nothing\n")
    r = subprocess.run([hoc, "coarsen", empty, "-o", bad, "--order", "4", "--faces", "100"], capture_output=True,
                       text=True, timeout=60)
    check(r.returncode == 3 and not os.path.exists(bad), "empty input: exit %d, no output" % r.returncode)
    # A Moebius band (60 x 6 grid, the last column joined to the first upside down): not orientable.
    n, m = 60, 6
    lines = []
    for i in range(n):
        t = 2 * math.pi * i / n
        for j in range(m):
            w = -0.3 + 0.6 * j / (m - 1)
            lines.append("v %.12g %.12g %.12g" % ((1 + w * math.cos(t / 2)) * math.cos(t),
                                                   (1 + w * math.cos(t / 2)) * math.sin(t), w * math.sin(t / 2)))
    idx = lambda i, j: (m - 1 - j) if i == n else i * m + j
    for i in range(n):
        for j in range(m - 1):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            lines += ["f %d %d %d" % (a + 1, b + 1, c + 1), "f %d %d %d" % (a + 1, c + 1, d + 1)]
    band = os.path.join(work, "moebius.obj")
    open(band, "w").write("\n".join(lines) + "\n")
    r = subprocess.run([hoc, "coarsen", band, "-o", bad, "--order", "4", "--ratio", "0.1"], capture_output=True,
                       text=True, timeout=60)
    check(r.returncode == 3 and "not orientable" in r.stderr and not os.path.exists(bad),
          "Moebius band: exit %d, says why (%s), no output" % (r.returncode, r.stderr.strip()[:80]))

    print("%d failure(s)" % len(failures))
    if failures:
        print("files kept in %s" % work)
        return 1
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
