#!/usr/bin/python3
"""Granular column-collapse benchmark of talus (issue 3; a benchmark, not a test).

Runs the two column-collapse cases, inputs/column_collapse_psi0.yaml (psi = 0)
and inputs/column_collapse_associated.yaml (psi = phi = 30 degrees), at two
resolutions each:

    coarse   the case as written (cell_size 0.05 m, time.step 0.0025 s)
    fine     cell_size and time.step halved (0.025 m, 0.00125 s)

with the same particles_per_cell (2 per cell and axis). For every run it
reports, from the `talus-summary: {json}` line (src/cli/main.cpp): the wall
time (median over the repeats), accepted steps, time-step cut-backs, Newton
iterations per step (mean = newton_iterations / steps, failed attempts
included; max = max_step_newton_iterations, over the accepted steps); and from
the ParaView output (docs/output.md): the final run-out and height of the
deposit, and their time series for the plot.

Geometry convention. The stored positions are particle centres. With the
initial particle spacing d = cell_size / particles_per_cell, the front is
L = max_p x_p + d/2 and the height H = max_p y_p + d/2 (the outer edge of the
outermost particle's own d x d square). L_0 and H_0 are measured the same way from
the first output (t = 0), which gives 0.5 m and 1.0 m for the column as
written; the reported figures are the run-out (L_f - L_0) / L_0 and the
relative height H_f / H_0 at the last output (t = time.end). Because L
follows the single farthest particle, the bulk front L_99 (the x below which
99 % of the mass lies, + d/2; also 0.5 m at t = 0) is reported as well, as
(L_99 - L_0) / L_0.

Usage (from the repository root; needs Debian's python3-yaml, python3-vtk9 and
python3-matplotlib, so use /usr/bin/python3):

    /usr/bin/python3 scripts/bench_column.py                       # 2 cases x 2 levels, 3 repeats
    /usr/bin/python3 scripts/bench_column.py --repeats 3 --fine-repeats 1
    /usr/bin/python3 scripts/bench_column.py --cases psi0 --levels coarse --repeats 1   # quick look
    /usr/bin/python3 scripts/bench_column.py --talus /work/build-bench/talus
    /usr/bin/python3 scripts/bench_column.py --replot              # table and plot again from the kept output

Writes into OUT (bench_results/column/ in the repository root by default, which
git ignores): the generated cases <case>_<level>.yaml, the talus output
<case>_<level>/particles.pvd, the logs <case>_<level>_run<k>.log, column.csv
(one row per case and level), column_runs.csv (every run), column_series.csv
(front and height at every output time), column.md (the table in Markdown)
and column.png (front and height against time, with the experimental
reference of Lube et al. 2005 for a = 2).
"""

import argparse
import csv
import json
import os
import re
import resource
import shlex
import shutil
import statistics
import subprocess
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after the backend choice)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import machine_busy_seconds, markdown_lines, table_lines  # noqa: E402
from pvd import pvd_series  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

CASES = [
    ("psi0", "inputs/column_collapse_psi0.yaml", "psi = 0"),
    ("associated", "inputs/column_collapse_associated.yaml", "psi = phi"),
]
# Refinement levels: factor applied to grid.cell_size and time.step.
LEVELS = [("coarse", 1.0), ("fine", 0.5)]

# Nominal initial column (the cases as written): width L_0 and height H_0.
L0_NOMINAL, H0_NOMINAL = 0.5, 1.0
ASPECT = H0_NOMINAL / L0_NOMINAL  # a = 2

