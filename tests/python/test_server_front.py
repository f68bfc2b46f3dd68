#!/usr/bin/python3
"""hocurved against hostile clients, directly and through the shipped reverse proxy: request heads
sent slowly or in floods, request framing (chunked with Content-Length, unknown transfer codings,
loose chunk syntax), bursts of concurrent submissions.

The proxy checks run docker/nginx.conf (the container's front) with Debian's nginx on loopback; they
are skipped when nginx is not installed. Usage: test_server_front.py BUILD_DIR
"""
import concurrent.futures
import os
import re
import select
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
import unittest
import urllib.request

BUILD_DIR = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.environ.get("HOCURVE_BUILD_DIR", "build"))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "server"))
import daemon as D  # noqa: E402

NGINX = shutil.which("nginx") or ("/usr/sbin/nginx" if os.access("/usr/sbin/nginx", os.X_OK) else None)
TETRA = (b"solid t\n" + b"".join(
    b"facet normal 0 0 0\nouter loop\n%s\nendloop\nendfacet\n" % b"\n".join(b"vertex %s" % v for v in f)
    for f in ([b"0 0 0", b"1 0 0", b"0 1 0"], [b"0 0 0", b"0 0 1", b"1 0 0"],
              [b"0 0 0", b"0 1 0", b"0 0 1"], [b"1 0 0", b"0 0 1", b"0 1 0"])) + b"endsolid t\n")


def rss_mb(pid):
    with open("/proc/%d/status" % pid) as f:
        return int(re.search(r"VmRSS:\s+(\d+)", f.read()).group(1)) / 1024


def status_of(reply):
    m = re.match(rb"HTTP/1\.[01] (\d{3})", reply)
    return int(m.group(1)) if m else None


def read_reply(s, timeout=10):
    """Reads until the peer closes or one answer is whole (by its Content-Length)."""
    s.settimeout(timeout)
    reply = b""
    try:
        while True:
            chunk = s.recv(65536)
            reply += chunk
            top, sep, rest = reply.partition(b"\r\n\r\n")
            m = re.search(rb"(?im)^content-length:\s*(\d+)", top)
            if not chunk or (sep and len(rest) >= (int(m.group(1)) if m else 0)):
                return reply
    except (ConnectionResetError, socket.timeout):
        return reply


