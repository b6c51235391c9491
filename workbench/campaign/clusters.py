"""Where a campaign's cases run: a Dask cluster chosen by name and options.

* ``"local"`` (the default): a ``distributed.LocalCluster`` of worker processes on this
  machine, one thread each (the engine's kernels are serial: one simulation per core);
* a batch system through `dask-jobqueue <https://jobqueue.dask.org>`_: ``"slurm"``,
  ``"pbs"``, ``"sge"``, ``"lsf"``, ``"moab"``, ``"oar"``, ``"htcondor"``, each job a worker
  script submitted to the queue (``cluster_options``: ``cores``, ``memory``, ``walltime``,
  ``queue``, ``account``, ``job_script_prologue`` ... as in dask-jobqueue's classes, or
  its ``~/.config/dask/jobqueue.yaml``);
* ``"jobqueue-local"``: dask-jobqueue's local job cluster, which runs the same job scripts as
  processes of this machine (how the batch path is tested without a batch system).

:class:`ClusterSpec` holds a name, its options and the number of workers; a sweep starts the
cluster when it needs it and closes it at the end.  A sweep also takes a scheduler's
address, a ``distributed.Client`` or a cluster object the caller made and closes.
"""
from __future__ import annotations

import importlib
import logging
from dataclasses import dataclass, field
from typing import Mapping

__all__ = ["ClusterSpec", "CLUSTERS", "local_client", "cluster_spec"]

#: The clusters a campaign starts by name: the class that makes each (module, name).
CLUSTERS: Mapping[str, tuple[str, str]] = {
    "local": ("distributed", "LocalCluster"),
    "slurm": ("dask_jobqueue", "SLURMCluster"),
    "pbs": ("dask_jobqueue", "PBSCluster"),
    "sge": ("dask_jobqueue", "SGECluster"),
    "lsf": ("dask_jobqueue", "LSFCluster"),
    "moab": ("dask_jobqueue", "MoabCluster"),
    "oar": ("dask_jobqueue", "OARCluster"),
    "htcondor": ("dask_jobqueue", "HTCondorCluster"),
    "jobqueue-local": ("dask_jobqueue.local", "LocalCluster"),
}

#: Seconds a sweep waits without any worker before it fails the cases left ("NoWorkers"):
#: on a local cluster or a scheduler, and on a batch cluster, where jobs wait in the queue.
NO_WORKER_TIMEOUT = {"local": 300.0, "batch": 3600.0}


@dataclass(frozen=True)
class ClusterSpec:
    """A cluster to start by name (:data:`CLUSTERS`), with the options of its class and the
    number of workers to scale it to.

    On a batch cluster (dask-jobqueue) each job runs ``processes`` workers; when the options
    give ``cores`` but not ``processes``, ``processes = cores`` (one thread per worker, as
    on the local cluster).  ``ClusterSpec("slurm", {"cores": 2, "memory": "4GB",
    "walltime": "01:00:00", "queue": "normal"}, n_workers=8)``: 4 jobs of 2 workers.
    """

    name: str = "local"
    options: Mapping = field(default_factory=dict)
    n_workers: int = 2

    def __post_init__(self):
        if self.name not in CLUSTERS:
            raise ValueError(f"cluster must be one of {', '.join(map(repr, CLUSTERS))}, "
                             f"got {self.name!r}")
        if not isinstance(self.options, Mapping):
            raise ValueError(f"cluster_options must be a mapping of option names to values, "
                             f"got {self.options!r}")
        if isinstance(self.n_workers, bool) or not isinstance(self.n_workers, int) \
                or not 1 <= self.n_workers <= 1024:
            # (a cluster of no worker would only fail its cases after no_worker_timeout)
            raise ValueError(f"n_workers (--workers) must be an integer in [1, 1024], "
                             f"got {self.n_workers!r}")
        object.__setattr__(self, "options", dict(self.options))

    @property
    def batch(self) -> bool:
        """True for a dask-jobqueue cluster (workers are jobs, which may wait in a queue)."""
        return CLUSTERS[self.name][0].startswith("dask_jobqueue")

    def __str__(self):
        opts = ", ".join(f"{k}={v}" for k, v in self.options.items())
        return (f"{'LocalCluster' if self.name == 'local' else self.name + ' cluster'}, "
                f"{self.n_workers} workers" + (f" ({opts})" if opts else ""))

    def make(self):
        """The cluster, started and scaled to :attr:`n_workers` (the caller closes it)."""
        module, cls = CLUSTERS[self.name]
        try:
            make = getattr(importlib.import_module(module), cls)
        except ImportError:
            raise ValueError(f"cluster {self.name!r} needs the package dask-jobqueue "
                             f"(pip install dask-jobqueue)") from None
        if self.name == "local":
            _known_to_local(self.options)
        cluster = _started(make, self.keywords(), self.name)
        if self.batch:
            cluster.scale(self.n_workers)       # n_workers workers: that many / processes jobs
        return cluster

    def keywords(self) -> dict:
        """The keyword arguments the cluster's class gets: the options, over the defaults
        (a LocalCluster: ``n_workers`` processes of one thread, the dashboard on a free
        port; a batch cluster: ``processes = cores`` when not given, the dashboard on a
        free port)."""
        if self.name == "local":
            kw = dict(n_workers=self.n_workers, threads_per_worker=1, processes=True,
                      dashboard_address=":0", silence_logs=logging.ERROR)   # any free port
            kw.update(self.options)
            return kw
        kw = dict(self.options)
        if "cores" in kw and "processes" not in kw:
            kw["processes"] = kw["cores"]
        kw.setdefault("scheduler_options", {"dashboard_address": ":0"})
        return kw

    def client(self):
        """A ``distributed.Client`` on a new cluster of this spec, its workers ignoring
        Ctrl-C; the caller closes both (``client.close(); client.cluster.close()``)."""
        from distributed import Client

        cluster = self.make()
        try:
            client = Client(cluster)
            client.register_plugin(_ignore_ctrl_c_plugin(), name="nscd-ignore-ctrl-c")
        except BaseException:
            cluster.close()
            raise
        return client


