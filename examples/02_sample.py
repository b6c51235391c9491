"""02 — build one of the paper's TexSol samples (§2.4): wire random walk (Eq. 16), 3D
geometric deposit of the sand around it, wire statistics, a picture.

    .venv/bin/python examples/02_sample.py --sample cylinder --scale 0.2 --out out/sample
"""
from __future__ import annotations

import argparse
from pathlib import Path

from engine import Scene
from engine.analysis import direction_histogram, wire_stats
from engine.prep import paper_sample
from workbench.figures import directions_figure


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sample", choices=("cylinder", "box", "slope"), default="cylinder")
    p.add_argument("--scale", type=float, default=0.2, help="1 = the paper's size")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=Path("out/sample"))
    p.add_argument("--smoke", action="store_true", help="tiny size, for CI")
    a = p.parse_args(argv)
    s = paper_sample(a.sample, 0.02 if a.smoke else a.scale, seed=a.seed)
    print(s)
    w = wire_stats(s.wire, s.container.volume)
    print(f"wire: {w.n_wires} wire(s), {w.n_beads} beads, {w.length * 1e3:.1f} mm, "
          f"{w.density / 1e3:.0f} km/m³, orientation eigenvalues {w.eigenvalues.round(3)}, "
          f"tortuosity {w.tortuosity:.0f} 1/m")
    h = {pl: direction_histogram(s.wire, pl) for pl in ("xy", "xz", "yz")}
    a.out.mkdir(parents=True, exist_ok=True)
    print("wrote", directions_figure(h, h, a.out / "directions.png"))
    # a picture of the sample (workbench.render, off-screen)
    from workbench.render import snapshot
    sc = Scene()
    s.add_to(sc)
    for a_, b_ in (("sand", "sand"), ("sand", "wire"), ("wire", "wire")):
        sc.interact(a_, b_, None)          # a picture only: no contact law needed
    model, state = sc.compile(dt=1e-5)
    print("wrote", snapshot(model, state, a.out / "sample.png", preset="beads"))


if __name__ == "__main__":
    main()
