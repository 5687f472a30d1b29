#!/usr/bin/python3
"""Time series of a talus run: front (run-out), height, kinetic and potential
energy at every output, and the force on each obstacle, as a CSV table and a
PNG with three panels (four with obstacles).

    /usr/bin/python3 scripts/plot_series.py output/column_collapse_psi0/particles.pvd \
        --out column_series.png --title "column collapse, psi = 0"

Reads the .pvd series with VTK's XML reader and draws with matplotlib (Agg,
no display needed). For every output (row of the CSV):

  time                     s      the output's time in the .pvd
  particles                -      number of particles
  mass                     kg     sum of the particle masses (2D: kg per m of thickness)
  front                    m      largest particle-centre coordinate along --x-axis
  front99                  m      the coordinate along --x-axis below which --mass-fraction
                                  (default 99 %) of the mass lies (the bulk front)
  height                   m      largest particle-centre coordinate along --vertical-axis
  kinetic_energy           J      sum of 1/2 m |v|^2 (2D: J per m of thickness)
  potential_energy_change  J      sum of m g h minus its value at the first output,
                                  h along --vertical-axis, g = --gravity (2D: J per m)
  max_speed                m/s    largest particle speed |v|

Positions are particle centres: add half the particle spacing to compare
front and height with the edge of the body. The vertical axis is y when every
z coordinate is 0 (2D output) and z otherwise (3D), unless --vertical-axis
says otherwise. Gravity is taken to point down that axis.

Wall forces: if the run has obstacles, talus writes obstacle_forces.csv next
to the .pvd (one row per time step: the force the material exerts on each
obstacle, N per m of thickness in 2D, N in 3D, then impulses and window
averages; docs/output.md). The script reads the forces (--forces) and adds,
per obstacle NAME, two columns

  NAME_force               N/m    |F| at the output's time (the step ending then;
                                  nan at t = 0, before the first step); N in 3D
  NAME_force_x             N/m    the component of F along --x-axis (the run-out
                                  axis; the column is named after it: _y, _z)

and a fourth panel with |F| (solid) and that component (dashed) at every
step; with bodies in contact (docs/contact.md#bodies-in-contact) also the
part of |F| from each body that touches the obstacle (dotted, from the
table's NAME_f_by_BODY columns). --obstacles limits all to the named
obstacles.
"""
import argparse
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import vtk  # noqa: E402
from vtk.util.numpy_support import vtk_to_numpy  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pvd import pvd_series  # noqa: E402

AXES = {"x": 0, "y": 1, "z": 2}
COLUMNS = ["time", "particles", "mass", "front", "front99", "height", "kinetic_energy",
           "potential_energy_change", "max_speed"]


def series(pvd):
    """(time, file) pairs of a .pvd collection, sorted by time."""
    items = pvd_series(pvd)
    if not items:
        sys.exit(f"plot_series: {pvd} lists no data sets")
    return items


def read(path):
    """Positions (n x 3), masses (n) and velocities (n x 3) of one output."""
    reader = vtk.vtkXMLPUnstructuredGridReader() if path.endswith(".pvtu") else vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    if grid.GetNumberOfPoints() == 0:
        sys.exit(f"plot_series: {path} has no particles")
    arrays = []
    for name in ("mass", "velocity"):
        array = grid.GetPointData().GetArray(name)
        if array is None:
            sys.exit(f"plot_series: {path} has no point array '{name}'")
        arrays.append(vtk_to_numpy(array).astype(float))
    return vtk_to_numpy(grid.GetPoints().GetData()).astype(float), arrays[0], arrays[1]


