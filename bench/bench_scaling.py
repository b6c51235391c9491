"""Scaling benchmark (issue 9, item 3): step cost and peak memory of dense packings of
1k, 4k, 16k and 64k bodies; cost per contact-sweep must stay flat within 30 %, memory
<= 2 kB per body plus the contacts.

Run:  .venv/bin/python bench/bench_scaling.py            (about 5-10 min on 2 shared cores)
      .venv/bin/python bench/bench_scaling.py --quick    (1k and 4k only, ~1 min)

Writes bench/results/scaling-YYYYMMDD-HHMM.json.

Scenes: a slightly compressed FCC packing (every lattice neighbour overlaps by 0.1-0.9 % of
r0, so ~6 contacts per body; the packing of bench_core.py) on the floor of a box, under
gravity, with the bodies numbered **at random** (``--order lattice`` keeps the lattice
numbering): a geometric deposit numbers its grains in placement order, so a real scene's
body numbering has little to do with space, and that is what a cache-friendly engine has
to cope with.  Each size runs in its own subprocess (clean peak RSS): compile, ``prep``
steps (tol 1e-4, max_iter 200), then ``steps`` timed steps at ``max_iter`` sweeps
(tol = 0, so every step does exactly ``max_iter`` sweeps: cost per contact-sweep without
the iteration count mixing in), single thread.

The yardstick in the same run: after the timed steps, ``bench/yardstick.py``'s tight sweep
and the engine's ``nlgs.sweep`` kernel each do ``sweeps`` sweeps on the same contact
arrays, in the local body layout that the engine's solve uses at these sizes
(``nlgs.layout``), interleaved, fastest of ``steps`` runs.  Its growth from 1k to 64k is
what this machine's memory system does to a minimal kernel on the same data; the ratio of
the two kernels says whether ours grows faster than that.

Memory: peak RSS above the process's RSS after imports and the numba warm-up (VmHWM reset
through /proc/self/clear_refs), the tracemalloc peak of numpy allocations, and the bytes
of every Model/State array split into per-body and per-contact parts.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

sys.path.insert(0, str(ROOT / "bench"))
import record  # noqa: E402

SIZES = {"1k": (7, 6, 6), "4k": (10, 10, 10), "16k": (16, 16, 16), "64k": (25, 25, 26)}


def packing(cells, order="random", seed=7, max_iter=200, tol=1e-4, threads=1):
    """Compressed FCC packing in a box (see the module docstring); returns (model, state)."""
    from engine import Scene, laws

    rng = np.random.default_rng(seed)
    r0 = 1e-4
    d = 2.0 * r0 * (1.0 - 0.0025)
    a = np.sqrt(2.0) * d
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    g = np.stack(np.meshgrid(*[np.arange(k) for k in cells], indexing="ij"), -1).reshape(-1, 1, 3)
    c = ((g + basis[None]) * a).reshape(-1, 3) + r0
    if order == "random":
        c = c[rng.permutation(len(c))]
    r = r0 * (1.0 + rng.uniform(-0.002, 0.002, len(c)))
    s = Scene(gravity=(0.0, 0.0, -9.81))
    s.add_spheres(c, r, density=2650.0, group="sand")
    hi = c.max(axis=0) + r0
    hi[2] *= 3.0
    s.add_box((0.0, 0.0, 0.0), hi, group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=0.3))
    s.interact("sand", "wall", laws.Coulomb(mu=0.3))
    return s.compile(dt=5e-5, theta=0.5, tol=tol, max_iter=max_iter, threads=threads)


def _status(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key):
                return int(line.split()[1]) * 1024
    return None


def _array_bytes(obj):
    out = {}
    for k, v in vars(obj).items():
        if isinstance(v, np.ndarray):
            out[k] = v.nbytes
    return out


def kernels_vs_yardstick(model, state, sweeps, reps):
    """ns per contact-sweep of the yardstick's and the engine's sweep kernels on the same
    arrays (the step's contacts in the local layout of ``nlgs.layout``); fastest of
    ``reps`` runs of ``sweeps`` sweeps each, interleaved."""
    from engine.solver import nlgs
    from yardstick import body_inverses, yard_sweep

    c = state.contacts_buf
    n = c.count
    nb = model.n_bodies
    loc = np.full(nb, -1, np.int32)
    perm = np.empty(nb, np.int32)
    li = np.empty(n, np.int32)
    lj = np.empty(n, np.int32)
    e = np.empty(0, np.int32)
    k = nlgs.layout(n, c.i, c.j, 0, e, e, loc, perm, li, lj, e.copy(), e.copy())
    p = perm[:k]
    body_dyn = np.ascontiguousarray(model.body_dyn[p])
    inv_m, inv_i = body_inverses(body_dyn)
    v0 = state.vel6[p].copy()
    imp0 = c.impulse[:n].copy()
    best = {"yardstick": np.inf, "engine": np.inf}
    for _ in range(reps):
        for name in best:
            vel = v0.copy()
            imp = c.impulse
            imp[:n] = imp0
            C = nlgs.Contacts(li, lj, c.frame, c.w, c.gterm, c.mu, c.ri, c.rj, imp)
            B = nlgs.Bodies(body_dyn, vel)
            t = time.perf_counter()
            for _ in range(sweeps):
                if name == "yardstick":
                    yard_sweep(n, li, lj, c.frame, c.w, c.gterm, c.mu, c.ri, c.rj, imp, inv_m,
                               inv_i, vel)
                else:
                    nlgs.sweep(n, c.n_pair, C, B, 1.0)
            best[name] = min(best[name], (time.perf_counter() - t) / (sweeps * n) * 1e9)
    c.impulse[:n] = imp0
    return dict(yardstick_ns_per_contact_sweep=best["yardstick"],
                engine_sweep_ns_per_contact_sweep=best["engine"],
                ratio=best["engine"] / best["yardstick"], contacts=int(n), local_bodies=int(k))


def one_size(label, order, prep, steps, sweeps, threads):
    """Child process: measure one size; prints one JSON line."""
    import numba

    numba.set_num_threads(1) if threads == 1 else None
    from engine import step
    from engine.contact import detect
    from engine.integrator import free_velocity, update
    from engine.solver.nlgs import solve

    # warm-up (numba cache load) on a tiny packing, then the RSS baseline
    m0, s0 = packing((2, 2, 2), order, threads=threads)
    for _ in range(3):
        step(m0, s0)
    kernels_vs_yardstick(m0, s0, 1, 1)
    del m0, s0
    base_rss = _status("VmRSS:")
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        hwm_reset = True
    except OSError:
        hwm_reset = False
    tracemalloc.start()
    t0 = time.perf_counter()
    model, state = packing(SIZES[label], order, threads=threads)
    t_compile = time.perf_counter() - t0
    t0 = time.perf_counter()
    prep_it = []
    for _ in range(prep):
        prep_it.append(step(model, state).iterations)
    t_prep = time.perf_counter() - t0
    timed = model.with_options(tol=0.0 + 1e-300, max_iter=sweeps)
    rows = []
    for _ in range(steps):
        ts = {}
        t = time.perf_counter()
        free_velocity(timed, state)
        ts["free_velocity"] = time.perf_counter() - t
        t = time.perf_counter()
        detect(timed, state)
        ts["detect"] = time.perf_counter() - t
        t = time.perf_counter()
        c0 = time.thread_time()
        it, res = solve(timed, state)
        ts["solve"] = time.perf_counter() - t
        ts["solve_cpu"] = time.thread_time() - c0
        t = time.perf_counter()
        update(timed, state)
        ts["update"] = time.perf_counter() - t
        ts["iterations"] = it
        ts["contacts"] = state.contacts_buf.count
        rows.append(ts)
    _, tm_peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    yard = kernels_vs_yardstick(model, state, sweeps, steps)
    peak_rss = _status("VmHWM:")
    nb = model.n_bodies
    nc = int(np.mean([r["contacts"] for r in rows]))
    step_s = [sum(r[k] for k in ("free_velocity", "detect", "solve", "update")) for r in rows]
    solve_ns = [r["solve"] / (r["iterations"] * r["contacts"]) * 1e9 for r in rows]
    solve_cpu_ns = [r["solve_cpu"] / (r["iterations"] * r["contacts"]) * 1e9 for r in rows]
    step_ns = [s / (r["iterations"] * r["contacts"]) * 1e9 for s, r in zip(step_s, rows)]
    model_b = _array_bytes(model)
    cb = state.contacts_buf
    contact_b = _array_bytes(cb)
    state_b = _array_bytes(state)
    per_contact_slot = sum(contact_b.values()) / cb.cap
    pairs_b = state_b.get("pairs", 0)
    body_b = (sum(model_b.values()) + sum(v for k, v in state_b.items() if k != "pairs")
              + pairs_b * 0)  # candidate pairs scale with contacts, counted there
    out = dict(
        label=label, order=order, n_bodies=nb, n_contacts=nc, cells=list(SIZES[label]),
        compile_s=t_compile, prep_steps=prep, prep_s=t_prep, prep_iterations=prep_it,
        timed_steps=steps, sweeps_per_step=sweeps,
        step_s_median=float(np.median(step_s)), step_s_all=step_s,
        stage_s_mean={k: float(np.mean([r[k] for r in rows]))
                      for k in ("free_velocity", "detect", "solve", "update")},
        step_ns_per_contact_sweep=float(np.median(step_ns)),
        solve_ns_per_contact_sweep=float(np.median(solve_ns)),
        solve_cpu_ns_per_contact_sweep=float(np.median(solve_cpu_ns)),
        kernels=yard,
        memory=dict(
            baseline_rss_bytes=base_rss, peak_rss_bytes=peak_rss, hwm_reset=hwm_reset,
            peak_rss_above_baseline_bytes=(peak_rss - base_rss) if hwm_reset else None,
            tracemalloc_peak_bytes=tm_peak,
            model_array_bytes=sum(model_b.values()),
            state_body_array_bytes=sum(v for k, v in state_b.items() if k != "pairs"),
            pairs_bytes=pairs_b, n_pairs=int(state.n_pairs),
            contact_buffer_bytes=sum(contact_b.values()), contact_capacity=int(cb.cap),
            bytes_per_contact_slot=per_contact_slot,
            body_bytes_per_body=body_b / nb,
            contact_bytes_per_contact=(sum(contact_b.values()) + pairs_b) / max(nc, 1),
        ),
    )
    mem = out["memory"]
    # what the process holds beyond the contact-proportional buffers, per body
    if mem["peak_rss_above_baseline_bytes"] is not None:
        mem["peak_rss_minus_contact_buffers_per_body"] = (
            mem["peak_rss_above_baseline_bytes"] - mem["contact_buffer_bytes"] - pairs_b) / nb
    print("RESULT " + json.dumps(out))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--order", default="random", choices=("random", "lattice"))
    ap.add_argument("--sizes", default=None, help="comma list among 1k,4k,16k,64k")
    ap.add_argument("--prep", type=int, default=3)
    ap.add_argument("--steps", type=int, default=3)
    ap.add_argument("--sweeps", type=int, default=50)
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        one_size(a.child, a.order, a.prep, a.steps, a.sweeps, 1)
        return 0
    sizes = a.sizes.split(",") if a.sizes else (["1k", "4k"] if a.quick else list(SIZES))
    t_all = time.perf_counter()
    busy = record.Busy()
    res = []
    for lab in sizes:
        cmd = [sys.executable, __file__, "--child", lab, "--order", a.order, "--prep",
               str(a.prep), "--steps", str(a.steps), "--sweeps", str(a.sweeps)]
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=1800)
        line = [x for x in p.stdout.splitlines() if x.startswith("RESULT ")]
        if p.returncode or not line:
            print(p.stdout[-2000:], p.stderr[-4000:])
            raise SystemExit(f"size {lab} failed")
        r = json.loads(line[0][7:])
        res.append(r)
        m = r["memory"]
        print(f"{lab:>4}: {r['n_bodies']:6d} bodies {r['n_contacts']:7d} contacts  step "
              f"{r['step_s_median'] * 1e3:8.1f} ms ({a.sweeps} sweeps)  solve "
              f"{r['solve_ns_per_contact_sweep']:5.1f} ns/contact-sweep (cpu "
              f"{r['solve_cpu_ns_per_contact_sweep']:5.1f}; kernel "
              f"{r['kernels']['engine_sweep_ns_per_contact_sweep']:5.1f} vs yardstick "
              f"{r['kernels']['yardstick_ns_per_contact_sweep']:5.1f})  peak RSS +"
              f"{(m['peak_rss_above_baseline_bytes'] or 0) / 2**20:6.1f} MiB, "
              f"{m['body_bytes_per_body']:.0f} B/body + {m['contact_bytes_per_contact']:.0f} B/contact",
              flush=True)
    base = res[0]["solve_ns_per_contact_sweep"]
    base_cpu = res[0]["solve_cpu_ns_per_contact_sweep"]
    worst = max(r["solve_ns_per_contact_sweep"] for r in res) / min(
        r["solve_ns_per_contact_sweep"] for r in res)
    worst_cpu = max(r["solve_cpu_ns_per_contact_sweep"] for r in res) / min(
        r["solve_cpu_ns_per_contact_sweep"] for r in res)
    mem_ok = all(
        r["memory"]["body_bytes_per_body"] <= 2048
        and (r["memory"].get("peak_rss_minus_contact_buffers_per_body") is None
             or r["memory"]["peak_rss_minus_contact_buffers_per_body"] <= 2048)
        for r in res)
    out = dict(
        benchmark="scaling", started=_dt.datetime.now().isoformat(timespec="seconds"),
        command="  ".join(["cd", str(ROOT), "&&", ".venv/bin/python bench/bench_scaling.py"]
                          + (sys.argv[1:] if argv is None else list(argv))),
        machine=record.machine(), busy=busy.finish(),
        note="Single thread; each size in its own process.",
        git=record.git_commit(),
        params=dict(order=a.order, prep_steps=a.prep, timed_steps=a.steps,
                    sweeps_per_step=a.sweeps, dt=5e-5, mu=0.3, r0=1e-4),
        sizes=res,
        summary=dict(
            solve_ns_per_contact_sweep={r["label"]: r["solve_ns_per_contact_sweep"] for r in res},
            solve_cpu_ns_per_contact_sweep={r["label"]: r["solve_cpu_ns_per_contact_sweep"]
                                            for r in res},
            relative_to_smallest={r["label"]: r["solve_ns_per_contact_sweep"] / base for r in res},
            relative_to_smallest_cpu={r["label"]: r["solve_cpu_ns_per_contact_sweep"] / base_cpu
                                      for r in res},
            max_over_min=worst, max_over_min_cpu=worst_cpu, flat_target=1.3,
            yardstick_ns_per_contact_sweep={
                r["label"]: r["kernels"]["yardstick_ns_per_contact_sweep"] for r in res},
            yardstick_max_over_min=(
                max(r["kernels"]["yardstick_ns_per_contact_sweep"] for r in res)
                / min(r["kernels"]["yardstick_ns_per_contact_sweep"] for r in res)),
            kernel_over_yardstick={r["label"]: r["kernels"]["ratio"] for r in res},
            flat_ok=worst <= 1.3, flat_ok_cpu=worst_cpu <= 1.3,
            memory_target_bytes_per_body=2048, memory_ok=mem_ok),
        total_wall_s=time.perf_counter() - t_all)
    path = record.write("scaling", out, quick=a.quick)
    print(f"flat: max/min {worst:.2f} (cpu {worst_cpu:.2f}; target <= 1.3); yardstick on the "
          f"same arrays max/min {out['summary']['yardstick_max_over_min']:.2f}; memory ok: {mem_ok}")
    print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
