"""Updaters in the run loop (engine.step.run, engine.trigger) and drive values as schedules
stored as data (engine.schedules): when an updater runs and what it sees, the stop
condition, a schedule kept by save/load, and a run resumed from a checkpoint of a ramped,
servo-walled box bit for bit."""
import math
import os
import signal

import numpy as np
import pytest

from engine import Scene, io, laws, run
from engine.drivers import BoxFaces, drive_values
from engine.schedules import Constant, FollowSchedules, Ramp, Servo, from_dict, to_dict
from engine.step import CallbackWriter
from engine.trigger import CallbackUpdater, every
from tests.helpers import G, lattice_pile


def falling(n=12):
    """``n`` grains falling into a box (no drive)."""
    rng = np.random.default_rng(1)
    pts, radii = lattice_pile(n, 1e-3, rng, ((0, 0, 0), (8e-3, 8e-3, 0.05)))
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, radii, density=2650.0)
    s.add_box((0, 0, 0), (8e-3, 8e-3, 0.05), group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=0.4))
    s.interact("sand", "wall", laws.Coulomb(mu=0.4))
    return s.compile(dt=2e-4, tol=1e-6, max_iter=500)


def servo_box(n=40, p=200.0):
    """``n`` grains in a box of five pressure-driven walls (x−, x+, y−, y+, top) on a fixed
    floor: the box triaxial test's isotropic stage in small, its pressure a ramp raised
    every 5 steps and its areas the box's faces (``Servo``)."""
    rng = np.random.default_rng(4)
    L = 8e-3
    pts, radii = lattice_pile(n, 1e-3, rng, ((0, 0, 0), (L, L, 0.05)))
    top_z = float((pts[:, 2] + radii).max()) + 1e-4
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, radii, density=2650.0)
    floor = s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    top = s.add_plane(point=(0, 0, top_z), normal=(0, 0, -1), group="wall")
    sides = [s.add_plane(point=pt, normal=nrm, group="wall") for pt, nrm in (
        ((0, 0, 0), (1, 0, 0)), ((L, 0, 0), (-1, 0, 0)),
        ((0, 0, 0), (0, 1, 0)), ((0, L, 0), (0, -1, 0)))]
    ramp = Ramp(0.0, p, 40, every=5)
    for b in (*sides, top):
        s.drive(b, pressure=ramp, mass=1e-3, area=Servo("box faces"))
    s.fix(floor)
    s.interact("sand", "sand", laws.Coulomb(mu=0.4))
    s.interact("sand", "wall", laws.Coulomb(mu=0.0))
    model, state = s.compile(dt=1e-4, tol=1e-6, max_iter=500)
    return model, state, [FollowSchedules(5), BoxFaces(floor, top, sides)], top


def test_an_updater_every_10_steps_runs_after_steps_10_20_30_and_sees_that_state():
    """An updater every 10 steps runs after steps 10, 20, 30 (not before the first step),
    after the writers of that step (which saw the state it sees), and what it sets acts
    from the next step on."""
    model, state = falling()
    log = []
    writer = CallbackWriter(lambda m, s: log.append(("write", s.step, s.position.copy())))

    def update(m, s):
        log.append(("update", s.step, s.position.copy()))
        s.load[m.sphere_ids[0]] = (0.0, 0.0, 1e-3)       # acts from the next step on

    run(model, state, 35, writers=[writer], progress=False,
        updaters=[CallbackUpdater(update, 10)])
    ups = [(i, e) for i, e in enumerate(log) if e[0] == "update"]
    assert [e[1] for _, e in ups] == [10, 20, 30]
    for i, (kind, n, x) in ups:
        assert log[i - 1][:2] == ("write", n)            # the writers of step n came first
        assert np.array_equal(log[i - 1][2], x)          # the same state: the end of step n


def test_updaters_run_in_list_order_and_a_later_one_sees_what_an_earlier_set():
    model, state = falling()
    seen = []
    first = CallbackUpdater(lambda m, s: s.load.__setitem__((0, 2), s.step * 1e-6), 5)
    second = CallbackUpdater(lambda m, s: seen.append((s.step, s.load[0, 2])), 5)
    run(model, state, 12, progress=False, updaters=[first, second])
    assert seen == [(5, 5 * 1e-6), (10, 10 * 1e-6)]


def test_the_stop_condition_ends_the_run_after_the_updaters_of_its_step():
    model, state = falling()
    order = []

    class Until:
        def trigger(self, step):
            return step % 4 == 0

        def __call__(self, m, s):
            order.append(("until", s.step))
            return s.step == 8

    up = CallbackUpdater(lambda m, s: order.append(("update", s.step)), 4)
    summary = run(model, state, 100, progress=False, updaters=[up], until=Until())
    assert summary.condition_met and summary.steps == 8 and state.step == 8
    assert order == [("update", 4), ("until", 4), ("update", 8), ("until", 8)]


