#!/usr/bin/python3
"""Balanced ranks (docs/parallel.md): 1 rank against 2, with the grid split on
the particles and with PETSc's even split of the box.

Cases (a granular column in the corner of a box twice as wide as its run-out
needs, the shape that leaves ranks idle under an even split):

  reference  inputs/reference_column_smooth.yaml (3,200 particles), --end s
  large      the same column at cell 0.002 m and 0.25 m wide: 100,000
             particles, 125,000 cells, --steps steps of 1e-3 s

Runs (1 rank, 2 ranks balanced, 2 ranks even) in interleaved rounds and
prints the medians of wall time and CPU time (user + sys of mpiexec and its
ranks), the speed-up of wall time against 1 rank (of the whole run, and of
the time loop alone: setup, seeding and the first partition excluded), and the particles on the
least and most loaded rank at the end. A benchmark, not a test: run it alone
on an otherwise idle machine (the speed-up needs 2 idle cores).

    /usr/bin/python3 scripts/bench_ranks.py --case large --steps 5 --repeats 3
"""
import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import markdown_lines, table_lines  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}


def case_text(name, end, steps):
    with open(os.path.join(REPO, "inputs", "reference_column_smooth.yaml")) as f:
        text = f.read()
    if name == "reference":
        return re.sub(r"(?m)^(\s*end:).*$", rf"\1 {end}", text)
    # The large column: cell 0.002 m, 0.25 x 0.4 m, 2 x 2 particles per cell.
    text = re.sub(r"(?m)^(\s*cell_size:).*$", r"\1 0.002", text)
    text = re.sub(r"(?m)^(\s*end:).*$", rf"\1 {steps * 1e-3}", text)
    text = re.sub(r"(?m)^(\s*step:).*$", r"\1 1.0e-3", text)
    text = text.replace("upper: [0.2, 0.4]", "upper: [0.25, 0.4]")
    return text


def run(talus, case, ranks, balance, work):
    text = case + f"\nparallel: {{balance: {'true' if balance else 'false'}}}\n"
    text = re.sub(r"(?m)^output:\n(\s+.*\n)*", "", text)
    text += "output: {enabled: false}\ncheckpoint: {enabled: false}\n"
    path = os.path.join(work, "case.yaml")
    with open(path, "w") as f:
        f.write(text)
    cmd = ([talus] if ranks == 1 else ["mpiexec", "-n", str(ranks), talus]) + ["run", path, "--overwrite"]
    before = os.times()
    t0 = time.monotonic()
    p = subprocess.run(cmd, env={**os.environ, **MPI_ENV}, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wall = time.monotonic() - t0
    after = os.times()
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stderr[-2000:]}")
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    summary = json.loads(p.stdout.split("talus-summary:", 1)[1].splitlines()[0])
    return wall, cpu, summary


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--talus", default=os.path.join(REPO, "build", "talus"))
    ap.add_argument("--case", choices=["reference", "large"], default="reference")
    ap.add_argument("--end", type=float, default=0.2, help="simulated seconds of the reference case")
    ap.add_argument("--steps", type=int, default=5, help="steps of the large case")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    case = case_text(args.case, args.end, args.steps)
    configs = [("1 rank", 1, True), ("2 ranks, balanced", 2, True), ("2 ranks, even split", 2, False)]
    samples = {c[0]: [] for c in configs}
    with tempfile.TemporaryDirectory() as work:
        for r in range(args.repeats):
            for name, ranks, balance in configs:
                samples[name].append(run(args.talus, case, ranks, balance, work))
                wall, cpu, s = samples[name][-1]
                print(f"  round {r + 1}: {name}: wall {wall:.2f} s, CPU {cpu:.2f} s, "
                      f"{s['steps']} steps, ranks {s['final_min_rank_particles']}-{s['final_max_rank_particles']}",
                      file=sys.stderr)
    base = statistics.median(w for w, _, _ in samples["1 rank"])
    base_loop = statistics.median(x["wall_seconds"] for _, _, x in samples["1 rank"])
    rows = []
    for name, ranks, balance in configs:
        wall = statistics.median(w for w, _, _ in samples[name])
        cpu = statistics.median(c for _, c, _ in samples[name])
        s = samples[name][-1][2]
        loop = statistics.median(x["wall_seconds"] for _, _, x in samples[name])
        rows.append({"run": name, "particles": s["particles"], "steps": s["steps"],
                     "newton": s["newton_iterations"], "wall": wall, "cpu": cpu, "speedup": base / wall,
                     "loop": loop, "loop_speedup": base_loop / loop,
                     "min": s["final_min_rank_particles"], "max": s["final_max_rank_particles"],
                     "rebalances": s["rebalances"], "worst": s["worst_imbalance"]})
    columns = [("run", "run", "{}"), ("particles", "particles", "{}"), ("steps", "steps", "{}"),
               ("newton", "Newton its", "{}"), ("wall", "wall s (median)", "{:.2f}"),
               ("cpu", "CPU s (median)", "{:.2f}"), ("speedup", "speed-up (wall)", "{:.2f}"),
               ("loop", "time loop wall s", "{:.2f}"), ("loop_speedup", "time loop speed-up", "{:.2f}"),
               ("min", "fewest particles on a rank", "{}"), ("max", "most", "{}"),
               ("rebalances", "re-partitions", "{}"), ("worst", "worst max/mean", "{:.3f}")]
    print("\n".join(markdown_lines(rows, columns) if args.markdown else table_lines(rows, columns)))


if __name__ == "__main__":
    main()
