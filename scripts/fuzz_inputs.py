#!/usr/bin/python3
"""Robustness fuzzing of the hocurve CLI with unusual but legitimate (or plausibly bad) inputs.

Generates meshes (derived from /work/shared/meshes plus tiny synthetic ones) into a temporary
directory, runs `hocurve curve --order 4` and `hocurve coarsen --order 4 --ratio 0.1` (both with
--stats) on each, and checks:
  * exit code in {0, 3} (3 = input refused; must come with a message on stderr), no signal, no hang;
  * on 0: the .msh reads back with the gmsh Python module, every triangle has the requested order,
    no NaN/Inf node coordinate, the stats JSON has invalid_after == 0 everywhere (curve:
    curving.validity; coarsen: lifting.validity and rejoin) and its element count matches the file.
Also runs --order 2 / --order 6 on a few cases and --threads 1 vs --threads 2 (byte-identical output).

Usage: nice /usr/bin/python3 scripts/fuzz_inputs.py [--hocurve build/hocurve] [--only REGEX]
       [--keep DIR (failing inputs are copied here; default /tmp/fuzz)] [--timeout 120] [--list]
Exit status: 0 if every run passed, 1 otherwise.
"""
import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
MESHES = os.path.normpath(os.path.join(HERE, "..", "..", "shared", "meshes"))  # ../shared beside the repo
SEED = 20240601

# --------------------------------------------------------------------------------------------
# mesh I/O


def read_obj(path):
    V, F = [], []
    with open(path) as f:
        for line in f:
            t = line.split()
            if not t:
                continue
            if t[0] == "v":
                V.append([float(x) for x in t[1:4]])
            elif t[0] == "f":
                idx = []
                for c in t[1:]:
                    i = int(c.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(V) + i)
                for k in range(1, len(idx) - 1):
                    F.append([idx[0], idx[k], idx[k + 1]])
    return np.array(V, float), np.array(F, np.int64)


def read_stl_ascii(path):
    pts = []
    with open(path) as f:
        for line in f:
            t = line.split()
            if t and t[0] == "vertex":
                pts.append(tuple(float(x) for x in t[1:4]))
    index, V, F = {}, [], []
    for k in range(0, len(pts), 3):
        tri = []
        for p in pts[k:k + 3]:
            if p not in index:
                index[p] = len(V)
                V.append(p)
            tri.append(index[p])
        F.append(tri)
    return np.array(V, float), np.array(F, np.int64)


def load(name):
    p = os.path.join(MESHES, name)
    return read_obj(p) if name.endswith(".obj") else read_stl_ascii(p)


def write_obj(path, V, F, header="fuzz"):
    with open(path, "w") as f:
        f.write("# %s\n" % header)
        for v in V:
            f.write("v %.17g %.17g %.17g\n" % tuple(v))
        for t in F:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))


def write_stl(path, V, F, name="fuzz"):
    V = np.asarray(V, float)
    with open(path, "w") as f:
        f.write("solid %s\n" % name)
        for t in F:
            a, b, c = V[t[0]], V[t[1]], V[t[2]]
            n = np.cross(b - a, c - a)
            ln = np.linalg.norm(n)
            n = n / ln if ln > 0 else np.zeros(3)
            f.write(" facet normal %.9g %.9g %.9g\n  outer loop\n" % tuple(n))
            for p in (a, b, c):
                f.write("   vertex %.17g %.17g %.17g\n" % tuple(p))
            f.write("  endloop\n endfacet\n")
        f.write("endsolid %s\n" % name)


def mean_edge(V, F):
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    return float(np.mean(np.linalg.norm(V[e[:, 0]] - V[e[:, 1]], axis=1)))


def combine(*parts):
    Vs, Fs, off = [], [], 0
    for V, F in parts:
        Vs.append(np.asarray(V, float))
        Fs.append(np.asarray(F, np.int64) + off)
        off += len(V)
    return np.concatenate(Vs), np.concatenate(Fs)


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q @ np.diag(np.sign(np.diag(r)))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


# --------------------------------------------------------------------------------------------
# synthetic meshes


def tetrahedron():
    V = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    F = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
    return V, F


def octahedron():
    V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    F = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return V, F


