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
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


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
