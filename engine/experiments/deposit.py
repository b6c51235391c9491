"""The deposit under gravity of §2.4 (Fig. 7): a geometrically built TexSol sample, "only
geometrically admissible", relaxed under gravity in its mould to obtain the force network;
the wire's tortuosity ξ is measured before and after."""
from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from ..analysis import wall_forces
from ..analysis.wire import wire_chains
from ..prep import Box, Cylinder, paper_sample
from ..prep.samples import Sample
from ..prep.relax import kinetic_energy
from ..model import MAX_OVERLAP, OVERLAP_TOL
from ..scene import Scene
from .config import DepositConfig
from .common import (RestCheckpoint, RestResult, check_bool, check_scale, compile_options,
                     deposit_laws, finish, rest_run, rest_summary, run_identity, run_meta,
                     sample_identity, solver_choice, wire_before_after, wire_law_or_default)

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
                    chain_solve: bool = False, contact_compliance: float = 0.0,
                    overlap_tol: float | None = OVERLAP_TOL,
                    max_overlap: float = MAX_OVERLAP,
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
    cfg = _checked(SimpleNamespace(**locals()))
    ckpt = RestCheckpoint(cfg.history, cfg.checkpoint_every, cfg.record_every, identity)
    cfg.resume = check_bool("resume", cfg.resume)
    smp, cfg.law = _sample(cfg)
    model, state, sand, ids = _in_mould(smp, cfg)
    chains0 = wire_chains(model, state) if cfg.wire else []
    z0 = state.position[sand, 2].copy()
    done = rest_run(model, state, sand, lambda m, s: kinetic_energy(m, s, sand), cfg,
                    desc="gravity deposit", checkpoint=ckpt, record_start=True, meta=run_meta(
                        "gravity_deposit", cfg.steps, config=cfg.config.model_dump(mode="json"),
                        scale=cfg.scale, seed=cfg.seed,
                        sample=smp.name, wire=cfg.wire, wire_density=smp.wire_density,
                        wire_law=cfg.law, neighbour_contact=cfg.neighbour_contact, dt=cfg.dt,
                        theta=cfg.theta, tol=cfg.tol, max_iter=cfg.max_iter, mu=cfg.mu,
                        mu_wall=cfg.mu_wall, mu_wire=cfg.mu_wire, steps=cfg.steps,
                        ke_fraction=cfg.ke_fraction))
    state = done.state
    chains1 = wire_chains(model, state) if cfg.wire else []
    res = DepositResult(
        name="gravity_deposit", time=done.rec.array("time"),
        kinetic_energy=done.rec.array("kinetic_energy"),
        **wire_before_after(chains0, chains1, smp.container.volume),
        settlement=float(np.mean(z0 - state.position[sand, 2])),
        wall_force=-float(wall_forces(model, state)[:, 2].sum()),   # on the walls: downward
        slack_share=float(np.mean(state.links.tension <= 0.0)) if model.n_links else math.nan,
        weight=float(model.body_mass[ids].sum() * G), at_rest=done.at_rest,
        history=done.hist.path, params=_params(cfg, smp))
    return finish(res, done.stages, cfg.max_nonconverged)


def _checked(cfg):
    """The arguments checked and turned into the test's config (``cfg.config``,
    :class:`~engine.experiments.config.DepositConfig`; a :class:`Sample` given against
    ``wire`` and ``wire_density``, ``wire`` then the sample's), the run's values from it,
    the scale and solver choice resolved; ``cfg.given``: a sample was given."""
    sample = cfg.sample
    cfg.given = isinstance(sample, Sample)
    args = {k: v for k, v in vars(cfg).items() if k in DepositConfig.keywords()}
    if cfg.given:
        if cfg.wire_density is not None:
            raise ValueError("gravity_deposit: wire_density builds the deposit's own sample; "
                             "with a Sample given, build the sample with it")
        if not cfg.wire and sample.wire:
            raise ValueError(f"gravity_deposit: wire = False but the sample has a wire of "
                             f"{sample.n_beads} beads; give a sample built with wire=False")
        args["sample"] = sample.name if sample.name in SAMPLES else "slope"  # (checked below)
        cfg.wire = args["wire"] = bool(sample.wire)
    config = DepositConfig.from_kwargs(**args)     # the arguments checked
    vars(cfg).update({k: v for k, v in config.kwargs().items() if k != "sample"},
                     config=config)
    cfg.scale = check_scale(cfg.scale)
    cfg.anderson, cfg.hot_sweeps = solver_choice(cfg.anderson, cfg.hot_sweeps)
    return cfg


def _sample(cfg):
    """(the geometric sample to relax: the one given, or :func:`engine.prep.paper_sample`'s;
    the wire's law)."""
    kw = dict(wire=cfg.wire, seed=cfg.seed)
    if cfg.wire_density is not None:
        kw["wire_density"] = cfg.wire_density
    law = wire_law_or_default(cfg.wire_law) if cfg.wire else None
    smp = cfg.sample if cfg.given else paper_sample(cfg.sample, cfg.scale, **kw)
    if not isinstance(smp.container, (Box, Cylinder)):
        raise ValueError(f"gravity_deposit: the sample's container is a "
                         f"{type(smp.container).__name__}; the mould is a Box or a Cylinder")
    return smp, law


def _in_mould(smp, cfg):
    """(model, state, sand ids, particle ids) of the sample in its mould (:func:`_mould`:
    its floor and side, open at the top, a little above the sand's top: the grains start at
    rest and only settle; it also frames the pictures on the sample)."""
    sc = Scene(gravity=(0.0, 0.0, -G))
    if cfg.wire:
        sand, beads = smp.add_to(sc, wire_law=cfg.law, neighbour_contact=cfg.neighbour_contact)
    else:
        sand, beads = smp.add_to(sc)[0], []
    ids = np.concatenate([sand, *beads]) if beads else np.asarray(sand)
    lo, hi = smp.container.bounds()
    _mould(sc, smp.container, 1.1 * max(hi[2] - lo[2], smp.height))
    deposit_laws(sc, "wall", mu=cfg.mu, mu_support=cfg.mu_wall, mu_wire=cfg.mu_wire,
                 wire=cfg.wire)
    model, state = sc.compile(**compile_options(cfg))
    return model, state, sand, ids


def _params(cfg, smp) -> dict:
    """``result.params``."""
    wire = cfg.wire
    return dict(scale=None if cfg.given else cfg.scale, sample=smp.name, wire=wire,
                wire_density=smp.wire_density, wire_law=repr(cfg.law),
                neighbour_contact=bool(wire and cfg.neighbour_contact), steps=cfg.steps,
                ke_fraction=cfg.ke_fraction, dt=cfg.dt, theta=cfg.theta, tol=cfg.tol,
                max_iter=cfg.max_iter, relax=cfg.relax, anderson=cfg.anderson,
                threads=cfg.threads, hot_sweeps=cfg.hot_sweeps,
                chain_solve=cfg.chain_solve, contact_compliance=cfg.contact_compliance,
                overlap_tol=cfg.overlap_tol,
                mu=cfg.mu, mu_wall=cfg.mu_wall,
                mu_wire=cfg.mu_wire, seed=cfg.seed, n_sand=int(smp.sand_radii.size),
                n_beads=smp.n_beads, friction_angle_deg=math.degrees(math.atan(cfg.mu)),
                config=cfg.config.model_dump(mode="json"))
