"""One time step, and the run loop with writers, progress bar and Ctrl-C safety.

The order of one step (each stage a public function of ``(model, state)``, testable alone):

1. :func:`engine.integrator.free_velocity` — drive forces at t_i, positions moved to the
   θ-predicted configuration q_m = q_i + (1-θ) h v_i, free velocity
   v_free = v_i + h M⁻¹ F (Eq. 4), imposed velocities set to their value at t_{i+1};
2. :func:`engine.contact.detect` — broadphase (rebuilt when a sphere has moved more than
   half the skin) and narrowphase at q_m: active contacts, gaps, local frames;
3. :func:`engine.solver.nlgs.solve` — warm start from the previous step's impulses, NLGS
   sweeps on Signorini + Coulomb (Eq. 5-6) until the Quad residual is below ``tol`` or
   ``max_iter``; the body velocities become v_{i+1}.  If the solved velocities close a
   candidate pair that the free ones left open (a grain stopped under a falling one, whose
   free velocities were equal; :func:`engine.contact.late_contacts_possible`), the
   narrowphase looks again with them, the pair is added and the step solved again from the
   impulses found, until the contacts no longer change or :data:`LATE_PASSES` times;
4. :func:`engine.integrator.update` — q_{i+1} = q_m + θ h v_{i+1}; time advances by h;
   with ``Options.overlap_tol``, :func:`engine.solver.projection.correct_positions` then
   pushes the overlaps beyond it out, on positions only (no velocity changed).

:func:`run` then, after each complete step n (``state.step`` = n):

5. the checks of :mod:`engine.sanity` (NaN/Inf, overlap, a sphere through a wall);
6. every **writer** whose ``trigger(n)`` fires, in list order (writers never modify the
   state: they see the step as it was computed, with the drive values it used);
7. every **updater** whose ``trigger(n)`` fires, in list order (:class:`Updater`): it may
   change the state (``state.load``, the drive values ``state.drive_pressure`` and
   ``state.drive_area``, ...); what it sets acts from step n + 1 on, and an updater later in
   the list sees what an earlier one set;
8. the stop condition ``until`` (when its trigger fires): true ends the run after step n;
9. a Ctrl-C / SIGTERM request ends the run after step n (its updaters have run, so the state
   is a restart point whatever the step).

HOOMD-blue's ``Simulation.run`` runs its updaters at the start of the next step with the
trigger of the step just done: the same order, except at the ends of a run (here the
updaters of a run's last step run, and none before its first; an updater's optional
``start(model, state)`` is called before the first step instead).
"""
from __future__ import annotations

import signal
import warnings
import time as _time
from dataclasses import dataclass, field
from typing import Callable, Iterable

import numpy as np

from . import stop as _stop
from .errors import NonConvergenceWarning, SimulationError
from .contact import detect, late_contacts_possible, restore_pairs
from .integrator import free_velocity, update
from .sanity import (ENERGY_WARN, OVERLAP_WARN, THROUGH, PhysicsWarning, energy_sources,
                     max_overlap, overlap_advice, reaction_gain, through_walls)
from .solver.nlgs import _break_links, solve
from .solver.projection import correct_positions
from .solver.residual import natural_residual
from .state import ContactBuffers, StepStats
from .model import SPHERE
from .trigger import CallbackUpdater, Updater, every  # noqa: F401  (public here)


#: Most extra solves of one step for contacts closed by the solve itself (:func:`step`).
LATE_PASSES = 3