# Experimental run-out fits of Lube, Huppert, Sparks & Freundt (2005),
# "Collapses of two-dimensional granular columns", Phys. Rev. E 72, 041301:
# dry sand (and other granular materials) in a channel, released onto a
# rough, frictional floor. (L_f - L_0)/L_0 ~ 1.2 a for a < 1.8 and
# ~ 1.9 a^(2/3) for a > 2.8 (approximate fits to their data); a = 2 lies in
# the transition between the two. Their final height follows approximately
# H_f / L_0 ~ a^(2/5) for a above about 1.15. These are experiments, not an
# analytic solution, and neither talus case models their material exactly.
LUBE_LINEAR = 1.2 * ASPECT                 # 2.40 at a = 2
LUBE_POWER = 1.9 * ASPECT ** (2.0 / 3.0)   # 3.02 at a = 2
LUBE_HEIGHT_OVER_L0 = ASPECT ** 0.4        # 1.32 at a = 2, i.e. H_f / H_0 ~ 0.66

# The front L = max x + d/2 follows the single farthest particle. A few
# isolated particles can run ahead of the deposit along the floor, so the table
# also gives the bulk front L_99: the x below which this fraction of the mass
# lies, + d/2 (0.5 m at t = 0, like L).
BULK_FRACTION = 0.99

# Columns of the table: (key, header, format).
COLUMNS = [
    ("case_label", "case", "{}"),
    ("level", "level", "{}"),
    ("cell_size", "cell m", "{:g}"),
    ("dt", "dt s", "{:g}"),
    ("particles", "particles", "{:d}"),
    ("runs", "runs", "{:d}"),
    ("wall_seconds", "wall s (median)", "{:.1f}"),
    ("steps", "steps", "{:d}"),
    ("cutbacks", "cut-backs", "{:d}"),
    ("newton_mean", "Newton/step mean", "{:.2f}"),
    ("newton_max", "Newton/step max", "{:d}"),
    ("ksp_per_step", "KSP/step", "{:.2f}"),
    ("front_final", "L_f m", "{:.3f}"),
    ("runout", "(L_f-L_0)/L_0", "{:.2f}"),
    ("runout99", "(L_99-L_0)/L_0", "{:.2f}"),
    ("height_final", "H_f m", "{:.3f}"),
    ("height_ratio", "H_f/H_0", "{:.3f}"),
    ("front_speed_final", "front m/s at end", "{:.2f}"),
]


def parse_args(argv):
    p = argparse.ArgumentParser(
        description="talus column-collapse benchmark (issue 3): wall time, steps, Newton iterations per step, "
        "cut-backs, final run-out and height, for both psi at two resolutions.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Usage" + __doc__.split("Usage", 1)[1],
    )
    p.add_argument("--talus", default=os.path.join("build", "talus"),
                   help="talus binary (relative paths are taken from the repository root; default build/talus)")
    p.add_argument("--cases", default=",".join(c[0] for c in CASES),
                   help="comma-separated cases (default psi0,associated)")
    p.add_argument("--levels", default=",".join(l[0] for l in LEVELS),
                   help="comma-separated resolutions (default coarse,fine)")
    p.add_argument("--repeats", type=int, default=3,
                   help="runs per case at the coarse level; the median wall time is reported (default 3)")
    p.add_argument("--fine-repeats", type=int, default=None, metavar="N",
                   help="runs per case at the fine level (default: --repeats; the fine associated case takes "
                   "about 35 minutes per run on a 2-core VM, when the run switches to GMRES + GAMG)")
    p.add_argument("--petsc", default="",
                   help="extra PETSc options for every run (write --petsc=\"-opt\" for a single option)")
    p.add_argument("--out", default=None,
                   help="output directory (default bench_results/column/ in the repository root, which git "
                   "ignores; a relative path given here is taken from the current directory)")
    p.add_argument("--timeout", type=float, default=3600.0, help="seconds before a run is killed (default 3600)")
    p.add_argument("--wait-idle", type=float, default=120.0, metavar="SECONDS",
                   help="before each run, wait up to SECONDS for a core to be free (other work skews the timings; "
                   "default 120, 0 to not wait)")
    p.add_argument("--replot", action="store_true",
                   help="run nothing: measure the geometry again from the output kept in OUT (timings from "
                   "OUT/column.csv), rewrite column.csv, column_series.csv and column.md, and redraw the plot")
    args = p.parse_args(argv)

    known_cases = [c[0] for c in CASES]
    args.case_list = [c.strip() for c in args.cases.split(",") if c.strip()]
    if not args.case_list or any(c not in known_cases for c in args.case_list):
        p.error(f"--cases takes a comma-separated subset of {','.join(known_cases)}")
    known_levels = [l[0] for l in LEVELS]
    args.level_list = [l.strip() for l in args.levels.split(",") if l.strip()]
    if not args.level_list or any(l not in known_levels for l in args.level_list):
        p.error(f"--levels takes a comma-separated subset of {','.join(known_levels)}")
    if args.fine_repeats is None:
        args.fine_repeats = args.repeats
    if args.repeats < 1 or args.fine_repeats < 1:
        p.error("--repeats and --fine-repeats must be >= 1")
    if not args.replot:
        talus = args.talus if os.path.isabs(args.talus) else os.path.join(REPO, args.talus)
        if not (os.path.isfile(talus) and os.access(talus, os.X_OK)):
            p.error(f"no talus binary at {talus}; build it with cmake (see README.md) or pass --talus")
        args.talus = talus
    return args


