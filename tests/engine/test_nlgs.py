"""NLGS solution satisfies Signorini + Coulomb at every contact (Eq. 5-6) at convergence."""
import numpy as np
import pytest

from engine import Scene, laws, run
from tests.helpers import G, lattice_pile


def _local_velocities(model, state):
    """End-of-step relative velocity u = H^T v in each contact frame (n, t, s)."""
    c = state.contacts_buf
    k = c.count
    i, j = c.i[:k], c.j[:k]
    fr = c.frame[:k]
    n, t, s = fr[:, 0:3], fr[:, 3:6], fr[:, 6:9]
    v = state.vel6
    dv = v[i, :3] - v[j, :3]
    om = c.ri[:k, None] * v[i, 3:] + c.rj[:k, None] * v[j, 3:]
    # u = Δv + ω_i × (-r_i n) - ω_j × (r_j n) = Δv - Ω × n
    u = dv - np.cross(om, n)
    return np.stack([(u * n).sum(1), (u * t).sum(1), (u * s).sum(1)], axis=1)


@pytest.mark.parametrize("mu", [0.0, 0.3, 1.0])
def test_converged_step_satisfies_signorini_and_coulomb(theta, mu):
    rng = np.random.default_rng(11)
    pts, radii = lattice_pile(150, 1e-3, rng, ((0, 0, 0), (10e-3, 10e-3, 0.1)))
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, radii, density=2650.0)
    s.add_box((0, 0, 0), (10e-3, 10e-3, 0.1), group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=mu))
    s.interact("sand", "wall", laws.Coulomb(mu=mu))
    model, state = s.compile(dt=2e-4, theta=theta, tol=1e-10, max_iter=20000)
    summary = run(model, state, 150, progress=False)  # dynamic: impacts and sliding
    assert not summary.non_converged
    c = state.contacts_buf
    k = c.count
    p = c.impulse[:k]
    u = _local_velocities(model, state)
    un = u[:, 0] + c.gterm[:k]
    vscale = G * model.options.dt  # velocity scale of one step of gravity
    pscale = p[:, 0].max()
    assert k > 100 and pscale > 0
    assert p[:, 0].min() >= 0.0  # no adhesion
    assert un.min() > -1e-6 * vscale  # no approach beyond the gap
    assert np.abs(un * p[:, 0]).max() < 1e-6 * vscale * pscale  # complementarity
    pt = np.hypot(p[:, 1], p[:, 2])
    assert np.all(pt <= mu * p[:, 0] * (1 + 1e-12) + 1e-15 * pscale)  # inside the cone
    sliding = pt > 0.999999 * mu * p[:, 0]
    ut = u[:, 1:]
    stick = (~sliding) & (p[:, 0] > 1e-6 * pscale)
    assert np.abs(ut[stick]).max(initial=0) < 1e-6 * vscale
    slide = sliding & (np.hypot(ut[:, 0], ut[:, 1]) > 1e-6 * vscale) & (p[:, 0] > 0)
    if mu > 0 and slide.any():  # friction opposes the slip: p_T = -λ u_T
        cosang = -(ut[slide] * p[slide, 1:]).sum(1) / (np.hypot(*ut[slide].T) * pt[slide])
        assert cosang.min() > 1 - 1e-6


def test_residual_is_the_quad_norm_and_decreases():
    """Sweeping more lowers the Quad residual; tol sets the work."""
    rng = np.random.default_rng(5)
    pts, radii = lattice_pile(150, 1e-3, rng, ((0, 0, 0), (10e-3, 10e-3, 0.1)))
    iters = {}
    for tol in (1e-3, 1e-6):
        s = Scene(gravity=(0, 0, -G))
        s.add_spheres(pts, radii, density=2650.0)
        s.add_box((0, 0, 0), (10e-3, 10e-3, 0.1), group="wall")
        s.interact("sand", "sand", laws.Coulomb(mu=0.5))
        s.interact("sand", "wall", laws.Coulomb(mu=0.5))
        model, state = s.compile(dt=2e-4, tol=tol, max_iter=100000)
        summary = run(model, state, 100, progress=False)
        assert not summary.non_converged and summary.max_residual < tol
        iters[tol] = summary.mean_iterations
    assert iters[1e-6] > 2 * iters[1e-3]
