"""Parameter sweeps: independent simulations run on ``dask.distributed`` (DESIGN §7).

The unit of work is one whole simulation (a *case*): a call ``experiment(**params,
**fixed)`` returning a mapping of results.  :func:`sweep` runs every case of a grid on a
Dask cluster — a ``LocalCluster`` of two worker processes by default, an existing
``Client``, or a scheduler address for a real cluster — and gathers the scalar results into
one table, written as JSON (the store of record) and HDF5::

    from engine.sweep import sweep
    table = sweep("cylinder_triaxial", {"k": [0.1, 1.0, 10.0], "wire": ["elastic"],
                                        "scale": [0.05], "seed": [0, 1]},
                  out="out/k_sweep.json")
    table.rows          # one dict per case: params, status, attempts, errors, result, elapsed
    table.column("H")   # one result across the cases (NaN where missing)

* a case that raises is reported (``status="failed"`` with the error and its traceback
  tail) and retried ``retries`` times (once by default) while the other cases keep going;
* the table is rewritten after every finished case, keyed by the case's parameters, so a
  re-run (or a run after a crash or Ctrl-C) skips the cases already done and retries the
  failed ones;
* ``client="serial"`` runs the cases one by one in this process (the reference the
  distributed run is compared with, and the fallback without a cluster).

An experiment is a picklable callable (a module-level function) or the name of one of the
paper's tests in :data:`EXPERIMENTS` (``"cylinder_triaxial"``, ``"box_triaxial"``,
``"slope_deposit"``, ``"gravity_deposit"``), whose wrappers take JSON-able parameters (``wire = "elastic" |
"rigid" | "none"`` and ``k`` [N] instead of a law object) and return the test's scalars
(:func:`scalars_of`).  Parameters must be JSON-able (numbers, strings, booleans, None,
lists): they are the case's key.  Results: numbers, booleans, strings and None go into the
table; anything else is left out (write arrays to files from the experiment and return the
path).
"""
from __future__ import annotations

import hashlib
import inspect
import itertools
import json
import math
import os
import socket
import time
import traceback
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

__all__ = ["sweep", "SweepTable", "expand_grid", "case_key", "case_id", "run_case",
           "scalars_of", "load_table", "EXPERIMENTS", "local_client", "CaseInterrupted",
           "not_interrupted", "update_results"]

#: Format version of the JSON table.
TABLE_VERSION = 1


# ------------------------------------------------------------------ cases and keys

def expand_grid(grid) -> list[dict]:
    """The cases of a grid.

    ``grid`` is either a mapping ``{name: [values...]}`` (the Cartesian product, in the
    order of the mapping; a scalar value counts as a one-value list) or a sequence of
    mappings (explicit cases, taken as they are).  Duplicated cases are kept once.
    """
    if isinstance(grid, Mapping):
        names = list(grid)
        values = [v if isinstance(v, (list, tuple, np.ndarray)) else [v] for v in grid.values()]
        cases = [dict(zip(names, combo)) for combo in itertools.product(*values)]
    elif isinstance(grid, (list, tuple)):
        cases = []
        for c in grid:
            if not isinstance(c, Mapping):
                raise ValueError(f"grid: a list of cases must hold mappings, got {c!r}")
            cases.append(dict(c))
    else:
        raise ValueError(f"grid must be a mapping of lists or a list of mappings, got {type(grid)}")
    out, seen = [], set()
    for c in cases:
        c = {k: _plain(v, k) for k, v in c.items()}
        key = case_key("", c)
        if key not in seen:
            seen.add(key)
            out.append(c)
    return out


def _plain(v, name):
    """A JSON-able copy of a parameter value (numpy scalars to Python)."""
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_plain(x, name) for x in v]
    if v is None or isinstance(v, (bool, int, str)):
        return v
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"parameter {name!r}: {v!r} is not finite")
        return v
    raise ValueError(f"parameter {name!r}: {v!r} is not JSON-able (numbers, strings, booleans, "
                     f"None, lists); pass objects through fixed= or build them in the experiment")


def _experiment_name(experiment) -> str:
    if isinstance(experiment, str):
        return experiment
    mod = getattr(experiment, "__module__", None) or "?"
    return f"{mod}.{getattr(experiment, '__qualname__', repr(experiment))}"


