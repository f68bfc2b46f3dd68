#!/usr/bin/python3
"""Test shapes for the hocurve accuracy and speed harness, built with Gmsh's OpenCASCADE kernel.

Every shape exists twice: as exact CAD (an OCC model, rebuilt on demand by `build_occ`) and as a
linear triangulation written as binary STL (`make_stl`). The STL is Gmsh's own mesh of the exact CAD
at size h, so its vertices lie on the exact surface (up to float32 rounding of binary STL) and the
Gmsh reference baseline (same mesh, `setOrder(p)` on the CAD) uses the very same triangulation.

Usage: shapes.py [OUTDIR] [--big]   (default OUTDIR /tmp/hocurve-bench) writes all accuracy STLs and
the ~200k-triangle speed sphere; --big also writes the 2.4M-triangle analytic icosphere.
"""
import os
import struct
import sys

import numpy as np

SHARED = os.environ.get("HOCURVE_SHARED_DIR", "/work/shared")
DEFAULT_OUT = "/tmp/hocurve-bench"

# name -> kind, parameters. Analytic shapes carry the parameters their distance function needs.
SHAPES = {
    "sphere": {"kind": "sphere", "radius": 1.0},
    "torus": {"kind": "torus", "R": 1.0, "r": 0.4},
    "ellipsoid": {"kind": "ellipsoid", "axes": (1.0, 0.7, 0.5)},
    "cylinder": {"kind": "cylinder", "radius": 0.5, "height": 1.0},  # axis z, z in [0, height]
    "screw": {"kind": "step", "file": "cad/screw.step"},
    "t20": {"kind": "step", "file": "cad/t20_data.step"},
}

# Mesh sizes per shape (coarse, middle, fine; accuracy.py --sizes N takes the first N). Analytic
# shapes use absolute sizes (sphere middle h=0.1 gives ~3.2k triangles) and have a 4th, finer size
# for the asymptotic order (--sizes 4); CAD parts use fractions of their bounding-box diagonal.
SIZES = {
    "sphere": [0.2, 0.1, 0.05, 0.025],
    "torus": [0.2, 0.1, 0.05, 0.025],
    "ellipsoid": [0.2, 0.1, 0.05, 0.025],
    "cylinder": [0.2, 0.1, 0.05, 0.025],
    "screw": ["d/40", "d/80", "d/160"],
    "t20": ["d/20", "d/40", "d/80"],
}


def gmsh_init():
    """Initialise Gmsh once per process (quiet, no config files)."""
    import gmsh
    if not getattr(gmsh, "_hocurve_init", False):
        gmsh.initialize(readConfigFiles=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh._hocurve_init = True
    return gmsh


def step_path(name):
    return os.path.join(SHARED, "meshes", SHAPES[name]["file"])


def add_step_parts():
    """Register every STEP solid of the shared CAD folder as a shape named after its file; returns
    the names, sorted."""
    names = []
    folder = os.path.join(SHARED, "meshes", "cad")
    for f in sorted(os.listdir(folder)) if os.path.isdir(folder) else []:
        if f.lower().endswith((".step", ".stp")):
            name = os.path.splitext(f)[0]
            SHAPES.setdefault(name, {"kind": "step", "file": "cad/" + f})
            names.append(name)
    return names


def build_occ(name, model_name=None):
    """Create the exact CAD of `name` in a new Gmsh model (made current) and return the model name."""
    gmsh = gmsh_init()
    spec = SHAPES[name]
    model_name = model_name or "occ_" + name
    gmsh.model.add(model_name)
    occ = gmsh.model.occ
    k = spec["kind"]
    if k == "sphere":
        occ.addSphere(0, 0, 0, spec["radius"])
    elif k == "torus":
        occ.addTorus(0, 0, 0, spec["R"], spec["r"])
    elif k == "ellipsoid":
        a, b, c = spec["axes"]
        s = occ.addSphere(0, 0, 0, 1.0)
        occ.dilate([(3, s)], 0, 0, 0, a, b, c)
    elif k == "cylinder":
        occ.addCylinder(0, 0, 0, 0, 0, spec["height"], spec["radius"])
    elif k == "step":
        occ.importShapes(step_path(name))
    else:
        raise ValueError(name)
    occ.synchronize()
    return model_name


def bbox_diagonal(name):
    gmsh = gmsh_init()
    build_occ(name, "bbox_" + name)
    x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(-1, -1)
    gmsh.model.remove()
    return float(np.linalg.norm([x1 - x0, y1 - y0, z1 - z0]))


def size_value(name, size):
    """Absolute mesh size for a SIZES entry ('d/40' = bounding-box diagonal / 40)."""
    if isinstance(size, str) and size.startswith("d/"):
        return bbox_diagonal(name) / float(size[2:])
    return float(size)


def size_label(size):
    return str(size).replace("/", "")


def mesh_occ(name, h, curvature=0):
    """Build the CAD of `name` in a new current model and mesh its surfaces at size h (linear).
    curvature > 0: also size from the curvature (that many elements per 2 pi radians, no lower
    size bound), as CAD users often mesh."""
    gmsh = gmsh_init()
    m = build_occ(name)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0 if curvature else h)
    gmsh.option.setNumber("Mesh.MeshSizeMax", h)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", curvature)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
    gmsh.option.setNumber("Mesh.HighOrderOptimize", 0)
    gmsh.model.mesh.generate(2)
    return m


