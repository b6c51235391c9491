"""Pieces shared by the paper's three tests: result object, loading-rate choice from the
inertial number, convergence bookkeeping, recorders, the stages (:class:`Stages`: each one
:func:`engine.step.run` with its updaters and stop condition), the run to rest
(:class:`AtRest`, :class:`SaveCheckpoint`, :func:`rest_run`) and its checkpoints."""
from __future__ import annotations

import contextlib
import contextvars
import functools
import hashlib
import json
import math
import os
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..drivers import ConfinementError  # noqa: F401  (re-exported: engine.experiments)
from ..laws import DEFAULT_STIFFNESS
from ..scene import check_bool  # noqa: F401  (the experiments import it from here)
from ..errors import ConvergenceError, NonConvergenceWarning
from ..step import run
from ..trigger import Updater

__all__ = ["TestResult", "ConvergenceError", "inertial_rate", "check_scale"]


@dataclass
class TestResult:
    """Curves of a mechanical test, one row per recorded step.

    Conventions: ``axial_strain`` and ``volumetric_strain`` are positive in compression /
    contraction and ``deviator`` q = σ_axial − σ_lateral [Pa] positive in compression (soil
    mechanics); the tensors ``stress``, ``sand_stress`` and ``wire_stress`` (n, 3, 3) [Pa]
    are Weber stresses (Eq. 18) with tension positive, as :func:`engine.analysis.weber_stress`.

    Attributes
    ----------
    name : str
    time : (n,) [s];  step : (n,)
    axial_strain, volumetric_strain : (n,) [-]
    deviator, mean_stress : (n,) [Pa]   q and p = −tr σ / 3.
    stress, sand_stress, wire_stress : (n, 3, 3) [Pa]
    wire_equivalent : (n,) [Pa]         ‖dev σ_wire‖ (Fig. 15).
    history : str                        the HDF5 history file.
    params : dict                        every parameter used, the loading rate and the
                                         inertial number chosen, seeds.
    convergence : dict                   steps, non-converged count and share, the limit.
    extra : dict                         test-specific outputs (wall stresses, profiles,
                                         toroidal maps, H, wire statistics ...).
    """

    name: str
    time: np.ndarray
    step: np.ndarray
    axial_strain: np.ndarray
    volumetric_strain: np.ndarray
    deviator: np.ndarray
    mean_stress: np.ndarray
    stress: np.ndarray
    sand_stress: np.ndarray
    wire_stress: np.ndarray
    wire_equivalent: np.ndarray
    history: str
    params: dict = field(default_factory=dict)
    convergence: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    def __str__(self):
        c = self.convergence
        s = (f"{self.name}: {len(self.time)} records, {c.get('steps', 0)} steps"
             f"{interrupted_note(self)}, "
             f"{c.get('non_converged', 0)} not converged ({c.get('share', 0):.1%}); ")
        if self.params.get("iso_reached") is False and not c.get("interrupted"):
            s += "isotropic stage NOT reached (see the warning); "
        if len(self.time):
            s += (f"final axial strain {self.axial_strain[-1]:.4f}, deviator "
                  f"{self.deviator[-1]:.4g} Pa, mean stress {self.mean_stress[-1]:.4g} Pa; ")
        return s + f"history {self.history}"

    def scalars(self) -> dict:
        """The test's scalar results (what a campaign's table keeps): the run's steps and
        convergence, the curves' final values, the wire stress's principal values, H
        (Table 2) or why it could not be fitted."""
        out = _run_scalars(self)
        n = len(self.time)
        last = (lambda a: float(np.asarray(a)[-1]) if n else float("nan"))
        out.update(records=n, axial_strain=last(self.axial_strain),
                   deviator=last(self.deviator), mean_stress=last(self.mean_stress),
                   volumetric_strain=last(self.volumetric_strain),
                   wire_equivalent=last(self.wire_equivalent),
                   iso_reached=bool(self.params.get("iso_reached")),
                   strain_rate=self.params.get("strain_rate"),
                   n_sand=self.params.get("n_sand"), n_beads=self.params.get("n_beads"))
        if n:
            w = np.linalg.eigvalsh(np.asarray(self.wire_stress[-1]))
            out["wire_principal_min"], out["wire_principal_max"] = float(w[0]), float(w[-1])
        H = self.extra.get("H")
        if H is not None:
            out.update(H=H.H, H_r2=H.r2, H_start_strain=H.start_point[0],
                       H_start_stress=H.start_point[1])
        elif "H_error" in self.extra:
            out["H_error"] = self.extra["H_error"]
        return out


def _run_scalars(result) -> dict:
    """The scalars of every test's result: steps, convergence, history, resumed from."""
    c = result.convergence or {}
    out = dict(steps=c.get("steps"), non_converged=c.get("non_converged"),
               non_converged_share=c.get("share"), history=result.history,
               steps_wall_time=c.get("wall_time"))
    if c.get("resumed_from"):                  # a run resumed from checkpoints of these steps
        out["resumed_from"] = ",".join(map(str, c["resumed_from"]))
    if c.get("resumed_with_other_code"):       # ... of them, under other engine code
        out["resumed_with_other_code"] = ",".join(map(str, c["resumed_with_other_code"]))
    return out


