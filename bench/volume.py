#!/usr/bin/python3
"""hocurve volume next to Gmsh on the same surfaces: time, tets, validity, scaled Jacobians.

For each shape (Gmsh OCC meshed at size h, written as ASCII STL) and order P:
- hocurve: `hocurve volume STL -o OUT.msh --order P --stats S.json` (wall time of the process;
  invalid tets before/after the optimizer and the certified min / 1st-percentile scaled Jacobian
  min det J / max det J from the stats);
- Gmsh 4.8: the same STL as a discrete surface in a GEO volume, generate(3) + setOrder(P)
  (what Gmsh does with an STL: its high-order nodes stay on the facets), timed in-process.
Both meshes are then sampled the same way (det J at the degree-3(P-1) lattice of every tet,
via gmsh.model.mesh.getJacobians): min and 1st percentile of min/max det J per tet, and the
count of tets with a sampled det J <= 0 (sampled: a lower figure than certified).

Usage: volume.py --hocurve build/hocurve [--orders 2,3,4] [--shapes sphere,torus,shell,big] [--no-gmsh]
"""
import argparse
import json
import os
import subprocess
import sys
import time

import gmsh
import numpy as np

SHAPES = {  # name -> (builder, h); big: a unit sphere of ~200k tets
    "sphere": ("sphere", 0.2),
    "torus": ("torus", 0.15),
    "shell": ("shell", 0.15),
    "big": ("sphere", 0.043),
}


def make_stl(kind, h, path):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    if kind == "sphere":
        gmsh.model.occ.addSphere(0, 0, 0, 1)
    elif kind == "torus":
        gmsh.model.occ.addTorus(0, 0, 0, 1, 0.35)
    else:  # spherical shell, gap 0.05
        a = gmsh.model.occ.addSphere(0, 0, 0, 1)
        b = gmsh.model.occ.addSphere(0, 0, 0, 0.95)
        gmsh.model.occ.cut([(3, a)], [(3, b)])
    gmsh.model.occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMin", h)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.model.mesh.generate(2)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.write(path)
    gmsh.finalize()


def sampled_quality(p):
    """Per-tet min/max det J at the degree-3(p-1) lattice of the current model's order-p tets,
    from the nodes and Gmsh's Lagrange gradients (numpy, in chunks of tets)."""
    d = 3 * (p - 1)
    pts = [(i / d, j / d, k / d) for k in range(d + 1) for j in range(d + 1 - k) for i in range(d + 1 - j - k)] if d else [(0.25,) * 3]
    etype = gmsh.model.mesh.getElementType("Tetrahedron", p)
    _, grads, _ = gmsh.model.mesh.getBasisFunctions(etype, [c for q in pts for c in q], "GradLagrange")
    nn = (p + 1) * (p + 2) * (p + 3) // 6
    G = np.asarray(grads).reshape(len(pts), nn, 3)
    _, conn = gmsh.model.mesh.getElementsByType(etype)
    conn = np.asarray(conn, dtype=np.int64).reshape(-1, nn)
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    X = np.zeros((int(np.max(tags)) + 1, 3))
    X[np.asarray(tags, dtype=np.int64)] = np.asarray(xyz).reshape(-1, 3)
    lo, hi = [], []
    for c in range(0, len(conn), 20000):
        E = X[conn[c:c + 20000]]                       # tets x nodes x 3
        J = np.einsum("eni,snj->esij", E, G)           # tets x samples x 3 x 3 (dx_i / du_j)
        det = np.linalg.det(J)
        lo.append(det.min(axis=1))
        hi.append(det.max(axis=1))
    lo, hi = np.concatenate(lo), np.concatenate(hi)
    s = np.where(hi > 0, lo / np.where(hi > 0, hi, 1), -1.0)
    return {"tets": len(s), "invalid": int((lo <= 0).sum()), "min": float(s.min()), "p1": float(np.percentile(s, 1))}


def gmsh_baseline(stl, p):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.merge(stl)
    surfaces = [t for _, t in gmsh.model.getEntities(2)]
    t0 = time.perf_counter()
    loop = gmsh.model.geo.addSurfaceLoop(surfaces)
    gmsh.model.geo.addVolume([loop])
    gmsh.model.geo.synchronize()
    gmsh.model.mesh.generate(3)
    t1 = time.perf_counter()
    gmsh.model.mesh.setOrder(p)
    t2 = time.perf_counter()
    q = sampled_quality(p)
    gmsh.finalize()
    q.update({"generate3": t1 - t0, "setorder": t2 - t1})
    return q


def hocurve_run(hoc, stl, p, work):
    out, stats = os.path.join(work, "vol.msh"), os.path.join(work, "vol.json")
    t0 = time.perf_counter()
    r = subprocess.run([hoc, "volume", stl, "-o", out, "--order", str(p), "--stats", stats, "--binary"],
                       capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if r.returncode not in (0, 4):
        raise RuntimeError(r.stderr)
    s = json.load(open(stats))
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.open(out)
    q = sampled_quality(p)
    gmsh.finalize()
    return wall, s, q


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hocurve", default="build/hocurve")
    ap.add_argument("--orders", default="2,3,4")
    ap.add_argument("--shapes", default="sphere,torus,shell")
    ap.add_argument("--work", default="/tmp/hocurve-bench-volume")
    ap.add_argument("--no-gmsh", action="store_true", help="hocurve only (re-measuring it)")
    a = ap.parse_args(argv)
    os.makedirs(a.work, exist_ok=True)
    print("shape  P   tets | hocurve: s (gen3 opt)  inv.before->after  certified min/p1 | sampled min/p1 |"
          " Gmsh gen3+setOrder: s  invalid  sampled min/p1")
    for name in a.shapes.split(","):
        kind, h = SHAPES[name]
        stl = os.path.join(a.work, f"{name}.stl")
        if not os.path.exists(stl):
            make_stl(kind, h, stl)
        for p in map(int, a.orders.split(",")):
            wall, s, q = hocurve_run(a.hocurve, stl, p, a.work)
            g = {"generate3": float("nan"), "setorder": 0, "invalid": -1, "min": float("nan"), "p1": float("nan")} \
                if a.no_gmsh else gmsh_baseline(stl, p)
            v, sec = s["volume"], s["seconds"]
            print(f"{name:6} {p} {v['final']['tets']:6} | {wall:6.2f} ({sec['tets']:.2f} {sec['optimize']:.2f})"
                  f"  {v['invalid_before']:4} -> {v['final']['invalid']:<3}"
                  f"  {v['final']['min_scaled_jacobian']:.3f}/{v['final']['p1_scaled_jacobian']:.3f}"
                  f" | {q['min']:.3f}/{q['p1']:.3f} | {g['generate3'] + g['setorder']:6.2f}"
                  f"  {g['invalid']:4}  {g['min']:.3f}/{g['p1']:.3f}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
