"""05 — Fig. 7: the deposit under gravity that finishes a geometric TexSol sample (§2.4). The
sample relaxes in its mould; the wire's tortuosity ξ is measured before and after, and the
wire is drawn at both ends of the run.

    .venv/bin/python examples/05_gravity_deposit.py --sample slope --scale 0.05 --out out/fig7
"""
from __future__ import annotations

import argparse
from pathlib import Path

from engine.experiments import gravity_deposit
from engine.experiments.deposit import SAMPLES


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sample", choices=SAMPLES, default="slope")
    p.add_argument("--scale", type=float, default=0.05, help="1 = the paper's size")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=Path("out/fig7"))
    p.add_argument("--smoke", action="store_true", help="tiny size, for CI")
    a = p.parse_args(argv)
    sample, scale = ("box", 0.02) if a.smoke else (a.sample, a.scale)
    r = gravity_deposit(scale, sample=sample, seed=a.seed, history=str(a.out / "deposit.h5"))
    print(r)
    from workbench.cli import render_frame
    from workbench.figures import tortuosity_figure

    print("wrote", tortuosity_figure(["paper (Fig. 7)", f"ours ({sample}, scale {scale:g})"],
                                     [839.0, r.wire_before.tortuosity],
                                     [1464.0, r.wire_after.tortuosity],
                                     a.out / "tortuosity.png"))
    for tag, frame in (("before", 0), ("after", -1)):
        print("wrote", render_frame(r.history, a.out / f"wire_{tag}.png", frame=frame,
                                    preset="wire"))


if __name__ == "__main__":
    main()
