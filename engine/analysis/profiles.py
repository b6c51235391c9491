"""Slope profiles of a deposit (paper Fig. 10): free-surface shape h(r) averaged around the
axis, floor pressure p(r), polynomial regressions and the maximum slope angle."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SlopeProfile:
    """Axisymmetric profiles of a deposit around a vertical axis.

    Attributes
    ----------
    r : (n,) [m]             bin centres; ``r_edges`` (n+1,) [m].
    height : (n,) [m]        free-surface height above the floor (mean over angular sectors
                             of the highest sphere top), NaN in empty bins.
    pressure : (n,) [Pa]     floor normal force in each annulus / annulus area.
    height_fit, pressure_fit : np.poly1d   least-squares polynomials of h(r) and p(r).
    max_slope_deg : float    max |dh/dr| of ``height_fit`` over the occupied bins, in degrees.
    """

    r: np.ndarray
    r_edges: np.ndarray
    height: np.ndarray
    pressure: np.ndarray
    height_fit: np.poly1d
    pressure_fit: np.poly1d
    max_slope_deg: float


def slope_profile(model, state, *, floor: int, center=(0.0, 0.0), r_max: float | None = None,
                  n_bins: int = 20, n_sectors: int = 12, degree: int = 3,
                  pressure_degree: int = 3) -> SlopeProfile:
    """h(r), p(r), their regressions and the maximum slope (paper §3.1, Fig. 10).

    Parameters
    ----------
    floor : int
        Body id of the floor plane (its normal must be +z); heights are measured from it.
    center : (x, y) [m]
        The vertical axis.
    r_max : float [m]
        Outer radius of the bins (default: the farthest sphere).
    degree, pressure_degree : int
        Degrees of the regressions (paper: 1 for sand, 3 and 8 for TexSol; 3 for p).
    """
    if int(n_bins) < 2 or int(n_sectors) < 1:
        raise ValueError(f"n_bins must be >= 2 and n_sectors >= 1, got {n_bins}, {n_sectors}")
    if not np.allclose(model.body_axis[floor], (0, 0, 1)):
        raise ValueError(f"floor {floor} must be a plane with normal +z")
    ids = model.sphere_ids
    p = state.position[ids]
    rad = model.body_radius[ids]
    dx, dy = p[:, 0] - center[0], p[:, 1] - center[1]
    rr = np.hypot(dx, dy)
    r_max = float(rr.max()) if r_max is None else float(r_max)
    edges = np.linspace(0.0, r_max, int(n_bins) + 1)
    rb = np.clip(np.digitize(rr, edges) - 1, 0, n_bins - 1)
    sector = ((np.arctan2(dy, dx) + np.pi) / (2 * np.pi) * n_sectors).astype(int) % n_sectors
    top = p[:, 2] + rad - state.position[floor, 2]
    best = np.full((n_bins, n_sectors), np.nan)
    np.fmax.at(best, (rb, sector), top)
    with np.errstate(all="ignore"):
        height = np.nanmean(best, axis=1)
    centres = 0.5 * (edges[:-1] + edges[1:])
    # floor pressure from the normal forces of the floor contacts
    pressure = np.zeros(n_bins)
    if state.last_dt:
        c = state.contacts
        on = c.j == floor
        if on.any():
            cr = np.hypot(c.point[on, 0] - center[0], c.point[on, 1] - center[1])
            cb = np.clip(np.digitize(cr, edges) - 1, 0, n_bins - 1)
            np.add.at(pressure, cb, c.normal_force[on])
    pressure /= np.pi * (edges[1:] ** 2 - edges[:-1] ** 2)
    ok = np.isfinite(height)
    if ok.sum() <= degree:
        raise ValueError(f"slope_profile: {ok.sum()} occupied bins, need more than degree={degree}")
    hfit = np.poly1d(np.polyfit(centres[ok], height[ok], degree))
    pfit = np.poly1d(np.polyfit(centres, pressure, min(pressure_degree, n_bins - 1)))
    rs = np.linspace(centres[ok].min(), centres[ok].max(), 200)
    slope = float(np.degrees(np.arctan(np.abs(hfit.deriv()(rs)).max())))
    return SlopeProfile(r=centres, r_edges=edges, height=height, pressure=pressure,
                        height_fit=hfit, pressure_fit=pfit, max_slope_deg=slope)
