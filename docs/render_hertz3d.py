"""Render the ``hertz3d`` case (results of run_cases.py) with ParaView into a PNG for the README.

Run with ParaView's Python (Debian bookworm: package python3-paraview, ParaView 5.11) under a virtual
X server::

    mpirun --allow-run-as-root -n 2 /usr/bin/python3 run_cases.py hertz3d --out /tmp/hz3d_render
    xvfb-run -a pvpython docs/render_hertz3d.py /tmp/hz3d_render docs/hertz3d.png

Two panels of one picture, from the final level's ``solution.xdmf``:
* left: the quarter ball seen from the side of its two symmetry planes (x = 0 and y = 0, where the
  model is cut), warped by the displacement (scale factor written in the picture), coloured by the von
  Mises stress (DG0, cell data), with the surface mesh drawn faintly so the adaptive refinement shows on
  the symmetry planes (the stress below the contact point, the clamped rim) and the undeformed outline;
* right: the contact zone seen from below (undeformed), coloured by ``contact_pressure`` (grey where it
  is 0), with two quarter circles: Hertz's contact radius a and the computed one sqrt(4A/π) (A the area
  of {p > 0}), both read from ``summary.json`` (``reference``, written because the case sets
  ``[reference] hertz = "sphere"``).

It prints the arrays ParaView found in ``solution.xdmf`` and exits with status 1 if ``displacement``,
``von_mises`` or ``contact_pressure`` is missing (status 2 without ``solution.xdmf``). The ParaView
workarounds (absolute path for the Xdmf3 reader, gathering the per-function blocks onto one mesh, X
rendering only, camera after the first render, views deleted before exit) are those of
``render_block.py``, whose helpers this script imports.
"""
import argparse
import builtins
import math
import os
import sys

from paraview.simple import (
    AssignViewToLayout, ColorBy, CreateLayout, CreateView, Delete, ExtractEdges, ExtractSurface,
    FeatureEdges, GetColorTransferFunction, GetOpacityTransferFunction, GetScalarBar, PolyLineSource,
    Render, SaveScreenshot, Show, WarpByVector)

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from render_block import nice_ceil, open_results, text  # noqa: E402 (the same ParaView recipe)

REQUIRED = ("displacement", "von_mises", "contact_pressure")
GREY = [0.82, 0.82, 0.82]


def parse():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", help="directory written by run_cases.py hertz3d (holds solution.xdmf/.h5)")
    ap.add_argument("output", help="PNG file to write")
    ap.add_argument("--scale", type=float, default=10.0, help="displacement magnification (default 10)")
    ap.add_argument("--size", type=int, nargs=2, default=(1400, 800), metavar=("W", "H"))
    return ap.parse_args()


def reference_values(summary):
    """(computed, Hertz) contact radius and peak pressure from summary.json, None where absent."""
    rows = {row["quantity"]: (row["computed"], row["reference"]) for row in summary.get("reference", [])}
    return rows.get("contact radius"), rows.get("peak contact pressure")


def new_view(layout, hint, W, H):
    view = CreateView("RenderView")
    AssignViewToLayout(view=view, layout=layout, hint=hint)
    view.ViewSize = [W, H]
    view.OrientationAxesVisibility = 0
    view.UseColorPaletteForBackground = 0
    view.Background = [1.0, 1.0, 1.0]
    view.EnableRenderOnInteraction = 0
    return view


def faint_edges(source, view, opacity, name):
    """The edges of ``source``'s surface mesh, drawn thin and translucent on top of it."""
    edges = Show(ExtractEdges(registrationName=name, Input=source), view)
    edges.ColorArrayName = ["POINTS", ""]
    edges.AmbientColor = edges.DiffuseColor = [0.0, 0.0, 0.0]
    edges.Opacity = opacity
    edges.LineWidth = 0.5
    return edges


