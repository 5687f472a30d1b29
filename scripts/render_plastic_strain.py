#!/usr/bin/python3
"""Render the particles of a talus run, coloured by the cumulative plastic
strain (or another point array), at chosen times, side by side like the
seminar's figures (t = 0, 1.7, 3.3, 5 s), to one PNG.

    xvfb-run -a /usr/bin/python3 scripts/render_plastic_strain.py \\
        output/slope_collapse_psi0/particles.pvd --times 0 1.7 3.3 5 --out slope.png

Draws with VTK's own rendering pipeline in an offscreen render window, which
on Debian still needs an X server: run it under `xvfb-run -a` (package xvfb,
with xauth). It uses only the `vtk` module and numpy, so it runs under
/usr/bin/python3 with python3-vtk9 and equally under ParaView's pvbatch or
pvpython with ParaView's own VTK (`xvfb-run -a pvbatch
scripts/render_plastic_strain.py ...`; scripts/install_paraview.sh installs
them beside python3-vtk9): the pictures are the same (tests/
test_render_script.sh compares them). Options, the layout and the colours are
described in docs/output.md ("render_plastic_strain.py: the plastic strain
rendered with VTK", under "Plots from a run").

- Each requested time uses the nearest written output; its time is the
  panel's label ("t = 1.7 s").
- One viewport per time, all with the same camera: a 2D run (every z = 0) is
  seen from +z (x to the right, y up, parallel projection) fitted to the
  union of the particle bounding boxes of the drawn outputs; a 3D run from an
  oblique direction.
- Particles are drawn as squares (or discs, --glyph disc) of the particle
  spacing d, flat-shaded in 2D so that each square has exactly the colour
  the lookup table gives its value. d = sqrt(V) in 2D, cbrt(V) in 3D, with V
  the median `volume` of the earliest drawn output (the nearest-neighbour
  distance if there is no `volume` array); --size overrides it.
- Colours: a fixed 256-entry viridis-like table (VIRIDIS_ANCHORS, linearly
  interpolated, 8-bit), value v -> entry floor(256 (v - vmin) / (vmax - vmin))
  clamped to [0, 255]; one shared colour bar at the bottom.
- Obstacles (obstacles.pvd next to particles.pvd, if there) are drawn in grey
  (RGB 153, 153, 153) behind the particles; --no-obstacles leaves them out.

For every panel it prints one line giving its pixel viewport and the world
window mapped onto it (used by tests/test_render_script.sh), then one line with
the image size, the colour scale, the particle spacing and the VTK version:

    panel 1: t = 1.7 s, file .../particles_000017.pvtu, viewport x 450 900 y 53 211 px from top-left, world x -0.479 16.479 y -0.477 5.477 m
    render_plastic_strain: wrote slope.png (1800 x 295 px, 4 panels, cumulative_plastic_strain in [0, 1], 2D, particle spacing 0.1 m, VTK 9.1.0)

Exit status 1 with a message naming the culprit on a missing file, an empty
series, an unknown field or component, or no X display.
"""
import argparse
import os
import sys
import xml.etree.ElementTree as ET

import numpy as np
import vtk
from vtk.util.numpy_support import numpy_to_vtk, vtk_to_numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pvd import pvd_series  # noqa: E402

PROG = "render_plastic_strain"

# viridis (matplotlib) sampled at 17 equally spaced points, 8-bit RGB; the
# table interpolates linearly between them (within 5/255 of viridis).
VIRIDIS_ANCHORS = [
    (68, 1, 84), (72, 24, 106), (71, 45, 123), (66, 64, 134), (59, 82, 139), (51, 99, 141),
    (44, 114, 142), (38, 130, 142), (33, 145, 140), (31, 160, 136), (40, 174, 128),
    (63, 188, 115), (94, 201, 98), (132, 212, 75), (173, 220, 48), (216, 226, 25), (253, 231, 37),
]
TABLE_SIZE = 256
OBSTACLE_GREY = 153  # 0.6 * 255
# DejaVu Sans (fonts-dejavu-core, a dependency of python3-matplotlib) has
# Greek letters and the like, VTK's built-in Arial does not.
FONT_FILE = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"


