"""Several frames of a history: fixed colour limits, one camera, PNG folders and movies
(workbench.frames, ``nscd render --frames / --movie``)."""
from __future__ import annotations

import numpy as np
import pytest

from engine import io
from workbench import cli, frames


@pytest.fixture(scope="module")
def triaxial(tmp_path_factory):
    """A short cylinder test with a wire: frames whose tensions and forces change, and the
    test's own toroidal map at its end (1 % strain).  (path, result)."""
    import warnings

    from engine.experiments import cylinder_triaxial

    path = tmp_path_factory.mktemp("frames") / "run.h5"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = cylinder_triaxial(0.05, axial_strain=0.01, frames=6, history=str(path),
                                progress=False, iso_max_steps=200, max_nonconverged=1.0,
                                torus_strains=[0.01])
    return path, res


@pytest.fixture(scope="module")
def history(triaxial):
    return triaxial[0]


def test_parse_frames():
    assert frames.parse_frames("all", 4) == [0, 1, 2, 3]
    assert frames.parse_frames(-1, 4) == [3]
    assert frames.parse_frames("1:3", 5) == [1, 2]
    assert frames.parse_frames("::2", 5) == [0, 2, 4]
    assert frames.parse_frames(":-1", 3) == [0, 1]
    assert frames.parse_frames([0, -1], 3) == [0, 2]
    for spec, says in (("7", "frame 7 is out of range .*5 frames: 0 to 4"),
                       ("a:b", "expected N, A:B, A:B:S or all"), ("3:1", "no frame"),
                       ("1:2:0", "expected"), (True, "expected")):
        with pytest.raises(ValueError, match=says):
            frames.parse_frames(spec, 5)


@pytest.mark.slow
def test_frames_share_the_colour_scale_of_the_whole_series(history, tmp_path, monkeypatch):
    """The wire's fixed limits are (0, the largest tension of any frame drawn), read from
    the history's own link tensions; every frame is drawn with them and one camera box;
    one frame alone keeps its own scale."""
    from workbench import render

    h = io.read_history(history)
    n = h.n_frames
    assert n > 3
    tmax = float(np.nanmax(np.where(h.link_broken, np.nan, h.link_tension)))
    lo, hi = frames.common_clim(history, "wire", range(n))
    assert lo == 0.0 and hi == pytest.approx(tmax, rel=1e-12)
    per_frame = [render.value_range(*io.load(history, frame=k), "wire")[1] for k in range(n)]
    assert max(per_frame) == hi and min(per_frame) < hi          # frames differ
    assert per_frame[0] == 0.0            # frame 0, the start state: a slack wire, (0, 0)
    seen = []
    real = render.snapshot

    def spy(model, state, path, **kw):
        seen.append((kw.get("clim"), None if kw.get("bounds") is None else kw["bounds"].copy()))
        return real(model, state, path, **kw)

    monkeypatch.setattr(render, "snapshot", spy)
    paths = frames.render_frames(history, tmp_path / "w", frames="all", preset="wire",
                                 window_size=(200, 150), progress=False)
    assert [p.name for p in paths] == [f"frame_{k:04d}.png" for k in range(n)]
    assert all(c == (lo, hi) for c, _ in seen)
    assert all(np.array_equal(b, seen[0][1]) for _, b in seen)
    seen.clear()
    frames.render_frames(history, tmp_path / "one.png", frames=0, preset="wire",
                         progress=False)
    assert seen == [(None, None)]
    # forces start at 0 (not at the strong-network threshold); beads by speed: its range
    assert frames.common_clim(history, "forces", [n - 1])[0] == 0.0
    vmin, vmax = frames.common_clim(history, "beads", range(n), color_by="speed")
    speeds = np.linalg.norm(h.velocity[:, model_spheres(history)], axis=2)
    assert (vmin, vmax) == pytest.approx((speeds.min(), speeds.max()), rel=1e-9)
    assert frames.common_clim(history, "beads", range(n)) is None      # by kind: no scale


def model_spheres(history):
    return io.load_model(history).sphere_ids


@pytest.mark.slow
@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
def test_a_movie_has_every_frame_at_the_window_size(history, tmp_path, suffix):
    import imageio.v3 as iio

    n = io.frame_count(history)
    path = frames.write_movie(history, tmp_path / f"m{suffix}", preset="forces",
                              window_size=(321, 240), fps=5, progress=False)
    movie = iio.imread(path)
    assert movie.shape == (n, 240, 320, 3)        # (even width for H.264 and the GIF alike)
    if suffix == ".gif":                          # 5 frames a second: 200 ms each
        from PIL import Image
        gif = Image.open(path)
        gif.seek(1)
        assert gif.info["duration"] == 200
    assert movie.std() > 5                         # not a blank picture
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())   # no part file left
    with pytest.raises(ValueError, match="must end in .mp4 or .gif"):
        frames.write_movie(history, tmp_path / "m.avi")


