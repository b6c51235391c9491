"""Local solvers: one small function per law (jax-md style), called by the NLGS sweep.

Each takes the local free velocity of its contact or link (the relative velocity that the
other contacts, links and external forces give, without its own impulse) and the inverse
of the diagonal of its Delassus block, and returns the impulse that satisfies the law
exactly: :func:`coulomb` for the contacts (:func:`engine.solver.kernels._contact`),
:func:`rod` and :func:`wire` for the four wire link laws
(:func:`engine.solver.kernels.link_update`).  Scalars in, scalars out.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def coulomb(fn, ft, fs, iwn, iwt, mu):
    """Signorini + 3D Coulomb local problem with a diagonal Delassus block.

    Solves, for the impulse p = (p_n, p_t, p_s) [N·s] and the end-of-step local velocity
    u = f + W p with W = diag(wn, wt, wt) [1/kg] (the blocks of Eq. 5 for spheres: n is
    decoupled from t, s because the lever arms are parallel to n):

    * Signorini (Eq. 6 with the gap term folded into ``fn``):
      0 <= u_n + max(g_m, 0)/h ⊥ p_n >= 0, with g_m the gap at the θ-predicted
      configuration q_m = q_i + (1-θ) h v_i.  This keeps the next predicted gap
      g_m + h u_n >= 0 and the end-of-step gap g_m + θ h u_n >= (1-θ) g_m >= 0 for every
      θ in [0.5, 1] (no penetration at impact), with no artificial restitution: an
      overlap that exists (g_m < 0) is not pushed out, only kept from growing;
    * Coulomb: ‖p_T‖ <= μ p_n, u_T = 0 if ‖p_T‖ < μ p_n, else p_T = -μ p_n u_T/‖u_T‖.

    Because W is diagonal with equal tangential entries, the exact solution is the
    De Saxcé projection with ρ = W⁻¹: p_n = max(0, -fn/wn), p_T = proj_{disk μ p_n}(-f_T/wt).

    Parameters
    ----------
    fn, ft, fs : float [m/s]
        Local free velocity (normal part includes max(g_m, 0)/h).
    iwn, iwt : float [kg]
        Inverses of the normal and tangential diagonal of W_αα.
    mu : float [-]

    Returns
    -------
    (pn, pt, ps) : floats [N·s]
    """
    if fn >= 0.0:
        return 0.0, 0.0, 0.0
    pn = -fn * iwn
    pt = -ft * iwt
    ps = -fs * iwt
    pt, ps = project_disk(pt, ps, mu * pn)
    return pn, pt, ps


@njit(cache=True, inline="always")
def project_disk(pt, ps, lim):
    """(pt, ps) projected on the disk of radius ``lim`` >= 0 (the Coulomb cone's section)."""
    nt2 = pt * pt + ps * ps
    if nt2 > lim * lim:
        scale = lim / np.sqrt(nt2)
        pt *= scale
        ps *= scale
    return pt, ps


@njit(cache=True, inline="always")
def rod(uf, stretch, iwc, lam0, relax):
    """Rigid rod (Eq. 9) and elastic rod (Eq. 11): the bilateral link laws after the change
    of variables of Eq. (8), for a link of Delassus diagonal W and compliance
    c = L/(k h²) (0 for the rigid rod):

        λ = (u_f + (g − L*)/h) / (W + c),

    any sign (tension positive), relaxed to λ0 + ω (λ − λ0).

    Parameters
    ----------
    uf : float [m/s]
        Local free velocity u + W λ0 (u = n·(v_i − v_j) the current normal velocity).
    stretch : float [m/s]
        The length term (g − L*)/h (:func:`engine.solver.kernels.lstar`).
    iwc : float [kg]
        1/(W + c).
    lam0 : float [N·s]
        The link's impulse before the update.
    relax : float [-]
        Relaxation ω (at ω = 1 the added term is exactly 0: the plain update).

    Returns
    -------
    float [N·s]
    """
    lam = (uf + stretch) * iwc
    lam += (relax - 1.0) * (lam - lam0)
    return lam


@njit(cache=True, inline="always")
def wire(uf, stretch, iwc, lam0, relax):
    """Rigid wire (Eq. 13) and elastic wire (Eq. 15): the unilateral laws, :func:`rod`'s
    λ (relaxed) projected on λ >= 0 (:func:`tension`): a wire pulls, never pushes.
    Arguments as :func:`rod`'s."""
    return tension(rod(uf, stretch, iwc, lam0, relax))


@njit(cache=True, inline="always")
def tension(lam):
    """``lam`` projected on λ >= 0 (the wires' constraint; the Coulomb cone's counterpart
    is :func:`project_disk`)."""
    if lam < 0.0:
        return 0.0
    return lam
