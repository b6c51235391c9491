"""The numbers the claims are scored with: the seeds' statistics, the verdict words, the
heaps' slopes and the macro-stiffness H of Table 2 (:func:`h_fit`)."""
from __future__ import annotations

import math

import numpy as np

from .scales import COMMON_FIT_DEGREE, PAPER_FIT_DEGREE, _fmt_k

def _verdict(ok):
    if ok is None:
        return "not comparable"
    return "reproduced" if ok else "not reproduced"


def _g(x, fmt=".3g"):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    return format(x, fmt)


def _seed_stats(values):
    v = np.asarray([x for x in values if x is not None and np.isfinite(x)], float)
    if v.size == 0:
        return float("nan"), float("nan"), 0
    sd = float(v.std(ddof=1)) if v.size > 1 else float("nan")
    return float(v.mean()), sd, int(v.size)


def _significant(mean, sd, n):
    """True if mean > 0 beyond 2 standard errors, False if it is not, None without spread."""
    if n < 2 or not np.isfinite(sd):
        return None
    return bool(mean - 2 * sd / math.sqrt(n) > 0)


def _against(mean, sd, n) -> str:
    """What a mean that is not above 0 beyond 2 standard errors is: within the spread, or
    below 0 beyond 2 standard errors (an effect of the opposite sign)."""
    if _significant(-mean, sd, n):
        return "below 0 beyond 2 standard errors: the opposite effect"
    return "within the seed spread"


def _spearman(x, y):
    rx = np.argsort(np.argsort(np.asarray(x, float))).astype(float)
    ry = np.argsort(np.argsort(np.asarray(y, float))).astype(float)
    if rx.std() == 0 or ry.std() == 0:
        return float("nan")
    return float(np.corrcoef(rx, ry)[0, 1])


def heap_slopes(t, tag) -> dict:
    """The maximum slopes [deg] of one heap's curves ``t`` (its h(r)): with the paper's fit
    for ``tag`` (sand / w400 / w800, :data:`PAPER_FIT_DEGREE`), with the common cubic, and
    with a straight line."""
    from engine.analysis import max_slope

    r, h = t["r"], t["height"]
    try:
        return dict(paper=max_slope(r, h, PAPER_FIT_DEGREE[tag])[1],
                    common=max_slope(r, h, COMMON_FIT_DEGREE)[1],
                    line=max_slope(r, h, 1)[1])
    except ValueError as e:
        raise ValueError(f"its {tag} heap: {e}") from None


#: The start of the fallback fit of H [-]: the largest of Table 2's linear starting points.
H_FIT_FROM = 0.006


def h_fit(strain, stress) -> dict | None:
    """The macro-stiffness H of a (ε_zz, σ_w^eq) curve (Table 2): the slope found by
    :func:`engine.analysis.macro_stiffness` (the longest final range linear within 1 %),
    or, when there is no such range (our small samples' curves are noisy), the least-squares
    line over ε_zz ≥ 0.6 % (the largest of the paper's linear starting points), with its r².
    None with fewer than 5 points.

    Why it is not ``macro_stiffness`` alone: that one raises ValueError when no final range
    is linear within 1 %, and no run of the reports so far had one (fig15's note), so the
    fallback line decides Fig. 15, 16 and Table 2; where a range is found the numbers are
    ``macro_stiffness``'s (``method`` says which of the two gave them)."""
    from engine.analysis import macro_stiffness

    e, s = np.asarray(strain, float), np.asarray(stress, float)
    try:
        m = macro_stiffness(e, s)
        return dict(H=m.H, intercept=m.intercept, start=m.start, r2=m.r2,
                    method="macro_stiffness (linear within 1 %)")
    except ValueError:
        pass
    start = int(np.searchsorted(e, H_FIT_FROM)) if e.size and e[-1] > H_FIT_FROM else 0
    x, y = e[start:], s[start:]
    if x.size < 5 or np.ptp(x) == 0:
        return None
    a, b = np.polyfit(x, y, 1)
    ss = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum((y - (a * x + b)) ** 2)) / ss if ss > 0 else 1.0
    return dict(H=float(a), intercept=float(b), start=start, r2=r2,
                method=f"least squares from ε = {H_FIT_FROM:.1%} (no range linear within 1 %)")


def _H_of(t):
    if t is None:
        return None
    f = h_fit(t["axial_strain"], t["wire_equivalent"])
    return None if f is None else f["H"]


def _H_list(curves, scale):
    ks, Hs = [], []
    for k in scale.k_list:
        H = _H_of(curves.get(f"cylinder_k{_fmt_k(k)}_seed0"))
        if H is not None:
            ks.append(float(k))
            Hs.append(H)
    return ks, Hs