def test_the_updaters_of_the_step_a_ctrl_c_came_on_have_run():
    """A stop request ends the run after the updaters of its step: the state is a restart
    point whatever the step."""
    model, state = falling()
    stop = CallbackWriter(lambda m, s: os.kill(os.getpid(), signal.SIGINT) if s.step == 10
                          else None)
    seen = []
    summary = run(model, state, 50, writers=[stop], progress=False,
                  updaters=[CallbackUpdater(lambda m, s: seen.append(s.step), 10)])
    assert summary.interrupted and state.step == 10 and seen == [10]


def test_run_without_updaters_is_as_before_and_bad_ones_are_named():
    """The old call run(model, state, steps, writers, progress) still works; a bad updater,
    trigger or stop condition is refused with one line naming it."""
    a, sa = falling()
    b, sb = falling()
    run(a, sa, 20, [], False)
    run(b, sb, 20, progress=False, updaters=[CallbackUpdater(lambda m, s: None, 3)])
    assert np.array_equal(sa.position, sb.position) and np.array_equal(sa.vel6, sb.vel6)
    with pytest.raises(ValueError, match=r"updaters\[0\] = 3: an updater needs trigger"):
        run(a, sa, 1, progress=False, updaters=[3])
    with pytest.raises(ValueError, match="CallbackUpdater: trigger must be an int >= 1"):
        CallbackUpdater(lambda m, s: None, "often")
    with pytest.raises(ValueError, match=r"every\(n\): n must be >= 1, got 0"):
        every(0)
    with pytest.raises(ValueError, match="until must be a callable"):
        run(a, sa, 1, progress=False, until=5)


def test_a_ramp_is_raised_every_n_steps_and_held():
    r = Ramp(0.0, 15e3, 400, every=10)
    assert r.at(0) == 0.0 and r.at(9) == 0.0 and r.at(10) == 15e3 * (10 / 400)
    assert r.at(395) == 15e3 * (390 / 400) and r.at(400) == r.at(10_000) == 15e3
    assert Ramp(1.0, 2.0, 0).at(1) == 2.0 and Ramp(5.0, 7.0, 4, origin=100).at(50) == 5.0
    for d in (Constant(3.0), r, Servo("box faces", 2.5)):
        assert from_dict(to_dict(d)) == d
    for bad, match in ((lambda: Ramp(0.0, math.inf, 10), r"Ramp: end must be a finite number"),
                       (lambda: Ramp(0.0, 1.0, -1), r"Ramp: steps must be an integer >= 0"),
                       (lambda: Ramp(0.0, 1.0, 10, every=0), r"Ramp: every must be an integer >= 1"),
                       (lambda: Constant("1"), r"Constant: value must be a finite number"),
                       (lambda: Servo(""), r"Servo: by must name the updater"),
                       (lambda: from_dict({"type": "Sine"}), r"unknown schedule")):
        with pytest.raises(ValueError, match=match):
            bad()


def test_a_servo_area_no_updater_set_stops_the_step_with_its_name():
    model, state, _, top = servo_box()
    with pytest.raises(ValueError, match=r"pressure drive on body \d+: area must be finite .* "
                                         r"\(not set yet by box faces\)"):
        run(model, state, 1, progress=False)


def test_the_ramp_and_the_servo_walls_drive_the_box(tmp_path):
    """The ramp reaches p at step 40 (raised every 5 steps), the walls' areas follow the
    box's faces, and the walls hold the grains."""
    model, state, updaters, top = servo_box()
    seen = []
    run(model, state, 60, progress=False, updaters=[*updaters, CallbackUpdater(
        lambda m, s: seen.append((s.step, float(s.drive_pressure[top]))), 5)])
    assert seen[0] == (5, 200.0 * 5 / 40) and seen[7] == (40, 200.0) and seen[-1] == (60, 200.0)
    x = state.position
    sides = updaters[1].sides
    assert state.drive_area[top] == (x[sides[1], 0] - x[sides[0], 0]) * (
        x[sides[3], 1] - x[sides[2], 1])


