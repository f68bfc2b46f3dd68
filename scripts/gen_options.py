#!/usr/bin/python3
"""Writes the documents generated from the option registry (cli/option_registry.cpp), read through
`hocurve options --json`: the job options' query parameters and schema in api/openapi.yaml,
api/schemas/JobOptions.json, docs/options.md and the Python client's JOB_OPTIONS. Only those parts
change; the prose around them is written by hand.

Usage: gen_options.py BUILD_DIR           rewrite the documents (`make options`)
       gen_options.py --check BUILD_DIR   exit 1 when a document differs from the registry (ctest)"""
import difflib
import json
import os
import re
import subprocess
import sys

SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OPENAPI = os.path.join("api", "openapi.yaml")
SCHEMA = os.path.join("api", "schemas", "JobOptions.json")
DOCS = os.path.join("docs", "options.md")
CLIENT = os.path.join("clients", "python", "hocurve_client.py")
JSON_TYPES = {"int": "integer", "number": "number", "choice": "string", "switch": "boolean", "flag": "boolean"}


def registry(build_dir):
    out = subprocess.run([os.path.join(build_dir, "hocurve"), "options", "--json"], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out)


def tidy(x):
    """Whole numbers as integers (35, not 35.0), as the documents write them."""
    return int(x) if isinstance(x, float) and x.is_integer() and abs(x) < 1e15 else x


def cli_ref(o):
    if not o["commands"]:
        return []
    return ["hocurve %s%s" % (o["flag"], " on|off" if o["type"] == "switch" else "")]


def description(o):
    scope = {("curve",): "curve only; ", ("coarsen",): "coarsen only; "}.get(tuple(o["modes"]), "both modes; ")
    notes = ["0: " + o["zero_means"]] if "zero_means" in o else []
    if "default" not in o and o["default_text"]:
        notes.append("default: " + o["default_text"])
    notes += cli_ref(o)
    prefix = "" if o["key"] == "mode" else scope + ("needs %s; " % o["needs"] if "needs" in o else "")
    return prefix + o["doc"] + (" (%s)" % "; ".join(notes) if notes else "")


def value_schema(o):
    s = {"type": JSON_TYPES[o["type"]]}
    if "choices" in o:
        s["enum"] = o["choices"]
    if "job_min" in o:
        s["exclusiveMinimum" if o.get("exclusive_min") else "minimum"] = tidy(o["job_min"])
        s["maximum"] = tidy(o["max"])
    if "default" in o:
        s["default"] = tidy(o["default"])
    return s


def job_options(reg):
    return [o for o in reg if o["modes"]]


def properties(reg):
    return {o["key"]: dict({"description": description(o)}, **value_schema(o)) for o in job_options(reg)}


def query_parameter(o):
    s = value_schema(o)
    if s["type"] == "boolean":  # query values are text: exactly this enum
        s = {"type": "string", "enum": ["0", "1", "true", "false"], "default": "1" if s["default"] else "0"}
    return {"name": o["key"], "in": "query", "description": description(o), "schema": s}


def dump(doc):
    # 1e-9, not Python's 1e-09, as the documents were written.
    return re.sub(r"(: -?[0-9.]+e-?)0([0-9])", r"\1\2", json.dumps(doc, indent=1)) + "\n"


def openapi_text(reg, text):
    doc = json.loads(text)
    keys = {o["key"] for o in reg}
    params = [query_parameter(o) for o in job_options(reg)]
    for op in doc["paths"].values():
        for method in op.values():
            old = method.get("parameters", []) if isinstance(method, dict) else []
            if any(p.get("in") == "query" and p.get("name") in keys for p in old):
                method["parameters"] = params + [p for p in old if not (p.get("in") == "query" and p["name"] in keys)]
    doc["components"]["schemas"]["JobOptions"]["properties"] = properties(reg)
    return dump(doc)


def schema_text(reg, text):
    doc = json.loads(text)
    doc["properties"] = properties(reg)
    return dump(doc)


def cell(s):
    return s.replace("|", "\\|")


def value_text(o):
    if "range" in o:
        jobs = o.get("job_range", o["range"])
        return o["range"] + (" (jobs: %s)" % jobs if jobs != o["range"] else "")
    if o["type"] == "choice":
        return " \\| ".join(o["choices"])
    return {"switch": "on \\| off", "flag": "-", "path": o.get("metavar", "FILE")}[o["type"]]


def docs_text(reg):
    lines = ["# Options", "",
             "Generated from the option registry (`cli/option_registry.cpp`) by `make options`; do not edit.",
             "The CLI takes an option as its flag (`--feature-angle 40`), a job as its key (`feature_angle=40`,",
             "or in the multipart `options` part: `{\"feature_angle\": 40}`; booleans there are JSON",
             "`true`/`false`, in a query `0`, `1`, `true` or `false`). Commands and job modes list where an",
             "option is taken; elsewhere it is refused. `docs/service.md` has the rules across options.", "",
             "| flag | job key | commands | job modes | values | default | meaning |",
             "|---|---|---|---|---|---|---|"]
    for o in reg:
        flag = "`%s`" % o["flag"] if o["commands"] else "-"
        if "short" in o:
            flag = "`%s`, %s" % (o["short"], flag)
        values = value_text(o)
        notes = ["0: " + o["zero_means"]] if "zero_means" in o else []
        if "needs" in o:
            notes.append("needs %s" % o["needs"])
        meaning = o["doc"] + (" (%s)" % "; ".join(notes) if notes else "")
        lines.append("| %s | %s | %s | %s | %s | %s | %s |" % (
            flag, "`%s`" % o["key"] if o["modes"] else "-", ", ".join(o["commands"]) or "-",
            ", ".join(o["modes"]) or "-", values, cell(o["default_text"]) or "-", cell(meaning)))
    return "\n".join(lines) + "\n"


def client_text(reg, text):
    """The Python client's JOB_OPTIONS, between its BEGIN and END markers."""
    begin, end = "# BEGIN generated job options\n", "# END generated job options\n"
    lines = ["JOB_OPTIONS = {\n"] + ['    "%s": ("%s", %s),\n' % (o["key"], o["type"], json.dumps(o.get("choices")).replace("null", "None"))
                                   for o in job_options(reg)] + ["}\n"]
    head, rest = text.split(begin, 1)
    return head + begin + "".join(lines) + end + rest.split(end, 1)[1]


def main(argv):
    check = "--check" in argv
    args = [a for a in argv if a != "--check"]
    if len(args) != 1:
        sys.exit(__doc__)
    reg = registry(os.path.abspath(args[0]))
    stale = []
    for rel, make in [(OPENAPI, lambda t: openapi_text(reg, t)), (SCHEMA, lambda t: schema_text(reg, t)),
                      (DOCS, lambda t: docs_text(reg)), (CLIENT, lambda t: client_text(reg, t))]:
        path = os.path.join(SOURCE_DIR, rel)
        old = open(path).read() if os.path.exists(path) else ""
        new = make(old)
        # The JSON documents are compared as JSON: a merged hunk written in another layout is no change.
        if new == old or (check and rel in (OPENAPI, SCHEMA) and json.loads(new) == json.loads(old)):
            continue
        stale.append(rel)
        if check:
            sys.stdout.writelines(difflib.unified_diff(old.splitlines(True), new.splitlines(True), rel, rel + " (registry)"))
        else:
            with open(path, "w") as f:
                f.write(new)
    if check and stale:
        print("%s differ from the option registry: run `make options`" % ", ".join(stale), file=sys.stderr)
        return 1
    print("up to date" if check else "rewritten: " + (", ".join(stale) or "none"))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
