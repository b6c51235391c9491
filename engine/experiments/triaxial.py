"""Triaxial tests of the paper: the box (§3.2, Fig. 11-12) and the cylinder (§3.3,
Fig. 13-16, Table 2).

Both run two stages on a geometric sample (:mod:`engine.prep.samples`), under gravity:

1. **isotropic**: the pressure p, raised linearly over ``ramp_steps``, is applied to the
   sides (pressure-driven side walls for the box; loads on the free-surface particles for
   the cylinder, :class:`engine.drivers.Confinement`) and to the top wall (pressure-driven),
   until the Weber mean stress (Eq. 18) and the top wall's stress are within ``iso_tol`` of p
   for ``iso_hold`` consecutive checks;
2. **triaxial**: the top wall moves down at a constant velocity v = ε̇ H₀, the lateral
   pressure held.  ε̇ comes from an inertial number I = ε̇ d √(ρ/p) (default I = 5e-4, a
   quasi-static test; the value used is in ``result.params``).

The default NLGS tolerance is 3e-4, not the engine's 1e-4: on these confined samples the
residual stagnates between 1e-4 and 2.5e-4 (measured on the cylinder at scale 0.05: 1 041 of
1 500 isotropic steps hit 1 000 sweeps at tol = 1e-4, relaxation 0.7 did not help; 186 of 800
at 3e-4, nearly all during the pressure ramp).  ``hot_sweeps`` (default None: 2, or 0 when
``anderson`` > 0; :data:`engine.experiments.common.HOT_SWEEPS`) re-sweeps the contacts that
changed most after each sweep (:attr:`engine.model.Options.hot_sweeps`, docs/speed.md).
``anderson`` (default 0) is the depth of the other NLGS acceleration
(:mod:`engine.solver.anderson`), the default before 2026-11-25.  ``threads`` (default 1) is
the NLGS thread count (:attr:`engine.model.Options.threads`); 2 pays only on samples of tens
of thousands of contacts (docs/speed.md).  ``chain_solve`` (default False) solves each wire
as one chain in every sweep (:attr:`engine.model.Options.chain_solve`, with every variant
of the sweep): on the rigid-wire cylinder at scale 0.3 it did not pay (docs/speed.md).

The walls' pressure is data: one :class:`~engine.schedules.Ramp` in the drives of the top
plate (and of the box's side walls), raised by :class:`~engine.schedules.FollowSchedules`;
their areas are :class:`~engine.schedules.Servo` values that :class:`engine.drivers.BoxFaces`
(the box's faces, each step) or :class:`engine.drivers.MembraneUpdater` (π R² of the
cylinder's membrane) set; the current values are in the State.  Each stage is one
:meth:`~engine.experiments.common.Stages.run` (:func:`engine.step.run`) with its updaters
and its stop condition (:class:`_Isotropic`; docs/experiments.md has the table).

Between the stages the top wall's drive is switched (:meth:`engine.model.Model.with_drive`).
A velocity-driven (kinematic) top wall in stage 1 was tried first: on a jammed packing of
rigid grains it made the NLGS fail to converge in 529 of 600 steps and overshot the target
stress by 100 %; a pressure-driven wall has no such infeasibility.
"""
from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from .. import laws
from ..analysis import (best_fit_strain, equivalent_stress, macro_stiffness, principal,
                        toroidal_map, wall_forces, weber_stress)
from ..drivers import BoxFaces, Confinement, MembraneUpdater
from ..schedules import FollowSchedules, Ramp, Servo
from ..trigger import Updater
from ..prep import Box, Cylinder, box_sample, cylinder_sample
from ..model import MAX_OVERLAP, TRIAXIAL_OVERLAP_TOL
from ..scene import Scene
from .config import CONFIGS
from .start import check_preparation, remove_group, start_of, without_wire
from .common import (ConfinementError, Recorder, Stages, TestResult, check_scale,
                     choose_rate, compile_options, finish, history_writer, run_meta,
                     solver_choice, wire_law_or_default)

__all__ = ["cylinder_triaxial", "box_triaxial"]

G = 9.81


def _laws_for(scene, mu, mu_wall, mu_wire, wire):
    scene.interact("sand", "sand", laws.Coulomb(mu=mu))
    scene.interact("sand", "wall", laws.Coulomb(mu=mu_wall))
    if wire:
        scene.interact("wire", "sand", laws.Coulomb(mu=mu_wire))
        scene.interact("wire", "wire", laws.Coulomb(mu=mu_wire))
        scene.interact("wire", "wall", laws.Coulomb(mu=mu_wire))


def _compaction_mu(value, least=0.0, why=""):
    """Check ``compaction_mu`` (None, or a friction coefficient >= ``least``; ``why``: the
    reason for ``least``, for the message)."""
    if value is None:
        return None
    try:
        m = float(value)
    except (TypeError, ValueError):
        m = float("nan")
    if not (math.isfinite(m) and m >= least):
        raise ValueError(f"compaction_mu must be None or a friction coefficient >= {least:g}"
                         f"{why}, got {value!r}")
    return m


def _compaction(model, compaction_mu):
    """The model of the isotropic stage: ``model`` itself, or, with ``compaction_mu`` set,
    a copy in which every contact (sand, wire and walls) has that friction coefficient
    (:meth:`engine.model.Model.with_friction`).  The triaxial stage always runs with the test's
    own ``mu``, ``mu_wall`` and ``mu_wire``.

    A low-friction compaction is the usual DEM way to reach a denser packing whatever the
    grains' friction (docs/paper.md, Fig. 14, has what it did to the cylinder samples).
    """
    return model if compaction_mu is None else model.with_friction(compaction_mu)


#: The cylinder test stops (:class:`ConfinementError`) when the confinement radius exceeds
#: this factor times its value at the start (:class:`engine.drivers.Confinement`'s
#: ``max_growth``).  A sample that stays together bulges by a few
#: per cent (Fig. 13a: 3.28 mm at mid-height against 3.03 at the ends at 10 % strain).  On
#: samples of scale 0.04 (about 250 grains) grains sometimes left the membrane (seed 1:
#: rigid wire and k = 1 N without compaction, and most runs with compaction_mu = 0.1).  The
#: escaped grain then counted as a surface grain, the force-weighted radius grew 150-200
#: times, the membrane's total force with it, and the run went on to a meaningless end.
RADIUS_RUNAWAY = 1.5


#: Smallest ``compaction_mu`` of the cylinder test: at 0 the free-surface confinement let
#: the frictionless grains out (scale 0.3, seed 0: the membrane radius blew up and the mean
#: stress stayed at 5 kPa of the 15 kPa target); 0.1 and 0.2 held at scale 0.3, not always
#: at 0.04 (docs/paper.md).
CYLINDER_COMPACTION_MU_MIN = 0.1