# ---------------------------------------------------------------- cases


def load_yaml(path):
    import yaml  # Debian's python3-yaml
    with open(path) as f:
        return yaml.safe_load(f)


def make_case(source, factor, output_dir):
    """The case of `source` with grid.cell_size and time.step multiplied by
    factor and output.directory set to output_dir; returns (dict, text)."""
    import yaml
    case = load_yaml(os.path.join(REPO, source))
    case["grid"]["cell_size"] = case["grid"]["cell_size"] * factor
    case["time"]["step"] = case["time"]["step"] * factor
    case.setdefault("output", {})
    case["output"]["enabled"] = True
    case["output"]["directory"] = output_dir
    header = (f"# generated by scripts/bench_column.py from {source}\n"
              f"# cell_size and time.step x {factor:g}; output.directory moved under the benchmark directory\n")
    return case, header + yaml.safe_dump(case, sort_keys=False, default_flow_style=None)


def particle_spacing(case):
    """Initial particle spacing of the first body: cell_size / particles_per_cell."""
    ppc = case["bodies"][0].get("particles_per_cell", 2)
    return case["grid"]["cell_size"] / ppc


# ---------------------------------------------------------------- runs


def run_once(args, case_path, log_path, timeout):
    """Runs talus on 1 rank; returns (summary dict or None, output text, exit code, seconds)."""
    cmd = [args.talus, "run", case_path, "--overwrite"] + shlex.split(args.petsc)
    wait_for_free_core(args.wait_idle)
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    busy0 = machine_busy_seconds()
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True, cwd=REPO)
    try:
        out, _ = proc.communicate(timeout=timeout)
        code = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, 9)
        out, _ = proc.communicate()
        out = (out or "") + f"\nbench_column: killed after {timeout:g} s\n"
        code = -9
    elapsed = time.monotonic() - t0
    busy1 = machine_busy_seconds()
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
    _write(log_path, " ".join(cmd) + "\n" + out)
    summary = None
    for line in out.splitlines():
        if line.startswith("talus-summary:"):
            summary = json.loads(line.split(":", 1)[1])
    if summary is not None:
        summary["process_seconds"] = elapsed
        # Cores kept busy by other processes during the run (0 on an idle machine).
        summary["other_cores"] = max(0.0, (busy1 - busy0) - cpu) / elapsed if elapsed > 0 else float("nan")
    return summary, out, code, elapsed


