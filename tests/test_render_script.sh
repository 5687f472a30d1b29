#!/usr/bin/env bash
# scripts/render_plastic_strain.py (VTK offscreen rendering under xvfb-run),
# under /usr/bin/python3 (python3-vtk9) and, when there is one, ParaView's
# pvbatch (the same pictures).
#  1. A synthetic particle series written here with VTK (3 outputs of 14
#     particles at known positions with known values, a box obstacle), drawn
#     in a row (squares, obstacles) and in a column (discs, a vector
#     component, clamped values, --no-obstacles). Asserted on the pixels: the
#     PNG size; inside every particle's square or disc exactly the table
#     colour of its value, outside all of them and the obstacle exactly white;
#     the obstacle grey; the colour bar in the bottom strip; a text label per
#     panel, giving the time of the nearest output.
#  2. The first 0.2 s of inputs/column_collapse_psi0.yaml (.pvtu output):
#     the t = 0 panel is all strain-0 colour, the last one has yielded colours.
#  3. Missing file, empty series, unknown field or component, no display:
#     exit 1 and a message naming the culprit.
#  4. ParaView's pvbatch, if found ($TALUS_PVBATCH, else
#     /opt/talus-paraview/bin/pvbatch from scripts/install_paraview.sh, else
#     pvbatch on the PATH; skipped with a message if there is none): the
#     pictures of 1, 2 and of a short 3D run drawn again under pvbatch pass
#     the same checks and are the same pictures as under python3 (same size,
#     same panel geometry, no pixel of a plot differing by more than 2/255,
#     at most 0.2 % of all pixels, i.e. text, differing); a missing file
#     fails the same way.
set -euo pipefail
talus=$1
repo=$2
script="$repo/scripts/render_plastic_strain.py"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
command -v xvfb-run >/dev/null || { echo "FAIL: xvfb-run not found (Debian package xvfb)"; exit 1; }

# --- 1. synthetic series -----------------------------------------------------
/usr/bin/python3 - "$work/syn" <<'PY'
import os, sys
import numpy as np
import vtk
from vtk.util.numpy_support import numpy_to_vtk
out = sys.argv[1]
os.makedirs(out)

def write_vtu(name, x, fields):
    g = vtk.vtkUnstructuredGrid()
    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(x, deep=True))
    g.SetPoints(pts)
    for i in range(len(x)):
        g.InsertNextCell(vtk.VTK_VERTEX, 1, [i])
    for k, v in fields.items():
        a = numpy_to_vtk(np.ascontiguousarray(v), deep=True)
        a.SetName(k)
        g.GetPointData().AddArray(a)
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetFileName(os.path.join(out, name))
    w.SetInputData(g)
    assert w.Write() == 1

def write_pvd(name, files):
    sets = "".join(f'<DataSet timestep="{t!r}" file="{f}"/>' for t, f in files)
    with open(os.path.join(out, name), "w") as f:
        f.write(f'<VTKFile type="Collection" version="0.1"><Collection>{sets}</Collection></VTKFile>\n')

# 5 x 3 lattice of spacing 0.5 m without its middle point (the obstacle's
# place), shifted 0.1 m to the right per output; particle spacing d = 0.1 m
# (volume 0.01 m^3 = d^2 x 1 m in 2D). Values at the centres of table bins,
# for vmin = 0, vmax = 2 (the largest value, which maps to the last entry).
rng = np.random.default_rng(5)
lattice = [(0.5 * i, 0.5 * j) for j in range(3) for i in range(5) if (i, j) != (2, 1)]
files, obstacle_files = [], []
for k, t in enumerate([0.0, 0.5, 1.0]):
    x = np.array([[px + 0.1 * k, py, 0.0] for px, py in lattice])
    n = len(x)
    strain = (rng.integers(0, 256, n) + 0.5) / 256 * 2.0
    if k == 0:
        strain[:] = 0.0
    if k == 2:
        strain[3] = 2.0
    velocity = np.zeros((n, 3))
    velocity[:, 1] = (rng.integers(0, 256, n) + 0.5) / 256 * 2.0 - 1.0   # bin centres for [-1, 1]
    velocity[0, 1], velocity[1, 1] = -3.0, 5.0                           # clamped to the ends
    velocity[:, 0] = 7.0                                                 # (magnitude would differ)
    write_vtu(f"particles_{k:06d}.vtu", x, {"cumulative_plastic_strain": strain, "volume": np.full(n, 0.01),
                                             "velocity": velocity, "particle_id": np.arange(n, dtype=np.int64)})
    files.append((t, f"particles_{k:06d}.vtu"))
    # the obstacle: a box [0.95, 1.25] x [0.35, 0.65] drawn as a filled polygon, like talus in 2D
    poly = vtk.vtkPolyData()
    pts = vtk.vtkPoints()
    for p in ((0.95, 0.35), (1.25, 0.35), (1.25, 0.65), (0.95, 0.65)):
        pts.InsertNextPoint(p[0], p[1], 0.0)
    poly.SetPoints(pts)
    cells = vtk.vtkCellArray()
    cells.InsertNextCell(4, [0, 1, 2, 3])
    poly.SetPolys(cells)
    w = vtk.vtkXMLPolyDataWriter()
    w.SetFileName(os.path.join(out, f"obstacles_{k:06d}.vtp"))
    w.SetInputData(poly)
    assert w.Write() == 1
    obstacle_files.append((t, f"obstacles_{k:06d}.vtp"))
