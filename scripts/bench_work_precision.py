#!/usr/bin/python3
"""Run time against error (issue 12, item 2): talus implicit and talus
explicit (time.integrator: explicit, docs/explicit.md) on cases with a known
answer, at several grids and steps; prints a table of CPU time (user + sys
of the run) and error, and writes a log-log plot of error against CPU time.

Studies (--studies):

  bar     The elastic vibrating bar (docs/explicit.md#verification): a 1 m bar
          fixed at x = 0, free at x = 1, E = 100 Pa, rho = 1, nu = 0, slip
          walls above and below (exactly 1D), initial velocity
          v0 sin(pi x / 2) with v0 = 1e-3 m/s (strain 1e-4, the linear
          solution holds), given in a particle file. Error: the largest
          |v_cm(t) - (2 v0 / pi) cos(omega t)| over one period, sampled at
          64 outputs, relative to 2 v0 / pi; the explicit velocities are
          compared at t - h/2 (leapfrog). Implicit: theta = 1/2 at
          h = 0.5, 2 and 8 dx / c; explicit: cfl 0.5 of its limit.
  column  The reference column on the mu = 0.4 floor
          (inputs/reference_column_frictional.yaml, 1 s). Error: the
          deposit's run-out L_99 and wall height against a reference run
          (explicit at cfl 0.125, about 27,000 steps), |dL| + |dH| in m.
          Implicit with theta = 1 (the default) at nominal 5e-3, 2.5e-3,
          1.25e-3, 6.25e-4 and 1.5625e-4 s, with theta = 1/2 at 5e-3, 2.5e-3
          and 1.25e-3 s; explicit at cfl 1, 0.5 and 0.25.

  incline An elastic block (0.4 x 0.2 m, E = 2e7 Pa, nu = 0.3, rho = 2000)
          sliding on a Coulomb incline: the grid aligned with a 30-degree
          slope (gravity tilted), the floor a frictional face with mu = 0.3,
          1 s from rest. Error: |d(1 s) - 0.5 a| / (0.5 a), d the slide of
          the block's centre of mass (bodies.csv), a = g (sin 30 - mu cos 30)
          = 2.356 m/s^2. Implicit theta = 1 at h = 0.04, 0.02, 0.01, 0.005
          and 0.0025 s (backward Euler: error h / t), theta = 1/2 at 0.04
          and 0.01 s (exact for a constant acceleration); explicit at cfl
          0.5; cells 0.1, 0.05 and 0.025 m.

  settle  An elastic column settling under its own weight between slip walls
          on a fixed floor (0.5 m wide, 1 m high, E = 1 MPa, nu = 0.3,
          rho = 2000; uniaxial strain, so the exact Cauchy stress is
          sigma_yy = -rho g (H - Y) in the original height Y). Error: the RMS
          of sigma_yy - exact over the particles at t = 2 s, relative to
          rho g H. Implicit theta = 1 with 4, 8 and 32 steps; explicit at cfl 0.5
          (it has no damping: the column keeps ringing); cells 0.1, 0.05, 0.025 m.
          The case where a quasi-static answer is wanted.

One run per configuration (the errors are deterministic; the CPU times are
single runs, so differences under about 10 % are noise). Run it alone on the
machine. Needs Debian's python3-vtk9 and python3-matplotlib:

    /usr/bin/python3 scripts/bench_work_precision.py                 # all four studies, ~14 min
    /usr/bin/python3 scripts/bench_work_precision.py --studies bar   # ~1 min
    /usr/bin/python3 scripts/bench_work_precision.py --studies settle # ~1 min
    /usr/bin/python3 scripts/bench_work_precision.py --studies incline # ~2 min
"""
import argparse
import math
import os
import shutil
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "scripts"))
from bench_common import markdown_lines, run_talus_case, table_lines  # noqa: E402
from bench_solvers import deposit  # noqa: E402
from pvd import pvd_series, read_particles  # noqa: E402


