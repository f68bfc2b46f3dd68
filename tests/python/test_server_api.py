#!/usr/bin/python3
"""hocurved end-to-end: every endpoint, bad input, idempotency, pagination, auth, and both clients,
against a real daemon on an ephemeral loopback port. Usage: test_server_api.py BUILD_DIR"""
import http.client
import http.server
import json
import os
import re
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import unittest

BUILD_DIR = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.environ.get("HOCURVE_BUILD_DIR", "build"))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "server"))
import daemon as D  # noqa: E402
from hocurve_client import Client, ProblemError  # noqa: E402

SPHERE = os.path.join(D.SHARED_DIR, "meshes", "sphere_surf_gmsh.stl")
TORUS = os.path.join(D.SHARED_DIR, "meshes", "torus.obj")


def data(path):
    with open(path, "rb") as f:
        return f.read()


MESH_SPHERE = data(SPHERE)
MESH_TORUS = data(TORUS)


def raw(url, method, path, body=None, headers=None):
    """One HTTP exchange with http.client (full control over headers); returns (status, headers, body)."""
    host, port = url.split("//")[1].split(":")
    c = http.client.HTTPConnection(host, int(port), timeout=30)
    try:
        c.request(method, path, body=body, headers=headers or {})
        r = c.getresponse()
        return r.status, {k.lower(): v for k, v in r.getheaders()}, r.read()
    finally:
        c.close()


def problem(testcase, resp, status, code):
    st, h, body = resp
    testcase.assertEqual(st, status, body[:300])
    testcase.assertEqual(h.get("content-type"), "application/problem+json")
    p = json.loads(body)
    testcase.assertEqual(p["status"], status)
    testcase.assertEqual(p["code"], code, p)
    testcase.assertTrue(p["type"].endswith("/" + code))
    testcase.assertTrue(p["detail"])
    return p


class CuttingProxy:
    """A loopback proxy in front of the daemon that drops the connection of the first `cuts`
    requests whose request line holds `marker` after `keep` bytes of their answer (a network
    failure mid-download); `edit` may rewrite each request's head. Records every head in `heads`."""

    def __init__(self, url, marker, keep, cuts=1, edit=None):
        self.upstream = ("127.0.0.1", int(url.rsplit(":", 1)[1]))
        self.marker, self.keep, self.cuts, self.edit = marker, keep, cuts, edit
        self.heads = []
        self.lock = threading.Lock()
        self.server = socket.create_server(("127.0.0.1", 0))
        self.url = "http://127.0.0.1:%d" % self.server.getsockname()[1]
        threading.Thread(target=self._accept, daemon=True).start()

    def close(self):
        self.server.close()

    def _accept(self):
        while True:
            try:
                client, _ = self.server.accept()
            except OSError:
                return
            threading.Thread(target=self._serve, args=(client,), daemon=True).start()

    def _serve(self, client):
        """Relays one connection; a request head arrives in one piece on loopback."""
        upstream = socket.create_connection(self.upstream, timeout=30)
        head = client.recv(65536)
        if self.edit:
            head = self.edit(head)
        with self.lock:
            self.heads.append(head)
            cut = self.marker in head.split(b"\r\n", 1)[0] and self.cuts > 0
            self.cuts -= cut
        upstream.sendall(head)
        threading.Thread(target=self._pump, args=(client, upstream, None), daemon=True).start()
        self._pump(upstream, client, self.keep if cut else None)

    @staticmethod
    def _pump(src, dst, limit):
        """Copies src to dst until either ends (or `limit` bytes went through), then closes both."""
        sent = 0
        try:
            while limit is None or sent < limit:
                data = src.recv(65536 if limit is None else min(65536, limit - sent))
                if not data:
                    break
                dst.sendall(data)
                sent += len(data)
        except OSError:
            pass
        for s in (src, dst):
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            s.close()


class ChunkedCut(http.server.BaseHTTPRequestHandler):
    """Answers every POST 200 with a chunked body that ends without its last chunk (a connection
    dropped mid-answer when the length is not announced)."""
    protocol_version = "HTTP/1.1"

    def do_POST(self):
        self.rfile.read(int(self.headers["Content-Length"]))
        self.send_response(200)
        self.send_header("Transfer-Encoding", "chunked")
        self.end_headers()
        self.wfile.write(b"b\r\n$MeshFormat\r\n")
        self.close_connection = True

    def log_message(self, *args):
        pass


def binary_stl(triangles, declared=None):
    data = bytearray(b"binary stl from test".ljust(80, b" "))
    data += struct.pack("<I", len(triangles) if declared is None else declared)
    for t in triangles:
        data += struct.pack("<3f", 0, 0, 1)
        for v in t:
            data += struct.pack("<3f", *v)
        data += b"\0\0"
    return bytes(data)


def schema_errors(value, schema, path=""):
    """The JSON Schema keywords the API documents use for options (type, enum, bounds, properties,
    additionalProperties), checked by hand: Debian's python3 has no jsonschema."""
    errs = []
    t = schema.get("type")
    kinds = {"object": lambda v: isinstance(v, dict), "string": lambda v: isinstance(v, str),
             "boolean": lambda v: isinstance(v, bool),
             "integer": lambda v: not isinstance(v, bool) and isinstance(v, (int, float)) and float(v).is_integer(),
             "number": lambda v: not isinstance(v, bool) and isinstance(v, (int, float))}
    if t and not any(kinds[k](value) for k in ([t] if isinstance(t, str) else t)):
        return ["%s: %r is not of type %s" % (path, value, t)]
    if "enum" in schema and value not in schema["enum"]:
        errs.append("%s: %r not in %r" % (path, value, schema["enum"]))
    if "minimum" in schema and value < schema["minimum"]:
        errs.append("%s: %r < minimum %r" % (path, value, schema["minimum"]))
    if "maximum" in schema and value > schema["maximum"]:
        errs.append("%s: %r > maximum %r" % (path, value, schema["maximum"]))
    if "exclusiveMinimum" in schema and value <= schema["exclusiveMinimum"]:
        errs.append("%s: %r <= exclusiveMinimum %r" % (path, value, schema["exclusiveMinimum"]))
    if isinstance(value, dict):
        props = schema.get("properties", {})
        for k, v in value.items():
            if k in props:
                errs += schema_errors(v, props[k], path + "/" + k)
            elif schema.get("additionalProperties") is False:
                errs.append("%s: additional property %r" % (path, k))
    return errs


def multipart(mesh, options):
    """A multipart/form-data body with the parts `mesh` and `options` (raw bytes of the JSON part)."""
    return (b"--XyZ\r\nContent-Disposition: form-data; name=\"mesh\"; filename=\"s.stl\"\r\n\r\n" + mesh +
            b"\r\n--XyZ\r\nContent-Disposition: form-data; name=\"options\"\r\n"
            b"Content-Type: application/json\r\n\r\n" + options + b"\r\n--XyZ--\r\n")


