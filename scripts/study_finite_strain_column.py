#!/usr/bin/python3
"""The finite-strain settling column of issue 13, item 1 (docs/formulation.md#finite-strain-the-settling-column).

An elastic column (nu = 0, rho0 = 1000 kg/m^3, height l0 = 1 m, four cells
wide between slip walls, on a slip floor) settles under gravity with
backward-Euler steps until it is at rest. Whatever the constitutive law,
the exact Cauchy stress is sigma_yy(Y) = -rho0 g (l0 - Y) in terms of a
particle's original height Y: the weight above it per unit width, whose
width the walls keep. The script runs each configuration, reads the final
output and prints, relative to rho0 g l0:

  L2      the root mean square of sigma_yy - exact over the particles,
  bias    their mean (a smooth error of the strain measure shows here),
  worst   the largest |sigma_yy - exact|,
  interior  the largest error for 0.2 l0 < Y < 0.8 l0,

and the largest displacement in cells. E sets the strain: rho0 g l0 / E is
the strain at the base (0.049 at E = 2e5 Pa, 0.0049 at 2e6 Pa).

--quadrature domain runs the column with the particles' domain quadrature
(docs/grid.md#particle-quadrature), by default on its own set of
configurations (--configurations quasi-static): grids down to 0.00625 m at
three strains, quasi-static steps of 0.5 s, and at 3.1 % strain
(E = 313,920 Pa) a series whose settled top lies 0.4-0.75 of a cell past a
knot on every grid, so that no grid function is entered by a sliver only.
--quadrature domain --configurations fine: the whole column's L2 on grids
from 0.05 down to 0.00078125 m at 3.3 % strain (E = 294,300 Pa), with the
position of the settled top within its cell. --configurations steps: the
same column on cells of 0.0125 and 0.003125 m at steps from 1 s down to
0.05 s, to the same 5 s.

--quadrature both runs every configuration with each quadrature; --plot PNG
draws the errors against the cell size (docs/images/finite_strain_column.png
is --quadrature both --configurations fine --plot).

usage: study_finite_strain_column.py [--talus build/talus] [--work DIR] [--quadrature point|domain|both]
                                     [--configurations original|quasi-static|fine|steps] [--ghost-penalty G]
                                     [--plot PNG]
"""
import argparse
import glob
import os
import subprocess
import sys
import tempfile

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import table_lines  # noqa: E402
from pvd import pvd_series  # noqa: E402

RHO, G, L0 = 1000.0, 9.81, 1.0

# (cell m, particles per cell, step s, end s, E Pa)
CONFIGURATIONS = [
    (0.1, 2, 0.01, 3.0, 2e5),
    (0.05, 2, 0.01, 3.0, 2e5),
    (0.025, 2, 0.01, 3.0, 2e5),
    (0.0125, 2, 0.01, 3.0, 2e5),
    (0.025, 3, 0.01, 3.0, 2e5),
    (0.025, 2, 0.005, 6.0, 2e5),
    (0.05, 2, 0.5, 5.0, 2e5),
    (0.025, 2, 0.5, 5.0, 2e5),
    (0.0125, 2, 0.5, 5.0, 2e5),
    (0.025, 2, 0.1, 5.0, 2e5),
    (0.05, 2, 0.01, 3.0, 6e5),
    (0.025, 2, 0.01, 3.0, 6e5),
    (0.05, 2, 0.01, 3.0, 2e6),
    (0.025, 2, 0.01, 3.0, 2e6),
    (0.0125, 2, 0.01, 3.0, 2e6),
    (0.0125, 2, 0.01, 3.0, 2e7),
]

# With domain quadrature: the grid series at quasi-static steps (the error is
# the quadrature's, not the time integration's) for three strains.
DOMAIN_CONFIGURATIONS = [
    (0.05, 2, 0.5, 5.0, 2e5),
    (0.025, 2, 0.5, 5.0, 2e5),
    (0.0125, 2, 0.5, 5.0, 2e5),
    (0.00625, 2, 0.5, 5.0, 2e5),
    (0.025, 3, 0.5, 5.0, 2e5),
    (0.0125, 3, 0.5, 5.0, 2e5),
    (0.025, 2, 0.01, 3.0, 2e5),
    (0.05, 2, 0.5, 5.0, 6e5),
    (0.025, 2, 0.5, 5.0, 6e5),
    (0.0125, 2, 0.5, 5.0, 6e5),
    (0.00625, 2, 0.5, 5.0, 6e5),
    (0.05, 2, 0.5, 5.0, 2e6),
    (0.025, 2, 0.5, 5.0, 2e6),
    (0.0125, 2, 0.5, 5.0, 2e6),
    (0.00625, 2, 0.5, 5.0, 2e6),
    # Settlement rho0 g l0^2 / (2 E) = 0.015625 m: the top at 0.984375 m.
    (0.05, 2, 0.5, 5.0, 313920.0),
    (0.025, 2, 0.5, 5.0, 313920.0),
    (0.0125, 2, 0.5, 5.0, 313920.0),
    (0.00625, 2, 0.5, 5.0, 313920.0),
]

