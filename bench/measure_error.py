#!/usr/bin/python3
"""Independent geometric error of a (high-order) triangle mesh against an exact shape.

Reads the .msh with the Gmsh Python API (any triangle order 1..10, MSH 2.2/4.1, ASCII/binary) and
evaluates every element's own Lagrange map (Gmsh's basis functions applied to the element's node
coordinates) on a lattice of local points; nothing of hocurve's C++ code is used. Distances to the
exact surface are analytic for sphere / torus / ellipsoid / capped cylinder and come from
OpenCASCADE (gmsh.model.getClosestPoint on the re-imported STEP) for CAD parts.

Usage: measure_error.py MESH.msh SHAPE [--stl STL] [--q Q] [--json]
  SHAPE is a name from bench/shapes.py (sphere, torus, ellipsoid, cylinder, screw, t20); for CAD
  shapes pass the input STL (--stl) so its .faces.npz sidecar restricts the candidate faces.
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench import shapes  # noqa: E402

TRIANGLE_TYPES = {2: 1, 9: 2, 21: 3, 23: 4, 25: 5, 42: 6, 43: 7, 44: 8, 45: 9, 46: 10}


# ----------------------------------------------------------------------------- reading
def read_triangles(path):
    """Read all triangle elements of a .msh file through Gmsh.

    Returns dict(type, order, tags (E,), conn (E, nn) node tags, X (E, nn, 3) node coordinates,
    types: {type: count} of every element type in the file)."""
    gmsh = shapes.gmsh_init()
    if not os.path.exists(path):
        raise FileNotFoundError(path)
    prev = gmsh.model.getCurrent() if gmsh.model.list() else None
    gmsh.model.add("measure_read")
    try:
        gmsh.merge(path)
        types, _, _ = gmsh.model.mesh.getElements()
        counts = {}
        for t in types:
            et, _ = gmsh.model.mesh.getElementsByType(int(t))
            counts[int(t)] = counts.get(int(t), 0) + len(et)
        tri = [t for t in counts if t in TRIANGLE_TYPES]
        if len(tri) != 1:
            raise ValueError("%s: expected exactly one triangle type, found %s" % (path, counts))
        t = tri[0]
        etags, ntags = gmsh.model.mesh.getElementsByType(t)
        nt, xyz, _ = gmsh.model.mesh.getNodes()
    finally:
        gmsh.model.remove()
        if prev:
            gmsh.model.setCurrent(prev)
    nt = np.asarray(nt, dtype=np.int64)
    lookup = np.full(int(nt.max()) + 1, -1, dtype=np.int64)
    lookup[nt] = np.arange(len(nt))
    coords = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    conn = np.asarray(ntags, dtype=np.int64).reshape(len(etags), -1)
    idx = lookup[conn]
    if (idx < 0).any():
        raise ValueError("%s: element references an unknown node" % path)
    return {"type": t, "order": TRIANGLE_TYPES[t], "tags": np.asarray(etags), "conn": conn,
            "X": coords[idx], "types": counts}


def lattice(q):
    """Local (u, v) points of the order-q triangle lattice, (q+1)(q+2)/2 points incl. boundary."""
    return np.array([(i / q, j / q) for j in range(q + 1) for i in range(q + 1 - j)])


def basis(etype, uv, space="Lagrange"):
    """Gmsh basis functions at local points uv: (npts, nn) for Lagrange, (npts, nn, 3) for Grad."""
    gmsh = shapes.gmsh_init()
    loc = np.column_stack([uv, np.zeros(len(uv))]).ravel().tolist()
    ncomp, vals, _ = gmsh.model.mesh.getBasisFunctions(etype, loc, space)
    vals = np.asarray(vals)
    if ncomp == 1:
        return vals.reshape(len(uv), -1)
    return vals.reshape(len(uv), -1, ncomp)


# ----------------------------------------------------------------------------- distances
def dist_sphere(P, radius=1.0):
    return np.abs(np.linalg.norm(P, axis=1) - radius)


def dist_torus(P, R, r):
    rho = np.hypot(P[:, 0], P[:, 1])
    return np.abs(np.hypot(rho - R, P[:, 2]) - r)


def dist_ellipsoid(P, axes, iters=200):
    """Exact distance to the ellipsoid sum (x_i/a_i)^2 = 1: the closest point is
    y_i = a_i^2 x_i / (a_i^2 + t) where t solves F(t) = sum (a_i x_i / (a_i^2 + t))^2 - 1 = 0.
    F is convex and decreasing on (-min a_i^2, inf); safeguarded Newton inside a bracket."""
    a2 = np.asarray(axes, float) ** 2
    X = np.asarray(P, float)
    n = len(X)
    lo = np.full(n, -a2.min())
    hi = np.sqrt(((a2 * X) ** 2).sum(1) / a2.min()) + 1e-12  # F(hi) <= 0
    hi = np.maximum(hi, 0.0)
    t = np.where((X ** 2 / a2).sum(1) >= 1, 0.0, -0.5 * a2.min())
    for _ in range(iters):
        d = a2[None, :] + t[:, None]
        q = (np.sqrt(a2)[None, :] * X) / d
        F = (q ** 2).sum(1) - 1
        dF = -2 * (q ** 2 / d).sum(1)
        lo = np.where(F > 0, t, lo)
        hi = np.where(F <= 0, t, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            tn = t - F / dF
        bad = ~np.isfinite(tn) | (tn <= lo) | (tn >= hi)
        tn = np.where(bad, 0.5 * (lo + hi), tn)
        if np.all(np.abs(tn - t) <= 1e-15 * (1 + np.abs(t))):
            t = tn
            break
        t = tn
    Y = a2[None, :] * X / (a2[None, :] + t[:, None])
    return np.linalg.norm(X - Y, axis=1)


def dist_cylinder(P, radius, height):
    """Distance to the boundary of the solid capped cylinder x^2+y^2 <= r^2, 0 <= z <= height."""
    rho = np.hypot(P[:, 0], P[:, 1])
    z = P[:, 2]
    inside = (rho <= radius) & (z >= 0) & (z <= height)
    din = np.minimum(np.minimum(radius - rho, z), height - z)
    dr = np.maximum(rho - radius, 0)
    dz = np.maximum(np.maximum(-z, z - height), 0)
    return np.where(inside, din, np.hypot(dr, dz))


class StepDistance:
    """Distance to the faces of a STEP part (OpenCASCADE projection through Gmsh).

    Candidate faces per element: the CAD faces of the input triangles around its three vertices
    (from the STL's .faces.npz sidecar); the distance is the minimum over their underlying
    surfaces. own_face=True: an element whose three vertices make an input triangle is measured
    against that triangle's CAD face alone (a point beside a fillet is not credited with the
    neighbouring plane). Elements whose vertices are not found there (moved) fall
    back to the minimum over every face whose bounding box, grown by `margin`, holds the point."""

    def __init__(self, name, sidecar=None, own_face=False):
        gmsh = shapes.gmsh_init()
        self.model = shapes.build_occ(name, "dist_" + name)
        self.faces = [t for _, t in gmsh.model.getEntities(2)]
        self.bbox = {t: np.array(gmsh.model.getBoundingBox(2, t)) for t in self.faces}
        lo = np.min([b[:3] for b in self.bbox.values()], axis=0)
        hi = np.max([b[3:] for b in self.bbox.values()], axis=0)
        self.margin = 0.02 * float(np.linalg.norm(hi - lo))
        self.vertex_faces = None
        if sidecar is not None and os.path.exists(sidecar):
            d = np.load(sidecar)
            V, F, face = d["V"], d["F"], d["face"]
            keys = _vkey(V)
            self.key_index = {k: i for i, k in enumerate(map(bytes, keys))}
            vf = [set() for _ in range(len(V))]
            self.vertex_uv = {}
            Fuv = d["Fuv"]
            for tri, f, tuv in zip(F, face, Fuv):
                for v, uv in zip(tri, tuv):
                    vf[v].add(int(f))
                    self.vertex_uv[(int(v), int(f))] = uv
            self.vertex_faces = vf
            self.V = V
            self.tri_face = {tuple(sorted(map(int, t))): int(f) for t, f in zip(F, face)} if own_face else {}
            self.margin = 2.0 * float(d["h"])

    def element_faces(self, Xv):
        """Candidate faces of elements with vertex coordinates Xv (E, 3, 3): boolean matrix
        (E, #faces), and a mask of elements with a vertex not found in the input (use bboxes)."""
        M = np.zeros((len(Xv), len(self.faces)), dtype=bool)
        unknown = np.ones(len(Xv), dtype=bool)
        if self.vertex_faces is None:
            return M, unknown
        col = {f: i for i, f in enumerate(self.faces)}
        keys = _vkey(Xv.reshape(-1, 3)).reshape(len(Xv), 3, -1)
        self.last_vertices = np.full((len(Xv), 3), -1)
        for e in range(len(Xv)):
            ok = True
            for k in range(3):
                i = self.key_index.get(bytes(keys[e, k]))
                if i is None:
                    ok = False
                    break
                self.last_vertices[e, k] = i
            own = self.tri_face.get(tuple(sorted(map(int, self.last_vertices[e])))) if ok else None
            if own is not None:
                M[e, col[own]] = True
            elif ok:
                for i in self.last_vertices[e]:
                    for f in self.vertex_faces[i]:
                        M[e, col[f]] = True
            unknown[e] = not ok
        return M, unknown

    def vertex_floor(self):
        """The input's own floor: the largest distance of an input vertex (as the STL stores it)
        from a CAD face it was meshed on. A vertex on a CAD curve belongs to the faces on both
        sides, and a STEP curve is only within the file's tolerance of them (the screw's slot rims
        are 3e-4 off its dome): no reconstruction through the input vertices gets below this there."""
        if self.vertex_faces is None:
            return None
        gmsh = shapes.gmsh_init()
        prev = gmsh.model.getCurrent()
        gmsh.model.setCurrent(self.model)
        V = np.asarray(self.V, dtype=np.float32).astype(np.float64)
        worst = 0.0
        try:
            for f in self.faces:
                vids = [v for v, fs in enumerate(self.vertex_faces) if f in fs]
                if vids:
                    worst = max(worst, float(np.linalg.norm(V[vids] - self.closest(f, V[vids]), axis=1).max()))
        finally:
            gmsh.model.setCurrent(prev)
        return worst

    def vertex_params(self, f, vids):
        """Known surface parameters on face f of input vertices vids (E, 3); NaN where unknown."""
        out = np.full(vids.shape + (2,), np.nan)
        for idx in np.ndindex(vids.shape):
            uv = self.vertex_uv.get((int(vids[idx]), f)) if vids[idx] >= 0 else None
            if uv is not None:
                out[idx] = uv
        return out

    def __call__(self, P, M=None, unknown=None):
        """Distances of points P (n, 3). M (n, #faces) / unknown (n,): candidate faces per point
        from element_faces; without them, every face whose grown bounding box holds the point."""
        gmsh = shapes.gmsh_init()
        prev = gmsh.model.getCurrent()
        gmsh.model.setCurrent(self.model)
        d = np.full(len(P), np.inf)
        try:
            for j, f in enumerate(self.faces):
                b = self.bbox[f]
                sel = np.all((P >= b[:3] - self.margin) & (P <= b[3:] + self.margin), axis=1)
                if M is not None:
                    sel = M[:, j] | (unknown & sel)
                idx = np.nonzero(sel)[0]
                if len(idx) == 0:
                    continue
                c = self.closest(f, P[idx])
                d[idx] = np.minimum(d[idx], np.linalg.norm(P[idx] - c, axis=1))
        finally:
            gmsh.model.setCurrent(prev)
        return d

    def closest(self, f, P):
        """OpenCASCADE's closest point on face f (getClosestPoint) for every point of P."""
        gmsh = shapes.gmsh_init()
        c, _ = gmsh.model.getClosestPoint(2, f, np.ascontiguousarray(P).ravel().tolist())
        return np.asarray(c).reshape(-1, 3)

    def gauss_newton(self, f, X, uv, iters=30):
        """Distances of points X (n, 3) to face f's surface by Gauss-Newton on |S(u,v) - x|^2 from
        parameters uv (n, 2) (S and dS from Gmsh: exact CAD evaluation); (distances, converged)."""
        gmsh = shapes.gmsh_init()
        uv = np.array(uv, dtype=np.float64)
        ok = np.ones(len(X), dtype=bool)
        step = np.full(len(X), np.inf)
        for it in range(iters):
            S = np.asarray(gmsh.model.getValue(2, f, uv.ravel().tolist())).reshape(-1, 3)
            D = np.asarray(gmsh.model.getDerivative(2, f, uv.ravel().tolist())).reshape(-1, 2, 3)
            r = X - S
            A = np.einsum("nik,njk->nij", D, D)
            g = np.einsum("nik,nk->ni", D, r)
            det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
            good = np.abs(det) > 1e-300
            det = np.where(good, det, 1.0)
            du = np.column_stack([(A[:, 1, 1] * g[:, 0] - A[:, 0, 1] * g[:, 1]) / det,
                                  (A[:, 0, 0] * g[:, 1] - A[:, 1, 0] * g[:, 0]) / det])
            ok &= good
            uv = uv + du
            step = np.linalg.norm(du * np.sqrt(np.stack([A[:, 0, 0], A[:, 1, 1]], 1)), axis=1)
            if np.all(step[ok] < 1e-13 * self.margin):
                break
        S = np.asarray(gmsh.model.getValue(2, f, uv.ravel().tolist())).reshape(-1, 3)
        ok &= step < 1e-10 * self.margin
        return np.linalg.norm(X - S, axis=1), ok

    def element_distance(self, P, Xv, lam, M, unknown):
        """Distances of the samples P (E*npts, 3) of elements with vertices Xv (E, 3, 3), samples
        at barycentric coordinates lam (npts, 3). Per candidate face, OCC projects each element
        vertex once; the samples then start from the barycentric blend of the vertices' surface
        parameters (known from the input mesh) and converge by Gauss-Newton on |S(u,v) - x|^2 (S and dS from Gmsh, exact CAD
        evaluation). Samples where this fails (no convergence, element across a periodic seam) are
        projected by OCC directly (getClosestPoint: exact but ~0.5 ms per point on a BSpline)."""
        gmsh = shapes.gmsh_init()
        prev = gmsh.model.getCurrent()
        gmsh.model.setCurrent(self.model)
        E, npts = len(Xv), len(lam)
        d = np.full(E * npts, np.inf)
        try:
            for j, f in enumerate(self.faces):
                b = self.bbox[f]
                Pin = P.reshape(E, npts, 3)
                box = np.all((Xv >= b[:3] - self.margin) & (Xv <= b[3:] + self.margin), axis=(1, 2))
                esel = np.nonzero(M[:, j] | (unknown & box))[0]
                if len(esel) == 0:
                    continue
                lo, hi = [np.asarray(x) for x in gmsh.model.getParametrizationBounds(2, f)]
                # Vertex parameters: from the input mesh where known, else projected by OCC.
                if self.vertex_faces is not None and hasattr(self, "last_vertices"):
                    uvv = self.vertex_params(f, self.last_vertices[esel])
                else:
                    uvv = np.full((len(esel), 3, 2), np.nan)
                # A neighbouring face known only at some vertices: start all from their mean.
                part = np.isnan(uvv[:, :, 0]) & ~np.all(np.isnan(uvv[:, :, 0]), axis=1)[:, None]
                if part.any():
                    with np.errstate(invalid="ignore"):
                        mean = np.nanmean(uvv, axis=1)
                    uvv = np.where(part[:, :, None], mean[:, None, :], uvv)
                miss = np.isnan(uvv[:, :, 0])
                if miss.any():
                    _, pu = gmsh.model.getClosestPoint(2, f, Xv[esel][miss].ravel().tolist())
                    uvv[miss] = np.asarray(pu).reshape(-1, 2)
                spread = uvv.max(1) - uvv.min(1)
                seam = np.any(spread > 0.25 * (hi - lo), axis=1)
                uv = np.einsum("pk,ekc->epc", lam, uvv).reshape(-1, 2)
                X = Pin[esel].reshape(-1, 3)
                dd, ok = self.gauss_newton(f, X, uv)
                ok &= np.repeat(~seam, npts)
                # Guard against a far stationary point: the surface points of the element's
                # vertices bound the true distance from above.
                Sv = np.asarray(gmsh.model.getValue(2, f, uvv.reshape(-1, 2).ravel().tolist()))
                Sv = Sv.reshape(len(esel), 1, 3, 3)
                vbound = np.linalg.norm(X.reshape(len(esel), npts, 1, 3) - Sv, axis=3).min(2).ravel()
                ok &= dd <= vbound * (1 + 1e-12) + 1e-300
                bad = np.nonzero(~ok)[0]
                if os.environ.get("HOCURVE_BENCH_DEBUG"):
                    print("face %d: %d samples, seam %d, outside %d" % (
                        f, len(ok), int(np.repeat(seam, npts).sum()), len(bad)))
                if len(bad):
                    # Across a periodic seam, or where the blend of the corners' parameters is a
                    # poor start: start from each corner's own parameters (the surface continues
                    # past a seam) and keep the closest point found within the bound.
                    found = np.full(len(bad), np.inf)
                    for k in range(3):
                        start = np.repeat(uvv[:, k, :], npts, axis=0)[bad]
                        dk, okk = self.gauss_newton(f, X[bad], start)
                        okk &= dk <= vbound[bad] * (1 + 1e-12) + 1e-300
                        found = np.where(okk, np.minimum(found, dk), found)
                    dd[bad] = found
                    # Only what no start reached goes to OCC's projection (exact, but ~0.5 ms a
                    # point on a B-spline, and onto a trimmed periodic face it can land across
                    # the seam, on a cylinder's far side: kept only where it is the closer).
                    rest = bad[~np.isfinite(found)]
                    if len(rest):
                        dd[rest] = np.linalg.norm(X[rest] - self.closest(f, X[rest]), axis=1)
                gi = (esel[:, None] * npts + np.arange(npts)[None, :]).ravel()
                d[gi] = np.minimum(d[gi], dd)
        finally:
            gmsh.model.setCurrent(prev)
        return d


def _vkey(V):
    """Exact lookup key of a vertex: its coordinates rounded to float32 (binary STL precision)."""
    return np.ascontiguousarray(np.asarray(V, dtype=np.float64).astype(np.float32)).view(np.uint8) \
        .reshape(len(V), 12)


def distance_function(name, stl=None, own_face=False):
    """Return f(P, elem_vertices) -> distances for shape `name` (own_face: see StepDistance)."""
    spec = shapes.SHAPES[name]
    k = spec["kind"]
    if k == "sphere":
        return lambda P, Xv=None: dist_sphere(P, spec["radius"])
    if k == "torus":
        return lambda P, Xv=None: dist_torus(P, spec["R"], spec["r"])
    if k == "ellipsoid":
        return lambda P, Xv=None: dist_ellipsoid(P, spec["axes"])
    if k == "cylinder":
        return lambda P, Xv=None: dist_cylinder(P, spec["radius"], spec["height"])
    sd = StepDistance(name, shapes.sidecar_path(stl) if stl else None, own_face)

    def f(P, Xv=None, uv=None):
        # Gauss-Newton needs good start parameters; without the sidecar's, use OCC directly
        # (a blend of projected vertex parameters can converge to a far stationary point).
        if Xv is None or sd.vertex_faces is None:
            return sd(P)
        M, unknown = sd.element_faces(Xv)
        lam = np.column_stack([1 - uv[:, 0] - uv[:, 1], uv[:, 0], uv[:, 1]])
        npts = len(uv)
        d = np.empty(len(P))
        ps = np.repeat(unknown, npts)
        if (~unknown).any():  # vertices found in the input: Gauss-Newton from known parameters
            k = np.nonzero(~unknown)[0]
            vids = sd.last_vertices
            sd.last_vertices = vids[k]
            d[~ps] = sd.element_distance(P[~ps], Xv[k], lam, M[k], np.zeros(len(k), bool))
            sd.last_vertices = vids
        if unknown.any():  # moved vertices: OCC projection on every face near the point
            d[ps] = sd(P[ps])
        return d
    f.step = True
    f.sd = sd
    return f


# ----------------------------------------------------------------------------- checks
def edge_check(conn, order):
    """Watertightness and conformity: every element edge, identified by the set of ALL its node
    tags (vertices and high-order edge nodes), must be used by exactly two elements."""
    p = order
    # Gmsh local order: 3 vertices, then p-1 nodes per edge, edges 0-1, 1-2, 2-0.
    edges = []
    for k, (a, b) in enumerate([(0, 1), (1, 2), (2, 0)]):
        cols = [a, b] + list(range(3 + k * (p - 1), 3 + (k + 1) * (p - 1)))
        edges.append(np.sort(conn[:, cols], axis=1))
    E = np.concatenate(edges)
    _, cnt = np.unique(E, axis=0, return_counts=True)
    # Edges of vertices only: detects high-order nodes that are not shared (vertex edge count 2,
    # full-edge count 1).
    V = np.sort(np.concatenate([conn[:, [0, 1]], conn[:, [1, 2]], conn[:, [2, 0]]]), axis=1)
    _, vcnt = np.unique(V, axis=0, return_counts=True)
    # conforming: each edge of vertices has one node set (open rims and non-manifold edges allowed).
    return {"edges": int(len(cnt)), "edges_not_twice": int((cnt != 2).sum()), "conforming": bool(len(cnt) == len(vcnt)),
            "vertex_edges_not_twice": int((vcnt != 2).sum()),
            "watertight": bool((cnt == 2).all() and (vcnt == 2).all())}


# ----------------------------------------------------------------------------- measure
def measure(path, name, stl=None, q=None, chunk=20000, dist=None, per_element=False):
    """Sample every element of `path` and measure its distance to shape `name`.

    Returns a dict with max/rms error over all samples, element count, watertightness and the
    number of elements whose sampled Jacobian (x_u x x_v) . n_straight is <= 0. per_element: also
    "element_max" (E,), each element's largest sampled distance, and "corners" (E, 3, 3)."""
    m = read_triangles(path)
    t, p, X = m["type"], m["order"], m["X"]
    if q is None:
        q = max(2 * p, 6)
    uv = lattice(q)
    B = basis(t, uv)                  # (npts, nn)
    G = basis(t, uv, "GradLagrange")  # (npts, nn, 3): d/du, d/dv, d/dw
    dist = dist or distance_function(name, stl)
    step = getattr(dist, "step", False)
    E = len(X)
    npts = len(uv)
    dmax, sq, nsamp = 0.0, 0.0, 0
    all_max = []
    worst = -1
    nonpos = 0
    min_ratio = np.inf
    for s in range(0, E, chunk):
        Xe = X[s:s + chunk]
        P = np.einsum("pn,enk->epk", B, Xe)
        Xu = np.einsum("pn,enk->epk", G[:, :, 0], Xe)
        Xv = np.einsum("pn,enk->epk", G[:, :, 1], Xe)
        n0 = np.cross(Xe[:, 1] - Xe[:, 0], Xe[:, 2] - Xe[:, 0])  # straight normal, |n0| = 2 area
        J = np.einsum("epk,ek->ep", np.cross(Xu, Xv), n0) / np.maximum(
            (n0 ** 2).sum(1), 1e-300)[:, None]                     # = 1 for an affine element
        jmin = J.min(1)
        nonpos += int((jmin <= 0).sum())
        min_ratio = min(min_ratio, float(jmin.min()))
        flat = P.reshape(-1, 3)
        if step:
            d = dist(flat, Xe[:, :3], uv)
        else:
            d = dist(flat)
        d = d.reshape(len(Xe), npts)
        emax = d.max(1)
        if per_element:
            all_max.append(emax)
        i = int(emax.argmax())
        if emax[i] > dmax:
            dmax, worst = float(emax[i]), s + i
        sq += float((d ** 2).sum())
        nsamp += d.size
    res = {"file": path, "shape": name, "element_type": t, "order": p, "elements": E,
           "types": {str(k): v for k, v in m["types"].items()},
           "samples_per_element": npts, "max": dmax, "rms": (sq / max(nsamp, 1)) ** 0.5,
           "worst_element": int(m["tags"][worst]) if worst >= 0 else None,
           "nonpositive_jacobian": nonpos, "min_jacobian_ratio": min_ratio}
    res.update(edge_check(m["conn"], p))
    if per_element:
        res["element_max"] = np.concatenate(all_max) if all_max else np.zeros(0)
        res["corners"] = X[:, :3]
    return res


def main(argv):
    import argparse
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mesh")
    ap.add_argument("shape", choices=sorted(shapes.SHAPES))
    ap.add_argument("--stl", help="input STL (CAD shapes: its .faces.npz sidecar)")
    ap.add_argument("--q", type=int, help="sampling lattice order (default max(2p, 6))")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    r = measure(a.mesh, a.shape, a.stl, a.q)
    if a.json:
        print(json.dumps(r, indent=1))
    else:
        print("%s: type %d (P%d), %d elements, max %.3e rms %.3e, watertight %s, "
              "non-positive Jacobian %d (min ratio %.3f)" % (
                  a.mesh, r["element_type"], r["order"], r["elements"], r["max"], r["rms"],
                  r["watertight"], r["nonpositive_jacobian"], r["min_jacobian_ratio"]))


if __name__ == "__main__":
    main(sys.argv[1:])
