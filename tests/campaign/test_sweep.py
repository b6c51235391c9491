"""workbench.campaign.sweep: cases on a LocalCluster of 2 workers give the numbers of the same cases run
one by one; a failing case is reported (and retried once) while the others finish; a
re-run skips the finished cases; the JSON and HDF5 tables agree."""
from __future__ import annotations

import json
import os
from pathlib import Path

import h5py
import numpy as np
import pytest

pytest.importorskip("distributed")

from engine import Scene, laws, run  # noqa: E402
from workbench.campaign import (case_id, case_key, expand_grid, load_table, local_client,  # noqa: E402
                      sweep, update_results)


# ---------------------------------------------------------------- a cheap experiment

def drop(*, height: float, mu: float = 0.5, steps: int = 200, fail: bool = False,
         flaky_dir: str | None = None, label: str = ""):
    """A sphere dropped on a plane with a sideways kick (a real engine run, ~0.1 s):
    final height, speeds and spin.  ``fail`` raises; ``flaky_dir`` fails the first
    attempt of the case (a marker file remembers it) and succeeds the second."""
    if fail:
        raise RuntimeError(f"injected failure (height={height})")
    if flaky_dir is not None:
        marker = Path(flaky_dir) / f"tried-{height}-{mu}"
        if not marker.exists():
            marker.parent.mkdir(parents=True, exist_ok=True)
            marker.write_text("1")
            raise RuntimeError("flaky: first attempt fails")
    s = Scene(gravity=(0.0, 0.0, -9.81))
    b = s.add_spheres(np.array([[0.0, 0.0, height]]), 1e-3, density=2650.0, group="sand")
    s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    s.interact("sand", "wall", laws.Coulomb(mu=mu))
    model, state = s.compile(dt=1e-4, theta=0.5)
    state.velocity[b[0]] = (0.3, 0.0, 0.0)
    run(model, state, steps, progress=False)
    return dict(z=float(state.position[b[0], 2]), vx=float(state.velocity[b[0], 0]),
                vz=float(state.velocity[b[0], 2]), spin_y=float(state.spin[b[0], 1]),
                pid=os.getpid(), note="ok", array=np.zeros(3))


@pytest.fixture(scope="module")
def client():
    c = local_client(2)
    yield c
    c.close()
    c.cluster.close()


# ---------------------------------------------------------------- grid and keys

def test_grid_product_and_keys():
    cases = expand_grid({"a": [1, 2], "b": ["x"], "c": 0.5})
    assert cases == [{"a": 1, "b": "x", "c": 0.5}, {"a": 2, "b": "x", "c": 0.5}]
    assert expand_grid([{"a": 1}, {"a": 1}, {"a": np.float64(2.0)}]) == [{"a": 1}, {"a": 2.0}]
    # the key does not depend on the order of the parameters
    assert case_key("e", {"a": 1, "b": 2}) == case_key("e", {"b": 2, "a": 1})
    assert case_id("e", {"a": 1}) != case_id("e", {"a": 2})
    with pytest.raises(ValueError, match="JSON-able"):
        expand_grid({"law": [laws.RigidWire()]})
    with pytest.raises(ValueError, match="not finite"):
        expand_grid({"a": [float("nan")]})
    with pytest.raises(ValueError, match="unknown experiment"):
        sweep("no_such_test", {"a": [1]}, client="serial")


# ---------------------------------------------------------------- distributed == serial

def test_local_cluster_matches_one_by_one(client, tmp_path):
    grid = {"height": [2e-3, 5e-3, 1e-2], "mu": [0.2, 0.8]}
    table = sweep(drop, grid, client, out=tmp_path / "drop.json", progress=False)
    assert len(table.done) == 6 and not table.failed
    # both workers were used, and the numbers are those of direct calls here
    assert len({r["result"]["pid"] for r in table.rows}) == 2
    for case in expand_grid(grid):
        direct = drop(**case)
        row = table.find(**case)
        for k in ("z", "vx", "vz", "spin_y"):
            assert row["result"][k] == direct[k], (case, k)
        assert row["result"]["_dropped"] == "array"       # not a scalar: left out, said so
    # the serial path gives the same table
    serial = sweep(drop, grid, "serial", out=tmp_path / "serial.json", progress=False)
    for a, b in zip(table.rows, serial.rows):
        assert a["key"] == b["key"]
        assert {k: v for k, v in a["result"].items() if k != "pid"} == \
               {k: v for k, v in b["result"].items() if k != "pid"}


