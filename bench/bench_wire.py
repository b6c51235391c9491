"""Wire benchmark: cost of a link in the NLGS sweep next to a contact, NLGS sweeps to
tolerance on a long chain for each wire law, frequency error of the beaded string against
h and θ, and proof that a scene without wires pays nothing for them.

Run:  .venv/bin/python bench/bench_wire.py      (about 4-5 min on 2 cores)
      .venv/bin/python bench/bench_wire.py --quick   (a smoke run of about 20 s)

Writes bench/results/wire-<YYYYmmdd-HHMM>.json and bench/results/wire-latest.json.
Single numba thread throughout (``numba.set_num_threads(1)``).

What is measured (bench/README.md, "Wire benchmark", has the details):

1. ``link_sweep``: ns per link per ``engine.solver.nlgs.link_sweep`` call on a 20 000-link
   wire hanging in 1 000 arcs between supports (RigidWire and ElasticWire(k=1)), next to ns per contact per contact
   ``sweep`` on bench_core's dense packing, interleaved repetitions in the same process,
   median over repetitions.  The arrays are exactly those ``solve`` passed to ``iterate``
   on the last of a few engine steps, swept in the engine's order (``model.link_order``:
   even positions along each wire, then odd ones).  The same links are also timed in
   plain order along the wire to show what the serial dependency along the chain costs.
2. ``chain``: a 1 000-bead chain fixed at both ends (circular-arc start, end distance
   0.8 × its length) under gravity, for RigidRod, ElasticRod, RigidWire, ElasticWire at
   θ = 0.5 and 1: NLGS sweeps per step, steps at max_iter, step time, link-length error
   and the true residual of the link laws at the "converged" solution.  Then a θ check:
   the θ-predicted configurations of a small chain at θ = 0.5, 0.75 and 1 compared.
3. ``string``: ``engine.validation.beaded_string`` for h ω₁ from 0.3 down to 0.005 and
   θ ∈ {0.5, 0.75, 1}: relative frequency error, wall time, convergence order.
4. ``no_wire``: ``iterate`` with nl = 0 (what ``solve`` runs for a sand-only scene) against
   the bare contact ``sweep`` called as many times, and against the same contacts plus a
   2-bead wire (nl = 1), on the packing's contacts and on a small packing (1 024 spheres).
"""
from __future__ import annotations

import argparse
import datetime as _dt
import inspect
import json
import os
import sys
import time
from pathlib import Path

_T_START = time.perf_counter()
ROOT = Path(__file__).resolve().parent.parent
BENCH = ROOT / "bench"
for _p in (str(ROOT), str(BENCH)):
    if _p not in sys.path:
        sys.path.insert(0, _p)

import numpy as np  # noqa: E402
import numba  # noqa: E402
from numba import njit  # noqa: E402

import bench_core as core  # noqa: E402
from engine import Scene, laws, step  # noqa: E402
from engine.contact import detect  # noqa: E402
from engine.integrator import free_velocity, update  # noqa: E402
from engine.solver import nlgs  # noqa: E402
from engine.solver.nlgs import (Bodies, Contacts, Links, iterate, link_prepare,  # noqa: E402
                                link_sweep, solve, sweep)
from engine.validation import beaded_string  # noqa: E402

#: 1. the long wire of the link-sweep timing: 1 000 arcs of 20 links hanging between supports
#: (fixed beads) at the same height, end distance of each arc 0.8 x its length.
LINK = dict(n_links=20000, links_per_arc=20, span_ratio=0.8, bead_radius=1e-4, density=1400.0,
            spacing_r=2.2, elastic_stiffness=1.0,
            gravity=(0.0, 0.0, -9.81), dt=5e-5, theta=0.5, tol=1e-4, prep_steps=5,
            prep_max_iter=200, reps=11, target_s=0.03)
#: 2. the long chain of the iteration counts.
CHAIN = dict(n_beads=1000, bead_radius=1e-4, density=1400.0, spacing_r=2.2, span_ratio=0.8,
             stiffness=10.0, gravity=(0.0, 0.0, -9.81), dt=5e-5, thetas=(0.5, 1.0), tol=1e-4,
             max_iter=20000, steps=300, max_wall_s=24.0, diverged_strain=0.5,
             theta_check_beads=50, theta_check_steps=100, theta_check_v0=1e-2)
#: 3. the beaded string (engine.validation.beaded_string's own defaults otherwise).
STRING = dict(h_omega=[float(x) for x in np.geomspace(0.3, 0.005, 9)], thetas=(0.5, 0.75, 1.0),
              stability_probe_h_omega_max=(1.9, 2.1), stability_probe_periods=10.0,
              order_fit_min_error_over_floor=10.0)
#: 4. sand only vs sand + a 2-bead wire, on the packing of bench_core.
NO_WIRE = dict(reps=21, target_s=0.02, overhead_iterations=200000, step_overhead_calls=2000,
               small_packing_cells=(8, 8, 4))

QUICK = dict(link=dict(n_links=2000, prep_steps=3, reps=5),
             chain=dict(n_beads=200, steps=60, max_wall_s=3.0),
             string=dict(h_omega=[float(x) for x in np.geomspace(0.3, 0.02, 4)]),
             no_wire=dict(reps=5, overhead_iterations=20000, step_overhead_calls=200,
                          small_packing_cells=(4, 4, 3)),
             packing=dict(cells=(5, 5, 4), prep_steps=3))


# ---------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------
_ITERATE_ARGS = tuple(inspect.signature(iterate.py_func).parameters)
#: The flat names under which the captured arguments keep the fields of ``iterate``'s named
#: tuples (C: Contacts, B: Bodies, L: Links).
_FLAT = dict(C=("c_i", "c_j", "frame", "w", "gterm", "mu", "ri", "rj", "impulse"),
             B=("body_dyn", "vel6"),
             L=("link_i", "link_j", "l_normal", "wl", "l_unilateral", "l_impulse", "l_order"))
_TUPLES = dict(C=Contacts, B=Bodies, L=Links)


def _flat_args(args) -> dict:
    """``iterate``'s positional arguments as a dict of flat names (the tuples' fields)."""
    out = {}
    for k, v in zip(_ITERATE_ARGS, args):
        if k in _FLAT:
            out.update(zip(_FLAT[k], v))
        else:
            out[k] = v
    return out


