"""Imposed velocity, force and pressure on walls and spheres."""
import numpy as np
import pytest

from engine import Scene, laws, run, step
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
