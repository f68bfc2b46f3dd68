#!/usr/bin/python3
"""Filleted boxes of several fillet radii and mesh sizes, curved at P4 with tangent junctions off and on.

Each case is a 1 x 0.8 x 0.6 box with every edge filleted at radius R (Gmsh's OpenCASCADE kernel), meshed by
Gmsh at size H (lower size H/4), written as STL and curved by `hocurve curve --order 4 --tangent-junctions
off|on`. Printed: the junction edges found and the largest distance to the exact CAD (cad_sweep.measure:
the elements' own Lagrange maps sampled on a degree-8 lattice, OpenCASCADE's closest point), per surface type.

Usage: fillets.py [--hocurve build/hocurve] [--out /tmp/hocurve-fillets] [R:H ...]
       (default cases 0.15:0.05 0.25:0.05 0.25:0.02 0.1:0.025)
"""
import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench import cad_sweep, shapes  # noqa: E402


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hocurve", default="build/hocurve")
    ap.add_argument("--out", default="/tmp/hocurve-fillets")
    ap.add_argument("cases", nargs="*", default=["0.15:0.05", "0.25:0.05", "0.25:0.02", "0.1:0.025"])
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    gmsh = shapes.gmsh_init()
    print("| R | h | #tri | junctions off: P4 | junction edges | junctions on: P4 | worst surface type (on) |")
    print("|---|---|---|---|---|---|---|")
    for case in a.cases:
        R, H = (float(x) for x in case.split(":"))
        name = "fb_%g_%g" % (R, H)
        gmsh.model.add(name)
        occ = gmsh.model.occ
        box = occ.addBox(0, 0, 0, 1, 0.8, 0.6)
        occ.synchronize()
        occ.fillet([box], [t for (_, t) in gmsh.model.getEntities(1)], [R])
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMin", H / 4)
        gmsh.option.setNumber("Mesh.MeshSizeMax", H)
        gmsh.model.mesh.generate(2)
        stl = os.path.join(a.out, name + ".stl")
        gmsh.write(stl)
        row = {}
        for tj in ("off", "on"):
            out = os.path.join(a.out, "%s_%s.msh" % (name, tj))
            subprocess.run([a.hocurve, "curve", stl, "-o", out, "--order", "4", "--stats", out + ".json",
                            "--tangent-junctions", tj], check=True, capture_output=True)
            junctions = json.load(open(out + ".json"))["curving"]["features"]["junction_edges"]
            err, by_kind, n, _ = cad_sweep.measure(gmsh, out, name)
            row[tj] = (err, by_kind, n, junctions)
        err, by_kind, n, junctions = row["on"]
        print("| %g | %g | %d | %.2e | %d | %.2e | %s |" % (
            R, H, n, row["off"][0], junctions, err, ", ".join("%s %.1e" % kv for kv in by_kind.items())), flush=True)
        gmsh.model.remove()


if __name__ == "__main__":
    main(sys.argv[1:])
