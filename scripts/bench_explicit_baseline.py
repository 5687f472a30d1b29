#!/usr/bin/python3
"""talus against an explicit MPM code on the reference column (issues 11 and 12).

Runs inputs/reference_column_smooth.yaml and reference_column_frictional.yaml
(3,200 particles, cell 0.01 m, 1 s of collapse) with talus, and the same case
with CB-Geo's explicit MPM (github.com/cb-geo/mpm, USF), in interleaved pairs
(talus, CB-Geo, talus, CB-Geo, ...), and prints the median CPU time (user +
sys of the child) of each, their ratio, talus's steps, cut-backs and Newton
iterations per step, and the deposit of each code's last run: L_99 (the x
below which 99 % of the mass lies) and the wall height (the top of the
particles within 1 cm of the left wall), both + half a particle spacing, as
scripts/bench_solvers.py computes them. A benchmark, not a test; run it alone
on the machine.

CB-Geo is not part of talus and is never committed. To set it up (Debian 12,
as root; it builds with Debian packages only; built and run so at 53fcb76):

    apt-get install -y g++ cmake ninja-build libeigen3-dev libhdf5-dev \\
        libboost-filesystem-dev libboost-system-dev python3-h5py
    # the source: a clone of github.com/cb-geo/mpm (e.g. of a fetched mirror)
    git clone <copy of github.com/cb-geo/mpm> /work/cbgeo/src
    cmake -S /work/cbgeo/src -B /work/cbgeo/build -G Ninja -DCMAKE_BUILD_TYPE=Release \\
        -DMPM_BUILD_TESTING=Off -DCMAKE_DISABLE_FIND_PACKAGE_MPI=ON -DCMAKE_DISABLE_FIND_PACKAGE_VTK=ON
    cmake --build /work/cbgeo/build -j2
    /usr/bin/python3 scripts/cbgeo_reference_column.py --out /work/cbgeo/column --tension-cutoff 173.2 --dt 5e-5

(tension cut-off 173.2 Pa = c cot(phi), talus's apex). The cases have a
margin of 2 cells of mesh beyond each wall (cbgeo_reference_column.py
--margin, default 2; the walls stay at x = 0, 1 and y = 0, 0.5 as velocity
constraints on every node on or beyond them), so that a particle thrown
across a wall stays in the mesh. The step: at the issue's 1e-4 s CB-Geo's
explicit USF diverges on both floors (particles that the flow stretches to
10-40 times their volume, then velocities of hundreds of m/s and stresses of
MPa: on the mu = 0.4 floor from t = 0.2 s, it leaves the mesh at step 3,450;
on the slip floor after the flow hits the right wall, step 7,272; at 8e-5 and
6.25e-5 s the slip floor still diverges at t = 0.80 and 0.79 s; on the
mu = 0.4 floor at 1e-4 s USL stops at step 324 and pressure smoothing at the
same step 3,450; PIC (velocity_update) runs at 1e-4 s but spreads far less:
L_99 0.68 m slip, 0.43 m mu = 0.4); at 5e-5 s
(20,000 steps) both floors run to 1 s (2026-11-25: L_99 0.9971 m and wall
height 0.0553 m slip, 0.7710 m and 0.2573 m mu = 0.4). The CB-Geo case's own
dt and steps are what is timed; the table shows them. Then:

    /usr/bin/python3 scripts/bench_explicit_baseline.py --cbgeo-bin /work/cbgeo/build/mpm \\
        --cbgeo-cases /work/cbgeo/column [--repeats 3] [--floors smooth frictional]

CB-Geo's log of the last run of each floor is <cases>/<floor>/run.log, its
particles <cases>/<floor>/results/<uuid>/particles<step>.h5 (HDF5 table
"table", written after the step <step>, i.e. at (step + 1) dt; the last one
is the state at the end).
"""
import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import markdown_lines, table_lines  # noqa: E402
from bench_solvers import deposit as talus_deposit  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def cpu_of(cmd, env=None, cwd=None, log=None, stdout_to_log=False):
    """Runs cmd; returns (user + sys CPU seconds of the child, its stdout).
    stderr goes to log (if given), and stdout too if stdout_to_log."""
    before = os.times()
    out = open(log, "w") if log else None
    try:
        p = subprocess.run(cmd, env=env, cwd=cwd,
                           stdout=out if (out and stdout_to_log) else subprocess.PIPE,
                           stderr=out if out else subprocess.DEVNULL, text=True)
    finally:
        if out:
            out.close()
    after = os.times()
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed with exit code {p.returncode}" + (f", see {log}" if log else ""))
    return (after.children_user - before.children_user) + (after.children_system - before.children_system), p.stdout