def fail(message):
    sys.exit(f"{PROG}: error: {message}")


def colour_table():
    """The 256 x 3 table of 8-bit RGB colours, entry k for values in bin k."""
    anchors = np.array(VIRIDIS_ANCHORS, dtype=float)
    x = np.linspace(0.0, 1.0, len(anchors))
    t = np.linspace(0.0, 1.0, TABLE_SIZE)
    return np.rint(np.stack([np.interp(t, x, anchors[:, c]) for c in range(3)], axis=1)).astype(int)


def lookup_table(vmin, vmax):
    """colour_table() as a vtkLookupTable over [vmin, vmax]: a value v gets
    entry floor(256 (v - vmin) / (vmax - vmin)), clamped to 0..255."""
    lut = vtk.vtkLookupTable()
    lut.SetNumberOfTableValues(TABLE_SIZE)
    lut.SetRange(vmin, vmax)
    for k, (r, g, b) in enumerate(colour_table()):
        lut.SetTableValue(k, r / 255.0, g / 255.0, b / 255.0, 1.0)
    lut.SetNanColor(1.0, 0.0, 0.0, 1.0)
    return lut


def read_grid(path):
    if not os.path.isfile(path):
        fail(f"missing file {path}")
    if path.endswith(".pvtu"):  # the pieces it lists must exist too
        try:
            pieces = [e.get("Source") for e in ET.parse(path).getroot().iter("Piece")]
        except ET.ParseError as e:
            fail(f"cannot read {path}: {e}")
        for piece in pieces:
            if piece and not os.path.isfile(os.path.join(os.path.dirname(path), piece)):
                fail(f"missing file {os.path.join(os.path.dirname(path), piece)} (a piece of {path})")
        reader = vtk.vtkXMLPUnstructuredGridReader()
    else:
        reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    if grid is None or grid.GetPoints() is None:
        fail(f"cannot read {path} (or it holds no particle)")
    return grid


def field_values(grid, path, spec):
    """The scalar to colour by: `name` (a vector or tensor: its magnitude),
    `name:k` (component k, from 0) or `name:magnitude`."""
    name, _, part = spec.partition(":")
    data = grid.GetPointData()
    array = data.GetArray(name)
    if array is None:
        names = sorted(data.GetArrayName(i) for i in range(data.GetNumberOfArrays()))
        fail(f"unknown field '{name}': {path} has no point array of that name (it has: {', '.join(names)})")
    values = vtk_to_numpy(array).astype(float)
    if values.ndim == 1:
        values = values[:, None]
    ncomp = values.shape[1]
    if part in ("", "magnitude"):
        return values[:, 0] if ncomp == 1 else np.sqrt((values**2).sum(axis=1))
    try:
        k = int(part)
    except ValueError:
        fail(f"unknown component '{part}' in --field {spec}: give a number from 0 or 'magnitude'")
    if not 0 <= k < ncomp:
        fail(f"component {k} of --field {spec} out of range: '{name}' has {ncomp} component(s)")
    return values[:, k]


def field_title(spec):
    name, _, part = spec.partition(":")
    title = name.replace("_", " ")
    if part and part != "magnitude":
        return f"{title} (component {part})"
    return title


def time_label(t):
    return f"t = {round(t, 6):g} s"


