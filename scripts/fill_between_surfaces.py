#!/usr/bin/python3
"""Writes a talus particle file (docs/case_file.md#particle-files) for a
sliding mass: the material between a lower surface (the sliding surface, or
the terrain it rests on) and an upper one (the pre-failure ground surface).

    # 2D: two profiles in the terrain-file format ("x height" per line)
    /usr/bin/python3 scripts/fill_between_surfaces.py \
        inputs/terrain/hillside_2d.txt inputs/terrain/slide_top_2d.txt \
        --spacing 0.05 --out inputs/particles/slide_mass_2d.csv
    # 3D: two ESRI ASCII height maps (.asc) with the same header
    /usr/bin/python3 scripts/fill_between_surfaces.py sliding_surface.asc dem.asc \
        --spacing 0.1 --out mass.csv

The surfaces are read as talus reads terrain files (docs/case_file.md#terrain-files):
a profile is linear between its vertices; a height map is split, cell by
cell, into the two triangles (00, 10, 11) and (00, 11, 01), as the terrain
obstacle does (src/contact/obstacle.cpp). So when the lower surface is also
the case's terrain obstacle, every particle lies outside it.

Particles sit on a square (cubic) lattice of the given spacing, anchored at
--origin (default 0: with spacing = cell_size / 2 and a grid whose lower
corner is a multiple of the spacing, they fall where a box body would put
them). A lattice point is kept if lower < z < upper there (y in 2D), within
the horizontal extent both surfaces cover. Each particle's volume is
spacing^dim (m^2 per unit thickness in 2D). Prints the particle count and
the volume (area in 2D).
"""
import argparse
import sys

import numpy as np


def fail(message):
    sys.exit(f"fill_between_surfaces: {message}")


def data_lines(path):
    """(line number, fields) of the lines that hold something."""
    try:
        with open(path) as f:
            for number, line in enumerate(f, 1):
                fields = line.split("#", 1)[0].replace(",", " ").split()
                if fields:
                    yield number, fields
    except OSError as e:
        fail(f"{path}: {e.strerror}")


def read_profile(path):
    points = []
    for number, fields in data_lines(path):
        if len(fields) != 2:
            fail(f"{path}:{number}: expected 'x height', found {len(fields)} fields")
        try:
            points.append((float(fields[0]), float(fields[1])))
        except ValueError:
            fail(f"{path}:{number}: '{' '.join(fields)}' is not two numbers")
    xs = np.array([p[0] for p in points])
    if len(xs) < 2 or np.any(np.diff(xs) <= 0):
        fail(f"{path}: needs at least 2 vertices with x increasing")
    return xs, np.array([p[1] for p in points])


class HeightMap:
    """An ESRI ASCII grid: heights[j, i] at (x0 + i s, y0 + j s), j = 0 the southmost row."""

    def __init__(self, path):
        header, rows = {}, []
        for number, fields in data_lines(path):
            if not rows and fields[0][0].isalpha() and fields[0].lower() not in ("nan", "inf"):
                if len(fields) != 2:
                    fail(f"{path}:{number}: header line '{fields[0]}' must hold one value")
                header[fields[0].lower()] = float(fields[1])
                continue
            try:
                rows.append([float(v) for v in fields])
            except ValueError:
                fail(f"{path}:{number}: a row of heights holds something that is not a number")
        for key in ("ncols", "nrows", "cellsize"):
            if key not in header:
                fail(f"{path}: the header has no {key}")
        self.nx, self.ny, self.s = int(header["ncols"]), int(header["nrows"]), header["cellsize"]
        corner = "xllcorner" in header
        self.x0 = header["xllcorner"] + 0.5 * self.s if corner else header["xllcenter"]
        self.y0 = header["yllcorner"] + 0.5 * self.s if "yllcorner" in header else header["yllcenter"]
        if len(rows) != self.ny or any(len(r) != self.nx for r in rows):
            fail(f"{path}: expected {self.ny} rows of {self.nx} heights")
        self.heights = np.array(rows[::-1])  # north row first in the file
        self.path = path

    def extent(self):
        return (self.x0, self.x0 + (self.nx - 1) * self.s), (self.y0, self.y0 + (self.ny - 1) * self.s)

    def height(self, x, y):
        """The height of the triangle under (x, y), as the terrain obstacle computes it."""
        fx, fy = (x - self.x0) / self.s, (y - self.y0) / self.s
        i = np.clip(np.floor(fx).astype(int), 0, self.nx - 2)
        j = np.clip(np.floor(fy).astype(int), 0, self.ny - 2)
        u, w = fx - i, fy - j
        h = self.heights
        z00, z10, z01, z11 = h[j, i], h[j, i + 1], h[j + 1, i], h[j + 1, i + 1]
        lower_triangle = u >= w  # (00, 10, 11), else (00, 11, 01)
        a = np.where(lower_triangle, z10 - z00, z11 - z01)
        b = np.where(lower_triangle, z11 - z10, z01 - z00)
        return z00 + a * u + b * w


