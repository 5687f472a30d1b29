#!/usr/bin/python3
"""A frictionless wall holding an elastic layer at rest, at step sizes from
1e-3 s to 1 s (issue 13, item 2; docs/contact.md#a-wall-at-rest-at-every-step-size).

The layer (H = 1 m high, rho = 2000 kg/m^3, E = 1e7 Pa, nu = 0.3, seeded
with its geostatic stress) lies on a slip floor between a slip face at
x = 0 and a rigid frictionless half-plane half a cell beyond a grid line,
at x = 0.8 + cell / 2 (0.8250000000000001 m in floating point on cells of
0.05 m, a round-off beyond the layer's face: the case of the missed contact
points, docs/contact.md#which-grid-points-are-contact-points; 0.8125 m and
0.80625 m on 0.025 and 0.0125 m), 2 x 2 particles per cell. The exact wall force is the at-rest earth
pressure K0 rho g H^2 / 2 with K0 = nu / (1 - nu) = 3/7: 4204.29 N/m. At
rest nothing may depend on the step: each run's wall force at every step
(obstacle_forces.csv) is compared with it, and the contact points that carry
force (more than 1e-6 of it, contacts_NNNNNN.pvtu at 20 outputs) are
counted. The seeded geostatic stress is not the discrete equilibrium, so
the first step of a small step size shows the wall taking up the load
(4 % low at 1e-3 s) and the layer rings about it: the table gives the first
step apart.

With talus's default options and with `-talus_balance_time_fraction 0`
(Newton held to the balance tolerance at every step, not to the time-error
bound: docs/solver.md#the-tolerance-follows-the-time-error).

usage: study_contact_wall.py [--talus build/talus] [--work DIR] [--steps 0.001,0.01,0.1,1]
                             [--cells 0.05,0.025,0.0125] [--balance default,exact] [--plot PNG]

--plot: the wall force against the step size, per grid (the last step, and
the range of every step after the first), with the closed form.
"""
import argparse
import csv
import os
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import markdown_lines, run_talus_case, table_lines  # noqa: E402
from pvd import pvd_series, read_particles  # noqa: E402

RHO, G, H, NU = 2000.0, 9.81, 1.0, 0.3
EXPECTED = NU / (1 - NU) * RHO * G * H * H / 2


def case_text(step, end, out, cell):
    # The wall half a cell beyond a grid line: x = 0.8 + cell / 2.
    wall = 0.8 + cell / 2
    return f"""grid: {{lower: [0, 0], upper: [1.2, 1.2], cell_size: {cell}}}
time: {{end: {end}, step: {step}}}
output: {{directory: {out}, interval: {end / 20}}}
gravity: [0, -9.81]
materials:
  - {{name: soil, model: linear_elastic, density: {RHO}, youngs_modulus: 1.0e7, poisson_ratio: {NU}}}
bodies:
  - {{name: layer, material: soil, box: {{lower: [0, 0], upper: [{wall}, 1.0]}}, initial_stress: geostatic}}
obstacles:
  - {{name: wall, type: half_plane, point: [{wall}, 0.0], normal: [-1.0, 0.0], friction: 0.0}}
boundaries: {{x_min: slip, x_max: free, y_min: slip, y_max: free}}
"""


