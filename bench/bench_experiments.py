"""Experiments benchmark (issue 7): wall time and steps of each of the paper's tests at the
largest scale run here, and the time projected for scale 1 (the paper's size).

Projection: cost ∝ bodies × steps × mean NLGS sweeps per step, the sweeps taken as measured
(they grow with the sample, so the projection is a lower bound when the solver is the
bottleneck).  Targets: cylinder triaxial at scale 1 under 10 min; slope under 1 h.

Usage: python bench/bench_experiments.py [--scale-cyl 0.2] [--scale-box 0.2] [--scale-slope 0.1]
                                        [--tests cylinder_triaxial,box_triaxial,slope_deposit]
                                        [--threads T] [--slope-steps N] [--hot-sweeps H]
                                        [--anderson M]

``--slope-steps N`` stops the slope deposit after N steps (default: the paper's 4 000, or
rest): a timing sample of the first N steps, e.g. to compare thread counts at scale 1.
``--hot-sweeps H`` runs every test with ``hot_sweeps=H`` and ``--anderson M`` with
``anderson=M`` (hot re-sweeps then off) instead of the tests' default ``hot_sweeps=2``
(``anderson=4`` was the default until 2026-11-25; docs/speed.md).
Writes bench/results/experiments-YYYYMMDD-HHMM.json.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import record  # noqa: E402

from engine.experiments import box_triaxial, cylinder_triaxial, slope_deposit  # noqa: E402
from engine.io import read_history  # noqa: E402

# the paper's sizes: bodies, and the steps of the paper's run
PAPER = {"cylinder_triaxial": (7300, 2000), "box_triaxial": (8000, 100000),
         "slope_deposit": (28900, 4000)}


def measure(name, fn, scale, tmp, threads=1, **kw):
    path = os.path.join(tmp, f"{name}.h5")
    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = fn(scale, history=path, progress=True, threads=threads, **kw)
    wall = time.perf_counter() - t
    h = read_history(path, frames=False)
    bodies = r.params["n_sand"] + r.params["n_beads"]
    steps = r.convergence["steps"]
    sweeps = float(np.mean(h.iterations)) if h.n_records else float("nan")
    pb, ps = PAPER[name]
    per_body_step = wall / (bodies * steps)
    row = dict(test=name, scale=scale, bodies=bodies, steps=steps, wall_seconds=wall,
               seconds_per_step=wall / steps, mean_sweeps=sweeps,
               non_converged_share=r.convergence["share"], anderson=r.params.get("anderson"),
               hot_sweeps=r.params.get("hot_sweeps"),
               threads=threads, interrupted=r.convergence.get("interrupted"),
               step_limit=kw.get("steps"),
               stepping_seconds=r.convergence.get("wall_time"),
               setup_seconds=wall - r.convergence.get("wall_time", 0.0),
               seconds_per_step_stepping=r.convergence.get("wall_time", wall) / steps,
               at_rest=getattr(r, "at_rest", None),
               paper_bodies=pb, paper_steps=ps,
               projected_scale1_seconds_for_our_steps=per_body_step * pb * steps,
               projected_scale1_seconds_for_paper_steps=per_body_step * pb * ps)
    print(f"{name:18s} scale {scale:5.3f}: {bodies:6d} bodies, {steps:6d} steps, {wall:7.1f} s "
          f"({1e3 * wall / steps:.1f} ms/step; stepping alone "
          f"{1e3 * row['seconds_per_step_stepping']:.1f} ms/step, {sweeps:.0f} sweeps/step, "
          f"{r.convergence['share']:.0%} not converged); projected at scale 1 "
          f"({pb} bodies × {ps} steps): {per_body_step * pb * ps / 60:.1f} min")
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale-cyl", type=float, default=0.2)
    ap.add_argument("--scale-box", type=float, default=0.1)
    ap.add_argument("--scale-slope", type=float, default=0.1)
    ap.add_argument("--tests", default="cylinder_triaxial,box_triaxial,slope_deposit",
                    help="comma-separated subset of the three tests")
    ap.add_argument("--threads", type=int, default=1,
                    help="NLGS threads of every test (docs/speed.md: 2 pays on large samples)")
    ap.add_argument("--hot-sweeps", type=int, default=None,
                    help="run with this many hot re-sweeps (default: the tests' 2)")
    ap.add_argument("--anderson", type=int, default=0,
                    help="run with Anderson mixing of this depth (hot re-sweeps off)")
    ap.add_argument("--slope-steps", type=int, default=None,
                    help="stop the slope deposit after this many steps (a timing sample)")
    a = ap.parse_args()
    if a.slope_steps is not None and a.slope_steps < 1:
        ap.error(f"--slope-steps must be >= 1, got {a.slope_steps}")
    tests = [t.strip() for t in a.tests.split(",") if t.strip()]
    known = {"cylinder_triaxial": (cylinder_triaxial, a.scale_cyl),
             "box_triaxial": (box_triaxial, a.scale_box),
             "slope_deposit": (slope_deposit, a.scale_slope)}
    bad = [t for t in tests if t not in known]
    if bad:
        ap.error(f"--tests: unknown {bad}; choose among {sorted(known)}")
    busy = record.Busy()
    out = {"machine": record.machine(), "git": record.git_commit(), "runs": []}
    with tempfile.TemporaryDirectory() as tmp:
        for t in tests:
            fn, scale = known[t]
            kw = {"steps": a.slope_steps} if t == "slope_deposit" and a.slope_steps else {}
            if a.anderson:
                kw.update(anderson=a.anderson)
            if a.hot_sweeps is not None:
                kw.update(hot_sweeps=a.hot_sweeps)
            out["runs"].append(measure(t, fn, scale, tmp, a.threads, **kw))
    out["targets_seconds"] = {"cylinder_triaxial": 600, "slope_deposit": 3600}
    out["busy"] = busy.finish()
    os.makedirs(os.path.join(os.path.dirname(__file__), "results"), exist_ok=True)
    path = os.path.join(os.path.dirname(__file__), "results",
                        time.strftime("experiments-%Y%m%d-%H%M.json"))
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    print("wrote", path)


if __name__ == "__main__":
    main()
