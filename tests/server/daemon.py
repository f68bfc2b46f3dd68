"""Test helper: starts hocurved on an ephemeral loopback port and provides fake workers.

Used by tests/python/test_server_*.py (imported via sys.path). Loopback only, bounded waits.
"""
import atexit
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request

SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHARED_DIR = os.environ.get("HOCURVE_SHARED_DIR", os.path.join(os.path.dirname(SOURCE_DIR), "shared"))
sys.path.insert(0, os.path.join(SOURCE_DIR, "clients", "python"))


def fake_worker(dirname, name, body):
    """Writes an executable worker script (python, or shell when body starts with #!/bin/sh)."""
    path = os.path.join(dirname, name)
    with open(path, "w") as f:
        if not body.startswith("#!"):
            f.write("#!/usr/bin/python3\n")
        f.write(body)
    os.chmod(path, 0o755)
    return path


# Worker that behaves like `hocurve` (progress lines, output, stats) after sleeping `SLEEP` seconds.
FAKE_OK = r"""
import json, os, sys, time
a = sys.argv[1:]
out = a[a.index('-o') + 1]; stats = a[a.index('--stats') + 1]
steps = int(os.environ.get('FAKE_STEPS', '3'))
for i in range(steps):
    print(json.dumps({"stage": "fits", "fraction": i / steps}), flush=True)
    time.sleep(float(os.environ.get('FAKE_SLEEP', '0.02')))
version = "2.2" if "msh22" in a else "4.1"
open(out, 'w').write("$MeshFormat\n%s 0 8\n$EndMeshFormat\n" % version)
json.dump({"fake": True, "argv": a}, open(stats, 'w'))
"""

# Worker that crashes (SIGSEGV) after one progress line.
FAKE_CRASH = """#!/bin/sh
echo '{"stage":"fits","fraction":0.1}'
echo "about to crash" >&2
kill -SEGV $$
"""


def real_worker(build_dir):
    p = os.path.join(build_dir, "hocurve")
    return p if os.access(p, os.X_OK) else None


def slow_wrapper(dirname, target, seconds):
    """A worker that sleeps, then execs `target` with the same arguments (real work, known delay)."""
    return fake_worker(dirname, "slow_worker.sh",
                       "#!/bin/sh\necho '{\"stage\":\"waiting\",\"fraction\":0.01}'\nsleep %s\nexec %s \"$@\"\n"
                       % (seconds, target))


class Daemon:
    def __init__(self, build_dir, data_dir=None, worker=None, args=(), env=None):
        self.exe = os.path.join(build_dir, "hocurved")
        self.tmp = tempfile.mkdtemp(prefix="hocurved-test-")
        # Removed when the test program exits (tests restart a daemon on the same folder).
        atexit.register(shutil.rmtree, self.tmp, True)
        self.data_dir = data_dir or os.path.join(self.tmp, "data")
        self.worker = worker
        self.args = list(args)
        self.env = dict(os.environ, **(env or {}))
        self.proc = None
        self.lines = []

    def start(self, timeout=10):
        cmd = [self.exe, "--host", "127.0.0.1", "--port", "0", "--data-dir", self.data_dir] + self.args
        if self.worker:
            cmd += ["--hocurve-bin", self.worker]
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=self.env)
        first = self.proc.stdout.readline().decode()
        if not first:
            raise RuntimeError("hocurved exited at start: rc=%s" % self.proc.wait(timeout))
        rec = json.loads(first)
        assert rec["msg"] == "listening", rec
        self.port = rec["port"]
        self.url = "http://127.0.0.1:%d" % self.port
        self.lines = [rec]
        threading.Thread(target=self._drain, daemon=True).start()
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:  # bounded: the server answers as soon as listen() runs
            try:
                with urllib.request.urlopen(self.url + "/healthz", timeout=2) as r:
                    if r.status == 200:
                        return self
            except (urllib.error.URLError, OSError):
                time.sleep(0.02)
        raise RuntimeError("hocurved did not answer /healthz")

    def _drain(self):
        for line in self.proc.stdout:
            try:
                self.lines.append(json.loads(line))
            except ValueError:
                self.lines.append({"raw": line.decode("utf-8", "replace")})

    def stop(self, sig=signal.SIGTERM, timeout=30):
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                return self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                raise
        return self.proc.returncode if self.proc else None

    def kill9(self):
        self.proc.kill()
        self.proc.wait(10)

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
