"""Over-relaxed Gauss–Seidel, projected SOR (Options.relax in (1, 2),
engine.solver.nlgs._contact and link_sweep): the impulses stay on their cones, the
converged solution is the plain one within the tolerance, in fewer sweeps on a landing
pile."""
import numpy as np
import pytest

from engine import step
from engine.model import Options

from tests.helpers import assert_same_wire_lid_trajectory, same_converged_step


@pytest.mark.parametrize("at", [150, 700])
def test_over_relaxed_step_matches_plain_within_tolerance(pile_states, at):
    """From the same state, one step converged to tol 1e-10 with ω = 1.4 (alone, and with
    the hot re-sweeps) gives the plain Gauss–Seidel velocities and per-body impulses (to
    the tolerance-level bounds of same_converged_step)."""
    model, states = pile_states
    tight = model.with_options(tol=1e-10, max_iter=50000)
    same_converged_step(tight, tight.with_options(relax=1.4), states[at])
    same_converged_step(tight, tight.with_options(relax=1.4, hot_sweeps=2), states[at])


def test_relax_one_is_the_plain_sweep_bit_for_bit(pile_states):
    """ω = 1 runs the plain update; ω = 1 + 1e-12 the over-relaxed copy of the loops, whose
    extra terms are (ω - 1) u: the same step to rounding (velocities within 1e-9 g h)."""
    from tests.helpers import G

    model, states = pile_states
    a, b = states[150].copy(), states[150].copy()
    step(model, a)
    step(model.with_options(relax=1.0 + 1e-12), b)
    assert np.abs(a.vel6 - b.vel6).max() < 1e-9 * G * model.options.dt


def test_over_relaxation_needs_fewer_sweeps_on_a_landing_pile(pile_states):
    """While the pile lands (step 150) the sweeps to tol 1e-8 drop by at least a third at
    ω = 1.4 against ω = 1 (the stopping test divides the change by ω, so both stop on
    about the same Gauss–Seidel update size)."""
    model, states = pile_states
    tight = model.with_options(tol=1e-8, max_iter=50000)
    a_state, b_state = states[150].copy(), states[150].copy()
    a = step(tight, a_state)
    b = step(tight.with_options(relax=1.4), b_state)
    assert a.converged and b.converged
    assert b.iterations <= 0.67 * a.iterations, (a.iterations, b.iterations)


def test_over_relaxed_impulses_stay_on_their_cones(pile_states):
    """Even at ω = 1.9 with a sweep cap that stops every step before convergence, every
    contact impulse satisfies p_n >= 0 and ‖p_T‖ <= μ p_n (the local solver projects the
    over-relaxed update), and the run stays finite."""
    model, states = pile_states
    m = model.with_options(relax=1.9, max_iter=7)
    state = states[150].copy()
    for _ in range(20):
        step(m, state)
        c = state.contacts_buf
        p = c.impulse[:c.count]
        assert (p[:, 0] >= 0.0).all()
        assert (np.hypot(p[:, 1], p[:, 2]) <= c.mu[:c.count] * p[:, 0] * (1 + 1e-12)).all()
    assert np.isfinite(state.vel6).all()


def test_over_relaxed_wire_and_driven_wall_match_plain():
    """Links (unilateral: clamped to λ >= 0 after the relaxation) and a pressure-driven lid,
    15 steps at tol 1e-10 with ω = 1.4: the plain trajectory within tolerance."""
    assert_same_wire_lid_trajectory(dict(relax=1.4))


def test_relax_range_and_mixing():
    for bad in (0.0, 2.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match=r"relax = .*: must be a number in \(0, 2\)"):
            Options(dt=1e-3, alert=0.0, skin=1e-3, relax=bad)
    for other in (dict(anderson=4), dict(threads=2)):
        with pytest.raises(ValueError, match=r"relax = 1.5 > 1 \(over-relaxation\) works with "
                                             r"the unmixed sweep on one thread only"):
            Options(dt=1e-3, alert=0.0, skin=1e-3, relax=1.5, **other)
    assert Options(dt=1e-3, alert=0.0, skin=1e-3, relax=0.8, anderson=4, threads=2).relax == 0.8
    assert Options(dt=1e-3, alert=0.0, skin=1e-3, relax=1.5, hot_sweeps=2).relax == 1.5
