#!/usr/bin/python3
"""End-to-end accuracy check of `hocurve curve`, measured independently of hocurve's C++ code.

Shapes: unit sphere (h=0.1, ~3.2k triangles) and torus R=1, r=0.4 (h=0.2, ~1k triangles), meshed by
Gmsh from exact OCC CAD and written as binary STL. hocurve curves them to P4; bench/measure_error.py
samples every element's Lagrange map (Gmsh basis functions) and measures the exact distance.

Also an abruptly graded sphere (h = 0.2, and 0.025 for x > 0.3): its long edges keep their fits; and
marching-tetrahedra spheres (caps and slivers): no false feature, cone point or planar patch, P4 >= 1000x
below linear; a marching-tetrahedra torus: no fit lowered to the straight triangles by its needles;
open surfaces (a hemisphere, a quarter torus): P4 >= 1000x / 500x below linear at their rims too; a
sphere cut by a plane: P4 at or below Gmsh's exact-CAD P4 next to the oblique rim; a cylinder crossed by a
hole: P4 within 10x of Gmsh's CAD P4 along the intersection curve; ../shared/meshes/cad/screw.step
meshed by Gmsh at d/40 and d/80: P4 >= 100x below linear.

Asserts: output reads back with Gmsh as a single block of type-23 triangles, one per input triangle,
watertight/conforming (every edge's node set shared by exactly two elements), no element with a
non-positive sampled Jacobian against its straight normal; sphere: P4 error >= 1000x below the
linear input's and <= 10x Gmsh's own P4 elevation of the exact CAD (REF); the coarse torus (h = r/2)
too.

Usage: test_accuracy.py BUILD_DIR   (the hocurve binary must exist there: CI builds it)
"""
import os
import shutil
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
from bench import accuracy, cad_sweep, isosurface, shapes  # noqa: E402
from bench import measure_error as me  # noqa: E402

failures = []


def check(cond, what):
    print(("ok    " if cond else "FAIL  ") + what, flush=True)
    if not cond:
        failures.append(what)


def check_harness(work):
    """The harness itself: Gmsh's exact-CAD P4 sphere at h=0.1 must reproduce the independently
    measured baseline of Gmsh's exact-CAD P4 sphere (3.67e-7), and the conformity check must flag an
    element edge whose high-order node is not shared."""
    stl = shapes.make_stl("sphere", 0.1, work)
    ref_path = os.path.join(work, "harness_ref_p4.msh")
    accuracy.gmsh_cad_order("sphere", 0.1, 4, ref_path)
    ref = me.measure(ref_path, "sphere", stl)
    check(2.5e-7 < ref["max"] < 5e-7 and ref["watertight"] and ref["nonpositive_jacobian"] == 0,
          "harness: Gmsh CAD P4 sphere h=0.1 max %.3e (reference 3.67e-7), watertight" % ref["max"])
    conn = me.read_triangles(ref_path)["conn"].copy()
    conn[0, 3] = conn.max() + 1  # a private node on edge 0-1 of element 0
    e = me.edge_check(conn, 4)
    check(not e["watertight"] and e["edges_not_twice"] == 2,
          "harness: an unshared high-order edge node is detected (%d edge keys used once)" % e["edges_not_twice"])


def graded_sphere(work):
    """Unit sphere meshed by Gmsh at h = 0.2, and h = 0.025 for x > 0.3 with no transition: an
    abrupt 8:1 jump (binary STL)."""
    gmsh = shapes.gmsh_init()
    gmsh.model.add("graded_sphere")
    gmsh.model.occ.addSphere(0, 0, 0, 1)
    gmsh.model.occ.synchronize()
    f = gmsh.model.mesh.field.add("Box")
    for k, v in dict(VIn=0.025, VOut=0.2, XMin=0.3, XMax=2, YMin=-2, YMax=2, ZMin=-2, ZMax=2, Thickness=0).items():
        gmsh.model.mesh.field.setNumber(f, k, v)
    gmsh.model.mesh.field.setAsBackgroundMesh(f)
    for o in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature",
              "Mesh.MeshSizeMin"):
        gmsh.option.setNumber(o, 0)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 1e22)
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.model.mesh.generate(2)
    path = os.path.join(work, "graded_sphere.stl")
    gmsh.option.setNumber("Mesh.Binary", 1)
    gmsh.write(path)
    gmsh.model.mesh.field.remove(f)
    gmsh.model.remove()
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 1)  # the defaults shapes.make_stl relies on
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
    return path


