#!/usr/bin/python3
"""talus against an explicit MPM code on the reference column (issues 11 and 12).

Runs inputs/reference_column_smooth.yaml and reference_column_frictional.yaml
(3,200 particles, cell 0.01 m, 1 s of collapse) with talus, and the same case
with CB-Geo's explicit MPM (github.com/cb-geo/mpm, USF, 1e-4 s, 10,000
steps), in interleaved pairs (talus, CB-Geo, talus, CB-Geo, ...), and prints
the median CPU time (user + sys of the child) of each, their ratio, and
talus's steps, cut-backs and Newton iterations per step. A benchmark, not a
test; run it alone on the machine.

CB-Geo is not part of talus and is never committed. To set it up (Debian 12,
as root; it builds with Debian packages only):

    # the source, from a fetched copy of github.com/cb-geo/mpm, in /work/cbgeo/src
    apt-get install -y libboost-filesystem-dev libboost-system-dev
    cmake -S /work/cbgeo/src -B /work/cbgeo/build -G Ninja -DCMAKE_BUILD_TYPE=Release \\
        -DMPM_BUILD_TESTING=Off -DCMAKE_DISABLE_FIND_PACKAGE_MPI=ON -DCMAKE_DISABLE_FIND_PACKAGE_VTK=ON
    cmake --build /work/cbgeo/build
    /usr/bin/python3 scripts/cbgeo_reference_column.py --out /work/cbgeo/column --tension-cutoff 173.2

(tension cut-off 173.2 Pa = c cot(phi), talus's Mohr-Coulomb apex). Then:

    /usr/bin/python3 scripts/bench_explicit_baseline.py --cbgeo-bin /work/cbgeo/build/mpm \\
        --cbgeo-cases /work/cbgeo/column [--repeats 3] [--floors smooth frictional]
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

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def cpu_of(cmd, env=None, cwd=None, log=None):
    """Runs cmd; returns (user + sys CPU seconds of the child, its stdout)."""
    before = os.times()
    out = open(log, "w") if log else None
    try:
        p = subprocess.run(cmd, env=env, cwd=cwd, stdout=subprocess.PIPE,
                           stderr=out if out else subprocess.DEVNULL, text=True)
    finally:
        if out:
            out.close()
    after = os.times()
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed with exit code {p.returncode}")
    return (after.children_user - before.children_user) + (after.children_system - before.children_system), p.stdout


def run_talus(talus, floor, work):
    src = os.path.join(REPO, "inputs", f"reference_column_{floor}.yaml")
    case = os.path.join(work, f"talus_{floor}.yaml")
    out = os.path.join(work, f"talus_{floor}")
    shutil.rmtree(out, ignore_errors=True)
    with open(src) as f:
        text = f.read()
    text = re.sub(r"(?m)^(\s*directory:).*$", rf"\1 {out}", text)
    with open(case, "w") as f:
        f.write(text)
    cpu, stdout = cpu_of([talus, "run", case])
    summary = json.loads(stdout.split("talus-summary:", 1)[1].splitlines()[0])
    return cpu, summary


def run_cbgeo(binary, cases, floor):
    d = os.path.join(cases, floor)
    with open(os.path.join(d, "mpm.json")) as f:
        uuid = json.load(f)["analysis"]["uuid"]
    shutil.rmtree(os.path.join(d, "results", uuid), ignore_errors=True)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    cpu, _ = cpu_of([binary, "-f", d + "/", "-i", "mpm.json", "-p", "1"], env=env,
                    log=os.path.join(d, "run.log"))
    with open(os.path.join(d, "run.log")) as f:
        if "MPM main:" in f.read():
            sys.exit(f"CB-Geo failed on {floor}, see {d}/run.log")
    return cpu


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--talus", default=os.path.join(REPO, "build", "talus"))
    ap.add_argument("--cbgeo-bin", required=True)
    ap.add_argument("--cbgeo-cases", required=True, help="directory with smooth/ and frictional/ CB-Geo inputs")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(REPO, "bench_results", "explicit_baseline"),
                    help="talus cases and output of the last run of each floor (git ignores bench_results/)")
    ap.add_argument("--floors", nargs="+", default=["smooth", "frictional"], choices=["smooth", "frictional"])
    args = ap.parse_args()
    rows = []
    work = args.out
    os.makedirs(work, exist_ok=True)
    for floor in args.floors:
        t_cpu, c_cpu, summaries = [], [], []
        for r in range(args.repeats):
            cpu, summary = run_talus(args.talus, floor, work)
            t_cpu.append(cpu)
            summaries.append(summary)
            c_cpu.append(run_cbgeo(args.cbgeo_bin, args.cbgeo_cases, floor))
            print(f"{floor} pair {r + 1}: talus {t_cpu[-1]:.1f} s, CB-Geo {c_cpu[-1]:.1f} s", flush=True)
        s = summaries[0]
        t, c = statistics.median(t_cpu), statistics.median(c_cpu)
        rows.append({"floor": floor, "talus": t, "cbgeo": c, "ratio": c / t, "steps": s["steps"],
                     "cutbacks": s["cutbacks"], "newton": s["newton_iterations"] / s["steps"],
                     "factorizations": s.get("factorizations"),
                     "pairs": len(t_cpu)})
    columns = [("floor", "floor", "{}"), ("talus", "talus CPU s", "{:.1f}"), ("cbgeo", "CB-Geo CPU s", "{:.1f}"),
               ("ratio", "CB-Geo / talus", "{:.2f}"), ("steps", "talus steps", "{}"),
               ("cutbacks", "cut-backs", "{}"), ("newton", "Newton/step", "{:.2f}"),
               ("factorizations", "LU factorizations", "{}"), ("pairs", "pairs", "{}")]
    print()
    print("\n".join(table_lines(rows, columns)))
    print()
    print("\n".join(markdown_lines(rows, columns)))


if __name__ == "__main__":
    main()
