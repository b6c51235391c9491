"""The runner: every case of a grid as an independent simulation, serially or on Dask,
gathered into one table (:mod:`workbench.campaign.table`).

On Dask each case is one task, ``client.submit(run_case, ..., retries=n, pure=False,
key=...)``: the scheduler runs a failed case again (Dask's own retries) while the others go
on, and :class:`distributed.as_completed` hands each finished case to the table.  The
workers report each case's stages and each failed attempt to the client as Dask events
(:data:`TOPIC`): the table lists every failed attempt's error and counts the attempts.
"""
from __future__ import annotations

import collections
import json
import math
import os
import socket
import time
import traceback
import uuid
from pathlib import Path
from typing import Mapping

from .cases import case_id, case_key, expand_grid, experiment_name
from .clusters import NO_WORKER_TIMEOUT, ClusterSpec, cluster_spec
from .experiments import check_paper_cases, not_interrupted, resolve
from .table import SweepTable, load_table, result_row, write_hdf5, write_json

__all__ = ["sweep", "run_case", "REPORT_EVERY", "TOPIC"]

#: Seconds between two progress events of one case sent by a worker.
REPORT_EVERY = 5.0

#: The Dask event topic of the running cases' reports and failed attempts (one for every
#: sweep: the scheduler keeps a bounded log per topic, and topics are never removed).
TOPIC = "nscd-sweep-progress"
_LISTENERS = {}                     # sweep id -> where its reports go, fn(msg)


def _dispatch(event):
    """Client side: hand a worker's report (``(timestamp, msg)``) to its sweep."""
    msg = event[1]
    fn = _LISTENERS.get(msg.get("sweep")) if isinstance(msg, dict) else None
    if fn is not None:
        fn(msg)


def _worker():
    try:
        from distributed import get_worker
        return get_worker()
    except (ImportError, ValueError):                  # not on a Dask worker
        return None


def _reporter(report):
    """The ``fn(desc, done, total)`` a case's stages call (:func:`report_stages_to`):
    ``report`` a callable (serial runs) or ``(sweep id, case id)``, sent as a Dask event
    (:data:`TOPIC`) by the worker running the case at most every :data:`REPORT_EVERY`
    seconds."""
    if report is None or callable(report):
        return report
    sweep_id, label = report
    worker = _worker()
    if worker is None:
        return None
    last = [-math.inf]

    def send(desc, done, total):
        now = time.monotonic()
        if now - last[0] >= REPORT_EVERY:
            last[0] = now
            worker.log_event(TOPIC, dict(sweep=sweep_id, id=label, kind="stage",
                                         desc=str(desc), done=int(done), total=int(total)))
    return send


def _error_text(exc, tb_text=None) -> str:
    msg = f"{type(exc).__name__}: {exc}"
    if tb_text:
        tail = [ln for ln in tb_text.strip().splitlines() if ln.strip()][-6:]
        msg += "\n" + "\n".join(tail)
    return msg


def run_case(experiment, params: dict, fixed: dict | None = None, report=None) -> dict:
    """Run one case and return ``{"result", "elapsed", "worker"}``; what runs on a worker.
    Exceptions propagate (the caller records them; on a Dask worker of a sweep, the
    attempt's error is also sent to the sweep as an event, before Dask runs the case again).
    ``report``: where the case's stages report their steps (see :func:`_reporter`; None:
    nowhere).  Raises :class:`CaseInterrupted` when the run was stopped by Ctrl-C /
    SIGTERM."""
    try:
        return _run_case(experiment, params, fixed, report)
    except Exception as e:
        if isinstance(report, tuple) and (worker := _worker()) is not None:
            worker.log_event(TOPIC, dict(sweep=report[0], id=report[1], kind="failed",
                                         error=_error_text(e, "".join(
                                             traceback.format_tb(e.__traceback__)))))
        raise


def _run_case(experiment, params, fixed, report):
    from engine.experiments.common import report_stages_to

    fn = resolve(experiment)
    t0 = time.perf_counter()
    with report_stages_to(_reporter(report)):
        res = fn(**params, **(fixed or {}))
    elapsed = time.perf_counter() - t0
    if not isinstance(res, Mapping):
        # a run stopped by Ctrl-C is no result; an engine.experiments result's type says
        # which of its values are its scalars
        res = not_interrupted(res, experiment_name(experiment), params)
        if callable(getattr(res, "scalars", None)):
            res = res.scalars()
    if not isinstance(res, Mapping):
        raise TypeError(f"experiment {experiment_name(experiment)} returned "
                        f"{type(res).__name__}, not a mapping of results")
    return {"result": result_row(res), "elapsed": elapsed,
            "worker": f"{socket.gethostname()}:{os.getpid()}"}


# ------------------------------------------------------------------ the sweep

