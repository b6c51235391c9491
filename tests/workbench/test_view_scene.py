"""The viewer's pieces without a browser: reading runs, colour limits, picking, clipping,
the curves of a triaxial test, units for reading, ``nscd run --view``."""
from __future__ import annotations

import re
import signal
import subprocess
import sys
import urllib.request
import warnings
from pathlib import Path

import numpy as np
import pytest

from engine import io
from workbench.units import reading_unit
from workbench.view import curves as vcurves
from workbench.view.scene import ViewOptions, ViewScene
from workbench.view.source import RunSource, ViewInputError, curves_of, field_values

ROOT = Path(__file__).resolve().parents[2]
RUN = str(ROOT / "tests" / "workbench" / "follow_run.py")


@pytest.fixture(scope="module")
def history(tmp_path_factory):
    path = tmp_path_factory.mktemp("vs") / "run.h5"
    r = subprocess.run([sys.executable, RUN, str(path), "--steps", "100", "--frames", "20"],
                       capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    return path


@pytest.fixture(scope="module")
def source(history):
    return RunSource(history)


def test_reading_units():
    f, u = reading_unit("N", 6.3e-4)                     # reads 630 µN
    assert u == "µN" and f == pytest.approx(1e6)
    f, u = reading_unit("N", 2.93e-3)
    assert u == "mN" and f == pytest.approx(1e3)
    f, u = reading_unit("m/s", 2e-5)
    assert u == "µm/s" and f == pytest.approx(1e6)
    assert reading_unit("Pa", 1.5e4) == (1e-3, "kPa")
    assert reading_unit("Pa", 999.0) == (1.0, "Pa")
    assert reading_unit("N", 0.9999) == (1.0, "N")       # not "999.9 mN"
    assert reading_unit("rad/s", 5e-3) == (1.0, "rad/s")
    assert reading_unit("N", 0.0) == (1.0, "N")


def test_colour_limits_are_the_extremes_over_every_frame(source, history):
    model = source.model
    ids = model.sphere_ids
    speeds = [np.linalg.norm(io.read_frame(history, k, model).velocity[ids], axis=1)
              for k in range(source.n_frames)]
    lo, hi = source.field_range("speed")
    assert lo == 0.0 and hi == pytest.approx(max(s.max() for s in speeds), rel=1e-12)
    fn = []
    for k in range(source.n_frames):
        st = io.read_frame(history, k, model)
        fn.append(st.contacts.normal_force)
    assert source.field_range("normal_force")[1] == pytest.approx(
        max(f.max() for f in fn if f.size), rel=1e-9)
    t = np.concatenate([io.read_frame(history, k, model).links.tension
                        for k in range(source.n_frames)])
    assert source.field_range("tension")[1] == pytest.approx(t.max(), rel=1e-12)


def test_field_values_match_the_meshes_arrays(source, history):
    from workbench import meshes
    from workbench.view.source import state_arrays

    st = source.state(source.n_frames - 1)
    a = state_arrays(source.model, st)
    bp, wp = meshes.bead_part(source.model, st), meshes.wire_part(source.model, st)
    cp = meshes.contact_part(source.model, st)
    np.testing.assert_allclose(field_values("speed", source.model, a), bp.point_data["speed"])
    np.testing.assert_allclose(field_values("strain", source.model, a), wp.cell_data["strain"],
                               rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(field_values("normal_force", source.model, a),
                               cp.cell_data["normal_force"], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(field_values("tangential_force", source.model, a),
                               cp.cell_data["tangential_force"], rtol=1e-9, atol=1e-12)


@pytest.fixture(scope="module")
def scene(source):
    sc = ViewScene(source.model, window_size=(400, 300))
    sc.update(source.state(source.n_frames - 1), ViewOptions())
    yield sc
    sc.plotter.close()


def test_a_ray_through_a_bead_picks_it_or_one_in_front(scene, source):
    st = scene.state
    model = source.model
    ids = model.sphere_ids
    rng = np.random.default_rng(1)
    for b in rng.choice(ids, 20, replace=False):
        c = st.position[b]
        d = np.array([0.3, -1.0, 0.2])
        d /= np.linalg.norm(d)
        o = c - 0.05 * d                       # 5 cm before the bead, looking through it
        info = scene.pick(o, d)
        assert info is not None and info["what"] in ("bead", "link")
        if info["what"] == "bead":
            hit = info["id"]
            # the bead hit is b, or one whose sphere the ray enters before b's centre
            p = st.position[hit]
            tc = (p - o) @ d
            assert hit == b or tc - model.body_radius[hit] <= (c - o) @ d
            assert np.linalg.norm(p - (o + tc * d)) <= model.body_radius[hit] * (1 + 1e-9)
    far = scene.pick(np.array([1.0, 1.0, 1.0]), np.array([0.0, 0.0, 1.0]))   # misses all
    assert far is None


def test_clip_keeps_the_chosen_side_and_flip_the_other(scene, source):
    st = scene.state
    opts = ViewOptions(clip_axis="x", clip_offset=0.5)
    scene.update(st, opts)
    sand = scene._drawn["sand"].points
    lo, hi = scene.bounds[:, 0]
    mid = lo + 0.5 * (hi - lo)
    assert sand[:, 0].max() <= mid and len(sand) > 10
    wire_before = len(scene._drawn["wire_beads"].points)
    scene.update(st, ViewOptions(clip_axis="x", clip_offset=0.5, clip_flip=True))
    assert scene._drawn["sand"].points[:, 0].min() >= mid
    assert len(scene._drawn["wire_beads"].points) == wire_before    # the wire is not cut
    scene.update(st, ViewOptions(clip_axis="x", clip_offset=0.5, clip_wire=True))
    assert scene._drawn["wire_beads"].points[:, 0].max() <= mid
    scene.update(st, ViewOptions())


def test_strong_network_threshold(scene, source):
    st = scene.state
    fn = st.contacts.normal_force
    for strong in (0.0, 1.0, 2.0):
        scene.update(st, ViewOptions(layers=dict(ViewOptions().layers, forces=True),
                                     color_by="normal_force", strong=strong))
        _, _, mask = scene._drawn["forces"]
        assert mask.sum() == (fn > strong * fn.mean()).sum()
    assert scene.bar[0] in ("normal force [mN]", "normal force [µN]", "normal force [N]")
    scene.update(st, ViewOptions())


def test_screenshot_is_deterministic(scene, tmp_path):
    a = scene.screenshot(tmp_path / "a.png")
    b = scene.screenshot(tmp_path / "b.png")
    assert Path(a).read_bytes() == Path(b).read_bytes()


def test_curves_of_a_triaxial_history(tmp_path):
    from engine.experiments import cylinder_triaxial

    h = tmp_path / "cyl.h5"
    with warnings.catch_warnings():            # a short run: its stage and overlap warnings
        warnings.simplefilter("ignore", RuntimeWarning)
        res = cylinder_triaxial(0.05, axial_strain=0.005, iso_max_steps=100, ramp_steps=50,
                                history=str(h), frames=20, progress=False)
    src = RunSource(h)
    assert src.meta["test"] == "cylinder_triaxial" and src.meta["params"]["seed"] == 0
    c = curves_of(src.records)
    eps, q = c["deviator"][0], c["deviator"][1]
    # the viewer's strain and deviator are the test's own (engine.experiments.triaxial)
    np.testing.assert_allclose(eps, res.axial_strain, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(q, res.deviator / 1e3, rtol=1e-12)
    np.testing.assert_allclose(c["wire_equivalent"][1], res.wire_equivalent / 1e3, rtol=1e-12)
    sel = c["_curve_records"]                  # per record: what the frame's line shows
    np.testing.assert_allclose(c["_q"][sel], res.deviator / 1e3, rtol=1e-12)
    np.testing.assert_allclose(c["_p"][sel], res.mean_stress / 1e3, rtol=1e-12)
    assert np.isnan(c["_q"][:sel[0]]).all()    # the isotropic stage
    fig = vcurves.figure(c, src.frame_step, src.frame_time, src.n_frames - 1)
    names = [d["name"] for d in fig["data"]]
    # the frame's lines: at the last frame's strain on the stress panel, its time elsewhere
    lines = vcurves.marks(c, src.frame_step, src.frame_time, src.n_frames - 1)
    assert fig["layout"]["shapes"] == lines and len(lines) == 3
    k = np.flatnonzero(near_last := (vcurves.nearest_frames(c["_step"], src.frame_step)[sel]
                                     == src.n_frames - 1))[0]
    assert lines[0]["x0"] == pytest.approx(eps[k]) and near_last.any()
    assert lines[1]["x0"] == lines[2]["x0"] == pytest.approx(src.frame_time[-1])
    assert "deviator q" in names and "kinetic energy [J]" in names
    near = vcurves.nearest_frames(c["_step"], src.frame_step)
    assert np.all(np.abs(src.frame_step[near] - c["_step"]) ==
                  np.min(np.abs(src.frame_step[None, :] - c["_step"][:, None]), axis=1))
    # the toroidal map of the sample's cylinder is drawn
    sc = ViewScene(src.model, window_size=(300, 200))
    sc.cylinder = "sample"
    sc.update(src.state(src.n_frames - 1),
              ViewOptions(layers=dict(ViewOptions().layers, torus=True)))
    assert "torus" in sc.plotter.actors
    # with its history, the map is on the run's recorded cylinder, as nscd render's
    from workbench.frames import frame_cylinder

    sc.history = str(h)
    sc.update(src.state(src.n_frames - 1),
              ViewOptions(layers=dict(ViewOptions().layers, torus=True)))
    cyl = frame_cylinder(h, frame=src.n_frames - 1)
    x_max = sc.plotter.actors["torus"].GetBounds()[1]
    assert x_max == pytest.approx(cyl.center[0] + cyl.radius, rel=1e-9)   # θ = 0 edge
    sc.plotter.close()


def test_a_checkpoint_is_shown_as_one_frame(tmp_path, source):
    st = source.state(0)
    p = tmp_path / "ck.h5"
    model = source.model
    try:
        io.save(p, model, st)
    except ValueError as e:              # a model with callables cannot be saved
        pytest.skip(str(e))
    src = RunSource(p)
    assert src.n_frames == 1 and src.content == "checkpoint"
    assert src.field_range("speed")[1] > 0
    with pytest.raises(ViewInputError, match="no such file"):
        RunSource(tmp_path / "nope.h5")


@pytest.mark.slow
def test_run_with_view_serves_the_run_being_written(tmp_path):
    cfg = tmp_path / "dep.toml"
    cfg.write_text('test = "gravity_deposit"\nscale = 0.02\n[parameters]\nsteps = 300\n'
                   'frames = 20\nrecord_every = 10\nmax_nonconverged = 1.0\n')
    p = subprocess.Popen([str(Path(sys.executable).with_name("nscd")), "run", str(cfg),
                          "--out", str(tmp_path / "out"), "--view"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    seen = []
    try:
        for line in p.stdout:
            seen.append(line)
            m = re.search(r"(http://\S+)", line)
            if m and "follows" in line:
                assert urllib.request.urlopen(m.group(1), timeout=30).status == 200
            if "stays" in line:
                p.send_signal(signal.SIGINT)
                break
        rc = p.wait(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
    assert any("follows the run" in x for x in seen), "".join(seen) + p.stderr.read()
    assert rc in (0, 130)


def test_log_scale_and_manual_limits(scene, source):
    st = scene.state
    scene.update(st, ViewOptions(color_by="speed", clim=(0.0, 0.2), log=True))
    lut = scene.plotter.actors["sand"].mapper.lookup_table
    assert lut.GetScale() == 1                          # VTK_SCALE_LOG10
    lo, hi = lut.GetRange()
    f = scene.bar[1]
    assert hi == pytest.approx(0.2 * f) and 0 < lo < hi  # a log scale cannot start at 0
    scene.update(st, ViewOptions(color_by="speed", clim=(0.01, 0.05)))
    assert scene.plotter.actors["sand"].mapper.lookup_table.GetRange() == \
        pytest.approx((0.01 * scene.bar[1], 0.05 * scene.bar[1]))
    scene.update(st, ViewOptions())


def test_a_ray_through_a_taut_link_picks_it(scene, source):
    st = scene.state
    layers = dict(ViewOptions().layers, sand=False, wire_beads=False)
    scene.update(st, ViewOptions(layers=layers))
    t = st.links.tension
    q = int(np.argmax(t))
    mid = 0.5 * (st.position[source.model.link_i[q]] + st.position[source.model.link_j[q]])
    d = np.array([0.0, 0.0, -1.0])
    info = scene.pick(mid - 0.05 * d, d)
    assert info is not None and info["what"] == "link"
    assert info["id"] == q or abs(info["tension [N]"] - t[q]) < 1e-12 or \
        np.linalg.norm(st.position[source.model.link_i[info["id"]]] - mid) < 4e-4
    scene.update(st, ViewOptions())


def test_a_history_whose_writer_was_killed_is_shown(tmp_path):
    from workbench.view.source import find_runs

    out = tmp_path / "killed.h5"
    sim = subprocess.Popen([sys.executable, RUN, str(out), "--steps", "400", "--frames", "10",
                            "--pause", "0.2"], stdout=subprocess.PIPE, text=True, cwd=ROOT)
    for _ in range(3):
        assert "frame" in sim.stdout.readline()
    sim.kill()                                        # SIGKILL: the file is never closed
    sim.wait()
    before = out.read_bytes()
    src = RunSource(out)
    assert src.n_frames >= 3
    assert src.state(src.n_frames - 1).step == src.frame_step[-1]
    (entry,) = find_runs(tmp_path)
    assert "being written" in entry.status or "not closed" in entry.status
    assert out.read_bytes() == before                  # only read


def test_glyphs_put_spheres_and_sticks_where_the_beads_and_links_are():
    """``--mode client``'s glyphs (workbench.view.glyphs): a sphere of the bead's diameter
    at its centre, a cylinder from one end of a link to the other of the link's radius
    (the pixels of a picture by VTK's glyph mapper: VTK's own bounds of a glyph mapper
    are conservative, not the glyphs' extent), and what the page is sent: the
    glyphed points with their scale and orientation arrays, the glyph mesh, the mapper's
    scaling and orientation."""
    import pyvista as pv
    from trame_vtk.modules.vtk.serializers.synchronization_context import (
        SynchronizationContext)

    from workbench import meshes, render
    from workbench.view import glyphs

    render.headless_backend()
    # seen from the front (along +y) in parallel projection: 20 µm a pixel
    pl = pv.Plotter(off_screen=True, window_size=(300, 300))
    pl.set_background("white")
    c, rb = np.array([2e-3, 0.0, 2e-3]), 1e-3
    beads = meshes.Part(points=c[None], cell_type="vertex", cells=np.zeros((1, 1), int),
                        point_data={"radius": np.array([rb])})
    glyphs.sphere_actor(pl, beads, "beads", color="red")
    p0, p1, r = np.array([-2e-3, 0.0, 0.0]), np.array([-2e-3, 0.0, 4e-3]), 3e-4
    link = meshes.Part(points=np.array([p0, p1]), cell_type="line",
                       cells=np.array([[0, 1]]))
    s = glyphs.stick_actor(pl, link, np.array([7.0]), np.array([r]), np.array([True]),
                           "link", color="blue")
    pl.camera.parallel_projection = True
    pl.camera.focal_point, pl.camera.position, pl.camera.up = (0, 0, 2e-3), (0, -1, 2e-3), \
        (0, 0, 1)
    pl.camera.parallel_scale = 3e-3
    img = pl.screenshot(return_img=True).astype(int)
    px = 6e-3 / 300

    def extent(mask):        # [x0, x1, z0, z1] [m] of the pixels of mask
        ys, xs = np.nonzero(mask)
        return np.array([xs.min() * px - 3e-3, (xs.max() + 1) * px - 3e-3,
                         5e-3 - (ys.max() + 1) * px, 5e-3 - ys.min() * px])

    red = (img[..., 0] - img[..., 2] > 60)
    blue = (img[..., 2] - img[..., 0] > 60)
    # two pixels of tolerance; the sphere's polygon is within its radius (8 x 6 sides)
    tol = 2 * px
    e = extent(red)
    assert e[2:] == pytest.approx([c[2] - rb, c[2] + rb], abs=tol)
    assert c[0] - rb - tol <= e[0] and e[1] <= c[0] + rb + tol
    assert e[1] - e[0] > 2 * rb * np.cos(np.pi / glyphs.SPHERE_RES[0]) - tol
    e = extent(blue)
    assert e[2:] == pytest.approx([0.0, 4e-3], abs=tol)            # along the link
    assert e[:2] == pytest.approx([-2e-3 - r, -2e-3 + r], abs=tol)  # its diameter
    assert glyphs.stick_actor(pl, link, np.array([7.0]), np.array([r]), np.array([False]),
                              "none") is None

    glyphs.register()
    ctx = SynchronizationContext()
    m = s.GetMapper()
    out = glyphs._glyph_serializer(s, m, "m1", ctx, 1)
    assert out["type"] == "vtkGlyph3DMapper"
    props = out["properties"]
    assert props["scaleArray"] == glyphs.SCALE and props["scaleMode"] == 2   # components
    assert props["orient"] and props["orientationMode"] == 0                 # direction
    assert props["orientationArray"] == glyphs.ORIENT
    assert [c[1][1] for c in out["calls"] if c[0] == "setInputData"] == [0, 1]
    fields = {f["name"] for f in out["dependencies"][0]["properties"]["fields"]}
    assert {glyphs.SCALE, glyphs.ORIENT, "value"} <= fields


def test_a_translucent_maps_colour_bar_gets_its_range_in_the_browser():
    """What vtk.js receives of the toroidal map's lookup table carries its mapping range (the
    map's colour limits): vtk.js keeps a table's default 0-255 until a mapper colours through
    it, which the 60 %-opaque map had not done when its bar was drawn (the client view's
    bar read 0-255 for a map of 0-411 Pa; checked in Chromium, docs/view.md)."""
    import pyvista as pv
    from trame_vtk.modules.vtk.serializers.synchronization_context import (
        SynchronizationContext)

    from workbench import render
    from workbench.view import glyphs

    render.headless_backend()
    pl = pv.Plotter(off_screen=True)
    surf = render.revolved_map(np.array([[0.0, 411.0], [50.0, 120.0]]), [0, 1e-3, 2e-3],
                               [0, 1e-3, 2e-3], (0, 0, 0), "value")
    actor = pl.add_mesh(surf, scalars="value", clim=(0.0, 411.0), opacity=0.6)
    from trame_vtk.modules.vtk.serializers.registry import SERIALIZERS
    from trame_vtk.modules.vtk.serializers.serialize import serialize

    glyphs.register()
    assert SERIALIZERS["vtkLookupTable"] is glyphs._lookup_table_serializer
    lut = actor.GetMapper().GetLookupTable()
    out = serialize(actor.GetMapper(), lut, "lut1", SynchronizationContext(), 1)
    assert out["properties"]["mappingRange"] == [0.0, 411.0]
    pl.close()
