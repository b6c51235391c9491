"""Scene builders shared by tests."""
import numpy as np

G = 9.81


def lattice_pile(n, r, rng, box, gap=1.05):
    """n spheres of radius r(1 ± 10 %) on a loose cubic lattice inside box = (lo, hi)."""
    lo, hi = np.asarray(box[0], float), np.asarray(box[1], float)
    d = 2 * r * 1.1 * gap
    nx = int((hi[0] - lo[0]) // d)
    ny = int((hi[1] - lo[1]) // d)
    pts = []
    k = 0
    while len(pts) < n:
        z = lo[2] + d / 2 + (k // (nx * ny)) * d
        i = k % (nx * ny)
        pts.append((lo[0] + d / 2 + (i % nx) * d, lo[1] + d / 2 + (i // nx) * d, z))
        k += 1
    radii = r * rng.uniform(0.9, 1.1, n)
    return np.asarray(pts), radii


def settle(model, state, steps, ids=None):
    """Static equilibrium by kinetic damping (dynamic relaxation): run ``steps`` steps and
    zero the velocities of bodies ``ids`` whenever their kinetic energy has just decreased
    (a peak was passed).  Returns the kinetic energy history."""
    from engine import step

    ids = model.sphere_ids if ids is None else np.asarray(ids)
    m = model.body_mass[ids]
    prev = 0.0
    history = []
    for _ in range(steps):
        step(model, state)
        ke = 0.5 * float(m @ (state.velocity[ids] ** 2).sum(axis=1))
        if ke < prev:
            state.vel6[ids] = 0.0
            ke = 0.0
        prev = ke
        history.append(ke)
    return np.asarray(history)


def box_pile(n, width, *, seed=7, theta=0.5, dt=2e-4, tol=1e-8, max_iter=5000, mu=0.4,
             wall_mu=0.0):
    """``n`` grains (r = 1 mm ± 10 %) on a loose lattice in a square box of side ``width`` [m]
    whose floor and side walls (group "side") have friction ``wall_mu`` (0: no Janssen
    effect, the floor carries the whole weight).  Returns (model, state, box ids, radii)."""
    from engine import Scene, laws

    rng = np.random.default_rng(seed)
    lo, hi = (0, 0, 0), (width, width, 0.1)
    pts, radii = lattice_pile(n, 1e-3, rng, (lo, hi), gap=1.02)
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, radii, density=2650.0)
    box = s.add_box(lo, hi, group="side")
    s.interact("sand", "sand", laws.Coulomb(mu=mu))
    s.interact("sand", "side", laws.Coulomb(mu=wall_mu))
    model, state = s.compile(dt=dt, theta=theta, tol=tol, max_iter=max_iter)
    return model, state, box, radii


def assert_option_refused(name, bad):
    """A bad value of solver option ``name`` is refused, with a ValueError naming it, both
    by Options and by Scene.compile."""
    import pytest

    from engine import Scene
    from engine.model import Options

    with pytest.raises(ValueError, match=name):
        Options(dt=1e-3, alert=0.0, skin=1e-3, **{name: bad})
    s = Scene()
    s.add_spheres([[0, 0, 1e-3]], 1e-3, density=1000.0)
    with pytest.raises(ValueError, match=name):
        s.compile(dt=1e-4, **{name: bad})


def same_converged_step(plain, other, state):
    """One step of ``plain`` and of ``other`` (the same scene, other solver options) from
    copies of ``state``; asserts both converged, that the velocities agree to 1e-6 of the
    velocity one step of gravity gives and the per-body contact impulses to 1e-8 of the
    largest (the tolerance-level difference of two converged solutions, tol 1e-10).
    Returns (stats_plain, stats_other, state_plain, state_other)."""
    from engine import step

    a_state, b_state = state.copy(), state.copy()
    a = step(plain, a_state)
    b = step(other, b_state)
    assert a.converged and b.converged
    gh = G * plain.options.dt
    np.testing.assert_allclose(b_state.vel6, a_state.vel6, rtol=0, atol=1e-6 * gh)
    na, nb_ = net_contact_impulse(plain, a_state), net_contact_impulse(other, b_state)
    np.testing.assert_allclose(nb_, na, rtol=0, atol=1e-8 * np.abs(na).max())
    return a, b, a_state, b_state


def net_contact_impulse(model, state):
    """Per-body resultant of the contact impulses (global frame), unique at convergence
    even where the contact impulses are not (hyperstatic packings)."""
    c = state.contacts
    net = np.zeros((model.n_bodies, 3))
    np.add.at(net, c.i, c.impulse_global)
    np.add.at(net, c.j, -c.impulse_global)
    return net


def wire_under_lid(**compile_kw):
    """A 6 x 6 x 3 lattice of grains (r = 1 mm) in a box, an elastic wire of 6 beads with
    fixed ends lying on it and a pressure-driven lid (10 Pa) above: links, a LINE body and
    all contact kinds in one small scene.  Returns (model, state, lid id)."""
    from engine import Scene, laws

    rng = np.random.default_rng(3)
    r = 1e-3
    radii = r * (1 - 0.002 * rng.uniform(0, 1, 108))
    s = Scene(gravity=(0, 0, -G))
    pts = np.stack(np.meshgrid(np.arange(6), np.arange(6), np.arange(3), indexing="ij"),
                   -1).reshape(-1, 3) * 2.0 * r + r
    pts[:, 2] += 1e-5
    s.add_spheres(pts, radii, density=2650.0)
    top = pts[:, 2].max() + r
    wire = np.array([[1.99 * r * k + 1.02 * r, 5 * r, top + r + 2e-5] for k in range(6)])
    beads = s.add_wire(wire, radius=0.98 * r, density=1400.0,
                       law=laws.ElasticWire(stiffness=100.0))
    s.fix([beads[0], beads[-1]])
    s.add_box((0, 0, 0), (12 * r, 12 * r, 0.05), group="wall")
    lid = s.add_plane(point=(0, 0, top + 2 * r + 4e-5), normal=(0, 0, -1), group="lid")
    s.drive(lid, pressure=10.0, mass=1e-3, area=(12 * r) ** 2)
    for g in ("sand", "wire"):
        s.interact(g, "wall", laws.Coulomb(mu=0.0))
        s.interact(g, "lid", laws.Coulomb(mu=0.0))
    s.interact("sand", "sand", laws.Coulomb(mu=0.3))
    s.interact("wire", "sand", laws.Coulomb(mu=0.3))
    s.interact("wire", "wire", laws.Coulomb(mu=0.3))
    model, state = s.compile(**{"dt": 1e-4, "tol": 1e-8, "max_iter": 50000, **compile_kw})
    return model, state, lid


def assert_same_wire_lid_trajectory(other: dict, plain: dict | None = None, steps: int = 15):
    """:func:`wire_under_lid` stepped ``steps`` times at tol 1e-10 with the ``plain`` options
    and with the ``other`` ones: every step converges, the positions (lid included) agree to
    1e-9 m and the link impulses to 1e-6 of the largest, tensions only (λ >= 0)."""
    from engine import step

    res = []
    for kw in (plain or {}, other):
        model, state, lid = wire_under_lid(tol=1e-10, **kw)
        for _ in range(steps):
            assert step(model, state).converged
        res.append((state, lid))
    (a, lid), (b, _) = res
    assert a.link_impulse.max() > 0.0
    np.testing.assert_allclose(b.position, a.position, rtol=0, atol=1e-9)
    assert abs(b.position[lid, 2] - a.position[lid, 2]) < 1e-9
    np.testing.assert_allclose(b.link_impulse, a.link_impulse, rtol=0,
                               atol=1e-6 * np.abs(a.link_impulse).max() + 1e-15)
    assert (b.link_impulse >= 0.0).all()


def stop_runs_at(monkeypatch, step, how="sigint"):
    """Every experiment run of this process (``engine.experiments.common.run``) stops at
    ``step``: by Ctrl-C (``how="sigint"``: the run stops after the step) or by a crash
    (``"crash"``: a RuntimeError out of the run, which leaves its files as a process killed
    there would)."""
    import os
    import signal

    import engine.experiments.common as common
    from engine.step import CallbackWriter

    real = common.run

    def stop(model, state):
        if state.step == step:
            if how == "sigint":
                os.kill(os.getpid(), signal.SIGINT)
            else:
                raise RuntimeError("crash")

    monkeypatch.setattr(common, "run", lambda model, state, n, writers=(), **k: real(
        model, state, n, writers=[*writers, CallbackWriter(stop)], **k))


def signal_child(proc, sig, *, before=None, timeout=60):
    """Send ``sig`` to the child ``proc`` (a ``subprocess.Popen`` with text pipes) once
    ``before()`` (if given) has returned, and collect its output; the child is killed on the
    way out whatever happens.  Returns (what ``before`` returned, monotonic time of the
    signal, stdout, stderr)."""
    import time

    try:
        got = before() if before is not None else None
        sent = time.monotonic()
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return got, sent, out, err


def slow_params(*values):
    """Parametrize values marked slow: those that run the threaded or Anderson sweeps,
    whose kernels take 70-150 s to compile on a fresh clone (``make test`` leaves them to
    ``make test-slow``)."""
    import pytest

    return [pytest.param(v, marks=pytest.mark.slow) for v in values]