class _Undo:
    """What a step changes before its solve ends, kept so that a stop request seen inside
    the solve (:class:`engine.stop.StepInterrupted`) can put the state back as it was before
    the step, bit for bit: positions, velocities, forces and the links' warm start are
    copied (72 bytes per body and 56 per link, a step's only copy), the contact buffer is
    swapped with a spare one (detection fills the spare), and a candidate list the step
    rebuilt is rebuilt as it was (:func:`engine.contact.restore_pairs`)."""

    _ARRAYS = ("position", "vel6", "force", "link_impulse", "link_normal", "link_gap")

    def __init__(self):
        self.saved = {}
        self.spare = None

    @staticmethod
    def needed(model, state) -> bool:
        """Whether the step's NLGS loop may run in chunks (:func:`engine.stop.in_chunks`), so
        that a stop request can end it: ``max_iter`` above the sweeps between two looks, for
        twice the previous step's contacts.  Otherwise the loop is one call (a small scene,
        at the default max_iter 1000 up to ~1000 contacts) and nothing is kept: the step
        pays nothing for what it cannot use."""
        every = _stop.sweeps_between_checks(2 * state.contacts_buf.count, model.n_links)
        return model.options.max_iter > every

    def keep(self, state) -> None:
        for name in self._ARRAYS:
            a = getattr(state, name)
            b = self.saved.get(name)
            if b is None or b.shape != a.shape or b.dtype != a.dtype:
                b = self.saved[name] = np.empty_like(a)
            np.copyto(b, a)
        self.pairs = (state.pairs_ref, state.pairs_margin, state.n_pairs,
                      state.workspace.sphere_order)
        c = state.contacts_buf
        if self.spare is None or self.spare is c:
            self.spare = ContactBuffers(c.cap)
        self.contacts, state.contacts_buf, self.spare = c, self.spare, c

    def restore(self, model, state) -> None:
        for name in self._ARRAYS:
            np.copyto(getattr(state, name), self.saved[name])
        ref, margin, n_pairs, order = self.pairs
        if state.pairs_ref is not ref:       # the step rebuilt the candidate list
            if ref is not None:
                restore_pairs(model, state, ref, margin, n_pairs)
            state.pairs_ref, state.pairs_margin, state.n_pairs = ref, margin, n_pairs
            state.workspace.sphere_order = order
        state.contacts_buf = self.contacts


def step(model, state) -> StepStats:
    """Advance ``state`` by one time step h = ``model.options.dt`` (in place).

    Returns
    -------
    StepStats
        ``iterations``, ``residual``, ``converged``, ``n_contacts``, ``rebuilt``.
    """
    return _step(model, state, None)


def _step(model, state, undo: _Undo | None) -> StepStats:
    """:func:`step`; with ``undo`` (:func:`run`), what the step changes before its solve
    ends is kept there first."""
    if undo is not None and undo.needed(model, state):
        undo.keep(state)
        with _stop.watching():
            return _stages(model, state)
    return _stages(model, state)


def _stages(model, state) -> StepStats:
    free_velocity(model, state)
    rebuilt = detect(model, state)
    free = state.workspace.free_vel          # the free velocities, kept for a second look
    if free is None or free.shape != state.vel6.shape:
        free = state.workspace.free_vel = np.empty_like(state.vel6)
    np.copyto(free, state.vel6)
    it, res = solve(model, state, break_links=False)
    c = state.contacts_buf
    late = 0
    for _ in range(LATE_PASSES):
        if not late_contacts_possible(model, state, free):
            break
        keys = c.key[:c.count].copy()
        solved = state.vel6.copy()
        state.vel6[:] = free
        rebuilt |= detect(model, state, solved=solved)
        if c.count == keys.size and np.array_equal(c.key[:c.count], keys):
            state.vel6[:] = solved          # the same contacts (and impulses): keep it
            break
        late += int(np.setdiff1d(c.key[:c.count], keys, assume_unique=True).size)
        more, res = solve(model, state, break_links=False)   # warm: this step's impulses
        it += more
    if model.n_links:
        _break_links(model, state, model.options.dt)
    gain, base = reaction_gain(state.vel6, free, model.body_mass, model.body_inertia,
                               model.sphere_ids, model.body_dof)
    nat = natural_residual(model, state, free) if model.options.natural_residual else None
    update(model, state)
    correct_positions(model, state)
    ov, at = max_overlap(c.count, c.gap, c.ri, c.rj, c.i, model.body_dof)
    stats = StepStats(iterations=it, residual=res, converged=res < model.options.tol,
                      n_contacts=c.count, rebuilt=rebuilt, late_contacts=late,
                      max_overlap=float(ov),
                      overlap_pair=(int(c.i[at]), int(c.j[at])) if at >= 0 else (-1, -1),
                      energy_gain=float(gain), free_energy=float(base),
                      natural_residual=nat)
    state.stats = stats
    return stats


def _check_ops(ops, kind: str, one: str, method: str) -> list:
    ops = list(ops)
    for k, o in enumerate(ops):
        if not (callable(getattr(o, "trigger", None)) and callable(getattr(o, method, None))):
            raise ValueError(f"{kind}[{k}] = {o!r}: {one} needs trigger(step) -> bool "
                             f"and {method}(model, state)")
    return ops


