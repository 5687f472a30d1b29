#!/usr/bin/python3
"""Core throughput benchmark of talus (a benchmark, not a test).

Generates 2D elastic cases in a temporary directory, runs `talus run` on them
(serial and, unless --no-mpi, with `mpiexec -n RANKS`), once per solver
configuration, --repeats times each, and reports the median of every figure.

The case: a square elastic soil block (density 2000 kg/m3, E = 1e7 Pa,
nu = 0.3) of side 10 m settling under gravity in a box with slip side walls and
a fixed floor, quadratic B-splines, 2 x 2 particles per cell; the body fills
the box width and the grid has 4 empty cells above it. The cell size is
chosen so that the particle count is close to each requested size.

Figures come from the `talus-summary: {json}` line printed at the end of a run
(see src/cli/main.cpp); docs/benchmarks.md explains every column.

Usage (from the repository root; needs matplotlib, Debian's python3-matplotlib):

    /usr/bin/python3 scripts/bench_core.py                   # 1e4 and 1e5 particles
    /usr/bin/python3 scripts/bench_core.py --sizes 1e4 --repeats 1 --no-mpi
    /usr/bin/python3 scripts/bench_core.py --steps 10,3      # 3 steps for the 2nd size
    /usr/bin/python3 scripts/bench_core.py --petsc="-talus_mat_type baij"   # '=' for a single option
    /usr/bin/python3 scripts/bench_core.py --solver cg-gamg="-talus_ksp_type cg -talus_pc_type gamg"

Writes OUT/bench_core.csv (medians), OUT/bench_core_runs.csv (every run),
OUT/bench_core.md (the table in Markdown) and OUT/bench_core.png
(time per step against particles), OUT being bench_results/ in the repository root by default.
"""

import argparse
import csv
import json
import math
import os
import resource
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after the backend choice)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import machine_busy_seconds, markdown_lines, table_lines  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Solver configurations compared by default: PETSc options added to the command
# line of `talus run`. "direct" adds none: with solver.direct_solver_limit set
# above any system size in the case (--direct-limit), talus' defaults give
# preonly + LU, PETSc's own LU in serial and MUMPS in parallel
# (src/solver/newton.cpp).
DEFAULT_SOLVERS = [
    ("direct", ""),
    ("gmres-gamg", "-talus_ksp_type gmres -talus_pc_type gamg -talus_ksp_rtol 1e-10"),
]

BLOCK_SIDE = 10.0  # m
HEADROOM_CELLS = 4  # empty cells above the block
DENSITY, YOUNGS, POISSON = 2000.0, 1.0e7, 0.3
PPC = 2  # particles per cell and axis

# talus reports peak_rss_mb = ru_maxrss / 1024, i.e. in MiB.
MIB = 1024.0 * 1024.0

MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}

# Columns of the table: (key, header, format).
COLUMNS = [
    ("solver", "solver", "{}"),
    ("ranks", "ranks", "{:d}"),
    ("particles", "particles", "{:d}"),
    ("steps", "steps", "{:d}"),
    ("cutbacks", "cutbacks", "{:g}"),
    ("updates_per_s", "P2G+G2P upd/s", "{:.3g}"),
    ("transfer_s_per_step", "transfer s/step", "{:.4f}"),
    ("solve_s_per_step", "solve s/step", "{:.4f}"),
    ("wall_s_per_step", "wall s/step", "{:.4f}"),
    ("newton_per_step", "Newton/step", "{:.2f}"),
    ("ksp_per_step", "KSP/step", "{:.1f}"),
    ("peak_rss_mb", "peak RSS MiB", "{:.1f}"),
    ("bytes_per_particle", "B/particle", "{:.0f}"),
    ("baseline_rss_mb", "baseline MiB", "{:.1f}"),
    ("bytes_per_particle_above_baseline", "B/particle above base", "{:.0f}"),
]


