"""Anderson acceleration of the NLGS sweeps (Options.anderson, engine.solver.anderson):
the same solution as plain Gauss–Seidel within the tolerance, in fewer sweeps."""
import numpy as np
import pytest

from engine import step

from tests.helpers import (assert_option_refused, assert_same_wire_lid_trajectory,
                           same_converged_step)


@pytest.mark.parametrize("bad", [-1, 17, 2.5, "four", None])
def test_anderson_is_validated(bad):
    assert_option_refused("anderson", bad)


@pytest.mark.slow
@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("at", [150, 700])
def test_anderson_step_matches_plain_within_tolerance(pile_states, at, threads):
    """From the same state, one step converged to tol 1e-10 gives the plain serial
    Gauss–Seidel velocities (to 1e-6 of the velocity one step of gravity gives) and
    per-body contact impulses (to 1e-8 of the largest), on 1 and 2 threads."""
    model, states = pile_states
    tight = model.with_options(tol=1e-10, max_iter=50000, anderson=0)
    same_converged_step(tight, tight.with_options(anderson=4, threads=threads), states[at])


@pytest.mark.slow
@pytest.mark.parametrize("threads", [1, 2])
def test_anderson_needs_fewer_sweeps_on_a_settled_pile(pile_states, threads):
    """On the settled pile, the sweeps to tol 1e-8 drop by at least 2x against plain
    Gauss–Seidel on the same number of threads (measured: see docs/speed.md)."""
    model, states = pile_states
    tight = model.with_options(tol=1e-8, max_iter=50000, anderson=0, threads=threads)
    a_state, b_state = states[700].copy(), states[700].copy()
    a = step(tight, a_state)
    b = step(tight.with_options(anderson=4), b_state)
    assert a.converged and b.converged
    assert b.iterations * 2 <= a.iterations, (a.iterations, b.iterations)


@pytest.mark.slow
@pytest.mark.parametrize("threads", [1, 2])
def test_anderson_with_wire_and_driven_wall(threads):
    """Links (mixed with the contacts, unilateral ones projected on λ >= 0) and a
    pressure-driven lid: the plain serial solver's trajectory within tolerance (tol 1e-10,
    so that both are within ~1e-8 of the exact one after 15 steps)."""
    assert_same_wire_lid_trajectory(dict(anderson=4, threads=threads))


@pytest.mark.slow
@pytest.mark.parametrize("threads", [1, 2])
def test_anderson_is_deterministic(pile_states, threads):
    model, states = pile_states
    acc = model.with_options(tol=1e-6, anderson=4, threads=threads)
    a, b = states[150].copy(), states[150].copy()
    for _ in range(3):
        step(acc, a)
        step(acc, b)
    assert np.array_equal(a.vel6, b.vel6)