def test_nscd_render_frames_movie_and_bad_options(history, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)                  # outputs by default in the current folder
    n = io.frame_count(history)
    assert cli.main(["render", str(history), "--frames", "all", "--preset", "wire",
                     "--window-size", "160x120"]) == 0
    assert len(list((tmp_path / "run_wire").glob("frame_*.png"))) == n
    assert cli.main(["render", str(history), "--color-by", "speed", "--cut", "0,-1,0",
                     "--camera", "front", "--clim", "0,0.5"]) == 0
    assert (tmp_path / "run_beads.png").stat().st_size > 1000
    assert not list(history.parent.glob("*.png"))          # never beside the input
    seen = {}                                    # --axes and --weak reach the pictures
    monkeypatch.setattr(cli, "render_options", lambda a, f=cli.render_options:
                        seen.setdefault("opts", f(a)))
    assert cli.main(["render", str(history), "--preset", "forces", "--weak", "--axes",
                     "--out", str(tmp_path / "fw.png"), "--window-size", "160x120"]) == 0
    assert seen["opts"]["weak"] is True and seen["opts"]["axes"] is True
    assert (tmp_path / "fw.png").stat().st_size > 1000
    monkeypatch.undo()
    monkeypatch.chdir(tmp_path)
    assert cli.main(["render", str(history), "--movie", str(tmp_path / "f.gif"),
                     "--frames", "0:3", "--window-size", "160x120"]) == 0
    import imageio.v3 as iio
    assert iio.imread(tmp_path / "f.gif").shape[0] == 3
    capsys.readouterr()
    for args, says in ((["--clim", "3,1"], "--clim '3,1': HIGH must be above LOW"),
                       (["--clim", "a"], "--clim 'a': expected LOW,HIGH"),
                       (["--window-size", "10x10"], "whole pixels in [16, 8192]"),
                       (["--frames", "99"], f"frame 99 is out of range (the history has {n}"),
                       (["--movie", "x.avi"], "must end in .mp4 or .gif"),
                       (["--preset", "wire", "--color-by", "speed"], "--color-by is for "
                                                                      "--preset beads"),
                       (["--cut", "1,2"], "--cut '1,2': expected X,Y,Z"),
                       (["--weak"], "--weak is for --preset forces (got --preset beads)"),
                       (["--preset", "torus", "--axes"], "--axes is for the 3D presets")):
        assert cli.main(["render", str(history), *args]) == 2, args
        err = capsys.readouterr().err.strip()
        assert says in err and "\n" not in err, (args, err)


