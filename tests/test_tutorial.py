#!/usr/bin/python3
"""The commands of docs/tutorial.md that make the particle files, and `talus check`
on the tutorial's cases (issue 15 item 9).

1. Every `/usr/bin/python3 scripts/fill_between_surfaces.py ...` line of
   docs/tutorial.md is run, as written, from a scratch copy of the repository
   root (scripts/ and inputs/); each must write, row for row, the committed
   particle file it names (inputs/particles/tutorial_*.csv).
2. The particles' total volume (their `volume` column summed) equals the
   area (2D) or volume (3D) between the two surfaces, computed here
   independently of the script: exactly between the two piecewise-linear
   profiles, and exactly between the two height maps triangulated as the
   terrain obstacle triangulates them (each cell split into (00, 10, 11) and
   (00, 11, 01), docs/case_file.md#terrain-files). Tolerance 0.5 % in 2D
   (a lattice of 0.05 m on a 0.8 m thick mass; measured 0.17 %: 1.4375
   against 1.43998 m^2) and 1.5 % in 3D (a 0.1 m lattice on a lens up to 0.5 m
   thick on a 0.2 m map; measured 0.80 %: 0.196 against 0.194452 m^3). The
   total printed by the script must be the same sum.
3. Every `./build/talus check inputs/tutorial_*.yaml` line of the tutorial is
   run (with this build's talus) and prints what the tutorial shows.
4. The case files shown on the page (from `grid:` on) are the files in inputs/.

usage: test_tutorial.py TALUS_BINARY SOURCE_DIR
"""
import atexit
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile

# Open MPI 4 creates and removes /tmp/ompi.<host>.<uid> at every singleton
# start, and starts that overlap another test's race on it ("orte_init
# failed", exit code 1; docs/testing.md): this test's talus runs get a
# session directory of their own.
_ompi_sessions = tempfile.mkdtemp(prefix="ompi.")
os.environ["OMPI_MCA_orte_tmpdir_base"] = _ompi_sessions
atexit.register(shutil.rmtree, _ompi_sessions, True)

talus, source = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
doc = open(os.path.join(source, "docs", "tutorial.md"), encoding="utf-8").read()
failures = []


def fail(message):
    failures.append(message)
    print("FAIL: " + message)


def data_rows(path):
    return [line for line in open(path) if line.strip() and not line.lstrip().startswith("#")]


def read_profile(path):
    points = []
    for line in open(path):
        fields = line.split("#", 1)[0].replace(",", " ").split()
        if fields:
            points.append((float(fields[0]), float(fields[1])))
    return points


def area_between(lower, upper):
    """Exact area between two piecewise-linear profiles where upper > lower, over their common x range."""
    def at(points, x):
        for (x0, z0), (x1, z1) in zip(points, points[1:]):
            if x0 <= x <= x1:
                return z0 + (z1 - z0) * (x - x0) / (x1 - x0)
        raise ValueError(x)
    lo, hi = max(lower[0][0], upper[0][0]), min(lower[-1][0], upper[-1][0])
    xs = sorted({lo, hi} | {x for x, _ in lower + upper if lo < x < hi})
    area = 0.0
    for a, b in zip(xs, xs[1:]):
        d0, d1 = at(upper, a) - at(lower, a), at(upper, b) - at(lower, b)
        if d0 >= 0 and d1 >= 0:
            area += 0.5 * (d0 + d1) * (b - a)
        elif d0 > 0 or d1 > 0:  # the positive part of a line crossing zero
            pos = max(d0, d1)
            area += 0.5 * pos * (b - a) * pos / (abs(d0) + abs(d1))
    return area


def read_map(path):
    header, rows = {}, []
    for line in open(path):
        fields = line.split()
        if not fields:
            continue
        if fields[0][0].isalpha():
            header[fields[0].lower()] = float(fields[1])
        else:
            rows.append([float(v) for v in fields])
    return header, rows[::-1]  # south row first


def volume_between(lower_path, upper_path):
    """Exact volume between two height maps of the same header, each cell split into two triangles."""
    (h1, low), (h2, up) = read_map(lower_path), read_map(upper_path)
    if h1 != h2:
        raise ValueError("the tutorial's maps share one header")
    s = h1["cellsize"]
    t = [[u - l for u, l in zip(ru, rl)] for ru, rl in zip(up, low)]
    if min(min(r) for r in t) < -1e-12:
        raise ValueError("the upper map dips below the lower one (not handled here)")
    volume = 0.0
    for j in range(len(t) - 1):
        for i in range(len(t[0]) - 1):
            t00, t10, t01, t11 = t[j][i], t[j][i + 1], t[j + 1][i], t[j + 1][i + 1]
            volume += 0.5 * s * s * ((t00 + t10 + t11) / 3 + (t00 + t11 + t01) / 3)
    return volume


