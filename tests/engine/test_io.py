"""engine.io: bit-identical restart from a checkpoint, the history writer (records, frames,
crash safety under SIGINT/SIGTERM/SIGKILL) and clear errors for bad files."""
import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

from engine import Scene, io, laws, run, step
from engine.model import Model
from engine.state import State
from tests.helpers import signal_child
from engine.step import CallbackWriter, NonConvergenceWarning
from tests.helpers import G, lattice_pile

ROOT = Path(__file__).resolve().parents[2]
R_TUBE = 6e-3


def scene(n=40, dt=2e-4, area=None):
    """40 grains and a 15-bead prestrained elastic wire in a cylinder with a floor cap,
    under a pressure-driven lid (the driven wall)."""
    rng = np.random.default_rng(5)
    pts, radii = lattice_pile(n, 1e-3, rng, ((-3.8e-3, -3.8e-3, 0), (3.8e-3, 3.8e-3, 0.05)))
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, radii, density=2650.0, group="sand")
    z0 = pts[:, 2].max() + 3e-3
    t = np.linspace(0, 2 * np.pi, 16)[:-1]
    wire = np.c_[3e-3 * np.cos(t), 3e-3 * np.sin(t), np.full(t.size, z0)]
    s.add_wire(wire, radius=5e-4, density=1400.0, group="wire",
               law=laws.ElasticWire(stiffness=50.0, prestrain=0.01))
    s.add_cylinder(center=(0, 0, 0), radius=R_TUBE, height=0.06, group="wall", bottom=True)
    lid = s.add_plane(point=(0, 0, z0 + 2e-3), normal=(0, 0, -1), group="lid")
    s.drive(lid, pressure=200.0, area=np.pi * R_TUBE ** 2 if area is None else area, mass=1e-3)
    mu = laws.Coulomb(mu=0.4)
    for a, b in (("sand", "sand"), ("sand", "wall"), ("wire", "sand"), ("wire", "wire"),
                 ("wire", "wall")):
        s.interact(a, b, mu)
    s.interact("sand", "lid", laws.Coulomb(mu=0.0))
    s.interact("wire", "lid", laws.Coulomb(mu=0.0))
    return s.compile(dt=dt, tol=1e-5, max_iter=400)


def _same(a, b):
    return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)


class _Quiet(warnings.catch_warnings):
    """Silence the NonConvergenceWarning of a short run (convergence is not tested here)."""

    def __enter__(self):
        super().__enter__()
        warnings.simplefilter("ignore", NonConvergenceWarning)


def _run(model, state, n):
    with _Quiet():
        run(model, state, n, progress=False)


# -- checkpoint -------------------------------------------------------------------------------
@pytest.mark.parametrize("at", [120, 525], ids=["falling", "verlet-reuse"])
def test_restart_from_checkpoint_is_bit_identical(tmp_path, at):
    """At step 120 grains fall and the candidate list is rebuilt nearly every step; at 525
    the pile is settling and the saved Verlet list is reused by the next steps (steps 521-534
    rebuild nothing)."""
    model, state = scene()
    _run(model, state, at)
    assert state.contacts_buf.count > 20 and np.count_nonzero(state.link_impulse) > 0
    path = tmp_path / "ckpt.h5"
    io.save(path, model, state)
    model2, state2 = io.load(path)
    rebuilt = [step(model, state).rebuilt, step(model2, state2).rebuilt]
    if at == 525:
        assert rebuilt == [False, False]
    _run(model, state, 99)
    _run(model2, state2, 99)
    assert state2.step == state.step == at + 100
    assert state2.time == state.time and state2.time_compensation == state.time_compensation
    for name in ("position", "vel6", "link_impulse", "warm_key", "warm_impulse"):
        assert _same(getattr(state2, name), getattr(state, name)), name
    assert _same(state2.spin, state.spin) and _same(state2.velocity, state.velocity)
    assert _same(state2.links.tension, state.links.tension)
    assert _same(state2.contacts.force, state.contacts.force)
    lid = model.bodies_in("lid")[0]
    assert state.position[lid, 2] < scene()[1].position[lid, 2]  # the driven lid did move


def test_restart_without_the_warm_start_would_differ(tmp_path):
    """The previous test is sensitive: dropping the saved warm-start data changes the bits."""
    model, state = scene()
    _run(model, state, 120)
    io.save(tmp_path / "c.h5", model, state)
    _, cold = io.load(tmp_path / "c.h5")
    cold.warm_key, cold.warm_impulse = np.zeros(0, np.int64), np.zeros((0, 3))
    cold.link_impulse[:] = 0.0
    _run(model, state, 20)
    _run(model, cold, 20)
    assert not np.array_equal(cold.position, state.position)


