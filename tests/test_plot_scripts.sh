#!/usr/bin/env bash
# The post-processing scripts: a short 2D column collapse (the first 0.3 s of
# inputs/column_collapse_psi0.yaml, outputs every 0.1 s), drawn with
# scripts/plot_particles.py and scripts/plot_series.py. Both exit 0 and write
# valid PNGs of a plausible size; the series CSV has one row per output whose
# numbers are checked against the case (mass, initial height) and against
# physics (no kinetic energy at rest, energy gained <= energy released).
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

/usr/bin/python3 - "$work" <<'PY'
import csv, os, struct, sys, xml.etree.ElementTree as ET
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
work = sys.argv[1]

# PNGs: signature, IHDR chunk first, width and height > 100 px, a plausible file size.
for name in ("particles.png", "series.png"):
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