def check_graded(hoc, work):
    """Long edges (LongEdgeOptions) on a smooth surface graded abruptly: the edges at the jump are
    long, and PN triangles there measured 1.9e-2. A mesh without features or flat faces skips the
    long-edge rule (its end fits agree anyway: test_solf_features checks that with the rule on)."""
    stl = graded_sphere(work)
    dist = me.distance_function("sphere", stl)
    lin = me.measure(stl, "sphere", stl, dist=dist)
    res = {}
    for ratio in ("2", "0"):
        out = os.path.join(work, "graded_%s.msh" % ratio)
        r = accuracy.run_hocurve(hoc, stl, out, 4, os.path.join(work, "graded_%s.json" % ratio), threads=2,
                                 extra=["--long-edge-ratio", ratio], timeout=300)
        check(r["rc"] == 0, "graded sphere: hocurve curve --long-edge-ratio %s exits 0 %s" % (ratio, r["stderr"][-300:]))
        if r["rc"] != 0:
            return
        res[ratio] = (me.measure(out, "sphere", stl, dist=dist), r["stats"]["curving"]["placement"])
    (m, pl), (m0, _) = res["2"], res["0"]
    print("      graded sphere: %d triangles, %d long edges, %d on PN curves; linear max %.3e | P4 max %.3e "
          "(long edges off: %.3e)" % (lin["elements"], pl["long_edges"], pl["long_edges_placed"], lin["max"],
                                      m["max"], m0["max"]), flush=True)
    check(pl["long_edges"] == 0 and pl["long_edges_placed"] == 0,
          "graded sphere: %d long edges (smooth: the rule skipped), none placed on PN curves" % pl["long_edges"])
    check(m["max"] * 1000 <= lin["max"] and m["max"] <= 1.01 * m0["max"] and m["nonpositive_jacobian"] == 0,
          "graded sphere: P4 error %.3e at least 1000x below linear %.3e, as without long edges" % (m["max"], lin["max"]))


def isosurface_p4(hoc, work, shape, grid, name):
    """Marching tetrahedra of `shape` on a grid^3 lattice (vertices on the surface), curved at P4:
    (the run's curving stats, linear and P4 measures), or None when hocurve failed (checked)."""
    f, half = isosurface.SHAPES[shape]
    V, T = isosurface.marching_tetrahedra(f, half, grid)
    stl = os.path.join(work, "%s_mt%d.stl" % (shape, grid))
    isosurface.write_stl(stl, isosurface.onto_surface(f, V), T, f)
    out = os.path.join(work, "%s_mt%d_p4.msh" % (shape, grid))
    r = accuracy.run_hocurve(hoc, stl, out, 4, out + ".json", timeout=300)
    check(r["rc"] == 0, "%s: hocurve curve --order 4 exits 0 (rc %s)" % (name, r["rc"]))
    if r["rc"] != 0:
        return None
    return r["stats"]["curving"], me.measure(stl, shape), me.measure(out, shape)