def read_output(path, names):
    return read_particles(path, names)[1]


# --- the vibrating bar --------------------------------------------------------

BAR_L, BAR_E, BAR_RHO, BAR_V0 = 1.0, 100.0, 1.0, 1e-3


def bar_case(work, label, cells, integrator, h):
    """Writes the bar's particle file and case; returns the case path."""
    dx = BAR_L / cells
    c = math.sqrt(BAR_E / BAR_RHO)
    beta = math.pi / (2 * BAR_L)
    period = 2 * math.pi / (beta * c)
    d = os.path.join(work, label)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    spacing = dx / 2  # 2 x 2 particles per cell
    with open(os.path.join(d, "bar.csv"), "w") as f:
        f.write("x, y, volume, vx, vy\n")
        for i in range(round(BAR_L / spacing)):
            x = (i + 0.5) * spacing
            for j in range(round(3 * dx / spacing)):
                f.write(f"{x:.17g} {(j + 0.5) * spacing:.17g} {spacing * spacing:.17g} "
                        f"{BAR_V0 * math.sin(beta * x):.17g} 0\n")
    time = f"end: {period:.17g}, step: {h:.17g}" + (", integrator: explicit" if integrator == "explicit"
                                                     else ", theta: 0.5")
    case = os.path.join(d, "bar.yaml")
    with open(case, "w") as f:
        f.write(f"grid: {{lower: [0, 0], upper: [{1.25 * BAR_L:.17g}, {3 * dx:.17g}], cell_size: {dx:.17g}}}\n"
                f"time: {{{time}}}\n"
                f"output: {{directory: {os.path.join(d, 'out')}, interval: {period / 64:.17g}}}\n"
                f"materials: [{{name: bar, model: linear_elastic, density: {BAR_RHO}, youngs_modulus: {BAR_E}, "
                f"poisson_ratio: 0}}]\n"
                f"bodies: [{{name: bar, material: bar, particles: bar.csv}}]\n"
                f"boundaries: {{x_min: fixed, x_max: free, y_min: slip, y_max: slip}}\n")
    return case, period


def bar_error(case_dir, period, integrator, h):
    c = math.sqrt(BAR_E / BAR_RHO)
    omega = math.pi / (2 * BAR_L) * c
    scale = 2 * BAR_V0 / math.pi
    worst = 0.0
    for t, path in pvd_series(os.path.join(case_dir, "out", "particles.pvd")):
        v, m = read_output(path, ["velocity", "mass"])
        vcm = float((v[:, 0] * m).sum() / m.sum())
        te = t - 0.5 * h if integrator == "explicit" and t > 0 else t
        worst = max(worst, abs(vcm - scale * math.cos(omega * te)))
    return worst / scale


def bar_study(talus, work):
    rows = []
    c = math.sqrt(BAR_E / BAR_RHO)
    for cells in (16, 32, 64, 128):
        dx = BAR_L / cells
        # The explicit limit of docs/explicit.md in 2D: 2 dx / (c sqrt(2 * 3)).
        configs = [("explicit", 0.5 * 2 * dx / (c * math.sqrt(6.0)), "explicit, cfl 0.5")]
        configs += [("implicit", k * dx / c, f"implicit theta 1/2, h = {k:g} dx/c") for k in (0.5, 2, 8)]
        for integrator, h, name in configs:
            period = 2 * math.pi / (math.pi / (2 * BAR_L) * c)
            h = period / math.ceil(period / h)  # a whole number of steps per period
            label = f"bar_{cells}_{integrator}_{h:.3e}"
            case, period = bar_case(work, label, cells, integrator, h)
            cpu, s = run_talus_case(talus, case)
            err = bar_error(os.path.join(work, label), period, integrator, h)
            rows.append({"study": "bar", "config": name, "cells": cells, "h": h, "steps": s["steps"],
                         "newton": s["newton_iterations"], "cpu": cpu, "error": err})
            print(f"bar {cells:4d} cells, {name:32s} h {h:.3e}: {cpu:6.2f} s, error {err:.3e}", flush=True)
    return rows