def run_talus(talus, floor, work, explicit=False):
    """One talus run of the floor's case; explicit: with time.integrator:
    explicit and the step from time.cfl (docs/explicit.md) instead of the
    implicit step."""
    src = os.path.join(REPO, "inputs", f"reference_column_{floor}.yaml")
    label = f"talus_{floor}" + ("_explicit" if explicit else "")
    case = os.path.join(work, label + ".yaml")
    out = os.path.join(work, label)
    shutil.rmtree(out, ignore_errors=True)
    with open(src) as f:
        text = f.read()
    text = re.sub(r"(?m)^(\s*directory:).*$", rf"\1 {out}", text)
    if explicit:
        text, n = re.subn(r"(?m)^(\s*)step:.*$", r"\1integrator: explicit", text)
        assert n == 1, "the case has no time.step to replace"
    with open(case, "w") as f:
        f.write(text)
    cpu, stdout = cpu_of([talus, "run", case, "--overwrite"])
    summary = json.loads(stdout.split("talus-summary:", 1)[1].splitlines()[0])
    return cpu, summary


def cbgeo_case(cases, floor):
    """(directory, mpm.json) of a CB-Geo case."""
    d = os.path.join(cases, floor)
    with open(os.path.join(d, "mpm.json")) as f:
        return d, json.load(f)


def cbgeo_margin(d):
    """Cells of mesh beyond the walls: the first node is at (-margin h, -margin h)."""
    with open(os.path.join(d, "mesh.txt")) as f:
        for line in f:
            parts = line.split()
            if len(parts) == 2 and "." in parts[0]:
                return round(-float(parts[0]) / 0.01)
    return None


def run_cbgeo(binary, cases, floor):
    d, cfg = cbgeo_case(cases, floor)
    uuid, nsteps = cfg["analysis"]["uuid"], cfg["analysis"]["nsteps"]
    shutil.rmtree(os.path.join(d, "results", uuid), ignore_errors=True)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    log = os.path.join(d, "run.log")
    cpu, _ = cpu_of([binary, "-f", d + "/", "-i", "mpm.json", "-p", "1"], env=env, log=log, stdout_to_log=True)
    with open(log) as f:
        text = f.read()
    steps = re.findall(r"Step: (\d+) of \d+", text)
    if "MPM main:" in text or not steps or int(steps[-1]) != nsteps - 1:
        sys.exit(f"CB-Geo failed on {floor} (last step {steps[-1] if steps else '-'} of {nsteps}), see {log}")
    return cpu


def deposit_of(x, y, m, spacing, wall_x=0.0, wall_band=0.01):
    """(L_99, wall height) of particle centres x, y with masses m, as
    bench_solvers.deposit computes them for talus."""
    import numpy as np
    order = np.argsort(x, kind="stable")
    cumulative = np.cumsum(m[order]) / m.sum()
    k = min(int(np.searchsorted(cumulative, 0.99 - 1e-12)), x.shape[0] - 1)
    near_wall = x <= wall_x + wall_band
    return float(x[order[k]]) + 0.5 * spacing, float(y[near_wall].max()) + 0.5 * spacing


