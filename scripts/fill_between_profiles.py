#!/usr/bin/python3
"""Writes a talus particle file (docs/case_file.md#particle-files) for a 2D
sliding mass: the material between a lower profile (the sliding surface, or
the terrain it rests on) and an upper one (the pre-failure ground surface).

    /usr/bin/python3 scripts/fill_between_profiles.py \
        inputs/terrain/hillside_2d.txt inputs/terrain/slide_top_2d.txt \
        --spacing 0.05 --out inputs/particles/slide_mass_2d.csv

Both profiles are terrain files ("x height" per line, x increasing, '#'
comments; docs/case_file.md#terrain-files), linearly interpolated. Particles
sit on a square lattice of the given spacing, anchored at --origin (default
0 0, so that with spacing = cell_size / 2 they fall where a box body of the
same case would put them), where the upper profile lies above the lower one;
a lattice point is kept if lower(x) < y < upper(x). Each particle's volume is
spacing^2 (m^2 per unit thickness). Prints the particle count and the area.
"""
import argparse
import sys

import numpy as np


def read_profile(path):
    points = []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            fields = line.split("#", 1)[0].replace(",", " ").split()
            if not fields:
                continue
            if len(fields) != 2:
                sys.exit(f"fill_between_profiles: {path}:{number}: expected 'x height', found {len(fields)} fields")
            try:
                points.append((float(fields[0]), float(fields[1])))
            except ValueError:
                sys.exit(f"fill_between_profiles: {path}:{number}: '{line.strip()}' is not two numbers")
    xs = np.array([p[0] for p in points])
    if len(xs) < 2 or np.any(np.diff(xs) <= 0):
        sys.exit(f"fill_between_profiles: {path}: needs at least 2 vertices with x increasing")
    return xs, np.array([p[1] for p in points])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("lower", help="terrain file of the lower profile (sliding surface)")
    parser.add_argument("upper", help="terrain file of the upper profile (ground surface)")
    parser.add_argument("--spacing", type=float, required=True, help="lattice spacing, m")
    parser.add_argument("--origin", type=float, nargs=2, default=[0.0, 0.0], help="lattice anchor (x, y), m")
    parser.add_argument("--velocity", type=float, nargs=2, help="initial velocity (vx, vy), m/s, written as columns")
    parser.add_argument("--out", required=True, help="the particle file to write")
    args = parser.parse_args()
    if not args.spacing > 0:
        sys.exit("fill_between_profiles: --spacing must be > 0")

    lx, ly = read_profile(args.lower)
    ux, uy = read_profile(args.upper)
    x0, x1 = max(lx[0], ux[0]), min(lx[-1], ux[-1])
    s = args.spacing
    ox, oy = args.origin
    # Lattice columns whose centre lies in the x range both profiles cover.
    i = np.arange(np.ceil((x0 - ox) / s - 0.5), np.floor((x1 - ox) / s - 0.5) + 1)
    x = ox + (i + 0.5) * s
    bottom, top = np.interp(x, lx, ly), np.interp(x, ux, uy)
    rows = []
    for xc, b, t in zip(x, bottom, top):
        if t <= b:
            continue
        j = np.arange(np.floor((b - oy) / s - 0.5) + 1, np.ceil((t - oy) / s - 0.5))
        y = oy + (j + 0.5) * s
        for yc in y[(y > b) & (y < t)]:
            rows.append((xc, yc))
    if not rows:
        sys.exit("fill_between_profiles: the upper profile is nowhere above the lower one: no particle")

    with open(args.out, "w") as f:
        f.write(f"# written by scripts/fill_between_profiles.py from {args.lower} (below) and {args.upper} (above),\n")
        f.write(f"# lattice spacing {s:g} m anchored at ({ox:g}, {oy:g}); volume in m^2 per unit thickness\n")
        if args.velocity:
            f.write("x, y, volume, vx, vy\n")
            for xc, yc in rows:
                f.write(f"{xc:.10g}, {yc:.10g}, {s * s:.10g}, {args.velocity[0]:.10g}, {args.velocity[1]:.10g}\n")
        else:
            f.write("x, y, volume\n")
            for xc, yc in rows:
                f.write(f"{xc:.10g}, {yc:.10g}, {s * s:.10g}\n")
    print(f"fill_between_profiles: {len(rows)} particles, area {len(rows) * s * s:.6g} m^2 -> {args.out}")


if __name__ == "__main__":
    main()
