#!/usr/bin/python3
"""Cost growth (issue 12, item 4): CPU time per step, per particle-step and
per particle and Newton iteration, Krylov iterations per Newton iteration,
the share of each phase of the step (transfers: stencils, P2G, G2P, commit;
the solve: active set, material updates, assembly, linear solves; of which
contact; and within the solve the stress updates with the internal forces,
the Jacobian matrices' assembly and the linear solves with their
factorizations, of which the operator products of docs/solver.md#the-jacobian-as-an-operator),
and peak memory, as the particle count grows, for the implicit
step and the explicit integrator (docs/explicit.md).

The case: the reference column (0.2 x 0.4 m of Mohr-Coulomb sand, phi 30,
psi 0, c 100 Pa, E 1 MPa, on a Coulomb floor mu = 0.4, in a 1 x 0.5 m box;
inputs/reference_column_frictional.yaml) at smaller cells, 2 x 2 particles
per cell; in 3D the same column extruded 0.2 m across y (2 x 2 x 2 particles
per cell). The implicit step is the reference column's 2.5e-3 s at every
size (the same physical loading: the first --steps steps, 0.01 s, in which
the toe yields; on the finest grids that is hundreds of explicit steps, so
Newton works harder there), the explicit one cfl 0.5 (10 x --steps steps).
The figures are per step, and per particle and Newton iteration (issue 11's
2 us target): the CPU time of the whole process, and per particle-step also
the time loop's alone (the summary's transfer and solve seconds, without the
start-up, seeding and output that dominate the shortest runs). One run per
row: run it alone on the machine.

    /usr/bin/python3 scripts/bench_cost_growth.py                  # 2D 8e2..8e5, 3D 1e3..2.2e5, about 14 minutes
    /usr/bin/python3 scripts/bench_cost_growth.py --dims 3
    /usr/bin/python3 scripts/bench_cost_growth.py --dims 2 --max 2e5
"""
import argparse
import os
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "scripts"))
from bench_common import markdown_lines, run_talus_case, table_lines  # noqa: E402


def case_text(dim, cell, integrator, out):
    step = IMPLICIT_STEP
    time = f"{{end: 1.0, step: {step:.6g}}}" if integrator == "implicit" else "{end: 1.0, integrator: explicit}"
    if dim == 2:
        grid = f"{{lower: [0, 0], upper: [1.0, 0.5], cell_size: {cell}}}"
        box = "{lower: [0, 0], upper: [0.2, 0.4]}"
        gravity = "[0, -9.81]"
        faces = "{x_min: slip, x_max: slip, y_min: {condition: frictional, friction: 0.4}, y_max: slip}"
    else:
        grid = f"{{lower: [0, 0, 0], upper: [1.0, 0.2, 0.5], cell_size: {cell}}}"
        box = "{lower: [0, 0, 0], upper: [0.2, 0.2, 0.4]}"
        gravity = "[0, 0, -9.81]"
        faces = ("{x_min: slip, x_max: slip, y_min: slip, y_max: slip, "
                 "z_min: {condition: frictional, friction: 0.4}, z_max: slip}")
    return (f"grid: {grid}\ntime: {time}\noutput: {{enabled: false}}\ncheckpoint: {{enabled: false}}\n"
            f"gravity: {gravity}\n"
            "materials: [{name: sand, model: mohr_coulomb, density: 1800, youngs_modulus: 1.0e6, poisson_ratio: 0.3,\n"
            "             friction_angle: 30, dilatancy_angle: 0, cohesion: 100}]\n"
            f"bodies: [{{name: column, material: sand, box: {box}}}]\n"
            f"boundaries: {faces}\n")


IMPLICIT_STEP = 2.5e-3  # the reference column's step at every size: the same physical loading


