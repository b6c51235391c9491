"""``open_in_paraview.py``: a ParaView Python script that opens a series written by
:mod:`workbench.series` with the presets' pipeline built, in one command::

    paraview --script=DIR/open_in_paraview.py            # the GUI, ready to explore
    pvpython DIR/open_in_paraview.py --screenshot out.png [--frame N] [--size 1600x1200]

(Debian's ParaView renders only with an X server: headless, ``xvfb-run -a -s "-screen 0
1280x1024x24" pvpython ...`` (on xvfb-run's default 8-bit screen, 2 runs of 9 aborted
with "bad X server connection"); its ``--force-offscreen-rendering`` crashes in the X
interactor.)

The pipeline, one source per part of the PVD (``ExtractBlock`` by block name):

* ``beads``: Point Gaussian spheres scaled by ``radius`` [m] (true size), coloured by
  ``kind`` (sand, wire bead) with a categorical legend;
* ``wire``: tubes around the links, coloured by the tension [mN] over
  [0, the series' maximum];
* ``contacts``: the strong force network (fn > mean fn of the frame, a Python Calculator
  and a Threshold, as ParaView users build it), tubes whose radius grows with the force,
  coloured by the normal force [mN] over [0, the series' maximum]; the full network is
  there, hidden (the eye in the pipeline browser shows it);
* ``walls``: translucent grey;
* a text with the frame's step, time and, for the triaxial tests, axial strain and q (the
  frame's field data, :mod:`workbench.series`).

Colour limits are fixed over the whole series (no rescaling from frame to frame).  The
script is plain text: edit it, or use it as the start of your own state.  It finds the
PVD beside itself (``__file__``), else at the absolute path it was written for.
"""
from __future__ import annotations

import json
from pathlib import Path

__all__ = ["write_state_script", "SCRIPT_NAME"]

#: File name of the script, beside the PVD.
SCRIPT_NAME = "open_in_paraview.py"