def cube(size=1.0, origin=(0, 0, 0)):
    V = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float) * size + np.array(origin, float)
    # vertex index = 4x + 2y + z
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    F = []
    for a, b, c, d in quads:
        F += [[a, b, c], [a, c, d]]
    return V, np.array(F)


def grid(nx, ny, sx=1.0, sy=1.0):
    xs, ys = np.linspace(0, sx, nx + 1), np.linspace(0, sy, ny + 1)
    V = np.array([[x, y, 0.0] for y in ys for x in xs])
    F = []
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i
            b, c, d = a + 1, a + nx + 2, a + nx + 1
            F += [[a, b, c], [a, c, d]]
    return V, np.array(F)


def latlong_sphere(nlat, nlon, r=1.0):
    V = [[0, 0, r]]
    for i in range(1, nlat):
        th = np.pi * i / nlat
        for j in range(nlon):
            ph = 2 * np.pi * j / nlon
            V.append([r * np.sin(th) * np.cos(ph), r * np.sin(th) * np.sin(ph), r * np.cos(th)])
    V.append([0, 0, -r])
    S = len(V) - 1
    ring = lambda i, j: 1 + (i - 1) * nlon + (j % nlon)
    F = []
    for j in range(nlon):
        F.append([0, ring(1, j), ring(1, j + 1)])
    for i in range(1, nlat - 1):
        for j in range(nlon):
            a, b, c, d = ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), ring(i, j + 1)
            F += [[a, b, c], [a, c, d]]
    for j in range(nlon):
        F.append([S, ring(nlat - 1, j + 1), ring(nlat - 1, j)])
    return np.array(V, float), np.array(F)


def closed_cone(n, apex, base_center, radius):
    apex, bc = np.array(apex, float), np.array(base_center, float)
    axis = bc - apex
    axis /= np.linalg.norm(axis)
    u = np.cross(axis, [1, 0, 0] if abs(axis[0]) < 0.9 else [0, 1, 0])
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    V = [apex] + [bc + radius * (np.cos(t) * u + np.sin(t) * w) for t in 2 * np.pi * np.arange(n) / n] + [bc]
    C = n + 1
    F = []
    for j in range(n):
        a, b = 1 + j, 1 + (j + 1) % n
        F.append([0, b, a])   # side
        F.append([C, a, b])   # base cap
    V, F = np.array(V), np.array(F)
    # orient outward (positive signed volume)
    vol = np.sum(np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])))
    if vol < 0:
        F = F[:, ::-1]
    return V, F


def gmsh_graded_sphere(path, h_fine, h_coarse, cap_radius):
    import gmsh
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("graded")
        gmsh.model.occ.addSphere(0, 0, 0, 1.0)
        gmsh.model.occ.synchronize()
        p = gmsh.model.occ.addPoint(0, 0, 1.0)
        gmsh.model.occ.synchronize()
        f1 = gmsh.model.mesh.field.add("Distance")
        gmsh.model.mesh.field.setNumbers(f1, "PointsList", [p])
        f2 = gmsh.model.mesh.field.add("Threshold")
        gmsh.model.mesh.field.setNumber(f2, "InField", f1)
        gmsh.model.mesh.field.setNumber(f2, "SizeMin", h_fine)
        gmsh.model.mesh.field.setNumber(f2, "SizeMax", h_coarse)
        gmsh.model.mesh.field.setNumber(f2, "DistMin", cap_radius)
        gmsh.model.mesh.field.setNumber(f2, "DistMax", cap_radius + 0.6)
        gmsh.model.mesh.field.setAsBackgroundMesh(f2)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h_coarse)
        gmsh.model.mesh.generate(2)
        gmsh.write(path)   # .stl by extension (binary off by default: ASCII)
    finally:
        gmsh.finalize()


# --------------------------------------------------------------------------------------------
# cases: (name, filename, writer(path)); every case gets curve P4 and coarsen P4


