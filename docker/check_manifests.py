#!/usr/bin/python3
"""Checks docker/compose.yaml, docker/k8s/*.yaml and docker/Dockerfile against each other and against
what hocurved really accepts (server/ sources), without podman, Docker or a cluster.

Usage: /usr/bin/python3 docker/check_manifests.py   (needs python3-yaml)
Checks: every YAML document parses and names apiVersion/kind/metadata.name; every HOCURVE_* variable
set anywhere is one hocurved reads; probe paths are routes of server/routes.cpp; ports, user, data
directory and volume agree with the Dockerfile; selectors, named ports, claims and secrets resolve;
grace periods outlast HOCURVE_SHUTDOWN_GRACE; workers x job memory fit the memory limit; the disk quota
fits the volume; the nginx front (docker/nginx.conf) listens on the image's port, forwards to hocurved's
HOCURVE_PORT on loopback and lets the largest upload and the longest sync job through. Prints one line per problem and exits 1 when there is any.
"""
import pathlib
import re
import sys

import yaml

ROOT = pathlib.Path(__file__).resolve().parent.parent
problems = []


def check(ok, what):
    if not ok:
        problems.append(what)
    return ok


def accepted_env():
    """HOCURVE_* names hocurved reads: one per config flag, plus the getenv() calls in server/."""
    config = (ROOT / "server/config.cpp").read_text()
    flags = re.findall(r'\{"([a-z][a-z-]*)",\s*\[\]\(Config&', config)
    check(len(flags) > 5, f"server/config.cpp: found only {len(flags)} flags; the parser here is out of date")
    names = {"HOCURVE_" + f.upper().replace("-", "_") for f in flags}
    for src in (ROOT / "server").glob("*.cpp"):
        names |= set(re.findall(r'getenv\("(HOCURVE_[A-Z_]+)"\)', src.read_text()))
    return names


def routes():
    text = (ROOT / "server/routes.cpp").read_text()
    return set(re.findall(r'svr\.Get\("(/[^"]*)"', text))


def dockerfile():
    """The runtime stage's ENV, USER, EXPOSE, VOLUME of docker/Dockerfile."""
    text = (ROOT / "docker/Dockerfile").read_text().replace("\\\n", " ")
    stage = text.split(" AS runtime", 1)[1]
    env = {}
    for line in re.findall(r"^ENV (.*)$", stage, re.M):
        env.update(dict(re.findall(r"(\w+)=(\S+)", line)))
    user = re.search(r"^USER (\S+)", stage, re.M).group(1)
    expose = re.search(r"^EXPOSE (\d+)", stage, re.M).group(1)
    volume = re.search(r'^VOLUME \["([^"]+)"\]', stage, re.M).group(1)
    health = re.search(r"^HEALTHCHECK .*", stage, re.M).group(0)
    return env, user, int(expose), volume, health


def nginx():
    """docker/nginx.conf: its listen port, upstream port, body limit (bytes) and read timeout (s)."""
    text = (ROOT / "docker/nginx.conf").read_text()
    listen = int(re.search(r"^\s*listen (\d+)", text, re.M).group(1))
    upstream = int(re.search(r"^\s*server 127\.0\.0\.1:(\d+);", text, re.M).group(1))
    body = size_bytes(re.search(r"^\s*client_max_body_size (\S+);", text, re.M).group(1))
    read = seconds(re.search(r"^\s*proxy_read_timeout (\S+);", text, re.M).group(1))
    return listen, upstream, body, read


def probe_target(probe):
    """(path, port) an httpGet probe or an exec probe running curl asks for; None if neither."""
    if "httpGet" in probe:
        return probe["httpGet"]["path"], probe["httpGet"]["port"]
    cmd = probe.get("exec", {}).get("command", [])
    m = next((re.match(r"http://127\.0\.0\.1:(\d+)(/\S*)$", a) for a in cmd if a.startswith("http://")), None)
    return (m.group(2), int(m.group(1))) if cmd[:1] == ["curl"] and m else None