_TEMPLATE = r'''"""Open __PVD__ in ParaView with nscd-workbench's pipeline (written by nscd-workbench).

    paraview --script=open_in_paraview.py
    pvpython open_in_paraview.py --screenshot out.png [--frame N] [--size 1600x1200]

Headless on Debian: xvfb-run -a -s "-screen 0 1280x1024x24" pvpython open_in_paraview.py --screenshot out.png
"""
import os
import sys

from paraview.simple import *  # noqa: F401,F403

PVD = __PVD_REPR__
WRITTEN_IN = __DIR_REPR__
PARTS = __PARTS__
#: ranges over the series, [min, max], by (part, array) [SI units]
RANGES = __RANGES__
SIZES = __SIZES__
#: names of the field data of every frame
FIELDS = __FIELDS__
COLORS = {"sand": [0.851, 0.702, 0.424], "wire": [0.122, 0.306, 0.612],
          "wall": [0.604, 0.647, 0.694]}

try:
    HERE = os.path.dirname(os.path.abspath(__file__))
except NameError:                       # paraview --script= may not set __file__
    HERE = WRITTEN_IN
if not os.path.exists(os.path.join(HERE, PVD)):
    HERE = WRITTEN_IN


def top(key, default):
    r = RANGES.get(key)
    return r[1] if r and r[1] > 0 else default


def lut(array, title, vmax, preset):
    t = GetColorTransferFunction(array)
    t.ApplyPreset(preset, True)
    t.AutomaticRescaleRangeMode = "Never"
    t.RescaleTransferFunction(0.0, vmax)
    GetOpacityTransferFunction(array).RescaleTransferFunction(0.0, vmax)
    bar = GetScalarBar(t, view)
    bar.Title = title
    bar.ComponentTitle = ""
    bar.TitleColor = bar.LabelColor = [0.0, 0.0, 0.0]
    bar.TitleFontSize, bar.LabelFontSize = 14, 12
    bar.RangeLabelFormat = "%-#.3g"
    return t


view = GetActiveViewOrCreate("RenderView")
view.Background = [1.0, 1.0, 1.0]
try:
    view.UseColorPaletteForBackground = 0
except AttributeError:
    pass
view.OrientationAxesVisibility = 1
reader = PVDReader(registrationName=PVD, FileName=os.path.join(HERE, PVD))
reader.UpdatePipelineInformation()


def part(name):
    return ExtractBlock(registrationName=name, Input=reader, Selectors=["/Root/" + name])


r_mean = SIZES.get("mean_radius", 1e-3)

if "walls" in PARTS:
    walls = part("walls")
    d = Show(walls, view)
    d.ColorArrayName = ["POINTS", ""]
    d.AmbientColor = d.DiffuseColor = COLORS["wall"]
    d.Opacity = 0.2

beads = part("beads")
d = Show(beads, view)
d.SetRepresentationType("Point Gaussian")
d.ShaderPreset = "Sphere"
d.GaussianRadius = 1.0
d.ScaleByArray = 1
d.SetScaleArray = ["POINTS", "radius"]
d.UseScaleFunction = 0                  # the radius array is the sphere's radius [m]
ColorBy(d, ("POINTS", "kind"))
kinds = GetColorTransferFunction("kind")
kinds.InterpretValuesAsCategories = 1
kinds.Annotations = ["0", "sand", "1", "wire bead"]
kinds.IndexedColors = COLORS["sand"] + COLORS["wire"]
d.SetScalarBarVisibility(view, False)
beads_display = d

if "wire" in PARTS:
    wire = part("wire")
    wire_mN = Calculator(registrationName="tension [mN]", Input=wire)
    wire_mN.AttributeType = "Cell Data"
    wire_mN.ResultArrayName = "tension_mN"
    wire_mN.Function = "tension*1000"
    tube = Tube(registrationName="wire tubes", Input=ExtractSurface(Input=wire_mN))
    tube.Radius = 0.45 * SIZES.get("bead_radius", r_mean)
    tube.NumberofSides = 12
    d = Show(tube, view)
    ColorBy(d, ("CELLS", "tension_mN"))
    lut("tension_mN", "wire tension [mN]", 1000 * top(("wire", "tension"), 1e-3), "Viridis (matplotlib)")
    d.SetScalarBarVisibility(view, True)
    # the beads of a wire show through the tubes: lighter sand
    beads_display.Opacity = 0.35

contacts = part("contacts")
ratio = PythonCalculator(registrationName="f / mean f", Input=contacts)
ratio.ArrayAssociation = "Cell Data"
ratio.ArrayName = "f_over_mean"
ratio.Expression = "normal_force / mean(normal_force)"
strong = Threshold(registrationName="strong network (f > mean f)", Input=ratio)
strong.Scalars = ["CELLS", "f_over_mean"]
strong.ThresholdMethod = "Above Upper Threshold"
strong.UpperThreshold = 1.0
force_mN = Calculator(registrationName="normal force [mN]", Input=strong)
force_mN.AttributeType = "Cell Data"
force_mN.ResultArrayName = "normal_force_mN"
force_mN.Function = "normal_force*1000"
on_points = CellDatatoPointData(Input=ExtractSurface(Input=force_mN))
on_points.PassCellData = 1
chains = Tube(registrationName="force chains", Input=on_points)
chains.Scalars = ["POINTS", "normal_force_mN"]
chains.VaryRadius = "By Scalar"
chains.Radius = 0.08 * r_mean
chains.RadiusFactor = 6.0
chains.NumberofSides = 8
d = Show(chains, view)
ColorBy(d, ("CELLS", "normal_force_mN"))
lut("normal_force_mN", "normal force [mN]", 1000 * top(("contacts", "normal_force"), 1e-3), "Plasma (matplotlib)")
d.SetScalarBarVisibility(view, True)
if "wire" in PARTS:                     # two bars: the force bar on the left
    GetScalarBar(GetColorTransferFunction("normal_force_mN"), view).WindowLocation = "Any Location"
    GetScalarBar(GetColorTransferFunction("normal_force_mN"), view).Position = [0.02, 0.25]
Hide(contacts, view)

label = PythonAnnotation(registrationName="frame label", Input=beads)
label.ArrayAssociation = "Field Data"
label.Expression = "'step %d   t = %.4g s' % (step[0], time[0])"
if "axial_strain" in FIELDS:            # a triaxial test: its strain and q (NaN before loading)
    label.Expression += (" + ('   axial strain %.2f %%   q = %.3g kPa' % (100 * axial_strain[0], "
                         "deviator[0] / 1e3) if axial_strain[0] == axial_strain[0] else "
                         "'   (before the loading)')")
d = Show(label, view)
d.Color = [0.0, 0.0, 0.0]
d.FontSize = 14
d.WindowLocation = "Upper Left Corner"

times = list(reader.TimestepValues) if reader.TimestepValues else [0.0]
ARGV = list(getattr(sys, "argv", None) or [])   # the GUI's embedded Python may have none


def argument(flag, default=None):
    return ARGV[ARGV.index(flag) + 1] if flag in ARGV[:-1] else default


frame = int(argument("--frame", "-1"))
# the time keeper, not the animation scene: from paraview --script, ParaView 5.11 hung here
# in UpdateAnimationUsingDataTimeSteps() and in setting AnimationTime
GetTimeKeeper().Time = times[frame]
view.ViewTime = times[frame]

# an iso view of the sample (from the front-right, a little above), fitted to it
view.CameraFocalPoint = [0.0, 0.0, 0.0]
view.CameraPosition = [1.0, -1.6, 0.9]
view.CameraViewUp = [0.0, 0.0, 1.0]
view.CameraParallelProjection = 0
view.ResetCamera(False)
Render(view)

shot = argument("--screenshot")
if shot:
    w, h = (int(v) for v in argument("--size", "1200x900").lower().split("x"))
    view.ViewSize = [w, h]              # fonts at their size, not magnified from a small view
    view.ResetCamera(False)
    Render(view)
    SaveScreenshot(shot, view, ImageResolution=[w, h])
    print("open_in_paraview: frame %d (t = %.6g s) -> %s" % (frame % len(times), times[frame], shot))
'''