def case_key(experiment, params: Mapping) -> str:
    """The key of a case in the table: the experiment's name and the parameters as
    canonical JSON (sorted keys), so the same parameters given in any order match."""
    return json.dumps({"experiment": _experiment_name(experiment), "params": params},
                      sort_keys=True, separators=(",", ":"))


def case_id(experiment, params: Mapping) -> str:
    """A short, file-name-safe id of a case (experiment name + 10 hex digits of the key)."""
    name = _experiment_name(experiment).rsplit(".", 1)[-1]
    return f"{name}-{hashlib.sha1(case_key(experiment, params).encode()).hexdigest()[:10]}"


# ------------------------------------------------------------------ the paper's tests

def _law(wire, k, prestrain=None, max_tension=None):
    """(has a wire, its law) of a sweep case: ``wire`` a law's name
    (:data:`engine.laws.WIRE_LAWS`, or "none"; True and False for "elastic" and "none"),
    ``k`` its stiffness [N], and the law's ``prestrain`` and ``max_tension``."""
    from . import laws

    if wire is True:
        wire = "elastic"
    elif wire is False or wire is None:
        wire = "none"
    if k is not None:
        try:
            k = float(k)
        except (TypeError, ValueError):
            raise ValueError(f"k must be the elastic wire's stiffness in N (> 0), got {k!r}") \
                from None
    law = laws.wire_law(wire, stiffness=k, prestrain=prestrain, max_tension=max_tension)
    return law is not None, law


def scalars_of(result) -> dict:
    """The scalar results of a :class:`engine.experiments.TestResult` or
    :class:`engine.experiments.SlopeResult` or :class:`engine.experiments.DepositResult`:
    final values, convergence, H (Table 2) ..."""
    c = result.convergence or {}
    out = dict(steps=c.get("steps"), non_converged=c.get("non_converged"),
               non_converged_share=c.get("share"), history=getattr(result, "history", None),
               steps_wall_time=c.get("wall_time"))
    if c.get("resumed_from"):                  # a run resumed from checkpoints of these steps
        out["resumed_from"] = ",".join(map(str, c["resumed_from"]))
    if c.get("resumed_with_other_code"):       # ... of them, under other engine code
        out["resumed_with_other_code"] = ",".join(map(str, c["resumed_with_other_code"]))
    if hasattr(result, "axial_strain"):                       # triaxial tests
        n = len(result.time)
        last = (lambda a: float(np.asarray(a)[-1]) if n else float("nan"))
        out.update(records=n, axial_strain=last(result.axial_strain),
                   deviator=last(result.deviator), mean_stress=last(result.mean_stress),
                   volumetric_strain=last(result.volumetric_strain),
                   wire_equivalent=last(result.wire_equivalent),
                   iso_reached=bool(result.params.get("iso_reached")),
                   strain_rate=result.params.get("strain_rate"),
                   n_sand=result.params.get("n_sand"), n_beads=result.params.get("n_beads"))
        if n:
            w = np.linalg.eigvalsh(np.asarray(result.wire_stress[-1]))
            out["wire_principal_min"], out["wire_principal_max"] = float(w[0]), float(w[-1])
        H = result.extra.get("H")
        if H is not None:
            out.update(H=H.H, H_r2=H.r2, H_start_strain=H.start_point[0],
                       H_start_stress=H.start_point[1])
        elif "H_error" in result.extra:
            out["H_error"] = result.extra["H_error"]
    else:                                                     # the deposits
        out.update(at_rest=bool(result.at_rest), weight=result.weight,
                   n_sand=result.params.get("n_sand"), n_beads=result.params.get("n_beads"))
        if hasattr(result, "max_slope_deg"):                  # slope deposit
            out.update(max_slope_deg=result.max_slope_deg, floor_force=result.floor_force,
                       lost_particles=result.params.get("lost_particles"))
        else:                                                 # deposit under gravity
            out.update(settlement=result.settlement, wall_force=result.wall_force,
                       slack_share=result.slack_share)
        if result.wire_before is not None:
            out.update(tortuosity_before=result.wire_before.tortuosity,
                       tortuosity_after=result.wire_after.tortuosity)
    return out