def cylinder_triaxial(scale: float = 0.05, *, sample=None, preparation: str = "geometric",
                      pressure: float = 15e3, wire: bool = True, wire_law=None,
                      neighbour_contact: bool = False, wire_density: float | None = None,
                      wire_mode: str = "isotropic", bead_radius: float | None = None,
                      helix_pitch: float | None = None, helix_inset: float | None = None,
                      remove_beads: str = "never",
                      wire_prestrain: float = 0.0, wire_taut_at_loading: bool = False,
                      confinement: str = "free_surface",
                      deposit_steps: int = 6000, axial_strain: float = 0.1,
                      strain_rate: float | None = None, target_I: float = 5e-4,
                      allow_dynamic: bool = False, dt: float = 5e-5, theta: float = 0.5,
                      tol: float = 3e-4, max_iter: int = 1000, relax: float = 1.0,
                      anderson: int = 0, threads: int = 1, hot_sweeps: int | None = None,
                      chain_solve: bool = False, contact_compliance: float = 0.0,
                      overlap_tol: float | None = TRIAXIAL_OVERLAP_TOL,
                      max_overlap: float = MAX_OVERLAP,
                      mu: float = 0.5, mu_wall: float = 0.5, mu_wire: float = 0.3,
                      compaction_mu: float | None = None, iso_tol: float = 0.02,
                      iso_hold: int = 5, iso_max_steps: int = 4000, confine_every: int = 10,
                      record_every: int = 10, frames: int = 100,
                      torus_strains=(0.02, 0.05, 0.1), max_nonconverged: float = 0.25,
                      ramp_steps: int = 400, history: str = "out/cylinder_triaxial.h5",
                      seed: int = 0, progress: bool = True) -> TestResult:
    """The cylinder triaxial test of §3.3 (Fig. 13-16, Table 2).

    The sample is :func:`engine.prep.cylinder_sample` (Ø9 mm × 20 mm, 6 200 grains + a wire
    at 250 km·m⁻³ at ``scale`` = 1) between a fixed floor and a top wall, confined by
    ``pressure`` [Pa] on its free-surface particles, then loaded to ``axial_strain`` at a
    constant velocity.  The paper's confining pressure for this test is not given: 15 kPa,
    its box test's, is the default.  ``wire_law``: the paper's ElasticWire(k = 1 N) by
    default; RigidWire() or ElasticWire(k) with k from 0.1 to 100 N for Table 2.
    ``compaction_mu``: the friction coefficient of every contact during the isotropic stage
    (None: the test's own; at least :data:`CYLINDER_COMPACTION_MU_MIN`), see
    :func:`_compaction`.
    ``neighbour_contact``: linked wire beads also touch like two spheres
    (:meth:`engine.Scene.add_wire`; default False: a slack link lets its two beads overlap).

    What the test starts from (:mod:`engine.experiments.start`, docs/experiments.md):

    * ``sample``: None (the test builds :func:`~engine.prep.cylinder_sample` at ``scale``
      with ``seed``, ``wire_density`` [m/m³] (None: the paper's), ``wire_mode``
      ("isotropic", Eq. 16, "orthotropic", Eq. 17, or "helix": the positive control of an
      encased column, ``helix_pitch`` [m] its rise per turn, ``helix_inset`` [m] its depth
      under the surface) and ``bead_radius`` r_w [m]
      (None: the paper's 0.135 mm)); a geometric
      :class:`engine.prep.Sample` in a cylinder; or an end state: a ``(model, state)``
      pair, a result with a history (``gravity_deposit``'s) or a history or checkpoint
      path, whose "sand" and "wire" particles are taken with their velocities and the
      links' own laws and reference lengths (its walls are left behind).
    * ``preparation``: "geometric" (the sample as it is) or "paper" (§2.4: the geometric
      sample relaxed under gravity in its mould first, :func:`gravity_deposit` with the
      test's solver options, ``mu_wall`` for the mould and at most ``deposit_steps``
      steps, its history ``<history>.deposit.h5``; then the mould removed).
    * ``remove_beads``: the controls of the reinforcement study.  "never" (default);
      "after_deposit": the wire sample is built (its sand laid around the beads), then its
      beads are taken out and the sand alone is prepared and tested
      (:func:`~engine.experiments.start.without_wire`); "at_loading": the TexSol sample is
      prepared and confined with its wire, then its beads leave the mechanics at the start
      of the loading (:func:`~engine.experiments.start.remove_group`: they stay in the
      files, fixed, touching nothing).  The beads without their links' force are
      ``wire_law=engine.laws.LooseWire()``.
    * ``wire_taut_at_loading``: at the start of the loading every link's reference length
      becomes its length then (a wire the preparation left slack, made just taut).
    * ``wire_prestrain`` ε₀: at the start of the loading every link's reference length
      becomes g/(1+ε₀), g its length then, so the preparation cannot relax it.
    * ``confinement``: "free_surface" (§3.3, :class:`engine.drivers.Confinement`) or
      "layer_crown" (LMGC90's 3D membrane example, :class:`engine.drivers.LayerCrown`).

    Returns a :class:`TestResult` (triaxial stage; the isotropic stage in
    ``extra["isotropic"]``); ``extra`` also holds the toroidal wire-stress maps at
    ``torus_strains`` (Fig. 13c), the macro-stiffness H of (ε_zz, σ_w^eq) (Table 2), the
    sample radius and height, the best-fit strains (Eq. 19) of the sand, the wire and all
    the particles over the loading (``best_fit_strain``, Fig. 12's measure) and
    ``extra["start"]``: what the test started from (the deposit's history, steps and
    settlement for the paper preparation) and, at the start of the loading, the sand's
    solid fraction in the confinement's volume and the wire's share of taut links and
    mean and largest tension [N].

    Raises ValueError for bad input (naming it), ConvergenceError when more than
    ``max_nonconverged`` of the steps hit ``max_iter``.
    """
    cfg = _config("cylinder_triaxial", dict(locals()), CYLINDER_COMPACTION_MU_MIN,
                  " (at 0 the free-surface confinement let the frictionless grains out)")
    st, deposit, cfg.law = _prepared("cylinder_triaxial", Cylinder, cylinder_sample, vars(cfg))
    rig = _cylinder_rig(st, cfg)
    _loading_rate(cfg, rig)
    rec, hist, stages = _recording(rig, cfg, "cylinder_triaxial", CYLINDER_UNITS,
                                   _cylinder_values(rig), cfg.confine_every)
    _run_stages(stages, hist, rig, cfg, lambda: _cylinder_isotropic(stages, rig, cfg),
                lambda: _cylinder_loading_updaters(rig, cfg))
    res = _cylinder_result(rig, cfg, rec, deposit)
    return finish(res, stages, cfg.max_nonconverged)


#: The test's arguments the paper preparation's deposit takes as they are.
_DEPOSIT_ARGS = ("dt", "theta", "tol", "max_iter", "relax", "anderson", "threads",
                 "hot_sweeps", "chain_solve", "contact_compliance", "overlap_tol",
                 "max_overlap", "mu",
                 "mu_wall", "mu_wire", "max_nonconverged", "seed")


