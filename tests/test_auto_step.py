#!/usr/bin/env python3
"""`time.step: auto` (issue 15, docs/solver.md#choosing-the-step).

Every implicit case in inputs/, with `step: auto` and its time.end cut to
three first steps, must
- take as its first step exactly the documented rule
  h = min(gravity_number sqrt(cell / |g|), courant cell / v0) with the
  defaults 0.05 and 0.5 (v0: the fastest initial body or obstacle velocity),
  to the 4 digits of the step line (a wrong rule or default moves it by far
  more);
- run those steps with no cut-back at t = 0 and exit 0.
`talus check` reports the same first step. A case without gravity, initial
velocity or moving obstacle has no time scale: `auto` is exit 2, naming
time.step.

usage: test_auto_step.py TALUS_BINARY SOURCE_DIR
"""
import atexit
import glob
import math
import os
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
failures = []


def expected_step(case):
    dim = len(case["grid"]["lower"])
    dx = float(case["grid"]["cell_size"])
    g = math.sqrt(sum(float(x) ** 2 for x in case.get("gravity", [0.0] * dim)))
    speeds = [math.sqrt(sum(float(x) ** 2 for x in b["velocity"])) for b in case["bodies"] if "velocity" in b]
    speeds += [math.sqrt(sum(float(x) ** 2 for x in o["velocity"])) for o in case.get("obstacles", [])
               if "velocity" in o]
    v0 = max(speeds, default=0.0)
    candidates = []
    if g > 0:
        candidates.append(0.05 * math.sqrt(dx / g))
    if v0 > 0:
        candidates.append(0.5 * dx / v0)
    return min(candidates)


with tempfile.TemporaryDirectory() as work:
    # Data files are named relative to the case file.
    for data in ("terrain", "particles"):
        os.symlink(os.path.join(source, "inputs", data), os.path.join(work, data))
    cases = 0
    for path in sorted(glob.glob(os.path.join(source, "inputs", "*.yaml"))):
        case = yaml.safe_load(open(path))
        if case["time"].get("integrator", "implicit") != "implicit":
            continue
        cases += 1
        name = os.path.basename(path)[:-5]
        h = expected_step(case)
        case["time"]["step"] = "auto"
        case["time"]["end"] = 3 * h
        case["output"] = {"enabled": False}
        case.pop("checkpoint", None)
        file = os.path.join(work, name + ".yaml")
        with open(file, "w") as f:
            yaml.safe_dump(case, f)
        check = subprocess.run([talus, "check", file], capture_output=True, text=True, timeout=120)
        if check.returncode != 0 or f"automatic steps from {h:.3g} s" not in check.stdout:
            failures.append(f"{name}: talus check: rc {check.returncode}, expected 'automatic steps from "
                            f"{h:.3g} s' in: {check.stdout.strip()} {check.stderr.strip()}")
            continue
        run = subprocess.run([talus, "run", file], capture_output=True, text=True, timeout=600)
        steps = [line.split() for line in run.stdout.splitlines() if line.startswith("step ")]
        cut_at_start = [line for line in run.stdout.splitlines() if "Newton failed" in line and "at t = 0 " in line]
        if run.returncode != 0 or not steps:
            failures.append(f"{name}: run ended with {run.returncode}: {run.stderr.strip()[-300:]}")
            continue
        first = float(steps[0][5])
        if abs(first - h) > 5e-4 * h:
            failures.append(f"{name}: first step {first} s, the rule gives {h:.6g} s")
        if cut_at_start:
            failures.append(f"{name}: cut back at t = 0: {cut_at_start[0].strip()}")
        print(f"{name}: auto step {first:.4g} s (rule {h:.4g} s), {len(steps)} steps, "
              f"{len(cut_at_start)} cut-backs at t = 0")
    if cases < 10:
        failures.append(f"only {cases} implicit cases found in inputs/")

    # No time scale: zero gravity and nothing moving.
    still = yaml.safe_load(open(os.path.join(source, "inputs", "elastic_column.yaml")))
    still["gravity"] = [0.0, 0.0]
    still["time"]["step"] = "auto"
    still["output"] = {"enabled": False}
    file = os.path.join(work, "still.yaml")
    with open(file, "w") as f:
        yaml.safe_dump(still, f)
    check = subprocess.run([talus, "check", file], capture_output=True, text=True, timeout=60)
    if check.returncode != 2 or "time.step" not in check.stderr or "auto" not in check.stderr:
        failures.append(f"no time scale: expected exit 2 naming time.step, got {check.returncode}: "
                        f"{check.stderr.strip()}")

    # No gravity, a body thrown at 2 m/s: the courant term alone, 0.5 cell / v0.
    thrown = yaml.safe_load(open(os.path.join(source, "inputs", "elastic_column.yaml")))
    thrown["gravity"] = [0.0, 0.0]
    thrown["bodies"][0]["velocity"] = [1.2, -1.6]
    thrown["time"]["step"] = "auto"
    h = 0.5 * float(thrown["grid"]["cell_size"]) / 2.0
    thrown["time"]["end"] = 2 * h
    thrown["output"] = {"enabled": False}
    thrown.pop("checkpoint", None)
    file = os.path.join(work, "thrown.yaml")
    with open(file, "w") as f:
        yaml.safe_dump(thrown, f)
    run = subprocess.run([talus, "run", file], capture_output=True, text=True, timeout=60)
    steps = [line.split() for line in run.stdout.splitlines() if line.startswith("step ")]
    if run.returncode != 0 or not steps or abs(float(steps[0][5]) - h) > 5e-4 * h:
        failures.append(f"thrown body: expected a first step of {h} s, got rc {run.returncode}, "
                        f"{steps[0] if steps else run.stderr.strip()}")
    else:
        print(f"thrown body: auto step {steps[0][5]} s (rule {h} s)")

for f in failures:
    print("FAIL", f)
sys.exit(1 if failures else 0)