#: Largest sample scale the tests build (10: ten times the paper's samples, about 300 000
#: bodies, a few GB; beyond, the memory asked for runs out before anything is built).
MAX_SCALE = 10.0


def check_scale(scale) -> float:
    """``scale`` as a float in (0, :data:`MAX_SCALE`] (1: the paper's sample size); a
    string or a bool is refused."""
    if isinstance(scale, (bool, np.bool_)) or not isinstance(scale, (int, float, np.number)):
        raise ValueError(f"scale must be a number in (0, {MAX_SCALE:g}] (1: the paper's "
                         f"sample), got {scale!r}")
    s = float(scale)
    if not (math.isfinite(s) and 0 < s <= MAX_SCALE):
        raise ValueError(f"scale must be a number in (0, {MAX_SCALE:g}] (1: the paper's "
                         f"sample), got {scale!r}")
    return s


def check_positive(name, value, unit):
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be finite and > 0 {unit}, got {value!r}")
    return v


#: The experiments' NLGS accelerator: re-sweeps of the hot contacts after each sweep
#: (``hot_sweeps``, docs/speed.md).  Measured against ``anderson=4`` (the default until
#: 2026-11-25) on every test: 14-21 % less wall time at the default scales and 17-20 % at
#: the paper's (cylinder, slope at half scale), with far fewer steps at ``max_iter``.
HOT_SWEEPS = 2


def solver_choice(anderson, hot_sweeps) -> tuple[int, int]:
    """(anderson, hot_sweeps) of an experiment: ``hot_sweeps=None`` means :data:`HOT_SWEEPS`
    when ``anderson`` is 0, and 0 when the caller asked for Anderson mixing (the two do not
    combine)."""
    a = int(anderson)
    return a, (HOT_SWEEPS if a == 0 else 0) if hot_sweeps is None else int(hot_sweeps)


def compile_options(cfg) -> dict:
    """The keywords of :meth:`engine.Scene.compile` of a test, from its flat config ``cfg``
    (time step, θ and the NLGS options): the one place the tests pass them on."""
    return dict(dt=cfg.dt, theta=cfg.theta, tol=cfg.tol, max_iter=cfg.max_iter,
                relax=cfg.relax, anderson=cfg.anderson, threads=cfg.threads,
                hot_sweeps=cfg.hot_sweeps, chain_solve=cfg.chain_solve,
                contact_compliance=cfg.contact_compliance, overlap_tol=cfg.overlap_tol,
                max_overlap=cfg.max_overlap)


def inertial_rate(pressure, d_mean, density, inertial_number):
    """Strain rate [1/s] of inertial number I = ε̇ d √(ρ/p) (GDR MiDi 2004)."""
    return inertial_number * math.sqrt(pressure / density) / d_mean


def inertial_number(rate, pressure, d_mean, density):
    return rate * d_mean * math.sqrt(density / pressure)


def choose_rate(rate, pressure, d_mean, density, *, target_I, allow_dynamic):
    """The loading strain rate: from ``target_I`` when ``rate`` is None; a given rate whose
    inertial number exceeds 0.1 is refused unless ``allow_dynamic``."""
    if rate is None:
        return inertial_rate(pressure, d_mean, density, target_I), target_I
    rate = check_positive("strain_rate", rate, "[1/s]")
    I = inertial_number(rate, pressure, d_mean, density)
    if I > 0.1 and not allow_dynamic:
        raise ValueError(f"strain_rate {rate:g} 1/s gives an inertial number I = {I:.3g} > 0.1 "
                         f"(a dynamic test); lower it or pass allow_dynamic=True")
    return rate, I


#: The wire stiffness k [N] of the tests' default law, the paper's ElasticWire(k = 1 N)
#: (§3.3; the slope's is not given, the same is used).
DEFAULT_WIRE_STIFFNESS = DEFAULT_STIFFNESS


def wire_law_or_default(wire_law):
    """``wire_law`` checked to be a wire law, or the tests' default
    ``ElasticWire(DEFAULT_WIRE_STIFFNESS)`` for None."""
    from .. import laws

    if wire_law is None:
        return laws.ElasticWire(stiffness=DEFAULT_WIRE_STIFFNESS)
    if not isinstance(wire_law, laws.WireLaw):
        raise ValueError(f"wire_law must be a wire law (engine.laws.RigidWire(), "
                         f"ElasticWire(k) ...), got {wire_law!r}")
    return wire_law


_REPORT = contextvars.ContextVar("nscd_stage_report", default=None)


@contextlib.contextmanager
def report_stages_to(fn):
    """Within this block every stage of a test calls ``fn(desc, steps_done, total)`` after
    each chunk of steps, whatever its ``progress`` flag: how :func:`engine.sweep.sweep`
    follows the cases running on its workers (their own bars are off there)."""
    token = _REPORT.set(fn)
    try:
        yield
    finally:
        _REPORT.reset(token)


