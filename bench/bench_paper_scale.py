"""Issue 31 §5's paper-scale targets, one run each on two threads: the slope (wall time
against 30 min, end state against the seed spread) and the deposit in the mould at tol 1e-4
(steps at ``max_iter`` against 2 %).

``--test slope`` (the default) runs the report's `slope_w400_seed0` at the paper's scale
(`workbench.paper`, Scale "paper": 26 000 grains and a wire of 400 km·m⁻³, 28 900 bodies,
up to 4 000 steps of 0.05 ms, the slope test's tolerance 1e-4), and stops early when the
heap is at rest, as the report's runs do.  The end state is the heap's maximum slope with
the paper's fit (a cubic for 400 km·m⁻³), compared with the report's three seeds
(`bench/results/paper-scale-slope-20261202-0919-sweep.json`).  A seed's sample changed
since those runs (docs/prep.md, 2026-12-05), so the comparison is with the seeds' spread,
not with seed 0's heap.  Target: 30 min.

``--test mould`` runs the report's `deposit_w400_seed0` (the same sample relaxed under
gravity in its mould, up to 12 000 steps of 0.05 ms) at tol 1e-4 instead of the report's
2e-4, with the 25 % rule off, and counts the steps that stop at ``max_iter``.  Target: 2 %.
Its settling is compared with the report's three deposits at 2e-4.

Both run with ``threads=2`` and nothing else on the machine (the JSON's ``busy`` says).
``--contact-compliance ε`` runs either with compliant contacts
(:attr:`engine.model.Options.contact_compliance`; default 0, rigid, as the report).

Usage: python bench/bench_paper_scale.py [--test slope|mould] [--threads 2] [--seed 0]
                                         [--steps N] [--tol T] [--contact-compliance ε]
Writes bench/results/paper-{slope,mould}-YYYYMMDD-HHMM.json.  30-60 min each on 2 idle
cores.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))
sys.path.insert(0, HERE)

import record  # noqa: E402

REFERENCE = os.path.join(HERE, "results", "paper-scale-slope-20261202-0919-sweep.json")
#: test -> (the report's case name prefix, its experiment, the target)
TESTS = {"slope": ("slope_w400_seed", "slope_deposit", "wall time <= 30 min"),
         "mould": ("deposit_w400_seed", "gravity_deposit", "steps at max_iter <= 2 %")}
TARGET_SECONDS = 30 * 60
TARGET_SHARE = 0.02
#: the report's case's scalars kept as the reference
KEEP = ("max_slope_deg", "steps", "non_converged_share", "settlement", "at_rest",
        "steps_wall_time")


def reference(prefix):
    """{seed: the report's scalars} of its paper-scale runs of this case."""
    with open(REFERENCE) as f:
        cases = json.load(f)["cases"]
    out = {}
    for c in cases:
        p, r = c["params"], c.get("result") or {}
        if p["name"].startswith(prefix):
            out[p["seed"]] = dict({k: r[k] for k in KEEP if k in r}, tol=p.get("tol"))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--test", choices=tuple(TESTS), default="slope")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--steps", type=int, default=None,
                    help="at most this many steps (default: the report's; fewer for a sample)")
    ap.add_argument("--tol", type=float, default=None,
                    help="NLGS tolerance (default: 1e-4, the target's)")
    ap.add_argument("--contact-compliance", type=float, default=0.0,
                    help="the contacts' normal compliance ε (Options.contact_compliance; "
                         "default 0: rigid, as the report)")
    a = ap.parse_args()
    if a.threads < 1 or (a.steps is not None and a.steps < 1):
        ap.error(f"--threads and --steps must be >= 1, got {a.threads} and {a.steps}")
    if not 0.0 <= a.contact_compliance <= 1.0:
        ap.error(f"--contact-compliance must be in [0, 1], got {a.contact_compliance}")

    from engine import experiments
    from engine.io import read_history
    from workbench.paper.runner import _deposit_curves, _test_kwargs
    from workbench.paper.scales import SCALES

    prefix, test, target = TESTS[a.test]
    scale = SCALES["paper"]
    params = dict(scale.slope if a.test == "slope" else scale.deposit, threads=a.threads)
    full_steps = params["steps"]
    params["tol"] = 1e-4 if a.tol is None else a.tol
    params["frames"] = 0                            # the scalars only (frames: ~1 MB each)
    if a.contact_compliance:
        params["contact_compliance"] = a.contact_compliance
    if a.steps is not None:
        params["steps"] = a.steps
    if a.test == "slope":
        params["wire_density"] = 400e3
    else:
        params["max_nonconverged"] = 1.0            # count the steps, do not stop on them
    busy = record.Busy()
    with tempfile.TemporaryDirectory() as tmp:
        kw = _test_kwargs(test, "elastic", 1.0, a.seed, os.path.join(tmp, "run.h5"), 0, params)
        kw.update(progress=True, resume=False)
        t = time.perf_counter()
        res = getattr(experiments, test)(**kw)
        wall = time.perf_counter() - t
        sweeps = read_history(kw["history"], frames=False).iterations
        try:
            curves = _deposit_curves(res, test, "bench")
        except RuntimeError as e:                    # a short sample: no heap yet
            print(e)
            curves = {}
    conv = res.convergence
    # a run stopped early (--steps, Ctrl-C) decides only what it already makes certain
    full = (not conv.get("interrupted") and (params["steps"] >= full_steps
                                             or bool(getattr(res, "at_rest", False))))
    out = dict(machine=record.machine(), git=record.git_commit(), test=a.test,
               case=dict(test=test, wire="elastic", k=1.0, seed=a.seed, **params),
               bodies=int(res.params["n_sand"] + res.params["n_beads"]),
               steps=int(conv["steps"]), at_rest=bool(getattr(res, "at_rest", False)),
               wall_seconds=wall, stepping_seconds=conv.get("wall_time"),
               seconds_per_step=wall / conv["steps"],
               mean_sweeps=float(np.mean(sweeps)), max_sweeps=int(np.max(sweeps)),
               steps_at_max_iter=int(conv["non_converged"]),
               share_at_max_iter=float(conv["share"]),
               reference=dict(file=os.path.relpath(REFERENCE, os.path.join(HERE, "..")),
                              seeds={str(k): v for k, v in sorted(reference(prefix).items())}),
               target=target)
    if a.test == "slope":
        ours = curves.get("max_slope_deg", np.nan)
        slopes = np.array([v["max_slope_deg"] for v in out["reference"]["seeds"].values()])
        mean, sd = float(slopes.mean()), float(slopes.std(ddof=1))
        out.update(max_slope_deg=float(ours) if np.isfinite(ours) else None,
                   reference_mean_deg=mean, reference_sd_deg=sd,
                   within_seed_range=(bool(slopes.min() - sd <= ours <= slopes.max() + sd)
                                      if np.isfinite(ours) else None),
                   target_met=(False if wall > TARGET_SECONDS
                               else bool(wall <= TARGET_SECONDS) if full else None))
    else:
        sc = res.scalars()
        out.update(settlement=getattr(res, "settlement", None),
                   outcomes={k: sc.get(k) for k in ("tortuosity_before", "tortuosity_after",
                                                    "slack_share", "wall_force", "weight")},
                   # more steps at max_iter than 2 % of the most the run may take: certain;
                   # the target is at tol 1e-4 (a looser tol's run decides nothing)
                   target_met=(
                       None if params["tol"] > 1e-4
                       else False if out["steps_at_max_iter"] > TARGET_SHARE * params["steps"]
                       else bool(out["share_at_max_iter"] <= TARGET_SHARE) if full else None))
    out["busy"] = busy.finish()
    verdict = {True: "met", False: "NOT met",
               None: "not decided (a shorter run, or the mould at a tol above 1e-4)"}
    print(f"paper-scale {a.test} (seed {a.seed}, {out['bodies']} bodies, threads={a.threads}, "
          f"tol {params['tol']:g}, contact_compliance {a.contact_compliance:g}): "
          f"{out['steps']} steps in {wall / 60:.1f} min "
          f"({1e3 * out['seconds_per_step']:.0f} ms/step, {out['mean_sweeps']:.0f} sweeps/step, "
          f"{out['steps_at_max_iter']} steps at max_iter = {100 * out['share_at_max_iter']:.1f} %,"
          f" at rest: {out['at_rest']}); target {target}: {verdict[out['target_met']]}")
    if a.test == "slope":
        print(f"max slope (cubic) {out['max_slope_deg']} deg; the report's paper-scale seeds "
              f"{', '.join(f'{s:.1f}' for s in slopes)} deg (mean {mean:.1f} ± {sd:.1f})")
    else:
        print(f"settlement {out['settlement']}; the report's deposits (tol 2e-4): "
              + "; ".join(f"seed {k}: {v.get('steps')} steps, {v.get('settlement')}"
                          for k, v in out["reference"]["seeds"].items()))
    print(out["busy"]["note"])
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    path = os.path.join(HERE, "results", time.strftime(f"paper-{a.test}-%Y%m%d-%H%M.json"))
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    print("wrote", path)


if __name__ == "__main__":
    main()