def _prepared(test, shape, builder, a):
    """(the :class:`~engine.experiments.start.Start` of a triaxial test, the deposit's
    result or None, the wire's law): the test's ``sample`` or its own, built by
    ``builder`` (:func:`~engine.prep.cylinder_sample` or :func:`~engine.prep.box_sample`),
    prepared as its ``preparation`` says (:mod:`engine.experiments.start`; the paper
    preparation's :func:`~engine.experiments.gravity_deposit` takes the test's solver
    options, friction and seed, and ``deposit_steps``).  ``a``: the test's arguments (its
    ``locals()`` on entry, with the scale and the solver choice resolved).  The wire law
    and the prestrain are checked before any sample is built."""
    sample, wire, wire_density, wire_mode = (a["sample"], a["wire"], a["wire_density"],
                                             a["wire_mode"])
    remove = a["remove_beads"]
    if remove != "never" and not wire:
        raise ValueError(f"{test}: remove_beads = {remove!r} takes the beads out of a wire "
                         f"sample; wire = False has none")
    law = wire_law_or_default(a["wire_law"]) if wire else None
    _check_prestrain(test, a["wire_prestrain"], a["neighbour_contact"])
    preparation = check_preparation(a["preparation"])
    given = [n for n, v in (("wire_density", wire_density), ("bead_radius", a["bead_radius"]),
                            ("helix_pitch", a["helix_pitch"]),
                            ("helix_inset", a["helix_inset"])) if v is not None] \
        + (["wire_mode"] if wire_mode != "isotropic" else [])
    if sample is not None and given:
        raise ValueError(f"{test}: {', '.join(given)} build(s) the test's own sample; with "
                         f"sample= given, build the sample with them "
                         f"(engine.prep.{shape.__name__.lower()}_sample)")
    if sample is not None and preparation == "layered":
        raise ValueError(f"{test}: preparation = 'layered' builds the test's own sample in "
                         f"layers; with sample= given, build it with engine.prep."
                         f"{shape.__name__.lower()}_sample(build='layered') and use "
                         f"preparation='paper'")

    def build():
        helix = {k: a[k] for k in ("helix_pitch", "helix_inset") if a[k] is not None}
        layered = dict(build="layered") if preparation == "layered" else {}
        return builder(a["scale"], wire=wire, wire_density=wire_density, wire_mode=wire_mode,
                       bead_radius=a["bead_radius"], seed=a["seed"], **helix, **layered)

    st = start_of(test, shape, sample, build, wire=wire, wire_law=a["wire_law"])
    if remove == "after_deposit":
        st, law = without_wire(st), None
    if preparation == "geometric":
        return st, None, st.wire_law(law) if st.has_wire else None
    if st.sample is None:
        raise ValueError(f"{test}: preparation = 'paper' relaxes a geometric sample in its "
                         f"mould first; the sample given is {st.source}, an end state "
                         f"already (use preparation='geometric')")
    from .deposit import gravity_deposit

    dep = gravity_deposit(sample=st.sample, wire=st.has_wire, wire_law=law,
                          neighbour_contact=a["neighbour_contact"],
                          history=deposit_history(a["history"]), progress=a["progress"],
                          steps=a["deposit_steps"], **{k: a[k] for k in _DEPOSIT_ARGS})
    st = start_of(test, shape, dep.history, None, wire=wire)
    return st, dep, st.wire_law(law) if st.has_wire else None


def deposit_history(history) -> str:
    """Where the paper preparation's deposit writes its history: ``history`` with the
    suffix ``.deposit.h5``."""
    root, ext = os.path.splitext(os.fspath(history))
    return root + ".deposit.h5"


def _check_prestrain(test, eps, neighbour_contact):
    if eps and neighbour_contact:
        raise ValueError(f"{test}: wire_prestrain = {eps:g} with neighbour_contact = True: a "
                         f"prestrained link pulls its beads into their contact; use one or "
                         f"the other")


def _prestrained(model, state, eps):
    """``model`` with every link's reference length g/(1+ε₀), g its length in ``state`` (the
    prestrain ``wire_prestrain`` of the triaxial tests, set at the start of the loading so
    that the preparation cannot relax it)."""
    from dataclasses import replace

    g = np.linalg.norm(state.position[model.link_i] - state.position[model.link_j], axis=1)
    return replace(model, link_ref_length=g / (1.0 + float(eps)))


def _remove_beads(rig, stages, cfg) -> None:
    """The control ``remove_beads="at_loading"``: the beads leave the mechanics
    (:func:`~engine.experiments.start.remove_group`) and the membrane wraps the sand alone
    from now on (its start radius kept for ``max_growth``)."""
    state = rig.state
    rig.model = stages.model = remove_group(rig.model, state, "wire")
    state.load[rig.bead_ids] = 0.0
    rig.removed = True
    if rig.membrane is not None:
        old = rig.membrane.membrane
        rig.membrane.membrane = _membrane(cfg.confinement, rig.sand, rig.axis)
        rig.membrane.membrane.start_radius = old.start_radius
        rig.membrane.apply(rig.model, state)


def _active(rig) -> np.ndarray:
    """The particles in the mechanics: the sand and the beads (unless removed)."""
    return rig.sand if rig.removed else np.r_[rig.sand, rig.bead_ids]


def _loading_start(rig, volume):
    """What the sample is at the start of the loading, on the basis every sample shares
    (the particles the membrane wraps, beads included):

    * ``volume`` [m³] (π R² H, R the membrane's radius; the box's L_x L_y H);
    * ``solid_fraction``: the sand's in that volume, ``solid_fraction_all``: the sand's and
      the beads';
    * the cylinder's ``core_solid_fraction`` and ``core_sand_fraction``: the same within
      r < 0.7 R and 0.1-0.9 H (:func:`engine.analysis.packing.solid_fraction`, each
      particle's part inside), clear of the membrane's and the plates' wall effect;
      ``radius`` R and ``sand_outer_radius``, the largest ‖x − axis‖ + r of the grains [m];
    * the wire's preload: share of taut links, mean and largest tension [N]."""
    from ..analysis.packing import solid_fraction

    model, state, st = rig.model, rig.state, rig.st
    ids = _active(rig)
    r = model.body_radius
    vol = 4 / 3 * np.pi * r ** 3
    out = dict(volume=float(volume),
               solid_fraction=float(vol[rig.sand].sum() / volume),
               solid_fraction_all=float(vol[ids].sum() / volume))
    if rig.membrane is not None:
        R, H = rig.membrane.membrane.radius, rig.height(state)
        x = state.position
        core = Cylinder(0.7 * R, 0.8 * H, (rig.axis[0], rig.axis[1], x[rig.floor, 2] + 0.1 * H))
        out.update(core_solid_fraction=solid_fraction(x[ids], r[ids], core),
                   core_sand_fraction=solid_fraction(x[rig.sand], r[rig.sand], core),
                   radius=float(R), sand_outer_radius=float(np.max(
                       np.hypot(x[rig.sand, 0] - rig.axis[0], x[rig.sand, 1] - rig.axis[1])
                       + r[rig.sand])))
    if model.n_links and not rig.removed:
        t = state.links.tension
        out.update(taut_share=float(np.mean(t > 0)), mean_tension=float(t.mean()),
                   max_tension=float(t.max()))
    return out