class _Progress:
    """The writer that keeps a test's counts as its steps go: after each step, the steps
    done and the non-converged ones (:class:`Stages`, so that a checkpoint saved by an
    updater has them), and every ``every`` steps (and at the end of each
    :meth:`Stages.run`) the test's one tqdm bar and the report ``(test name[, stage], steps
    done, total)`` to the function set by :func:`report_stages_to`.  It reads the state."""

    def __init__(self, stages, every: int):
        self.stages, self.every = stages, max(1, int(every))
        self.shown = stages.steps

    def trigger(self, step) -> bool:
        return True

    def write(self, model, state) -> None:
        st = self.stages
        st.steps += 1
        if not state.stats.converged:
            st.non_converged.append(state.step)
        if st.steps - self.shown >= self.every:
            self.show()

    def show(self) -> None:
        st = self.stages
        if st.bar is not None:
            st.bar.update(st.steps - self.shown)
            st.bar.set_postfix(nc=len(st.non_converged), refresh=False)
        self.shown = st.steps
        if st.report is not None:
            st.report(st.desc if st.stage is None else f"{st.desc}, {st.stage}",
                      st.steps, st.total)


class Stages:
    """Runs the stages of a test (each a :func:`engine.step.run` with its updaters and stop
    condition) with one tqdm bar, counts non-converged steps, stops on Ctrl-C, and keeps the
    recorders.  Every ``report_every`` steps it reports ``(test name[, stage], steps done,
    total)`` to the function set by :func:`report_stages_to`, if any (``total``: the test's
    upper bound on its steps)."""

    def __init__(self, model, state, writers, *, progress, total, desc, report_every=10):
        self.model, self.state, self.writers = model, state, list(writers)
        self.desc, self.total = desc, int(total)
        self.stage = None
        self.report = _REPORT.get()
        self.report_every = report_every
        self.steps = 0
        self.wall_time = 0.0  # [s] spent in the steps (writers included), not in the set-up
        self.non_converged = []
        self.resumed_from = []      # the steps a resumed run went on from (RestCheckpoint)
        self.other_code_at = []     # those of them where the engine's code had changed
        self.interrupted = False
        self.condition_met = False  # the last run's stop condition ended it
        self._started = None        # perf_counter() at the start of the running stage
        self.bar = None
        if progress:
            from tqdm.auto import tqdm
            self.bar = tqdm(total=int(total), unit="step", desc=desc, dynamic_ncols=True,
                            mininterval=0.1 if sys.stderr.isatty() else 10.0)

    def run(self, n, updaters=(), until=None):
        """Run at most n steps of ``self.model`` with these updaters and stop condition
        (:func:`engine.step.run`; ``steps`` and ``non_converged`` count as it goes); False
        if interrupted."""
        progress = _Progress(self, self.report_every)
        self._started = time.perf_counter()
        s = None
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", NonConvergenceWarning)
                s = run(self.model, self.state, int(n), writers=self.writers + [progress],
                        progress=False, updaters=updaters, until=until)
        finally:
            self._started = None
            if progress.shown != self.steps or (s is not None and s.steps == 0):
                progress.show()         # the bar where the stage ended (or failed)
        self.wall_time += s.wall_time
        self.condition_met = s.condition_met
        if s.interrupted:
            self.interrupted = True
        return not s.interrupted

    def elapsed(self) -> float:
        """[s] spent in the steps so far, the running stage's included."""
        return self.wall_time + (0.0 if self._started is None
                                 else time.perf_counter() - self._started)

    def set_stage(self, name):
        """Name the stage now running (``"isotropic"``, ``"loading"``): the bar and the
        reports show it after the test's name."""
        self.stage = name
        if self.bar is not None:
            self.bar.set_description(f"{self.desc}, {name}", refresh=False)

    def record_last(self):
        """The state reached, to every writer that has not recorded this step
        (``write_final``): a test ends between two records (its step count is rarely a
        multiple of ``record_every``, or Ctrl-C stopped it), and its end state is kept."""
        for w in self.writers:
            final = getattr(w, "write_final", None)
            if final is not None:
                final(self.model, self.state)

    def close(self):
        if self.bar is not None:
            if (not self.interrupted and sys.exc_info()[0] is None
                    and self.bar.n < self.bar.total):
                # ``total`` is an upper bound (the isotropic stage ends when it is reached):
                # a test that finished ends its bar at 100 %, not at the share of that
                # bound (one stopped by Ctrl-C or an error keeps it)
                self.bar.total = self.bar.n
                self.bar.refresh()
            self.bar.close()

    def convergence(self, limit):
        share = len(self.non_converged) / self.steps if self.steps else 0.0
        return dict(steps=self.steps, non_converged=len(self.non_converged), share=share,
                    limit=limit, interrupted=self.interrupted, wall_time=self.wall_time,
                    resumed_from=list(self.resumed_from),
                    resumed_with_other_code=list(self.other_code_at),
                    non_converged_steps=self.non_converged[:1000])