def busy_cores(seconds=1.0):
    """Cores kept busy over a short sample (/proc/stat)."""
    def sample():
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:]]
        idle = v[3] + (v[4] if len(v) > 4 else 0)
        return sum(v[:8]), idle
    try:
        t0, i0 = sample()
        time.sleep(seconds)
        t1, i1 = sample()
    except (OSError, ValueError, IndexError):
        return 0.0
    return (os.cpu_count() or 1) * (1.0 - (i1 - i0) / max(t1 - t0, 1))


def wait_for_free_core(max_seconds):
    """Waits (at most max_seconds) until at least one core is free for the
    serial run; returns the seconds waited."""
    if max_seconds <= 0:
        return 0.0
    limit = (os.cpu_count() or 1) - 0.85
    t0 = time.monotonic()
    warned = False
    while busy_cores() > limit:
        if time.monotonic() - t0 > max_seconds:
            print(f"    (no free core after {max_seconds:g} s; running anyway)", flush=True)
            break
        if not warned:
            print("    (waiting for a free core)", flush=True)
            warned = True
        time.sleep(2.0)
    return time.monotonic() - t0


def failure_reason(out, code):
    """The most telling lines of a failed run's output."""
    lines = [l.strip() for l in out.splitlines() if l.strip()]
    picked = [l[l.find("talus:"):] for l in lines
              if "talus: error" in l or "talus: internal error" in l or "talus: simulation failed" in l][:1]
    picked += [l for l in lines if "PETSC ERROR:" in l][:2]
    if not picked:
        picked = lines[-2:]
    return f"exit code {code}: " + " | ".join(picked)[:300]


def cutback_times(out):
    """Times t of the failed Newton solves printed in the progress output."""
    return [float(m.group(1)) for m in re.finditer(r"Newton failed \(.*?\) at t = (\S+) with h", out)]


def _write(path, text):
    with open(path, "w") as f:
        f.write(text)


# ---------------------------------------------------------------- geometry


def extents(pvtu_path, mass_fraction=BULK_FRACTION):
    """(max x, max y, x below which mass_fraction of the mass lies, particle
    count) of the particle centres in a .pvtu."""
    import numpy as np
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
    r = vtk.vtkXMLPUnstructuredGridReader()
    r.SetFileName(pvtu_path)
    r.Update()
    grid = r.GetOutput()
    pts = grid.GetPoints()
    if pts is None or pts.GetNumberOfPoints() == 0:
        return float("nan"), float("nan"), float("nan"), 0
    x = vtk_to_numpy(pts.GetData())
    m = grid.GetPointData().GetArray("mass")
    m = vtk_to_numpy(m) if m is not None else np.ones(x.shape[0])
    order = np.argsort(x[:, 0], kind="stable")
    cumulative = np.cumsum(m[order]) / m.sum()
    k = min(int(np.searchsorted(cumulative, mass_fraction - 1e-12)), x.shape[0] - 1)
    return float(x[:, 0].max()), float(x[:, 1].max()), float(x[order[k], 0]), int(x.shape[0])


def measure(pvd_path, spacing):
    """Front L = max x + d/2, bulk front L_99 = (x below which 99 % of the
    mass lies) + d/2 and height H = max y + d/2 at every output time."""
    series = []
    for t, path in pvd_series(pvd_path):
        xmax, ymax, xbulk, n = extents(path)
        series.append({"t": t, "front": xmax + 0.5 * spacing, "front99": xbulk + 0.5 * spacing,
                       "height": ymax + 0.5 * spacing, "max_x": xmax, "particles": n})
    return series


# ---------------------------------------------------------------- output