def lattice(lo, hi, origin, s):
    """Lattice coordinates origin + (k + 1/2) s within [lo, hi]."""
    k = np.arange(np.ceil((lo - origin) / s - 0.5), np.floor((hi - origin) / s - 0.5) + 1)
    return origin + (k + 0.5) * s


def fill_column(bottom, top, origin, s):
    """The lattice heights strictly between bottom and top."""
    if top <= bottom:
        return np.empty(0)
    z = lattice(bottom, top, origin, s)
    return z[(z > bottom) & (z < top)]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("lower", help="the lower surface: a profile (2D) or an .asc height map (3D)")
    parser.add_argument("upper", help="the upper surface, of the same kind")
    parser.add_argument("--spacing", type=float, required=True, help="lattice spacing, m")
    parser.add_argument("--origin", type=float, nargs="+", help="lattice anchor (x y [z]), m; default 0")
    parser.add_argument("--velocity", type=float, nargs="+", help="initial velocity (vx vy [vz]), m/s, written as columns")
    parser.add_argument("--out", required=True, help="the particle file to write")
    args = parser.parse_args()
    three_d = args.lower.lower().endswith(".asc")
    if three_d != args.upper.lower().endswith(".asc"):
        fail("give two profiles (2D) or two .asc height maps (3D), not one of each")
    dim = 3 if three_d else 2
    if not args.spacing > 0:
        fail("--spacing must be > 0")
    origin = args.origin or [0.0] * dim
    for name, values in (("--origin", origin), ("--velocity", args.velocity)):
        if values is not None and len(values) != dim:
            fail(f"{name} needs {dim} numbers in {dim}D")
    s = args.spacing

    rows = []
    if three_d:
        lower, upper = HeightMap(args.lower), HeightMap(args.upper)
        (lx, ly), (ux, uy) = lower.extent(), upper.extent()
        xs = lattice(max(lx[0], ux[0]), min(lx[1], ux[1]), origin[0], s)
        ys = lattice(max(ly[0], uy[0]), min(ly[1], uy[1]), origin[1], s)
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        bottom, top = lower.height(X, Y), upper.height(X, Y)
        for a in range(len(xs)):
            for b in range(len(ys)):
                for z in fill_column(bottom[a, b], top[a, b], origin[2], s):
                    rows.append((xs[a], ys[b], z))
    else:
        lx, lz = read_profile(args.lower)
        ux, uz = read_profile(args.upper)
        xs = lattice(max(lx[0], ux[0]), min(lx[-1], ux[-1]), origin[0], s)
        bottom, top = np.interp(xs, lx, lz), np.interp(xs, ux, uz)
        for x, b, t in zip(xs, bottom, top):
            for y in fill_column(b, t, origin[1], s):
                rows.append((x, y))
    if not rows:
        fail("the upper surface is nowhere above the lower one: no particle")

    axes = ["x", "y", "z"][:dim]
    volume = s**dim
    with open(args.out, "w") as f:
        f.write(f"# written by scripts/fill_between_surfaces.py from {args.lower} (below) and {args.upper} (above),\n")
        f.write(f"# lattice spacing {s:g} m anchored at ({', '.join(f'{o:g}' for o in origin)}); "
                f"volume in m^{dim}{' per unit thickness' if dim == 2 else ''}\n")
        header = axes + ["volume"] + (["v" + a for a in axes] if args.velocity else [])
        f.write(", ".join(header) + "\n")
        tail = [volume] + (list(args.velocity) if args.velocity else [])
        for r in rows:
            f.write(", ".join(f"{v:.10g}" for v in list(r) + tail) + "\n")
    what = "volume" if dim == 3 else "area"
    print(f"fill_between_surfaces: {len(rows)} particles, {what} {len(rows) * volume:.6g} m^{dim} -> {args.out}")


if __name__ == "__main__":
    main()
