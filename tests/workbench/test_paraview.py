"""ParaView's own reader opens every PVD the workbench writes (issue 8, item 2).

``pvpython`` (Debian's ``paraview`` + ``python3-paraview``, installed by ``make install``
when apt is there) runs ``pv_probe.py`` in a subprocess: no X server is needed for
reading data (plain ``pvpython``, no ``--force-offscreen-rendering``).  For each PVD the
test checks that ParaView sees every time step at the engine's time, each frame's blocks
in the same order with the writer's names, and point/cell counts and per-component array
ranges equal to the engine's values recorded at that frame (exact: the VTU stores
float64 and both sides take min/max of the same numbers).

Skipped, with the reason, only when ``pvpython`` is not installed.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess

import numpy as np
import pytest

from engine import Scene, laws, run
from engine.step import CallbackWriter
from workbench import meshes
from workbench.series import SeriesWriter

from .scenes import texsol_cylinder

PVPYTHON = shutil.which("pvpython") or ("/usr/bin/pvpython" if os.path.exists("/usr/bin/pvpython")
                                        else None)
pytestmark = pytest.mark.skipif(
    PVPYTHON is None, reason="pvpython not found: ParaView is not installed (Debian: "
    "`apt-get install paraview python3-paraview`, which `make install` does when apt is there)")

PROBE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "pv_probe.py")


def _expected(model, state, walls):
    """What ParaView must see in one frame, from the engine's arrays (walls: the
    workbench's own geometry, the engine has no wall mesh)."""
    ids = model.sphere_ids
    rng = lambda a: [[float(a[:, c].min()), float(a[:, c].max())] for c in range(a.shape[1])] \
        if len(a) else None  # noqa: E731
    col = lambda a: np.asarray(a, float).reshape(len(a), -1)  # noqa: E731
    frame = {"beads": {"points": ids.size, "cells": ids.size, "point_data": {
        "radius": rng(col(model.body_radius[ids])),
        "velocity": rng(state.velocity[ids]),
        "spin": rng(state.spin[ids]),
        "group": rng(col(model.body_group[ids]))},
        "bounds": rng(state.position[ids])}}
    c = state.contacts
    k = len(c) if state.last_dt else 0
    cd = {}
    if k:
        f = c.force
        fn = c.normal_force
        cd = {"normal_force": rng(col(fn)),
              "tangential_force": rng(col(np.linalg.norm(f - fn[:, None] * c.normal, axis=1))),
              "force": rng(f), "i": rng(col(c.i)), "j": rng(col(c.j))}
    frame["contacts"] = {"points": 2 * k, "cells": k, "cell_data": cd}
    if model.n_links:
        links = state.links
        frame["wire"] = {"points": 2 * len(links), "cells": len(links), "cell_data": {
            "tension": rng(col(links.tension)), "broken": rng(col(links.broken.astype(int))),
            "length": rng(col(links.length)), "ref_length": rng(col(model.link_ref_length))}}
    if walls:
        part = meshes.wall_part(model, state)
        frame["walls"] = {"points": part.n_points, "cells": part.n_cells,
                          "cell_data": {"body_id": rng(col(model.wall_ids))}}
    return frame


def _series(out, name, model, state, steps, every):
    """Run with a SeriesWriter (initial frame included) and record the engine's values
    at every written frame."""
    writer = SeriesWriter(out, every=every, name=name)
    frames = []

    def record(model, state):
        frames.append((float(state.time), _expected(model, state, model.n_walls > 0)))

    record(model, state)
    writer.write(model, state)
    run(model, state, steps, writers=[writer, CallbackWriter(record, trigger=every)],
        progress=False)
    writer.close()
    return writer.pvd_path, frames