def _history_path(params, fixed, default_name):
    d = fixed.get("history_dir") or os.path.join("out", "sweep")
    os.makedirs(d, exist_ok=True)
    return os.path.join(d, f"{case_id(default_name, params)}.h5")


def _paper_test(name):
    def experiment(*, wire="elastic", k=None, prestrain=None, max_tension=None,
                   history_dir=None, **params):
        from . import experiments

        fn = getattr(experiments, name)
        has_wire, law = _law(wire, k, prestrain, max_tension)
        kw = dict(params)
        kw["wire"] = has_wire
        if params.get("sample") is not None and wire == "elastic" and k is None \
                and prestrain is None and max_tension is None:
            law = None                 # a start state's wire keeps its own law
        if has_wire and law is not None:
            kw["wire_law"] = law
        key_params = dict(params, wire=wire, k=k)     # (ids of earlier tables kept:)
        key_params.update({n: v for n, v in (("prestrain", prestrain),
                                             ("max_tension", max_tension)) if v is not None})
        kw.setdefault("history", _history_path(key_params, {"history_dir": history_dir}, name))
        kw.setdefault("progress", False)
        if "resume" in inspect.signature(fn).parameters:
            # the deposits: a case stopped or killed goes on from its last checkpoint (on a
            # Dask worker, which cannot catch Ctrl-C, the periodic one)
            kw.setdefault("resume", True)
            kw.setdefault("checkpoint_every", 60)
        return scalars_of(not_interrupted(fn(**kw), name, params))

    experiment.__name__ = experiment.__qualname__ = name
    return experiment


def _check_paper_cases(name, cases, fixed) -> None:
    """Refuse, before anything runs, a case of a paper test with a parameter the test does
    not take, a wire it cannot build, a bad scale or solver options out of range (naming
    the case, the field and the allowed values): such a case would fail the same way on
    every attempt."""
    import inspect

    from . import experiments
    from .experiments.common import check_scale
    from .experiments.params import check_args

    sig = inspect.signature(getattr(experiments, name)).parameters
    allowed = (set(sig) - {"wire_law"}) | {"k", "prestrain", "max_tension", "history_dir"}
    for c in cases:
        params = dict(fixed, **c)
        bad = sorted(set(params) - allowed)
        if bad:
            raise ValueError(f"{name} takes no parameter {', '.join(map(repr, bad))}; its "
                             f"parameters are {', '.join(sorted(allowed))}")
        try:
            _law(params.get("wire", "elastic"), params.get("k"), params.get("prestrain"),
                 params.get("max_tension"))
            check_scale(params.get("scale", sig["scale"].default))
            check_args(name, {n: params.get(n, p.default) for n, p in sig.items()
                              if n != "wire"})          # (the sweep's wire is a law's name)
        except ValueError as e:
            raise ValueError(f"{name}, case {c}: {str(e).removeprefix(name + ': ')}") from None


#: The paper's tests by name, as sweep experiments (JSON-able parameters in, scalars out).
EXPERIMENTS: dict[str, Callable] = {n: _paper_test(n) for n in
                                    ("cylinder_triaxial", "box_triaxial", "slope_deposit",
                                     "gravity_deposit")}


def _resolve(experiment) -> Callable:
    if isinstance(experiment, str):
        try:
            return EXPERIMENTS[experiment]
        except KeyError:
            raise ValueError(f"unknown experiment {experiment!r}; known: "
                             f"{', '.join(EXPERIMENTS)} (or pass a function)") from None
    if not callable(experiment):
        raise ValueError(f"experiment must be a callable or a name, got {experiment!r}")
    return experiment


# ------------------------------------------------------------------ one case

def _scalar(v):
    if isinstance(v, np.generic):
        v = v.item()
    if v is None or isinstance(v, (bool, int, str)):
        return v, True
    if isinstance(v, float):
        return (v if math.isfinite(v) else None), True
    return None, False


#: Seconds between two progress events of one case sent by a worker.
REPORT_EVERY = 5.0


#: The Dask event topic of the running cases' reports (one for every sweep: the scheduler
#: keeps a bounded log per topic, and topics are never removed).
TOPIC = "nscd-sweep-progress"
_LISTENERS = {}                     # sweep id -> on_stage(case id, desc, done, total)


