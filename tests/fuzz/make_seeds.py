#!/usr/bin/python3
"""Seed corpora of the reader harnesses, built at run time (nothing large is committed).

Usage: /usr/bin/python3 tests/fuzz/make_seeds.py OUTDIR
Writes OUTDIR/{stl,obj,ply,off,msh,gzip}/: small patches (8 and 40 faces) of the shared meshes
(../shared/meshes) in every variant each reader knows (STL ascii/binary, OBJ with polygons and
negative indices, PLY ascii and binary both endians, OFF, Gmsh 2.2 and 4.1 ascii and binary via
meshio), heads of the shared files, the small inputs of scripts/fuzz_inputs.py, and gzip of all
of them. Every seed stays under MAX_BYTES, so libFuzzer's -max_len can stay small.
"""
import contextlib
import gzip
import io
import os
import struct
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
MESHES = os.path.normpath(os.path.join(ROOT, "..", "shared", "meshes"))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import fuzz_inputs  # noqa: E402  (the CLI robustness cases: their small inputs are seeds too)

MAX_BYTES = 16384


def patch(V, F, k):
    """The first k faces with the vertices they use, renumbered in first-use order."""
    F = np.asarray(F)[:k]
    used, inv = np.unique(F.reshape(-1), return_inverse=True)
    return np.asarray(V)[used], inv.reshape(-1, 3)


def num(x):
    return repr(float(x))


def stl_ascii(V, F):
    s = ["solid seed"]
    for f in F:
        s.append("  facet normal 0 0 0\n    outer loop")
        s += ["      vertex %s %s %s" % tuple(num(x) for x in V[i]) for i in f]
        s.append("    endloop\n  endfacet")
    s.append("endsolid seed\n")
    return "\n".join(s).encode()


def stl_binary(V, F):
    out = bytearray(b"seed".ljust(80, b" ") + struct.pack("<I", len(F)))
    for f in F:
        out += struct.pack("<12fH", 0, 0, 0, *V[f].reshape(-1), 0)
    return bytes(out)


def obj(V, F, quads=False):
    s = ["# seed", "o seed", "g part"] + ["v %s %s %s" % tuple(num(x) for x in v) for v in V]
    s += ["vn 0 0 1", "vt 0 0", "s 1"]
    k = 0
    while k < len(F):
        f = F[k]
        if quads and k + 1 < len(F):  # a polygon over two triangles' corners exercises splitting
            f = list(dict.fromkeys(list(F[k]) + list(F[k + 1])))
            k += 1
        if k % 3 == 0:
            s.append("f " + " ".join("%d/1/1" % (i + 1) for i in f))
        elif k % 3 == 1:
            s.append("f " + " ".join("%d" % (i - len(V)) for i in f))  # negative (relative)
        else:
            s.append("f " + " ".join("%d//1" % (i + 1) for i in f))
        k += 1
    s.append("l 1 2")
    return ("\n".join(s) + "\n").encode()


def off(V, F):
    s = ["OFF", "# seed", "%d %d 0" % (len(V), len(F))]
    s += ["%s %s %s" % tuple(num(x) for x in v) for v in V]
    s += ["3 %d %d %d" % tuple(f) + (" 255 0 0" if k % 2 else "") for k, f in enumerate(F)]
    return ("\n".join(s) + "\n").encode()


def ply(V, F, fmt, count="uchar", index="int"):
    head = ("ply\nformat %s 1.0\ncomment seed\nelement vertex %d\nproperty float x\nproperty float y\n"
            "property float z\nproperty uchar red\nelement face %d\nproperty list %s %s vertex_indices\n"
            "end_header\n" % (fmt, len(V), len(F), count, index)).encode()
    if fmt == "ascii":
        body = "".join("%s %s %s 7\n" % tuple(num(x) for x in v) for v in V)
        body += "".join("3 %d %d %d\n" % tuple(f) for f in F)
        return head + body.encode()
    e = "<" if fmt == "binary_little_endian" else ">"
    cc = {"uchar": "B", "uint": "I", "ushort": "H"}[count]
    ic = {"int": "i", "uint": "I", "short": "h"}[index]
    body = b"".join(struct.pack(e + "3fB", *v, 7) for v in V)
    body += b"".join(struct.pack(e + cc + "3" + ic, 3, *f) for f in F)
    return head + body


