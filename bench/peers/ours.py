"""Our side of the peer comparison (run from the project venv).

    python bench/peers/ours.py init  --out init.json
    python bench/peers/ours.py steps --state S.json --steps N --out R.json
                               [--dense-contacts 2000 --dense-out dense.json]
    python bench/peers/ours.py rest  --state S.json --out R.json [--cap-s 600]

``init`` writes the loose-lattice start of bench_core's 1 000-sphere deposit (same
generator, same seed).  ``steps`` times N steps of engine.step (numba warmed up first, one
numba thread) and can save the first state with >= C active contacts as the common start
of the "dense" comparison.  ``rest`` runs until the kinetic energy drops below 1e-4 of its
peak.  Every figure goes to the JSON given by --out.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
for p in (str(ROOT), str(ROOT / "bench"), str(HERE)):
    if p not in sys.path:
        sys.path.insert(0, p)

import numpy as np  # noqa: E402
import numba  # noqa: E402

from engine import Scene, laws, step  # noqa: E402
import common  # noqa: E402

P = common.PARAMS


def build(state_file: str, dt: float | None = None, anderson: int | None = None,
          hot_sweeps: int = 0, tol: float | None = None, relax: float = 1.0,
          contact_compliance: float = 0.0):
    """Our Scene from a state file: spheres with their velocities and spins, open box.
    ``dt``, ``tol`` and ``anderson`` override the common parameters' time step and NLGS
    tolerance and the engine's default acceleration depth; ``hot_sweeps`` and ``relax``:
    :attr:`engine.model.Options.hot_sweeps` and ``relax`` (> 1: over-relaxation);
    ``contact_compliance``: :attr:`engine.model.Options.contact_compliance` (0: rigid)."""
    st = common.load_state(state_file)
    s = Scene(gravity=(0.0, 0.0, -P["gravity"]))
    s.add_spheres(st["position"], st["radius"], density=P["density"], group="sand",
                  velocities=st["vel6"][:, :3], spins=st["vel6"][:, 3:])
    s.add_box(st["box_lo"], st["box_hi"], group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=P["mu"]))
    s.interact("sand", "wall", laws.Coulomb(mu=P["mu"]))
    t0 = time.perf_counter()
    extra = {} if anderson is None else dict(anderson=anderson)
    if hot_sweeps:
        extra["hot_sweeps"] = hot_sweeps
    model, state = s.compile(dt=P["dt"] if dt is None else dt, theta=P["theta"],
                             tol=P["tol"] if tol is None else tol,
                             max_iter=P["max_iter"], relax=relax,
                             contact_compliance=contact_compliance, **extra)
    return st, model, state, time.perf_counter() - t0


def warm() -> float:
    """Compile (or load from numba's cache) every kernel on a tiny scene; not timed."""
    from bench_core import warm_up
    return warm_up()["total_s"]


def sphere_arrays(model, state):
    sph = model.sphere_ids
    return state.position[sph].copy(), state.vel6[sph].copy(), model.body_radius[sph].copy()


def cmd_init(a):
    from bench_core import deposit_scene, DEPOSIT
    assert DEPOSIT["seed"] == P["seed"] and DEPOSIT["spacing_factor"] == P["spacing_factor"]
    model, state, geom = deposit_scene(*P["lattice"])
    pos, vel6, rad = sphere_arrays(model, state)
    common.save_state(a.out, rad, pos, vel6, geom["box_lo_m"], geom["box_hi_m"], P,
                      origin="bench_core.deposit_scene(10, 10, 10): loose cubic lattice, "
                             "lateral jitter, bottom layer 0.02 r_max above the floor")
    print(f"init: {len(rad)} spheres, box {geom['box_hi_m']}")


def _finish(a, st, model, state, rec, extra):
    pos, vel6, rad = sphere_arrays(model, state)
    out = dict(engine="nscd-workbench", numba_threads=numba.get_num_threads(), **extra)
    out["final"] = common.summary(pos, rad, vel6, st["box_lo"], st["box_hi"], P["density"])
    out["final"]["contacts_engine"] = int(state.contacts_buf.count)
    out["per_step"] = rec
    with open(a.out, "w") as f:
        json.dump(out, f)


def cmd_steps(a):
    warm_s = warm()
    st, model, state, compile_s = build(a.state)
    rec = dict(wall_s=[], contacts=[], iterations=[], residual=[])
    checkpoints = {int(c) for c in a.checkpoints.split(",") if c.strip()}
    ckpt = {}
    dense_saved = None
    final = None
    t_all = time.perf_counter()
    wall = None
    k = 0
    # the timed steps; then, if the dense state has not been met yet, more (untimed) steps
    # until it is, at most --dense-max-steps in all
    while True:
        timed = k < a.steps and wall is None
        t0 = time.perf_counter()
        s = step(model, state)
        t1 = time.perf_counter()
        k += 1
        if timed:
            rec["wall_s"].append(t1 - t0)
            rec["contacts"].append(int(s.n_contacts))
            rec["iterations"].append(int(s.iterations))
            rec["residual"].append(float(s.residual))
        if k in checkpoints and timed:  # untimed
            pos, vel6, rad = sphere_arrays(model, state)
            ckpt[str(k)] = common.summary(pos, rad, vel6, st["box_lo"], st["box_hi"],
                                          P["density"])
            ckpt[str(k)]["contacts_engine"] = int(s.n_contacts)
        if a.dense_out and dense_saved is None and s.n_contacts >= a.dense_contacts:
            pos, vel6, rad = sphere_arrays(model, state)
            common.save_state(a.dense_out, rad, pos, vel6, st["box_lo"], st["box_hi"], P,
                              origin=f"our deposit from {Path(a.state).name} after {k} "
                                     f"steps (first step with >= {a.dense_contacts} contacts)",
                              step=k, contacts_engine=int(s.n_contacts))
            dense_saved = k
        if timed and (k == a.steps or time.perf_counter() - t_all > a.cap_s):
            wall = time.perf_counter() - t_all
            pos, vel6, rad = sphere_arrays(model, state)
            final = common.summary(pos, rad, vel6, st["box_lo"], st["box_hi"], P["density"])
            final["contacts_engine"] = int(s.n_contacts)
            sim_t = float(state.time)
        if wall is not None and (not a.dense_out or dense_saved is not None
                                 or k >= a.dense_max_steps):
            break
    out = dict(engine="nscd-workbench", numba_threads=numba.get_num_threads(),
               mode="steps", state=Path(a.state).name, steps_requested=a.steps,
               steps_done=len(rec["wall_s"]), wall_s=wall, cap_s=a.cap_s,
               cap_hit=len(rec["wall_s"]) < a.steps, warmup_s=warm_s,
               scene_compile_s=compile_s, dense_state_step=dense_saved,
               simulated_time_s=sim_t, checkpoints=ckpt,
               non_converged_steps=int(np.sum(np.asarray(rec["residual"]) >= P["tol"])),
               final=final, per_step=rec)
    with open(a.out, "w") as f:
        json.dump(out, f)
    print(f"ours steps: {len(rec['wall_s'])} steps in {wall:.2f} s, "
          f"{rec['contacts'][-1]} contacts at the end"
          + (f"; dense state (>= {a.dense_contacts} contacts) at step {dense_saved}"
             if a.dense_out else ""))


def cmd_rest(a):
    warm_s = warm()
    st, model, state, compile_s = build(a.state, a.dt, a.anderson, a.hot_sweeps, a.tol,
                                        a.relax, a.contact_compliance)
    sph = model.sphere_ids
    rad = model.body_radius[sph]
    m, inertia = common.masses(rad, P["density"])
    rec = dict(wall_s=[], contacts=[], iterations=[], residual=[], kinetic_energy_J=[])
    peak = 0.0
    at_rest = False
    t_all = time.perf_counter()
    for k in range(a.max_steps):
        t0 = time.perf_counter()
        s = step(model, state)
        v = state.vel6[sph]
        ke = 0.5 * float(np.dot(m, np.einsum("ij,ij->i", v[:, :3], v[:, :3]))
                         + np.dot(inertia, np.einsum("ij,ij->i", v[:, 3:], v[:, 3:])))
        rec["wall_s"].append(time.perf_counter() - t0)  # the energy check is included
        rec["contacts"].append(int(s.n_contacts))
        rec["iterations"].append(int(s.iterations))
        rec["residual"].append(float(s.residual))
        rec["kinetic_energy_J"].append(ke)
        peak = max(peak, ke)
        if peak > 0.0 and ke < a.rest_ratio * peak:
            at_rest = True
            break
        if time.perf_counter() - t_all > a.cap_s:
            break
    wall = time.perf_counter() - t_all
    n = len(rec["wall_s"])
    # static equilibrium at the end: the walls carry the pile's weight (1 at rest; the side
    # walls' friction carries part of it, so this is all walls, not the floor alone)
    from engine.analysis import wall_forces
    weight = float(np.sum(m)) * P["gravity"]
    walls_z = float(wall_forces(model, state)[:, 2].sum())
    _finish(a, st, model, state, rec, dict(
        walls_vertical_force_over_weight=-walls_z / weight,
        mode="rest", state=Path(a.state).name, rest_ratio=a.rest_ratio, at_rest=at_rest,
        dt_s=model.options.dt, tol=model.options.tol, anderson=model.options.anderson,
        relax=model.options.relax, contact_compliance=model.options.contact_compliance,
        hot_sweeps=model.options.hot_sweeps,
        steps_done=n, simulated_time_s=float(state.time), wall_s=wall, cap_s=a.cap_s,
        cap_hit=not at_rest, kinetic_energy_peak_J=peak,
        kinetic_energy_peak_step=int(np.argmax(rec["kinetic_energy_J"])) + 1,
        warmup_s=warm_s, scene_compile_s=compile_s,
        non_converged_steps=int(np.sum(np.asarray(rec["residual"]) >= model.options.tol))))
    print(f"ours rest: {'at rest' if at_rest else 'NOT at rest'} after {n} steps "
          f"({state.time:.4f} s simulated) in {wall:.1f} s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("init")
    p.add_argument("--out", required=True)
    p = sub.add_parser("steps")
    p.add_argument("--state", required=True)
    p.add_argument("--steps", type=int, required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--cap-s", type=float, default=1e9)
    p.add_argument("--dense-contacts", type=int, default=2000)
    p.add_argument("--dense-out")
    p.add_argument("--checkpoints", default="")
    p.add_argument("--dense-max-steps", type=int, default=5000)
    p = sub.add_parser("rest")
    p.add_argument("--state", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--cap-s", type=float, default=600.0)
    p.add_argument("--max-steps", type=int, default=200000)
    p.add_argument("--rest-ratio", type=float, default=1e-4)
    p.add_argument("--dt", type=float, default=None, help="time step [s] (default: the common one)")
    p.add_argument("--tol", type=float, default=None,
                   help="NLGS tolerance (default: the common one, 1e-4)")
    p.add_argument("--anderson", type=int, default=None,
                   help="NLGS Anderson depth (default: the engine's default)")
    p.add_argument("--hot-sweeps", type=int, default=0,
                   help="re-sweeps of the hot contacts (needs --anderson 0)")
    p.add_argument("--relax", type=float, default=1.0,
                   help="NLGS relaxation (> 1: over-relaxation, needs --anderson 0)")
    p.add_argument("--contact-compliance", type=float, default=0.0,
                   help="the contacts' normal compliance ε (0: rigid)")
    a = ap.parse_args()
    numba.set_num_threads(1)
    {"init": cmd_init, "steps": cmd_steps, "rest": cmd_rest}[a.cmd](a)


if __name__ == "__main__":
    main()