class CaptureIterate:
    """Record the arguments that ``nlgs.solve`` passes to ``iterate`` (solve looks the
    kernel up in its module at call time), still calling the real kernel.

    ``self.args`` is a dict name -> value of the last call, arrays copied after the call
    returned (so: the post-solve impulses and velocities, the step's link data ``wl``).
    """

    def __enter__(self):
        self.args = None
        self.calls = 0
        real = self._real = nlgs.iterate

        def spy(*args):
            out = real(*args)
            self.args = {k: (v.copy() if isinstance(v, np.ndarray) else v)
                         for k, v in _flat_args(args).items()}
            self.result = out
            self.calls += 1
            return out

        nlgs.iterate = spy
        return self

    def __exit__(self, *exc):
        nlgs.iterate = self._real
        return False


def _iter_call(a: dict, **over):
    """Positional argument tuple of ``iterate`` from a captured dict, with overrides."""
    d = dict(a, **over)
    return tuple(_TUPLES[k](*(d[f] for f in _FLAT[k])) if k in _FLAT else d[k]
                 for k in _ITERATE_ARGS)


@njit(cache=True)
def bare_sweeps(k, n, n_pair, C, B, relax):
    """``k`` contact sweeps back to back in compiled code (what ``iterate`` does with nl = 0,
    less its residual and tolerance test)."""
    num = 0.0
    den = 0.0
    for _ in range(k):
        a, b = sweep(n, n_pair, C, B, relax)
        num += a
        den += b
    return num, den


def time_interleaved(cases: dict, reps: int, target_s: float) -> dict:
    """Median cost per unit per call of several kernels, repetitions interleaved.

    ``cases[name] = (units, fresh, run)``: ``fresh()`` returns fresh copies of the mutable
    arrays (not timed), ``run(copies, k)`` makes ``k`` calls.  ``k`` is chosen per case so
    that a repetition lasts about ``target_s``; every repetition starts from fresh copies;
    the order of the cases rotates from one repetition to the next.
    """
    ks = {}
    for name, (units, fresh, run) in cases.items():
        c = fresh()
        run(c, 1)  # warm (compilation or cache load, caches)
        c = fresh()
        t = time.perf_counter()
        run(c, 1)
        one = max(time.perf_counter() - t, 1e-7)
        ks[name] = max(3, int(target_s / one))
    wall = {n: [] for n in cases}
    cpu = {n: [] for n in cases}
    names = list(cases)
    for r in range(reps):
        for name in names[r % len(names):] + names[:r % len(names)]:
            units, fresh, run = cases[name]
            c = fresh()
            k = ks[name]
            c0 = time.thread_time()
            t0 = time.perf_counter()
            run(c, k)
            t1 = time.perf_counter()
            c1 = time.thread_time()
            wall[name].append((t1 - t0) / (k * units) * 1e9)
            cpu[name].append((c1 - c0) / (k * units) * 1e9)
    out = {}
    for name, (units, _, _) in cases.items():
        a = np.asarray(wall[name])
        out[name] = dict(units=int(units), calls_per_repetition=ks[name], repetitions=reps,
                         median_ns=float(np.median(a)), min_ns=float(a.min()),
                         cpu_median_ns=float(np.median(cpu[name])), all_ns=wall[name])
    return out


def ratios(t: dict, num: str, den: str) -> dict:
    """num/den from :func:`time_interleaved` figures: ratio of medians, of minima, median of
    the ratios of the repetitions' paired figures (same repetition index: run back to
    back), and of the CPU-time medians."""
    x, y = np.asarray(t[num]["all_ns"]), np.asarray(t[den]["all_ns"])
    return dict(of_medians=float(np.median(x) / np.median(y)), of_mins=float(x.min() / y.min()),
                paired_median=float(np.median(x / y)),
                cpu_of_medians=float(t[num]["cpu_median_ns"] / t[den]["cpu_median_ns"]))


def _law_name(law) -> str:
    k = law.stiffness_value
    return type(law).__name__ + ("" if not np.isfinite(k) else f"(k={k:g})")


def wire_scene(pts, law, r, density, gravity, dt, theta, tol, max_iter, fixed=None):
    """One wire through ``pts``, beads ``fixed`` (default: both ends) fixed, no contact
    between beads."""
    s = Scene(gravity=gravity)
    b = s.add_wire(pts, radius=r, density=density, group="wire", law=law)
    s.interact("wire", "wire", None)
    s.fix(b[[0, -1]] if fixed is None else b[fixed])
    model, state = s.compile(dt=dt, theta=theta, tol=tol, max_iter=max_iter)
    return model, state, b


def festoon(n_arcs: int, links_per_arc: int, a: float, span_ratio: float) -> np.ndarray:
    """Bead centres of ``n_arcs`` circular arcs (see :func:`arc`) laid end to end along x:
    a wire hanging over ``n_arcs + 1`` supports at the same height (beads
    0, links_per_arc, 2 links_per_arc, ...).  Consecutive centres exactly ``a`` apart."""
    one = arc(links_per_arc, a, span_ratio)
    span = one[-1, 0]
    pts = [one[0:1]] + [one[1:] + (q * span, 0.0, 0.0) for q in range(n_arcs)]
    return np.concatenate(pts)


def arc(n_links: int, a: float, span_ratio: float) -> np.ndarray:
    """Bead centres on a circular arc sagging in the x–z plane: ``n_links`` equal chords
    ``a`` (exact), end distance ``span_ratio × n_links × a``, ends at the same height."""
    f = lambda p: np.sin(n_links * p / 2) / (n_links * np.sin(p / 2)) - span_ratio  # noqa: E731
    lo, hi = 1e-12, 2 * np.pi / n_links * (1 - 1e-9)  # f decreases from 1 - span to < 0
    for _ in range(200):
        m = 0.5 * (lo + hi)
        lo, hi = (m, hi) if f(m) > 0 else (lo, m)
    phi = 0.5 * (lo + hi)
    R = a / (2 * np.sin(phi / 2))
    ang = -np.pi / 2 + (np.arange(n_links + 1) - n_links / 2) * phi
    pts = np.column_stack([R * np.cos(ang), np.zeros(n_links + 1), R * np.sin(ang)])
    return pts - pts[0]