def test_a_schedule_survives_save_and_load_and_the_run_resumes_bit_for_bit(tmp_path):
    """A model whose drives are a Ramp and Servo areas, saved mid-ramp and loaded, has the
    same drives (data, no stand-in for a callable) and the same current values; run on from
    the checkpoint, it ends where the run that never stopped does, bit for bit."""
    model, state, updaters, top = servo_box()
    run(model, state, 60, progress=False, updaters=updaters)
    ref = state

    model, state, updaters, top = servo_box()
    run(model, state, 23, progress=False, updaters=updaters)
    io.save(tmp_path / "c.h5", model, state)
    m2, s2 = io.load(tmp_path / "c.h5")
    assert m2.drives == model.drives
    assert isinstance(m2.drives[0].value, Ramp) and isinstance(m2.drives[0].area, Servo)
    assert not any(isinstance(d.value, io.UnsavedCallable) or isinstance(d.area, io.UnsavedCallable)
                   for d in m2.drives)
    for a, b in zip(drive_values(model, state), drive_values(m2, s2)):
        assert np.array_equal(a, b)
    run(m2, s2, 60 - 23, progress=False,
        updaters=[FollowSchedules(5), BoxFaces(*_faces(updaters[1]))])
    assert s2.step == ref.step == 60
    for name in ("position", "vel6", "drive_pressure", "drive_area", "link_impulse"):
        assert np.array_equal(getattr(s2, name), getattr(ref, name)), name


def _faces(b):
    return b.floor, b.top, b.sides


def test_a_checkpoint_as_the_last_updater_resumes_a_servo_box_bit_for_bit(tmp_path):
    """engine.io.Checkpoint given as the last updater saves the state with what the
    updaters set at that step (as a writer it would save it before them): run on from the
    file of step 25, the box ends where the run that never stopped does."""
    model, state, updaters, top = servo_box()
    run(model, state, 40, progress=False,
        updaters=[*updaters, io.Checkpoint(str(tmp_path / "c_{step}.h5"), 25)])
    m2, s2 = io.load(tmp_path / "c_25.h5")
    assert s2.step == 25
    run(m2, s2, 15, progress=False, updaters=[FollowSchedules(5), BoxFaces(*_faces(updaters[1]))])
    for name in ("position", "vel6", "drive_pressure", "drive_area"):
        assert np.array_equal(getattr(s2, name), getattr(state, name)), name


def membrane_column(seed=1):
    """The cylinder triaxial test's isotropic stage in small: a scale-0.04 sand sample on a
    fixed floor under a top plate whose pressure is a ramp (raised every 5 steps) on the
    membrane's area π R² (``Servo``), the free-surface membrane updated every 5 steps."""
    from engine.drivers import Confinement, MembraneUpdater
    from engine.prep import cylinder_sample

    smp = cylinder_sample(0.04, wire=False, seed=seed)
    s = Scene(gravity=(0, 0, -G))
    sand = smp.add_to(s)[0]
    floor = s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    top = s.add_plane(point=(0, 0, smp.height), normal=(0, 0, -1), group="wall")
    s.drive(top, pressure=Ramp(0.0, 15e3, 20, every=5), mass=1e-3, area=Servo("membrane"))
    s.fix(floor)
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.interact("sand", "wall", laws.Coulomb(mu=0.5))
    model, state = s.compile(dt=5e-5, tol=3e-4, max_iter=1000)
    membrane = MembraneUpdater(Confinement(0.0, sand), top, 5)
    membrane.apply(model, state)
    return model, state, sand, top, membrane


def test_a_membrane_run_resumes_from_its_checkpoint_bit_for_bit(tmp_path):
    """The membrane's loads and the plate's pressure and area are in the State: saved after
    step 20 and loaded, the column goes on with a new membrane (the first run's start
    radius) and ends at step 40 where the run that never stopped does, bit for bit."""
    from engine.drivers import Confinement, MembraneUpdater

    model, state, sand, top, membrane = membrane_column()
    run(model, state, 40, progress=False, updaters=[FollowSchedules(5), membrane])
    assert state.drive_pressure[top] == 15e3 and np.abs(state.load[sand]).sum() > 0
    ref = state

    model, state, sand, top, membrane = membrane_column()
    run(model, state, 20, progress=False,
        updaters=[FollowSchedules(5), membrane, io.Checkpoint(str(tmp_path / "c.h5"), 20)])
    m2, s2 = io.load(tmp_path / "c.h5")
    again = MembraneUpdater(Confinement(0.0, sand, start_radius=membrane.membrane.start_radius),
                            top, 5)
    run(m2, s2, 20, progress=False, updaters=[FollowSchedules(5), again])
    for name in ("position", "vel6", "load", "drive_pressure", "drive_area"):
        assert np.array_equal(getattr(s2, name), getattr(ref, name)), name
    with pytest.raises(ValueError, match=r"start_radius must be a radius > 0 \[m\]"):
        Confinement(1.0, sand, start_radius=-1.0)
