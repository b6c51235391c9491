"""The slope deposit of §3.1 (Fig. 8-10): a cylindrical TexSol sample released on a "rubber
plane" of equal fixed beads on a hexagonal lattice, run under gravity until it is at rest."""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from ..analysis import slope_profile
from ..analysis.wire import wire_chains
from ..prep import Cylinder, slope_sample
from ..prep.relax import kinetic_energy
from ..model import MAX_OVERLAP, OVERLAP_TOL
from ..scene import Scene
from .config import SlopeConfig
from .start import start_of
from .common import (RestCheckpoint, RestResult, check_bool, check_scale, compile_options,
                     deposit_laws, finish, rest_run, rest_summary, run_identity, run_meta,
                     sample_identity, solver_choice, wire_before_after, wire_law_or_default)

__all__ = ["slope_deposit", "SlopeResult", "hex_floor"]

G = 9.81

#: Radial bins of the heap's profile h(r), p(r) (Fig. 10).
PROFILE_BINS = 12


def check_fit_degree(fit_degree, wire, n_bins) -> int:
    """The degree of the heap's height regression: 1 for sand and 3 with a wire when None,
    else an integer in [1, n_bins − 1]."""
    if fit_degree is None:
        return 3 if wire else 1
    if isinstance(fit_degree, (bool, np.bool_)) or not isinstance(fit_degree, (int, np.integer)) \
            or not 1 <= fit_degree <= n_bins - 1:
        raise ValueError(f"fit_degree must be an integer in [1, {n_bins - 1}] (the profile "
                         f"has {n_bins} radial bins) or None, got {fit_degree!r}")
    return int(fit_degree)


@dataclass(kw_only=True)
class SlopeResult(RestResult):
    """What :func:`slope_deposit` returns.

    Attributes
    ----------
    name : str
    profile : engine.analysis.SlopeProfile     h(r), p(r), regressions, max slope (Fig. 10);
                                               None when the run stopped (``steps``, Ctrl-C)
                                               before the heap spread over enough radial
                                               bins to fit (``params["profile_error"]``).
    max_slope_deg : float [deg]                (nan without a profile)
    sector_heights : (n_r, n_sectors) [m]      heap height per radial bin and angular sector
                                               (axisymmetry check; (0, 8) without a profile).
    floor_force : float [N]                    vertical force on the rubber plane.
    weight : float [N]                         weight of the sample.
    time, kinetic_energy : (n,) [s], [J]       of the sample (sand and wire) per record.
    wire_before, wire_after : engine.analysis.WireStats | None   (tortuosity: Fig. 7)
    histograms_before, histograms_after : {plane: (edges, weights)}  (Fig. 8-9)
    at_rest : bool;  history : str;  params, convergence : dict
    """

    profile: object
    max_slope_deg: float
    sector_heights: np.ndarray
    floor_force: float

    def __str__(self):
        return rest_summary(self, f"max slope {self.max_slope_deg:.1f}°; floor force / weight "
                                  f"= {self.floor_force / self.weight:.4f}")


def hex_floor(radius: float, extent: float, z: float = 0.0) -> np.ndarray:
    """Centres of touching beads of ``radius`` [m] on a hexagonal lattice covering the disk
    of radius ``extent`` [m] about the z axis, at height ``z`` + radius."""
    a = 2 * radius
    n = int(math.ceil(extent / a)) + 1
    i, j = np.meshgrid(np.arange(-n, n + 1), np.arange(-2 * n, 2 * n + 1), indexing="ij")
    x = a * (i + 0.5 * (j % 2))
    y = a * math.sqrt(3) / 2 * j
    keep = np.hypot(x, y) <= extent
    return np.stack([x[keep], y[keep], np.full(keep.sum(), z + radius)], 1)