def _best_fit(ref, state, sand, beads) -> dict:
    """Best-fit strains (Eq. 19) of the sand, the wire and all the particles from ``ref``
    (the positions at the start of the loading) to ``state`` (Fig. 12's measure)."""
    sand = np.asarray(sand)
    out = {}
    for name, sel in (("sand", sand), ("wire", beads), ("all", np.concatenate([sand, beads]))):
        if sel.size >= 4:
            out[name] = best_fit_strain(ref, state.position, sel)
    return out


def _start_extra(st, deposit, loading_start) -> dict:
    """``result.extra["start"]``: what the test started from and what it was at the start of
    the loading."""
    out = dict(source=st.source, deposit=None)
    if deposit is not None:
        out["deposit"] = dict(history=deposit.history, at_rest=deposit.at_rest,
                              steps=deposit.convergence.get("steps"),
                              settlement=deposit.settlement,
                              slack_share=deposit.slack_share)
    out.update(loading_start or {})
    return out


#: The lateral confinements of the cylinder test (its ``confinement``): the free-surface
#: membrane of §3.3 (:class:`engine.drivers.Confinement`) and the layer crowns of LMGC90's
#: 3D membrane example (:class:`engine.drivers.LayerCrown`).
CONFINEMENTS = ("free_surface", "layer_crown")


def _membrane(kind, ids, axis):
    from ..drivers import LayerCrown

    if kind == "free_surface":
        return Confinement(0.0, ids, center=axis, max_growth=RADIUS_RUNAWAY)
    if kind == "layer_crown":
        return LayerCrown(0.0, ids, center=axis, max_growth=RADIUS_RUNAWAY)
    raise ValueError(f"confinement = {kind!r}: must be one of {', '.join(map(repr, CONFINEMENTS))}")


def _weber(model, state, part, V):
    """Weber sum (Eq. 18) of the whole sample with volume V (tension positive)."""
    s = weber_stress(model, state, part=part)
    return s.tensor * s.volume / V


def _mean(stress):
    if stress is None or len(stress) == 0:
        return np.zeros(0)
    return -np.trace(np.asarray(stress), axis1=1, axis2=2) / 3


def _axial(stress):
    if stress is None or len(stress) == 0:
        return np.zeros(0)
    return -np.asarray(stress)[:, 2, 2]


def _split(rec, stage_of):
    """Rows of the triaxial stage, starting with the last isotropic record (the state the
    loading starts from: axial strain 0, deviator about 0), and rows of the isotropic one."""
    st = np.asarray(stage_of)
    first = np.flatnonzero(st == 1)
    if first.size and first[0] > 0:
        st = st.copy()
        st[first[0] - 1] = 2                      # both stages
    tri = {k: np.asarray(v)[st >= 1] for k, v in rec.rows.items()}
    iso = {k: np.asarray(v)[(st == 0) | (st == 2)] for k, v in rec.rows.items()}
    return tri, iso


def _result(name, tri, H0, history):
    stress = tri.get("stress", np.zeros((0, 3, 3)))
    n = len(stress)
    if n == 0:
        z = np.zeros(0)
        return TestResult(name, z, z.astype(int), z, z, z, z, np.zeros((0, 3, 3)),
                          np.zeros((0, 3, 3)), np.zeros((0, 3, 3)), z, os.path.abspath(history))
    V = tri["volume"]
    sig_a = -stress[:, 2, 2]
    sig_r = -(stress[:, 0, 0] + stress[:, 1, 1]) / 2
    wire_s = tri["wire_stress"]
    return TestResult(
        name=name, time=tri["time"], step=tri["step"].astype(int),
        axial_strain=1 - tri["height"] / H0, volumetric_strain=1 - V / V[0],
        deviator=sig_a - sig_r, mean_stress=-np.trace(stress, axis1=1, axis2=2) / 3,
        stress=stress, sand_stress=tri["sand_stress"], wire_stress=wire_s,
        wire_equivalent=np.array([equivalent_stress(s) for s in wire_s]),
        history=os.path.abspath(history))


def box_triaxial(scale: float = 0.05, *, sample=None, preparation: str = "geometric",
                 pressure: float = 15e3, wire: bool = True, wire_law=None,
                 neighbour_contact: bool = False, bead_radius: float | None = None,
                 wire_density: float | None = None, wire_mode: str = "isotropic",
                 helix_pitch: float | None = None, helix_inset: float | None = None,
                 remove_beads: str = "never",
                 wire_prestrain: float = 0.0, wire_taut_at_loading: bool = False,
                 deposit_steps: int = 6000,
                 axial_strain: float = 0.05, strain_rate: float | None = None,
                 target_I: float = 5e-4, allow_dynamic: bool = False, dt: float = 5e-5,
                 theta: float = 0.5, tol: float = 3e-4, max_iter: int = 1000,
                 relax: float = 1.0, anderson: int = 0, threads: int = 1,
                 hot_sweeps: int | None = None,
                 chain_solve: bool = False, contact_compliance: float = 0.0,
                 overlap_tol: float | None = TRIAXIAL_OVERLAP_TOL,
                 max_overlap: float = MAX_OVERLAP, mu: float = 0.5,
                 mu_wall: float = 0.0,
                 mu_wire: float = 0.3, compaction_mu: float | None = None,
                 wall_mass: float | None = None, iso_tol: float = 0.02, iso_hold: int = 5,
                 iso_max_steps: int = 4000, check_every: int = 10, ramp_steps: int = 400,
                 record_every: int = 10, frames: int = 100, max_nonconverged: float = 0.25,
                 history: str = "out/box_triaxial.h5", seed: int = 0,
                 progress: bool = True) -> TestResult:
    """The box triaxial test of §3.2 (Fig. 11-12).

    The sample is :func:`engine.prep.box_sample` (a 16 mm cube, 6 500 grains + a wire at
    200 km·m⁻³ at ``scale`` = 1; ``bead_radius`` r_w for Fig. 12) on a fixed floor, with
    four side walls under ``pressure`` (paper: about 15 kPa; pressure drives whose area
    follows the sample) and a top wall servo-controlled to the same stress, then moved down
    at a constant velocity.  The side walls are frictionless by default (``mu_wall``).
    ``compaction_mu``: the friction of the isotropic stage, see :func:`_compaction`.
    ``neighbour_contact``: linked wire beads also touch like two spheres
    (:meth:`engine.Scene.add_wire`; default False: a slack link lets its two beads overlap).
    ``sample``, ``preparation``, ``wire_density``, ``wire_mode``, ``wire_prestrain`` and
    ``deposit_steps`` as in :func:`cylinder_triaxial` (a box sample; the paper
    preparation's mould is the box's floor and four sides, with ``mu_wall``; the walls of
    an end state's box are where its side planes were, else at its particles' extent).

    ``extra`` holds the wall stresses (compression positive: x−, x+, y−, y+, top) per
    record, the wire Weber stress of the upper and lower halves with principal values and
    directions (Fig. 11), and the best-fit strains (Eq. 19) of the sand, the wire and all
    the particles (Fig. 12).
    """
    cfg = _config("box_triaxial", dict(locals()))
    st, deposit, cfg.law = _prepared("box_triaxial", Box, box_sample, vars(cfg))
    rig = _box_rig(st, cfg)
    _loading_rate(cfg, rig)
    rec, hist, stages = _recording(rig, cfg, "box_triaxial", BOX_UNITS, _box_values(rig),
                                   cfg.check_every)
    _run_stages(stages, hist, rig, cfg,
                lambda: _isotropic(stages, rig, cfg, cfg.check_every, _box_measure(rig),
                                   [rig.faces]),
                lambda: [rig.faces])
    res = _box_result(rig, cfg, rec, deposit)
    return finish(res, stages, cfg.max_nonconverged)