def cbgeo_deposit(cases, floor, spacing):
    """(L_99, wall height, time) of the last particles file CB-Geo wrote."""
    import h5py  # Debian: python3-h5py
    d, cfg = cbgeo_case(cases, floor)
    folder = os.path.join(d, cfg["post_processing"].get("path", "results/"), cfg["analysis"]["uuid"])
    files = [(int(m.group(1)), os.path.join(folder, n)) for n in os.listdir(folder)
             for m in [re.fullmatch(r"particles(\d+)\.h5", n)] if m]
    step, path = max(files)
    nsteps = cfg["analysis"]["nsteps"]
    if step != nsteps - 1:
        print(f"warning: CB-Geo's last output on {floor} is after step {step + 1} of {nsteps}, not the end",
              file=sys.stderr)
    with h5py.File(path, "r") as f:
        table = f["table"][:]
    l99, wall = deposit_of(table["coord_x"], table["coord_y"], table["mass"], spacing)
    return l99, wall, (step + 1) * cfg["analysis"]["dt"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--talus", default=os.path.join(REPO, "build", "talus"))
    ap.add_argument("--cbgeo-bin", required=True)
    ap.add_argument("--cbgeo-cases", required=True, help="directory with smooth/ and frictional/ CB-Geo inputs")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(REPO, "bench_results", "explicit_baseline"),
                    help="talus cases and output of the last run of each floor (git ignores bench_results/)")
    ap.add_argument("--floors", nargs="+", default=["smooth", "frictional"], choices=["smooth", "frictional"])
    ap.add_argument("--spacing", type=float, default=0.005, help="particle spacing for the deposit (m)")
    ap.add_argument("--no-explicit", action="store_true",
                    help="skip talus's own explicit integrator (time.integrator: explicit) in each round")
    args = ap.parse_args()
    rows = []
    work = args.out
    os.makedirs(work, exist_ok=True)
    for floor in args.floors:
        t_cpu, e_cpu, c_cpu, summaries, e_summaries = [], [], [], [], []
        for r in range(args.repeats):
            # One round: talus implicit, talus explicit, CB-Geo (interleaved).
            cpu, summary = run_talus(args.talus, floor, work)
            t_cpu.append(cpu)
            summaries.append(summary)
            if not args.no_explicit:
                cpu, summary = run_talus(args.talus, floor, work, explicit=True)
                e_cpu.append(cpu)
                e_summaries.append(summary)
            c_cpu.append(run_cbgeo(args.cbgeo_bin, args.cbgeo_cases, floor))
            print(f"{floor} round {r + 1}: talus {t_cpu[-1]:.1f} s"
                  + (f", talus explicit {e_cpu[-1]:.1f} s" if e_cpu else "")
                  + f", CB-Geo {c_cpu[-1]:.1f} s", flush=True)
        s = summaries[0]
        t, c = statistics.median(t_cpu), statistics.median(c_cpu)
        e = statistics.median(e_cpu) if e_cpu else None
        if e_cpu:
            e_l99, e_wall = talus_deposit(os.path.join(work, f"talus_{floor}_explicit", "particles.pvd"), args.spacing)
        t_l99, t_wall = talus_deposit(os.path.join(work, f"talus_{floor}", "particles.pvd"), args.spacing)
        c_l99, c_wall, c_end = cbgeo_deposit(args.cbgeo_cases, floor, args.spacing)
        d, cfg = cbgeo_case(args.cbgeo_cases, floor)
        rows.append({"floor": floor, "talus": t, "cbgeo": c, "ratio": c / t, "steps": s["steps"],
                     "cutbacks": s["cutbacks"], "newton": s["newton_iterations"] / s["steps"],
                     "factorizations": s.get("factorizations"),
                     "cbgeo_steps": cfg["analysis"]["nsteps"], "cbgeo_dt": cfg["analysis"]["dt"],
                     "margin": cbgeo_margin(d), "t_l99": t_l99, "c_l99": c_l99,
                     "t_wall": t_wall, "c_wall": c_wall, "c_end": c_end,
                     "explicit": e if e is not None else "-",
                     "explicit_ratio": e / t if e is not None else "-",
                     "explicit_steps": e_summaries[0]["steps"] if e_summaries else "-",
                     "e_l99": e_l99 if e_cpu else "-", "e_wall": e_wall if e_cpu else "-",
                     "pairs": len(t_cpu)})
    columns = [("floor", "floor", "{}"), ("talus", "talus CPU s", "{:.1f}"), ("cbgeo", "CB-Geo CPU s", "{:.1f}"),
               ("ratio", "CB-Geo / talus", "{:.2f}"), ("steps", "talus steps", "{}"),
               ("explicit", "talus explicit CPU s", "{:.1f}"),
               ("explicit_ratio", "talus explicit / implicit", "{:.2f}"),
               ("explicit_steps", "talus explicit steps", "{}"),
               ("cutbacks", "cut-backs", "{}"), ("newton", "Newton/step", "{:.2f}"),
               ("factorizations", "LU factorizations", "{}"),
               ("cbgeo_steps", "CB-Geo steps", "{}"), ("cbgeo_dt", "CB-Geo dt s", "{:g}"),
               ("margin", "CB-Geo margin cells", "{}"), ("c_end", "CB-Geo end s", "{:.4f}"),
               ("t_l99", "talus L_99 m", "{:.4f}"), ("c_l99", "CB-Geo L_99 m", "{:.4f}"),
               ("t_wall", "talus wall height m", "{:.4f}"), ("c_wall", "CB-Geo wall height m", "{:.4f}"),
               ("e_l99", "talus explicit L_99 m", "{:.4f}"), ("e_wall", "talus explicit wall height m", "{:.4f}"),
               ("pairs", "rounds", "{}")]
    print()
    print("\n".join(table_lines(rows, columns)))
    print()
    print("\n".join(markdown_lines(rows, columns)))


if __name__ == "__main__":
    main()
