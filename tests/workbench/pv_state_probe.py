"""Run by ``pvpython`` under ``xvfb-run`` (not by pytest): run an exported
``open_in_paraview.py`` as ParaView would, with ``--screenshot``, then dump what the
script built: the pipeline's source names, the representation and scale array of the
beads, the colour limits of the wire and force colour maps, and the frame label's text.

    xvfb-run -a pvpython pv_state_probe.py OUT.json open_in_paraview.py SHOT.png WxH [FRAME]
"""
import json
import runpy
import sys

out, script, shot, size = sys.argv[1:5]
frame = sys.argv[5] if len(sys.argv) > 5 else "-1"
sys.argv = [script, "--screenshot", shot, "--size", size, "--frame", frame]
runpy.run_path(script, run_name="__main__")

from paraview import servermanager  # noqa: E402
from paraview.simple import (FindSource, GetColorTransferFunction, GetDisplayProperties,  # noqa: E402
                             GetSources)


def limits(name):
    pts = list(GetColorTransferFunction(name).RGBPoints)
    return [pts[0], pts[-4]]


beads = GetDisplayProperties(FindSource("beads"))
label = servermanager.Fetch(FindSource("frame label"))
report = {
    "sources": sorted(k[0] for k in GetSources()),
    "beads": {"representation": str(beads.Representation).strip("'"),
              "scale_array": [str(s) for s in beads.SetScaleArray],
              "scale_by_array": int(beads.ScaleByArray)},
    "walls_opacity": float(GetDisplayProperties(FindSource("walls")).Opacity),
    "tension_mN": limits("tension_mN"),
    "normal_force_mN": limits("normal_force_mN"),
    "label": label.GetColumn(0).GetValue(0),
}
with open(out, "w") as f:
    json.dump(report, f)
