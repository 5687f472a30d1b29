#!/usr/bin/python3
"""Cost of frictional contact in talus (issue 4; a benchmark, not a test).

Runs the granular column of inputs/column_collapse_psi0.yaml (a = 2,
Drucker-Prager phi = 30, psi = 0, 800 particles, 600 steps of 2.5 ms) with
four floors, everything else equal:

    slip        y_min: slip                     no contact points at all
    frictional0 y_min frictional, mu = 0        contact; the same physics as slip
    frictional  y_min frictional, mu = 0.4      contact with friction
    fixed       y_min: fixed                    no contact points (no-slip face)

and reports, from the `talus-summary: {json}` line and the progress lines of
every run: wall time (median over the repeats), accepted steps, cut-backs,
Newton iterations per step (mean over the attempts, max over the accepted
steps), contact points per step, the time spent in the contact part of the
step (candidate search + natural-map rows of the residual and the Jacobian)
as a share of the solve time, and the final run-out (L_f - L_0)/L_0 with
L = the farthest particle centre + d/2. slip against frictional0 isolates the
cost of the contact machinery (same solution); frictional against slip shows
what friction changes.

Usage (repository root, Debian's python3-yaml, python3-vtk9, python3-matplotlib):

    /usr/bin/python3 scripts/bench_contact.py                   # 3 repeats
    /usr/bin/python3 scripts/bench_contact.py --repeats 1 --talus /work/build/talus

Writes into OUT (bench_results/contact/ by default, ignored by git): the
generated cases, the logs, contact.csv, contact.md (the table) and
contact.png (Newton iterations per step against time for the four floors).
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import markdown_lines, table_lines  # noqa: E402
from pvd import pvd_series  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOURCE = "inputs/column_collapse_psi0.yaml"
FLOORS = [
    ("slip", "slip", "slip floor (no contact)"),
    ("frictional0", {"condition": "frictional", "friction": 0.0}, "frictional floor, mu = 0"),
    ("frictional", {"condition": "frictional", "friction": 0.4}, "frictional floor, mu = 0.4"),
    ("fixed", "fixed", "fixed floor (no contact)"),
]
COLUMNS = [
    ("label", "floor", "{}"),
    ("runs", "runs", "{:d}"),
    ("wall_seconds", "wall s (median)", "{:.2f}"),
    ("steps", "steps", "{:d}"),
    ("cutbacks", "cut-backs", "{:d}"),
    ("newton_mean", "Newton/step mean", "{:.2f}"),
    ("newton_max", "Newton/step max", "{:d}"),
    ("contact_per_step", "contact points/step", "{:.1f}"),
    ("contact_ms_per_step", "contact ms/step", "{:.2f}"),
    ("contact_share", "contact % of solve", "{:.1f}"),
    ("runout", "(L_f-L_0)/L_0", "{:.2f}"),
]
STEP_LINE = re.compile(r"^step\s+\d+\s+t\s+(\S+)\s+h\s+\S+\s+newton\s+(\d+)")


def run(talus, case_path):
    t0 = time.monotonic()
    # A progress line at every step (STEP_LINE: its Newton iterations); the
    # repeats run into the same directory.
    out = subprocess.run([talus, "run", case_path, "--overwrite", "--progress-steps", "1"], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True)
    seconds = time.monotonic() - t0
    if out.returncode != 0:
        sys.exit(f"talus failed on {case_path}:\n{out.stdout[-2000:]}")
    summary = None
    series = []
    for line in out.stdout.splitlines():
        if line.startswith("talus-summary:"):
            summary = json.loads(line.split(":", 1)[1])
        m = STEP_LINE.match(line)
        if m:
            series.append((float(m.group(1)), int(m.group(2))))
    return summary, series, seconds, out.stdout


def final_front(pvd_path, spacing):
    from vtkmodules.vtkIOXML import vtkXMLPUnstructuredGridReader
    from vtkmodules.util.numpy_support import vtk_to_numpy
    fronts = []
    for _, path in [pvd_series(pvd_path)[0], pvd_series(pvd_path)[-1]]:
        reader = vtkXMLPUnstructuredGridReader()
        reader.SetFileName(path)
        reader.Update()
        x = vtk_to_numpy(reader.GetOutput().GetPoints().GetData())[:, 0]
        fronts.append(x.max() + spacing / 2)
    return fronts


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0], epilog="Usage" + __doc__.split("Usage", 1)[1],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--talus", default=os.path.join(REPO, "build", "talus"))
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", default=os.path.join(REPO, "bench_results", "contact"))
    args = p.parse_args(argv)
    import yaml
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(REPO, SOURCE)) as f:
        base = yaml.safe_load(f)
    spacing = base["grid"]["cell_size"] / base["bodies"][0].get("particles_per_cell", 2)
    rows, curves = [], {}
    for key, floor, label in FLOORS:
        case = yaml.safe_load(yaml.safe_dump(base))
        case["boundaries"]["y_min"] = floor
        case["output"] = {"directory": os.path.join(args.out, key), "interval": 1.5}
        case["checkpoint"] = {"enabled": False}
        case_path = os.path.join(args.out, key + ".yaml")
        with open(case_path, "w") as f:
            f.write(f"# generated by scripts/bench_contact.py from {SOURCE}: y_min = {floor}\n")
            yaml.safe_dump(case, f, sort_keys=False, default_flow_style=None)
        walls, last = [], None
        for k in range(args.repeats):
            summary, series, seconds, text = run(args.talus, case_path)
            with open(os.path.join(args.out, f"{key}_run{k}.log"), "w") as f:
                f.write(text)
            walls.append(summary["wall_seconds"])
            last = (summary, series)
        summary, series = last
        curves[label] = series
        l0, lf = final_front(os.path.join(args.out, key, "particles.pvd"), spacing)
        steps = summary["steps"]
        rows.append({
            "label": label, "runs": args.repeats, "wall_seconds": statistics.median(walls), "steps": steps,
            "cutbacks": summary["cutbacks"], "newton_mean": summary["newton_iterations"] / steps,
            "newton_max": summary["max_step_newton_iterations"],
            "contact_per_step": summary.get("contact_points", 0) / steps,
            "contact_ms_per_step": 1e3 * summary.get("contact_seconds", 0.0) / steps,
            "contact_share": 100.0 * summary.get("contact_seconds", 0.0) / summary["solve_seconds"],
            "runout": (lf - l0) / l0,
        })
        print(f"{label}: done", flush=True)
    print("\n".join(table_lines(rows, COLUMNS)))
    with open(os.path.join(args.out, "contact.md"), "w") as f:
        f.write("\n".join(markdown_lines(rows, COLUMNS)) + "\n")
    with open(os.path.join(args.out, "contact.csv"), "w") as f:
        f.write(",".join(c[0] for c in COLUMNS) + "\n")
        for r in rows:
            f.write(",".join(str(r[c[0]]) for c in COLUMNS) + "\n")
    fig, ax = plt.subplots(figsize=(8, 4))
    for label, series in curves.items():
        ax.plot([t for t, _ in series], [n for _, n in series], label=label, lw=1)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("Newton iterations in the step")
    ax.set_title("Granular column a = 2: Newton iterations per accepted step")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "contact.png"), dpi=120)
    print(f"wrote {args.out}/contact.md, contact.csv, contact.png")


if __name__ == "__main__":
    main(sys.argv[1:])