# -- the stages of both tests -----------------------------------------------------------------
def _run_stages(stages, hist, rig, cfg, isotropic, loading_updaters):
    """Both tests' stages: ``isotropic()`` (its answer in ``cfg.iso_reached``), the loading
    with the updaters ``loading_updaters()`` makes once the loading has started (they read
    its start), unless a stop request came, the end; the recording closed whatever
    happens."""
    try:
        cfg.iso_reached = isotropic()
        _loading(stages, rig, cfg)
        if not stages.interrupted:
            stages.run(rig.n_load, updaters=loading_updaters())
        _ended(stages, rig)
    finally:
        stages.close()
        hist.close()


def _config(test, args, least_mu=0.0, why="") -> SimpleNamespace:
    """A test's arguments (its ``locals()`` on entry) turned into its config
    (:mod:`engine.experiments.config`, ``cfg.config``) and run from it: its keywords, with
    the scale and the solver choice resolved, ``p`` and ``eps_max`` as floats, ``compaction_mu`` checked to be at
    least ``least_mu`` (``why``: the reason, for the message)."""
    config = CONFIGS[test].from_kwargs(**args)
    cfg = SimpleNamespace(**config.kwargs(), config=config)
    cfg.sample = args["sample"]                 # (an object, which the config does not hold)
    cfg.scale = check_scale(cfg.scale)
    cfg.anderson, cfg.hot_sweeps = solver_choice(cfg.anderson, cfg.hot_sweeps)
    cfg.p, cfg.eps_max = float(cfg.pressure), float(cfg.axial_strain)
    cfg.compaction_mu = _compaction_mu(cfg.compaction_mu, least_mu, why)
    return cfg


def _loading_rate(cfg, rig) -> None:
    """``cfg.rate`` [1/s] and ``cfg.I`` of the loading, and ``cfg.est_steps``, the test's
    upper bound on its steps."""
    cfg.rate, cfg.I = choose_rate(cfg.strain_rate, cfg.p, rig.d_mean, 2650.0,
                                  target_I=cfg.target_I, allow_dynamic=cfg.allow_dynamic)
    cfg.est_steps = cfg.iso_max_steps + int(cfg.eps_max / (cfg.rate * cfg.dt)) + 1


@dataclass(eq=False)
class _Rig:
    """A triaxial test's compiled scene and what its stages measure on it: the model and
    state, the sample's sand and bead ids, the floor and top plates, the box's side walls or
    the cylinder's membrane updater; ``stage`` (0 isotropic, 1 loading) is what the records
    are marked with, ``stage_of`` those marks."""

    model: object
    state: object
    st: object
    sand: np.ndarray
    bead_ids: np.ndarray
    floor: int
    top: int
    sides: tuple = ()
    faces: object = None            # BoxFaces (box)
    membrane: object = None         # MembraneUpdater (cylinder)
    axis: tuple = (0.0, 0.0)
    stage: int = 0
    stage_of: list = field(default_factory=list)
    H0: float = 0.0
    R0: float = 0.0
    ref: np.ndarray = None
    preload: dict = None
    n_load: int = 0
    strains: dict = field(default_factory=dict)
    maps: dict = field(default_factory=dict)
    removed: bool = False           # the beads taken out at the loading (remove_beads)

    @property
    def d_mean(self) -> float:
        return 2 * float(self.st.sand_radii.mean())

    def height(self, state) -> float:
        return state.position[self.top, 2] - state.position[self.floor, 2]


def _scene(st, cfg):
    """The test's Scene with the sample's particles: (scene, sand ids, bead ids)."""
    sc = Scene(gravity=(0.0, 0.0, -G))
    sand, beads = st.add_to(sc, wire_law=cfg.law, neighbour_contact=cfg.neighbour_contact)
    return sc, sand, np.concatenate(beads) if beads else np.zeros(0, np.int64)


def _compiled(sc, st, cfg):
    """The fixed floor's and the contact laws' last touches, then (model, state) with an end
    state's velocities and links carried over."""
    _laws_for(sc, cfg.mu, cfg.mu_wall, cfg.mu_wire, st.has_wire)
    model, state = sc.compile(**compile_options(cfg))
    return st.carry_over(model, state), state


def _ramp(cfg, every) -> Ramp:
    """The isotropic stage's pressure: 0 to p over ``ramp_steps``, raised every ``every``
    steps (a sudden p on a loose sample throws its outer grains in at metres per second)."""
    return Ramp(0.0, cfg.p, cfg.ramp_steps, every=every)


class _SplitRecorder(Recorder):
    """A recorder of one function returning a dict of the values ``keys``."""

    def __init__(self, fn, keys, every):
        super().__init__({k: None for k in keys}, every)
        self.fn = fn
        self.rows = {}

    def values(self, model, state) -> dict:
        return self.fn(model, state)


def _recording(rig, cfg, test, units, values, every):
    """(recorder, history, stages) of a triaxial test: ``values(model, state)`` (a dict of
    the ``units``' keys) recorded every ``record_every`` steps into the HDF5 history, the
    stages starting on the isotropic stage's model (:func:`_compaction`) and reporting
    every ``every`` steps."""
    rec = _SplitRecorder(values, tuple(units), cfg.record_every)
    hist = history_writer(cfg.history, rec, units, cfg.record_every, cfg.frames,
                          meta=run_meta(test, cfg.est_steps,
                                        config=cfg.config.model_dump(mode="json"),
                                        **_meta(rig, cfg)))
    stages = Stages(_compaction(rig.model, cfg.compaction_mu), rig.state, [rec, hist],
                    progress=cfg.progress, total=cfg.est_steps,
                    desc=test.replace("_", " "), report_every=every)
    return rec, hist, stages