def parse_args(argv):
    p = argparse.ArgumentParser(
        description="talus core benchmark: P2G/G2P throughput, time per implicit step, "
        "Newton/KSP iterations and memory per particle (medians of --repeats runs).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Usage" + __doc__.split("Usage", 1)[1],
    )
    p.add_argument("--talus", default=os.path.join("build", "talus"),
                   help="talus binary (relative paths are taken from the repository root; default build/talus)")
    p.add_argument("--sizes", default="1e4,1e5",
                   help="comma-separated target particle counts (default 1e4,1e5)")
    p.add_argument("--steps", default="10",
                   help="time steps per run: one number, or one per size, comma-separated (default 10)")
    p.add_argument("--dt", type=float, default=0.005, help="time step in s (default 0.005)")
    p.add_argument("--direct-limit", type=int, default=1000000000, metavar="N",
                   help="solver.direct_solver_limit written into the cases (default 1000000000: talus' direct "
                   "LU default at every size, so that a configuration's PETSc options alone choose the solver; "
                   "-1 leaves the key out, and talus switches to GMRES + GAMG above solver.direct_solver_limit (default 5000) unknowns)")
    p.add_argument("--repeats", type=int, default=3, help="runs per row; medians are reported (default 3)")
    p.add_argument("--ranks", type=int, default=2, help="MPI ranks of the parallel rows (default 2)")
    p.add_argument("--no-mpi", action="store_true", help="serial rows only")
    p.add_argument("--petsc", default="",
                   help='extra PETSc options for every run, e.g. "-talus_ksp_type cg -talus_pc_type gamg" '
                   "(placed last on the command line, so they override a configuration's own options)")
    p.add_argument("--solver", action="append", metavar="NAME=OPTIONS", default=None,
                   help="a solver configuration (repeatable); replaces the default pair "
                   "direct and gmres-gamg; NAME= with no options means talus' defaults")
    p.add_argument("--out", default=None,
                   help="output directory (default bench_results/ in the repository root, which git ignores; "
                   "a relative path given here is taken from the current directory)")
    p.add_argument("--timeout", type=float, default=3600.0, help="seconds before a run is killed (default 3600)")
    p.add_argument("--wait-idle", type=float, default=300.0, metavar="SECONDS",
                   help="before each run, wait up to SECONDS for the cores to be idle (other work skews the "
                   "timings; default 300, 0 to not wait)")
    p.add_argument("--replot", action="store_true",
                   help="run nothing: print the table and redraw the plot from OUT/bench_core.csv")
    p.add_argument("--keep-cases", action="store_true", help="keep the generated case files and logs")
    p.add_argument("--no-baseline", action="store_true", help="skip the tiny baseline-memory runs")
    args = p.parse_args(argv)

    try:
        args.size_list = [int(round(float(s))) for s in args.sizes.split(",") if s.strip()]
    except ValueError:
        p.error("--sizes must be numbers, e.g. 1e4,1e5")
    if not args.size_list or min(args.size_list) < 4:
        p.error("--sizes must hold particle counts >= 4")
    try:
        steps = [int(s) for s in args.steps.split(",") if s.strip()]
    except ValueError:
        p.error("--steps must be whole numbers")
    if len(steps) == 1:
        steps = steps * len(args.size_list)
    if len(steps) != len(args.size_list) or min(steps) < 1:
        p.error("--steps needs one positive number, or one per size")
    args.step_list = steps
    if args.repeats < 1 or args.ranks < 2 or args.dt <= 0:
        p.error("--repeats must be >= 1, --ranks >= 2 and --dt > 0")
    if args.solver:
        args.solver_list = []
        for s in args.solver:
            name, sep, opts = s.partition("=")
            if not sep or not name.strip():
                p.error("--solver takes NAME=OPTIONS, e.g. lu-mumps=\"-talus_pc_factor_mat_solver_type mumps\"")
            args.solver_list.append((name.strip(), opts.strip()))
    else:
        args.solver_list = list(DEFAULT_SOLVERS)
    talus = args.talus if os.path.isabs(args.talus) else os.path.join(REPO, args.talus)
    if not (os.path.isfile(talus) and os.access(talus, os.X_OK)):
        p.error(f"no talus binary at {talus}; build it with cmake (see README.md) or pass --talus")
    args.talus = talus
    return args


# ---------------------------------------------------------------- cases


def block_geometry(target_particles, ppc=PPC):
    """Cells per side n of the square block and the cell size h (10 m / n)."""
    n = max(3, int(round(math.sqrt(target_particles / ppc**2))))
    return n, BLOCK_SIDE / n


