"""Compliant contacts (``Options.contact_compliance``, issue 31 §2).

Facts: a contact of compliance ε is the unilateral spring of Eq. (14) with g_ref = 0 and
stiffness 1/(ε h² W_nn), so a body at rest carries the static overlap ε h² W_nn F (a
sphere on a floor: ε g h²; a column: linear in the load), for either θ, and comes to rest
in a few steps; an overlap is the spring's (pushed out) where the rigid law only keeps it
from growing; the natural-map residual holds the compliance term (0 at rest); the mould
deposit that stagnates with the rigid law converges at every step with ε = 0.01; a released
overlap is a known energy source; bad values and over-relaxation are refused in one line.
"""
from __future__ import annotations

import numpy as np
import pytest

from engine import Scene, laws, step
from engine.experiments import gravity_deposit
from engine.solver.residual import natural_map

G = 9.81


def _column(n, eps, theta=0.5, dt=1e-4, r=1e-3, natural=False):
    """``n`` equal spheres stacked on a floor, touching, at rest."""
    s = Scene(gravity=(0.0, 0.0, -G))
    s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    z = r + 2 * r * np.arange(n)
    s.add_spheres(np.stack([np.zeros(n), np.zeros(n), z], 1), np.full(n, r), density=2650.0,
                  group="sand")
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.interact("sand", "wall", laws.Coulomb(mu=0.5))
    return s.compile(dt=dt, theta=theta, tol=1e-12, max_iter=10_000, contact_compliance=eps,
                     natural_residual=natural)


@pytest.mark.parametrize("theta", [0.5, 1.0])
@pytest.mark.parametrize("eps", [0.01, 0.1])
def test_a_sphere_on_a_floor_sinks_by_eps_g_h2_and_rests(theta, eps):
    dt = 1e-4
    model, state = _column(1, eps, theta, dt)
    z0 = state.position[-1, 2]
    for _ in range(10):
        step(model, state)
    # the spring's static overlap F/k = ε h² W_nn m g = ε g h² (W_nn = 1/m on a floor)
    assert z0 - state.position[-1, 2] == pytest.approx(eps * G * dt**2, rel=1e-6)
    assert abs(state.vel6[-1, 2]) < 1e-6 * G * dt    # at rest within a few steps


def test_a_column_overlaps_in_proportion_to_the_load():
    n, eps, dt = 5, 0.02, 1e-4
    model, state = _column(n, eps, dt=dt)
    for _ in range(30):
        step(model, state)
    z = np.sort(state.position[model.sphere_ids, 2])
    r = 1e-3
    gaps = np.diff(np.concatenate([[0.0], z])) - np.r_[r, np.full(n - 1, 2 * r)]
    # sphere-sphere contact k from the top carries k weights, W_nn = 2/m: 2 k ε g h²;
    # the floor carries n weights with W_nn = 1/m: n ε g h²
    k = np.arange(n, 0, -1)
    expect = -eps * G * dt**2 * np.where(np.arange(n) == 0, n, 2 * k)
    np.testing.assert_allclose(gaps, expect, rtol=1e-5)


def test_the_natural_residual_holds_the_compliance_term():
    model, state = _column(3, 0.05, natural=True)
    for _ in range(20):
        st = step(model, state)
    assert st.n_contacts == 3
    assert st.natural_residual < 1e-10          # u_n + g/h + ε W_nn p_n = 0 at rest
    # the same state read as a rigid contact's (no compliance term) is far from it
    c = state.contacts_buf
    free = state.vel6.copy()
    free[model.sphere_ids, 2] -= G * model.options.dt   # (q's scale only)
    rigid, _ = natural_map(c.count, c.i, c.j, c.frame, c.ri, c.rj, c.gterm, c.w, c.mu,
                           c.impulse, state.vel6, free, 0.0)
    comp, _ = natural_map(c.count, c.i, c.j, c.frame, c.ri, c.rj, c.gterm, c.w, c.mu,
                          c.impulse, state.vel6, free, 0.05)
    assert comp < 1e-20 and rigid > 1e-12           # (squared sums)


