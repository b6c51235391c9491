"""Relaxation of a geometric sample under gravity (paper §2.4: "A deposit is then made under
gravity to relax the sample and to obtain the force network")."""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..analysis.energy import kinetic_energy
from ..model import SPHERE
from ..step import NonConvergenceWarning, run
from ..trigger import Updater

__all__ = ["relax", "RelaxReport", "kinetic_energy"]


@dataclass
class RelaxReport:
    """What :func:`relax` did.

    Attributes
    ----------
    steps : int;  time : float [s] simulated;  wall_time : float [s]
    peak_kinetic_energy, final_kinetic_energy : float [J]
    ratio : float        final / peak.
    at_rest : bool       the criterion ratio <= ke_fraction was met.
    interrupted : bool   Ctrl-C / SIGTERM stopped it.
    non_converged : list of int   steps that hit max_iter.
    wire_kinetic_energy : float [J]  of the wire beads at the end (not in the criterion).
    history : (k, 2) array of (time [s], kinetic energy [J]) at each check.
    top_body : int             the watched body with the most kinetic energy at the end
    top_share : float          its share of the final kinetic energy
    top_spin_share : float     the share of its own energy that is rotation
    """

    steps: int = 0
    time: float = 0.0
    wall_time: float = 0.0
    peak_kinetic_energy: float = 0.0
    final_kinetic_energy: float = 0.0
    ratio: float = math.nan
    at_rest: bool = False
    interrupted: bool = False
    non_converged: list = field(default_factory=list)
    wire_kinetic_energy: float = 0.0
    history: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    top_body: int = -1
    top_share: float = 0.0
    top_spin_share: float = 0.0

    def __str__(self):
        state = "at rest" if self.at_rest else "NOT at rest"
        s = (f"relaxation {state} after {self.steps} steps ({self.time:.4g} s simulated, "
             f"{self.wall_time:.3g} s wall): kinetic energy {self.final_kinetic_energy:.3g} J "
             f"= {self.ratio:.2e} of its peak {self.peak_kinetic_energy:.3g} J")
        if self.wire_kinetic_energy:
            s += f" (wire beads: {self.wire_kinetic_energy:.3g} J)"
        if not self.at_rest and self.top_body >= 0 and self.top_share >= 0.5:
            s += (f"; body {self.top_body} holds {100 * self.top_share:.0f} % of it, "
                  f"{100 * self.top_spin_share:.0f} % of that in rotation")
            if self.top_spin_share >= 0.5:
                s += (" (a point contact has no rolling or spinning friction: a grain can turn "
                      "in place for good; watch other bodies with bodies=)")
        if self.non_converged:
            s += f"; {len(self.non_converged)} steps did not converge"
        if self.interrupted:
            s += "; interrupted"
        return s


def _top_body(rep, model, state, bodies) -> None:
    """Fill ``rep.top_*``: which watched body holds the most kinetic energy, and how."""
    if bodies.size == 0:
        return
    v = state.vel6[bodies]
    trans = 0.5 * model.body_mass[bodies] * np.einsum("ij,ij->i", v[:, :3], v[:, :3])
    rot = 0.5 * model.body_inertia[bodies] * np.einsum("ij,ij->i", v[:, 3:], v[:, 3:])
    e = trans + rot
    total = float(e.sum())
    if total <= 0.0:
        return
    k = int(np.argmax(e))
    rep.top_body = int(bodies[k])
    rep.top_share = float(e[k] / total)
    rep.top_spin_share = float(rot[k] / e[k])