def case_yaml(cells, cell_size, height_cells, body_cells, steps, dt, direct_limit, ppc=PPC):
    """A 2D elastic block under gravity: body of body_cells x body_cells cells
    in a box cells wide and height_cells high. direct_limit < 0 leaves
    solver.direct_solver_limit out (talus' default)."""
    solver = "" if direct_limit < 0 else f"solver:\n  direct_solver_limit: {direct_limit:d}\n"
    width = repr(cells * cell_size)
    height = repr(height_cells * cell_size)
    body = repr(body_cells * cell_size)
    return f"""# generated by scripts/bench_core.py
grid:
  lower: [0.0, 0.0]
  upper: [{width}, {height}]
  cell_size: {cell_size!r}
  shape_function: quadratic_bspline
time:
  end: {steps * dt!r}
  step: {dt!r}
output: {{enabled: false}}
gravity: [0.0, -9.81]
materials:
  - name: soil
    model: linear_elastic
    density: {DENSITY}
    youngs_modulus: {YOUNGS}
    poisson_ratio: {POISSON}
bodies:
  - name: block
    material: soil
    box: {{lower: [0.0, 0.0], upper: [{body}, {body}]}}
    particles_per_cell: {ppc}
boundaries:
  x_min: slip
  x_max: slip
  y_min: fixed
  y_max: slip
{solver}"""


def block_case(target_particles, steps, dt, direct_limit=-1):
    n, h = block_geometry(target_particles)
    return case_yaml(n, h, n + HEADROOM_CELLS, n, steps, dt, direct_limit), n


def tiny_case(dt, direct_limit=-1):
    """Baseline for the fixed cost of a process: 4 x 4 cells, a 2 x 2-cell body (16 particles), 1 step."""
    return case_yaml(4, 0.25, 4, 2, 1, dt, direct_limit)


# ---------------------------------------------------------------- runs


def command(args, case_path, ranks, options):
    cmd = [args.talus, "run", case_path, "--overwrite"] + shlex.split(options) + shlex.split(args.petsc)
    if ranks > 1:
        mpi = ["mpiexec", "-n", str(ranks)]
        if ranks > (os.cpu_count() or 1):
            mpi.append("--oversubscribe")
        cmd = mpi + cmd
    return cmd


def run_once(args, case_path, ranks, options, log_path, timeout=None):
    """Runs talus; returns the summary dict, or raises RuntimeError with the reason."""
    timeout = args.timeout if timeout is None else min(timeout, args.timeout)
    cmd = command(args, case_path, ranks, options)
    env = dict(os.environ)
    if ranks > 1:
        env.update(MPI_ENV)
    wait_until_idle(args.wait_idle)
    load = os.getloadavg()[0]  # other work on the machine skews the timings
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    busy0 = machine_busy_seconds()
    t0 = time.monotonic()
    # A new session, so that a timeout can kill mpiexec and its ranks together.
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                            start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, 9)
        out, _ = proc.communicate()
        _write(log_path, " ".join(cmd) + "\n" + (out or ""))
        raise RuntimeError(f"killed after {timeout:g} s, no answer (log {log_path})")
    elapsed = time.monotonic() - t0
    busy1 = machine_busy_seconds()
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
    _write(log_path, " ".join(cmd) + "\n" + out)
    summary = None
    for line in out.splitlines():
        if line.startswith("talus-summary:"):
            summary = json.loads(line.split(":", 1)[1])
    if proc.returncode != 0 or summary is None:
        raise RuntimeError(f"exit code {proc.returncode}, {'no' if summary is None else 'a'} summary line: "
                           f"{failure_reason(out)} (log {log_path})")
    summary["process_seconds"] = elapsed
    summary["load_before"] = load
    # Cores kept busy by other processes during the run: the machine's busy CPU
    # time minus this run's own (all ranks), over the elapsed time. Near 0 on
    # an idle machine; 0.5 means half a core went to other work.
    summary["other_cores"] = max(0.0, (busy1 - busy0) - cpu) / elapsed if elapsed > 0 else float("nan")
    return summary


