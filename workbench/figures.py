"""Matplotlib figures of runs, drawn with the Agg canvas (no pyplot, no global state).

Every function takes plain arrays (or lists) in SI units and a path, saves a PNG and
returns the path.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["deposit_figure", "stress_strain_figure", "stiffness_figure", "slope_figure",
           "directions_figure", "convergence_figure", "tortuosity_figure"]


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


def _axes(nrows=1, ncols=1, size=(6.4, 4.4)):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, squeeze=False)


def _save(fig, path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    return path


def stress_strain_figure(results, path, *, labels=None, title=None) -> Path:
    """Deviator q [kPa] and volumetric strain against axial strain for one or several
    :class:`engine.experiments.TestResult` (Fig. 14 style: sand, elastic and rigid wire),
    with the wire part's equivalent stress (Fig. 15) in a third panel."""
    results = list(results) if isinstance(results, (list, tuple)) else [results]
    labels = labels or [r.params.get("wire_law", r.name) if r.params.get("wire") else "sand"
                        for r in results]
    fig, ax = _axes(3, 1, size=(6.4, 8.0))
    for r, lab in zip(results, labels):
        e = 100 * np.asarray(r.axial_strain)
        ax[0, 0].plot(e, np.asarray(r.deviator) / 1e3, label=lab)
        ax[1, 0].plot(e, 100 * np.asarray(r.volumetric_strain), label=lab)
        ax[2, 0].plot(e, np.asarray(r.wire_equivalent), label=lab)
    ax[0, 0].set_ylabel("deviator q = σ₁ − σ₃ [kPa]")
    ax[1, 0].set_ylabel("volumetric strain [%]\n(contraction > 0)")
    ax[2, 0].set_ylabel("wire equivalent stress\n‖dev σ_w‖ [Pa]")
    ax[2, 0].set_xlabel("axial strain [%] (compression > 0)")
    for a in ax[:, 0]:
        a.grid(alpha=0.3)
    ax[0, 0].legend(fontsize=8)
    if title:
        ax[0, 0].set_title(title)
    return _save(fig, path)


def stiffness_figure(k, H, path, *, H_rigid=None) -> Path:
    """Macro-stiffness H [Pa] against the wire stiffness k [N] (Table 2), log k axis; the
    rigid wire's H∞ as a horizontal line."""
    fig, ax = _axes()
    a = ax[0, 0]
    a.semilogx(k, H, "o-", label="elastic wire")
    if H_rigid is not None:
        a.axhline(H_rigid, color="k", ls="--", label="rigid wire (H∞)")
    a.set_xlabel("wire stiffness k [N]")
    a.set_ylabel("macro-stiffness H [Pa]")
    a.grid(alpha=0.3, which="both")
    a.legend(fontsize=8)
    return _save(fig, path)


def slope_figure(profiles, path, *, labels=None) -> Path:
    """Heap shape h(r) [mm] and floor pressure p(r) [Pa] with their regressions (Fig. 10)
    for one or several :class:`engine.analysis.SlopeProfile`."""
    profiles = list(profiles) if isinstance(profiles, (list, tuple)) else [profiles]
    labels = labels or [f"#{k}" for k in range(len(profiles))]
    fig, ax = _axes(2, 1, size=(6.4, 6.4))
    for p, lab in zip(profiles, labels):
        r = 1e3 * p.r
        line, = ax[0, 0].plot(r, 1e3 * p.height, "o", ms=3, label=f"{lab} ({p.max_slope_deg:.1f}°)")
        rs = np.linspace(p.r.min(), p.r.max(), 200)
        ax[0, 0].plot(1e3 * rs, 1e3 * p.height_fit(rs), color=line.get_color())
        ax[1, 0].plot(r, p.pressure, "o", ms=3, color=line.get_color(), label=lab)
        ax[1, 0].plot(1e3 * rs, p.pressure_fit(rs), color=line.get_color())
    ax[0, 0].set_ylabel("height h [mm]")
    ax[1, 0].set_ylabel("floor pressure p [Pa]")
    ax[1, 0].set_xlabel("radius r [mm]")
    for a in ax[:, 0]:
        a.grid(alpha=0.3)
    ax[0, 0].legend(fontsize=8)
    return _save(fig, path)


