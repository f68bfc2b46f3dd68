#!/usr/bin/env python3
"""Client for hocurved, the hocurve HTTP job service. Standard library only.

As a module:
    from hocurve_client import Client, ProblemError
    c = Client("http://127.0.0.1:8080")
    job = c.submit("mesh.stl", {"order": 4})
    job = c.wait(job["id"])
    c.download(job["id"], "mesh_p4.msh")

Downloads go to OUT.part, renamed to OUT only when complete. A dropped connection or a short
read is resumed (Range: bytes=N- with If-Range: the first answer's ETag), up to
DOWNLOAD_ATTEMPTS tries with backoff; a 200 to a resumed request (the result changed) starts over.
Every other answer is checked whole too: one that ends before its Content-Length (or, chunked,
before its last chunk) raises ProblemError (status 0, "Incomplete response"). The synchronous
curve() is a POST and is not resumed: its dest (also written as dest.part, renamed when complete)
is then not created; retry, or use submit/wait/download, whose download resumes.

As a program:
    hocurve_client.py --url http://127.0.0.1:8080 submit mesh.stl --order 4 --wait -o mesh_p4.msh
    hocurve_client.py status JOB | wait JOB | download JOB -o OUT | stats JOB | cancel JOB | list | info
Errors are RFC 9457 problem details; the CLI prints their title and detail and exits 1.
"""
import argparse
import errno
import http.client
import io
import json
import os
import sys
import time
import urllib.error
import urllib.parse
import urllib.request
import uuid

TERMINAL = ("succeeded", "failed", "cancelled")
DOWNLOAD_ATTEMPTS = 5  # tries of one result download in all; waits 0.5, 1, 2, 4 s between them


class ProblemError(Exception):
    """An error answered by the server (application/problem+json) or a transport failure (status 0)."""

    def __init__(self, status, problem):
        self.status = status
        self.problem = problem if isinstance(problem, dict) else {"detail": str(problem)}
        self.type = self.problem.get("code") or self.problem.get("type", "")
        self.title = self.problem.get("title", "HTTP %d" % status)
        self.detail = self.problem.get("detail", "")
        self.retry_after = None
        super().__init__("%s (%d %s): %s" % (self.title, status, self.type, self.detail))


