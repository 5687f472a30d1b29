#!/usr/bin/python3
"""Solver choices side by side on the reference column (issue 11).

Runs inputs/reference_column_<floor>.yaml (or any case given with --case)
once per solver configuration and round, the configurations interleaved
within each round, and prints per configuration the median CPU time
(user + sys of the talus process), the steps, cut-backs, Newton and Krylov
iterations and factorizations (identical in every round on one rank), and
the deposit of the final output: L_99 (the x below which 99 % of the mass
lies) and the wall height (the top of the particles within 1 cm of the left
wall), both + half a particle spacing, as in docs/benchmarks.md, and the
wall height as the deposit's mean height over the 2 cm next to the wall
(its volume there / 2 cm), which does not move in steps of a particle.

    /usr/bin/python3 scripts/bench_solvers.py                          # both floors, ILU default against LU, 3 rounds
    /usr/bin/python3 scripts/bench_solvers.py --floors frictional --end 0.3 --rounds 1
    /usr/bin/python3 scripts/bench_solvers.py --solver default= --solver lu="-talus_pc_type lu"
    /usr/bin/python3 scripts/bench_solvers.py --case inputs/landslide_3d_terrain.yaml --end 0.5 --no-deposit
    /usr/bin/python3 scripts/bench_solvers.py --solver default= --solver noghost=@ghost_penalty=0

A configuration's words of the form @key=value are keys of the case file's
`solver:` section (docs/case_file.md#solver-optional) rather than PETSc
options; the case must not have a `solver:` section of its own then. A word
%PATH runs that configuration with the talus binary PATH (an older build, for
a before/after comparison in the same interleaved rounds):

    /usr/bin/python3 scripts/bench_solvers.py --solver before=%/tmp/old/build/talus --solver after=

Time it alone: other jobs on the machine change the CPU times.
"""
import argparse
import json
import os
import re
import shlex
import statistics
import subprocess
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "scripts"))
from pvd import pvd_series, read_particles  # noqa: E402


def cpu_of(cmd):
    """(user + sys CPU seconds of the child, its stdout); exits on failure."""
    before = os.times()
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    after = os.times()
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed with exit code {p.returncode}:\n{p.stderr[-2000:]}")
    return (after.children_user - before.children_user) + (after.children_system - before.children_system), p.stdout


def deposit(pvd_path, spacing, wall_x=0.0, wall_band=0.01):
    """(L_99, wall height) of the last output of a 2D run."""
    import numpy as np
    _, path = pvd_series(pvd_path)[-1]
    x, (m,) = read_particles(path, ["mass"])
    m = m if m is not None else np.ones(x.shape[0])
    order = np.argsort(x[:, 0], kind="stable")
    cumulative = np.cumsum(m[order]) / m.sum()
    k = min(int(np.searchsorted(cumulative, 0.99 - 1e-12)), x.shape[0] - 1)
    near_wall = x[:, 0] <= wall_x + wall_band
    return float(x[order[k], 0]) + 0.5 * spacing, float(x[near_wall, 1].max()) + 0.5 * spacing


def wall_strip_height(pvd_path, width=0.02, wall_x=0.0):
    """The deposit's mean height over the `width` next to the left wall of
    the last output of a 2D run: the particles' (current) volume there per
    unit width. Unlike the top particle within 1 cm (deposit()), which moves
    in steps of a particle spacing (5 mm, 2.2 % of the reference column's
    wall height), it varies continuously with the deposit."""
    _, path = pvd_series(pvd_path)[-1]
    x, (volume,) = read_particles(path, ["volume"])
    return float(volume[x[:, 0] < wall_x + width].sum()) / width