write_pvd("particles.pvd", files)
write_pvd("obstacles.pvd", obstacle_files)
write_pvd("empty.pvd", [])
write_pvd("broken.pvd", [(0.0, "particles_000000.vtu"), (0.5, "no_such_output.vtu")])
PY

# The pictures (name: arguments); each is drawn to name.png, its output in name.log.
declare -A pictures=(
  [row]='syn/particles.pvd --times 0.1 0.45 2 --width 300 --title synthetic'
  [column]='syn/particles.pvd --times 0 1 --width 200 --layout column --glyph disc --no-obstacles --field velocity:1 --vmin -1 --vmax 1'
  [real]='out/particles.pvd --times 0 0.1 0.2 --width 300'
  [block]='out3/particles.pvd --times 0 0.02 --field velocity --width 300'
)
render() {  # render interpreter name: picture name under xvfb-run, to name.png, stdout to name.log
  local interp=$1 name=$2 start=$(date +%s%N)
  # shellcheck disable=SC2086  # the arguments above are split on spaces
  xvfb-run -a "$interp" "$script" ${pictures[${name%_pv}]} --out "$name.png" > "$name.log" 2> "$name.err" \
    || { echo "FAIL: $interp render_plastic_strain.py ${pictures[${name%_pv}]}"; cat "$name.log" "$name.err"; exit 1; }
  echo "$name: $(( ($(date +%s%N) - start) / 1000000 )) ms under $interp (xvfb-run included)"
}
render /usr/bin/python3 row
render /usr/bin/python3 column

cat > check_synthetic.py <<'PY'
import os, re, sys
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
work, repo, suffix = sys.argv[1:]   # suffix: "" (python3) or "_pv" (pvbatch) in the file names
sys.path.insert(0, os.path.join(repo, "scripts"))
import render_plastic_strain as rps  # noqa: E402  (the table only; the expected index is computed here)

table = rps.colour_table()
# The table: 256 8-bit colours within 5/255 of matplotlib's viridis (17 anchors,
# linear in between), increasing in luminance (every 4th entry).
import matplotlib  # noqa: E402
viridis = np.rint(matplotlib.colormaps["viridis"](np.linspace(0, 1, 256))[:, :3] * 255)
assert table.shape == (256, 3) and np.abs(table - viridis).max() <= 5, np.abs(table - viridis).max()
assert np.all(np.diff((table @ [0.2126, 0.7152, 0.0722])[::4]) > 0)   # (8-bit rounding: flat between neighbours)

def index(v, vmin, vmax):  # vtkLookupTable's linear rule, written out
    return min(255, max(0, int(np.floor((v - vmin) / (vmax - vmin) * 256))))

def png(name):
    r = vtk.vtkPNGReader()
    r.SetFileName(os.path.join(work, name))
    r.Update()
    img = r.GetOutput()
    w, h, _ = img.GetDimensions()
    assert img.GetPointData().GetScalars().GetNumberOfComponents() == 3, name
    return vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, 3)[::-1].astype(int)  # row 0 = top

panel_re = re.compile(r"panel (\d+): t = (\S+) s, file (.*), viewport x (\d+) (\d+) y (\d+) (\d+) px from top-left, "
                      r"world x (\S+) (\S+) y (\S+) (\S+) m")
def panels(name):
    out = []
    for line in open(os.path.join(work, name + ".log")):
        m = panel_re.match(line)
        if m:
            g = m.groups()
            out.append(dict(label=g[1], file=g[2], vx=(int(g[3]), int(g[4])), vy=(int(g[5]), int(g[6])),
                            wx=(float(g[7]), float(g[8])), wy=(float(g[9]), float(g[10]))))
    return out