class Client:
    def __init__(self, base_url, token=None, timeout=60.0):
        self.base_url = base_url.rstrip("/")
        self.token = token
        self.timeout = timeout

    # -- transport ---------------------------------------------------------------------------
    def _open(self, method, path, body=None, headers=None, query=None):
        """Sends one request; returns the open response, raises ProblemError for an error answer
        (status >= 400) or a transport failure (status 0)."""
        url = self.base_url + path
        if query:
            url += "?" + urllib.parse.urlencode({k: _qv(v) for k, v in query.items()})
        req = urllib.request.Request(url, data=body, method=method)
        for k, v in (headers or {}).items():
            req.add_header(k, v)
        if self.token:
            req.add_header("Authorization", "Bearer " + self.token)
        try:
            resp = urllib.request.urlopen(req, timeout=self.timeout)
        except urllib.error.HTTPError as e:
            raw = e.read()
            try:
                problem = json.loads(raw.decode("utf-8", "replace"))
            except ValueError:
                problem = {"title": "HTTP %d" % e.code, "detail": raw[:200].decode("utf-8", "replace")}
            err = ProblemError(e.code, problem)
            ra = e.headers.get("Retry-After")
            err.retry_after = float(ra) if ra and ra.replace(".", "", 1).isdigit() else None
            raise err from None
        except (urllib.error.URLError, OSError) as e:
            raise ProblemError(0, {"title": "Connection failed", "detail": "%s: %s" % (url, e)}) from None
        return resp

    def _request(self, method, path, body=None, headers=None, query=None, stream_to=None):
        resp = self._open(method, path, body, headers, query)
        with resp:
            if stream_to is not None:
                with _part_file(stream_to) as f:
                    total = self._receive_whole(resp, f, method, stream_to)
                return resp.status, dict(resp.headers), total
            buf = io.BytesIO()
            self._receive_whole(resp, buf, method)
            data = buf.getvalue()
            ctype = resp.headers.get("Content-Type", "")
            if data and "json" in ctype:
                return resp.status, dict(resp.headers), json.loads(data)
            return resp.status, dict(resp.headers), data

    @staticmethod
    def _receive_whole(resp, f, method, dest=None):
        """Copies the body of `resp` to `f`; returns its length, or raises ProblemError (status 0)
        if the answer ended early (not resumed: only download() does that)."""
        failure = _receive(resp, f)
        if failure is None:
            return f.tell()
        where = "%s not written; " % dest if dest else ""
        advice = ("a POST is not resumed: retry, or use the job API (submit --wait -o OUT), whose download resumes"
                  if method == "POST" else "retry")
        raise ProblemError(0, {"title": "Incomplete response", "detail": "%s %s: the answer ended early (%s); %s%s" % (
            method, resp.url, failure, where, advice)})

    # -- API -----------------------------------------------------------------------------------
    def health(self):
        return self._request("GET", "/healthz")[2]

    def info(self):
        return self._request("GET", "/v1/info")[2]

    def submit(self, mesh, options=None, idempotency_key=None, multipart=False, retries=0):
        """Upload a mesh (path or bytes) with options; returns the job (202). Retries 429 `retries` times."""
        data = _read_mesh(mesh)
        options = dict(options or {})
        headers = {}
        if idempotency_key:
            headers["Idempotency-Key"] = idempotency_key
        for attempt in range(retries + 1):
            try:
                if multipart:
                    boundary = "hocurve-" + uuid.uuid4().hex
                    name = os.path.basename(mesh) if isinstance(mesh, str) else "mesh.bin"
                    body = _multipart(boundary, name, data, options)
                    h = dict(headers, **{"Content-Type": "multipart/form-data; boundary=" + boundary})
                    return self._request("POST", "/v1/jobs", body, h)[2]
                h = dict(headers, **{"Content-Type": "application/octet-stream"})
                return self._request("POST", "/v1/jobs", data, h, query=options)[2]
            except ProblemError as e:
                if e.status != 429 or attempt == retries:
                    raise
                time.sleep(e.retry_after or 1.0)

    def curve(self, mesh, options=None, dest=None):
        """Synchronous POST /v1/curve for small meshes: returns the .msh bytes (or writes `dest`)."""
        data = _read_mesh(mesh)
        h = {"Content-Type": "application/octet-stream"}
        if dest:
            return self._request("POST", "/v1/curve", data, h, query=options or {}, stream_to=dest)[2]
        return self._request("POST", "/v1/curve", data, h, query=options or {})[2]

    def get(self, job_id):
        return self._request("GET", "/v1/jobs/" + urllib.parse.quote(job_id, safe=""))[2]

    def list(self, status=None, page_size=None):
        """All jobs, newest first, following next_page_token."""
        token = ""
        while True:
            q = {}
            if status:
                q["status"] = status
            if page_size:
                q["page_size"] = page_size
            if token:
                q["page_token"] = token
            page = self._request("GET", "/v1/jobs", query=q)[2]
            for j in page["jobs"]:
                yield j
            token = page.get("next_page_token", "")
            if not token:
                return

    def wait(self, job_id, timeout=600.0, interval=0.2, on_progress=None):
        """Polls until the job is terminal; returns it. Raises TimeoutError after `timeout` s."""
        deadline = time.monotonic() + timeout
        while True:
            job = self.get(job_id)
            if on_progress:
                on_progress(job)
            if job["status"] in TERMINAL:
                return job
            if time.monotonic() > deadline:
                raise TimeoutError("job %s still %s after %.0f s" % (job_id, job["status"], timeout))
            time.sleep(interval)
            interval = min(interval * 1.5, 2.0)

    def download(self, job_id, dest, attempts=DOWNLOAD_ATTEMPTS):
        """Streams the result .msh to `dest` (written atomically); returns the byte count. An
        interrupted transfer resumes where it stopped (see the module's docstring)."""
        path = "/v1/jobs/%s/result" % urllib.parse.quote(job_id, safe="")
        with _part_file(dest) as f:
            etag, failure = None, None
            for attempt in range(attempts):
                if attempt:
                    time.sleep(0.5 * 2 ** (attempt - 1))
                etag, failure = self._download_attempt(path, f, etag)
                if failure is None:
                    return f.tell()
            raise ProblemError(0, {"title": "Download failed", "detail": "%s%s after %d attempts: %s" % (
                self.base_url, path, attempts, failure)})

    def _download_attempt(self, path, f, etag):
        """One GET of a download into `f`: resumes at f's end if it holds bytes of version `etag`,
        else (or if the answer is the whole result) starts over. Returns the answer's ETag and None
        once f holds the full length, or why not (transport failure, short read); raises
        ProblemError for an error answer."""
        have = f.tell()
        resume = have > 0 and etag is not None
        try:
            resp = self._open("GET", path, headers={"Range": "bytes=%d-" % have, "If-Range": etag} if resume else None)
        except ProblemError as e:
            if e.status != 0:
                raise
            return etag, e.detail
        with resp:
            if resp.status != 206 or not resume:
                f.seek(0)
                f.truncate()
            return resp.headers.get("ETag"), _receive(resp, f)

    def stats(self, job_id):
        return self._request("GET", "/v1/jobs/%s/stats" % urllib.parse.quote(job_id, safe=""))[2]

    def cancel(self, job_id):
        """DELETE: cancels a queued/running job (returns it) or deletes a finished one (returns None)."""
        status, _, body = self._request("DELETE", "/v1/jobs/" + urllib.parse.quote(job_id, safe=""))
        return body if status == 202 else None