def link_law_residual(model, state) -> np.ndarray:
    """Per-link error of the link law at the solver's answer, as a fraction of L.

    Called after ``solve`` (positions at the θ-predicted configuration q_m, velocities
    v_{i+1}).  With ℓ⁺ = ‖(x_i − x_j) + h (v_i − v_j)‖ the next predicted length, λ the
    link impulse and T = λ/h the tension, the laws ask ℓ⁺ = L (rigid) and
    T = k (ℓ⁺ − L)/L (elastic), T >= 0 for the wires, which may also be slack (λ = 0,
    ℓ⁺ <= L).  Returns e = |ℓ⁺ − L − L T/k| / L (T/k = 0 for the rigid laws), or
    max(ℓ⁺ − L, 0)/L for a slack wire: 0 for an exact solve (to O(h²‖w_⊥‖²/L²) where the
    engine's L* correction is switched off).
    """
    i, j = model.link_i, model.link_j
    h = model.options.dt
    d = (state.position[i] - state.position[j]) + h * (state.vel6[i, :3] - state.vel6[j, :3])
    ell = np.sqrt((d * d).sum(1))
    L = model.link_ref_length
    k = model.link_stiffness
    lam = state.link_impulse
    elastic = np.isfinite(k)
    stretch = np.where(elastic, lam / (h * np.where(elastic, k, 1.0)), 0.0)
    e = (ell - L) / L - stretch
    slack = (model.link_unilateral != 0) & (lam <= 0.0)
    return np.where(slack, np.maximum(e, 0.0), np.abs(e))