def build_cases():
    rng = np.random.default_rng(SEED)
    cases = []

    def add(name, ext, fn):
        cases.append((name, name + "." + ext, fn))

    def obj(V, F):
        return lambda p: write_obj(p, V, F)

    def stl(V, F):
        return lambda p: write_stl(p, V, F)

    torus, bunny, spot = load("torus.obj"), load("bunny_closed.obj"), load("spot.obj")
    sphere, hinge = load("sphere_surf_gmsh.stl"), load("hinge_netgen.stl")

    # transformations
    add("torus_scale1e-6", "obj", obj(torus[0] * 1e-6, torus[1]))
    add("torus_scale1e6", "obj", obj(torus[0] * 1e6, torus[1]))
    add("hinge_scale1e-6", "stl", stl(hinge[0] * 1e-6, hinge[1]))
    add("hinge_scale1e6", "stl", stl(hinge[0] * 1e6, hinge[1]))
    T = np.array([1e5, -3e5, 7e4])
    add("spot_translated", "obj", obj(spot[0] + T, spot[1]))
    add("hinge_translated", "stl", stl(hinge[0] + T, hinge[1]))
    R = random_rotation(rng)
    add("bunny_rotated", "obj", obj(bunny[0] @ R.T, bunny[1]))
    add("hinge_rotated", "stl", stl(hinge[0] @ R.T, hinge[1]))

    # noise
    for pct in (1, 10):
        for nm, (V, F), ext in (("sphere", sphere, "stl"), ("bunny", bunny, "obj")):
            h = mean_edge(V, F)
            Vn = V + rng.normal(scale=pct / 100.0 * h, size=V.shape)
            add("%s_noise%dpct" % (nm, pct), ext, (stl if ext == "stl" else obj)(Vn, F))

    # orientation
    Ft = torus[1].copy()
    sel = rng.random(len(Ft)) < 0.2
    Ft[sel] = Ft[sel][:, ::-1]
    add("torus_flip20pct", "obj", obj(torus[0], Ft))
    add("bunny_flipall", "obj", obj(bunny[0], bunny[1][:, ::-1]))
    add("hinge_flipall", "stl", stl(hinge[0], hinge[1][:, ::-1]))

    # duplicated faces (same and reversed order), zero-area faces, unreferenced vertices
    V, F = spot
    d = rng.choice(len(F), len(F) // 10, replace=False)
    add("spot_dupfaces", "obj", obj(V, np.concatenate([F, F[d[: len(d) // 2]], F[d[len(d) // 2:]][:, ::-1]])))
    d = rng.choice(len(F), 20, replace=False)
    rep = np.stack([F[d, 0], F[d, 0], F[d, 1]], axis=1)
    add("spot_repeated_vertex_faces", "obj", obj(V, np.concatenate([F, rep])))
    # isolated collinear triangles near the surface
    c = V.mean(axis=0)
    h = mean_edge(V, F)
    P = np.array([c + np.array([2.0, 0, 0]) + k * h * np.array([1, 1, 0]) for k in range(3)])
    add("spot_isolated_collinear", "obj", obj(*combine((V, F), (P, [[0, 1, 2]]))))
    # collinear flaps on existing edges: (a, b, midpoint of ab) as extra faces
    d = rng.choice(len(F), 10, replace=False)
    mids = 0.5 * (V[F[d, 0]] + V[F[d, 1]])
    flaps = np.stack([F[d, 0], F[d, 1], len(V) + np.arange(len(d))], axis=1)
    add("spot_collinear_flaps", "obj", obj(np.concatenate([V, mids]), np.concatenate([F, flaps])))
    # T-junction closed by a zero-area cap: split face abc at m (midpoint of ab) into amc, mbc
    # (the neighbour abd keeps edge ab; the zero-area face (b, a, m) closes the surface watertight)
    Vt, Ftj = torus
    Ftj = Ftj.copy()
    extraV, newF, used = [], [], set()
    for k in rng.choice(len(Ftj), 40, replace=False):
        a, b, cc = Ftj[k]
        if {a, b} & used:
            continue
        used |= {a, b}
        m = len(Vt) + len(extraV)
        extraV.append(0.5 * (Vt[a] + Vt[b]))
        Ftj[k] = [a, m, cc]
        newF += [[m, b, cc], [b, m, a]]
    add("torus_tjunction_zero_area_caps", "obj", obj(np.concatenate([Vt, extraV]), np.concatenate([Ftj, newF])))
    lo, hi = torus[0].min(axis=0), torus[0].max(axis=0)
    add("torus_unreferenced_vertices", "obj",
        obj(np.concatenate([torus[0], lo + rng.random((200, 3)) * (hi - lo)]), torus[1]))
    add("torus_unreferenced_far_vertices", "obj",
        obj(np.concatenate([torus[0], [[1e30, 0, 0], [-1e30, 5, 5], [0, 0, 1e-300]]]), torus[1]))

    # triangle soup (every face its own vertex copies)
    V, F = spot
    add("spot_soup", "obj", obj(V[F.reshape(-1)], np.arange(3 * len(F)).reshape(-1, 3)))
    V, F = hinge
    add("hinge_soup", "obj", obj(V[F.reshape(-1)], np.arange(3 * len(F)).reshape(-1, 3)))

    # components
    add("torus_two_copies", "obj", obj(*combine(torus, (torus[0] + [3.0, 0, 0], torus[1]))))
    add("bunny_two_copies", "obj", obj(*combine(bunny, (bunny[0] + [0, 0, 10.0], bunny[1]))))
    h = mean_edge(*torus)
    tri = np.array([[1e4, 0, 0], [1e4 + h, 0, 0], [1e4, h, 0]])
    add("torus_plus_far_triangle", "obj", obj(*combine(torus, (tri, [[0, 1, 2]]))))
    add("torus_plus_far_big_triangle", "obj", obj(*combine(torus, (tri * [1, 1e3, 1] + [0, 0, 0], [[0, 1, 2]]))))

    # tiny synthetic meshes
    add("single_triangle", "stl", stl([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]))
    add("two_triangles", "obj", obj([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]]))
    add("two_triangles_folded", "obj", obj([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 0.5, 0.01]], [[0, 1, 2], [0, 2, 3]]))
    add("tetrahedron", "stl", stl(*tetrahedron()))
    add("octahedron", "obj", obj(*octahedron()))
    add("cube12", "stl", stl(*cube()))
    add("flat_square_2x2", "obj", obj(*grid(2, 2)))
    add("strip_1000x1", "obj", obj(*grid(1000, 1, 1000.0, 1.0)))
    add("strip_1000x1_bent", "obj",
        obj(*(lambda V, F: (np.c_[V[:, 0], V[:, 1] * np.cos(V[:, 0] / 50), V[:, 1] * np.sin(V[:, 0] / 50)], F))(*grid(1000, 1, 1000.0, 1.0))))

    # topology defects
    V, F = bunny
    cen = V[F].mean(axis=1)
    v0 = F[len(F) // 2, 0]
    near = np.argsort(np.linalg.norm(cen - V[v0], axis=1))[:30]
    add("bunny_hole30", "obj", obj(V, np.delete(F, near, axis=0)))
    V, F = sphere
    add("sphere_hole30", "stl", stl(V, np.delete(F, np.argsort(np.linalg.norm(V[F].mean(axis=1) - V[F[0, 0]], axis=1))[:30], axis=0)))
    # three pages sharing one edge
    add("nonmanifold_book3", "obj",
        obj([[0, 0, 0], [0, 0, 1], [1, 0, 0.5], [-0.5, 0.866, 0.5], [-0.5, -0.866, 0.5]], [[0, 1, 2], [1, 0, 3], [0, 1, 4]]))
    # sphere with a fin on one edge (3 faces share it)
    V, F = sphere
    a, b = F[0, 0], F[0, 1]
    fin = 0.5 * (V[a] + V[b]) * 1.3
    add("sphere_fin_nonmanifold_edge", "stl", stl(np.concatenate([V, [fin]]), np.concatenate([F, [[a, b, len(V)]]])))
    # two closed cones sharing their apex (bow-tie vertex)
    add("bowtie_cones", "obj", obj(*(lambda A, B: (np.concatenate([A[0], B[0][1:]]),
                                                   np.concatenate([A[1], np.where(B[1] == 0, 0, B[1] - 1 + len(A[0]))])))(
        closed_cone(24, [0, 0, 0], [0, 0, 1], 0.5), closed_cone(24, [0, 0, 0], [0, 0, -1], 0.5))))
    # two tori touching in one vertex (indexed OBJ: the touching vertex is shared)
    V, F = torus
    iv = int(np.argmax(V[:, 0]))
    V2 = V * [-1, 1, 1] + 2 * V[iv] * [1, 0, 0]
    add("tori_touching_vertex_coincident", "obj", obj(*combine((V, F), (V2, F[:, ::-1]))))

    # graded spheres (gmsh) and lat-long spheres with pole fans
    cases.append(("sphere_graded_100to1", "sphere_graded_100to1.stl",
                  lambda p: gmsh_graded_sphere(p, 0.005, 0.5, 0.12)))
    add("latlong_10x200", "obj", obj(*latlong_sphere(10, 200)))
    add("latlong_200x10", "obj", obj(*latlong_sphere(200, 10)))
    add("latlong_4x400", "obj", obj(*latlong_sphere(4, 400)))

    # coincident but unconnected vertices: separate vertex lists at identical coordinates
    add("cubes_sharing_face_coincident", "obj", obj(*combine(cube(), cube(origin=(1, 0, 0)))))
    add("cubes_sharing_edge_coincident", "obj", obj(*combine(cube(), cube(origin=(1, 1, 0)))))
    add("cubes_sharing_face_offset1e-12", "obj", obj(*combine(cube(), cube(origin=(1 + 1e-12, 0, 0)))))
    S = latlong_sphere(16, 32)
    add("spheres_touching_pole", "obj", obj(*combine(S, (S[0] + [0, 0, 2.0], S[1]))))
    add("spheres_touching_pole_stl", "stl", stl(*combine(S, (S[0] + [0, 0, 2.0], S[1]))))
    # two grids, one on top of the other (identical positions, no shared indices)
    G = grid(8, 8)
    add("grid_doubled_coincident", "obj", obj(*combine(G, (G[0], G[1][:, ::-1]))))

    # self-intersecting: two overlapping spheres in one file
    add("spheres_overlapping", "stl", stl(*combine(sphere, (sphere[0] + [0.5, 0.2, 0.1], sphere[1]))))
    add("tori_interlocked", "obj", obj(*combine(torus, (torus[0][:, [0, 2, 1]] + [1.0, 0, 0], torus[1]))))

    # extremes and plainly bad inputs (exit 3 is a fine answer for these)
    add("torus_scale1e-150", "obj", obj(torus[0] * 1e-150, torus[1]))
    add("torus_scale1e150", "obj", obj(torus[0] * 1e150, torus[1]))
    add("torus_scale1e40", "obj", obj(torus[0] * 1e40, torus[1]))
    add("torus_translated1e9", "obj", obj(torus[0] + [1e9, 0, 0], torus[1]))
    add("torus_translated1e13", "obj", obj(torus[0] + [1e13, 0, 0], torus[1]))
    for nm, bad in (("nan", np.nan), ("inf", np.inf)):
        Vn = torus[0].copy()
        Vn[5, 2] = bad
        add("torus_%s_vertex" % nm, "obj", obj(Vn, torus[1]))
    Vn = np.concatenate([torus[0], [[np.nan, 0, 0]]])
    add("torus_unreferenced_nan_vertex", "obj", obj(Vn, torus[1]))
    add("all_collinear", "obj", obj([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], [[0, 1, 2], [1, 2, 3], [0, 1, 3]]))
    add("all_same_point", "stl", stl(np.zeros((4, 3)), [[0, 1, 2], [1, 2, 3]]))
    add("empty_obj", "obj", obj(np.zeros((0, 3)), np.zeros((0, 3), int)))
    add("vertices_only_obj", "obj", obj(torus[0][:10], np.zeros((0, 3), int)))
    add("out_of_range_index", "obj", obj(torus[0][:3], [[0, 1, 2], [0, 1, 7]]))
    return cases


EXTRA_ORDERS = {"bunny_hole30", "latlong_10x200", "sphere_noise10pct", "octahedron", "bowtie_cones",
                "hinge_scale1e-6"}
THREADS_CASE = "bunny_rotated"

# --------------------------------------------------------------------------------------------
# running and checking

CHECK_MSH = r"""
import sys, json, math
import gmsh
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
out = {}
try:
    gmsh.open(sys.argv[1])
    tri_orders, other = {}, {}
    ntri = 0
    for t in gmsh.model.mesh.getElementTypes():
        name, dim, order, nn, _, _ = gmsh.model.mesh.getElementProperties(t)
        tags, _ = gmsh.model.mesh.getElementsByType(t)
        if name.startswith("Triangle"):
            tri_orders[str(order)] = tri_orders.get(str(order), 0) + len(tags)
            ntri += len(tags)
        else:
            other[name] = other.get(name, 0) + len(tags)
    _, coords, _ = gmsh.model.mesh.getNodes()
    bad = sum(1 for c in coords if not math.isfinite(c))
    out = {"tri_orders": tri_orders, "other": other, "ntri": ntri, "nodes": len(coords) // 3, "nonfinite": bad}
except Exception as e:
    out = {"error": str(e)}
print(json.dumps(out))
gmsh.finalize()
"""


def run(cmd, timeout):
    t0 = time.time()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        out, err = p.communicate(timeout=timeout)
        rc = p.returncode
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        out, err = p.communicate()
        rc = "TIMEOUT"
    return rc, time.time() - t0, out.decode(errors="replace"), err.decode(errors="replace")


def find_key(j, key, acc):
    if isinstance(j, dict):
        for k, v in j.items():
            if k == key:
                acc.append(v)
            find_key(v, key, acc)
    elif isinstance(j, list):
        for v in j:
            find_key(v, key, acc)
    return acc


def check_output(msh, stats, order, timeout):
    """Returns (problems list, info string)."""
    probs, info = [], ""
    if not os.path.exists(msh):
        return ["no output .msh"], info
    if not os.path.exists(stats):
        probs.append("no stats JSON")
    else:
        try:
            s = json.load(open(stats))
            ia = find_key(s, "invalid_after", [])
            if not ia:
                probs.append("stats: no invalid_after key")
            elif any(x != 0 for x in ia):
                dg = find_key(s, "degenerate_input", [])
                note = " (= degenerate_input %s: zero-area input faces)" % dg if max(ia) <= max(dg + [0]) else ""
                probs.append("stats: invalid_after=%s%s" % (ia, note))
            ib = find_key(s, "invalid_before", []) + find_key(s, "invalid_before_repair", [])
            rp = find_key(s, "repaired", [])
            msj = [x for x in find_key(s, "min_scaled_jacobian", []) if isinstance(x, (int, float))]
            info = "inv_before=%s rep=%s minSJ=%s" % (sum(ib), sum(rp), ("%.3g" % min(msj)) if msj else "-")
            if msj and not min(msj) > 0:
                probs.append("stats: min_scaled_jacobian=%s" % min(msj))
            nel = s.get("output", {}).get("elements")
        except Exception as e:  # noqa
            probs.append("stats unreadable: %s" % e)
            nel = None
    rc, _, out, err = run([sys.executable, "-c", CHECK_MSH, msh], timeout)
    if rc != 0:
        probs.append("gmsh reader rc=%s %s" % (rc, err.strip().splitlines()[-1:] if err.strip() else ""))
        return probs, info
    try:
        r = json.loads(out.strip().splitlines()[-1])
    except Exception:
        probs.append("gmsh check printed nothing usable")
        return probs, info
    if "error" in r:
        probs.append("gmsh.open: %s" % r["error"])
        return probs, info
    if r["ntri"] == 0:
        probs.append("no triangles in output")
    if set(r["tri_orders"]) - {str(order)}:
        probs.append("triangle orders %s != %d" % (r["tri_orders"], order))
    if r["nonfinite"]:
        probs.append("%d non-finite node coordinates" % r["nonfinite"])
    if os.path.exists(stats) and nel is not None and nel != r["ntri"]:
        probs.append("stats elements %s != %d triangles in file" % (nel, r["ntri"]))
    info += " tris=%d" % r["ntri"]
    return probs, info


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hocurve", default=os.path.join(HERE, "..", "build", "hocurve"))
    ap.add_argument("--only", default=None, help="regex on case names")
    ap.add_argument("--keep", default="/tmp/fuzz", help="failing inputs are copied here")
    ap.add_argument("--timeout", type=float, default=120.0)
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--workdir", default=None, help="default: a fresh temporary directory (removed at the end)")
    a = ap.parse_args()
    exe = os.path.abspath(a.hocurve)

    cases = build_cases()
    if a.only:
        cases = [c for c in cases if re.search(a.only, c[0])]
    if a.list:
        for c in cases:
            print(c[0])
        return 0
    work = a.workdir or tempfile.mkdtemp(prefix="hocurve_fuzz_")
    os.makedirs(work, exist_ok=True)
    os.makedirs(a.keep, exist_ok=True)

    results = []
    print("%-34s %-40s %5s %7s  %s" % ("case", "command", "rc", "sec", "verdict"), flush=True)

    def one(name, inp, label, args, order, out):
        stats = out[:-4] + ".json"
        cmd = [exe] + args[:1] + [inp, "-o", out] + args[1:] + ["--stats", stats]
        rc, dt, _, err = run(cmd, a.timeout)
        errlines = [l for l in err.strip().splitlines() if l.strip()]
        probs, info = [], ""
        if rc == 0:
            probs, info = check_output(out, stats, order, a.timeout)
            verdict = "OK " + info if not probs else "FAIL " + "; ".join(probs)
        elif rc == 3:
            if not errlines:
                probs = ["exit 3 without a message"]
                verdict = "FAIL exit 3 without a message"
            else:
                verdict = "REFUSED: " + errlines[-1][:150]
        else:
            what = {"TIMEOUT": "HANG (killed after %gs)" % a.timeout}.get(rc)
            if what is None:
                what = "SIGNAL %s" % signal.Signals(-rc).name if isinstance(rc, int) and rc < 0 else "exit %s" % rc
            probs = [what]
            verdict = "FAIL " + what
        ok = not probs
        line = "%-34s %-40s %5s %7.1f  %s" % (name, label, rc, dt, verdict)
        if not ok:
            if errlines:
                line += "\n    stderr: " + errlines[0][:300]
            kept = os.path.join(a.keep, os.path.basename(inp))
            if not os.path.exists(kept):
                shutil.copy(inp, kept)
            kcmd = [exe] + args[:1] + [kept, "-o", os.path.join(a.keep, os.path.basename(out))] + args[1:] + \
                   ["--stats", os.path.join(a.keep, os.path.basename(stats))]
            line += "\n    cmd: " + " ".join(kcmd)
        print(line, flush=True)
        results.append((name, label, rc, dt, ok))
        return ok

    for name, fname, writer in cases:
        inp = os.path.join(work, fname)
        try:
            writer(inp)
        except Exception as e:  # generator bug: report and continue
            print("%-34s generator failed: %s" % (name, e), flush=True)
            continue
        runs = [("curve --order 4", ["curve", "--order", "4"], 4),
                ("coarsen --order 4 --ratio 0.1", ["coarsen", "--order", "4", "--ratio", "0.1"], 4)]
        if name in EXTRA_ORDERS:
            runs += [("curve --order 2", ["curve", "--order", "2"], 2),
                     ("curve --order 6", ["curve", "--order", "6"], 6),
                     ("coarsen --order 2 --ratio 0.1", ["coarsen", "--order", "2", "--ratio", "0.1"], 2),
                     ("coarsen --order 6 --ratio 0.1", ["coarsen", "--order", "6", "--ratio", "0.1"], 6)]
        for k, (label, args, order) in enumerate(runs):
            one(name, inp, label, args, order, os.path.join(work, "%s.r%d.msh" % (name, k)))
        if name == THREADS_CASE:
            for cmdname, base in (("curve", ["curve", "--order", "4"]),
                                  ("coarsen", ["coarsen", "--order", "4", "--ratio", "0.1"])):
                outs = []
                for th in ("1", "2"):
                    o = os.path.join(work, "%s.%s.t%s.msh" % (name, cmdname, th))
                    one(name, inp, "%s --threads %s" % (cmdname, th), base + ["--threads", th], 4, o)
                    outs.append(o)
                same = all(os.path.exists(o) for o in outs) and open(outs[0], "rb").read() == open(outs[1], "rb").read()
                verdict = "OK byte-identical" if same else "FAIL outputs differ between --threads 1 and 2"
                print("%-34s %-40s %5s %7s  %s" % (name, "%s threads 1 vs 2" % cmdname, "-", "-", verdict), flush=True)
                if not same:
                    kept = os.path.join(a.keep, os.path.basename(inp))
                    shutil.copy(inp, kept)
                    for o in outs:
                        if os.path.exists(o):
                            shutil.copy(o, os.path.join(a.keep, os.path.basename(o)))
                    print("    kept: %s and outputs in %s" % (kept, a.keep), flush=True)
                results.append((name, cmdname + " threads", "-", 0.0, same))

    nfail = sum(1 for r in results if not r[4])
    print("\n%d runs, %d failed (failing inputs kept in %s)" % (len(results), nfail, a.keep))
    if not a.workdir:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if nfail == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
