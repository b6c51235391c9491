"""Best-fit strain of a set of particles, Eq. (19) (Cambou's formulation analysed by Bagi).

With X̃ and Ũ the positions (reference configuration) and displacements relative to their
means over the set, the displacement gradient E minimising Σ ‖Ũ − E X̃‖² is

    E^T = (Σ X̃ ⊗ X̃)⁻¹ (Σ X̃ ⊗ Ũ)                                       (Eq. 19)

and the (small) strain is its symmetric part ε = (E + E^T)/2.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .stress import principal


@dataclass(frozen=True)
class StrainResult:
    """Best-fit strain of a particle set.

    Attributes
    ----------
    gradient : (3, 3) [-]  best-fit displacement gradient E (Ũ ≈ E X̃).
    tensor : (3, 3) [-]    strain ε = sym(E), extension positive.
    principal : (3,) [-]   principal strains, descending; ``directions`` (3, 3) as columns.
    volumetric : float [-] tr ε.
    deviatoric : (3, 3) [-] ε − tr ε / 3 I.
    n : int                particles used.
    """

    gradient: np.ndarray
    tensor: np.ndarray
    principal: np.ndarray
    directions: np.ndarray
    volumetric: float
    deviatoric: np.ndarray
    n: int


def best_fit_strain(ref_positions, positions, ids=None, *, rcond: float = 1e-10) -> StrainResult:
    """Eq. (19) on particles ``ids`` (default: all rows) between two configurations.

    Parameters
    ----------
    ref_positions, positions : (n, 3) [m]
        Centres in the reference and current configurations (e.g. ``state.position`` copies).
    ids : int array, optional
        Rows to use (sand, wire beads, or all).
    rcond : float
        The set is refused when the smallest eigenvalue of Σ X̃ ⊗ X̃ is below ``rcond`` times
        the largest (coplanar, collinear or too few particles).

    Raises
    ------
    ValueError
        Shapes differ, non-finite positions, fewer than 4 particles, or a degenerate
        (coplanar) set: the message names the rank found.
    """
    x0 = np.asarray(ref_positions, dtype=float)
    x1 = np.asarray(positions, dtype=float)
    if x0.shape != x1.shape or x0.ndim != 2 or x0.shape[1] != 3:
        raise ValueError(f"ref_positions and positions must both be (n, 3), got {x0.shape} and {x1.shape}")
    if ids is not None:
        ids = np.asarray(ids)
        x0, x1 = x0[ids], x1[ids]
    n = x0.shape[0]
    if n < 4:
        raise ValueError(f"best_fit_strain needs at least 4 non-coplanar particles, got {n}")
    if not (np.isfinite(x0).all() and np.isfinite(x1).all()):
        raise ValueError("best_fit_strain: positions must be finite")
    xt = x0 - x0.mean(axis=0)
    ut = (x1 - x0) - (x1 - x0).mean(axis=0)
    a = xt.T @ xt  # Σ X̃ ⊗ X̃
    ev = np.linalg.eigvalsh(a)
    if ev[0] <= rcond * ev[-1]:
        rank = int(np.sum(ev > rcond * ev[-1]))
        raise ValueError(f"best_fit_strain needs at least 4 non-coplanar particles: the {n} "
                         f"given span a space of rank {rank} < 3")
    et = np.linalg.solve(a, xt.T @ ut)  # Eq. (19): E^T
    grad = et.T
    eps = 0.5 * (grad + grad.T)
    w, v = principal(eps)
    tr = float(np.trace(eps))
    return StrainResult(gradient=grad, tensor=eps, principal=w, directions=v, volumetric=tr,
                        deviatoric=eps - tr / 3.0 * np.eye(3), n=n)