@pytest.mark.slow
def test_box_triaxial_on_two_workers_matches_direct_calls(client, tmp_path):
    """The paper's box test at a tiny scale: the sweep on 2 workers gives bit-identical
    curves' end values to running each case here, one by one."""
    from engine.experiments import box_triaxial

    grid = {"scale": [0.03], "axial_strain": [0.002], "seed": [0, 1]}
    table = sweep("box_triaxial", grid, client, out=tmp_path / "box.json",
                  fixed={"history_dir": str(tmp_path / "runs")}, progress=False)
    assert len(table.done) == 2, [r["errors"] for r in table.rows]
    for case in expand_grid(grid):
        r = box_triaxial(case["scale"], axial_strain=case["axial_strain"], seed=case["seed"],
                         history=str(tmp_path / f"direct{case['seed']}.h5"), progress=False)
        row = table.find(**case)["result"]
        assert row["deviator"] == float(r.deviator[-1])
        assert row["mean_stress"] == float(r.mean_stress[-1])
        assert row["steps"] == r.convergence["steps"]
        assert Path(row["history"]).exists()


@pytest.mark.slow
def test_running_cases_report_their_stages(client, tmp_path):
    """Progress of a long sweep: each case's stages report (stage, steps done, total) —
    on a worker as Dask events to the client, in a serial run to the caller — and the last
    report of a case is its step count."""
    import time

    from workbench.campaign.experiments import resolve as _resolve
    from workbench.campaign.runner import _run_dask, run_case

    fn = _resolve("box_triaxial")
    params = dict(scale=0.03, axial_strain=0.002)
    calls = []
    res = run_case(fn, dict(params, seed=0), {"history_dir": str(tmp_path / "serial")},
                   report=lambda *a: calls.append(a))
    assert calls and [c[0] for c in calls][0] == "box triaxial, isotropic"
    assert calls[-1][0] == "box triaxial, loading"
    done = [c[1] for c in calls]
    assert done == sorted(done) and done[-1] == res["result"]["steps"] <= calls[-1][2]

    events, finished = [], []
    rows = [dict(id=f"case{s}", params=dict(params, seed=s), attempts=0) for s in (0, 1)]
    _run_dask(fn, rows, client, {"history_dir": str(tmp_path / "dask")}, 2,
              lambda row, payload: finished.append(row["id"]),
              lambda row, msg, final=None: pytest.fail(msg),
              on_stage=lambda *a: events.append(a))
    assert sorted(finished) == ["case0", "case1"]
    t0 = time.monotonic()                 # the events travel apart from the results
    while {e[0] for e in events} != {"case0", "case1"} and time.monotonic() - t0 < 10:
        time.sleep(0.1)
    assert {e[0] for e in events} == {"case0", "case1"}
    for label, desc, n, total in events:
        assert desc.startswith("box triaxial, ") and 0 < n <= total


# ---------------------------------------------------------------- failures and re-runs

def test_failing_case_is_reported_and_the_others_finish(client, tmp_path):
    grid = [{"height": 2e-3}, {"height": 3e-3, "fail": True}, {"height": 4e-3},
            {"height": 5e-3, "flaky_dir": str(tmp_path / "flaky")}]
    out = tmp_path / "t.json"
    table = sweep(drop, grid, client, out=out, progress=False)
    bad = table.find(height=3e-3)
    assert bad["status"] == "failed"
    assert bad["attempts"] == 2                             # retried once
    assert len(bad["errors"]) == 2 and "injected failure" in bad["errors"][0]
    flaky = table.find(height=5e-3)
    assert flaky["status"] == "done" and flaky["attempts"] == 2
    assert "flaky" in flaky["errors"][0]
    assert [r["status"] for r in table.rows] == ["done", "failed", "done", "done"]
    # the stored tables say the same
    stored = load_table(out)
    assert [r["status"] for r in stored.rows] == ["done", "failed", "done", "done"]
    with h5py.File(out.with_suffix(".h5"), "r") as f:
        assert [s.decode() for s in f["status"][()]] == ["done", "failed", "done", "done"]
        assert "injected failure" in f["error"][1].decode()
        z = f["results/z"][()]
        assert np.isnan(z[1]) and np.all(np.isfinite(z[[0, 2, 3]]))
        np.testing.assert_array_equal(f["params/height"][()], [2e-3, 3e-3, 4e-3, 5e-3])


