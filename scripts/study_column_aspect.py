#!/usr/bin/python3
"""Granular column collapse over aspect ratios: convergence and experiments
(issue 12 item 2, issue 13 item 3; a study, not a test).

A column of dry sand, width L_0 = 0.2 m against the left wall of a channel
and height H_0 = a L_0, collapses onto a rough horizontal floor. For every
aspect ratio a it runs talus at three grids (cell L_0/10, L_0/20, L_0/40,
2 x 2 particles per cell) and two steps (2.5e-3 and 1.25e-3 s), and reports
the final deposit:

    run-out    (L_f - L_0) / L_0,  L_f = L_99 + d/2: the x below which 99 %
               of the mass lies (the farthest particle is reported too)
    height     H_f / L_0,          H_f = max y + d/2 (at the wall)

with d the initial particle spacing (the edge of the outermost particle's
own square, as docs/benchmarks.md measures the reference column), the change
between the two finest grids and between the two steps, and the experimental
fits of Lube, Huppert, Sparks & Freundt (2005), Phys. Rev. E 72, 041301, for
quasi-2D collapses of sand in a channel onto a rough floor (approximately
(L_f - L_0)/L_0 = 1.2 a for a < 1.8 and 1.9 a^(2/3) for a > 2.8; H_f/L_0 = a
for a < 1.15 and a^(2/5) above).

The material and floor (docs/benchmarks.md#column-collapse-over-aspect-ratios
says why): Mohr-Coulomb phi = 30 deg, psi = 0, c = 0 (dry sand), E = 1 MPa,
nu = 0.3, rho = 1800 kg/m^3; the floor is a Coulomb contact face with
mu = tan(phi) (a rough bed, the grains' own friction); walls and lid slip.
Each run lasts 4.5 sqrt(H_0/g) (the experiments' motion stops by about
3 sqrt(H_0/g)), at least 1 s; the final kinetic energy is reported to show
the deposit has stopped.

    /usr/bin/python3 scripts/study_column_aspect.py                    # a = 0.5, 1, 2, 4, 8; about 40 min
    /usr/bin/python3 scripts/study_column_aspect.py --aspects 2 --levels 10,20
    /usr/bin/python3 scripts/study_column_aspect.py --replot           # table and plot from the kept output
    /usr/bin/python3 scripts/study_column_aspect.py --aspects 0.5,1 --levels 10,20,40,80 \
        --out bench_results/column_aspect_low                           # the low columns, one grid more
    /usr/bin/python3 scripts/study_column_aspect.py --replot --merge bench_results/column_aspect_low
    /usr/bin/python3 scripts/study_column_aspect.py --friction-angle 40 --levels 20 --steps 0.00125 \
        --out bench_results/column_aspect_phi40                         # the sensitivity to phi
    /usr/bin/python3 scripts/study_column_aspect.py --floor fixed --out bench_results/column_aspect_fixed
                                                                        # the no-slip floor
    /usr/bin/python3 scripts/study_column_aspect.py --quadrature domain --aspects 2 --levels 10,20,40 \
        --steps 0.00125 --out bench_results/column_aspect_domain        # domain quadrature
    /usr/bin/python3 scripts/study_column_aspect.py --floor fixed --aspects 8 --levels 10,20,40 \
        --steps 0.00125 --packing-correction 0.25 --out bench_results/column_aspect_packing
                                                                        # the packing correction
    /usr/bin/python3 scripts/study_column_aspect.py --floor fixed --aspects 8 --levels 10 \
        --steps 0.00125 --particles-per-cell 4 --out bench_results/column_aspect_ppc4

The table's `packing` is how densely the final deposit's particles sit
against their own volumes (scripts/particle_packing.py, boxes of 0.04 m;
1 is consistent; docs/transfers.md#packing).

Writes into OUT (default bench_results/column_aspect/, which git ignores):
the cases, the talus output, aspect.csv, aspect.md and aspect.png.
Needs Debian's python3-yaml, python3-vtk9 and python3-matplotlib.
"""

