#!/usr/bin/python3
"""CAD benchmark: every STEP solid of ../shared/meshes/cad, curved from Gmsh's STL of it.

For each part, size (bounding-box diagonal / 40 and / 80) and sizing (uniform; uniform capped by
curvature, Mesh.MeshSizeFromCurvature = 12), Gmsh meshes the exact CAD and writes a binary STL;
then, in the same run:
  linear   the STL's own triangles,
  P2, P4   `hocurve curve STL --order p` (the STL alone: no CAD reaches hocurve),
  REF P4   Gmsh's setOrder(4) of the same triangulation on the exact CAD (nodes on the CAD).
Each element is measured against its **own CAD face** (the face Gmsh meshed the triangle with the
same three corners on) at the points of a degree-5 lattice, which meets no P2 or P4 node but the
corners (bench/measure_error.py: the element's own Lagrange map, OpenCASCADE's exact surface).

Reported per row: the largest and the median element error; linear / P4 of the largest; elements
farther from their face than their straight selves by more than 1e-6 of the diagonal ("worse");
the largest error of an element on a planar face, relative to the diagonal ("planar"); samples
with a non-positive Jacobian ("J<=0") and watertightness. Each part runs in a process of its own:
Gmsh 4.8.4 aborts on some STEP files while meshing; such a row says so and the run goes on.

Usage: cad_bench.py [--hocurve BIN] [--out DIR] [--parts a,b] [--divisions 40,80]
                    [--curvature 0,12] [--orders 2,4] [--q 5] [--jobs 2] [--json FILE] [--timeout S]
"""
import argparse
import concurrent.futures
import json
import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench import accuracy  # noqa: E402
from bench import measure_error as me  # noqa: E402
from bench import shapes  # noqa: E402

WORSE_TOLERANCE = 1e-6  # of the diagonal: "farther than its straight self"


def corner_keys(corners):
    """Order-free identity of each element: its corners as float32 bytes, sorted."""
    c = np.ascontiguousarray(np.asarray(corners, np.float64).astype(np.float32))
    keys = [tuple(sorted(bytes(v) for v in tri)) for tri in c]
    return keys


def planar_faces(name):
    """Tags of the part's CAD faces whose surface is a plane."""
    gmsh = shapes.gmsh_init()
    shapes.build_occ(name, "types_" + name)
    tags = {t for _, t in gmsh.model.getEntities(2) if gmsh.model.getType(2, t) == "Plane"}
    gmsh.model.remove()
    return tags


def compare(lin, ho, diag, planar, face):
    """Per-element figures of a curved mesh `ho` against the straight one `lin` (measure results
    with per_element; face: corner key -> CAD face): elements worse than straight, median error,
    largest error on planes."""
    straight = dict(zip(corner_keys(lin["corners"]), lin["element_max"]))
    worse, plane_max, unmatched = 0, 0.0, 0
    for k, e in zip(corner_keys(ho["corners"]), ho["element_max"]):
        s = straight.get(k)
        if s is None:
            unmatched += 1
            continue
        worse += int(e > s + WORSE_TOLERANCE * diag)
        if face.get(k) in planar:
            plane_max = max(plane_max, float(e))
    return {"worse": worse, "unmatched": unmatched, "median": float(np.median(ho["element_max"])),
            "planar_max_relative": plane_max / diag}


def slim(m):
    return {k: m[k] for k in ("max", "rms", "elements", "watertight", "nonpositive_jacobian")}


def run_one(a):
    """One part at one size and sizing: the row as a dict (run in a child process)."""
    shapes.add_step_parts()
    name, div, curv = a.one[0], int(a.one[1]), int(a.one[2])
    size = "d/%d" % div
    row = {"part": name, "size": size, "curvature": curv}
    t = time.time()
    stl = shapes.make_stl(name, size, a.out, curvature=curv)
    h = shapes.size_value(name, size)
    diag = shapes.bbox_diagonal(name)
    side = np.load(shapes.sidecar_path(stl))
    planar = planar_faces(name)
    dist = me.distance_function(name, stl, own_face=True)
    lin = me.measure(stl, name, stl, q=a.q, dist=dist, per_element=True)
    face = dict(zip(corner_keys(side["V"][side["F"]]), map(int, side["face"])))
    row.update({"h": h, "diagonal": diag, "triangles": lin["elements"], "mesh_seconds": time.time() - t,
                "linear": dict(slim(lin), median=float(np.median(lin["element_max"])))})
    work = os.path.join(a.out, "runs")
    os.makedirs(work, exist_ok=True)
    tag = "%s_d%d_c%d" % (name, div, curv)
    for p in a.orders:
        out = os.path.join(work, "%s_hoc_p%d.msh" % (tag, p))
        st = os.path.join(work, "%s_hoc_p%d.json" % (tag, p))
        r = accuracy.run_hocurve(a.hocurve, stl, out, p, st, timeout=a.timeout)
        e = {"rc": r["rc"], "seconds": r["seconds"]}
        if r["rc"] == 0:
            m = me.measure(out, name, stl, q=a.q, dist=dist, per_element=True)
            e.update(slim(m), **compare(lin, m, diag, planar, face))
            e["models"] = (r.get("stats") or {}).get("models")
        else:
            e["error"] = r["stderr"].strip().splitlines()[-1:]
        row["P%d" % p] = e
    if not a.no_ref:
        out = os.path.join(work, "%s_REF_p4.msh" % tag)
        gmsh = shapes.gmsh_init()
        shapes.mesh_occ(name, h, curv)
        gmsh.model.mesh.setOrder(4)
        gmsh.option.setNumber("Mesh.Binary", 1)
        gmsh.write(out)
        gmsh.model.remove()
        m = me.measure(out, name, stl, q=a.q, dist=dist, per_element=True)
        row["REF4"] = dict(slim(m), median=float(np.median(m["element_max"])))
    row["seconds"] = time.time() - t
    return row


