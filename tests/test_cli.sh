#!/usr/bin/env bash
# Command-line behaviour: every case in inputs/ validates; a bad case exits
# with code 2 and writes nothing; a run leaves a .pvd series whose files VTK
# reads back with the expected arrays and values.
set -euo pipefail
talus=$1
repo=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"

for case in "$repo"/inputs/*.yaml; do
  "$talus" check "$case" > /dev/null || { echo "FAIL: talus check $case"; exit 1; }
done

# A non-physical value: exit code 2, the key and line named, no output directory.
sed -e 's/poisson_ratio: 0.3/poisson_ratio: 0.7/' -e "s#directory: .*#directory: $work/bad_out#" \
  "$repo/inputs/elastic_column.yaml" > bad.yaml
set +e
"$talus" run bad.yaml > bad.log 2>&1
code=$?
set -e
[ "$code" -eq 2 ] || { echo "FAIL: exit code $code for a bad case (want 2)"; cat bad.log; exit 1; }
grep -q "bad.yaml:[0-9]*: materials\[0\].poisson_ratio = 0.7" bad.log || { echo "FAIL: message"; cat bad.log; exit 1; }
[ ! -e "$work/bad_out" ] || { echo "FAIL: a bad case wrote output"; exit 1; }

# A short run: .pvd, .pvtu and .vtu files, read back with VTK.
sed -e "s#directory: .*#directory: $work/out#" -e 's/end: 0.5/end: 0.02/' \
  "$repo/inputs/elastic_column.yaml" > run.yaml
"$talus" run run.yaml > run.log
/usr/bin/python3 - "$work/out" <<'PY'
import sys, xml.etree.ElementTree as ET
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
out = sys.argv[1]
entries = ET.parse(out + "/particles.pvd").getroot().findall(".//DataSet")
times = [float(e.get("timestep")) for e in entries]
assert len(entries) == 2 and abs(times[-1] - 0.02) < 1e-12, times   # t = 0 and the end
first = vtk.vtkXMLPUnstructuredGridReader()
first.SetFileName(out + "/" + entries[0].get("file"))
first.Update()
g = first.GetOutput()
pd = g.GetPointData()
names = {pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())}
want = {"velocity", "displacement", "stress", "mean_stress", "deviatoric_stress", "mass", "volume",
        "material_id", "body_id", "particle_id"}
assert want <= names, names - want
# Initial state of inputs/elastic_column.yaml: 0.5 x 1 m body, 2x2 particles per 0.05 m cell.
n = g.GetNumberOfPoints()
assert n == 10 * 20 * 4, n
mass = vtk_to_numpy(pd.GetArray("mass"))
assert abs(mass.sum() - 2000.0 * 0.5 * 1.0) < 1e-9 * 1000, mass.sum()
assert np.all(vtk_to_numpy(pd.GetArray("stress")) == 0.0)
assert pd.GetArray("stress").GetNumberOfComponents() == 6
last = vtk.vtkXMLPUnstructuredGridReader()
last.SetFileName(out + "/" + entries[-1].get("file"))
last.Update()
v = vtk_to_numpy(last.GetOutput().GetPointData().GetArray("velocity"))
assert v.shape == (n, 3) and np.all(v[:, 2] == 0.0)
assert v[:, 1].mean() < 0.0      # the column starts to settle downwards
print("cli ok:", n, "particles,", len(entries), "outputs")
PY

# The same run on two ranks: one .vtu piece per rank, same particles in total.
sed -e "s#directory: .*#directory: $work/out2#" run.yaml > run2.yaml
mpiexec -n 2 "$talus" run run2.yaml > run2.log
/usr/bin/python3 - "$work/out2" <<'PY'
import sys, glob
import vtk
out = sys.argv[1]
assert len(glob.glob(out + "/particles_000001_*.vtu")) == 2, glob.glob(out + "/*")
r = vtk.vtkXMLPUnstructuredGridReader()
r.SetFileName(out + "/particles_000001.pvtu")
r.Update()
assert r.GetOutput().GetNumberOfPoints() == 800, r.GetOutput().GetNumberOfPoints()
print("cli ok on 2 ranks")
PY

# SIGINT ends a run after the current step with a checkpoint (exit 130);
# --restart continues it to the end, on two ranks; h5dump reads the checkpoint.
sed -e "s#directory: .*#directory: $work/sig#" -e "s#end: .*#end: 1.0#" "$repo/inputs/column_collapse_psi0.yaml" > sig.yaml
"$talus" run sig.yaml > sig.log 2>&1 &
pid=$!
for _ in $(seq 1 100); do grep -q "^step " sig.log 2>/dev/null && break; sleep 0.1; done
kill -INT $pid
set +e
wait $pid
code=$?
set -e
[ "$code" -eq 130 ] || { echo "SIGINT: expected exit 130, got $code"; cat sig.log; exit 1; }
checkpoint=$(sed -n 's/.*continue with --restart \(.*\)$/\1/p' sig.log)
[ -f "$checkpoint" ] || { echo "SIGINT: no checkpoint named in the log"; cat sig.log; exit 1; }
[ ! -e "$checkpoint.tmp" ] || { echo "SIGINT: temporary checkpoint left behind"; exit 1; }
h5dump -a /run/time "$checkpoint" | grep -q "DATA" || { echo "h5dump cannot read $checkpoint"; exit 1; }
# The serial checkpoint continues on two ranks: each keeps the particles in its cells.
mpiexec -n 2 "$talus" run sig.yaml --restart "$checkpoint" > restart.log
grep -q "restarting from $checkpoint" restart.log || { echo "restart not reported"; cat restart.log; exit 1; }
/usr/bin/python3 - "$work/sig" <<'PY'
import sys, xml.etree.ElementTree as ET
out = sys.argv[1]
times = [float(d.get("timestep")) for d in ET.parse(out + "/particles.pvd").getroot().iter("DataSet")]
# One series from t = 0 to the end: the outputs before the signal are kept.
assert times[0] == 0.0 and abs(times[-1] - 1.0) < 1e-9, times
assert all(b > a for a, b in zip(times, times[1:])), times
import vtk
r = vtk.vtkXMLPUnstructuredGridReader()
r.SetFileName(out + "/" + list(ET.parse(out + "/particles.pvd").getroot().iter("DataSet"))[-1].get("file"))
r.Update()
assert r.GetOutput().GetNumberOfPoints() == 800, r.GetOutput().GetNumberOfPoints()
print("cli ok: interrupted and restarted on 2 ranks,", len(times), "outputs from 0 to", times[-1])
PY

# A known non-zero state read back from the VTK files: the elastic column
# seeded with a geostatic stress, output at t = 0 only (time.end = one step).
sed -e "s#directory: .*#directory: $work/geo#" -e "s#end: .*#end: 0.005#" \
    -e "s#particles_per_cell: 2#particles_per_cell: 2\n    initial_stress: geostatic#" \
    "$repo/inputs/elastic_column.yaml" > geo.yaml
"$talus" run geo.yaml > geo.log
/usr/bin/python3 - "$work/geo" <<'PY'
import sys, xml.etree.ElementTree as ET
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
out = sys.argv[1]
first = list(ET.parse(out + "/particles.pvd").getroot().iter("DataSet"))[0]
assert float(first.get("timestep")) == 0.0
r = vtk.vtkXMLPUnstructuredGridReader()
r.SetFileName(out + "/" + first.get("file"))
r.Update()
g = r.GetOutput()
pd = g.GetPointData()
a = lambda name: vtk_to_numpy(pd.GetArray(name))
x = vtk_to_numpy(g.GetPoints().GetData())
n = g.GetNumberOfPoints()
rho, grav, nu, H, d = 2000.0, 9.81, 0.3, 1.0, 0.025
sv = -rho * grav * (H - x[:, 1])            # lithostatic, at the particle centres
k0 = nu / (1 - nu)
s = a("stress")                              # ParaView order XX YY ZZ XY YZ XZ, Cauchy
scale = rho * grav * H
assert np.abs(s[:, 1] - sv).max() < 1e-9 * scale, np.abs(s[:, 1] - sv).max()
assert np.abs(s[:, 0] - k0 * sv).max() < 1e-9 * scale
assert np.abs(s[:, 2] - k0 * sv).max() < 1e-9 * scale
assert np.abs(s[:, 3:]).max() == 0.0
p = (1 + 2 * k0) * sv / 3
assert np.abs(a("mean_stress") - p).max() < 1e-9 * scale
q = np.abs(1 - k0) * np.abs(sv)              # von Mises of (k0, 1, k0) sigma_v
assert np.abs(a("deviatoric_stress") - q).max() < 1e-9 * scale
assert np.abs(a("volume") - d * d).max() < 1e-15
assert np.abs(a("mass") - rho * d * d).max() < 1e-12
assert np.all(a("cumulative_plastic_strain") == 0.0) and np.all(a("separation_strain") == 0.0)
assert np.all(a("velocity") == 0.0) and np.all(a("displacement") == 0.0)
assert np.all(a("material_id") == 0) and np.all(a("body_id") == 0)
assert sorted(a("particle_id").tolist()) == list(range(n))
print("cli ok: geostatic state read back,", n, "particles, sigma_v at the base", sv.min())
PY