def _dispatch(event):
    """Client side: hand a worker's report (``(timestamp, msg)``) to its sweep."""
    msg = event[1]
    fn = _LISTENERS.get(msg.get("sweep")) if isinstance(msg, dict) else None
    if fn is not None:
        fn(msg["id"], msg["desc"], msg["done"], msg["total"])


def _reporter(report):
    """The ``fn(desc, done, total)`` a case's stages call (:func:`report_stages_to`):
    ``report`` a callable (serial runs) or ``(sweep id, case id)``, sent as a Dask event
    (:data:`TOPIC`) by the worker running the case at most every :data:`REPORT_EVERY`
    seconds."""
    if report is None or callable(report):
        return report
    sweep_id, label = report
    try:
        from distributed import get_worker
        worker = get_worker()
    except (ImportError, ValueError):                  # not on a Dask worker
        return None
    last = [-math.inf]

    def send(desc, done, total):
        now = time.monotonic()
        if now - last[0] >= REPORT_EVERY:
            last[0] = now
            worker.log_event(TOPIC, dict(sweep=sweep_id, id=label, desc=str(desc),
                                         done=int(done), total=int(total)))
    return send


class CaseInterrupted(KeyboardInterrupt):
    """A case's run was stopped by Ctrl-C / SIGTERM: it is not a result (its steps were
    not all run) nor a failure to retry; the sweep stops, keeps the cases finished, and
    runs this one again when it is run again."""


def not_interrupted(result, name: str, params: dict):
    """``result`` (an experiment's), or :class:`CaseInterrupted` when Ctrl-C / SIGTERM stopped
    its run: what a sweep's experiment wrapper checks before turning a result into table
    values, so a partial run is never recorded as done."""
    c = getattr(result, "convergence", None) or {}
    if c.get("interrupted"):
        raise CaseInterrupted(f"{name} {json.dumps(params, default=str)}: interrupted after "
                              f"{c.get('steps', 0)} steps (history "
                              f"{getattr(result, 'history', None)})")
    return result


def run_case(experiment, params: dict, fixed: dict | None = None, report=None) -> dict:
    """Run one case and return ``{"result", "elapsed", "worker"}``; what runs on a worker.
    Exceptions propagate (the caller records them).  ``report``: where the case's stages
    report their steps (see :func:`_reporter`; None: nowhere).  Raises
    :class:`CaseInterrupted` when the run was stopped by Ctrl-C / SIGTERM."""
    from .experiments.common import report_stages_to

    fn = _resolve(experiment)
    t0 = time.perf_counter()
    with report_stages_to(_reporter(report)):
        res = fn(**params, **(fixed or {}))
    elapsed = time.perf_counter() - t0
    if hasattr(res, "convergence") and not isinstance(res, Mapping):
        res = scalars_of(not_interrupted(res, _experiment_name(experiment), params))
    if not isinstance(res, Mapping):
        raise TypeError(f"experiment {_experiment_name(experiment)} returned {type(res).__name__}, "
                        f"not a mapping of results")
    return {"result": _result_row(res), "elapsed": elapsed,
            "worker": f"{socket.gethostname()}:{os.getpid()}"}


def _result_row(res: Mapping) -> dict:
    """A case's results as the table stores them: the scalars (non-finite floats as None),
    and the names of the values that are not scalars in ``_dropped``."""
    table, dropped = {}, []
    for k, v in res.items():
        s, ok = _scalar(v)
        if ok:
            table[str(k)] = s
        else:
            dropped.append(str(k))
    if dropped:
        table["_dropped"] = ",".join(dropped)
    return table


# ------------------------------------------------------------------ the table

