#!/usr/bin/python3
"""hocurved under stress and failure: 8 concurrent clients submitting 200 jobs, kill -9 during a job
and restart, a crashing worker, cancel, timeout, graceful SIGTERM; non-UTF-8 text, abandoned and slow
requests, leftovers of killed writers. Real daemon, loopback only.
Usage: test_server_robust.py BUILD_DIR"""
import concurrent.futures
import fcntl
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import unittest
import urllib.error
import urllib.request

BUILD_DIR = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.environ.get("HOCURVE_BUILD_DIR", "build"))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "server"))
import daemon as D  # noqa: E402
from hocurve_client import Client, ProblemError  # noqa: E402

SPHERE = os.path.join(D.SHARED_DIR, "meshes", "sphere_surf_gmsh.stl")


def wait_for(pred, timeout, interval=0.05):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        v = pred()
        if v:
            return v
        time.sleep(interval)
    return None


class Robust(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="hocurved-robust-")
        self.real = D.real_worker(BUILD_DIR)
        self.ok_worker = self.real or D.fake_worker(self.tmp, "fake_ok.py", D.FAKE_OK)
        if not self.real:
            print("NOTE: %s/hocurve not built: using a fake worker" % BUILD_DIR, file=sys.stderr)
        self.daemons = []

    def tearDown(self):
        for d in self.daemons:
            try:
                d.stop(timeout=30)
            except Exception:
                pass
        shutil.rmtree(self.tmp, ignore_errors=True)

    def daemon(self, worker, args=(), data_dir=None, env=None):
        d = D.Daemon(BUILD_DIR, data_dir=data_dir or os.path.join(self.tmp, "data"), worker=worker, args=args, env=env)
        d.start()
        self.daemons.append(d)
        return d

    def test_200_concurrent_submissions_none_lost(self):
        d = self.daemon(self.ok_worker, ["--workers", "2", "--max-queue", "12", "--http-threads", "12"])
        with open(SPHERE, "rb") as f:
            mesh = f.read()

        def client(k):
            c = Client(d.url, timeout=60)
            accepted, refused = [], 0
            for _ in range(25):
                try:
                    accepted.append(c.submit(mesh, {"order": 2})["id"])
                except ProblemError as e:
                    assert e.status == 429 and e.type == "queue-full", e
                    assert e.retry_after and e.retry_after > 0
                    refused += 1
            return accepted, refused

        with concurrent.futures.ThreadPoolExecutor(8) as ex:
            results = list(ex.map(client, range(8)))
        accepted = [i for a, _ in results for i in a]
        refused = sum(r for _, r in results)
        self.assertEqual(len(accepted) + refused, 200)
        self.assertEqual(len(set(accepted)), len(accepted))
        self.assertGreater(len(accepted), 0)
        c = Client(d.url)
        for i in accepted:
            self.assertEqual(c.wait(i, timeout=120)["status"], "succeeded", i)
        listed = {j["id"] for j in c.list()}
        self.assertTrue(set(accepted) <= listed)
        metrics = urllib.request.urlopen(d.url + "/metrics", timeout=10).read().decode()
        self.assertIn("hocurve_queue_full_total %d\n" % refused, metrics)
        print("\n  200 submissions: %d accepted, %d refused with 429" % (len(accepted), refused), file=sys.stderr)

    def test_kill9_during_job_then_restart(self):
        data = os.path.join(self.tmp, "data")
        slow = D.slow_wrapper(self.tmp, self.ok_worker, 2)
        d = self.daemon(slow, ["--workers", "1"], data_dir=data)
        c = Client(d.url)
        first = c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=60)
        self.assertEqual(first["status"], "succeeded")
        job = c.submit(SPHERE, {"order": 3})
        self.assertTrue(wait_for(lambda: c.get(job["id"])["status"] == "running", 10))
        queued = c.submit(SPHERE, {"order": 2})
        d.kill9()
        d2 = self.daemon(slow, ["--workers", "1"], data_dir=data)
        c2 = Client(d2.url)
        done = c2.wait(job["id"], timeout=60)
        self.assertEqual(done["status"], "succeeded", done["error"])
        self.assertEqual(done["attempts"], 2)
        self.assertEqual(c2.wait(queued["id"], timeout=60)["status"], "succeeded")
        # The job finished before the crash is still listed and downloadable.
        self.assertIn(first["id"], [j["id"] for j in c2.list()])
        out = os.path.join(self.tmp, "first.msh")
        self.assertEqual(c2.download(first["id"], out), first["result"]["bytes"])

    def test_crashing_worker_fails_job_and_daemon_keeps_serving(self):
        crash = D.fake_worker(self.tmp, "crash.sh", D.FAKE_CRASH)
        d = self.daemon(crash, ["--workers", "2"])
        c = Client(d.url)
        jobs = [c.submit(SPHERE, {"order": 2})["id"] for _ in range(3)]
        for i in jobs:
            done = c.wait(i, timeout=30)
            self.assertEqual(done["status"], "failed")
            self.assertEqual(done["error"]["code"], "worker-crashed")
            self.assertIn("signal 11", done["error"]["detail"])
            self.assertIn("about to crash", done["error"]["detail"])  # the worker's last stderr line
        self.assertEqual(c.health()["status"], "ok")
        self.assertEqual(len(list(c.list(status="failed"))), 3)

    def test_worker_exit_codes(self):
        w = D.fake_worker(self.tmp, "exit.sh", "#!/bin/sh\necho 'sphere.stl: facet 7: degenerate' >&2\nexit ${FAKE_RC}\n")
        for rc, code in [("3", "invalid-mesh"), ("2", "invalid-options"), ("4", "internal"), ("5", "payload-too-large")]:
            d = self.daemon(w, data_dir=os.path.join(self.tmp, "data" + rc), env={"FAKE_RC": rc})
            c = Client(d.url)
            done = c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=30)
            self.assertEqual((done["status"], done["error"]["code"]), ("failed", code))
            self.assertIn("facet 7: degenerate", done["error"]["detail"])
            with self.assertRaises(ProblemError) as e:
                c.stats(done["id"])
            self.assertEqual(e.exception.status, 409)
            if rc == "3":  # the sync variant maps a refused mesh to 422
                with self.assertRaises(ProblemError) as e:
                    c.curve(SPHERE, {"order": 2})
                self.assertEqual((e.exception.status, e.exception.type), (422, "invalid-mesh"), e.exception.problem)

    def test_one_time_budget_for_info_and_curving(self):
        # The input check (`hocurve info`) and the curving share --job-timeout: 2 s + 2 s > 3 s.
        w = D.fake_worker(self.tmp, "slow_info.sh", "#!/bin/sh\nsleep 2\n"
                          "if [ \"$1\" = info ]; then echo '{}'; exit 0; fi\n"
                          "while [ \"$1\" != -o ]; do shift; done\necho x > \"$2\"\n")
        d = self.daemon(w, ["--job-timeout", "3"], data_dir=os.path.join(self.tmp, "data-budget"))
        c = Client(d.url)
        t0 = time.monotonic()
        done = c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=30)
        self.assertEqual((done["status"], done["error"]["code"]), ("failed", "timeout"), done)
        self.assertLess(time.monotonic() - t0, 5.5)

    def test_cancel_timeout_and_memory_limit(self):
        env = {"FAKE_SLEEP": "0.5", "FAKE_STEPS": "100"}  # 50 s unless stopped
        slow = D.fake_worker(self.tmp, "slow.py", D.FAKE_OK)
        d = self.daemon(slow, ["--workers", "1", "--job-timeout", "3"], env=env)
        c = Client(d.url)
        running = c.submit(SPHERE, {"order": 2})
        queued = c.submit(SPHERE, {"order": 2})
        self.assertTrue(wait_for(lambda: c.get(running["id"])["status"] == "running", 10))
        t0 = time.monotonic()
        self.assertEqual(c.cancel(queued["id"])["status"], "cancelled")
        after = c.cancel(running["id"])
        self.assertEqual(after["status"], "cancelled")
        self.assertLess(time.monotonic() - t0, 5)
        self.assertEqual(c.get(running["id"])["error"]["code"], "cancelled")
        with self.assertRaises(ProblemError) as e:
            c.download(running["id"], os.path.join(self.tmp, "x.msh"))
        self.assertEqual(e.exception.status, 409)
        # Time limit.
        t = c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=30)
        self.assertEqual((t["status"], t["error"]["code"]), ("failed", "timeout"))
        # Memory limit (RLIMIT_AS): a worker that allocates far beyond it dies; the job fails.
        hog = D.fake_worker(self.tmp, "hog.py", "x = bytearray(2 << 30)\n")
        d2 = self.daemon(hog, ["--job-memory-mb", "256"], data_dir=os.path.join(self.tmp, "data-hog"))
        c2 = Client(d2.url)
        h = c2.wait(c2.submit(SPHERE, {"order": 2})["id"], timeout=30)
        self.assertEqual(h["status"], "failed")
        self.assertIn("MemoryError", h["error"]["detail"])

    def test_sigterm_drains_and_queued_jobs_survive(self):
        data = os.path.join(self.tmp, "data")
        env = {"FAKE_SLEEP": "0.3", "FAKE_STEPS": "100"}
        slow = D.fake_worker(self.tmp, "slow.py", D.FAKE_OK)
        d = self.daemon(slow, ["--workers", "1", "--shutdown-grace", "2"], data_dir=data, env=env)
        c = Client(d.url)
        a = c.submit(SPHERE, {"order": 2})
        b = c.submit(SPHERE, {"order": 2})
        self.assertTrue(wait_for(lambda: c.get(a["id"])["status"] == "running", 10))
        t0 = time.monotonic()
        d.proc.send_signal(signal.SIGTERM)

        def readyz_status():
            try:
                urllib.request.urlopen(d.url + "/readyz", timeout=5)
                return None
            except urllib.error.HTTPError as e:
                return e.code
        # While draining: not ready, new jobs refused with 503 draining, status still served.
        self.assertEqual(wait_for(readyz_status, 1.5, 0.02), 503)
        with self.assertRaises(ProblemError) as e:
            c.submit(SPHERE, {"order": 2})
        self.assertEqual((e.exception.status, e.exception.type), (503, "draining"))
        self.assertEqual(c.get(a["id"])["status"], "running")
        self.assertEqual(d.proc.wait(20), 0)
        self.assertLess(time.monotonic() - t0, 10)
        msgs = [l.get("msg") for l in d.lines]
        self.assertIn("draining", msgs)
        self.assertEqual(msgs[-1], "stopped")
        for i in (a, b):
            with open(os.path.join(data, "jobs", i["id"], "state.json")) as f:
                state = json.load(f)
            self.assertEqual(state["status"], "queued")
        fast = D.fake_worker(self.tmp, "fast.py", D.FAKE_OK)
        d2 = self.daemon(fast, data_dir=data)
        c2 = Client(d2.url)
        for i in (a, b):
            self.assertEqual(c2.wait(i["id"], timeout=30)["status"], "succeeded")

    def test_retention_and_quota(self):
        fast = D.fake_worker(self.tmp, "fast.py", D.FAKE_OK)
        d = self.daemon(fast, ["--retention", "1", "--max-disk-mb", "0.3"])
        c = Client(d.url)
        j = c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=30)  # 119 KB of 300 KB
        self.assertEqual(j["status"], "succeeded")
        c.submit(SPHERE, {"order": 2})
        with self.assertRaises(ProblemError) as e:  # a third upload would exceed the quota
            c.submit(SPHERE, {"order": 2})
        self.assertEqual((e.exception.status, e.exception.type), (507, "quota-exceeded"))
        self.assertIn("quota (0.3 MiB)", e.exception.detail)
        # Above the upload limit it is 413, whatever the quota.
        host, port = d.url.split("//")[1].split(":")
        with socket.create_connection((host, int(port)), timeout=10) as s:
            s.sendall(b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/octet-stream\r\n"
                      b"Content-Length: 999999999999\r\n\r\n")
            self.assertIn(b" 413 ", s.recv(4096).split(b"\r\n")[0])
        gone = wait_for(lambda: j["id"] not in [x["id"] for x in c.list()], 10)
        self.assertTrue(gone, "expired job still listed")
        self.assertTrue(wait_for(lambda: not os.path.exists(os.path.join(d.data_dir, "jobs", j["id"])), 10))
        c.wait(c.submit(SPHERE, {"order": 2}, retries=0)["id"], timeout=30)  # space was freed

    # --- Found by a black-box sweep ---------------------------------------------------------------

    def raw(self, d, head, body=b"", wait=10):
        """Sends one raw HTTP request; returns the status line and the whole reply (its headers, and
        the body as long as Content-Length says: they may come in several reads)."""
        host, port = d.url.split("//")[1].split(":")
        with socket.create_connection((host, int(port)), timeout=wait) as s:
            s.sendall(head + body)
            reply = b""
            while True:
                chunk = s.recv(65536)
                reply += chunk
                top, _, rest = reply.partition(b"\r\n\r\n")
                lengths = [int(l.split(b":")[1]) for l in top.split(b"\r\n") if l.lower().startswith(b"content-length:")]
                if not chunk or (_ and len(rest) >= (lengths[0] if lengths else 0)):
                    break
        return reply.split(b"\r\n", 1)[0], reply

    def test_error_message_with_invalid_utf8_is_saved_and_not_rerun(self):
        if not self.real:
            self.skipTest("needs the real worker's message")
        bad = os.path.join(self.tmp, "bad.stl")
        with open(bad, "wb") as f:  # the refusal echoes the file's own bytes
            f.write(b"solid \xff\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 \xffq\n"
                    b"   vertex 0 1 0\n  endloop\n endfacet\nendsolid\n")
        data = os.path.join(self.tmp, "data")
        d = self.daemon(self.real, data_dir=data)
        c = Client(d.url)
        job = c.wait(c.submit(bad, {"order": 2})["id"], timeout=30)
        self.assertEqual((job["status"], job["error"]["code"]), ("failed", "invalid-mesh"))
        with open(os.path.join(data, "jobs", job["id"], "state.json"), "rb") as f:
            self.assertEqual(json.loads(f.read().decode("utf-8"))["status"], "failed")  # was left "running"
        d.stop()
        again = Client(self.daemon(self.real, data_dir=data).url).get(job["id"])
        self.assertEqual((again["status"], again["attempts"]), ("failed", 1))  # not run again

    def test_invalid_utf8_key_and_file_name(self):
        d = self.daemon(self.ok_worker)
        with open(SPHERE, "rb") as f:
            mesh = f.read()
        head = (b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/octet-stream\r\n"
                b"Idempotency-Key: k\xe9y\r\nContent-Length: %d\r\n\r\n" % len(mesh))
        self.assertIn(b" 400 ", self.raw(d, head, mesh)[0])  # was 500, and the upload stayed on disk
        part = (b"--XyZ\r\nContent-Disposition: form-data; name=\"mesh\"; filename=\"mesh-\xff.stl\"\r\n"
                b"Content-Type: application/octet-stream\r\n\r\n" + mesh + b"\r\n--XyZ--\r\n")
        head = (b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: multipart/form-data; boundary=XyZ\r\n"
                b"Content-Length: %d\r\n\r\n" % len(part))
        status, reply = self.raw(d, head, part)
        self.assertIn(b" 202 ", status, reply[:300])
        job = json.loads(reply.split(b"\r\n\r\n", 1)[1].decode("utf-8"))
        self.assertEqual(Client(d.url).wait(job["id"], timeout=30)["status"], "succeeded")
        self.assertEqual(os.listdir(os.path.join(d.data_dir, "uploads")), [])
        self.assertEqual(os.listdir(os.path.join(d.data_dir, "jobs")), [job["id"]])

    def test_sync_request_abandoned_cancels_its_job(self):
        slow = D.slow_wrapper(self.tmp, self.ok_worker, 60)
        d = self.daemon(slow, ["--workers", "1"])
        with open(SPHERE, "rb") as f:
            mesh = f.read()
        host, port = d.url.split("//")[1].split(":")
        s = socket.create_connection((host, int(port)), timeout=10)
        s.sendall(b"POST /v1/curve?order=2 HTTP/1.1\r\nHost: x\r\nContent-Type: application/octet-stream\r\n"
                  b"Content-Length: %d\r\n\r\n" % len(mesh) + mesh)
        running = lambda: json.loads(urllib.request.urlopen(d.url + "/readyz", timeout=5).read())["running"]
        self.assertTrue(wait_for(lambda: running() == 1, 10))
        s.close()  # the client gives up
        self.assertTrue(wait_for(lambda: running() == 0, 10), "the abandoned job kept its worker")
        self.assertTrue(any(r.get("msg") == "sync job cancelled: the client hung up" for r in d.lines))

    def test_sync_request_half_closed_gets_its_result(self):
        # shutdown(SHUT_WR) after the whole request is legal: the client still reads the answer.
        # The daemon took the FIN for a hang-up and cancelled the job (and the library would not
        # have written to such a client anyway). An interim 100 Continue may come first: the probe
        # that tells a half-close from a close.
        d = self.daemon(D.slow_wrapper(self.tmp, self.ok_worker, 1), ["--workers", "1"])
        with open(SPHERE, "rb") as f:
            mesh = f.read()
        host, port = d.url.split("//")[1].split(":")
        with socket.create_connection((host, int(port)), timeout=20) as s:
            s.sendall(b"POST /v1/curve?order=2 HTTP/1.1\r\nHost: x\r\nContent-Type: application/octet-stream\r\n"
                      b"Content-Length: %d\r\n\r\n" % len(mesh) + mesh)
            s.shutdown(socket.SHUT_WR)
            reply = b""
            while True:  # the daemon closes once the answer is written (the client sends no more)
                chunk = s.recv(65536)
                if not chunk:
                    break
                reply += chunk
        while reply.startswith(b"HTTP/1.1 100 "):
            reply = reply.split(b"\r\n\r\n", 1)[1]
        head, _, body = reply.partition(b"\r\n\r\n")
        self.assertTrue(head.startswith(b"HTTP/1.1 200 "), reply[:300])
        self.assertTrue(body.startswith(b"$MeshFormat"), body[:100])
        self.assertFalse(any(r.get("msg") == "sync job cancelled: the client hung up" for r in d.lines))

    def test_data_directory_deleted_keeps_its_lock(self):
        # Deleting the data directory took the lock file with it: a second daemon could then start
        # on the re-created directory. The daemon now takes its lock again (or answers 503 while
        # another process holds the new lock file).
        d = self.daemon(self.ok_worker)
        c = Client(d.url)
        readyz = lambda: self.raw(d, b"GET /readyz HTTP/1.1\r\nHost: x\r\n\r\n")
        shutil.rmtree(d.data_dir)
        status, reply = readyz()
        self.assertIn(b" 503 ", status)
        self.assertIn(b"storage-unavailable", reply)
        os.makedirs(d.data_dir)
        self.assertIn(b" 200 ", readyz()[0])  # lock taken again, folders made again
        self.assertTrue(os.path.exists(os.path.join(d.data_dir, "lock")))
        self.assertEqual(c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=30)["status"], "succeeded")
        r = subprocess.run([d.exe, "--host", "127.0.0.1", "--port", "0", "--data-dir", d.data_dir],
                           capture_output=True, timeout=20)
        self.assertEqual(r.returncode, 1, r.stdout[-500:])  # a second daemon on it refuses to start
        self.assertIn(b"another hocurved", r.stdout)
        # A new directory whose lock another process holds (moved in at once, so the daemon cannot
        # take it first): 503 for probes and submissions until that process lets go.
        shutil.rmtree(d.data_dir)
        other = os.path.join(self.tmp, "other")
        os.makedirs(other)
        with open(os.path.join(other, "lock"), "w") as held:
            fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
            os.rename(other, d.data_dir)
            status, reply = readyz()
            self.assertIn(b" 503 ", status)
            self.assertIn(b"another process", reply)
            with self.assertRaises(ProblemError) as e:
                c.submit(SPHERE, {"order": 2})
            self.assertEqual((e.exception.status, e.exception.type), (503, "storage-unavailable"))
        self.assertIn(b" 200 ", readyz()[0])

    def test_slow_upload_is_cut_off(self):
        d = self.daemon(self.ok_worker)
        host, port = d.url.split("//")[1].split(":")
        with socket.create_connection((host, int(port)), timeout=30) as s:
            s.sendall(b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/octet-stream\r\n"
                      b"Content-Length: 100000\r\n\r\n")
            t0, reply = time.monotonic(), b""
            s.settimeout(0.5)
            while not reply and time.monotonic() - t0 < 30:
                s.sendall(b"x" * 10)  # 20 bytes per second
                try:
                    reply = s.recv(4096)
                except socket.timeout:
                    pass
            self.assertIn(b" 408 ", reply.split(b"\r\n")[0])
            self.assertLess(time.monotonic() - t0, 25)
            t1, closed = time.monotonic(), False
            while not closed and time.monotonic() - t1 < 10:  # a client that keeps sending is let go
                try:
                    s.sendall(b"x" * 10)
                    closed = s.recv(4096) == b""
                except socket.timeout:
                    pass
                except OSError:
                    closed = True
            self.assertTrue(closed and time.monotonic() - t1 < 5, "the connection stayed open after the 408")
        self.assertEqual(os.listdir(os.path.join(d.data_dir, "uploads")), [])

    def test_readyz_needs_a_worker_program(self):
        d = self.daemon(os.path.join(self.tmp, "no-such-worker"))
        with self.assertRaises(urllib.error.HTTPError) as e:
            urllib.request.urlopen(d.url + "/readyz", timeout=5)
        self.assertEqual(e.exception.code, 503)
        self.assertIn("cannot be executed", json.loads(e.exception.read())["detail"])

    def test_two_content_lengths_and_encoded_slash_refused(self):
        d = self.daemon(self.ok_worker)
        head = (b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/octet-stream\r\n"
                b"Content-Length: 10\r\nContent-Length: 20\r\n\r\n")
        self.assertIn(b" 400 ", self.raw(d, head, b"x" * 20)[0])  # was 202: a request smuggling risk
        self.assertEqual(os.listdir(os.path.join(d.data_dir, "jobs")), [])
        job = Client(d.url).wait(Client(d.url).submit(SPHERE, {"order": 2})["id"], timeout=30)
        head = b"GET /v1/jobs/%s%%2Fresult HTTP/1.1\r\nHost: x\r\n\r\n" % job["id"].encode()
        self.assertIn(b" 404 ", self.raw(d, head)[0])  # was 200: an encoded '/' reached another route

    def test_result_over_quota_is_dropped(self):
        big = D.fake_worker(self.tmp, "big.py", D.FAKE_OK.replace(
            'open(out, \'w\').write("$MeshFormat\\n%s 0 8\\n$EndMeshFormat\\n" % version)',
            'open(out, \'w\').write("x" * 400000)'))
        d = self.daemon(big, ["--max-disk-mb", "0.3"])
        c = Client(d.url)
        job = c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=30)  # 119 KB in, 400 KB out
        self.assertEqual((job["status"], job["error"]["code"], job["error"]["status"]), ("failed", "quota-exceeded", 507))
        self.assertEqual(sorted(os.listdir(os.path.join(d.data_dir, "jobs", job["id"]))),
                         ["input.stl", "state.json", "stats.json", "worker.log"])

    def test_disk_bytes_match_the_files(self):
        data = os.path.join(self.tmp, "data")
        d = self.daemon(self.ok_worker, data_dir=data)
        c = Client(d.url)
        jobs = [c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=30)["id"] for _ in range(4)]

        def metric(dd):
            text = urllib.request.urlopen(dd.url + "/metrics", timeout=10).read().decode()
            return int(float([l.split()[1] for l in text.splitlines() if l.startswith("hocurve_disk_bytes ")][0]))

        def on_disk():
            return sum(os.path.getsize(os.path.join(r, f)) for r, _, fs in os.walk(os.path.join(data, "jobs")) for f in fs)

        self.assertEqual(metric(d), on_disk())  # counted inputs and results only: stats and logs were missed
        for j in jobs[:2]:
            c.cancel(j)
        self.assertEqual(metric(d), on_disk())
        d.stop()
        d2 = self.daemon(self.ok_worker, data_dir=data)
        self.assertEqual(metric(d2), on_disk())
        for j in jobs[2:]:
            Client(d2.url).cancel(j)
        self.assertEqual((metric(d2), on_disk()), (0, 0))  # each deleted job left its state.json counted

    def test_temporary_files_and_server_paths(self):
        data = os.path.join(self.tmp, "data")
        d = self.daemon(self.ok_worker, data_dir=data)
        c = Client(d.url)
        job = c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=30)
        self.assertNotIn(data, json.dumps(c.stats(job["id"])))  # stats name files, not server paths
        d.stop()
        leftover = os.path.join(data, "jobs", job["id"], "result.part.msh.tmp.1f2e")  # a killed writer's
        with open(leftover, "wb") as f:
            f.write(b"x" * 1000)
        self.daemon(self.ok_worker, data_dir=data)
        self.assertFalse(os.path.exists(leftover))


    # --- Service hardening: quota under parallel uploads, weaker items of the attack sweep ---------

    def test_parallel_uploads_stay_within_the_quota(self):
        slow = D.fake_worker(self.tmp, "slow.py", D.FAKE_OK)
        d = self.daemon(slow, ["--max-disk-mb", "1"], env={"FAKE_SLEEP": "5"})
        body = b"solid big\n" + b"x" * (330 * 1000 - 22) + b"\nendsolid big\n"
        head = (b"POST /v1/jobs?order=2 HTTP/1.1\r\nHost: x\r\nContent-Type: application/octet-stream\r\n"
                b"Content-Length: %d\r\n\r\n" % len(body))
        socks = [socket.create_connection(("127.0.0.1", d.port), timeout=30) for _ in range(12)]
        try:
            for s in socks:  # every upload starts before any ends: each was checked against an empty store
                s.sendall(head)
            time.sleep(0.5)
            for s in socks:
                s.sendall(body)
            statuses = []
            for s in socks:
                reply = b""
                while b"\r\n\r\n" not in reply:
                    chunk = s.recv(65536)
                    if not chunk:
                        break
                    reply += chunk
                statuses.append(int(reply.split(b" ")[1]))
        finally:
            for s in socks:
                s.close()
        accepted = statuses.count(202)
        self.assertEqual(accepted + statuses.count(507), 12, statuses)
        self.assertEqual(accepted, 3, statuses)  # 3 x 330 KB fit in 1 MiB (was: all 12, 4 MB)
        used = sum(os.path.getsize(os.path.join(r, f)) for r, _, fs in os.walk(os.path.join(d.data_dir, "jobs")) for f in fs)
        self.assertLessEqual(used, 1048576 + len(body), used)
        print("\n  12 parallel 330 KB uploads, 1 MiB quota: %d accepted, %d bytes stored" % (accepted, used), file=sys.stderr)

    def test_weaker_items_of_the_attack_sweep(self):
        with open(os.path.join(self.tmp, "token"), "w") as f:
            f.write("s3cret\n")
        d = self.daemon(self.ok_worker, ["--token-file", os.path.join(self.tmp, "token"), "--client-timeout", "1"])
        with open(SPHERE, "rb") as f:
            mesh = f.read()
        auth = b"Authorization: Bearer s3cret\r\n"
        post = (b"POST /v1/jobs%s HTTP/1.1\r\nHost: x\r\n%sContent-Type: application/octet-stream\r\n"
                b"Content-Length: %d\r\n\r\n")
        # ';' is no separator here, and neither a second value: 400, not order=3 (or 4) by accident.
        status, reply = self.raw(d, post % (b"?order=3;order=4", auth, len(mesh)), mesh)
        self.assertIn(b" 400 ", status)
        self.assertIn(b"invalid-options", reply)
        # "Bearer" and the token may be apart by more than one space (RFC 9110 11.4: 1*SP).
        status, _ = self.raw(d, b"GET /v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer   s3cret\r\n\r\n")
        self.assertIn(b" 200 ", status)
        # One Connection header on a 401 to a client that said close itself.
        status, reply = self.raw(d, b"GET /v1/jobs HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
        self.assertIn(b" 401 ", status)
        self.assertEqual(reply.lower().count(b"\r\nconnection:"), 1, reply)
        # A body that stops coming is 408, as documented (was 400).
        status, _ = self.raw(d, post % (b"?order=2", auth, len(mesh)), mesh[:1000])
        self.assertIn(b" 408 ", status)
        # A gzip bomb (20 MB of zeros in 20 KB) is refused at submission, before any worker inflates it.
        import gzip
        bomb = gzip.compress(b"\0" * (20 << 20))
        status, reply = self.raw(d, post % (b"?order=2", auth, len(bomb)), bomb)
        self.assertIn(b" 422 ", status)
        self.assertIn(b"gzip", reply)
        text = gzip.compress(b"hello world\n" * 1000)
        self.assertIn(b" 415 ", self.raw(d, post % (b"?order=2", auth, len(text)), text)[0])
        zipped = gzip.compress(mesh)
        self.assertIn(b" 202 ", self.raw(d, post % (b"?order=2", auth, len(zipped)), zipped)[0])
        # An OBJ may open with many group and object lines before its first vertex.
        obj = b"".join(b"o part%d\ng group%d\nusemtl m\n" % (i, i) for i in range(3000))
        obj += b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"
        self.assertIn(b" 202 ", self.raw(d, post % (b"?order=2", auth, len(obj)), obj)[0])

    def test_out_of_memory_abort_is_413(self):
        # Under a small RLIMIT_AS the worker's threads or allocations fail and the runtime aborts.
        worker = D.fake_worker(self.tmp, "oom.py", "import os, signal, sys\n"
                               "if sys.argv[1] != 'info':\n"
                               "    sys.stderr.write(\"terminate called after throwing an instance of 'std::system_error'\\n"
                               "  what():  pthread_create has failed: Resource temporarily unavailable\\n\")\n"
                               "    sys.stderr.flush()\n    os.kill(os.getpid(), signal.SIGABRT)\n" + D.FAKE_OK)
        workers = [worker] + ([self.real] if self.real else [])
        for w in workers:  # the real one with --job-memory-mb 16 (was 500 worker-crashed)
            d = self.daemon(w, ["--job-memory-mb", "16"], data_dir=os.path.join(self.tmp, "data-" + os.path.basename(w)))
            c = Client(d.url)
            job = c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=60)
            self.assertEqual((job["status"], job["error"]["code"], job["error"]["status"]),
                             ("failed", "payload-too-large", 413), (w, job))
            d.stop()

    def test_crashing_input_check_fails_the_job(self):
        # `hocurve info` crashes; the run itself would succeed (and report counts: null).
        worker = D.fake_worker(self.tmp, "info_crash.py", "import os, signal, sys\n"
                               "if sys.argv[1] == 'info':\n    os.kill(os.getpid(), signal.SIGSEGV)\n" + D.FAKE_OK)
        d = self.daemon(worker)
        c = Client(d.url)
        job = c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=30)
        self.assertEqual((job["status"], job["error"]["code"]), ("failed", "worker-crashed"), job)
        self.assertIn("input check", job["error"]["detail"])


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0], "-v"] + sys.argv[2:])