def test_rerun_skips_finished_cases(tmp_path, capsys):
    out = tmp_path / "r.json"
    grid = [{"height": 2e-3}, {"height": 3e-3, "fail": True}]
    first = sweep(drop, grid, "serial", out=out)
    assert [r["status"] for r in first.rows] == ["done", "failed"]
    capsys.readouterr()
    # the second run: the finished case is taken from the table, the failed one re-runs,
    # and a new case is added
    grid2 = [{"height": 2e-3}, {"height": 3e-3, "fail": True}, {"height": 6e-3}]
    second = sweep(drop, grid2, "serial", out=out)
    text = capsys.readouterr().out
    assert "3 cases, 1 already done, 2 to run" in text
    assert second.rows[0]["skipped"] and second.rows[0]["result"] == first.rows[0]["result"]
    assert second.rows[1]["status"] == "failed" and not second.rows[1]["skipped"]
    assert second.rows[2]["status"] == "done" and not second.rows[2]["skipped"]
    # a third run has nothing to do for the finished cases; other cases in the file stay
    third = sweep(drop, [{"height": 6e-3}], "serial", out=out, progress=False)
    assert third.rows[0]["skipped"]
    with open(out) as f:
        assert len(json.load(f)["cases"]) == 3


def test_results_recomputed_after_the_run_are_kept_and_resumed(tmp_path):
    """update_results replaces the named done rows' scalars as a sweep stores them (NaN as
    None, arrays dropped), leaves the other rows as they were, and a re-run of the sweep
    takes the new scalars as finished."""
    out = tmp_path / "u.json"
    grid = [{"height": 2e-3}, {"height": 4e-3}]
    first = sweep(drop, grid, "serial", out=out, progress=False)
    a, b = first.rows
    new = dict(a["result"], z=-1.0, extra=float("nan"), array=np.ones(2), rescored=True)
    update_results(out, {a["id"]: new})
    stored = load_table(out).rows
    assert stored[0]["result"]["z"] == -1.0 and stored[0]["result"]["extra"] is None
    assert "array" not in stored[0]["result"] and stored[0]["result"]["rescored"] is True
    assert stored[0]["result"]["_dropped"] == "array"            # as run_case records it
    assert stored[1] == b
    again = sweep(drop, grid, "serial", out=out, progress=False)
    assert again.rows[0]["skipped"] and again.rows[0]["result"]["z"] == -1.0
    with pytest.raises(ValueError, match="no sweep table"):
        update_results(tmp_path / "none.json", {})


@pytest.mark.slow
def test_a_cluster_without_workers_fails_the_cases_instead_of_hanging(tmp_path):
    c = local_client(0)
    try:
        table = sweep(drop, [{"height": 2e-3}, {"height": 3e-3}], c, out=tmp_path / "n.json",
                      no_worker_timeout=2.0, progress=False)
    finally:
        c.close()
        c.cluster.close()
    assert [r["status"] for r in table.rows] == ["failed", "failed"]
    assert all("NoWorkers" in r["errors"][-1] for r in table.rows)


