"""The deposit under gravity of §2.4 (Fig. 7): a geometrically built TexSol sample, "only
geometrically admissible", relaxed under gravity in its mould to obtain the force network;
the wire's tortuosity ξ is measured before and after."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..analysis import wall_forces
from ..analysis.wire import wire_chains
from ..prep import Box, Cylinder, paper_sample
from ..prep.samples import Sample
from ..prep.relax import kinetic_energy
from ..scene import Scene
from .params import check_args
from .common import (RestCheckpoint, RestResult, check_bool, check_scale, sample_identity,
                     deposit_laws, finish, rest_recording, run_meta, rest_summary, run_identity,
                     run_to_rest, solver_choice, wire_before_after, wire_law_or_default)

__all__ = ["gravity_deposit", "DepositResult", "SAMPLES"]

G = 9.81

#: The samples a deposit can relax: the paper's three (engine.prep.paper_sample).
SAMPLES = ("slope", "cylinder", "box")


@dataclass(kw_only=True)
class DepositResult(RestResult):
    """What :func:`gravity_deposit` returns.

    Attributes
    ----------
    name : str
    time, kinetic_energy : (n,) [s], [J]       of the sand grains, per record.
    wire_before, wire_after : engine.analysis.WireStats | None   tortuosity ξ [m⁻¹] (Fig. 7),
                                               orientation tensor, length density.
    histograms_before, histograms_after : {plane: (edges, weights)}  wire element directions.
    settlement : float [m]                     mean downward displacement of the sand grains.
    wall_force : float [N]                     vertical force of the grains on the mould
                                               (floor and sides) at the end.
    weight : float [N]                         weight of the sample (sand and wire).
    slack_share : float                        share of the wire links carrying no tension
                                               at the end (nan without a wire).
    at_rest : bool;  history : str;  params, convergence : dict
    """

    settlement: float
    wall_force: float
    slack_share: float

    def __str__(self):
        return rest_summary(self, f"settlement {self.settlement * 1e6:.1f} µm; mould force "
                                  f"/ weight = {self.wall_force / self.weight:.4f}")


def _mould(sc, container, height):
    """The mould's walls (group "wall"): a floor plane at the container's base and its side
    (the cylinder's inner wall, or the box's four side planes), open at the top."""
    if isinstance(container, Cylinder):
        sc.add_plane(point=container.center, normal=(0, 0, 1), group="wall")
        sc.add_cylinder(center=container.center, axis=(0, 0, 1), radius=container.radius,
                        height=height, bottom=False, group="wall")   # the plane: the floor
    elif isinstance(container, Box):
        lo, hi = container.lo, container.hi
        sc.add_plane(point=lo, normal=(0, 0, 1), group="wall")
        for ax in (0, 1):
            n = [0.0, 0.0, 0.0]
            n[ax] = 1.0
            sc.add_plane(point=lo, normal=tuple(n), group="wall")
            n[ax] = -1.0
            sc.add_plane(point=hi, normal=tuple(n), group="wall")
    else:  # pragma: no cover - paper_sample builds only these two
        raise TypeError(f"no mould for a {type(container).__name__} container")


def gravity_deposit(scale: float = 0.05, *, sample: str | Sample = "slope", wire: bool = True,
                    wire_density: float | None = None, wire_law=None, neighbour_contact: bool = False, steps: int = 6000,
                    ke_fraction: float = 1e-4, dt: float = 1e-4, theta: float = 0.5,
                    tol: float = 1e-4, max_iter: int = 1000, relax: float = 1.0,
                    anderson: int = 0, threads: int = 1, hot_sweeps: int | None = None,
                    mu: float = 0.5, mu_wall: float = 0.5, mu_wire: float = 0.3,
                    record_every: int = 20, frames: int = 200,
                    max_nonconverged: float = 0.25, history: str = "out/gravity_deposit.h5",
                    seed: int = 0, checkpoint_every: int = 0, resume: bool = False,
                    progress: bool = True) -> DepositResult:
    """The deposit under gravity of §2.4 that turns a geometric sample into a granular
    medium, and its Fig. 7: "A deposit is then made under gravity to relax the sample and to
    obtain the force network. Consequently, the geometry is modified, namely wire
    tortuosity ξ is amplified" (839 → 1 464 m⁻¹ in the paper), with ξ = (1/l) ∫ ρ⁻¹(s) ds
    (:func:`engine.analysis.tortuosity`).

    ``sample`` is one of :data:`SAMPLES`, built by :func:`engine.prep.paper_sample` at
    ``scale`` (1: the paper's size; the slope sample, Ø12 mm × 14 mm with 26 000 grains
    and 400 km·m⁻³ of wire, by default; ``wire_density`` [m/m³] for another content), or a
    geometric sample already built (an :class:`engine.prep.Sample`: ``scale``, ``seed`` and
    ``wire_density`` then do not build it; ``wire=False`` is refused with a sample that has
    a wire).  It
    stays in its mould (the container's floor and side, with friction ``mu_wall`` for sand
    and wire; open at the top) and runs under gravity, each step the
    θ-method (Eq. 4) with NLGS on the contacts and the wire links (Eq. 5-15), until the
    sand's kinetic energy is below ``ke_fraction`` of its peak, or ``steps`` steps.  The
    wire beads are left out of the criterion: a bead of a taut wire keeps a velocity of
    (its link's position error)/h that flips sign every step (:func:`engine.prep.relax`).
    The history has a frame of the geometric sample (step 0) and of the end.
    Solver options as in :func:`slope_deposit`.
    ``neighbour_contact``: linked wire beads also touch like two spheres
    (:meth:`engine.Scene.add_wire`; default False: a slack link lets its two beads overlap).
    ``checkpoint_every`` [steps] (default 0: only when interrupted): a checkpoint
    (``history`` with the suffix ``.resume.h5``, :class:`engine.experiments.common.RestCheckpoint`)
    that far apart and when Ctrl-C / SIGTERM stops the run; ``resume=True`` goes on from
    one left by the same call (a run killed or stopped), bit for bit as if it had never
    stopped, and starts afresh, with a warning, from a checkpoint of other parameters.
    """
    identity = run_identity(dict(locals(), sample=sample_identity(sample),
                                 test="gravity_deposit"))
    given = isinstance(sample, Sample)
    args = dict(locals())
    if given:
        if wire_density is not None:
            raise ValueError("gravity_deposit: wire_density builds the deposit's own sample; "
                             "with a Sample given, build the sample with it")
        if not wire and sample.wire:
            raise ValueError(f"gravity_deposit: wire = False but the sample has a wire of "
                             f"{sample.n_beads} beads; give a sample built with wire=False")
        args["sample"] = sample.name if sample.name in SAMPLES else "slope"  # (checked below)
        wire = bool(sample.wire)
    check_args("gravity_deposit", args)
    scale = check_scale(scale)
    anderson, hot_sweeps = solver_choice(anderson, hot_sweeps)
    ckpt = RestCheckpoint(history, checkpoint_every, record_every, identity)
    resume = check_bool("resume", resume)
    kw = dict(wire=wire, seed=seed)
    if wire_density is not None:
        kw["wire_density"] = wire_density
    law = wire_law_or_default(wire_law) if wire else None
    smp = sample if given else paper_sample(sample, scale, **kw)
    if not isinstance(smp.container, (Box, Cylinder)):
        raise ValueError(f"gravity_deposit: the sample's container is a "
                         f"{type(smp.container).__name__}; the mould is a Box or a Cylinder")
    sc = Scene(gravity=(0.0, 0.0, -G))
    sand, beads = smp.add_to(sc, wire_law=law, neighbour_contact=neighbour_contact) if wire else (smp.add_to(sc)[0], [])
    ids = np.concatenate([sand, *beads]) if beads else np.asarray(sand)
    # the grains start at rest and only settle: a side a little above the sand's top holds
    # them (and frames the pictures on the sample)
    lo, hi = smp.container.bounds()
    _mould(sc, smp.container, 1.1 * max(hi[2] - lo[2], smp.height))
    deposit_laws(sc, "wall", mu=mu, mu_support=mu_wall, mu_wire=mu_wire, wire=wire)
    model, state = sc.compile(dt=dt, theta=theta, tol=tol, max_iter=max_iter, relax=relax,
                              anderson=anderson, threads=threads, hot_sweeps=hot_sweeps)
    chains0 = wire_chains(model, state) if wire else []
    z0 = state.position[sand, 2].copy()
    resumed = ckpt.load(model, history) if resume else None
    if resumed is not None:
        state = resumed.state

    rec, hist, stages = rest_recording(model, state, sand, history=history,
                                       record_every=record_every, frames=frames,
                                       progress=progress, steps=steps, desc="gravity deposit",
                                       checkpoint=ckpt, resumed=resumed,
                                       meta=run_meta(
                                           "gravity_deposit", steps, scale=scale, seed=seed,
                                           sample=smp.name, wire=wire,
                                           wire_density=smp.wire_density,
                                           wire_law=law, neighbour_contact=neighbour_contact,
                                           dt=dt, theta=theta, tol=tol, max_iter=max_iter,
                                           mu=mu, mu_wall=mu_wall, mu_wire=mu_wire, steps=steps,
                                           ke_fraction=ke_fraction))
    try:
        if resumed is None:
            rec.write(model, state)      # the geometric sample: step 0, record and frame
            hist.write(model, state)
        at_rest = run_to_rest(stages, steps, record_every, ke_fraction,
                              lambda: kinetic_energy(model, state, sand), checkpoint=ckpt,
                              resumed=resumed)
    finally:
        stages.close()
        hist.close()
    if not stages.interrupted:
        ckpt.remove()
    ckpt.lock.release()
    fz = float(wall_forces(model, state)[:, 2].sum())       # on the walls: < 0 (downward)
    weight = float(model.body_mass[ids].sum() * G)
    chains1 = wire_chains(model, state) if wire else []
    res = DepositResult(
        name="gravity_deposit", time=rec.array("time"),
        kinetic_energy=rec.array("kinetic_energy"),
        **wire_before_after(chains0, chains1, smp.container.volume),
        settlement=float(np.mean(z0 - state.position[sand, 2])), wall_force=-fz,
        slack_share=float(np.mean(state.links.tension <= 0.0)) if model.n_links else math.nan,
        weight=weight, at_rest=at_rest, history=hist.path,
        params=dict(scale=None if given else scale, sample=smp.name, wire=wire, wire_density=smp.wire_density,
                    wire_law=repr(law), neighbour_contact=bool(wire and neighbour_contact), steps=steps, ke_fraction=ke_fraction, dt=dt,
                    theta=theta, tol=tol, max_iter=max_iter, relax=relax, anderson=anderson,
                    threads=threads, hot_sweeps=hot_sweeps, mu=mu, mu_wall=mu_wall,
                    mu_wire=mu_wire, seed=seed, n_sand=int(smp.sand_radii.size),
                    n_beads=smp.n_beads, friction_angle_deg=math.degrees(math.atan(mu))))
    return finish(res, stages, max_nonconverged)
