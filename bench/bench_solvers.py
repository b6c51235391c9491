"""Solver options benchmark (issue 9, item 5: every knob that trades speed measured): the
1 000-sphere deposit of ``make bench-peers`` run to rest with plain Gauss–Seidel,
Anderson mixing (``anderson=4``, the experiments' default until 2026-11-25), re-sweeps of the hot
contacts (``hot_sweeps``) and over-relaxation (``relax`` > 1, alone and with the re-sweeps),
at the paper's step and at a 10x larger one.

Run:  .venv/bin/python bench/bench_solvers.py            (about 6 min, one thread)
      .venv/bin/python bench/bench_solvers.py --quick    (h = 5e-4 s only, ~30 s)

Writes bench/results/solvers-YYYYMMDD-HHMM.json.

The start is ``bench/peers/ours.py init``'s loose lattice (bench_core's deposit, same seed);
the scene, tolerance (1e-4) and sweep cap (1 000) are those of the peers comparison.  Each
run goes until the spheres' kinetic energy drops below 1e-4 of its peak (or ``--cap-s``),
and reports the wall time, steps, full sweeps per step (re-sweeps not counted), steps at
``max_iter`` and the final mean height (the rest state: runs that take different paths
through a chaotic deposit end within about 1 % of each other).  One run per setting: the
machine's noise shows in ``busy``.
"""
from __future__ import annotations

import argparse
import datetime
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
for _p in (str(ROOT), str(ROOT / "bench"), str(ROOT / "bench" / "peers")):
    if _p not in sys.path:
        sys.path.insert(0, _p)

import numpy as np  # noqa: E402

import record  # noqa: E402

#: (label, options) of the settings compared.
SETTINGS = [("plain", dict(anderson=0, hot_sweeps=0)),
            ("anderson=4", dict(anderson=4, hot_sweeps=0)),
            ("hot_sweeps=2", dict(anderson=0, hot_sweeps=2)),
            ("hot_sweeps=3", dict(anderson=0, hot_sweeps=3)),
            ("relax=1.4", dict(anderson=0, hot_sweeps=0, relax=1.4)),
            ("hot_sweeps=2,relax=1.3", dict(anderson=0, hot_sweeps=2, relax=1.3)),
            ("hot_sweeps=2,relax=1.4", dict(anderson=0, hot_sweeps=2, relax=1.4))]


def to_rest(init, dt, opts, cap_s, max_steps=10**9):
    """Run one setting from the init state to rest; returns its figures."""
    import common
    import ours
    from engine import step

    _, model, state, _ = ours.build(init, dt, opts["anderson"])
    model = model.with_options(hot_sweeps=opts["hot_sweeps"], relax=opts.get("relax", 1.0))
    sph = model.sphere_ids
    m, inertia = common.masses(model.body_radius[sph], common.PARAMS["density"])
    peak = 0.0
    its, capped, ke = [], 0, np.inf
    t0 = time.perf_counter()
    at_rest = False
    while time.perf_counter() - t0 < cap_s and len(its) < max_steps:
        s = step(model, state)
        its.append(s.iterations)
        capped += not s.converged
        v = state.vel6[sph]
        ke = 0.5 * float(np.dot(m, (v[:, :3] ** 2).sum(1)) + np.dot(inertia, (v[:, 3:] ** 2).sum(1)))
        peak = max(peak, ke)
        if peak > 0.0 and ke < 1e-4 * peak:
            at_rest = True
            break
    wall = time.perf_counter() - t0
    z = state.position[sph, 2]
    return dict(dt_s=dt, options=opts, at_rest=at_rest, wall_s=wall, steps=len(its),
                full_sweeps_per_step=float(np.mean(its)), steps_at_max_iter=capped,
                mean_height_m=float(z.mean()), cap_s=cap_s)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="the larger step only")
    ap.add_argument("--cap-s", type=float, default=300.0)
    a = ap.parse_args(argv)
    import numba
    import ours

    numba.set_num_threads(1)
    t_all = time.perf_counter()
    started = datetime.datetime.now().isoformat(timespec="seconds")
    busy = record.Busy()
    ours.warm()
    tmp = tempfile.TemporaryDirectory()
    init = str(Path(tmp.name) / "init.json")
    ours.cmd_init(argparse.Namespace(out=init))
    # compile every path once (numba cache loads), not timed
    for _, opts in SETTINGS:
        to_rest(init, 5e-4, opts, 60.0, max_steps=3)
    dts = [5e-4] if a.quick else [5e-5, 5e-4]
    rows = []
    for dt in dts:
        for label, opts in SETTINGS:
            r = to_rest(init, dt, opts, a.cap_s)
            r["label"] = label
            rows.append(r)
            print(f"h = {dt:g} s  {label:22s}: {'at rest' if r['at_rest'] else 'NOT at rest'} "
                  f"after {r['steps']} steps in {r['wall_s']:.1f} s, "
                  f"{r['full_sweeps_per_step']:.0f} full sweeps/step, "
                  f"{r['steps_at_max_iter']} at max_iter, mean height "
                  f"{1e3 * r['mean_height_m']:.4f} mm", flush=True)
    tmp.cleanup()
    summary = {}
    for dt in dts:
        by = {r["label"]: r for r in rows if r["dt_s"] == dt}
        summary[f"h={dt:g}"] = {
            k: dict(wall_s=v["wall_s"], speedup_over_plain=by["plain"]["wall_s"] / v["wall_s"],
                    speedup_over_anderson4=by["anderson=4"]["wall_s"] / v["wall_s"])
            for k, v in by.items()}
    out = dict(benchmark="solvers", started=started,
               command="cd " + str(ROOT) + " && .venv/bin/python bench/bench_solvers.py "
                       + " ".join(sys.argv[1:] if argv is None else list(argv)),
               machine=record.machine(), busy=busy.finish(), git=record.git_commit(),
               params=dict(tol=1e-4, max_iter=1000, rest_ratio=1e-4, cap_s=a.cap_s),
               runs=rows, summary=summary, total_wall_s=time.perf_counter() - t_all)
    path = record.write("solvers", out, quick=a.quick)
    print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
