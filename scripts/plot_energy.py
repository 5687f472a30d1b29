#!/usr/bin/python3
"""The energy balance of a talus run (docs/energy.md) as a picture: energy.csv
(written next to particles.pvd) drawn as stacked areas over time,

    kinetic + elastic + (gravitational - its initial value)
    + plastic, contact, face, transfer and time-integration dissipation
    - obstacle and correction work,

whose top edge mirrors the gravitational energy released (drawn dashed,
below zero) when the balance closes, with the closing error on a second
panel.

    /usr/bin/python3 scripts/plot_energy.py output/reference_column_frictional/energy.csv \
        --out energy.png --title "reference column, mu = 0.4"

Prints the final value of every column (J; J per m of thickness in 2D) and
the largest |balance_error| relative to the energy that moved (the largest
K + E + |K + G + E - (K0 + G0 + E0)|), the measure tests/test_energy_balance.cpp
asserts. Needs Debian's python3-matplotlib (use /usr/bin/python3).
"""
import argparse
import csv
import sys

STACK = [("kinetic", "kinetic"), ("elastic", "elastic"), ("plastic_dissipation", "plastic"),
         ("contact_dissipation", "contact"), ("face_dissipation", "faces"), ("transfer_dissipation", "transfer"),
         ("time_dissipation", "time integration")]
RECEIVED = [("obstacle_work", "obstacle work"), ("correction_work", "face corrections")]


def read(path):
    # Column names without their units ("kinetic [J/m]" -> "kinetic").
    with open(path) as f:
        rows = [{k.split(" [")[0]: v for k, v in r.items()} for r in csv.DictReader(f)]
    if not rows:
        sys.exit(f"{path}: no rows")
    missing = [k for k, _ in STACK + RECEIVED + [("gravitational", ""), ("balance_error", "")] if k not in rows[0]]
    if missing:
        sys.exit(f"{path}: not a talus energy.csv (no column {', '.join(missing)})")
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv", help="energy.csv of a run")
    ap.add_argument("--out", default="energy.png")
    ap.add_argument("--title", default="")
    args = ap.parse_args()
    c = read(args.csv)
    t = c["time"]
    g0 = c["gravitational"][0]
    initial = c["kinetic"][0] + c["gravitational"][0] + c["elastic"][0]
    moved = max(k + e + abs(k + g + e - initial) for k, g, e in zip(c["kinetic"], c["gravitational"], c["elastic"]))
    worst = max(abs(x) for x in c["balance_error"])
    for key in ["kinetic", "gravitational", "elastic"] + [k for k, _ in STACK[2:] + RECEIVED] + ["balance_error"]:
        print(f"{key:22s} {c[key][-1]: .6e}")
    print(f"largest |balance_error| {worst:.3e} J = {worst / moved if moved > 0 else float('nan'):.3e} "
          f"of the energy that moved ({moved:.6e} J)")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    layers = [c[k] for k, _ in STACK] + [[-x for x in c[k]] for k, _ in RECEIVED]
    labels = [name for _, name in STACK] + [name for _, name in RECEIVED]
    top.stackplot(t, *layers, labels=labels, alpha=0.8)
    top.plot(t, [g - g0 for g in c["gravitational"]], "k--", label="gravitational - initial")
    top.axhline(0.0, color="k", linewidth=0.5)
    top.set_ylabel("energy (J)")
    top.legend(fontsize=7, ncol=3, loc="lower left")
    if args.title:
        top.set_title(args.title)
    bottom.plot(t, c["balance_error"], "r-")
    bottom.set_ylabel("closing error (J)")
    bottom.set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(args.out, dpi=80)
    print(f"plot: {args.out}")


if __name__ == "__main__":
    main()
