"""Several frames of a history: fixed colour limits, one camera, a folder of PNGs or a movie
(``nscd render --frames``, ``--movie``).

::

    from workbench.frames import render_frames, write_movie
    render_frames("out/demo/run.h5", "out/frames", frames="all", preset="wire")
    write_movie("out/demo/run.h5", "out/demo/wire.mp4", preset="wire")   # or .gif

Every frame of one call is drawn with the same colour limits (by default the range of the
preset's field over all the frames drawn: :func:`common_clim`) and the same camera (framed
on the scene over all those frames), so the frames can be compared and a movie does not
flicker.  Movies are written with imageio: MP4 through the ``imageio-ffmpeg`` wheel (its own
ffmpeg binary, no system ffmpeg), GIF through Pillow.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

__all__ = ["parse_frames", "common_clim", "render_frames", "write_movie", "MOVIE_SUFFIXES"]

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


def common_clim(history, preset: str, frames, **options):
    """The colour limits (lo, hi) covering ``preset``'s field over ``frames`` of
    ``history`` (the union of :func:`workbench.render.value_range` of each; widened to
    (lo, lo + 1) when empty), or None for a picture without a colour scale (beads coloured
    by kind) or without data."""
    from .render import value_range

    if preset == "beads" and options.get("color_by", "kind") == "kind":
        return None                                   # no colour scale
    lo, hi = np.inf, -np.inf
    for _, model, state in _states(history, frames):
        r = value_range(model, state, preset, **_frame_options(model, state, preset, options))
        if r is not None:                             # (an empty map: no data there)
            lo, hi = min(lo, r[0]), max(hi, r[1])
    if not np.isfinite(lo):
        return None
    return (float(lo), float(hi) if hi > lo else float(lo) + 1.0)


def _frame_options(model, state, preset, options):
    from engine.model import CYLINDER

    from .meshes import sample_cylinder

    opts = dict(options)
    if preset == "torus" and "cylinder" not in opts and not (model.body_kind == CYLINDER).any():
        opts["cylinder"] = sample_cylinder(model, state)
    return opts


def common_bounds(history, frames):
    """(2, 3) box [m] holding the free bodies of every frame of ``frames`` (one camera for
    them all)."""
    from . import meshes

    boxes = [meshes.scene_bounds(model, state, free_only=True)
             for _, model, state in _states(history, frames)]
    return np.array([np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)])


def _plan(history, frames, preset, clim, options):
    """(the frame indices, the options every one of them is drawn with: the common colour
    limits and camera box when there are several)."""
    from engine import io

    picked = parse_frames(frames, io.frame_count(history))
    if clim is None and len(picked) > 1:
        clim = common_clim(history, preset, picked, **options)
    fixed = {} if clim is None else {"clim": clim}
    if len(picked) > 1 and preset != "torus":
        fixed["bounds"] = common_bounds(history, picked)
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
    camera (framed on them all).  ``options`` go to the preset (``color_by``, ``cut`` ...,
    :func:`workbench.render.snapshot`).  Returns the paths written."""
    from engine import io

    from .render import WINDOW_SIZE, snapshot

    picked, opts = _plan(history, frames, preset, clim, options)
    size = WINDOW_SIZE if window_size is None else window_size
    out = Path(out)
    paths = []
    for k in _progress(picked, len(picked), "render", progress and len(picked) > 1):
        model, state = io.load(history, frame=k)
        target = out if len(picked) == 1 else out / f"frame_{k:04d}.png"
        paths.append(snapshot(model, state, target, preset=preset, camera=camera,
                              window_size=size, **_frame_options(model, state, preset, opts)))
    return paths


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
    picked, opts = _plan(history, frames, preset, clim, options)
    w, h = WINDOW_SIZE if window_size is None else window_size
    w, h = int(w) // 2 * 2, int(h) // 2 * 2          # H.264 wants even sizes
    path.parent.mkdir(parents=True, exist_ok=True)
    kw = dict(fps=fps, codec="libx264", quality=7, pixelformat="yuv420p",
              macro_block_size=2) if path.suffix.lower() == ".mp4" else \
        dict(duration=1000.0 / fps, loop=0)     # Pillow's GIF duration is in ms (1/fps s: 0)
    tmp = path.with_name(f".{path.name}.part{path.suffix}")
    try:
        with imageio.get_writer(tmp, **kw) as writer:
            for k in _progress(picked, len(picked), "movie", progress):
                model, state = io.load(history, frame=k)
                pl = plotter(model, state, preset, camera=camera, window_size=(w, h),
                             **_frame_options(model, state, preset, opts))
                try:
                    writer.append_data(pl.screenshot(None, return_img=True,
                                                     transparent_background=False))
                finally:
                    pl.close()
        os.replace(tmp, path)              # a movie cut short never replaces a good one
    finally:
        if tmp.exists():
            tmp.unlink()
    return path
