"""Campaigns: many independent simulations run on ``dask.distributed`` and gathered into one
table (DESIGN §7).  The workflow layer above the engine: the engine runs one simulation,
the campaign runs a grid of them.

The unit of work is one whole simulation (a *case*): a call ``experiment(**params,
**fixed)`` returning a mapping of results, or an :mod:`engine.experiments` result whose
``scalars()`` the table keeps.  :func:`sweep` runs every case of a grid on a Dask cluster —
a ``LocalCluster`` of two worker processes by default, a batch system's cluster by name
through dask-jobqueue (``cluster="slurm", cluster_options={...}``), a scheduler address, an
existing ``Client`` — and gathers the scalar results into one table, written as JSON (the
store of record) and HDF5::

    from workbench.campaign import sweep
    table = sweep("cylinder_triaxial", {"k": [0.1, 1.0, 10.0], "wire": ["elastic"],
                                        "scale": [0.05], "seed": [0, 1]},
                  out="out/k_sweep.json")
    table.rows          # one dict per case: params, status, attempts, errors, result, elapsed
    table.column("H")   # one result across the cases (NaN where missing)

* a case that raises is reported (``status="failed"`` with the error and its traceback
  tail, and its attempts) and run again ``retries`` times (once by default; Dask's own
  retries on a cluster) while the other cases keep going;
* the table is rewritten after every finished case, keyed by the case's parameters, so a
  re-run (or a run after a crash or Ctrl-C) skips the cases already done and retries the
  failed ones;
* ``client="serial"`` runs the cases one by one in this process (the reference the
  distributed run is compared with, and the fallback without a cluster).

Modules: :mod:`workbench.campaign.cases` (grids, keys), :mod:`workbench.campaign.experiments` (the paper's tests
by name), :mod:`workbench.campaign.runner` (the sweep on Dask or in this process),
:mod:`workbench.campaign.table` (the table, resume), :mod:`workbench.campaign.clusters` (clusters by name).
"""
from .cases import case_id, case_key, expand_grid
from .clusters import CLUSTERS, ClusterSpec, cluster_spec, local_client
from .experiments import EXPERIMENTS, CaseInterrupted, not_interrupted, scalars_of
from .runner import run_case, sweep, table_path
from .table import TABLE_VERSION, SweepTable, load_table, update_results, write_hdf5

__all__ = ["sweep", "SweepTable", "expand_grid", "case_key", "case_id", "run_case",
           "scalars_of", "load_table", "EXPERIMENTS", "local_client", "CaseInterrupted",
           "not_interrupted", "update_results", "write_hdf5", "TABLE_VERSION", "CLUSTERS",
           "ClusterSpec", "cluster_spec", "table_path"]
