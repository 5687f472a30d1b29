#!/usr/bin/python3
"""Write CB-Geo mpm inputs for the reference granular column (talus issue 11).

Box 1 m x 0.5 m, square cells 0.01 m (100 x 50 ED2Q4), column 0.2 m x 0.4 m
against the left wall, 2 x 2 particles per cell at x = 0.0025, 0.0075, ...
(3,200 particles), Mohr-Coulomb sand, gravity (0, -9.81), explicit USF,
1 s (--dt, default 1e-4 s, the issue's: 10,000 steps).  Walls and lid: slip.
Floor: slip ("smooth") or slip + Coulomb friction mu = 0.4 ("frictional").

The mesh extends --margin cells (default 2) beyond each wall: x from
-margin*0.01 to 1 + margin*0.01, y from -margin*0.01 to 0.5 + margin*0.01.
The walls stay at x = 0, x = 1, y = 0 and y = 0.5: every node on or beyond a
wall has its normal velocity fixed to zero (node sets 0: x <= 0, 1: x >= 1,
2: y <= 0, 3: y >= 0.5), so a particle thrown across a wall lands in a cell
whose nodes all have zero normal velocity and stays in the mesh instead of
stopping the run with "Particle outside the mesh domain" (--margin 0: the
mesh ends at the walls, the old setup).  Empty margin cells cost nothing
and give no NaN: CB-Geo activates only the nodes of cells holding particles
and divides by a nodal mass only above 1e-15 (include/node.tcc).

The margin is not enough at dt 1e-4 s: CB-Geo's explicit USF diverges there
on both floors (particles stretched to 10-40 times their volume, then
velocities of hundreds of m/s and stresses of MPa; the mu = 0.4 floor stops
at step 3,450, the slip floor at step 7,272; at 8e-5 and 6.25e-5 s the slip
floor still diverges at t = 0.80 and 0.79 s).  With --dt 5e-5 (20,000
steps) both floors run to 1 s.

CB-Geo writes the particles (HDF5, results/<uuid>/particlesNNNNN.h5, table
"table") after step NNNNN, i.e. at time (NNNNN + 1) * dt, and only when
NNNNN % output_steps == 0; the default --output-steps is chosen to divide
nsteps - 1, so the last file is the state at the end (t = nsteps * dt, 1 s).

Usage: cbgeo_reference_column.py --out DIR [--margin N] [--dt S] [--nsteps N] [--output-steps N]
                                 [--tension-cutoff T]
e.g.   cbgeo_reference_column.py --out /work/cbgeo/column --tension-cutoff 173.2 --dt 5e-5
Writes DIR/smooth/ and DIR/frictional/, each with mpm.json, mesh.txt,
particles.txt, entity_sets.json (outside the repository: CB-Geo is not part
of talus; scripts/bench_explicit_baseline.py runs them beside talus).
CB-Geo's Mohr-Coulomb needs a tension cut-off; 173.2 Pa = c cot(phi) is
talus's apex (the default 50 Pa is the value CB-Geo's own sand-column
generator pairs with c = 100 Pa).
"""
import argparse
import json
import os
import sys

LX, LY, H = 1.0, 0.5, 0.01
NX, NY = 100, 50
COL_W, COL_H = 0.2, 0.4
PPC = 2  # particles per cell per direction


