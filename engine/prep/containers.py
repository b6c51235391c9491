"""Small value objects for containers and analysis regions: Box, Cylinder, Sphere, TorusCell.

Each has ``volume`` [m³] and ``contains(points) -> (n,) bool`` (boundary included).  The same
objects describe where a sample is built (sample preparation) and where an average is taken
(:func:`engine.analysis.weber_stress`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _vec(v, name):
    a = np.asarray(v, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be 3 finite numbers, got {v!r}")
    return a


def _pos(v, name):
    v = float(v)
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be finite and > 0 [m], got {v!r}")
    return v


@dataclass(frozen=True)
class Box:
    """Axis-aligned box [lo, hi] [m]."""

    lo: tuple
    hi: tuple

    def __post_init__(self):
        lo, hi = _vec(self.lo, "lo"), _vec(self.hi, "hi")
        if np.any(hi <= lo):
            raise ValueError(f"Box needs hi > lo on every axis, got lo={lo.tolist()}, hi={hi.tolist()}")
        object.__setattr__(self, "lo", tuple(lo))
        object.__setattr__(self, "hi", tuple(hi))

    @property
    def volume(self) -> float:
        return float(np.prod(np.subtract(self.hi, self.lo)))

    def contains(self, p) -> np.ndarray:
        p = np.atleast_2d(p)
        return np.all((p >= self.lo) & (p <= self.hi), axis=1)

    def shrunk(self, margin: float) -> "Box":
        """The box of the points at distance >= ``margin`` [m] from every face."""
        m = float(margin)
        return Box(np.add(self.lo, m), np.subtract(self.hi, m))

    def bounds(self):
        """(lo, hi) of the bounding box [m]."""
        return np.array(self.lo), np.array(self.hi)


@dataclass(frozen=True)
class Cylinder:
    """Vertical cylinder of ``radius`` and ``height`` [m]; ``center`` is the centre of its
    base (as in :meth:`engine.Scene.add_cylinder`), the axis is +z."""

    radius: float
    height: float
    center: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        object.__setattr__(self, "radius", _pos(self.radius, "radius"))
        object.__setattr__(self, "height", _pos(self.height, "height"))
        object.__setattr__(self, "center", tuple(_vec(self.center, "center")))

    @property
    def volume(self) -> float:
        return float(np.pi * self.radius ** 2 * self.height)

    def contains(self, p) -> np.ndarray:
        d = np.atleast_2d(p) - self.center
        return (np.hypot(d[:, 0], d[:, 1]) <= self.radius) & (d[:, 2] >= 0) & (d[:, 2] <= self.height)

    def shrunk(self, margin: float) -> "Cylinder":
        """The cylinder of the points at distance >= ``margin`` [m] from its side, base and top."""
        m = float(margin)
        return Cylinder(self.radius - m, self.height - 2 * m, np.add(self.center, (0, 0, m)))

    def bounds(self):
        c = np.array(self.center)
        return c - (self.radius, self.radius, 0.0), c + (self.radius, self.radius, self.height)


@dataclass(frozen=True)
class Sphere:
    """Ball of ``radius`` [m] around ``center`` [m]."""

    radius: float
    center: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        object.__setattr__(self, "radius", _pos(self.radius, "radius"))
        object.__setattr__(self, "center", tuple(_vec(self.center, "center")))

    @property
    def volume(self) -> float:
        return float(4.0 / 3.0 * np.pi * self.radius ** 3)

    def contains(self, p) -> np.ndarray:
        return np.linalg.norm(np.atleast_2d(p) - self.center, axis=1) <= self.radius

    def shrunk(self, margin: float) -> "Sphere":
        return Sphere(self.radius - float(margin), self.center)

    def bounds(self):
        c = np.array(self.center)
        return c - self.radius, c + self.radius


@dataclass(frozen=True)
class TorusCell:
    """Cell of revolution about the vertical axis through ``center``: r_in <= r <= r_out,
    z_lo <= z − center_z <= z_hi [m] (a torus cell of the toroidal maps, paper Fig. 13c)."""

    r_in: float
    r_out: float
    z_lo: float
    z_hi: float
    center: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        if not (0 <= self.r_in < self.r_out) or not (self.z_lo < self.z_hi):
            raise ValueError(f"TorusCell needs 0 <= r_in < r_out and z_lo < z_hi, got "
                             f"r=({self.r_in}, {self.r_out}), z=({self.z_lo}, {self.z_hi})")
        object.__setattr__(self, "center", tuple(_vec(self.center, "center")))

    @property
    def volume(self) -> float:
        return float(np.pi * (self.r_out ** 2 - self.r_in ** 2) * (self.z_hi - self.z_lo))

    def contains(self, p) -> np.ndarray:
        d = np.atleast_2d(p) - self.center
        r = np.hypot(d[:, 0], d[:, 1])
        return (r >= self.r_in) & (r <= self.r_out) & (d[:, 2] >= self.z_lo) & (d[:, 2] <= self.z_hi)