import argparse
import csv
import json
import math
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import markdown_lines, table_lines  # noqa: E402
from particle_packing import packing  # noqa: E402
from pvd import pvd_series, read_particles  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
L0 = 0.2
PPC = 2
PHI = 30.0  # the friction angle (deg); --friction-angle changes it, and the floor's mu = tan(phi) with it
QUADRATURE = "point"  # grid.quadrature; --quadrature domain (docs/grid.md#particle-quadrature)
FLOOR = "frictional"  # the floor: a Coulomb face with mu = tan(phi), or --floor fixed (no slip)
PACKING_CORRECTION = None  # transfer.packing_correction (docs/transfers.md#packing); None: talus's default
G = 9.81


def lube_runout(a):
    """Lube et al. (2005) fits, linear below 1.8, power above 2.8, and a
    straight line in log-log between (the transition)."""
    if a <= 1.8:
        return 1.2 * a
    if a >= 2.8:
        return 1.9 * a ** (2.0 / 3.0)
    lo, hi = math.log(1.2 * 1.8), math.log(1.9 * 2.8 ** (2.0 / 3.0))
    s = (math.log(a) - math.log(1.8)) / (math.log(2.8) - math.log(1.8))
    return math.exp(lo + s * (hi - lo))


def lube_height(a):
    return a if a <= 1.15 else a ** 0.4


def end_time(a):
    return max(1.0, 4.5 * math.sqrt(a * L0 / G))


def floor_text():
    if FLOOR == "fixed":
        return "fixed"
    return f"{{condition: frictional, friction: {math.tan(math.radians(PHI)):.6f}}}"


def case_text(a, cells_per_width, step, out):
    cell = L0 / cells_per_width
    h0 = a * L0
    length = L0 * (2.0 + 2.5 * lube_runout(a))
    # A whole number of cells in each direction.
    nx = math.ceil(length / cell)
    ny = math.ceil(h0 / cell) + 3
    end = end_time(a)
    return f"""# Column collapse a = {a}, cell L0/{cells_per_width}, step {step} s
# (scripts/study_column_aspect.py).
grid:
  lower: [0.0, 0.0]
  upper: [{nx * cell:.10g}, {ny * cell:.10g}]
  cell_size: {cell:.10g}
  quadrature: {QUADRATURE}
time:
  end: {end:.4f}
  step: {step}
output:
  directory: {out}
  interval: {end / 10:.6f}
gravity: [0.0, -{G}]
materials:
  - name: sand
    model: mohr_coulomb
    density: 1800.0
    youngs_modulus: 1.0e6
    poisson_ratio: 0.3
    friction_angle: {PHI}
    dilatancy_angle: 0.0
    cohesion: 0.0
bodies:
  - name: column
    material: sand
    box: {{lower: [0.0, 0.0], upper: [{L0}, {h0:.10g}]}}
    particles_per_cell: {PPC}
boundaries:
  x_min: slip
  x_max: slip
  y_min: {floor_text()}
  y_max: slip
""" + (f"transfer:\n  packing_correction: {PACKING_CORRECTION:g}\n" if PACKING_CORRECTION is not None else "")


def deposit(pvd_path, spacing):
    """(L_99 + d/2, farthest particle + d/2, max y + d/2, kinetic energy per
    unit thickness) of the last output."""
    import numpy as np
    _, path = pvd_series(pvd_path)[-1]
    x, (m, v) = read_particles(path, ["mass", "velocity"])
    order = np.argsort(x[:, 0], kind="stable")
    cumulative = np.cumsum(m[order]) / m.sum()
    k = min(int(np.searchsorted(cumulative, 0.99 - 1e-12)), x.shape[0] - 1)
    ke = 0.5 * float((m * (v ** 2).sum(axis=1)).sum())
    return (float(x[order[k], 0]) + 0.5 * spacing, float(x[:, 0].max()) + 0.5 * spacing,
            float(x[:, 1].max()) + 0.5 * spacing, ke)


