#!/usr/bin/env bash
# The post-processing scripts: a short 2D column collapse (the first 0.3 s of
# inputs/column_collapse_psi0.yaml, outputs every 0.1 s), drawn with
# scripts/plot_particles.py and scripts/plot_series.py. Both exit 0 and write
# valid PNGs of a plausible size; the series CSV has one row per output whose
# numbers are checked against the case (mass, initial height) and against
# physics (no kinetic energy at rest, energy gained <= energy released); the
# energy balance drawn by scripts/plot_energy.py closes.
# Then the same column on a frictional floor with a wall in its way: the
# force columns of plot_series.py equal those of obstacle_forces.csv. Last,
# two blocks with their own velocity fields on a floor (bodies in contact):
# plot_series.py reads the table's by-body block, whose parts sum to the force.
set -euo pipefail
talus=$1
repo=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"

sed -e "s#directory: .*#directory: $work/out#" -e 's/end: .*/end: 0.3/' -e 's/interval: .*/interval: 0.1/' \
  "$repo/inputs/column_collapse_psi0.yaml" > run.yaml
"$talus" run run.yaml > run.log 2>&1 || { echo "FAIL: talus run"; cat run.log; exit 1; }

/usr/bin/python3 "$repo/scripts/plot_particles.py" out/particles.pvd --times 0 0.1 0.2 0.3 --dpi 50 \
  --out particles.png > particles.log 2>&1 || { echo "FAIL: plot_particles.py"; cat particles.log; exit 1; }
/usr/bin/python3 "$repo/scripts/plot_series.py" out/particles.pvd --out series.png --title "test" \
  > series.log 2>&1 || { echo "FAIL: plot_series.py"; cat series.log; exit 1; }
[ -f series.csv ] || { echo "FAIL: no series.csv next to series.png"; ls; exit 1; }
# The energy balance (docs/energy.md): scripts/plot_energy.py draws energy.csv
# and reports the closing error relative to the energy that moved, which must
# stay at the Newton tolerance (tests/test_energy_balance.cpp: below 1e-6).
/usr/bin/python3 "$repo/scripts/plot_energy.py" out/energy.csv --out energy.png --title "test" \
  > energy.log 2>&1 || { echo "FAIL: plot_energy.py"; cat energy.log; exit 1; }
relative=$(sed -n 's/^largest |balance_error| .* = \([0-9.e+-]*\) of the energy that moved.*/\1/p' energy.log)
/usr/bin/python3 -c "import sys; r = float(sys.argv[1]); sys.exit(0 if r < 1e-6 else 1)" "$relative" \
  || { echo "FAIL: energy balance closes only to $relative"; cat energy.log; exit 1; }

/usr/bin/python3 - "$work" <<'PY'
import csv, os, struct, sys, xml.etree.ElementTree as ET
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
work = sys.argv[1]

# PNGs: signature, IHDR chunk first, width and height > 100 px, a plausible file size.
for name in ("particles.png", "series.png", "energy.png"):
    path = os.path.join(work, name)
    with open(path, "rb") as f:
        head = f.read(24)
    assert head[:8] == b"\x89PNG\r\n\x1a\n", (name, head[:8])
    length, kind, width, height = struct.unpack(">I4sII", head[8:24])
    assert kind == b"IHDR" and length == 13, (name, kind, length)
    assert width > 100 and height > 100, (name, width, height)
    size = os.path.getsize(path)
    assert 5_000 < size < 5_000_000, (name, size)
    print(f"{name}: {width} x {height} px, {size} bytes")

# One row per output, at the times of the .pvd.
entries = list(ET.parse(os.path.join(work, "out/particles.pvd")).getroot().iter("DataSet"))
times = [float(e.get("timestep")) for e in entries]
with open(os.path.join(work, "series.csv")) as f:
    rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]
assert len(rows) == len(entries) == 4, (len(rows), len(entries))
assert all(abs(r["time"] - t) < 1e-12 for r, t in zip(rows, times)), times
assert all(abs(t - 0.1 * k) < 1e-9 for k, t in enumerate(times)), times

# The case: 0.5 x 1.0 m of sand at 2000 kg/m^3 = 1000 kg per m of thickness,
# 2 x 2 particles per 0.05 m cell (spacing d = 0.025 m, 800 particles), so the
# highest particle centre starts at 1.0 - d/2 = 0.9875 m and the front at 0.5 - d/2.
d = 0.025
for r in rows:
    assert r["particles"] == 800, r
    assert abs(r["mass"] - 1000.0) <= 1e-9 * 1000.0, r["mass"]