def _until_met(until, model, state) -> bool:
    if until is None:
        return False
    trigger = getattr(until, "trigger", None)
    if trigger is not None and not trigger(state.step):
        return False
    return bool(until(model, state))


class CallbackWriter:
    """A writer calling ``fn(model, state)`` when ``trigger(step)`` fires.

    Any object with ``trigger(step) -> bool`` and ``write(model, state)`` (and optionally
    ``flush()`` and ``close()``) is a writer.
    """

    def __init__(self, fn: Callable, trigger: Callable[[int], bool] | int = 1):
        self.fn = fn
        self.trigger = every(trigger) if isinstance(trigger, int) else trigger

    def write(self, model, state) -> None:
        self.fn(model, state)


@dataclass
class RunSummary:
    """What :func:`run` reports.

    Attributes
    ----------
    steps : int
        Steps done in this call.
    time : float [s]
        Simulated time reached.
    wall_time : float [s]
    interrupted : bool
        Ctrl-C (SIGINT) or SIGTERM stopped the run after a complete step.
    non_converged : list of int
        Step numbers that hit ``max_iter`` without reaching ``tol``.
    max_residual : float
        Largest final residual over the run's steps.
    mean_iterations : float
    max_contacts : int
    max_overlap : float
        Largest contact overlap of the run / the smaller radius [-]; above
        :data:`engine.sanity.OVERLAP_WARN` the summary says so.
    max_overlap_step : int
        The step it was seen (-1: no overlap).
    max_overlap_travel : float
        How far that contact's two bodies moved against each other in that step, as a
        fraction of the smaller radius (what the warning's advice reads, :func:`_travel`).
    energy_gain : float
        Largest kinetic energy the reactions added to the free motion in one step, as a
        fraction of the free motion's (:func:`engine.sanity.reaction_gain`; 0 when none
        did), looked at in scenes without drives, elastic links or stretched rigid links only
        (:func:`engine.sanity.energy_sources`); above :data:`engine.sanity.ENERGY_WARN`
        the summary says so.
    energy_gain_step : int
        The step it was seen (-1: none).
    condition_met : bool
        The run's ``until`` condition ended it.
    """

    steps: int = 0
    time: float = 0.0
    wall_time: float = 0.0
    interrupted: bool = False
    non_converged: list = field(default_factory=list)
    max_residual: float = 0.0
    mean_iterations: float = 0.0
    max_contacts: int = 0
    max_overlap: float = 0.0
    max_overlap_step: int = -1
    max_overlap_travel: float = 0.0
    energy_gain: float = 0.0
    energy_gain_step: int = -1
    condition_met: bool = False

    def __str__(self) -> str:
        nc = len(self.non_converged)
        head = (f"{self.steps} steps to t = {self.time:.6g} s in {self.wall_time:.3g} s; "
                f"mean {self.mean_iterations:.1f} NLGS sweeps/step; up to {self.max_contacts} contacts; ")
        if nc:
            shown = ", ".join(map(str, self.non_converged[:10])) + (" ..." if nc > 10 else "")
            head += f"{nc} steps did NOT converge (max residual {self.max_residual:.3g}): steps {shown}"
        else:
            head += f"all steps converged (max residual {self.max_residual:.3g})"
        if self.max_overlap > OVERLAP_WARN:
            head += (f"; WARNING: overlaps up to {100 * self.max_overlap:.3g} % of a radius "
                     f"(step {self.max_overlap_step}; above {100 * OVERLAP_WARN:g} %: lower "
                     f"dt, or check speeds, loads and masses)")
        if self.energy_gain > ENERGY_WARN:
            head += (f"; WARNING: the reactions added kinetic energy ({self.energy_gain:.3g} of "
                     f"the free motion's, step {self.energy_gain_step}): they can only take it "
                     f"away, the solve did not hold (lower tol or dt)")
        if self.interrupted:
            head += "; interrupted"
        return head


def _travel(model, state, i: int, j: int) -> float:
    """How far bodies ``i`` and ``j`` (a contact) move against each other in one step at
    their velocities now, as a fraction of the smaller radius (a wall: the sphere's)."""
    if i < 0:
        return 0.0
    r = model.body_radius[i] if model.body_kind[j] != SPHERE else min(
        model.body_radius[i], model.body_radius[j])
    return float(np.linalg.norm(state.vel6[i, :3] - state.vel6[j, :3])
                 * model.options.dt / r)


