"""Siconos side of the peer comparison; run with Debian's /usr/bin/python3.

    /usr/bin/python3 bench/peers/siconos_deposit.py --state S.json --steps N --out R.json
                                                   [--cap-s 600] [--workdir DIR]

The spheres, box and parameters of the state file go into a MechanicsHdf5Runner scene
(Bullet detection, MoreauJeanOSI θ, FrictionContact solved by NSGS at tol / itermax,
Newton_max_iter 1, restitution 0), which then runs N steps.  Per-step wall time is taken
between the runner's start- and end-of-iteration hooks (everything the runner does in a
step: births, computeOneStep, change log, nextStep), with HDF5 output switched off after
the runner's mandatory first-step output.  The final positions and velocities are read
back from the kernel for the comparison.
"""
import argparse
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import numpy as np  # noqa: E402

import common  # noqa: E402

import siconos.kernel as sk  # noqa: E402
import siconos.numerics as sn  # noqa: E402
from siconos.io.mechanics_run import MechanicsHdf5Runner  # noqa: E402
from siconos.mechanics.collision.tools import Contactor  # noqa: E402
from siconos.mechanics.collision.bullet import SiconosBulletOptions  # noqa: E402

P = common.PARAMS


def build_scene(path, st, margin_ratio):
    rad, pos, vel6 = st["radius"], st["position"], st["vel6"]
    lo, hi = np.asarray(st["box_lo"]), np.asarray(st["box_hi"])
    size = hi - lo
    th = 0.5 * size[0]  # wall thickness (Bullet boxes), outside the box
    wm = margin_ratio * float(rad.min())
    with MechanicsHdf5Runner(io_filename=path, mode="w", verbose=False) as io:
        io.add_primitive_shape("Floor", "Box", (size[0] + 2 * th, size[1] + 2 * th, th),
                               insideMargin=wm, outsideMargin=wm)
        io.add_primitive_shape("WallX", "Box", (th, size[1] + 2 * th, size[2] + th),
                               insideMargin=wm, outsideMargin=wm)
        io.add_primitive_shape("WallY", "Box", (size[0] + 2 * th, th, size[2] + th),
                               insideMargin=wm, outsideMargin=wm)
        c = 0.5 * (lo + hi)
        zc = lo[2] + 0.5 * (size[2] - th)
        io.add_object("floor", [Contactor("Floor")], translation=[c[0], c[1], lo[2] - th / 2])
        io.add_object("wall_xm", [Contactor("WallX")], translation=[lo[0] - th / 2, c[1], zc])
        io.add_object("wall_xp", [Contactor("WallX")], translation=[hi[0] + th / 2, c[1], zc])
        io.add_object("wall_ym", [Contactor("WallY")], translation=[c[0], lo[1] - th / 2, zc])
        io.add_object("wall_yp", [Contactor("WallY")], translation=[c[0], hi[1] + th / 2, zc])
        io.add_Newton_impact_friction_nsl("contact", mu=P["mu"], e=P["restitution"])
        m, inertia = common.masses(rad, P["density"])
        for i in range(len(rad)):
            io.add_primitive_shape(f"S{i}", "Sphere", (float(rad[i]),),
                                   insideMargin=margin_ratio * float(rad[i]),
                                   outsideMargin=margin_ratio * float(rad[i]))
            io.add_object(f"s{i}", [Contactor(f"S{i}")], translation=pos[i].tolist(),
                          velocity=vel6[i].tolist(), mass=float(m[i]),
                          inertia=[float(inertia[i])] * 3)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--state", required=True)
    ap.add_argument("--steps", type=int, required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--cap-s", type=float, default=1e9)
    ap.add_argument("--workdir", default=None)
    ap.add_argument("--checkpoints", default="",
                    help="comma-separated step numbers at which the state summary is taken "
                         "(outside the timed part of the step)")
    ap.add_argument("--world-scale", type=float, default=1000.0)
    ap.add_argument("--breaking-threshold", type=float, default=None,
                    help="Bullet contactBreakingThreshold (default: our alert distance "
                         "0.1 r_min, times world-scale)")
    ap.add_argument("--margin-ratio", type=float, default=1e-5)
    a = ap.parse_args()

    st = common.load_state(a.state)
    rad = st["radius"]
    n = len(rad)
    workdir = a.workdir or os.path.dirname(os.path.abspath(a.out))
    h5 = os.path.join(workdir, "siconos-" + os.path.splitext(os.path.basename(a.out))[0] + ".hdf5")

    t0 = time.perf_counter()
    build_scene(h5, st, a.margin_ratio)
    build_s = time.perf_counter() - t0

    bo = SiconosBulletOptions()
    bo.worldScale = a.world_scale
    alert = 0.1 * float(rad.min())
    bo.contactBreakingThreshold = (a.breaking_threshold if a.breaking_threshold is not None
                                   else alert * a.world_scale)
    bo.perturbationIterations = 0
    bo.minimumPointsPerturbationThreshold = 0

    so = sk.solver_options_create(sn.SICONOS_FRICTION_3D_NSGS)
    so.iparam[sn.SICONOS_IPARAM_MAX_ITER] = P["max_iter"]
    so.dparam[sn.SICONOS_DPARAM_TOL] = P["tol"]

    g = P["gravity"]

    def gravity(body):
        body.setFExtPtr([0.0, 0.0, -body.scalarMass() * g])

    rec = dict(wall_s=[], contacts=[], iterations=[], residual=[])
    checkpoints = {int(c) for c in a.checkpoints.split(",") if c.strip()}
    ckpt = {}
    clock = {}
    stop = {"cap_hit": False}
    t_run = [None]

    def start_hook(io):
        clock["t"] = time.perf_counter()
        if t_run[0] is None:
            t_run[0] = clock["t"]

    def end_hook(io):
        rec["wall_s"].append(time.perf_counter() - clock["t"])
        osnspb = io._simulation.oneStepNSProblem(0)
        sol = osnspb.numericsSolverOptions()
        rec["contacts"].append(int(osnspb.getSizeOutput() // 3))
        rec["iterations"].append(int(sol.iparam[sn.SICONOS_IPARAM_ITER_DONE]))
        rec["residual"].append(float(sol.dparam[sn.SICONOS_DPARAM_RESIDU]))
        io._output_frequency = 10 ** 9  # no HDF5 output after the first step
        if len(rec["wall_s"]) in checkpoints:
            x, v6 = _sphere_state(io, n)
            c = common.summary(x, rad, v6, st["box_lo"], st["box_hi"], P["density"])
            c["contacts_engine"] = rec["contacts"][-1]
            ckpt[str(len(rec["wall_s"]))] = c
        if time.perf_counter() - t_run[0] > a.cap_s and len(rec["wall_s"]) < a.steps:
            stop["cap_hit"] = True
            # end the run loop: the runner stops when the simulation has no next event
            io._simulation.nonSmoothDynamicalSystem().setT(io._simulation.nextTime())
        if os.environ.get("PEERS_VERBOSE"):
            print("siconos step", len(rec["wall_s"]), rec["contacts"][-1],
                  rec["iterations"][-1], f"{rec['wall_s'][-1]:.4f}", flush=True)

    t1 = time.perf_counter()
    with MechanicsHdf5Runner(io_filename=h5, mode="r+", verbose=False,
                             set_external_forces=gravity) as io:
        io.run(T=a.steps * P["dt"] * (1.0 + 1e-9), h=P["dt"], theta=P["theta"],
               Newton_max_iter=1, solver_options=so, bullet_options=bo,
               output_frequency=10 ** 9, verbose=False, verbose_progress=False,
               start_run_iteration_hook=start_hook, end_run_iteration_hook=end_hook)
        x, v6 = _sphere_state(io, n)
        final_time = float(io._simulation.startingTime())
    total = time.perf_counter() - t1
    run_s = sum(rec["wall_s"])
    summ = common.summary(x, rad, v6, st["box_lo"], st["box_hi"], P["density"])
    summ["contacts_engine"] = rec["contacts"][-1] if rec["contacts"] else 0
    out = dict(engine="siconos", version=_version(), state=os.path.basename(a.state),
               ld_preload=os.environ.get("LD_PRELOAD", ""),
               steps_requested=a.steps, steps_done=len(rec["wall_s"]), cap_s=a.cap_s,
               cap_hit=stop["cap_hit"], scene_build_s=build_s,
               run_call_s=total, steps_wall_s=run_s, setup_in_run_s=total - run_s,
               bullet=dict(worldScale=bo.worldScale,
                           contactBreakingThreshold=bo.contactBreakingThreshold,
                           margin_ratio=a.margin_ratio, perturbationIterations=0),
               solver=dict(id="SICONOS_FRICTION_3D_NSGS", tol=P["tol"], itermax=P["max_iter"],
                           theta=P["theta"], h=P["dt"], Newton_max_iter=1),
               simulated_time_s=final_time, final=summ, checkpoints=ckpt, per_step=rec)
    with open(a.out, "w") as f:
        json.dump(out, f)
    print(f"siconos: {len(rec['wall_s'])} steps in {run_s:.2f} s "
          f"(LD_PRELOAD={'yes' if out['ld_preload'] else 'no'}), "
          f"{summ['contacts_engine']} contacts at the end")


def _sphere_state(io, n):
    """Positions (n, 3) and velocities (n, 6) of the spheres, in input order: the runner
    numbers dynamic objects 1..n in insertion order (s0 -> 1, ...)."""
    pos = np.asarray(io._io.positions(io._nsds))
    vel = np.asarray(io._io.velocities(io._nsds))
    pos = pos[np.argsort(pos[:, 0])]
    vel = vel[np.argsort(vel[:, 0])]
    assert pos.shape[0] == n and pos[0, 0] == 1 and pos[-1, 0] == n, pos[[0, -1], 0]
    return pos[:, 1:4], vel[:, 1:7]


def _version():
    try:
        import siconos
        return getattr(siconos, "__version__", None) or "4.4 (Debian python3-siconos)"
    except Exception:  # pragma: no cover
        return None


if __name__ == "__main__":
    main()