class AtRest(Updater):
    """The rest criterion of a run to rest, an updater at the end of each chunk of ``every``
    steps (and at the run's last step, ``steps``): the kinetic energy ``energy(model,
    state)`` [J] is
    at most ``ke_fraction`` of its peak so far, looked at from the 10th chunk on (a sample
    released at rest gains energy first).  The steps are counted from the start of the run
    (the :class:`Stages`' count), so a resumed run (``peak``, ``at_rest`` from its
    checkpoint) looks on the same steps as one that never stopped.  The run's stop
    condition is :attr:`at_rest`."""

    def __init__(self, stages, steps, every, ke_fraction, energy, peak=0.0, at_rest=False):
        self.stages, self.steps, self.every = stages, int(steps), int(every)
        self.ke_fraction, self.energy = ke_fraction, energy
        self.peak, self.at_rest = peak, at_rest

    def trigger(self, step) -> bool:
        n = self.stages.steps
        return n % self.every == 0 or n == self.steps

    def update(self, model, state) -> None:
        ke = self.energy(model, state)
        self.peak = max(self.peak, ke)
        self.at_rest = (self.stages.steps >= 10 * self.every and self.peak > 0
                        and ke <= self.ke_fraction * self.peak)

    def __call__(self, model, state) -> bool:
        return self.at_rest


class SaveCheckpoint(Updater):
    """The updater saving a run to rest's :class:`RestCheckpoint` every ``checkpoint.every``
    steps of the run while it is not at rest (after :class:`AtRest`, whose peak it keeps)."""

    def __init__(self, checkpoint: "RestCheckpoint", stages, rest: AtRest):
        self.checkpoint, self.stages, self.rest = checkpoint, stages, rest
        self.saved_at = None

    def trigger(self, step) -> bool:
        return not self.rest.at_rest and self.checkpoint.due(self.stages.steps)

    def update(self, model, state) -> None:
        self.checkpoint.save(self.stages, self.rest.peak, self.rest.at_rest)
        self.saved_at = self.stages.steps


def run_to_rest(stages: Stages, steps: int, every: int, ke_fraction: float, energy,
                checkpoint: "RestCheckpoint | None" = None,
                resumed: "Resumed | None" = None) -> bool:
    """Run ``stages`` until it is at rest (:class:`AtRest`, every ``every`` steps), or
    ``steps`` steps in all, or an interruption; then hand the end state to the writers
    (:meth:`Stages.record_last`).  Returns whether the rest criterion was met.

    ``checkpoint``: saved every ``checkpoint.every`` steps (:class:`SaveCheckpoint`) and at
    an interruption, so the run can go on from there; ``resumed``: the run goes on from
    such a checkpoint (its peak energy, whether it was at rest), and ends as if it had never
    stopped: a stop in the last step of a chunk looks at it before saving."""
    rest = AtRest(stages, steps, every, ke_fraction, energy,
                  *(() if resumed is None else (resumed.peak, resumed.at_rest)))
    save = None if checkpoint is None else SaveCheckpoint(checkpoint, stages, rest)
    if not rest.at_rest and stages.steps < steps:
        ran = stages.run(steps - stages.steps, updaters=[rest] + ([save] if save else []),
                         until=rest)
        if not ran and save is not None and save.saved_at != stages.steps:
            checkpoint.save(stages, rest.peak, rest.at_rest)   # before its end record
    stages.record_last()
    return rest.at_rest


#: Arguments of a test that do not change its run (not part of a checkpoint's identity;
#: the thread count is checked on the model, :meth:`RestCheckpoint.load`; the slope's
#: ``fit_degree`` only changes the regression of the heap at rest).
NOT_IDENTITY = ("history", "progress", "resume", "checkpoint_every", "threads", "fit_degree",
                "max_overlap")


def run_identity(arguments: dict) -> str:
    """The JSON a checkpoint is tied to: a test's name and the arguments that decide its
    result (``locals()`` at the test's start), numpy scalars as numbers, laws by their
    repr."""
    def plain(v):
        if isinstance(v, np.generic):
            v = v.item()
        return v if isinstance(v, (bool, int, float, str, type(None))) else repr(v)

    return json.dumps({k: plain(v) for k, v in arguments.items() if k not in NOT_IDENTITY
                       and not (k in LATER_ARGUMENTS and v == LATER_ARGUMENTS[k])},
                      sort_keys=True)


#: Arguments added after checkpoints were first written, left out of a run's identity at
#: these defaults, so that a checkpoint written before them still resumes.
LATER_ARGUMENTS = {"chain_solve": False, "contact_compliance": 0.0}