def check_front(where, env, listen_port, n_upstream, n_body, n_read):
    """hocurved behind the front: on loopback, on the port nginx.conf forwards to, with limits that fit."""
    check(env.get("HOCURVE_HOST") == "127.0.0.1", f"{where}: HOCURVE_HOST must be 127.0.0.1 behind the front")
    check(int(env.get("HOCURVE_PORT", 8080)) == n_upstream, f"{where}: HOCURVE_PORT != nginx.conf upstream {n_upstream}")
    check(n_upstream != listen_port, f"{where}: hocurved and the front on one port")
    check(float(env.get("HOCURVE_MAX_UPLOAD_MB", 64)) * 2**20 < n_body, f"{where}: nginx client_max_body_size below HOCURVE_MAX_UPLOAD_MB")
    check(float(env.get("HOCURVE_JOB_TIMEOUT", 600)) + 30 <= n_read, f"{where}: nginx proxy_read_timeout below HOCURVE_JOB_TIMEOUT + 30 s")


def size_bytes(q):
    units = {"Ki": 2**10, "Mi": 2**20, "Gi": 2**30, "Ti": 2**40, "k": 1e3, "M": 1e6, "G": 1e9,
             "g": 2**30, "m": 2**20}
    m = re.fullmatch(r"([\d.]+)([A-Za-z]*)", str(q))
    return float(m.group(1)) * units.get(m.group(2), 1)


def seconds(v):
    m = re.fullmatch(r"([\d.]+)(s|m)?", str(v))
    return float(m.group(1)) * (60 if m.group(2) == "m" else 1)