def test_named_experiment_rejects_bad_input_before_running(tmp_path):
    """A paper test's case with a wire it cannot build, a stiffness that is not a positive
    number, a parameter the test does not take, a solver option out of range or a bad scale
    is refused before any case runs (no table written), naming the case or the parameter
    and listing the allowed names or values."""
    bad = [({"scale": [0.03], "wire": ["elastic", "steel"]}, r"case \{.*'steel'\}: wire must"),
           ({"k": ["abc"]}, "k must be the elastic wire's stiffness in N"),
           ({"k": [-1.0]}, r"stiffness = -1.0: must be a finite number > 0"),
           ({"scale": [0.03], "dt": [1e-4, -1.0]}, r"case \{.*'dt': -1.0\}: dt = -1.0: "
                                                   r"must be a number in \(0, 0.01\]"),
           ({"scale": [0.03], "theta": [0.3]}, r"theta = 0.3: must be a number in \[0.5, 1\]"),
           ({"scale": [0.0]}, r"scale must be a number in \(0, 10\]"),
           ({"scale": [1e9]}, r"scale must be a number in \(0, 10\] \(1: the paper's sample\), "
                              r"got 1000000000.0"),
           ({"scale": [0.03], "frictoin": [0.3]}, "takes no parameter 'frictoin'; its "
                                                   "parameters are .*mu_wire"),
           # types (issue 33: "steps=abc" ran the case twice before failing)
           ({"scale": [0.03], "ramp_steps": ["abc"]}, "ramp_steps = 'abc': must be an integer in \\[0, 1000000000\\], not a string"),
           ({"scale": [0.03], "ramp_steps": [2.5]}, "ramp_steps = 2.5: must be an integer in"),
           ({"scale": [0.03], "seed": [True]}, "seed = True: must be an integer in"),
           ({"scale": [0.03], "mu": ["0.3"]}, r"mu = '0.3': must be a number in \[0, 10\], not a string"),
           ({"scale": [0.03], "mu": [float("nan")]}, "parameter 'mu': nan is not finite"),
           ({"scale": [0.03], "neighbour_contact": [1]}, "neighbour_contact = 1: must be true "
                                                         "or false")]
    for grid, says in bad:
        with pytest.raises(ValueError, match=says):
            sweep("box_triaxial", grid, "serial", out=tmp_path / "bad.json", retries=0,
                  progress=False)
    assert not (tmp_path / "bad.json").exists()
    # typed values of the right kinds pass the check (an int for a float, None where allowed)
    from workbench.campaign.experiments import check_paper_cases as _check_paper_cases

    _check_paper_cases("box_triaxial", [{"scale": 1, "mu": 0, "seed": 3, "hot_sweeps": None,
                                         "neighbour_contact": False}], {})
    # a local cluster of no worker is refused at once (it would fail every case only after
    # no_worker_timeout)
    for n in (0, -1, 2.0):
        with pytest.raises(ValueError, match=r"--workers\) must be an integer in \[1, 1024\]"):
            sweep(drop, [{"height": 2e-3}], None, out=tmp_path / "w.json", n_workers=n,
                  progress=False)
    assert not (tmp_path / "w.json").exists()



class _Stopped:
    """What an experiment stopped by Ctrl-C returns (a result whose convergence record
    says so), reduced."""

    def __init__(self, steps):
        self.convergence = dict(steps=steps, interrupted=True)
        self.history = None


def stopped_drop(*, height: float, stop_at: float | None = None):
    """A sphere falling 50 steps; Ctrl-C stops the run at step 5 when ``height == stop_at``
    (a fixed argument: not part of the case's key)."""
    import signal

    from engine.step import CallbackWriter

    def interrupter(model, state):
        if height == stop_at and state.step == 5:
            os.kill(os.getpid(), signal.SIGINT)

    s = Scene(gravity=(0.0, 0.0, -9.81))
    s.add_spheres(np.array([[0.0, 0.0, height]]), 1e-3, density=2650.0, group="sand")
    model, state = s.compile(dt=1e-4)
    summary = run(model, state, 50, writers=[CallbackWriter(interrupter)], progress=False)
    if summary.interrupted:
        return _Stopped(summary.steps)
    return dict(steps=summary.steps, z=float(state.position[0, 2]))


def test_an_interrupted_case_stops_the_sweep_and_runs_again_later(tmp_path, capsys):
    """Ctrl-C during a case: the cases finished are kept, the stopped one is neither a result
    nor a failure (it stays pending) and the cases after it wait; the next run runs them."""
    from workbench.campaign import CaseInterrupted

    out = tmp_path / "i.json"
    grid = [{"height": 2e-3}, {"height": 3e-3}, {"height": 4e-3}]
    with pytest.raises(CaseInterrupted, match="interrupted after 5 steps"):
        sweep(stopped_drop, grid, "serial", out=out, fixed={"stop_at": 3e-3})
    assert "interrupted; 1 of 3 cases done" in capsys.readouterr().out
    rows = load_table(out).rows
    assert [r["status"] for r in rows] == ["done", "pending", "pending"]
    assert rows[1]["errors"] == []                  # not counted as a failed attempt
    again = sweep(stopped_drop, grid, "serial", out=out, progress=False)
    assert [r["skipped"] for r in again.rows] == [True, False, False]
    assert [r["status"] for r in again.rows] == ["done"] * 3
    assert [r["result"]["steps"] for r in again.rows] == [50] * 3