def write_state_script(pvd_path, path=None, *, ranges: dict | None = None,
                       sizes: dict | None = None, parts=("beads", "contacts"),
                       fields=("step", "time")) -> Path:
    """Write the ParaView script of the series ``pvd_path`` (default
    ``<its folder>/open_in_paraview.py``) and return its path.

    ``ranges``: ``{(part, array): [min, max]}`` over the series (SI units; the colour
    limits: ``("wire", "tension")``, ``("contacts", "normal_force")``), ``sizes``:
    ``{"mean_radius": m, "bead_radius": m}`` (tube radii), ``parts``: the PVD's parts,
    ``fields``: the names of the frames' field data."""
    pvd = Path(pvd_path).resolve()
    out = Path(path) if path is not None else pvd.parent / SCRIPT_NAME
    rng = {(str(k[0]), str(k[1])): [float(v[0]), float(v[1])] for k, v in (ranges or {}).items()}
    text = (_TEMPLATE
            .replace("__PVD_REPR__", repr(pvd.name))
            .replace("__DIR_REPR__", repr(str(pvd.parent)))
            .replace("__PVD__", pvd.name)
            .replace("__PARTS__", repr(list(parts)))
            .replace("__FIELDS__", repr(sorted(fields)))
            .replace("__RANGES__", repr(rng))
            .replace("__SIZES__", json.dumps({k: float(v) for k, v in (sizes or {}).items()})))
    from engine.files import write_text

    write_text(out, text)
    return out
