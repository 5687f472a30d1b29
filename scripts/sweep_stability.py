#!/usr/bin/python3
"""Numerical stability under stress (issue 12, item 5): a sweep of small
collapsing columns over cell size x step (from the explicit limit to 100
times it) x dilatancy x friction angle x stiffness x model x floor, with the
implicit step, plus the explicit integrator at its CFL step on every
material; prints one row per run (ended / cut back / failed, steps against
nominal, Newton iterations per step, the energy balance's closing error
relative to the energy that moved) and a summary of the failure classes.
Every failed run keeps its case file in the output directory to reproduce.

The column: 0.2 m wide, 0.4 m high, against the left wall of a 1 m x 0.5 m
box, 0.3 s of collapse, 2 x 2 particles per cell; its free surface gives
the grid points with little mass at the edge of a body. The runs are a
seeded random sample of the full grid of combinations (--runs, default 120;
--seed), so repeated sweeps look at other corners.

    /usr/bin/python3 scripts/sweep_stability.py                    # 140 runs, about 5 minutes
    /usr/bin/python3 scripts/sweep_stability.py --runs 20 --seed 3

A run that ends with exit code 0 and a closing error below 1e-6 of the
energy that moved is "ok"; "cut back" means it ended with cut-backs; a
non-zero exit code is "failed" (exit 3: Newton gave up, the smallest step
did not converge; anything else, a crash or NaN, is a defect to fix).
"""
import argparse
import csv
import itertools
import json
import math
import os
import random
import shutil
import subprocess
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "scripts"))
from bench_common import markdown_lines, table_lines  # noqa: E402

CELLS = (0.05, 0.025)
STEP_FACTORS = (1, 10, 100)         # times the explicit limit
DILATANCY = ("0", "half", "phi")    # psi = 0, phi / 2, phi
FRICTION = (30.0, 45.0)
STIFFNESS = (1e5, 1e7, 1e9)
MODELS = ("drucker_prager", "mohr_coulomb")
FLOORS = ("fixed", "coulomb")
END, RHO, NU = 0.3, 1800.0, 0.3


def explicit_limit(cell, E):
    """docs/explicit.md: 2 dx / (c_p sqrt(dim s)), quadratic B-splines (s = 3), 2D."""
    c = math.sqrt(E * (1 - NU) / ((1 + NU) * (1 - 2 * NU)) / RHO)
    return 2 * cell / (c * math.sqrt(2 * 3.0))


def case_text(out, cell, step, integrator, psi, phi, E, model, floor):
    dil = {"0": 0.0, "half": phi / 2, "phi": phi}[psi]
    floor_text = "fixed" if floor == "fixed" else "{condition: frictional, friction: 0.4}"
    time = (f"{{end: {END}, step: {step:.6g}}}" if integrator == "implicit"
            else f"{{end: {END}, integrator: explicit}}")
    return (f"grid: {{lower: [0, 0], upper: [1.0, 0.5], cell_size: {cell}}}\n"
            f"time: {time}\n"
            f"output: {{directory: {out}, interval: {END}}}\n"
            f"checkpoint: {{enabled: false}}\n"
            f"gravity: [0, -9.81]\n"
            f"materials: [{{name: soil, model: {model}, density: {RHO}, youngs_modulus: {E:g}, poisson_ratio: {NU},\n"
            f"             friction_angle: {phi}, dilatancy_angle: {dil}, cohesion: 100}}]\n"
            f"bodies: [{{name: column, material: soil, box: {{lower: [0, 0], upper: [0.2, 0.4]}}}}]\n"
            f"boundaries: {{x_min: slip, x_max: slip, y_min: {floor_text}, y_max: slip}}\n")


