#!/usr/bin/python3
"""Accuracy of hocurve against exact shapes, with Gmsh baselines measured in the same run.

For every shape (bench/shapes.py), mesh size and order p:
  linear   the input STL itself (P1),
  hocurve  `hocurve curve IN.stl -o OUT.msh --order p --stats S.json`,
  A        Gmsh given the same STL, setOrder(p) (high-order nodes stay on the facets),
  REF      Gmsh from the exact OCC CAD, same triangulation, setOrder(p) (nodes on the CAD).
Every mesh is measured by bench/measure_error.py (the elements' own Lagrange maps, exact distance).

Usage: accuracy.py [--out DIR] [--hocurve BIN] [--shapes sphere,torus] [--orders 1,2,3,4,6]
                   [--sizes 3] [--json FILE] [--no-hocurve] [--no-baselines] [--threads N]
                   [--ascii-stl]
"""
import argparse
import glob
import json
import math
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench import shapes  # noqa: E402
from bench import measure_error as me  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def find_hocurve():
    """The newest hocurve binary in a build directory of the repository, or None."""
    cands = [p for p in glob.glob(os.path.join(REPO, "build*", "hocurve")) if os.access(p, os.X_OK)]
    return max(cands, key=os.path.getmtime) if cands else None


def run_hocurve(binary, stl, out, order, stats=None, threads=None, extra=(), timeout=1800):
    """Run `hocurve curve`; returns dict(rc, seconds, stderr tail, stats dict or None)."""
    cmd = [binary, "curve", stl, "-o", out, "--order", str(order)]
    if stats:
        cmd += ["--stats", stats]
    if threads:
        cmd += ["--threads", str(threads)]
    cmd += list(extra)
    t = time.time()
    try:
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=timeout)
        rc, err = r.returncode, r.stderr.decode(errors="replace")
    except subprocess.TimeoutExpired:
        rc, err = -9, "timeout after %d s" % timeout
    res = {"cmd": " ".join(cmd), "rc": rc, "seconds": time.time() - t, "stderr": err[-2000:]}
    if stats and rc == 0 and os.path.exists(stats):
        with open(stats) as f:
            res["stats"] = json.load(f)
    return res


def gmsh_stl_order(stl, order, out):
    """Baseline A: Gmsh reads the STL and elevates it with setOrder (nodes on the facets)."""
    gmsh = shapes.gmsh_init()
    gmsh.model.add("baseline_A")
    gmsh.merge(stl)
    gmsh.model.mesh.setOrder(order)
    gmsh.option.setNumber("Mesh.Binary", 1)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(out)
    gmsh.model.remove()


def gmsh_cad_order(name, h, order, out):
    """Baseline REF: Gmsh meshes the exact CAD at size h (the STL's triangulation) and elevates
    it with setOrder, which places the high-order nodes on the CAD surfaces."""
    gmsh = shapes.gmsh_init()
    shapes.mesh_occ(name, h)
    gmsh.model.mesh.setOrder(order)
    gmsh.option.setNumber("Mesh.Binary", 1)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(out)
    gmsh.model.remove()


def slim(m):
    return {k: m[k] for k in ("max", "rms", "elements", "element_type", "order", "watertight",
                              "edges_not_twice", "nonpositive_jacobian", "min_jacobian_ratio")}


def run(args):
    hoc = None if args.no_hocurve else (args.hocurve or find_hocurve())
    if not args.no_hocurve and not hoc:
        print("note: no hocurve binary found (build the 'hocurve' target); measuring baselines only")
    orders = [int(x) for x in args.orders.split(",")]
    results = []
    work = os.path.join(args.out, "runs")
    os.makedirs(work, exist_ok=True)
    for name in args.shapes.split(","):
        dist = None
        for size in shapes.SIZES[name][:args.sizes]:
            stl = shapes.make_stl(name, size, args.out, ascii=args.ascii_stl)
            h = shapes.size_value(name, size)
            dist = me.distance_function(name, stl)
            tag = "%s_%s" % (name, shapes.size_label(size))
            lin = me.measure(stl, name, stl, q=args.q, dist=dist)
            row = {"shape": name, "size": str(size), "h": h, "triangles": lin["elements"],
                   "linear": slim(lin), "hocurve": {}, "A": {}, "REF": {}}
            if shapes.SHAPES[name]["kind"] == "step":
                row["vertex_floor"] = me.StepDistance(name, shapes.sidecar_path(stl)).vertex_floor()
            print("%s h=%.4g: %d triangles, linear max %.3e" % (name, h, lin["elements"], lin["max"]),
                  flush=True)
            for p in orders:
                if hoc and p >= 1:
                    out = os.path.join(work, "%s_hoc_p%d.msh" % (tag, p))
                    st = os.path.join(work, "%s_hoc_p%d.json" % (tag, p))
                    r = run_hocurve(hoc, stl, out, p, st, args.threads)
                    entry = {"rc": r["rc"], "seconds": r["seconds"]}
                    if r["rc"] == 0:
                        entry.update(slim(me.measure(out, name, stl, q=args.q, dist=dist)))
                    else:
                        entry["error"] = r["stderr"].strip().splitlines()[-1:] if r["stderr"] else []
                    row["hocurve"][p] = entry
                    print("  hocurve P%d: %s" % (p, fmt_entry(entry)), flush=True)
                if not args.no_baselines and p >= 2:
                    out = os.path.join(work, "%s_A_p%d.msh" % (tag, p))
                    gmsh_stl_order(stl, p, out)
                    row["A"][p] = slim(me.measure(out, name, stl, q=args.q, dist=dist))
                    out = os.path.join(work, "%s_REF_p%d.msh" % (tag, p))
                    gmsh_cad_order(name, h, p, out)
                    row["REF"][p] = slim(me.measure(out, name, stl, q=args.q, dist=dist))
                    print("  A P%d max %.3e | REF P%d max %.3e" % (p, row["A"][p]["max"], p,
                                                                  row["REF"][p]["max"]), flush=True)
            results.append(row)
    return results