class Nginx:
    """docker/nginx.conf on loopback: its listen port and upstream rewritten, files in a temp folder."""

    def __init__(self, upstream_port):
        self.tmp = tempfile.mkdtemp(prefix="hocurve-nginx-")
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            self.port = s.getsockname()[1]
        with open(os.path.join(D.SOURCE_DIR, "docker", "nginx.conf")) as f:
            conf = f.read()
        conf = conf.replace("listen 8080", "listen 127.0.0.1:%d" % self.port)
        conf = conf.replace("server 127.0.0.1:8081", "server 127.0.0.1:%d" % upstream_port)
        conf = conf.replace("/tmp/nginx", self.tmp + "/nginx")
        self.conf = os.path.join(self.tmp, "nginx.conf")
        with open(self.conf, "w") as f:
            f.write(conf)
        self.proc = subprocess.Popen([NGINX, "-e", "stderr", "-p", self.tmp, "-c", self.conf, "-g", "daemon off;"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            try:
                with urllib.request.urlopen("http://127.0.0.1:%d/healthz" % self.port, timeout=2) as r:
                    if r.status == 200:
                        return
            except OSError:
                time.sleep(0.05)
        self.stop()
        raise RuntimeError("nginx did not start: %s" % self.proc.stderr.read().decode(errors="replace"))

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        shutil.rmtree(self.tmp, ignore_errors=True)


class Direct(unittest.TestCase):
    """Every check against hocurved itself; the subclass repeats them through nginx."""
    proxied = False

    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="hocurved-front-")
        self.addCleanup(shutil.rmtree, self.tmp, True)
        worker = D.fake_worker(self.tmp, "fake_ok.py", D.FAKE_OK)
        with open(os.path.join(self.tmp, "token"), "w") as f:
            f.write("s3cret\n")
        self.d = D.Daemon(BUILD_DIR, data_dir=os.path.join(self.tmp, "data"), worker=worker,
                          args=["--token-file", os.path.join(self.tmp, "token"), "--client-timeout", "3"],
                          env={"FAKE_SLEEP": "0.2"})
        self.d.start()
        self.addCleanup(self.d.stop)
        self.port = self.d.port
        if self.proxied:
            front = Nginx(self.d.port)
            self.addCleanup(front.stop)
            self.port = front.port

    def connect(self, timeout=10):
        return socket.create_connection(("127.0.0.1", self.port), timeout=timeout)

    def request(self, data, timeout=10):
        with self.connect(timeout) as s:
            s.sendall(data)
            return read_reply(s, timeout)

    def healthz_seconds(self):
        t = time.monotonic()
        with urllib.request.urlopen("http://127.0.0.1:%d/healthz" % self.port, timeout=5) as r:
            self.assertEqual(r.status, 200)
        return time.monotonic() - t

    def test_healthz_answers_while_500_slow_heads_are_held(self):
        held = []
        try:
            for i in range(500):
                s = self.connect()
                s.sendall(b"GET /v1/jobs HTTP/1.1\r\nHost: x\r\n")
                held.append(s)
            worst = 0.0
            for round_ in range(4):  # one more header line on every connection each round
                for s in held:
                    s.sendall(b"X-Slow-%d: 1\r\n" % round_)
                worst = max(worst, self.healthz_seconds())
                time.sleep(0.25)
            self.assertLess(worst, 1.0)
            print("\n  /healthz with 500 slow heads held: worst %.3f s" % worst, file=sys.stderr)
        finally:
            for s in held:
                s.close()
        # A head still incomplete after --client-timeout (3 s here) is answered 408 and closed
        # (nginx, in front, closes it silently after its client_header_timeout).
        with self.connect() as s:
            s.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
            t = time.monotonic()
            reply = read_reply(s, 20)
            waited = time.monotonic() - t
        self.assertLess(waited, 15)
        if not self.proxied:
            self.assertEqual(status_of(reply), 408, reply[:200])
            self.assertIn(b"Connection: close", reply)

    def test_healthz_answers_while_uploads_hold_every_thread(self):
        if self.proxied:
            return  # nginx buffers bodies: slow uploads never reach hocurved
        d = D.Daemon(BUILD_DIR, data_dir=os.path.join(self.tmp, "data4"), worker=self.d.worker,
                     args=["--http-threads", "4", "--client-timeout", "3"])
        d.start()
        self.addCleanup(d.stop)
        held = []
        try:
            for _ in range(8):
                s = socket.create_connection(("127.0.0.1", d.port), timeout=10)
                s.sendall(b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: model/stl\r\n"
                          b"Content-Length: 1000000\r\n\r\nsolid x\n")
                held.append(s)
            worst = 0.0
            for _ in range(4):
                time.sleep(0.5)
                for s in held:
                    s.sendall(b" ")  # a byte now and then: never silent for --client-timeout
                t = time.monotonic()
                with urllib.request.urlopen(d.url + "/healthz", timeout=5) as r:
                    self.assertEqual(r.status, 200)
                worst = max(worst, time.monotonic() - t)
            self.assertLess(worst, 1.0)
            print("\n  /healthz with 8 slow uploads on 4 threads: worst %.3f s" % worst, file=sys.stderr)
        finally:
            for s in held:
                s.close()

    def test_header_flood_is_refused_before_authentication(self):
        before = rss_mb(self.d.proc.pid)
        line = b"X-Flood: " + b"a" * 5 + b"\r\n"  # 2M such lines over 4 connections: 30 MB

        def flood(_):
            s = self.connect(timeout=20)
            try:
                s.sendall(b"GET /v1/jobs HTTP/1.1\r\nHost: x\r\n")
                block = line * 4096
                for _ in range(2 * 1024 * 1024 // 4 // 4096):
                    if select.select([s], [], [], 0)[0]:
                        break  # answered: stop sending
                    try:
                        s.sendall(block)
                    except (BrokenPipeError, ConnectionResetError):
                        break
                return status_of(read_reply(s, 20))
            finally:
                s.close()

        with concurrent.futures.ThreadPoolExecutor(4) as ex:
            statuses = list(ex.map(flood, range(4)))
        after = rss_mb(self.d.proc.pid)
        print("\n  header flood: statuses %s, hocurved RSS %.1f -> %.1f MB" % (statuses, before, after), file=sys.stderr)
        for st in statuses:
            self.assertIn(st, (431, 400))  # nginx says 400 (Request Header Or Cookie Too Large)
        self.assertLess(after - before, 50)
        self.assertLess(self.healthz_seconds(), 1.0)
        if not self.proxied:  # counted, though refused before routing
            with urllib.request.urlopen("http://127.0.0.1:%d/metrics" % self.port, timeout=5) as r:
                self.assertIn('hocurve_http_requests_total{method="GET",route="other",code="431"} 4', r.read().decode())

    def test_request_framing(self):
        auth = b"Authorization: Bearer s3cret\r\n"
        # Chunked and Content-Length together: refused, and the connection ends (RFC 9112 6.1),
        # so the request smuggled behind it is never answered.
        smuggled = b"GET /v1/info HTTP/1.1\r\nHost: x\r\n" + auth + b"\r\n"
        reply = self.request(b"DELETE /v1/jobs/nosuchjob HTTP/1.1\r\nHost: x\r\n" + auth +
                             b"Transfer-Encoding: chunked\r\nContent-Length: 5\r\n\r\n0\r\n\r\n" + smuggled)
        self.assertEqual(status_of(reply), 400, reply[:300])
        self.assertEqual(reply.count(b"HTTP/1.1 "), 1, reply)
        # A transfer coding other than chunked: 501 alone, 400 with a length (nginx: 501 and 400).
        reply = self.request(b"DELETE /v1/jobs/nosuchjob HTTP/1.1\r\nHost: x\r\n" + auth +
                             b"Transfer-Encoding: gzip\r\n\r\n")
        self.assertIn(status_of(reply), (501, 400), reply[:300])
        reply = self.request(b"DELETE /v1/jobs/nosuchjob HTTP/1.1\r\nHost: x\r\n" + auth +
                             b"Transfer-Encoding: gzip\r\nContent-Length: 5\r\n\r\nhello")
        self.assertIn(status_of(reply), (400, 501), reply[:300])
        # A body the route does not read (GET, a chunked DELETE) ends the connection: read as the
        # next request, it would be one no proxy saw. (A proxy reads it as a body: what follows it
        # is the client's own next request.)
        for head, body in () if self.proxied else ((b"GET /healthz HTTP/1.1\r\nHost: x\r\nContent-Length: %d\r\n\r\n", smuggled),
                           (b"DELETE /v1/jobs/nosuchjob HTTP/1.1\r\nHost: x\r\n" + auth +
                            b"Transfer-Encoding: chunked\r\n\r\n", b"%x\r\n%s\r\n0\r\n\r\n" % (len(smuggled), smuggled))):
            if b"%d" in head:
                head = head % len(body)
            reply = self.request(head + body + smuggled)
            self.assertNotIn(b'"api_version"', reply)  # /v1/info never answered
            self.assertEqual(reply.count(b"HTTP/1.1 "), 1, reply)
        # Strict chunk syntax: well-formed framing reaches the route (404), loose framing is 400.
        good = b"5;ext=1\r\nhello\r\n0\r\n\r\n"  # (cpp-httplib 0.11 refuses trailer fields: 400)
        head = b"PUT /nothing HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n"
        self.assertEqual(status_of(self.request(head + good)), 404)
        for loose in (b"0x5\r\nhello\r\n0\r\n\r\n", b" 5\r\nhello\r\n0\r\n\r\n", b"5\nhello\n0\n\n",
                      b"5\r\nhelloXX0\r\n\r\n", b"-1\r\nhello\r\n0\r\n\r\n", b"+5\r\nhello\r\n0\r\n\r\n"):
            if self.proxied and b"\r" not in loose:
                continue  # nginx takes bare LFs and sends the body on chunked with CRLFs
            reply = self.request(head + loose)
            self.assertEqual(status_of(reply), 400, (loose, reply[:300]))
        # A header line folded onto the next (obs-fold) or a blank before the colon: 400.
        for bad in (b"X-A: 1\r\n  folded\r\n", b"X-A : 1\r\n"):
            reply = self.request(b"GET /healthz HTTP/1.1\r\nHost: x\r\n" + bad + b"\r\n")
            self.assertEqual(status_of(reply), 400, (bad, reply[:300]))

    def test_300_concurrent_submissions_all_answered(self):
        n = 300
        go = threading.Barrier(n)
        head = (b"POST /v1/jobs?order=2 HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer s3cret\r\n"
                b"Content-Type: model/stl\r\nContent-Length: %d\r\n\r\n" % len(TETRA))

        def submit(_):
            try:
                go.wait(30)
                t = time.monotonic()
                s = self.connect(timeout=60)
                connect = time.monotonic() - t
                with s:
                    s.sendall(head + TETRA)
                    reply = read_reply(s, 60)
            except OSError as e:
                return ("error", repr(e), 0.0)
            return (status_of(reply), reply, connect)

        with concurrent.futures.ThreadPoolExecutor(n) as ex:
            results = list(ex.map(submit, range(n)))
        counts = {}
        for st, reply, _ in results:
            counts[st] = counts.get(st, 0) + 1
            self.assertIn(st, (202, 429), reply[:300])
            if st == 429:
                self.assertRegex(reply, rb"(?i)\r\nRetry-After: \d+\r\n")
        slow_connects = sum(1 for _, _, c in results if c > 1.0)
        print("\n  300 concurrent submissions: %s, connects over 1 s: %d" % (counts, slow_connects), file=sys.stderr)
        self.assertEqual(slow_connects, 0)
        ids = {re.search(rb'"id":"([^"]+)"', r).group(1).decode() for st, r, _ in results if st == 202}
        self.assertEqual(len(ids), counts.get(202, 0))
        jobs = set(os.listdir(os.path.join(self.d.data_dir, "jobs")))
        self.assertTrue(ids <= jobs, ids - jobs)  # none lost


@unittest.skipUnless(NGINX, "nginx is not installed (scripts/install-deps.sh installs it)")
class ThroughNginx(Direct):
    proxied = True


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
