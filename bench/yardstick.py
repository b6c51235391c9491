"""The yardstick: a minimal, tight numba NLGS sweep that ``engine.solver.nlgs.sweep`` is
compared with (bench/bench_core.py).

Same problem, same arrays: a scalar-only frictional Gauss–Seidel sweep (Signorini +
3D Coulomb with a diagonal Delassus block, De Saxcé projection) with body-velocity updates
(translation + rotation) on the engine's contact buffers (i, j, frame n/t/s, Delassus
diagonals w, gap terms, μ, lever arms, impulses) and on ``vel6``.  It also accumulates the
two sums of the "Quad" convergence norm, which any real NLGS needs.

What it leaves out, on purpose (features of the production kernel, not of the method):
LINE walls (pressure/force-driven planes), the relaxation ω, and the skip of contacts
between two immobile bodies.  Body data are two contiguous 1D arrays, inverse mass and
inverse inertia (0 for fixed walls).  The impulse is the same as the production kernel's
up to rounding (p_T = p_T0 - u_T / w_t instead of -(u_T - w_t p_T0) / w_t).
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def yard_sweep(n, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse, inv_m, inv_i, vel6):
    """One Gauss–Seidel sweep over ``n`` contacts; returns (Σ‖WΔp‖², Σ‖Wp‖²)."""
    num = 0.0
    den = 0.0
    for a in range(n):
        i = c_i[a]
        j = c_j[a]
        nx = frame[a, 0]
        ny = frame[a, 1]
        nz = frame[a, 2]
        tx = frame[a, 3]
        ty = frame[a, 4]
        tz = frame[a, 5]
        sx = frame[a, 6]
        sy = frame[a, 7]
        sz = frame[a, 8]
        wn = w[a, 0]
        wt = w[a, 1]
        r_i = ri[a]
        r_j = rj[a]
        pn0 = impulse[a, 0]
        pt0 = impulse[a, 1]
        ps0 = impulse[a, 2]
        # relative velocity at the contact: Δv and Ω = r_i ω_i + r_j ω_j
        dvx = vel6[i, 0] - vel6[j, 0]
        dvy = vel6[i, 1] - vel6[j, 1]
        dvz = vel6[i, 2] - vel6[j, 2]
        ox = r_i * vel6[i, 3] + r_j * vel6[j, 3]
        oy = r_i * vel6[i, 4] + r_j * vel6[j, 4]
        oz = r_i * vel6[i, 5] + r_j * vel6[j, 5]
        fn = nx * dvx + ny * dvy + nz * dvz - wn * pn0 + gterm[a]
        if fn < 0.0:
            iwt = 1.0 / wt
            pn = -fn / wn
            pt = pt0 - (tx * dvx + ty * dvy + tz * dvz - (sx * ox + sy * oy + sz * oz)) * iwt
            ps = ps0 - (sx * dvx + sy * dvy + sz * dvz + (tx * ox + ty * oy + tz * oz)) * iwt
            lim = mu[a] * pn
            nt2 = pt * pt + ps * ps
            if nt2 > lim * lim:
                sc = lim / np.sqrt(nt2)
                pt *= sc
                ps *= sc
        else:
            pn = 0.0
            pt = 0.0
            ps = 0.0
        impulse[a, 0] = pn
        impulse[a, 1] = pt
        impulse[a, 2] = ps
        dpn = pn - pn0
        dpt = pt - pt0
        dps = ps - ps0
        num += (wn * dpn) ** 2 + (wt * dpt) ** 2 + (wt * dps) ** 2
        den += (wn * pn) ** 2 + (wt * pt) ** 2 + (wt * ps) ** 2
        # impulse change on i (+P) and j (-P); rotation: ω += -r/I (Δp_t s - Δp_s t)
        px = dpn * nx + dpt * tx + dps * sx
        py = dpn * ny + dpt * ty + dps * sy
        pz = dpn * nz + dpt * tz + dps * sz
        qx = dpt * sx - dps * tx
        qy = dpt * sy - dps * ty
        qz = dpt * sz - dps * tz
        mi = inv_m[i]
        ci = -r_i * inv_i[i]
        mj = inv_m[j]
        cj = -r_j * inv_i[j]
        vel6[i, 0] += mi * px
        vel6[i, 1] += mi * py
        vel6[i, 2] += mi * pz
        vel6[i, 3] += ci * qx
        vel6[i, 4] += ci * qy
        vel6[i, 5] += ci * qz
        vel6[j, 0] -= mj * px
        vel6[j, 1] -= mj * py
        vel6[j, 2] -= mj * pz
        vel6[j, 3] += cj * qx
        vel6[j, 4] += cj * qy
        vel6[j, 5] += cj * qz
    return num, den


def body_inverses(body_dyn) -> tuple[np.ndarray, np.ndarray]:
    """Contiguous inverse mass and inverse inertia columns of ``model.body_dyn``."""
    from engine.model import DYN_INV_INERTIA, DYN_INV_MASS

    return (np.ascontiguousarray(body_dyn[:, DYN_INV_MASS]),
            np.ascontiguousarray(body_dyn[:, DYN_INV_INERTIA]))


__all__ = ["yard_sweep", "body_inverses"]