def _check_physics(model, state, stats, walls) -> None:
    """The checks of :mod:`engine.sanity` that stop a run: an overlap past
    ``Options.max_overlap``, a sphere through a wall it interacts with."""
    limit = model.options.max_overlap
    if stats.max_overlap > limit:
        i, j = stats.overlap_pair
        travel = _travel(model, state, i, j)
        raise SimulationError(
            f"step {state.step} (t = {state.time:.6g} s): bodies {i} and {j} overlap by "
            f"{100 * stats.max_overlap:.3g} % of a radius, past max_overlap = {limit:g} "
            f"(results beyond it are not physical; max_overlap = 1000 goes on anyway); "
            f"{overlap_advice(model.options, travel)}")
    if walls.size:
        b, w, where = through_walls(state.position, model.body_radius, model.body_group,
                                    model.sphere_ids, walls, model.pair_law, model.body_kind,
                                    model.body_axis, model.body_height, model.body_caps,
                                    model.body_dof)
        if b >= 0:
            raise SimulationError(
                f"step {state.step} (t = {state.time:.6g} s): sphere {b} "
                f"{THROUGH[where].format(w=w)}; lower dt = {model.options.dt:g} s, or check "
                f"the wall's drive and the loads")


def _check_finite(model, state) -> None:
    bad = ~(np.isfinite(state.position).all(axis=1) & np.isfinite(state.vel6).all(axis=1))
    if bad.any():
        ids = np.flatnonzero(bad)
        raise SimulationError(
            f"non-finite position or velocity at step {state.step} (t = {state.time:.6g} s) "
            f"for {ids.size} bodies, e.g. ids {ids[:10].tolist()}; "
            f"check dt = {model.options.dt:g} s, drives and overlaps")