def test_checkpoint_round_trips_every_model_and_state_field(tmp_path):
    s = Scene(gravity=(0.1, 0, -G))
    s.add_spheres([[0, 0, 1e-3], [3e-3, 0, 1e-3]], 1e-3, density=2650.0)  # on the floor
    s.add_wire([[0, 0, 3.05e-3], [2.5e-3, 0, 3.05e-3], [5e-3, 0, 3.05e-3]], radius=1e-3, density=1e3,
               group="wire", law=laws.BrittleElasticWire(stiffness=3.0, prestrain=0.02,
                                                         max_tension=7.0))
    s.add_plane(group="wall")
    piston = s.add_plane(point=(0, 0, 0.02), normal=(0, 0, -1), group="wall")
    side = s.add_plane(point=(-5e-3, 0, 0), normal=(1, 0, 0), group="side")
    ball = s.add_spheres([[0, 3e-3, 1e-3]], 1e-3, density=2650.0, group="ball")[0]
    s.drive(piston, velocity=(0, 0, -1e-3))
    s.drive(side, force=(2.0, 0, 0), mass=0.5)
    s.drive(ball, force=(0, 0, 1e-4))
    for a, b in (("sand", "sand"), ("sand", "wall"), ("wire", "sand"), ("wire", "wall"),
                 ("wire", "wire"), ("sand", "side"), ("wire", "side"), ("ball", "side"),
                 ("ball", "sand"), ("ball", "wire"), ("ball", "ball"), ("ball", "wall")):
        s.interact(a, b, laws.Coulomb(mu=0.25 if "wire" in (a, b) else 0.5))
    model, state = s.compile(dt=1e-4, theta=0.7, tol=1e-7, max_iter=77, relax=0.9)
    _run(model, state, 30)
    io.save(tmp_path / "c.h5", model, state)
    m2, s2 = io.load(tmp_path / "c.h5")
    for f in dataclasses.fields(Model):
        a, b = getattr(model, f.name), getattr(m2, f.name)
        if isinstance(a, np.ndarray):
            assert _same(a, b) and not b.flags.writeable, f.name
    assert m2.options == model.options and m2.group_names == model.group_names
    assert m2.laws == model.laws and type(m2.laws[0]) is laws.Coulomb
    assert [(d.body, d.kind) for d in m2.drives] == [(d.body, d.kind) for d in model.drives]
    for d, e in zip(model.drives, m2.drives):
        assert _same(np.asarray(d.value), np.asarray(e.value)) and d.area == e.area
    for f in dataclasses.fields(State):  # every field, also ones added after this test
        a, b = getattr(state, f.name), getattr(s2, f.name)
        if f.name == "pairs":
            assert _same(a[:state.n_pairs], b[:state.n_pairs]) and a.shape == b.shape
        elif isinstance(a, np.ndarray):
            assert _same(a, b), f.name
        elif f.name == "workspace":      # not saved: a loaded state rebuilds it
            assert a.free_vel is not None and b.free_vel is None and b.sphere_order is None
        elif f.name != "contacts_buf":
            assert a == b and type(a) is type(b), f.name
    c, c2 = state.contacts_buf, s2.contacts_buf
    assert (c.count, c.n_pair, c.cap) == (c2.count, c2.n_pair, c2.cap) and c.count > 0
    for name in c._FIELDS:
        assert _same(getattr(c, name)[:c.count], getattr(c2, name)[:c.count]), name
    # every dataset carries its SI unit, the root its format and version
    with h5py.File(tmp_path / "c.h5") as f:
        assert f.attrs["format"] == "nscd-workbench" and f.attrs["format_version"] == io.FORMAT_VERSION
        units = {}

        def collect(name, obj):
            if isinstance(obj, h5py.Dataset):
                units[name] = obj.attrs.get("unit")

        f.visititems(collect)
        assert len(units) > 40 and all(isinstance(u, str) and u for u in units.values()), units
        assert units["model/body_radius"] == "m" and units["state/warm_impulse"] == "N s"
        assert units["model/drives/1/value"] == "N" and units["state/vel6"].startswith("columns")


def test_every_model_and_state_array_has_a_unit():
    model, state = scene()
    for obj, table in ((model, io.MODEL_UNITS), (state, io.STATE_UNITS)):
        arrays = {f.name for f in dataclasses.fields(obj) if isinstance(getattr(obj, f.name), np.ndarray)}
        assert arrays - {"pairs_ref"} <= set(table), sorted(arrays - set(table))


