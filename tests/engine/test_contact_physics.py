"""Frictional contact physics against closed forms (Signorini + Coulomb, Eq. 5-6)."""
import numpy as np
import pytest

from engine import Scene, laws, run, step

from tests.helpers import G, box_pile


def test_sphere_resting_on_plane(theta):
    """Reaction = weight to 1e-6 relative, penetration < 1e-9 m, no drift over 10 000 steps."""
    r = 0.01
    s = Scene(gravity=(0, 0, -G))
    s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    s.add_spheres([[0.0, 0.0, r]], r, density=2650.0, group="sand")
    s.interact("sand", "wall", laws.Coulomb(mu=0.5))
    model, state = s.compile(dt=1e-4, theta=theta)
    weight = model.body_mass[1] * G
    worst_pen = 0.0
    reactions = []
    for _ in range(10_000):
        stats = step(model, state)
        assert stats.converged and stats.n_contacts == 1
        worst_pen = max(worst_pen, r - state.position[1, 2])
        reactions.append(state.contacts.normal_force[0])
    assert worst_pen < 1e-9
    np.testing.assert_allclose(reactions, weight, rtol=1e-6)
    assert abs(state.position[1, 2] - r) < 1e-9  # no drift
    assert np.abs(state.position[1, :2]).max() < 1e-12


def test_sliding_sphere_ends_rolling_at_five_sevenths(theta):
    """Solid sphere launched sliding (no spin): rolls without slip at 5/7 v0 after 2 v0/(7 μ g)."""
    r, v0, mu, dt = 0.01, 1.0, 0.3, 1e-4
    s = Scene(gravity=(0, 0, -G))
    s.add_plane(group="wall")
    s.add_spheres([[0.0, 0.0, r]], r, density=2650.0, velocities=[[v0, 0, 0]])
    s.interact("sand", "wall", laws.Coulomb(mu=mu))
    model, state = s.compile(dt=dt, theta=theta)
    t_slip = None
    for _ in range(2000):
        step(model, state)
        slip = state.velocity[1, 0] - r * state.spin[1, 1]
        if t_slip is None and abs(slip) < 1e-9 * v0:
            t_slip = state.time
    assert t_slip == pytest.approx(2 * v0 / (7 * mu * G), rel=0.02)
    assert state.velocity[1, 0] == pytest.approx(5 / 7 * v0, rel=0.01)
    assert state.spin[1, 1] * r == pytest.approx(5 / 7 * v0, rel=0.01)
    assert abs(state.velocity[1, 1]) < 1e-12 and abs(state.velocity[1, 2]) < 1e-9


def test_infinite_friction_rolls_at_five_sevenths_in_one_step(theta):
    """μ = inf (perfectly rough): the slip stops within the first step, so the 5/7 law holds
    at once (t_slip = 2 v0/(7 μ g) -> 0), angular momentum about the contact point being
    conserved: v = 5/7 v0, ω r = v.  NaN-free: the cone bound is never inf × 0."""
    r, v0 = 0.01, 1.0
    s = Scene(gravity=(0, 0, -G))
    s.add_plane(group="wall")
    s.add_spheres([[0.0, 0.0, r]], r, density=2650.0, velocities=[[v0, 0, 0]])
    s.interact("sand", "wall", laws.Coulomb(mu=np.inf))
    model, state = s.compile(dt=1e-4, theta=theta, tol=1e-10)
    for _ in range(50):
        assert step(model, state).converged
        assert state.velocity[1, 0] == pytest.approx(5 / 7 * v0, rel=1e-8)
        assert state.spin[1, 1] * r == pytest.approx(5 / 7 * v0, rel=1e-8)
    assert np.isfinite(state.vel6).all()