def _known_to_local(options) -> None:
    """Refuse an option that neither LocalCluster nor its nannies and workers take (one
    was passed on to every nanny, which failed to start with a traceback each)."""
    import inspect

    from distributed import LocalCluster, Nanny, Worker

    names = set()
    for cls in (LocalCluster, Nanny, Worker):
        names |= {p.name for p in inspect.signature(cls.__init__).parameters.values()
                  if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)} - {"self"}
    bad = sorted(set(options) - names)
    if bad:
        raise ValueError(f"cluster_options (--cluster-option) {', '.join(bad)}: not an option "
                         f"of the local cluster (distributed.LocalCluster, its nannies and "
                         f"workers; e.g. memory_limit, threads_per_worker)")


def _started(make, kw, name):
    try:
        return make(**kw)
    except (TypeError, ValueError) as e:   # an unknown option, a missing cores / memory
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ValueError(f"cluster_options of the {name!r} cluster: {msg}") from None


def cluster_spec(cluster="local", cluster_options: Mapping | None = None,
                 n_workers: int = 2) -> ClusterSpec:
    """:class:`ClusterSpec` of a name and options (``cluster_options`` None: none)."""
    return ClusterSpec(cluster, dict(cluster_options or {}), n_workers)


def local_client(n_workers: int = 2, *, threads_per_worker: int = 1, **kwargs):
    """A ``dask.distributed.Client`` on a new ``LocalCluster`` of ``n_workers`` processes
    (one thread each: the engine's kernels are serial, one simulation per core), the
    dashboard on a free port (``client.dashboard_link``).  The caller closes it
    (``client.close(); client.cluster.close()``)."""
    from distributed import Client, LocalCluster

    kw = dict(n_workers=n_workers, threads_per_worker=threads_per_worker, processes=True,
              dashboard_address=":0", silence_logs=logging.ERROR)     # any free port
    kw.update(kwargs)
    cluster = LocalCluster(**kw)
    client = Client(cluster)
    client.register_plugin(_ignore_ctrl_c_plugin(), name="nscd-ignore-ctrl-c")
    return client


def _ignore_ctrl_c_plugin():
    """A worker plugin: the workers of a cluster started here ignore SIGINT.  Ctrl-C in a
    terminal reaches every process of its group; the sweep's own process stops the sweep
    (it keeps the finished cases) and closes the cluster, while workers killed by it
    mid-case made their nannies print tracebacks.  (``setup`` runs in the worker's main
    thread.)"""
    from distributed.diagnostics.plugin import WorkerPlugin

    class IgnoreCtrlC(WorkerPlugin):
        def setup(self, worker):
            import signal
            import threading

            if threading.current_thread() is threading.main_thread():   # processes=True
                signal.signal(signal.SIGINT, signal.SIG_IGN)

    return IgnoreCtrlC()