def read(path):
    r = vtk.vtkXMLUnstructuredGridReader() if path.endswith(".vtu") else vtk.vtkXMLPUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    g = r.GetOutput()
    return vtk_to_numpy(g.GetPoints().GetData()), g.GetPointData()

d = 0.1
tol = 2   # per channel, 8-bit; flat shading writes the table's bytes (measured 0), 2 leaves room for float->byte rounding
box = (0.95, 1.25, 0.35, 0.65)
worst = 0

def check(name, n_expected, W, field, vmin, vmax, shape, obstacles):
    global worst
    name += suffix
    img = png(name + ".png")
    P = panels(name)
    assert len(P) == n_expected, (name, P)
    H, Wimg, _ = img.shape
    row = len({p["vy"] for p in P}) == 1
    assert Wimg == (n_expected * W if row else W), (name, Wimg)
    inside_total = 0
    for p in P:
        (x0, x1), (y0, y1) = p["vx"], p["vy"]
        (wx0, wx1), (wy0, wy1) = p["wx"], p["wy"]
        assert x1 - x0 == W and 0 < y0 < y1 < H, p
        s = W / (wx1 - wx0)                                       # px per m, the same both ways
        assert abs((wy1 - wy0) * s - (y1 - y0)) < 1e-6, (p, s)
        assert P[0]["wx"] == p["wx"] and P[0]["wy"] == p["wy"]    # one camera for all panels
        x, data = read(p["file"])
        v = vtk_to_numpy(data.GetArray(field[0]))
        v = v if v.ndim == 1 else v[:, field[1]]
        # the world window holds every particle with its glyph
        assert wx0 < x[:, 0].min() - d / 2 and x[:, 0].max() + d / 2 < wx1, p
        assert wy0 < x[:, 1].min() - d / 2 and x[:, 1].max() + d / 2 < wy1, p
        # pixel centres of the panel in world coordinates
        sub = img[y0:y1, x0:x1]
        X = wx0 + (np.arange(W) + 0.5) / s
        Y = wy1 - (np.arange(y1 - y0) + 0.5) / s
        XX, YY = np.meshgrid(X, Y)
        margin = 1.5 / s                                          # 1.5 px: edge pixels are left out
        covered = np.zeros(XX.shape, bool)
        for (px, py, _), value in zip(x, v):
            want = table[index(value, vmin, vmax)]
            if shape == "square":
                dist = np.maximum(np.abs(XX - px), np.abs(YY - py))
            else:
                dist = np.hypot(XX - px, YY - py)
            inside = dist < d / 2 - margin
            covered |= dist < d / 2 + margin
            # the centre pixel (the projected position), then every pixel inside the glyph
            cx, cy = int((px - wx0) * s), int((wy1 - py) * s)
            err = int(np.abs(sub[cy, cx] - want).max())
            assert err <= tol, (name, p["label"], (px, py), value, sub[cy, cx], want)
            err = int(np.abs(sub[inside] - want).max())
            worst = max(worst, err)
            assert err <= tol and inside.sum() >= 0.8 * (d * s - 3) ** 2 * (1 if shape == "square" else np.pi / 4), \
                (name, p["label"], (px, py), err, inside.sum())
            inside_total += int(inside.sum())
        in_box = (XX > box[0] + margin) & (XX < box[1] - margin) & (YY > box[2] + margin) & (YY < box[3] - margin)
        near_box = (XX > box[0] - margin) & (XX < box[1] + margin) & (YY > box[2] - margin) & (YY < box[3] + margin)
        if obstacles:
            assert np.all(sub[in_box] == rps.OBSTACLE_GREY), (name, p["label"], np.unique(sub[in_box].reshape(-1, 3), axis=0))
            covered |= near_box
        background = ~covered
        assert background.sum() > 0.5 * background.size
        assert np.all(sub[background] == 255), (name, p["label"], "non-white background pixels", int((sub[background] != 255).any(axis=-1).sum()))
        # the label strip above the plot: some dark text pixels
        label_rows = img[max(0, y0 - round(max(16, 0.05 * W))):y0, x0:x1]
        assert (label_rows.max(axis=-1) < 110).sum() >= 15, (name, p["label"], "no label text")
    # the colour bar strip below the last panel holds both ends of the table
    bottom = img[max(p["vy"][1] for p in P):].reshape(-1, 3)
    for k in (0, 128, 255):
        assert (np.abs(bottom - table[k]).max(axis=1) <= tol).sum() >= 10, (name, "colour bar lacks entry", k)
    print(f"{name}: {Wimg} x {H} px, {len(P)} panels, labels {[p['label'] for p in P]}, "
          f"{inside_total} glyph pixels checked, px per m {W / (P[0]['wx'][1] - P[0]['wx'][0]):.2f}")
    return img, P