first = rows[0]
assert abs(first["height"] - (1.0 - d / 2)) < 1e-12, first["height"]
assert abs(first["front"] - (0.5 - d / 2)) < 1e-12 and first["front99"] <= first["front"], first
assert first["kinetic_energy"] == 0.0 and first["potential_energy_change"] == 0.0 and first["max_speed"] == 0.0, first
for a, b in zip(rows, rows[1:]):
    assert b["height"] < a["height"], ("height does not decrease", a, b)   # the column collapses
    assert b["front"] > a["front"], ("front does not advance", a, b)       # and spreads
for r in rows[1:]:
    assert r["kinetic_energy"] > 0.0 and r["max_speed"] > 0.0 and r["potential_energy_change"] < 0.0, r
    assert r["front99"] <= r["front"], r

# Energy balance. From rest with zero stress, gravity is the only source of
# energy (the fixed floor and the slip walls do no work), and the particle
# potential energy change is exactly the work of gravity on the grid because
# the particles move with the end-of-step grid velocities. The step can only
# lose energy (theta = 1 backward Euler, plastic dissipation, the transfers)
# or store it as elastic energy, so KE(t) <= -dPE(t) holds strictly; the
# tolerance, 1e-6 of the released energy, only absorbs floating-point
# rounding of the sums (about 1e-13 relative) with room to spare.
for r in rows[1:]:
    released = -r["potential_energy_change"]
    assert r["kinetic_energy"] <= released + 1e-6 * released, ("energy created", r)

# Independent recomputation from the last output: mass, kinetic energy,
# potential energy change (g = 9.81 along y), front and height.
def read(path):
    reader = vtk.vtkXMLPUnstructuredGridReader()
    reader.SetFileName(os.path.join(work, "out", path))
    reader.Update()
    g = reader.GetOutput()
    return (vtk_to_numpy(g.GetPoints().GetData()), vtk_to_numpy(g.GetPointData().GetArray("mass")),
            vtk_to_numpy(g.GetPointData().GetArray("velocity")))
x0, m0, _ = read(entries[0].get("file"))
x, m, v = read(entries[-1].get("file"))
last = rows[-1]
assert abs(m.sum() - 1000.0) <= 1e-9 * 1000.0, m.sum()
ke = 0.5 * float((m * (v**2).sum(axis=1)).sum())
dpe = 9.81 * (float((m * x[:, 1]).sum()) - float((m0 * x0[:, 1]).sum()))
assert abs(last["kinetic_energy"] - ke) <= 1e-12 * ke, (last["kinetic_energy"], ke)
assert abs(last["potential_energy_change"] - dpe) <= 1e-9 * abs(dpe), (last["potential_energy_change"], dpe)
assert last["front"] == x[:, 0].max() and last["height"] == x[:, 1].max(), last

print("plot_scripts ok:", len(rows), "outputs; height",
      " ".join(f"{r['height']:.4f}" for r in rows), "m; KE",
      " ".join(f"{r['kinetic_energy']:.1f}" for r in rows), "J/m; -dPE",
      " ".join(f"{0.0 - r['potential_energy_change']:.1f}" for r in rows), "J/m")
PY

# Wall force: the same column on a frictional floor (mu = 0.4, y_min) with a
# wall box in its way, for 0.3 s. plot_series.py reads obstacle_forces.csv
# (one row per step) and writes, per obstacle, |F| and F_x at each output: they
# must equal the table's row of the step ending at that output (nan at t = 0),
# and the fourth panel makes the PNG taller.
sed -e "s#directory: .*#directory: $work/wall#" -e 's/end: .*/end: 0.3/' -e 's/interval: .*/interval: 0.1/' \
  "$repo/inputs/column_collapse_frictional_floor.yaml" > wall.yaml
printf '%s\n' 'obstacles:' '  - {name: wall, type: box, lower: [0.7, 0.0], upper: [0.8, 0.3], friction: 0.3}' >> wall.yaml
"$talus" run wall.yaml > wall.log 2>&1 || { echo "FAIL: talus run (wall)"; cat wall.log; exit 1; }
/usr/bin/python3 "$repo/scripts/plot_series.py" wall/particles.pvd --out wall_series.png \
  > wall_series.log 2>&1 || { echo "FAIL: plot_series.py (wall)"; cat wall_series.log; exit 1; }
/usr/bin/python3 "$repo/scripts/plot_series.py" wall/particles.pvd --out wall_only.png --obstacles wall \
  > wall_only.log 2>&1 || { echo "FAIL: plot_series.py --obstacles wall"; cat wall_only.log; exit 1; }

/usr/bin/python3 - "$work" <<'PY'
import csv, math, os, struct, sys
import numpy as np
work = sys.argv[1]
with open(os.path.join(work, "wall/obstacle_forces.csv")) as f:
    table = list(csv.reader(f))
