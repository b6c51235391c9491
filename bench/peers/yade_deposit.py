# Yade side of the peer comparison: the same deposit run to rest, headless.
#
#     PEERS_STATE=init.json PEERS_OUT=yade.json PEERS_CAP_S=600 yade -n -j1 -x bench/peers/yade_deposit.py
#
# Soft-contact DEM, E = 1e8 Pa, Poisson ratio 0.25 (Yade's default; ks = 0.25 kn), friction
# angle atan(0.3), density 2650, time step 0.5 x PWaveTimeStep().  Walls are Yade's
# infinite `wall` bodies at the box faces (floor + 4 sides).  Contact law (PEERS_YADE_LAW):
#   frict (default)   FrictMat + Law2_ScGeom_FrictPhys_CundallStrack (elastic contacts) with
#                     Yade's usual local damping 0.2 (PEERS_DAMPING) in NewtonIntegrator
#                     (the set-up of peers.md);
#   viscel            ViscElMat + Ip2_ViscElMat_ViscElMat_ViscElPhys + Law2_ScGeom_ViscElPhys_Basic,
#                     kn from E, normal viscous damping from the restitution en = PEERS_EN
#                     (0.01: nearly critical, the soft-contact stand-in for our e = 0),
#                     no local damping (free fall is free fall, as in the NSCD engines).
#                     Not the default: at en = 0.01 and 0.5 x PWaveTimeStep() it blew up
#                     (kinetic energy to ~1 J) when the bulk reached the floor.
# A PyRunner checks the kinetic energy every PEERS_CHECK_EVERY iterations (default 100):
# the run stops when it is below PEERS_REST_RATIO (1e-4) of its peak, or at the wall-clock
# cap PEERS_CAP_S (then the JSON says cap_hit).
import json
import math
import os
import sys
import time

import numpy as np

# under `yade -x`, __file__ is yade's own launcher; sys.argv[0] is this script
sys.path.insert(0, os.path.dirname(os.path.abspath(sys.argv[0])))
import common  # noqa: E402

P = common.PARAMS
st = common.load_state(os.environ["PEERS_STATE"])
out_path = os.environ["PEERS_OUT"]
cap_s = float(os.environ.get("PEERS_CAP_S", "600"))
rest_ratio = float(os.environ.get("PEERS_REST_RATIO", "1e-4"))
check_every = int(os.environ.get("PEERS_CHECK_EVERY", "100"))
young = float(os.environ.get("PEERS_YOUNG", "1e8"))
law = os.environ.get("PEERS_YADE_LAW", "frict")
en = float(os.environ.get("PEERS_EN", "0.01"))
damping = float(os.environ.get("PEERS_DAMPING", "0.2" if law == "frict" else "0.0"))
dt_factor = float(os.environ.get("PEERS_DT_FACTOR", "0.5"))

t_setup = time.perf_counter()
if law == "viscel":
    mat = O.materials.append(ViscElMat(young=young, poisson=0.25, en=en, et=1.0,
                                       frictionAngle=math.atan(P["mu"]), density=P["density"],
                                       label="sand"))
    functors = ([Ip2_ViscElMat_ViscElMat_ViscElPhys()], [Law2_ScGeom_ViscElPhys_Basic()])
elif law == "frict":
    mat = O.materials.append(FrictMat(young=young, poisson=0.25,
                                      frictionAngle=math.atan(P["mu"]), density=P["density"],
                                      label="sand"))
    functors = ([Ip2_FrictMat_FrictMat_FrictPhys()], [Law2_ScGeom_FrictPhys_CundallStrack()])
else:
    raise SystemExit(f"PEERS_YADE_LAW must be viscel or frict, not {law!r}")
lo, hi = st["box_lo"], st["box_hi"]
walls = [utils.wall(lo[2], axis=2, material=mat), utils.wall(lo[0], axis=0, material=mat),
         utils.wall(hi[0], axis=0, material=mat), utils.wall(lo[1], axis=1, material=mat),
         utils.wall(hi[1], axis=1, material=mat)]
O.bodies.append(walls)
ids = []
for x, r, v in zip(st["position"], st["radius"], st["vel6"]):
    b = utils.sphere(tuple(float(c) for c in x), float(r), material=mat)
    b.state.vel = Vector3(*(float(c) for c in v[:3]))
    b.state.angVel = Vector3(*(float(c) for c in v[3:]))
    ids.append(O.bodies.append(b))

O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Wall_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Wall_Sphere_ScGeom()],
                    functors[0], functors[1]),
    NewtonIntegrator(damping=damping, gravity=(0.0, 0.0, -P["gravity"])),
    PyRunner(command="check()", iterPeriod=check_every),
]
O.dt = dt_factor * PWaveTimeStep()
setup_s = time.perf_counter() - t_setup

rec = dict(iteration=[], time_s=[], wall_s=[], kinetic_energy_J=[], contacts=[],
           unbalanced_force=[])
S = dict(peak=0.0, peak_iter=0, at_rest=False, cap_hit=False, t0=None)


def check():
    now = time.perf_counter()
    ke = utils.kineticEnergy()
    S["peak"], S["peak_iter"] = (ke, O.iter) if ke > S["peak"] else (S["peak"], S["peak_iter"])
    # a sparse trace: every 50th check, and the last one
    done = S["peak"] > 0.0 and ke < rest_ratio * S["peak"]
    over = now - S["t0"] > cap_s
    if len(rec["iteration"]) == 0 or (O.iter // check_every) % 50 == 0 or done or over:
        rec["iteration"].append(O.iter)
        rec["time_s"].append(O.time)
        rec["wall_s"].append(now - S["t0"])
        rec["kinetic_energy_J"].append(ke)
        rec["contacts"].append(sum(1 for i in O.interactions if i.isReal))
        rec["unbalanced_force"].append(utils.unbalancedForce())
    if done:
        S["at_rest"] = True
        O.pause()
    elif over:
        S["cap_hit"] = True
        O.pause()


S["t0"] = time.perf_counter()
O.run()
O.wait()
wall = time.perf_counter() - S["t0"]

pos = np.array([list(O.bodies[i].state.pos) for i in ids])
vel6 = np.array([list(O.bodies[i].state.vel) + list(O.bodies[i].state.angVel) for i in ids])
summ = common.summary(pos, st["radius"], vel6, lo, hi, P["density"])
summ["contacts_engine"] = sum(1 for i in O.interactions if i.isReal)
res = dict(engine="yade", version=str(yade.config.version) if hasattr(yade, "config") else None,
           threads=O.numThreads, law=law, young_Pa=young, poisson=0.25,
           en=en if law == "viscel" else None, local_damping=damping,
           dt_s=O.dt, dt_rule=f"{dt_factor} x PWaveTimeStep()", pwave_dt_s=PWaveTimeStep(),
           rest_ratio=rest_ratio, check_every=check_every, at_rest=S["at_rest"],
           cap_s=cap_s, cap_hit=S["cap_hit"], wall_s=wall, setup_s=setup_s,
           iterations=O.iter, simulated_time_s=O.time,
           kinetic_energy_peak_J=S["peak"], kinetic_energy_peak_iteration=S["peak_iter"],
           ms_per_iteration=wall / max(O.iter, 1) * 1e3, final=summ, trace=rec)
with open(out_path, "w") as f:
    json.dump(res, f)
print(f"yade: {'at rest' if S['at_rest'] else 'NOT at rest (cap hit)'} after {O.iter} "
      f"iterations ({O.time:.4f} s simulated) in {wall:.1f} s")
