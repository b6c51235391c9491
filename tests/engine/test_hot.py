"""Re-sweeps of the hot contacts (Options.hot_sweeps, engine.solver.nlgs.iterate_hot, and
on threads engine.solver.parallel.iterate_groups): the same solution as plain Gauss–Seidel
within the tolerance, in fewer full sweeps."""
import numpy as np
import pytest

from engine import step
from engine.model import Options
from engine.solver.nlgs import hot_list

from tests.helpers import (assert_option_refused, assert_same_wire_lid_trajectory, slow_params,
                           same_converged_step)


@pytest.mark.parametrize("bad", [-1, 9, 2.5, "three", None, True])
def test_hot_sweeps_is_validated(bad):
    assert_option_refused("hot_sweeps", bad)


def test_hot_sweeps_refuse_mixing():
    with pytest.raises(ValueError, match="hot_sweeps = 3 works with the unmixed sweep only"):
        Options(dt=1e-3, alert=0.0, skin=1e-3, hot_sweeps=3, anderson=4, threads=2)
    assert Options(dt=1e-3, alert=0.0, skin=1e-3, hot_sweeps=0, anderson=4).hot_sweeps == 0
    assert Options(dt=1e-3, alert=0.0, skin=1e-3, hot_sweeps=3, threads=2).threads == 2


def test_hot_list_and_its_group_starts():
    """hot_list: the contacts above factor x the mean, in order, and where each group
    starts in that list (against numpy)."""
    rng = np.random.default_rng(5)
    q = rng.exponential(1.0, 1000) ** 3
    bounds = np.array([0, 0, 137, 500, 999, 1000], np.int64)
    hot, hb = np.empty(1000, np.int32), np.empty(bounds.size, np.int64)
    m = hot_list(1000, q, 2.0, hot, bounds, hb)
    want = np.flatnonzero(q > 2.0 * q.sum() / 1000)
    assert 0 < m < 1000
    assert np.array_equal(hot[:m], want)
    assert np.array_equal(hb, np.searchsorted(want, bounds))


@pytest.mark.parametrize("threads", [1, *slow_params(2, 3)])
@pytest.mark.parametrize("at", [150, 700])
def test_hot_step_matches_plain_within_tolerance(pile_states, at, threads):
    """From the same state, one step converged to tol 1e-10 gives the plain Gauss–Seidel
    velocities (to 1e-6 of the velocity one step of gravity gives) and per-body contact
    impulses (to 1e-8 of the largest), on one thread and with the re-sweeps in the
    parallel group order."""
    model, states = pile_states
    tight = model.with_options(tol=1e-10, max_iter=50000)
    same_converged_step(tight, tight.with_options(hot_sweeps=3, threads=threads), states[at])


@pytest.mark.parametrize("threads", [1, *slow_params(2)])
def test_hot_needs_fewer_full_sweeps_on_a_landing_pile(pile_states, threads):
    """While the pile lands (step 150), the full sweeps to tol 1e-8 drop by at least 2x
    against plain Gauss–Seidel on as many threads (measured on one thread: 291 against
    76).  This counts full sweeps only; the time, re-sweeps included, is measured in
    docs/speed.md (rest deposit)."""
    model, states = pile_states
    tight = model.with_options(tol=1e-8, max_iter=50000, threads=threads)
    a_state, b_state = states[150].copy(), states[150].copy()
    a = step(tight, a_state)
    b = step(tight.with_options(hot_sweeps=3), b_state)
    assert a.converged and b.converged
    assert b.iterations * 2 <= a.iterations, (a.iterations, b.iterations)


@pytest.mark.parametrize("threads", [1, *slow_params(2)])
def test_hot_with_wire_and_driven_wall(threads):
    """Links (swept in the full sweeps) and a pressure-driven lid (its contacts in the
    second loop, or shared by every domain): the plain solver's trajectory within
    tolerance (tol 1e-10)."""
    assert_same_wire_lid_trajectory(dict(hot_sweeps=3, threads=threads))


@pytest.mark.parametrize("threads", [1, *slow_params(2)])
def test_hot_is_deterministic(pile_states, threads):
    model, states = pile_states
    hot = model.with_options(tol=1e-6, hot_sweeps=3, threads=threads)
    a, b = states[150].copy(), states[150].copy()
    for _ in range(3):
        step(hot, a)
        step(hot, b)
    assert np.array_equal(a.vel6, b.vel6)
