"""Siconos's natural-map residual of a solved step, beside our Quad norm (issue 31 §2).

The NLGS stops on the Quad norm (:mod:`engine.solver.nlgs`): an *increment* norm, the
change of the impulses in the last sweep weighted by the Delassus diagonal, relative to
the impulses, as LMGC90's.  Siconos stops on the *natural-map* residual of
``fc3d_compute_error``: how far the pair (impulse r, local velocity u) is from satisfying
Signorini + Coulomb, whatever the last sweep did.  For each contact α, with the modified
(De Saxcé) velocity and ρ = 1,

    e_α = r_α − P_K(r_α − (u_α + μ_α ‖u_Tα‖ e_n)),

P_K the projection on the Coulomb cone K = {‖r_T‖ <= μ r_n}; the residual is
sqrt(Σ_α ‖e_α‖²) / ‖q‖, q the local free velocity (the velocities the contacts would see
without any impulse), which is Siconos's normalisation (the error divided by the norm of
the problem's q).  In SI units (r in N s, u in m/s) the velocity terms dominate, as they do
in Siconos on the same scene.  Here u_n and q_n include the gap term max(g_m, 0)/h of
:func:`engine.solver.local.coulomb` (our Signorini condition is on u_n + max(g_m, 0)/h),
and with compliant contacts (``Options.contact_compliance`` ε > 0) u_n holds g_m/h and
ε W_nn r_n, as the sweeps' law does.
Contacts between two immobile bodies are left out; so are wire links (Siconos's deposit has
none).

It costs one pass over the contacts (about a sweep), so it is computed only when asked:
``Options.natural_residual`` (``Scene.compile(..., natural_residual=True)``) puts it in
each step's :class:`engine.state.StepStats` and in the histories' ``natural_residual``
record.
"""
from __future__ import annotations

import math

from numba import njit

from .kernels import local_velocity

__all__ = ["natural_residual", "natural_map"]


@njit(cache=True, inline="always")
def _local(a, c_i, c_j, frame, ri, rj, vel6):
    """Local velocity (n, t, s) of contact ``a`` from the body velocities (the sweep's
    :func:`~engine.solver.kernels.local_velocity`, without the gap term)."""
    return local_velocity(c_i[a], c_j[a], ri[a], rj[a], frame[a, 0], frame[a, 1], frame[a, 2],
                          frame[a, 3], frame[a, 4], frame[a, 5], frame[a, 6], frame[a, 7],
                          frame[a, 8], vel6)


@njit(cache=True)
def natural_map(n, c_i, c_j, frame, ri, rj, gterm, w, mu, impulse, vel6, free6, eps=0.0):
    """(Σ_α ‖e_α‖², Σ_α ‖q_α‖²) over the ``n`` contacts (see the module docstring):
    ``vel6`` the solved body velocities, ``free6`` the free ones, ``impulse`` (n, 3) local
    (n, t, s) [N s]; ``eps`` the contacts' normal compliance (``Options.contact_compliance``:
    u_n holds its term ε W_nn p_n, as the sweeps' local law)."""
    err = 0.0
    qq = 0.0
    for a in range(n):
        if w[a, 0] <= 0.0:
            continue
        g = gterm[a]
        un, ut, us = _local(a, c_i, c_j, frame, ri, rj, vel6)
        un += g + eps * w[a, 0] * impulse[a, 0]
        fn, ft, fs = _local(a, c_i, c_j, frame, ri, rj, free6)
        fn += g
        qq += fn * fn + ft * ft + fs * fs
        m = mu[a]
        rn = impulse[a, 0]
        rt = impulse[a, 1]
        rs = impulse[a, 2]
        x0 = rn - (un + m * math.sqrt(ut * ut + us * us))
        x1 = rt - ut
        x2 = rs - us
        nt = math.sqrt(x1 * x1 + x2 * x2)
        if nt <= m * x0:                 # inside the cone
            y0, y1, y2 = x0, x1, x2
        elif m * nt <= -x0:              # inside the polar cone
            y0, y1, y2 = 0.0, 0.0, 0.0
        else:                            # onto the cone's surface
            y0 = (x0 + m * nt) / (1.0 + m * m)
            f = m * y0 / nt
            y1 = f * x1
            y2 = f * x2
        err += (rn - y0) ** 2 + (rt - y1) ** 2 + (rs - y2) ** 2
    return err, qq


def natural_residual(model, state, free6) -> float:
    """The natural-map residual of the step just solved (the contacts of
    ``state.contacts_buf`` and ``state.vel6``), ``free6`` the step's free velocities
    (nb, 6); 0 when there is nothing to solve (no contact, or q = 0)."""
    c = state.contacts_buf
    err, qq = natural_map(c.count, c.i, c.j, c.frame, c.ri, c.rj, c.gterm, c.w, c.mu,
                          c.impulse, state.vel6, free6, model.options.contact_compliance)
    if qq <= 0.0:
        return 0.0 if err == 0.0 else math.inf
    return math.sqrt(err) / math.sqrt(qq)
