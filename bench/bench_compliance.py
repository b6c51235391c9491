"""The mould deposit with compliant contacts against the rigid law (issue 31 §2).

    .venv/bin/python bench/bench_compliance.py [--scale 0.1] [--seeds 0,1,2] [--workers 2]

``gravity_deposit`` (the slope sample with its wire in its mould, h = 1e-4 s, θ = 0.5,
``hot_sweeps=2``, to rest) for each seed, three ways:

* ``rigid-2e-4``: the rigid law at tol 2e-4, as the report's paper-scale deposits ran;
* ``rigid-1e-4``: the rigid law at the default tol 1e-4 (the target's setting);
* ``eps-0.01``: ``contact_compliance=0.01`` at tol 1e-4.

Every step is recorded (``record_every=1``): its sweeps, whether it converged, its largest
overlap.  The 25 % rule is off (``max_nonconverged=1``), so that each run goes to rest and
its share of steps at ``max_iter`` is counted.

The criterion, fixed before the runs: the compliant deposit gives the rigid law's physics
when, for the wire's tortuosity after the deposit, its amplification (after / before), the
settlement and the share of slack links, the difference of the seed means of ``eps-0.01``
and ``rigid-2e-4`` is within two standard errors of that difference (each run's seeds'
standard deviation over √seeds, added in quadrature).  It cures the stagnation when at most
2 % of its steps stop at ``max_iter``.

Counts, residuals and outcomes; the wall times are reported but several runs share the
cores (``--workers``), so they compare runs of the same JSON only.  JSON:
bench/results/compliance-*.json.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
for p in (str(HERE.parent), str(HERE)):
    if p not in sys.path:
        sys.path.insert(0, p)

import numpy as np  # noqa: E402

from record import Busy, machine, write  # noqa: E402

#: name: (contact_compliance, tol)
RUNS = {"rigid-2e-4": (0.0, 2e-4), "rigid-1e-4": (0.0, 1e-4), "eps-0.01": (0.01, 1e-4)}
#: The outcomes the criterion compares (``DepositResult.scalars()`` keys, and the ratio).
OUTCOMES = ("tortuosity_after", "amplification", "settlement", "slack_share")


def one(args):
    """One deposit: ``(name, seed, scale, folder)`` -> its row."""
    import h5py

    from engine.experiments import gravity_deposit

    name, seed, scale, folder = args
    eps, tol = RUNS[name]
    h5 = str(Path(folder) / f"{name}-{seed}.h5")
    t = time.perf_counter()
    r = gravity_deposit(scale, seed=seed, tol=tol, contact_compliance=eps, record_every=1,
                        max_nonconverged=1.0, history=h5, progress=False)
    wall = time.perf_counter() - t
    with h5py.File(h5, "r") as f:
        it = f["records/iterations"][:]
        ov = f["records/max_overlap"][:]
    row = {k: (float(v) if isinstance(v, (float, np.floating)) else v)
           for k, v in r.scalars().items() if k != "history"}
    row.update(name=name, seed=seed, contact_compliance=eps, tol=tol, wall_s=wall,
               sweeps_total=int(it.sum()), sweeps_per_step=float(it.mean()),
               max_overlap=float(ov.max()), median_step_max_overlap=float(np.median(ov)),
               amplification=row["tortuosity_after"] / row["tortuosity_before"])
    print(f"{name} seed {seed}: {r.convergence['steps']} steps, {row['non_converged']} at "
          f"max_iter ({100 * row['non_converged_share']:.1f} %), {row['sweeps_per_step']:.0f} "
          f"sweeps/step, xi {row['tortuosity_before']:.0f} -> {row['tortuosity_after']:.0f} 1/m, "
          f"settlement {1e6 * row['settlement']:.1f} um, slack {row['slack_share']:.3f}, "
          f"max overlap {row['max_overlap']:.2e}, {wall:.0f} s", flush=True)
    return row


def compare(rows, a="eps-0.01", b="rigid-2e-4"):
    """The criterion of the module doc: {outcome: dict(mean_a, mean_b, diff, two_se, same)}."""
    out = {}
    for k in OUTCOMES:
        xa = np.array([r[k] for r in rows if r["name"] == a], float)
        xb = np.array([r[k] for r in rows if r["name"] == b], float)
        if xa.size < 2 or xb.size < 2:
            return None
        two_se = 2.0 * np.sqrt(xa.var(ddof=1) / xa.size + xb.var(ddof=1) / xb.size)
        d = xa.mean() - xb.mean()
        out[k] = dict(mean=float(xa.mean()), mean_reference=float(xb.mean()), diff=float(d),
                      two_se=float(two_se), same=bool(abs(d) <= two_se))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=0.1)
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--runs", default=",".join(RUNS), help=f"among {', '.join(RUNS)}")
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args(argv)
    seeds = [int(s) for s in a.seeds.split(",") if s.strip()]
    names = [n for n in a.runs.split(",") if n.strip()]
    bad = [n for n in names if n not in RUNS]
    if bad or not seeds or a.workers < 1 or not 0 < a.scale <= 1:
        ap.error(f"--runs among {', '.join(RUNS)} (got {bad}), --seeds a list of integers, "
                 f"--workers >= 1, --scale in (0, 1]")
    busy = Busy()
    with tempfile.TemporaryDirectory() as folder:
        jobs = [(n, s, a.scale, folder) for s in seeds for n in names]
        with ProcessPoolExecutor(a.workers) as ex:
            rows = list(ex.map(one, jobs))
    verdict = compare(rows)
    if verdict:
        for k, v in verdict.items():
            print(f"{k}: eps-0.01 {v['mean']:.4g} against rigid-2e-4 {v['mean_reference']:.4g}"
                  f" (diff {v['diff']:.3g}, 2 SE {v['two_se']:.3g}): "
                  f"{'same' if v['same'] else 'DIFFERENT'}")
    out = dict(machine=machine(), scale=a.scale, seeds=seeds, runs={n: RUNS[n] for n in names},
               workers=a.workers, rows=rows, criterion=verdict, busy=busy.finish())
    print("wrote", write("compliance", out))


if __name__ == "__main__":
    main()
