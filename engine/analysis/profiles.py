"""Slope profiles of a deposit (paper Fig. 10): free-surface shape h(r) averaged around the
axis, floor pressure p(r), polynomial regressions and the maximum slope angle."""
from __future__ import annotations

from dataclasses import dataclass

import warnings

import numpy as np

from ..model import SPHERE


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


def max_slope(r, height, degree: int, *, samples: int = 200) -> tuple[np.poly1d, float]:
    """The paper's maximum slope of a heap (§3.1, Fig. 10): the least-squares polynomial of
    ``degree`` through the occupied bins of h(r) (finite ``height`` [m] at the bin centres
    ``r`` [m]) and its steepest slope max |dh/dr| over them [deg], on ``samples`` radii.

    The paper fits sand with a line, TexSol(1) with a cubic and TexSol(2) with a polynomial
    of the 8th degree.  The fit is made on [-1, 1] (``numpy.polynomial.Polynomial.fit``),
    which keeps the 8th degree well conditioned at radii of millimetres; the returned
    ``np.poly1d`` is the same polynomial in r."""
    r, h = np.asarray(r, float), np.asarray(height, float)
    degree = int(degree)
    if degree < 1:
        raise ValueError(f"degree must be >= 1, got {degree}")
    ok = np.isfinite(h)
    if ok.sum() <= degree:
        raise ValueError(f"{ok.sum()} occupied bins, need more than degree={degree}")
    fit = np.polynomial.Polynomial.fit(r[ok], h[ok], degree)
    rs = np.linspace(r[ok].min(), r[ok].max(), int(samples))
    slope = float(np.degrees(np.arctan(np.abs(fit.deriv()(rs)).max())))
    return np.poly1d(fit.convert().coef[::-1]), slope


def slope_profile(model, state, *, floor, center=(0.0, 0.0), r_max: float | None = None,
                  n_bins: int = 20, n_sectors: int = 12, degree: int = 3,
                  pressure_degree: int = 3) -> SlopeProfile:
    """h(r), p(r), their regressions and the maximum slope (paper §3.1, Fig. 10).

    Parameters
    ----------
    floor : int or (k,) int
        Body id of the floor plane (its normal must be +z), or the ids of the fixed beads of
        a rough floor (the paper's "rubber plane"): heights are then measured from the top
        of the beads, the pressure comes from the contacts on them, and the beads are not
        part of the heap.
    center : (x, y) [m]
        The vertical axis.
    r_max : float [m]
        Outer radius of the bins (default: the farthest sphere).
    degree, pressure_degree : int
        Degrees of the regressions (paper: 1 for sand, 3 and 8 for TexSol; 3 for p); the
        maximum slope is :func:`max_slope`'s.
    """
    if int(n_bins) < 2 or int(n_sectors) < 1:
        raise ValueError(f"n_bins must be >= 2 and n_sectors >= 1, got {n_bins}, {n_sectors}")
    beads = np.atleast_1d(np.asarray(floor))
    if beads.size == 1 and model.body_kind[int(beads[0])] != SPHERE:
        floor = int(beads[0])
        if not np.allclose(model.body_axis[floor], (0, 0, 1)):
            raise ValueError(f"floor {floor} must be a plane with normal +z")
        base = state.position[floor, 2]
        ids = model.sphere_ids
        below = base
    else:
        base = float((state.position[beads, 2] + model.body_radius[beads]).max())
        ids = np.setdiff1d(model.sphere_ids, beads)
        below = float((state.position[beads, 2] - model.body_radius[beads]).min())
    # spheres that fell off the floor's edge are not part of the heap (one at z = -0.43 m
    # entered the outer bin and the fit gave a 89.5 deg slope)
    ids = ids[state.position[ids, 2] >= below]
    p = state.position[ids]
    rad = model.body_radius[ids]
    dx, dy = p[:, 0] - center[0], p[:, 1] - center[1]
    rr = np.hypot(dx, dy)
    r_max = float(rr.max()) if r_max is None else float(r_max)
    edges = np.linspace(0.0, r_max, int(n_bins) + 1)
    rb = np.clip(np.digitize(rr, edges) - 1, 0, n_bins - 1)
    sector = ((np.arctan2(dy, dx) + np.pi) / (2 * np.pi) * n_sectors).astype(int) % n_sectors
    top = p[:, 2] + rad - base
    best = np.full((n_bins, n_sectors), np.nan)
    np.fmax.at(best, (rb, sector), top)
    with warnings.catch_warnings():               # bins no sphere reaches: NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        height = np.nanmean(best, axis=1)
    centres = 0.5 * (edges[:-1] + edges[1:])
    # floor pressure from the normal forces of the floor contacts
    pressure = np.zeros(n_bins)
    if state.last_dt:
        c = state.contacts
        on_j, on_i = np.isin(c.j, beads), np.isin(c.i, beads)
        on = on_j ^ on_i
        if on.any():
            cr = np.hypot(c.point[on, 0] - center[0], c.point[on, 1] - center[1])
            cb = np.clip(np.digitize(cr, edges) - 1, 0, n_bins - 1)
            # vertical force on the floor (the contact force acts on i)
            fz = np.where(on_j[on], -c.force[on, 2], c.force[on, 2])
            np.add.at(pressure, cb, -fz)
    pressure /= np.pi * (edges[1:] ** 2 - edges[:-1] ** 2)
    try:
        hfit, slope = max_slope(centres, height, degree)
    except ValueError as e:
        raise ValueError(f"slope_profile: {e}") from None
    pfit = np.poly1d(np.polyfit(centres, pressure, min(pressure_degree, n_bins - 1)))
    return SlopeProfile(r=centres, r_edges=edges, height=height, pressure=pressure,
                        height_fit=hfit, pressure_fit=pfit, max_slope_deg=slope)