def make_stl(name, size, outdir=DEFAULT_OUT, ascii=False, curvature=0):
    """Return the path of the binary STL of shape `name` at SIZES entry `size`, creating it if absent.

    ascii=True writes ASCII STL with full double precision (binary STL rounds vertices to float32,
    ~5e-8 on the unit sphere, which floors the achievable error). Next to it, NAME.faces.npz keeps the CAD face tag of every triangle (used to measure distances
    to STEP parts face by face) and the mesh size h."""
    os.makedirs(outdir, exist_ok=True)
    path = os.path.join(outdir, "%s_%s%s%s.stl" % (name, size_label(size), "_c%d" % curvature if curvature else "",
                                                   "_ascii" if ascii else ""))
    if os.path.exists(path) and os.path.exists(sidecar_path(path)):
        return path
    gmsh = gmsh_init()
    h = size_value(name, size)
    mesh_occ(name, h, curvature)
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    lookup = np.zeros(int(tags.max()) + 1, dtype=np.int64)
    lookup[tags.astype(np.int64)] = np.arange(len(tags))
    V = np.asarray(xyz).reshape(-1, 3)
    F, face, Fuv = [], [], []
    for _, s in gmsh.model.getEntities(2):
        _, ntags = gmsh.model.mesh.getElementsByType(2, s)
        ntags = np.asarray(ntags, dtype=np.int64)
        f = lookup[ntags].reshape(-1, 3)
        F.append(f)
        face.append(np.full(len(f), s))
        # Surface parameters of the triangle's vertices on its own face (start of projections).
        st, _, su = gmsh.model.mesh.getNodes(2, s, includeBoundary=True, returnParametricCoord=True)
        st = np.asarray(st, dtype=np.int64)
        su = np.asarray(su).reshape(-1, 2) if len(su) == 2 * len(st) else np.zeros((len(st), 2))
        loc = {int(t): i for i, t in enumerate(st)}
        Fuv.append(su[[loc.get(int(t), 0) for t in ntags]].reshape(-1, 3, 2))
    gmsh.model.remove()
    F = np.concatenate(F)
    face = np.concatenate(face)
    (write_ascii_stl if ascii else write_binary_stl)(path, V, F)
    np.savez(sidecar_path(path), V=V, F=F, face=face, Fuv=np.concatenate(Fuv), h=h)
    return path


def sidecar_path(stl_path):
    return stl_path[:-4] + ".faces.npz"