def main():
    env_ok, paths = accepted_env(), routes()
    check({"/healthz", "/readyz", "/metrics"} <= paths, f"server/routes.cpp: probe routes missing from {sorted(paths)}")
    d_env, d_user, d_port, d_volume, d_health = dockerfile()
    uid = int(d_user.split(":")[0])
    for k in d_env:
        check(not k.startswith("HOCURVE_") or k in env_ok, f"Dockerfile: ENV {k} is not read by hocurved")
    check(int(d_env.get("HOCURVE_PORT", 8080)) == d_port, f"Dockerfile: HOCURVE_PORT != EXPOSE {d_port}")
    check(d_env.get("HOCURVE_DATA_DIR") == d_volume, "Dockerfile: HOCURVE_DATA_DIR != VOLUME")
    check(d_env.get("HOCURVE_HOST") == "0.0.0.0", "Dockerfile: HOCURVE_HOST must be 0.0.0.0 in a container")
    check(f":{d_port}/healthz" in d_health, f"Dockerfile: HEALTHCHECK does not probe :{d_port}/healthz")
    check(uid != 0, "Dockerfile: runs as root")
    grace = float(d_env.get("HOCURVE_SHUTDOWN_GRACE", 20))
    n_listen, n_upstream, n_body, n_read = nginx()
    check(n_listen == d_port, f"nginx.conf: listens on {n_listen}, not the image's port {d_port}")
    front_cmd = ["nginx", "-e", "stderr", "-c", "/usr/local/share/hocurve/nginx.conf", "-g", "daemon off;"]

    # ---- compose ----
    compose = yaml.safe_load((ROOT / "docker/compose.yaml").read_text())
    svc = compose["services"]["hocurved"]
    c_env = {k: str(v) for k, v in (svc.get("environment") or {}).items()}
    for k in c_env:
        check(k in env_ok, f"compose.yaml: {k} is not read by hocurved")
    check(any(str(p).endswith(f":{d_port}") for p in svc.get("ports", [])), f"compose.yaml: no port maps to {d_port}")
    check(any(str(v).split(":")[1] == d_volume for v in svc.get("volumes", [])), f"compose.yaml: no volume on {d_volume}")
    for v in svc.get("volumes", []):
        src = str(v).split(":")[0]
        check(src.startswith((".", "/")) or src in (compose.get("volumes") or {}), f"compose.yaml: volume {src} undeclared")
    c_grace = float(c_env.get("HOCURVE_SHUTDOWN_GRACE", grace))
    check(seconds(svc.get("stop_grace_period", "10s")) > c_grace, "compose.yaml: stop_grace_period <= HOCURVE_SHUTDOWN_GRACE")
    mem = svc.get("deploy", {}).get("resources", {}).get("limits", {}).get("memory")
    workers = int(c_env.get("HOCURVE_WORKERS", d_env.get("HOCURVE_WORKERS", 2)))
    job_mb = float(c_env.get("HOCURVE_JOB_MEMORY_MB", d_env.get("HOCURVE_JOB_MEMORY_MB", 4096)))
    if mem:
        check(workers * job_mb * 2**20 <= size_bytes(mem), f"compose.yaml: {workers} workers x {job_mb} MB > memory {mem}")
    front = compose["services"].get("front", {})
    check(front.get("network_mode") == "service:hocurved", "compose.yaml: front must share hocurved's network namespace")
    check(front.get("entrypoint") == front_cmd, "compose.yaml: front does not run docker/nginx.conf")
    check_front("compose.yaml", c_env, n_listen, n_upstream, n_body, n_read)
    check(svc.get("build", {}).get("dockerfile") == "docker/Dockerfile", "compose.yaml: build.dockerfile")
    check((ROOT / "docker" / svc.get("build", {}).get("context", "?") / ".dockerignore").exists(),
          "compose.yaml: build context has no .dockerignore")

    # ---- kubernetes ----
    docs = {}
    for f in sorted((ROOT / "docker/k8s").glob("*.yaml")):
        for doc in yaml.safe_load_all(f.read_text()):
            if doc is None:
                continue
            ok = all(k in doc for k in ("apiVersion", "kind", "metadata")) and "name" in doc["metadata"]
            if check(ok, f"{f.name}: a document without apiVersion/kind/metadata.name"):
                docs[(doc["kind"], doc["metadata"]["name"])] = (f.name, doc)
    deps = [d for (k, _), (_, d) in docs.items() if k == "Deployment"]
    check(len(deps) == 1, "k8s: expected one Deployment")
    for dep in deps:
        spec, pod = dep["spec"], dep["spec"]["template"]
        labels = pod["metadata"]["labels"]
        check(all(labels.get(k) == v for k, v in spec["selector"]["matchLabels"].items()), "Deployment: selector does not match the pod labels")
        check(spec.get("replicas", 1) == 1 and spec.get("strategy", {}).get("type") == "Recreate",
              "Deployment: one replica with Recreate (one writer per data volume)")
        ps = pod["spec"]
        sc = ps.get("securityContext", {})
        check(sc.get("runAsUser") == uid and sc.get("runAsNonRoot") is True, f"Deployment: runAsUser != {uid}")
        vols = {v["name"]: v for v in ps.get("volumes", [])}
        ctrs = {c["name"]: c for c in ps["containers"]}
        check(set(ctrs) == {"front", "hocurved"}, f"Deployment: containers {sorted(ctrs)}, expected front and hocurved")
        ctr, front = ctrs.get("hocurved", {}), ctrs.get("front", {})
        check(front.get("command") == front_cmd, "Deployment: front does not run docker/nginx.conf")
        ports = {p.get("name"): p["containerPort"] for p in front.get("ports", [])}
        check(d_port in ports.values(), f"Deployment: the front's containerPort != {d_port}")
        k_env = {e["name"]: e.get("value") for e in ctr.get("env", [])}
        for k in k_env:
            check(k in env_ok, f"Deployment: env {k} is not read by hocurved")
        check_front("Deployment", k_env, n_listen, n_upstream, n_body, n_read)
        if front.get("securityContext", {}).get("readOnlyRootFilesystem"):
            check("/tmp" in {m["mountPath"] for m in front.get("volumeMounts", [])}, "Deployment: front without a /tmp volume")
        mounts = {m["mountPath"]: m["name"] for m in ctr.get("volumeMounts", [])}
        for path, vname in mounts.items():
            check(vname in vols, f"Deployment: volumeMount {vname} has no volume")
        check(d_volume in mounts, f"Deployment: nothing mounted on the data directory {d_volume}")
        if ctr.get("securityContext", {}).get("readOnlyRootFilesystem"):
            check("/tmp" in mounts, "Deployment: read-only root filesystem without a /tmp volume")
        targets = {}
        for probe in ("startupProbe", "livenessProbe", "readinessProbe"):
            t = probe_target(ctr.get(probe, {}))
            if check(t is not None, f"Deployment: no {probe} (httpGet, or exec curl http://127.0.0.1:PORT/PATH)"):
                targets[probe] = t[0]
                check(t[0] in paths, f"Deployment: {probe} path {t[0]} is not a route")
                check(t[1] == int(k_env.get("HOCURVE_PORT", 8080)), f"Deployment: {probe} port {t[1]} is not HOCURVE_PORT")
        check(targets.get("readinessProbe") == "/readyz", "Deployment: readiness must use /readyz (503 while draining)")
        check(targets.get("livenessProbe") == "/healthz", "Deployment: liveness must use /healthz")
        k_grace = float(k_env.get("HOCURVE_SHUTDOWN_GRACE", grace))
        check(ps.get("terminationGracePeriodSeconds", 30) > k_grace, "Deployment: terminationGracePeriodSeconds <= HOCURVE_SHUTDOWN_GRACE")
        lim = ctr.get("resources", {}).get("limits", {})
        workers = int(k_env.get("HOCURVE_WORKERS", d_env.get("HOCURVE_WORKERS", 2)))
        job_mb = float(k_env.get("HOCURVE_JOB_MEMORY_MB", d_env.get("HOCURVE_JOB_MEMORY_MB", 4096)))
        if check("memory" in lim, "Deployment: no memory limit"):
            check(workers * job_mb * 2**20 <= size_bytes(lim["memory"]), f"Deployment: {workers} x {job_mb} MB > {lim['memory']}")
        check("cpu" in lim, "Deployment: no cpu limit")
        for v in vols.values():
            if "persistentVolumeClaim" in v:
                claim = v["persistentVolumeClaim"]["claimName"]
                if check(("PersistentVolumeClaim", claim) in docs, f"Deployment: claim {claim} is not in k8s/"):
                    pvc = docs[("PersistentVolumeClaim", claim)][1]
                    quota = float(k_env.get("HOCURVE_MAX_DISK_MB", 10240)) * 1e6
                    check(quota < size_bytes(pvc["spec"]["resources"]["requests"]["storage"]),
                          "Deployment: HOCURVE_MAX_DISK_MB does not fit the PersistentVolumeClaim")
            if "secret" in v:
                name = v["secret"]["secretName"]
                if check(("Secret", name) in docs, f"Deployment: secret {name} is not in k8s/"):
                    keys = set(docs[("Secret", name)][1].get("stringData", {})) | set(docs[("Secret", name)][1].get("data", {}))
                    tf = k_env.get("HOCURVE_TOKEN_FILE")
                    if tf:
                        mdir = next((p for p, n in mounts.items() if n == v["name"]), None)
                        check(mdir is not None and tf.startswith(mdir + "/") and tf[len(mdir) + 1:] in keys,
                              f"Deployment: HOCURVE_TOKEN_FILE {tf} is not a key of secret {name}")
        for (kind, _), (fname, svc_doc) in docs.items():
            if kind != "Service":
                continue
            sel = svc_doc["spec"]["selector"]
            check(all(labels.get(k) == v for k, v in sel.items()), f"{fname}: selector does not match the pod labels")
            for p in svc_doc["spec"]["ports"]:
                t = p.get("targetPort", p["port"])
                check(t in ports or t in ports.values(), f"{fname}: targetPort {t} is not a container port")

    for p in problems:
        print("check_manifests:", p)
    print(f"check_manifests: {len(docs)} Kubernetes objects, compose service, Dockerfile: "
          f"{'OK' if not problems else f'{len(problems)} problem(s)'}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
