"""Study: the decomposition of the gap between a TexSol sample and the sand, on a fair basis.

For every seed, pressure and preparation, the cylinder triaxial test of the chain of
``workbench.reinforcement.CHAIN``: the sand sample; the matched sand (the TexSol sample's
sand, laid around its beads, prepared and tested without them); the TexSol sample with its
links loose (the beads as bodies, no link force); the TexSol sample; and beside the chain,
the TexSol packing with its beads taken out at the start of the loading.  Every sample is
measured on one basis: the membrane wraps grains and beads.  Each step's Δq/q against the
one before it, paired by seed, at 2, 5 and 10 % strain and at the peak, with two standard
errors.

The criterion, fixed before the runs: a step adds (or removes) strength when its Δq/q is
above (below) zero by more than two standard errors.

Resumable (a ``workbench.campaign.sweep`` table, ``--table``, default
``bench/results/chain-table-scale<S>.json``); at the end the summary goes to
``bench/results/chain-<date>.json`` and ``.md``.

Usage:
  python bench/study_chain.py [--scale 0.3] [--seeds 0,1,2] [--pressures 15e3,2e3]
                              [--preparations paper,geometric] [--wire elastic --k 1]
                              [--strain 0.1] [--workers 2|1] [--summary-only]
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import record  # noqa: E402


def _floats(text):
    return [float(x) for x in text.split(",") if x.strip()]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=0.3)
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--pressures", default="15e3", help="[Pa], comma-separated")
    ap.add_argument("--preparations", default="paper")
    ap.add_argument("--wire", default="elastic", choices=("elastic", "rigid"))
    ap.add_argument("--k", type=float, default=1.0, help="[N] (elastic)")
    ap.add_argument("--strain", type=float, default=0.1)
    ap.add_argument("--no-side", action="store_true",
                    help="leave out the packing with its beads removed at the loading")
    ap.add_argument("--workers", type=int, default=2, choices=(1, 2))
    ap.add_argument("--overlap-tol", default="default",
                    help="the position correction's overlap_tol of every case (none: off; "
                         "default: the engine's, written into the cases; legacy: no "
                         "overlap_tol in the cases, the keys of the tables run before it)")
    ap.add_argument("--table", default=None)
    ap.add_argument("--runs", default="out/chain_runs", help="the histories (not committed)")
    ap.add_argument("--summary-only", action="store_true")
    a = ap.parse_args(argv)
    from workbench.campaign import load_table, sweep
    from workbench.reinforcement import (chain_case, chain_cases, chain_markdown, rescore,
                                         summarize_chain)

    seeds = [int(s) for s in a.seeds.split(",")]
    preps = [p.strip() for p in a.preparations.split(",") if p.strip()]
    from engine.model import OVERLAP_TOL

    ov = {} if a.overlap_tol == "legacy" else {"overlap_tol": (
        OVERLAP_TOL if a.overlap_tol == "default" else None if a.overlap_tol == "none"
        else float(a.overlap_tol))}
    todo = chain_cases(seeds, a.scale, pressures=_floats(a.pressures), preparations=preps,
                       wire=a.wire, k=a.k if a.wire == "elastic" else None,
                       axial_strain=a.strain, side=not a.no_side, **ov)
    table_path = a.table or os.path.join(record.RESULTS, f"chain-table-scale{a.scale:g}.json")
    runs_dir = os.path.join(a.runs, f"scale{a.scale:g}")
    busy = record.Busy()
    if a.summary_only:
        table = load_table(table_path)
        table.rows = [r for r in table.rows if r["params"] in todo]
    else:
        table = sweep(chain_case, todo, None if a.workers > 1 else "serial", out=table_path,
                      fixed={"runs_dir": runs_dir}, n_workers=a.workers, hdf5=False,
                      progress=True)
    print(table)
    rows = [(r["params"], rescore(r["params"]["name"], r["result"], runs_dir))
            for r in table.done]
    summary = summarize_chain(rows)
    md = chain_markdown(summary)
    print(md)
    out = dict(benchmark="chain", machine=record.machine(), busy=busy.finish(),
               git=record.git_commit(), table=os.path.relpath(table_path),
               params=dict(scale=a.scale, seeds=seeds, pressures=_floats(a.pressures),
                           preparations=preps, wire=a.wire, k=a.k, axial_strain=a.strain,
                           workers=a.workers, summary_only=a.summary_only),
               criterion="a step adds strength when its Δq/q is above 0 by more than 2 SE",
               n_done=len(table.done), failed=[r["id"] for r in table.failed],
               summary=summary, runs={p["name"]: r for p, r in rows})
    path = record.write("chain", out)
    Path(str(path).replace(".json", ".md")).write_text(md)
    print(path)


if __name__ == "__main__":
    main()