class _part_file:
    """`with _part_file(dest) as f`: f is dest + ".part", opened for writing; renamed to `dest` when
    the block ends normally, removed when it raises."""

    def __init__(self, dest):
        self.dest, self.tmp = dest, dest + ".part"

    def __enter__(self):
        self.f = open(self.tmp, "wb")
        return self.f

    def __exit__(self, exc_type, *exc):
        self.f.close()
        if exc_type is None:
            os.replace(self.tmp, self.dest)
            return False
        try:
            os.remove(self.tmp)
        except OSError:
            pass
        return False


def _copy(resp, f):
    """Copies a response body to `f` in 64 KiB chunks; returns the byte count (short if the
    connection ended early: http.client then just stops)."""
    total = 0
    while True:
        chunk = resp.read(1 << 16)
        if not chunk:
            return total
        f.write(chunk)
        total += len(chunk)


def _receive(resp, f):
    """Copies a body to the end of `f`; returns None once f holds the answer's full length (or
    the whole of a chunked body), else why not with the byte counts, e.g. "short read: 29621 of
    89807 bytes". Transport failures are returned; a local write error raises."""
    size = _full_length(resp)
    try:
        _copy(resp, f)
    except http.client.IncompleteRead as e:  # chunked: the connection ended before the last chunk
        f.write(e.partial)
        why = "no last chunk"
    except (ConnectionError, TimeoutError, http.client.HTTPException) as e:
        why = str(e) or type(e).__name__
    else:
        if size is None or f.tell() == size:
            return None
        why = "short read"
    return "%s: %d%s bytes" % (why, f.tell(), "" if size is None else " of %d" % size)


def _full_length(resp):
    """The full length of the representation: Content-Range's total for a 206, else Content-Length
    (None if the answer does not say)."""
    if resp.status == 206:
        total = (resp.headers.get("Content-Range") or "").rpartition("/")[2]
        return int(total) if total.isdigit() else None
    length = resp.headers.get("Content-Length")
    return int(length) if length and length.isdigit() else None


