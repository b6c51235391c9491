"""Grain-size distributions (paper §2.4, §3: sand "lying between Ø0.3 mm and Ø0.8 mm").

Every function returns radii [m] in a random order (the order in which the geometric deposit
places them) and takes ``seed=``.  The sample size is given either by a number of grains
``n`` or by a total solid ``volume`` [m³] (draws stop at the first grain that reaches it).
"""
from __future__ import annotations

import numpy as np

__all__ = ["uniform", "two_size", "solid_volume"]


def _check_size(n, volume):
    if (n is None) == (volume is None):
        raise ValueError("give exactly one of n (number of grains) and volume [m³]")
    if n is not None:
        if int(n) != n or n < 1:
            raise ValueError(f"n must be an integer >= 1, got {n!r}")
        return int(n), None
    v = float(volume)
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"volume must be finite and > 0 [m³], got {volume!r}")
    return None, v


def _diameters(name_lo, lo, name_hi, hi):
    lo, hi = float(lo), float(hi)
    if not (np.isfinite(lo) and lo > 0):
        raise ValueError(f"{name_lo} must be finite and > 0 [m], got {lo!r}")
    if not (np.isfinite(hi) and hi >= lo):
        raise ValueError(f"{name_hi} must be finite and >= {name_lo} = {lo!r} [m], got {hi!r}")
    return lo, hi


def _take(draw, n, volume, rng):
    """Draw diameters with ``draw(rng, k)`` until n grains or the solid volume is reached."""
    if n is not None:
        return 0.5 * draw(rng, n)
    out, total = [], 0.0
    while total < volume:
        d = draw(rng, 1024)
        cum = total + np.cumsum(np.pi / 6.0 * d ** 3)
        k = int(np.searchsorted(cum, volume)) + 1          # grains up to the one reaching it
        out.append(d[:k])
        total = cum[min(k, d.size) - 1]
    return 0.5 * np.concatenate(out)


def uniform(d_min: float, d_max: float, *, n: int | None = None, volume: float | None = None,
            weighting: str = "number", seed: int = 0) -> np.ndarray:
    """Radii [m] of grains whose diameter is uniform between ``d_min`` and ``d_max`` [m].

    Parameters
    ----------
    d_min, d_max : float [m], 0 < d_min <= d_max
    n : int, optional          number of grains; or
    volume : float [m³], optional  total solid volume to reach.
    weighting : {"number", "volume"}
        ``"number"``: the number of grains is uniform in d (pdf ∝ 1).  ``"volume"``: the solid
        volume is uniform in d (a straight grading curve; number pdf ∝ d⁻³).
    seed : int

    Returns
    -------
    (n,) float64 radii [m].
    """
    d_min, d_max = _diameters("d_min", d_min, "d_max", d_max)
    n, volume = _check_size(n, volume)
    if weighting == "number":
        def draw(rng, k):
            return rng.uniform(d_min, d_max, k)
    elif weighting == "volume":
        # inverse CDF of p(d) ∝ d⁻³ on [d_min, d_max]
        a, b = d_min ** -2, d_max ** -2

        def draw(rng, k):
            return (a - rng.uniform(0.0, 1.0, k) * (a - b)) ** -0.5
    else:
        raise ValueError(f"weighting must be 'number' or 'volume', got {weighting!r}")
    return _take(draw, n, volume, np.random.default_rng(seed))


def two_size(d_small: float, d_large: float, *, n: int | None = None,
             volume: float | None = None, large_volume_fraction: float = 0.5,
             seed: int = 0) -> np.ndarray:
    """Radii [m] of a binary mix: diameters ``d_small`` and ``d_large`` [m], the large grains
    making ``large_volume_fraction`` ∈ [0, 1] of the solid volume (in expectation)."""
    d_small, d_large = _diameters("d_small", d_small, "d_large", d_large)
    n, volume = _check_size(n, volume)
    f = float(large_volume_fraction)
    if not 0.0 <= f <= 1.0:
        raise ValueError(f"large_volume_fraction must be in [0, 1], got {large_volume_fraction!r}")
    # number probability of a large grain from the volume fraction
    ratio = (d_large / d_small) ** 3
    p_large = f / (f + (1.0 - f) * ratio) if f < 1.0 else 1.0

    def draw(rng, k):
        return np.where(rng.uniform(0.0, 1.0, k) < p_large, d_large, d_small)
    return _take(draw, n, volume, np.random.default_rng(seed))


def solid_volume(radii) -> float:
    """Σ 4/3 π r³ [m³]."""
    r = np.asarray(radii, dtype=float)
    return float(4.0 / 3.0 * np.pi * np.sum(r ** 3))
