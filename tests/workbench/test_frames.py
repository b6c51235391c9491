"""Several frames of a history: fixed colour limits, one camera, PNG folders and movies
(workbench.frames, ``nscd render --frames / --movie``)."""
from __future__ import annotations

import numpy as np
import pytest

from engine import io
from workbench import cli, frames


@pytest.fixture(scope="module")
def history(tmp_path_factory):
    """A short cylinder test with a wire: frames whose tensions and forces change."""
    import warnings

    from engine.experiments import cylinder_triaxial

    path = tmp_path_factory.mktemp("frames") / "run.h5"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cylinder_triaxial(0.05, axial_strain=0.01, frames=6, history=str(path),
                          progress=False, iso_max_steps=200, max_nonconverged=1.0)
    return path


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
                       (["--cut", "1,2"], "--cut '1,2': expected X,Y,Z")):
        assert cli.main(["render", str(history), *args]) == 2, args
        err = capsys.readouterr().err.strip()
        assert says in err and "\n" not in err, (args, err)