def _box_with_brittle_wire():
    """Sand in an open box (five planes) and a brittle wire hanging from a fixed bead; its
    first link breaks (tension > max_tension), so ``broken`` is 1 in later frames."""
    s = Scene(gravity=(0.0, 0.0, -9.81))
    s.add_box((-4e-3, -4e-3, 0.0), (4e-3, 4e-3, 12e-3))
    pts = [[x, y, 1.1e-3] for x in (-2.5e-3, 0.0, 2.5e-3) for y in (-2.5e-3, 0.0, 2.5e-3)]
    s.add_spheres(pts, 1e-3, density=2650.0, group="sand")
    beads = s.add_wire([[0, 0, 10e-3], [0, 0, 7e-3], [0, 0, 4e-3]], radius=1e-3, density=2000.0,
                       law=laws.BrittleElasticWire(stiffness=1.0, max_tension=1e-4))
    s.fix(beads[:1])
    for a, b in (("sand", "sand"), ("sand", "wall"), ("wire", "sand"), ("wire", "wall")):
        s.interact(a, b, laws.Coulomb(mu=0.5))
    s.interact("wire", "wire", None)
    return s.compile(dt=1e-4, theta=0.5, tol=1e-6, max_iter=500)


@pytest.fixture(scope="module")
def probed(tmp_path_factory):
    out = tmp_path_factory.mktemp("paraview")
    model, state, _ = texsol_cylinder(steps=0)
    cyl = _series(out / "cyl", "texsol", model, state, steps=120, every=30)
    model2, state2 = _box_with_brittle_wire()
    box = _series(out / "box", "box", model2, state2, steps=200, every=40)
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "DISPLAY")}
    report = out / "probe.json"
    proc = subprocess.run([PVPYTHON, PROBE, str(report), str(cyl[0]), str(box[0])], env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    data = json.loads(report.read_text())
    return data, {str(cyl[0]): cyl[1], str(box[0]): box[1]}


def _check(pv_frame, engine, names) -> int:
    """Compare one frame; return the number of array ranges compared."""
    blocks = pv_frame["blocks"]
    assert [b["name"] for b in blocks] == names
    n = 0
    for b in blocks:
        exp = engine[b["name"]]
        assert (b["points"], b["cells"]) == (exp["points"], exp["cells"]), b["name"]
        if "bounds" in exp:  # sphere centres: VTK bounds (xmin, xmax, ymin, ...) = engine's
            assert [b["bounds"][0:2], b["bounds"][2:4], b["bounds"][4:6]] == exp["bounds"]
        for where in ("point_data", "cell_data"):
            for arr, rng in exp.get(where, {}).items():
                got = b[where][arr]
                assert got["range"] == rng, (b["name"], arr, got["range"], rng)
                n += 1
    return n


def test_pvpython_sees_every_time_step_and_the_engine_values(probed):
    data, engine = probed
    assert data["paraview"].startswith("paraview version")
    for pvd, frames in engine.items():
        seen = data["pvd"][pvd]
        assert seen["times"] == [t for t, _ in frames]  # every time step, exact times
        names = ["beads", "contacts"] + (["wire"] if "wire" in frames[0][1] else []) + \
            (["walls"] if "walls" in frames[0][1] else [])
        compared = 0
        for pv_frame, (t, exp) in zip(seen["frames"], frames):
            assert pv_frame["time"] == t
            compared += _check(pv_frame, exp, names)
        assert compared >= 10 * len(frames)


def test_first_frame_has_an_empty_contacts_block(probed):
    """t = 0 has no contact forces yet: the contacts block is there, empty, with its
    arrays, so the block numbers are the same in every frame."""
    data, engine = probed
    for pvd in engine:
        first = data["pvd"][pvd]["frames"][0]["blocks"][1]
        assert first["name"] == "contacts" and first["cells"] == 0 and first["points"] == 0
        assert first["cell_data"]["normal_force"]["tuples"] == 0


def test_broken_flag_reaches_paraview(probed):
    data, engine = probed
    box = next(p for p in engine if p.endswith("box.pvd"))
    wire = [b for b in data["pvd"][box]["frames"][-1]["blocks"] if b["name"] == "wire"][0]
    assert wire["cell_data"]["broken"]["range"] == [[0.0, 1.0]]
    walls = [b for b in data["pvd"][box]["frames"][-1]["blocks"] if b["name"] == "walls"][0]
    assert walls["cells"] == 10  # five planes clipped to an open box, two triangles each