class Grid:
    """Nodes (i, j), i = 0..nx, j = 0..ny, at ((i - margin) H, (j - margin) H)."""

    def __init__(self, margin):
        self.m = margin
        self.nx, self.ny = NX + 2 * margin, NY + 2 * margin

    def node_id(self, i, j):
        return j * (self.nx + 1) + i

    @property
    def nnodes(self):
        return (self.nx + 1) * (self.ny + 1)

    @property
    def ncells(self):
        return self.nx * self.ny

    def write_mesh(self, path):
        with open(path, "w") as f:
            f.write("! elementShape quadrilateral\n")
            f.write("! elementNumPoints 4\n")
            f.write(f"{self.nnodes}\t{self.ncells}\n")
            for j in range(self.ny + 1):
                for i in range(self.nx + 1):
                    f.write(f"{(i - self.m) * H:.6f}\t{(j - self.m) * H:.6f}\n")
            for j in range(self.ny):
                for i in range(self.nx):
                    # counter-clockwise, as ED2Q4 expects
                    f.write(f"{self.node_id(i, j)}\t{self.node_id(i + 1, j)}\t"
                            f"{self.node_id(i + 1, j + 1)}\t{self.node_id(i, j + 1)}\n")

    def write_entity_sets(self, path):
        """Node sets, decided on the integer indices (no rounding): 0 on or
        beyond the left wall (x <= 0), 1 the right wall (x >= 1), 2 the floor
        (y <= 0), 3 the lid (y >= 0.5)."""
        m, nx, ny = self.m, self.nx, self.ny
        every = [(i, j) for j in range(ny + 1) for i in range(nx + 1)]
        sets = {
            "node_sets": [
                {"id": 0, "set": [self.node_id(i, j) for i, j in every if i <= m]},       # left
                {"id": 1, "set": [self.node_id(i, j) for i, j in every if i >= NX + m]},  # right
                {"id": 2, "set": [self.node_id(i, j) for i, j in every if j <= m]},       # floor
                {"id": 3, "set": [self.node_id(i, j) for i, j in every if j >= NY + m]},  # lid
            ]
        }
        with open(path, "w") as f:
            json.dump(sets, f, indent=1)


def write_particles(path):
    d = H / PPC
    nx, ny = round(COL_W / d), round(COL_H / d)
    with open(path, "w") as f:
        f.write(f"{nx * ny}\n")
        for j in range(ny):
            for i in range(nx):
                f.write(f"{(i + 0.5) * d:.6f}\t{(j + 0.5) * d:.6f}\n")
    return nx * ny


def config(variant, dt, nsteps, output_steps, tension_cutoff, uuid):
    bc = {
        "velocity_constraints": [
            {"nset_id": 0, "dir": 0, "velocity": 0.0},
            {"nset_id": 1, "dir": 0, "velocity": 0.0},
            {"nset_id": 2, "dir": 1, "velocity": 0.0},
            {"nset_id": 3, "dir": 1, "velocity": 0.0},
        ]
    }
    if variant == "frictional":
        # Floor: normal y (dir 1), outward normal -y (sign_n -1), mu 0.4, on
        # node set 2: the floor nodes at y = 0 and the constrained nodes below.
        # In CB-Geo (include/node.tcc, apply_friction_constraints) friction is
        # nodal: on an active node with mass, before the velocity update, if
        # its own normal acceleration points into the wall (acc_y < 0), the
        # tangential acceleration is reduced by mu |acc_y| (or the tangential
        # velocity stopped, if that is less); then v_y = 0 is imposed. A node
        # is active only when a cell around it holds particles, so the nodes
        # below the floor take part only if a particle has been thrown below
        # y = 0; the friction there makes such a particle slide with the same
        # mu instead of freely. In the normal flow only the y = 0 row acts,
        # exactly as in the mesh without margin (its cells below are empty,
        # as the outside was). On nodes beyond the side walls both velocity
        # components are fixed, so the friction there changes nothing.
        bc["friction_constraints"] = [
            {"nset_id": 2, "dir": 1, "sign_n": -1, "friction": 0.4}
        ]
    return {
        "title": f"Reference granular column ({variant} floor)",
        "mesh": {
            "mesh": "mesh.txt",
            "entity_sets": "entity_sets.json",
            "io_type": "Ascii2D",
            "check_duplicates": True,
            "isoparametric": False,
            "node_type": "N2D",
            "cell_type": "ED2Q4",
            "boundary_conditions": bc,
        },
        "particles": [
            {
                "generator": {
                    "type": "file",
                    "location": "particles.txt",
                    "io_type": "Ascii2D",
                    "particle_type": "P2D",
                    "material_id": 0,
                    "pset_id": 0,
                    "check_duplicates": True,
                }
            }
        ],
        "materials": [
            {
                "id": 0,
                "type": "MohrCoulomb2D",
                "density": 1800.0,
                "youngs_modulus": 1.0e6,
                "poisson_ratio": 0.3,
                "friction": 30.0,
                "dilation": 0.0,
                "cohesion": 100.0,
                "tension_cutoff": tension_cutoff,
                "softening": False,
                "residual_friction": 30.0,
                "residual_dilation": 0.0,
                "residual_cohesion": 100.0,
                "peak_pdstrain": 0.0,
                "residual_pdstrain": 0.0,
            }
        ],
        "external_loading_conditions": {"gravity": [0.0, -9.81]},
        "analysis": {
            "type": "MPMExplicit2D",
            "mpm_scheme": "usf",
            "velocity_update": False,
            "locate_particles": True,
            "dt": dt,
            "nsteps": nsteps,
            "uuid": uuid,
            "resume": {"resume": False},
        },
        "post_processing": {"path": "results/", "output_steps": output_steps},
    }


