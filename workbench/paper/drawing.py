"""The report's pictures and series, loops over the figures and series of the claims
(:data:`.registry.CLAIMS`): matplotlib figures (:func:`make_figures`), PyVista pictures of
the last frames (:func:`snapshots`) and ParaView series (:func:`series`)."""
from __future__ import annotations

from pathlib import Path

from .registry import Picture, Plot, figures_of, series_runs
from .scales import Scale


def make_figures(curves: dict, scale: Scale, fig_dir: Path, chosen=None) -> dict:
    """The report's matplotlib figures, {key: path}; a figure whose runs are missing is
    drawn with what there is (an empty panel says so).  ``chosen``: claim ids (None: all);
    only their figures are drawn (the other files in ``fig_dir`` are left as they are)."""
    fig_dir.mkdir(parents=True, exist_ok=True)
    return {f.key: f.draw(curves, scale, fig_dir / f.file)
            for f in figures_of(chosen) if isinstance(f, Plot)}


def snapshots(runs_dir: Path, fig_dir: Path, runs=None) -> tuple[dict, list]:
    """PyVista pictures of the frames the claims show (Fig. 7, 9, 11, 13); ({key: path},
    problems).  ``runs``: the names of the report's runs (None: all); the others are not
    drawn."""
    from ..frames import render_frame

    out, problems = {}, []
    for p in figures_of(None):
        if not isinstance(p, Picture) or (runs is not None and p.run not in runs):
            continue
        try:
            out[p.key] = render_frame(runs_dir / f"{p.run}.h5", fig_dir / p.file,
                                      frame=p.frame, preset=p.preset, camera=p.camera, **p.opts)
        except Exception as e:  # noqa: BLE001 - a picture that cannot be drawn is reported
            problems.append(f"{p.key} ({p.run}, {p.preset}): {type(e).__name__}: {e}")
    return out, problems


def series(runs_dir: Path, series_dir: Path, runs=None) -> tuple[dict, list]:
    """ParaView series (VTU + PVD) of the runs the claims export (those of them in
    ``runs``, when given)."""
    from ..series import export_history as export_series

    out, problems = {}, []
    for run in series_runs():
        if runs is not None and run not in runs:
            continue
        try:
            out[run] = export_series(runs_dir / f"{run}.h5", series_dir / run, name=run,
                                     progress=False)
        except Exception as e:  # noqa: BLE001
            problems.append(f"{run}: {type(e).__name__}: {e}")
    return out, problems
