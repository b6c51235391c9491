"""workbench.campaign.clusters and the Dask path: a batch cluster by name (dask-jobqueue's local job
cluster, which runs the same job scripts as local processes) gives the numbers of the
same cases run here; a case failing once is run again by Dask's own retries and reports
two attempts; clusters and options are checked with one-line errors; engine.sweep is a
deprecation alias of the campaign package."""
from __future__ import annotations

import importlib
import sys
import warnings

import pytest

pytest.importorskip("distributed")

from workbench import campaign  # noqa: E402
from workbench.campaign import ClusterSpec, cluster_spec, expand_grid, local_client, sweep  # noqa: E402
from tests.campaign.test_sweep import drop  # noqa: E402


def test_a_batch_cluster_by_name_runs_the_cases_as_jobs(tmp_path):
    """``cluster="jobqueue-local"``: two jobs of one worker each (dask-jobqueue's job
    scripts, run as local processes); the table's numbers are those of direct calls."""
    pytest.importorskip("dask_jobqueue")
    grid = {"height": [2e-3, 5e-3], "mu": [0.2, 0.8]}
    table = sweep(drop, grid, out=tmp_path / "jobs.json", cluster="jobqueue-local",
                  cluster_options={"cores": 1, "memory": "1GB"}, n_workers=2,
                  progress=False)
    assert len(table.done) == 4 and not table.failed, [r["errors"] for r in table.rows]
    assert len({r["result"]["pid"] for r in table.rows}) == 2      # both jobs worked
    for case in expand_grid(grid):
        direct = drop(**case)
        row = table.find(**case)
        assert row["attempts"] == 1
        for k in ("z", "vx", "vz", "spin_y"):
            assert row["result"][k] == direct[k], (case, k)


def test_a_case_failing_once_is_retried_by_dask_and_counts_two_attempts(tmp_path):
    """One ``client.submit(..., retries=1)`` per case: the scheduler runs the flaky case
    again; the table has its first attempt's error and ``attempts == 2``, and the case that
    always fails has both errors and ``attempts == 2``."""
    client = local_client(2)
    submitted = []
    submit = client.submit

    def counting_submit(*args, **kwargs):
        submitted.append(kwargs)
        return submit(*args, **kwargs)

    client.submit = counting_submit
    try:
        grid = [{"height": 5e-3, "flaky_dir": str(tmp_path / "flaky")},
                {"height": 3e-3, "fail": True}]
        table = sweep(drop, grid, client, out=tmp_path / "r.json", progress=False)
    finally:
        client.close()
        client.cluster.close()
    assert len(submitted) == 2 and all(kw["retries"] == 1 and kw["pure"] is False
                                       for kw in submitted)
    flaky, bad = table.rows
    assert flaky["status"] == "done" and flaky["attempts"] == 2
    assert len(flaky["errors"]) == 1 and "flaky: first attempt fails" in flaky["errors"][0]
    assert bad["status"] == "failed" and bad["attempts"] == 2
    assert len(bad["errors"]) == 2 and all("injected failure" in e for e in bad["errors"])
    assert "test_sweep.py" in bad["errors"][0]                # the traceback's tail


def test_clusters_and_their_options_are_checked_with_one_line_errors(tmp_path):
    with pytest.raises(ValueError, match=r"cluster must be one of 'local', 'slurm', .*"
                                         r"got 'slurmx'"):
        sweep(drop, [{"height": 2e-3}], out=tmp_path / "c.json", cluster="slurmx")
    with pytest.raises(ValueError, match=r"n_workers \(--workers\) must be an integer"):
        cluster_spec("slurm", {"cores": 1}, n_workers=0)
    with pytest.raises(ValueError, match="cluster_options must be a mapping"):
        ClusterSpec("local", ["cores=1"])
    with pytest.raises(ValueError, match="give them without a client"):
        sweep(drop, [{"height": 2e-3}], "serial", out=tmp_path / "c.json", cluster="local")
    with pytest.raises(ValueError, match="client must be None, 'serial', a scheduler "):
        sweep(drop, [{"height": 2e-3}], 42, out=tmp_path / "c.json", progress=False)
    assert not (tmp_path / "c.json").exists()
    pytest.importorskip("dask_jobqueue")
    with pytest.raises(ValueError, match=r"cluster_options of the 'jobqueue-local' cluster: "
                                         r".*'bogus'"):
        ClusterSpec("jobqueue-local", {"cores": 1, "memory": "1GB", "bogus": 1}).make()
    with pytest.raises(ValueError, match=r"cluster_options of the 'jobqueue-local' cluster: "
                                         r".*cores and memory"):
        ClusterSpec("jobqueue-local", {}).make()
    assert str(ClusterSpec("slurm", {"cores": 2, "memory": "4GB"}, 8)) == \
        "slurm cluster, 8 workers (cores=2, memory=4GB)"


def test_engine_sweep_is_a_deprecation_alias_of_campaign():
    old_all = ["sweep", "SweepTable", "expand_grid", "case_key", "case_id", "run_case",
               "scalars_of", "load_table", "EXPERIMENTS", "local_client", "CaseInterrupted",
               "not_interrupted", "update_results"]
    sys.modules.pop("engine.sweep", None)
    with pytest.warns(DeprecationWarning, match="engine.sweep is deprecated.*campaign"):
        alias = importlib.import_module("engine.sweep")
    for name in old_all:
        assert getattr(alias, name) is getattr(campaign, name), name
        assert name in alias.__all__
    from workbench.campaign.experiments import check_paper_cases
    from workbench.campaign.table import TABLE_VERSION

    with warnings.catch_warnings():
        warnings.simplefilter("error")               # an imported module does not warn again
        from engine.sweep import _check_paper_cases, sweep as old_sweep
    assert _check_paper_cases is check_paper_cases and old_sweep is campaign.sweep
    assert alias.TABLE_VERSION == TABLE_VERSION == 1
    with pytest.raises(AttributeError, match="moved to the 'workbench.campaign' package"):
        alias.no_such_name


def test_a_slurm_cluster_by_name_writes_the_job_script_asked_for():
    """What ``cluster="slurm"`` submits (built here, no job submitted): the options in the
    ``#SBATCH`` lines, ``processes = cores`` workers of one thread each per job."""
    dask_jobqueue = pytest.importorskip("dask_jobqueue")
    spec = ClusterSpec("slurm", {"cores": 2, "memory": "4GB", "walltime": "01:00:00",
                                 "queue": "normal", "account": "proj"}, n_workers=4)
    assert spec.batch and spec.keywords()["processes"] == 2
    with dask_jobqueue.SLURMCluster(**spec.keywords()) as cluster:
        script = cluster.job_script()
    for line in ("#SBATCH -p normal", "#SBATCH -A proj", "#SBATCH --cpus-per-task=2",
                 "#SBATCH -t 01:00:00", "distributed.cli.dask_worker", "--nworkers 2",
                 "--nthreads 1"):
        assert line in script, (line, script)


def test_an_option_the_local_cluster_does_not_take_is_refused_before_it_starts():
    """An unknown option went on to every nanny, which failed to start with a traceback
    each; now one line before anything starts.  The options it does take pass the check."""
    from workbench.campaign.clusters import _known_to_local

    with pytest.raises(ValueError, match=r"\(--cluster-option\) bogus, nannies: not an "
                                         r"option of the local cluster"):
        ClusterSpec("local", {"bogus": 1, "nannies": 2}).make()
    _known_to_local({"memory_limit": "1GB", "threads_per_worker": 1, "n_workers": 2,
                     "dashboard_address": ":0"})