def particle_spacing(frames, dim):
    """Median particle spacing of the earliest drawn output."""
    _, _, grid, x, _ = min(frames, key=lambda f: f[0])
    volume = grid.GetPointData().GetArray("volume")
    if volume is not None and volume.GetNumberOfTuples() > 0:
        v = float(np.median(vtk_to_numpy(volume)))
        if v > 0.0:
            return v ** (1.0 / dim)
    if len(x) < 2:
        return 1.0
    locator = vtk.vtkStaticPointLocator()
    locator.SetDataSet(grid)
    locator.BuildLocator()
    ids = vtk.vtkIdList()
    sample = range(0, len(x), max(1, len(x) // 2000))
    distances = []
    for i in sample:
        locator.FindClosestNPoints(2, x[i], ids)
        j = ids.GetId(1) if ids.GetId(0) == i else ids.GetId(0)
        distances.append(float(np.linalg.norm(x[j] - x[i])))
    d = float(np.median(distances))
    return d if d > 0.0 else 1.0


def obstacle_files(pvd, times):
    """The obstacles.pvd output nearest to each drawn time, or Nones."""
    path = os.path.join(os.path.dirname(pvd), "obstacles.pvd")
    if not os.path.isfile(path):
        return [None] * len(times)
    series = pvd_series(path)
    if not series:
        return [None] * len(times)
    files = [min(series, key=lambda o: abs(o[0] - t))[1] for t in times]
    for f in files:
        if not os.path.isfile(f):
            fail(f"missing file {f} (listed in {path})")
    return files


def glyph_source(kind, dim, d):
    if dim == 3:
        s = vtk.vtkSphereSource()
        s.SetRadius(0.5 * d)
        s.SetThetaResolution(12)
        s.SetPhiResolution(8)
    elif kind == "disc":
        s = vtk.vtkRegularPolygonSource()
        s.SetNumberOfSides(24)
        s.SetRadius(0.5 * d)
    else:
        s = vtk.vtkPlaneSource()
        s.SetOrigin(-0.5 * d, -0.5 * d, 0.0)
        s.SetPoint1(0.5 * d, -0.5 * d, 0.0)
        s.SetPoint2(-0.5 * d, 0.5 * d, 0.0)
    return s


def particle_actor(x, values, lut, source, dim):
    points = vtk.vtkPoints()
    points.SetData(numpy_to_vtk(np.ascontiguousarray(x, dtype=float), deep=True))
    poly = vtk.vtkPolyData()
    poly.SetPoints(points)
    scalars = numpy_to_vtk(np.ascontiguousarray(values, dtype=float), deep=True)
    scalars.SetName("render_field")
    poly.GetPointData().SetScalars(scalars)
    mapper = vtk.vtkGlyph3DMapper()
    mapper.SetInputData(poly)
    mapper.SetSourceConnection(source.GetOutputPort())
    mapper.SetScaling(False)
    mapper.SetOrient(False)
    mapper.SetLookupTable(lut)
    mapper.SetScalarRange(lut.GetRange())
    mapper.SetScalarModeToUsePointData()
    mapper.ScalarVisibilityOn()
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    if dim == 2:  # flat: the pixels carry the table's colours exactly
        prop = actor.GetProperty()
        prop.SetAmbient(1.0)
        prop.SetDiffuse(0.0)
        prop.SetSpecular(0.0)
    return actor


def obstacle_actor(path, dim, d):
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(path)
    reader.Update()
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputConnection(reader.GetOutputPort())
    mapper.ScalarVisibilityOff()
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    prop = actor.GetProperty()
    prop.SetColor(OBSTACLE_GREY / 255.0, OBSTACLE_GREY / 255.0, OBSTACLE_GREY / 255.0)
    prop.SetLineWidth(3.0)
    if dim == 2:
        prop.SetAmbient(1.0)
        prop.SetDiffuse(0.0)
        prop.SetSpecular(0.0)
        actor.SetPosition(0.0, 0.0, -d)  # behind the particles, seen from +z
    else:
        prop.SetOpacity(0.5)
    return actor


def set_font(prop, size, bold=False):
    font_file = FONT_FILE.replace(".ttf", "-Bold.ttf") if bold else FONT_FILE
    if os.path.isfile(font_file):
        prop.SetFontFamily(vtk.VTK_FONT_FILE)
        prop.SetFontFile(font_file)
    else:
        prop.SetFontFamilyToArial()
        prop.SetBold(bold)
    prop.SetFontSize(size)
    prop.SetColor(0.0, 0.0, 0.0)
    prop.ShadowOff()
    prop.ItalicOff()


def text_actor(text, x, y, size, justify="left", bold=False):
    actor = vtk.vtkTextActor()
    actor.SetInput(text)
    prop = actor.GetTextProperty()
    set_font(prop, size, bold)
    prop.SetVerticalJustificationToCentered()
    if justify == "center":
        prop.SetJustificationToCentered()
    else:
        prop.SetJustificationToLeft()
    actor.SetDisplayPosition(int(x), int(y))
    return actor


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("pvd", help="the run's particles.pvd")
    p.add_argument("--times", type=float, nargs="+", default=[0.0, 1.7, 3.3, 5.0],
                   help="times to draw (s); each uses the nearest output (default: 0 1.7 3.3 5)")
    p.add_argument("--field", default="cumulative_plastic_strain",
                   help="point array: name, name:k (component k from 0) or name:magnitude (default of vectors/tensors)")
    p.add_argument("--vmin", type=float, default=None, help="bottom of the colour scale (default 0, or the minimum if negative)")
    p.add_argument("--vmax", type=float, default=None, help="top of the colour scale (default: the maximum over the drawn outputs)")
    p.add_argument("--out", default="plastic_strain.png", help="the PNG to write")
    p.add_argument("--width", type=int, default=600, help="width of one panel in pixels (default 600)")
    p.add_argument("--title", default=None, help="a title above the panels")
    p.add_argument("--layout", choices=("row", "column"), default="row", help="panels side by side (row) or stacked")
    p.add_argument("--glyph", choices=("square", "disc"), default="square", help="particle shape in 2D")
    p.add_argument("--size", type=float, default=None, help="particle spacing d in m (default: from the volume array)")
    p.add_argument("--no-obstacles", action="store_true", help="do not draw obstacles.pvd")
    a = p.parse_args()

    if a.width < 50:
        fail(f"--width {a.width} is too small (at least 50 px)")
    if not os.path.isfile(a.pvd):
        fail(f"missing file {a.pvd}")
    try:
        outputs = pvd_series(a.pvd)
    except Exception as e:  # noqa: BLE001 - a broken XML file
        fail(f"cannot read {a.pvd}: {e}")
    if not outputs:
        fail(f"{a.pvd} lists no data sets (empty series)")

    # The frames: (time, file, grid, positions, values).
    frames = []
    for t in a.times:
        time, path = min(outputs, key=lambda o: abs(o[0] - t))
        grid = read_grid(path)
        x = vtk_to_numpy(grid.GetPoints().GetData()).astype(float)
        frames.append((time, path, grid, x, field_values(grid, path, a.field)))

    dim = 3 if any(np.abs(f[3][:, 2]).max() > 0.0 for f in frames) else 2  # talus writes z = 0 in 2D
    d = a.size if a.size is not None else particle_spacing(frames, dim)
    if not d > 0.0:
        fail(f"--size {a.size} must be positive")
    data_min = min(float(np.nanmin(f[4])) for f in frames)
    data_max = max(float(np.nanmax(f[4])) for f in frames)
    vmin = a.vmin if a.vmin is not None else min(0.0, data_min)
    vmax = a.vmax if a.vmax is not None else max(data_max, vmin)
    if not vmax > vmin:
        vmax = vmin + 1.0
    obstacles = [None] * len(frames) if a.no_obstacles else obstacle_files(a.pvd, [f[0] for f in frames])

    if not os.environ.get("DISPLAY"):
        fail("no X display: run under xvfb-run -a (Debian package xvfb), e.g. "
             "xvfb-run -a /usr/bin/python3 scripts/render_plastic_strain.py ... (or xvfb-run -a pvbatch ...)")

    # Layout (pixels). World window: the union bounding box of the particle
    # centres, widened by d/2 (the glyphs) and 3 % of its larger side.
    W = a.width
    n = len(frames)
    lo = np.min([f[3].min(axis=0) for f in frames], axis=0)
    hi = np.max([f[3].max(axis=0) for f in frames], axis=0)
    label_h = max(16, round(0.05 * W))
    font = max(10, round(0.6 * label_h))
    if dim == 2:
        pad = 0.5 * d + 0.03 * max(hi[0] - lo[0], hi[1] - lo[1], d)
        wx0, wx1, wy0, wy1 = lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad
        plot_h = int(min(max(round(W * (wy1 - wy0) / (wx1 - wx0)), 0.25 * W), 1.5 * W))
    else:
        # oblique view from the -y side and above (z up), fitted to the
        # projection of the union bounding box (widened by d/2)
        direction = np.array([0.55, -1.0, 0.6]) / np.linalg.norm([0.55, -1.0, 0.6])
        up = np.array([0.0, 0.0, 1.0]) - direction[2] * direction
        up /= np.linalg.norm(up)
        right = np.cross(direction, up)  # view direction is -direction
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        corners = corners + 0.5 * d * np.sign(corners - 0.5 * (lo + hi))
        u, v = corners @ right, corners @ up
        ext_u, ext_v = 1.06 * np.ptp(u) + d, 1.06 * np.ptp(v) + d
        plot_h = int(min(max(round(W * ext_v / ext_u), 0.25 * W), 1.5 * W))
        centre3 = 0.5 * (u.min() + u.max()) * right + 0.5 * (v.min() + v.max()) * up \
            + float(np.mean(corners @ direction)) * direction
    panel_h = label_h + plot_h
    title_h = round(1.4 * label_h) if a.title else 0
    bar_h = round(3.8 * label_h)
    cols, rows = (n, 1) if a.layout == "row" else (1, n)
    width, height = cols * W, title_h + rows * panel_h + bar_h

    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.SetMultiSamples(0)
    window.SetNumberOfLayers(2)
    window.SetSize(width, height)

    # Layer 0: white background, texts and the colour bar over the whole window
    # (display coordinates: pixels from the bottom-left corner).
    annotation = vtk.vtkRenderer()
    annotation.SetBackground(1.0, 1.0, 1.0)
    annotation.SetLayer(0)
    window.AddRenderer(annotation)
    if a.title:
        annotation.AddActor2D(text_actor(a.title, width / 2, height - title_h / 2, round(1.15 * font), "center", True))

    lut = lookup_table(vmin, vmax)
    source = glyph_source(a.glyph, dim, d)
    camera = vtk.vtkCamera()
    if dim == 2:
        wh = wy1 - wy0
        scale = min(W / (wx1 - wx0), plot_h / wh)  # px per m
        camera.ParallelProjectionOn()
        camera.SetFocalPoint(0.5 * (wx0 + wx1), 0.5 * (wy0 + wy1), 0.0)
        camera.SetPosition(0.5 * (wx0 + wx1), 0.5 * (wy0 + wy1), 10.0 * max(wx1 - wx0, wh))
        camera.SetViewUp(0.0, 1.0, 0.0)
        camera.SetParallelScale(0.5 * plot_h / scale)
        camera.SetClippingRange(1.0 * max(wx1 - wx0, wh), 20.0 * max(wx1 - wx0, wh))
    else:
        radius = float(np.linalg.norm(hi - lo)) + d
        camera.ParallelProjectionOn()
        camera.SetFocalPoint(*centre3)
        camera.SetPosition(*(centre3 + 4.0 * radius * direction))
        camera.SetViewUp(*up)
        camera.SetParallelScale(0.5 * max(ext_v, ext_u * plot_h / W))
        camera.SetClippingRange(2.0 * radius, 6.0 * radius)

    for k, (time, path, grid, x, values) in enumerate(frames):
        col, row = (k, 0) if a.layout == "row" else (0, k)
        x0 = col * W                            # from the left
        top = title_h + row * panel_h           # from the top
        plot_top = top + label_h
        renderer = vtk.vtkRenderer()
        renderer.SetLayer(1)
        renderer.SetActiveCamera(camera)
        renderer.SetViewport(x0 / width, (height - plot_top - plot_h) / height, (x0 + W) / width, (height - plot_top) / height)
        renderer.AddActor(particle_actor(x, values, lut, source, dim))
        if obstacles[k] is not None:
            renderer.AddActor(obstacle_actor(obstacles[k], dim, d))
        window.AddRenderer(renderer)
        label = time_label(time)
        annotation.AddActor2D(text_actor(label, x0 + 0.3 * font, height - top - label_h / 2, font))
        line = f"panel {k}: {label}, file {path}, viewport x {x0} {x0 + W} y {plot_top} {plot_top + plot_h} px from top-left"
        if dim == 2:
            cx, cy = 0.5 * (wx0 + wx1), 0.5 * (wy0 + wy1)
            hw, hh = 0.5 * W / scale, 0.5 * plot_h / scale
            line += f", world x {cx - hw!r} {cx + hw!r} y {cy - hh!r} {cy + hh!r} m"
        print(line)

    # The colour bar across the bottom strip: the bar and its tick labels
    # (vtkScalarBarActor), the field name centred below them (a text actor:
    # the scalar bar's own horizontal title collides with the tick labels).
    bar = vtk.vtkScalarBarActor()
    bar.SetLookupTable(lut)
    bar.SetOrientationToHorizontal()
    bar.SetTitle("")
    bar.SetNumberOfLabels(5)
    bar.SetMaximumNumberOfColors(TABLE_SIZE)
    bar.SetLabelFormat("%.3g")
    bar.SetUnconstrainedFontSize(True)
    bar.SetTextPositionToPrecedeScalarBar()  # tick labels below the bar
    set_font(bar.GetLabelTextProperty(), font)
    bar_w = min(0.7 * width, 2.5 * W) if a.layout == "row" else 0.8 * W
    frame_h = round(2.0 * label_h)
    frame_bottom = bar_h - round(0.3 * label_h) - frame_h
    bar.GetPositionCoordinate().SetCoordinateSystemToDisplay()
    bar.GetPositionCoordinate().SetValue(0.5 * (width - bar_w), frame_bottom)
    bar.GetPosition2Coordinate().SetCoordinateSystemToDisplay()
    bar.GetPosition2Coordinate().SetValue(bar_w, frame_h)
    bar.SetMaximumHeightInPixels(frame_h)
    bar.SetMaximumWidthInPixels(int(bar_w))
    bar.SetBarRatio(0.4)
    annotation.AddActor2D(bar)
    annotation.AddActor2D(text_actor(field_title(a.field), width / 2, 0.5 * frame_bottom, font, "center"))

    window.Render()
    image = vtk.vtkWindowToImageFilter()
    image.SetInput(window)
    image.SetInputBufferTypeToRGB()
    image.ReadFrontBufferOff()
    image.Update()
    writer = vtk.vtkPNGWriter()
    writer.SetCompressionLevel(9)
    writer.SetFileName(a.out)
    writer.SetInputConnection(image.GetOutputPort())
    writer.Write()
    if not os.path.isfile(a.out):
        fail(f"could not write {a.out}")
    print(f"{PROG}: wrote {a.out} ({width} x {height} px, {n} panel{'s' if n != 1 else ''}, {a.field} in [{vmin:g}, {vmax:g}], "
          f"{'2D' if dim == 2 else '3D'}, particle spacing {d:g} m, VTK {vtk.vtkVersion.GetVTKVersion()})")


if __name__ == "__main__":
    main()