def notes(rows):
    """One line per remark on a row: failures, cut-backs, walls, differing repeats."""
    out = []
    for r in rows:
        name = f"{r['case_label']}, {r['level']}"
        if r.get("error"):
            out.append(f"{name}: FAILED ({r['error']})")
        t_final, t_end = r.get("t_final"), r.get("t_end")
        if isinstance(t_final, (int, float)) and isinstance(t_end, (int, float)) and t_final < t_end - 1e-9:
            out.append(f"{name}: the last output is at t = {r['t_final']:g} s, not time.end = {r['t_end']:g} s; "
                       "L_f and H_f are taken there")
        if r.get("cutback_times"):
            out.append(f"{name}: cut-backs at t = {r['cutback_times']} s")
        if r.get("wall_time_reached") not in (None, ""):
            out.append(f"{name}: the front L reached the last cell before the end of the grid (x = "
                       f"{r['x_max_grid']:g} m, slip wall) at t = {r['wall_time_reached']:.2f} s; "
                       "the wall limits L_f")
        if r.get("repeat_spread"):
            out.append(f"{name}: {r['repeat_spread']}")
        if r.get("other_cores", 0.0) > 0.2:
            out.append(f"{name}: other processes kept {r['other_cores']:.2f} cores busy during the median run")
    return out


def write_markdown(path, rows, note):
    _write(path, "\n".join(markdown_lines(rows, COLUMNS, 2) + ["", note, ""] + ["- " + n for n in notes(rows)] + [""]))


def write_csv(path, rows, keys):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in keys})


def read_csv(path):
    """Rows of a CSV written earlier (numbers converted back)."""
    rows = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            row = {}
            for k, v in r.items():
                if v == "":
                    row[k] = ""
                    continue
                try:
                    row[k] = int(v) if re.fullmatch(r"-?\d+", v) else float(v)
                except ValueError:
                    row[k] = v
            rows.append(row)
    return rows


