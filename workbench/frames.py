"""Several frames of a history: fixed colour limits, one camera, a folder of PNGs or a movie
(``nscd render --frames``, ``--movie``).

::

    from workbench.frames import render_frames, write_movie
    render_frames("out/demo/run.h5", "out/frames", frames="all", preset="wire")
    write_movie("out/demo/run.h5", "out/demo/wire.mp4", preset="wire")   # or .gif

Every frame of one call is drawn with the same colour limits (by default the range of the
preset's field over all the frames drawn: :func:`common_clim`) and the same camera (framed
on the scene over all those frames), so the frames can be compared and a movie does not
flicker.

What the history knows and a state does not: each frame's title says its step, time and,
for a triaxial test, the axial strain (:func:`frame_title`: ``step 913 · t = 45.65 ms ·
axial strain 5.00 %``), and the torus preset draws a ``cylinder_triaxial`` run's own
cylinder at that frame (:func:`frame_cylinder`: the sample's recorded radius and height).
Both are options like any other: ``title=``, ``cylinder=`` override them.

Movies are written with imageio: MP4 through the ``imageio-ffmpeg`` wheel (its own ffmpeg
binary, no system ffmpeg), GIF through Pillow.
"""
from __future__ import annotations

import errno
import os
from pathlib import Path

import numpy as np

from engine.errors import WriteFailed
from engine.files import free_bytes, is_write_error, replacing

__all__ = ["parse_frames", "common_clim", "render_frames", "render_frame", "write_movie",
           "MOVIE_SUFFIXES", "frame_cylinder", "frame_title"]

MOVIE_SUFFIXES = (".mp4", ".gif")


def parse_frames(spec, n: int) -> list[int]:
    """Frame indices of a history of ``n`` frames from ``spec``: an integer (negative from
    the end), ``"A:B"`` or ``"A:B:S"`` (Python slice, B excluded, either end may be left
    out), ``"all"``, or a sequence of integers."""
    if n <= 0:
        raise ValueError("the history holds no frame (run with frames > 0)")
    if isinstance(spec, (list, tuple, range, np.ndarray)):
        picked = [int(k) for k in spec]
    elif isinstance(spec, (int, np.integer)) and not isinstance(spec, bool):
        picked = [int(spec)]
    elif isinstance(spec, str) and spec.strip() == "all":
        picked = list(range(n))
    elif isinstance(spec, str):
        text = spec.strip()
        try:
            if ":" in text:
                parts = [int(p) if p.strip() else None for p in text.split(":")]
                if len(parts) > 3 or parts[-1] == 0 and len(parts) == 3:
                    raise ValueError
                picked = list(range(n))[slice(*parts)]
            else:
                picked = [int(text)]
        except ValueError:
            raise ValueError(f"frames {spec!r}: expected N, A:B, A:B:S or all") from None
    else:
        raise ValueError(f"frames {spec!r}: expected N, A:B, A:B:S or all")
    bad = [k for k in picked if not -n <= k < n]
    if bad:
        raise ValueError(f"frames {spec!r}: frame {bad[0]} is out of range (the history has "
                         f"{n} frames: 0 to {n - 1}, or -1 for the last)")
    if not picked:
        raise ValueError(f"frames {spec!r}: no frame of the {n} the history holds")
    return [k % n for k in picked]


def _states(history, frames):
    from engine import io

    for k in frames:
        yield k, *io.load(history, frame=k)


#: What the refusal of a toroidal map says of a test's sample.
_SAMPLES = {"box_triaxial": "a box sample", "gravity_deposit": "a deposit",
            "slope_deposit": "a deposit on a slope", "pullout_test": "a pull-out box"}


class _Run:
    """What a history file says of its run, read once for all its frames: the test's name
    (None for a checkpoint or a history without meta), its records and its triaxial
    loading curves (:func:`engine.analysis.loading_curves`; None when it is no triaxial
    test's)."""

    def __init__(self, path):
        from engine import io

        self.path = Path(path)
        self.test, self.records, self.curves = None, None, None
        if io.file_content(path)[0] != "history":
            return                                         # a checkpoint: a state only
        self.test = io.history_meta(path).get("test")
        try:
            self.records = io.read_history(path, frames=False)
        except io.NoRecords:                  # a run just started (damage is not swallowed)
            return
        from engine.analysis import loading_curves

        self.curves = loading_curves(self.records)

    def record_at(self, step: int) -> int | None:
        """Index of the record of ``step`` (the nearest one in steps when none was written
        then, e.g. at step 0), or None without records."""
        if self.records is None or not len(self.records.step):
            return None
        steps = np.asarray(self.records.step)
        return int(np.argmin(np.abs(steps - int(step))))


