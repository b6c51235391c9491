"""Freezing the contacts that do not change, measured (issue 31 §3).

    .venv/bin/python bench/bench_freeze.py [--quick]

Siconos's contact freezing skips, for a while, the contacts whose impulse has stopped
changing; our hot re-sweeps (``Options.hot_sweeps``) are the other half of the same idea:
after each full sweep, only the contacts whose ‖W Δp‖² exceeded ``factor`` × the mean are
swept again, ``H`` times, and the others are in effect frozen until the next full sweep,
which alone decides convergence (the same stopping test).  With a small ``factor`` the
re-swept set is every contact that still changes, the frozen ones are those that have
stopped: a freezing policy.  This benchmark solves the same steps from the same states
with ``factor`` from 2 (the engine's, :data:`engine.solver.kernels.HOT_FACTOR`) down to
0.01 and ``H`` in 0..8, and counts the work exactly: contact updates (n per full sweep plus
the re-swept contacts), full sweeps, and whether the step reached tol.  One contact update
costs about the same in a full sweep and in a re-sweep (the same kernel), so the updates
are the cost; no wall time is taken (the machine may be shared).

States: the peers' deposit (bench/peers, h = 5e-5 s, tol 1e-4) in its dense phase, and the
mould deposit of ``gravity_deposit`` (slope sample with its wire, scale 0.1) during and
after its settling transient (docs/speed.md, "Why the mould deposit stagnates").
JSON: bench/results/freeze-*.json.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
for p in (str(HERE.parent), str(HERE), str(HERE / "peers")):
    if p not in sys.path:
        sys.path.insert(0, p)

import numpy as np  # noqa: E402

from bench_residual import mould_model, peers_model, prepared_step  # noqa: E402
from engine import step  # noqa: E402
from engine.solver import kernels as K  # noqa: E402
from record import Busy, machine, write  # noqa: E402

FACTORS = (2.0, 1.0, 0.5, 0.1, 0.01)
SWEEPS = (0, 2, 4, 8)


def solve_counting(model, state, factor, hot_sweeps, max_iter):
    """One step's solve from ``state`` (not modified) with the hot re-sweeps at ``factor``
    and ``hot_sweeps``, counting contact updates; the loop of kernels._iterate_hot."""
    s, C, B, L = prepared_step(model, state)
    c = s.contacts_buf
    n, nl, o = c.count, model.n_links, model.options
    q = np.empty(n)
    hot = np.empty(n, np.int32)
    bounds = np.full(1, c.n_pair, np.int64)
    hbounds = np.empty(1, np.int64)
    updates = 0
    res = np.inf
    for it in range(max_iter):
        num, den = K._full(n, c.n_pair, q, C, B, 1.0, False, True)
        res = K.links_then_residual(num, den, nl, L, B, 1.0)
        updates += n
        if res < o.tol:
            return dict(full_sweeps=it + 1, updates=updates, residual=float(res),
                        converged=True, contacts=int(n))
        if hot_sweeps:
            m = K.hot_list(n, q, factor, hot, bounds, hbounds)
            updates += hot_sweeps * int(m)
            K.resweep_hot(n, q, factor, hot, bounds, hbounds, hot_sweeps, C, B, 1.0, False)
    return dict(full_sweeps=max_iter, updates=updates, residual=float(res), converged=False,
                contacts=int(n))


def states_at(model, state, steps_at, label):
    """{"label, step k": the state before step k} for k in ``steps_at``, stepping on."""
    out = {}
    for k in range(max(steps_at) + 1):
        if k in steps_at:
            out[f"{label}, step {k}"] = state.copy()
        step(model, state)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--max-iter", type=int, default=3000)
    a = ap.parse_args(argv)
    busy = Busy()
    cases = []
    import common
    m1, s1 = peers_model(common.PARAMS["tol"], hot_sweeps=2)
    st1 = states_at(m1, s1, (300,) if a.quick else (700, 1000, 1300), "peers deposit")
    cases += [(m1, k, v) for k, v in st1.items()]
    scale = 0.05 if a.quick else 0.1
    m2, s2 = mould_model(scale, True, hot_sweeps=2)
    st2 = states_at(m2, s2, (20,) if a.quick else (50, 160, 250),
                    f"mould deposit scale {scale}")
    cases += [(m2, k, v) for k, v in st2.items()]
    rows = []
    for model, name, state in cases:
        base = None
        for H in SWEEPS:
            for f in (FACTORS if H else (2.0,)):
                r = solve_counting(model, state, f, H, a.max_iter)
                r.update(state=name, factor=f, hot_sweeps=H)
                if H == 2 and f == 2.0:
                    base = r
                rows.append(r)
        for r in rows:
            if r["state"] == name:
                r["updates_vs_engine_default"] = r["updates"] / base["updates"]
        best = min((r for r in rows if r["state"] == name and r["converged"]),
                   key=lambda r: r["updates"], default=None)
        print(f"{name}: {base['contacts']} contacts; engine's (factor 2, H 2): "
              f"{base['full_sweeps']} full sweeps, {base['updates']:.3g} updates"
              f"{'' if base['converged'] else ' (max_iter)'}; plain: "
              f"{next(r for r in rows if r['state'] == name and r['hot_sweeps'] == 0)['updates']:.3g}; "
              + (f"fewest: factor {best['factor']:g}, H {best['hot_sweeps']}: "
                 f"{best['updates']:.3g} ({best['updates_vs_engine_default']:.2f}x)"
                 if best else "none converged"), flush=True)
    out = dict(machine=machine(), busy=busy.finish(), max_iter=a.max_iter,
               factors=FACTORS, hot_sweeps=SWEEPS, rows=rows)
    path = write("freeze", out, quick=a.quick)
    print(f"-> {path}")


if __name__ == "__main__":
    main()
