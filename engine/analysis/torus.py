"""Toroidal maps: tensor averages on torus cells of a cylindrical sample (paper Fig. 13c)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..prep.containers import Cylinder
from .stress import equivalent_stress, weber_stress


@dataclass(frozen=True)
class ToroidalMap:
    """Weber stress on (r, z) torus cells around the cylinder axis.

    Attributes
    ----------
    r_edges : (n_r+1,) [m] ; z_edges : (n_z+1,) [m] (relative to the cylinder base)
    stress : (n_r, n_z, 3, 3) [Pa]  NaN in cells holding no sphere centre.
    equivalent : (n_r, n_z) [Pa]     ‖dev σ‖ per cell.
    volume : (n_r, n_z) [m³]
    """

    r_edges: np.ndarray
    z_edges: np.ndarray
    stress: np.ndarray
    equivalent: np.ndarray
    volume: np.ndarray

    def slab_stress(self) -> np.ndarray:
        """(n_z, 3, 3) [Pa]: the Weber stress of each horizontal slab of the map (all its
        r cells together), i.e. the volume-weighted mean of its cells' tensors, an empty cell
        counting zero.  Eq. (18) sums over the particles of a region, so this equals
        :func:`weber_stress` on the slab itself.  A slab holds n_r times the particles of a
        cell: on small samples, where most cells hold a few beads, its profile along z is the
        steadier reading of where the wire works (Fig. 13c)."""
        s = np.where(np.isfinite(self.stress), self.stress, 0.0)
        w = self.volume[:, :, None, None]
        return (s * w).sum(axis=0) / self.volume.sum(axis=0)[:, None, None]

    def slab_equivalent(self) -> np.ndarray:
        """(n_z,) [Pa]: ‖dev σ‖ of each slab's stress (:meth:`slab_stress`)."""
        return np.array([equivalent_stress(t) for t in self.slab_stress()])


def toroidal_map(model, state, cylinder: Cylinder, *, n_r: int = 5, n_z: int = 10,
                 part: str = "wire") -> ToroidalMap:
    """Weber stress (Eq. 18, ``part`` "wire", "sand" or "all") on n_r × n_z torus cells
    tiling ``cylinder`` (equal widths in r and z)."""
    from ..prep.containers import TorusCell

    if int(n_r) < 1 or int(n_z) < 1:
        raise ValueError(f"n_r and n_z must be >= 1, got {n_r}, {n_z}")
    r_edges = np.linspace(0.0, cylinder.radius, int(n_r) + 1)
    z_edges = np.linspace(0.0, cylinder.height, int(n_z) + 1)
    stress = np.full((n_r, n_z, 3, 3), np.nan)
    eq = np.full((n_r, n_z), np.nan)
    vol = np.zeros((n_r, n_z))
    for a in range(n_r):
        for b in range(n_z):
            cell = TorusCell(r_edges[a], r_edges[a + 1], z_edges[b], z_edges[b + 1],
                             center=cylinder.center)
            vol[a, b] = cell.volume
            try:
                s = weber_stress(model, state, region=cell, part=part).tensor
            except ValueError:  # no sphere centre in this cell
                continue
            stress[a, b] = s
            eq[a, b] = equivalent_stress(s)
    return ToroidalMap(r_edges=r_edges, z_edges=z_edges, stress=stress, equivalent=eq, volume=vol)