@dataclass
class SweepTable:
    """Rows of a sweep, one per case, and where they are stored.

    Each row: ``key`` (see :func:`case_key`), ``id``, ``experiment``, ``params``,
    ``status`` ("done" or "failed"), ``attempts``, ``errors`` (one message per failed
    attempt), ``result`` (scalars), ``elapsed`` [s] of the successful attempt, ``worker``,
    ``skipped`` (True when taken from an earlier run).
    """

    rows: list = field(default_factory=list)
    path: str | None = None
    wall_time: float = 0.0

    @property
    def done(self) -> list:
        return [r for r in self.rows if r["status"] == "done"]

    @property
    def failed(self) -> list:
        return [r for r in self.rows if r["status"] == "failed"]

    def find(self, **params) -> dict | None:
        """The row whose parameters include ``params`` (the first one), or None."""
        for r in self.rows:
            if all(r["params"].get(k) == v for k, v in params.items()):
                return r
        return None

    def column(self, name: str) -> np.ndarray:
        """One result (or parameter) across the rows, NaN where missing or not numeric."""
        out = []
        for r in self.rows:
            v = (r.get("result") or {}).get(name, r["params"].get(name))
            out.append(float(v) if isinstance(v, (int, float)) else float("nan"))
        return np.asarray(out)

    def __str__(self):
        return (f"sweep: {len(self.rows)} cases, {len(self.done)} done "
                f"({sum(1 for r in self.done if r.get('skipped'))} skipped as finished), "
                f"{len(self.failed)} failed; {self.wall_time:.1f} s; table {self.path}")


def load_table(path) -> SweepTable:
    """Read a sweep's JSON table (an empty table when the file does not exist)."""
    p = Path(path)
    if not p.exists():
        return SweepTable(path=str(p))
    with open(p) as f:
        data = json.load(f)
    if not isinstance(data, dict) or "cases" not in data:
        raise ValueError(f"{p}: not a sweep table (no 'cases')")
    if int(data.get("version", 0)) > TABLE_VERSION:
        raise ValueError(f"{p}: sweep table version {data['version']} is newer than this "
                         f"code's {TABLE_VERSION}")
    return SweepTable(rows=list(data["cases"]), path=str(p))


def _write_json(table: SweepTable, path: Path, meta: dict):
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w") as f:
        json.dump({"version": TABLE_VERSION, **meta, "cases": table.rows}, f, indent=1,
                  sort_keys=False, allow_nan=False)
    os.replace(tmp, path)                      # atomic: a crash leaves the old table


def update_results(path, results: Mapping[str, dict]) -> SweepTable:
    """Replace the ``result`` scalars of the table's done rows named in ``results`` (case id
    -> scalars), as a sweep stores them (non-finite floats as None), and write the table
    back atomically; for results recomputed after the run (a study rescoring its cases from
    their histories) that must outlive the histories."""
    table = load_table(path)
    if not table.rows:
        raise ValueError(f"{path}: no sweep table there")
    for row in table.done:
        if row["id"] in results:
            row["result"] = _result_row(results[row["id"]])
    _write_json(table, Path(path), dict(experiment=table.rows[0]["experiment"]))
    return table


def write_hdf5(table: SweepTable, path) -> Path:
    """The table as HDF5: one dataset per parameter and per numeric result (NaN where
    missing), ``status``, ``attempts``, ``elapsed`` [s], ``id`` and ``error`` as strings."""
    import h5py

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = table.rows
    tmp = path.with_name(path.name + ".tmp")
    with h5py.File(tmp, "w") as f:
        f.attrs["content"] = "sweep"
        f.attrs["format_version"] = TABLE_VERSION
        f.attrs["n_cases"] = len(rows)
        str_dt = h5py.string_dtype()
        f.create_dataset("id", data=np.array([r["id"] for r in rows], dtype=object), dtype=str_dt)
        f.create_dataset("status", data=np.array([r["status"] for r in rows], dtype=object),
                         dtype=str_dt)
        f.create_dataset("error", data=np.array([(r["errors"] or [""])[-1] for r in rows],
                                                dtype=object), dtype=str_dt)
        f.create_dataset("attempts", data=np.array([r["attempts"] for r in rows], dtype=np.int64))
        el = f.create_dataset("elapsed", data=np.array(
            [r.get("elapsed") if r.get("elapsed") is not None else np.nan for r in rows], float))
        el.attrs["unit"] = "s"
        for group, src in (("params", "params"), ("results", "result")):
            g = f.create_group(group)
            names = sorted({k for r in rows for k in (r.get(src) or {})})
            for k in names:
                vals = [(r.get(src) or {}).get(k) for r in rows]
                if all(v is None or isinstance(v, (int, float, bool)) for v in vals):
                    g.create_dataset(k, data=np.array([np.nan if v is None else float(v)
                                                       for v in vals]))
                else:
                    g.create_dataset(k, data=np.array(["" if v is None else json.dumps(v)
                                                       if not isinstance(v, str) else v
                                                       for v in vals], dtype=object),
                                     dtype=str_dt)
    os.replace(tmp, path)
    return path


