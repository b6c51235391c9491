"""Sweep benchmark (issue 10): the Table 2 sweep (cylinder triaxial, the paper's 10 wire
stiffnesses k + the rigid wire) on a LocalCluster of 2 workers against the same cases one by
one in one process, and the wall time of the default-scale report (`nscd paper`).

The cases are those of `nscd paper` at the chosen scale (``workbench.paper.SCALES``); the
serial and the distributed run each start from an empty table, and the results are checked
to be identical (same numbers, case by case).

Usage: python bench/bench_sweep.py [--scale default|tiny] [--no-report] [--out DIR]
Writes bench/results/sweep-YYYYMMDD-HHMM.json.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import record  # noqa: E402

from campaign import sweep  # noqa: E402
from workbench.paper import SCALES, build_report, h_fit, paper_case, read_curves  # noqa: E402


def table2_cases(scale):
    cy = scale.cylinder
    cases = [dict(test="cylinder_triaxial", name=f"cylinder_k{k:g}_seed0", wire="elastic",
                  k=float(k), seed=0, **cy) for k in scale.k_list]
    cases.append(dict(test="cylinder_triaxial", name="cylinder_rigid_seed0", wire="rigid",
                      k=None, seed=0, **cy))
    return cases


def h_of(row):
    """The report's H of a Table 2 case (``h_fit`` on its ε_zz, σ_w^eq curve) and its r².
    The sweep table's own ``H`` is engine.analysis.macro_stiffness's, None when no final
    range is linear within 1 % (every case at the default scale)."""
    t = read_curves(row["result"]["curves"])
    f = h_fit(t["axial_strain"], t["wire_equivalent"])
    return None if f is None else dict(H=f["H"], r2=f["r2"], method=f["method"])


def run_sweep(cases, client, tmp, tag):
    runs = os.path.join(tmp, f"runs-{tag}")
    t = time.perf_counter()
    table = sweep(paper_case, cases, client, out=os.path.join(tmp, f"{tag}.json"),
                  fixed={"runs_dir": runs}, progress=True)
    wall = time.perf_counter() - t
    return table, wall


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scale", default="default", choices=list(SCALES))
    ap.add_argument("--no-report", action="store_true", help="skip the report's timing")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "results"))
    ap.add_argument("--report-dir", help="keep the report there (default: a temporary folder)")
    a = ap.parse_args()
    scale = SCALES[a.scale]
    started = time.strftime("%Y%m%d-%H%M")
    m0 = record.machine()
    busy = record.Busy()
    cases = table2_cases(scale)
    tmp = tempfile.mkdtemp(prefix="bench_sweep_")
    try:
        report = None
        if not a.no_report:
            t = time.perf_counter()
            rep = build_report(a.report_dir or os.path.join(tmp, "paper"), scale, progress=True)
            wall = time.perf_counter() - t
            report = dict(wall_seconds=wall, simulations_seconds=rep.table.wall_time,
                          runs=len(rep.table.rows), failed=len(rep.table.failed),
                          verdicts={s: sum(c.status == s for c in rep.claims)
                                    for s in ("reproduced", "not reproduced", "not comparable")},
                          claims={c.id: c.status for c in rep.claims})
            shutil.copy(rep.path, os.path.join(a.out, f"sweep-{started}-report.md"))
            with open(os.path.join(a.out, f"sweep-{started}.json"), "w") as f:   # partial
                json.dump(dict(benchmark="sweep", started=started, git=record.git_commit(),
                               scale=scale.name, machine=m0, report=report,
                               table2="not finished yet"), f, indent=1)
        serial, t_serial = run_sweep(cases, "serial", tmp, "serial")
        dist, t_dist = run_sweep(cases, None, tmp, "dask")
        same = all(a_["result"].get(k) == b["result"].get(k)
                   for a_, b in zip(serial.rows, dist.rows)
                   for k in ("deviator", "H", "wire_equivalent", "steps"))
        H = {r["params"]["name"]: h_of(r) for r in dist.rows}
        same = same and H == {r["params"]["name"]: h_of(r) for r in serial.rows}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    res = dict(
        benchmark="sweep", started=started, git=record.git_commit(), scale=scale.name,
        machine=m0, busy=busy.finish(),
        table2=dict(cases=len(cases), parameters=scale.cylinder,
                    serial_seconds=t_serial, dask_2_workers_seconds=t_dist,
                    speedup=t_serial / t_dist if t_dist else None,
                    identical_results=same,
                    per_case_seconds={r["params"]["name"]: r["elapsed"] for r in serial.rows},
                    failed_serial=[r["params"]["name"] for r in serial.failed],
                    failed_dask=[r["params"]["name"] for r in dist.failed],
                    H=H),
        report=report)
    os.makedirs(a.out, exist_ok=True)
    path = os.path.join(a.out, f"sweep-{started}.json")
    with open(path, "w") as f:
        json.dump(res, f, indent=1)
    print(json.dumps({k: res[k] for k in ("table2", "report")}, indent=1)[:3000])
    print(path)


if __name__ == "__main__":
    main()