# -- what the history knows: the run's cylinder, the frame's title ---------------------------
@pytest.mark.slow
def test_torus_cylinder_is_the_runs_recorded_cylinder(triaxial, tmp_path, monkeypatch):
    """For a cylinder_triaxial history the torus preset's cylinder at a frame is the
    sample's cylinder the test recorded at that frame's step (records ``radius``,
    ``height``; base on the floor at z = 0), not one fitted around the grains; the same
    rule in render_frames / write_movie / common_clim / the CLI, and at the last frame the
    picture's map is the test's own ``extra["torus_maps"]``."""
    from engine.analysis import toroidal_map
    from workbench import meshes, render

    history, res = triaxial
    rec = io.read_history(history, frames=False)
    n = io.frame_count(history)
    for k in (0, n // 2, n - 1):
        model, state = io.load(history, frame=k)
        cyl = frames.frame_cylinder(history, k)
        i = int(np.argmin(np.abs(rec.step - state.step)))
        if k:                                  # frame 0 (step 0): the first record's
            assert rec.step[i] == state.step
        assert cyl.radius == rec.extra["radius"][i] and cyl.height == rec.extra["height"][i]
        assert cyl.center == (0.0, 0.0, 0.0)
        fitted = meshes.sample_cylinder(model, state)               # the old guess
        assert abs(fitted.radius - cyl.radius) > 1e-6
    # the test's map at 1 % strain (its last step) is the map of the last frame's picture
    (strain, tmap), = res.extra["torus_maps"].items()
    model, state = io.load(history, frame=-1)
    mine = toroidal_map(model, state, frames.frame_cylinder(history, -1), part="wire")
    np.testing.assert_array_equal(mine.r_edges, tmap.r_edges)
    np.testing.assert_array_equal(mine.z_edges, tmap.z_edges)
    # (a frame read back has its links' directions at the frame's positions, the test's
    # live state at the step's predicted configuration: engine.io; 0.1 % here)
    np.testing.assert_allclose(mine.equivalent, tmap.equivalent, rtol=1e-2, atol=1e-6,
                               equal_nan=True)
    seen = []
    real = render.snapshot

    def spy(model, state, path, **kw):
        seen.append((state.step, kw.get("cylinder")))
        return real(model, state, path, **kw)

    monkeypatch.setattr(render, "snapshot", spy)
    frames.render_frames(history, tmp_path / "t", frames="all", preset="torus",
                         window_size=(200, 120), progress=False)
    assert len(seen) == n
    for step, cyl in seen:
        i = int(np.argmin(np.abs(rec.step - step)))
        assert (cyl.radius, cyl.height) == (rec.extra["radius"][i], rec.extra["height"][i])
    # cylinder= still overrides
    from engine.prep.containers import Cylinder
    seen.clear()
    mine = Cylinder(2e-3, 4e-3)
    frames.render_frames(history, tmp_path / "o.png", preset="torus", cylinder=mine,
                         window_size=(200, 120), progress=False)
    assert seen[0][1] is mine


def _plain_history(path, scene_fn, steps=20, meta=None):
    model, state = scene_fn()
    h = io.History(path, frames=10, flush=10, meta=meta)
    try:
        import warnings

        from engine import run
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            run(model, state, steps, writers=[h], progress=False)
    finally:
        h.close()
    return path


def test_torus_refuses_a_box_history_in_one_line(tmp_path):
    """A box_triaxial history (a box sample, no cylinder wall): one line saying what the
    run is; ``cylinder=`` still draws one."""
    from engine.prep.containers import Cylinder

    from .test_render import _box_sample

    h = _plain_history(tmp_path / "box.h5", _box_sample, meta={"test": "box_triaxial"})
    with pytest.raises(ValueError) as err:
        frames.render_frames(h, tmp_path / "t.png", preset="torus", progress=False)
    text = str(err.value)
    assert "\n" not in text
    assert text == ("preset 'torus': a toroidal map needs a cylindrical sample, and box.h5 is "
                    "a box_triaxial test's history (a box sample: 32 spheres, walls: 6 planes, "
                    "no cylinder wall); pass cylinder=Cylinder(radius, height, center) to draw "
                    "one anyway")
    assert cli.main(["render", str(h), "--preset", "torus", "--out",
                     str(tmp_path / "c.png")]) == 2
    assert frames.render_frames(h, tmp_path / "c.png", preset="torus", part="sand",
                                cylinder=Cylinder(2e-3, 4e-3, center=(2e-3, 2e-3, 0.0)),
                                window_size=(200, 120), progress=False)[0].is_file()


def test_frame_title_says_step_time_and_strain(triaxial, tmp_path, monkeypatch):
    """The default title of a history frame, read back from the picture's text actor:
    ``step N · t = T ms · axial strain E %`` for a triaxial test (the strain of the frame's
    record, 1 - H/H0 from the last isotropic record; ``isotropic stage`` before it);
    without strain for another history; ``title=`` overrides."""
    from engine.analysis import loading_curves
    from workbench import render

    from .scenes import texsol_cylinder

    history, res = triaxial
    rec = io.read_history(history, frames=False)
    stage = rec.extra["stage"]
    H0 = rec.extra["height"][np.flatnonzero(stage >= 1)[0] - 1]
    titles = []
    real = render.plotter

    def spy(*args, **kw):
        pl = real(*args, **kw)
        titles.append(pl.renderer.actors["title"].GetInput() if "title" in pl.renderer.actors
                      else None)
        return pl

    monkeypatch.setattr(render, "plotter", spy)
    frames.render_frames(history, tmp_path / "w", frames="all", preset="wire",
                         window_size=(200, 150), progress=False)
    n = io.frame_count(history)
    assert len(titles) == n
    steps, times = io.frame_index(history)
    last = int(np.flatnonzero(rec.step == steps[-1])[0])
    e = 1.0 - rec.extra["height"][last] / H0
    assert titles[-1] == f"step {steps[-1]} · t = {1e3 * times[-1]:.4g} ms · axial strain " \
                         f"{100 * e:.2f} %"
    assert 0.9 <= 100 * e <= 1.1                      # the run ends at 1 % strain
    assert titles[0] == "step 0 · t = 0 s · isotropic stage"
    curves = loading_curves(rec)
    assert np.isnan(curves["strain"][0])
    # the movie and common_clim draw the same frames with the same titles
    titles.clear()
    frames.write_movie(history, tmp_path / "m.gif", frames="-1", preset="forces",
                       window_size=(160, 120), progress=False)
    assert titles == [f"step {steps[-1]} · t = {1e3 * times[-1]:.4g} ms · axial strain "
                      f"{100 * e:.2f} %"]
    titles.clear()
    frames.render_frames(history, tmp_path / "x.png", preset="wire", title="mine",
                         window_size=(160, 120), progress=False)
    assert titles == ["mine"]
    # another history: step and time only
    titles.clear()
    plain = _plain_history(tmp_path / "plain.h5",
                           lambda: texsol_cylinder(n_sand=40, wire_beads=8, steps=0)[:2])
    frames.render_frames(plain, tmp_path / "p.png", preset="torus", window_size=(300, 160),
                         progress=False)
    assert titles == ["step 20 · t = 2 ms"]