def cpu_busy_fraction(seconds=1.0):
    """Fraction of all cores' time spent busy over a short sample (/proc/stat)."""
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
    return 1.0 - (i1 - i0) / max(t1 - t0, 1)


def wait_until_idle(max_seconds, busy_limit=0.15):
    """Waits (at most max_seconds) until the cores are idle, so that other work
    does not share them with the run; returns the seconds waited."""
    if max_seconds <= 0:
        return 0.0
    t0 = time.monotonic()
    warned = False
    while cpu_busy_fraction() > busy_limit:
        if time.monotonic() - t0 > max_seconds:
            print(f"    (the machine is still busy after {max_seconds:g} s; running anyway)", flush=True)
            break
        if not warned:
            print("    (waiting for other work on the machine to finish)", flush=True)
            warned = True
        time.sleep(2.0)
    return time.monotonic() - t0


def failure_reason(out):
    """The most telling lines of a failed run's output."""
    lines = [l.strip() for l in out.splitlines() if l.strip()]
    picked = [l[l.find("talus:"):] for l in lines
              if "talus: error" in l or "talus: internal error" in l or "talus: simulation failed" in l][:1]
    skip = ("Option left", "Configure options", "WARNING!", "See https", "Petsc Release", "------", " on a ",
            "#")
    picked += [l for l in lines if "PETSC ERROR:" in l and not any(k in l for k in skip)][:2]
    if not picked:
        picked = lines[-3:]
    return " | ".join(picked)[:400]


def _write(path, text):
    with open(path, "w") as f:
        f.write(text)


def derived(s, ranks):
    """Per-run figures of one summary."""
    steps = max(s["steps"], 1)
    tr = s["transfer_seconds"]
    return {
        "ranks": ranks,
        "particles": s["particles"],
        "steps": s["steps"],
        "cutbacks": s["cutbacks"],
        "updates_per_s": s["particles"] * s["steps"] / tr if tr > 0 else float("nan"),
        "transfer_s_per_step": tr / steps,
        "solve_s_per_step": s["solve_seconds"] / steps,
        "wall_s_per_step": s["wall_seconds"] / steps,
        "newton_per_step": s["newton_iterations"] / steps,
        "ksp_per_step": s["linear_iterations"] / steps,
        "peak_rss_mb": s["peak_rss_mb"],
        "bytes_per_particle": s["peak_rss_mb"] * MIB / s["particles"],
        "wall_seconds": s["wall_seconds"],
        "transfer_seconds": tr,
        "solve_seconds": s["solve_seconds"],
        "process_seconds": s["process_seconds"],
        "load_before": s["load_before"],
        "other_cores": s["other_cores"],
    }


def median_row(runs):
    row = {}
    for key, value in runs[0].items():
        if isinstance(value, (int, float)):
            med = statistics.median(r[key] for r in runs)
            row[key] = int(med) if isinstance(value, int) and float(med).is_integer() else med
        else:
            row[key] = value
    return row


# ---------------------------------------------------------------- output


def write_csv(path, rows, keys):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in keys})


def plot(path, rows, title):
    """Two log-log panels against particles, one line per (solver, ranks):
    wall time per step (solid) with its solve part (dashed), and the transfer
    time per step (P2G + G2P + migration)."""
    from matplotlib.ticker import FuncFormatter
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.8))
    configs = []
    for r in rows:
        c = (r["solver"], int(r["ranks"]))
        if c not in configs:
            configs.append(c)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (solver, ranks) in enumerate(configs):
        pts = sorted((r["particles"], r["wall_s_per_step"], r["solve_s_per_step"], r["transfer_s_per_step"])
                     for r in rows if r["solver"] == solver and int(r["ranks"]) == ranks)
        if not pts:
            continue
        n = [p[0] for p in pts]
        color = colors[i % len(colors)]
        label = f"{solver}, {ranks} rank{'s' if ranks > 1 else ''}"
        ax.plot(n, [p[1] for p in pts], "o-", color=color, label=label + " (wall)")
        ax.plot(n, [p[2] for p in pts], "x--", color=color, alpha=0.6, label=label + " (solve)")
        bx.plot(n, [p[3] for p in pts], "o-", color=color, label=label)
    plain = FuncFormatter(lambda v, _: f"{v:g}")
    # minor ticks: label 2x and 5x the powers of ten only
    minor = FuncFormatter(
        lambda v, _: f"{v:g}" if v > 0 and round(v / 10 ** math.floor(math.log10(v) + 1e-9)) in (2, 5) else "")
    for axis, ylabel, sub in ((ax, "seconds per implicit step", "time per step: wall (solid), solve (dashed)"),
                              (bx, "seconds per step", "transfers per step (stencils, P2G, G2P, migration)")):
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.yaxis.set_major_formatter(plain)
        axis.yaxis.set_minor_formatter(minor)
        axis.set_xlabel("particles")
        axis.set_ylabel(ylabel)
        axis.set_title(sub, fontsize=10)
        axis.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def read_rows(path):
    """Rows of a bench_core.csv written earlier (numbers converted back)."""
    rows = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            row = {}
            for k, v in r.items():
                try:
                    row[k] = int(v) if v.lstrip("-").isdigit() else float(v) if v not in ("", "nan") else v
                except ValueError:
                    row[k] = v
                if v == "nan":
                    row[k] = float("nan")
            row["runs"] = row.get("runs") or 0
            rows.append(row)
    return rows


