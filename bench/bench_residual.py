"""Our Quad norm against Siconos's natural-map residual, step by step (issue 31 §2).

    .venv/bin/python bench/bench_residual.py [--quick] [--mould-scale 0.1 --mould-steps 300]

1. The peers' deposit (bench/peers: 1 000 spheres from the loose lattice to rest, h = 5e-5 s,
   tol 1e-4, max_iter 1 000, the settings of `make bench-peers`) with
   ``natural_residual=True``, at ``--tols`` (the peers' 1e-4 first): every step's Quad residual (our stopping test) and natural-map
   residual (Siconos's, :mod:`engine.solver.residual`), so that our tolerance can be read
   in Siconos's measure.
2. The mould deposit of ``gravity_deposit`` (the slope sample with its wire, at
   ``--mould-scale``), its first ``--mould-steps`` steps at tol 1e-4, and the same sample's
   sand built without a wire: where the NLGS stagnates, in both measures.

No timing: the figures are counts and residuals.  JSON: bench/results/residual-*.json.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
for p in (str(HERE.parent), str(HERE), str(HERE / "peers")):
    if p not in sys.path:
        sys.path.insert(0, p)

import numpy as np  # noqa: E402

from engine import Scene, step  # noqa: E402
from record import Busy, machine, write  # noqa: E402


def _quantiles(x):
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if not x.size:
        return None
    q = np.quantile(x, [0.0, 0.1, 0.5, 0.9, 1.0])
    return dict(zip(("min", "p10", "median", "p90", "max"), map(float, q)))


def _run(model, state, steps, stop=None, label=""):
    rows = dict(iterations=[], residual=[], natural_residual=[], contacts=[])
    from tqdm import tqdm
    for k in tqdm(range(steps), desc=label, leave=False):
        st = step(model, state)
        rows["iterations"].append(int(st.iterations))
        rows["residual"].append(float(st.residual))
        rows["natural_residual"].append(float(st.natural_residual))
        rows["contacts"].append(int(st.n_contacts))
        if stop is not None and stop(model, state):
            break
    return rows


def _summary(rows, tol, max_iter):
    q = np.asarray(rows["residual"])
    nat = np.asarray(rows["natural_residual"])
    it = np.asarray(rows["iterations"])
    conv = (q < tol) & (it > 0)
    capped = it >= max_iter
    return dict(
        steps=int(q.size), steps_at_max_iter=int(capped.sum()),
        share_at_max_iter=float(capped.mean()) if q.size else None,
        mean_sweeps=float(it.mean()) if q.size else None,
        natural_at_converged_steps=_quantiles(nat[conv]),
        natural_over_quad_at_converged_steps=_quantiles(nat[conv] / q[conv]),
        natural_at_max_iter_steps=_quantiles(nat[capped]),
        quad_at_max_iter_steps=_quantiles(q[capped]),
        natural_below_tol_at_max_iter_steps=int(np.sum(nat[capped] < tol)),
    )


def peers_model(tol: float, **options):
    """The peers' deposit (bench/peers: bench_core's loose lattice of 1 000 spheres in an
    open box, the peers' h, θ, μ, max_iter) compiled at ``tol`` with ``options``."""
    import common
    from bench_core import deposit_scene
    from engine import laws
    P = common.PARAMS
    model0, state0, geom = deposit_scene(*P["lattice"])
    sph = model0.sphere_ids
    s = Scene(gravity=(0.0, 0.0, -P["gravity"]))
    s.add_spheres(state0.position[sph], model0.body_radius[sph], density=P["density"],
                  group="sand")
    s.add_box(geom["box_lo_m"], geom["box_hi_m"], group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=P["mu"]))
    s.interact("sand", "wall", laws.Coulomb(mu=P["mu"]))
    return s.compile(dt=P["dt"], theta=P["theta"], tol=tol, max_iter=P["max_iter"],
                     **options)


def mould_model(scale: float, wire: bool, **options):
    """gravity_deposit's mould around the slope sample (seed 0) at ``scale``, with its wire
    (ElasticWire 1 N) or with the same sand only (the holes kept), h = 1e-4 s, tol 1e-4,
    max_iter 1 000, ``options`` added."""
    from engine.prep import paper_sample
    from engine.experiments.deposit import _mould
    from engine.experiments.common import deposit_laws, wire_law_or_default
    smp = paper_sample("slope", scale, wire=True, seed=0)
    sc = Scene(gravity=(0.0, 0.0, -9.81))
    if wire:
        smp.add_to(sc, wire_law=wire_law_or_default(None))
    else:
        sc.add_spheres(smp.sand_centers, smp.sand_radii, density=2650.0, group="sand")
    lo, hi = smp.container.bounds()
    _mould(sc, smp.container, 1.1 * max(hi[2] - lo[2], smp.height))
    deposit_laws(sc, "wall", mu=0.5, mu_support=0.5, mu_wire=0.3, wire=wire)
    return sc.compile(dt=1e-4, theta=0.5, tol=1e-4, max_iter=1000, **options)