def fmt_entry(e):
    if "max" not in e:
        return "FAILED rc=%s %s" % (e.get("rc"), " ".join(e.get("error", [])))
    return "max %.3e rms %.3e, %.1f s, watertight %s, J<=0: %d" % (
        e["max"], e["rms"], e.get("seconds", 0), e["watertight"], e["nonpositive_jacobian"])


def cell(e):
    if e is None:
        return "—"
    if "max" not in e:
        return "FAIL(rc %s)" % e.get("rc")
    flag = "" if e["watertight"] and e["nonpositive_jacobian"] == 0 else "*"
    return "%.2e%s" % (e["max"], flag)


def conv_order(e1, e2, n1, n2):
    """Observed order from two meshes with n1 < n2 triangles (h ~ 1/sqrt(n))."""
    try:
        return math.log(e1 / e2) / math.log(math.sqrt(n2 / n1))
    except (ValueError, ZeroDivisionError, TypeError):
        return float("nan")


def markdown(results, orders):
    lines = []
    by_shape = {}
    for r in results:
        by_shape.setdefault(r["shape"], []).append(r)
    for name, rows in by_shape.items():
        lines.append("\n### %s  (max distance to the exact surface; * = not watertight or J<=0)\n" % name)
        head = "| h | #tri | method | P1 (linear) | " + " | ".join("P%d" % p for p in orders if p >= 2) + " |"
        lines.append(head)
        lines.append("|" + "---|" * (4 + len([p for p in orders if p >= 2])))
        for r in rows:
            for meth, label in (("hocurve", "hocurve"), ("A", "A: Gmsh STL+setOrder"),
                                ("REF", "REF: Gmsh CAD+setOrder")):
                lin = cell(r["linear"]) if meth == "hocurve" else ""
                cells = [cell(r[meth].get(p) or r[meth].get(str(p))) for p in orders if p >= 2]
                lines.append("| %.4g | %d | %s | %s | %s |" % (r["h"], r["triangles"], label, lin,
                                                              " | ".join(cells)))
        # observed convergence orders between consecutive sizes
        if len(rows) > 1:
            lines.append("\nObserved convergence order (max error, h ~ 1/sqrt(#tri)):\n")
            lines.append("| sizes | method | P1 | " + " | ".join("P%d" % p for p in orders if p >= 2) + " |")
            lines.append("|" + "---|" * (3 + len([p for p in orders if p >= 2])))
            for a, b in zip(rows, rows[1:]):
                for meth in ("hocurve", "REF"):
                    o1 = conv_order(a["linear"]["max"], b["linear"]["max"], a["triangles"], b["triangles"])
                    os_ = []
                    for p in orders:
                        if p < 2:
                            continue
                        ea, eb = get(a[meth], p), get(b[meth], p)
                        os_.append("%.2f" % conv_order(ea, eb, a["triangles"], b["triangles"])
                                   if ea and eb else "—")
                    lines.append("| %.3g→%.3g | %s | %.2f | %s |" % (a["h"], b["h"], meth, o1, " | ".join(os_)))
    # summary ratios
    lines.append("\n### Ratios at P4 (max error)\n")
    lines.append("| shape | h | #tri | linear / hocurve P4 | hocurve P4 / REF P4 | input floor | hocurve P4 s |")
    lines.append("|---|---|---|---|---|---|---|")
    for r in results:
        e4 = get(r["hocurve"], 4)
        ref4 = get(r["REF"], 4)
        secs = (r["hocurve"].get(4) or r["hocurve"].get("4") or {}).get("seconds")
        floor = r.get("vertex_floor")
        lines.append("| %s | %.4g | %d | %s | %s | %s | %s |" % (
            r["shape"], r["h"], r["triangles"],
            "%.3g" % (r["linear"]["max"] / e4) if e4 else "—",
            "%.3g" % (e4 / ref4) if e4 and ref4 else "—",
            "%.2e" % floor if floor else "—",
            "%.2f" % secs if secs else "—"))
    lines.append("\ninput floor (CAD parts): the largest distance of an input vertex from a CAD face it was "
                 "meshed on (STEP curves are only within the file's tolerance of their faces); a fit "
                 "through the input vertices does not get below it next to them.")
    return "\n".join(lines)


def get(d, p):
    e = d.get(p) or d.get(str(p))
    return e["max"] if e and "max" in e else None


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=shapes.DEFAULT_OUT, help="cache/work directory")
    ap.add_argument("--hocurve", help="hocurve binary (default: newest build*/hocurve)")
    ap.add_argument("--shapes", default="sphere,torus,ellipsoid,cylinder,screw,t20")
    ap.add_argument("--orders", default="1,2,3,4,6")
    ap.add_argument("--sizes", type=int, default=3, help="how many sizes per shape (coarse first)")
    ap.add_argument("--q", type=int, help="sampling lattice order (default max(2p, 6))")
    ap.add_argument("--threads", type=int, help="hocurve --threads")
    ap.add_argument("--json", help="write all figures as JSON here")
    ap.add_argument("--ascii-stl", action="store_true",
                    help="double-precision ASCII STL input instead of binary (float32) STL")
    ap.add_argument("--no-hocurve", action="store_true")
    ap.add_argument("--no-baselines", action="store_true")
    a = ap.parse_args(argv)
    results = run(a)
    orders = [int(x) for x in a.orders.split(",")]
    print(markdown(results, orders))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main(sys.argv[1:])