# ------------------------------------------------------------------ the cluster

def local_client(n_workers: int = 2, *, threads_per_worker: int = 1, **kwargs):
    """A ``dask.distributed.Client`` on a new ``LocalCluster`` of ``n_workers`` processes
    (one thread each: the engine's kernels are serial, one simulation per core), the
    dashboard on a free port (``client.dashboard_link``).  The caller closes it
    (``client.close(); client.cluster.close()``)."""
    import logging

    from distributed import Client, LocalCluster

    kw = dict(n_workers=n_workers, threads_per_worker=threads_per_worker, processes=True,
              dashboard_address=":0", silence_logs=logging.ERROR)     # any free port
    kw.update(kwargs)
    cluster = LocalCluster(**kw)
    client = Client(cluster)
    client.register_plugin(_ignore_ctrl_c_plugin(), name="nscd-ignore-ctrl-c")
    return client


def _ignore_ctrl_c_plugin():
    """A worker plugin: the workers of a LocalCluster ignore SIGINT.  Ctrl-C in a terminal
    reaches every process of its group; the sweep's own process stops the sweep (it keeps
    the finished cases) and closes the cluster, while workers killed by it mid-case made
    their nannies print tracebacks.  (``setup`` runs in the worker's main thread.)"""
    from distributed.diagnostics.plugin import WorkerPlugin

    class IgnoreCtrlC(WorkerPlugin):
        def setup(self, worker):
            import signal
            import threading

            if threading.current_thread() is threading.main_thread():   # processes=True
                signal.signal(signal.SIGINT, signal.SIG_IGN)

    return IgnoreCtrlC()


def _error_text(exc, tb_text=None) -> str:
    msg = f"{type(exc).__name__}: {exc}"
    if tb_text:
        tail = [ln for ln in tb_text.strip().splitlines() if ln.strip()][-6:]
        msg += "\n" + "\n".join(tail)
    return msg


# ------------------------------------------------------------------ the sweep

