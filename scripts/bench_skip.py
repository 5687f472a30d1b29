#!/usr/bin/python3
"""A scene pays only for what it needs (issue 12, item 7): a benchmark, not a test.

Runs variants of one scene in interleaved rounds and prints the median CPU
time (user + sys of the talus process) per step, and its ratio to the plain
elastic scene measured in the same rounds:

  elastic            an elastic block (10 m wide, 5 m high, E = 1e7 Pa) settling
                     on a fixed floor between slip walls, 2 x 2 particles per cell
  obstacle_far       the same with a rigid half-plane obstacle far above it
                     (never touched: no contact point, no contact row)
  elastic_range_dp   Drucker-Prager with a cohesion of 1e9 Pa: every particle
                     stays in the elastic range (the return mapping's elastic
                     branch only)
  plastic            Drucker-Prager, c = 0, phi = 30: the block spreads
  empty_doubled      the elastic scene in a grid box twice as high (the added
                     half is empty: no particle, no active point)

Usage (alone on the machine; about 2 minutes with the defaults):

    /usr/bin/python3 scripts/bench_skip.py [--cell 0.1] [--steps 10] [--rounds 3] [--talus build/talus]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import markdown_lines, table_lines  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

ELASTIC = "{name: soil, model: linear_elastic, density: 2000, youngs_modulus: 1.0e7, poisson_ratio: 0.3}"
DP_ELASTIC = ("{name: soil, model: drucker_prager, density: 2000, youngs_modulus: 1.0e7, poisson_ratio: 0.3, "
              "friction_angle: 30, cohesion: 1.0e9}")
DP_PLASTIC = ("{name: soil, model: drucker_prager, density: 2000, youngs_modulus: 1.0e7, poisson_ratio: 0.3, "
              "friction_angle: 30, cohesion: 0}")


def case(cell, steps, material, height=8.0, obstacle=False):
    text = (f"grid: {{lower: [0, 0], upper: [20.0, {height}], cell_size: {cell}}}\n"
            f"time: {{end: {steps * 0.01}, step: 0.01}}\n"
            "output: {enabled: false}\n"
            "gravity: [0, -9.81]\n"
            f"materials: [{material}]\n"
            "bodies: [{name: block, material: soil, box: {lower: [0, 0], upper: [10.0, 5.0]}}]\n"
            "boundaries: {x_min: slip, x_max: slip, y_min: fixed, y_max: slip}\n")
    if obstacle:
        text += ("obstacles: [{name: roof, type: half_plane, point: [0, 7.5], normal: [0, -1], friction: 0.3}]\n")
    return text


def run(talus, path):
    before = os.times()
    p = subprocess.run([talus, "run", path, "--overwrite"], capture_output=True, text=True)
    after = os.times()
    if p.returncode != 0:
        sys.exit(f"talus failed on {path}:\n{p.stderr}")
    summary = json.loads(p.stdout.split("talus-summary: ")[1].splitlines()[0])
    cpu = (after.children_user - before.children_user) + (after.children_system - before.children_system)
    return cpu, summary


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--talus", default=os.path.join(REPO, "build", "talus"))
    ap.add_argument("--cell", type=float, default=0.1)
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    variants = {
        "elastic": case(a.cell, a.steps, ELASTIC),
        "obstacle_far": case(a.cell, a.steps, ELASTIC, obstacle=True),
        "elastic_range_dp": case(a.cell, a.steps, DP_ELASTIC),
        "plastic": case(a.cell, a.steps, DP_PLASTIC),
        "empty_doubled": case(a.cell, a.steps, ELASTIC, height=16.0),
    }
    cpu = {k: [] for k in variants}
    summaries = {}
    with tempfile.TemporaryDirectory() as work:
        paths = {}
        for k, text in variants.items():
            paths[k] = os.path.join(work, k + ".yaml")
            with open(paths[k], "w") as f:
                f.write(text)
        for r in range(a.rounds):
            for k in variants:
                seconds, summaries[k] = run(a.talus, paths[k])
                cpu[k].append(seconds)
                print(f"round {r + 1}: {k}: {seconds:.2f} s CPU", flush=True)
    base = statistics.median(cpu["elastic"]) / summaries["elastic"]["steps"]
    rows = []
    for k in variants:
        s = summaries[k]
        per_step = statistics.median(cpu[k]) / s["steps"]
        rows.append({"scene": k, "cpu": statistics.median(cpu[k]), "range": f"{min(cpu[k]):.2f}-{max(cpu[k]):.2f}",
                     "steps": s["steps"], "per_step": per_step * 1e3, "ratio": per_step / base,
                     "particles": s["particles"], "newton": s["newton_iterations"] / s["steps"],
                     "contacts": s["contact_points"]})
    columns = [("scene", "scene", "{}"), ("particles", "particles", "{}"), ("steps", "steps", "{}"),
               ("newton", "Newton/step", "{:.2f}"), ("contacts", "contact points (sum)", "{}"),
               ("cpu", "CPU s (median)", "{:.2f}"), ("range", "range", "{}"), ("per_step", "ms/step", "{:.1f}"),
               ("ratio", "per step / elastic", "{:.3f}")]
    print("\n".join(table_lines(rows, columns)))
    print()
    print("\n".join(markdown_lines(rows, columns)))


if __name__ == "__main__":
    main()
