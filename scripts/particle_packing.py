#!/usr/bin/python3
"""How densely the particles of a run are packed, against their own volumes
(issue 13 item 3; a diagnostic, not a test).

A particle carries its reference volume V_0 = m / rho_0 and its volume
V = V_0 J, J the volume ratio the grid's velocity gradients have built up
(docs/transfers.md#particles). Where the particles stay a continuum their
positions should fill space at the same rate: in a box of area (volume) A
inside the body, sum V over the particles whose positions lie in it should
be A. This script bins the particles of each output into square (cubic)
boxes of side --box, keeps the boxes whose 2 dim face neighbours hold
particles too (the body's interior: boxes cut by the free surface or the
floor are partly empty), and prints per output time

    packing   sum(V) / A, weighted by sum(V): the material volume the
              particles say they have per unit of space their positions
              fill; 1 is consistent, 1.26 means the positions are crowded
              into 1/1.26 of the space the material occupies
    boxes > 1.2   the share of interior boxes packed 20 % or more
    J max         the largest volume ratio (particles flung apart)

    /usr/bin/python3 scripts/particle_packing.py RUN/particles.pvd --density 1800 --box 0.02
    /usr/bin/python3 scripts/particle_packing.py RUN/particles.pvd --density 1800 --box 0.02 --last

Needs Debian's python3-vtk9 and numpy. Reads the `mass` and `volume` point
arrays of the output (docs/output.md); one material density (--density).
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pvd import pvd_series, read_particles  # noqa: E402


def packing(x, reference_volume, volume, box):
    """(volume-weighted mean packing of the interior boxes, share of them
    above 1.2, number of interior boxes); x is (n, 3) with unused trailing
    coordinates zero, volume the weights summed per box."""
    dim = 3 if np.ptp(x[:, 2]) > 0 else 2
    # Boxes aligned with the origin: bodies seeded from a box whose corners are
    # whole multiples of --box start with a whole number of particles per box.
    lo = np.floor(x[:, :dim].min(axis=0) / box) * box - box
    n = np.ceil((x[:, :dim].max(axis=0) - lo) / box).astype(int) + 2
    edges = [lo[k] + box * np.arange(n[k] + 1) for k in range(dim)]
    summed, _ = np.histogramdd(x[:, :dim], bins=edges, weights=volume)
    occupied = summed > 0
    interior = occupied.copy()
    for k in range(dim):
        interior &= np.roll(occupied, 1, axis=k) & np.roll(occupied, -1, axis=k)
    ratio = summed[interior] / box ** dim
    weight = summed[interior]
    if weight.sum() == 0:
        return float("nan"), float("nan"), 0
    return float((ratio * weight).sum() / weight.sum()), float((ratio > 1.2).mean()), int(interior.sum())


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("pvd", help="particles.pvd of a run")
    p.add_argument("--density", type=float, required=True, help="the material's reference density rho_0, kg/m^3")
    p.add_argument("--box", type=float, required=True, help="side of the boxes, m (two cells or more)")
    p.add_argument("--last", action="store_true", help="only the last output")
    args = p.parse_args()
    if args.density <= 0 or args.box <= 0:
        sys.exit("--density and --box must be positive")
    series = pvd_series(args.pvd)
    if args.last:
        series = series[-1:]
    print("| t s | packing of V_0 | packing of V = V_0 J | interior boxes | boxes > 1.2 | J max | particles with J > 2 |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for t, path in series:
        x, (mass, volume) = read_particles(path, ["mass", "volume"])
        if mass is None or volume is None:
            sys.exit(f"{path}: the output has no mass or volume array")
        reference = mass / args.density
        j = volume / reference
        p0, _, _ = packing(x, reference, reference, args.box)
        pv, above, boxes = packing(x, reference, volume, args.box)
        print(f"| {t:.3f} | {p0:.3f} | {pv:.3f} | {boxes} | {100 * above:.0f} % | {j.max():.3g} | {(j > 2).sum()} |")


if __name__ == "__main__":
    main()