def check_isosurface(hoc, work):
    """Marching-tetrahedra spheres (grids 16 and 32: 2,972 and 12,868 triangles, vertices on the
    sphere, edge lengths p99/p1 = 73 and 107). Grid 32's caps made 7 false sharp edges and a quad
    coplanar by chance was flattened as a CAD planar face (P4 1.7e-3); grid 16's vertices amid
    slivers passed as cone points by their angle defect per area (4 flat fans, P4 4.7e-3). Now: no
    feature, no cone point, no planar patch, P4 >= 1000x below linear."""
    for grid in (16, 32):
        name = "iso-surface sphere grid %d" % grid
        run = isosurface_p4(hoc, work, "sphere", grid, name)
        if run is None:
            continue
        c, lin, m = run
        check(c["features"]["sharp_edges"] == 0 and c["features"]["cone_points"] == 0 and
              c["placement"]["planar_faces"] == 0,
              "%s: %d sharp edges, %d cone points, %d planar faces (smooth: none)" % (
                  name, c["features"]["sharp_edges"], c["features"]["cone_points"], c["placement"]["planar_faces"]))
        check(m["max"] * 1000 <= lin["max"] and m["nonpositive_jacobian"] == 0 and m["watertight"],
              "%s: P4 %.3e, linear %.3e (%.0fx), valid, watertight" % (
                  name, m["max"], lin["max"], lin["max"] / max(m["max"], 1e-300)))


def check_isosurface_needles(hoc, work):
    """Marching-tetrahedra tori (grids 24 and 32: 8,656 and 15,716 triangles) have needles whose
    corners nearly meet (a 2.7e-6 edge beside two of 0.14).
    - The fits' sanity bound, sqrt(2 area) of each face, lowered every fit at their corners to the
      straight triangles (grid 32: 6 fits). The bound of such a needle is now its long edge's: no
      fit falls to degree 0.
    - Their long edges' end fits differ by 3-7e-4 of their length, and the long-edge rule put them
      on PN curves: P4 at the linear error (grid 32 6.9e-3, grid 24 1.1e-2). A mesh with almost no
      feature edge and no flat CAD face now trusts its fits on every edge: grid 32 5.2e-6 (>= 1000x
      below linear).
    - Grid 24 pairs needles tilted 23 degrees from their long neighbours: the kink test, in the
      frame of their own normals, made two false feature curves (P4 2.7e-3). Needles whose long
      neighbours contradict them take the frame of the normals around (as caps): one left, 7.5e-4.
    - That one, and grid 16's seven (edges of 36-45 degrees on a coarse tube), are curves of one
      or two edges with a free end; dropped (FeatureOptions::min_dangling_edges = 3): grid 24
      1.8e-5 (>= 300x below linear), grid 16 8.5e-5 (>= 100x; was 1.9e-2)."""
    for grid, gain in ((32, 1000), (24, 300), (16, 100)):
        name = "iso-surface torus grid %d" % grid
        run = isosurface_p4(hoc, work, "torus", grid, name)
        if run is None:
            continue
        c, lin, m = run
        hist = c["fits"]["degree_histogram"]
        check(int(hist.get("0", 0)) == 0 and c["validity"]["invalid_after"] == 0 and c["placement"].get("smooth_surface") and
              c["placement"]["long_edges"] == 0,
              "%s: %s fits of degree 0 (straight), %d invalid after repair, smooth surface %s, %d long edges (smooth: none)" % (
                  name, hist.get("0", 0), c["validity"]["invalid_after"], c["placement"].get("smooth_surface"),
                  c["placement"]["long_edges"]))
        check(m["max"] * gain <= lin["max"] and m["nonpositive_jacobian"] == 0 and m["watertight"],
              "%s: P4 %.3e, linear %.3e (%.0fx >= %dx; %d sharp edges, %d needles aligned), valid, watertight" % (
                  name, m["max"], lin["max"], lin["max"] / max(m["max"], 1e-300), gain,
                  c["features"]["sharp_edges"], c["validity"]["needles_aligned"]))


def cad_stl_and_ref(gmsh, name, h, work):
    """Meshes cad_sweep shape `name` at size h (0: Gmsh's own; left current in gmsh, at order 1): its binary STL and
    Gmsh's exact-CAD P4 of the same triangulation (REF), as paths in work."""
    cad_sweep.build(gmsh, name)
    cad_sweep.set_size(gmsh, h)
    gmsh.model.mesh.generate(2)
    stl = os.path.join(work, name + ".stl")
    gmsh.option.setNumber("Mesh.Binary", 1)
    gmsh.write(stl)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.model.mesh.setOrder(4)
    ref_path = os.path.join(work, name + "_ref4.msh")
    gmsh.write(ref_path)
    gmsh.model.mesh.setOrder(1)
    return stl, ref_path