def _run(history) -> _Run:
    return history if isinstance(history, _Run) else _Run(history)


def _loaded(run, frame, model, state):
    from engine import io

    if state is None:
        model, state = io.load(run.path, frame=frame)
    return model, state


def frame_cylinder(history, frame: int = -1, model=None, state=None):
    """The cylinder of the toroidal map (preset ``torus``) of frame ``frame`` of
    ``history``, one rule for Python and the ``nscd`` command:

    * a ``cylinder_triaxial`` test's history (:func:`engine.io.history_meta`): the sample's
      cylinder the test recorded at the frame's step (records ``radius`` and ``height``
      [m], the nearest record when none was written at that step), its base on the floor
      (the lowest upward plane; the test builds ``Cylinder(radius, H)`` for its own maps);
    * a scene with a cylinder wall: that wall;
    * otherwise (a box sample, a deposit): ValueError, one line, saying what the run is.

    ``model``, ``state``: the frame, when already loaded.  Returns an
    :class:`engine.prep.containers.Cylinder`."""
    from engine.model import PLANE
    from engine.prep.containers import Cylinder

    from .render import no_cylinder_error, scene_summary, wall_cylinder

    run = _run(history)
    model, state = _loaded(run, frame, model, state)
    if run.test == "cylinder_triaxial":
        i = run.record_at(state.step)
        ex = run.records.extra if run.records is not None else {}
        if i is not None and "radius" in ex and "height" in ex:
            r, h = float(ex["radius"][i]), float(ex["height"][i])
            if np.isfinite(r) and np.isfinite(h) and r > 0 and h > 0:
                floors = [w for w in model.wall_ids if model.body_kind[w] == PLANE
                          and model.body_axis[w][2] > 0.99]
                z0 = min((float(state.position[w, 2]) for w in floors), default=0.0)
                return Cylinder(radius=r, height=h, center=(0.0, 0.0, z0))
    cyl = wall_cylinder(model, state)
    if cyl is not None:
        return cyl
    name = run.path.name
    if run.test is None:
        what = f"{name} ({scene_summary(model)}) has no cylinder wall and no recorded cylinder"
    elif run.test == "cylinder_triaxial":
        what = (f"{name}, a cylinder_triaxial test's history, holds no radius and height "
                f"records ({scene_summary(model)}, no cylinder wall)")
    else:
        sample = _SAMPLES.get(run.test, "a sample")
        what = (f"{name} is a {run.test} test's history ({sample}: {scene_summary(model)}, "
                f"no cylinder wall)")
    raise no_cylinder_error(what, "pass cylinder=Cylinder(radius, height, center) to draw "
                                  "one anyway")


def frame_title(history, frame: int = -1, model=None, state=None) -> str:
    """The default title of a picture of frame ``frame`` of ``history``: ``step 913 · t =
    45.65 ms`` (:func:`workbench.render.default_title`), then for a triaxial test's
    history the axial strain at the frame's record (:func:`engine.analysis.loading_curves`;
    ``axial strain 5.00 %``, or ``isotropic stage`` before the loading), nothing about
    strain otherwise."""
    from .render import default_title

    run = _run(history)
    model, state = _loaded(run, frame, model, state)
    more = []
    i = run.record_at(state.step) if run.curves is not None else None
    if i is not None:
        e = float(run.curves["strain"][i])
        if np.isfinite(e):
            more.append(f"axial strain {100.0 * e:.2f} %")
        else:
            more.append("isotropic stage")
    return default_title(state, *more)


