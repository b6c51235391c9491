"""Matplotlib figures of runs, drawn with the Agg canvas (no pyplot, no global state).

Every figure function takes plain arrays (or lists) in SI units and a path, saves a PNG
and returns the path.  :func:`law_label` and :func:`experiment_title` give the words of
their legends and titles (a wire law, a test's name).
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from .units import reading_unit

__all__ = ["deposit_figure", "stress_strain_figure", "stiffness_figure", "slope_figure",
           "directions_figure", "convergence_figure", "tortuosity_figure", "law_label",
           "experiment_title", "SAND_ONLY"]

#: Legend font size of every figure here [pt] (the figures are 6.4 in wide at 110 dpi).
_LEGEND_SIZE = 9


# ---------------------------------------------------------------- words for the legends

#: The words of a run without wire.
SAND_ONLY = "sand only"

#: Wire laws in words, by class name (:mod:`engine.laws`).
_LAW_WORDS = {"RigidRod": "rigid rod", "ElasticRod": "elastic rod", "RigidWire": "rigid wire",
              "ElasticWire": "elastic wire", "BrittleElasticWire": "brittle elastic wire"}

#: Tests in words, by their result's ``name`` (:mod:`engine.experiments`).
_TEST_WORDS = {"cylinder_triaxial": "cylinder triaxial test",
               "box_triaxial": "box triaxial test", "gravity_deposit": "gravity deposit",
               "slope_deposit": "slope deposit", "pullout_test": "wire pull-out test"}


def _num(value: float, digits: int = 3) -> str:
    """``value`` to ``digits`` significant digits, positional, no trailing zeros, with a
    true minus sign: 1.0 -> "1", 0.2 -> "0.2", 1000 -> "1000", -0.05 -> "−0.05"."""
    v = float(value)
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "∞" if v > 0 else "−∞"
    text = np.format_float_positional(float(f"{v:.{digits}g}"), trim="-")
    return text.replace("-", "−")


def _law_words(kind: str, fields: dict) -> str:
    words = [_LAW_WORDS.get(kind, kind)]
    k = fields.get("stiffness")
    if k is not None and math.isfinite(float(k)):
        words.append(f"k = {_num(k)} N")          # k is a force per unit strain: N, as Table 2
    e0 = float(fields.get("prestrain") or 0.0)
    if e0 != 0.0:
        words.append(f"ε₀ = {_num(100 * e0)} %")
    t = fields.get("max_tension")
    if t is not None and math.isfinite(float(t)):
        factor, unit = reading_unit("N", float(t))
        words.append(f"T_max = {_num(float(t) * factor)} {unit}")
    return ", ".join(words)


_REPR = re.compile(r"^\s*([A-Za-z_]\w*)\((.*)\)\s*$")
_FIELD = re.compile(r"(\w+)\s*=\s*([^,]+)")


def law_label(law) -> str:
    """A wire law in words, for a legend: ``"elastic wire, k = 1 N"``, ``"elastic wire,
    k = 0.2 N, ε₀ = 1 %"`` (the prestrain only when not 0), ``"rigid wire"``, ``"rigid
    rod"``, ``"elastic rod, k = 2 N"``, ``"brittle elastic wire, k = 1 N, T_max = 5 mN"``
    (the tension in a unit chosen for reading, :func:`workbench.units.reading_unit`) and
    :data:`SAND_ONLY` for a run without wire.

    Parameters
    ----------
    law : one of
        an :class:`engine.laws.WireLaw` (the best: its fields are read as they are);
        None (no wire);
        a result's ``params`` (a mapping with ``wire`` and ``wire_law``, the law's repr, as
        the tests of :mod:`engine.experiments` write them) or a result with such ``params``;
        a law's repr (``"ElasticWire(prestrain=0.0, stiffness=1.0)"``, ``"None"``) or a name
        of :data:`engine.laws.WIRE_LAWS` (``"elastic"``: its default law, ``"none"``).

    A string that is none of these is returned as it is (a label already in words).
    Raises ValueError for a mapping that names no wire (neither ``wire`` nor ``wire_law``).
    """
    from engine import laws

    if law is None:
        return SAND_ONLY
    if isinstance(law, laws.WireLaw):
        fields = {name: getattr(law, name) for name in type(law).model_fields}
        return _law_words(type(law).__name__, fields)
    params = getattr(law, "params", None)
    if isinstance(params, dict):                  # a TestResult
        law = params
    if isinstance(law, dict):
        if "wire" not in law and "wire_law" not in law:
            raise ValueError(f"law_label: these params name no wire (no 'wire' nor "
                             f"'wire_law'): {sorted(law)}")
        if "wire" in law and not law["wire"]:
            return SAND_ONLY
        return law_label(law.get("wire_law"))
    if isinstance(law, str):
        text = law.strip()
        if text in ("None", "none", ""):
            return SAND_ONLY
        if text in laws.WIRE_LAWS:                # a name: its default law (brittle: none)
            if text == "brittle":
                return _LAW_WORDS["BrittleElasticWire"]
            return law_label(laws.wire_law(text))
        m = _REPR.match(text)
        if m and m.group(1) in _LAW_WORDS:
            fields = {}
            for name, value in _FIELD.findall(m.group(2)):
                try:
                    fields[name] = float(value)
                except ValueError:
                    fields[name] = None
            return _law_words(m.group(1), fields)
        return law
    raise TypeError(f"law_label: expected a wire law, None, a result's params or a law's "
                    f"repr, got {type(law).__name__}")


def experiment_title(name: str) -> str:
    """A test's result ``name`` in words: ``"cylinder_triaxial"`` -> ``"cylinder triaxial
    test"``; a name not known is shown with spaces for its underscores."""
    return _TEST_WORDS.get(name, str(name).replace("_", " "))


