"""Contact-force network statistics and boundary measures (paper §3.2: strong and weak
networks, "the properties of force magnitude distribution")."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import SPHERE


@dataclass(frozen=True)
class ForceNetwork:
    """Sphere–sphere normal-force network of the last step.

    Attributes
    ----------
    i, j : (k,) int32      the contacts carrying a force (f_n > 0).
    normal_force : (k,) [N]
    mean_force : float [N]  ⟨f_n⟩ over those contacts.
    strong : (k,) bool      f_n > ⟨f_n⟩ (the strong network).
    pdf_edges, pdf : (nb+1,), (nb,)  probability density of f_n/⟨f_n⟩ (integrates to 1).
    coordination : float    z = 2 k / N over the N spheres (rattlers included).
    coordination_no_rattlers : float  the same over spheres with >= 2 force-carrying contacts.
    """

    i: np.ndarray
    j: np.ndarray
    normal_force: np.ndarray
    mean_force: float
    strong: np.ndarray
    pdf_edges: np.ndarray
    pdf: np.ndarray
    coordination: float
    coordination_no_rattlers: float


def force_network(model, state, *, bins: int = 20, max_ratio: float = 5.0) -> ForceNetwork:
    """Strong network, f/⟨f⟩ distribution and coordination number of sphere–sphere contacts.

    Raises ``ValueError`` when no sphere–sphere contact carries a force.
    """
    c = state.contacts
    sel = (model.body_kind[c.j] == SPHERE) & (c.impulse[:, 0] > 0) if len(c) else np.zeros(0, bool)
    if not np.any(sel):
        raise ValueError("force_network: no sphere–sphere contact carries a force (run steps first)")
    fn = c.normal_force[sel]
    i, j = c.i[sel], c.j[sel]
    mean = float(fn.mean())
    pdf, edges = np.histogram(fn / mean, bins=bins, range=(0.0, max_ratio), density=False)
    pdf = pdf / (fn.size * np.diff(edges))
    ns = model.n_spheres
    deg = np.bincount(np.concatenate([i, j]), minlength=model.n_bodies)[model.sphere_ids]
    keep = deg >= 2
    return ForceNetwork(i=i, j=j, normal_force=fn, mean_force=mean, strong=fn > mean,
                        pdf_edges=edges, pdf=pdf, coordination=2.0 * fn.size / ns,
                        coordination_no_rattlers=float(deg[keep].sum() / keep.sum()) if keep.any() else 0.0)


def wall_forces(model, state, walls=None) -> np.ndarray:
    """Total force [N] exerted **on** each wall by the spheres over the last step, (n, 3).

    ``walls``: body ids (default: every wall, in ``model.wall_ids`` order).
    """
    walls = model.wall_ids if walls is None else np.atleast_1d(np.asarray(walls))
    out = np.zeros((len(walls), 3))
    c = state.contacts
    if len(c):
        f = c.force
        for k, w in enumerate(walls):
            out[k] = -f[c.j == w].sum(axis=0)
    return out