def slope_deposit(scale: float = 0.02, *, sample=None, wire: bool = True,
                  wire_density: float | None = None,
                  wire_law=None, neighbour_contact: bool = False, steps: int = 4000, ke_fraction: float = 1e-4,
                  rubber_radius: float = 0.3e-3, floor_extent: float = 5.0, dt: float = 5e-5,
                  theta: float = 0.5, tol: float = 1e-4, max_iter: int = 1000,
                  relax: float = 1.0, anderson: int = 0, threads: int = 1,
                  hot_sweeps: int | None = None, chain_solve: bool = False,
                  contact_compliance: float = 0.0,
                  overlap_tol: float | None = OVERLAP_TOL,
                  max_overlap: float = MAX_OVERLAP, mu: float = 0.5,
                  mu_floor: float = 0.8, mu_wire: float = 0.3, record_every: int = 20,
                  frames: int = 200, max_nonconverged: float = 0.25,
                  history: str = "out/slope_deposit.h5", seed: int = 0,
                  checkpoint_every: int = 0, resume: bool = False,
                  fit_degree: int | None = None, progress: bool = True) -> SlopeResult:
    """The slope deposit of §3.1.

    The sample is :func:`engine.prep.slope_sample` (Ø12 mm × 14 mm, 26 000 grains Ø0.2–0.6
    mm + 2 900 beads at 400 km·m⁻³ with a wire-free outer layer at ``scale`` = 1;
    ``wire_density=800e3`` for the paper's TexSol(2), ``wire=False`` for sand only), or
    ``sample``: a geometric sample (:class:`engine.prep.Sample`) or an end state, such as
    :func:`~engine.experiments.gravity_deposit`'s (:mod:`engine.experiments.start`; its
    axis is moved onto the floor's centre), lifted
    onto a floor of fixed beads of ``rubber_radius`` [m] on a hexagonal lattice spanning
    ``floor_extent`` × the sample radius, and released (no mould) under gravity.  It runs
    until the sample's kinetic energy is below ``ke_fraction`` of its peak, or ``steps``
    steps (the paper's 4 000 steps of 0.05 ms).  ``hot_sweeps`` (default None: 2, or 0
    when ``anderson`` > 0) re-sweeps the contacts that changed most after each sweep
    (:attr:`engine.model.Options.hot_sweeps`): at scale 0.05, 1.5 % of the steps hit
    ``max_iter`` with it against 21 % with ``anderson=4`` (docs/speed.md).  ``anderson``
    (default 0) is the depth of the other NLGS acceleration (:mod:`engine.solver.anderson`),
    the default before 2026-11-25.  ``threads`` (default 1) is the NLGS thread count
    (:attr:`engine.model.Options.threads`); 2 pays only on samples of tens of thousands of
    contacts (docs/speed.md).  ``relax`` (default 1) is the NLGS relaxation factor
    (:attr:`engine.model.Options.relax`; > 1, over-relaxation, on one thread and unmixed).
    ``neighbour_contact``: linked wire beads also touch like two spheres
    (:meth:`engine.Scene.add_wire`; default False: a slack link lets its two beads overlap).
    ``checkpoint_every``, ``resume``: checkpoints and going on from one, as in
    :func:`engine.experiments.gravity_deposit`.  ``fit_degree`` is the degree of the height
    regression whose steepest slope is ``max_slope_deg`` (:func:`engine.analysis.max_slope`;
    1 to 11, the profile's 12 bins; default None: 1 for sand, 3 with a wire).  The paper
    fits sand with a line, TexSol(1) with a cubic and TexSol(2) with the 8th degree, so a
    higher degree finds a steeper slope on the same heap (docs/paper.md, Fig. 10).
    """
    args = dict(locals())
    config = SlopeConfig.from_kwargs(**args)      # the arguments checked
    identity = run_identity(dict(args, sample=sample_identity(sample), test="slope_deposit"))
    cfg = SimpleNamespace(**config.kwargs(), config=config)
    cfg.sample = sample                 # (an object, which the config does not hold)
    cfg.scale = check_scale(cfg.scale)
    cfg.anderson, cfg.hot_sweeps = solver_choice(cfg.anderson, cfg.hot_sweeps)
    ckpt = RestCheckpoint(cfg.history, cfg.checkpoint_every, cfg.record_every, identity)
    cfg.resume = check_bool("resume", cfg.resume)
    cfg.fit_degree = check_fit_degree(fit_degree, cfg.wire, PROFILE_BINS)  # (2.0 refused)
    st, cfg.law = _slope_start(cfg)
    heap = _heap(st, cfg)
    model, sand = heap.model, heap.sand
    chains0 = wire_chains(model, heap.state) if st.has_wire else []

    def energy(model, state):
        # grains that rolled off the floor's edge fall for good: not in the criterion
        return kinetic_energy(model, state, sand[state.position[sand, 2] >= 0.0])

    done = rest_run(model, heap.state, heap.ids, energy, cfg, desc="slope deposit",
                    checkpoint=ckpt, meta=run_meta(
                        "slope_deposit", cfg.steps, config=cfg.config.model_dump(mode="json"),
                        scale=cfg.scale, seed=cfg.seed,
                        sample=st.source, wire=st.has_wire, wire_density=cfg.wire_density,
                        wire_law=cfg.law, neighbour_contact=cfg.neighbour_contact, dt=cfg.dt,
                        theta=cfg.theta, tol=cfg.tol, max_iter=cfg.max_iter, mu=cfg.mu,
                        mu_floor=cfg.mu_floor, mu_wire=cfg.mu_wire, steps=cfg.steps,
                        ke_fraction=cfg.ke_fraction))
    res = _slope_result(heap, done, cfg, st, chains0)
    return finish(res, done.stages, cfg.max_nonconverged)