def plot(path, rows, series, title):
    """Front position and height against time, one line per (case, level),
    with the end of each case's grid and the experimental reference of
    Lube et al. (2005) for a = 2."""
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 6.8))
    colors = {"psi0": "C0", "associated": "C3"}
    styles = {"coarse": "o--", "fine": "s-"}
    walls = {}
    for r in rows:
        pts = [s for s in series if s["case"] == r["case"] and s["level"] == r["level"]]
        if not pts:
            continue
        label = f"{r['case_label']}, {r['level']} (h = {r['cell_size']:g} m)"
        if r.get("error"):
            label += ", failed"
        t = [s["t"] for s in pts]
        kw = dict(color=colors.get(r["case"], "k"), markersize=3.5, linewidth=1.3)
        ax.plot(t, [s["front"] for s in pts], styles.get(r["level"], "-"), label=label + ": L", **kw)
        if all(isinstance(s.get("front99"), float) for s in pts):
            ax.plot(t, [s["front99"] for s in pts], "-" if r["level"] == "fine" else "--", color=kw["color"],
                    linewidth=0.9, alpha=0.45, label=label + ": bulk front L_99")
        bx.plot(t, [s["height"] for s in pts], styles.get(r["level"], "-"), label=label, **kw)
        if isinstance(r.get("x_max_grid"), (int, float)):
            walls.setdefault(float(r["x_max_grid"]), []).append((r["case_label"], kw["color"]))
    for x, owners in sorted(walls.items()):
        names = sorted({n for n, _ in owners})
        ax.axhline(x, color=owners[0][1], linestyle="-", linewidth=3, alpha=0.15,
                   label=f"end of the grid (slip wall), {', '.join(names)}: x = {x:g} m")
    tmax = max([s["t"] for s in series] + [1.5])
    grey = "0.35"
    for value, text, style in ((L0_NOMINAL * (1 + LUBE_LINEAR), f"1.2a = {LUBE_LINEAR:.2f} (fit for a < 1.8)", ":"),
                               (L0_NOMINAL * (1 + LUBE_POWER), f"1.9a^(2/3) = {LUBE_POWER:.2f} (fit for a > 2.8)",
                                "-.")):
        ax.axhline(value, color=grey, linestyle=style, linewidth=1.2,
                   label=f"experiments: (L_f-L_0)/L_0 ~ {text}, L_f ~ {value:.2f} m")
    ax.axhspan(L0_NOMINAL * (1 + LUBE_LINEAR), L0_NOMINAL * (1 + LUBE_POWER), color=grey, alpha=0.08)
    bx.axhline(L0_NOMINAL * LUBE_HEIGHT_OVER_L0, color=grey, linestyle=":", linewidth=1.2,
               label=f"experiments: H_f/L_0 ~ a^(2/5), H_f ~ {L0_NOMINAL * LUBE_HEIGHT_OVER_L0:.2f} m (approx.)")
    ax.set_ylabel("front L = max x + d/2 (m)")
    bx.set_ylabel("height H = max y + d/2 (m)")
    ax.set_title("front position (initial width L_0 = 0.5 m)", fontsize=10)
    bx.set_title("height (initial height H_0 = 1.0 m)", fontsize=10)
    for axis in (ax, bx):
        axis.set_xlabel("time (s)")
        axis.set_xlim(0, tmax)
        axis.grid(True, alpha=0.3)
        axis.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2 if axis is ax else 1,
                    frameon=False)
    ax.set_ylim(0, 1.04 * max([x for x in walls] + [s["front"] for s in series] + [2.5]))
    bx.set_ylim(0, 1.1 * H0_NOMINAL)
    fig.suptitle(title + " (d = cell_size / particles_per_cell, the initial particle spacing)\n"
                 "Grey: Lube, Huppert, Sparks & Freundt (2005), EXPERIMENTS with real sand on a rough, frictional "
                 "floor, a = 2 (approximate fits), not an analytic solution", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ---------------------------------------------------------------- main


# Columns of column.csv (one row per case and level) and column_series.csv.
ROW_KEYS = ["case", "case_label", "level", "cell_size", "dt", "t_end", "particles", "runs", "wall_seconds",
            "wall_min", "wall_max", "steps", "cutbacks", "newton_iterations", "newton_mean", "newton_max",
            "linear_iterations", "ksp_per_step", "solve_seconds", "transfer_seconds", "peak_rss_mb", "other_cores",
            "spacing", "L0", "H0", "t_final", "front_final", "runout", "front99_final", "runout99", "height_final",
            "height_ratio", "front_speed_final", "x_max_grid", "wall_time_reached", "cutback_times",
            "repeat_spread", "error"]
SERIES_KEYS = ["case", "level", "t", "front", "front99", "height", "max_x", "particles"]


def geometry(row, outputs, spacing, cell_size):
    """Adds the run-out and height figures of the output series to row."""
    if outputs:
        first, final = outputs[0], outputs[-1]
        row.update(L0=first["front"], H0=first["height"], t_final=final["t"], front_final=final["front"],
                   height_final=final["height"], runout=(final["front"] - first["front"]) / first["front"],
                   front99_final=final["front99"], runout99=(final["front99"] - first["front"]) / first["front"],
                   height_ratio=final["height"] / first["height"], spacing=spacing)
        if len(outputs) > 1:
            # Mean front speed over the last output interval: ~0 once the deposit has stopped.
            prev = outputs[-2]
            row["front_speed_final"] = (final["front"] - prev["front"]) / max(final["t"] - prev["t"], 1e-30)
        # The slip wall at the grid end (v_x = 0 at its nodes) slows the
        # particles of the last cell: a front L within one cell of the grid
        # end has reached the wall, and the wall limits the run-out.
        at_wall = [s["t"] for s in outputs if s["front"] >= row["x_max_grid"] - cell_size]
        if at_wall:
            row["wall_time_reached"] = at_wall[0]


def summarise(args, name, label, level, case, runs, outputs, spacing, error):
    """One table row from the runs of a (case, level)."""
    row = {"case": name, "case_label": label, "level": level, "cell_size": case["grid"]["cell_size"],
           "dt": case["time"]["step"], "t_end": case["time"]["end"], "runs": len(runs),
           "x_max_grid": case["grid"]["upper"][0],
           "error": error or ""}
    if runs:
        walls = [s["wall_seconds"] for s in runs]
        med = statistics.median(walls)
        median_run = min(runs, key=lambda s: abs(s["wall_seconds"] - med))
        last = runs[-1]
        steps = max(last["steps"], 1)
        row.update(
            particles=last["particles"], wall_seconds=med, wall_min=min(walls), wall_max=max(walls),
            steps=last["steps"], cutbacks=last["cutbacks"], newton_iterations=last["newton_iterations"],
            newton_mean=last["newton_iterations"] / steps, newton_max=last["max_step_newton_iterations"],
            linear_iterations=last["linear_iterations"], ksp_per_step=last["linear_iterations"] / steps,
            solve_seconds=median_run["solve_seconds"], transfer_seconds=median_run["transfer_seconds"],
            other_cores=median_run["other_cores"], peak_rss_mb=last["peak_rss_mb"])
        keys = ("steps", "cutbacks", "newton_iterations", "linear_iterations")
        differ = [k for k in keys if len({s[k] for s in runs}) > 1]
        if differ:
            row["repeat_spread"] = "the repeats differ in " + ", ".join(
                f"{k} ({', '.join(str(s[k]) for s in runs)})" for k in differ) + "; the last run is reported"
    geometry(row, outputs, spacing, case["grid"]["cell_size"])
    return row


def main(argv=None):
    args = parse_args(argv)
    out_dir = os.path.abspath(args.out) if args.out else os.path.join(REPO, "bench_results", "column")
    os.makedirs(out_dir, exist_ok=True)
    csv_path = os.path.join(out_dir, "column.csv")
    series_path = os.path.join(out_dir, "column_series.csv")
    png_path = os.path.join(out_dir, "column.png")
    if args.replot:
        # Timings and iterations from column.csv; the geometry is measured
        # again from the output kept in OUT/<case>_<level>/, where it exists.
        rows, series = read_csv(csv_path), read_csv(series_path)
        remeasured = []
        for r in rows:
            tag = f"{r['case']}_{r['level']}"
            pvd = os.path.join(out_dir, tag, "particles.pvd")
            case_path = os.path.join(out_dir, tag + ".yaml")
            if os.path.isfile(pvd) and os.path.isfile(case_path):
                case = load_yaml(case_path)
                outputs = measure(pvd, particle_spacing(case))
                geometry(r, outputs, particle_spacing(case), case["grid"]["cell_size"])
                series = [s for s in series if not (s["case"] == r["case"] and s["level"] == r["level"])]
                series += [dict(s, case=r["case"], level=r["level"]) for s in outputs]
                remeasured.append(tag)
        if remeasured:
            write_csv(csv_path, rows, ROW_KEYS)
            write_csv(series_path, series, SERIES_KEYS)
        note = ("redrawn with --replot" + (f"; geometry measured again from the output of {', '.join(remeasured)}"
                                           if remeasured else ""))
        write_markdown(os.path.join(out_dir, "column.md"), rows, note)
        plot(png_path, rows, series, "talus granular column collapse, a = 2")
        print("\n".join(table_lines(rows, COLUMNS)))
        print(note)
        print("\n".join("note: " + n for n in notes(rows)))
        return 0

    start = time.monotonic()
    print(f"bench_column: talus {args.talus}, output {out_dir}", flush=True)
    print(f"bench_column: cases {args.case_list}, levels {args.level_list}, repeats {args.repeats} (coarse), "
          f"{args.fine_repeats} (fine), 1 rank" + (f", extra PETSc options '{args.petsc}'" if args.petsc else ""),
          flush=True)
    rows, raw, all_series = [], [], []
    for name, source, label in CASES:
        if name not in args.case_list:
            continue
        for level, factor in LEVELS:
            if level not in args.level_list:
                continue
            tag = f"{name}_{level}"
            output_dir = os.path.join(out_dir, tag)
            case, text = make_case(source, factor, output_dir)
            case_path = os.path.join(out_dir, tag + ".yaml")
            _write(case_path, text)
            spacing = particle_spacing(case)
            repeats = args.repeats if level == "coarse" else args.fine_repeats
            print(f"{label}, {level}: cell_size {case['grid']['cell_size']:g} m, step {case['time']['step']:g} s, "
                  f"end {case['time']['end']:g} s, grid x to {case['grid']['upper'][0]:g} m, "
                  f"{repeats} run(s)", flush=True)
            runs, error, cuts = [], None, []
            for k in range(repeats):
                shutil.rmtree(output_dir, ignore_errors=True)  # no stale outputs of an earlier run
                log = os.path.join(out_dir, f"{tag}_run{k + 1}.log")
                s, out, code, elapsed = run_once(args, case_path, log, args.timeout)
                cuts = cutback_times(out)
                if code != 0 or s is None:
                    error = failure_reason(out, code) + f" (log {os.path.relpath(log, REPO)})"
                    print(f"  run {k + 1}/{repeats}: FAILED after {elapsed:.1f} s: {error}", flush=True)
                    break
                runs.append(s)
                raw.append(dict(s, case=name, level=level, repeat=k + 1))
                print(f"  run {k + 1}/{repeats} (other work {s['other_cores']:.2f} cores): wall "
                      f"{s['wall_seconds']:.1f} s, {s['steps']} steps, {s['cutbacks']} cut-backs, "
                      f"{s['newton_iterations']} Newton (max {s['max_step_newton_iterations']}/step), "
                      f"{s['linear_iterations']} KSP", flush=True)
            pvd = os.path.join(output_dir, "particles.pvd")
            outputs = measure(pvd, spacing) if os.path.isfile(pvd) else []
            row = summarise(args, name, label, level, case, runs, outputs, spacing, error)
            if cuts:
                row["cutback_times"] = " ".join(f"{t:.4g}" for t in cuts[:12]) + (" ..." if len(cuts) > 12 else "")
            rows.append(row)
            for s in outputs:
                all_series.append(dict(s, case=name, level=level))
            if outputs:
                print(f"  run-out (L_f - L_0)/L_0 = {row['runout']:.3f} (L_f = {row['front_final']:.3f} m, "
                      f"L_0 = {row['L0']:.3f} m), bulk (L_99 - L_0)/L_0 = {row['runout99']:.3f}, "
                      f"H_f/H_0 = {row['height_ratio']:.3f} "
                      f"(H_f = {row['height_final']:.3f} m) at t = {row['t_final']:g} s", flush=True)

    write_csv(csv_path, rows, ROW_KEYS)
    write_csv(os.path.join(out_dir, "column_runs.csv"), raw,
              ["case", "level", "repeat", "particles", "steps", "cutbacks", "newton_iterations",
               "max_step_newton_iterations", "linear_iterations", "wall_seconds", "solve_seconds",
               "transfer_seconds", "process_seconds", "peak_rss_mb", "other_cores"])
    write_csv(series_path, all_series, SERIES_KEYS)
    total = time.monotonic() - start
    note = (f"wall time: median of the runs (column runs), 1 rank; run-out and height at t = time.end from the "
            f"last run, L = max x + d/2, H = max y + d/2, d = cell_size / particles_per_cell; "
            f"whole benchmark {total / 60:.1f} min")
    write_markdown(os.path.join(out_dir, "column.md"), rows, note)
    if all_series:
        plot(png_path, rows, all_series, "talus granular column collapse, a = 2")

    print()
    print("\n".join(table_lines(rows, COLUMNS)))
    print(note)
    print("\n".join("note: " + n for n in notes(rows)))
    print(f"bench_column: wrote {out_dir}/column.csv, column_runs.csv, column_series.csv, column.md"
          + (", column.png" if all_series else ""))
    return 0 if all(not r.get("error") for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
