"""Core benchmark of the engine: NLGS sweep cost against a tight yardstick, and the cost of
a step split into its four stages on gravity deposits of 1 000 and 10 000 spheres.

Run:  .venv/bin/python bench/bench_core.py      (or ``make bench``; about 4-5 min on 2 cores)
      .venv/bin/python bench/bench_core.py --quick   (a smoke run of a few seconds)

Writes bench/results/core-<YYYYmmdd-HHMM>.json and bench/results/core-latest.json.

What is measured (bench/README.md has the details):

1. ``sweep``: ns per contact per NLGS sweep of ``engine.solver.nlgs.sweep`` and of the
   yardstick ``bench.yardstick.yard_sweep`` on the same contact arrays, single thread,
   interleaved repetitions in the same process, median (and min) over repetitions.  The
   contacts are those of a slightly compressed FCC packing (> 20 000 contacts) after a few
   engine steps (real frames, Delassus diagonals and warm impulses), and again on the final
   state of the 10 000-sphere deposit.
2. ``deposit``: wall time per step and its split into free_velocity / detect / solve /
   update (called in that order, exactly as ``engine.step.step`` does), NLGS sweeps and
   contacts per step, for gravity deposits of 1 000 and 10 000 spheres.  Numba compilation
   is excluded (a tiny scene warms every kernel up first) and reported separately: in this
   process (usually a load from numba's on-disk cache) and cold, in a subprocess with an
   empty cache directory.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from functools import partial
from pathlib import Path

_T_START = time.perf_counter()
ROOT = Path(__file__).resolve().parent.parent
BENCH = ROOT / "bench"
for _p in (str(ROOT), str(BENCH)):
    if _p not in sys.path:
        sys.path.insert(0, _p)

import numpy as np  # noqa: E402

_T0 = time.perf_counter()
import numba  # noqa: E402

from engine import Scene, laws, step  # noqa: E402
from engine.contact import detect  # noqa: E402
from engine.integrator import free_velocity, update  # noqa: E402
from engine.solver import nlgs  # noqa: E402
from engine.solver.nlgs import Bodies, Contacts, solve, sweep  # noqa: E402
import record  # noqa: E402
from yardstick import body_inverses, yard_sweep  # noqa: E402

IMPORT_S = time.perf_counter() - _T0

#: Physical and solver parameters of the deposits (peers.md's comparison set-up).
DEPOSIT = dict(r_min=1e-4, r_max=3e-4, density=2650.0, mu=0.3, dt=5e-5, theta=0.5, tol=1e-4,
               max_iter=1000, gravity=(0.0, 0.0, -9.81), spacing_factor=1.05, seed=12345)
#: The dense packing of the sweep benchmark.
PACKING = dict(cells=(12, 12, 10), r0=1e-4, compression=0.0025, polydispersity=0.002,
               density=2650.0, mu=0.3, dt=5e-5, theta=0.5, tol=1e-4, max_iter=1000,
               prep_steps=5, seed=7)
QUICK_PACKING = dict(PACKING, cells=(5, 5, 4), prep_steps=3)
STAGES = ("free_velocity", "detect", "solve", "update")


# ---------------------------------------------------------------------------------------
# scenes
# ---------------------------------------------------------------------------------------
def deposit_scene(nx: int, ny: int, nz: int, p: dict = DEPOSIT):
    """Loose cubic lattice of nx*ny*nz spheres (radii uniform r_min..r_max) just above the
    floor of an open box (floor + 4 walls).  Lattice spacing ``spacing_factor * 2 r_max``;
    each sphere is shifted sideways at random within its own lattice cell (so that columns
    do not stay stacked; no overlap, nothing outside the box); the bottom layer starts
    0.02 r_max above the floor for the largest spheres."""
    rng = np.random.default_rng(p["seed"])
    n = nx * ny * nz
    r = rng.uniform(p["r_min"], p["r_max"], n)
    sp = 2.0 * p["r_max"] * p["spacing_factor"]
    g = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"),
                 -1).reshape(-1, 3).astype(float)
    c = (g + 0.5) * sp
    c[:, :2] += rng.uniform(-1.0, 1.0, (n, 2)) * 0.9 * (0.5 * sp - r)[:, None]
    z0 = 1.02 * p["r_max"]
    c[:, 2] = z0 + g[:, 2] * sp
    s = Scene(gravity=p["gravity"])
    s.add_spheres(c, r, density=p["density"], group="sand")
    hi = (nx * sp, ny * sp, z0 + nz * sp)
    s.add_box((0.0, 0.0, 0.0), hi, group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=p["mu"]))
    s.interact("sand", "wall", laws.Coulomb(mu=p["mu"]))
    model, state = s.compile(dt=p["dt"], theta=p["theta"], tol=p["tol"], max_iter=p["max_iter"])
    geom = dict(n_spheres=n, lattice=[nx, ny, nz], spacing_m=sp, box_lo_m=[0.0, 0.0, 0.0],
                box_hi_m=list(hi), bottom_layer_centre_z_m=z0,
                lateral_jitter="uniform within +-0.9 (spacing/2 - r) per sphere")
    return model, state, geom


def packing_scene(p: dict = PACKING, extra=None):
    """FCC lattice of nearly equal spheres, nearest-neighbour distance (1 - compression)
    2 r0, radii r0 (1 ± polydispersity): every lattice neighbour overlaps by 0.1-0.9 % of
    r0 (below Scene.compile's 1 % check), so all 12 neighbours are contacts.  The lattice
    rests on the floor of a box whose four side walls touch it; gravity on.

    ``extra(scene, hi)``, if given, may add bodies to the scene (box corner ``hi``) before
    it is compiled (bench_wire.py adds a small wire above the packing)."""
    rng = np.random.default_rng(p["seed"])
    r0 = p["r0"]
    d = 2.0 * r0 * (1.0 - p["compression"])
    a = np.sqrt(2.0) * d
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    g = np.stack(np.meshgrid(*[np.arange(k) for k in p["cells"]], indexing="ij"),
                 -1).reshape(-1, 1, 3)
    c = ((g + basis[None]) * a).reshape(-1, 3) + r0
    n = c.shape[0]
    r = r0 * (1.0 + rng.uniform(-p["polydispersity"], p["polydispersity"], n))
    s = Scene(gravity=(0.0, 0.0, -9.81))
    s.add_spheres(c, r, density=p["density"], group="sand")
    hi = c.max(axis=0) + r0
    hi[2] *= 3.0
    s.add_box((0.0, 0.0, 0.0), hi, group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=p["mu"]))
    s.interact("sand", "wall", laws.Coulomb(mu=p["mu"]))
    if extra is not None:
        extra(s, hi)
    model, state = s.compile(dt=p["dt"], theta=p["theta"], tol=p["tol"], max_iter=p["max_iter"])
    return model, state, dict(n_spheres=n, nn_distance_m=d, box_hi_m=hi.tolist())


# ---------------------------------------------------------------------------------------
# warm-up (numba compilation or cache load)
# ---------------------------------------------------------------------------------------
def _sweep_args(model, state):
    """Contact arguments of the yardstick."""
    c = state.contacts_buf
    return (c.count, c.i, c.j, c.frame, c.w, c.gterm, c.mu, c.ri, c.rj)


def _ours_args(model, state):
    """Contact arguments of ``nlgs.sweep`` (it also takes the sphere–sphere count n_pair):
    (n, n_pair, then the fields of its ``Contacts`` tuple but the impulses)."""
    c = state.contacts_buf
    return (c.count, c.n_pair) + _sweep_args(model, state)[1:]


def warm_up() -> dict:
    """Run every kernel the benchmark times once on a tiny scene (27 spheres)."""
    t0 = time.perf_counter()
    model, state, _ = deposit_scene(3, 3, 3)
    t1 = time.perf_counter()
    step(model, state)
    t2 = time.perf_counter()
    for _ in range(60):  # contacts form: every kernel runs with n > 0
        free_velocity(model, state)
        detect(model, state)
        solve(model, state)
        update(model, state)
    c = state.contacts_buf
    assert c.count > 0, "warm-up scene has no contact"
    t3 = time.perf_counter()
    args = _sweep_args(model, state)
    oargs = _ours_args(model, state)
    im, ii = body_inverses(model.body_dyn)
    sweep(*oargs[:2], Contacts(*oargs[2:], c.impulse.copy()),
          Bodies(model.body_dyn, state.vel6.copy()), model.options.relax)
    yard_sweep(*args, c.impulse.copy(), im, ii, state.vel6.copy())
    t4 = time.perf_counter()
    return dict(scene_compile_s=t1 - t0, first_step_s=t2 - t1, next_60_steps_s=t3 - t2,
                sweep_and_yardstick_first_call_s=t4 - t3, total_s=t4 - t0,
                contacts_at_end=int(c.count))


def numba_cache_stats() -> dict:
    """Cache hits / misses of the timed kernels in this process."""
    import importlib

    broadphase = importlib.import_module("engine.contact.broadphase")
    narrowphase = importlib.import_module("engine.contact.narrowphase")
    integrator = importlib.import_module("engine.integrator")

    out = {}
    for mod, names in ((nlgs, ("prepare", "iterate", "sweep", "warm_store")),
                       (broadphase, ("build_pairs", "max_displacement")),
                       (narrowphase, ("narrowphase",)),
                       (integrator, ("_free_velocity", "_update"))):
        for name in names:
            st = getattr(mod, name).stats
            out[f"{mod.__name__}.{name}"] = dict(hits=sum(st.cache_hits.values()),
                                                 misses=sum(st.cache_misses.values()))
    st = yard_sweep.stats
    out["bench.yardstick.yard_sweep"] = dict(hits=sum(st.cache_hits.values()),
                                             misses=sum(st.cache_misses.values()))
    return out


def cold_compile(timeout: float = 300.0) -> dict:
    """Import + warm-up in a subprocess whose numba cache directory is empty."""
    with tempfile.TemporaryDirectory(prefix="nscd-bench-numba-") as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=tmp)
        t0 = time.perf_counter()
        try:
            out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--_cold-probe"],
                                 env=env, capture_output=True, text=True, timeout=timeout,
                                 cwd=str(ROOT))
        except subprocess.TimeoutExpired:
            return dict(error=f"timed out after {timeout} s")
        wall = time.perf_counter() - t0
    if out.returncode != 0:
        return dict(error=out.stderr[-2000:])
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res["subprocess_wall_s"] = wall
    return res


# ---------------------------------------------------------------------------------------
# 1. sweep cost: production kernel vs yardstick
# ---------------------------------------------------------------------------------------
def time_sweeps(model, state, reps: int = 11, target_s: float = 0.03) -> dict:
    """ns/contact/sweep of ``nlgs.sweep`` and ``yard_sweep`` on ``state.contacts_buf``.

    Both start every repetition from the same copies of vel6 and impulses; repetitions
    alternate between the two kernels (so that load changes hit both alike).
    """
    c = state.contacts_buf
    n = int(c.count)
    args = _sweep_args(model, state)
    oargs = _ours_args(model, state)
    bd = model.body_dyn
    relax = model.options.relax
    im, ii = body_inverses(bd)
    v0 = state.vel6.copy()
    p0 = c.impulse.copy()

    # same answer? one sweep each from the same state
    va, pa = v0.copy(), p0.copy()
    num_a, den_a = sweep(*oargs[:2], Contacts(*oargs[2:], pa), Bodies(bd, va), relax)
    vb, pb = v0.copy(), p0.copy()
    num_b, den_b = yard_sweep(*args, pb, im, ii, vb)
    check = dict(max_rel_diff_impulse=float(np.abs(pa[:n] - pb[:n]).max() / max(np.abs(pa[:n]).max(), 1e-300)),
                 max_rel_diff_vel6=float(np.abs(va - vb).max() / max(np.abs(va).max(), 1e-300)),
                 quad_sums_ours=[num_a, den_a], quad_sums_yardstick=[num_b, den_b])

    # sweeps per repetition so that one repetition lasts about target_s
    t = time.perf_counter()
    sweep(*oargs[:2], Contacts(*oargs[2:], pa), Bodies(bd, va), relax)
    one = max(time.perf_counter() - t, 1e-7)
    k = max(3, int(target_s / one))

    def timed(make):
        """k sweeps from the same starting copies: (wall, cpu) seconds; ``make(p, v)``
        returns one sweep on the copies p, v (its argument tuples built before the clock)."""
        v, p = v0.copy(), p0.copy()
        one_sweep = make(p, v)
        c0 = time.thread_time()
        t0 = time.perf_counter()
        for _ in range(k):
            one_sweep()
        return time.perf_counter() - t0, time.thread_time() - c0

    def run_ours():
        return timed(lambda p, v: partial(sweep, *oargs[:2], Contacts(*oargs[2:], p),
                                          Bodies(bd, v), relax))

    def run_yard():
        return timed(lambda p, v: partial(yard_sweep, *args, p, im, ii, v))

    run_ours()  # warm caches and branch predictors
    run_yard()
    ours, yard, ours_cpu, yard_cpu = [], [], [], []
    for r in range(reps):
        order = (run_ours, run_yard) if r % 2 == 0 else (run_yard, run_ours)
        for f in order:
            wall, cpu = f()
            (ours if f is run_ours else yard).append(wall / (k * n) * 1e9)
            (ours_cpu if f is run_ours else yard_cpu).append(cpu / (k * n) * 1e9)
    ours_a, yard_a = np.asarray(ours), np.asarray(yard)
    oc, yc = np.asarray(ours_cpu), np.asarray(yard_cpu)
    imp = c.impulse[:n]
    active = imp[:, 0] > 0.0
    sliding = active & (np.hypot(imp[:, 1], imp[:, 2]) >= 0.999 * c.mu[:n] * imp[:, 0])
    return dict(
        n_contacts=n, n_bodies=int(model.n_bodies),
        n_wall_contacts=int(np.sum(c.rj[:n] == 0.0)),
        active_fraction=float(active.mean()), sliding_fraction=float(sliding.mean()),
        sweeps_per_repetition=k, repetitions=reps,
        ours_ns=dict(median=float(np.median(ours_a)), min=float(ours_a.min()), all=ours),
        yardstick_ns=dict(median=float(np.median(yard_a)), min=float(yard_a.min()), all=yard),
        cpu_time_ns=dict(note="time.thread_time (CPU time of this thread: not inflated "
                              "when the scheduler runs another process instead)",
                         ours_median=float(np.median(oc)), yardstick_median=float(np.median(yc)),
                         ratio_of_medians=float(np.median(oc) / np.median(yc)),
                         ours_all=ours_cpu, yardstick_all=yard_cpu),
        ratio_of_medians=float(np.median(ours_a) / np.median(yard_a)),
        ratio_of_mins=float(ours_a.min() / yard_a.min()),
        median_of_paired_ratios=float(np.median(ours_a / yard_a)),
        same_answer=check)


def bench_sweep_packing(p: dict) -> dict:
    t0 = time.perf_counter()
    model, state, geom = packing_scene(p)
    prep = []
    for _ in range(p["prep_steps"]):
        ts = time.perf_counter()
        st = step(model, state)
        prep.append(dict(iterations=st.iterations, residual=st.residual, converged=st.converged,
                         n_contacts=st.n_contacts, wall_s=time.perf_counter() - ts))
    res = time_sweeps(model, state)
    res.update(scene=geom, prep_steps=prep, setup_and_timing_s=time.perf_counter() - t0)
    return res


# ---------------------------------------------------------------------------------------
# 2. deposits: step cost by stage
# ---------------------------------------------------------------------------------------
def bench_deposit(dims, steps: int, max_wall_s: float, window: int = 50, label: str = ""):
    t0 = time.perf_counter()
    model, state, geom = deposit_scene(*dims)
    compile_s = time.perf_counter() - t0
    tm = np.zeros((steps, 4))
    its = np.zeros(steps, np.int64)
    res = np.zeros(steps)
    nc = np.zeros(steps, np.int64)
    rebuilt = np.zeros(steps, bool)
    tol = model.options.tol
    pc = time.perf_counter
    start = pc()
    cpu0 = time.process_time()
    done = 0
    stopped_by = "steps"
    last_print = start
    for k in range(steps):
        a = pc()
        free_velocity(model, state)
        b = pc()
        rebuilt[k] = detect(model, state)
        c = pc()
        it, r = solve(model, state)
        d = pc()
        update(model, state)
        e = pc()
        tm[k] = (b - a, c - b, d - c, e - d)
        its[k] = it
        res[k] = r
        nc[k] = state.contacts_buf.count
        done = k + 1
        if e - last_print > 20.0:
            last_print = e
            print(f"    {label} step {done}/{steps}: {nc[k]} contacts, {it} sweeps, "
                  f"{e - start:.0f} s", flush=True)
        if e - start > max_wall_s and done < steps:
            stopped_by = f"wall-time cap {max_wall_s:g} s"
            break
    wall = pc() - start
    cpu = time.process_time() - cpu0
    tm, its, res, nc, rebuilt = tm[:done], its[:done], res[:done], nc[:done], rebuilt[:done]
    finite = bool(np.isfinite(state.position).all() and np.isfinite(state.vel6).all())
    total = tm.sum(axis=0)
    step_s = tm.sum(axis=1)
    conv = res < tol
    sweeps_x_contacts = float(np.sum(its.astype(float) * nc))
    sph = model.sphere_ids
    z = state.position[sph, 2]
    tail = slice(max(0, done - max(1, done // 10)), done)

    def stage_dict(sel):
        s = tm[sel]
        return {name: dict(mean_ms=float(s[:, q].mean() * 1e3), total_s=float(s[:, q].sum()),
                           fraction=float(s[:, q].sum() / max(s.sum(), 1e-300)))
                for q, name in enumerate(STAGES)}

    trace = []
    for w0 in range(0, done, window):
        sl = slice(w0, min(done, w0 + window))
        trace.append(dict(steps=[w0 + 1, sl.stop], contacts_mean=float(nc[sl].mean()),
                          sweeps_mean=float(its[sl].mean()), sweeps_max=int(its[sl].max()),
                          non_converged=int((~conv[sl]).sum()),
                          step_ms=float(step_s[sl].mean() * 1e3),
                          stage_ms=[float(x) for x in tm[sl].mean(axis=0) * 1e3]))
    return dict(
        scene=geom, options=model.options.model_dump(), steps_requested=steps, steps_done=done, stopped_by=stopped_by,
        simulated_time_s=float(state.time), scene_compile_s=compile_s, wall_s=wall,
        cpu_s=cpu, cpu_over_wall=cpu / wall if wall > 0 else None,
        step_ms=dict(mean=float(step_s.mean() * 1e3), median=float(np.median(step_s) * 1e3),
                     max=float(step_s.max() * 1e3),
                     last_10pct_mean=float(step_s[tail].mean() * 1e3)),
        stages=stage_dict(slice(0, done)),
        stages_last_10pct=stage_dict(tail),
        stage_totals_s={name: float(total[q]) for q, name in enumerate(STAGES)},
        nlgs=dict(sweeps_mean=float(its.mean()), sweeps_max=int(its.max()),
                  sweeps_last_10pct_mean=float(its[tail].mean()),
                  non_converged_steps=int((~conv).sum()),
                  non_converged_first=[int(x) + 1 for x in np.flatnonzero(~conv)[:20]],
                  residual_max=float(res.max()),
                  solve_ns_per_contact_per_sweep=(float(total[2] / sweeps_x_contacts * 1e9)
                                                  if sweeps_x_contacts else None)),
        contacts=dict(mean=float(nc.mean()), max=int(nc.max()), final=int(nc[-1]),
                      first_step_with_contacts=(int(np.argmax(nc > 0)) + 1) if nc.any() else None),
        broadphase_rebuilds=int(rebuilt.sum()),
        final_state=dict(finite=finite, sphere_z_max_m=float(z.max()),
                         sphere_speed_max_m_s=float(np.linalg.norm(state.vel6[sph, :3], axis=1).max())),
        trace=trace,
    ), model, state


# ---------------------------------------------------------------------------------------
# machine, repository
# ---------------------------------------------------------------------------------------
def _git(*args) -> str | None:
    try:
        return subprocess.run(["git", *args], cwd=str(ROOT), capture_output=True, text=True,
                              timeout=20).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None


def _engine_hash() -> str:
    h = hashlib.sha256()
    for f in sorted((ROOT / "engine").rglob("*.py")):
        h.update(str(f.relative_to(ROOT)).encode())
        h.update(f.read_bytes())
    return h.hexdigest()


def machine_info() -> dict:
    """record.machine() and the thread set-up (the run's ``busy`` figure: record.Busy)."""
    return dict(
        record.machine(),
        sched_affinity=len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        numba_default_threads=int(numba.config.NUMBA_NUM_THREADS),
        loadavg_start=list(os.getloadavg()))


# ---------------------------------------------------------------------------------------
def _fmt_sweep(name, r):
    return (f"  {name}: {r['n_contacts']} contacts ({r['n_bodies']} bodies, "
            f"{r['active_fraction']:.0%} active, {r['sliding_fraction']:.0%} sliding)\n"
            f"    ours      {r['ours_ns']['median']:6.1f} ns/contact/sweep (min {r['ours_ns']['min']:.1f})\n"
            f"    yardstick {r['yardstick_ns']['median']:6.1f} ns/contact/sweep (min {r['yardstick_ns']['min']:.1f})\n"
            f"    ratio     {r['ratio_of_medians']:6.2f}x  (target <= 1.5x; paired {r['median_of_paired_ratios']:.2f}x; "
            f"same answer: impulses to {r['same_answer']['max_rel_diff_impulse']:.1e})\n"
            f"    CPU time  ours {r['cpu_time_ns']['ours_median']:.1f}, yardstick "
            f"{r['cpu_time_ns']['yardstick_median']:.1f} ns/contact/sweep, ratio "
            f"{r['cpu_time_ns']['ratio_of_medians']:.2f}x (thread_time; robust to a busy machine)")


def _fmt_deposit(name, r):
    s = r["stages"]
    n = r["nlgs"]
    lines = [f"  {name}: {r['steps_done']} steps ({r['stopped_by']}), t = {r['simulated_time_s']:.4g} s, "
             f"wall {r['wall_s']:.1f} s (CPU {r['cpu_s']:.1f} s), {r['contacts']['final']} contacts at the end "
             f"(mean {r['contacts']['mean']:.0f}, max {r['contacts']['max']})",
             f"    step {r['step_ms']['mean']:.2f} ms mean, {r['step_ms']['median']:.2f} median, "
             f"{r['step_ms']['max']:.1f} max, {r['step_ms']['last_10pct_mean']:.1f} over the last 10 %",
             "    " + ", ".join(f"{k} {v['mean_ms']:.3f} ms ({v['fraction']:.1%})" for k, v in s.items()),
             f"    NLGS sweeps/step mean {n['sweeps_mean']:.1f}, max {n['sweeps_max']} "
             f"(last 10 %: {n['sweeps_last_10pct_mean']:.0f}); {n['non_converged_steps']} steps hit "
             f"max_iter (max residual {n['residual_max']:.2g}); solve = "
             + (f"{n['solve_ns_per_contact_per_sweep']:.1f} ns/contact/sweep all included"
                if n['solve_ns_per_contact_per_sweep'] else "n/a")]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="smoke run: small sizes, few steps")
    ap.add_argument("--steps-1k", type=int, default=1500)
    ap.add_argument("--steps-10k", type=int, default=1000)
    ap.add_argument("--max-wall-10k", type=float, default=300.0,
                    help="stop the 10 000-sphere deposit after this many seconds [s]")
    ap.add_argument("--no-cold-compile", action="store_true",
                    help="skip the cold-compile subprocess")
    ap.add_argument("--out-dir", default=str(BENCH / "results"))
    ap.add_argument("--_cold-probe", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)

    if a._cold_probe:  # subprocess of cold_compile(): print timings as one JSON line
        w = warm_up()
        print(json.dumps(dict(import_s=IMPORT_S, warm_up=w, cache=numba_cache_stats())))
        return 0

    if a.quick:
        dims_1k, dims_10k = (5, 5, 4), (8, 8, 6)
        a.steps_1k, a.steps_10k = min(a.steps_1k, 300), min(a.steps_10k, 200)
        pack = QUICK_PACKING
    else:
        dims_1k, dims_10k = (10, 10, 10), (25, 25, 16)
        pack = PACKING
    stamp = _dt.datetime.now()
    busy = record.Busy()
    out = dict(benchmark="core", started=stamp.isoformat(timespec="seconds"), quick=a.quick,
               machine=machine_info(),
               git=dict(commit=_git("rev-parse", "HEAD"),
                        dirty_engine=(_git("status", "--porcelain", "--", "engine") or "").splitlines(),
                        engine_sources_sha256=_engine_hash()))
    print(f"nscd-workbench core benchmark  ({out['machine']['cpu_model']}, {out['machine']['nproc']} cpus, "
          f"numba {numba.__version__}, numpy {np.__version__}, commit {(out['git']['commit'] or '?')[:10]})")

    # -- compilation --------------------------------------------------------------------
    print("compilation (excluded from every figure below)")
    w = warm_up()
    comp = dict(import_s=IMPORT_S, warm_up_in_process=w, cache=numba_cache_stats())
    misses = sum(v["misses"] for v in comp["cache"].values())
    print(f"  this process: import {IMPORT_S:.2f} s, tiny-scene warm-up {w['total_s']:.2f} s "
          f"({'numba cache loads' if misses == 0 else f'{misses} kernels compiled'})")
    if not a.no_cold_compile:
        cold = cold_compile()
        comp["cold"] = cold
        if "error" in cold:
            print(f"  cold compile FAILED: {cold['error'][:300]}")
        else:
            print(f"  cold (empty numba cache, subprocess): import {cold['import_s']:.2f} s + "
                  f"warm-up {cold['warm_up']['total_s']:.1f} s (first step {cold['warm_up']['first_step_s']:.1f} s)")
    out["compilation"] = comp

    # -- 1. sweep vs yardstick ------------------------------------------------------------
    default_threads = numba.get_num_threads()
    numba.set_num_threads(1)
    print("1. NLGS sweep, single thread (numba.set_num_threads(1))")
    sw = bench_sweep_packing(pack)
    sw["params"] = {k: list(v) if isinstance(v, tuple) else v for k, v in pack.items()}
    print(_fmt_sweep("dense FCC packing", sw))
    out["sweep"] = dict(packing=sw, numba_threads=1,
                        yardstick="bench/yardstick.py:yard_sweep (scalar frictional GS, "
                                  "translation + rotation updates, Quad sums; no LINE walls, "
                                  "no relaxation)")
    numba.set_num_threads(default_threads)

    # -- 2. deposits ---------------------------------------------------------------------
    print(f"2. gravity deposits (step = free_velocity, detect, solve, update; numba threads "
          f"{default_threads})")
    out["deposit"] = dict(params={k: list(v) if isinstance(v, tuple) else v for k, v in DEPOSIT.items()},
                          numba_threads=default_threads)
    n1 = int(np.prod(dims_1k))
    r1, _, _ = bench_deposit(dims_1k, a.steps_1k, max_wall_s=float("inf"), label=f"{n1}")
    out["deposit"][f"n{n1}"] = r1
    print(_fmt_deposit(f"{n1} spheres", r1))
    n10 = int(np.prod(dims_10k))
    r10, m10, s10 = bench_deposit(dims_10k, a.steps_10k, max_wall_s=a.max_wall_10k, label=f"{n10}")
    out["deposit"][f"n{n10}"] = r10
    print(_fmt_deposit(f"{n10} spheres", r10))

    # -- 1b. sweep vs yardstick on the deposit's final contacts -----------------------------
    if s10.contacts_buf.count > 0:
        numba.set_num_threads(1)
        sd = time_sweeps(m10, s10)
        numba.set_num_threads(default_threads)
        out["sweep"][f"deposit{n10}_final_state"] = sd
        print("1b. NLGS sweep on the final contacts of the deposit, single thread")
        print(_fmt_sweep(f"{n10}-sphere deposit after {r10['steps_done']} steps", sd))

    out["machine"]["loadavg_end"] = list(os.getloadavg())
    out["busy"] = busy.finish()
    out["total_wall_s"] = time.perf_counter() - _T_START
    sp = out["sweep"]["packing"]
    out["summary"] = dict(
        sweep_n_contacts=sp["n_contacts"],
        sweep_ours_ns_per_contact=sp["ours_ns"]["median"],
        sweep_yardstick_ns_per_contact=sp["yardstick_ns"]["median"],
        sweep_ratio=sp["ratio_of_medians"], sweep_ratio_paired=sp["median_of_paired_ratios"],
        sweep_ratio_target=1.5,
        sweep_ratio_ok=sp["ratio_of_medians"] <= 1.5,
        **{f"step_ms_mean_n{k}": out["deposit"][f"n{k}"]["step_ms"]["mean"] for k in (n1, n10)},
        **{f"nlgs_fraction_n{k}": out["deposit"][f"n{k}"]["stages"]["solve"]["fraction"] for k in (n1, n10)},
        **{f"non_converged_steps_n{k}": out["deposit"][f"n{k}"]["nlgs"]["non_converged_steps"] for k in (n1, n10)},
        cold_compile_s=(comp.get("cold", {}).get("warm_up", {}).get("total_s")),
    )
    sd = out["sweep"].get(f"deposit{n10}_final_state")
    if sd is not None:
        out["summary"].update(
            sweep_deposit_n_contacts=sd["n_contacts"],
            sweep_deposit_ours_ns_per_contact=sd["ours_ns"]["median"],
            sweep_deposit_yardstick_ns_per_contact=sd["yardstick_ns"]["median"],
            sweep_deposit_ratio=sd["ratio_of_medians"],
            sweep_deposit_ratio_ok=sd["ratio_of_medians"] <= 1.5)
    bad = [k for k in ("sweep_ratio_ok", "sweep_deposit_ratio_ok") if out["summary"].get(k) is False]
    if bad:
        print(f"NOTE: our sweep is above 1.5x the yardstick ({', '.join(bad)})")
    if (_engine_hash() != out["git"]["engine_sources_sha256"]):
        out["git"]["warning"] = "engine/ sources changed while the benchmark ran"
        print("WARNING: engine/ sources changed while the benchmark ran")

    od = Path(a.out_dir)
    od.mkdir(parents=True, exist_ok=True)
    name = f"core-{stamp.strftime('%Y%m%d-%H%M')}" + ("-quick" if a.quick else "") + ".json"
    text = json.dumps(out, indent=1, default=_json_default)
    (od / name).write_text(text)
    (od / ("core-latest-quick.json" if a.quick else "core-latest.json")).write_text(text)
    print(f"total {out['total_wall_s']:.0f} s; wrote {od / name}")
    return 0


_json_default = record._json_default


if __name__ == "__main__":
    sys.exit(main())