def check_open_surfaces(hoc, work):
    """Open surfaces (binary STL): a hemisphere (h = 0.05, 6,184 triangles) and a quarter torus
    (h = 0.1, 998 triangles), each bounded by circles. A vertex on the boundary has one wedge but a
    half disc of rings; fitted on the two-sided point count, float32 rounding was amplified at the
    hemisphere's rim (P4 1.97e-6, 350x below linear) and the torus's rim fits were 14x Gmsh's
    exact-CAD P4 (2.2e-5). Now: P4 >= 1000x / 500x below linear, within 10x of Gmsh's CAD P4.
    The hemisphere at h = 0.4 (199 triangles): its rim edges (6.7% of its edges) counted as creases, so
    it was no smooth surface and a long edge at its pole went on a PN triangle (P4 4.3e-2, linear
    4.8e-2); rims no longer count: P4 >= 1000x below linear."""
    gmsh = shapes.gmsh_init()
    for name, sphere_or_torus, h, gain in (("hemisphere", "sphere", 0.05, 1000), ("quartertorus", "torus", 0.1, 500),
                                           ("hemisphere", "sphere", 0.4, 1000)):
        stl, ref_path = cad_stl_and_ref(gmsh, name, h, work)
        gmsh.model.remove()
        out = os.path.join(work, name + "_p4.msh")
        r = accuracy.run_hocurve(hoc, stl, out, 4, out + ".json", timeout=300)
        check(r["rc"] == 0, "%s: hocurve curve --order 4 exits 0 (rc %s)" % (name, r["rc"]))
        if r["rc"] != 0:
            continue
        # Distances to the whole sphere / torus: the open surface's samples lie on its own part.
        dist = me.distance_function(sphere_or_torus, stl)
        lin, m, ref = (me.measure(x, sphere_or_torus, stl, dist=dist) for x in (stl, out, ref_path))
        rim = m["edges_not_twice"] > 0 and m["conforming"]
        check(m["max"] * gain <= lin["max"] and m["max"] <= 10 * ref["max"] and m["nonpositive_jacobian"] == 0 and rim,
              "%s: P4 %.3e, linear %.3e (%.0fx, >= %dx), Gmsh CAD P4 %.3e; valid, conforming but its %d rim edges" % (
                  name, m["max"], lin["max"], lin["max"] / max(m["max"], 1e-300), gain, ref["max"], m["edges_not_twice"]))


def check_curve_sides(hoc, work):
    """Elements beside CAD curves where the surface meets the curve obliquely (h = 0.1).
    - A sphere cut by a plane (2,826 triangles): the rim's curve fits move its nodes tangentially off
      the sphere fits' blend. Face nodes beside the rim that stayed on the blend bent the elements
      between their nodes: P4 2.6e-6 (1300x below linear, 11x above Gmsh's exact-CAD P4), order 3.
      Now P4 at or below Gmsh's CAD P4 and >= 3e4x below linear (4.4e-8, 77,000x: the float32
      STL's rounding; from an ASCII STL 3.4e-9).
    - A cylinder crossed by a hole (2,874 triangles): its intersection curve turns away from any
      circle, and curve fits reaching three edges each way missed it by 4.9e-5 (13x Gmsh's CAD P4);
      on a narrower stencil 2.1e-5 (300x below linear). Its edges now go where the two surface
      fits cross: P4 at or below Gmsh's CAD P4 and >= 3000x below linear (6.5e-7, 10,000x).
    - A cone (674 triangles) with 3 triangles round its apex, whose edges read as short feature
      curves: the apex fan stayed straight (P4 = linear, 3.7e-2; Gmsh's CAD P4 9.7e-3). Now a cone
      model fits round the apex: P4 at or below Gmsh's CAD P4 and >= 10x below linear (2.3e-3, 16x).
    - Two cylinders crossed in a tee (1,400 triangles): the saddle curve where they meet moves its
      nodes along the branch by up to 7.6% of an edge beyond the surface blend, and faces beside it
      only followed shifts within 5% (the limit that keeps scans' noisy curve fits out of faces):
      every node within 2e-8 of the CAD, yet P4 8.6e-5 (7x Gmsh's CAD P4) between them. A curve
      between two exact surfaces is their crossing, and faces now follow it whatever its shift:
      P4 at or below Gmsh's CAD P4 and >= 1000x below linear."""
    gmsh = shapes.gmsh_init()
    for name, gain, ref_factor in (("cutsphere", 3e4, 1), ("crosshole", 3000, 1), ("cone", 10, 1), ("tee", 1000, 1)):
        check_cad_p4(gmsh, hoc, work, name, 0.1, gain, ref_factor)