def msh_variants(V, F):
    import meshio
    out = {}
    m = meshio.Mesh(np.asarray(V, float), [("triangle", np.asarray(F))])
    for fmt in ("gmsh22", "gmsh"):
        for binary in (False, True):
            with tempfile.TemporaryDirectory() as d:
                p = os.path.join(d, "m.msh")
                with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
                    meshio.write(p, m, file_format=fmt, binary=binary)
                out["%s_%s" % (fmt, "bin" if binary else "asc")] = open(p, "rb").read()
    return out


def shared_meshes():
    """(label, V, F) of a few shared meshes of each kind."""
    out = []
    for name in ("torus.obj", "spot.obj", "hinge_netgen.stl", "sphere_surf_gmsh.stl"):
        if os.path.exists(os.path.join(MESHES, name)):
            V, F = fuzz_inputs.load(name)
            out.append((name.split(".")[0], V, F))
    return out


def heads():
    """Beginnings of the shared files as they are (exporters' headers, comments, layout)."""
    out = {}
    for name in sorted(os.listdir(MESHES)) if os.path.isdir(MESHES) else []:
        p = os.path.join(MESHES, name)
        if not os.path.isfile(p) or name.split(".")[-1] not in ("obj", "stl", "gz"):
            continue
        data = open(p, "rb").read()
        if name.endswith(".gz"):
            data = gzip.decompress(data)
        if name.endswith(".stl") and struct.unpack("<I", data[80:84])[0] * 50 + 84 <= len(data) and not data[:5] == b"solid":
            # binary STL: the header and 20 facets, with the count made true
            out[("stl", name)] = data[:80] + struct.pack("<I", 20) + data[84:84 + 50 * 20]
        else:
            kind = "obj" if ".obj" in name else "stl"
            out[(kind, name)] = data[:MAX_BYTES // 2]
    return out


def main():
    outdir = sys.argv[1]
    seeds = {k: {} for k in ("stl", "obj", "ply", "off", "msh")}
    tiny = [("tri", np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.]]), np.array([[0, 1, 2]])),
            ("octa",) + tuple(np.asarray(a) for a in fuzz_inputs.octahedron())]
    for label, V, F in tiny + shared_meshes():
        for k in (8, 40):
            Vp, Fp = patch(V, F, k)
            tag = "%s_%d" % (label, k)
            seeds["stl"][tag + "_ascii"] = stl_ascii(Vp, Fp)
            seeds["stl"][tag + "_binary"] = stl_binary(Vp, Fp)
            seeds["obj"][tag] = obj(Vp, Fp)
            seeds["obj"][tag + "_polygons"] = obj(Vp, Fp, quads=True)
            seeds["off"][tag] = off(Vp, Fp)
            seeds["ply"][tag + "_ascii"] = ply(Vp, Fp, "ascii")
            seeds["ply"][tag + "_le"] = ply(Vp, Fp, "binary_little_endian")
            seeds["ply"][tag + "_be_uint"] = ply(Vp, Fp, "binary_big_endian", "uint", "uint")
            for variant, data in msh_variants(Vp, Fp).items():
                seeds["msh"][tag + "_" + variant] = data
            if len(F) <= k:
                break
    for (kind, name), data in heads().items():
        seeds[kind]["head_" + name] = data
    with tempfile.TemporaryDirectory() as d:
        for label, fname, fn in fuzz_inputs.build_cases():
            if label.startswith("sphere_graded"):
                continue  # meshed by gmsh: slow, and large
            p = os.path.join(d, fname)
            fn(p)
            if os.path.getsize(p) <= MAX_BYTES:
                seeds[fname.split(".")[-1]]["cli_" + label] = open(p, "rb").read()
    seeds["gzip"] = {}
    for kind in ("stl", "obj", "ply", "off", "msh"):
        for tag, data in seeds[kind].items():
            if len(data) <= MAX_BYTES // 2:
                seeds["gzip"][kind + "_" + tag] = gzip.compress(data, mtime=0)
    two = gzip.compress(stl_ascii(*patch(*tiny[1][1:], 4)), mtime=0) + gzip.compress(b"", mtime=0)
    seeds["gzip"]["two_members"] = two  # concatenated members are legal
    for kind, files in seeds.items():
        os.makedirs(os.path.join(outdir, kind), exist_ok=True)
        n = 0
        for tag, data in files.items():
            if len(data) <= MAX_BYTES:
                with open(os.path.join(outdir, kind, tag), "wb") as f:
                    f.write(data)
                n += 1
        print("make_seeds: %-4s %3d seeds" % (kind, n))


if __name__ == "__main__":
    main()