def common_clim(history, preset: str, frames, **options):
    """The colour limits (lo, hi) covering ``preset``'s field over ``frames`` of
    ``history`` (the union of :func:`workbench.render.value_range` of each; widened to
    (lo, lo + 1) when empty), or None for a picture without a colour scale (beads coloured
    by kind) or without data."""
    from .render import value_range

    if preset == "beads" and options.get("color_by", "kind") == "kind":
        return None                                   # no colour scale
    run = _run(history)
    lo, hi = np.inf, -np.inf
    for _, model, state in _states(run.path, frames):
        r = value_range(model, state, preset, **_frame_options(run, model, state, preset,
                                                               options))
        if r is not None:                             # (an empty map: no data there)
            lo, hi = min(lo, r[0]), max(hi, r[1])
    if not np.isfinite(lo):
        return None
    return (float(lo), float(hi) if hi > lo else float(lo) + 1.0)


def _frame_options(run, model, state, preset, options):
    """``options`` with what the history says of this frame: its title
    (:func:`frame_title`) and, for the torus preset, its cylinder (:func:`frame_cylinder`),
    unless given."""
    opts = dict(options)
    if "title" not in opts:
        opts["title"] = frame_title(run, model=model, state=state)
    if preset == "torus" and opts.get("cylinder") is None and opts.get("tmap") is None:
        opts["cylinder"] = frame_cylinder(run, model=model, state=state)
    return opts


def common_bounds(history, frames):
    """(2, 3) box [m] holding the free bodies of every frame of ``frames`` (one camera for
    them all)."""
    from . import meshes

    boxes = [meshes.scene_bounds(model, state, free_only=True)
             for _, model, state in _states(history, frames)]
    return np.array([np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)])


def _plan(run, frames, preset, clim, options):
    """(the frame indices, the options every one of them is drawn with: the common colour
    limits and camera box when there are several)."""
    from engine import io

    picked = parse_frames(frames, io.frame_count(run.path))
    if clim is None and len(picked) > 1:
        clim = common_clim(run, preset, picked, **options)
    fixed = {} if clim is None else {"clim": clim}
    if len(picked) > 1 and preset != "torus":
        fixed["bounds"] = common_bounds(run.path, picked)
    return picked, {**options, **fixed}


def _progress(it, total, desc, progress):
    if not progress:
        return it
    from tqdm.auto import tqdm

    return tqdm(it, total=total, unit="frame", desc=desc)


def render_frames(history, out, *, frames=-1, preset: str = "beads", camera="iso",
                  window_size=None, clim=None, progress: bool = True, **options) -> list[Path]:
    """Render ``frames`` (see :func:`parse_frames`) of ``history`` with ``preset``.

    One frame: to the PNG ``out`` (``.png`` added without a suffix).  Several: into the
    folder ``out`` as ``frame_0000.png`` ... (the history's frame index), all with the same
    colour limits (``clim``, by default :func:`common_clim` over these frames) and the same
    camera (framed on them all).  Each frame's title is :func:`frame_title` and the torus
    preset's cylinder :func:`frame_cylinder` unless ``title=`` / ``cylinder=`` are given.
    ``options`` go to the preset (``color_by``, ``cut``, ``axes`` ...,
    :func:`workbench.render.snapshot`).  Returns the paths written."""
    from engine import io

    from .render import WINDOW_SIZE, snapshot

    run = _Run(history)
    picked, opts = _plan(run, frames, preset, clim, options)
    size = WINDOW_SIZE if window_size is None else window_size
    out = Path(out)
    paths = []
    for k in _progress(picked, len(picked), "render", progress and len(picked) > 1):
        model, state = io.load(history, frame=k)
        target = out if len(picked) == 1 else out / f"frame_{k:04d}.png"
        try:
            paths.append(snapshot(model, state, target, preset=preset, camera=camera,
                                  window_size=size,
                                  **_frame_options(run, model, state, preset, opts)))
        except WriteFailed as e:      # each PNG is whole or absent: say which are there
            if len(picked) == 1:
                raise
            raise WriteFailed(e.filename, e.errno, f"{e.strerror}; {len(paths)} of the "
                              f"{len(picked)} frames were written before it") from None
    return paths


def render_frame(history, out, *, frame=-1, preset="beads", camera="iso", **options) -> Path:
    """Frame ``frame`` of ``history`` (a history or a checkpoint) drawn with ``preset`` to
    the PNG ``out`` (:func:`render_frames` for several)."""
    return render_frames(history, out, frames=frame, preset=preset, camera=camera,
                         progress=False, **options)[0]


