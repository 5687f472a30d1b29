#!/usr/bin/python3
"""The 3D landslide at 1e5 particles and more (issue 11's size target: at
least 1e5 particles running 1 s of simulated time on one core;
docs/benchmarks.md#the-3d-landslide-at-1e5-particles).

inputs/landslide_3d_terrain.yaml (588 particles at cell 0.15 m) with a finer
cell: the same terrain, wall, material, friction and 2 x 2 x 2 particles per
cell, `time.step: auto` (docs/solver.md#choosing-the-step). At --cell 0.025
it has 135,133 particles. Runs `talus run` once per cell size on one rank and
prints the CPU time (user + sys), steps, cut-backs, Newton and Krylov
iterations, CPU per particle-step and per particle and Newton iteration,
the peak memory, and the front and kinetic energy at the end.

usage: bench_landslide_3d_large.py [--cell 0.025] [--end 1.0] [--talus build/talus] [--work DIR]
       (about an hour and a half at 0.025 m on this 2-core machine; --cell 0.05: 16,889 particles)
"""
import argparse
import os
import sys
import tempfile

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import run_talus_case, table_lines  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cell", default="0.025", help="comma-separated cell sizes (m)")
    parser.add_argument("--end", type=float, default=1.0, help="simulated time (s)")
    parser.add_argument("--talus", default=os.path.join(HERE, "..", "build", "talus"))
    parser.add_argument("--work", default=None)
    args = parser.parse_args()
    work = args.work or tempfile.mkdtemp(prefix="landslide_3d_large_")
    os.makedirs(work, exist_ok=True)
    inputs = os.path.join(HERE, "..", "inputs")
    terrain = os.path.join(work, "terrain")
    if not os.path.exists(terrain):
        os.symlink(os.path.abspath(os.path.join(inputs, "terrain")), terrain)
    rows = []
    for cell in [float(c) for c in args.cell.split(",")]:
        case = yaml.safe_load(open(os.path.join(inputs, "landslide_3d_terrain.yaml")))
        case["grid"]["cell_size"] = cell
        case["time"]["end"] = args.end
        case["time"]["step"] = "auto"
        case["output"]["directory"] = os.path.join(work, f"output_{cell:g}")
        case["output"]["interval"] = args.end / 10
        path = os.path.join(work, f"landslide_{cell:g}.yaml")
        with open(path, "w") as f:
            yaml.safe_dump(case, f)
        cpu, s = run_talus_case(os.path.abspath(args.talus), path)
        particle_steps = s["particles"] * s["steps"]
        rows.append({"cell": cell, "particles": s["particles"], "cpu": cpu, "steps": s["steps"],
                     "cutbacks": s["cutbacks"], "newton": s["newton_iterations"], "krylov": s["linear_iterations"],
                     "per_step": 1e6 * cpu / particle_steps,
                     "per_newton": 1e6 * cpu / (s["particles"] * s["newton_iterations"]),
                     "rss": s["peak_rss_mb"]})
        print(f"cell {cell:g}: done", file=sys.stderr)
    columns = [("cell", "cell m", "{:g}"), ("particles", "particles", "{:,}"), ("cpu", "CPU s", "{:.1f}"),
               ("steps", "steps", "{}"), ("cutbacks", "cut-backs", "{}"), ("newton", "Newton", "{:,}"),
               ("krylov", "Krylov", "{:,}"), ("per_step", "us/particle-step", "{:.1f}"),
               ("per_newton", "us/particle-Newton", "{:.2f}"), ("rss", "peak MB", "{:.0f}")]
    print("\n".join(table_lines(rows, columns)))


if __name__ == "__main__":
    main()
