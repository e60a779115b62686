"""Render the README picture of the ``block`` case with ParaView from nc_dolfinx's XDMF output.

Usage (pvpython comes with Debian's python3-paraview, which ``install.sh --paraview`` must install;
run it under Xvfb)::

    /usr/bin/python3 run_cases.py block --out /tmp/block_render
    xvfb-run -a pvpython docs/render_block.py /tmp/block_render docs/block.png [--scale 3]

The picture shows the body warped by the displacement (scale factor written in the picture),
coloured by the von Mises stress (DG0, cell data) with the mesh edges drawn faintly so the adaptive
refinement is visible, the undeformed outline, and the contact pressure on the bottom edge as
arrows (the foundation pushing on the body) coloured and scaled by ``contact_pressure``.

It first prints the arrays ParaView found in ``solution.xdmf`` and exits with status 1 if any of
``displacement``, ``von_mises``, ``contact_pressure`` or ``eta`` is missing, so it doubles as a check
that the XDMF output opens in ParaView with the expected names.

Notes on this ParaView build (Debian bookworm, 5.11):
* the script hands the Xdmf3 reader an absolute path: given a bare file name (``solution.xdmf``, no
  directory part) the reader looks for ``solution.xdmfsolution.h5`` and the process aborts;
* dolfinx writes every function as its own grid sharing one mesh, so the reader returns one block
  per function; ``MergeBlocks`` would stack 11 copies of the cells and drop every array that is not
  on all blocks, so a small programmable filter gathers the arrays of all blocks onto one mesh;
* this build renders through X only: ``--force-offscreen-rendering`` or no DISPLAY crashes
  (SIGSEGV/SIGABRT), so run it as ``xvfb-run -a pvpython``;
* the programmable filter runs in ``__main__`` and rebinds ``min``/``max`` there to VTK's numpy
  versions, hence ``builtins.min``/``builtins.max`` below;
* ``paraview.simple.Render`` resets the camera on a view's first render, so the camera is set after
  one, and the view is deleted before exit (otherwise X reports GLXBadContext and the exit status
  is 1).
"""
import argparse
import builtins
import json
import math
import os
import sys

import numpy
from paraview import servermanager
from paraview.simple import (
    AssignViewToLayout, Calculator, ColorBy, CreateLayout, CreateView, Delete, ExtractEdges,
    ExtractSurface, FeatureEdges, GetColorTransferFunction, GetOpacityTransferFunction, GetScalarBar,
    Glyph, Line, ProgrammableFilter, Render, ResampleWithDataset, SaveScreenshot, Show, Text,
    WarpByVector, Xdmf3ReaderS)
from vtkmodules.util.numpy_support import vtk_to_numpy

REQUIRED = ("displacement", "von_mises", "contact_pressure", "eta")

# Gather the arrays of all blocks (one per written function, all on the same mesh) onto one grid.
GATHER = r"""
inp = self.GetInputDataObject(0, 0)
out = self.GetOutputDataObject(0)
it = inp.NewIterator()
it.InitTraversal()
first = None
while not it.IsDoneWithTraversal():
    ds = it.GetCurrentDataObject()
    if first is None:
        first = ds
        out.ShallowCopy(ds)
    elif (ds.GetNumberOfPoints(), ds.GetNumberOfCells()) != (first.GetNumberOfPoints(), first.GetNumberOfCells()):
        raise RuntimeError("XDMF grids are not on the same mesh")
    for src, dst in ((ds.GetPointData(), out.GetPointData()), (ds.GetCellData(), out.GetCellData())):
        for i in range(src.GetNumberOfArrays()):
            dst.AddArray(src.GetAbstractArray(i))
    it.GoToNextItem()
"""


def parse():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", help="directory written by run_cases.py (holds solution.xdmf/.h5)")
    ap.add_argument("output", help="PNG file to write")
    ap.add_argument("--scale", type=float, default=3.0, help="displacement magnification (default 3)")
    ap.add_argument("--size", type=int, nargs=2, default=(1400, 800), metavar=("W", "H"))
    return ap.parse_args()