def run(model, state, steps: int, writers: Iterable = (), progress: bool = True, *,
        updaters: Iterable = (), until=None) -> RunSummary:
    """Run at most ``steps`` steps of :func:`step`; after each step, the writers, then the
    updaters, then the stop condition, each when its trigger fires (the module docstring
    has the order).

    Parameters
    ----------
    steps : int >= 0
        At most this many steps (fewer when ``until`` ends the run, or Ctrl-C).
    writers : iterable of writers (``trigger(step)``, ``write(model, state)``, optional
        ``flush()``); they run after a complete step and never modify the state.  A
        writer's optional ``write_start(model, state)`` is called before the first step
        (:class:`engine.io.History` writes the start state as its first frame there).
    progress : bool
        Show a tqdm progress bar with the step rate, NLGS sweeps and contacts.
    updaters : iterable of updaters (:class:`Updater`: ``trigger(step)``,
        ``update(model, state)``, optional ``start(model, state)``), run in list order after
        the writers of each step whose number fires their trigger.
    until : callable ``(model, state) -> bool`` or None
        The stop condition, looked at after the updaters (only on the steps its own
        ``trigger(step)`` fires, if it has one): true ends the run
        (``RunSummary.condition_met``).

    Returns
    -------
    RunSummary
        Non-converged steps are listed, never hidden: if there are any, a
        :class:`NonConvergenceWarning` carrying the summary is also issued.

    Raises
    ------
    SimulationError
        A position or velocity became NaN/Inf (the step and the bodies are named).

    Notes
    -----
    Ctrl-C (SIGINT) and SIGTERM stop the run: after the current step, or inside a long
    step, whose NLGS loop looks at the request every :func:`engine.stop.sweeps_between_checks`
    sweeps (about 40 ms of work; steps whose ``max_iter`` sweeps fit in one such chunk are
    not watched, they end within that time anyway); such a step is undone, the state is the
    previous step's bit for bit.  Writers are flushed and the summary (``interrupted=True``) is returned with
    the state reached.  A request made before the run (:func:`engine.stop.request`, what
    ``nscd``'s SIGTERM handler does from its start) stops it before its first step.
    """
    if not isinstance(steps, (int, np.integer)) or steps < 0:
        raise ValueError(f"steps must be an integer >= 0, got {steps!r}")
    writers = _check_ops(writers, "writers", "a writer", "write")
    updaters = _check_ops(updaters, "updaters", "an updater", "update")
    if until is not None and not callable(until):
        raise ValueError(f"until must be a callable (model, state) -> bool or None, got {until!r}")
    summary = RunSummary()
    stop = {"flag": False}

    def _handler(signum, frame):
        stop["flag"] = True
        _stop.request()

    old = {}
    try:  # signals can only be caught in the main thread
        for sig in (signal.SIGINT, signal.SIGTERM):
            old[sig] = signal.signal(sig, _handler)
    except ValueError:
        old = {}

    bar = None
    if progress:
        from tqdm.auto import tqdm

        import sys

        tty = sys.stderr.isatty()  # in a log file, a line every 10 s instead of every 0.1 s
        bar = tqdm(total=int(steps), unit="step", dynamic_ncols=True, leave=True,
                   mininterval=0.1 if tty else 10.0)
    t0 = _time.perf_counter()
    total_it = 0
    undo = _Undo()
    walls = model.wall_ids.astype(np.int64)
    check_energy = energy_sources(model, state) is None
    for w in writers:                   # the start state (a history's frame 0 ...)
        start = getattr(w, "write_start", None)
        if start is not None:
            start(model, state)
    try:
        for u in updaters:              # what an updater sets before the first step
            start = getattr(u, "start", None)
            if start is not None:
                start(model, state)
        for _ in range(int(steps)):
            if _stop.requested():        # also a request made before the run started
                stop["flag"] = True
                summary.interrupted = True
                break
            try:
                stats = _step(model, state, undo)
            except _stop.StepInterrupted:   # inside the step: the state before it, back
                undo.restore(model, state)
                summary.interrupted = True
                break
            _check_finite(model, state)
            if stats.max_overlap > summary.max_overlap:
                summary.max_overlap, summary.max_overlap_step = stats.max_overlap, state.step
                summary.max_overlap_travel = _travel(model, state, *stats.overlap_pair)
            if check_energy and stats.energy_gain > 0.0:
                rel = stats.energy_gain / max(stats.free_energy, 1e-300)
                if rel > summary.energy_gain:
                    summary.energy_gain, summary.energy_gain_step = rel, state.step
            _check_physics(model, state, stats, walls)
            summary.steps += 1
            total_it += stats.iterations
            summary.max_residual = max(summary.max_residual, stats.residual)
            summary.max_contacts = max(summary.max_contacts, stats.n_contacts)
            if not stats.converged:
                summary.non_converged.append(state.step)
            for w in writers:
                if w.trigger(state.step):
                    w.write(model, state)
            for u in updaters:
                if u.trigger(state.step):
                    u.update(model, state)
            if _until_met(until, model, state):
                summary.condition_met = True
            if bar is not None:
                bar.update(1)
                if summary.steps % 20 == 0 or summary.steps == steps:
                    bar.set_postfix(it=stats.iterations, res=f"{stats.residual:.1e}",
                                    contacts=stats.n_contacts, nc=len(summary.non_converged),
                                    refresh=False)
            if stop["flag"]:
                summary.interrupted = True
                break
            if summary.condition_met:
                break
    finally:
        if summary.interrupted or stop["flag"]:
            _stop.clear()                   # honoured
        for sig, h in old.items():
            signal.signal(sig, h)
        for w in writers:
            if hasattr(w, "flush"):
                w.flush()
        if bar is not None:
            bar.close()
        summary.wall_time = _time.perf_counter() - t0
        summary.time = state.time
        summary.mean_iterations = total_it / summary.steps if summary.steps else 0.0
    if summary.max_overlap > OVERLAP_WARN:
        warnings.warn(f"overlaps up to {100 * summary.max_overlap:.3g} % of a radius (step "
                      f"{summary.max_overlap_step}), above {100 * OVERLAP_WARN:g} %: "
                      f"{overlap_advice(model.options, summary.max_overlap_travel)}",
                      PhysicsWarning, stacklevel=2)
    if summary.energy_gain > ENERGY_WARN:
        warnings.warn(f"the reactions added kinetic energy to the free motion "
                      f"({summary.energy_gain:.3g} of it, step {summary.energy_gain_step}); "
                      f"contacts and rigid links can only take it away: the solve did not "
                      f"hold (lower tol or dt)", PhysicsWarning, stacklevel=2)
    if summary.non_converged:
        warnings.warn(str(summary), NonConvergenceWarning, stacklevel=2)
    elif progress:
        from tqdm.auto import tqdm

        tqdm.write(str(summary))
    return summary


__all__ = ["step", "run", "every", "Updater", "CallbackUpdater", "CallbackWriter",
           "RunSummary", "SimulationError", "NonConvergenceWarning"]