def table_path(out, name: str) -> Path:
    """Where a sweep's JSON table goes for ``out``: inside an existing folder as
    ``sweep_<name>.json``; a path ending in ``.json`` as it is; a path without a suffix with
    ``.json`` added.  Another suffix is refused (ValueError): the table is JSON."""
    out = Path(out)
    if out.is_dir():
        return out / f"sweep_{name}.json"
    if out.suffix == "":
        return out.with_suffix(".json")
    if out.suffix != ".json":
        raise ValueError(f"out = {str(out)!r}: the sweep's table is a JSON file: give a path "
                         f"ending in .json, or a folder to put sweep_{name}.json in")
    return out


def sweep(experiment, grid, client=None, *, out="out/sweep.json", retries: int = 1,
          fixed: dict | None = None, n_workers: int = 2, hdf5: bool = True,
          progress: bool = True, no_worker_timeout: float | None = None,
          cluster: str | None = None, cluster_options: Mapping | None = None) -> SweepTable:
    """Run every case of ``grid`` (see :func:`expand_grid`) as an independent simulation and
    gather the scalar results into one table.

    Parameters
    ----------
    experiment : callable or str
        ``experiment(**params, **fixed) -> mapping`` (a module-level function, so workers
        can import it; or one returning an :mod:`engine.experiments` result, whose
        ``scalars()`` go in the table), or a name of :data:`EXPERIMENTS`.
    grid : mapping of lists (Cartesian product) or list of mappings (explicit cases)
        The parameters of the cases, JSON-able; they key the table.
    client : None, "serial", a scheduler address (str), a ``distributed.Client``, a Dask
        cluster object or a :class:`ClusterSpec`
        None: a new cluster (``cluster``, a LocalCluster by default) of ``n_workers``
        workers, closed at the end; "serial": the cases one by one in this process, no Dask.
        A client or a cluster object given is the caller's to close.
    out : path of the JSON table [.json]; the HDF5 table is written next to it
        (same stem, ``.h5``) when ``hdf5``.  Cases already "done" in it are skipped.
    retries : int
        How many times a failed case is run again (1: it runs at most twice; Dask's
        ``retries`` on a cluster).
    fixed : dict, optional
        Keyword arguments given to every case but not part of its key (output folders,
        ``progress=False`` ...).
    n_workers : int
        Workers of the cluster started here (``client=None``).
    progress : bool
        One line per finished or failed case on stdout, and a tqdm bar of the finished
        cases whose text names each running case's stage and steps (reported by the
        workers every :data:`REPORT_EVERY` s as Dask events).
    no_worker_timeout : float [s], optional
        When the cluster has had no worker for this long (all killed or crashed, or jobs
        that never started), the cases still pending fail ("NoWorkers") instead of waiting
        forever.  None: 300 s, or 3600 s on a batch cluster started here (jobs wait in
        the queue).
    cluster : str, optional
        The cluster to start when ``client`` is None: a name of :data:`CLUSTERS`
        ("local", the default; "slurm", "pbs", "sge", "lsf", "moab", "oar", "htcondor"
        through dask-jobqueue; "jobqueue-local").
    cluster_options : mapping, optional
        Keyword arguments of that cluster's class (a batch cluster: ``cores``, ``memory``,
        ``walltime``, ``queue``, ``account`` ...; see :class:`ClusterSpec`).

    Returns
    -------
    SweepTable
        Every case of the grid in grid order (finished earlier ones marked ``skipped``),
        also written to ``out``.  A failed case does not raise: it is in ``table.failed``.
    """
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise ValueError(f"retries must be an integer >= 0, got {retries!r}")
    if client is None:
        client = cluster_spec(cluster or "local", cluster_options, n_workers)
    elif cluster is not None or cluster_options:
        raise ValueError(f"cluster / cluster_options start a cluster: give them without a "
                         f"client (got client={client!r})")
    fn = resolve(experiment)
    name = experiment_name(experiment)
    cases = expand_grid(grid)
    fixed = dict(fixed or {})
    if isinstance(experiment, str):
        check_paper_cases(name, cases, fixed)
    out = table_path(out, name)
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
    view = _Progress(progress)
    n_total = len(rows)
    view.say(f"sweep {name}: {n_total} cases, {n_total - len(todo)} already done, "
             f"{len(todo)} to run -> {out}")
    view.open(len(todo))

    def save():
        write_json(SweepTable(rows=others + rows, path=str(out)), out, meta)

    def finished(row, payload):
        row.update(status="done", result=payload["result"], elapsed=payload["elapsed"],
                   worker=payload["worker"])
        save()
        view.finished(row)

    def failed(row, msg, final=None):
        row["errors"].append(msg)
        final = row["attempts"] > retries if final is None else final
        if final:
            row["status"] = "failed"
            save()
        view.failed(row, msg, final)
        return not final

    try:
        if todo:
            if isinstance(client, str) and client == "serial":
                _run_serial(fn, todo, fixed, finished, failed, view)
            else:
                _run_dask(fn, todo, client, fixed, n_workers, finished, failed,
                          retries=retries, no_worker_timeout=no_worker_timeout,
                          on_stage=view.on_stage if view.following else None, show=view.show)
    except KeyboardInterrupt:
        # Ctrl-C / SIGTERM: the finished cases are in the table already; the others stay
        # pending (not failed), so running the sweep again runs them
        view.close()
        save()
        if hdf5:
            write_hdf5(SweepTable(rows=others + rows), out.with_suffix(".h5"))
        n_done = sum(r["status"] == "done" for r in rows)
        view.say(f"sweep {name}: interrupted; {n_done} of {n_total} cases done in {out}, the "
                 f"{sum(r['status'] == 'pending' for r in rows)} pending run when it is run "
                 f"again")
        raise
    finally:
        view.close()
    table.wall_time = time.perf_counter() - t0
    save()
    if hdf5:
        write_hdf5(SweepTable(rows=others + rows), out.with_suffix(".h5"))
    view.say(str(table))
    return table