def style_bar(bar, title, position, length):
    bar.Title = title
    bar.ComponentTitle = ""
    bar.Visibility = 1
    bar.Orientation = "Vertical"
    bar.WindowLocation = "Any Location"
    bar.Position = position
    bar.ScalarBarLength = length
    bar.TitleColor = bar.LabelColor = [0.1, 0.1, 0.1]
    bar.TitleFontSize, bar.LabelFontSize = 16, 14
    bar.TitleFontFamily = bar.LabelFontFamily = "Arial"
    bar.AddRangeLabels = 1
    bar.RangeLabelFormat = "%.3g"
    bar.ScalarBarThickness = 16
    return bar


def quarter_circle(radius, z, name, view, color, width):
    """The arc of the given radius around the z-axis in the quadrant x, y >= 0, at height z."""
    points = []
    for k in range(65):
        t = 0.5 * math.pi * k / 64
        points += [radius * math.cos(t), radius * math.sin(t), z]
    arc = Show(PolyLineSource(registrationName=name, Points=points), view)
    arc.ColorArrayName = ["POINTS", ""]
    arc.AmbientColor = arc.DiffuseColor = color
    arc.LineWidth = width
    arc.Ambient, arc.Diffuse = 1.0, 0.0
    return arc


def body_panel(surface, view, found, scale):
    """Left panel: the warped quarter ball from the side of its symmetry planes, by von Mises."""
    warped = WarpByVector(registrationName="warped surface", Input=surface)
    warped.Vectors = ["POINTS", "displacement"]
    warped.ScaleFactor = scale
    body = Show(warped, view)
    ColorBy(body, ("CELLS", "von_mises"))
    vm_hi = found["von_mises"][2][1]
    vm_top = nice_ceil(vm_hi)
    lut = GetColorTransferFunction("von_mises")
    lut.ApplyPreset("Turbo", True)
    lut.RescaleTransferFunction(0.0, vm_top)
    GetOpacityTransferFunction("von_mises").RescaleTransferFunction(0.0, vm_top)
    lut.AutomaticRescaleRangeMode = "Never"
    body.Ambient, body.Diffuse = 0.35, 0.65
    faint_edges(warped, view, 0.18, "surface mesh edges")
    outline = FeatureEdges(registrationName="undeformed outline", Input=surface)
    outline.BoundaryEdges, outline.FeatureEdges, outline.FeatureAngle = 0, 1, 40.0
    outline.NonManifoldEdges, outline.ManifoldEdges = 0, 0
    od = Show(outline, view)
    od.ColorArrayName = ["POINTS", ""]
    od.AmbientColor = od.DiffuseColor = [0.3, 0.3, 0.3]
    od.LineWidth = 1.5
    od.Ambient, od.Diffuse = 1.0, 0.0
    Render(view)  # the first Render of a view resets its camera: set the camera after it
    # from the side of the symmetry planes (x, y < 0), a little above the equator of the half ball
    focus = [0.52, 0.40, 0.52]  # the body left of the colour bar, below the texts
    view.CameraFocalPoint = focus
    view.CameraPosition = [focus[0] - 3.6, focus[1] - 4.6, focus[2] + 1.2]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    view.CameraParallelProjection = 1
    view.CameraParallelScale = 0.9
    return lut, vm_hi, vm_top


def contact_panel(surface, view, found, radii):
    """Right panel: the contact zone from below, by contact pressure, with the two contact radii."""
    zone = Show(surface, view)
    ColorBy(zone, ("POINTS", "contact_pressure"))
    p_max = builtins.max(found["contact_pressure"][2][1], 1e-300)
    lut = GetColorTransferFunction("contact_pressure")
    lut.ApplyPreset("Cool to Warm", True)
    lut.RescaleTransferFunction(1e-6 * p_max, p_max)  # p = 0 (no contact) falls below: grey
    lut.UseBelowRangeColor = 1
    lut.BelowRangeColor = GREY
    lut.AutomaticRescaleRangeMode = "Never"
    zone.Ambient, zone.Diffuse = 1.0, 0.0
    edges = faint_edges(surface, view, 0.25, "contact zone edges")
    edges.Position = [0.0, 0.0, -1e-4]  # between the camera (below) and the surface
    computed, hertz = radii if radii else (None, None)
    if hertz:
        quarter_circle(hertz, -3e-4, "Hertz radius", view, [0.0, 0.0, 0.0], 2.5)
    if computed:
        quarter_circle(computed, -4e-4, "computed radius", view, [1.0, 1.0, 1.0], 1.5)
    Render(view)
    extent = 1.5 * (hertz or computed or 0.1)
    # x to the right, y down the picture: the contact point near the upper left corner, room for the
    # texts below and the colour bar on the right
    centre = [0.5 * extent, 0.66 * extent, 0.0]
    view.CameraParallelProjection = 1
    view.CameraFocalPoint = centre
    view.CameraPosition = [centre[0], centre[1], -5.0]  # below, looking up
    view.CameraViewUp = [0.0, -1.0, 0.0]
    view.CameraParallelScale = 0.78 * extent
    return lut, p_max, extent