def energy_error(out):
    """Largest |balance_error| over the run relative to the energy that moved."""
    path = os.path.join(out, "energy.csv")
    if not os.path.exists(path):
        return float("nan")
    worst, moved, first = 0.0, 0.0, None
    with open(path) as f:
        for row in csv.DictReader(f):
            row = {k.split(" [")[0]: v for k, v in row.items()}  # names without their units
            k, g, e = float(row["kinetic"]), float(row["gravitational"]), float(row["elastic"])
            if first is None:
                first = k + g + e
            worst = max(worst, abs(float(row["balance_error"])))
            moved = max(moved, k + e + abs(k + g + e - first))
    return worst / moved if moved > 0 else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--talus", default=os.path.join(REPO, "build", "talus"))
    ap.add_argument("--runs", type=int, default=120)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", default=os.path.join(REPO, "bench_results", "stability"))
    ap.add_argument("--timeout", type=float, default=600)
    args = ap.parse_args()
    combos = list(itertools.product(CELLS, STEP_FACTORS, DILATANCY, FRICTION, STIFFNESS, MODELS, FLOORS))
    rng = random.Random(args.seed)
    implicit = rng.sample(combos, min(args.runs, len(combos)))
    # The explicit integrator on every material and floor at the finer cell
    # (the step is its own: the factor does not apply).
    explicit = [(0.025, None, psi, phi, E, model, floor)
                for psi, phi, E, model, floor in itertools.product(DILATANCY, FRICTION, STIFFNESS, MODELS, FLOORS)
                if E <= 1e7 and psi != "half"]
    explicit = rng.sample(explicit, min(len(explicit), max(1, args.runs // 6)))
    runs = [("implicit",) + c for c in implicit] + [("explicit",) + c for c in explicit]
    os.makedirs(args.out, exist_ok=True)
    rows = []
    for n, (integrator, cell, factor, psi, phi, E, model, floor) in enumerate(runs):
        limit = explicit_limit(cell, E)
        step = min(factor * limit, END / 10) if factor else limit
        label = f"run{n:03d}"
        out = os.path.join(args.out, label)
        shutil.rmtree(out, ignore_errors=True)
        case = os.path.join(args.out, label + ".yaml")
        with open(case, "w") as f:
            f.write(case_text(out, cell, step, integrator, psi, phi, E, model, floor))
        try:
            p = subprocess.run([args.talus, "run", case, "--overwrite"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               timeout=args.timeout)
            code, stdout, stderr = p.returncode, p.stdout, p.stderr
        except subprocess.TimeoutExpired:
            code, stdout, stderr = "timeout", "", ""
        summary = {}
        if "talus-summary:" in stdout:
            summary = json.loads(stdout.split("talus-summary:", 1)[1].splitlines()[0])
        steps, cut = summary.get("steps", 0), summary.get("cutbacks", 0)
        err = energy_error(out)
        if code == 0:
            verdict = "ok" if cut == 0 else "cut back"
            if not (err < 1e-6):
                verdict += ", energy"
        else:
            verdict = f"failed ({code})"
        nominal = math.ceil(END / step - 1e-9)
        message = (stderr.strip().splitlines() or [""])[-1][:120]
        rows.append({"run": label, "integrator": integrator, "cell": cell, "step": step, "x limit": factor or "cfl 0.5",
                     "psi": psi, "phi": phi, "E": E, "model": model, "floor": floor, "verdict": verdict,
                     "steps/nominal": f"{steps}/{nominal}" if integrator == "implicit" else f"{steps}",
                     "cut-backs": cut,
                     "Newton/step": summary.get("newton_iterations", 0) / steps if steps else float("nan"),
                     "energy error": err, "message": message if code != 0 else ""})
        print(f"{label} {integrator:8s} cell {cell} h {step:.2e} psi {psi:4s} phi {phi:g} E {E:g} {model:14s} "
              f"{floor:7s}: {verdict}, {steps} steps, {cut} cut-backs, energy {err:.1e}", flush=True)
        if verdict in ("ok", "cut back"):
            shutil.rmtree(out, ignore_errors=True)  # keep only what reproduces a failure
            os.remove(case)
    columns = [(k, k, f) for k, f in (("run", "{}"), ("integrator", "{}"), ("cell", "{}"), ("step", "{:.2e}"),
                                      ("x limit", "{}"), ("psi", "{}"), ("phi", "{:g}"), ("E", "{:g}"),
                                      ("model", "{}"), ("floor", "{}"), ("verdict", "{}"), ("steps/nominal", "{}"),
                                      ("cut-backs", "{}"), ("Newton/step", "{:.1f}"), ("energy error", "{:.1e}"),
                                      ("message", "{}"))]
    print()
    print("\n".join(table_lines(rows, columns)))
    print()
    print("\n".join(markdown_lines(rows, columns, text_columns=2)))
    counts = {}
    for r in rows:
        counts[r["verdict"]] = counts.get(r["verdict"], 0) + 1
    print("\nsummary: " + ", ".join(f"{v}: {n}" for v, n in sorted(counts.items())) + f" of {len(rows)} runs")
    failed = [r for r in rows if r["verdict"] not in ("ok", "cut back")]
    for r in failed:
        print(f"  {r['run']}: {r['verdict']} {r['message']} (case {os.path.join(args.out, r['run'] + '.yaml')})")
    return 1 if any(not r["verdict"].startswith(("ok", "cut back", "failed (3)")) for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