def default_output_steps(nsteps):
    """Steps between outputs such that the last output is after the last
    step: the largest divisor of nsteps - 1 up to nsteps / 10 (909 for
    10,000 steps, about 11 outputs), or nsteps - 1 (the first and the last
    step only) if that divisor would mean more than 100 outputs (20,000
    steps: 19999 = 7 x 2857)."""
    last = max(nsteps - 1, 1)
    k = max(d for d in range(1, max(nsteps // 10, 1) + 1) if last % d == 0)
    return k if last // k <= 100 else last


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="directory for smooth/ and frictional/ (not the repository)")
    ap.add_argument("--margin", type=int, default=2,
                    help="cells of mesh beyond each wall (default 2; 0 = mesh ends at the walls)")
    ap.add_argument("--dt", type=float, default=1.0e-4,
                    help="time step, s (default 1e-4, the issue's; CB-Geo needs 5e-5 here, see the header "
                         "of scripts/bench_explicit_baseline.py)")
    ap.add_argument("--nsteps", type=int, default=None, help="steps (default: 1 s / dt)")
    ap.add_argument("--output-steps", type=int, default=None,
                    help="steps between outputs (default: a divisor of nsteps - 1, so the end state is written)")
    ap.add_argument("--tension-cutoff", type=float, default=50.0,
                    help="Mohr-Coulomb tension cut-off, Pa (173.2 = c cot(phi), talus's apex)")
    ap.add_argument("--suffix", default="")
    a = ap.parse_args()
    if a.margin < 0:
        ap.error("--margin must be >= 0")
    if a.nsteps is None:
        a.nsteps = round(1.0 / a.dt)
    output_steps = a.output_steps or default_output_steps(a.nsteps)
    if (a.nsteps - 1) % output_steps:
        print(f"warning: with --output-steps {output_steps} the last output is after step "
              f"{(a.nsteps - 1) // output_steps * output_steps + 1} of {a.nsteps}, not the end", file=sys.stderr)
    grid = Grid(a.margin)
    for variant in ("smooth", "frictional"):
        d = os.path.join(a.out, variant)
        os.makedirs(d, exist_ok=True)
        grid.write_mesh(os.path.join(d, "mesh.txt"))
        n = write_particles(os.path.join(d, "particles.txt"))
        grid.write_entity_sets(os.path.join(d, "entity_sets.json"))
        cfg = config(variant, a.dt, a.nsteps, output_steps, a.tension_cutoff,
                     f"column-{variant}{a.suffix}")
        with open(os.path.join(d, "mpm.json"), "w") as f:
            json.dump(cfg, f, indent=2)
        print(f"{d}: {n} particles, {grid.nnodes} nodes, {grid.ncells} cells (margin {a.margin}), "
              f"dt {a.dt:g} s, {a.nsteps} steps, output every {output_steps} steps")


if __name__ == "__main__":
    main()
