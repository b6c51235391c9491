"""Each wire solved as one chain (``Options.chain_solve``) on a real test, run three ways,
one after the other in this process, on one NLGS thread (four ways): the demo's TexSol cylinder
triaxial test (``--test cylinder``, the default: ``nscd demo``'s scale 0.1, 5 % axial
strain, seed 0, ElasticWire k = 1 N) or the slope deposit (``--test slope``: scale 0.05,
2 000 steps, ``--law rigid`` for the rigid wire of issue 31's probe):

* ``plain_hot2``: the tests' default solver (plain link sweeps, ``hot_sweeps=2``);
* ``plain_hot0``: plain link sweeps, ``hot_sweeps=0`` (``chains_hot0``'s peer);
* ``chains_hot0``: ``chain_solve=True``, ``hot_sweeps=0``;
* ``chains_hot2``: ``chain_solve=True`` with the default ``hot_sweeps=2``.

For each: wall time, recorded steps, mean NLGS sweeps per recorded step, steps at
max_iter, and the answer (cylinder: the final deviator q and wire equivalent stress; slope:
the maximum slope); the same seed, so the answers differ by the solver's path within its
tolerance, not by the seed spread.  ``--runs`` picks some of the four (for example
``plain_hot2,chains_hot2`` for a long run), and ``chains_anderson`` adds the chain solve
inside Anderson mixing (depth 4, ``hot_sweeps=0``).  ``--threads T`` runs them all on T NLGS
threads (the chains then in the parallel sweep's link phase).

Run:  .venv/bin/python bench/bench_chains.py [--test cylinder|slope] [--law elastic|rigid]
      [--scale S] [--strain E] [--steps N] [--runs plain_hot2,chains_hot2] [--threads T]
Writes bench/results/chains-<YYYYmmdd-HHMM>.json.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402

import record  # noqa: E402
from engine import io  # noqa: E402
from engine import laws  # noqa: E402
from engine.experiments import cylinder_triaxial, slope_deposit  # noqa: E402


#: The ways: name -> (chain_solve, hot_sweeps, anderson).
RUNS = {"plain_hot2": (False, 2, 0), "plain_hot0": (False, 0, 0), "chains_hot0": (True, 0, 0),
        "chains_hot2": (True, 2, 0), "chains_anderson": (True, 0, 4)}
#: The runs made when --runs is not given.
DEFAULT_RUNS = ("plain_hot2", "plain_hot0", "chains_hot0", "chains_hot2")


def one(name, a, out_dir, chain_solve, hot_sweeps, anderson):
    h = str(Path(out_dir) / f"{name}.h5")
    t0 = time.perf_counter()
    law = laws.RigidWire() if a.law == "rigid" else laws.ElasticWire(stiffness=1.0)
    if a.test == "cylinder":
        res = cylinder_triaxial(a.scale, axial_strain=a.strain, history=h, frames=0,
                                hot_sweeps=hot_sweeps, chain_solve=chain_solve, wire_law=law,
                                anderson=anderson, threads=a.threads, progress=False)
    else:
        res = slope_deposit(a.scale, steps=a.steps, history=h, frames=0, wire_law=law,
                            hot_sweeps=hot_sweeps, chain_solve=chain_solve, anderson=anderson,
                            threads=a.threads, progress=False, max_nonconverged=1.0)
    wall = time.perf_counter() - t0
    rec = io.read_history(h, frames=False)
    its = np.asarray(rec.iterations)
    conv = res.convergence
    out = dict(name=name, chain_solve=chain_solve, hot_sweeps=hot_sweeps, anderson=anderson,
               threads=a.threads, wall_s=wall,
               recorded_steps=int(its.size), sweeps_mean=float(its.mean()),
               sweeps_median=float(np.median(its)), sweeps_max=int(its.max()),
               steps=int(conv["steps"]), not_converged=int(conv["non_converged"]))
    if a.test == "cylinder":
        out.update(q_end_Pa=float(res.deviator[-1]),
                   wire_equivalent_end_Pa=float(res.wire_equivalent[-1]))
        out["answer"] = (f"q end {out['q_end_Pa'] / 1e3:.2f} kPa, wire eq. "
                         f"{out['wire_equivalent_end_Pa']:.1f} Pa")
    else:
        out.update(max_slope_deg=float(res.max_slope_deg))
        out["answer"] = f"max slope {out['max_slope_deg']:.1f} deg"
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--test", choices=("cylinder", "slope"), default="cylinder")
    ap.add_argument("--law", choices=("elastic", "rigid"), default="elastic")
    ap.add_argument("--scale", type=float, default=None,
                    help="sample scale (default 0.1 cylinder, 0.05 slope)")
    ap.add_argument("--strain", type=float, default=0.05, help="cylinder: axial strain")
    ap.add_argument("--steps", type=int, default=2000, help="slope: steps")
    ap.add_argument("--runs", default=",".join(DEFAULT_RUNS),
                    help=f"comma-separated, among {', '.join(RUNS)}")
    ap.add_argument("--threads", type=int, default=1, help="NLGS threads of every run")
    a = ap.parse_args(argv)
    if a.threads < 1:
        ap.error(f"--threads must be >= 1, got {a.threads}")
    names = [x.strip() for x in a.runs.split(",") if x.strip()]
    bad = [x for x in names if x not in RUNS]
    if bad or not names:
        ap.error(f"--runs: unknown {bad or a.runs!r}; choose among {', '.join(RUNS)}")
    if a.scale is None:
        a.scale = 0.1 if a.test == "cylinder" else 0.05
    busy = record.Busy()
    runs = {}
    with tempfile.TemporaryDirectory() as d:
        cylinder_triaxial(0.04, axial_strain=0.002, iso_max_steps=20, ramp_steps=10,
                          history=str(Path(d) / "warm.h5"), frames=0, progress=False)  # JIT
        for name in names:
            r = runs[name] = one(name, a, d, *RUNS[name])
            print(f"{name:12s} {r['wall_s']:6.1f} s, {r['steps']} steps, sweeps/recorded step "
                  f"mean {r['sweeps_mean']:.1f} (median {r['sweeps_median']:.0f}, max "
                  f"{r['sweeps_max']}), {r['not_converged']} at max_iter; {r['answer']}",
                  flush=True)
            if len(runs) < len(names):       # a long set: what is done is kept on disk
                partial = record.RESULTS / f"chains-{a.test}-{a.law}-partial.json"
                record.RESULTS.mkdir(parents=True, exist_ok=True)
                partial.write_text(json.dumps(dict(runs=runs, threads=a.threads,
                                                   scale=a.scale), indent=1))
    ratios = {}
    for hot in (0, 2):
        p, c = runs.get(f"plain_hot{hot}"), runs.get(f"chains_hot{hot}")
        if p and c:
            ratios[f"sweeps_plain_hot{hot}_over_chains_hot{hot}"] = p["sweeps_mean"] / c["sweeps_mean"]
            ratios[f"wall_plain_hot{hot}_over_chains_hot{hot}"] = p["wall_s"] / c["wall_s"]
    out = dict(benchmark="chains", test=a.test, law=a.law, scale=a.scale,
               axial_strain=a.strain if a.test == "cylinder" else None,
               steps=a.steps if a.test == "slope" else None, seed=0, threads=a.threads,
               machine=record.machine(), git=record.git_commit(), runs=runs,
               ratios=ratios,
               busy=busy.finish())
    print("ratios (plain / chains): " + ", ".join(f"{k} {v:.2f}" for k, v in out["ratios"].items()))
    print(f"busy: {out['busy'].get('note', out['busy'])}")
    print(f"wrote {record.write(f'chains-{a.test}-{a.law}', out)}")
    (record.RESULTS / f"chains-{a.test}-{a.law}-partial.json").unlink(missing_ok=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
