"""Study (issue 10, Fig. 7): the deposit in the mould with and without contacts between
linked beads (``neighbour_contact``, :meth:`engine.Scene.add_wire`).

``gravity_deposit(scale, sample="slope", seed=s, neighbour_contact=nc)`` for each seed and
both values, one run after the other.  For each run: at rest or not, steps, steps at
``max_iter``, ξ before / after and its rise, the grains' settlement, the links shorter than
0.999 × 2 r_w at the end (beads of a slack link overlapping), the shortest link / 2 r_w,
the slack links, the mould's force / weight and the wall time.

Usage: python bench/study_neighbour_contact.py [--scale 0.05] [--seeds 0,1,2]
Writes bench/results/deposit-neighbour-contact-YYYYMMDD-HHMM.json (about 6 min at the
default scale on one core).
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


def one(scale: float, seed: int, nc: bool, folder: str) -> dict:
    from engine.experiments import gravity_deposit
    from engine.io import load

    t0 = time.perf_counter()
    r = gravity_deposit(scale, sample="slope", neighbour_contact=nc, seed=seed,
                        history=os.path.join(folder, f"d{seed}{nc}.h5"), progress=False)
    m, s = load(r.history, frame=-1)
    x = s.links.length / (2 * m.body_radius[m.link_i])
    return dict(seed=seed, neighbour_contact=nc, at_rest=r.at_rest,
                steps=r.convergence["steps"], non_converged=r.convergence["non_converged"],
                xi_before=r.wire_before.tortuosity, xi_after=r.wire_after.tortuosity,
                rise=r.wire_after.tortuosity / r.wire_before.tortuosity - 1,
                settlement=r.settlement, min_link_over_2r=float(x.min()),
                share_links_below_2r=float((x < 0.999).mean()), slack_share=r.slack_share,
                wall_force_over_weight=r.wall_force / r.weight,
                wall_time=time.perf_counter() - t0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=0.05)
    ap.add_argument("--seeds", default="0,1,2")
    a = ap.parse_args(argv)
    seeds = [int(s) for s in a.seeds.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for seed in seeds:
            for nc in (False, True):
                rows.append(one(a.scale, seed, nc, folder))
                print({k: (round(float(v), 4) if isinstance(v, float) else v)
                       for k, v in rows[-1].items()}, flush=True)
    summary = {}
    for nc in (False, True):
        rises = [r["rise"] for r in rows if r["neighbour_contact"] is nc]
        summary[f"neighbour_contact={nc}"] = dict(
            rise_mean=float(statistics.mean(rises)),
            rise_std=float(statistics.stdev(rises)) if len(rises) > 1 else None)
        print(f"neighbour_contact={nc}: xi rise {summary[f'neighbour_contact={nc}']}")
    path = record.write("deposit-neighbour-contact", dict(
        what="gravity_deposit(scale, sample='slope', seed, neighbour_contact) with and "
             "without contacts between linked beads (bench/study_neighbour_contact.py)",
        scale=a.scale, seeds=seeds, commit=record.git_commit(), machine=record.machine(),
        summary=summary, rows=rows))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
