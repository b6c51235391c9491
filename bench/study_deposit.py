"""Study (issue 10, Fig. 7): the deposit in the mould under one knob set two ways, seed by
seed: contacts between linked beads (``neighbour_contact``, :meth:`engine.Scene.add_wire`)
or the NLGS tolerance (``tol``).

``gravity_deposit(scale, sample="slope", seed=s, <knob>=v)`` for each seed and value, one
run after the other.  For each run: at rest or not, steps, steps at ``max_iter``, ξ before
/ after and its rise, the grains' settlement, the links shorter than 0.999 × 2 r_w at the
end (beads of a slack link overlapping), the shortest link / 2 r_w, the slack links, the
mould's force / weight and the wall time.

Usage: python bench/study_deposit.py [--knob neighbour_contact|tol] [--values 1e-4,2e-4]
                                     [--scale 0.05] [--seeds 0,1,2] [--dt 1e-4]
Writes bench/results/deposit-<knob>-YYYYMMDD-HHMM.json (about 6 min at the default scale
on one core for two values and three seeds).
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import record  # noqa: E402

def _bool(text: str) -> bool:
    if text not in ("False", "True"):
        raise SystemExit(f"--values: neighbour_contact takes False or True, got {text!r}")
    return text == "True"


KNOBS = {"neighbour_contact": (_bool, "False,True"), "tol": (float, "1e-4,2e-4")}


def one(scale: float, seed: int, knob: str, value, dt: float, folder: str) -> dict:
    from engine.experiments import gravity_deposit
    from engine.io import load

    t0 = time.perf_counter()
    r = gravity_deposit(scale, sample="slope", seed=seed, dt=dt, progress=False,
                        history=os.path.join(folder, f"d{seed}{knob}{value}.h5"),
                        **{knob: value})
    m, s = load(r.history, frame=-1)
    x = s.links.length / (2 * m.body_radius[m.link_i])
    return {"seed": seed, knob: value, "at_rest": r.at_rest,
            "steps": r.convergence["steps"], "non_converged": r.convergence["non_converged"],
            "xi_before": r.wire_before.tortuosity, "xi_after": r.wire_after.tortuosity,
            "rise": r.wire_after.tortuosity / r.wire_before.tortuosity - 1,
            "settlement": r.settlement, "min_link_over_2r": float(x.min()),
            "share_links_below_2r": float((x < 0.999).mean()), "slack_share": r.slack_share,
            "wall_force_over_weight": r.wall_force / r.weight,
            "wall_time": time.perf_counter() - t0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--knob", choices=sorted(KNOBS), default="neighbour_contact")
    ap.add_argument("--values", default=None, help="comma-separated (default: per knob)")
    ap.add_argument("--scale", type=float, default=0.05)
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--dt", type=float, default=1e-4, help="time step [s] (the default "
                    "report's deposit: 1e-4; the paper's scale: 5e-5)")
    a = ap.parse_args(argv)
    parse, default = KNOBS[a.knob]
    values = [parse(v) for v in (a.values or default).split(",")]
    seeds = [int(s) for s in a.seeds.split(",")]
    busy = record.Busy()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for seed in seeds:
            for v in values:
                rows.append(one(a.scale, seed, a.knob, v, a.dt, folder))
                print({k: (round(float(x), 4) if isinstance(x, float) else x)
                       for k, x in rows[-1].items()}, flush=True)
    summary = {}
    for v in values:
        rises = [r["rise"] for r in rows if r[a.knob] == v]
        summary[f"{a.knob}={v}"] = dict(
            rise_mean=float(statistics.mean(rises)),
            rise_std=float(statistics.stdev(rises)) if len(rises) > 1 else None,
            steps=[r["steps"] for r in rows if r[a.knob] == v],
            wall_time=sum(r["wall_time"] for r in rows if r[a.knob] == v))
        print(f"{a.knob}={v}: {summary[f'{a.knob}={v}']}")
    path = record.write(f"deposit-{a.knob.replace('_', '-')}", dict(
        what=f"gravity_deposit(scale, sample='slope', seed, dt, {a.knob}) for each value "
             f"(bench/study_deposit.py)",
        knob=a.knob, values=values, scale=a.scale, dt=a.dt, seeds=seeds,
        commit=record.git_commit(), machine=record.machine(), busy=busy.finish(),
        summary=summary, rows=rows))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
