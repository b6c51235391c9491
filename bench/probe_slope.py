"""Where the paper-scale slope's sweeps go (issue 31 §5), from one state of the run.

    .venv/bin/python bench/probe_slope.py [--scale 1] [--warm 300] [--steps 10]
                                          [--sweeps 10000] [--repeats 2] [--threads-only]
                                          [--state-cache PATH]

The scene is the report's `slope_w400_seed0` (``slope_deposit``'s own builders: the slope
sample of seed 0 with its wire of 400 km·m⁻³, ElasticWire, on its floor of fixed beads,
h = 5e-5 s, tol 1e-4, ``hot_sweeps=2``), stepped ``--warm`` steps on two threads (or read
from ``--state-cache`` when that file exists; written there otherwise, a pickle).  From
that state:

1. **Threads**: ``--steps`` steps on one thread and on two, from the same state,
   ``--repeats`` times in turn; the time per full sweep of each (wall, so the machine must
   be quiet: the JSON's ``busy`` says).  ``--threads-only`` stops there.
2. **Sweeps of the solver variants** (counts, no timing conclusion): ``--steps`` steps on
   one thread with the default (``hot_sweeps=2``), over-relaxation ω = 1.2 and 1.3, and
   ``hot_sweeps=4``: sweeps per step and steps at ``max_iter``.
3. **The error field** of the next step (``probe_stagnation.probe_sweeps``): ``--sweeps``
   plain sweeps; at a few sweeps the Quad residual, the full ‖W Δp‖, how far the
   velocities are from the last sweep's, and at sweep 1 000 where that error sits.

JSON: bench/results/slope-probe-*.json.  About 10 min at ``--warm 300`` on two idle
cores (the warm-up is most of it: about 0.7 s a step at the paper's scale).
"""
from __future__ import annotations

import argparse
import os
import pickle
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

#: The variants of part 2: label -> options changed from the run's.
VARIANTS = {"default (hot_sweeps=2)": {}, "relax=1.2": dict(relax=1.2),
            "relax=1.3": dict(relax=1.3), "hot_sweeps=4": dict(hot_sweeps=4)}


def slope_scene(scale: float):
    """(model on two threads, start state) of ``slope_deposit``'s scene, as the report's
    `slope_w400_seed0` builds it: the test's own defaults (:class:`SlopeConfig`) but for
    the scale, the wire density, tol, dt and the thread count."""
    from engine.experiments.common import solver_choice
    from engine.experiments.config import SlopeConfig
    from engine.experiments.slope import _heap, _slope_start

    config = SlopeConfig.from_kwargs(scale=scale, wire_density=400e3, seed=0, dt=5e-5,
                                     tol=1e-4, threads=2)
    cfg = SimpleNamespace(**config.kwargs())
    cfg.anderson, cfg.hot_sweeps = solver_choice(cfg.anderson, cfg.hot_sweeps)
    st, cfg.law = _slope_start(cfg)
    heap = _heap(st, cfg)
    return heap.model, heap.state


def steps_from(model, state, n):
    """``n`` steps from a copy of ``state``: (wall s, sweeps per step, steps at max_iter)."""
    from engine import step

    s = state.copy()
    t = time.perf_counter()
    sweeps, missed = [], 0
    for _ in range(n):
        r = step(model, s)
        sweeps.append(r.iterations)
        missed += not r.converged
    return time.perf_counter() - t, float(np.mean(sweeps)), missed


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--warm", type=int, default=300, help="steps before the probed state")
    ap.add_argument("--steps", type=int, default=10, help="steps of parts 1 and 2")
    ap.add_argument("--sweeps", type=int, default=10000, help="plain sweeps of part 3")
    ap.add_argument("--repeats", type=int, default=2, help="part 1: turns of 1 and 2 threads")
    ap.add_argument("--threads-only", action="store_true", help="part 1 only")
    ap.add_argument("--state-cache", default=None,
                    help="read the warmed state from this pickle, or write it there")
    a = ap.parse_args(argv)
    if not 0 < a.scale <= 1 or a.warm < 0 or a.steps < 1 or a.sweeps < 1000 or a.repeats < 1:
        ap.error("--scale must be in (0, 1], --warm >= 0, --steps >= 1, --sweeps >= 1000, "
                 "--repeats >= 1")
    from record import Busy, git_commit, machine, write

    from bench_residual import prepared_step
    from engine import step
    from engine.solver import kernels as K
    from probe_stagnation import local_operator, probe_sweeps

    busy = Busy()
    model2, state = slope_scene(a.scale)
    cache = Path(a.state_cache) if a.state_cache else None
    warm_s = None
    if cache is not None and cache.exists():
        with open(cache, "rb") as f:
            state = pickle.load(f)
        if state.step != a.warm:
            ap.error(f"--state-cache {cache} holds step {state.step}, not --warm {a.warm}")
    else:
        t = time.perf_counter()
        for _ in range(a.warm):
            step(model2, state)
        warm_s = time.perf_counter() - t
        if cache is not None:
            tmp = cache.with_suffix(".tmp")
            with open(tmp, "wb") as f:
                pickle.dump(state, f)
            os.replace(tmp, cache)
    n = state.contacts_buf.count
    print(f"scale {a.scale}: {model2.n_bodies} bodies, state at step {state.step} "
          f"({n} contacts)", flush=True)
    model1 = model2.with_options(threads=1)
    steps_from(model2, state, 1)    # (compiles the two-thread kernels if they are not cached)
    threads = []
    for rep in range(a.repeats):
        for T, m in ((1, model1), (2, model2)):
            wall, sweeps, missed = steps_from(m, state, a.steps)
            row = dict(threads=T, repeat=rep, wall_s=wall, sweeps_per_step=sweeps,
                       at_max_iter=missed, ms_per_sweep=1e3 * wall / (sweeps * a.steps))
            threads.append(row)
            print(f"{T} thread(s): {wall:.2f} s, {sweeps:.1f} sweeps/step, "
                  f"{row['ms_per_sweep']:.3f} ms per sweep", flush=True)
    out = dict(machine=machine(), git=git_commit(), scale=a.scale, seed=0,
               state_step=int(state.step), warm_seconds=warm_s, bodies=model1.n_bodies,
               contacts=n, steps=a.steps, threads=threads)
    if a.threads_only:
        out["busy"] = busy.finish()
        print("wrote", write("slope-probe", out))
        return
    variants = {}
    for label, opts in VARIANTS.items():
        wall, sweeps, missed = steps_from(model1.with_options(**opts), state, a.steps)
        variants[label] = dict(options=opts, sweeps_per_step=sweeps, at_max_iter=missed,
                               wall_s=wall)
        print(f"{label}: {sweeps:.1f} sweeps/step, {missed} of {a.steps} at max_iter",
              flush=True)
    s, C, B, L = prepared_step(model1, state)
    c = s.contacts_buf
    nl = model1.n_links

    def sweep():
        return K.sweep_all(n, c.n_pair, nl, C, B, L, 1.0)

    H, _ = local_operator(model1, c, n)
    rows, field = probe_sweeps(model1, s, c, n, sweep, a.sweeps, H)
    for r in rows:
        print(f"sweep {r['sweep']:6d}: Quad {r['quad']:.2e}, full ||W dp|| "
              f"{r['full_change']:.2e}, velocities {r['velocity_error']:.3f} from the last "
              f"sweep's", flush=True)
    print("error field:", field)
    out.update(variants=variants, sweeps=rows, error_field=field, busy=busy.finish())
    print("wrote", write("slope-probe", out))


if __name__ == "__main__":
    main()
