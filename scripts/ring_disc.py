#!/usr/bin/python3
"""A disc (2D) or a ball-free cylinder section seeded on rings, as a talus
particle file (docs/case_file.md#particle-files): J rings of equal width
R / J, ring j holding round(2 pi r_j / (R / J)) particles of equal volume
(the ring's area shared out), at angles offset by half a particle. Its edge
is a polygon of about 2 pi J sides, not the lattice's staircase, so that a
rigid disc rolls (docs/contact.md#rigid-bodies). Prints the disc's mass
per unit density, its inertia about the centre (each particle a square of
its volume, own inertia v^2 / 6) and the contact radius R_c (the outer
ring plus half its particles' size), for a = g sin(alpha) / (1 + I / (M R_c^2)).

    /usr/bin/python3 scripts/ring_disc.py --centre 0.5 0.3 --radius 0.2 --rings 16 \\
        --out inputs/particles/ring_disc_2d.csv
"""
import argparse
import math


def ring_disc(cx, cy, radius, rings):
    width = radius / rings
    rows = []
    for j in range(rings):
        r = (j + 0.5) * width
        n = max(1, round(2 * math.pi * r / width))
        area = math.pi * ((j + 1) ** 2 - j ** 2) * width * width
        for k in range(n):
            t = 2 * math.pi * (k + 0.5) / n
            rows.append((cx + r * math.cos(t), cy + r * math.sin(t), area / n))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--centre", type=float, nargs=2, required=True, metavar=("X", "Y"))
    ap.add_argument("--radius", type=float, required=True)
    ap.add_argument("--rings", type=int, default=16)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    if not (args.radius > 0 and args.rings >= 1):
        ap.error("--radius must be > 0 and --rings >= 1")
    rows = ring_disc(args.centre[0], args.centre[1], args.radius, args.rings)
    with open(args.out, "w") as f:
        f.write(f"# written by scripts/ring_disc.py: a disc of radius {args.radius} m centred at "
                f"({args.centre[0]}, {args.centre[1]}) on {args.rings} rings; volume in m^2 per unit thickness\n")
        f.write("x, y, volume\n")
        for x, y, v in rows:
            f.write(f"{x:.12g}, {y:.12g}, {v:.12g}\n")
    cx, cy = args.centre
    mass = sum(v for _, _, v in rows)
    inertia = sum(v * ((x - cx) ** 2 + (y - cy) ** 2) + v * v / 6 for x, y, v in rows)
    outer = max(math.hypot(x - cx, y - cy) for x, y, _ in rows)
    outer_volume = next(v for x, y, v in rows if abs(math.hypot(x - cx, y - cy) - outer) < 1e-9)
    contact = outer + 0.5 * math.sqrt(outer_volume)
    print(f"{len(rows)} particles, area {mass:.6g} m^2, I / (M R_c^2) = {inertia / (mass * contact ** 2):.6f}, "
          f"R_c = {contact:.6g} m")


if __name__ == "__main__":
    main()