def _meta(rig, cfg) -> dict:
    """What the history says of the run (:func:`run_meta`)."""
    out = dict(scale=cfg.scale, seed=cfg.seed, sample=rig.st.source,
               preparation=cfg.preparation)
    if hasattr(cfg, "confinement"):
        out["confinement"] = cfg.confinement
    return dict(out, pressure=cfg.p, wire=rig.st.has_wire, wire_law=cfg.law,
                wire_density=rig.st.wire_density, frames=cfg.frames,
                neighbour_contact=cfg.neighbour_contact, axial_strain=cfg.eps_max,
                strain_rate=cfg.rate, dt=cfg.dt, theta=cfg.theta, tol=cfg.tol,
                max_iter=cfg.max_iter, mu=cfg.mu, mu_wall=cfg.mu_wall, mu_wire=cfg.mu_wire)


class _Isotropic:
    """The stop condition of the isotropic stage: every ``every`` steps from its start, the
    pressure is at p and every stress ``measure()`` returns is within ``iso_tol`` of it, for
    ``iso_hold`` checks in a row."""

    def __init__(self, rig, cfg, every, measure):
        self.rig, self.p, self.tol, self.hold = rig, cfg.p, cfg.iso_tol, cfg.iso_hold
        self.measure, self.every, self.origin = measure, every, rig.state.step
        self.ok, self.values = 0, ()

    def trigger(self, step) -> bool:
        return (step - self.origin) % self.every == 0

    def __call__(self, model, state) -> bool:
        self.values = self.measure()
        ok = (state.drive_pressure[self.rig.top] == self.p
              and all(abs(v / self.p - 1) < self.tol for v in self.values))
        self.ok = self.ok + 1 if ok else 0
        return self.ok >= self.hold


