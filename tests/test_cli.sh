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
