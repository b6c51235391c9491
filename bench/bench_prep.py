"""Sample-preparation benchmark (issue 5): geometric deposit time and solid fraction for
1 000 / 6 200 / 26 000 grains, the wire random walk of the paper's three samples, and the
paper-scale cylinder sample (6 200 grains + wire) against the 10 s target.

Yardstick: LMGC90's Fortran geometric deposit placed 1 948 grains in 5.7 s on this kind of
machine (shared/notes/peers.md; LMGC90 cannot be installed by the benchmark, so that figure
is quoted, not re-measured).  Writes bench/results/prep-YYYYMMDD-HHMM.json.
"""
from __future__ import annotations

import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import record  # noqa: E402

from engine.prep import Cylinder, geometric, granulometry, paper_sample  # noqa: E402
from engine.prep.samples import PAPER  # noqa: E402

LMGC90_GRAINS_PER_S = 1948 / 5.7


def core_fraction(c, r, cyl):
    m = 4 * r.max()
    top = (c[:, 2] + r).max()
    rr = np.hypot(c[:, 0], c[:, 1])
    if top - 2 * m < 4 * r.max():
        # a pile lower than 12 r_max has no core by this rule: a thinner slice holds a few
        # grains, whose whole volumes count (0.0 to 0.95 on the 1 000-grain piles, 3.2 mm)
        return None
    k = (rr < cyl.radius - m) & (c[:, 2] > m) & (c[:, 2] < top - m)
    return float((4 / 3 * np.pi * r[k] ** 3).sum() / (np.pi * (cyl.radius - m) ** 2 * (top - 2 * m)))


def _fraction_text(f):
    return "- (no core)" if f is None else f"{f:.3f}"


def main():
    busy = record.Busy()
    out = {"machine": record.machine(), "git": record.git_commit(), "deposit": [],
           "walk": [], "samples": []}
    geometric(np.full(20, 1e-4), Cylinder(1e-3, 4e-3))          # compile (cached)
    # sand only, the paper's granulometries, in a tall cylinder of the paper's diameter
    for n, (dmin, dmax), R in ((1000, (0.3e-3, 0.8e-3), 4.5e-3), (6200, (0.3e-3, 0.8e-3), 4.5e-3),
                               (26000, (0.2e-3, 0.6e-3), 6e-3)):
        radii = granulometry.uniform(dmin, dmax, n=n, seed=0)
        cyl = Cylinder(R, 60e-3)
        t = time.perf_counter()
        c, r = geometric(radii, cyl, seed=1)
        dt = time.perf_counter() - t
        row = dict(grains=n, d_min=dmin, d_max=dmax, radius=R, seconds=dt,
                   grains_per_s=n / dt, vs_lmgc90=(n / dt) / LMGC90_GRAINS_PER_S,
                   core_solid_fraction=core_fraction(c, r, cyl))
        out["deposit"].append(row)
        print(f"deposit {n:6d} grains: {dt:6.2f} s  {n / dt:8.0f} grains/s "
              f"({row['vs_lmgc90']:.1f}x LMGC90's 342/s)  core solid fraction {_fraction_text(row['core_solid_fraction'])}")
    for name in ("cylinder", "box", "slope"):
        p = PAPER[name]
        s = paper_sample(name, 1.0, seed=0)
        out["samples"].append(dict(name=name, grains=int(s.sand_radii.size), beads=s.n_beads,
                                   wires=len(s.wire), wire_density=s.wire_density,
                                   target_density=p["wire_density"], height=s.height,
                                   walk_seconds=s.info["wire_time"],
                                   deposit_seconds=s.info["deposit_time"]))
        print(f"{s}")
    cyl = out["samples"][0]
    total = cyl["walk_seconds"] + cyl["deposit_seconds"]
    out["paper_cylinder_seconds"] = total
    out["target_seconds"] = 10.0
    print(f"paper-scale cylinder sample (6 200 grains + {cyl['beads']} beads): {total:.2f} s "
          f"(target < 10 s)")
    out["busy"] = busy.finish()
    os.makedirs(os.path.join(os.path.dirname(__file__), "results"), exist_ok=True)
    path = os.path.join(os.path.dirname(__file__), "results",
                        time.strftime("prep-%Y%m%d-%H%M.json"))
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    print("wrote", path)


if __name__ == "__main__":
    main()