def check_cad_p4(gmsh, hoc, work, name, h, gain, ref_factor):
    """cad_sweep shape `name` meshed at size h (0: Gmsh's own), curved at P4 from its binary STL:
    at least `gain` below linear, at most ref_factor x Gmsh's exact-CAD P4, valid and watertight."""
    stl, ref_path = cad_stl_and_ref(gmsh, name, h, work)
    out = os.path.join(work, "%s_%g_p4.msh" % (name, h))
    r = accuracy.run_hocurve(hoc, stl, out, 4, out + ".json", timeout=300)
    what = "%s at %s" % (name, "h = %g" % h if h > 0 else "Gmsh's sizes")
    check(r["rc"] == 0, "%s: hocurve curve --order 4 exits 0 (rc %s)" % (what, r["rc"]))
    if r["rc"] == 0:
        (lin, _, n, _), (p4, _, _, tight), (ref, _, _, _) = (cad_sweep.measure(gmsh, x, name) for x in (stl, out, ref_path))
        inv = r["stats"]["curving"]["validity"]["invalid_after"]
        check(p4 <= ref_factor * ref and p4 * gain <= lin and tight and inv == 0,
              "%s (%d triangles): P4 %.3e, linear %.3e (%.0fx, >= %gx), Gmsh CAD P4 %.3e (%.2fx, at most %gx); "
              "valid, watertight" % (what, n, p4, lin, lin / max(p4, 1e-300), gain, ref, p4 / max(ref, 1e-300), ref_factor))
    gmsh.model.remove()


def check_coarse_quadrics(hoc, work):
    """CAD shapes meshed at Gmsh's own sizes (binary STL, 140-520 triangles, 6-16 edges round a
    circle): every edge turns by 25-60 degrees, so the sides of cylinders, cones and ellipsoids read
    as creases, and their fits, on stencils wrapping a third of the way round, missed by the chord.
    P4 was at the linear error but on the ellipsoid (2x) and frustum (4x). Their vertices lie on
    quadrics to rounding: such edges are now chords (FeatureOptions::exact_quadrics), such wedges
    fit the quadric (FitOptions::exact_quadrics), and curves between two of them follow the
    crossing: P4 >= 40x below linear, within 3x of Gmsh's exact-CAD P4; the tee, the drilled ball
    and the cross hole, whose faces now follow those curves smoothly (place_nodes), at most 1x
    (they were 2.5x, 1.3x and 1.5x: 5.7e-4, 4.5e-4, 3.0e-4; now about 0.3x, 0.1x, 0.2x). The half torus's vertices
    lie on no quadric but on a cyclide (ExactQuadricOptions::cyclides): P4 was at the linear error
    (5.8e-2), now 4.4e-4, 0.85x Gmsh's. The capsule and the filleted box meet their half spheres,
    fillets and corner spheres tangentially, and at these sizes every stencil reaches across a
    junction: 3.1e-3 and 3.7e-3 (67x and 47x Gmsh's) until quadrics were confirmed by their regions
    (ExactQuadricOptions::region_points), shared with neighbours whose faces lie on them, and fitted
    tangent to them on fillets two triangles across (share_exact_fits.hpp): 2.1e-5 and 3.4e-5.
    The filleted box at h = 0.1: its corner spheres' faces have every corner on a junction circle,
    and their nodes were blended from fits across the junctions (2.4e-3, 63x Gmsh's) until faces
    took the exact fit of a neighbour that holds them (face_exact_fits): 1.4e-5. The rounded
    cylinder at h = 0.1: its torus fillets are two rows across, and no fan of the middle row
    determines a cyclide (1.9e-3, 32x Gmsh's) until each fillet's whole region was fitted tangent to
    the cylinder and the plane along its rims (fit_tangent_cyclide): 4.4e-5. The rounded cylinder at
    Gmsh's sizes (370 triangles): its fillets are one triangle across, and the wedges beside the few
    vertices inside them fitted a plane times a sphere (the cap's points and the fillet's on one
    cubic cyclide, 57 degrees off the torus): P4 4.0e-2, the linear error. Cubic cyclides are no
    CAD faces (plane_sphere): P4 now >= 2x below linear (1.6e-2; Gmsh's CAD P4 1.2e-3: its edges
    turning 36 degrees across the fillet still read as creases)."""
    gmsh = shapes.gmsh_init()
    for name in ("frustum", "ellipsoid", "halftorus", "capsule", "filletbox"):
        check_cad_p4(gmsh, hoc, work, name, 0, 40, 3)
    for name in ("tee", "drilledball", "crosshole"):  # curves between two exact surfaces: at most Gmsh's
        check_cad_p4(gmsh, hoc, work, name, 0, 40, 1)
    check_cad_p4(gmsh, hoc, work, "filletbox", 0.1, 100, 3)
    check_cad_p4(gmsh, hoc, work, "roundcyl", 0.1, 100, 3)
    check_cad_p4(gmsh, hoc, work, "roundcyl", 0, 2, 15)