def _slope_start(cfg):
    """(the :class:`~engine.experiments.start.Start` of the sample, the wire's law)."""
    law = wire_law_or_default(cfg.wire_law) if cfg.wire else None
    if cfg.sample is not None and cfg.wire_density is not None:
        raise ValueError("slope_deposit: wire_density builds the test's own sample; with "
                         "sample= given, build the sample with it (engine.prep.slope_sample)")
    st = start_of("slope_deposit", Cylinder, cfg.sample,
                  lambda: slope_sample(cfg.scale, wire=cfg.wire, wire_density=cfg.wire_density,
                                       seed=cfg.seed),
                  wire=cfg.wire, wire_law=cfg.wire_law)
    return st, st.wire_law(law) if st.has_wire else None


def _heap(st, cfg) -> SimpleNamespace:
    """The slope's scene: the sample, its axis on the floor's centre, lifted onto a floor
    of fixed beads of ``rubber_radius`` on a hexagonal lattice spanning ``floor_extent`` ×
    its radius R.  (model, state, sand, ids (sand and beads), rubber, R, lift)."""
    axis = st.axis()
    R = st.outer_radius(axis)
    lift = 2 * cfg.rubber_radius
    sc = Scene(gravity=(0.0, 0.0, -G))
    sand, beads = st.add_to(sc, wire_law=cfg.law, neighbour_contact=cfg.neighbour_contact,
                            shift=(-axis[0], -axis[1], lift - st.floor))
    ids = np.concatenate([sand, *beads]) if beads else np.asarray(sand)
    rubber = sc.add_spheres(hex_floor(cfg.rubber_radius, cfg.floor_extent * R),
                            cfg.rubber_radius, density=1000.0, group="rubber")
    sc.fix(rubber)
    sc.interact("rubber", "rubber", None)
    deposit_laws(sc, "rubber", mu=cfg.mu, mu_support=cfg.mu_floor, mu_wire=cfg.mu_wire,
                 wire=st.has_wire)
    model, state = sc.compile(**compile_options(cfg))
    return SimpleNamespace(model=st.carry_over(model, state), state=state,
                           sand=np.asarray(sand), ids=ids, rubber=rubber, R=R, lift=lift)