class _Watch(Updater):
    """The updater and stop condition of :func:`relax`: every ``check_every`` steps (and at
    the last, ``max_steps``) it reads the watched bodies' kinetic energy into the report and
    the bar; at rest when, from ``min_steps`` on, it is at most ``ke_fraction`` of its
    peak."""

    def __init__(self, rep, origin, check_every, max_steps, min_steps, ke_fraction, bodies,
                 progress):
        self.rep, self.origin, self.every = rep, origin, check_every
        self.max_steps, self.min_steps, self.f, self.bodies = (max_steps, min_steps,
                                                               ke_fraction, bodies)
        self.history, self.last, self.shown = [], None, 0
        self.bar = None
        if progress:
            from tqdm.auto import tqdm
            import sys
            self.bar = tqdm(total=int(max_steps), unit="step", desc="relax", dynamic_ncols=True,
                            mininterval=0.1 if sys.stderr.isatty() else 10.0)

    def trigger(self, step) -> bool:
        n = step - self.origin
        return n % self.every == 0 or n == self.max_steps

    def update(self, model, state) -> None:
        rep = self.rep
        self.last = state.step
        ke = kinetic_energy(model, state, self.bodies)
        self.history.append((state.time, ke))
        rep.peak_kinetic_energy = max(rep.peak_kinetic_energy, ke)
        rep.final_kinetic_energy = ke
        rep.ratio = ke / rep.peak_kinetic_energy if rep.peak_kinetic_energy > 0 else 0.0
        if self.bar is not None:
            n = state.step - self.origin
            self.bar.update(n - self.shown)
            self.shown = n
            self.bar.set_postfix(ke_ratio=f"{rep.ratio:.1e}", refresh=False)

    def __call__(self, model, state) -> bool:
        return state.step - self.origin >= self.min_steps and self.rep.ratio <= self.f


def relax(model, state, *, ke_fraction: float = 1e-4, max_steps: int = 20000,
          min_steps: int = 100, check_every: int = 10, bodies=None,
          progress: bool = True) -> RelaxReport:
    """Run the model under its gravity until the kinetic energy falls below ``ke_fraction``
    of its peak, so the sample settles and its force network forms.

    Parameters
    ----------
    model, state : from :meth:`engine.Scene.compile`; the state is advanced in place.
    ke_fraction : float in (0, 1)
        Rest criterion: E_k <= ke_fraction × max over the run of E_k.
    max_steps : int
        Give up after this many steps (the report says ``at_rest=False`` and a warning is
        issued).
    min_steps : int
        Steps before the criterion is looked at (the sample starts at rest: E_k rises first).
    check_every : int
        Steps between two evaluations of E_k.
    bodies : (k,) int, optional
        The bodies whose E_k is watched.  Default: every sphere that is not a wire bead.
        Wire beads are left out because their kinetic energy does not die out: a bead of a
        taut wire resting on grains keeps a velocity of the order of (its link's position
        error)/h that flips sign from step to step (measured: a few mm/s at h = 1e-4 s, for a
        negligible mass), while its position stays put to the micrometre.  Their energy is
        reported as ``wire_kinetic_energy``.
    progress : bool
        A tqdm bar with E_k / peak.

    Returns
    -------
    RelaxReport
    """
    f = float(ke_fraction)
    if not 0.0 < f < 1.0:
        raise ValueError(f"ke_fraction must be in (0, 1), got {ke_fraction!r}")
    for name, v, lo in (("max_steps", max_steps, 1), ("min_steps", min_steps, 0),
                        ("check_every", check_every, 1)):
        if not isinstance(v, (int, np.integer)) or v < lo:
            raise ValueError(f"{name} must be an integer >= {lo}, got {v!r}")
    beads = np.unique(np.concatenate([np.asarray(model.link_i), np.asarray(model.link_j)]))
    if bodies is None:
        sph = np.flatnonzero(np.asarray(model.body_kind) == SPHERE)
        bodies = np.setdiff1d(sph, beads)
    rep = RelaxReport()
    watch = _Watch(rep, state.step, check_every, max_steps, min_steps, f, bodies, progress)
    t0 = state.time
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NonConvergenceWarning)
            summ = run(model, state, int(max_steps), progress=False, updaters=[watch],
                       until=watch)
        if summ.interrupted and watch.last != state.step:
            watch.update(model, state)          # the state a Ctrl-C left, looked at too
        rep.steps, rep.wall_time = summ.steps, summ.wall_time
        rep.non_converged = list(summ.non_converged)
        rep.interrupted = summ.interrupted
        rep.at_rest = summ.condition_met and not summ.interrupted
    finally:
        if watch.bar is not None:
            watch.bar.close()
        rep.time = state.time - t0
        rep.wire_kinetic_energy = kinetic_energy(model, state, beads) if beads.size else 0.0
        _top_body(rep, model, state, np.asarray(bodies))
        rep.history = np.asarray(watch.history).reshape(-1, 2)
    if not rep.at_rest and not rep.interrupted:
        warnings.warn(str(rep), RuntimeWarning, stacklevel=2)
    if rep.non_converged:
        warnings.warn(str(rep), NonConvergenceWarning, stacklevel=2)
    return rep