row, Prow = check("row", 3, 300, ("cumulative_plastic_strain", None), 0.0, 2.0, "square", True)
col, Pcol = check("column", 2, 200, ("velocity", 1), -1.0, 1.0, "disc", False)
# labels: the nearest output to 0.1, 0.45 and 2 s, i.e. 0, 0.5 and 1 s
assert [p["label"] for p in Prow] == ["0", "0.5", "1"] and [p["label"] for p in Pcol] == ["0", "1"], (Prow, Pcol)
assert [os.path.basename(p["file"]) for p in Prow] == [f"particles_{k:06d}.vtu" for k in range(3)]
# heights: title strip + rows x (label strip + plot) + colour bar strip, the same strips in both
label_h, bar_h = max(16, round(0.05 * 300)), round(3.8 * max(16, round(0.05 * 300)))
assert Prow[0]["vy"][0] == round(1.4 * label_h) + label_h and row.shape[0] == Prow[0]["vy"][1] + bar_h, (Prow, row.shape)
label_c = max(16, round(0.05 * 200))
assert col.shape[0] == 2 * (label_c + Pcol[0]["vy"][1] - Pcol[0]["vy"][0]) + round(3.8 * label_c), col.shape
print(f"synthetic{suffix}: max colour error inside the glyphs {worst} (tolerance {tol}), background exactly white")
PY
/usr/bin/python3 check_synthetic.py "$work" "$repo" ""

# --- 2. a short real run (the first 0.2 s of the psi = 0 column) ----------
sed -e "s#directory: .*#directory: $work/out#" -e 's/end: .*/end: 0.2/' -e 's/interval: .*/interval: 0.1/' \
  "$repo/inputs/column_collapse_psi0.yaml" > run.yaml
"$talus" run run.yaml > run.log 2>&1 || { echo "FAIL: talus run"; cat run.log; exit 1; }
render /usr/bin/python3 real

cat > check_real.py <<'PY'
import os, re, sys
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
work, repo, suffix = sys.argv[1:]
sys.path.insert(0, os.path.join(repo, "scripts"))
import render_plastic_strain as rps  # noqa: E402
table = rps.colour_table()
r = vtk.vtkPNGReader()
r.SetFileName(os.path.join(work, f"real{suffix}.png"))
r.Update()
w, h, _ = r.GetOutput().GetDimensions()
img = vtk_to_numpy(r.GetOutput().GetPointData().GetScalars()).reshape(h, w, 3)[::-1].astype(int)
log = open(os.path.join(work, f"real{suffix}.log")).read()
P = re.findall(r"panel \d+: t = (\S+) s, file (.*?), viewport x (\d+) (\d+) y (\d+) (\d+)", log)
assert [p[0] for p in P] == ["0", "0.1", "0.2"] and all(p[1].endswith(".pvtu") for p in P), P
assert w == 3 * 300, w
assert "particle spacing 0.025 m" in log, log        # sqrt(volume) = cell 0.05 / 2 particles per cell
counts = []
for label, f, x0, x1, y0, y1 in P:
    sub = img[int(y0):int(y1), int(x0):int(x1)].reshape(-1, 3)
    particle = (sub != 255).any(axis=1)
    zero = (np.abs(sub - table[0]).max(axis=1) <= 2)
    other = particle & ~zero
    counts.append((label, int(particle.sum()), int(zero.sum()), int(other.sum())))
label, n, n0, n_other = counts[0]
# t = 0: 800 particles of 0.025 m, all strain 0: every particle pixel has the colour of entry 0 (flat, no blending)
assert n > 2000 and n0 == n, counts
label, n, n0, n_other = counts[-1]
assert n_other > 0.05 * n, counts                  # yielded particles: colours of strain > 0
print(f"real run{suffix}: panels (label, particle px, strain-0 px, other px):", counts)
PY
/usr/bin/python3 check_real.py "$work" "$repo" ""

# A 3D run to compare below (lit spheres, oblique camera): the first two
# steps of elastic_block_3d.yaml. Here only: the size and spheres in each panel.
sed -e "s#directory: .*#directory: $work/out3#" -e 's/end: .*/end: 0.02/' -e 's/interval: .*/interval: 0.01/' \
  "$repo/inputs/elastic_block_3d.yaml" > block.yaml