def write_case(src, work, label, end, step, solver_keys=None):
    with open(src) as f:
        text = f.read()
    if solver_keys:
        if re.search(r"(?m)^solver:", text):
            sys.exit(f"{src} has a solver: section; @key=value configurations need a case without one")
        text += "\nsolver: {" + ", ".join(f"{k}: {v}" for k, v in solver_keys.items()) + "}\n"
    out = os.path.join(work, label)
    text = re.sub(r"(?m)^(\s*directory:).*$", rf"\1 {out}", text)
    if end is not None:
        text = re.sub(r"(?m)^(\s*end:).*$", rf"\1 {end}", text, count=1)
    if step is not None:
        text = re.sub(r"(?m)^(\s*step:).*$", rf"\1 {step}", text, count=1)
    # Relative file paths in the case (terrain, particles) stay valid: the
    # case is written beside the original.
    case = os.path.join(os.path.dirname(src), f".bench_solvers_{label}.yaml")
    with open(case, "w") as f:
        f.write(text)
    return case, os.path.join(out, "particles.pvd")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--talus", default=os.path.join(REPO, "build", "talus"))
    ap.add_argument("--floors", default="frictional,smooth", help="reference column floors")
    ap.add_argument("--case", help="another case file instead of the reference column")
    ap.add_argument("--end", type=float, help="time.end (default: the case's)")
    ap.add_argument("--step", type=float, help="time.step (default: the case's)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--solver", action="append", metavar="NAME=OPTS",
                    help="a configuration: name and PETSc options (repeatable); "
                         "default: default= and lu='-talus_pc_type lu'")
    ap.add_argument("--no-deposit", action="store_true", help="skip L_99 and the wall height (3D cases)")
    ap.add_argument("--spacing", type=float, default=0.005, help="particle spacing for the deposit (m)")
    ap.add_argument("--out", default=os.path.join(REPO, "bench_results", "solvers"))
    args = ap.parse_args()

    solvers = args.solver or ["default=", "lu=-talus_pc_type lu"]
    configs = []
    for s in solvers:
        name, _, opts = s.partition("=")
        words = shlex.split(opts)
        keys = dict(w[1:].split("=", 1) for w in words if w.startswith("@"))
        binary = next((w[1:] for w in words if w.startswith("%")), args.talus)
        configs.append((name, [w for w in words if w[0] not in "@%"], keys, binary))
    cases = [(os.path.splitext(os.path.basename(args.case))[0], os.path.abspath(args.case))] if args.case else [
        (f"reference_column_{f}", os.path.join(REPO, "inputs", f"reference_column_{f}.yaml"))
        for f in args.floors.split(",")]
    os.makedirs(args.out, exist_ok=True)
    results = {}
    written = []
    try:
        for rnd in range(args.rounds):
            for case_name, src in cases:
                for name, opts, keys, binary in configs:
                    label = f"{case_name}_{name}"
                    case, pvd = write_case(src, args.out, label, args.end, args.step, keys)
                    written.append(case)
                    cpu, stdout = cpu_of([binary, "run", case, "--overwrite"] + opts)
                    summary = json.loads(stdout.split("talus-summary:", 1)[1].splitlines()[0])
                    row = results.setdefault((case_name, name), {"cpu": [], "summary": summary, "pvd": pvd})
                    row["cpu"].append(cpu)
                    print(f"round {rnd + 1}: {label}: {cpu:.2f} s CPU", flush=True)
    finally:
        for c in set(written):
            if os.path.exists(c):
                os.remove(c)

    header = ("case", "solver", "CPU s (median)", "range", "steps", "cut-backs", "Newton", "Newton/step",
              "Krylov", "factorizations", "L_99 m", "wall height m", "wall height, 2 cm strip m")
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for (case_name, name), row in results.items():
        s = row["summary"]
        l99 = wall = strip = "-"
        if not args.no_deposit and s.get("dim") == 2:
            a, b = deposit(row["pvd"], args.spacing)
            l99, wall, strip = f"{a:.4f}", f"{b:.4f}", f"{wall_strip_height(row['pvd']):.4f}"
        cpu = row["cpu"]
        lines.append("| " + " | ".join(str(v) for v in (
            case_name, name, f"{statistics.median(cpu):.2f}", f"{min(cpu):.2f}-{max(cpu):.2f}", s["steps"],
            s["cutbacks"], s["newton_iterations"], f"{s['newton_iterations'] / max(s['steps'], 1):.2f}",
            s["linear_iterations"], s.get("factorizations", "-"), l99, wall, strip)) + " |")
    text = "\n".join(lines)
    print(text)
    with open(os.path.join(args.out, "bench_solvers.md"), "w") as f:
        f.write(text + "\n")


if __name__ == "__main__":
    main()