def _sigint_handler():
    import signal

    return signal.getsignal(signal.SIGINT) == signal.SIG_IGN


def test_local_cluster_workers_ignore_ctrl_c(client):
    """Ctrl-C is for the sweep's process, which stops the sweep and closes the cluster."""
    assert list(client.run(_sigint_handler).values()) == [True, True]


def nap(*, seconds: float) -> dict:
    """A case that takes ``seconds`` of wall time and no CPU (the sweep's own behaviour,
    without the engine's compilation in each worker of a fresh clone)."""
    import time

    t0 = time.monotonic()
    while time.monotonic() - t0 < seconds:
        time.sleep(0.05)
    return dict(slept=time.monotonic() - t0)


_CTRL_C_SCRIPT = """
import signal
import sys
# a terminal's Ctrl-C: a command started in the background by a shell without job control
# (CI) inherits SIGINT ignored, and Python then keeps ignoring it
signal.signal(signal.SIGINT, signal.default_int_handler)
from workbench.campaign import sweep
from tests.campaign.test_sweep import nap
if __name__ == "__main__":
    grid = [dict(seconds=0.1), dict(seconds=600.0), dict(seconds=601.0)]
    try:
        sweep(nap, grid, None, out=sys.argv[1], n_workers=2)
    except KeyboardInterrupt:
        sys.exit(130)
"""