# The whole column's L2 on grids down to 0.00078125 m (--configurations fine,
# domain quadrature): settlement about rho0 g l0^2 / (2 E) = l0 / 60, so the
# settled top sits at a different fraction of a cell on each grid (printed).
FINE_CONFIGURATIONS = [(cell, 2, 0.5, 5.0, 294300.0)
                       for cell in (0.05, 0.025, 0.0125, 0.00625, 0.003125, 0.0015625, 0.00078125)]

# The step: the settled column of FINE_CONFIGURATIONS on two grids at
# backward-Euler steps from 1 s down to 0.05 s (5 s: 5 to 100 steps).
STEP_CONFIGURATIONS = [(cell, 2, step, 5.0, 294300.0)
                       for cell in (0.0125, 0.003125) for step in (1.0, 0.5, 0.25, 0.1, 0.05)]

# Dynamic settling (steps of 0.01 and 0.005 s, the column still rings a
# little at the end) and one quasi-static run, to compare the two strain
# increments (--strain-increment): the same bias with both, the ringing's.
INCREMENT_CONFIGURATIONS = [(0.05, 2, 0.01, 3.0, 2e5), (0.025, 2, 0.01, 3.0, 2e5), (0.025, 2, 0.005, 6.0, 2e5),
                            (0.025, 2, 0.5, 5.0, 2e5)]


def case_text(cell, ppc, step, end, E, directory, quadrature="point", increment="linear"):
    return f"""grid:
  lower: [0.0, 0.0]
  upper: [{4 * cell}, {1.2 * L0}]
  cell_size: {cell}
  quadrature: {quadrature}
time:
  end: {end}
  step: {step}
  theta: 1.0
  strain_increment: {increment}
output:
  directory: {directory}
  interval: {end}
gravity: [0.0, {-G}]
materials:
  - name: soil
    model: linear_elastic
    density: {RHO}
    youngs_modulus: {E}
    poisson_ratio: 0.0
bodies:
  - name: column
    material: soil
    box: {{lower: [0.0, 0.0], upper: [{4 * cell}, {L0}]}}
    particles_per_cell: {ppc}
boundaries:
  x_min: slip
  x_max: slip
  y_min: slip
  y_max: slip
"""