def test_with_friction_changes_the_sliding_deceleration_mid_run(theta):
    """Two spheres sliding on a floor (groups a and b, same Coulomb law): while sliding, a
    step's friction impulse is μ m g h, so v drops by μ g h per step.  Model.with_friction
    (0, [(a, wall)]) stops a's deceleration at once and leaves b's (the shared law is not
    changed); with_friction(0.6) then gives both 0.6 g.  Rounding-level tolerances."""
    r, v0, dt = 0.01, 1.0, 1e-4
    s = Scene(gravity=(0, 0, -G))
    s.add_plane(group="wall")
    ia = s.add_spheres([[0.0, 0.0, r]], r, density=2650.0, velocities=[[v0, 0, 0]], group="a")
    ib = s.add_spheres([[0.0, 1.0, r]], r, density=2650.0, velocities=[[v0, 0, 0]], group="b")
    s.interact("a", "wall", laws.Coulomb(mu=0.3))
    s.interact("b", "wall", laws.Coulomb(mu=0.3))
    s.interact("a", "b", laws.Coulomb(mu=0.3))
    s.interact("a", "a", None)
    s.interact("b", "b", None)
    model, state = s.compile(dt=dt, theta=theta, tol=1e-12)
    a, b = int(ia[0]), int(ib[0])

    def vx(k):
        return state.velocity[k, 0]

    def run_steps(m, n):
        for _ in range(n):
            assert step(m, state).converged

    run_steps(model, 5)  # the contacts exist (the first step lands them)
    for m, n, mu_a, mu_b in ((model, 20, 0.3, 0.3),
                             (model.with_friction(0.0, [("a", "wall")]), 20, 0.0, 0.3),
                             (model.with_friction(0.6), 20, 0.6, 0.6)):
        va, vb = vx(a), vx(b)
        run_steps(m, n)
        assert va - vx(a) == pytest.approx(mu_a * G * dt * n, rel=1e-9, abs=1e-12)
        assert vb - vx(b) == pytest.approx(mu_b * G * dt * n, rel=1e-9, abs=1e-12)
    assert model.law_param[model.pair_law[model.group_id("b"), model.group_id("wall")], 0] == 0.3


def test_with_friction_refuses_bad_input():
    s = Scene(gravity=(0, 0, -G))
    s.add_plane(group="wall")
    s.add_spheres([[0.0, 0.0, 0.01]], 0.01, density=2650.0)
    s.interact("sand", "wall", laws.Coulomb(mu=0.3))
    s.interact("sand", "sand", None)
    model, _ = s.compile(dt=1e-4)
    for bad in (-0.1, float("nan"), "x", None):
        with pytest.raises(ValueError, match="mu must be"):
            model.with_friction(bad)
    with pytest.raises(ValueError, match="unknown group"):
        model.with_friction(0.1, [("sand", "grains")])
    with pytest.raises(ValueError, match="do not interact"):
        model.with_friction(0.1, [("sand", "sand")])
    with pytest.raises(ValueError, match="pairs must be"):
        model.with_friction(0.1, ["sand"])


def test_perfectly_inelastic_head_on_impact(theta):
    """Momentum conserved to 1e-12 relative; the two spheres leave with one common velocity."""
    s = Scene(gravity=(0, 0, 0))
    ra, rb = 0.01, 0.015
    s.add_spheres([[0, 0, 0], [ra + rb + 2e-3, 0, 0]], [ra, rb], density=1000.0,
                  velocities=[[1.0, 0, 0], [-0.5, 0, 0]])
    s.interact("sand", "sand", laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=1e-4, theta=theta)
    m = model.body_mass
    p0 = m @ state.velocity
    run(model, state, 200, progress=False)
    p1 = m @ state.velocity
    np.testing.assert_allclose(p1, p0, rtol=1e-12, atol=1e-15)
    v_common = p0[0] / m.sum()
    np.testing.assert_allclose(state.velocity[:, 0], v_common, rtol=1e-9)
    assert np.abs(state.spin).max() == 0.0  # head-on: no friction, no spin


def _floor_reaction(model, state, floor):
    c = state.contacts
    return c.normal_force[c.j == floor].sum()