def explicit_step(cell, dim):
    # docs/explicit.md: cfl 0.5 x 2 dx / (c_p sqrt(3 dim)), c_p of E = 1 MPa, nu = 0.3, rho = 1800.
    c = (1.0e6 * 0.7 / (1.3 * 0.4) / 1800) ** 0.5
    return 0.5 * 2 * cell / (c * (3 * dim) ** 0.5)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--talus", default=os.path.join(REPO, "build", "talus"))
    ap.add_argument("--dims", nargs="+", type=int, default=[2, 3], choices=[2, 3])
    ap.add_argument("--max", type=float, default=1e6, help="largest particle count")
    ap.add_argument("--steps", type=int, default=4, help="implicit steps per run (explicit: 10x as many)")
    ap.add_argument("--out", default=os.path.join(REPO, "bench_results", "cost_growth"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    # 3D: 1,024 to 221,184 particles (issue 12 asks up to 2e5; the cell must
    # divide the 1 x 0.2 x 0.5 m box).
    sizes = {2: [0.01 * 2 ** -k for k in range(-1, 5)], 3: [0.05, 0.025, 0.01, 1.0 / 120]}
    rows = []
    for dim in args.dims:
        for cell in sizes[dim]:
            particles = round(0.2 / cell * 0.4 / cell * 4) if dim == 2 else round(0.2 / cell * 0.2 / cell * 0.4 / cell * 8)
            if particles > args.max:
                continue
            for integrator in ("implicit", "explicit"):
                h = IMPLICIT_STEP if integrator == "implicit" else explicit_step(cell, dim)
                steps = args.steps if integrator == "implicit" else 10 * args.steps
                label = f"{dim}d_{cell:g}_{integrator}"
                case = os.path.join(args.out, label + ".yaml")
                text = case_text(dim, cell, integrator, os.path.join(args.out, label))
                text = text.replace("end: 1.0", f"end: {steps * h:.10g}")
                with open(case, "w") as f:
                    f.write(text)
                cpu, s = run_talus_case(args.talus, case)
                n, newton = s["steps"], s["newton_iterations"]
                wall = s["wall_seconds"]
                rows.append({
                    "dim": dim, "integrator": integrator, "particles": s["particles"], "cell": cell, "steps": n,
                    "cpu": cpu, "ms/step": 1e3 * cpu / n, "us/particle-step": 1e6 * cpu / (n * s["particles"]),
                    # The time loop alone (transfers and solves, one thread:
                    # its wall time is its CPU time), without the start-up,
                    # seeding and output that dominate the shortest runs.
                    "loop us/particle-step": 1e6 * (s["transfer_seconds"] + s["solve_seconds"]) / (n * s["particles"]),
                    "us/particle-Newton": 1e6 * cpu / (newton * s["particles"]) if newton else "-",
                    "Newton/step": newton / n, "Krylov/Newton": s["linear_iterations"] / newton if newton else "-",
                    "transfer %": 100 * s["transfer_seconds"] / wall, "solve %": 100 * s["solve_seconds"] / wall,
                    "contact %": 100 * s["contact_seconds"] / wall,
                    "material %": 100 * s["material_seconds"] / wall,
                    "assembly %": 100 * s["assembly_seconds"] / wall,
                    "linear %": 100 * s["linear_solve_seconds"] / wall,
                    "operator %": 100 * s["operator_seconds"] / wall, "peak MiB": s["peak_rss_mb"],
                    "kB/particle": 1024 * s["peak_rss_mb"] / s["particles"]})
                r = rows[-1]
                print(f"{dim}D {integrator:8s} {r['particles']:8d} particles: {cpu:7.2f} s, {n} steps, "
                      f"{r['us/particle-step']:.2f} us/particle-step, Newton/step {r['Newton/step']:.1f}", flush=True)
    columns = [("dim", "dim", "{}"), ("integrator", "integrator", "{}"), ("particles", "particles", "{:,}"),
               ("steps", "steps", "{}"), ("ms/step", "ms/step", "{:.2f}"),
               ("us/particle-step", "µs/particle-step", "{:.2f}"),
               ("loop us/particle-step", "time loop µs/particle-step", "{:.2f}"),
               ("us/particle-Newton", "µs/particle-Newton", "{:.2f}"), ("Newton/step", "Newton/step", "{:.1f}"),
               ("Krylov/Newton", "Krylov/Newton", "{:.1f}"), ("transfer %", "transfers %", "{:.0f}"),
               ("solve %", "solve %", "{:.0f}"), ("contact %", "of which contact %", "{:.1f}"),
               ("material %", "stress updates %", "{:.0f}"), ("assembly %", "matrix assembly %", "{:.0f}"),
               ("linear %", "linear solves %", "{:.0f}"), ("operator %", "of which operator %", "{:.0f}"),
               ("peak MiB", "peak MiB", "{:.0f}"), ("kB/particle", "kB/particle", "{:.2f}")]
    print()
    print("\n".join(table_lines(rows, columns)))
    print()
    print("\n".join(markdown_lines(rows, columns, text_columns=2)))


if __name__ == "__main__":
    main()