# --- the reference column ----------------------------------------------------

def column_case(work, label, integrator, value):
    src = os.path.join(REPO, "inputs", "reference_column_frictional.yaml")
    with open(src) as f:
        text = f.read()
    out = os.path.join(work, label)
    shutil.rmtree(out, ignore_errors=True)
    lines = []
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("directory:"):
            line = line[: line.index("directory:")] + f"directory: {out}"
        elif stripped.startswith("step:"):
            indent = line[: line.index("step:")]
            line = indent + (f"step: {value[0]}\n{indent}theta: {value[1]}" if integrator == "implicit"
                             else f"integrator: explicit\n{indent}cfl: {value}")
        lines.append(line)
    case = os.path.join(work, label + ".yaml")
    with open(case, "w") as f:
        f.write("\n".join(lines) + "\n")
    return case, out


def column_study(talus, work):
    spacing = 0.005
    case, out = column_case(work, "column_reference", "explicit", 0.125)
    cpu, s = run_talus_case(talus, case)
    ref = deposit(os.path.join(out, "particles.pvd"), spacing)
    print(f"column reference (explicit, cfl 0.125): {cpu:.1f} s, {s['steps']} steps, "
          f"L_99 {ref[0]:.4f} m, wall height {ref[1]:.4f} m", flush=True)
    rows = [{"study": "column", "config": "reference: explicit, cfl 0.125", "cells": 100, "h": 1.0 / s["steps"],
             "steps": s["steps"], "newton": 0, "cpu": cpu, "error": float("nan"),
             "l99": ref[0], "wall": ref[1]}]
    configs = [("implicit", (h, 1.0), f"implicit theta 1, h = {h:g} s") for h in (0.005, 0.0025, 0.00125, 0.000625,
                                                                               0.00015625)]
    configs += [("implicit", (h, 0.5), f"implicit theta 1/2, h = {h:g} s") for h in (0.005, 0.0025, 0.00125)]
    configs += [("explicit", c, f"explicit, cfl {c:g}") for c in (1.0, 0.5, 0.25)]
    for integrator, value, name in configs:
        label = f"column_{integrator}_{value[0]:g}_{value[1]:g}" if integrator == "implicit" else f"column_explicit_{value:g}"
        case, out = column_case(work, label, integrator, value)
        cpu, s = run_talus_case(talus, case)
        l99, wall = deposit(os.path.join(out, "particles.pvd"), spacing)
        err = abs(l99 - ref[0]) + abs(wall - ref[1])
        rows.append({"study": "column", "config": name, "cells": 100, "h": 1.0 / s["steps"], "steps": s["steps"],
                     "newton": s["newton_iterations"], "cpu": cpu, "error": err, "l99": l99, "wall": wall})
        print(f"column {name:28s}: {cpu:6.1f} s, {s['steps']} steps, L_99 {l99:.4f}, wall {wall:.4f}, "
              f"error {err:.4f} m", flush=True)
    return rows


# --- the block on a Coulomb incline -----------------------------------------

INCLINE_DEG, INCLINE_MU, INCLINE_G, INCLINE_END = 30.0, 0.3, 9.81, 1.0