def list_arrays(src):
    """Print the point and cell arrays ParaView found; return their names."""
    found = {}
    for assoc, arrays in (("point", src.PointData), ("cell", src.CellData)):
        for name in arrays.keys():
            info = arrays[name]
            lo_hi = info.GetRange(-1) if info.GetNumberOfComponents() > 1 else info.GetRange(0)
            found[name] = (assoc, info.GetNumberOfComponents(), lo_hi)
    print("arrays found in the XDMF file by ParaView:")
    for name in sorted(found):
        assoc, ncomp, (lo, hi) = found[name]
        what = "magnitude range" if ncomp > 1 else "range"
        print(f"  {name:18s} {assoc:5s} data, {ncomp} component(s), {what} [{lo:.4g}, {hi:.4g}]")
    return found


def nice_ceil(v):
    """The smallest of 1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8 times a power of ten that is >= v > 0."""
    e = 10.0 ** math.floor(math.log10(v))
    return next(m * e for m in (1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10) if m * e >= v * (1 - 1e-12))


def text(view, string, location, size=14, bold=False, color=(0.1, 0.1, 0.1)):
    t = Text(Text=string)
    d = Show(t, view)
    d.WindowLocation = location
    d.FontSize = size
    d.Bold = int(bold)
    d.Color = list(color)
    d.FontFamily = "Arial"
    return d


def open_results(folder, required, program):
    """Read ``solution.xdmf`` and ``summary.json`` of a results folder: (reader, arrays found, summary,
    the arrays of all blocks gathered onto one mesh), or an exit status: 2 without ``solution.xdmf``, 1
    if an array of ``required`` is missing (both with a message naming ``program``)."""
    xdmf = os.path.join(os.path.abspath(folder), "solution.xdmf")
    if not os.path.isfile(xdmf):
        print(f"{program}: {xdmf} not found", file=sys.stderr)
        return 2
    reader = Xdmf3ReaderS(registrationName="solution.xdmf", FileName=[xdmf])  # absolute path!
    reader.UpdatePipeline()
    found = list_arrays(reader)
    missing = [n for n in required if n not in found]
    if missing:
        print(f"{program}: missing array(s) {', '.join(missing)} in {xdmf}", file=sys.stderr)
        return 1
    summary = {}
    if os.path.isfile(os.path.join(os.path.dirname(xdmf), "summary.json")):
        with open(os.path.join(os.path.dirname(xdmf), "summary.json")) as f:
            summary = json.load(f)
    mesh = ProgrammableFilter(registrationName="gather", Input=reader)
    mesh.OutputDataSetType = "vtkUnstructuredGrid"
    mesh.Script = GATHER
    mesh.UpdatePipeline()
    return reader, found, summary, mesh