with tempfile.TemporaryDirectory() as work:
    # A scratch repository root: the scripts, and the tutorial's inputs (the
    # commands overwrite the particle files there, not in the source tree).
    os.symlink(os.path.join(source, "scripts"), os.path.join(work, "scripts"))
    shutil.copytree(os.path.join(source, "inputs"), os.path.join(work, "inputs"),
                    ignore=lambda d, names: [n for n in names if n.endswith(".csv")])

    fills = re.findall(r"^ *(/usr/bin/python3 scripts/fill_between_surfaces\.py [^\n]*)$", doc, re.M)
    if len(fills) != 2:
        fail(f"expected 2 fill_between_surfaces.py commands (2D and 3D) in docs/tutorial.md, found {len(fills)}")
    for command in fills:
        args = shlex.split(command)
        out = args[args.index("--out") + 1]
        spacing = float(args[args.index("--spacing") + 1])
        lower, upper = args[2], args[3]
        run = subprocess.run(args, cwd=work, capture_output=True, text=True, timeout=60)
        print(f"{command}\n  {run.stdout.strip()} {run.stderr.strip()}")
        if run.returncode != 0:
            fail(f"{command}: exit {run.returncode}")
            continue
        if not os.path.basename(out).startswith("tutorial_"):
            fail(f"{out}: the tutorial's files are named tutorial_*")
        committed = os.path.join(source, out)
        if not os.path.exists(committed) or data_rows(os.path.join(work, out)) != data_rows(committed):
            fail(f"{command} does not reproduce the committed {out}")
        rows = data_rows(os.path.join(work, out))
        columns = [c.strip() for c in rows[0].split(",")]
        volumes = [float(r.split(",")[columns.index("volume")]) for r in rows[1:]]
        total = sum(volumes)
        three_d = lower.endswith(".asc")
        if three_d:
            exact = volume_between(os.path.join(work, lower), os.path.join(work, upper))
            tolerance, what = 0.015, "volume"
        else:
            exact = area_between(read_profile(os.path.join(work, lower)), read_profile(os.path.join(work, upper)))
            tolerance, what = 0.005, "area"
        error = abs(total - exact) / exact
        print(f"  {len(volumes)} particles of {spacing ** (3 if three_d else 2):g}: {what} {total:.6g}, "
              f"between the surfaces {exact:.6g}, relative error {error:.2e} (tolerance {tolerance:g})")
        if error > tolerance:
            fail(f"{out}: particle {what} {total:.6g} differs from the {what} between the surfaces "
                 f"{exact:.6g} by {error:.2%} (> {tolerance:.1%})")
        if any(abs(v - spacing ** (3 if three_d else 2)) > 1e-15 for v in volumes):
            fail(f"{out}: a particle volume is not spacing^dim")
        printed = re.search(r"(\d+) particles, \w+ ([\d.e+-]+) m\^", run.stdout)
        if not printed or int(printed.group(1)) != len(volumes) or \
                abs(float(printed.group(2)) - total) > 1e-5 * total:
            fail(f"{command}: prints '{run.stdout.strip()}', the file holds {len(volumes)} particles, {total:.6g}")

    # talus check, as the tutorial runs it, and the line it shows.
    checks = re.findall(r"^ *\./build/talus check (inputs/tutorial_\w+\.yaml)$", doc, re.M)
    if sorted(set(checks)) != ["inputs/tutorial_landslide_2d.yaml", "inputs/tutorial_landslide_3d.yaml"]:
        fail(f"docs/tutorial.md should run talus check on both tutorial cases, found {checks}")
    for case in sorted(set(checks)):
        run = subprocess.run([talus, "check", case], cwd=work, capture_output=True, text=True, timeout=60)
        line = run.stdout.strip()
        print(f"talus check {case}: {line} {run.stderr.strip()}")
        if run.returncode != 0:
            fail(f"talus check {case}: exit {run.returncode}: {run.stderr.strip()}")
        elif "    " + line not in doc and "\n" + line not in doc:
            fail(f"talus check {case} prints '{line}', which docs/tutorial.md does not show")

for case in ("inputs/tutorial_landslide_2d.yaml", "inputs/tutorial_landslide_3d.yaml"):
    text = open(os.path.join(source, case)).read()
    body = text[text.index("\ngrid:") + 1:]
    if "```yaml\n" + body + "```" not in doc:
        fail(f"docs/tutorial.md does not show {case} as it is (from grid: on)")

if failures:
    print(f"{len(failures)} failure(s)")
    sys.exit(1)
print("tutorial: ok")