class ServerApi(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="hocurved-api-")
        cls.real = D.real_worker(BUILD_DIR)
        cls.worker = cls.real or D.fake_worker(cls.tmp, "fake_ok.py", D.FAKE_OK)
        if not cls.real:
            print("NOTE: %s/hocurve not built: using a fake worker" % BUILD_DIR, file=sys.stderr)
        cls.d = D.Daemon(BUILD_DIR, worker=cls.worker, args=["--workers", "2", "--max-upload-mb", "1"]).start()
        cls.c = Client(cls.d.url, timeout=30)

    @classmethod
    def tearDownClass(cls):
        rc = cls.d.stop()
        assert rc == 0, rc
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def submit_wait(self, mesh=SPHERE, options=None, **kw):
        job = self.c.submit(mesh, options or {"order": 2}, **kw)
        return self.c.wait(job["id"], timeout=60)

    # -- probes and documents -------------------------------------------------------------
    def test_health_ready_info(self):
        st, h, body = raw(self.d.url, "GET", "/healthz")
        self.assertEqual(st, 200)
        self.assertRegex(h["x-request-id"], r"^[0-9a-f]{16}$")
        st, h, _ = raw(self.d.url, "GET", "/readyz", headers={"X-Request-Id": "abc-123"})
        self.assertEqual((st, h["x-request-id"]), (200, "abc-123"))
        info = self.c.info()
        self.assertEqual(info["orders"], [2, 3, 4, 5, 6])
        self.assertEqual(info["limits"]["max_upload_bytes"], 1 << 20)
        self.assertIn("msh41", info["output_formats"])

    def test_openapi_document(self):
        doc = json.loads(raw(self.d.url, "GET", "/v1/openapi.json")[2])
        self.assertTrue(doc["openapi"].startswith("3.1"))
        for path in ["/v1/jobs", "/v1/jobs/{id}", "/v1/jobs/{id}/result", "/v1/jobs/{id}/stats", "/v1/curve",
                     "/v1/info", "/healthz", "/readyz", "/metrics", "/v1/openapi.json"]:
            self.assertIn(path, doc["paths"])
        # Every problem type the server can emit is documented.
        src = open(os.path.join(D.SOURCE_DIR, "server", "problem.cpp")).read()
        slugs = set(re.findall(r'\{"([a-z-]+)", "', src))
        text = json.dumps(doc)
        for slug in slugs:
            self.assertIn(slug, text, "problem type %s not in openapi.yaml" % slug)

    def test_openapi_job_options_match_the_server(self):
        served = json.loads(raw(self.d.url, "GET", "/v1/openapi.json")[2])
        with open(os.path.join(D.SOURCE_DIR, "api", "openapi.yaml")) as f:
            self.assertEqual(served, json.load(f))  # the file is served as it is
        schema = served["components"]["schemas"]["JobOptions"]
        # The job options of the registry (cli/option_registry.cpp, which the server validates with) =
        # the schema's = each upload's query parameters.
        known = set(schema["properties"])
        if self.real:  # else (a fake worker) there is no registry to ask
            registry = json.loads(subprocess.run([self.real, "options", "--json"], capture_output=True, check=True).stdout)
            self.assertEqual({o["key"] for o in registry if o["modes"]}, known)
        with open(os.path.join(D.SOURCE_DIR, "api", "schemas", "JobOptions.json")) as f:
            standalone = json.load(f)
        self.assertEqual({k: v for k, v in standalone.items() if not k.startswith("$")}, schema)
        for path in ("/v1/jobs", "/v1/curve"):
            params = {p["name"]: p for p in served["paths"][path]["post"]["parameters"] if p["in"] == "query"}
            self.assertEqual(set(params), known, path)
            for name, p in params.items():
                prop = schema["properties"][name]
                self.assertEqual(p.get("description"), prop.get("description"), name)
                if prop["type"] == "boolean":  # query text: exactly the enum
                    self.assertEqual(p["schema"]["enum"], ["0", "1", "true", "false"], name)
                    self.assertEqual(p["schema"]["default"], "1" if prop["default"] else "0", name)
                else:
                    self.assertEqual(p["schema"], {k: v for k, v in prop.items() if k != "description"}, name)
        # Every bound of the schema is the server's: at a bound accepted (an empty body is then refused
        # as invalid-mesh, after the options), past it refused with the option's pointer.
        context = {"curve only": "", "coarsen only": "mode=coarsen&faces=100&"}
        for name, prop in schema["properties"].items():
            desc = prop.get("description", "")
            pre = next((q for k, q in context.items() if desc.startswith(k)), "")
            if name in ("faces", "ratio"):
                pre = "mode=coarsen&"
            if name == "max_faces":
                pre += "tolerance=0.01&"
            integer = prop["type"] == "integer"
            probes = []  # (value, accepted)
            if "minimum" in prop:
                probes += [(prop["minimum"], True), (prop["minimum"] - (1 if integer else 1e-3), False)]
            if "exclusiveMinimum" in prop:
                probes += [(prop["exclusiveMinimum"], False)]
            if "maximum" in prop:
                probes += [(prop["maximum"], True), (prop["maximum"] + 1 if integer else prop["maximum"] * 1.001, False)]
            elif prop["type"] in ("integer", "number"):
                probes.append((10 ** 15, True))  # no documented upper bound
            for value, ok in probes:
                text = str(int(value)) if integer else repr(float(value))
                st, _, body = self.post("/v1/jobs?%s%s=%s" % (pre, name, text), b"")
                if ok:
                    self.assertEqual(st, 422, "%s=%s: %s" % (name, text, body[:300]))
                else:
                    p = problem(self, (st, _, body), 400, "invalid-options")
                    self.assertIn("/options/" + name, [e["pointer"] for e in p["errors"]], text)
        # Defaults the server fills in are the documented ones, and every job's options validate.
        self.submit_wait(options={"order": 2, "weld_tolerance": 1e-7, "min_jacobian": 0.02})
        jobs = json.loads(raw(self.d.url, "GET", "/v1/jobs?page_size=500")[2])["jobs"]
        self.assertTrue(jobs)
        for j in jobs:
            self.assertEqual(schema_errors(j["options"], schema, "/options"), [], j["options"])
        job = self.c.submit(SPHERE, {})
        self.c.cancel(job["id"])
        for k, v in job["options"].items():
            self.assertEqual(schema["properties"][k]["default"], v, k)

    def test_metrics_text_format(self):
        self.submit_wait()
        st, h, body = raw(self.d.url, "GET", "/metrics")
        self.assertEqual(st, 200)
        self.assertTrue(h["content-type"].startswith("text/plain; version=0.0.4"))
        text = body.decode()
        self.assertTrue(text.endswith("\n"))
        declared = {}
        for line in text.splitlines():
            m = re.match(r"# TYPE (\S+) (counter|gauge|histogram)$", line)
            if m:
                declared[m.group(1)] = m.group(2)
                continue
            if line.startswith("# HELP"):
                continue
            m = re.match(r'^([a-zA-Z_:][a-zA-Z0-9_:]*)(\{(?:[a-z_]+="(?:[^"\\]|\\.)*",?)*\})? (\S+)$', line)
            self.assertTrue(m, "bad sample line: %r" % line)
            name = m.group(1)
            base = re.sub(r"_(bucket|sum|count)$", "", name)
            self.assertTrue(name in declared or base in declared, "no TYPE for %s" % name)
            float(m.group(3).replace("+Inf", "inf"))
        self.assertRegex(text, r'hocurve_jobs_finished_total\{state="succeeded"\} [1-9]')
        self.assertRegex(text, r'hocurve_upload_bytes_total [1-9]')
        buckets = [float(x) for x in re.findall(r'hocurve_job_duration_seconds_bucket\{le="[^"]+"\} (\d+)', text)]
        self.assertEqual(buckets, sorted(buckets))  # cumulative
        self.assertRegex(text, r'hocurve_http_requests_total\{method="POST",route="/v1/jobs",code="202"\} [1-9]')

    # -- the happy path --------------------------------------------------------------------
    def test_submit_poll_download_stats(self):
        st, h, body = raw(self.d.url, "POST", "/v1/jobs?order=3&nodes=equispaced", MESH_SPHERE,
                          {"Content-Type": "application/octet-stream"})
        self.assertEqual(st, 202, body)
        job = json.loads(body)
        self.assertEqual(h["location"], "/v1/jobs/" + job["id"])
        self.assertIn("retry-after", h)
        self.assertEqual(job["status"], "queued")
        self.assertEqual(job["options"], {"mode": "curve", "order": 3, "nodes": "equispaced", "format": "msh41",
                                          "binary": False})
        self.assertEqual(job["input"]["format"], "stl-ascii")
        self.assertEqual(job["input"]["bytes"], os.path.getsize(SPHERE))
        done = self.c.wait(job["id"], timeout=60)
        self.assertEqual(done["status"], "succeeded", done["error"])
        self.assertTrue(done["done"])
        self.assertEqual(done["progress"]["fraction"], 1.0)
        for k in ("created", "started", "finished"):
            self.assertRegex(done[k], r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z$")
        self.assertLessEqual(done["created"], done["started"])
        self.assertLessEqual(done["started"], done["finished"])
        st, h, msh = raw(self.d.url, "GET", "/v1/jobs/%s/result" % job["id"])
        self.assertEqual(st, 200)
        self.assertIn('filename="%s.msh"' % job["id"], h["content-disposition"])
        self.assertEqual(int(h["content-length"]), len(msh))
        self.assertEqual(done["result"]["bytes"], len(msh))
        self.assertTrue(msh.startswith(b"$MeshFormat\n4.1"))
        stats = self.c.stats(job["id"])
        self.assertEqual(stats, done["stats"])
        if self.real:
            self.check_msh_order(msh, 3)
            # Input counts (from `hocurve info`) against the independent MANIFEST.tsv.
            with open(os.path.join(D.SHARED_DIR, "meshes", "MANIFEST.tsv")) as f:
                rows = [l.rstrip("\n").split("\t") for l in f]
            col = rows[0].index("triangles")
            triangles = int([r for r in rows if r[0] == "sphere_surf_gmsh.stl"][0][col])
            self.assertEqual(done["input"]["counts"]["faces"], triangles)
            self.assertEqual(done["input"]["counts"]["euler_characteristic"], 2)

    def check_msh_order(self, msh, order):
        """Independent read-back with Gmsh's Python API: triangles of the requested order only."""
        path = os.path.join(self.tmp, "readback.msh")
        with open(path, "wb") as f:
            f.write(msh)
        code = ("import gmsh,sys\ngmsh.initialize(); gmsh.option.setNumber('General.Terminal',0)\n"
                "gmsh.open(sys.argv[1]); t,_,_=gmsh.model.mesh.getElements(2)\n"
                "print(sorted(set(gmsh.model.mesh.getElementProperties(x)[2] for x in t)))\n")
        out = subprocess.run(["/usr/bin/python3", "-c", code, path], capture_output=True, text=True, timeout=60)
        self.assertEqual(out.stdout.strip(), "[%d]" % order, out.stderr)

    def test_multipart_submission_like_curl_F(self):
        job = self.c.submit(TORUS, {"order": 2, "format": "msh22"}, multipart=True)
        self.assertEqual(job["input"]["client_filename"], "torus.obj")
        self.assertEqual(job["input"]["format"], "obj")
        self.assertEqual(job["options"]["format"], "msh22")
        done = self.c.wait(job["id"], timeout=60)
        self.assertEqual(done["status"], "succeeded", done["error"])
        msh = raw(self.d.url, "GET", "/v1/jobs/%s/result" % job["id"])[2]
        self.assertTrue(msh.startswith(b"$MeshFormat\n2.2"))

    def test_sync_curve(self):
        st, h, body = raw(self.d.url, "POST", "/v1/curve?order=2", MESH_SPHERE,
                          {"Content-Type": "model/stl"})
        self.assertEqual(st, 200, body[:300])
        self.assertIn("attachment", h["content-disposition"])
        self.assertTrue(body.startswith(b"$MeshFormat"))
        # The daemon's defaults are the CLI's: with no options, the same bytes as `hocurve curve` (P4,
        # equispaced nodes where Gmsh reads them; the daemon once gave P3 on Lobatto nodes).
        st, h, body = raw(self.d.url, "POST", "/v1/curve", MESH_SPHERE, {"Content-Type": "model/stl"})
        self.assertEqual(st, 200, body[:300])
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "cli.msh")
            subprocess.run([os.path.join(BUILD_DIR, "hocurve"), "curve", SPHERE, "-o", out], check=True)
            self.assertEqual(body, data(out))
        # Sync jobs are not listed and are gone afterwards.
        self.assertNotIn(h["x-job-id"], [j["id"] for j in self.c.list()])
        problem(self, raw(self.d.url, "GET", "/v1/jobs/" + h["x-job-id"]), 404, "not-found")
        problem(self, raw(self.d.url, "POST", "/v1/curve", os.urandom(3000), {"Content-Type": "application/octet-stream"}),
                415, "unsupported-media-type")

    # -- idempotency and pagination -------------------------------------------------------------
    def test_idempotency_key(self):
        key = "key-" + os.urandom(6).hex()
        a = self.c.submit(SPHERE, {"order": 2}, idempotency_key=key)
        st, h, body = raw(self.d.url, "POST", "/v1/jobs?order=2", MESH_SPHERE,
                          {"Content-Type": "application/octet-stream", "Idempotency-Key": key})
        self.assertEqual(st, 202)
        self.assertEqual(json.loads(body)["id"], a["id"])
        self.assertEqual(h.get("idempotent-replayed"), "true")
        p = problem(self, raw(self.d.url, "POST", "/v1/jobs?order=3", MESH_SPHERE,
                              {"Content-Type": "application/octet-stream", "Idempotency-Key": key}),
                    422, "idempotency-key-reused")
        self.assertIn(a["id"], p["detail"])
        problem(self, raw(self.d.url, "POST", "/v1/jobs?order=2", MESH_TORUS,
                          {"Content-Type": "application/octet-stream", "Idempotency-Key": key}),
                422, "idempotency-key-reused")

    def test_pagination(self):
        ids = {self.c.submit(SPHERE, {"order": 2}, retries=20)["id"] for _ in range(5)}
        seen, token, pages = [], "", 0
        while pages < 100:
            q = "/v1/jobs?page_size=2" + ("&page_token=" + token if token else "")
            page = json.loads(raw(self.d.url, "GET", q)[2])
            self.assertLessEqual(len(page["jobs"]), 2)
            seen += [j["id"] for j in page["jobs"]]
            pages += 1
            token = page["next_page_token"]
            if not token:
                break
        self.assertEqual(len(seen), len(set(seen)))
        self.assertTrue(ids <= set(seen))
        self.assertEqual(seen, sorted(seen, reverse=True))  # newest first
        all_jobs = json.loads(raw(self.d.url, "GET", "/v1/jobs?page_size=100000")[2])
        self.assertEqual([j["id"] for j in all_jobs["jobs"]], seen)  # coerced to the maximum, not rejected
        problem(self, raw(self.d.url, "GET", "/v1/jobs?page_token=zzz"), 400, "invalid-page-token")
        problem(self, raw(self.d.url, "GET", "/v1/jobs?page_size=-1"), 400, "invalid-request")
        problem(self, raw(self.d.url, "GET", "/v1/jobs?state=x"), 400, "invalid-request")
        if len(seen) > 2:  # a token only works with the filter that produced it
            tok = json.loads(raw(self.d.url, "GET", "/v1/jobs?page_size=1")[2])["next_page_token"]
            problem(self, raw(self.d.url, "GET", "/v1/jobs?status=failed&page_token=" + tok), 400, "invalid-page-token")

    # -- bad input --------------------------------------------------------------------------------
    def post(self, path, body, ctype="application/octet-stream", headers=None):
        h = {"Content-Type": ctype}
        h.update(headers or {})
        return raw(self.d.url, "POST", path, body, h)

    def test_bad_options(self):
        mesh = MESH_SPHERE
        for q, key in [("order=0", "order"), ("order=99", "order"), ("order=abc", "order"), ("mode=melt", "mode"),
                       ("foo=1", "foo"), ("nodes=gauss", "nodes"), ("format=vtk", "format"), ("binary=maybe", "binary"),
                       ("mode=coarsen", "faces"), ("mode=coarsen&faces=10&ratio=0.1", "ratio"),
                       ("mode=coarsen&ratio=1.5", "ratio"), ("faces=100", "faces"), ("order=3&order=4", "order")]:
            p = problem(self, self.post("/v1/jobs?" + q, mesh), 400, "invalid-options")
            self.assertIn("/options/" + key, [e["pointer"] for e in p["errors"]], q)
        # Multipart: invalid JSON, non-object JSON, unknown key, unexpected part.
        for opts, code in [(b"{order: 3", "invalid-json"), (b"[1,2]", "invalid-options"),
                           (b'{"order": 3, "smooth": true}', "invalid-options")]:
            body = (b"--XyZ\r\nContent-Disposition: form-data; name=\"mesh\"; filename=\"s.stl\"\r\n\r\n" + mesh +
                    b"\r\n--XyZ\r\nContent-Disposition: form-data; name=\"options\"\r\n\r\n" + opts + b"\r\n--XyZ--\r\n")
            problem(self, self.post("/v1/jobs", body, "multipart/form-data; boundary=XyZ"), 400, code)
        body = b"--XyZ\r\nContent-Disposition: form-data; name=\"other\"\r\n\r\nx\r\n--XyZ--\r\n"
        problem(self, self.post("/v1/jobs", body, "multipart/form-data; boundary=XyZ"), 400, "invalid-request")

    def test_option_types(self):
        # Query booleans: exactly the spec's enum 0/1/true/false.
        for v in ("0", "1", "true", "false"):
            self.assertEqual(self.post("/v1/jobs?binary=%s&tangent_junctions=%s" % (v, v), b"")[0], 422, v)
        for v in ("yes", "no", "TRUE", "False", "", "2", "on"):
            for key in ("binary", "tangent_junctions"):
                p = problem(self, self.post("/v1/jobs?%s=%s" % (key, v), b""), 400, "invalid-options")
                self.assertEqual([e["pointer"] for e in p["errors"]], ["/options/" + key], v)
        # Multipart options are JSON: JSON numbers and booleans, never strings standing for them.
        empty = b""  # refused after the options (422 invalid-mesh): options accepted
        for opts in (b'{"order": 3, "binary": true, "tangent_junctions": false, "feature_angle": 40}',
                     b'{"order": 3.0, "weld_tolerance": 0, "min_jacobian": 0.05, "long_edge_ratio": 2}',
                     b'{"mode": "coarsen", "faces": 100, "redecimate": 2, "max_deviation": 0.01}'):
            st, _, body = self.post("/v1/jobs", multipart(empty, opts), "multipart/form-data; boundary=XyZ")
            self.assertEqual(st, 422, opts + b" " + body[:300])
        for opts, keys in [(b'{"order": "3"}', ["order"]), (b'{"binary": "1"}', ["binary"]),
                           (b'{"binary": 1}', ["binary"]), (b'{"tangent_junctions": "false"}', ["tangent_junctions"]),
                           (b'{"feature_angle": "40", "weld_tolerance": "0"}', ["feature_angle", "weld_tolerance"]),
                           (b'{"mode": "coarsen", "faces": "100"}', ["faces"]),
                           (b'{"mode": "coarsen", "ratio": "0.5", "redecimate": "2"}', ["ratio", "redecimate"]),
                           (b'{"order": true}', ["order"]), (b'{"format": 41}', ["format"])]:
            p = problem(self, self.post("/v1/jobs", multipart(MESH_SPHERE, opts), "multipart/form-data; boundary=XyZ"),
                        400, "invalid-options")
            self.assertEqual(sorted(e["pointer"] for e in p["errors"]), ["/options/" + k for k in keys], opts)
        # Query text and JSON together: each read by its own rules.
        st, _, body = self.post("/v1/jobs?order=3&binary=1", multipart(empty, b'{"tangent_junctions": false}'),
                                "multipart/form-data; boundary=XyZ")
        self.assertEqual(st, 422, body[:300])
        p = problem(self, self.post("/v1/jobs?binary=1", multipart(MESH_SPHERE, b'{"order": "3"}'),
                                    "multipart/form-data; boundary=XyZ"), 400, "invalid-options")
        self.assertEqual([e["pointer"] for e in p["errors"]], ["/options/order"])

    def test_bad_bodies(self):
        problem(self, self.post("/v1/jobs", os.urandom(5000)), 415, "unsupported-media-type")  # garbage
        problem(self, self.post("/v1/jobs", b""), 422, "invalid-mesh")
        problem(self, self.post("/v1/jobs", b'{"mesh": 1}', "application/json"), 415, "unsupported-media-type")
        problem(self, self.post("/v1/jobs", MESH_SPHERE, "application/x-www-form-urlencoded"), 415,
                "unsupported-media-type")
        tri = [((0, 0, 0), (1, 0, 0), (0, 1, 0))] * 10
        p = problem(self, self.post("/v1/jobs", binary_stl(tri, declared=1000)), 422, "invalid-mesh")  # lying count
        self.assertIn("1000 facets", p["detail"])
        good = binary_stl(tri)
        problem(self, self.post("/v1/jobs", good[:-30], headers={}), 422, "invalid-mesh")  # truncated binary STL
        p = problem(self, self.post("/v1/jobs", b"\0" * (2 << 20)), 413, "payload-too-large")
        self.assertEqual(p["limit_bytes"], 1 << 20)
        # Truncated ASCII STL is accepted, then refused by the worker: failed job, error invalid-mesh.
        if self.real:
            text = MESH_SPHERE
            job = json.loads(self.post("/v1/jobs?order=2", text[: len(text) // 2])[2])
            done = self.c.wait(job["id"], timeout=60)
            self.assertEqual(done["status"], "failed")
            self.assertEqual(done["error"]["code"], "invalid-mesh")
            self.assertTrue(done["error"]["detail"])
            self.assertNotIn(self.d.data_dir, done["error"]["detail"])  # server paths stay private
            problem(self, raw(self.d.url, "GET", "/v1/jobs/%s/result" % job["id"]), 409, "job-state-conflict")

    def test_chunked_body_needs_length(self):
        host, port = self.d.url.split("//")[1].split(":")
        c = http.client.HTTPConnection(host, int(port), timeout=30)
        c.request("POST", "/v1/jobs", body=iter([MESH_SPHERE[:2000], MESH_SPHERE[2000:4000]]),
                  headers={"Content-Type": "application/octet-stream"}, encode_chunked=True)
        r = c.getresponse()
        body = r.read()
        c.close()
        self.assertIn(r.status, (411,), body)
        self.assertEqual(json.loads(body)["code"], "length-required")

    def raw_socket(self, request, timeout=10):
        """Sends `request` bytes as they are (no header fixing by http.client); returns the answer bytes."""
        import socket
        host, port = self.d.url.split("//")[1].split(":")
        with socket.create_connection((host, int(port)), timeout=timeout) as s:
            s.sendall(request)
            out = b""
            while b"\r\n\r\n" not in out or len(out) < out.find(b"\r\n\r\n") + 4 + int(
                    (re.search(rb"Content-Length: (\d+)", out) or [0, b"0"])[1]):
                chunk = s.recv(65536)
                if not chunk:
                    break
                out += chunk
            return out

    def test_methods_lengths_and_ranges(self):
        # A path that exists, not with this method: 405 naming the allowed ones; OPTIONS lists them.
        problem(self, raw(self.d.url, "DELETE", "/v1/info"), 405, "method-not-allowed")
        st, h, _ = raw(self.d.url, "PUT", "/v1/jobs/abc", body=b"")
        self.assertEqual((st, h.get("allow")), (405, "GET, HEAD, DELETE, OPTIONS"))
        st, h, body = raw(self.d.url, "OPTIONS", "/v1/jobs")
        self.assertEqual((st, h.get("allow"), body), (204, "GET, HEAD, POST, OPTIONS", b""))
        # A body without a length is refused at once: the HTTP library would wait for the client to close.
        t0 = time.monotonic()
        out = self.raw_socket(b"PUT /v1/elsewhere HTTP/1.1\r\nHost: x\r\n\r\n")
        self.assertLess(time.monotonic() - t0, 5)
        self.assertIn(b" 411 ", out.split(b"\r\n")[0])
        # Unparsable requests get their own request id, never the previous request's.
        ids = []
        for _ in range(2):
            out = self.raw_socket(b"FOO / HTTP/1.1\r\nHost: x\r\n\r\n")
            self.assertIn(b" 400 ", out.split(b"\r\n")[0])
            ids.append(json.loads(out.split(b"\r\n\r\n", 1)[1])["request_id"])
        self.assertTrue(ids[0] and ids[1] and ids[0] != ids[1], ids)
        # Method labels of the metrics stay a bounded set.
        self.raw_socket(b"RND1 /healthz HTTP/1.1\r\nHost: x\r\n\r\n")
        metrics = raw(self.d.url, "GET", "/metrics")[2].decode()
        self.assertNotIn('method="RND1"', metrics)

    def test_result_byte_ranges(self):
        # A download can resume: one byte range of a result is served (206), HEAD says so; JSON
        # ignores Range and says "Accept-Ranges: none" (the library said "bytes" on every HEAD).
        done = self.submit_wait()
        path = "/v1/jobs/%s/result" % done["id"]
        full = raw(self.d.url, "GET", path)[2]
        n = len(full)
        st, h, body = raw(self.d.url, "HEAD", path)
        self.assertEqual((st, h.get("accept-ranges"), h.get("content-length"), body), (200, "bytes", str(n), b""))
        etag, modified = h["etag"], h["last-modified"]
        st, h, _ = raw(self.d.url, "HEAD", "/v1/jobs/" + done["id"])
        self.assertEqual((st, h.get("accept-ranges")), (200, "none"))
        st, h, body = raw(self.d.url, "GET", "/v1/jobs/" + done["id"], headers={"Range": "bytes=0-9"})
        self.assertEqual((st, json.loads(body)["id"], h.get("content-range")), (200, done["id"], None))
        for rng, first, last in [("bytes=0-9", 0, 9), ("bytes=%d-" % (n - 100), n - 100, n - 1), ("bytes=-5", n - 5, n - 1),
                                 ("bytes=10-%d" % (10 * n), 10, n - 1)]:
            st, h, body = raw(self.d.url, "GET", path, headers={"Range": rng})
            self.assertEqual((st, h.get("content-range"), body), (206, "bytes %d-%d/%d" % (first, last, n), full[first:last + 1]), rng)
        for rng in ["bytes=%d-" % n, "bytes=99999999-", "bytes=-0"]:
            p = problem(self, raw(self.d.url, "GET", path, headers={"Range": rng}), 416, "range-not-satisfiable")
            self.assertEqual(raw(self.d.url, "GET", path, headers={"Range": rng})[1].get("content-range"), "bytes */%d" % n)
            self.assertIn(str(n), p["detail"])
        # Several ranges, or an If-Range naming another version: the whole result, 200.
        for headers in [{"Range": "bytes=0-1,5-6"}, {"Range": "bytes=0-9", "If-Range": '"other"'},
                        {"Range": "bytes=0-9", "If-Range": "Thu, 01 Jan 1970 00:00:00 GMT"}]:
            st, _, body = raw(self.d.url, "GET", path, headers=headers)
            self.assertEqual((st, body), (200, full), headers)
        for validator in [etag, modified]:
            st, _, body = raw(self.d.url, "GET", path, headers={"Range": "bytes=0-9", "If-Range": validator})
            self.assertEqual((st, body), (206, full[:10]), validator)
        if shutil.which("curl"):  # as a person resumes: curl -C - on a partial file
            out = os.path.join(self.tmp, "resumed.msh")
            with open(out, "wb") as f:
                f.write(full[:n // 3])
            subprocess.run(["curl", "-sSf", "-C", "-", "-o", out, self.d.url + path], check=True, timeout=30)
            self.assertEqual(data(out), full)

    def test_malformed_range_is_ignored(self):
        # RFC 9110 14.2: a Range the server does not understand is ignored, on every route. The HTTP
        # library answered 416 to these before any handler ran, and left a POST's body unread.
        done = self.submit_wait()
        path = "/v1/jobs/%s/result" % done["id"]
        full = raw(self.d.url, "GET", path)[2]
        for rng in ["bytes=abc", "items=0-5", "bytes=5-2", "bytes=0-1-2", "bytes=99999999999999999999999-"]:
            st, h, body = raw(self.d.url, "GET", path, headers={"Range": rng})
            self.assertEqual((st, h.get("content-range"), body == full), (200, None, True), rng)
            st, _, body = raw(self.d.url, "GET", "/v1/jobs/" + done["id"], headers={"Range": rng})
            self.assertEqual((st, json.loads(body)["id"]), (200, done["id"]), rng)
            st, _, body = raw(self.d.url, "POST", "/v1/jobs?order=2", MESH_SPHERE,
                              {"Content-Type": "application/octet-stream", "Range": rng})
            self.assertEqual(st, 202, body)
        # A valid range the library could not parse is served; one past the end still gets 416.
        st, h, body = raw(self.d.url, "GET", path, headers={"Range": "BYTES=0-9"})
        self.assertEqual((st, body), (206, full[:10]))
        st, h, _ = raw(self.d.url, "GET", path, headers={"Range": "bytes=%d-" % len(full)})
        self.assertEqual((st, h.get("content-range")), (416, "bytes */%d" % len(full)))

    def test_pipelined_requests_all_answered_in_order(self):
        # Requests written at once on one connection: each answered, in order (cpp-httplib dropped
        # what it had read past the first one). Past the keep-alive count (5) the last answer says
        # Connection: close and the connection ends at once: the client resends the rest.
        import socket
        host, port = self.d.url.split("//")[1].split(":")

        def pipeline(paths):
            reqs = b"".join(b"GET %s HTTP/1.1\r\nHost: x\r\nX-Request-Id: abc-%d\r\n\r\n" % (p.encode(), i)
                            for i, p in enumerate(paths))
            answers, out = [], b""
            with socket.create_connection((host, int(port)), timeout=5) as s:
                s.sendall(reqs)
                t0 = time.monotonic()
                while len(answers) < len(paths):
                    head, sep, rest = out.partition(b"\r\n\r\n")
                    length = re.search(rb"(?i)content-length: (\d+)", head) if sep else None
                    if length and len(rest) >= int(length[1]):
                        answers.append((head, rest[:int(length[1])]))
                        out = rest[int(length[1]):]
                        continue
                    chunk = s.recv(65536)
                    if not chunk:
                        break
                    out += chunk
                tail = s.recv(100) if answers and b"Connection: close" in answers[-1][0] else b""
                return answers, tail, time.monotonic() - t0

        answers, _, seconds = pipeline(["/healthz", "/v1/info", "/readyz"])
        self.assertEqual(len(answers), 3)
        self.assertLess(seconds, 1)
        for i, (head, body) in enumerate(answers):
            self.assertTrue(head.startswith(b"HTTP/1.1 200 "), head)
            self.assertIn(b"X-Request-Id: abc-%d\r\n" % i, head + b"\r\n")
        self.assertEqual(json.loads(answers[0][1]), {"status": "ok"})
        self.assertEqual(json.loads(answers[1][1])["name"], "hocurved")
        self.assertEqual(json.loads(answers[2][1])["status"], "ready")
        answers, tail, seconds = pipeline(["/healthz"] * 7)
        self.assertEqual(len(answers), 5)
        self.assertIn(b"Connection: close", answers[4][0])
        self.assertEqual(tail, b"")  # closed, not left waiting
        self.assertLess(seconds, 1)

    def test_one_daemon_per_data_directory_and_port(self):
        # A second daemon on the same data directory would rerun the first one's jobs; on the same
        # port it would take half its connections. Both refuse to start.
        for args in (["--port", "0", "--data-dir", self.d.data_dir],
                     ["--port", str(self.d.port), "--data-dir", os.path.join(self.tmp, "other-data")]):
            r = subprocess.run([os.path.join(BUILD_DIR, "hocurved"), "--host", "127.0.0.1"] + args,
                               capture_output=True, timeout=20)
            self.assertEqual(r.returncode, 1, r.stdout[-500:])
            self.assertIn(b"another hocurved" if "--port" in args and args[1] == "0" else b"cannot bind", r.stdout)

    def test_paths_and_ids(self):
        for path in ["/v1/jobs/does-not-exist", "/v1/jobs/..%2f..%2fetc%2fpasswd", "/v1/jobs/../../etc/passwd",
                     "/v1/jobs/%2e%2e", "/v1/jobs/a%00b", "/v1/jobs/x/result", "/v1/jobs/x/stats", "/v2/anything",
                     "/v1/jobs/" + "a" * 65]:
            st, h, body = raw(self.d.url, "GET", path)
            self.assertEqual(st, 404, path)
            self.assertEqual(h["content-type"], "application/problem+json", path)
        problem(self, raw(self.d.url, "GET", "/v1/jobs/" + "a" * 300), 414, "uri-too-long")
        problem(self, raw(self.d.url, "DELETE", "/v1/jobs/nope"), 404, "not-found")
        # The data directory is not reachable through ids.
        self.assertNotEqual(raw(self.d.url, "GET", "/v1/jobs/..%2Fstate.json")[0], 200)

    def test_delete_finished_job(self):
        done = self.submit_wait()
        st, _, _ = raw(self.d.url, "DELETE", "/v1/jobs/" + done["id"])
        self.assertEqual(st, 204)
        problem(self, raw(self.d.url, "GET", "/v1/jobs/" + done["id"]), 404, "not-found")
        self.assertFalse(os.path.exists(os.path.join(self.d.data_dir, "jobs", done["id"])))

    # -- clients ---------------------------------------------------------------------------------
    def test_python_cli(self):
        out = os.path.join(self.tmp, "cli.msh")
        cli = os.path.join(D.SOURCE_DIR, "clients", "python", "hocurve_client.py")
        r = subprocess.run(["/usr/bin/python3", cli, "--url", self.d.url, "submit", SPHERE, "--order", "2", "--wait",
                            "-o", out], capture_output=True, text=True, timeout=90)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(json.loads(r.stdout)["status"], "succeeded")
        self.assertIn("100%", r.stderr)  # progress bar
        self.assertTrue(data(out).startswith(b"$MeshFormat"))
        r = subprocess.run(["/usr/bin/python3", cli, "--url", self.d.url, "submit", SPHERE, "--order", "0"],
                           capture_output=True, text=True, timeout=30)
        self.assertEqual(r.returncode, 1)
        self.assertIn("order must be an integer", r.stderr)  # the problem's detail is shown
        r = subprocess.run(["/usr/bin/python3", cli, "--url", self.d.url, "status", "nope"],
                           capture_output=True, text=True, timeout=30)
        self.assertEqual(r.returncode, 1)
        self.assertIn("not-found", r.stderr)

    def test_python_download_resumes(self):
        # Two connections dropped mid-download: the client resumes each time (Range + If-Range) and
        # ends with the whole file; an If-Range the server does not match (a changed result) gets
        # 200 and the client starts over.
        done = self.submit_wait()
        full = raw(self.d.url, "GET", "/v1/jobs/%s/result" % done["id"])[2]
        out = os.path.join(self.tmp, "resumed-py.msh")
        proxy = CuttingProxy(self.d.url, b"/result", keep=len(full) // 3, cuts=2)
        try:
            self.assertEqual(Client(proxy.url, timeout=30).download(done["id"], out), len(full))
        finally:
            proxy.close()
        self.assertEqual(data(out), full)
        self.assertFalse(os.path.exists(out + ".part"))
        ranges = [re.search(rb"\r\nRange: bytes=(\d+)-\r\n", h) for h in proxy.heads]
        self.assertEqual([int(m[1]) if m else None for m in ranges][:1], [None])
        self.assertEqual(len(proxy.heads), 3, proxy.heads)
        self.assertTrue(all(m and 0 < int(m[1]) < len(full) for m in ranges[1:]), proxy.heads)
        self.assertTrue(all(b"\r\nIf-Range: \"" in h for h in proxy.heads[1:]), proxy.heads)
        stale = CuttingProxy(self.d.url, b"/result", keep=len(full) // 3, cuts=1,
                             edit=lambda h: re.sub(rb"If-Range: [^\r]*", b'If-Range: "stale"', h))
        try:
            self.assertEqual(Client(stale.url, timeout=30).download(done["id"], out), len(full))
        finally:
            stale.close()
        self.assertEqual(data(out), full)
        # Every attempt cut: a bounded number of tries, then an error, and no file left behind.
        os.remove(out)
        cutter = CuttingProxy(self.d.url, b"/result", keep=len(full) // 3, cuts=99)
        try:
            with self.assertRaises(ProblemError) as e:
                Client(cutter.url, timeout=30).download(done["id"], out, attempts=3)
        finally:
            cutter.close()
        self.assertIn("after 3 attempts", str(e.exception))
        self.assertFalse(os.path.exists(out) or os.path.exists(out + ".part"))

    def sync_clients(self, url, out):
        """Client.curve(SPHERE, order 2, dest=out) and (if curl is installed) curve_sync.sh against
        `url`: per client, (None, the bytes it wrote at out) or (its error text, None); out and
        out.part are removed after each, and no out.part may be left."""
        def python():
            try:
                Client(url, timeout=30).curve(SPHERE, {"order": 2}, dest=out)
            except ProblemError as e:
                return str(e)

        def curl():
            r = subprocess.run(["bash", os.path.join(D.SOURCE_DIR, "clients", "curl", "curve_sync.sh"), SPHERE, out,
                                "order=2"], capture_output=True, text=True, timeout=60, env=dict(os.environ, HOCURVE_URL=url))
            self.assertIn(r.returncode, (0, 1), r.stderr)
            return r.stderr if r.returncode else None

        results = []
        for run in [python] + ([curl] if shutil.which("curl") else []):
            err = run()
            self.assertFalse(os.path.exists(out + ".part"))
            results.append((err, None if err else data(out)))
            if os.path.exists(out):
                os.remove(out)
        return results

    def test_sync_clients_refuse_a_cut_answer(self):
        # POST /v1/curve is not resumed: an answer cut short (fewer bytes than its Content-Length, or
        # a chunked one without its last chunk) is an error naming the counts, and nothing is saved.
        full = raw(self.d.url, "POST", "/v1/curve?order=2", MESH_SPHERE, {"Content-Type": "model/stl"})[2]
        out = os.path.join(self.tmp, "sync.msh")
        whole = self.sync_clients(self.d.url, out)
        self.assertEqual(whole, [(None, full)] * len(whole))
        proxy = CuttingProxy(self.d.url, b"/v1/curve", keep=len(full) // 3, cuts=3)
        try:
            cut = self.sync_clients(proxy.url, out)
            with self.assertRaises(ProblemError) as e:  # the bytes-returning form too
                Client(proxy.url, timeout=30).curve(SPHERE, {"order": 2})
        finally:
            proxy.close()
        self.assertRegex(str(e.exception), r"the answer ended early \(short read: \d+ of %d bytes\); a POST" % len(full))
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), ChunkedCut)
        threading.Thread(target=server.serve_forever, daemon=True).start()
        try:
            chunked = self.sync_clients("http://127.0.0.1:%d" % server.server_address[1], out)
        finally:
            server.shutdown()
            server.server_close()
        for (err, got), length in [(c, " of %d" % len(full)) for c in cut] + [(c, "") for c in chunked]:
            self.assertIsNone(got, err)
            self.assertRegex(err, r"POST http://127\.0\.0\.1:\d+/v1/curve\?order=2: the answer ended early \([^)]*\b\d+%s "
                                  r"bytes\); %s not written; a POST is not resumed: retry, or use the job API" %
                             (length, re.escape(out)))

    def test_python_cli_local_errors(self):
        # A missing mesh, an output in a missing directory or under a file: one `error:` line, exit 1.
        cli = os.path.join(D.SOURCE_DIR, "clients", "python", "hocurve_client.py")
        blocker = os.path.join(self.tmp, "a-file")
        with open(blocker, "w") as f:
            f.write("x")
        done = self.submit_wait()
        for args in (["submit", os.path.join(self.tmp, "missing.stl"), "--order", "2"],
                     ["submit", SPHERE, "--order", "2", "--wait", "-o", os.path.join(self.tmp, "no", "dir", "o.msh")],
                     ["submit", SPHERE, "--order", "2", "--wait", "-o", os.path.join(blocker, "o.msh")],
                     ["download", done["id"], "-o", os.path.join(self.tmp, "no", "dir", "o.msh")],
                     ["download", done["id"], "-o", os.path.join(blocker, "o.msh")]):
            r = subprocess.run(["/usr/bin/python3", cli, "--url", self.d.url] + args, capture_output=True, text=True,
                               timeout=60)
            self.assertEqual(r.returncode, 1, args)
            self.assertNotIn("Traceback", r.stderr, args)
            self.assertRegex(r.stderr, r"^error: [^\n]+\n$", args)
        self.assertFalse(os.path.exists(os.path.join(self.tmp, "no")))

    def test_curl_scripts(self):
        if not shutil.which("curl"):
            self.skipTest("curl not installed")
        d = os.path.join(D.SOURCE_DIR, "clients", "curl")
        env = dict(os.environ, HOCURVE_URL=self.d.url)
        r = subprocess.run(["bash", os.path.join(d, "submit.sh"), SPHERE, "order=2"], capture_output=True,
                           text=True, timeout=30, env=env)
        self.assertEqual(r.returncode, 0, r.stderr)
        job_id = r.stdout.strip()
        self.assertRegex(job_id, r"^[0-9a-f]{24}$")
        r = subprocess.run(["bash", os.path.join(d, "poll.sh"), job_id], capture_output=True, text=True, timeout=90,
                           env=env)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("succeeded", r.stdout)
        out = os.path.join(self.tmp, "curl.msh")
        r = subprocess.run(["bash", os.path.join(d, "download.sh"), job_id, out], capture_output=True, text=True,
                           timeout=30, env=env)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertTrue(data(out).startswith(b"$MeshFormat"))
        r = subprocess.run(["bash", os.path.join(d, "cancel.sh"), job_id], capture_output=True, text=True,
                           timeout=30, env=env)
        self.assertEqual(r.returncode, 0, r.stderr)  # finished job: deleted
        r = subprocess.run(["bash", os.path.join(d, "poll.sh"), job_id], capture_output=True, text=True, timeout=30,
                           env=env)
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("not-found", r.stderr + r.stdout)

    def test_curl_download_resumes(self):
        # download.sh through connections dropped mid-way: it resumes with curl -C - and If-Range,
        # starts over when the server answers a resume with 200, and ends with the whole file.
        if not shutil.which("curl"):
            self.skipTest("curl not installed")
        done = self.submit_wait()
        full = raw(self.d.url, "GET", "/v1/jobs/%s/result" % done["id"])[2]
        script = os.path.join(D.SOURCE_DIR, "clients", "curl", "download.sh")
        out = os.path.join(self.tmp, "resumed-curl.msh")
        for cuts, edit in [(2, None), (1, lambda h: re.sub(rb"If-Range: [^\r]*", b'If-Range: "stale"', h))]:
            proxy = CuttingProxy(self.d.url, b"/result", keep=len(full) // 3, cuts=cuts, edit=edit)
            try:
                r = subprocess.run(["bash", script, done["id"], out], capture_output=True, text=True, timeout=60,
                                   env=dict(os.environ, HOCURVE_URL=proxy.url))
            finally:
                proxy.close()
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertEqual(data(out), full)
            self.assertFalse(os.path.exists(out + ".part"))
            self.assertEqual(len(proxy.heads), cuts + 1 + (edit is not None), proxy.heads)
            if not edit:
                self.assertNotIn(b"\r\nRange:", proxy.heads[0])
                for h in proxy.heads[1:]:
                    m = re.search(rb"\r\nRange: bytes=(\d+)-\r\n", h)
                    self.assertTrue(m and 0 < int(m[1]) < len(full) and b"\r\nIf-Range: \"" in h, h)


class CurlProgress(unittest.TestCase):
    def test_poll_prints_percent(self):
        if not shutil.which("curl"):
            self.skipTest("curl not installed")
        tmp = tempfile.mkdtemp(prefix="hocurved-poll-")
        # A worker whose progress fraction is 0.1 + 0.2 = 0.30000000000000004 for a while.
        worker = D.fake_worker(tmp, "fake_progress.py", "import time\nprint('{\"stage\": \"fits\", \"fraction\": %r}' % "
                               "(0.1 + 0.2), flush=True)\ntime.sleep(1.5)\n" + D.FAKE_OK)
        with D.Daemon(BUILD_DIR, worker=worker) as d:
            job = Client(d.url).submit(SPHERE, {"order": 2})
            env = dict(os.environ, HOCURVE_URL=d.url)
            r = subprocess.run(["bash", os.path.join(D.SOURCE_DIR, "clients", "curl", "poll.sh"), job["id"]],
                               capture_output=True, text=True, timeout=60, env=env)
        shutil.rmtree(tmp, ignore_errors=True)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("running 30%", r.stderr)
        self.assertNotIn("0.3000", r.stderr)


class ServerAuth(unittest.TestCase):
    def test_bearer_token(self):
        tmp = tempfile.mkdtemp(prefix="hocurved-auth-")
        token = os.path.join(tmp, "token")
        with open(token, "w") as f:
            f.write("s3cret-token\n")
        worker = D.fake_worker(tmp, "fake_ok.py", D.FAKE_OK)
        with D.Daemon(BUILD_DIR, worker=worker, args=["--token-file", token]) as d:
            self.assertEqual(raw(d.url, "GET", "/healthz")[0], 200)
            problem(self, raw(d.url, "GET", "/v1/jobs"), 401, "unauthorized")
            problem(self, raw(d.url, "GET", "/v1/jobs", headers={"Authorization": "Bearer s3cret-tokem"}), 401,
                    "unauthorized")
            problem(self, raw(d.url, "GET", "/v1/jobs", headers={"Authorization": "Bearer s3cret-token2"}), 401,
                    "unauthorized")
            self.assertEqual(raw(d.url, "GET", "/v1/jobs", headers={"Authorization": "Bearer s3cret-token"})[0], 200)
            # The scheme is case-insensitive (RFC 9110).
            self.assertEqual(raw(d.url, "GET", "/v1/jobs", headers={"Authorization": "bearer s3cret-token"})[0], 200)
            c = Client(d.url, token="s3cret-token")
            job = c.wait(c.submit(SPHERE, {"order": 2})["id"], timeout=30)
            self.assertEqual(job["status"], "succeeded")
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0], "-v"] + sys.argv[2:])