def main():
    args = parse()
    opened = open_results(args.results, REQUIRED, "render_block")
    if isinstance(opened, int):
        return opened
    reader, found, summary, mesh = opened
    s = args.scale
    warped = WarpByVector(registrationName="warped", Input=mesh)
    warped.Vectors = ["POINTS", "displacement"]
    warped.ScaleFactor = s
    warped.UpdatePipeline()

    W, H = args.size
    view = CreateView("RenderView")
    layout = CreateLayout("block")
    AssignViewToLayout(view=view, layout=layout, hint=0)
    layout.SetSize(W, H)
    view.ViewSize = [W, H]
    view.OrientationAxesVisibility = 0
    view.UseColorPaletteForBackground = 0
    view.Background = [1.0, 1.0, 1.0]
    view.CameraParallelProjection = 1
    view.EnableRenderOnInteraction = 0

    # body coloured by von Mises
    vm_lo, vm_hi = found["von_mises"][2]
    body = Show(warped, view)
    body.Representation = "Surface"
    ColorBy(body, ("CELLS", "von_mises"))
    vm_lut = GetColorTransferFunction("von_mises")
    vm_lut.ApplyPreset("Turbo", True)
    # linear scale up to a round number above the 99.5th percentile: the corner singularities
    # (Γ_D meets Γ_C at (0, 0), clamped corner (0, 1)) would otherwise leave the rest uniformly blue
    vm = vtk_to_numpy(servermanager.Fetch(mesh).GetCellData().GetArray("von_mises"))
    vm_top = nice_ceil(float(numpy.percentile(vm, 99.5)))
    vm_lut.RescaleTransferFunction(0.0, vm_top)
    GetOpacityTransferFunction("von_mises").RescaleTransferFunction(0.0, vm_top)
    vm_lut.UseAboveRangeColor = int(vm_hi > vm_top)
    vm_lut.AboveRangeColor = [0.35, 0.0, 0.0]
    vm_lut.AutomaticRescaleRangeMode = "Never"
    body.Ambient, body.Diffuse = 1.0, 0.0  # flat colours, no shading on a 2D picture

    # faint mesh edges on top of it
    # (a second Show of the same source would return the same representation: extract the edges)
    edges = Show(ExtractEdges(registrationName="mesh edges", Input=warped), view)
    edges.Representation = "Surface"
    edges.ColorArrayName = ["POINTS", ""]
    edges.AmbientColor = edges.DiffuseColor = [0.0, 0.0, 0.0]
    edges.Opacity = 0.22
    edges.LineWidth = 0.6
    edges.Position = [0.0, 0.0, 0.001]

    # undeformed outline (boundary of the original mesh)
    outline = FeatureEdges(registrationName="undeformed outline",
                           Input=ExtractSurface(registrationName="surface", Input=mesh))
    outline.BoundaryEdges, outline.FeatureEdges = 1, 0
    outline.NonManifoldEdges, outline.ManifoldEdges = 0, 0
    od = Show(outline, view)
    od.ColorArrayName = ["POINTS", ""]
    od.AmbientColor = od.DiffuseColor = [0.35, 0.35, 0.35]
    od.LineWidth = 2.0
    od.Ambient, od.Diffuse = 1.0, 0.0
    od.Position = [0.0, 0.0, 0.002]

    # contact pressure along the bottom edge: sample the P1 field on y = 0 at evenly spaced points,
    # move the samples with the (scaled) displacement, draw arrows ending on the deformed edge
    (x0, x1, y0, y1, _, _) = reader.GetDataInformation().GetBounds()
    p_max = builtins.max(found["contact_pressure"][2][1], 1e-300)
    arrow_len = 0.28 * (y1 - y0)          # length of the arrow of the largest pressure
    k = arrow_len / p_max                 # arrow length per unit pressure
    line = Line(registrationName="contact edge", Point1=[x0, y0, 0.0], Point2=[x1, y0, 0.0],
                Resolution=48)
    sampled = ResampleWithDataset(registrationName="sampled", SourceDataArrays=mesh,
                                  DestinationMesh=line)
    sampled.PassPointArrays = 0
    on_edge = WarpByVector(registrationName="sampled warped", Input=sampled)
    on_edge.Vectors = ["POINTS", "displacement"]
    on_edge.ScaleFactor = s
    vec = Calculator(registrationName="pressure vector", Input=on_edge)
    vec.ResultArrayName = "p_vec"
    vec.Function = "contact_pressure*jHat"
    tails = Calculator(registrationName="arrow tails", Input=vec)
    tails.CoordinateResults = 1
    tails.Function = f"coords - {k!r}*contact_pressure*jHat"
    arrows = Glyph(registrationName="pressure arrows", Input=tails, GlyphType="Arrow")
    arrows.OrientationArray = ["POINTS", "p_vec"]
    arrows.ScaleArray = ["POINTS", "contact_pressure"]
    arrows.ScaleFactor = k
    arrows.GlyphMode = "All Points"
    arrows.GlyphType.TipResolution = 24
    arrows.GlyphType.TipRadius = 0.065
    arrows.GlyphType.TipLength = 0.16
    arrows.GlyphType.ShaftRadius = 0.018
    ad = Show(arrows, view)
    ColorBy(ad, ("POINTS", "contact_pressure"))
    p_lut = GetColorTransferFunction("contact_pressure")
    p_lut.ColorSpace = "Lab"
    p_lut.RGBPoints = [0.0, 0.62, 0.78, 0.97, p_max, 0.02, 0.12, 0.42]  # light to dark blue
    p_lut.RescaleTransferFunction(0.0, p_max)
    p_lut.AutomaticRescaleRangeMode = "Never"
    ad.Ambient, ad.Diffuse = 1.0, 0.0
    # envelope of the arrow tails: the pressure profile
    env = Show(tails, view)
    env.ColorArrayName = ["POINTS", ""]
    env.AmbientColor = env.DiffuseColor = [0.05, 0.2, 0.45]
    env.LineWidth = 1.5
    env.Ambient, env.Diffuse = 1.0, 0.0

    Render(view)  # the first Render of a view resets its camera: set the camera after it
    # camera: 2D, parallel projection; fit the scene (outline, warped body, arrows) into the part
    # of the picture left free by the texts (top) and the colour bars (right)
    boxes = [o.GetDataInformation().GetBounds() for o in (outline, warped, tails)]
    sx0, sx1 = builtins.min(bb[0] for bb in boxes), builtins.max(bb[1] for bb in boxes)
    sy0, sy1 = builtins.min(bb[2] for bb in boxes), builtins.max(bb[3] for bb in boxes)
    left, right, top, bottom = 60, W - 260, 135, H - 45       # free pixel box
    ppu = builtins.min((right - left) / (sx1 - sx0), (bottom - top) / (sy1 - sy0))  # pixels per unit
    cx = 0.5 * (sx0 + sx1) + (0.5 * W - 0.5 * (left + right)) / ppu
    cy = 0.5 * (sy0 + sy1) - (0.5 * H - 0.5 * (top + bottom)) / ppu
    view.CameraPosition = [cx, cy, 10.0]
    view.CameraFocalPoint = [cx, cy, 0.0]
    view.CameraViewUp = [0.0, 1.0, 0.0]
    view.CameraParallelScale = 0.5 * H / ppu

    # colour bars, both on the right
    vm_bar = GetScalarBar(vm_lut, view)
    vm_bar.Title = "von Mises stress"
    vm_bar.ComponentTitle = f"(max {vm_hi:.3g})" if vm_hi > vm_top else ""
    vm_bar.Position = [0.84, 0.46]
    vm_bar.ScalarBarLength = 0.42
    p_bar = GetScalarBar(p_lut, view)
    p_bar.Title = "contact pressure"
    p_bar.ComponentTitle = ""
    p_bar.Position = [0.84, 0.06]
    p_bar.ScalarBarLength = 0.30
    for bar in (vm_bar, p_bar):
        bar.Visibility = 1
        bar.Orientation = "Vertical"
        bar.WindowLocation = "Any Location"
        bar.TitleColor = bar.LabelColor = [0.1, 0.1, 0.1]
        bar.TitleFontSize, bar.LabelFontSize = 17, 15
        bar.TitleFontFamily = bar.LabelFontFamily = "Arial"
        bar.AddRangeLabels = 1
        bar.RangeLabelFormat = "%.3g"
        bar.ScalarBarThickness = 18
        bar.DrawTickMarks = 1

    # annotations
    title = summary.get("title", "block: an elastic rectangle pressed onto a deformable foundation")
    sub = f"{summary.get('refine', 'adaptive')} mesh"
    if "level" in summary:
        sub += (f" after {summary['level']} refinements"
                f" ({summary.get('cells', '?')} cells, {summary.get('dofs', '?')} dofs)")
    text(view, title, "Upper Left Corner", size=22, bold=True)
    info = text(view, sub + f";  displacement x{s:g};  grey: undeformed outline;\n"
                "arrows: contact pressure exerted by the foundation on the bottom edge",
                "Any Location", size=16)
    info.Position = [0.008, 0.865]
    info.Justification = "Left"
    Render(view)
    out = os.path.abspath(args.output)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    SaveScreenshot(out, layout, ImageResolution=[W, H], TransparentBackground=0)
    print(f"wrote {out} ({W}x{H}, displacement x{s:g})")
    # tear the view down before the interpreter exits (otherwise X reports GLXBadContext at exit)
    Delete(layout)
    Delete(view)
    return 0


if __name__ == "__main__":
    sys.exit(main())
