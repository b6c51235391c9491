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
    """Total force [N] exerted **on** each wall by the spheres over the last step, (n, 3):
    the opposite of the sphere–wall impulses, divided by the step length (zeros before the
    first step).

    ``walls``: body ids (default: every wall, in ``model.wall_ids`` order).  Used by the
    experiments and by :class:`engine.io.History` (its ``wall_force`` records).
    """
    walls = model.wall_ids if walls is None else np.atleast_1d(np.asarray(walls))
    out = np.zeros((len(walls), 3))
    c = state.contacts_buf
    if not state.last_dt or c.count == c.n_pair:
        return out
    a = slice(c.n_pair, c.count)  # sphere–wall contacts come after the sphere–sphere ones
    fr, p = c.frame[a], c.impulse[a]
    glob = p[:, 0:1] * fr[:, 0:3] + p[:, 1:2] * fr[:, 3:6] + p[:, 2:3] * fr[:, 6:9]
    slot = np.full(model.n_bodies, -1, np.int64)
    slot[walls] = np.arange(len(walls))
    k = slot[c.j[a]]
    on = k >= 0
    np.add.at(out, k[on], -glob[on] / state.last_dt)
    return out


def wall_stress(model, state, walls, areas) -> np.ndarray:
    """Normal stress [Pa] the spheres exert on each plane wall: (force on the wall · its
    normal) / area, **compression positive** (the usual sign for boundary pressures).

    ``areas``: (n,) [m²], the walls' current areas.
    """
    walls = np.atleast_1d(np.asarray(walls))
    areas = np.broadcast_to(np.asarray(areas, dtype=float), walls.shape)
    if np.any(~np.isfinite(areas) | (areas <= 0)):
        raise ValueError(f"areas must be finite and > 0 m², got {areas.tolist()}")
    f = wall_forces(model, state, walls)
    # the spheres push a wall against its normal (which points towards them)
    return -np.einsum("kd,kd->k", f, model.body_axis[walls]) / areas


def box_strain(ref_lengths, lengths) -> dict:
    """Strains of a box sample from its edge lengths (e.g. distances between opposite walls).

    Parameters
    ----------
    ref_lengths, lengths : (3,) [m]

    Returns
    -------
    dict with ``strain`` (3,) [-] ΔL/L₀ (extension positive), ``axial`` [-] (= strain[2]),
    ``volumetric`` [-] V/V₀ − 1.
    """
    l0 = np.asarray(ref_lengths, dtype=float)
    l1 = np.asarray(lengths, dtype=float)
    if l0.shape != (3,) or l1.shape != (3,) or np.any(l0 <= 0) or np.any(l1 <= 0):
        raise ValueError(f"ref_lengths and lengths must be 3 positive lengths [m], got {l0}, {l1}")
    e = l1 / l0 - 1.0
    return dict(strain=e, axial=float(e[2]), volumetric=float(np.prod(l1) / np.prod(l0) - 1.0))


def cylinder_strain(model, ref_positions, positions, *, center=(0.0, 0.0), n_sectors: int = 16,
                    n_layers: int = 8) -> dict:
    """Axial, radial and volumetric strains of a cylindrical sample from its outer particles.

    The height is the extent of the sphere tops and bottoms; the radius is the mean, over
    angular sectors × height layers, of the outermost sphere edge ‖x − axis‖ + r (a discrete
    outer envelope).  Extension positive.  Returns a dict with ``axial``, ``radial`` and
    ``volumetric`` [-] ((1+ε_r)²(1+ε_z) − 1) and the measured ``height`` and ``radius`` [m].
    """
    ids = model.sphere_ids
    rad = model.body_radius[ids]

    def measure(x):
        x = np.asarray(x, dtype=float)[ids]
        z0, z1 = (x[:, 2] - rad).min(), (x[:, 2] + rad).max()
        d = np.hypot(x[:, 0] - center[0], x[:, 1] - center[1]) + rad
        sec = ((np.arctan2(x[:, 1] - center[1], x[:, 0] - center[0]) + np.pi)
               / (2 * np.pi) * n_sectors).astype(int) % n_sectors
        lay = np.clip(((x[:, 2] - z0) / (z1 - z0) * n_layers).astype(int), 0, n_layers - 1)
        env = np.full((n_sectors, n_layers), np.nan)
        np.fmax.at(env, (sec, lay), d)
        return z1 - z0, float(np.nanmean(env))

    h0, r0 = measure(ref_positions)
    h1, r1 = measure(positions)
    ez, er = h1 / h0 - 1.0, r1 / r0 - 1.0
    return dict(axial=float(ez), radial=float(er), volumetric=float((1 + er) ** 2 * (1 + ez) - 1),
                height=float(h1), radius=float(r1))
