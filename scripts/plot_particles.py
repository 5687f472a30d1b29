#!/usr/bin/python3
"""Particles of a talus run coloured by one field, at chosen times, stacked
like the seminar's figures (t = 0, 1.7, 3.3, 5 s).

    /usr/bin/python3 scripts/plot_particles.py output/slope_collapse_psi0/particles.pvd \
        --times 0 1.7 3.3 5 --field cumulative_plastic_strain --vmax 1 --out slope.png

Reads the .pvd series with VTK's XML reader and draws with matplotlib (Agg,
no display needed). For each requested time the nearest written output is
used; its time is printed in the panel title.
"""
import argparse
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import vtk  # noqa: E402
from vtk.util.numpy_support import vtk_to_numpy  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pvd import pvd_series  # noqa: E402


def series(pvd):
    """(time, file) pairs of a .pvd collection, sorted by time."""
    items = pvd_series(pvd)
    if not items:
        sys.exit(f"plot_particles: {pvd} lists no data sets")
    return items


def read(path, field):
    reader = vtk.vtkXMLPUnstructuredGridReader() if path.endswith(".pvtu") else vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    array = grid.GetPointData().GetArray(field)
    if array is None:
        sys.exit(f"plot_particles: {path} has no point array '{field}'")
    return vtk_to_numpy(grid.GetPoints().GetData()), vtk_to_numpy(array)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("pvd")
    p.add_argument("--times", type=float, nargs="+", default=[0.0, 1.7, 3.3, 5.0])
    p.add_argument("--field", default="cumulative_plastic_strain")
    p.add_argument("--vmax", type=float, default=None, help="top of the colour scale (default: the data's maximum)")
    p.add_argument("--out", default="particles.png")
    p.add_argument("--title", default=None)
    p.add_argument("--dpi", type=int, default=100)
    a = p.parse_args()

    outputs = series(a.pvd)
    frames = []
    for t in a.times:
        time, path = min(outputs, key=lambda o: abs(o[0] - t))
        x, value = read(path, a.field)
        if value.ndim > 1:  # vectors and tensors: their magnitude
            value = (value**2).sum(axis=1) ** 0.5
        frames.append((time, x, value))
    vmax = a.vmax if a.vmax is not None else max(float(v.max()) for _, _, v in frames) or 1.0
    xmin = min(float(x[:, 0].min()) for _, x, _ in frames)
    xmax = max(float(x[:, 0].max()) for _, x, _ in frames)
    ymin = min(float(x[:, 1].min()) for _, x, _ in frames)
    ymax = max(float(x[:, 1].max()) for _, x, _ in frames)
    aspect = (ymax - ymin) / max(xmax - xmin, 1e-12)
    fig, axes = plt.subplots(len(frames), 1, figsize=(8, 0.6 + len(frames) * (8 * aspect + 0.5)), squeeze=False)
    for ax, (time, x, value) in zip(axes[:, 0], frames):
        points = ax.scatter(x[:, 0], x[:, 1], c=value, s=1.5, cmap="viridis", vmin=0.0, vmax=vmax, linewidths=0)
        ax.set_aspect("equal")
        ax.set_xlim(xmin, xmax)
        ax.set_ylim(ymin, ymax)
        ax.set_title(f"t = {time:g} s", fontsize=9)
        ax.tick_params(labelsize=7)
    fig.colorbar(points, ax=axes[:, 0].tolist(), shrink=0.8, label=a.field.replace("_", " "))
    if a.title:
        fig.suptitle(a.title)
    fig.savefig(a.out, dpi=a.dpi)
    print(f"plot_particles: wrote {a.out} ({len(frames)} panels, {a.field} in [0, {vmax:g}])")


if __name__ == "__main__":
    main()