"$talus" run block.yaml > block_run.log 2>&1 || { echo "FAIL: talus run (3D)"; cat block_run.log; exit 1; }
render /usr/bin/python3 block
cat > check_block.py <<'PY'
import os, re, sys
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
work, suffix = sys.argv[1:]
r = vtk.vtkPNGReader()
r.SetFileName(os.path.join(work, f"block{suffix}.png"))
r.Update()
w, h, _ = r.GetOutput().GetDimensions()
img = vtk_to_numpy(r.GetOutput().GetPointData().GetScalars()).reshape(h, w, 3)[::-1].astype(int)
log = open(os.path.join(work, f"block{suffix}.log")).read()
assert f"({w} x {h} px, 2 panels" in log and ", 3D," in log, (w, h, log)
P = [tuple(map(int, m)) for m in re.findall(r"viewport x (\d+) (\d+) y (\d+) (\d+)", log)]
drawn = [int((img[y0:y1, x0:x1] != 255).any(axis=-1).sum()) for x0, x1, y0, y1 in P]
assert len(P) == 2 and min(drawn) > 0.1 * (P[0][1] - P[0][0]) * (P[0][3] - P[0][2]), (P, drawn)
print(f"3D block{suffix}: {w} x {h} px, sphere pixels per panel {drawn}")
PY
/usr/bin/python3 check_block.py "$work" ""

# --- 3. failures ---------------------------------------------------------------
expect_fail() {  # expect_fail text args...: exit 1 and text in stderr (interpreter: $interp)
  local text=$1
  shift
  set +e
  "${interp:-/usr/bin/python3}" "$script" "$@" > fail.out 2> fail.err
  local rc=$?
  set -e
  [ $rc -eq 1 ] || { echo "FAIL: exit $rc (expected 1) for $*"; cat fail.out fail.err; exit 1; }
  grep -qF -- "$text" fail.err || { echo "FAIL: '$text' not in the message for $*"; cat fail.err; exit 1; }
  echo "fails as expected: ${interp:-/usr/bin/python3} $* -> $(cat fail.err)"
}
expect_fail "missing file syn/nothing.pvd" syn/nothing.pvd
expect_fail "syn/empty.pvd lists no data sets" syn/empty.pvd
expect_fail "no_such_output.vtu" syn/broken.pvd --times 0 0.5
expect_fail "unknown field 'plastic_strain'" syn/particles.pvd --field plastic_strain
expect_fail "component 3 of --field velocity:3 out of range" syn/particles.pvd --field velocity:3
(unset DISPLAY; expect_fail "no X display: run under xvfb-run" syn/particles.pvd --out nodisplay.png)
[ ! -e nodisplay.png ] || { echo "FAIL: a PNG written without a display"; exit 1; }

# --- 4. the same pictures under ParaView's pvbatch ----------------------------
pvbatch=${TALUS_PVBATCH:-}
if [ -z "$pvbatch" ]; then
  if [ -x /opt/talus-paraview/bin/pvbatch ]; then
    pvbatch=/opt/talus-paraview/bin/pvbatch
  else
    pvbatch=$(command -v pvbatch || true)
  fi
fi
if [ -z "$pvbatch" ]; then
  echo "render_script: pvbatch part SKIPPED: no pvbatch here (neither /opt/talus-paraview/bin/pvbatch, from scripts/install_paraview.sh, nor pvbatch on the PATH)"
  echo "render_script ok (python3 only)"
  exit 0
fi
# Which Python modules does it use? (No display needed.) ParaView's own VTK:
# vtkmodules beside the paraview package (a pvbatch that picked up
# python3-vtk9's modules would crash, or compare VTK 9.1 with itself).
cat > probe.py <<'PY'
import os
import vtkmodules, paraview
from paraview.simple import GetParaViewVersion
from vtkmodules.vtkCommonCore import vtkVersion
v = GetParaViewVersion()
here = os.path.dirname(os.path.dirname(vtkmodules.__file__))
if here != os.path.dirname(os.path.dirname(paraview.__file__)):
    raise SystemExit(f"vtkmodules ({vtkmodules.__file__}) not beside paraview ({paraview.__file__})")