def directions_figure(before, after, path) -> Path:
    """Rose diagrams of the wire element directions in the (x,y), (x,z), (y,z) planes,
    before and after (Fig. 8-9); ``before``/``after`` are {plane: (edges, weights)} as in
    :func:`engine.analysis.direction_histogram`."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 6.0), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    for row, (name, h) in enumerate((("before", before), ("after", after))):
        for col, plane in enumerate(("xy", "xz", "yz")):
            a = fig.add_subplot(2, 3, 3 * row + col + 1, projection="polar")
            edges, w = h[plane]
            w = np.asarray(w, float) / max(float(np.sum(w)), 1e-300)
            width = np.diff(edges)
            # undirected: draw each bin and its opposite
            a.bar(np.r_[edges[:-1], edges[:-1] + np.pi], np.r_[w, w], width=np.r_[width, width],
                  align="edge", color="C0" if row == 0 else "C3", alpha=0.8)
            a.set_title(f"{name}: ({plane[0]},{plane[1]})", fontsize=9)
            a.set_yticklabels([])
    return _save(fig, path)


def convergence_figure(iterations, residual, path, *, tol=None, max_iter=None,
                       step=None, n_contacts=None, converged=None) -> Path:
    """How hard the NLGS worked on the recorded steps, against their step numbers ``step``
    (the history's ``step``; the record index when not given): the sweeps per step with
    ``max_iter``; the final residual, over ``tol`` when given (a converged step sits at or
    below 1, so the panel shows how far the others stopped from it); and the contact count
    ``n_contacts`` (the size of the problem) when given.  Steps that did not converge
    (``converged`` False, the history's flag; without it, residual above ``tol``) are marked
    in red in every panel, and the title counts them."""
    it = np.asarray(iterations)
    res = np.asarray(residual, dtype=float)
    x = np.arange(it.size) if step is None else np.asarray(step)
    if x.shape != it.shape:
        raise ValueError(f"step must have one entry per record ({it.size}), got {x.shape}")
    if res.shape != it.shape:
        raise ValueError(f"residual must have one entry per record ({it.size}), got {res.shape}")
    nc = None if n_contacts is None else np.asarray(n_contacts)
    if nc is not None and nc.shape != it.shape:
        raise ValueError(f"n_contacts must have one entry per record ({it.size}), got {nc.shape}")
    fig, ax = _axes(2 if nc is None else 3, 1, size=(6.4, 5.0 if nc is None else 6.6))
    if converged is not None:
        bad = ~np.asarray(converged, dtype=bool)
        if bad.shape != it.shape:
            raise ValueError(f"converged must have one entry per record ({it.size}), got "
                             f"{bad.shape}")
    else:
        bad = res > tol if tol else np.zeros(it.size, bool)
    rel = res / tol if tol else res
    panels = [(it, "NLGS sweeps per step"),
              (rel, "final residual / tol" if tol else "final residual (Quad norm)")]
    if nc is not None:
        panels.append((nc, "contacts"))
    for a, (y, label) in zip(ax[:, 0], panels):
        a.plot(x, y, lw=0.8, color="C0")
        if bad.any():
            a.plot(x[bad], y[bad], "o", ms=3, color="C3", label="not converged")
        a.set_ylabel(label)
        a.grid(alpha=0.3)
    if max_iter:
        ax[0, 0].axhline(max_iter, color="C3", ls="--", lw=0.8, label="max_iter")
    ax[1, 0].set_yscale("log")
    if tol:
        ax[1, 0].axhline(1.0, color="C3", ls="--", lw=0.8, label="tol")
        lo = min(0.1, float(np.nanmin(rel[rel > 0])) / 2) if (rel > 0).any() else 0.1
        ax[1, 0].set_ylim(lo, max(10.0, 2 * float(np.nanmax(rel))))
    for a in ax[:2, 0]:
        a.legend(fontsize=8, loc="upper right")
    ax[-1, 0].set_xlabel("record" if step is None else "step")
    ax[0, 0].set_title(f"{int(bad.sum())} of {it.size} recorded steps not converged; "
                       f"mean {it.mean():.0f} sweeps" if it.size else "no recorded step",
                       fontsize=10)
    return _save(fig, path)


def tortuosity_figure(labels, before, after, path) -> Path:
    """Tortuosity ξ [1/m] before and after a deposit for several samples (Fig. 7)."""
    fig, ax = _axes()
    x = np.arange(len(labels))
    ax[0, 0].bar(x - 0.2, before, 0.4, label="before")
    ax[0, 0].bar(x + 0.2, after, 0.4, label="after")
    ax[0, 0].set_xticks(x, labels)
    ax[0, 0].set_ylabel("tortuosity ξ [1/m]")
    ax[0, 0].legend(fontsize=8)
    return _save(fig, path)