def incline_case(work, label, cell, integrator, h, weight=1.0):
    out = os.path.join(work, label)
    shutil.rmtree(out, ignore_errors=True)
    theta = math.radians(INCLINE_DEG)
    time = (f"{{end: {INCLINE_END}, step: {h:.17g}, theta: {weight}}}" if integrator == "implicit"
            else f"{{end: {INCLINE_END}, integrator: explicit}}")
    case = os.path.join(work, label + ".yaml")
    with open(case, "w") as f:
        f.write(f"grid: {{lower: [0, 0], upper: [3.0, 0.4], cell_size: {cell}}}\n"
                f"time: {time}\n"
                f"output: {{directory: {out}, interval: {INCLINE_END}}}\n"
                f"gravity: [{INCLINE_G * math.sin(theta):.17g}, {-INCLINE_G * math.cos(theta):.17g}]\n"
                f"materials: [{{name: rock, model: linear_elastic, density: 2000, youngs_modulus: 2.0e7, "
                f"poisson_ratio: 0.3}}]\n"
                f"bodies: [{{name: block, material: rock, box: {{lower: [0.1, 0.0], upper: [0.5, 0.2]}}}}]\n"
                f"boundaries: {{x_min: free, x_max: free, y_min: {{condition: frictional, friction: {INCLINE_MU}}}, "
                f"y_max: free}}\n")
    return case, out


def incline_error(out):
    import csv
    rows = list(csv.reader(open(os.path.join(out, "bodies.csv"))))
    first, last = rows[1], rows[-1]
    slide = float(last[1]) - float(first[1])
    theta = math.radians(INCLINE_DEG)
    exact = 0.5 * INCLINE_G * (math.sin(theta) - INCLINE_MU * math.cos(theta)) * INCLINE_END ** 2
    return abs(slide - exact) / exact


def incline_study(talus, work):
    rows = []
    for cell in (0.1, 0.05, 0.025):
        configs = ([("implicit", h, 1.0) for h in (0.04, 0.02, 0.01, 0.005, 0.0025)] +
                   [("implicit", h, 0.5) for h in (0.04, 0.01)] + [("explicit", None, None)])
        for integrator, h, weight in configs:
            name = f"implicit theta {weight:g}" if integrator == "implicit" else "explicit, cfl 0.5"
            label = f"incline_{cell:g}_{integrator}_{h}_{weight}"
            case, out = incline_case(work, label, cell, integrator, h, weight)
            cpu, s = run_talus_case(talus, case)
            err = incline_error(out)
            rows.append({"study": "incline", "config": f"{name}, cell {cell:g}", "cells": round(0.4 / cell),
                         "h": INCLINE_END / s["steps"], "steps": s["steps"], "newton": s["newton_iterations"],
                         "cpu": cpu, "error": err})
            print(f"incline cell {cell:g} {name:20s} h {INCLINE_END / s['steps']:.3e}: {cpu:6.2f} s, "
                  f"{s['steps']} steps, error {err:.3e}", flush=True)
    return rows


# --- the settling elastic column --------------------------------------------

SETTLE_H, SETTLE_RHO, SETTLE_G, SETTLE_END = 1.0, 2000.0, 9.81, 2.0


def settle_case(work, label, cell, integrator, steps):
    out = os.path.join(work, label)
    shutil.rmtree(out, ignore_errors=True)
    time = (f"{{end: {SETTLE_END}, step: {SETTLE_END / steps:.17g}}}" if integrator == "implicit"
            else f"{{end: {SETTLE_END}, integrator: explicit}}")
    case = os.path.join(work, label + ".yaml")
    with open(case, "w") as f:
        f.write(f"grid: {{lower: [0, 0], upper: [0.5, {2 * SETTLE_H}], cell_size: {cell}}}\n"
                f"time: {time}\n"
                f"output: {{directory: {out}, interval: {SETTLE_END}}}\n"
                f"gravity: [0, -{SETTLE_G}]\n"
                f"materials: [{{name: soil, model: linear_elastic, density: {SETTLE_RHO}, youngs_modulus: 1.0e6, "
                f"poisson_ratio: 0.3}}]\n"
                f"bodies: [{{name: column, material: soil, box: {{lower: [0, 0], upper: [0.5, {SETTLE_H}]}}}}]\n"
                f"boundaries: {{x_min: slip, x_max: slip, y_min: fixed, y_max: slip}}\n")
    return case, out