def run(talus, work, step, exact_balance, cell):
    # At least 1 s and at least 20 steps.
    end = max(1.0, 20 * step)
    label = f"c{cell:g}_h{step:g}" + ("_exact" if exact_balance else "")
    out = os.path.join(work, label)
    case = out + ".yaml"
    with open(case, "w") as f:
        f.write(case_text(step, end, out, cell))
    if exact_balance:
        os.environ["PETSC_OPTIONS"] = "-talus_balance_time_fraction 0"
    try:
        cpu, summary = run_talus_case(talus, case)
    finally:
        os.environ.pop("PETSC_OPTIONS", None)
    with open(os.path.join(out, "obstacle_forces.csv")) as f:
        rows = list(csv.reader(f))
    # "wall_fx [N/m]" (older builds: "wall_fx")
    column = next(i for i, name in enumerate(rows[0]) if name.split(" ")[0] == "wall_fx")
    force = np.array([float(r[column]) for r in rows[1:]])  # on the wall, +x
    loaded = []
    for _, path in pvd_series(os.path.join(out, "contacts.pvd"))[1:]:
        _, (f,) = read_particles(path, ["contact_force"])
        loaded.append(int((np.linalg.norm(f, axis=1) > 1e-6 * EXPECTED).sum()) if f is not None else 0)
    deviation = (force - EXPECTED) / EXPECTED
    return {"label": label, "cell": cell, "step": step, "balance": "exact" if exact_balance else "default",
            "steps": summary["steps"], "newton": summary["newton_iterations"], "cpu": cpu,
            "first": force[0], "final": force[-1], "worst": 100 * np.abs(deviation[1:]).max(),
            "spread": 100 * (force.max() - force.min()) / EXPECTED, "final_error": 100 * deviation[-1],
            "up": force[1:].max() - force[-1], "down": force[-1] - force[1:].min(),
            "loaded": f"{min(loaded)}-{max(loaded)}" if loaded else "-"}


COLUMNS = [
    ("cell", "cell m", "{:g}"),
    ("step", "h s", "{:g}"),
    ("balance", "Newton tolerance", "{}"),
    ("steps", "steps", "{}"),
    ("newton", "Newton", "{}"),
    ("cpu", "CPU s", "{:.1f}"),
    ("first", "first step N/m", "{:.3f}"),
    ("final", "last step N/m", "{:.3f}"),
    ("worst", "largest |F - K0 rho g H^2/2| after the first step %", "{:.3f}"),
    ("final_error", "last step - K0 rho g H^2/2 %", "{:.3f}"),
    ("spread", "max - min over the steps %", "{:.2g}"),
    ("loaded", "loaded contact points", "{}"),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--talus", default=os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                                    "build", "talus"))
    ap.add_argument("--work", default=None)
    ap.add_argument("--steps", default="0.001,0.01,0.1,1")
    ap.add_argument("--cells", default="0.05,0.025,0.0125",
                    help="cell sizes (the wall stands half a cell beyond a grid line on each)")
    ap.add_argument("--plot", default=None, help="write this PNG")
    ap.add_argument("--balance", default="default,exact",
                    help="default: talus's Newton tolerance; exact: -talus_balance_time_fraction 0")
    args = ap.parse_args()
    work = args.work or tempfile.mkdtemp(prefix="talus_wall_")
    os.makedirs(work, exist_ok=True)
    rows = []
    for balance in args.balance.split(","):
        for cell in (float(c) for c in args.cells.split(",")):
            for step in (float(s) for s in args.steps.split(",")):
                rows.append(run(os.path.abspath(args.talus), work, step, balance == "exact", cell))
            print("  ".join(str(rows[-1][k]) for k, _, _ in COLUMNS), flush=True)
    print(f"\nK0 rho g H^2 / 2 = {EXPECTED:.3f} N/m; work directory {work}\n")
    print("\n".join(table_lines(rows, COLUMNS)))
    print()
    print("\n".join(markdown_lines(rows, COLUMNS, text_columns=3)))
    if args.plot:
        plot(rows, args.plot)


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.axhline(EXPECTED, color="0.5", lw=2, label="K0 rho g H^2 / 2")
    for k, cell in enumerate(sorted({r["cell"] for r in rows}, reverse=True)):
        mine = sorted((r for r in rows if r["cell"] == cell and r["balance"] == "default"), key=lambda r: r["step"])
        h = [r["step"] for r in mine]
        color = f"C{k}"
        ax.plot(h, [r["final"] for r in mine], "o-", color=color, label=f"cell {cell:g} m: last step")
        low = [r["final"] - r["down"] for r in mine]
        high = [r["final"] + r["up"] for r in mine]
        ax.fill_between(h, low, high, color=color, alpha=0.2, lw=0)
    ax.set_xscale("log")
    ax.set_xlabel("step h (s)")
    ax.set_ylabel("wall force (N/m)")
    ax.set_title("A wall holding a layer at rest (band: every step after the first)", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