def final_state(directory):
    _, path = pvd_series(glob.glob(os.path.join(directory, "particles.pvd"))[0])[-1]
    reader = vtk.vtkXMLPUnstructuredGridReader() if path.endswith(".pvtu") else vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    data = grid.GetPointData()
    x = vtk_to_numpy(grid.GetPoints().GetData())
    u = vtk_to_numpy(data.GetArray("displacement"))
    stress = vtk_to_numpy(data.GetArray("stress"))
    velocity = vtk_to_numpy(data.GetArray("velocity"))
    return x, u, stress, velocity


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--talus", default=os.path.join(os.path.dirname(__file__), "..", "build", "talus"))
    parser.add_argument("--work", default=None)
    parser.add_argument("--quadrature", choices=["point", "domain", "both"], default="point",
                        help="both: every configuration with each (for --plot)")
    parser.add_argument("--plot", default=None,
                        help="write a PNG: the errors against the cell size, per E, ppc and step")
    parser.add_argument("--strain-increment", choices=["linear", "logarithmic"], default="linear",
                        help="time.strain_increment of the runs (docs/formulation.md#the-strain-increment)")
    parser.add_argument("--ghost-penalty", type=float, default=None,
                        help="solver.ghost_penalty of the runs (default: the case file's default, 0.03); "
                             "docs/formulation.md: the sliver and the setting that controls it")
    parser.add_argument("--configurations", choices=["original", "quasi-static", "fine", "steps", "increment"], default=None,
                        help="default: original with point quadrature, quasi-static with domain")
    args = parser.parse_args()
    chosen = args.configurations or ("original" if args.quadrature == "point" else "quasi-static")
    configurations = {"original": CONFIGURATIONS, "quasi-static": DOMAIN_CONFIGURATIONS,
                      "fine": FINE_CONFIGURATIONS, "steps": STEP_CONFIGURATIONS,
                      "increment": INCREMENT_CONFIGURATIONS}[chosen]
    work = args.work or tempfile.mkdtemp(prefix="finite_strain_")
    os.makedirs(work, exist_ok=True)
    rows = []
    quadratures = ["point", "domain"] if args.quadrature == "both" else [args.quadrature]
    runs = [(q,) + c for q in quadratures for c in configurations]
    for n, (quadrature, cell, ppc, step, end, E) in enumerate(runs):
        directory = os.path.join(work, f"run_{n}")
        case = os.path.join(work, f"case_{n}.yaml")
        with open(case, "w") as f:
            f.write(case_text(cell, ppc, step, end, E, directory, quadrature, args.strain_increment))
            if args.ghost_penalty is not None:
                f.write(f"solver:\n  ghost_penalty: {args.ghost_penalty}\n")
        subprocess.run([os.path.abspath(args.talus), "run", case, "--quiet", "--overwrite"], check=True,
                       stdout=subprocess.DEVNULL)
        x, u, stress, velocity = final_state(directory)
        Y = x[:, 1] - u[:, 1]
        error = (stress[:, 1] + RHO * G * (L0 - Y)) / (RHO * G * L0)
        interior = (Y > 0.2 * L0) & (Y < 0.8 * L0)
        # Without the two rows of particles at the floor and the two at the top.
        spacing = cell / ppc
        inner = (Y > 2 * spacing) & (Y < L0 - 2 * spacing)
        rows.append({"quadrature": quadrature, "inner L2": float(np.sqrt(np.mean(error[inner] ** 2))), "cell": cell, "ppc": ppc, "h": step, "steps": int(round(end / step)), "E": E,
                     "L2": float(np.sqrt(np.mean(error ** 2))), "bias": float(np.mean(error)),
                     "worst": float(np.abs(error).max()), "interior": float(np.abs(error[interior]).max()),
                     "moved": float(np.abs(u[:, 1]).max() / cell),
                     # The top domains' upper edge (half a spacing above the top
                     # particle; the top is stress free, stretch 1) past the
                     # last grid line below it, in cells: near 0 is a sliver.
                     "top": float(((x[:, 1].max() + 0.5 * spacing) / cell) % 1.0), "vmax": float(np.abs(velocity).max())})
        print(f"run {n + 1}/{len(runs)} done", file=sys.stderr)
    columns = [("quadrature", "quadrature", "{}"), ("cell", "cell m", "{:g}"), ("ppc", "ppc", "{}"), ("h", "h s", "{:g}"), ("steps", "steps", "{}"),
               ("E", "E Pa", "{:.4g}"), ("L2", "L2", "{:.2e}"), ("bias", "bias", "{:+.1e}"),
               ("worst", "worst", "{:.2e}"), ("interior", "interior", "{:.2e}"), ("inner L2", "L2 w/o 2 rows each end", "{:.2e}"),
               ("moved", "moved cells", "{:.2f}"), ("top", "top past a grid line, cells", "{:.2f}"), ("vmax", "v_max m/s", "{:.0e}")]
    print("\n".join(table_lines(rows, columns)))
    if args.plot:
        plot(rows, args.plot)


def plot(rows, path):
    """L2 over all particles (solid) and the interior's largest error
    (dashed) against the cell, one colour per quadrature, E, ppc and step;
    a slope of 1.5 for reference."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    groups = sorted({(r["quadrature"], r["E"], r["ppc"], r["h"]) for r in rows})
    for k, (q, E, ppc, h) in enumerate(groups):
        mine = sorted((r for r in rows if (r["quadrature"], r["E"], r["ppc"], r["h"]) == (q, E, ppc, h)),
                      key=lambda r: r["cell"])
        cells = [r["cell"] for r in mine]
        strain = RHO * G * L0 / E
        label = f"{q}, base strain {100 * strain:.1f} %" + (f", {ppc}x{ppc}" if ppc != 2 else "") + f", h {h:g} s"
        ax.loglog(cells, [r["L2"] for r in mine], "o-", color=f"C{k}", label=label + ": L2")
        ax.loglog(cells, [r["interior"] for r in mine], "s--", color=f"C{k}", ms=4, label=label + ": interior")
    c = np.array([min(r["cell"] for r in rows), max(r["cell"] for r in rows)])
    ax.loglog(c, 1e-5 * (c / c[0]) ** 1.5, "k:", label="slope 1.5")
    ax.axhline(1e-5, color="0.6", lw=1)
    ax.set_xlabel("cell (m)")
    ax.set_ylabel("stress error / (rho0 g l0)")
    ax.set_title("Settling elastic column at finite strain", fontsize=9)
    ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