def prepared_step(model, state):
    """The next step's problem, set up on a copy of ``state`` as the solve stage does (free
    velocities, contacts, Delassus diagonals, warm start, the links' data): returns
    ``(s, C, B, L)``, the copy and the sweeps' named tuples
    (:class:`engine.solver.kernels.Contacts`, ``Bodies``, ``Links``) on it, for the probes
    that sweep a step themselves (``s.contacts_buf.count`` contacts, ``model.n_links``
    links).  ``state`` is not modified."""
    from engine.contact import detect
    from engine.integrator import free_velocity
    from engine.solver import kernels as K
    from engine.solver.nlgs import LINK_COLUMNS

    s = state.copy()
    free_velocity(model, s)
    detect(model, s)
    c = s.contacts_buf
    n, nl, o = c.count, model.n_links, model.options
    K.prepare(n, c.i, c.j, c.key, c.frame, c.gap, c.ri, c.rj, c.w, c.gterm, c.impulse,
              model.body_dyn, s.vel6, s.warm_key, s.warm_impulse, o.dt, model.n_bodies,
              o.contact_compliance)
    wl = np.empty((nl, LINK_COLUMNS))
    if nl:
        K.link_prepare(nl, model.link_i, model.link_j, model.link_ref_length,
                       model.link_stiffness, s.link_broken, s.position, model.body_dyn, s.vel6,
                       s.link_impulse, s.link_normal, s.link_gap, wl, o.dt)
    C = K.Contacts(c.i, c.j, c.frame, c.w, c.gterm, c.mu, c.ri, c.rj, c.impulse)
    B = K.Bodies(model.body_dyn, s.vel6)
    L = K.Links(model.link_i, model.link_j, s.link_normal, wl, model.link_unilateral,
                s.link_impulse, model.link_order)
    return s, C, B, L


def peers_deposit(quick: bool, tol: float) -> dict:
    import common
    P = common.PARAMS
    model, state = peers_model(tol, natural_residual=True)
    sph = model.sphere_ids
    m = model.body_mass[sph]
    peak = [0.0]

    def at_rest(model, state):
        v = state.vel6[sph, :3]
        ke = 0.5 * float(np.dot(m, np.einsum("ij,ij->i", v, v)))
        peak[0] = max(peak[0], ke)
        return peak[0] > 0 and ke < 1e-4 * peak[0]

    t0 = time.perf_counter()
    rows = _run(model, state, 400 if quick else 20000, at_rest, f"peers deposit, tol {tol:g}")
    out = dict(scene="bench/peers deposit (1 000 spheres, loose lattice, open box)",
               dt=P["dt"], tol=tol, max_iter=P["max_iter"], mu=P["mu"],
               at_rest=bool(peak[0] > 0 and rows["iterations"] and len(rows["iterations"]) < (400 if quick else 20000)),
               wall_s=time.perf_counter() - t0,
               **_summary(rows, tol, P["max_iter"]), per_step=rows)
    return out


def mould(scale: float, steps: int, wire: bool) -> dict:
    model, state = mould_model(scale, wire, hot_sweeps=2, natural_residual=True)
    t0 = time.perf_counter()
    rows = _run(model, state, steps, None, f"mould deposit, wire={wire}")
    return dict(scene=f"gravity_deposit's mould, slope sample scale {scale}, seed 0, "
                      f"{'with its wire (ElasticWire 1 N)' if wire else 'its sand only'}",
                scale=scale, wire=wire, dt=1e-4, tol=1e-4, max_iter=1000, hot_sweeps=2,
                n_bodies=int(model.n_bodies), wall_s=time.perf_counter() - t0,
                **_summary(rows, 1e-4, 1000), per_step=rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--mould-scale", type=float, default=0.1)
    ap.add_argument("--mould-steps", type=int, default=300)
    ap.add_argument("--tols", default="1e-4,1e-3,3e-3",
                    help="Quad tolerances of the peers' deposit runs (the first is the peers' 1e-4)")
    a = ap.parse_args(argv)
    busy = Busy()
    out = dict(machine=machine())
    tols = [float(t) for t in a.tols.split(",")]
    out["peers_deposit"] = peers_deposit(a.quick, tols[0])
    out["peers_deposit_other_tols"] = [peers_deposit(a.quick, t) for t in tols[1:]]
    steps = 30 if a.quick else a.mould_steps
    out["mould_wire"] = mould(a.mould_scale, steps, True)
    out["mould_sand_of_the_wire_sample"] = mould(a.mould_scale, steps, False)
    out["busy"] = busy.finish()
    path = write("residual", out, quick=a.quick)
    named = [("peers_deposit", out["peers_deposit"])]
    named += [(f"peers_deposit tol {r['tol']:g}", r) for r in out["peers_deposit_other_tols"]]
    named += [(k, out[k]) for k in ("mould_wire", "mould_sand_of_the_wire_sample")]
    for key, r in named:
        nq = r["natural_over_quad_at_converged_steps"]
        nat = r["natural_at_converged_steps"]
        print(f"{key}: {r['steps']} steps, {r['steps_at_max_iter']} at max_iter "
              f"({100 * r['share_at_max_iter']:.1f} %), {r['mean_sweeps']:.0f} sweeps/step; "
              f"natural/Quad at converged steps: median "
              f"{nq['median'] if nq else float('nan'):.3g} "
              f"(p10 {nq['p10'] if nq else float('nan'):.3g}, "
              f"p90 {nq['p90'] if nq else float('nan'):.3g}); natural there: median "
              f"{nat['median'] if nat else float('nan'):.3g}")
    print(f"-> {path}")


if __name__ == "__main__":
    main()