def main():
    args = parse()
    opened = open_results(args.results, REQUIRED, "render_hertz3d")
    if isinstance(opened, int):
        return opened
    _, found, summary, mesh = opened
    radii, peaks = reference_values(summary)
    surface = ExtractSurface(registrationName="surface", Input=mesh)

    W, H = args.size
    layout = CreateLayout("hertz3d")
    layout.SplitHorizontal(0, 0.56)
    layout.SetSize(W, H)
    left, right = new_view(layout, 1, int(0.56 * W), H), new_view(layout, 2, W - int(0.56 * W), H)
    vm_lut, vm_hi, vm_top = body_panel(surface, left, found, args.scale)
    p_lut, p_max, extent = contact_panel(surface, right, found, radii)

    style_bar(GetScalarBar(vm_lut, left), "von Mises stress", [0.87, 0.08], 0.45)
    p_bar = style_bar(GetScalarBar(p_lut, right), "contact pressure", [0.83, 0.30], 0.5)
    p_bar.RangeLabelFormat = "%.0f"  # the lower end is 1e-6 p_max: "0"
    title = summary.get("title", "hertz3d").split(":")[0]
    text(left, f"{title}: a quarter ball pressed by its weight onto a stiff foundation", "Upper Left Corner",
         size=20, bold=True)
    sub = f"{summary.get('refine', 'adaptive')} mesh"
    if "level" in summary:
        sub += (f" after {summary['level']} refinements ({summary.get('cells', 0):,} tetrahedra,"
                f" {summary.get('dofs', 0):,} dofs)")
    info = text(left, sub + f"\nseen from the symmetry planes x = 0, y = 0; displacement x{args.scale:g};"
                "\nsurface mesh edges; dark grey lines: undeformed edges", "Any Location", size=15)
    info.Position = [0.01, 0.855]
    info.Justification = "Left"
    lines = ["contact zone seen from below (undeformed); grey: p = 0"]
    if radii:
        lines.append(f"black: Hertz radius a = {radii[1]:.4f}")
        lines.append(f"white: computed sqrt(4A/pi) = {radii[0]:.4f} ({100 * (radii[0] / radii[1] - 1):+.1f} %)")
    if peaks:
        lines.append(f"peak pressure {peaks[0]:.1f}, Hertz p0 = {peaks[1]:.1f}"
                     f" ({100 * (peaks[0] / peaks[1] - 1):+.1f} %)")
    note = text(right, "\n".join(lines), "Any Location", size=15)
    note.Position = [0.03, 0.03]
    note.Justification = "Left"
    Render(left)
    Render(right)
    out = os.path.abspath(args.output)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    SaveScreenshot(out, layout, ImageResolution=[W, H], TransparentBackground=0)
    print(f"wrote {out} ({W}x{H}, displacement x{args.scale:g}, von Mises scale 0..{vm_top:g}"
          f" (max {vm_hi:.4g}), contact pressure max {p_max:.4g})")
    Delete(layout)  # tear the views down before the interpreter exits (GLXBadContext otherwise)
    Delete(left)
    Delete(right)
    return 0


if __name__ == "__main__":
    sys.exit(main())