def _isotropic(stages, rig, cfg, every, measure, updaters) -> bool:
    """Stage 1: the pressure raised by its ramp (:class:`~engine.schedules.FollowSchedules`
    every ``every`` steps, then ``updaters``) until :class:`_Isotropic` holds, at most
    ``iso_max_steps`` rounded up to a multiple of ``every``.  Returns whether it held; if
    not, a RuntimeWarning says so with the stresses reached (the loading then starts from
    there, and the result's ``params["iso_reached"]`` is False)."""
    stages.set_stage("isotropic")
    until = _Isotropic(rig, cfg, every, measure)
    trigger = until.trigger
    steps = -(-cfg.iso_max_steps // every) * every
    start = stages.steps
    stages.run(steps, updaters=[FollowSchedules(trigger), *updaters], until=until)
    reached = until.ok >= cfg.iso_hold
    if not reached and not stages.interrupted:
        got = ", ".join(f"{v:.4g}" for v in until.values)
        warnings.warn(f"the isotropic stage did not reach {cfg.p:.4g} Pa (within "
                      f"{cfg.iso_tol:.0%} for {cfg.iso_hold} checks) in {stages.steps - start} "
                      f"steps (iso_max_steps = {cfg.iso_max_steps}): the stresses were {got} "
                      f"Pa; the loading starts from there. Raise iso_max_steps",
                      RuntimeWarning, stacklevel=3)
    return reached


def _loading(stages, rig, cfg) -> None:
    """Between the stages: the loading's reference (height H0, radius R0, positions), the
    sample's state at its start, the wire's prestrain, and the top plate switched to the
    velocity ε̇ H0 downwards (:meth:`~engine.model.Model.with_drive`) for ``n_load`` steps."""
    rig.stage = 1
    stages.set_stage("loading")
    state = rig.state
    if cfg.remove_beads == "at_loading" and rig.st.has_wire:
        _remove_beads(rig, stages, cfg)
    rig.H0 = rig.height(state)
    volume = (math.pi * rig.membrane.membrane.radius ** 2 * rig.H0 if rig.membrane is not None
              else float(np.prod(_box_dims(rig, state))))
    rig.R0 = rig.membrane.membrane.radius if rig.membrane is not None else 0.0
    rig.ref = state.position.copy()
    rig.preload = _loading_start(rig, volume)
    model = rig.model
    if rig.st.has_wire and not rig.removed and (cfg.wire_prestrain or cfg.wire_taut_at_loading):
        model = _prestrained(model, state, cfg.wire_prestrain)
    rig.model = stages.model = model.with_drive(rig.top, velocity=(0.0, 0.0, -cfg.rate * rig.H0))
    rig.n_load = int(math.ceil(cfg.eps_max / (cfg.rate * cfg.dt)))


def _ended(stages, rig) -> None:
    """After the loading: the end state to the writers that have not recorded it
    (:meth:`Stages.record_last`), the best-fit strains of the loading (Eq. 19)."""
    stages.record_last()
    rig.strains = _best_fit(rig.ref, rig.state, rig.sand, rig.bead_ids)


def _params(rig, cfg, deposit) -> dict:
    """``result.params`` of both tests (the cylinder's adds its confinement)."""
    st, wire = rig.st, rig.st.has_wire
    return dict(scale=cfg.scale, sample=st.source, preparation=cfg.preparation,
                wire_density=st.wire_density,
                wire_mode=cfg.wire_mode if cfg.sample is None else None,
                helix_pitch=cfg.helix_pitch, helix_inset=cfg.helix_inset,
                remove_beads=cfg.remove_beads,
                bead_radius=st.bead_radius if wire else None,
                wire_prestrain=cfg.wire_prestrain if wire else 0.0,
                wire_taut_at_loading=bool(wire and cfg.wire_taut_at_loading),
                deposit_steps=cfg.deposit_steps if deposit is not None else None,
                pressure=cfg.p, wire=wire, wire_law=repr(cfg.law),
                neighbour_contact=bool(wire and cfg.neighbour_contact),
                axial_strain=cfg.eps_max, strain_rate=cfg.rate, inertial_number=cfg.I,
                loading_velocity=cfg.rate * rig.H0, dt=cfg.dt, theta=cfg.theta, tol=cfg.tol,
                max_iter=cfg.max_iter, anderson=cfg.anderson, threads=cfg.threads,
                hot_sweeps=cfg.hot_sweeps, chain_solve=cfg.chain_solve,
                contact_compliance=cfg.contact_compliance,
                overlap_tol=cfg.overlap_tol, mu=cfg.mu,
                mu_wall=cfg.mu_wall,
                mu_wire=cfg.mu_wire, compaction_mu=cfg.compaction_mu, seed=cfg.seed,
                n_sand=int(st.sand_radii.size), n_beads=st.n_beads, d_mean=rig.d_mean,
                iso_reached=cfg.iso_reached, config=cfg.config.model_dump(mode="json"))


def _insert_after(d: dict, key: str, **new) -> dict:
    """``d`` with the items ``new`` after ``key`` (the order the results always had)."""
    out = {}
    for k, v in d.items():
        out[k] = v
        if k == key:
            out.update(new)
    return out


def _common_result(name, rig, cfg, rec, deposit):
    """(result, loading rows, isotropic rows) with the parts both tests share."""
    tri, iso = _split(rec, rig.stage_of)
    res = _result(name, tri, rig.H0, cfg.history)
    res.params = _params(rig, cfg, deposit)
    res.extra["start"] = _start_extra(rig.st, deposit, rig.preload)
    res.extra["best_fit_strain"] = rig.strains
    return res, tri, iso


# -- the cylinder ---------------------------------------------------------------------------------
#: What the cylinder test records (and the unit of each).
CYLINDER_UNITS = dict(stress="Pa", sand_stress="Pa", wire_stress="Pa", height="m",
                      volume="m^3", radius="m", stage="-", time="s", step="-")


def _check_width(st, scale) -> None:
    across = 2 * st.outer_radius(st.axis()) / (2 * float(st.sand_radii.mean()))
    if across < 5.5:
        raise ValueError(
            f"scale {scale} gives a sample {across:.1f} mean grain diameters across; the "
            f"free-surface confinement needs at least 5.5 (scale >= 0.04): on thinner samples "
            f"it threw grains out at tens of m/s (measured at scale 0.03)")


class _SampleApart(MembraneUpdater):
    """The cylinder's membrane updater, whose :class:`ConfinementError` says what to do."""

    def __init__(self, membrane, top, every, cfg):
        super().__init__(membrane, top, every)
        self.cfg = cfg

    def apply(self, model, state) -> None:
        try:
            super().apply(model, state)
        except ConfinementError as e:
            raise ConfinementError(
                f"cylinder_triaxial: the sample came apart: {e}. Seen on samples of scale "
                f"0.04 (here scale {self.cfg.scale:g}, seed {self.cfg.seed}); use a larger "
                f"scale. The history {self.cfg.history} keeps the steps run so far.") from e


def _cylinder_rig(st, cfg) -> _Rig:
    """The cylinder's scene: the sample on a fixed floor under a top plate driven by the
    pressure ramp on the area π R² of the membrane (:class:`MembraneUpdater`, every
    ``confine_every`` steps); the membrane applied once.  The membrane wraps every particle
    of the sample, grains and beads alike: its radius and the volume π R² H come from the
    outermost particle of each cell, whichever it is, and a bead on the surface takes its
    share of the load like a grain, in proportion to its cross-section π r_w²
    (:class:`engine.drivers.Confinement`).  (Until 2026-12-07 the membrane held the sand
    only: in a wire sample the beads at the surface were left outside it, its radius came
    from grains lying deeper, and the volume, the solid fraction and the stresses were
    measured on a radius 4-5 % smaller than the sand sample's.)"""
    _check_width(st, cfg.scale)
    axis = st.axis()
    sc, sand, bead_ids = _scene(st, cfg)
    floor = sc.add_plane(point=(axis[0], axis[1], st.floor), normal=(0, 0, 1), group="wall")
    top = sc.add_plane(point=(axis[0], axis[1], st.floor + st.height), normal=(0, 0, -1),
                       group="wall")
    sc.drive(top, pressure=_ramp(cfg, cfg.confine_every), mass=0.2 * st.sand_mass,
             area=Servo("membrane"))
    sc.fix(floor)
    model, state = _compiled(sc, st, cfg)
    membrane = _SampleApart(_membrane(cfg.confinement, np.r_[np.asarray(sand), bead_ids],
                                      axis), top,
                            _every_from(state.step, cfg.confine_every), cfg)
    membrane.apply(model, state)
    return _Rig(model, state, st, np.asarray(sand), bead_ids, floor, top, membrane=membrane,
                axis=axis)


def _every_from(origin, n):
    """The trigger of every ``n`` steps from step ``origin``."""
    return lambda step: (step - origin) % n == 0


def _cylinder_stresses(rig, model, state):
    """(σ, σ_sand, σ_wire, V): Eq. (18) over the whole sample of volume V = π R² H (the
    membrane is its lateral boundary, its loads a part of the sand's)."""
    conf = rig.membrane.membrane
    V = math.pi * conf.radius ** 2 * rig.height(state)
    mem = conf.membrane_stress(model) / V
    sand_s = _weber(model, state, "sand", V) - mem
    wire_s = _weber(model, state, "wire", V) if model.n_links else np.zeros((3, 3))
    return sand_s + wire_s, sand_s, wire_s, V


def _cylinder_values(rig):
    def values(model, state):
        tot, sand_s, wire_s, V = _cylinder_stresses(rig, model, state)
        rig.stage_of.append(rig.stage)
        return dict(stress=tot, sand_stress=sand_s, wire_stress=wire_s, height=rig.height(state),
                    volume=V, radius=rig.membrane.membrane.radius, stage=rig.stage,
                    time=state.time, step=state.step)
    return values


class _TopStress(Updater):
    """The stress on the top plate [Pa] (compression positive: the spheres push it up) on
    the membrane's area π R² of the step just run: placed before the membrane's updater."""

    def __init__(self, rig, trigger):
        self.rig, self.trigger, self.value = rig, trigger, math.nan

    def update(self, model, state) -> None:
        rig = self.rig
        self.value = (wall_forces(rig.model, state, [rig.top])[0, 2]
                      / (math.pi * rig.membrane.membrane.radius ** 2))


def _cylinder_isotropic(stages, rig, cfg) -> bool:
    """The isotropic stage of the cylinder: the ramp, the top plate's stress measured, the
    membrane updated, then the check of the mean stress and the plate's."""
    probe = _TopStress(rig, rig.membrane.trigger)

    def measure():
        return (-np.trace(_cylinder_stresses(rig, rig.model, rig.state)[0]) / 3, probe.value)

    return _isotropic(stages, rig, cfg, cfg.confine_every, measure, [probe, rig.membrane])


class _TorusMaps(Updater):
    """The toroidal maps of the wire stress (Fig. 13c) at the strains ``torus_strains``,
    each taken at the membrane's first update at or past it; the last update, within one
    step of the final strain (the first step lags by θ h ε̇), takes a target equal to it."""

    def __init__(self, rig, cfg, trigger):
        self.rig, self.trigger, self.eps_max = rig, trigger, cfg.eps_max
        self.targets = sorted(float(e) for e in cfg.torus_strains if e <= cfg.eps_max + 1e-12)
        self.end = rig.state.step + rig.n_load

    def update(self, model, state) -> None:
        rig, targets = self.rig, self.targets
        H = rig.height(state)
        eps = 1 - H / rig.H0
        last = state.step >= self.end
        while targets and rig.st.has_wire and (
                eps >= targets[0] or (last and targets[0] >= self.eps_max - 1e-12)):
            e = targets.pop(0)
            rig.maps[e] = toroidal_map(model, state, Cylinder(
                rig.membrane.membrane.radius, H,
                (rig.axis[0], rig.axis[1], state.position[rig.floor, 2])), part="wire")


def _cylinder_loading_updaters(rig, cfg) -> list:
    """The loading's updaters: the membrane every ``confine_every`` steps from the
    loading's start and at its last step, then the toroidal maps."""
    origin, every, end = rig.state.step, cfg.confine_every, rig.state.step + rig.n_load
    trigger = (lambda step: (step - origin) % every == 0 or step == end)
    rig.membrane = _SampleApart(rig.membrane.membrane, rig.top, trigger, cfg)
    return [rig.membrane, _TorusMaps(rig, cfg, trigger)]


def _cylinder_result(rig, cfg, rec, deposit) -> TestResult:
    res, tri, iso = _common_result("cylinder_triaxial", rig, cfg, rec, deposit)
    res.params = _insert_after(res.params, "preparation", confinement=cfg.confinement)
    if len(res.time):
        res.extra["radial_strain"] = tri["radius"] / rig.R0 - 1          # extension positive
    res.extra["isotropic"] = dict(time=iso.get("time"), mean_stress=_mean(iso.get("stress")),
                                  axial_stress=_axial(iso.get("stress")),
                                  reached=cfg.iso_reached)
    res.extra["torus_maps"] = rig.maps
    res.extra["height"], res.extra["radius"] = tri.get("height"), tri.get("radius")
    if rig.st.has_wire and len(res.time) >= 5:
        try:
            res.extra["H"] = macro_stiffness(res.axial_strain, res.wire_equivalent)
        except ValueError as e:
            res.extra["H"] = None
            res.extra["H_error"] = str(e)
    return res


# -- the box ------------------------------------------------------------------------------------
#: What the box test records (and the unit of each).
BOX_UNITS = dict(stress="Pa", sand_stress="Pa", wire_stress="Pa", wire_stress_upper="Pa",
                 wire_stress_lower="Pa", wall_stress="Pa", height="m", volume="m^3",
                 radius="m", stage="-", time="s", step="-")


def _box_rig(st, cfg) -> _Rig:
    """The box's scene: the sample on a fixed floor, four side walls and a top plate driven
    by the pressure ramp on the faces of the sample (:class:`BoxFaces`, each step), with
    mass ``wall_mass`` (None: 0.2 × the sample's)."""
    box = st.box()
    lo, hi = np.array(box.lo), np.array(box.hi)
    sc, sand, bead_ids = _scene(st, cfg)
    cfg.wall_mass = 0.2 * st.sand_mass if cfg.wall_mass is None else float(cfg.wall_mass)
    floor = sc.add_plane(point=(0, 0, lo[2]), normal=(0, 0, 1), group="wall")
    top = sc.add_plane(point=(0, 0, lo[2] + st.height), normal=(0, 0, -1), group="wall")
    sides = tuple(sc.add_plane(point=pt, normal=n, group="wall") for pt, n in (
        ((lo[0], 0, 0), (1, 0, 0)), ((hi[0], 0, 0), (-1, 0, 0)),
        ((0, lo[1], 0), (0, 1, 0)), ((0, hi[1], 0), (0, -1, 0))))
    ramp = _ramp(cfg, cfg.check_every)
    for b in (*sides, top):
        sc.drive(b, pressure=ramp, mass=cfg.wall_mass, area=Servo("box faces"))
    sc.fix(floor)
    model, state = _compiled(sc, st, cfg)
    return _Rig(model, state, st, np.asarray(sand), bead_ids, floor, top, sides=sides,
                faces=BoxFaces(floor, top, sides))


def _box_dims(rig, state):
    """(L_x, L_y, H) [m] of the box between its walls."""
    x, s = state.position, rig.sides
    return x[s[1], 0] - x[s[0], 0], x[s[3], 1] - x[s[2], 1], x[rig.top, 2] - x[rig.floor, 2]


def _wall_sigma(rig, model, state):
    """The stresses on the walls x−, x+, y−, y+, top [Pa], compression positive (the spheres
    push each wall against its normal)."""
    Lx, Ly, H = _box_dims(rig, state)
    walls = np.array([*rig.sides, rig.top])
    f = wall_forces(model, state, walls)
    areas = np.array([Ly * H, Ly * H, Lx * H, Lx * H, Lx * Ly])
    normals = np.array([model.body_axis[b] for b in walls])
    return -np.einsum("ka,ka->k", f, normals) / areas


def _wire_halves(rig, model, state, Lx, Ly, H):
    """The wire's Weber stress in the upper and lower halves of the box (Fig. 11)."""
    zmid = state.position[rig.floor, 2] + 0.5 * H
    x0, y0 = state.position[rig.sides[0], 0], state.position[rig.sides[2], 1]
    halves = []
    for zl, zh in ((zmid, zmid + 0.5 * H), (zmid - 0.5 * H, zmid)):
        reg = Box((x0, y0, zl), (x0 + Lx, y0 + Ly, zh))
        try:
            halves.append(weber_stress(model, state, region=reg, part="wire").tensor
                          if model.n_links else np.zeros((3, 3)))
        except ValueError:
            halves.append(np.full((3, 3), np.nan))
    return halves


def _box_values(rig):
    def values(model, state):
        Lx, Ly, H = _box_dims(rig, state)
        V = Lx * Ly * H
        sand_s = _weber(model, state, "sand", V)
        wire_s = _weber(model, state, "wire", V) if model.n_links else np.zeros((3, 3))
        upper, lower = _wire_halves(rig, model, state, Lx, Ly, H)
        rig.stage_of.append(rig.stage)
        return dict(stress=sand_s + wire_s, sand_stress=sand_s, wire_stress=wire_s,
                    wire_stress_upper=upper, wire_stress_lower=lower,
                    wall_stress=_wall_sigma(rig, model, state), height=H, volume=V,
                    radius=0.0, stage=rig.stage, time=state.time, step=state.step)
    return values


def _box_measure(rig):
    """The isotropic stage's stresses: the mean stress and the five walls'."""
    def measure():
        Lx, Ly, H = _box_dims(rig, rig.state)
        return (-np.trace(_weber(rig.model, rig.state, "all", Lx * Ly * H)) / 3,
                *_wall_sigma(rig, rig.model, rig.state))
    return measure


def _box_result(rig, cfg, rec, deposit) -> TestResult:
    res, tri, iso = _common_result("box_triaxial", rig, cfg, rec, deposit)
    res.params = _insert_after(res.params, "compaction_mu", wall_mass=cfg.wall_mass)
    res.extra["isotropic"] = dict(time=iso.get("time"), mean_stress=_mean(iso.get("stress")),
                                  axial_stress=_axial(iso.get("stress")),
                                  wall_stress=iso.get("wall_stress"), reached=cfg.iso_reached)
    res.extra["wall_stress"] = tri.get("wall_stress")
    for half in ("upper", "lower"):
        t = tri.get(f"wire_stress_{half}")
        res.extra[f"wire_stress_{half}"] = t
        if t is not None and len(t) and np.all(np.isfinite(t[-1])):
            w, v = principal(t[-1])
            res.extra[f"wire_principal_{half}"] = (w, v)
    return res
