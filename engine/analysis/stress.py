"""Weber (Love) average stress of a granular region, Eq. (18), split into sand and wire parts.

    σ_Ω = −(1/V_Ω) Σ_{α ∈ Ω} l^α ⊗ f^α

with f^α the mean force over the last step on body i of contact or link α and l^α its
branch vector: the inter-centre vector x_i − x_j for a sphere–sphere contact or a wire link,
x_i − x_c (centre minus contact point) for a sphere–wall contact.  The minus sign makes the
tensor **tension positive** (continuum-mechanics convention, as the paper's wire stresses):
a compressed granular region has negative principal stresses and a positive mean pressure
p = −tr σ / 3.  A contact belongs to Ω when its contact point does, a link when the
midpoint of its two beads does.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import SPHERE

PARTS = ("all", "sand", "wire")


@dataclass(frozen=True)
class StressResult:
    """Average stress of a region.

    Attributes
    ----------
    tensor : (3, 3) [Pa]  tension positive.
    volume : float [m³]
    n_contacts, n_links : int   contributions counted.
    principal : (3,) [Pa]  principal stresses, descending.
    directions : (3, 3)  unit principal directions as columns, in the order of ``principal``.
    mean_pressure : float [Pa]  p = −tr σ / 3 (> 0 in compression).
    equivalent : float [Pa]  ‖dev σ‖ (Frobenius norm of the deviator, paper Fig. 13-15).
    """

    tensor: np.ndarray
    volume: float
    n_contacts: int
    n_links: int
    principal: np.ndarray
    directions: np.ndarray
    mean_pressure: float
    equivalent: float


def equivalent_stress(sigma) -> float:
    """‖dev σ‖ [Pa]: Frobenius norm of the deviatoric part of a (3, 3) tensor."""
    s = np.asarray(sigma, dtype=float)
    dev = s - np.trace(s) / 3.0 * np.eye(3)
    return float(np.sqrt(np.sum(dev * dev)))


def principal(sigma) -> tuple[np.ndarray, np.ndarray]:
    """Principal values (descending) and directions (columns) of the symmetric part."""
    s = np.asarray(sigma, dtype=float)
    w, v = np.linalg.eigh(0.5 * (s + s.T))
    order = np.argsort(w)[::-1]
    return w[order], v[:, order]


def _sample_box_volume(model, state) -> float:
    ids = model.sphere_ids
    r = model.body_radius[ids][:, None]
    p = state.position[ids]
    return float(np.prod((p + r).max(axis=0) - (p - r).min(axis=0)))


def weber_stress(model, state, *, region=None, part: str = "all") -> StressResult:
    """Weber stress (Eq. 18) of ``region`` from the contacts and links of the last step.

    Parameters
    ----------
    region : Box, Cylinder, Sphere or TorusCell (:mod:`engine.prep.containers`), optional
        Averaging domain and its volume; default: the bounding box of the spheres.
    part : "all" | "sand" | "wire"
        Contacts and links, contacts only, or wire links only (tension positive).

    Raises
    ------
    ValueError
        Unknown ``part``, no step run yet, or a region holding no sphere centre (outside the
        sample).
    """
    if part not in PARTS:
        raise ValueError(f"part must be one of {PARTS}, got {part!r}")
    h = state.last_dt
    if not h:
        raise ValueError("weber_stress needs the forces of a step: run at least one step first")
    if region is None:
        volume = _sample_box_volume(model, state)
        inside = lambda pts: np.ones(len(pts), bool)  # noqa: E731
    else:
        volume = float(region.volume)
        inside = region.contains
        if not inside(state.position[model.sphere_ids]).any():
            raise ValueError(f"region {region!r} contains no sphere centre: it lies outside "
                             "the sample")
    sigma = np.zeros((3, 3))
    n_c = n_l = 0
    x = state.position
    if part in ("all", "sand"):
        c = state.contacts
        if len(c):
            sel = inside(c.point)
            i, j = c.i[sel], c.j[sel]
            wall = model.body_kind[j] != SPHERE
            branch = x[i] - np.where(wall[:, None], c.point[sel], x[j])
            sigma -= np.einsum("ka,kb->ab", branch, c.force[sel])
            n_c = int(sel.sum())
    if part in ("all", "wire") and model.n_links:
        li, lj = model.link_i, model.link_j
        sel = inside(0.5 * (x[li] + x[lj]))
        branch = x[li[sel]] - x[lj[sel]]
        tension = state.link_impulse[sel] / h
        # force on i: −T n (n from j to i, at the step's predicted configuration)
        force_i = -tension[:, None] * state.link_normal[sel]
        sigma -= np.einsum("ka,kb->ab", branch, force_i)
        n_l = int(sel.sum())
    sigma /= volume
    w, v = principal(sigma)
    return StressResult(tensor=sigma, volume=volume, n_contacts=n_c, n_links=n_l, principal=w,
                        directions=v, mean_pressure=float(-np.trace(sigma) / 3.0),
                        equivalent=equivalent_stress(sigma))
