"""Imposed velocity, force and pressure on walls and spheres."""
import numpy as np
import pytest

from engine import Scene, laws, run
from tests.helpers import G


def _sphere_under_lid(theta, **drive):
    r = 2e-3
    s = Scene(gravity=(0, 0, -G))
    floor = s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="floor")
    lid = s.add_plane(point=(0, 0, 2 * r + 1e-4), normal=(0, 0, -1), group="lid")
    ball = s.add_spheres([[0, 0, r]], r, density=2650.0)[0]
    s.interact("sand", "floor", laws.Coulomb(mu=0.3))
    s.interact("sand", "lid", laws.Coulomb(mu=0.3))
    s.drive(lid, **drive)
    model, state = s.compile(dt=1e-4, theta=theta, tol=1e-10)
    return model, state, floor, lid, ball


@pytest.mark.parametrize("how", ["pressure", "pressure-callable-area", "force"])
def test_pressure_or_force_on_lid_is_carried_to_the_floor(theta, how):
    p, area = 2e3, 1e-4  # 2 kPa on 1 cm² = 0.2 N
    if how == "pressure":
        drive = dict(pressure=p, area=area, mass=1e-3)
    elif how == "pressure-callable-area":
        calls = []
        drive = dict(pressure=lambda t: p, area=lambda m, s: calls.append(s.step) or area, mass=1e-3)
    else:
        drive = dict(force=(0, 0, -p * area), mass=1e-3)
    model, state, floor, lid, ball = _sphere_under_lid(theta, **drive)
    run(model, state, 400, progress=False)
    c = state.contacts
    weight = model.body_mass[ball] * G
    assert c.normal_force[c.j == floor].sum() == pytest.approx(weight + p * area, rel=1e-6)
    assert c.normal_force[c.j == lid].sum() == pytest.approx(p * area, rel=1e-6)
    # the lid moved along its normal only, and rests on the sphere
    assert state.position[lid, 2] == pytest.approx(4e-3, abs=1e-9)
    assert np.all(state.position[lid, :2] == 0.0)
    assert np.linalg.norm(state.velocity[lid]) < 1e-9
    if how == "pressure-callable-area":
        assert calls[:3] == [0, 1, 2] and len(calls) == 400


def test_imposed_velocity_wall_pushes_a_sphere(theta):
    """A wall driven at 1 cm/s along a frictionless floor carries the sphere at its speed."""
    r, v = 2e-3, 0.01
    s = Scene(gravity=(0, 0, -G))
    s.add_plane(group="floor")
    pusher = s.add_plane(point=(-r - 1e-4, 0, 0), normal=(1, 0, 0), group="pusher")
    s.add_spheres([[0, 0, r]], r, density=2650.0)
    s.interact("sand", "floor", laws.Coulomb(mu=0.0))
    s.interact("sand", "pusher", laws.Coulomb(mu=0.0))
    s.drive(pusher, velocity=(v, 0, 0))
    model, state = s.compile(dt=1e-4, theta=theta)
    run(model, state, 500, progress=False)
    assert state.velocity[pusher, 0] == v
    assert state.velocity[2, 0] == pytest.approx(v, rel=1e-9)
    assert state.position[pusher, 0] == pytest.approx(-r - 1e-4 + v * state.time, rel=1e-12)
    assert state.position[2, 0] - state.position[pusher, 0] >= r - 1e-12


def test_fixed_sphere_does_not_move_and_supports_another(theta):
    r = 1e-3
    s = Scene(gravity=(0, 0, -G))
    base, top = s.add_spheres([[0, 0, 0], [0, 0, 2 * r]], r, density=2650.0)
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.fix([base])
    model, state = s.compile(dt=1e-4, theta=theta)
    run(model, state, 1000, progress=False)
    assert np.all(state.position[base] == 0.0) and np.all(state.vel6[base] == 0.0)
    assert state.position[top, 2] == pytest.approx(2 * r, abs=1e-12)
    assert state.contacts.normal_force[0] == pytest.approx(model.body_mass[top] * G, rel=1e-9)