def child(a, name, div, curv):
    """Run one row in a child process; a crash or a timeout becomes a row that says so."""
    cmd = [sys.executable, os.path.abspath(__file__), "--one", name, str(div), str(curv), "--out", a.out,
           "--hocurve", a.hocurve, "--orders", ",".join(map(str, a.orders)), "--timeout", str(a.timeout),
           "--q", str(a.q)]
    if a.no_ref:
        cmd.append("--no-ref")
    try:
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=4 * a.timeout)
        lines = [ln for ln in r.stdout.decode(errors="replace").splitlines() if ln.startswith("{")]
        if r.returncode == 0 and lines:
            return json.loads(lines[-1])
        why = (r.stderr.decode(errors="replace").strip().splitlines() or ["exit %d" % r.returncode])[-1]
    except subprocess.TimeoutExpired:
        why = "timeout"
    return {"part": name, "size": "d/%d" % div, "curvature": curv, "failed": why[:160]}


def report(r):
    print("%s %s c%d: %s" % (r["part"], r["size"], r["curvature"], r.get("failed") or "linear %.2e, P4 %s, REF %s (%.0f s)" % (
        r["linear"]["max"], fmt(r.get("P4", {}).get("max")), fmt(r.get("REF4", {}).get("max")), r["seconds"])),
        flush=True)
    return r


def fmt(x, f="%.2e"):
    return f % x if isinstance(x, (int, float)) else "—"


def table(rows, orders):
    head = ["part", "size", "curv", "#tri", "linear"] + ["P%d" % p for p in orders] + [
        "REF P4", "lin/P4", "P4/REF", "P4 med", "REF med", "worse", "planar", "J<=0", "wt", "P4 s"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        if "failed" in r:
            out.append("| %s | %s | %d | Gmsh could not mesh it: %s |" % (r["part"], r["size"], r["curvature"], r["failed"]))
            continue
        p4 = r.get("P4", {})
        ref = r.get("REF4", {})
        ho = [r.get("P%d" % p, {}) for p in orders]
        cells = [r["part"], r["size"], str(r["curvature"]), str(r["triangles"]), fmt(r["linear"]["max"])]
        cells += [fmt(e.get("max")) if "max" in e else "FAIL(%s)" % e.get("rc") for e in ho]
        cells += [fmt(ref.get("max")),
                  fmt(r["linear"]["max"] / p4["max"], "%.3g") if p4.get("max") else "—",
                  fmt(p4["max"] / ref["max"], "%.3g") if p4.get("max") and ref.get("max") else "—",
                  fmt(p4.get("median")), fmt(ref.get("median")),
                  "/".join(str(e.get("worse", "—")) for e in ho),
                  fmt(p4.get("planar_max_relative"), "%.1e"),
                  "/".join(str(e.get("nonpositive_jacobian", "—")) for e in ho),
                  "/".join("y" if e.get("watertight") else "n" for e in ho),
                  fmt(p4.get("seconds"), "%.2f")]
        out.append("| " + " | ".join(cells) + " |")
    ok = [r for r in rows if r.get("P4", {}).get("max")]
    if ok:
        ratios = [r["linear"]["max"] / r["P4"]["max"] for r in ok]
        refs = [r["P4"]["median"] / r["REF4"]["median"] for r in ok if r.get("REF4", {}).get("median")]
        out.append("")
        out.append("rows %d (of %d); lin/P4: min %.3g, median %.3g; P4 median / REF median: median %s; "
                   "elements worse than straight (P4): %d; largest planar error / diagonal (P4): %.1e" % (
                       len(ok), len(rows), min(ratios), float(np.median(ratios)),
                       "%.3g" % float(np.median(refs)) if refs else "—",
                       sum(r["P4"]["worse"] for r in ok), max(r["P4"]["planar_max_relative"] for r in ok)))
    out.append("\nworse: elements farther from their CAD face than their straight triangle by more than "
               "%g of the diagonal (P2/P4); planar: the largest P4 error of an element on a planar face / "
               "diagonal; J<=0: elements with a non-positive sampled Jacobian." % WORSE_TOLERANCE)
    return "\n".join(out)


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hocurve", default=None)
    ap.add_argument("--out", default="/tmp/hocurve-cad")
    ap.add_argument("--parts", default="", help="comma-separated part names (default: every STEP file)")
    ap.add_argument("--divisions", default="40,80")
    ap.add_argument("--curvature", default="0,12")
    ap.add_argument("--orders", default="2,4")
    ap.add_argument("--timeout", type=int, default=900, help="seconds per hocurve run")
    ap.add_argument("--q", type=int, default=5, help="sampling lattice degree")
    ap.add_argument("--jobs", type=int, default=1, help="rows measured at once (one process each)")
    ap.add_argument("--json")
    ap.add_argument("--no-ref", action="store_true", help="skip Gmsh's exact-CAD P4")
    ap.add_argument("--one", nargs=3, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    a.orders = [int(x) for x in a.orders.split(",")]
    a.hocurve = a.hocurve or accuracy.find_hocurve()
    if a.one:
        print(json.dumps(run_one(a), default=float))
        return
    parts = a.parts.split(",") if a.parts else shapes.add_step_parts()
    todo = [(name, div, curv) for name in parts for div in map(int, a.divisions.split(","))
            for curv in map(int, a.curvature.split(","))]
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        rows = list(pool.map(lambda t: report(child(a, *t)), todo))
    print(table(rows, a.orders))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1, default=float)


if __name__ == "__main__":
    main(sys.argv[1:])