def _qv(v):
    if isinstance(v, bool):
        return "1" if v else "0"
    return str(v)


def _read_mesh(mesh):
    if isinstance(mesh, (bytes, bytearray)):
        return bytes(mesh)
    with open(mesh, "rb") as f:
        return f.read()


def _multipart(boundary, filename, data, options):
    b = boundary.encode()
    parts = [
        b"--" + b + b"\r\n",
        b'Content-Disposition: form-data; name="mesh"; filename="' + filename.replace('"', "_").encode() + b'"\r\n',
        b"Content-Type: application/octet-stream\r\n\r\n", data, b"\r\n",
        b"--" + b + b"\r\n",
        b'Content-Disposition: form-data; name="options"\r\n',
        b"Content-Type: application/json\r\n\r\n", json.dumps(options).encode(), b"\r\n",
        b"--" + b + b"--\r\n",
    ]
    return b"".join(parts)


def _progress_bar(job, stream=sys.stderr):
    p = job.get("progress") or {}
    frac = min(max(float(p.get("fraction") or 0.0), 0.0), 1.0)
    width = 30
    filled = int(round(frac * width))
    stream.write("\r[%s%s] %3d%% %-10s %-12s" % ("#" * filled, "." * (width - filled), int(round(frac * 100)),
                                               job["status"], (p.get("stage") or "")[:12]))
    stream.flush()


# The daemon's job options (key: kind, choices), generated from its option registry by `make options`.
# BEGIN generated job options
JOB_OPTIONS = {
    "mode": ("choice", ["curve", "coarsen"]),
    "order": ("int", None),
    "nodes": ("choice", ["equispaced", "lobatto"]),
    "format": ("choice", ["msh41", "msh22"]),
    "binary": ("flag", None),
    "tangent_junctions": ("switch", None),
    "exact_quadrics": ("switch", None),
    "faces": ("int", None),
    "ratio": ("number", None),
    "max_deviation": ("number", None),
    "redecimate": ("int", None),
    "tolerance": ("number", None),
    "max_faces": ("int", None),
    "feature_angle": ("number", None),
    "long_edge_ratio": ("number", None),
    "weld_tolerance": ("number", None),
    "min_jacobian": ("number", None),
}
# END generated job options


def _job_options(args):
    """The job options given on the command line (a switch as a boolean, a flag only when set)."""
    opts = {}
    for key, (kind, _) in JOB_OPTIONS.items():
        v = getattr(args, key)
        if kind == "switch" and v is not None:
            opts[key] = v == "on"
        elif kind == "flag" and v:
            opts[key] = True
        elif kind not in ("switch", "flag") and v is not None:
            opts[key] = v
    return opts