class _Progress:
    """What a sweep shows: one line per finished or failed case, and a tqdm bar of the
    finished cases whose text names each running case's stage and steps."""

    def __init__(self, progress):
        self.progress = progress
        self.bar = None
        self.running = {}                              # case id -> (desc, done, total)
        self.shown = -math.inf

    @property
    def following(self):
        return self.bar is not None

    def open(self, n):
        if self.progress and n:
            import sys

            from tqdm.auto import tqdm
            self.bar = tqdm(total=n, unit="case", desc="sweep", dynamic_ncols=True,
                            mininterval=0.5 if sys.stderr.isatty() else 60.0)

    def close(self):
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def say(self, msg):
        if self.bar is not None:
            self.bar.write(msg)
        elif self.progress:
            print(msg, flush=True)

    def on_stage(self, label, desc, done, total):
        self.running[label] = (desc, done, total)

    def show(self):
        # the text changes with every report; redraw at the bar's own rate (once a minute
        # in a log file), not at the reports'
        if self.bar is not None:
            self.bar.set_postfix_str("; ".join(f"{k} {d} {n}/{t}" for k, (d, n, t)
                                               in list(self.running.items())), refresh=False)
            if time.monotonic() - self.shown >= self.bar.mininterval:
                self.shown = time.monotonic()
                self.bar.refresh()

    def finished(self, row):
        self.running.pop(row["id"], None)
        self.say(f"  done   {row['id']} {json.dumps(row['params'])} in {row['elapsed']:.1f} s "
                 f"(attempt {row['attempts']})")
        if self.bar is not None:
            self.bar.update(1)
            self.show()

    def failed(self, row, msg, final):
        self.running.pop(row["id"], None)
        if final and self.bar is not None:
            self.bar.update(1)
        self.say(f"  {'FAILED' if final else 'failed'} {row['id']} {json.dumps(row['params'])} "
                 f"(attempt {row['attempts']}{'' if final else ', retrying'}): "
                 f"{msg.splitlines()[0]}")


def _run_serial(fn, todo, fixed, finished, failed, view):
    """The cases one by one in this process, each run again until it succeeds or
    ``failed`` says it is final."""
    for row in todo:
        while True:
            row["attempts"] += 1

            def report(desc, done, total, label=row["id"]):
                view.on_stage(label, desc, done, total)
                view.show()

            try:
                payload = run_case(fn, row["params"], fixed,
                                   report=report if view.following else None)
            except Exception as e:  # noqa: BLE001 - a case's failure is data
                if failed(row, _error_text(e, traceback.format_exc())):
                    continue
            else:
                finished(row, payload)
            break


def _connect(client, n_workers):
    """(client, the client if it is ours to close, the cluster if it is ours to close,
    the default no-worker timeout) of what a sweep was given."""
    from distributed import Client

    if client is None:
        client = cluster_spec("local", None, n_workers)
    if isinstance(client, ClusterSpec):
        c = client.client()
        return c, c, c.cluster, NO_WORKER_TIMEOUT["batch" if client.batch else "local"]
    if isinstance(client, str):
        c = Client(client)
        return c, c, None, NO_WORKER_TIMEOUT["local"]
    if isinstance(client, Client):
        return client, None, None, NO_WORKER_TIMEOUT["local"]
    if hasattr(client, "scheduler_address"):           # a cluster object of the caller's
        c = Client(client)
        return c, c, None, NO_WORKER_TIMEOUT["local"]
    raise ValueError(f"client must be None, 'serial', a scheduler address, a "
                     f"distributed.Client, a Dask cluster or a workbench.campaign.ClusterSpec, "
                     f"got {client!r}")


