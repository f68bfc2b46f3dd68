#!/usr/bin/python3
"""Gmsh's own validity check agrees with hocurve's: every curved element hocurve writes has a
positive Jacobian determinant according to Gmsh's Plugin(AnalyseMeshQuality), which bounds the
Jacobian with Bezier coefficients independently of hocurve's code.

Inputs: shared meshes whose triangulations are hardest to curve validly (CAD exports with needles
and fans, a noisy scan, a raw Thingi10K file), written by `hocurve curve` at P2, P4 and P6 and by
`hocurve coarsen` at P3 and P4 (with and without --tolerance). For each output: the plugin's
minimum of min J / max J over the elements must be > 0, for as many elements as the stats report.
Harness: a P2 triangle folded on purpose must come out with a non-positive value (so the check can
fail).

Usage: test_gmsh_validity.py BUILD_DIR
"""
import json
import os
import subprocess
import sys
import tempfile

import gmsh

SHARED = os.path.join(os.environ.get("HOCURVE_SHARED_DIR", os.path.join(os.path.dirname(__file__), "../../../shared")),
                      "meshes")

failures = []


def check(cond, what):
    print(("ok    " if cond else "FAIL  ") + what, flush=True)
    if not cond:
        failures.append(what)


def gmsh_min_jacobian_ratio():
    """Runs Plugin(AnalyseMeshQuality) on the current model's 2D elements: (element count, the
    smallest min J / max J, how many are <= 0)."""
    gmsh.plugin.setNumber("AnalyseMeshQuality", "JacobianDeterminant", 1)
    gmsh.plugin.setNumber("AnalyseMeshQuality", "IGEMeasure", 0)
    gmsh.plugin.setNumber("AnalyseMeshQuality", "ICNMeasure", 0)
    gmsh.plugin.setNumber("AnalyseMeshQuality", "CreateView", 1)
    gmsh.plugin.setNumber("AnalyseMeshQuality", "DimensionOfElements", 2)
    gmsh.plugin.run("AnalyseMeshQuality")
    values = []
    for v in gmsh.view.getTags():
        name = gmsh.option.getString("View[%d].Name" % gmsh.view.getIndex(v))
        if name.startswith("minJ/maxJ"):
            _, _, data, _, _ = gmsh.view.getModelData(v, 0)
            values += [d[0] for d in data]
    return len(values), (min(values) if values else float("nan")), sum(1 for x in values if not x > 0)


def check_file(path, expected, what):
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(path)
        n, lo, bad = gmsh_min_jacobian_ratio()
    finally:
        gmsh.finalize()
    check(n == expected and bad == 0 and lo > 0,
          "%s: Gmsh finds %d elements (stats: %d), %d with min J <= 0, smallest min J / max J %.3g" % (what, n, expected, bad, lo))


def check_harness():
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("folded")
        s = gmsh.model.addDiscreteEntity(2)
        # P2 triangle (Gmsh type 9): corners, then the midpoints of 0-1, 1-2, 2-0; the first one is
        # pulled across the opposite corner, which folds the element.
        xyz = [0, 0, 0, 1, 0, 0, 0, 1, 0, 0.5, 1.5, 0, 0.5, 0.5, 0, 0, 0.5, 0]
        gmsh.model.mesh.addNodes(2, s, [1, 2, 3, 4, 5, 6], xyz)
        gmsh.model.mesh.addElementsByType(s, 9, [1], [1, 2, 3, 4, 5, 6])
        n, lo, bad = gmsh_min_jacobian_ratio()
    finally:
        gmsh.finalize()
    check(n == 1 and bad == 1, "harness: a folded P2 triangle is found invalid (min J / max J %.3g)" % lo)


def run(hoc, args, work, name):
    out, stats = os.path.join(work, name + ".msh"), os.path.join(work, name + ".json")
    p = subprocess.run([hoc] + args + ["-o", out, "--stats", stats], capture_output=True, text=True, timeout=600)
    if p.returncode != 0:
        check(False, "%s: exit %d: %s" % (name, p.returncode, p.stderr.strip()[-300:]))
        return None, None
    with open(stats) as f:
        return out, json.load(f)["output"]["elements"]


def main(argv):
    hoc = os.path.join(argv[1], "hocurve")
    check_harness()
    cases = [
        ("curve", "ktoolcav.stl", ["--order", "2"]),
        ("curve", "ktoolcav.stl", ["--order", "4"]),
        ("curve", "ktoolcav.stl", ["--order", "6"]),
        ("curve", "t13_data.stl", ["--order", "4"]),
        ("curve", "king_ascii.stl.gz", ["--order", "4"]),
        ("curve", "hammer_scan.obj", ["--order", "4"]),
        ("curve", "thingi10k_1004825.stl", ["--order", "4"]),
        ("coarsen", "skull_lowres.obj", ["--order", "4", "--ratio", "0.04", "--tolerance", "0.005"]),
        ("coarsen", "armadillo.obj", ["--order", "3", "--ratio", "0.03"]),
        ("coarsen", "ktoolcav.stl", ["--order", "4", "--ratio", "0.04", "--tolerance", "0.005"]),
        ("coarsen", "lever_solidedge.stl", ["--order", "4", "--ratio", "0.04"]),
    ]
    with tempfile.TemporaryDirectory() as work:
        for k, (mode, mesh, opts) in enumerate(cases):
            name = "%s %s %s" % (mode, mesh, " ".join(opts))
            out, n = run(hoc, [mode, os.path.join(SHARED, mesh)] + opts, work, "case%d" % k)
            if out:
                check_file(out, n, name)
    print("%d failure(s)" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
