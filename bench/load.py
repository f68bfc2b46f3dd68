#!/usr/bin/python3
"""Load benchmark for hocurved: starts a daemon on a loopback ephemeral port (or uses --url), submits
jobs from several client threads while other threads poll job status, and reports throughput
(jobs/s) and GET /v1/jobs/{id} latency percentiles while jobs run.

Usage: bench/load.py BUILD_DIR [--jobs 40] [--clients 4] [--pollers 4] [--mesh M] [--order 2] [--workers 2]
       bench/load.py --url http://host:port ...   (an already running server)
"""
import argparse
import concurrent.futures
import json
import os
import sys
import threading
import time
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(SOURCE, "tests", "server"))
sys.path.insert(0, os.path.join(SOURCE, "clients", "python"))
import daemon as D  # noqa: E402
from hocurve_client import Client, ProblemError  # noqa: E402


def pct(values, q):
    if not values:
        return float("nan")
    v = sorted(values)
    return v[min(len(v) - 1, int(round(q * (len(v) - 1))))]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build_dir", nargs="?", default=os.path.join(SOURCE, "build"))
    ap.add_argument("--url")
    ap.add_argument("--jobs", type=int, default=40)
    ap.add_argument("--clients", type=int, default=4)
    ap.add_argument("--pollers", type=int, default=4)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--mesh", default=os.path.join(D.SHARED_DIR, "meshes", "sphere_surf_gmsh.stl"))
    ap.add_argument("--order", type=int, default=2)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    a = ap.parse_args()

    d = None
    if not a.url:
        worker = D.real_worker(a.build_dir)
        if not worker:
            sys.exit("no %s/hocurve; build it first" % a.build_dir)
        d = D.Daemon(a.build_dir, worker=worker,
                     args=["--workers", str(a.workers), "--max-queue", str(a.jobs + 10), "--http-threads", "16"]).start()
        a.url = d.url
    mesh = open(a.mesh, "rb").read()
    c = Client(a.url, timeout=60)
    ids, lock, latencies, refused = [], threading.Lock(), [], [0]
    stop = threading.Event()

    def submitter(n):
        cl = Client(a.url, timeout=60)
        for _ in range(n):
            try:
                j = cl.submit(mesh, {"order": a.order}, retries=50)
                with lock:
                    ids.append(j["id"])
            except ProblemError:
                with lock:
                    refused[0] += 1

    def poller():
        cl = Client(a.url, timeout=60)
        k = 0
        while not stop.is_set():
            with lock:
                target = ids[k % len(ids)] if ids else None
            k += 1
            if target is None:
                time.sleep(0.01)
                continue
            t = time.perf_counter()
            cl.get(target)
            with lock:
                latencies.append(time.perf_counter() - t)

    t0 = time.perf_counter()
    pollers = [threading.Thread(target=poller, daemon=True) for _ in range(a.pollers)]
    for p in pollers:
        p.start()
    per = [a.jobs // a.clients + (1 if i < a.jobs % a.clients else 0) for i in range(a.clients)]
    with concurrent.futures.ThreadPoolExecutor(a.clients) as ex:
        list(ex.map(submitter, per))
    t_submitted = time.perf_counter()
    states = {}
    for i in list(ids):
        states[i] = c.wait(i, timeout=600)["status"]
    t_done = time.perf_counter()
    stop.set()
    for p in pollers:
        p.join(5)
    ok = sum(1 for s in states.values() if s == "succeeded")
    report = {
        "jobs": len(ids), "succeeded": ok, "refused": refused[0], "workers": a.workers,
        "submit_seconds": round(t_submitted - t0, 3), "total_seconds": round(t_done - t0, 3),
        "jobs_per_second": round(ok / (t_done - t0), 2),
        "status_requests": len(latencies),
        "status_p50_ms": round(pct(latencies, 0.50) * 1e3, 2),
        "status_p99_ms": round(pct(latencies, 0.99) * 1e3, 2),
        "mesh": os.path.basename(a.mesh), "order": a.order,
    }
    if d:
        d.stop()
    if a.json:
        print(json.dumps(report))
    else:
        for k, v in report.items():
            print("%-18s %s" % (k, v))
    return 0 if ok == len(ids) else 1


if __name__ == "__main__":
    sys.exit(main())