def write_ascii_stl(path, V, F):
    """Write vertices V and triangles F as ASCII STL with 17 significant digits, atomically."""
    V = np.asarray(V, dtype=np.float64)
    P = V[np.asarray(F, dtype=np.int64)]
    n = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write("solid hocurve_bench\n")
        for t, nn in zip(P, n):
            f.write("facet normal %.17g %.17g %.17g\n outer loop\n" % tuple(nn))
            for v in t:
                f.write("  vertex %.17g %.17g %.17g\n" % tuple(v))
            f.write(" endloop\nendfacet\n")
        f.write("endsolid hocurve_bench\n")
    os.replace(tmp, path)


def write_binary_stl(path, V, F):
    """Write vertices V (n,3) and triangles F (m,3) as binary STL (float32), atomically."""
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    P = V[F]  # (m,3,3)
    n = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    rec = np.zeros(len(F), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec["n"] = n
    rec["v"] = P
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(b"hocurve bench icosphere".ljust(80, b" "))
        f.write(struct.pack("<I", len(F)))
        rec.tofile(f)
    os.replace(tmp, path)


def icosphere(n):
    """Unit-sphere triangulation: each icosahedron face split into n^2 triangles, vertices projected
    radially onto the sphere. Returns (V, F) with shared vertices; 20 n^2 triangles."""
    t = (1 + 5 ** 0.5) / 2
    IV = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
                   [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    IF = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
                   [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
                   [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    # Local lattice of one face: points (i, j), i + j <= n, and its triangles.
    ij = np.array([(i, j) for j in range(n + 1) for i in range(n + 1 - j)])
    index = {tuple(p): k for k, p in enumerate(ij)}
    tris = []
    for j in range(n):
        for i in range(n - j):
            tris.append((index[(i, j)], index[(i + 1, j)], index[(i, j + 1)]))
            if i + j < n - 1:
                tris.append((index[(i + 1, j)], index[(i + 1, j + 1)], index[(i, j + 1)]))
    tris = np.array(tris)
    npf = len(ij)
    a = (n - ij[:, 0] - ij[:, 1]) / n
    b = ij[:, 0] / n
    c = ij[:, 1] / n
    P = (a[None, :, None] * IV[IF[:, 0]][:, None, :] + b[None, :, None] * IV[IF[:, 1]][:, None, :]
         + c[None, :, None] * IV[IF[:, 2]][:, None, :]).reshape(-1, 3)
    # Merge the copies of shared edge/corner points: integer keys far finer than the spacing.
    key = np.round(P / np.linalg.norm(IV[0]) * n * 64).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inv = inv.reshape(-1)
    V = P[first]
    V /= np.linalg.norm(V, axis=1)[:, None]
    F = (tris[None, :, :] + (np.arange(20) * npf)[:, None, None]).reshape(-1, 3)
    return V, inv[F]


def make_speed_sphere(outdir=DEFAULT_OUT):
    """~200k-triangle Gmsh sphere (h=0.0122) as binary STL."""
    return make_stl("sphere", 0.0122, outdir)


def make_big_sphere(outdir=DEFAULT_OUT, n=346):
    """Analytic icosphere with 20 n^2 triangles (n=346: 2.39M) as binary STL."""
    os.makedirs(outdir, exist_ok=True)
    path = os.path.join(outdir, "sphere_ico%d.stl" % n)
    if not os.path.exists(path):
        V, F = icosphere(n)
        write_binary_stl(path, V, F)
    return path


def main(argv):
    out = DEFAULT_OUT
    args = [a for a in argv if not a.startswith("--")]
    if args:
        out = args[0]
    for name, sizes in SIZES.items():
        for s in sizes:
            p = make_stl(name, s, out)
            print(p, os.path.getsize(p) // 50, "triangles")
    p = make_speed_sphere(out)
    print(p, os.path.getsize(p) // 50, "triangles")
    if "--big" in argv:
        p = make_big_sphere(out)
        print(p, os.path.getsize(p) // 50, "triangles")


if __name__ == "__main__":
    main(sys.argv[1:])
