"""04 — the paper's slope deposit (§3.1): a TexSol cylinder released on a rubber plane of
beads; heap shape, floor pressure and slope (Fig. 10), wire directions before and after
(Fig. 8-9) and tortuosity (Fig. 7).

    .venv/bin/python examples/04_slope.py --scale 0.05 --out out/slope
"""
from __future__ import annotations

import argparse
from pathlib import Path

from engine.experiments import slope_deposit
from workbench.figures import directions_figure, slope_figure


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scale", type=float, default=0.05)
    p.add_argument("--out", type=Path, default=Path("out/slope"))
    p.add_argument("--smoke", action="store_true", help="tiny size, for CI")
    a = p.parse_args(argv)
    kw = dict(dt=1e-4, steps=300) if a.smoke else {}
    res = {}
    for name, extra in (("sand", dict(wire=False)), ("400 km/m3", {})):
        r = slope_deposit(0.01 if a.smoke else a.scale, history=str(a.out / f"{name.split()[0]}.h5"),
                          max_nonconverged=1.0 if a.smoke else 0.25, **kw, **extra)
        print(f"{name}: {r}")
        res[name] = r
    print("wrote", slope_figure([r.profile for r in res.values()], a.out / "slope.png",
                                labels=list(res)))
    t = res["400 km/m3"]
    print("wrote", directions_figure(t.histograms_before, t.histograms_after,
                                     a.out / "directions.png"))


if __name__ == "__main__":
    main()