def _profile(heap, state, cfg, steps):
    """(the heap's profile or None, why not or None, the per-sector heights): None when
    the run stopped (``steps``, Ctrl-C) before the heap spread over the floor."""
    try:
        prof = slope_profile(heap.model, state, floor=heap.rubber, center=(0.0, 0.0),
                             r_max=cfg.floor_extent * heap.R, n_bins=PROFILE_BINS, n_sectors=8,
                             degree=cfg.fit_degree)
    except ValueError as e:
        error = (f"no slope profile after {steps} steps ({e}): the heap has not spread over "
                 f"the floor yet")
        warnings.warn(f"slope_deposit: {error}; the result has profile=None and "
                      f"max_slope_deg=nan", RuntimeWarning, stacklevel=4)
        return None, error, np.full((0, 8), np.nan)
    return prof, None, _sector_heights(heap, state, prof)


def _sector_heights(heap, state, prof) -> np.ndarray:
    """The heap's height per radial bin and angular sector (the axisymmetry check)."""
    model = heap.model
    hp = np.setdiff1d(model.sphere_ids, heap.rubber)
    x = state.position[hp]
    rr = np.hypot(x[:, 0], x[:, 1])
    rb = np.clip(np.digitize(rr, prof.r_edges) - 1, 0, len(prof.r) - 1)
    sec = ((np.arctan2(x[:, 1], x[:, 0]) + np.pi) / (2 * np.pi) * 8).astype(int) % 8
    sector_h = np.full((len(prof.r), 8), np.nan)
    np.fmax.at(sector_h, (rb, sec), x[:, 2] + model.body_radius[hp] - heap.lift)
    return sector_h


def _floor_force(heap, state) -> float:
    """The vertical force of the heap on the rubber plane [N]."""
    c = state.contacts
    on_j, on_i = np.isin(c.j, heap.rubber), np.isin(c.i, heap.rubber)
    return -float(-c.force[on_j & ~on_i, 2].sum() + c.force[on_i & ~on_j, 2].sum())


def _slope_result(heap, done, cfg, st, chains0) -> SlopeResult:
    model, state = heap.model, done.state
    prof, profile_error, sector_h = _profile(heap, state, cfg, done.stages.steps)
    lost = int(np.count_nonzero(state.position[heap.ids, 2] < 0.0))
    if lost:
        warnings.warn(f"slope_deposit: {lost} particles rolled off the floor's edge "
                      f"(floor_extent = {cfg.floor_extent:g} sample radii) and fell; they are "
                      f"left out of the rest criterion and the profile", RuntimeWarning,
                      stacklevel=3)
    wire = st.has_wire
    chains1 = wire_chains(model, state) if wire else []
    return SlopeResult(
        name="slope_deposit", profile=prof,
        max_slope_deg=prof.max_slope_deg if prof is not None else float("nan"),
        sector_heights=sector_h, floor_force=_floor_force(heap, state),
        weight=float(model.body_mass[heap.ids].sum() * G),
        time=done.rec.array("time"), kinetic_energy=done.rec.array("kinetic_energy"),
        **wire_before_after(chains0, chains1, st.volume()), at_rest=done.at_rest,
        history=done.hist.path,
        params=dict(scale=cfg.scale, sample=st.source, wire=wire, wire_density=st.wire_density,
                    wire_law=repr(cfg.law), neighbour_contact=bool(wire and cfg.neighbour_contact),
                    steps=cfg.steps, ke_fraction=cfg.ke_fraction,
                    rubber_radius=cfg.rubber_radius, n_rubber=int(len(heap.rubber)),
                    floor_extent=cfg.floor_extent, dt=cfg.dt, theta=cfg.theta, tol=cfg.tol,
                    max_iter=cfg.max_iter, relax=cfg.relax, anderson=cfg.anderson,
                    threads=cfg.threads, hot_sweeps=cfg.hot_sweeps,
                    chain_solve=cfg.chain_solve, contact_compliance=cfg.contact_compliance,
                    overlap_tol=cfg.overlap_tol, mu=cfg.mu,
                    mu_floor=cfg.mu_floor, mu_wire=cfg.mu_wire, seed=cfg.seed,
                    n_sand=int(st.sand_radii.size), n_beads=st.n_beads,
                    friction_angle_deg=math.degrees(math.atan(cfg.mu)),
                    profile_error=profile_error, lost_particles=lost,
                    config=cfg.config.model_dump(mode="json")))
