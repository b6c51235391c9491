"""Study (issue 30): when does the wire reinforce the sand?  The cylinder triaxial test of
every case of ``workbench.reinforcement.FACTORS`` (one factor at a time from the paper's
baseline, each wire run against the sand run of the same seed), as a ``campaign.sweep``.

Resumable: the sweep's table (``--table``, default
``bench/results/reinforcement-table-scale<S>.json``) keeps every finished case, and a run of
the same command skips them; stop it (Ctrl-C) or lose the session and run it again.  At the
end: the summary (Δq/q at 2, 5, 10 % strain with two standard errors, per factor and level)
in ``bench/results/reinforcement-YYYYMMDD-HHMM.json`` and the figure beside it
(``--figure`` also writes it where the docs show it).

Usage:
  python bench/study_reinforcement.py [--scale 1] [--seeds 0,1,2] [--workers 2|1]
                                      [--factors "law, paper preparation",...] [--figure PNG]
  python bench/study_reinforcement.py --quick     # scale 0.05, 2 % strain, seed 0: a smoke run
At scale 1 (6 200 grains, 10 % strain) a case takes about 3 min, 5-6 with the paper's
preparation (its deposit in the mould); the 57 cases of 3 seeds about 2.5 h on 2 workers.
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import record  # noqa: E402


def main(argv=None):
    from workbench.reinforcement import FACTORS

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--workers", type=int, default=2, choices=(1, 2),
                    help="2: campaign.sweep's LocalCluster; 1: one case after the other")
    ap.add_argument("--factors", default=None,
                    help=f"a comma-free list separated by ';' of: {'; '.join(FACTORS)}")
    ap.add_argument("--table", default=None)
    ap.add_argument("--runs", default="out/reinforcement_runs",
                    help="where the cases' histories go (not committed)")
    ap.add_argument("--figure", default=None, help="also write the Δq/q figure here")
    ap.add_argument("--summary-only", action="store_true",
                    help="no run: the summary of the cases the table holds (while a sweep "
                         "writes it, or after)")
    ap.add_argument("--quick", action="store_true",
                    help="scale 0.05, 2 %% strain, seed 0, the law factors only")
    a = ap.parse_args(argv)
    from campaign import sweep
    from workbench.reinforcement import cases, figure, rescore, summarize

    scale, strain = (0.05, 0.02) if a.quick else (a.scale, 0.1)
    seeds = [0] if a.quick else [int(s) for s in a.seeds.split(",")]
    factors = None
    if a.factors:
        factors = [f.strip() for f in a.factors.split(";") if f.strip()]
        bad = [f for f in factors if f not in FACTORS]
        if bad:
            ap.error(f"--factors: unknown {bad}; known: {list(FACTORS)}")
    elif a.quick:
        factors = ["law, paper preparation"]
    todo = cases(seeds, scale, factors=factors, axial_strain=strain)
    table_path = a.table or os.path.join(
        record.RESULTS, f"reinforcement-table-scale{scale:g}{'-quick' if a.quick else ''}.json")
    busy = record.Busy()
    from workbench.reinforcement import case

    runs_dir = os.path.join(a.runs, f"scale{scale:g}")
    if a.summary_only:
        from campaign import load_table

        table = load_table(table_path)
        table.rows = [r for r in table.rows if r["params"] in todo]
    else:
        table = sweep(case, todo, None if a.workers > 1 else "serial", out=table_path,
                      fixed={"runs_dir": runs_dir}, n_workers=a.workers, hdf5=False,
                      progress=True)
    print(table)
    # q at each strain recomputed from the histories where they are here (cases run before
    # the strain slack of workbench.reinforcement.STRAIN_SLACK missed q at 10 %)
    rows = [(r["params"], rescore(r["params"]["name"], r["result"], runs_dir))
            for r in table.done]
    # kept in the table, so a later summary without the histories (a fresh clone, another
    # machine) gives the same figures
    fresh = {r["id"]: res for r, (_, res) in zip(table.done, rows)
             if res.get("rescored") and res != r["result"]}
    if fresh:
        from campaign import update_results

        update_results(table_path, fresh)
        print(f"{len(fresh)} rescored results kept in {table_path}")
    summary = summarize(rows)
    for factor, levels in summary["factors"].items():
        for label, lv in levels.items():
            cells = []
            for tag in ("2", "5", "10"):
                st = lv[f"dq_{tag}"]
                cells.append(f"{100 * st['mean']:+6.1f} ± {100 * st['two_se']:4.1f} %"
                             if st["n"] else "      —      ")
            print(f"{factor[:28]:28s} {label[:26]:26s} n={len(lv['seeds'])}  " + "  ".join(cells)
                  + f"  σw0 {lv['wire_eq_start']['mean']:7.1f} Pa"
                  + f"  taut {lv['taut_share']['mean']:.2f}")
    out = dict(benchmark="reinforcement", machine=record.machine(), busy=busy.finish(),
               git=record.git_commit(), table=os.path.relpath(table_path),
               params=dict(scale=scale, axial_strain=strain, seeds=seeds, factors=factors,
                           workers=a.workers, summary_only=a.summary_only),
               n_done=len(table.done), failed=[r["id"] for r in table.failed],
               summary=summary, runs={p["name"]: r for p, r in rows})
    path = record.write("reinforcement", out, quick=a.quick)
    print(path)
    from workbench.reinforcement import markdown_table

    md = markdown_table(summary)
    Path(str(path).replace(".json", ".md")).write_text(md)
    print(md)
    png = figure(summary, str(path).replace(".json", ".png"))
    if a.figure:
        figure(summary, a.figure)
    print(png)


if __name__ == "__main__":
    main()
