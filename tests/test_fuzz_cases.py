#!/usr/bin/env python3
"""Fuzz-style hostile case files (issue 14): mutations of the cases in
inputs/ must be either valid or refused cleanly.

Each mutation takes a case from inputs/, picks one value, key or section at
random and replaces it with something hostile (an extreme or non-finite
number, a wrong type, an empty or huge text, a NUL escape, a deleted key, a
duplicated or unknown key), and runs `talus check` on it. The run must end
with exit code 0 (still valid) or 2 (refused); with 2, stderr must be exactly
one line "talus: error: ..." naming the file; never a crash, a PETSc or
HDF5 trace, an internal error (exit 1) or a hang (60 s timeout). A mutation
that is still valid also runs its first step (`talus run` with time.end one
step), which must end with 0, 2 or 3 (done, refused, failed) and no crash.

usage: test_fuzz_cases.py TALUS_BINARY SOURCE_DIR [COUNT] [SEED]
"""
import atexit
import glob
import os
import random
import shutil
import subprocess
import sys
import tempfile

import yaml  # python3-yaml, installed by scripts/install_dependencies.sh

# Open MPI 4 creates and removes /tmp/ompi.<host>.<uid> at every singleton
# start, and starts that overlap another test's race on it ("orte_init
# failed", exit code 1; docs/testing.md): this test's talus runs get a
# session directory of their own.
_ompi_sessions = tempfile.mkdtemp(prefix="ompi.")
os.environ["OMPI_MCA_orte_tmpdir_base"] = _ompi_sessions
atexit.register(shutil.rmtree, _ompi_sessions, True)

talus, source = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
count = int(sys.argv[3]) if len(sys.argv) > 3 else 60
rng = random.Random(int(sys.argv[4]) if len(sys.argv) > 4 else 20261125)

HOSTILE = [0, -1, -0.0, 1e-324, 4.9e-324, 1e308, -1e308, 1e300, float("nan"), float("inf"), "-.inf", ".nan",
           "abc", "", "x" * 5000, "\\0", [], {}, [1, 2, 3], {"a": 1}, True, None, 2**63, -(2**63), 1e-300]
FORBIDDEN = ["Segmentation", "terminate called", "Assertion", "PETSC ERROR", "HDF5-DIAG", "internal error",
             "Aborted", "core dumped", "Caught signal"]


def paths(node, prefix=()):
    """Every (path, value) in a YAML tree."""
    yield prefix, node
    if isinstance(node, dict):
        for k, v in node.items():
            yield from paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from paths(v, prefix + (i,))


def mutate(doc):
    """One hostile change, in place; returns its description."""
    targets = [p for p, _ in paths(doc) if p]
    path = rng.choice(targets)
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    key = path[-1]
    kind = rng.random()
    if kind < 0.6:
        value = rng.choice(HOSTILE)
        parent[key] = value
        return f"{'.'.join(map(str, path))} = {str(value)[:40]!r}"
    if kind < 0.75 and isinstance(parent, dict):
        del parent[key]
        return f"deleted {'.'.join(map(str, path))}"
    if kind < 0.85 and isinstance(parent, dict):
        parent[str(key) + "_"] = parent[key]
        return f"unknown key {key}_"
    if isinstance(parent, list):
        parent.append(parent[key])
        return f"duplicated {'.'.join(map(str, path))}"
    parent[key] = rng.choice([[parent[key]], {"value": parent[key]}])
    return f"wrapped {'.'.join(map(str, path))}"


failures = []
outcomes = {0: 0, 2: 0}
with tempfile.TemporaryDirectory() as work:
    # A copy of inputs/ (with its data files): the mutated cases live beside
    # their data, and never in the source tree, where another test (cli)
    # checks every inputs/*.yaml at the same time.
    shutil.copytree(os.path.join(source, "inputs"), os.path.join(work, "inputs"))
    cases = sorted(glob.glob(os.path.join(work, "inputs", "*.yaml")))
    for n in range(count):
        case = rng.choice(cases)
        doc = yaml.safe_load(open(case))
        what = mutate(doc)
        # In the case's directory, so that its data files are found; output
        # into the scratch directory (talus check writes nothing anyway).
        if isinstance(doc.get("output"), dict):
            doc["output"]["directory"] = os.path.join(work, "out")
        name = os.path.join(os.path.dirname(case), f"_fuzz_{os.getpid()}_{n}.yaml")
        try:
            with open(name, "w") as f:
                yaml.safe_dump(doc, f, allow_unicode=False)
            try:
                r = subprocess.run([talus, "check", name], capture_output=True, text=True, timeout=60, cwd=work)
                code, out, err = r.returncode, r.stdout, r.stderr
            except subprocess.TimeoutExpired:
                code, out, err = "timeout", "", ""
        finally:
            os.remove(name)
        ran = None
        if code == 0:
            # Still valid: run its first step too (exit 0, 2 or 3: a refused
            # or failed run is fine, a crash or a trace is not).
            if isinstance(doc.get("time"), dict) and "step" in doc["time"]:
                doc["time"]["end"] = doc["time"]["step"]
            elif isinstance(doc.get("time"), dict):
                # An explicit case picks its own step (a fraction of a
                # millisecond): a few of them, not the whole run (which took
                # more than the timeout under the sanitizers, docs/testing.md).
                doc["time"]["end"] = 1e-3
            doc["output"] = {"directory": os.path.join(work, f"run_{n}")}
            doc.pop("checkpoint", None)
            try:
                with open(name, "w") as f:
                    yaml.safe_dump(doc, f, allow_unicode=False)
                try:
                    r = subprocess.run([talus, "run", name], capture_output=True, text=True, timeout=120, cwd=work)
                    ran, out, err = r.returncode, out + r.stdout, err + r.stderr
                except subprocess.TimeoutExpired:
                    ran = "timeout"
            finally:
                os.remove(name)
        problems = []
        if ran is not None and ran not in (0, 2, 3):
            problems.append(f"run: exit {ran}")
        if code not in (0, 2):
            problems.append(f"exit {code}")
        if any(word in out + err for word in FORBIDDEN):
            problems.append("crash or trace in the output")
        if code == 2:
            lines = err.strip().splitlines()
            if len(lines) != 1 or not lines[0].startswith("talus: error: ") or os.path.basename(name) not in lines[0]:
                problems.append("not one 'talus: error:' line naming the file")
        if code in outcomes:
            outcomes[code] += 1
        if problems:
            failures.append(f"{os.path.basename(case)}: {what}: {', '.join(problems)}\n    {err.strip()[:300]}")
print(f"{count} mutated cases: {outcomes[0]} still valid, {outcomes[2]} refused with exit 2, {len(failures)} failed")
for f in failures:
    print("FAIL:", f)
sys.exit(1 if failures else 0)