def sample_identity(sample):
    """What a checkpoint's identity holds of a test's ``sample`` argument: a name as it is,
    a built sample (:class:`engine.prep.Sample`) as the SHA-256 of its particles."""
    from ..prep.samples import Sample

    if sample is None or isinstance(sample, str):
        return sample
    h = hashlib.sha256()
    if isinstance(sample, Sample):
        for a in (sample.sand_centers, sample.sand_radii, *sample.wire):
            h.update(np.ascontiguousarray(a, dtype=float).tobytes())
        h.update(repr((sample.name, sample.bead_radius, sample.container)).encode())
        return f"{sample.name} sample {h.hexdigest()[:16]}"
    if isinstance(sample, tuple) and len(sample) == 2 and hasattr(sample[1], "vel6"):
        for a in (sample[1].position, sample[1].vel6, sample[0].body_radius,
                  sample[0].link_ref_length):
            h.update(np.ascontiguousarray(a, dtype=float).tobytes())
        return f"state {h.hexdigest()[:16]}"
    path = getattr(sample, "history", sample)
    return os.fspath(path) if isinstance(path, (str, os.PathLike)) else repr(sample)


@functools.cache
def engine_code() -> str:
    """A fingerprint of the engine's code (12 hex digits of the SHA-256 of the paths and
    bytes of every ``engine/**/*.py``).  A checkpoint keeps the one it was written with;
    a run resumed under another says so (:meth:`RestCheckpoint.load`)."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py")):
        h.update(p.relative_to(root).as_posix().encode() + b"\0" + p.read_bytes())
    return h.hexdigest()[:12]


engine_code()   # at import: the code this process runs, not files edited while it runs


@dataclass
class Resumed:
    """A run to rest restored from its checkpoint (:meth:`RestCheckpoint.load`);
    ``other_code``: the checkpoint was written by other engine code (:func:`engine_code`)."""

    state: object
    steps: int
    peak: float
    at_rest: bool
    info: dict
    other_code: bool = False


def _model_difference(a, b) -> str | None:
    """None if the two models are the same (arrays, options, laws), else what differs."""
    import dataclasses

    from ..model import Model

    for f in dataclasses.fields(Model):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            if not (isinstance(y, np.ndarray) and x.shape == y.shape
                    and np.array_equal(x, y, equal_nan=x.dtype.kind == "f")):
                return f"its model's {f.name}"
    oa, ob = a.options.model_dump(), b.options.model_dump()
    diff = sorted(k for k in oa if oa[k] != ob.get(k))
    if diff:
        return "its solver options (" + ", ".join(f"{k} {oa[k]!r}, now {ob.get(k)!r}"
                                                  for k in diff) + ")"
    if ([(type(x).__name__, x.model_dump()) for x in a.laws]
            != [(type(x).__name__, x.model_dump()) for x in b.laws]):
        return "its contact laws"
    return None


class RestCheckpoint:
    """Checkpoints of a run to rest (``history`` with the suffix ``.resume.h5``): the whole
    state (:func:`engine.io.save`, a bit-identical restart point) with the recorded
    curves, the step count, the non-converged steps, the peak energy and the history's
    run id, every ``every`` steps (rounded up to a multiple of ``record_every``; 0: only
    when interrupted) and when Ctrl-C / SIGTERM stops the run.  The test called again with
    ``resume=True`` goes on from it, and ends as the run that never stopped would have, bit
    for bit (the history's records and frames after the checkpoint are cut and written
    again).  It is removed when the run ends, and when a run starts afresh."""

    SUFFIX = ".resume.h5"

    def __init__(self, history: str, every: int, record_every: int, identity: str):
        if (isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 0):
            raise ValueError(f"checkpoint_every must be an integer >= 0 [steps; 0: only when "
                             f"interrupted], got {every!r}")
        from ..io import lock_history

        self.path = os.path.splitext(os.fspath(history))[0] + self.SUFFIX
        # the run's lock, before its checkpoint is read or removed: a second run on the
        # same history is refused (engine.io.RunLocked) before it touches anything
        self.lock = lock_history(history)
        self.every = -(-int(every) // record_every) * record_every
        self.identity = identity
        self.recorder = None
        self.history = None         # the History writer (its run id)

    def due(self, steps: int) -> bool:
        return bool(self.every) and steps % self.every == 0

    def save(self, stages: Stages, peak: float, at_rest: bool = False) -> None:
        from ..io import save

        rec = self.recorder
        extra = {"identity": self.identity, "steps": stages.steps, "peak": float(peak),
                 "at_rest": int(bool(at_rest)), "wall_time": stages.elapsed(),
                 "run_id": self.history.run_id or "",
                 "resumed_from": np.asarray(stages.resumed_from, np.int64),
                 "other_code_at": np.asarray(stages.other_code_at, np.int64),
                 "engine_code": engine_code(),
                 "non_converged": np.asarray(stages.non_converged, np.int64),
                 "written_step": -1 if rec.written_step is None else rec.written_step}
        extra.update({f"rec_{k}": np.asarray(v, float) for k, v in rec.rows.items()})
        save(self.path, stages.model, stages.state, extra)

    def load(self, model, history: str) -> Resumed | None:
        """The run restored from the checkpoint, or None: there is none, or it cannot be
        used (another run's parameters, model or history; unreadable; its history gone or
        not reopenable): a warning says why, the checkpoint is removed and the run starts
        afresh.  A checkpoint written by other engine code (:func:`engine_code`: the
        engine was edited or updated in between) is resumed, with a warning, and the run's
        ``convergence["resumed_with_other_code"]`` lists the step: such a run may not end
        as one that never stopped would have."""
        from ..io import history_run_id, load, load_extra, read_history

        if not os.path.exists(self.path):
            return None
        why = None
        try:
            info = load_extra(self.path)
            if info.get("identity") != self.identity:
                why = "it belongs to a run with other parameters"
            elif not os.path.exists(history):
                why = f"its history {history} is gone"
            else:
                ckpt_model, state = load(self.path)
        except (ValueError, OSError, KeyError) as e:       # FormatError is a ValueError
            why = f"it cannot be read ({e})"
        if why is None:
            try:
                h = read_history(history, frames=False)
                run_id = history_run_id(history) or ""
            except (ValueError, OSError) as e:   # the history is bad, not the checkpoint
                raise ValueError(f"cannot resume: {e}; the checkpoint {self.path} is kept "
                                 f"(move or remove the history to start afresh)") from None
            diff = _model_difference(ckpt_model, model)
            if diff is not None:
                why = f"{diff} differs from this run's (another engine version?)"
            elif run_id != info.get("run_id", ""):
                why = f"its history {history} is another run's"
            elif h.n_records and h.step[-1] < int(info["written_step"]):
                why = f"its history {history} stops before it"
        if why is not None:
            warnings.warn(f"not resuming from {self.path}: {why}; the run starts afresh",
                          RuntimeWarning, stacklevel=3)
            self.remove()
            return None
        written_by = str(info.get("engine_code", "")) or "unknown"
        other = written_by != engine_code()
        if other:
            warnings.warn(f"resuming from {self.path}, written by other engine code "
                          f"({written_by}, now {engine_code()}): the run goes on, but may not "
                          f"end as one that never stopped would have", RuntimeWarning,
                          stacklevel=3)
        return Resumed(state=state, steps=int(info["steps"]), peak=float(info["peak"]),
                       at_rest=bool(info.get("at_rest", 0)), info=info, other_code=other)

    def restore(self, resumed: Resumed, rec: "Recorder", stages: Stages) -> None:
        """Put the recorder's curves and the stages' counts back as they were saved."""
        info = resumed.info
        for k in rec.fns:
            rec.rows[k] = [float(v) for v in np.atleast_1d(info[f"rec_{k}"])]
            if rec.rows[k]:
                rec.last[k] = rec.rows[k][-1]
        w = int(info["written_step"])
        rec.written_step = None if w < 0 else w
        stages.steps = resumed.steps
        stages.wall_time = float(info["wall_time"])
        stages.non_converged = [int(v) for v in np.atleast_1d(info["non_converged"])]
        stages.resumed_from = [int(v) for v in np.atleast_1d(info.get("resumed_from", []))]
        stages.resumed_from.append(resumed.steps)
        stages.other_code_at = [int(v) for v in np.atleast_1d(info.get("other_code_at", []))]
        if resumed.other_code:
            stages.other_code_at.append(resumed.steps)
        if stages.bar is not None:
            stages.bar.update(resumed.steps)

    def remove(self) -> None:
        import glob

        from ..files import leftovers

        for p in [self.path, *glob.glob(glob.escape(self.path) + ".tmp*"),
                  *leftovers(self.path)]:
            if os.path.exists(p):
                os.remove(p)


def wire_histograms(chains) -> dict:
    """Direction histograms of the wire elements in the three planes, 18 bins (Fig. 8-9)."""
    from ..analysis.wire import direction_histogram

    return {pl: direction_histogram(chains, pl, bins=18) for pl in ("xy", "xz", "yz")}


@dataclass(kw_only=True)
class RestResult:
    """The fields of a deposit's result (a sample run under gravity until it is at rest):
    :class:`engine.experiments.SlopeResult` and :class:`engine.experiments.DepositResult`
    add their own."""

    name: str
    time: np.ndarray
    kinetic_energy: np.ndarray
    wire_before: object
    wire_after: object
    histograms_before: dict
    histograms_after: dict
    weight: float
    at_rest: bool
    history: str
    params: dict = field(default_factory=dict)
    convergence: dict = field(default_factory=dict)

    def scalars(self) -> dict:
        """The deposit's scalar results (what a campaign's table keeps): the run's steps and
        convergence, at rest, the weight, the grain and bead counts, then the fields a
        deposit's result type declares as numbers (``float``, ``int``, ``bool``: the slope's
        maximum slope and floor force, the deposit's settlement, mould force and slack
        share), the particles lost (when counted) and the wire's tortuosity before and
        after."""
        import dataclasses

        out = _run_scalars(self)
        out.update(at_rest=bool(self.at_rest), weight=self.weight,
                   n_sand=self.params.get("n_sand"), n_beads=self.params.get("n_beads"))
        common = {f.name for f in dataclasses.fields(RestResult)}
        out.update({f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                    if f.name not in common and f.type in ("float", "int", "bool")})
        if "lost_particles" in self.params:
            out["lost_particles"] = self.params["lost_particles"]
        if self.wire_before is not None:
            out.update(tortuosity_before=self.wire_before.tortuosity,
                       tortuosity_after=self.wire_after.tortuosity)
        return out


def deposit_laws(sc, support: str, *, mu, mu_support, mu_wire, wire) -> None:
    """The Coulomb laws of a deposit: sand–sand ``mu``, sand and wire on the ``support``
    group (the mould, the rubber floor) ``mu_support``, wire–sand and wire–wire
    ``mu_wire``."""
    from .. import laws

    sc.interact("sand", "sand", laws.Coulomb(mu=mu))
    sc.interact("sand", support, laws.Coulomb(mu=mu_support))
    if wire:
        for g in ("sand", "wire"):
            sc.interact("wire", g, laws.Coulomb(mu=mu_wire))
        sc.interact("wire", support, laws.Coulomb(mu=mu_support))


def wire_before_after(chains0, chains1, volume) -> dict:
    """The wire fields of a deposit's result: statistics (tortuosity ξ, Fig. 7; orientation;
    length density over ``volume`` [m³]) and direction histograms (Fig. 8-9) of the chains
    before (``chains0``) and after (``chains1``); None and {} without a wire."""
    from ..analysis.wire import wire_stats

    if not chains0:
        return dict(wire_before=None, wire_after=None, histograms_before={},
                    histograms_after={})
    return dict(wire_before=wire_stats(chains0, volume), wire_after=wire_stats(chains1, volume),
                histograms_before=wire_histograms(chains0),
                histograms_after=wire_histograms(chains1))


def rest_recording(model, state, ids, *, history, record_every, frames, progress, steps,
                   desc, checkpoint: RestCheckpoint | None = None,
                   resumed: Resumed | None = None, meta: dict | None = None):
    """The writers and stages of a run to rest: a :class:`Recorder` of the time and the
    kinetic energy of ``ids`` [J], its HDF5 history, and the :class:`Stages` running both;
    returns (recorder, history, stages).  ``resumed``: the run goes on from that checkpoint
    (``state`` is its state): the history is reopened there and the curves and counts
    restored.  ``meta``: what the history says of the run (:func:`run_meta`)."""
    from ..analysis.energy import kinetic_energy

    rec = Recorder({"time": lambda m, s: s.time,
                    "kinetic_energy": lambda m, s: kinetic_energy(m, s, ids)}, record_every)
    if checkpoint is not None and resumed is None:
        checkpoint.remove()             # a fresh start: an old checkpoint is not of this run
    hist = history_writer(history, rec, {"time": "s", "kinetic_energy": "J"}, record_every,
                          frames, resume_step=None if resumed is None else resumed.steps,
                          meta=meta)
    try:
        stages = Stages(model, state, [rec, hist], progress=progress, total=steps, desc=desc,
                        report_every=record_every)
        if checkpoint is not None:
            checkpoint.recorder, checkpoint.history = rec, hist
            if resumed is not None:
                checkpoint.restore(resumed, rec, stages)
    except BaseException:
        hist.close()
        raise
    return rec, hist, stages


@dataclass
class RestRun:
    """What :func:`rest_run` leaves: the state reached (the checkpoint's, when resumed),
    the recorder of the time and the kinetic energy, the history, the stages and whether
    the run came to rest."""

    state: object
    rec: Recorder
    hist: object
    stages: Stages
    at_rest: bool


def rest_run(model, state, ids, energy, cfg, *, desc, meta, checkpoint: RestCheckpoint,
             record_start: bool = False) -> RestRun:
    """A deposit's one stage: run under gravity until at rest (:func:`run_to_rest`:
    ``energy(model, state)`` [J] at most ``cfg.ke_fraction`` of its peak, or ``cfg.steps``
    steps), recording the time and the kinetic energy of ``ids`` every
    ``cfg.record_every`` steps (:func:`rest_recording`); with ``cfg.resume``, from the
    ``checkpoint`` a stopped run of the same call left.  ``record_start``: the start
    state is the history's first record and frame (not on a resumed run).  The checkpoint
    is removed when the run ends (kept when it was interrupted) and its lock released."""
    resumed = checkpoint.load(model, cfg.history) if cfg.resume else None
    if resumed is not None:
        state = resumed.state
    rec, hist, stages = rest_recording(model, state, ids, history=cfg.history,
                                       record_every=cfg.record_every, frames=cfg.frames,
                                       progress=cfg.progress, steps=cfg.steps, desc=desc,
                                       checkpoint=checkpoint, resumed=resumed, meta=meta)
    try:
        if record_start and resumed is None:
            rec.write(model, state)      # the start: step 0, record and frame
            hist.write(model, state)
        at_rest = run_to_rest(stages, cfg.steps, cfg.record_every, cfg.ke_fraction, energy,
                              checkpoint=checkpoint, resumed=resumed)
    finally:
        stages.close()
        hist.close()
    if not stages.interrupted:
        checkpoint.remove()
    checkpoint.lock.release()
    return RestRun(state, rec, hist, stages, at_rest)


def interrupted_note(result) -> str:
    """", INTERRUPTED (Ctrl-C / SIGTERM)" for a result whose run was stopped, else ""."""
    return ", INTERRUPTED (Ctrl-C / SIGTERM)" if result.convergence.get("interrupted") else ""


def rest_summary(result, middle: str) -> str:
    """One line on a run to rest: name, at rest or not after how many steps, ``middle``
    (the test's own numbers), the wire's tortuosity before and after, the history."""
    s = (f"{result.name}: {'at rest' if result.at_rest else 'NOT at rest'} after "
         f"{result.convergence.get('steps', 0)} steps{interrupted_note(result)}; {middle}")
    if result.wire_before is not None:
        s += (f"; tortuosity {result.wire_before.tortuosity:.0f} -> "
              f"{result.wire_after.tortuosity:.0f} 1/m")
    return s + f"; history {result.history}"


class Recorder:
    """A writer computing named quantities ``fn(model, state)`` every ``every`` steps and
    keeping them in lists (``rows``); ``last`` holds the latest values, which the HDF5
    history's extras read so nothing is computed twice."""

    def __init__(self, fns: dict, every: int):
        self.fns = fns
        self.every = int(every)
        self.rows = {k: [] for k in fns}
        self.last = {}
        self.active = True
        self.written_step = None

    def trigger(self, step):
        return self.active and step % self.every == 0

    def write(self, model, state):
        self.written_step = state.step
        for k, v in self.values(model, state).items():
            self.last[k] = v
            self.rows.setdefault(k, []).append(v)

    def values(self, model, state) -> dict:
        return {k: fn(model, state) for k, fn in self.fns.items()}

    def write_final(self, model, state):
        """:meth:`write` unless this step is recorded already or recording is off."""
        if self.active and self.written_step != state.step:
            self.write(model, state)

    def array(self, k):
        return np.asarray(self.rows[k])


def run_meta(test: str, total_steps: int, config: dict | None = None, **params) -> dict:
    """What a test's history says of its run (:class:`engine.io.History` ``meta``): its
    name, the steps it expects at most, its main parameters (``params``, laws as their
    repr: what ``nscd view`` lists beside each run) and ``config``, every argument it was
    called with (its :class:`~engine.experiments.config.TestConfig` as JSON; ``nscd
    info`` prints them)."""
    def plain(v):
        if v is None or isinstance(v, (bool, int, float, str)):
            return v
        if isinstance(v, (np.integer, np.floating, np.bool_)):
            return v.item()
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        return repr(v)

    out = {"test": test, "total_steps": int(total_steps),
           "params": {k: plain(v) for k, v in params.items()}}
    if config is not None:
        out["config"] = config
    return out


def history_writer(path, recorder: Recorder, units: dict, every: int, frames: int,
                   resume_step: int | None = None, meta: dict | None = None):
    """An :class:`engine.io.History` recording the recorder's latest values as extras, and a
    particle frame (positions, velocities, contacts) every ``frames`` steps, rounded up to a
    multiple of ``every`` (0: no frames): a frame is written with a record, whose values the
    extras read (``frames=6`` with records every 10 steps failed with a KeyError)."""
    from ..io import HISTORY_SCALARS, History

    if not isinstance(frames, (int, np.integer)) or isinstance(frames, bool) or frames < 0:
        raise ValueError(f"frames must be an integer >= 0 [steps between particle frames; 0: "
                         f"none], got {frames!r}")
    frames = -(-int(frames) // every) * every

    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    extra = {k: ((lambda m, s, k=k: recorder.last[k]), units.get(k, "-")) for k in recorder.fns
             if k not in HISTORY_SCALARS}       # time, step ... are recorded by History itself
    h = History(path, trigger=lambda step: recorder.trigger(step), frames=frames, extra=extra,
                flush=max(every, 1), resume_step=resume_step, meta=meta)
    return h


def finish(result: TestResult, stages: Stages, limit: float):
    """Fill the convergence record and fail loudly past the limit.  A run stopped by
    Ctrl-C / SIGTERM is returned as it is (``convergence["interrupted"]``, the state
    reached in its history): it is not judged on the steps it did not run, so the user
    keeps what it computed (the hard first steps of a deposit would fail it otherwise)."""
    result.convergence = stages.convergence(limit)
    c = result.convergence
    if c["steps"] and c["share"] > limit and not c["interrupted"]:
        raise ConvergenceError(
            f"{result.name}: {c['non_converged']} of {c['steps']} steps ({c['share']:.1%}) hit "
            f"max_iter without reaching tol (limit {limit:.0%}); raise max_iter, loosen tol or "
            f"lower dt (the history is in {result.history})", result)
    return result