def read_forces(path):
    """The obstacle force table: times (steps), per obstacle name its force
    vectors (steps x dim), and per obstacle the parts of that force by body
    ({name: {body: steps x dim}}; empty without bodies in contact). The table
    has four blocks of columns of equal size (docs/output.md): the forces
    NAME_fx [unit], ..., the impulses, their running totals and the window
    forces; with bodies in contact a fifth, NAME_f_by_BODY_x, ...; the first
    and the fifth are read."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows or rows[0][0].split(" [")[0] != "time":
        sys.exit(f"plot_series: {path} is not an obstacle force table (no 'time' column)")
    header = [h.split(" [")[0] for h in rows[0]]  # names without their units
    by_body_columns = [k for k, h in enumerate(header) if "_f_by_" in h]
    blocks = len(header) - 1 - len(by_body_columns)
    if blocks <= 0 or blocks % 4:
        sys.exit(f"plot_series: {path} is not an obstacle force table (no four blocks of obstacle columns)")
    data = np.array([[float(v) for v in r] for r in rows[1:] if len(r) == len(header)], dtype=float).reshape(-1, len(header))
    forces = {}
    for k, column in enumerate(header[1:1 + blocks // 4], start=1):
        name, _, component = column.rpartition("_f")
        if not name or component not in ("x", "y", "z"):
            sys.exit(f"plot_series: {path}: column '{column}' is not NAME_fx, NAME_fy or NAME_fz")
        forces.setdefault(name, {})["xyz".index(component)] = data[:, k]
    parts = {}
    for k in by_body_columns:
        name, _, rest = header[k].partition("_f_by_")
        body, _, component = rest.rpartition("_")
        if name not in forces or not body or component not in ("x", "y", "z"):
            sys.exit(f"plot_series: {path}: column '{header[k]}' is not NAME_f_by_BODY_x, _y or _z")
        parts.setdefault(name, {}).setdefault(body, {})["xyz".index(component)] = data[:, k]
    out = {}
    for name, comps in forces.items():
        dim = len(comps)
        out[name] = np.stack([comps[a] for a in range(dim)], axis=1)
    by_body = {name: {body: np.stack([c[a] for a in range(len(c))], axis=1) for body, c in bodies.items()}
               for name, bodies in parts.items()}
    return data[:, 0], out, by_body


def force_at(times, values, t):
    """The row of the step that ends at time t (None if no step ends there)."""
    if times.size == 0:
        return None
    k = int(np.argmin(np.abs(times - t)))
    return values[k] if abs(times[k] - t) <= 1e-9 * max(1.0, abs(t)) else None


def bulk_front(x, m, fraction):
    """The coordinate x below which `fraction` of the mass m lies (the
    particle at which the cumulative mass, sorted by x, reaches it)."""
    order = np.argsort(x, kind="stable")
    cumulative = np.cumsum(m[order]) / m.sum()
    k = min(int(np.searchsorted(cumulative, fraction - 1e-12)), x.size - 1)
    return float(x[order[k]])


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("pvd")
    p.add_argument("--out", default="series.png")
    p.add_argument("--csv", default=None, help="the table (default: --out with .csv instead of .png)")
    p.add_argument("--x-axis", choices=AXES, default="x", help="direction of the run-out (default x)")
    p.add_argument("--vertical-axis", choices=AXES, default=None,
                   help="direction of height and potential energy (default: y for 2D output, z for 3D)")
    p.add_argument("--gravity", type=float, default=9.81, help="g in m/s^2, pointing down the vertical axis")
    p.add_argument("--mass-fraction", type=float, default=0.99, help="mass fraction of the bulk front (default 0.99)")
    p.add_argument("--forces", default=None,
                   help="obstacle force table (default: obstacle_forces.csv next to the .pvd, if there is one)")
    p.add_argument("--obstacles", nargs="+", default=None, help="the obstacles whose force to plot (default: all)")
    p.add_argument("--title", default=None)
    p.add_argument("--dpi", type=int, default=100)
    a = p.parse_args()
    if not 0.0 < a.mass_fraction <= 1.0:
        sys.exit("plot_series: --mass-fraction must be in (0, 1]")

    frames = [(t, *read(path)) for t, path in series(a.pvd)]
    three_d = any(np.any(x[:, 2] != 0.0) for _, x, _, _ in frames)
    vertical = AXES[a.vertical_axis] if a.vertical_axis else (2 if three_d else 1)
    along = AXES[a.x_axis]
    if along == vertical:
        sys.exit("plot_series: --x-axis and --vertical-axis must differ")

    rows = []
    potential0 = None
    for t, x, m, v in frames:
        potential = a.gravity * float(np.dot(m, x[:, vertical]))
        if potential0 is None:
            potential0 = potential
        speed2 = (v**2).sum(axis=1)
        rows.append({"time": t, "particles": x.shape[0], "mass": float(m.sum()),
                     "front": float(x[:, along].max()), "front99": bulk_front(x[:, along], m, a.mass_fraction),
                     "height": float(x[:, vertical].max()), "kinetic_energy": 0.5 * float(np.dot(m, speed2)),
                     "potential_energy_change": potential - potential0, "max_speed": float(np.sqrt(speed2.max()))})

    # The force on each obstacle (the table of every step), at the outputs too.
    forces_path = a.forces or os.path.join(os.path.dirname(a.pvd), "obstacle_forces.csv")
    force_times, forces, by_body = np.zeros(0), {}, {}
    if a.forces or os.path.exists(forces_path):
        force_times, forces, by_body = read_forces(forces_path)
        if a.obstacles:
            unknown = [n for n in a.obstacles if n not in forces]
            if unknown:
                sys.exit(f"plot_series: {forces_path} has no obstacle {', '.join(unknown)} (it has {', '.join(forces)})")
            forces = {n: forces[n] for n in a.obstacles}
    elif a.obstacles:
        sys.exit(f"plot_series: --obstacles given but there is no {forces_path}")
    columns = list(COLUMNS)
    for name, F in forces.items():
        columns += [f"{name}_force", f"{name}_force_{'xyz'[along]}"]
        for r in rows:
            f = force_at(force_times, F, r["time"])
            r[f"{name}_force"] = float(np.linalg.norm(f)) if f is not None else float("nan")
            r[f"{name}_force_{'xyz'[along]}"] = float(f[along]) if f is not None and along < F.shape[1] else float("nan")

    csv_path = a.csv or os.path.splitext(a.out)[0] + ".csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns)
        w.writeheader()
        for r in rows:
            w.writerow({k: (repr(r[k]) if isinstance(r[k], float) else r[k]) for k in columns})

    per_m = "" if three_d else "/m"
    names = "xyz"
    t = [r["time"] for r in rows]
    panels = 4 if forces else 3
    fig, axes = plt.subplots(panels, 1, figsize=(7, 8 if panels == 3 else 10), sharex=True)
    ax = axes[0]
    ax.plot(t, [r["front"] for r in rows], "o-", markersize=3, label=f"front (max {names[along]})")
    ax.plot(t, [r["front99"] for r in rows], "s--", markersize=3,
            label=f"bulk front ({100 * a.mass_fraction:g} % of the mass below)")
    ax.set_ylabel(f"front: {names[along]} (m)")
    ax.legend(fontsize=8)
    ax = axes[1]
    ax.plot(t, [r["height"] for r in rows], "o-", markersize=3, color="C2")
    ax.set_ylabel(f"height: max {names[vertical]} (m)")
    ax = axes[2]
    ax.plot(t, [r["kinetic_energy"] for r in rows], "o-", markersize=3, color="C3", label="kinetic energy")
    ax.plot(t, [-r["potential_energy_change"] for r in rows], "s--", markersize=3, color="C4",
            label="potential energy released (−ΔPE)")
    ax.set_ylabel(f"energy (J{per_m})")
    ax.legend(fontsize=8)
    if forces:
        ax = axes[3]
        for k, (name, F) in enumerate(forces.items()):
            ax.plot(force_times, np.linalg.norm(F, axis=1), "-", linewidth=1, color=f"C{k}", label=f"{name}: |F|")
            # With bodies in contact: each body's part of |F| (dotted), where it touches.
            for j, (body, Fb) in enumerate(by_body.get(name, {}).items()):
                if np.any(Fb != 0.0):
                    ax.plot(force_times, np.linalg.norm(Fb, axis=1), ":", linewidth=1, color=f"C{k}",
                            alpha=0.4 + 0.6 * (j + 1) / (len(by_body[name]) + 1), label=f"{name}: |F| of {body}")
            if along < F.shape[1]:
                ax.plot(force_times, F[:, along], "--", linewidth=1, color=f"C{k}", label=f"{name}: F{names[along]}")
        ax.set_ylabel(f"force on obstacle (N{per_m})")
        ax.legend(fontsize=8)
    axes[-1].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=8)
    if a.title:
        fig.suptitle(a.title)
    fig.tight_layout()
    fig.savefig(a.out, dpi=a.dpi)
    print(f"plot_series: wrote {a.out} and {csv_path} ({len(rows)} outputs, {'3D' if three_d else '2D'}, "
          f"vertical axis {names[vertical]}" + (f", forces on {', '.join(forces)} from {forces_path}" if forces else "") + ")")


if __name__ == "__main__":
    main()