assert table[0][:5] == ["time [s]", "wall_fx [N/m]", "wall_fy [N/m]", "y_min_fx [N/m]", "y_min_fy [N/m]"], table[0]
assert len(table[0]) == 17, table[0]          # then impulses, running totals and window forces (docs/output.md)
F = np.array(table[1:], dtype=float)[:, :5]   # time and the forces
assert F.shape == (120, 5) and np.all(np.diff(F[:, 0]) > 0), F.shape       # 0.3 s in steps of 0.0025 s
with open(os.path.join(work, "wall_series.csv")) as f:
    rows = list(csv.DictReader(f))
with open(os.path.join(work, "series.csv")) as f:
    assert not any("force" in k for k in next(csv.DictReader(f))), "force columns without obstacles"
assert len(rows) == 4
checked = 0
for r in rows:
    t = float(r["time"])
    for name, k in (("wall", 1), ("y_min", 3)):
        force, fx = float(r[f"{name}_force"]), float(r[f"{name}_force_x"])
        if t == 0.0:
            assert math.isnan(force) and math.isnan(fx), r                   # no step before t = 0
            continue
        row = F[np.argmin(np.abs(F[:, 0] - t))]
        assert abs(row[0] - t) < 1e-9, (row[0], t)
        want = math.hypot(row[k], row[k + 1])
        assert abs(force - want) <= 1e-12 * max(want, 1.0) and fx == row[k], (name, t, force, want, fx, row)
        checked += 1
assert checked == 6
# The floor carries the column: at t = 0.1 its vertical load is within 50 % of
# the weight m g = 1000 kg/m x 9.81 (the column is accelerating, so not equal).
mg = 1000.0 * 9.81
assert 0.5 * mg < -F[np.argmin(np.abs(F[:, 0] - 0.1)), 4] < 1.5 * mg
with open(os.path.join(work, "wall_only.csv")) as f:
    header = next(csv.reader(f))
assert [h for h in header if "force" in h] == ["wall_force", "wall_force_x"], header

# The PNG with the fourth panel: taller than the three-panel one (same dpi).
def size(name):
    with open(os.path.join(work, name), "rb") as f:
        head = f.read(24)
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", head[16:24])
(w3, h3), (w4, h4) = size("series.png"), size("wall_series.png")
assert w4 == w3 and h4 > h3, (w3, h3, w4, h4)
print("plot_scripts ok: wall force;", "wall |F| at the outputs",
      " ".join(r["wall_force"] for r in rows), "N/m; floor |F|", " ".join(f"{float(r['y_min_force']):.1f}" for r in rows))
PY

cat > bodies.yaml <<EOF
grid: {lower: [0, 0], upper: [1.2, 0.6], cell_size: 0.05}
time: {end: 0.1, step: 0.01}
output: {directory: $work/bodies, interval: 0.05}
gravity: [0, -9.81]
materials: [{name: rock, model: linear_elastic, density: 2000, youngs_modulus: 2.0e7, poisson_ratio: 0.3}]
bodies: [{name: left, material: rock, box: {lower: [0.2, 0.1], upper: [0.5, 0.3]}},
         {name: right, material: rock, box: {lower: [0.7, 0.1], upper: [0.9, 0.5]}}]
contact: {bodies: [{pair: [left, right], friction: 0.3}]}
obstacles: [{name: floor, type: half_plane, point: [0, 0.1], normal: [0, 1], friction: 0.5}]
boundaries: {x_min: free, x_max: free, y_min: free, y_max: free}
EOF
"$talus" run bodies.yaml > bodies.log 2>&1 || { echo "FAIL: talus run (bodies)"; cat bodies.log; exit 1; }
/usr/bin/python3 "$repo/scripts/plot_series.py" bodies/particles.pvd --out bodies_series.png \
  > bodies_series.log 2>&1 || { echo "FAIL: plot_series.py with bodies in contact"; cat bodies_series.log; exit 1; }
/usr/bin/python3 - "$work" <<'PY'
import csv, os, sys
rows = list(csv.reader(open(os.path.join(sys.argv[1], "bodies", "obstacle_forces.csv"))))
h = [c.split(" [")[0] for c in rows[0]]
for r in rows[1:]:
    v = dict(zip(h, map(float, r)))
    for a in "xy":
        parts = v[f"floor_f_by_left_{a}"] + v[f"floor_f_by_right_{a}"]
        assert abs(parts - v[f"floor_f{a}"]) <= 1e-9 * max(1.0, abs(v[f"floor_f{a}"])), (a, parts, v)
print("plot_scripts ok: bodies in contact, the floor force split by body in", len(rows) - 1, "rows")
PY