# ---------------------------------------------------------------- main


def main(argv=None):
    args = parse_args(argv)
    out_dir = os.path.abspath(args.out) if args.out else os.path.join(REPO, "bench_results")
    os.makedirs(out_dir, exist_ok=True)
    if args.replot:
        rows = read_rows(os.path.join(out_dir, "bench_core.csv"))
        good = [r for r in rows if r.get("runs")]
        if good:
            plot(os.path.join(out_dir, "bench_core.png"), good,
                 f"talus 2D elastic block (medians of {max(r['runs'] for r in good)} run(s))")
        print("\n".join(table_lines(rows, COLUMNS)))
        return 0
    rank_list = [1] if args.no_mpi else [1, args.ranks]
    work = tempfile.mkdtemp(prefix="talus_bench_")
    print(f"bench_core: talus {args.talus}, work directory {work}", flush=True)
    print(f"bench_core: sizes {args.size_list}, steps {args.step_list}, dt {args.dt:g} s, "
          f"{args.repeats} repeat(s), ranks {rank_list}, solvers {[n for n, _ in args.solver_list]}"
          + (f", extra PETSc options '{args.petsc}'" if args.petsc else ""), flush=True)

    baseline = {}  # (solver, ranks) -> median peak RSS of the tiny case
    if not args.no_baseline:
        tiny = os.path.join(work, "tiny.yaml")
        _write(tiny, tiny_case(args.dt, args.direct_limit))
        for solver, options in args.solver_list:
            for ranks in rank_list:
                rss = []
                for k in range(args.repeats):
                    log = os.path.join(work, f"tiny_{solver}_np{ranks}_{k}.log")
                    try:
                        rss.append(run_once(args, tiny, ranks, options, log, timeout=120)["peak_rss_mb"])
                    except RuntimeError as e:
                        print(f"  baseline {solver} np{ranks}: FAILED: {e}", flush=True)
                        break
                if rss:
                    baseline[(solver, ranks)] = statistics.median(rss)
                    print(f"  baseline {solver}, {ranks} rank(s): peak RSS {baseline[(solver, ranks)]:.1f} MiB",
                          flush=True)

    rows, raw = [], []
    for size, steps in zip(args.size_list, args.step_list):
        text, n = block_case(size, steps, args.dt, args.direct_limit)
        case = os.path.join(work, f"block_{size}.yaml")
        _write(case, text)
        print(f"size {size:g}: block {n} x {n} cells (h = {BLOCK_SIDE / n:.5g} m), "
              f"{(PPC * n) ** 2} particles, {steps} steps", flush=True)
        for solver, options in args.solver_list:
            serial_seconds = None
            for ranks in rank_list:
                runs, error = [], None
                # A parallel run that hangs (a rank stuck in a collective) is
                # given up after 10x the serial time (at least 120 s).
                limit = None if serial_seconds is None else max(120.0, 10.0 * serial_seconds)
                for k in range(args.repeats):
                    log = os.path.join(work, f"block_{size}_{solver}_np{ranks}_{k}.log")
                    try:
                        s = run_once(args, case, ranks, options, log, timeout=limit)
                    except RuntimeError as e:
                        error = str(e)
                        print(f"  {solver}, {ranks} rank(s), run {k + 1}: FAILED: {e}", flush=True)
                        break
                    d = derived(s, ranks)
                    d.update(solver=solver, size=size, repeat=k + 1)
                    runs.append(d)
                    raw.append(d)
                    print(f"  {solver}, {ranks} rank(s), run {k + 1}/{args.repeats} "
                          f"(other work {s['other_cores']:.2f} cores): wall {s['wall_seconds']:.3f} s "
                          f"(transfer {s['transfer_seconds']:.3f}, solve {s['solve_seconds']:.3f}), "
                          f"{s['newton_iterations']} Newton, {s['linear_iterations']} KSP, "
                          f"{s['peak_rss_mb']:.1f} MiB", flush=True)
                if runs:
                    row = median_row(runs)
                    row["runs"] = len(runs)
                    if ranks == 1:
                        serial_seconds = row["process_seconds"]
                else:
                    row = {"solver": solver, "ranks": ranks, "particles": (PPC * n) ** 2, "runs": 0}
                row["size"] = size
                row["solver_options"] = (options + " " + args.petsc).strip()
                row["error"] = error or ""
                base = baseline.get((solver, ranks))
                if base is not None and runs:
                    row["baseline_rss_mb"] = base
                    row["bytes_per_particle_above_baseline"] = (row["peak_rss_mb"] - base) * MIB / row["particles"]
                if runs and row["steps"] != steps:
                    row["error"] = (row["error"] + f"; {row['steps']} steps instead of {steps} (cut-backs)")
                    row["error"] = row["error"].lstrip("; ")
                rows.append(row)

    keys = ["solver", "ranks", "size", "particles", "steps", "cutbacks", "runs", "updates_per_s",
            "transfer_s_per_step", "solve_s_per_step", "wall_s_per_step", "newton_per_step", "ksp_per_step",
            "peak_rss_mb", "bytes_per_particle", "baseline_rss_mb", "bytes_per_particle_above_baseline",
            "wall_seconds", "transfer_seconds", "solve_seconds", "process_seconds", "other_cores", "solver_options",
            "error"]
    write_csv(os.path.join(out_dir, "bench_core.csv"), rows, keys)
    per_run = ("runs", "baseline_rss_mb", "bytes_per_particle_above_baseline", "other_cores", "solver_options",
               "error")
    write_csv(os.path.join(out_dir, "bench_core_runs.csv"), raw,
              ["solver", "ranks", "size", "repeat", "load_before", "other_cores"]
              + [k for k in keys[3:] if k not in per_run])
    note = f"medians of {args.repeats} run(s); dt = {args.dt:g} s"
    _write(os.path.join(out_dir, "bench_core.md"), "\n".join(markdown_lines(rows, COLUMNS, 1) + ["", note, ""]))
    good = [r for r in rows if r.get("runs")]
    if good:
        plot(os.path.join(out_dir, "bench_core.png"), good, f"talus 2D elastic block ({note})")

    print()
    print("\n".join(table_lines(rows, COLUMNS)))
    print(note + "; memory: the largest rank's peak RSS in MiB (talus' peak_rss_mb), "
          "B/particle = MiB x 2^20 / all particles")
    for r in rows:
        if r.get("runs") and r.get("other_cores", 0.0) > 0.2:
            print(f"note: {r['solver']}, {r['ranks']} rank(s), {r['particles']} particles: other processes kept "
                  f"{r['other_cores']:.2f} cores busy during the median run; the timings are skewed")
        if r.get("error"):
            print(f"note: {r['solver']}, {r['ranks']} rank(s), {r['particles']} particles: {r['error']}")
    print(f"bench_core: wrote {out_dir}/bench_core.csv, bench_core_runs.csv, bench_core.md"
          + (", bench_core.png" if good else ""))
    if not args.keep_cases:
        if any(r.get("error") for r in rows):
            print(f"bench_core: kept {work} (logs of the failed runs)")
        else:
            shutil.rmtree(work, ignore_errors=True)
    return 0 if all(r.get("runs") for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
