#!/usr/bin/python3
"""Generality sweep: CAD shapes that no option was tuned on, curved from Gmsh's STL at P1..P6.

Each shape is built with Gmsh's OpenCASCADE kernel (a cone with its apex, a box with filleted edges,
a cylinder with a cross hole, a sphere cut by a plane, half a torus, a capsule and a cylinder with
filleted rims (tangent junctions); three open surfaces, whose rims are boundary curves: a hemisphere,
a pipe and a quarter torus; the lists COARSE, FREEFORM and UNSEEN name more, run when named), meshed
by Gmsh at size h, written
as STL, curved by `hocurve curve --order p`, and measured against the exact CAD: the largest distance
from the element's own Lagrange map, sampled on a degree max(2p, 6) lattice, to the closest of the
model's surfaces (gmsh.model.getClosestPoint). Also reported: the largest distance per CAD surface
type (plane, cylinder, sphere, cone, torus, ...) closest to each sample, which tells where the
error is (e.g. the fillets of a box), and that every element is valid and the mesh watertight (open
surfaces: conforming, every edge used twice but whole rim edges).
REF P4: Gmsh's own P4 of the same triangulation from the exact CAD (setOrder(4)), for scale.
--entities: hocurve reads Gmsh's .msh of the same mesh instead, each CAD face an entity, so the
face borders (tangent ones too, e.g. where a fillet meets a plane) are feature curves.

--algorithm N: Gmsh's 2D mesher (Mesh.Algorithm: 1 MeshAdapt, 5 Delaunay, 6 Frontal-Delaunay, its
default); --curvature N: sizes from the curvature as well (Mesh.MeshSizeFromCurvature, N elements
per 2 pi radians), as users of CAD parts often ask. Other meshers than the default leave other
triangulations of the same shapes: long edges beside short ones, slivers at tangent junctions.

Usage: cad_sweep.py [--hocurve build/hocurve] [--out /tmp/hocurve-sweep] [--sizes 0.1,0.05]
                    [--orders 1,2,4,6] [--entities] [--algorithm 6] [--curvature 0] [SHAPE ...]
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench import measure_error as me  # noqa: E402
from bench import shapes  # noqa: E402

SHAPES = ["cone", "filletbox", "crosshole", "cutsphere", "halftorus", "capsule", "roundcyl"]
# COARSE: coarse meshes of CAD quadrics, mostly run at Gmsh's own sizes (--sizes default).
COARSE = ["tee", "drilledball", "frustum", "ellipsoid"]
# FREEFORM: free-form B-spline surfaces (no exact quadric or cyclide holds them): a loft through
# three unlike sections, and a torus stretched unevenly.
FREEFORM = ["loft", "squashedtorus"]
# UNSEEN: shapes no option was tuned on: a vase (a spline profile revolved), a cam
# (a closed spline extruded: a ruled B-spline side), a twisted prism (a square lofted onto its 45-degree turn), a
# box with chamfered edges, a plate with holes, spherical caps out of a block, a knob with a rounded end; then an
# elbow (two cylinders and a quarter torus), a spherical pocket in a block, a stadium prism, a cone on a
# cylinder with an oblique hole, an elliptic cylinder.
UNSEEN = ["vase", "cam", "twist", "chamferbox", "holeplate", "dome", "knob", "elbow", "pocket", "stadium", "conecyl",
          "ellipcyl"]
# OPEN: open surfaces, the solid's planar faces removed, their rims left as boundary curves.
OPEN = ["hemisphere", "pipe", "quartertorus"]


def build(gmsh, name):
    """Create shape `name` in a new model (made current)."""
    gmsh.model.add(name)
    occ = gmsh.model.occ
    if name == "cone":  # apex at (0, 0, 1): a point singularity
        occ.addCone(0, 0, 0, 0, 0, 1, 0.5, 0)
    elif name == "filletbox":  # planes, cylinders and sphere corners meeting tangentially
        box = occ.addBox(0, 0, 0, 1, 0.8, 0.6)
        occ.synchronize()
        occ.fillet([box], [t for (_, t) in gmsh.model.getEntities(1)], [0.15])
    elif name == "crosshole":  # two cylinders: a non-planar intersection curve
        outer = occ.addCylinder(0, 0, -1, 0, 0, 2, 0.6)
        hole = occ.addCylinder(-1, 0, 0, 2, 0, 0, 0.3)
        occ.cut([(3, outer)], [(3, hole)])
    elif name == "cutsphere":
        sphere = occ.addSphere(0, 0, 0, 1)
        occ.cut([(3, sphere)], [(3, occ.addBox(-2, -2, 0.4, 4, 4, 4))])
    elif name == "halftorus":
        torus = occ.addTorus(0, 0, 0, 1, 0.35)
        occ.cut([(3, torus)], [(3, occ.addBox(-2, 0, -1, 4, 2, 2))])
    elif name == "capsule":  # a cylinder between two half spheres: tangent circles
        parts = [occ.addCylinder(0, 0, -0.5, 0, 0, 1, 0.4), occ.addSphere(0, 0, -0.5, 0.4), occ.addSphere(0, 0, 0.5, 0.4)]
        occ.fuse([(3, parts[0])], [(3, p) for p in parts[1:]])
    elif name == "roundcyl":  # a cylinder with filleted rims: tori tangent to the side and the caps
        cyl = occ.addCylinder(0, 0, 0, 0, 0, 1, 0.5)
        occ.synchronize()
        occ.fillet([cyl], [t for (_, t) in gmsh.model.getEntities(1) if gmsh.model.getType(1, t) == "Circle"], [0.12])
    elif name == "tee":  # two cylinders fused: a saddle-shaped junction curve
        occ.fuse([(3, occ.addCylinder(-1, 0, 0, 2, 0, 0, 0.3))], [(3, occ.addCylinder(0, 0, 0, 0, 0, 1, 0.2))])
    elif name == "drilledball":  # a sphere with a hole through it
        occ.cut([(3, occ.addSphere(0, 0, 0, 1))], [(3, occ.addCylinder(0, 0, -2, 0, 0, 4, 0.3))])
    elif name == "frustum":  # a truncated cone between two planes
        occ.addCone(0, 0, 0, 0, 0, 1, 0.5, 0.2)
    elif name == "ellipsoid":  # a sphere scaled (a B-spline surface in OCC)
        occ.dilate([(3, occ.addSphere(0, 0, 0, 1))], 0, 0, 0, 1, 0.7, 0.5)
    elif name == "loft":  # B-spline side through an ellipse, a circle and a tilted ellipse, flat caps
        wires = []
        for z, rx, ry, dx in ((0, 0.6, 0.35, 0), (0.6, 0.3, 0.3, 0.15), (1.2, 0.5, 0.25, -0.1)):
            c = occ.addEllipse(dx, 0, z, rx, ry) if rx != ry else occ.addCircle(dx, 0, z, rx)
            wires.append(occ.addCurveLoop([c]))
        occ.addThruSections(wires, makeSolid=True, makeRuled=False)
    elif name == "squashedtorus":  # a torus scaled unevenly (a B-spline surface in OCC)
        occ.dilate([(3, occ.addTorus(0, 0, 0, 1, 0.4))], 0, 0, 0, 1, 0.6, 0.8)
    elif name == "vase":  # a spline profile revolved about z: a surface of revolution, not a quadric
        prof = [occ.addPoint(x, 0, z) for x, z in ((0.5, 0), (0.7, 0.4), (0.4, 0.8), (0.5, 1.2))]
        axis0, axis1 = occ.addPoint(0, 0, 0), occ.addPoint(0, 0, 1.2)
        loop = occ.addCurveLoop([occ.addLine(axis0, prof[0]), occ.addSpline(prof), occ.addLine(prof[-1], axis1),
                                 occ.addLine(axis1, axis0)])
        face = occ.addPlaneSurface([loop])
        occ.revolve([(2, face)], 0, 0, 0, 0, 0, 1, 2 * np.pi)
        occ.remove([(2, face)])  # a full turn leaves the profile inside the solid
    elif name == "cam":  # a closed smooth spline extruded: flat caps, a ruled free-form side
        t = np.linspace(0, 2 * np.pi, 9)[:-1]
        r = 0.5 + 0.15 * np.cos(t) + 0.1 * np.sin(2 * t)
        pts = [occ.addPoint(ri * np.cos(ti), ri * np.sin(ti), 0) for ri, ti in zip(r, t)]
        curve = occ.addSpline(pts + [pts[0]])
        occ.extrude([(2, occ.addPlaneSurface([occ.addCurveLoop([curve])]))], 0, 0, 0.6)
    elif name == "twist":  # a square lofted onto itself turned 45 degrees: twisted B-spline sides, sharp edges
        wires = []
        for z, a in ((0, 0), (1, np.pi / 4)):
            c = [(0.4 * np.cos(a + k * np.pi / 2), 0.4 * np.sin(a + k * np.pi / 2)) for k in range(4)]
            p = [occ.addPoint(x, y, z) for x, y in c]
            wires.append(occ.addCurveLoop([occ.addLine(p[k], p[(k + 1) % 4]) for k in range(4)]))
        occ.addThruSections(wires, makeSolid=True, makeRuled=False)
    elif name == "holeplate":  # a plate with two holes: at Gmsh's sizes, walls of 5-7 chords, three rows high
        plate = occ.addBox(0, 0, 0, 2, 1, 0.1)
        occ.cut([(3, plate)], [(3, occ.addCylinder(x, 0.5, -1, 0, 0, 2, r)) for x, r in ((0.5, 0.12), (1.4, 0.2))])
    elif name == "dome":  # spherical caps out of a block's faces: concave circles, small caps meshed as fans
        caps = [occ.addSphere(-0.5, 0, -0.3, 0.35), occ.addSphere(0.4, 0, -0.5, 0.6)]
        occ.fuse([(3, occ.addBox(-1, -0.5, -0.4, 2, 1, 0.4))], [(3, c) for c in caps])
    elif name == "knob":  # a cylinder with a hemispherical end on a plate: a tangent circle
        knob = [occ.addCylinder(0, 0, 0, 0, 0, 0.5, 0.25), occ.addSphere(0, 0, 0.5, 0.25)]
        occ.fuse([(3, occ.addBox(-1, -1, -0.2, 2, 2, 0.2))], [(3, k) for k in knob])
    elif name == "chamferbox":  # a box with its 12 edges chamfered: planes only, 45-degree and corner creases
        box = occ.addBox(0, 0, 0, 1, 0.8, 0.6)
        occ.synchronize()
        edges = [t for (_, t) in gmsh.model.getEntities(1)]
        occ.chamfer([box], edges, [gmsh.model.getAdjacencies(1, e)[0][0] for e in edges], [0.1])
    elif name == "elbow":  # two cylinders joined by a quarter torus: tangent circles
        quarter = occ.intersect([(3, occ.addTorus(0, 0, 0, 1, 0.3))], [(3, occ.addBox(0, 0, -1, 2, 2, 2))])[0]
        occ.fuse([(3, occ.addCylinder(1, 0, 0, 0, -1, 0, 0.3))], quarter + [(3, occ.addCylinder(0, 1, 0, -1, 0, 0, 0.3))])
    elif name == "pocket":  # a spherical pocket cut into a block's top
        occ.cut([(3, occ.addBox(-1, -1, -0.5, 2, 2, 0.5))], [(3, occ.addSphere(0, 0, 0.3, 0.6))])
    elif name == "stadium":  # a slot-shaped prism: half cylinders tangent to its flat sides
        ends = [occ.addCylinder(x, 0, 0, 0, 0, 0.4, 0.3) for x in (-0.5, 0.5)]
        occ.fuse([(3, occ.addBox(-0.5, -0.3, 0, 1, 0.6, 0.4))], [(3, e) for e in ends])
    elif name == "conecyl":  # a cone on a cylinder, an oblique hole through both
        body = occ.fuse([(3, occ.addCylinder(0, 0, 0, 0, 0, 0.6, 0.5))], [(3, occ.addCone(0, 0, 0.6, 0, 0, 0.5, 0.5, 0.1))])
        occ.cut(body[0], [(3, occ.addCylinder(-1, -0.3, 0.2, 2, 0.6, 0.5, 0.12))])
    elif name == "ellipcyl":  # a cylinder scaled to semi-axes 0.5, 0.3 (a B-spline surface in OCC)
        occ.dilate([(3, occ.addCylinder(0, 0, 0, 0, 0, 1, 0.5))], 0, 0, 0, 1, 0.6, 1)
    elif name == "hemisphere":  # boundary: the equator, where the surface is vertical
        sphere = occ.addSphere(0, 0, 0, 1)
        occ.cut([(3, sphere)], [(3, occ.addBox(-2, -2, -2, 4, 4, 2))])
    elif name == "pipe":  # boundary: two circles on a ruled surface
        occ.addCylinder(0, 0, 0, 0, 0, 2, 0.5)
    elif name == "quartertorus":  # boundary: two tube circles, across the saddle inside
        torus = occ.addTorus(0, 0, 0, 1, 0.4)
        occ.intersect([(3, torus)], [(3, occ.addBox(0, 0, -1, 2, 2, 2))])
    else:
        raise ValueError("unknown shape " + name)
    occ.synchronize()
    if name in OPEN:
        gmsh.model.removeEntities(gmsh.model.getEntities(3))
        gmsh.model.removeEntities([(2, t) for (_, t) in gmsh.model.getEntities(2) if gmsh.model.getType(2, t) == "Plane"])


def set_size(gmsh, h):
    """Mesh size h (down to h / 4), or for h = 0 Gmsh's defaults."""
    gmsh.option.setNumber("Mesh.MeshSizeMax", h if h > 0 else 1e22)
    gmsh.option.setNumber("Mesh.MeshSizeMin", h / 4)


