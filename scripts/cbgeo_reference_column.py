#!/usr/bin/python3
"""Write CB-Geo mpm inputs for the reference granular column (talus issue 11).

Box 1 m x 0.5 m, square cells 0.01 m (100 x 50 ED2Q4), column 0.2 m x 0.4 m
against the left wall, 2 x 2 particles per cell at x = 0.0025, 0.0075, ...
(3,200 particles), Mohr-Coulomb sand, gravity (0, -9.81), explicit USF,
dt 1e-4 s, 10,000 steps.  Walls and lid: slip.  Floor: slip ("smooth") or
slip + Coulomb friction mu = 0.4 ("frictional").

Usage: cbgeo_reference_column.py --out DIR [--nsteps N] [--output-steps N] [--tension-cutoff T]
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

LX, LY, H = 1.0, 0.5, 0.01
NX, NY = 100, 50
COL_W, COL_H = 0.2, 0.4
PPC = 2  # particles per cell per direction


def node_id(i, j):
    return j * (NX + 1) + i


def write_mesh(path):
    with open(path, "w") as f:
        f.write("! elementShape quadrilateral\n")
        f.write("! elementNumPoints 4\n")
        f.write(f"{(NX + 1) * (NY + 1)}\t{NX * NY}\n")
        for j in range(NY + 1):
            for i in range(NX + 1):
                f.write(f"{i * H:.6f}\t{j * H:.6f}\n")
        for j in range(NY):
            for i in range(NX):
                # counter-clockwise, as ED2Q4 expects
                f.write(f"{node_id(i, j)}\t{node_id(i + 1, j)}\t"
                        f"{node_id(i + 1, j + 1)}\t{node_id(i, j + 1)}\n")


def write_particles(path):
    d = H / PPC
    nx, ny = round(COL_W / d), round(COL_H / d)
    with open(path, "w") as f:
        f.write(f"{nx * ny}\n")
        for j in range(ny):
            for i in range(nx):
                f.write(f"{(i + 0.5) * d:.6f}\t{(j + 0.5) * d:.6f}\n")
    return nx * ny


def write_entity_sets(path):
    sets = {
        "node_sets": [
            {"id": 0, "set": [node_id(0, j) for j in range(NY + 1)]},   # left
            {"id": 1, "set": [node_id(NX, j) for j in range(NY + 1)]},  # right
            {"id": 2, "set": [node_id(i, 0) for i in range(NX + 1)]},   # floor
            {"id": 3, "set": [node_id(i, NY) for i in range(NX + 1)]},  # lid
        ]
    }
    with open(path, "w") as f:
        json.dump(sets, f, indent=1)


def config(variant, nsteps, output_steps, tension_cutoff, uuid):
    bc = {
        "velocity_constraints": [
            {"nset_id": 0, "dir": 0, "velocity": 0.0},
            {"nset_id": 1, "dir": 0, "velocity": 0.0},
            {"nset_id": 2, "dir": 1, "velocity": 0.0},
            {"nset_id": 3, "dir": 1, "velocity": 0.0},
        ]
    }
    if variant == "frictional":
        # floor: normal y (dir 1), outward normal -y (sign_n -1), mu 0.4
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
            "dt": 1.0e-4,
            "nsteps": nsteps,
            "uuid": uuid,
            "resume": {"resume": False},
        },
        "post_processing": {"path": "results/", "output_steps": output_steps},
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True, help="directory for smooth/ and frictional/ (not the repository)")
    ap.add_argument("--nsteps", type=int, default=10000)
    ap.add_argument("--output-steps", type=int, default=500)
    ap.add_argument("--tension-cutoff", type=float, default=50.0)
    ap.add_argument("--suffix", default="")
    a = ap.parse_args()
    for variant in ("smooth", "frictional"):
        d = os.path.join(a.out, variant)
        os.makedirs(d, exist_ok=True)
        write_mesh(os.path.join(d, "mesh.txt"))
        n = write_particles(os.path.join(d, "particles.txt"))
        write_entity_sets(os.path.join(d, "entity_sets.json"))
        cfg = config(variant, a.nsteps, a.output_steps, a.tension_cutoff,
                     f"column-{variant}{a.suffix}")
        with open(os.path.join(d, "mpm.json"), "w") as f:
            json.dump(cfg, f, indent=2)
        print(f"{d}: {n} particles, {(NX + 1) * (NY + 1)} nodes, {NX * NY} cells")


if __name__ == "__main__":
    main()