def _is_test_name(text) -> bool:
    return isinstance(text, str) and (text in _TEST_WORDS
                                      or re.fullmatch(r"[a-z][a-z0-9]*(_[a-z0-9]+)+", text)
                                      is not None)


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
            ax.legend(loc="best", fontsize=_LEGEND_SIZE)
    axes[-1].set_xlabel("time [s]")
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def _axes(nrows=1, ncols=1, size=(6.4, 4.4)):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, squeeze=False)


def _save(fig, path, tight: bool = False) -> Path:
    from engine.files import replacing

    path = Path(path)
    with replacing(path, "the figure could not be written") as tmp:
        fig.savefig(tmp, **({"bbox_inches": "tight", "pad_inches": 0.1} if tight else {}))
    return path


def _result_label(r) -> str:
    """A result's legend words: its wire law (:func:`law_label` of its ``params``), or its
    name when its params name no wire."""
    try:
        return law_label(getattr(r, "params", None) or {})
    except ValueError:
        return str(getattr(r, "name", "run"))


def _stress_strain_title(title, results) -> str | None:
    """The title in words: a test's name (``"cylinder_triaxial"``, given or, when ``title``
    is None, the results') becomes the test in words with the confining pressure the runs
    share; any other title is kept as it is."""
    if title is None:
        names = {getattr(r, "name", None) for r in results}
        if len(names) != 1 or not _is_test_name(next(iter(names))):
            return None
        title = names.pop()
    if not _is_test_name(title):
        return title
    words = experiment_title(title)
    pressures = {(getattr(r, "params", None) or {}).get("pressure") for r in results}
    if len(pressures) == 1 and None not in pressures:
        p = float(pressures.pop())
        factor, unit = reading_unit("Pa", p)
        words += f", confining pressure {_num(p * factor)} {unit}"
    return words