def settle_error(out):
    import numpy as np
    _, path = pvd_series(os.path.join(out, "particles.pvd"))[-1]
    x, (u, stress) = read_particles(path, ["displacement", "stress"])  # stress: xx, yy, zz, xy, yz, xz (Cauchy)
    Y = x[:, 1] - u[:, 1]
    exact = -SETTLE_RHO * SETTLE_G * (SETTLE_H - Y)
    return float(np.sqrt(np.mean((stress[:, 1] - exact) ** 2))) / (SETTLE_RHO * SETTLE_G * SETTLE_H)


def settle_study(talus, work):
    rows = []
    for cell in (0.1, 0.05, 0.025):
        for integrator, steps in (("implicit", 4), ("implicit", 8), ("implicit", 32), ("explicit", None)):
            name = f"implicit theta 1, {steps} steps" if integrator == "implicit" else "explicit, cfl 0.5"
            label = f"settle_{cell:g}_{integrator}_{steps}"
            case, out = settle_case(work, label, cell, integrator, steps)
            cpu, s = run_talus_case(talus, case)
            err = settle_error(out)
            rows.append({"study": "settle", "config": name, "cells": round(SETTLE_H / cell), "h": SETTLE_END / s["steps"],
                         "steps": s["steps"], "newton": s["newton_iterations"], "cpu": cpu, "error": err})
            print(f"settle cell {cell:g} {name:28s}: {cpu:6.2f} s, {s['steps']} steps, error {err:.3e}", flush=True)
    return rows


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    studies = sorted({r["study"] for r in rows})
    fig, axes = plt.subplots(1, len(studies), figsize=(6 * len(studies), 4.5), squeeze=False)
    for ax, study in zip(axes[0], studies):
        groups = {}
        for r in rows:
            if r["study"] == study and r["error"] == r["error"]:
                key = r["config"] if study in ("bar", "settle", "incline") else r["config"].split(", h")[0].split(", cfl")[0]
                groups.setdefault(key, []).append(r)
        for key, rs in sorted(groups.items()):
            rs.sort(key=lambda r: r["cpu"])
            ax.loglog([r["cpu"] for r in rs], [r["error"] for r in rs], "o-", label=key)
        ax.set_xlabel("CPU time (s)")
        ax.set_ylabel({"bar": "relative error of v_cm", "column": "|dL_99| + |dH_wall| (m)",
                       "settle": "RMS sigma_yy error / (rho g H)",
                       "incline": "relative error of the slide at 1 s"}[study])
        ax.set_title({"bar": "vibrating bar (16-128 cells)", "column": "reference column, mu = 0.4",
                      "settle": "elastic column settling, 10-40 cells high, t = 2 s",
                      "incline": "block on a 30-degree Coulomb incline, mu = 0.3"}[study])
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=80)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--talus", default=os.path.join(REPO, "build", "talus"))
    ap.add_argument("--studies", nargs="+", default=["bar", "settle", "incline", "column"],
                    choices=["bar", "settle", "incline", "column"])
    ap.add_argument("--out", default=os.path.join(REPO, "bench_results", "work_precision"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rows = []
    if "bar" in args.studies:
        rows += bar_study(args.talus, args.out)
    if "settle" in args.studies:
        rows += settle_study(args.talus, args.out)
    if "incline" in args.studies:
        rows += incline_study(args.talus, args.out)
    if "column" in args.studies:
        rows += column_study(args.talus, args.out)
    columns = [("study", "study", "{}"), ("config", "configuration", "{}"), ("cells", "cells", "{}"),
               ("h", "h s", "{:.3e}"), ("steps", "steps", "{}"), ("newton", "Newton", "{}"),
               ("cpu", "CPU s", "{:.2f}"), ("error", "error", "{:.3e}")]
    print()
    print("\n".join(table_lines(rows, columns)))
    print()
    print("\n".join(markdown_lines(rows, columns, text_columns=2)))
    png = os.path.join(args.out, "work_precision.png")
    plot(rows, png)
    print(f"\nplot: {png}")


if __name__ == "__main__":
    main()