def check_freeform(hoc, work):
    """A loft through an ellipse, a circle and an ellipse (a B-spline side no quadric or cyclide
    holds, between two flat caps), h = 0.1. Its top rim turns 43 degrees at the two vertices beside
    the ellipse's tip and 25 next to them: both were corners, so the tip edge stayed a chord (P4
    1.39e-3, 5x below linear) until a curve turning alike on both sides, or more gently on one,
    counts as a coarse smooth curve (FeatureOptions::coarse_circle_max_deg): 2.1e-4. Free-form
    surfaces rest on the polynomial fits, and at this size those are about 20x Gmsh's exact-CAD P4
    (1.0e-5): the bound records that gap, it is not a goal."""
    gmsh = shapes.gmsh_init()
    check_cad_p4(gmsh, hoc, work, "loft", 0.1, 25, 30)


def main(argv):
    build = argv[1] if len(argv) > 1 else os.environ.get("HOCURVE_BUILD_DIR", "build")
    hoc = os.path.join(build, "hocurve")
    if not os.access(hoc, os.X_OK):
        print("FAIL  hocurve binary not found at %s (build the 'hocurve' target)" % hoc)
        return 1
    work = tempfile.mkdtemp(prefix="hocurve-acc-")
    check_harness(work)
    check_graded(hoc, work)
    check_isosurface(hoc, work)
    check_isosurface_needles(hoc, work)
    check_open_surfaces(hoc, work)
    check_curve_sides(hoc, work)
    check_coarse_quadrics(hoc, work)
    check_freeform(hoc, work)
    # (shape, size, gain, ref_factor): P4 at least gain x below linear and, where ref_factor is
    # given, within ref_factor x Gmsh's exact-CAD P4 (the brief's targets for the sphere: 1000x,
    # 10x); the coarse torus (h = r/2) the same since its cyclide fits (1575x, 0.37x Gmsh; 244x before); the coarse
    # ellipsoid (226 triangles) had two one-edge false curves at its tips and was 2x below linear
    # (FeatureOptions::min_dangling_edges: 115x).
    # The torus at h = 0.05 (15k triangles): wedges took neighbours' cyclides, each fitted to one
    # stencil and 6-7e-7 off where extrapolated (P4 7.7e-7, 5.5x Gmsh's) until the wedges holding
    # one surface refit it together (refit_shared_surfaces): 6.4e-8.
    # screw.step at d/40 and d/80 (864 and 2954 triangles): its dome is a spindle torus whose apex
    # the slot cuts away; the wedges beside the slot took no cyclide (the next one within 15-350x
    # the tolerance, the slot's rims 12x the tolerance off the dome) and P4 was 21x / 45x below
    # linear (9.0e-3 / 1.25e-3) until ExactQuadricOptions::unique_cyclide_precise and
    # fit_region's off_features: 555x / 159x (3.3e-4 / 3.5e-4).
    # T20 at d/20 (1840 triangles): its nut's conical chamfer is one triangle across between the top
    # circle and the hex flats' hyperbolas, and vanishes where they touch. Fitted across the band
    # (32x below linear, 4.4e-3) until band fits took the rulings (FitOptions::band_ruling_max_deg),
    # and the elements at the cusps, failing only at that corner, were bisected toward straight
    # instead of pulled 20%: see bench/README.
    cases = [("sphere", 0.1, 1000, 10), ("torus", 0.2, 1000, 10), ("torus", 0.05, 1000, 1), ("ellipsoid", 0.3, 50, None),
             ("screw", "d/40", 100, None), ("screw", "d/80", 100, None), ("t20", "d/20", 100, None)]
    for name, size, gain, ref_factor in cases:
        stl = shapes.make_stl(name, size, work)
        h = shapes.size_value(name, size)
        dist = me.distance_function(name, stl)
        lin = me.measure(stl, name, stl, dist=dist)
        label = shapes.size_label(size)
        out = os.path.join(work, "%s_%s_p4.msh" % (name, label))
        r = accuracy.run_hocurve(hoc, stl, out, 4, os.path.join(work, "%s_%s.json" % (name, label)), threads=2,
                                 extra=["--binary"], timeout=300)
        check(r["rc"] == 0, "%s: hocurve curve --order 4 exits 0 (rc %s, %.1f s) %s" % (
            name, r["rc"], r["seconds"], r["stderr"].strip()[-300:] if r["rc"] else ""))
        if r["rc"] != 0:
            continue
        m = me.measure(out, name, stl, dist=dist)
        ref_path = os.path.join(work, "%s_%s_ref_p4.msh" % (name, label))
        accuracy.gmsh_cad_order(name, h, 4, ref_path)
        ref = me.measure(ref_path, name, stl, dist=dist)
        print("      %s: %d triangles; linear max %.3e | hocurve P4 max %.3e rms %.3e | "
              "Gmsh REF P4 max %.3e | linear/P4 %.0f, P4/REF %.2f, min J ratio %.3f" % (
                  name, lin["elements"], lin["max"], m["max"], m["rms"], ref["max"],
                  lin["max"] / max(m["max"], 1e-300), m["max"] / max(ref["max"], 1e-300),
                  m["min_jacobian_ratio"]), flush=True)
        check(m["element_type"] == 23 and set(m["types"]) <= {"23", "15", "1"},
              "%s: output is Gmsh type 23 (P4 triangles); element types %s" % (name, m["types"]))
        check(m["elements"] == lin["elements"],
              "%s: %d elements for %d input triangles" % (name, m["elements"], lin["elements"]))
        check(m["watertight"], "%s: watertight and conforming (%d edges not shared by exactly 2)" % (
            name, m["edges_not_twice"]))
        check(m["nonpositive_jacobian"] == 0,
              "%s: %d elements with non-positive sampled Jacobian" % (name, m["nonpositive_jacobian"]))
        check(m["max"] * gain <= lin["max"], "%s: P4 error %.3e at least %gx below linear %.3e" % (
            name, m["max"], gain, lin["max"]))
        if ref_factor:
            check(m["max"] <= ref_factor * ref["max"], "%s: P4 error %.3e within %gx of Gmsh CAD P4 %.3e" % (
                name, m["max"], ref_factor, ref["max"]))
    if failures:
        print("test_accuracy: %d check(s) failed (files kept in %s)" % (len(failures), work))
        return 1
    shutil.rmtree(work, ignore_errors=True)
    print("test_accuracy: all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