def stress_strain_figure(results, path, *, labels=None, title=None, reference=None,
                         reference_label: str = "sand only (reference)") -> Path:
    """Deviator q and volumetric strain against axial strain for one or several
    :class:`engine.experiments.TestResult` (Fig. 14 style: sand, elastic and rigid wire),
    with the wire part's equivalent stress (Fig. 15) in a third panel.

    Parameters
    ----------
    results : a TestResult or a list of them (anything with ``axial_strain``, ``deviator``,
        ``volumetric_strain``, ``wire_equivalent``; ``params`` and ``name`` for the words).
    path : the PNG to write.
    labels : list, optional
        One legend entry per result: a string (kept as it is) or a wire law / None (put in
        words by :func:`law_label`).  Default: each result's wire law in words, from its
        ``params``.
    title : str, optional
        A test's name (``"cylinder_triaxial"``) is put in words (``"cylinder triaxial test,
        confining pressure 15 kPa"``); another title is kept.  Default: the results' test.
    reference : TestResult or list of them, optional
        Sand-only runs drawn as grey dashed lines in the deviator and volumetric panels,
        labelled ``reference_label`` (a string, or one per reference run; they have no wire
        stress).

    Runs without wire stress (all zero) are left out of the wire panel.  With more than
    four legend entries the legend goes to the right of the panels, off the curves.

    The stresses are shown in a unit chosen for reading (Pa or kPa,
    :func:`workbench.units.reading_unit`); strains in %.
    """
    results = list(results) if isinstance(results, (list, tuple)) else [results]
    if labels is None:
        labels = [_result_label(r) for r in results]
    else:
        labels = [lab if isinstance(lab, str) else law_label(lab) for lab in labels]
        if len(labels) != len(results):
            raise ValueError(f"labels: one per result ({len(results)}), got {len(labels)}")
    refs = [] if reference is None else (list(reference) if isinstance(reference, (list, tuple))
                                         else [reference])
    ref_labels = ([reference_label] * len(refs) if isinstance(reference_label, str)
                  else list(reference_label))
    if len(ref_labels) != len(refs):
        raise ValueError(f"reference_label: one per reference run ({len(refs)}), got "
                         f"{len(ref_labels)}")
    curves = results + refs

    def largest(key, runs):
        values = [np.abs(np.asarray(getattr(r, key), dtype=float)) for r in runs]
        values = [v[np.isfinite(v)] for v in values if np.size(v)]
        return max((float(v.max()) for v in values if v.size), default=0.0)

    q_factor, q_unit = reading_unit("Pa", largest("deviator", curves))
    w_factor, w_unit = reading_unit("Pa", largest("wire_equivalent", results))
    outside = len(curves) > 4                        # the legend right of the panels
    fig, ax = _axes(3, 1, size=(9.0 if outside else 6.4, 8.0))
    for r, lab in zip(results, labels):
        e = 100 * np.asarray(r.axial_strain)
        ax[0, 0].plot(e, np.asarray(r.deviator) * q_factor, label=lab)
        ax[1, 0].plot(e, 100 * np.asarray(r.volumetric_strain), label=lab)
        w = np.asarray(r.wire_equivalent, dtype=float)
        if np.any(w[np.isfinite(w)] != 0):           # a sand run has no wire stress
            ax[2, 0].plot(e, w * w_factor, label=lab)
        else:
            ax[2, 0].plot([], [])                    # keep the colour of this run
    greys = [0.2] if len(refs) <= 1 else np.linspace(0.15, 0.55, len(refs))
    for ref, lab, g in zip(refs, ref_labels, greys):
        style = dict(color=str(round(float(g), 2)), ls="--", lw=1.3, label=lab)
        e = 100 * np.asarray(ref.axial_strain)
        ax[0, 0].plot(e, np.asarray(ref.deviator) * q_factor, **style)
        ax[1, 0].plot(e, 100 * np.asarray(ref.volumetric_strain), **style)
    ax[0, 0].set_ylabel(f"deviator q = σ₁ − σ₃ [{q_unit}]")
    ax[1, 0].set_ylabel("volumetric strain [%]\n(contraction > 0)")
    ax[2, 0].set_ylabel(f"wire equivalent stress\n‖dev σ_w‖ [{w_unit}]")
    ax[2, 0].set_xlabel("axial strain [%] (compression > 0)")
    for a in ax[:, 0]:
        a.grid(alpha=0.3)
    entries = len(ax[0, 0].get_legend_handles_labels()[0])
    if outside:                                      # off the curves, right of the panels
        ax[0, 0].legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=_LEGEND_SIZE,
                        borderaxespad=0.0)
    elif entries:
        ax[0, 0].legend(loc="best", fontsize=_LEGEND_SIZE)
    words = _stress_strain_title(title, curves)
    if words:
        ax[0, 0].set_title(words, fontsize=11)
    return _save(fig, path, tight=outside)


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
    a.legend(loc="best", fontsize=_LEGEND_SIZE)
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
    ax[0, 0].legend(loc="best", fontsize=_LEGEND_SIZE)
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


def _convergence_title(n, at_max, not_conv, it, rel, tol, max_iter) -> str:
    """Two lines: how many recorded steps, how many at max_iter (and %); the sweeps per
    step (mean, max) and the largest residual reached (over tol when given)."""
    if n == 0:
        return "no recorded step"
    def count(k, what):
        if k == 0:
            return f"none {what}"
        return f"{k} {what} ({_num(100 * k / n, 2)} %)"
    first = f"{n} recorded steps, "
    if max_iter:
        first += count(int(at_max.sum()), f"at max_iter = {max_iter}")
        extra = int((not_conv & ~at_max).sum())
        if extra:
            first += f", {extra} more not converged"
    else:
        first += count(int(not_conv.sum()), "not converged")
    finite = rel[np.isfinite(rel)]
    top = float(finite.max()) if finite.size else float("nan")
    second = f"NLGS sweeps per step: mean {it.mean():.0f}, max {int(it.max())}; "
    second += (f"largest residual reached / tol = {_num(top)}" if tol else
               f"largest residual reached = {top:.3g}")
    return first + "\n" + second


