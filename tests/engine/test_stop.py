"""Stop requests inside a step (issue 33 item 4): the NLGS loop looks at them every few
hundred sweeps, in chunks whose result is bit for bit one call's, and the interrupted step
is undone exactly."""
import copy
import dataclasses
import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from engine import run, step, stop
from engine.step import NonConvergenceWarning
from tests.engine.test_io import scene
from tests.helpers import signal_child, slow_params

ROOT = Path(__file__).resolve().parents[2]

_SETTLED = {}


def settled(tol=1e-9, max_iter=3000, **opt):
    """The test_io scene (40 grains, a wire, a pressure lid) after 300 steps of 1 ms, with a
    tight tolerance so that each step needs its whole ``max_iter``."""
    if not _SETTLED:
        model, state = scene(dt=1e-3)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NonConvergenceWarning)
            for _ in range(300):
                step(model, state)
        _SETTLED["v"] = (model, state)
    model, state = _SETTLED["v"]
    model = dataclasses.replace(model, options=model.options.model_copy(
        update=dict(tol=tol, max_iter=max_iter, **opt)))
    return model, copy.deepcopy(state)


STATE_FIELDS = ("position", "vel6", "force", "link_impulse", "link_normal", "link_gap",
                "warm_key", "warm_impulse", "pairs_ref")


def assert_same_state(a, b):
    for name in STATE_FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None) == (y is None), name
        if x is not None:
            np.testing.assert_array_equal(x, y, err_msg=name)
    assert (a.time, a.step, a.n_pairs, a.time_compensation) == (
        b.time, b.step, b.n_pairs, b.time_compensation)
    np.testing.assert_array_equal(a.pairs[:a.n_pairs], b.pairs[:b.n_pairs])
    ca, cb = a.contacts_buf, b.contacts_buf
    assert ca.count == cb.count
    for name in ("i", "j", "key", "gap", "impulse"):
        np.testing.assert_array_equal(getattr(ca, name)[:ca.count], getattr(cb, name)[:cb.count])


@pytest.mark.parametrize("opt", [{}, {"hot_sweeps": 2}, *slow_params(
    {"anderson": 4}, {"threads": 2}, {"threads": 2, "anderson": 3},
    {"threads": 2, "hot_sweeps": 2})], ids=["plain", "hot", "anderson", "threads",
                                             "threads-anderson", "threads-hot"])
def test_sweeps_in_chunks_are_one_call_bit_for_bit(opt, monkeypatch):
    """Five steps of up to 3000 sweeps each, looked at every 7 sweeps (430 chunks a step),
    end bit for bit as with one call per step, for the four NLGS loops."""
    out = []
    for chunk in (None, 7):
        model, state = settled(**opt)
        with monkeypatch.context() as mp:
            if chunk:
                mp.setattr(stop, "MIN_SWEEPS", chunk)
                mp.setattr(stop, "CHECK_WORK", 1)
            with stop.watching():
                its = [step(model, state).iterations for _ in range(5)]
        out.append((state, its))
    assert out[0][1] == out[1][1] and max(out[0][1]) > 200
    assert_same_state(out[0][0], out[1][0])


def _interrupt_after(mp, chunks):
    """A stop request at the ``chunks``-th look of the NLGS loop (as a signal there would)."""
    seen = {"n": 0}
    check = stop.check

    def counting():
        seen["n"] += 1
        if seen["n"] == chunks:
            stop.request()
        check()

    mp.setattr(stop, "check", counting)
    mp.setattr(stop, "MIN_SWEEPS", 20)
    mp.setattr(stop, "CHECK_WORK", 1)
    return seen


def test_an_interrupted_step_is_undone_and_the_run_goes_on_as_if_never_stopped(monkeypatch):
    """The scene falling (the candidate list is rebuilt on the way: the undone step is one
    that rebuilt it) at tol 1e-7: a stop request inside step k leaves the state of step k-1,
    bit for bit (positions, velocities, forces, warm starts, candidate pairs, contacts); run
    again from there, the run ends bit for bit as the one that was never stopped."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonConvergenceWarning)
        model, state = scene(dt=5e-4)
        model = dataclasses.replace(model, options=model.options.model_copy(
            update=dict(tol=1e-7, max_iter=2000)))
        ref = copy.deepcopy(state)
        rebuilt = []
        for _ in range(60):
            rebuilt.append(step(model, ref).rebuilt)
            if ref.step > 20 and rebuilt[-1]:
                break
        k = ref.step                    # a step that rebuilds the list, after 20 that did not all
        assert rebuilt[-1] and k < 60
        ref = copy.deepcopy(state)
        run(model, ref, k + 10, progress=False)
        s = copy.deepcopy(state)
        run(model, s, k - 1, progress=False)
        before = copy.deepcopy(s)
        with monkeypatch.context() as mp:
            seen = _interrupt_after(mp, 1)
            summary = run(model, s, 10, progress=False)
        assert summary.interrupted and summary.steps == 0 and seen["n"] == 1
        assert not stop.requested()                # honoured, then cleared
        assert_same_state(s, before)
        run(model, s, 11, progress=False)
    assert_same_state(s, ref)


def test_a_stop_requested_before_the_run_stops_it_before_its_first_step():
    model, state = scene()
    stop.request()
    summary = run(model, state, 5, progress=False)
    assert summary.interrupted and summary.steps == 0 and state.step == 0
    assert not stop.requested()
    assert run(model, state, 2, progress=False).steps == 2


CHILD = textwrap.dedent("""
    import copy, dataclasses, sys, time, warnings
    from engine import run
    from tests.engine.test_stop import settled, assert_same_state
    warnings.simplefilter("ignore")
    model, state = settled(tol=1e-14, max_iter=10**9)   # one step would take hours
    before = copy.deepcopy(state)
    print("stepping", flush=True)
    summary = run(model, state, 3, progress=False)
    t = time.monotonic()
    assert_same_state(state, before)
    print(summary.interrupted, summary.steps, f"{t:.6f}", flush=True)
""")


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_real_signal_inside_a_long_step_stops_it_within_a_second(tmp_path, sig):
    """A step of up to 10^9 sweeps (tol 1e-14: it would take hours): SIGTERM / Ctrl-C sent
    2 s into it ends the run within a second, with the state before the step."""
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    proc = subprocess.Popen([sys.executable, str(script)], cwd=ROOT,
                            env={**os.environ, "PYTHONPATH": str(ROOT)},
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    def stepping():
        assert proc.stdout.readline().strip() == "stepping"
        time.sleep(2.0)

    _, sent, out, err = signal_child(proc, sig, before=stepping)
    assert proc.returncode == 0, err[-2000:]
    interrupted, steps, t = out.split()
    assert (interrupted, steps) == ("True", "0")
    assert float(t) - sent < 1.0          # CLOCK_MONOTONIC is system-wide
