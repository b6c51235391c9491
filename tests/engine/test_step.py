"""run(): writers, summary of non-converged steps, NaN stop, Ctrl-C safety, progress."""
import os
import signal

import numpy as np
import pytest

from engine import Scene, SimulationError, laws, run, step
from engine.step import CallbackWriter, NonConvergenceWarning, every
from tests.helpers import G, lattice_pile


def _pile(n=60, max_iter=1000, tol=1e-6):
    rng = np.random.default_rng(3)
    pts, radii = lattice_pile(n, 1e-3, rng, ((0, 0, 0), (8e-3, 8e-3, 0.1)))
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, radii, density=2650.0)
    s.add_box((0, 0, 0), (8e-3, 8e-3, 0.1), group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=0.4))
    s.interact("sand", "wall", laws.Coulomb(mu=0.4))
    return s.compile(dt=2e-4, tol=tol, max_iter=max_iter)


class Recorder:
    def __init__(self, trigger):
        self.trigger = trigger
        self.steps = []
        self.flushed = 0

    def write(self, model, state):
        self.steps.append(state.step)

    def flush(self):
        self.flushed += 1


def test_writers_fire_on_their_trigger_after_complete_steps():
    model, state = _pile()
    rec = Recorder(every(3))
    seen = []
    cb = CallbackWriter(lambda m, s: seen.append((s.step, s.time)), trigger=5)
    summary = run(model, state, 10, writers=[rec, cb], progress=False)
    assert rec.steps == [3, 6, 9] and rec.flushed == 1
    assert [s for s, _ in seen] == [5, 10]
    assert seen[0][1] == pytest.approx(5 * 2e-4, rel=1e-12)
    assert summary.steps == 10 and summary.time == pytest.approx(10 * 2e-4)


def test_non_converged_steps_are_counted_and_shown():
    model, state = _pile(max_iter=1, tol=1e-12)
    with pytest.warns(NonConvergenceWarning, match="did NOT converge"):
        summary = run(model, state, 300, progress=False)
    assert len(summary.non_converged) > 0
    assert all(1 <= s <= 300 for s in summary.non_converged)
    assert "did NOT converge" in str(summary)
    assert summary.max_residual >= 1e-12


def test_run_stops_on_nan_naming_step_and_body():
    model, state = _pile()
    run(model, state, 2, progress=False)
    state.vel6[7, 2] = np.nan
    with pytest.raises(SimulationError, match=r"at step 3 .*ids \[[0-9, ]*\b7\b"):
        run(model, state, 5, progress=False)


def test_ctrl_c_returns_the_state_reached_with_writers_flushed():
    model, state = _pile()
    # the handler run() must put back (SIG_IGN when pytest runs as a background job)
    before = signal.getsignal(signal.SIGINT)

    class Interrupter(Recorder):
        def write(self, model, state):
            super().write(model, state)
            if state.step == 4:
                os.kill(os.getpid(), signal.SIGINT)

    rec = Interrupter(every(1))
    summary = run(model, state, 50, writers=[rec], progress=False)
    assert summary.interrupted and summary.steps == 4 and state.step == 4
    assert rec.flushed == 1 and rec.steps == [1, 2, 3, 4]
    # the state is a complete step: continuing gives the same result as never stopping
    ref_model, ref = _pile()
    run(ref_model, ref, 6, progress=False)
    run(model, state, 2, progress=False)
    np.testing.assert_array_equal(state.position, ref.position)
    assert signal.getsignal(signal.SIGINT) is before


def test_progress_bar_shows_rate_and_iterations(capsys):
    model, state = _pile()
    run(model, state, 40, progress=True)
    err = capsys.readouterr().err
    assert "40/40" in err and "it=" in err and "step/s" in err


def test_warm_start_at_rest_needs_few_sweeps():
    model, state = _pile(tol=1e-6)
    run(model, state, 800, progress=False)
    stats = step(model, state)
    assert stats.converged and stats.n_contacts > 60
    assert stats.iterations <= 3


def test_warm_store_and_lookup_match_a_plain_sort_and_dictionary():
    """The counting-sort warm store gives the keys of np.sort with their impulses, and
    prepare's per-body lookup warm-starts exactly the contacts whose key was stored (with
    that impulse), on keys of every kind: sphere–sphere, sphere–wall subs, first and last
    bodies, empty buckets."""
    from engine.contact import tangent_frame
    from engine.model import DYN_INV_MASS
    from engine.solver import nlgs

    rng = np.random.default_rng(5)
    nb = 300
    pairs = {(int(i), int(j), int(s)) for i, j, s in zip(rng.integers(0, nb - 1, 900),
                                                          rng.integers(1, nb, 900),
                                                          rng.integers(0, 3, 900)) if i < j}
    pairs |= {(0, 1, 0), (nb - 2, nb - 1, 2)}
    cs = np.array(sorted(pairs), np.int64)[rng.permutation(len(pairs))]
    n = len(cs)
    key = (cs[:, 0] * nb + cs[:, 1]) * 4 + cs[:, 2]
    frame = np.empty((n, 9))
    for a in range(n):
        nv = rng.normal(size=3)
        nv /= np.linalg.norm(nv)
        frame[a, :3] = nv
        frame[a, 3:] = tangent_frame(*nv)
    imp = np.column_stack([rng.uniform(0.1, 1, n), rng.normal(0, .05, n), rng.normal(0, .05, n)])
    keys, glob = nlgs.warm_store(n, key, frame, imp, nb)
    order = np.argsort(key)
    assert np.array_equal(keys, key[order])
    ref = np.einsum("ak,akd->ad", imp, frame.reshape(n, 3, 3))
    np.testing.assert_allclose(glob, ref[order], rtol=1e-14, atol=1e-16)
    # next step: a shuffled mix of kept and new contacts, on the same bodies
    keep = rng.random(n) < 0.7
    new = np.array([k for k in (rng.integers(0, nb - 1, 400) * nb + rng.integers(1, nb, 400)) * 4
                    if k not in set(key.tolist())][:100], np.int64)
    k2 = np.concatenate([key[keep], new])[rng.permutation(keep.sum() + len(new))]
    m = len(k2)
    ci = (k2 // 4 // nb).astype(np.int32)
    cj = (k2 // 4 % nb).astype(np.int32)
    body_dyn = np.zeros((nb, 8))
    body_dyn[:, DYN_INV_MASS] = 1.0
    f2 = np.tile(np.array([0, 0, 1, 1, 0, 0, 0, 1, 0.0]), (m, 1))
    imp2 = np.zeros((m, 3))
    hits = nlgs.prepare(m, ci, cj, k2, f2, np.zeros(m), np.ones(m), np.ones(m), np.empty((m, 4)),
                        np.empty(m), imp2, body_dyn, np.zeros((nb, 6)), keys, glob, 1e-3, nb)
    stored = dict(zip(keys.tolist(), glob))
    for a in range(m):
        g = stored.get(int(k2[a]))
        if g is not None and g[2] > 0:  # kept, pressing along this frame's normal (z)
            np.testing.assert_array_equal(imp2[a], [g[2], g[0], g[1]])
        else:
            assert not imp2[a].any()
    assert hits == sum(1 for k in k2.tolist() if k in stored and stored[k][2] > 0) > 50
