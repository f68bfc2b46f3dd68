#!/usr/bin/python3
"""Invariance sweep: the same CAD shape, rotated, reordered and moved away from the origin.

Each shape of cad_sweep.py is meshed by Gmsh at size h and written as an STL (full precision,
as Gmsh writes it). Then copies of its triangles are made: turned by a seeded random rotation
about the origin and shuffled (face order, hence vertex order), written at full precision
("rot"), and as a float32 binary STL shifted by s along (1, 1, 1) ("f32+s"; s = 0 too): a part
placed in an assembly's coordinates, whose float32 rounding grows with its distance from the
origin (half a unit in the last place: 1e-6 at 10, 1.5e-5 at 300, for a part of size 1).
The linear input's error is given for scale. Every copy is curved at P4 (`hocurve curve --order 4`), its nodes moved back by the inverse
transform (in double precision) and measured against the exact CAD as cad_sweep.py does. A result
independent of the placement gives one figure per row.

Usage: transform_sweep.py [--hocurve build/hocurve] [--out /tmp/hocurve-transform] [--size 0.1]
                          [--seeds 1,2] [--shifts 0,30,100,300] [SHAPE ...]
"""
import argparse
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench import cad_sweep  # noqa: E402
from bench import measure_error as me  # noqa: E402
from bench import shapes  # noqa: E402


def stl_triangles(path):
    """Triangles (n x 3 x 3) of an ASCII STL."""
    v = [list(map(float, l.split()[1:4])) for l in open(path) if l.strip().startswith("vertex")]
    return np.array(v).reshape(-1, 3, 3)


def cad_error(gmsh, name, hocurve, stl, out, q=np.eye(3), shift=0.0, order=4):
    """Max distance to the CAD of hocurve's P4 (or `order`) of stl, its nodes x mapped back by (x - shift) q."""
    if os.path.exists(out):
        os.remove(out)
    r = subprocess.run([hocurve, "curve", stl, "--order", str(order), "-o", out], capture_output=True, text=True)
    if r.returncode != 0:
        return "exit %d" % r.returncode
    m = me.read_triangles(out)
    X = (m["X"] - shift) @ q
    B = me.basis(m["type"], me.lattice(8))
    d, _ = cad_sweep.closest_surface(gmsh, np.einsum("pn,enk->epk", B, X).reshape(-1, 3))
    return "%.2e" % d.max()


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("shapes", nargs="*", default=["filletbox", "crosshole", "cutsphere", "halftorus", "roundcyl",
                                                  "capsule", "knob", "conecyl", "ellipcyl", "elbow"])
    ap.add_argument("--hocurve", default=os.path.join(os.path.dirname(__file__), "..", "build", "hocurve"))
    ap.add_argument("--out", default="/tmp/hocurve-transform")
    ap.add_argument("--size", type=float, default=0.1)
    ap.add_argument("--seeds", default="1,2")
    ap.add_argument("--shifts", default="0,30,100,300")
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    gmsh = shapes.gmsh_init()
    seeds = [int(s) for s in a.seeds.split(",")]
    shifts = [float(s) for s in a.shifts.split(",")]
    print("| shape | h | linear | P4 as meshed | " + " | ".join("rot %d" % s for s in seeds) + " | " +
          " | ".join("f32+%g" % s for s in shifts) + " |")
    print("|---|---|---|---|" + "---|" * (len(seeds) + len(shifts)))
    for name in a.shapes:
        cad_sweep.build(gmsh, name)
        cad_sweep.set_size(gmsh, a.size)
        gmsh.model.mesh.generate(2)
        stl = os.path.join(a.out, "%s.stl" % name)
        gmsh.write(stl)
        T = stl_triangles(stl)
        row = [cad_error(gmsh, name, a.hocurve, stl, os.path.join(a.out, "%s.msh" % name), order=o) for o in (1, 4)]
        copies = [(seed, 0.0, False) for seed in seeds] + [(seeds[0], s, True) for s in shifts]
        for seed, shift, float32 in copies:
            rng = np.random.default_rng(seed)
            q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            q[:, 0] *= np.sign(np.linalg.det(q))  # a rotation, not a reflection
            moved = os.path.join(a.out, "%s_moved.stl" % name)
            P = (T @ q.T + shift)[rng.permutation(len(T))].reshape(-1, 3)
            write = shapes.write_binary_stl if float32 else shapes.write_ascii_stl
            write(moved, P, np.arange(len(P)).reshape(-1, 3))
            row.append(cad_error(gmsh, name, a.hocurve, moved, os.path.join(a.out, "%s_moved.msh" % name), q, shift))
        print("| %s | %g | %s |" % (name, a.size, " | ".join(row)), flush=True)
        gmsh.model.remove()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
