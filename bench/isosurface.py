#!/usr/bin/python3
"""Iso-surface inputs: hocurve on marching-tetrahedra meshes of analytic shapes.

Meshes extracted from a sampled implicit function (CT segmentations, topology optimisation,
scans) are full of caps (three nearly collinear corners) and slivers: edge lengths span two
decades. This bench builds such meshes of the unit sphere and the torus (R=1, r=0.4) by marching
tetrahedra on a jittered grid, moves every vertex onto the exact surface (as an exact scan would
have it), writes them as binary STL, runs `hocurve curve` at each order and measures the maximum
distance to the exact surface at points inside every element (bench/measure_error.py), next to
the linear input's own error. It also prints the sharp edges found (a smooth surface has none)
and the long edges placed on PN triangles.

Usage: bench/isosurface.py [--hocurve BIN] [--out DIR] [--orders 2,4] [--grids 24,32] [--curve-args ARGS]
"""
import argparse
import os
import struct
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench import measure_error  # noqa: E402
from bench.accuracy import find_hocurve, run_hocurve  # noqa: E402

SHAPES = {
    # name: (implicit function, half-width of the sampled box)
    "sphere": (lambda x, y, z: np.sqrt(x * x + y * y + z * z) - 1.0, 1.45),
    "torus": (lambda x, y, z: np.sqrt((np.sqrt(x * x + y * y) - 1.0) ** 2 + z * z) - 0.4, 1.45),
}
# The six tetrahedra of a cube around its diagonal 0-6 (corner k = bits x, y, z of the cube's order below).
CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]])
TETS = [(0, 5, 1, 6), (0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6)]


def marching_tetrahedra(f, half, n, seed=1):
    """Vertices (on the zero set, linearly interpolated) and outward triangles of f < 0."""
    g = np.linspace(-half, half, n)
    jitter = np.random.default_rng(seed).uniform(-0.3, 0.3, 3) * (g[1] - g[0])
    X, Y, Z = np.meshgrid(g + jitter[0], g + jitter[1], g + jitter[2], indexing="ij")
    P = np.stack([X, Y, Z], -1).reshape(-1, 3)
    S = f(P[:, 0], P[:, 1], P[:, 2])
    idx = np.arange(n ** 3).reshape(n, n, n)
    vid, V, T = {}, [], []

    def vertex(a, b):  # the zero crossing on grid edge (a, b)
        key = (min(a, b), max(a, b))
        if key not in vid:
            t = S[a] / (S[a] - S[b])
            vid[key] = len(V)
            V.append(P[a] + t * (P[b] - P[a]))
        return vid[key]

    for i in range(n - 1):
        for j in range(n - 1):
            for k in range(n - 1):
                c = [idx[i + a, j + b, k + d] for a, b, d in CUBE]
                s = S[c]
                if s.min() > 0 or s.max() < 0:
                    continue
                for tet in TETS:
                    q = [c[m] for m in tet]
                    ins = [m for m in q if S[m] < 0]
                    outs = [m for m in q if S[m] >= 0]
                    if len(ins) == 1:
                        T.append([vertex(ins[0], o) for o in outs])
                    elif len(ins) == 3:
                        T.append([vertex(outs[0], o) for o in ins])
                    elif len(ins) == 2:
                        (a, b), (cc, d) = ins, outs
                        quad = [vertex(a, cc), vertex(a, d), vertex(b, d), vertex(b, cc)]
                        T += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
    V, T = np.array(V), np.array([t for t in T if len(set(t)) == 3])
    return V, T


def gradient(f, P, e=1e-6):
    return np.stack([(f(*(P + e * np.eye(3)[d]).T) - f(*(P - e * np.eye(3)[d]).T)) / (2 * e) for d in range(3)], 1)


def onto_surface(f, V, iters=30):
    """Newton steps along the gradient: every vertex onto the exact zero set."""
    for _ in range(iters):
        g = gradient(f, V)
        V = V - (f(*V.T) / (g * g).sum(1))[:, None] * g
    return V


def write_stl(path, V, T, f):
    with open(path, "wb") as out:
        out.write(b"hocurve bench/isosurface.py".ljust(80, b" "))
        out.write(struct.pack("<I", len(T)))
        for t in T:
            a, b, c = V[t]
            if np.dot(np.cross(b - a, c - a), gradient(f, ((a + b + c) / 3)[None])[0]) < 0:
                b, c = c, b  # outward
            out.write(struct.pack("<3f", 0, 0, 0) + struct.pack("<9f", *a, *b, *c) + b"\0\0")


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hocurve", default=None)
    ap.add_argument("--out", default="/tmp/hocurve-bench/isosurface")
    ap.add_argument("--orders", default="2,4")
    ap.add_argument("--grids", default="24,32")
    ap.add_argument("--curve-args", default="", help="extra `hocurve curve` arguments, e.g. '--long-edge-ratio 0'")
    a = ap.parse_args(argv)
    hoc = a.hocurve or find_hocurve()
    if not hoc:
        sys.exit("no hocurve binary: build first or pass --hocurve")
    os.makedirs(a.out, exist_ok=True)
    orders = [int(x) for x in a.orders.split(",")]
    print("| shape | grid | #tri | edge p99/p1 | linear | " + " | ".join("P%d (sharp, PN edges)" % p for p in orders) +
          " | linear / P%d |" % orders[-1])
    print("|---|---|---|---|---|" + "---|" * len(orders) + "---|")
    for name, (f, half) in SHAPES.items():
        for n in [int(x) for x in a.grids.split(",")]:
            V, T = marching_tetrahedra(f, half, n)
            V = onto_surface(f, V)
            stl = os.path.join(a.out, "%s_mt%d.stl" % (name, n))
            write_stl(stl, V, T, f)
            row, errs = [], {}
            for p in [1] + orders:
                out = os.path.join(a.out, "%s_mt%d_p%d.msh" % (name, n, p))
                r = run_hocurve(hoc, stl, out, p, stats=out + ".json",
                                extra=["--method", "linear"] if p == 1 else a.curve_args.split())
                if r["rc"] != 0:
                    row.append("exit %d" % r["rc"])
                    continue
                m = measure_error.measure(out, name)
                errs[p] = m["max"]
                c = r["stats"]["curving"]
                if p == 1:
                    row.append("%.2e" % m["max"])
                else:
                    if p == orders[0]:
                        row.insert(0, "%.0f" % c["uniformity"]["edge_length"]["p99_p1"])
                    bad = "" if m["nonpositive_jacobian"] == 0 and m["watertight"] else " INVALID"
                    row.append("%.2e (%d, %d)%s" % (m["max"], c["features"]["sharp_edges"],
                                                    c["placement"]["long_edges_placed"], bad))
            ratio = "%.0f" % (errs[1] / errs[orders[-1]]) if 1 in errs and orders[-1] in errs else "-"
            print("| %s | %d | %d | %s | %s |" % (name, n, len(T), " | ".join(row), ratio), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