def _run_dask(fn, todo, client, fixed, n_workers, finished, failed, *, retries=1, poll=5.0,
              no_worker_timeout=None, on_stage=None, show=lambda: None):
    """Run the cases of ``todo`` on Dask: one task each, with Dask's ``retries``; every
    failed attempt reported by its worker goes to ``failed(row, msg, final=False)``, the
    last one with ``final=True``; ``on_stage(case id, desc, done, total)`` gets the
    workers' stage reports."""
    from distributed import as_completed

    client, own_client, own_cluster, default_timeout = _connect(client, n_workers)
    if no_worker_timeout is None:
        no_worker_timeout = default_timeout
    sweep_id = uuid.uuid4().hex[:12]
    by_id = {row["id"]: row for row in todo}
    reported = {row["id"]: 0 for row in todo}           # failed attempts reported by events
    last_error = {}                                     # case id -> its last attempt's error
    events = collections.deque()        # the workers' reports, appended by the client's thread
    futures = {}

    def handle_events():
        # in this thread, before the cases finished since: a worker's report of an attempt
        # reaches the client before the attempt's result or error
        while events:
            msg = events.popleft()
            row = by_id.get(msg.get("id"))
            if row is None:
                continue
            if msg.get("kind") == "failed":
                reported[row["id"]] += 1
                row["attempts"] += 1
                if reported[row["id"]] <= retries:      # the last one: when its future errs
                    failed(row, msg["error"], final=False)
                else:
                    last_error[row["id"]] = msg["error"]
            elif on_stage is not None:
                on_stage(msg["id"], msg["desc"], msg["done"], msg["total"])

    try:
        _LISTENERS[sweep_id] = events.append
        client.subscribe_topic(TOPIC, _dispatch)
        for row in todo:
            # pure=False and a key of this sweep: never a cached result nor another
            # sweep's task; Dask runs a failed case again up to `retries` times
            futures[client.submit(run_case, fn, row["params"], fixed, (sweep_id, row["id"]),
                                  retries=retries, pure=False,
                                  key=f"{row['id']}-{sweep_id}")] = row
        ac = as_completed(list(futures))
        no_workers_since, last_poll = None, time.monotonic()
        while futures:
            batch = ac.next_batch(block=False)
            handle_events()
            if not batch:
                time.sleep(0.1)
                if time.monotonic() - last_poll < poll:
                    continue
                last_poll = time.monotonic()
                show()
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
            show()
            for fut in batch:
                row = futures.pop(fut, None)
                if row is None:
                    continue
                if fut.status == "finished":
                    row["attempts"] = reported[row["id"]] + 1
                    finished(row, fut.result())
                else:
                    _failed_last(fut, row, last_error.pop(row["id"], None), failed)
                fut.release()
    except KeyboardInterrupt:
        # Ctrl-C: the cases running on a cluster not ours would go on without anyone to
        # gather them (a cluster of ours is closed below)
        if own_cluster is None and futures:
            try:
                client.cancel(list(futures))
            except Exception:  # noqa: BLE001 - the interrupt matters, not the cancel
                pass
        raise
    finally:
        _LISTENERS.pop(sweep_id, None)
        if not _LISTENERS:
            try:
                client.unsubscribe_topic(TOPIC)
            except Exception:  # noqa: BLE001 - a closed client has nothing to undo
                pass
        if own_client is not None:
            _mute_workers(own_client)
            own_client.close()
        if own_cluster is not None:
            own_cluster.close()


def _mute_workers(client):
    """Before a cluster of ours is closed: its workers stop logging, so that a worker still
    busy with a case (after Ctrl-C) does not print a traceback when its heartbeat finds the
    scheduler gone (seen under load: "Failed to communicate with scheduler during
    heartbeat").  The sweep's own errors reach the table, not these logs."""
    try:
        client.run(_silence_distributed)
    except Exception:  # noqa: BLE001 - a closing cluster may refuse; the close goes on
        pass


def _silence_distributed():
    import logging

    for name in ("distributed", "distributed.worker", "distributed.nanny", "distributed.core",
                 "distributed.comm"):
        logging.getLogger(name).setLevel(logging.CRITICAL)


def _failed_last(fut, row, msg, failed):
    """The last attempt of a case failed: its error ``msg`` as its worker reported it, or,
    when no worker could (None: a worker that died, KilledWorker; a cancelled task), as the
    client sees it."""
    if msg is None:
        try:
            exc = fut.exception()
        except Exception as e:  # noqa: BLE001 - a cancelled future raises here
            exc = e
        tb = fut.traceback() if fut.status == "error" else None
        msg = _error_text(exc, "".join(traceback.format_tb(tb)) if tb is not None else None)
        row["attempts"] += 1
    failed(row, msg, final=True)