@pytest.mark.slow
def test_ctrl_c_on_a_local_cluster_keeps_the_finished_cases_quietly(tmp_path):
    """Ctrl-C in a terminal (SIGINT to the whole process group) while a LocalCluster sweep
    runs: the finished case stays done, the running ones stay pending (not failed), the
    cluster closes, and nothing prints a traceback (a nanny did in one of the two runs tried
    before the workers ignored SIGINT)."""
    import signal
    import subprocess
    import sys
    import time

    script, out = tmp_path / "s.py", tmp_path / "t.json"
    script.write_text(_CTRL_C_SCRIPT)
    root = Path(__file__).resolve().parents[2]
    p = subprocess.Popen([sys.executable, str(script), str(out)], cwd=root, text=True,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
                         env=dict(os.environ, PYTHONPATH=str(root)))
    try:
        t0, first = time.monotonic(), False
        while time.monotonic() - t0 < 600 and p.poll() is None and not first:
            first = out.exists() and any(r["status"] == "done" for r in load_table(out).rows)
            time.sleep(0.5)
        assert first, "the first case did not finish in 600 s"
        time.sleep(2.0)                              # the two long cases are running
        os.killpg(p.pid, signal.SIGINT)
        t1 = time.monotonic()
        _, err = p.communicate(timeout=300)
        assert time.monotonic() - t1 < 60, "the sweep took a minute or more to stop"
    finally:
        try:                    # whatever is left of the group (workers outliving their parent)
            os.killpg(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    assert p.returncode == 130, err
    assert "Traceback" not in err, err
    assert [r["status"] for r in load_table(out).rows] == ["done", "pending", "pending"]


def test_an_interrupted_named_test_is_not_recorded_as_done(tmp_path, monkeypatch):
    """The paper's tests by name (what ``nscd sweep`` runs) go through a wrapper returning
    table values: an interrupted run must still stop the sweep and stay pending."""
    from workbench.campaign import CaseInterrupted
    from tests.helpers import stop_runs_at

    stop_runs_at(monkeypatch, 30)
    out = tmp_path / "g.json"
    with pytest.raises(CaseInterrupted, match="gravity_deposit .* interrupted after 30 steps"):
        sweep("gravity_deposit", {"scale": [0.02], "sample": ["box"], "seed": [0, 1]}, "serial",
              out=out, fixed={"history_dir": str(tmp_path / "runs")}, progress=False)
    assert [r["status"] for r in load_table(out).rows] == ["pending", "pending"]


def test_a_grid_names_every_wire_law_and_its_parameters(tmp_path, monkeypatch):
    """``wire`` of a sweep case is any of engine.laws.WIRE_LAWS (or "none"), with ``k``,
    ``prestrain`` and ``max_tension``: the test function gets that law; a parameter the
    law has not is refused before any case runs (the rigid wire's k used to be ignored)."""
    from engine import experiments
    from workbench.campaign import EXPERIMENTS
    from workbench.campaign.experiments import check_paper_cases as _check_paper_cases

    got = []

    def fake(scale=0.05, **kw):        # records the arguments instead of running the test
        got.append(kw)
        raise RuntimeError("recorded")

    cases = {"brittle": (dict(k=2.0, max_tension=0.5, prestrain=0.01),
                         laws.BrittleElasticWire(stiffness=2.0, max_tension=0.5, prestrain=0.01)),
             "rigid_rod": (dict(prestrain=0.02), laws.RigidRod(prestrain=0.02)),
             "elastic_rod": (dict(k=3.0), laws.ElasticRod(stiffness=3.0)),
             "elastic": ({}, laws.ElasticWire(stiffness=1.0)),
             "rigid": ({}, laws.RigidWire()),
             "loose": ({}, laws.LooseWire())}
    for wire, (kw, want) in cases.items():
        _check_paper_cases("gravity_deposit", [dict(wire=wire, **kw)], {})
    for case, says in ((dict(wire="rigid", k=1.0), "the 'rigid' wire has no stiffness"),
                       (dict(wire="brittle"), "max_tension: required by the 'brittle' wire"),
                       (dict(wire="elastic", max_tension=1.0), "the 'elastic' wire has no "
                                                               "max_tension"),
                       (dict(wire="none", prestrain=0.1), "the wire is 'none'"),
                       (dict(wire="steel"), "wire must be one of 'elastic', 'rigid'")):
        with pytest.raises(ValueError, match=says):
            _check_paper_cases("gravity_deposit", [case], {})
    monkeypatch.setattr(experiments, "gravity_deposit", fake)
    for wire, (kw, want) in cases.items():
        with pytest.raises(RuntimeError, match="recorded"):
            EXPERIMENTS["gravity_deposit"](wire=wire, history_dir=str(tmp_path), **kw)
        assert got[-1]["wire"] is True and got[-1]["wire_law"] == want, wire


def test_a_grid_prepares_and_starts_the_triaxial_tests(tmp_path, monkeypatch):
    """``preparation``, ``wire_density``, ``wire_mode``, ``wire_prestrain`` and
    ``confinement`` are sweep parameters like the others (checked before any case runs); a
    case with a ``sample`` path and the default wire lets the state keep its own law."""
    from engine import experiments
    from workbench.campaign import EXPERIMENTS
    from workbench.campaign.experiments import check_paper_cases as _check_paper_cases

    _check_paper_cases("cylinder_triaxial", [dict(preparation="paper", wire_density=5e5,
                                                  wire_mode="orthotropic", wire_prestrain=0.01,
                                                  confinement="layer_crown"),
                                             dict(preparation="layered")], {})
    for case, says in ((dict(preparation="wet"), r"preparation = 'wet': must be one of "
                                                 r"'geometric', 'paper'"),
                       (dict(confinement="rubber"), "confinement = 'rubber'"),
                       (dict(wire_mode="spiral"), "wire_mode = 'spiral'"),
                       (dict(wire_prestrain=-0.1), r"wire_prestrain = -0.1: must be a number "
                                                   r"in \[0, 1\]")):
        with pytest.raises(ValueError, match=says):
            _check_paper_cases("cylinder_triaxial", [case], {})
    got = []

    def fake(scale=0.05, **kw):
        got.append(kw)
        raise RuntimeError("recorded")

    monkeypatch.setattr(experiments, "cylinder_triaxial", fake)
    with pytest.raises(RuntimeError):
        EXPERIMENTS["cylinder_triaxial"](sample="out/d.h5", history_dir=str(tmp_path))
    assert got[-1]["wire"] is True and "wire_law" not in got[-1]
    with pytest.raises(RuntimeError):
        EXPERIMENTS["cylinder_triaxial"](sample="out/d.h5", wire="rigid",
                                         history_dir=str(tmp_path))
    assert got[-1]["wire_law"] == laws.RigidWire()      # refused by the test: named