def test_save_refuses_a_callable_drive_and_names_it(tmp_path):
    model, state = scene(area=lambda m, s: np.pi * R_TUBE ** 2)
    lid = model.bodies_in("lid")[0]
    with pytest.raises(ValueError, match=rf"pressure drive on body {lid}: area is a Python callable"):
        io.save(tmp_path / "c.h5", model, state)
    assert not any(tmp_path.iterdir())  # nothing half-written is left
    model, state = scene()
    with pytest.raises(ValueError, match="state must be an engine State"):
        io.save(tmp_path / "c.h5", model, model)


def test_checkpoint_writer_saves_on_its_trigger(tmp_path):
    model, state = scene()
    with _Quiet():
        run(model, state, 20, writers=[io.Checkpoint(tmp_path / "c_{step:04d}.h5", trigger=10)],
            progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c_0010.h5", "c_0020.h5"]
    assert io.load(tmp_path / "c_0020.h5")[1].step == 20


def test_history_write_final_keeps_the_end_state_once(tmp_path):
    """A run of 25 steps recorded every 10 with frames every 20 (and the start state, frame
    0): write_final adds the end
    state (step 25) as a record and a frame, with the same values the writer records at a
    trigger (time, kinetic energy), and writes nothing more when called again or when the
    end step was recorded already."""
    model, state = scene()
    h = io.History(tmp_path / "h.h5", trigger=10, frames=20)
    with _Quiet():
        run(model, state, 25, writers=[h], progress=False)
    h.write_final(model, state)
    h.write_final(model, state)
    h.close()
    d = io.read_history(tmp_path / "h.h5")
    assert d.step.tolist() == [10, 20, 25] and d.frame_step.tolist() == [0, 20, 25]
    assert d.time[-1] == pytest.approx(25 * model.options.dt, rel=1e-12)
    assert d.kinetic_energy[-1] == io.kinetic_energy(model, state)
    np.testing.assert_array_equal(io.load(tmp_path / "h.h5", frame=-1)[1].position,
                                  state.position)
    h2 = io.History(tmp_path / "h2.h5", trigger=10, frames=20)
    with _Quiet():
        run(model, state, 15, writers=[h2], progress=False)    # steps 26..40: 30, 40 recorded
    h2.write_final(model, state)
    h2.close()
    d2 = io.read_history(tmp_path / "h2.h5")
    assert d2.step.tolist() == [30, 40] and d2.frame_step.tolist() == [25, 40]   # its start


def test_iter_frames_gives_each_frame_as_load_does_from_one_open_file(tmp_path, monkeypatch):
    """io.iter_frames yields every complete frame of a history in order, each the state
    io.load rebuilds for that frame (positions, velocities, spins, links, contacts), with
    the file opened once; a checkpoint is refused by name."""
    model, state = scene()
    with io.History(tmp_path / "h.h5", trigger=10, frames=5) as h, _Quiet():
        run(model, state, 30, writers=[h], progress=False)
    n = io.frame_count(tmp_path / "h.h5")
    opened = []
    real = io._open_read
    monkeypatch.setattr(io, "_open_read", lambda p: opened.append(p) or real(p))
    states = list(io.iter_frames(tmp_path / "h.h5"))
    assert len(opened) == 1 and len(states) == n == 7            # steps 0, 5, ..., 30
    monkeypatch.setattr(io, "_open_read", real)
    for k, got in enumerate(states):
        want = io.load(tmp_path / "h.h5", frame=k)[1]
        assert got.step == want.step == 5 * k
        for name in ("position", "vel6", "link_impulse"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
        c, d = got.contacts_buf, want.contacts_buf
        assert c.count == d.count
        np.testing.assert_array_equal(c.impulse[:c.count], d.impulse[:d.count])
    io.save(tmp_path / "c.h5", model, state)
    with pytest.raises(io.FormatError, match="c.h5: is a checkpoint file, expected a history"):
        next(io.iter_frames(tmp_path / "c.h5"))


def test_a_checkpoint_refuses_a_frame_other_than_its_state(checkpoint):
    assert io.load(checkpoint, frame=0)[1].step == io.load(checkpoint)[1].step == 5
    with pytest.raises(ValueError, match=r"is a checkpoint, which holds one state: frame=3 "
                                         r"applies to history files only"):
        io.load(checkpoint, frame=3)


# -- bad files ------------------------------------------------------------------------------
@pytest.fixture
def checkpoint(tmp_path):
    model, state = scene()
    _run(model, state, 5)
    path = tmp_path / "c.h5"
    io.save(path, model, state)
    return path


@pytest.mark.timeout(120)  # a reader that loops on a damaged file fails, never hangs CI
def test_corrupt_truncated_foreign_and_newer_files_give_a_format_error(tmp_path, checkpoint):
    garbage = tmp_path / "garbage.h5"
    garbage.write_bytes(np.random.default_rng(0).bytes(4096))
    truncated = tmp_path / "truncated.h5"
    truncated.write_bytes(checkpoint.read_bytes()[: checkpoint.stat().st_size // 2])
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["data"] = np.arange(3)
    newer = tmp_path / "newer.h5"
    newer.write_bytes(checkpoint.read_bytes())
    with h5py.File(newer, "a") as f:
        f.attrs["format_version"] = io.FORMAT_VERSION + 1
    flipped = tmp_path / "flipped.h5"  # one byte of the stored positions changed
    raw = bytearray(checkpoint.read_bytes())
    at = raw.find(io.load(checkpoint)[1].position[3:5].tobytes())
    assert at > 0
    raw[at + 5] ^= 0xFF
    flipped.write_bytes(bytes(raw))
    holed = tmp_path / "holed.h5"
    holed.write_bytes(checkpoint.read_bytes())
    with h5py.File(holed, "a") as f:
        del f["state/warm_key"]
    cases = {garbage: "not a readable HDF5 file", truncated: "HDF5|corrupt",
             foreign: "not an nscd-workbench file", newer: "newer than this engine reads",
             holed: "corrupt or incomplete.*warm_key", flipped: "corrupt or incomplete"}
    for path, msg in cases.items():
        with pytest.raises(io.FormatError, match=msg) as e:
            io.load(path)
        assert isinstance(e.value, ValueError) and str(path) in str(e.value)
        assert not isinstance(e.value, KeyError)
    with pytest.raises(io.FormatError, match="is a checkpoint file, expected a history"):
        io.read_history(checkpoint)
    with pytest.raises(FileNotFoundError):
        io.load(tmp_path / "missing.h5")


# -- history ----------------------------------------------------------------------------------
def _stress(model, state):
    c = state.contacts
    if not len(c):
        return np.zeros((3, 3))
    return np.einsum("ki,kj->ij", c.force, c.point)


def test_history_reload_returns_what_was_observed_during_the_run(tmp_path):
    from engine.analysis import wall_forces

    model, state = scene()
    seen, frames = [], []

    def observe(m, s):
        v = s.vel6[m.sphere_ids]
        ke = 0.5 * (np.sum(m.body_mass[m.sphere_ids] * (v[:, :3] ** 2).sum(1))
                    + np.sum(m.body_inertia[m.sphere_ids] * (v[:, 3:] ** 2).sum(1)))
        seen.append((s.time, s.step, ke, s.stats.iterations, s.stats.residual,
                     s.stats.converged, s.stats.n_contacts, wall_forces(m, s),
                     np.count_nonzero(s.link_impulse), _stress(m, s)))
        if s.step % 25 == 0:
            c = s.contacts
            frames.append((s.step, s.position.copy(), s.velocity.copy(), s.spin.copy(),
                           s.links.tension, c.i, c.j, c.force))

    path = tmp_path / "run.h5"
    with io.History(path, frames=25, flush=10, extra={"stress": (_stress, "N m")}) as h:
        with _Quiet():  # two runs append to the same history
            run(model, state, 60, writers=[CallbackWriter(observe, 1), h], progress=False)
            run(model, state, 40, writers=[CallbackWriter(observe, 1), h], progress=False)
    d = io.read_history(path)
    assert d.n_records == 100 and d.n_frames == 5       # the start state, then 25 ... 100
    assert d.frame_step.tolist() == [0, 25, 50, 75, 100]
    t, st, ke, it, res, conv, nc, wf, nl, sig = map(np.asarray, zip(*seen))
    assert np.array_equal(d.time, t) and np.array_equal(d.step, np.arange(1, 101))
    assert np.allclose(d.kinetic_energy, ke, rtol=1e-12, atol=0)
    assert np.array_equal(d.iterations, it) and np.array_equal(d.residual, res)
    assert np.array_equal(d.converged, conv) and np.array_equal(d.n_contacts, nc)
    assert np.array_equal(d.n_links, nl) and nl.max() > 0
    assert d.wall_force.shape == (100, model.n_walls, 3) and np.abs(wf).max() > 0
    assert np.allclose(d.wall_force, wf, rtol=1e-12, atol=1e-15)
    assert np.array_equal(d.wall_ids, model.wall_ids)
    assert np.array_equal(d.extra["stress"], sig) and d.units["stress"] == "N m"
    assert d.units["wall_force"] == "N" and d.units["kinetic_energy"] == "J"
    for k, (s_, pos, vel, spin, ten, ci, cj, cf) in enumerate(frames, start=1):
        assert d.frame_step[k] == s_
        assert np.array_equal(d.position[k], pos) and np.array_equal(d.velocity[k], vel)
        assert np.array_equal(d.spin[k], spin) and np.array_equal(d.link_tension[k], ten)
        c = d.contacts(k)
        assert np.array_equal(c["i"], ci) and np.array_equal(c["j"], cj)
        assert np.array_equal(c["force"], cf)
    # the model is stored once: load() gives it back with the state of a frame
    m2, s2 = io.load(path, frame=2)
    assert _same(m2.body_radius, model.body_radius) and m2.options == model.options
    assert s2.step == 50 and np.array_equal(s2.position, frames[1][1])
    assert np.allclose(s2.contacts.force, frames[1][7], rtol=1e-9, atol=1e-12)
    assert np.allclose(s2.links.tension, frames[1][4], rtol=1e-12, atol=0)
    for bad in (9, True, 1.0, "1"):              # True was read as frame 1
        with pytest.raises(ValueError, match=rf"frame = {bad!r}: must be an integer in"):
            io.load(path, frame=bad)


def test_history_keeps_a_callable_drive_as_a_placeholder(tmp_path):
    area = lambda m, s: np.pi * R_TUBE ** 2  # noqa: E731
    model, state = scene(area=area)
    with io.History(tmp_path / "h.h5", frames=5) as h:
        run(model, state, 5, writers=[h], progress=False)
    m2, s2 = io.load(tmp_path / "h.h5")
    lid = model.bodies_in("lid")[0]
    with pytest.raises(ValueError, match=rf"area of the pressure drive on body {lid} was the "
                                         r"Python callable .*<lambda>"):
        step(m2, s2)
    m3, s3 = io.load(tmp_path / "h.h5", callables={(lid, "area"): area})
    step(m3, s3)
    assert s3.step == 6


# -- crash safety -----------------------------------------------------------------------------
CHILD = """
import sys
from engine import io, run
from tests.engine.test_io import scene

model, state = scene()
with io.History(sys.argv[1], frames=50, flush=20) as h:
    summary = run(model, state, 10**7, writers=[h], progress=False)
print(summary.interrupted, state.step, flush=True)
"""


def _wait_records(proc, path, n, timeout=120.0):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        assert proc.poll() is None, proc.communicate()
        try:
            d = io.read_history(path, frames=False)
            if d.n_records >= n:
                return d
        except (FileNotFoundError, io.FormatError):
            pass
        time.sleep(0.2)
    raise AssertionError(f"no {n} records in {path} after {timeout} s")


@pytest.mark.timeout(300)
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL],
                         ids=["SIGINT", "SIGTERM", "SIGKILL"])
def test_killed_run_leaves_a_readable_history(tmp_path, sig):
    path = tmp_path / "run.h5"
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, str(script), str(path)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    before, _, out, err = signal_child(proc, sig, before=lambda: _wait_records(proc, path, 100))
    d = io.read_history(path)
    n = d.n_records
    assert n >= before.n_records
    assert np.array_equal(d.step, np.arange(1, n + 1))  # complete, in order, no torn record
    assert d.n_frames >= 2 and d.frame_step[-1] >= d.step[-1] - 50
    assert np.all(np.isfinite(d.position)) and d.wall_force.shape == (n, 2, 3)
    assert io.load_model(path).n_bodies == scene()[0].n_bodies
    if sig == signal.SIGKILL:
        assert proc.returncode == -signal.SIGKILL
    else:  # run() traps the signal, finishes the step and flushes: nothing is lost
        assert proc.returncode == 0, err
        interrupted, last = out.split()
        assert interrupted == "True"
        assert 0 <= int(last) - d.step[-1] <= 20 and int(last) == d.step[-1]
        with h5py.File(path, "r") as f:  # closed cleanly: opens without SWMR
            assert json.loads(f["records"].attrs["extra"]) == []


def test_history_bad_input_names_the_field(tmp_path):
    p = tmp_path / "h.h5"
    for kw, msg in ((dict(frames=-1), "frames must be"), (dict(flush=0), "flush must be"),
                    (dict(trigger="x"), "trigger must be"),
                    (dict(extra={"time": len}), "bad record name 'time'"),
                    (dict(extra={"a": 3.0}), r"extra\['a'\] must be a callable")):
        with pytest.raises(ValueError, match=msg):
            io.History(p, **kw)
    model, state = scene()
    shapes = iter([np.zeros(3), np.zeros(4)])
    h = io.History(p, extra={"grows": lambda m, s: next(shapes)})
    with pytest.raises(ValueError, match=r"extra\['grows'\] returned shape \(4,\), expected \(3,\)"):
        run(model, state, 2, writers=[h], progress=False)
    h.close()
    with pytest.raises(ValueError, match="is closed"):
        h.write(model, state)


def test_history_frame_gives_the_wire_stress(tmp_path):
    """A frame's state carries the link frame (unit vector j -> i at the frame's positions),
    so the wire part of the Weber stress (Eq. 18) read from a history matches the one of the
    run: equal up to the O(h v) difference between the end-of-step positions of the frame
    and the predicted configuration the run used."""
    from engine.analysis import weber_stress

    model, state = scene()
    live = {}

    def observe(m, s):
        if s.step % 25 == 0:
            live[s.step] = weber_stress(m, s, part="wire").tensor

    path = tmp_path / "run.h5"
    with io.History(path, frames=25) as h, _Quiet():
        run(model, state, 100, writers=[CallbackWriter(observe, 1), h], progress=False)
    k = max(range(4), key=lambda q: np.abs(live[25 * (q + 1)]).max())   # the most taut frame
    _, s2 = io.load(path, frame=k + 1)                                 # (frame 0: the start)
    assert np.allclose(np.linalg.norm(s2.link_normal, axis=1), 1.0)
    got = weber_stress(model, s2, part="wire").tensor
    ref = live[25 * (k + 1)]
    assert np.abs(ref).max() > 0
    np.testing.assert_allclose(got, ref, rtol=0, atol=0.02 * np.abs(ref).max())


def test_file_content_tells_a_checkpoint_from_a_history(tmp_path):
    model, state = scene(n=10)
    io.save(tmp_path / "c.h5", model, state)
    assert io.file_content(tmp_path / "c.h5") == ("checkpoint", io.FORMAT_VERSION)
    with io.History(tmp_path / "h.h5", frames=2) as h, _Quiet():
        run(model, state, 2, writers=[h], progress=False)
    assert io.file_content(tmp_path / "h.h5") == ("history", io.FORMAT_VERSION)
    with h5py.File(tmp_path / "x.h5", "w") as f:
        f.attrs["format"] = "something-else"
    with pytest.raises(io.FormatError, match="not an"):
        io.file_content(tmp_path / "x.h5")
    with pytest.raises(FileNotFoundError):
        io.file_content(tmp_path / "missing.h5")


def test_checkpoint_extra_arrays_and_text_round_trip(tmp_path):
    model, state = scene()
    p = tmp_path / "c.h5"
    io.save(p, model, state, extra={"steps": 250, "rows": np.arange(3.0), "who": "deposit"})
    e = io.load_extra(p)
    assert e["steps"] == 250 and e["who"] == "deposit"
    np.testing.assert_array_equal(e["rows"], [0.0, 1.0, 2.0])
    assert _same(io.load(p)[1].position, state.position)
    with pytest.raises(ValueError, match=r"extra\['bad'\]: numbers or a str"):
        io.save(tmp_path / "d.h5", model, state, extra={"bad": np.array([object()])})
    io.save(tmp_path / "e.h5", model, state)
    assert io.load_extra(tmp_path / "e.h5") == {}


def test_history_resumed_at_a_step_cuts_what_follows_it(tmp_path):
    """A history reopened at step 30 (records every 10, frames every 20) keeps the records
    of steps <= 30 on the grid and the frames <= 30, drops the rest, and goes on."""
    model, state = scene()
    p = tmp_path / "h.h5"
    with io.History(p, trigger=10, frames=20) as h:
        run(model, state, 50, writers=[h], progress=False)
        h.write_final(model, state)              # (on the grid already: nothing more)
    with io.History(p, trigger=10, frames=20, resume_step=30) as h:
        assert (h.n_records, h.n_frames) == (3, 2)
    d = io.read_history(p)
    assert d.step.tolist() == [10, 20, 30] and d.frame_step.tolist() == [0, 20]
    with pytest.raises(FileNotFoundError, match="no history to resume"):
        io.History(tmp_path / "none.h5", resume_step=3)


def test_history_run_id_is_kept_by_a_resume_and_read_while_open(tmp_path):
    """A history's random run id reads back as written, also while its writer has the file
    open (SWMR); a resumed history keeps it; a checkpoint has none to give."""
    model, state = scene()
    p = tmp_path / "h.h5"
    with io.History(p, trigger=10, frames=20) as h:
        run(model, state, 20, writers=[h], progress=False)
        rid = h.run_id
        assert len(rid) == 32 and io.history_run_id(p) == rid
    with io.History(p, trigger=10, frames=20, resume_step=10) as h:
        assert h.run_id == rid
    assert io.history_run_id(p) == rid
    with io.History(tmp_path / "g.h5") as g:                   # another run, another id
        assert g.run_id != rid
    io.save(tmp_path / "c.h5", model, state)
    with pytest.raises(ValueError, match="is not a history"):
        io.history_run_id(tmp_path / "c.h5")


def test_read_frame_is_load_of_that_frame_and_contacts_can_be_left_out(tmp_path):
    """read_frame with the model read once gives load(frame)'s state, array for array;
    contacts=False gives the same bodies and links and no contacts; frame_index and
    frame_arrays name the same frames; bad names and frames are refused by name."""
    model, state = scene()
    p = tmp_path / "h.h5"
    with io.History(p, trigger=10, frames=20) as h:
        _run_with(model, state, 60, h)
    m = io.load_model(p)
    steps, times = io.frame_index(p)
    _, start = io.load(p, frame=0)                  # frame 0: the state the run started from
    assert _same(start.position, scene()[1].position)
    assert steps.tolist() == [0, 20, 40, 60] and times == pytest.approx(steps * model.options.dt)
    for k in range(1, 4):                       # (frame 0, the start, has no contacts)
        _, want = io.load(p, frame=k)
        got = io.read_frame(p, k, m)
        for name in ("position", "vel6", "link_impulse", "link_broken"):
            assert _same(getattr(got, name), getattr(want, name)), name
        cw, cg = want.contacts, got.contacts
        assert len(cw) > 0 and np.array_equal(cg.force, cw.force)
        assert np.array_equal(cg.normal, cw.normal) and np.array_equal(cg.i, cw.i)
        bare = io.read_frame(p, k, m, contacts=False)
        assert len(bare.contacts) == 0 and _same(bare.position, want.position)
        assert np.array_equal(bare.links.tension, want.links.tension)
    arrays = list(io.frame_arrays(p, ["velocity", "contact_force"], frames=[2, 0]))
    assert np.array_equal(arrays[0]["velocity"], io.load(p, frame=2)[1].velocity)
    assert np.array_equal(arrays[1]["contact_force"], io.load(p, frame=0)[1].contacts.force)
    with pytest.raises(ValueError, match=r"unknown array\(s\) \['speed'\]"):
        list(io.frame_arrays(p, ["speed"]))
    for bad in (4, -1, True, 2.5):
        with pytest.raises(ValueError, match=rf"frame = {bad!r}: must be an integer in \[0, 3\]"):
            list(io.frame_arrays(p, ["position"], frames=[bad]))
    with pytest.raises(ValueError, match=r"frame = 7: must be an integer in \[-4, 3\]"):
        io.read_frame(p, 7, m)


def _run_with(model, state, n, writer):
    with _Quiet():
        run(model, state, n, writers=[writer], progress=False)


def test_history_meta_round_trips_and_survives_a_resume(tmp_path):
    model, state = scene()
    p = tmp_path / "h.h5"
    meta = {"test": "mine", "total_steps": 40, "params": {"k": 0.2, "wire": "elastic"}}
    with io.History(p, trigger=10, frames=20, meta=meta) as h:
        _run_with(model, state, 20, h)
        assert io.history_meta(p) == meta                      # while being written
    with io.History(p, trigger=10, frames=20, resume_step=10):
        pass
    assert io.history_meta(p) == meta
    with io.History(tmp_path / "none.h5") as g:
        _run_with(model, state, 1, g)
    assert io.history_meta(tmp_path / "none.h5") == {}
    with io.History(tmp_path / "law.h5", meta={"law": laws.RigidWire()}) as g:
        _run_with(model, state, 1, g)
    assert io.history_meta(tmp_path / "law.h5") == {"law": str(laws.RigidWire())}
    with pytest.raises(ValueError, match="meta must be a dict .*, got list"):
        io.History(tmp_path / "bad.h5", meta=["test"])
    loop = {}
    loop["self"] = loop
    with pytest.raises(ValueError, match="meta must be a JSON-serialisable dict"):
        io.History(tmp_path / "bad.h5", meta=loop)
    assert not (tmp_path / "bad.h5").exists()          # refused before the file is made
    io.save(tmp_path / "c.h5", model, state)
    with pytest.raises(ValueError, match="is not a history"):
        io.history_meta(tmp_path / "c.h5")


def _short_history(path):
    """(a history of the test scene, 40 steps, a record every 10 and a frame every 5; its
    frame count, at least 4): what the damage tests copy and spoil."""
    model, state = scene()
    with io.History(path, trigger=10, frames=5) as h:
        run(model, state, 40, writers=[h], progress=False)
    n = io.frame_count(path)
    assert n >= 4
    return path, n


def test_a_damaged_history_names_the_frame_and_the_dataset(tmp_path):
    """Copies of a real history damaged where a checksum cannot see (NaN positions in one
    frame, contact indices beyond the model, a negative radius in the model): every reader
    says which frame and dataset in one line (FormatError, a ValueError); the intact frames
    still read, one by one."""
    import shutil

    import h5py

    good, n = _short_history(tmp_path / "good.h5")
    model = io.load_model(good)

    def damaged(name, edit):
        p = tmp_path / f"{name}.h5"
        shutil.copy(good, p)
        with h5py.File(p, "r+") as f:
            edit(f)
            del f["frames/crc32"], f["records/crc32"]   # as a file without checksums
        return p

    def nan_position(f):
        f["frames/position"][2, 3, 0] = np.nan
    p = damaged("nan", nan_position)
    with pytest.raises(ValueError, match=r"nan\.h5: frame 2: frames/position holds non-finite"):
        io.load(p, frame=2)
    with pytest.raises(ValueError, match=r"frame 2: frames/position holds non-finite"):
        list(io.iter_frames(p))
    with pytest.raises(ValueError, match=r"frame 2: frames/position holds non-finite"):
        list(io.frame_arrays(p, ["position"]))
    assert np.all(np.isfinite(io.load(p, frame=1)[1].position))      # the others read
    assert np.all(np.isfinite(io.load(p, frame=3)[1].position))

    last = n - 1
    assert io.load(good, frame=last)[1].contacts_buf.count > 0

    def far_contact(f):
        k = int(f["frames/contact_start"][last])
        f["frames/contacts/j"][k] = 10 ** 6
    p = damaged("index", far_contact)
    nb = model.n_bodies
    with pytest.raises(ValueError, match=rf"frame {last}: frames/contacts/j points outside "
                                         rf"the model's {nb} bodies"):
        io.load(p)
    with pytest.raises(ValueError, match=rf"frame {last}: frames/contacts/j points outside"):
        list(io.frame_arrays(p, ["contact_j"], frames=[last]))

    def negative_radius(f):
        r = f["model/body_radius"][...]
        r[model.sphere_ids[0]] = -1e-3
        del f["model/body_radius"]
        f["model/body_radius"] = r
    p = damaged("radius", negative_radius)
    with pytest.raises(ValueError, match=rf"model/body_radius of sphere "
                                         rf"{model.sphere_ids[0]} is -0\.001"):
        io.load(p)
    for p in tmp_path.glob("*.h5"):                       # every message is one line
        try:
            io.load(p, frame=2)
        except ValueError as e:
            assert "\n" not in str(e)


def test_damaged_bytes_fail_the_checksums_naming_the_frame_or_record(tmp_path):
    """Bytes flipped or zeroed in a copy of a real history, where HDF5's own metadata
    checksums cannot see them (inside a frame's or a record's data): every reader names the
    frame (or record) and dataset in one line; the intact frames still read one by one."""
    import shutil

    import h5py

    good, n = _short_history(tmp_path / "good.h5")
    io.read_history(good)                                  # a good file reads whole

    def damaged(name, dataset, chunk, at, flip):
        p = tmp_path / f"{name}.h5"
        shutil.copy(good, p)
        with h5py.File(p, "r") as f:
            info = f[dataset].id.get_chunk_info(chunk)
        with open(p, "r+b") as fh:
            fh.seek(info.byte_offset + at)
            b = fh.read(4)
            fh.seek(info.byte_offset + at)
            fh.write(bytes(x ^ 0xFF for x in b) if flip else b"\0" * 4)
        return p

    p = damaged("flip", "frames/position", 2, 40, True)     # frame 2's chunk
    for read in (lambda: io.load(p, frame=2), lambda: list(io.iter_frames(p)),
                 lambda: list(io.frame_arrays(p, ["position"])), lambda: io.read_history(p)):
        with pytest.raises(ValueError, match=r"flip\.h5: frame 2: frames/position fails its "
                                             r"checksum \(the file is damaged"):
            read()
    assert io.load(p, frame=1)[1].step == io.load(good, frame=1)[1].step
    np.testing.assert_array_equal(io.load(p, frame=3)[1].position,
                                  io.load(good, frame=3)[1].position)

    p = damaged("contacts", "frames/contacts/normal", 0, 8, True)   # flipped: contact 0's
    with h5py.File(good) as f:                                      # normal, y component
        k = int(np.flatnonzero(f["frames/contact_count"][:n] > 0)[0])
        assert f["frames/contact_start"][k] == 0
    with pytest.raises(ValueError, match=rf"frame {k}: frames/contacts/normal fails its "
                                         rf"checksum"):
        io.load(p, frame=k)
    assert io.read_frame(p, k, contacts=False).step == io.load(good, frame=k)[1].step

    p = damaged("record", "records/kinetic_energy", 0, 16, True)     # record 2
    with pytest.raises(ValueError, match=r"record\.h5: records: record 2 of \d+ fails its "
                                         r"checksum"):
        io.read_history(p, frames=False)
    io.load(p, frame=-1)                                    # its frames read
