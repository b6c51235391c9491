"""Macro-stiffness H: slope of the linear part of a (ε_zz, σ_w^eq) curve (paper Table 2)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class MacroStiffness:
    """H [Pa] (stress per unit strain), the linear range found and its quality.

    Attributes
    ----------
    H : float                 slope of the least-squares line over the linear range.
    intercept : float
    start : int               first index of the linear range (it runs to the end).
    start_point : (float, float)  (strain, stress) at ``start`` (Table 2's starting point).
    r2 : float                coefficient of determination of the fit.
    rel_rms : float           RMS residual / stress range over the linear range.
    """

    H: float
    intercept: float
    start: int
    start_point: tuple
    r2: float
    rel_rms: float


def macro_stiffness(strain, stress, *, rel_tol: float = 0.01, min_points: int = 5) -> MacroStiffness:
    """Slope of the longest final range of the curve that is linear within ``rel_tol``.

    The range [s, n) starts at the smallest s for which the least-squares line leaves an RMS
    residual below ``rel_tol`` × the stress range over [s, n).  The paper's curves are linear
    from a starting point to the end of the test (Fig. 15).
    """
    e = np.asarray(strain, dtype=float)
    s = np.asarray(stress, dtype=float)
    if e.shape != s.shape or e.ndim != 1:
        raise ValueError(f"strain and stress must be 1D of equal length, got {e.shape}, {s.shape}")
    n = e.size
    if n < min_points:
        raise ValueError(f"macro_stiffness needs at least {min_points} points, got {n}")
    for start in range(0, n - min_points + 1):
        x, y = e[start:], s[start:]
        A = np.column_stack([x, np.ones_like(x)])
        (slope, icpt), *_ = np.linalg.lstsq(A, y, rcond=None)
        res = y - (slope * x + icpt)
        span = np.ptp(y)
        rel = float(np.sqrt(np.mean(res ** 2)) / span) if span > 0 else 0.0
        if rel <= rel_tol:
            ss = float(np.sum((y - y.mean()) ** 2))
            r2 = 1.0 - float(np.sum(res ** 2)) / ss if ss > 0 else 1.0
            return MacroStiffness(H=float(slope), intercept=float(icpt), start=start,
                                  start_point=(float(e[start]), float(s[start])), r2=r2,
                                  rel_rms=rel)
    raise ValueError(f"no final range of >= {min_points} points is linear within {rel_tol:.0%}")


def loading_curves(records) -> dict | None:
    """The triaxial curves of a test's recorded history, one value per record, in SI units:
    ``{"strain", "deviator", "mean_stress", "wire_equivalent", "loading"}``.

    ``records`` is an :class:`engine.io.HistoryData` (or anything with ``time`` and an
    ``extra`` dict) of a triaxial test: extras ``stress`` (n, 3, 3) [Pa, tension positive],
    ``height`` [m], ``stage`` (0 isotropic, >= 1 loading) and optionally ``wire_stress``.
    The loading starts from the last isotropic record (as the tests'
    :class:`~engine.experiments.common.TestResult` curves do): there, axial strain
    ``1 - H/H0`` is 0.  ``strain`` [-] (compression positive), ``deviator`` q = σ_a − σ_r
    [Pa] and ``mean_stress`` p = −tr σ / 3 [Pa] (compression positive) and
    ``wire_equivalent`` ‖dev σ_w‖ [Pa] are NaN before it; ``loading`` is the (k,) index
    array of the records from that one on.  ``None`` for a history that is not a triaxial
    test's (no ``stress`` / ``height`` extras, or no loading record)."""
    from .stress import equivalent_stress

    ex = getattr(records, "extra", {}) or {}
    n = len(np.asarray(records.time))
    if "stress" not in ex or "height" not in ex or n == 0:
        return None
    s = np.asarray(ex["stress"], float)
    h = np.asarray(ex["height"], float)
    stage = np.asarray(ex.get("stage", np.zeros(n)), int)
    load = np.flatnonzero(stage >= 1)
    if not load.size:
        return None
    first = max(int(load[0]) - 1, 0)
    sel = np.arange(first, n)
    out = {k: np.full(n, np.nan) for k in ("strain", "deviator", "mean_stress",
                                           "wire_equivalent")}
    out["strain"][sel] = 1.0 - h[sel] / h[first]
    sa = -s[sel, 2, 2]
    sr = -(s[sel, 0, 0] + s[sel, 1, 1]) / 2.0
    out["deviator"][sel] = sa - sr
    out["mean_stress"][sel] = -np.trace(s[sel], axis1=1, axis2=2) / 3.0
    if "wire_stress" in ex:
        w = np.asarray(ex["wire_stress"], float)
        out["wire_equivalent"][sel] = [equivalent_stress(x) for x in w[sel]]
    out["loading"] = sel
    return out