def closest_surface(gmsh, P):
    """Distance from every point of P to the current model's surfaces, and the closest one's type."""
    best = np.full(len(P), np.inf)
    kind = np.empty(len(P), dtype=object)
    for (_, tag) in gmsh.model.getEntities(2):
        c, _ = gmsh.model.getClosestPoint(2, tag, P.reshape(-1).tolist())
        d = np.linalg.norm(np.asarray(c).reshape(-1, 3) - P, axis=1)
        closer = d < best
        best[closer], kind[closer] = d[closer], gmsh.model.getType(2, tag)
    return best, kind


def measure(gmsh, msh, name):
    m = me.read_triangles(msh)
    gmsh.model.setCurrent(name)
    B = me.basis(m["type"], me.lattice(max(2 * m["order"], 6)))
    P = np.einsum("pn,enk->epk", B, m["X"]).reshape(-1, 3)
    d, kind = closest_surface(gmsh, P)
    by_kind = {k: float(d[kind == k].max()) for k in sorted(set(kind))}
    ec = me.edge_check(m["conn"], m["order"])
    # Open surfaces and non-manifold ones cannot be watertight: conforming is what they can be.
    tight = ec["watertight"] or (name in OPEN and ec["conforming"])
    return float(d.max()), by_kind, len(m["X"]), tight


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("shapes", nargs="*", default=SHAPES + OPEN)
    ap.add_argument("--hocurve", default=os.path.join(os.path.dirname(__file__), "..", "build", "hocurve"))
    ap.add_argument("--out", default="/tmp/hocurve-sweep")
    ap.add_argument("--sizes", default="0.1,0.05",
                    help="mesh sizes; 'default' leaves Gmsh's own (from the shape's size: coarse)")
    ap.add_argument("--orders", default="1,2,4,6")
    ap.add_argument("--entities", action="store_true",
                    help="give hocurve a .msh keeping the CAD faces as entities (their borders are then features) instead of the STL")
    ap.add_argument("--algorithm", type=int, default=6, help="Gmsh's Mesh.Algorithm (1, 5, 6, ...)")
    ap.add_argument("--curvature", type=int, default=0, help="Gmsh's Mesh.MeshSizeFromCurvature (0: off)")
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    gmsh = shapes.gmsh_init()
    orders = [int(p) for p in a.orders.split(",")]
    print("| shape | h | #tri | " + " | ".join("P%d" % p for p in orders) + " | REF P4 | worst surface type (P4 or last) | invalid | watertight |")
    print("|---|---|---|" + "---|" * len(orders) + "---|---|---|---|")
    failed = False
    for name in a.shapes:
        for h in (0.0 if x == "default" else float(x) for x in a.sizes.split(",")):
            build(gmsh, name)
            set_size(gmsh, h)
            gmsh.option.setNumber("Mesh.Algorithm", a.algorithm)
            gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", a.curvature)
            gmsh.model.mesh.generate(2)
            stl = os.path.join(a.out, "%s_%g.%s" % (name, h, "msh" if a.entities else "stl"))
            gmsh.write(stl)
            gmsh.model.mesh.setOrder(4)
            ref = os.path.join(a.out, "%s_%g_ref4.msh" % (name, h))
            gmsh.write(ref)
            gmsh.model.mesh.setOrder(1)
            errors, invalid, tight, ntri, where = [], 0, True, 0, ""
            for p in orders:
                msh = os.path.join(a.out, "%s_%g%s_p%d.msh" % (name, h, "_entities" if a.entities else "", p))
                r = subprocess.run([a.hocurve, "curve", stl, "--order", str(p), "-o", msh, "--stats", msh + ".json"],
                                   capture_output=True, text=True)
                if r.returncode != 0:
                    errors.append("exit %d" % r.returncode)
                    failed = True
                    continue
                stats = json.load(open(msh + ".json"))
                invalid += stats["curving"]["validity"]["invalid_after"] if p > 1 else 0
                e, by_kind, ntri, wt = measure(gmsh, msh, name)
                tight &= bool(wt)
                errors.append("%.2e" % e)
                if p == 4 or not where:
                    where = ", ".join("%s %.1e" % kv for kv in by_kind.items())
            failed |= invalid > 0 or not tight
            ref_error = measure(gmsh, ref, name)[0]
            print("| %s | %g | %d | %s | %.2e | %s | %d | %s |" % (name, h, ntri, " | ".join(errors), ref_error, where,
                                                                 invalid, "yes" if tight else "no"), flush=True)
            gmsh.model.remove()
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
