"""03 — the paper's cylinder triaxial test (§3.3) for sand, an elastic wire and a rigid wire
(Fig. 14): stress–strain curves and the wire's macro-stiffness H (Table 2).

    .venv/bin/python examples/03_cylinder_triaxial.py --scale 0.1 --out out/triaxial
"""
from __future__ import annotations

import argparse
from pathlib import Path

from engine import laws
from engine.experiments import cylinder_triaxial
from workbench.figures import stress_strain_figure


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scale", type=float, default=0.1)
    p.add_argument("--strain", type=float, default=0.1, help="final axial strain")
    p.add_argument("--out", type=Path, default=Path("out/triaxial"))
    p.add_argument("--smoke", action="store_true", help="tiny size, for CI")
    a = p.parse_args(argv)
    scale, strain = (0.05, 0.005) if a.smoke else (a.scale, a.strain)
    cases = {"sand": dict(wire=False),
             "elastic wire k = 0.2 N": dict(wire_law=laws.ElasticWire(stiffness=0.2)),
             "rigid wire": dict(wire_law=laws.RigidWire())}
    results = []
    for name, kw in cases.items():
        r = cylinder_triaxial(scale, axial_strain=strain, history=str(a.out / f"{name.split()[0]}.h5"),
                              **kw)
        print(f"{name}: {r}")
        H = r.extra.get("H")
        if H is not None:
            print(f"  macro-stiffness H = {H.slope:.4g} Pa")
        results.append(r)
    print("wrote", stress_strain_figure(results, a.out / "stress_strain.png", labels=list(cases)))


if __name__ == "__main__":
    main()