def main(argv=None):
    ap = argparse.ArgumentParser(prog="hocurve_client", description="Client for the hocurved job service")
    ap.add_argument("--url", default=os.environ.get("HOCURVE_URL", "http://127.0.0.1:8080"))
    ap.add_argument("--token-file", default=os.environ.get("HOCURVE_TOKEN_FILE"))
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds to wait for a job")
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("submit", help="upload a mesh and create a job")
    s.add_argument("mesh")
    for key, (kind, choices) in JOB_OPTIONS.items():
        flag = "--" + key.replace("_", "-")
        if kind == "flag":
            s.add_argument(flag, action="store_true", dest=key)
        elif kind == "switch":
            s.add_argument(flag, choices=("on", "off"), dest=key)
        else:
            s.add_argument(flag, type={"int": int, "number": float}.get(kind, str), choices=choices, dest=key)
    s.add_argument("--idempotency-key")
    s.add_argument("--wait", action="store_true", help="wait with a progress bar")
    s.add_argument("-o", "--output", help="with --wait: download the result here")
    for name in ("status", "wait", "stats", "cancel"):
        p = sub.add_parser(name)
        p.add_argument("job")
    d = sub.add_parser("download")
    d.add_argument("job")
    d.add_argument("-o", "--output", required=True)
    lp = sub.add_parser("list")
    lp.add_argument("--status")
    sub.add_parser("info")
    args = ap.parse_args(argv)

    out = sys.stdout
    try:
        token = None
        if args.token_file:
            with open(args.token_file) as f:
                token = f.read().strip()
        c = Client(args.url, token=token)
        if getattr(args, "output", None):
            _check_writable(args.output)  # before uploading or waiting: fail in a second, not after the job
        if args.cmd == "submit":
            opts = _job_options(args)
            job = c.submit(args.mesh, opts, idempotency_key=args.idempotency_key, retries=5)
            if not args.wait:
                out.write(json.dumps(job, indent=2) + "\n")
                return 0
            job = c.wait(job["id"], timeout=args.timeout, on_progress=_progress_bar)
            sys.stderr.write("\n")
            return _finish(c, job, args.output, out)
        if args.cmd == "status":
            out.write(json.dumps(c.get(args.job), indent=2) + "\n")
        elif args.cmd == "wait":
            job = c.wait(args.job, timeout=args.timeout, on_progress=_progress_bar)
            sys.stderr.write("\n")
            return _finish(c, job, None, out)
        elif args.cmd == "download":
            n = c.download(args.job, args.output)
            sys.stderr.write("wrote %s (%d bytes)\n" % (args.output, n))
        elif args.cmd == "stats":
            out.write(json.dumps(c.stats(args.job), indent=2) + "\n")
        elif args.cmd == "cancel":
            job = c.cancel(args.job)
            out.write((json.dumps(job, indent=2) if job else '{"deleted": true}') + "\n")
        elif args.cmd == "list":
            for j in c.list(status=args.status):
                out.write("%s  %-9s  %-8s  %s\n" % (j["id"], j["status"], j["options"].get("mode"), j["created"]))
        elif args.cmd == "info":
            out.write(json.dumps(c.info(), indent=2) + "\n")
        return 0
    except ProblemError as e:
        sys.stderr.write("error: %s (HTTP %d, %s)\n  %s\n" % (e.title, e.status, e.type, e.detail))
        return 1
    except TimeoutError as e:
        sys.stderr.write("error: %s\n" % e)
        return 1
    except OSError as e:  # a local file: the mesh, the output, the token file
        sys.stderr.write("error: %s\n" % _os_error_text(e))
        return 1


def _os_error_text(e):
    """`PATH: reason` of an OSError, without the errno prefix."""
    what = e.strerror or str(e)
    return "%s: %s" % (e.filename, what) if e.filename else what


def _check_writable(path):
    """Raises OSError unless a file can be created at `path` (its directory exists and is writable)."""
    d = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(d):
        raise OSError(errno.ENOENT if not os.path.exists(d) else errno.ENOTDIR,
                      "cannot write the output: %s" % ("no such directory" if not os.path.exists(d) else
                                                       "not a directory"), d)
    if os.path.isdir(path):
        raise OSError(errno.EISDIR, "cannot write the output: it is a directory", path)
    if not os.access(d, os.W_OK):
        raise OSError(errno.EACCES, "cannot write the output: directory not writable", d)


def _finish(c, job, output, out):
    out.write(json.dumps({k: job[k] for k in ("id", "status", "error", "stats")}, indent=2) + "\n")
    if job["status"] != "succeeded":
        err = job.get("error") or {}
        sys.stderr.write("error: job %s %s: %s\n" % (job["id"], job["status"], err.get("detail", "")))
        return 1
    if output:
        n = c.download(job["id"], output)
        sys.stderr.write("wrote %s (%d bytes)\n" % (output, n))
    return 0


if __name__ == "__main__":
    sys.exit(main())
