"""Run by the ParaView GUI (``paraview --script=pv_gui_probe.py``, not by pytest): run an
exported ``open_in_paraview.py`` inside the GUI as a user's ``--script`` would, save the
view, and write a JSON report (``ok`` or the traceback) to the path in the environment
variable ``NSCD_GUI_REPORT``.  The GUI stays open: the test kills it once the report is
there.  The state script's path is in ``NSCD_GUI_SCRIPT``, the picture's in
``NSCD_GUI_SHOT``."""
import json
import os
import traceback

report = {"ok": False}
try:
    script = os.environ["NSCD_GUI_SCRIPT"]
    ns = {"__name__": "__main__"}       # no __file__: as the GUI runs a --script
    exec(compile(open(script).read(), script, "exec"), ns)
    from paraview.simple import SaveScreenshot
    SaveScreenshot(os.environ["NSCD_GUI_SHOT"], ns["view"], ImageResolution=[640, 480])
    report = {"ok": True, "here": ns["HERE"], "frame": ns["frame"], "times": ns["times"]}
except BaseException:
    report["error"] = traceback.format_exc()
with open(os.environ["NSCD_GUI_REPORT"] + ".tmp", "w") as f:
    json.dump(report, f)
os.replace(os.environ["NSCD_GUI_REPORT"] + ".tmp", os.environ["NSCD_GUI_REPORT"])