def test_time_dependent_velocity_drive_follows_the_theta_rule(theta):
    """A wall driven at v(t) = a t moves by h Σ((1-θ) v(t_i) + θ v(t_i+1)) = a h² (n(n-1)/2 + θ n)."""
    a, h, n = 2.0, 1e-3, 50
    s = Scene()
    wall = s.add_plane(point=(0, 0, -1.0), normal=(0, 0, 1))
    s.add_spheres([[0, 0, 1.0]], 0.01, density=1000.0)
    s.interact("sand", "wall", laws.Coulomb(mu=0.0))
    s.drive(wall, velocity=lambda t: (0.0, 0.0, a * t))
    model, state = s.compile(dt=h, theta=theta)
    run(model, state, n, progress=False)
    assert state.position[wall, 2] == pytest.approx(-1.0 + a * h * h * (n * (n - 1) / 2 + theta * n),
                                                    rel=1e-12)
    assert state.velocity[wall, 2] == pytest.approx(a * n * h, rel=1e-12)


# -- free-surface confinement ---------------------------------------------------------------------
def _ring(n=16, layers=3, r=1e-3, R=6e-3):
    a = 2 * np.pi * np.arange(n) / n
    pts = [(R * np.cos(t), R * np.sin(t), r + 2 * r * k) for k in range(layers) for t in a]
    s = Scene()
    ids = s.add_spheres(np.array(pts), r, density=2650.0)
    s.interact("sand", "sand", laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=1e-4)
    return model, state, ids


def test_confinement_loads_the_surface_with_p_times_its_area_and_guards_its_radius():
    """A ring of equal spheres: every sphere is a surface particle, the loads add up to
    p 2π R H (R the outer radius, H the height) and point to the axis.  Moved out by 1.4x
    the sample is still confined; by 1.6x (grains out of the membrane) ``apply`` raises
    ConfinementError and leaves the loads as they were; ``max_growth=None`` never does."""
    from engine.drivers import Confinement, ConfinementError

    model, state, ids = _ring()
    p, r = 1e4, 1e-3
    conf = Confinement(p, ids, cell=2 * r)
    conf.apply(model, state)
    R, H = 6e-3 + r, 6 * r
    assert conf.start_radius == pytest.approx(R, rel=1e-12) and conf.height == pytest.approx(H)
    f = state.load[ids]
    assert np.linalg.norm(f, axis=1).sum() == pytest.approx(p * 2 * np.pi * R * H, rel=1e-12)
    radial = state.position[ids, :2] / np.linalg.norm(state.position[ids, :2], axis=1)[:, None]
    assert np.einsum("ka,ka->k", f[:, :2], radial) == pytest.approx(-np.linalg.norm(f, axis=1))
    start = state.position.copy()
    state.position[ids, :2] = 1.4 * start[ids, :2]
    conf.apply(model, state)                               # bulged: still confined
    kept = state.load.copy()
    state.position[ids, :2] = 1.6 * start[ids, :2]
    with pytest.raises(ConfinementError, match=r"grew from 7 mm to 10\.6 mm .*max_growth = 1\.5"):
        conf.apply(model, state)
    assert np.array_equal(state.load, kept)
    free = Confinement(p, ids, cell=2 * r, max_growth=None)
    state.position[:] = start
    free.apply(model, state)
    state.position[ids, :2] = 3.0 * start[ids, :2]
    free.apply(model, state)
    assert free.radius == pytest.approx(3 * 6e-3 + r)


@pytest.mark.parametrize("bad", [1.0, 0.5, float("nan"), "x"])
def test_confinement_refuses_a_growth_limit_that_is_not_above_one(bad):
    from engine.drivers import Confinement

    with pytest.raises(ValueError, match="max_growth must be a finite factor > 1"):
        Confinement(1e4, [0, 1], max_growth=bad)