def convergence_figure(iterations, residual, path, *, tol=None, max_iter=None,
                       step=None, n_contacts=None, converged=None) -> Path:
    """How hard the NLGS worked on the recorded steps, against their step numbers ``step``
    (the history's ``step``; the record index when not given).

    Panels: the NLGS sweeps per step with the ``max_iter`` line; the residual reached, over
    ``tol`` when given, on a linear axis around the data (a converged step sits at or below
    1, the others show how far they stopped from it) -- or, when every recorded step
    converged, a strip saying so in words (the residuals all sit at tol then: a flat line
    says nothing); and the contact count ``n_contacts`` (the size of the problem) when
    given.  The steps at ``max_iter`` or not converged (``converged`` False, the history's
    flag; without it, residual above ``tol``) are marked in red in every panel.  The title
    states the recorded steps, the steps at max_iter (count and %), the mean and max sweeps
    per step and the largest residual reached / tol.
    """
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
    if converged is not None:
        not_conv = ~np.asarray(converged, dtype=bool)
        if not_conv.shape != it.shape:
            raise ValueError(f"converged must have one entry per record ({it.size}), got "
                             f"{not_conv.shape}")
    else:
        not_conv = res > tol if tol else np.zeros(it.size, bool)
    at_max = it >= max_iter if max_iter else np.zeros(it.size, bool)
    bad = not_conv | at_max
    rel = res / tol if tol else res
    all_good = not bad.any()
    ratios = [3.0, 1.0 if all_good else 2.2] + ([2.0] if nc is not None else [])
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    height = 2.2 * sum(ratios) / 3 + 0.9
    fig = Figure(figsize=(6.4, height), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots(len(ratios), 1, squeeze=False, gridspec_kw=dict(height_ratios=ratios))
    red = dict(ls="none", marker="o", ms=4, color="C3")
    bad_label = "at max_iter (not converged)" if max_iter else "not converged"
    # 1. sweeps per step
    a = ax[0, 0]
    a.plot(x, it, lw=0.9, color="C0")
    if bad.any():
        a.plot(x[bad], it[bad], label=f"{int(bad.sum())} {bad_label}", **red)
    if max_iter:
        a.axhline(max_iter, color="C3", ls="--", lw=0.8, label=f"max_iter = {max_iter}")
    a.set_ylabel("NLGS sweeps per step")
    a.set_ylim(bottom=0)
    # 2. residual reached
    a = ax[1, 0]
    label = "residual / tol" if tol else "final residual (Quad norm)"
    if it.size == 0 or all_good:
        a.set_axis_off()
        text = ("no recorded step" if it.size == 0 else
                f"all {it.size} recorded steps converged"
                + (" (residual ≤ tol)" if tol else ""))
        a.text(0.5, 0.5, text, transform=a.transAxes, ha="center", va="center",
               fontsize=11, color="0.15")
    else:
        a.plot(x, rel, lw=0.8, color="0.55")
        a.plot(x[bad], rel[bad], label=bad_label, **red)
        if tol:
            a.axhline(1.0, color="k", ls="--", lw=0.8, label="tol")
        finite = rel[np.isfinite(rel) & (rel > 0)]
        top = float(finite.max()) if finite.size else 1.0
        if tol and top > 50:                  # far beyond tol: log, tight around the data
            a.set_yscale("log")
            a.set_ylim(max(float(finite.min()) / 1.5, 1e-3), 1.5 * top)
        else:
            a.set_ylim(0, 1.1 * max(top, 1.0 if tol else 0.0) or 1.0)
        a.set_ylabel(label)
    # 3. contacts
    if nc is not None:
        a = ax[2, 0]
        a.plot(x, nc, lw=0.9, color="C0")
        if bad.any():
            a.plot(x[bad], nc[bad], **red)
        a.set_ylabel("contacts")
    data_axes = [a for a in ax[:, 0] if a.axison]
    for a in data_axes:
        a.grid(alpha=0.3)
        if a.get_legend_handles_labels()[0]:
            a.legend(loc="best", fontsize=_LEGEND_SIZE)
    data_axes[-1].set_xlabel("record" if step is None else "step")
    ax[0, 0].set_title(_convergence_title(it.size, at_max, not_conv, it, rel, tol, max_iter),
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
    ax[0, 0].legend(loc="best", fontsize=_LEGEND_SIZE)
    return _save(fig, path)