COLUMNS = [
    ("a", "a", "{:g}"),
    ("cells", "cell", "L0/{:d}"),
    ("step", "h s", "{:g}"),
    ("particles", "particles", "{:d}"),
    ("cpu", "CPU s", "{:.1f}"),
    ("steps", "steps", "{:d}"),
    ("cutbacks", "cut-backs", "{:d}"),
    ("newton_per_step", "Newton/step", "{:.2f}"),
    ("runout", "(L_f-L0)/L0", "{:.3f}"),
    ("farthest", "farthest", "{:.3f}"),
    ("height", "H_f/L0", "{:.3f}"),
    ("ke_ratio", "KE end/peak pot.", "{:.1e}"),
    ("packing", "packing", "{:.2f}"),
    ("lube_runout", "Lube run-out", "{:.2f}"),
    ("lube_height", "Lube H_f/L0", "{:.2f}"),
]


def run_label(a, cells, step):
    """The run's name; particles per cell and the packing correction only
    where they are not the defaults (the names of earlier studies stay)."""
    return (f"a{a:g}_c{cells}_h{step:g}" + (f"_p{PPC}" if PPC != 2 else "")
            + (f"_k{PACKING_CORRECTION:g}" if PACKING_CORRECTION is not None else ""))


def run(args, a, cells, step):
    label = run_label(a, cells, step)
    out = os.path.join(args.out, label)
    case = os.path.join(args.out, label + ".yaml")
    with open(case, "w") as f:
        f.write(case_text(a, cells, step, out))
    before = os.times()
    p = subprocess.run([args.talus, "run", case, "--overwrite"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       text=True)
    after = os.times()
    with open(os.path.join(args.out, label + ".log"), "w") as f:
        f.write(p.stdout + p.stderr)
    if p.returncode != 0:
        print(f"{label}: exit {p.returncode}: {p.stderr[-500:]}", file=sys.stderr)
        return None
    summary = json.loads(p.stdout.split("talus-summary:", 1)[1].splitlines()[0])
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    return {"label": label, "a": a, "cells": cells, "step": step, "cpu": cpu, "particles": summary["particles"],
            "steps": summary["steps"], "cutbacks": summary["cutbacks"],
            "newton_per_step": summary["newton_iterations"] / max(1, summary["steps"])}


def measure(args, row):
    spacing = L0 / row["cells"] / PPC
    pvd = os.path.join(args.out, row["label"], "particles.pvd")
    l99, far, top, ke = deposit(pvd, spacing)
    # How densely the deposit's particles are packed against their volumes
    # (boxes of 0.04 m = L0/5; scripts/particle_packing.py).
    x, (m,) = read_particles(pvd_series(pvd)[-1][1], ["mass"])
    reference = m / 1800.0
    packed = packing(x, reference, reference, 0.04)[0]
    a = row["a"]
    potential = 1800.0 * G * L0 * (a * L0) ** 2 / 2.0  # rho g L0 H0^2 / 2, per unit thickness
    row.update({"runout": (l99 - L0) / L0, "farthest": (far - L0) / L0, "height": top / L0,
                "ke_ratio": ke / potential, "packing": packed, "lube_runout": lube_runout(a),
                "lube_height": lube_height(a)})
    return row


def changes(rows):
    """Per aspect ratio: the relative change of run-out and height between the
    two finest grids (at the smaller step) and between the two steps (at
    the finest grid)."""
    lines = []
    for a in sorted({r["a"] for r in rows}):
        mine = [r for r in rows if r["a"] == a]
        cells = sorted({r["cells"] for r in mine})
        steps = sorted({r["step"] for r in mine})
        def pick(c, h):
            return next((r for r in mine if r["cells"] == c and r["step"] == h), None)
        parts = [f"a = {a:g}:"]
        if len(cells) >= 2:
            f, g = pick(cells[-1], steps[0]), pick(cells[-2], steps[0])
            if f and g:
                parts.append(f"grid L0/{cells[-2]} -> L0/{cells[-1]}: run-out {100 * (f['runout'] / g['runout'] - 1):+.1f} %, "
                             f"height {100 * (f['height'] / g['height'] - 1):+.1f} %")
        if len(steps) >= 2:
            f, g = pick(cells[-1], steps[0]), pick(cells[-1], steps[-1])
            if f and g:
                parts.append(f"step {steps[-1]:g} -> {steps[0]:g} s at L0/{cells[-1]}: run-out "
                             f"{100 * (f['runout'] / g['runout'] - 1):+.1f} %, height {100 * (f['height'] / g['height'] - 1):+.1f} %")
        lines.append(" ".join(parts))
    return lines


def plot(rows, path, overlays=()):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5))
    aa = [0.4 + 0.01 * i for i in range(800)]
    ax[0].plot(aa, [lube_runout(a) for a in aa], color="0.6", lw=3, label="Lube et al. 2005 (fits)")
    ax[1].plot(aa, [lube_height(a) for a in aa], color="0.6", lw=3, label="Lube et al. 2005 (fits)")
    steps = sorted({r["step"] for r in rows})
    for cells, marker in zip(sorted({r["cells"] for r in rows}), "os^D"):
        for step, fill in zip(steps, ("full", "none")):
            sel = sorted((r for r in rows if r["cells"] == cells and r["step"] == step), key=lambda r: r["a"])
            if not sel:
                continue
            kw = dict(marker=marker, fillstyle=fill, ls="-" if fill == "full" else ":",
                      label=f"talus, cell L0/{cells}, h {step:g} s")
            ax[0].plot([r["a"] for r in sel], [r["runout"] for r in sel], **kw)
            ax[1].plot([r["a"] for r in sel], [r["height"] for r in sel], **kw)
    for label, extra in overlays:
        for cells in sorted({r["cells"] for r in extra}):
            sel = sorted((r for r in extra if r["cells"] == cells and r["step"] == min(x["step"] for x in extra)),
                         key=lambda r: r["a"])
            kw = dict(marker="x", color="k", ls="--", label=f"{label}, cell L0/{cells}, h {sel[0]['step']:g} s")
            ax[0].plot([r["a"] for r in sel], [r["runout"] for r in sel], **kw)
            ax[1].plot([r["a"] for r in sel], [r["height"] for r in sel], **kw)
    for k, label in enumerate(("run-out (L_f - L0)/L0, L_f = L_99", "final height H_f/L0")):
        ax[k].set_xscale("log")
        ax[k].set_yscale("log")
        ax[k].set_xlabel("aspect ratio a = H0/L0")
        ax[k].set_ylabel(label)
        ax[k].grid(True, which="both", alpha=0.3)
    ax[0].legend(fontsize=7)
    floor = "no-slip floor" if FLOOR == "fixed" else "Coulomb floor mu = tan phi"
    fig.suptitle(f"Column collapse: Mohr-Coulomb phi {PHI:g}, psi 0, c 0; {floor}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--talus", default=os.path.join(REPO, "build", "talus"))
    p.add_argument("--aspects", default="0.5,1,2,4,8")
    p.add_argument("--levels", default="10,20,40", help="cells across the column's width L0")
    p.add_argument("--steps", default="0.0025,0.00125")
    p.add_argument("--out", default=os.path.join(REPO, "bench_results", "column_aspect"))
    p.add_argument("--replot", action="store_true")
    p.add_argument("--append", action="store_true",
                   help="keep the rows of OUT/aspect.csv and add (or replace) the runs of this call")
    p.add_argument("--merge", action="append", default=[], metavar="DIR",
                   help="with --replot: first take the rows of DIR/aspect.csv into OUT/aspect.csv, "
                        "replacing rows of the same run (label)")
    p.add_argument("--overlay", action="append", default=[], metavar="DIR:LABEL",
                   help="also plot the runs of another study's DIR/aspect.csv (e.g. another friction angle)")
    p.add_argument("--friction-angle", type=float, default=PHI,
                   help="the sand's friction angle in degrees (the floor's mu = tan of it); default 30")
    p.add_argument("--floor", choices=["frictional", "fixed"], default=FLOOR,
                   help="the floor: a Coulomb face with mu = tan(phi) (default) or no slip")
    p.add_argument("--quadrature", choices=["point", "domain"], default=QUADRATURE,
                   help="the particles' quadrature (grid.quadrature); default point")
    p.add_argument("--particles-per-cell", type=int, default=PPC, help="per axis; default 2")
    p.add_argument("--packing-correction", type=float, default=PACKING_CORRECTION,
                   help="transfer.packing_correction (docs/transfers.md#packing); default: talus's (0.25)")
    args = p.parse_args()
    globals()["PHI"] = args.friction_angle
    globals()["QUADRATURE"] = args.quadrature
    globals()["FLOOR"] = args.floor
    globals()["PPC"] = args.particles_per_cell
    globals()["PACKING_CORRECTION"] = args.packing_correction
    os.makedirs(args.out, exist_ok=True)
    csv_path = os.path.join(args.out, "aspect.csv")
    keys = [k for k, _, _ in COLUMNS] + ["label"]
    def read_rows(path=None):
        with open(path or csv_path) as f:
            # Columns an earlier study did not have are empty.
            rows = [{k: (v if k == "label" else float(v) if v != "" else None) for k, v in r.items()}
                    for r in csv.DictReader(f)]
        for r in rows:
            for k in ("cells", "particles", "steps", "cutbacks"):
                r[k] = int(r[k])
        return rows

    if args.replot:
        rows = read_rows()
        for folder in args.merge:
            extra = read_rows(os.path.join(folder, "aspect.csv"))
            labels = {r["label"] for r in extra}
            rows = sorted([r for r in rows if r["label"] not in labels] + extra,
                          key=lambda r: (r["a"], r["cells"], -r["step"]))
        if args.merge:
            with open(csv_path, "w", newline="") as f:
                w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
                w.writeheader()
                w.writerows(rows)
    else:
        rows = read_rows() if args.append and os.path.exists(csv_path) else []
        for a in [float(x) for x in args.aspects.split(",")]:
            for cells in [int(x) for x in args.levels.split(",")]:
                for step in [float(x) for x in args.steps.split(",")]:
                    row = run(args, a, cells, step)
                    if row is None:
                        continue
                    row = measure(args, row)
                    rows = [r for r in rows if r["label"] != row["label"]] + [row]
                    rows.sort(key=lambda r: (r["a"], r["cells"], -r["step"]))
                    print("  ".join(table_lines([row], COLUMNS)[2:]), flush=True)
                    with open(csv_path, "w", newline="") as f:
                        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
                        w.writeheader()
                        w.writerows(rows)
    print("\n".join(table_lines(rows, COLUMNS)))
    print("\n".join(changes(rows)))
    with open(os.path.join(args.out, "aspect.md"), "w") as f:
        f.write("\n".join(markdown_lines(rows, COLUMNS, text_columns=0)) + "\n\n" + "\n".join(changes(rows)) + "\n")
    overlays = []
    for spec in args.overlay:
        folder, label = spec.split(":", 1)
        overlays.append((label, read_rows(os.path.join(folder, "aspect.csv"))))
    plot(rows, os.path.join(args.out, "aspect.png"), overlays)
    print(f"wrote {args.out}/aspect.md and aspect.png")


if __name__ == "__main__":
    main()