def write_movie(history, path, *, frames="all", preset: str = "beads", camera="iso",
                window_size=None, clim=None, fps: float = 10.0, progress: bool = True,
                **options) -> Path:
    """Every frame of ``frames`` of ``history`` into one movie at ``path`` (``.mp4``:
    H.264 through imageio-ffmpeg; ``.gif``: Pillow), with fixed colour limits and camera
    (as :func:`render_frames`) and a progress bar.  Returns the path."""
    import imageio.v2 as imageio

    from engine import io

    from .render import WINDOW_SIZE, plotter

    path = Path(path)
    if path.suffix.lower() not in MOVIE_SUFFIXES:
        raise ValueError(f"movie {str(path)!r}: the file must end in "
                         f"{' or '.join(MOVIE_SUFFIXES)}")
    if not (isinstance(fps, (int, float)) and not isinstance(fps, bool) and 0 < fps <= 120):
        raise ValueError(f"fps must be a number in (0, 120], got {fps!r}")
    run = _Run(history)
    picked, opts = _plan(run, frames, preset, clim, options)
    w, h = WINDOW_SIZE if window_size is None else window_size
    w, h = int(w) // 2 * 2, int(h) // 2 * 2          # H.264 wants even sizes
    path.parent.mkdir(parents=True, exist_ok=True)
    kw = dict(fps=fps, codec="libx264", quality=7, pixelformat="yuv420p",
              macro_block_size=2) if path.suffix.lower() == ".mp4" else \
        dict(duration=1000.0 / fps, loop=0)     # Pillow's GIF duration is in ms (1/fps s: 0)
    if path.suffix.lower() == ".mp4":
        kw["ffmpeg_log_level"] = "quiet"     # its failures are told below, in one line
    mp4 = path.suffix.lower() == ".mp4"

    def pictures():
        for k in _progress(picked, len(picked), "movie", progress):
            model, state = io.load(history, frame=k)
            pl = plotter(model, state, preset, camera=camera, window_size=(w, h),
                         **_frame_options(run, model, state, preset, opts))
            try:
                yield pl.screenshot(None, return_img=True, transparent_background=False)
            finally:
                pl.close()

    done = 0
    with replacing(path, "the movie could not be written") as tmp:   # a movie cut short
        open(tmp, "wb").close()            # never replaces a good one; a disk that cannot
        if not mp4:                        # take a file is seen before ffmpeg starts
            # a GIF: Pillow writes every frame at the end anyway; built in memory, so that
            # a full disk meets one plain write (imageio's writer, failing on close, failed
            # again when it was freed, with a traceback)
            import io as _io

            buf = _io.BytesIO()
            imageio.mimwrite(buf, list(pictures()), format="GIF", **kw)
            with open(tmp, "wb") as f:
                f.write(buf.getvalue())
            return path
        try:
            with imageio.get_writer(tmp, **kw) as writer:
                for picture in pictures():
                    writer.append_data(picture)
                    done += 1
            _check_movie(tmp, len(picked))
        except (OSError, RuntimeError) as e:
            if isinstance(e, WriteFailed) or is_write_error(e):
                raise
            # ffmpeg died (its pipe broke) or wrote a movie it cannot read back: the disk
            # is the usual cause; its own words are not a user's to read
            code = errno.ENOSPC if free_bytes(tmp) < (1 << 20) else errno.EIO
            raise WriteFailed(path, code, f"the movie could not be written (ffmpeg stopped "
                              f"after {done} of {len(picked)} frames: "
                              f"{os.strerror(code)}); the older file of this name, if any, "
                              f"is kept") from None
    return path


def _check_movie(path: Path, n: int) -> None:
    """Raise RuntimeError unless ffmpeg reads ``n`` frames back from the movie ``path``
    (imageio-ffmpeg does not look at ffmpeg's exit status: a movie whose end could not be
    written is otherwise taken as done)."""
    import imageio_ffmpeg

    got, _ = imageio_ffmpeg.count_frames_and_secs(str(path))
    if got != n:
        raise RuntimeError(f"{path}: the movie holds {got} frames, not {n}")
