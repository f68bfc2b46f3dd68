#!/usr/bin/python3
"""Wall time and peak memory: hocurve vs Gmsh elevating the same STL to P4 and writing binary MSH 4.1.

Cases: the ~200k-triangle Gmsh sphere (hocurve and Gmsh), the 2.39M-triangle analytic icosphere
(hocurve only; --gmsh-big adds Gmsh, which took 131 s and 4.5 GB in an earlier measurement) and the
scans of ../shared/meshes (--no-scans skips them): hocurve curves the file as given, Gmsh elevates
the same triangles, read from a linear .msh hocurve writes first (Gmsh reads no OBJ), untimed.
Each program runs in a fresh child process of a small wrapper process, so the peak RSS reported
(getrusage(RUSAGE_CHILDREN).ru_maxrss of that wrapper) belongs to that one run only.

Usage: speed.py [--out DIR] [--hocurve BIN] [--threads 2] [--order 4] [--gmsh-big] [--no-big]
                [--no-scans] [--json FILE]
"""
import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from bench import shapes  # noqa: E402
from bench.accuracy import find_hocurve  # noqa: E402

GMSH_SCRIPT = r"""
import sys, time, gmsh
stl, order, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
gmsh.initialize(readConfigFiles=False)
gmsh.option.setNumber("General.Terminal", 0)
t0 = time.time(); gmsh.merge(stl)
t1 = time.time(); gmsh.model.mesh.setOrder(order)
t2 = time.time()
gmsh.option.setNumber("Mesh.Binary", 1); gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
gmsh.write(out)
t3 = time.time()
print("read %.2f setOrder %.2f write %.2f" % (t1 - t0, t2 - t1, t3 - t2))
gmsh.finalize()
"""


def measured(cmd, timeout=3600):
    """Run cmd in a fresh wrapper process; return dict(rc, wall, peak_rss_mb, stdout, stderr)."""
    wrapper = (
        "import json, resource, subprocess, sys, time\n"
        "t = time.time()\n"
        "r = subprocess.run(sys.argv[1:], stdout=subprocess.PIPE, stderr=subprocess.PIPE)\n"
        "w = time.time() - t\n"
        "ru = resource.getrusage(resource.RUSAGE_CHILDREN)\n"
        "print(json.dumps({'rc': r.returncode, 'wall': w, 'peak_rss_mb': ru.ru_maxrss / 1024.0,\n"
        "  'cpu': ru.ru_utime + ru.ru_stime, 'stdout': r.stdout.decode(errors='replace')[-1000:],\n"
        "  'stderr': r.stderr.decode(errors='replace')[-1000:]}))\n")
    r = subprocess.run([sys.executable, "-c", wrapper] + cmd, stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, timeout=timeout)
    if r.returncode != 0:
        return {"rc": r.returncode, "stderr": r.stderr.decode(errors="replace")[-1000:]}
    return json.loads(r.stdout.decode())


SCANS = ["stanford_bunny_scan.obj", "hammer_scan.obj", "boot.obj", "armadillo.obj"]


def triangles(path):
    if path.endswith(".stl"):
        return (os.path.getsize(path) - 84) // 50
    with open(path) as f:
        return sum(1 for line in f if line.startswith("f "))


def linear_msh(hoc, src, work):
    """src's triangles as a linear .msh for Gmsh (written by hocurve --method linear --order 1)."""
    out = os.path.join(work, os.path.splitext(os.path.basename(src))[0] + "_p1.msh")
    if not os.path.exists(out):
        subprocess.run([hoc, "curve", src, "-o", out, "--order", "1", "--method", "linear"], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return out


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=shapes.DEFAULT_OUT)
    ap.add_argument("--hocurve", help="hocurve binary (default: newest build*/hocurve)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--order", type=int, default=4)
    ap.add_argument("--gmsh-big", action="store_true", help="also run Gmsh on the 2.4M sphere")
    ap.add_argument("--no-big", action="store_true", help="skip the 2.4M sphere")
    ap.add_argument("--no-scans", action="store_true", help="skip the shared scans")
    ap.add_argument("--json", help="write the figures as JSON here")
    a = ap.parse_args(argv)
    hoc = a.hocurve or find_hocurve()
    work = os.path.join(a.out, "speed")
    os.makedirs(work, exist_ok=True)
    sphere = shapes.make_speed_sphere(a.out)
    cases = [("sphere ~200k", sphere, sphere, True)]
    if not a.no_big:
        big = shapes.make_big_sphere(a.out)
        cases.append(("icosphere 2.39M", big, big, a.gmsh_big))
    if not a.no_scans and hoc:
        for name in SCANS:
            src = os.path.join(shapes.SHARED, "meshes", name)
            if os.path.exists(src):
                cases.append((name, src, linear_msh(hoc, src, work), True))
    rows = []
    for label, src, gmsh_input, with_gmsh in cases:
        n = triangles(src)
        if hoc:
            out = os.path.join(work, "hocurve_p%d.msh" % a.order)
            r = measured([hoc, "curve", src, "-o", out, "--order", str(a.order), "--binary",
                          "--threads", str(a.threads), "--stats", os.path.join(work, "stats.json")])
            r.update(case=label, triangles=n, program="hocurve --threads %d" % a.threads,
                     output_mb=os.path.getsize(out) / 1e6 if os.path.exists(out) else None)
            try:
                with open(os.path.join(work, "stats.json")) as f:
                    r["stats"] = json.load(f)
            except (OSError, ValueError):
                pass
            rows.append(r)
            print(row_line(r), flush=True)
            if os.path.exists(out):
                os.remove(out)
        else:
            print("note: no hocurve binary found; Gmsh only")
        if with_gmsh:
            out = os.path.join(work, "gmsh_p%d.msh" % a.order)
            r = measured([sys.executable, "-c", GMSH_SCRIPT, gmsh_input, str(a.order), out])
            r.update(case=label, triangles=n, program="Gmsh merge+setOrder+write",
                     output_mb=os.path.getsize(out) / 1e6 if os.path.exists(out) else None)
            rows.append(r)
            print(row_line(r), flush=True)
            if os.path.exists(out):
                os.remove(out)
    print("\n| case | #tri | program | P | rc | wall s | CPU s | peak RSS MB | output MB |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print("| %s | %d | %s | %d | %s | %.1f | %.1f | %.0f | %s |" % (
            r["case"], r["triangles"], r["program"], a.order, r.get("rc"), r.get("wall", float("nan")),
            r.get("cpu", float("nan")), r.get("peak_rss_mb", float("nan")),
            "%.0f" % r["output_mb"] if r.get("output_mb") else "—"))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)


def row_line(r):
    return "%s, %s: rc %s, wall %.1f s, peak RSS %.0f MB %s" % (
        r["case"], r["program"], r.get("rc"), r.get("wall", float("nan")), r.get("peak_rss_mb", float("nan")),
        (r.get("stdout") or "").strip()[-200:] if r.get("rc") == 0 else (r.get("stderr") or "")[-300:])


if __name__ == "__main__":
    main(sys.argv[1:])