def test_column_of_ten_spheres_floor_reaction(theta):
    r = 0.005
    s = Scene(gravity=(0, 0, -G))
    floor = s.add_plane(group="floor")
    s.add_spheres([[0, 0, r + 2 * r * k] for k in range(10)], r, density=2650.0)
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.interact("sand", "floor", laws.Coulomb(mu=0.5))
    model, state = s.compile(dt=1e-4, theta=theta, tol=1e-8, max_iter=5000)
    summary = run(model, state, 300, progress=False)
    assert not summary.non_converged
    m = model.body_mass
    weight = m[model.sphere_ids].sum() * G
    assert _floor_reaction(model, state, floor) == pytest.approx(weight, rel=1e-3)
    # every contact of the column carries the weight of the spheres above it
    c = state.contacts
    above = np.array([m[(j if j != floor else i):].sum() * G for i, j in zip(c.i, c.j)])
    np.testing.assert_allclose(c.normal_force, above, rtol=1e-3)
    assert np.abs(state.position[1:, :2]).max() < 1e-12


def test_pile_of_500_spheres_floor_reaction(theta):
    """At rest, the floor carries the whole weight (side walls frictionless: no Janssen)."""
    hi = (16e-3, 16e-3)
    model, state, box, _ = box_pile(500, hi[0], theta=theta, tol=1e-6, max_iter=2000)
    floor = box[0]
    ke = []
    for _ in range(1500):
        step(model, state)
        ke.append(0.5 * model.body_mass[model.sphere_ids] @ (state.velocity[model.sphere_ids] ** 2).sum(1))
    assert ke[-1] < 1e-6 * max(ke)  # at rest
    weight = model.body_mass[model.sphere_ids].sum() * G
    assert _floor_reaction(model, state, floor) == pytest.approx(weight, rel=1e-3)
    # nothing escaped the box
    p = state.position[model.sphere_ids]
    assert p.min() > 0 and p[:, 0].max() < hi[0] and p[:, 1].max() < hi[1]


@pytest.mark.parametrize("speed", [0.0, 20.0])
def test_sphere_in_cylinder_rests_on_wall(theta, speed):
    """Pushed sideways by a constant force (and, at 20 m/s, thrown at the wall faster than
    the alert distance per step), the sphere ends at rest against the side wall."""
    R, H, r = 0.02, 0.05, 0.004
    s = Scene(gravity=(0, 0, -G))
    tube = s.add_cylinder(center=(0, 0, 0), axis=(0, 0, 1), radius=R, height=H, group="wall")
    ball = s.add_spheres([[0.0, 0.0, r]], r, density=2650.0, velocities=[[speed, 0, 0]])[0]
    s.interact("sand", "wall", laws.Coulomb(mu=0.3))
    push = 0.01  # [N] along +x
    s.drive(ball, force=(push, 0, 0))
    model, state = s.compile(dt=1e-4, theta=theta, tol=1e-8)
    worst = 0.0
    for _ in range(1500):
        step(model, state)
        worst = max(worst, np.hypot(*state.position[ball, :2]))
    assert worst < R - r + 1e-6  # no escape (the predicted gap catches fast impacts)
    assert state.position[ball, 0] == pytest.approx(R - r, abs=1e-8)
    assert np.linalg.norm(state.velocity[ball]) < 1e-8
    c = state.contacts
    side = (c.j == tube) & (c.sub == 0)
    assert side.sum() == 1 and ((c.j == tube) & (c.sub == 1)).sum() == 1
    # static equilibrium: the wall and the bottom cap (whose friction may share the
    # sideways push, statically indeterminate) balance the push and the weight
    weight = model.body_mass[ball] * G
    np.testing.assert_allclose(c.force.sum(axis=0), [-push, 0.0, weight], rtol=0, atol=1e-6 * push)
    assert c.normal_force[side][0] >= push - 0.3 * weight - 1e-9