def _overlapping_pair(eps, overlap):
    s = Scene(gravity=(0.0, 0.0, 0.0))
    s.add_spheres([[-1e-3, 0, 0], [1e-3 - overlap, 0, 0]], [1e-3, 1e-3], density=2650.0,
                  group="sand")
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    return s.compile(dt=1e-4, tol=1e-12, max_iter=100, contact_compliance=eps)


def test_an_overlap_is_kept_by_the_rigid_law_and_released_by_the_spring():
    d = 2e-6                                  # 0.2 % of the radius
    model, state = _overlapping_pair(0.0, d)
    step(model, state)
    # rigid: an existing overlap is not pushed out, only kept from growing
    assert np.all(state.vel6 == 0.0)
    model, state = _overlapping_pair(0.01, d)
    step(model, state)
    # the spring pushes it out: relative normal velocity d/h less the compliance's share
    # (u_n = -g/h - ε W_nn p_n, p_n = m (u_n / 2), W_nn = 2/m: u_n = (d/h) / (1 + ε))
    un = state.vel6[1, 0] - state.vel6[0, 0]
    assert un == pytest.approx(d / 1e-4 / 1.01, rel=1e-9)


@pytest.mark.slow
def test_the_mould_deposit_converges_with_compliance_where_the_rigid_law_stagnates(tmp_path):
    # the first 25 steps of the mould deposit at scale 0.1 (seed 0), tol 1e-4: the rigid
    # law's sweeps wander and stop at max_iter (docs/speed.md, issue 31 §2); with ε = 0.01
    # every step converges
    kw = dict(steps=25, max_nonconverged=1.0, frames=0, progress=False)
    rigid = gravity_deposit(0.1, history=str(tmp_path / "r.h5"), **kw)
    soft = gravity_deposit(0.1, contact_compliance=0.01, history=str(tmp_path / "s.h5"), **kw)
    assert rigid.convergence["non_converged"] >= 20
    assert soft.convergence["non_converged"] == 0


def test_a_released_overlap_is_a_known_energy_source_not_a_warning():
    import warnings

    from engine import run
    from engine.sanity import energy_sources

    model, state = _overlapping_pair(0.01, 2e-6)
    assert energy_sources(model, state) == "compliant contacts"
    with warnings.catch_warnings():
        warnings.simplefilter("error")            # no PhysicsWarning for the spring's push
        summary = run(model, state, 3, progress=False)
    assert state.vel6[1, 0] > 0.0 and "energy" not in str(summary).lower()
    rigid, _ = _overlapping_pair(0.0, 2e-6)
    assert energy_sources(rigid, state) is None


@pytest.mark.parametrize("bad", [-0.01, 1.5, float("nan")])
def test_bad_compliance_is_refused_in_one_line(bad):
    with pytest.raises(ValueError) as e:
        _column(1, bad)
    assert "contact_compliance" in str(e.value)


def test_over_relaxation_is_refused_with_compliance():
    s = Scene(gravity=(0.0, 0.0, -G))
    s.add_spheres([[0, 0, 1e-3]], [1e-3], density=2650.0, group="sand")
    with pytest.raises(ValueError) as e:
        s.compile(dt=1e-4, relax=1.4, contact_compliance=0.01)
    msg = str(e.value)
    assert "contact_compliance" in msg and "relax" in msg and "\n" not in msg


def test_a_checkpoint_written_before_the_keyword_still_resumes():
    # a run's identity (what its checkpoint is tied to) leaves out the keyword at its
    # default, so a rigid run checkpointed before it existed resumes; a compliant run is
    # another run
    from engine.experiments.common import run_identity

    old = dict(test="gravity_deposit", scale=0.1, tol=1e-4, chain_solve=False)
    assert run_identity(dict(old, contact_compliance=0.0)) == run_identity(old)
    assert run_identity(dict(old, contact_compliance=0.01)) != run_identity(old)
