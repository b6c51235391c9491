"""Units chosen for reading: a value range in SI shown with a prefix (mN, µm/s, kPa).

::

    scale, label = reading_unit("N", 6.3e-4)     # (1e3, "mN"): show values × 1e3 in mN
    reading_unit("m/s", 2e-5)                    # (1e6, "µm/s")
    reading_unit("Pa", 1.5e4)                    # (1e-3, "kPa")

The prefix is the one that puts the largest magnitude of the range between 1 and 1000
(the values read 1 to 999 on a colour bar or an axis).  Units without a prefix family
(``-``, ``rad/s``, ``J``, codes) are left as they are.  One place for the viewer
(:mod:`workbench.view`) and the pictures: the same field reads the same everywhere.
"""
from __future__ import annotations

import math

__all__ = ["reading_unit", "PREFIXED"]

_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"),
             (1e-9, "n"))

#: SI units that take a prefix here (the rest are shown as they are).
PREFIXED = ("N", "Pa", "m", "m/s", "J", "N s")


def reading_unit(unit: str, magnitude: float) -> tuple[float, str]:
    """(factor, label): values [``unit``] times ``factor`` read in ``label``, chosen so that
    ``magnitude`` (the largest absolute value shown) reads between 1 and 1000.  A unit not
    in :data:`PREFIXED`, or a magnitude of 0 or not finite, gives (1.0, unit)."""
    if unit not in PREFIXED:
        return 1.0, unit
    m = abs(float(magnitude))
    if not math.isfinite(m) or m == 0.0:
        return 1.0, unit
    for value, prefix in _PREFIXES:
        if m >= value * 0.9995:          # 999.6 mN reads "1 N", not "999.6 mN"
            return 1.0 / value, prefix + unit
    value, prefix = _PREFIXES[-1]
    return 1.0 / value, prefix + unit