def sweep(experiment, grid, client=None, *, out="out/sweep.json", retries: int = 1,
          fixed: dict | None = None, n_workers: int = 2, hdf5: bool = True,
          progress: bool = True, no_worker_timeout: float = 300.0) -> SweepTable:
    """Run every case of ``grid`` (see :func:`expand_grid`) as an independent simulation and
    gather the scalar results into one table.

    Parameters
    ----------
    experiment : callable or str
        ``experiment(**params, **fixed) -> mapping`` (a module-level function, so workers
        can import it), or a name of :data:`EXPERIMENTS`.
    grid : mapping of lists (Cartesian product) or list of mappings (explicit cases)
        The parameters of the cases, JSON-able; they key the table.
    client : None, "serial", a ``dask.distributed.Client`` or a scheduler address (str)
        None: a new ``LocalCluster`` of ``n_workers`` processes, closed at the end;
        "serial": the cases one by one in this process, no Dask.
    out : path of the JSON table [.json]; the HDF5 table is written next to it
        (same stem, ``.h5``) when ``hdf5``.  Cases already "done" in it are skipped.
    retries : int
        How many times a failed case is submitted again (1: it runs at most twice).
    fixed : dict, optional
        Keyword arguments given to every case but not part of its key (output folders,
        ``progress=False`` ...).
    progress : bool
        One line per finished or failed case on stdout, and a tqdm bar of the finished
        cases whose text names each running case's stage and steps (reported by the
        workers every :data:`REPORT_EVERY` s as Dask events).
    no_worker_timeout : float [s]
        When the cluster has had no worker for this long (all killed or crashed), the
        cases still pending fail ("NoWorkers") instead of waiting forever.

    Returns
    -------
    SweepTable
        Every case of the grid in grid order (finished earlier ones marked ``skipped``),
        also written to ``out``.  A failed case does not raise: it is in ``table.failed``.
    """
    if int(retries) < 0:
        raise ValueError(f"retries must be >= 0, got {retries!r}")
    if client is None and not (isinstance(n_workers, int) and 1 <= n_workers <= 1024):
        # (a cluster of no worker would only fail its cases after no_worker_timeout)
        raise ValueError(f"n_workers (--workers) must be an integer in [1, 1024], "
                         f"got {n_workers!r}")
    fn = _resolve(experiment)
    name = _experiment_name(experiment)
    cases = expand_grid(grid)
    fixed = dict(fixed or {})
    if isinstance(experiment, str):
        _check_paper_cases(name, cases, fixed)
    out = Path(out)
    if out.suffix != ".json":
        out = out.with_suffix(".json")
    old = load_table(out)
    by_key = {r["key"]: r for r in old.rows}
    rows, todo = [], []
    for p in cases:
        key = case_key(name, p)
        prev = by_key.get(key)
        if prev is not None and prev.get("status") == "done":
            prev = dict(prev, skipped=True)
            rows.append(prev)
        else:
            row = dict(key=key, id=case_id(name, p), experiment=name, params=p, status="pending",
                       attempts=0, errors=[], result={}, elapsed=None, worker=None,
                       skipped=False)
            rows.append(row)
            todo.append(row)
    # rows of other grids already in the file are kept (one file may hold several sweeps)
    keys = {r["key"] for r in rows}
    others = [r for r in old.rows if r["key"] not in keys]
    table = SweepTable(rows=rows, path=str(out))
    meta = dict(experiment=name)
    t0 = time.perf_counter()

    bar = None
    running = {}                                     # case id -> (desc, done, total)

    def say(msg):
        if bar is not None:
            bar.write(msg)
        elif progress:
            print(msg, flush=True)

    def on_stage(label, desc, done, total):
        running[label] = (desc, done, total)

    shown = [-math.inf]

    def show():
        # the text changes with every report; redraw at the bar's own rate (once a minute
        # in a log file), not at the reports'
        if bar is not None:
            bar.set_postfix_str("; ".join(f"{k} {d} {n}/{t}" for k, (d, n, t)
                                          in list(running.items())), refresh=False)
            if time.monotonic() - shown[0] >= bar.mininterval:
                shown[0] = time.monotonic()
                bar.refresh()

    n_total = len(rows)
    say(f"sweep {name}: {n_total} cases, {n_total - len(todo)} already done, "
        f"{len(todo)} to run -> {out}")
    if progress and todo:
        import sys

        from tqdm.auto import tqdm
        bar = tqdm(total=len(todo), unit="case", desc="sweep", dynamic_ncols=True,
                   mininterval=0.5 if sys.stderr.isatty() else 60.0)

    def save():
        full = SweepTable(rows=others + rows, path=str(out))
        _write_json(full, out, meta)

    def finished(row, payload):
        row.update(status="done", result=payload["result"], elapsed=payload["elapsed"],
                   worker=payload["worker"])
        save()
        running.pop(row["id"], None)
        say(f"  done   {row['id']} {json.dumps(row['params'])} in {row['elapsed']:.1f} s "
            f"(attempt {row['attempts']})")
        if bar is not None:
            bar.update(1)
            show()

    def failed(row, msg, final=None):
        row["errors"].append(msg)
        running.pop(row["id"], None)
        final = row["attempts"] > retries if final is None else final
        if final:
            row["status"] = "failed"
            save()
            if bar is not None:
                bar.update(1)
        say(f"  {'FAILED' if final else 'failed'} {row['id']} {json.dumps(row['params'])} "
            f"(attempt {row['attempts']}{'' if final else ', retrying'}): "
            f"{msg.splitlines()[0]}")
        return not final

    try:
        _run_todo(fn, todo, client, fixed, n_workers, finished, failed, on_stage, show,
                  bar is not None, no_worker_timeout)
    except KeyboardInterrupt:
        # Ctrl-C / SIGTERM: the finished cases are in the table already; the others stay
        # pending (not failed), so running the sweep again runs them
        if bar is not None:
            bar.close()
            bar = None
        save()
        if hdf5:
            write_hdf5(SweepTable(rows=others + rows), out.with_suffix(".h5"))
        n_done = sum(r["status"] == "done" for r in rows)
        say(f"sweep {name}: interrupted; {n_done} of {n_total} cases done in {out}, the "
            f"{sum(r['status'] == 'pending' for r in rows)} pending run when it is run again")
        raise
    finally:
        if bar is not None:
            bar.close()
            bar = None
    table.wall_time = time.perf_counter() - t0
    save()
    if hdf5:
        write_hdf5(SweepTable(rows=others + rows), out.with_suffix(".h5"))
    say(str(table))
    return table