# ---------------------------------------------------------------------------------------
# 1. link sweep vs contact sweep
# ---------------------------------------------------------------------------------------
def prepare_link_case(law, p: dict) -> dict:
    """Festoon wire, a few engine steps; the arrays ``solve`` gave ``iterate`` on the last."""
    r = p["bead_radius"]
    a = p["spacing_r"] * r
    k = p["links_per_arc"]
    pts = festoon(p["n_links"] // k, k, a, p["span_ratio"])
    t0 = time.perf_counter()
    model, state, b = wire_scene(pts, law, r, p["density"], p["gravity"], p["dt"], p["theta"],
                                 p["tol"], p["prep_max_iter"], fixed=np.arange(0, len(pts), k))
    prep = []
    with CaptureIterate() as cap:
        for _ in range(p["prep_steps"]):
            st = step(model, state)
            prep.append(dict(iterations=st.iterations, residual=st.residual))
    a_ = cap.args
    imp = a_["l_impulse"]
    nl = int(a_["nl"])
    return dict(model=model, args=a_, nl=nl, prep_steps=prep,
                setup_s=time.perf_counter() - t0,
                taut_fraction=float(np.mean(imp[:nl] > 0.0)),
                tension_N=dict(min=float(imp.min() / p["dt"]), median=float(np.median(imp) / p["dt"]),
                               max=float(imp.max() / p["dt"])))


def _link_case(a: dict, along_wire: bool = False):
    """Link sweep case in the engine's order, or in plain order along the wire."""
    nl = int(a["nl"])
    li, lj, nrm, wl, uni = a["link_i"], a["link_j"], a["l_normal"], a["wl"], a["l_unilateral"]
    imp0 = a["l_impulse"]
    bd, v0, relax = a["body_dyn"], a["vel6"], a["relax"]
    lorder = np.arange(nl, dtype=np.int32) if along_wire else a["l_order"]

    def fresh():
        return imp0.copy(), v0.copy()

    def run(c, k):
        p, v = c
        L, B = Links(li, lj, nrm, wl, uni, p, lorder), Bodies(bd, v)
        for _ in range(k):
            link_sweep(nl, L, B, relax)

    return nl, fresh, run


def _contact_case(a: dict):
    n = int(a["n"])
    args = (a["n"], a["n_pair"], a["c_i"], a["c_j"], a["frame"], a["w"], a["gterm"], a["mu"],
            a["ri"], a["rj"])
    bd, v0, p0, relax = a["body_dyn"], a["vel6"], a["impulse"], a["relax"]

    def fresh():
        return p0.copy(), v0.copy()

    def run(c, k):
        p, v = c
        C, B = Contacts(*args[2:], p), Bodies(bd, v)
        for _ in range(k):
            sweep(*args[:2], C, B, relax)

    return n, fresh, run


def prepare_packing(p: dict, extra=None) -> dict:
    """bench_core's dense packing after its prep steps; the arrays of the last ``iterate``."""
    t0 = time.perf_counter()
    model, state, geom = core.packing_scene(p, extra=extra)
    prep = []
    with CaptureIterate() as cap:
        for _ in range(p["prep_steps"]):
            ts = time.perf_counter()
            st = step(model, state)
            prep.append(dict(iterations=st.iterations, residual=st.residual,
                             n_contacts=st.n_contacts, wall_s=time.perf_counter() - ts))
    return dict(model=model, state=state, args=cap.args, scene=geom, prep_steps=prep,
                setup_s=time.perf_counter() - t0)


def bench_link_sweep(p: dict, packing: dict) -> dict:
    t0 = time.perf_counter()
    cases_in = {"RigidWire": laws.RigidWire(),
                "ElasticWire": laws.ElasticWire(stiffness=p["elastic_stiffness"])}
    prepared = {name: prepare_link_case(law, p) for name, law in cases_in.items()}
    cases = {"contact": _contact_case(packing["args"])}
    for name, pc in prepared.items():
        cases[f"link {name}"] = _link_case(pc["args"])
        cases[f"link {name} along-wire"] = _link_case(pc["args"], along_wire=True)
    t = time_interleaved(cases, p["reps"], p["target_s"])
    c_ns = t["contact"]["median_ns"]
    c_cpu = t["contact"]["cpu_median_ns"]
    laws_out = {}
    for name, pc in prepared.items():
        lk = t[f"link {name}"]
        aw = t[f"link {name} along-wire"]
        laws_out[name] = dict(
            law=_law_name(cases_in[name]), n_links=pc["nl"], ns_per_link=lk,
            ns_per_link_along_wire_order=aw,
            ratio_link_over_contact=lk["median_ns"] / c_ns,
            ratio_link_over_contact_cpu=lk["cpu_median_ns"] / c_cpu,
            ratios_link_over_contact=ratios(t, f"link {name}", "contact"),
            speedup_over_along_wire_order=aw["median_ns"] / lk["median_ns"],
            taut_fraction=pc["taut_fraction"], tension_N=pc["tension_N"],
            prep_steps=pc["prep_steps"], setup_s=pc["setup_s"])
    ca = packing["args"]
    return dict(laws=laws_out, contact=dict(ns_per_contact=t["contact"], n_contacts=int(ca["n"]),
                                           scene=packing["scene"]),
                wall_s=time.perf_counter() - t0)


# ---------------------------------------------------------------------------------------
# 2. long chain: sweeps to tolerance
# ---------------------------------------------------------------------------------------
def chain_laws(k: float) -> dict:
    return {"RigidRod": laws.RigidRod(), "ElasticRod": laws.ElasticRod(stiffness=k),
            "RigidWire": laws.RigidWire(), "ElasticWire": laws.ElasticWire(stiffness=k)}


def _length_error(ell, L, unilateral: bool) -> float:
    e = ell / L - 1.0
    return float(np.maximum(e, 0.0).max() if unilateral else np.abs(e).max())


def run_chain(law, theta: float, p: dict, chain_solve: bool = False) -> dict:
    r = p["bead_radius"]
    a = p["spacing_r"] * r
    pts = arc(p["n_beads"] - 1, a, p["span_ratio"])
    model, state, b = wire_scene(pts, law, r, p["density"], p["gravity"], p["dt"], theta,
                                 p["tol"], p["max_iter"])
    model = model.with_options(chain_solve=chain_solve)
    L = model.link_ref_length
    nl = L.shape[0]
    rigid = not np.isfinite(law.stiffness_value)
    steps = p["steps"]
    its = np.zeros(steps, np.int64)
    res = np.zeros(steps)
    wall = np.zeros(steps)
    solve_s = np.zeros(steps)
    lawres = np.zeros(steps)
    strain = np.zeros(steps)  # max |ℓ/L − 1| (wires: max(ℓ/L − 1, 0)) at the end of each step
    uni = bool(law.unilateral)
    pc = time.perf_counter
    start = pc()
    done = 0
    stopped_by = "steps"
    z0 = state.position[b, 2].copy()
    for k in range(steps):
        t0 = pc()
        free_velocity(model, state)
        detect(model, state)
        t1 = pc()
        it, rs = solve(model, state)
        t2 = pc()
        e = link_law_residual(model, state)  # at q_m, v_{i+1} (not timed)
        t3 = pc()
        update(model, state)
        t4 = pc()
        wall[k] = (t4 - t3) + (t2 - t0)
        solve_s[k] = t2 - t1
        its[k] = it
        res[k] = rs
        lawres[k] = e.max()
        d = state.position[model.link_i] - state.position[model.link_j]
        ell = np.sqrt((d * d).sum(1))
        strain[k] = _length_error(ell, L, uni) if np.isfinite(ell).all() else np.inf
        done = k + 1
        if not strain[k] < p["diverged_strain"]:
            stopped_by = f"diverged (a link at {strain[k]:.3g} x its length off)"
            break
        if pc() - start > p["max_wall_s"] and done < steps:
            stopped_by = f"wall-time cap {p['max_wall_s']:g} s"
            break
    sl = slice(0, done)
    its, res, wall, solve_s, lawres, strain = its[sl], res[sl], wall[sl], solve_s[sl], lawres[sl], strain[sl]
    lk = state.links
    ell = lk.length
    sweeps_x_links = float(its.sum()) * nl
    tail = slice(max(0, done - max(1, done // 10)), done)
    finite = bool(np.isfinite(state.position).all() and np.isfinite(state.vel6).all())
    z = state.position[b, 2]
    out = dict(
        law=_law_name(law), theta=theta, chain_solve=bool(chain_solve),
        steps_requested=steps, steps_done=done,
        stopped_by=stopped_by, simulated_time_s=float(state.time), wall_s=pc() - start,
        sweeps=dict(mean=float(its.mean()), median=float(np.median(its)), max=int(its.max()),
                    last_10pct_mean=float(its[tail].mean()),
                    hit_max_iter=int((its >= p["max_iter"]).sum()),
                    not_converged=int((res >= p["tol"]).sum())),
        step_ms=dict(mean=float(wall.mean() * 1e3), median=float(np.median(wall) * 1e3),
                     max=float(wall.max() * 1e3)),
        solve_ns_per_link_per_sweep=float(solve_s.sum() / sweeps_x_links * 1e9) if sweeps_x_links else None,
        law_residual=dict(note="max over links of |l+ - L - L T/k| / L after solve, l+ the "
                               "next predicted length (0 for an exact solve; see link_law_residual)",
                          mean_of_step_max=float(lawres.mean()), max=float(lawres.max()),
                          last=float(lawres[-1])),
        link_length_error=dict(note="max |l/L - 1| at the end of a step (wires: max(l/L - 1, 0): "
                                    "a slack wire may be shorter)",
                               end=_length_error(ell, L, uni), max_over_run=float(strain.max())),
        tension_end_N=dict(min=float(lk.tension.min()), max=float(lk.tension.max())),
        sag_m=dict(start=float(z0[0] - z0.min()), end=float(z[0] - z.min()) if finite else None),
        speed_max_end_m_s=float(np.abs(state.vel6[b, :3]).max()),
        finite=finite)
    if not rigid:
        out["strain_end"] = dict(max=float((ell / L - 1).max()),
                                 T_max_over_k=float(lk.tension.max() / law.stiffness_value))
    return out


def theta_check(p: dict) -> dict:
    """Does θ change the motion?  A small RigidWire chain (arc, both ends fixed, gravity)
    with a sideways initial velocity v0, solved tightly, at θ = 0.5, 0.75, 1: the
    θ-predicted configurations q_m of every step, compared with θ = 0.5.

    With constant forces, q_m⁺ = q_{i+1} + (1−θ) h v_{i+1} = q_m + h v_{i+1} and v_{i+1}
    depends on (q_m, v_i) only, so the sequence (q_m, v) does not depend on θ except
    through its start q_m⁰ = q_0 + (1−θ) h v_0: the differences should stay at
    (θ − 0.5) h |v0| (plus what that initial shift grows into).
    """
    r = p["bead_radius"]
    pts = arc(p["theta_check_beads"] - 1, p["spacing_r"] * r, p["span_ratio"])
    v0 = p["theta_check_v0"]
    traj = {}
    for theta in (0.5, 0.75, 1.0):
        model, state, b = wire_scene(pts, laws.RigidWire(), r, p["density"], p["gravity"], p["dt"],
                                     theta, 1e-10, 10 ** 6)
        state.vel6[b[1:-1], 1] = v0
        q = []
        its = []
        for _ in range(p["theta_check_steps"]):
            free_velocity(model, state)
            detect(model, state)
            its.append(solve(model, state)[0])
            q.append(state.position[b].copy())
            update(model, state)
        traj[theta] = (np.asarray(q), its)
    q5 = traj[0.5][0]
    out = dict(beads=p["theta_check_beads"], steps=p["theta_check_steps"], v0_m_s=v0, tol=1e-10,
               displacement_max_m=float(np.abs(q5[-1] - q5[0]).max()), thetas={})
    for theta in (0.75, 1.0):
        d = np.abs(traj[theta][0] - q5).max(axis=(1, 2))
        out["thetas"][f"theta{theta:g}"] = dict(
            qm_diff_first_m=float(d[0]), qm_diff_max_m=float(d.max()), qm_diff_last_m=float(d[-1]),
            predicted_initial_shift_m=(theta - 0.5) * p["dt"] * v0,
            sweeps_total=int(sum(traj[theta][1])), sweeps_total_theta0_5=int(sum(traj[0.5][1])))
    return out


def bench_chain(p: dict) -> dict:
    """Each law and θ with the plain link sweeps, then with each wire solved as one chain
    (``Options.chain_solve``, :mod:`engine.solver.chains`), same chain, same steps: the
    ratios of sweeps per step and of step time (plain / chain) in ``chain_solve_gain``."""
    out = {}
    gain = {}
    for theta in p["thetas"]:
        for name, law in chain_laws(p["stiffness"]).items():
            key = f"{name}_theta{theta:g}"
            for cs in (False, True):
                r = run_chain(law, theta, p, chain_solve=cs)
                out[key + ("_chains" if cs else "")] = r
                print(_fmt_chain(r), flush=True)
            plain, ch = out[key], out[key + "_chains"]
            gain[key] = dict(sweeps_plain=plain["sweeps"]["mean"],
                             sweeps_chains=ch["sweeps"]["mean"],
                             sweeps_ratio=plain["sweeps"]["mean"] / ch["sweeps"]["mean"],
                             step_ms_plain=plain["step_ms"]["mean"],
                             step_ms_chains=ch["step_ms"]["mean"],
                             step_time_ratio=plain["step_ms"]["mean"] / ch["step_ms"]["mean"],
                             same_steps=plain["steps_done"] == ch["steps_done"])
            g = gain[key]
            print(f"    chain solve: {g['sweeps_plain']:.0f} -> {g['sweeps_chains']:.1f} sweeps/step "
                  f"({g['sweeps_ratio']:.0f}x fewer), {g['step_ms_plain']:.2f} -> "
                  f"{g['step_ms_chains']:.2f} ms/step ({g['step_time_ratio']:.1f}x)"
                  + ("" if g["same_steps"] else "  [different step counts: wall-time cap]"),
                  flush=True)
    out["chain_solve_gain"] = gain
    return out


# ---------------------------------------------------------------------------------------
# 3. beaded string: frequency error vs h and θ
# ---------------------------------------------------------------------------------------
def string_constants() -> dict:
    """ω₁ and the highest transverse mode ω_N of beaded_string's default string."""
    d = {k: v.default for k, v in inspect.signature(beaded_string).parameters.items()}
    n, k, e0, r, rho = d["n_free"], d["stiffness"], d["prestrain"], d["bead_radius"], d["density"]
    m = rho * 4.0 / 3.0 * np.pi * r ** 3
    a = 2.2 * r
    c = 2.0 * np.sqrt(k * e0 / (m * a))
    return dict(defaults={kk: v for kk, v in d.items() if kk not in ("dt", "theta")},
                omega1=c * np.sin(np.pi / (2 * (n + 1))),
                omegaN=c * np.sin(n * np.pi / (2 * (n + 1))))


def _verlet_error(x: float) -> float:
    """Relative frequency error of drift–kick–drift (position Verlet) at h ω = x."""
    return 2.0 / x * np.arcsin(x / 2.0) - 1.0 if x < 2.0 else float("nan")


def bench_string(p: dict) -> dict:
    sc = string_constants()
    w1, wN = sc["omega1"], sc["omegaN"]
    out = dict(omega1_rad_s=w1, omegaN_rad_s=wN, string=sc["defaults"],
               stability_limit_h_omega1=2.0 * w1 / wN, points={}, order={})
    for theta in p["thetas"]:
        pts = []
        for hw in p["h_omega"]:
            dt = hw / w1
            t0 = time.perf_counter()
            r = beaded_string(dt=dt, theta=theta)
            wall = time.perf_counter() - t0
            pts.append(dict(h_omega1=hw, dt_s=dt, h_omegaN=dt * wN, rel_error=float(r["rel_error"]),
                            verlet_prediction=_verlet_error(hw), omega=float(r["omega"]),
                            omega_exact=float(r["omega_exact"]), steps=int(r["steps"]),
                            sweeps_per_step=float(r["iterations"]), wall_s=wall))
        out["points"][f"theta{theta:g}"] = pts
        # order: slope of log(error) vs log(h ω₁) over the stable points well above the
        # error floor (the smallest error measured: amplitude nonlinearity, see README)
        e = np.array([q["rel_error"] for q in pts])
        x = np.array([q["h_omega1"] for q in pts])
        stable = np.array([q["h_omegaN"] < 2.0 for q in pts]) & np.isfinite(e)
        floor = float(e[stable].min()) if stable.any() else float("nan")
        use = stable & (e > p["order_fit_min_error_over_floor"] * floor)
        slope = float(np.polyfit(np.log(x[use]), np.log(e[use]), 1)[0]) if use.sum() >= 2 else None
        local = [float(np.log(e[q] / e[q + 1]) / np.log(x[q] / x[q + 1]))
                 for q in range(len(e) - 1) if stable[q] and stable[q + 1]]
        out["order"][f"theta{theta:g}"] = dict(fitted_order=slope, points_used=int(use.sum()),
                                               error_floor=floor, local_orders=local)
    # stability probe: just below and above h ω_N = 2, longer runs
    probe = []
    for theta in (p["thetas"][0], p["thetas"][-1]):
        for hwn in p["stability_probe_h_omega_max"]:
            dt = hwn / wN
            r = beaded_string(dt=dt, theta=theta, periods=p["stability_probe_periods"])
            probe.append(dict(theta=theta, h_omegaN=hwn, h_omega1=dt * w1,
                              periods=p["stability_probe_periods"], rel_error=float(r["rel_error"]),
                              verlet_prediction=_verlet_error(dt * w1)))
    out["stability_probe"] = probe
    return out


# ---------------------------------------------------------------------------------------
# 4. a scene without wires pays nothing
# ---------------------------------------------------------------------------------------
def _far_wire(scene, hi):
    """A free 2-bead RigidWire high in the packing's box, far from every sphere and wall."""
    r = 1.5e-4  # larger than every sand radius: Scene.compile's default alert/skin unchanged
    c = np.array([0.5 * hi[0], 0.5 * hi[1], 0.8 * hi[2]])
    scene.add_wire([c, c + (2.2 * r, 0.0, 0.0)], radius=r, density=2650.0, group="wire",
                   law=laws.RigidWire())
    for g in ("sand", "wall", "wire"):
        scene.interact("wire", g, laws.Coulomb(mu=0.3))


def bench_no_wire(p: dict, sand: dict, wired: dict) -> dict:
    t0 = time.perf_counter()
    a, b = sand["args"], wired["args"]
    n = int(a["n"])
    pairs = lambda d: set(zip(d["c_i"][:int(d["n"])].tolist(), d["c_j"][:int(d["n"])].tolist()))  # noqa: E731
    same = dict(n_contacts_sand=n, n_contacts_with_wire=int(b["n"]), nl_sand=int(a["nl"]),
                nl_with_wire=int(b["nl"]), same_contact_set=bool(pairs(a) == pairs(b)),
                same_contact_order=bool(n == int(b["n"]) and np.array_equal(a["c_i"][:n], b["c_i"][:n])
                                        and np.array_equal(a["c_j"][:n], b["c_j"][:n])))
    assert a["nl"] == 0 and b["nl"] == 1, (a["nl"], b["nl"])

    def iter_case(args_dict, units=n, **over):
        def fresh():
            return args_dict["impulse"].copy(), args_dict["vel6"].copy(), args_dict["l_impulse"].copy()

        def run(c, k):
            imp, v, limp = c
            it, _ = iterate(*_iter_call(args_dict, impulse=imp, vel6=v, l_impulse=limp, tol=0.0,
                                        max_iter=k, **over))
            assert it == k, (it, k)

        return units, fresh, run

    def bare_case(args_dict):
        bd, relax = args_dict["body_dyn"], args_dict["relax"]
        cargs = tuple(args_dict[k] for k in ("n", "n_pair", "c_i", "c_j", "frame", "w", "gterm",
                                              "mu", "ri", "rj"))

        def fresh():
            return args_dict["impulse"].copy(), args_dict["vel6"].copy()

        def run(c, k):
            imp, v = c
            bare_sweeps(k, *cargs[:2], Contacts(*cargs[2:], imp), Bodies(bd, v), relax)

        return n, fresh, run

    # one iteration = one call of k: "units" = contacts, so the figures are ns per contact per
    # iteration; ns per iteration = that x n_contacts
    # (a) and (b) on the sand-only scene; (c) on the scene with the wire, and (a2) = (c) with
    # nl = 0 on exactly the same arrays (the two scenes' contacts are the same set, but the
    # broadphase may list them in another order, which changes the Gauss-Seidel order)
    cases = {"a_iterate_nl0": iter_case(a), "b_bare_sweep": bare_case(a),
             "c_iterate_nl1": iter_case(b), "a2_iterate_nl0_wire_scene_arrays": iter_case(b, nl=0)}
    t = time_interleaved(cases, p["reps"], p["target_s"])
    med = {k: v["median_ns"] for k, v in t.items()}
    # fixed cost of the link path alone: iterate with the contact count set to 0, nl = 1
    k = p["overhead_iterations"]
    fresh = lambda: (b["impulse"].copy(), b["vel6"].copy(), b["l_impulse"].copy())  # noqa: E731
    imp, v, limp = fresh()
    iterate(*_iter_call(b, n=0, n_pair=0, impulse=imp, vel6=v, l_impulse=limp, tol=0.0, max_iter=10))
    best = []
    for _ in range(5):
        imp, v, limp = fresh()
        ts = time.perf_counter()
        iterate(*_iter_call(b, n=0, n_pair=0, impulse=imp, vel6=v, l_impulse=limp, tol=0.0,
                            max_iter=k))
        best.append((time.perf_counter() - ts) / k * 1e9)
    # per-step fixed cost of a wire in solve() outside iterate: link_prepare on 1 link, the
    # wl allocation and _break_links (Python + numpy)
    wm, ws = wired["model"], wired["state"]
    calls = p["step_overhead_calls"]
    vel = ws.vel6.copy()
    limp = ws.link_impulse.copy()
    nrm = ws.link_normal.copy()
    gap = ws.link_gap.copy()
    h = wm.options.dt
    ts = time.perf_counter()
    for _ in range(calls):
        wl = np.empty((1, nlgs.LINK_COLUMNS))
        link_prepare(1, wm.link_i, wm.link_j, wm.link_ref_length, wm.link_stiffness,
                     ws.link_broken, ws.position, wm.body_dyn, vel, limp, nrm, gap, wl, h)
        nlgs._break_links(wm, ws, h)
    step_overhead_us = (time.perf_counter() - ts) / calls * 1e6
    sand_solve_ms = [q["wall_s"] * 1e3 for q in sand["prep_steps"]]
    return dict(
        check=same, timings=t,
        ns_per_iteration={k: v * n for k, v in med.items()},
        ns_per_contact_per_iteration=med,
        ratio_a_over_b=ratios(t, "a_iterate_nl0", "b_bare_sweep"),
        ratio_c_over_a=ratios(t, "c_iterate_nl1", "a_iterate_nl0"),
        ratio_c_over_a2=ratios(t, "c_iterate_nl1", "a2_iterate_nl0_wire_scene_arrays"),
        link_path_fixed_ns_per_iteration=dict(
            note="iterate with n = 0 contacts and nl = 1 link: empty contact loop + link_sweep "
                 "of one link + residual, per iteration (min and median of 5 runs)",
            min=float(min(best)), median=float(np.median(best)), iterations_per_run=k),
        wire_step_overhead_us=dict(
            note="per step, outside iterate: np.empty((nl, LINK_COLUMNS)) + link_prepare(1 link) + "
                 "_break_links (what solve adds once per step for a scene with a wire)",
            value=step_overhead_us,
            sand_only_step_wall_ms_last_prep_steps=sand_solve_ms),
        wall_s=time.perf_counter() - t0)


# ---------------------------------------------------------------------------------------
# printing
# ---------------------------------------------------------------------------------------
def _fmt_link(r: dict) -> str:
    c = r["contact"]["ns_per_contact"]
    lines = [f"  contact sweep, dense packing ({r['contact']['n_contacts']} contacts): "
             f"{c['median_ns']:.1f} ns/contact (min {c['min_ns']:.1f}, CPU {c['cpu_median_ns']:.1f})"]
    for name, q in r["laws"].items():
        lk, aw = q["ns_per_link"], q["ns_per_link_along_wire_order"]
        lines.append(
            f"  link sweep, {q['law']}, {q['n_links']} links ({q['taut_fraction']:.0%} taut): "
            f"{lk['median_ns']:.1f} ns/link (min {lk['min_ns']:.1f}, CPU {lk['cpu_median_ns']:.1f}); "
            f"link/contact {q['ratio_link_over_contact']:.2f}x (paired "
            f"{q['ratios_link_over_contact']['paired_median']:.2f}x, CPU {q['ratio_link_over_contact_cpu']:.2f}x)\n"
            f"      same links swept in plain order along the wire: {aw['median_ns']:.1f} ns/link "
            f"(the engine's even-then-odd order is {q['speedup_over_along_wire_order']:.2f}x faster)")
    return "\n".join(lines)


def _fmt_chain(r: dict) -> str:
    s = r["sweeps"]
    lr = r["law_residual"]
    extra = (f", strain max {r['strain_end']['max']:.2e} (T_max/k {r['strain_end']['T_max_over_k']:.2e})"
             if "strain_end" in r else
             f", |l/L-1| end {r['link_length_error']['end']:.2e} (max {r['link_length_error']['max_over_run']:.2e})")
    return (f"  {r['law']:<20s} theta {r['theta']:<4g}{' chains' if r.get('chain_solve') else ''}: "
            f"{r['steps_done']} steps ({r['stopped_by']}); "
            f"sweeps/step mean {s['mean']:.0f}, max {s['max']}, {s['hit_max_iter']} at max_iter; "
            f"{r['step_ms']['mean']:.1f} ms/step "
            f"({r['solve_ns_per_link_per_sweep']:.1f} ns/link/sweep in solve)\n"
            f"      law residual {lr['mean_of_step_max']:.1e} mean, {lr['max']:.1e} max{extra}; "
            f"T {r['tension_end_N']['min']:.2e}..{r['tension_end_N']['max']:.2e} N, "
            f"sag {r['sag_m']['start'] * 1e3:.2f} -> "
            + (f"{r['sag_m']['end'] * 1e3:.2f} mm" if r["sag_m"]["end"] is not None else "n/a"))


def _fmt_string(r: dict) -> str:
    lines = [f"  omega1 = {r['omega1_rad_s']:.2f} rad/s, omegaN = {r['omegaN_rad_s']:.1f} rad/s: "
             f"h omegaN < 2 <=> h omega1 < {r['stability_limit_h_omega1']:.3f}"]
    thetas = list(r["points"])
    lines.append("    h*omega1   dt [s]     " + "  ".join(f"err {t[5:]:<5s} wall" for t in thetas)
                 + "   (2/x)asin(x/2)-1")
    for q in range(len(r["points"][thetas[0]])):
        p0 = r["points"][thetas[0]][q]
        row = f"    {p0['h_omega1']:<9.4f}  {p0['dt_s']:<9.3e}  "
        row += "  ".join(f"{r['points'][t][q]['rel_error']:<9.2e} {r['points'][t][q]['wall_s']:4.2f}s"
                         for t in thetas)
        row += f"   {p0['verlet_prediction']:.2e}"
        lines.append(row)
    for t, o in r["order"].items():
        lines.append(f"  {t}: fitted order {o['fitted_order']:.2f} over {o['points_used']} points "
                     f"(error floor {o['error_floor']:.1e})" if o["fitted_order"] is not None
                     else f"  {t}: too few points for an order fit")
    lines.append("  stability probe (" + f"{r['stability_probe'][0]['periods']:g} periods): " + "; ".join(
        f"theta {q['theta']:g}, h omegaN {q['h_omegaN']:.2f}: err {q['rel_error']:.2e}"
        for q in r["stability_probe"]))
    return "\n".join(lines)


def _fmt_ratio(q: dict) -> str:
    return (f"{q['of_medians']:.3f} (paired {q['paired_median']:.3f}, of minima {q['of_mins']:.3f}, "
            f"CPU {q['cpu_of_medians']:.3f})")


def _fmt_no_wire(name: str, r: dict) -> str:
    t = r["ns_per_iteration"]
    return (f"  {name}: {r['check']['n_contacts_sand']} contacts (with the far wire: same set "
            f"{r['check']['same_contact_set']}, same order {r['check']['same_contact_order']})\n"
            f"    (a)  iterate, nl = 0               {t['a_iterate_nl0'] / 1e3:8.2f} us/iteration\n"
            f"    (b)  bare sweep                    {t['b_bare_sweep'] / 1e3:8.2f} us/iteration   "
            f"a/b  = {_fmt_ratio(r['ratio_a_over_b'])}\n"
            f"    (c)  iterate, + 2-bead wire, nl = 1 {t['c_iterate_nl1'] / 1e3:8.2f} us/iteration   "
            f"c/a  = {_fmt_ratio(r['ratio_c_over_a'])}\n"
            f"    (a2) iterate, nl = 0, (c)'s arrays {t['a2_iterate_nl0_wire_scene_arrays'] / 1e3:8.2f} us/iteration   "
            f"c/a2 = {_fmt_ratio(r['ratio_c_over_a2'])}\n"
            f"    link path alone (n = 0, nl = 1): {r['link_path_fixed_ns_per_iteration']['min']:.1f} ns/iteration; "
            f"per step outside iterate (link_prepare + _break_links): "
            f"{r['wire_step_overhead_us']['value']:.1f} us")


# ---------------------------------------------------------------------------------------
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="smoke run: small sizes, few steps")
    ap.add_argument("--chain-steps", type=int, default=None)
    ap.add_argument("--chain-max-wall", type=float, default=None,
                    help="stop each chain run after this many seconds [s]")
    ap.add_argument("--out-dir", default=str(BENCH / "results"))
    a = ap.parse_args(argv)

    link_p, chain_p, string_p, nowire_p = dict(LINK), dict(CHAIN), dict(STRING), dict(NO_WIRE)
    pack_p = dict(core.PACKING)
    if a.quick:
        link_p.update(QUICK["link"])
        chain_p.update(QUICK["chain"])
        string_p.update(QUICK["string"])
        nowire_p.update(QUICK["no_wire"])
        pack_p.update(QUICK["packing"])
    if a.chain_steps is not None:
        chain_p["steps"] = a.chain_steps
    if a.chain_max_wall is not None:
        chain_p["max_wall_s"] = a.chain_max_wall

    numba.set_num_threads(1)
    stamp = _dt.datetime.now()
    busy = core.record.Busy()
    out = dict(benchmark="wire", started=stamp.isoformat(timespec="seconds"), quick=a.quick,
               machine=core.machine_info(), numba_threads=1,
               git=dict(commit=core._git("rev-parse", "HEAD"),
                        dirty_engine=(core._git("status", "--porcelain", "--", "engine") or "").splitlines(),
                        engine_sources_sha256=core._engine_hash()),
               params=dict(link=link_p, chain=chain_p, string=string_p, no_wire=nowire_p,
                           packing=pack_p))
    print(f"nscd-workbench wire benchmark  ({out['machine']['cpu_model']}, {out['machine']['nproc']} cpus, "
          f"numba {numba.__version__} (1 thread), numpy {np.__version__}, "
          f"commit {(out['git']['commit'] or '?')[:10]})", flush=True)

    t0 = time.perf_counter()
    w = core.warm_up()
    out["warm_up_s"] = dict(core_warm_up=w["total_s"], total=time.perf_counter() - t0)
    print(f"warm-up {out['warm_up_s']['total']:.1f} s (excluded)", flush=True)

    packing = prepare_packing(pack_p)
    print(f"1. link sweep vs contact sweep (single thread; packing set up in {packing['setup_s']:.1f} s)",
          flush=True)
    r1 = bench_link_sweep(link_p, packing)
    r1["contact"]["prep_steps"] = packing["prep_steps"]
    out["link_sweep"] = r1
    print(_fmt_link(r1), flush=True)

    print("4. a scene without wires pays nothing (K sweeps in one compiled call; ns per "
          "iteration = one sweep of every contact)", flush=True)
    wired = prepare_packing(pack_p, extra=_far_wire)
    r4 = dict(packing=bench_no_wire(nowire_p, packing, wired))
    print(_fmt_no_wire("dense packing", r4["packing"]), flush=True)
    del packing, wired
    small_p = dict(pack_p, cells=tuple(nowire_p["small_packing_cells"]))
    sand_s = prepare_packing(small_p)
    wired_s = prepare_packing(small_p, extra=_far_wire)
    r4["small_packing"] = bench_no_wire(nowire_p, sand_s, wired_s)
    r4["small_packing"]["scene"] = sand_s["scene"]
    print(_fmt_no_wire(f"small packing ({sand_s['scene']['n_spheres']} spheres)",
                       r4["small_packing"]), flush=True)
    out["no_wire"] = r4
    del sand_s, wired_s

    print("3. beaded string: relative error of omega1 vs h and theta "
          "(engine.validation.beaded_string)", flush=True)
    r3 = bench_string(string_p)
    out["string"] = r3
    print(_fmt_string(r3), flush=True)

    print(f"2. chain of {chain_p['n_beads']} beads fixed at both ends, {chain_p['steps']} steps "
          f"(cap {chain_p['max_wall_s']:g} s each), h = {chain_p['dt']:g} s, tol = {chain_p['tol']:g}, "
          f"max_iter = {chain_p['max_iter']}", flush=True)
    out["chain"] = bench_chain(chain_p)
    tc = theta_check(chain_p)
    out["theta_check"] = tc
    print(f"  theta check ({tc['beads']}-bead RigidWire chain, v0 = {tc['v0_m_s']:g} m/s sideways, "
          f"tol 1e-10, {tc['steps']} steps): max |q_m(theta) - q_m(0.5)| = "
          + "; ".join(f"{k[5:]}: {v['qm_diff_max_m']:.3e} m (initial shift (theta-0.5) h v0 = "
                      f"{v['predicted_initial_shift_m']:.3e} m)" for k, v in tc["thetas"].items())
          + f"; the chain moved {tc['displacement_max_m']:.2e} m", flush=True)

    out["machine"]["loadavg_end"] = list(os.getloadavg())
    out["busy"] = busy.finish()
    out["total_wall_s"] = time.perf_counter() - _T_START
    ls = out["link_sweep"]
    out["summary"] = dict(
        contact_ns=ls["contact"]["ns_per_contact"]["median_ns"],
        **{f"link_ns_{k}": v["ns_per_link"]["median_ns"] for k, v in ls["laws"].items()},
        **{f"link_over_contact_{k}": v["ratio_link_over_contact"] for k, v in ls["laws"].items()},
        **{f"link_order_speedup_{k}": v["speedup_over_along_wire_order"] for k, v in ls["laws"].items()},
        **{f"chain_sweeps_mean_{k}": v["sweeps"]["mean"] for k, v in out["chain"].items()
           if k != "chain_solve_gain"},
        **{f"chain_hit_max_iter_{k}": v["sweeps"]["hit_max_iter"] for k, v in out["chain"].items()
           if k != "chain_solve_gain"},
        **{f"chain_solve_sweeps_ratio_{k}": v["sweeps_ratio"]
           for k, v in out["chain"]["chain_solve_gain"].items()},
        **{f"chain_solve_step_time_ratio_{k}": v["step_time_ratio"]
           for k, v in out["chain"]["chain_solve_gain"].items()},
        **{f"string_order_{k}": v["fitted_order"] for k, v in out["string"]["order"].items()},
        **{f"no_wire_{k}_iterate_over_bare": v["ratio_a_over_b"]["of_medians"] for k, v in r4.items()},
        **{f"no_wire_{k}_with_wire_over_without_same_arrays": v["ratio_c_over_a2"]["of_medians"]
           for k, v in r4.items()})
    if core._engine_hash() != out["git"]["engine_sources_sha256"]:
        out["git"]["warning"] = "engine/ sources changed while the benchmark ran"
        print("WARNING: engine/ sources changed while the benchmark ran")
    od = Path(a.out_dir)
    od.mkdir(parents=True, exist_ok=True)
    name = f"wire-{stamp.strftime('%Y%m%d-%H%M')}" + ("-quick" if a.quick else "") + ".json"
    text = json.dumps(out, indent=1, default=core._json_default)
    (od / name).write_text(text)
    (od / ("wire-latest-quick.json" if a.quick else "wire-latest.json")).write_text(text)
    print(f"total {out['total_wall_s']:.0f} s; wrote {od / name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
