"""Matplotlib figures of runs, drawn with the Agg canvas (no pyplot, no global state).

Every function takes plain arrays (or lists) in SI units and a path, saves a PNG and
returns the path.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["deposit_figure"]


def _new_figure(nrows: int, size=(7.0, 7.5)):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, 1, sharex=True)
    return fig, axes


def deposit_figure(history, path, *, tol: float | None = None, title: str | None = None) -> Path:
    """Kinetic energy, NLGS sweeps, contact count (and final residual) against time.

    Parameters
    ----------
    history : mapping of equal-length 1-D sequences, one entry per step
        ``time`` [s], ``kinetic_energy`` [J], ``iterations`` (NLGS sweeps of the step),
        ``contacts`` (active contacts of the step) and, optionally, ``residual`` (final
        Quad norm of the step, [-]) which adds a fourth panel.
    path : path of the PNG to write (parent directories are created).
    tol : float, optional
        NLGS tolerance, drawn as a dashed line on the residual panel.
    title : str, optional

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    t = np.asarray(history["time"], dtype=float)
    series = [("kinetic_energy", "kinetic energy [J]", True),
              ("iterations", "NLGS sweeps per step", False),
              ("contacts", "active contacts", False)]
    if "residual" in history and len(history["residual"]):
        series.append(("residual", "final residual [-]", True))
    for key, _, _ in series:
        if len(history[key]) != t.size:
            raise ValueError(f"history[{key!r}] has {len(history[key])} values, "
                             f"history['time'] has {t.size}")
    fig, axes = _new_figure(len(series))
    for ax, (key, label, log) in zip(axes, series):
        y = np.asarray(history[key], dtype=float)
        if log:
            positive = y > 0
            ax.semilogy(t[positive], y[positive], lw=1.0)
        else:
            ax.plot(t, y, lw=1.0)
        ax.set_ylabel(label)
        ax.grid(True, which="major", alpha=0.3)
        if key == "residual" and tol is not None:
            ax.axhline(tol, color="k", ls="--", lw=0.8, label=f"tol = {tol:g}")
            ax.set_ylim(bottom=1e-3 * tol)  # steps solved exactly (residual ~ 1e-16) clipped
            ax.legend(loc="best", fontsize="small")
    axes[-1].set_xlabel("time [s]")
    if title:
        fig.suptitle(title)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    return path