def _run_todo(fn, todo, client, fixed, n_workers, finished, failed, on_stage, show, follow,
              no_worker_timeout):
    """Run the cases of ``todo``, serially or on Dask; ``follow``: pass their stage
    reports to ``on_stage``."""
    if todo:
        if isinstance(client, str) and client == "serial":
            for row in todo:
                while True:
                    row["attempts"] += 1
                    def report(desc, done, total, label=row["id"]):
                        on_stage(label, desc, done, total)
                        show()
                    try:
                        payload = run_case(fn, row["params"], fixed,
                                           report=report if follow else None)
                    except Exception as e:  # noqa: BLE001 - a case's failure is data
                        if failed(row, _error_text(e, traceback.format_exc())):
                            continue
                    else:
                        finished(row, payload)
                    break
        else:
            _run_dask(fn, todo, client, fixed, n_workers, finished, failed,
                      no_worker_timeout=no_worker_timeout,
                      on_stage=on_stage if follow else None, show=show)


def _run_dask(fn, todo, client, fixed, n_workers, finished, failed, *, poll=5.0,
              no_worker_timeout=300.0, on_stage=None, show=lambda: None):
    from distributed import Client, wait
    try:
        from dask.distributed import TimeoutError as _DistTimeout
    except ImportError:  # pragma: no cover
        _DistTimeout = TimeoutError

    own = None
    if client is None:
        client = own = local_client(n_workers)
    elif isinstance(client, str):
        client = own = Client(client)
    sweep_id = None
    futures = {}
    try:
        if on_stage is not None:            # the workers' stage reports, as Dask events
            sweep_id = uuid.uuid4().hex[:12]
            _LISTENERS[sweep_id] = on_stage
            client.subscribe_topic(TOPIC, _dispatch)

        def submit(row):
            row["attempts"] += 1
            # pure=False: a retry is a new task, never the cached failed one
            return client.submit(run_case, fn, row["params"], fixed,
                                 None if sweep_id is None else (sweep_id, row["id"]),
                                 pure=False,
                                 key=f"{row['id']}-a{row['attempts']}")

        futures = {submit(row): row for row in todo}
        no_workers_since = None
        while futures:
            try:
                done = wait(list(futures), timeout=poll, return_when="FIRST_COMPLETED").done
            except (TimeoutError, _DistTimeout):
                done = set()
            show()
            if not done:
                # a cluster whose workers are all gone (killed, crashed) would wait forever:
                # after no_worker_timeout seconds without a worker the pending cases fail
                if not client.scheduler_info().get("workers"):
                    no_workers_since = no_workers_since or time.monotonic()
                    if time.monotonic() - no_workers_since > no_worker_timeout:
                        for fut, row in list(futures.items()):
                            failed(row, f"NoWorkers: the cluster had no worker for "
                                        f"{no_worker_timeout:.0f} s", final=True)
                            fut.release()
                        futures.clear()
                else:
                    no_workers_since = None
                continue
            for fut in done:
                row = futures.pop(fut)
                try:
                    payload = fut.result()
                except Exception as e:  # noqa: BLE001 - includes KilledWorker (a crashed case)
                    tb = fut.traceback()
                    tb_text = "".join(traceback.format_tb(tb)) if tb is not None else None
                    if failed(row, _error_text(e, tb_text)):
                        futures[submit(row)] = row
                else:
                    finished(row, payload)
                fut.release()
    except KeyboardInterrupt:
        # Ctrl-C: the cases running on a cluster not ours would go on without anyone to
        # gather them (our own LocalCluster is closed below)
        if getattr(own, "cluster", None) is None and futures:
            try:
                client.cancel(list(futures))
            except Exception:  # noqa: BLE001 - the interrupt matters, not the cancel
                pass
        raise
    finally:
        if sweep_id is not None:
            _LISTENERS.pop(sweep_id, None)
            if not _LISTENERS:
                try:
                    client.unsubscribe_topic(TOPIC)
                except Exception:  # noqa: BLE001 - a closed client has nothing to undo
                    pass
        if own is not None:
            cluster = getattr(own, "cluster", None)
            own.close()
            if cluster is not None:
                cluster.close()