print(f"ParaView {v.major}.{v.minor} with VTK {vtkVersion.GetVTKVersion()} from {here}")
PY
if ! "$pvbatch" probe.py > probe.log 2>&1; then
  if [ -n "${TALUS_PVBATCH:-}" ] || grep -qF "talus install_paraview.sh wrapper" "$pvbatch" 2>/dev/null; then
    echo "FAIL: $pvbatch cannot import paraview.simple:"; grep -vE '^ *[0-9]+ +0x' probe.log | tail -n 5; exit 1
  fi
  echo "render_script: pvbatch part SKIPPED: $pvbatch cannot import paraview.simple (Debian's paraview without"
  echo "  its Python? scripts/install_paraview.sh gives a working one):"; grep -vE '^ *[0-9]+ +0x' probe.log | tail -n 2
  echo "render_script ok (python3 only)"
  exit 0
fi
echo "pvbatch: $pvbatch: $(tail -n 1 probe.log)"
pv_vtk=$(sed -n 's/.* with VTK \([^ ]*\) from .*/\1/p' probe.log | tail -n 1)
for name in row column real block; do
  render "$pvbatch" "${name}_pv"
done
/usr/bin/python3 check_synthetic.py "$work" "$repo" _pv
/usr/bin/python3 check_real.py "$work" "$repo" _pv
/usr/bin/python3 check_block.py "$work" _pv
interp=$pvbatch expect_fail "missing file syn/nothing.pvd" syn/nothing.pvd
# each picture drawn by the VTK it should be: python3-vtk9's, ParaView's
py_vtk=$(/usr/bin/python3 -c 'import vtk; print(vtk.vtkVersion.GetVTKVersion())')
for name in row column real block; do
  grep -qF "VTK $py_vtk)" "$name.log" || { echo "FAIL: $name.png not drawn with VTK $py_vtk"; cat "$name.log"; exit 1; }
  grep -qF "VTK $pv_vtk)" "${name}_pv.log" || { echo "FAIL: ${name}_pv.png not drawn with ParaView's VTK $pv_vtk"; cat "${name}_pv.log"; exit 1; }
done
echo "drawn with VTK $py_vtk (python3) and VTK $pv_vtk (pvbatch)"

# The same pictures: same size, the same panel lines (geometry computed by the
# script), in every panel's plot (particles, obstacles, background) no pixel
# differing by more than 2/255 in a channel (8-bit rounding), and over the
# whole picture at most 0.2 % of the pixels: only text (labels, title, the
# colour bar's ticks) may be rasterised differently by the two VTK versions.
/usr/bin/python3 - "$work" <<'PY'
import os, re, sys
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
work = sys.argv[1]
TOL, LIMIT = 2, 0.002

def png(name):
    r = vtk.vtkPNGReader()
    r.SetFileName(os.path.join(work, name))
    r.Update()
    w, h, _ = r.GetOutput().GetDimensions()
    return vtk_to_numpy(r.GetOutput().GetPointData().GetScalars()).reshape(h, w, -1)[::-1].astype(int)

def panel_lines(name):
    return [l.rstrip("\n") for l in open(os.path.join(work, name + ".log")) if l.startswith("panel ")]

worst = 0.0
for name in ("row", "column", "real", "block"):
    a, b = png(name + ".png"), png(name + "_pv.png")
    assert a.shape == b.shape, (name, a.shape, b.shape)
    la, lb = panel_lines(name), panel_lines(name + "_pv")
    assert la == lb and la, (name, la, lb)
    differ = np.abs(a - b).max(axis=-1) > TOL
    plots = np.zeros(differ.shape, bool)
    for l in la:
        x0, x1, y0, y1 = map(int, re.search(r"viewport x (\d+) (\d+) y (\d+) (\d+)", l).groups())
        plots[y0:y1, x0:x1] = True
    text = int(((a != 255).any(axis=-1) & ~plots).sum())      # non-white pixels outside the plots
    assert not (differ & plots).any(), (name, "pixels of a plot differ", int((differ & plots).sum()))
    fraction = float(differ.mean())
    assert fraction <= LIMIT, (name, fraction)
    worst = max(worst, fraction)
    print(f"{name}: {a.shape[1]} x {a.shape[0]} px under both, {int(differ.sum())} pixels differ by more than "
          f"{TOL}/255 ({100 * fraction:.3f} %, limit {100 * LIMIT:g} %), none in the plots; largest difference "
          f"{int(np.abs(a - b).max())}/255; {text} non-white pixels outside the plots")
print(f"pvbatch and python3: largest fraction of differing pixels {100 * worst:.3f} %")
PY
echo "render_script ok (python3 and pvbatch)"
