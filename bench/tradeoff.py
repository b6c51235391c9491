"""Speed/accuracy trade (issue 9, item 5): error against wall time as the time step h,
θ, the NLGS tolerance and the bead (grain) size vary, on cases with a reference answer.

Run:  .venv/bin/python bench/tradeoff.py            (about 10-15 min on 2 shared cores)
      .venv/bin/python bench/tradeoff.py --quick    (a smoke run of about 1 min)

Writes bench/results/tradeoff-<YYYYmmdd-HHMM>.json and a figure next to it
(tradeoff-<YYYYmmdd-HHMM>.png, matplotlib Agg), and prints a table.

Cases (each one knob varied at a time around a default point; the default is marked):

``string``      first transverse mode of a taut beaded string
                (:func:`engine.validation.beaded_string`): error |ω/ω₁ − 1| against the
                discrete closed form ω₁ = 2√(T/(m a)) sin(π/(2(N+1))).  The bead-size
                sweep keeps the string (length, tension, mass per length) and changes the
                number of beads: its error is against the continuous string ω = (π/L)√(T/μ)
                (DESIGN §4), and h is capped at 0.5 √(m a/T) (h ω_N ≈ 1, ω_N the highest
                mode: docs/wire.md, stable only while h ω_N < 2), so small beads cost steps.
``catenary``    a RigidWire chain hanging between two fixed beads at the same height,
                settled by kinetic damping over a fixed simulated time: the fitted
                y = a cosh((x−x₀)/a) + c against a = H/(μ g), H the horizontal tension of
                the end link, μ the mass per length.  The bead-size sweep keeps the chain
                length and changes the number of links.
``catenary, chains``  the same, with ``chain_solve=True`` (each wire solved as one chain,
                issue 31 §1), h and tol varied.
``sliding``     a solid sphere launched sliding without spin on a plane (Coulomb μ = 0.3):
                error of the final velocity against 5/7 v₀, and of the time at which it
                starts rolling against 2 v₀/(7 μ g) (the larger of the two is plotted).
``pile``        grains settling in a box with frictionless side walls for a fixed
                simulated time: |floor reaction / weight − 1| at the end.  The grain-size
                sweep keeps the box and the grain volume.
``triaxial``    :func:`engine.experiments.box_triaxial` at a tiny scale (0.02: 130 grains
                + 34 wire beads), short strain: RMS difference of the deviator q(ε_a) from
                a reference run at a tight tolerance, relative to the reference's mean q.

Wall time is that of the whole case run (scene build + steps; numba compilation is
excluded by a warm-up of every case first).  The machine has two cores shared with other
jobs: the JSON records the load average, and the timings are noisy (repeat a point before
trusting a ratio under 1.3×).
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

_T_START = time.perf_counter()
ROOT = Path(__file__).resolve().parent.parent
BENCH = ROOT / "bench"
for _p in (str(ROOT), str(BENCH)):
    if _p not in sys.path:
        sys.path.insert(0, _p)

import numpy as np  # noqa: E402
import numba  # noqa: E402

import bench_core as core  # noqa: E402
from engine import Scene, laws, step  # noqa: E402
from engine.step import NonConvergenceWarning  # noqa: E402
from engine.validation import beaded_string  # noqa: E402

G = 9.81

NOTE = ("Timings are wall times on a 2-core machine shared with other workers (load average "
        "in 'machine'); they are noisy: differences under about 30 % between two points are "
        "not meaningful.  Errors are deterministic (same inputs give the same error).")

# --- default points and the values of each knob ------------------------------------------
STRING = dict(default=dict(dt=5e-4, theta=0.5, tol=1e-8, n_free=15),
              dt=[2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5],
              theta=[0.5, 0.75, 1.0],
              tol=[1e-2, 1e-3, 1e-4, 1e-6, 1e-8, 1e-12],
              n_free=[3, 7, 15, 31, 63],
              # the fixed string of the bead-size sweep: the default one (15 free beads of
              # r = 1 mm, a = 2.2 mm, 2000 kg/m³, k = 1 N, ε₀ = 0.01)
              bead_radius=1e-3, density=2000.0, stiffness=1.0, prestrain=0.01, periods=2.0)
CATENARY = dict(default=dict(dt=2e-4, theta=0.5, tol=1e-8, n_links=30),
                dt=[1e-3, 5e-4, 2e-4, 1e-4, 5e-5],
                theta=[0.5, 1.0],
                tol=[1e-2, 1e-3, 1e-4, 1e-6, 1e-8, 1e-10],
                n_links=[6, 10, 20, 30, 60],
                length=30 * 2.2e-3, span_ratio=0.7, bead_radius=1e-3, density=2000.0,
                settle_time=1.2, max_iter=20000)
SLIDING = dict(default=dict(dt=1e-4, theta=0.5, tol=1e-4),
               dt=[2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5],
               theta=[0.5, 1.0],
               tol=[1e-2, 1e-4, 1e-8],
               r=0.01, v0=1.0, mu=0.3)
PILE = dict(default=dict(dt=2e-4, theta=0.5, tol=1e-4, r=1e-3),
            dt=[1e-3, 5e-4, 2e-4, 1e-4],
            theta=[0.5, 1.0],
            tol=[1e-2, 1e-3, 1e-4, 1e-5, 1e-6],
            r=[1.6e-3, 1.25e-3, 1e-3, 0.8e-3],
            width=10e-3, n_at_1mm=120, settle_time=0.3, mu=0.4, max_iter=5000)
TRIAXIAL = dict(default=dict(dt=5e-5, theta=0.5, tol=3e-4),
                dt=[1e-4, 5e-5, 2.5e-5],
                theta=[0.5, 1.0],
                tol=[1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 1e-5],
                reference=dict(dt=5e-5, theta=0.5, tol=1e-6, max_iter=10000),
                scale=0.02, axial_strain=0.02, max_iter=5000, record_every=5, seed=0,
                # sample-to-sample spread: the default settings on other samples (seeds)
                # against the reference; a knob whose error stays below it is in the noise
                other_seeds=[1, 2])

QUICK = dict(
    string=dict(dt=[1e-3, 5e-4], theta=[0.5, 1.0], tol=[1e-4, 1e-8], n_free=[7, 15]),
    catenary=dict(dt=[5e-4, 2e-4], theta=[0.5], tol=[1e-4, 1e-8], n_links=[10, 30],
                  settle_time=0.3),
    sliding=dict(dt=[1e-3, 1e-4], theta=[0.5], tol=[1e-4]),
    pile=dict(dt=[2e-4], theta=[0.5], tol=[1e-2, 1e-4], r=[1.25e-3], settle_time=0.1,
              n_at_1mm=60),
    triaxial=dict(dt=[5e-5], theta=[0.5], tol=[1e-2, 3e-4], axial_strain=0.005, other_seeds=[1],
                  reference=dict(dt=5e-5, theta=0.5, tol=1e-5, max_iter=5000)),
)


# ---------------------------------------------------------------------------------------
# the cases: each returns dict(error=..., and what else it saw); wall time is added outside
# ---------------------------------------------------------------------------------------
def case_string(p, dt, theta, tol, n_free):
    """Beaded string.  At the default n_free, the error is against the discrete closed
    form (h, θ, tol only).  In the bead-size sweep (``p['_bead_sweep']``) the string is
    the same physical string cut in n_free + 1 segments: error against the continuous
    string, h capped for stability."""
    n0 = STRING["default"]["n_free"]
    a0 = 2.2 * p["bead_radius"]
    L = (n0 + 1) * a0
    m0 = p["density"] * 4 / 3 * np.pi * p["bead_radius"] ** 3
    mu = m0 / a0                                   # mass per length [kg/m]
    T = p["stiffness"] * p["prestrain"]
    if not p.get("_bead_sweep"):
        r = beaded_string(n_free=n_free, stiffness=p["stiffness"], prestrain=p["prestrain"],
                          bead_radius=p["bead_radius"], density=p["density"], dt=dt,
                          theta=theta, tol=tol, periods=p["periods"])
        return dict(error=float(r["rel_error"]), omega=float(r["omega"]),
                    omega_exact=float(r["omega_exact"]), h_omega1=float(dt * r["omega_exact"]),
                    steps=int(r["steps"]), sweeps_per_step=float(r["iterations"]))
    a = L / (n_free + 1)
    rb = a / 2.2
    m = mu * a
    rho = m / (4 / 3 * np.pi * rb ** 3)
    h = min(dt, 0.5 * np.sqrt(m * a / T))
    r = beaded_string(n_free=n_free, stiffness=p["stiffness"], prestrain=p["prestrain"],
                      bead_radius=rb, density=rho, dt=h, theta=theta, tol=tol,
                      periods=p["periods"], amplitude=1e-3)
    w_cont = np.pi / L * np.sqrt(T / mu)
    return dict(error=float(abs(r["omega"] / w_cont - 1)), omega=float(r["omega"]),
                omega_continuous=float(w_cont), omega_discrete=float(r["omega_exact"]),
                discrete_vs_continuous=float(abs(r["omega_exact"] / w_cont - 1)),
                time_error=float(r["rel_error"]), dt_used=float(h), bead_radius=float(rb),
                steps=int(r["steps"]), sweeps_per_step=float(r["iterations"]))


def _arc_free_v(n_links, a, span_ratio):
    """A V-shaped start: ``n_links`` (even) chords of length ``a``, ends span_ratio × the
    length apart, at the same height."""
    half = n_links // 2
    phi = np.arccos(span_ratio)
    k = np.arange(n_links + 1)
    x = k * a * np.cos(phi)
    z = -(half - np.abs(k - half)) * a * np.sin(phi)
    return np.column_stack([x, np.zeros_like(x), z])


def _catenary(x, a, x0, c):
    return a * np.cosh((x - x0) / a) + c


def case_catenary(p, dt, theta, tol, n_links):
    from scipy.optimize import curve_fit

    a_link = p["length"] / n_links
    r = min(p["bead_radius"], a_link / 2.2)
    m0 = p["density"] * 4 / 3 * np.pi * p["bead_radius"] ** 3
    mu = m0 / (2.2 * p["bead_radius"])          # the same mass per length for every n_links
    rho = mu * a_link / (4 / 3 * np.pi * r ** 3)
    pts = _arc_free_v(n_links, a_link, p["span_ratio"])
    s = Scene(gravity=(0, 0, -G))
    b = s.add_wire(pts, radius=r, density=rho, group="wire", law=laws.RigidWire())
    s.interact("wire", "wire", None)
    s.fix(b[[0, -1]])
    model, state = s.compile(dt=dt, theta=theta, tol=tol, max_iter=p["max_iter"],
                             chain_solve=p.get("chain_solve", False))
    ids = b[1:-1]
    m = model.body_mass[ids]
    steps = int(round(p["settle_time"] / dt))
    prev, nc, its = 0.0, 0, 0
    for _ in range(steps):  # kinetic damping: zero the velocities at each kinetic-energy peak
        st = step(model, state)
        nc += not st.converged
        its += st.iterations
        ke = 0.5 * float(m @ (state.velocity[ids] ** 2).sum(1))
        if ke < prev:
            state.vel6[ids] = 0.0
            ke = 0.0
        prev = ke
    x, z = state.position[b, 0], state.position[b, 2]
    if not np.all(np.isfinite(z)):
        return dict(error=np.inf, steps=steps, non_converged=nc)
    sag = z[0] - z.min()
    (a, x0, c), _ = curve_fit(_catenary, x, z, p0=(x[-1] / 2, x[-1] / 2, z.min() - x[-1] / 2),
                              maxfev=20000)
    rms = float(np.sqrt(np.mean((_catenary(x, a, x0, c) - z) ** 2)))
    end = state.position[b[1]] - state.position[b[0]]
    H = state.links.tension[0] * abs(end[0]) / np.linalg.norm(end)
    a_exact = H / (mu * G)
    return dict(error=float(abs(a / a_exact - 1)), a_fit=float(a), a_from_tension=float(a_exact),
                rms_over_sag=rms / sag, steps=steps, sweeps_per_step=its / steps,
                non_converged=nc)


def case_sliding(p, dt, theta, tol):
    r, v0, mu = p["r"], p["v0"], p["mu"]
    s = Scene(gravity=(0, 0, -G))
    s.add_plane(group="wall")
    s.add_spheres([[0.0, 0.0, r]], r, density=2650.0, velocities=[[v0, 0, 0]])
    s.interact("sand", "wall", laws.Coulomb(mu=mu))
    model, state = s.compile(dt=dt, theta=theta, tol=tol)
    t_exact = 2 * v0 / (7 * mu * G)
    steps = int(np.ceil(2 * t_exact / dt))
    t_slip, its, nc = None, 0, 0
    for _ in range(steps):
        st = step(model, state)
        its += st.iterations
        nc += not st.converged
        slip = state.velocity[1, 0] - r * state.spin[1, 1]
        if t_slip is None and abs(slip) < 1e-9 * v0:
            t_slip = state.time
    ev = abs(state.velocity[1, 0] / (5 / 7 * v0) - 1)
    et = abs(t_slip / t_exact - 1) if t_slip is not None else np.inf
    return dict(error=float(max(ev, et)), velocity_error=float(ev), slip_time_error=float(et),
                steps=steps, sweeps_per_step=its / steps, non_converged=nc)


def case_pile(p, dt, theta, tol, r):
    rng = np.random.default_rng(7)
    w = p["width"]
    n = max(8, int(round(p["n_at_1mm"] * (1e-3 / r) ** 3)))
    d = 2 * r * 1.1 * 1.1
    nx = int(w // d)
    pts = []
    for k in range(n):
        i = k % (nx * nx)
        pts.append((d / 2 + (i % nx) * d, d / 2 + (i // nx) * d, d / 2 + (k // (nx * nx)) * d))
    pts = np.asarray(pts)
    # each grain shifted sideways at random within its cell: a disordered pile, not columns
    pts[:, :2] += rng.uniform(-0.03 * d, 0.03 * d, (n, 2))
    radii = r * rng.uniform(0.9, 1.1, n)
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, radii, density=2650.0)
    box = s.add_box((0, 0, 0), (w, w, 0.1), group="side")
    s.interact("sand", "sand", laws.Coulomb(mu=p["mu"]))
    s.interact("sand", "side", laws.Coulomb(mu=0.0))
    model, state = s.compile(dt=dt, theta=theta, tol=tol, max_iter=p["max_iter"])
    steps = int(round(p["settle_time"] / dt))
    its, nc = 0, 0
    for _ in range(steps):
        st = step(model, state)
        its += st.iterations
        nc += not st.converged
    c = state.contacts
    R = float(c.normal_force[c.j == box[0]].sum())
    W = float(model.body_mass[model.sphere_ids].sum() * G)
    ids = model.sphere_ids
    ke = 0.5 * float(model.body_mass[ids] @ (state.velocity[ids] ** 2).sum(1))
    return dict(error=abs(R / W - 1), reaction=R, weight=W, n_grains=n, kinetic_energy=ke,
                steps=steps, sweeps_per_step=its / steps, non_converged=nc)


def _triaxial(p, dt, theta, tol, max_iter, tmp):
    from engine.experiments import box_triaxial
    from engine.experiments.common import ConvergenceError

    f = 5e-5 / dt  # same physical ramp and check times whatever h
    kw = dict(axial_strain=p["axial_strain"], dt=dt, theta=theta, tol=tol, max_iter=max_iter,
              max_nonconverged=1.0, record_every=max(1, int(round(p["record_every"] * f))),
              ramp_steps=int(round(400 * f)), check_every=max(1, int(round(10 * f))),
              iso_max_steps=int(round(4000 * f)), seed=p["seed"],
              history=os.path.join(tmp, f"tri-{dt:g}-{theta:g}-{tol:g}.h5"), progress=False)
    try:
        r = box_triaxial(p["scale"], **kw)
    except ConvergenceError as e:  # not expected with max_nonconverged=1
        r = e.result
    return r


def case_triaxial(p, dt, theta, tol, ref, tmp, seed=None):
    if seed is not None:
        p = dict(p, seed=seed)
    r = _triaxial(p, dt, theta, tol, p["max_iter"], tmp)
    eps, q = np.asarray(r.axial_strain), np.asarray(r.deviator)
    e_ref, q_ref = ref["axial_strain"], ref["deviator"]
    lo, hi = max(eps.min(), e_ref.min()), min(eps.max(), e_ref.max())
    grid = np.linspace(lo, hi, 50)
    d = np.interp(grid, eps, q) - np.interp(grid, e_ref, q_ref)
    scale = float(np.mean(np.abs(q_ref)))
    c = r.convergence
    # the mean deviator over the second half of the loading (the strength the curve
    # levels at) is a steadier figure than the curve itself, which on 130 grains jumps as
    # contacts open and close
    half = lambda e, q: float(np.mean(q[e >= 0.5 * p["axial_strain"]]))  # noqa: E731
    q2, q2_ref = half(eps, q), half(e_ref, q_ref)
    return dict(error=float(np.sqrt(np.mean(d ** 2)) / scale),
                plateau_error=float(abs(q2 / q2_ref - 1)), plateau_q_Pa=q2,
                plateau_q_ref_Pa=q2_ref,
                final_deviator_Pa=float(q[-1]), final_deviator_ref_Pa=float(q_ref[-1]),
                steps=int(c.get("steps", 0)), non_converged=int(c.get("non_converged", 0)),
                n_records=int(len(q)))


# ---------------------------------------------------------------------------------------
def _timed(fn, *args, min_total_s=0.5, max_repeats=15):
    """Run ``fn(*args)``; a run shorter than ``min_total_s`` is repeated (up to
    ``max_repeats`` times, errors are deterministic) and the median wall time kept."""
    walls = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonConvergenceWarning)
        warnings.simplefilter("ignore", RuntimeWarning)
        while True:
            t = time.perf_counter()
            out = fn(*args)
            walls.append(time.perf_counter() - t)
            if sum(walls) >= min_total_s or len(walls) >= max_repeats:
                break
    out["wall_s"] = float(np.median(walls))
    out["repeats"] = len(walls)
    return out


def sweep(name, fn, p, knobs, extra=()):
    """Run ``fn`` at the default point and with each knob of ``knobs`` varied alone."""
    d = p["default"]
    rows = []
    seen = {}
    for knob in knobs:
        for v in p[knob]:
            point = dict(d, **{knob: v})
            key = tuple(sorted(point.items()))
            if key in seen and knob != "n_free":  # the default point: run once, tagged twice
                rows.append(dict(seen[key], knob=knob, value=v))
                continue
            pp = dict(p, _bead_sweep=(knob == "n_free"))
            out = _timed(fn, pp, *[point[k] for k in d], *extra)
            row = dict(case=name, knob=knob, value=v, default=(v == d[knob]), **point, **out)
            if knob != "n_free":
                seen[key] = row
            rows.append(row)
            print(_fmt_row(row), flush=True)
    return rows


def _fmt_row(r):
    nc = r.get("non_converged", 0)
    return (f"  {r['case']:9s} {r['knob']:7s} {r['value']:<9.3g} error {r['error']:9.2e}   "
            f"wall {r['wall_s']:7.2f} s   steps {r.get('steps', 0):6d}   "
            f"sweeps/step {r.get('sweeps_per_step', float('nan')):7.1f}"
            + (f"   plateau q error {r['plateau_error']:.2e}" if "plateau_error" in r else "")
            + (f"   NOT CONVERGED: {nc} steps" if nc else "")
            + ("   (default)" if r["default"] else ""))


def figure(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    rows = rows + [dict(r, case="triaxial (plateau q)", error=r["plateau_error"])
                   for r in rows if "plateau_error" in r]
    cases = list(dict.fromkeys(r["case"] for r in rows))
    ncol = min(3, len(cases))
    nrow = -(-len(cases) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 3.8 * nrow), squeeze=False)
    for ax in axes.ravel()[len(cases):]:
        ax.set_visible(False)
    axes = axes.ravel()
    style = {"dt": ("o-", "C0", "h"), "theta": ("s", "C1", "θ"), "tol": ("^-", "C2", "tol"),
             "n_free": ("D-", "C3", "beads"), "n_links": ("D-", "C3", "links"),
             "r": ("D-", "C3", "grain r"), "sample": ("x", "C4", "other sample (seed)")}
    floor = 1e-16
    for ax, case in zip(axes, cases):
        sub = [r for r in rows if r["case"] == case]
        for knob in dict.fromkeys(r["knob"] for r in sub):
            k = [r for r in sub if r["knob"] == knob]
            k.sort(key=lambda r: r["value"])  # the line follows the knob's values
            fmt, col, lab = style.get(knob, ("x-", "k", knob))
            x = [r["wall_s"] for r in k]
            y = [max(r["error"], floor) if np.isfinite(r["error"]) else np.nan for r in k]
            ax.plot(x, y, fmt, color=col, label=lab, ms=5, alpha=0.8)
            for r, xx, yy in zip(k, x, y):
                ax.annotate(f"{r['value']:.2g}", (xx, yy), fontsize=6, color=col,
                            xytext=(3, 2), textcoords="offset points")
        dflt = [r for r in sub if r["default"]]
        if dflt:
            ax.plot(dflt[0]["wall_s"], max(dflt[0]["error"], floor), "k*", ms=12,
                    label="default", zorder=5)
        ax.set_xscale("log")
        ax.set_yscale("log")
        # the wall-time axis's minor-tick labels (2×10⁰ 3×10⁰ …) overlapped each other
        ax.xaxis.set_minor_formatter(NullFormatter())
        errs = [max(r["error"], floor) for r in sub if np.isfinite(r["error"])]
        if errs and max(errs) < 1.01 * min(errs):
            # the same error at every knob value (the chain solve's catenary): a decade
            # around it, not tick labels that all read the same number
            ax.set_ylim(min(errs) / 3.0, max(errs) * 3.0)
        ax.set_title(case)
        ax.set_xlabel("wall time [s]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    for ax in axes[::ncol]:
        ax.set_ylabel("relative error [-]")
    fig.suptitle("nscd-workbench: error vs wall time, one knob at a time "
                 "(2 shared cores, noisy timings)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="smoke run (about 1 min)")
    ap.add_argument("--out-dir", default=str(BENCH / "results"))
    ap.add_argument("--only", nargs="*", default=None,
                    help="cases to run (string catenary sliding pile triaxial)")
    a = ap.parse_args(argv)
    numba.set_num_threads(1)
    stamp = _dt.datetime.now()
    ps = dict(string=dict(STRING), catenary=dict(CATENARY), sliding=dict(SLIDING),
              pile=dict(PILE), triaxial=dict(TRIAXIAL))
    if a.quick:
        for k, v in QUICK.items():
            ps[k].update(v)
    for k, v in ps.items():  # keep the default point in every knob list
        for knob, val in v["default"].items():
            if knob in v and val not in v[knob]:
                v[knob] = sorted(v[knob] + [val])
    only = a.only or list(ps)
    busy = core.record.Busy()
    out = dict(benchmark="tradeoff", started=stamp.isoformat(timespec="seconds"),
               quick=a.quick, note=NOTE, machine=core.machine_info(),
               git=dict(commit=core._git("rev-parse", "HEAD") or os.environ.get("TRADEOFF_COMMIT"),
                        engine_uncommitted=core._git("status", "--short", "engine"),
                        engine_dir=str(ROOT / "engine"),
                        engine_sources_sha256=core._engine_hash()),
               numba_threads=1,
               params={k: {kk: vv for kk, vv in v.items()} for k, v in ps.items() if k in only},
               rows=[])

    # warm-up: every kernel the cases use, so compilation (or the cache load) is not timed
    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        beaded_string(n_free=3, dt=1e-3, periods=0.5)
        case_sliding(SLIDING, 1e-3, 0.5, 1e-4)
        case_pile(dict(PILE, n_at_1mm=20, settle_time=0.004), 2e-4, 0.5, 1e-4, 1e-3)
        case_catenary(dict(CATENARY, settle_time=0.004), 2e-4, 0.5, 1e-4, 6)
        case_catenary(dict(CATENARY, settle_time=0.004, chain_solve=True), 2e-4, 0.5, 1e-4, 6)
    out["warm_up_s"] = time.perf_counter() - t
    print(f"warm-up {out['warm_up_s']:.1f} s; single numba thread; " + NOTE, flush=True)

    rows = out["rows"]
    if "string" in only:
        print("beaded string: error of omega_1 (bead sweep: against the continuous string)")
        rows += sweep("string", case_string, ps["string"], ["dt", "theta", "tol", "n_free"])
    if "catenary" in only:
        print("hanging chain vs catenary: |a_fit / (H/(mu g)) - 1|")
        rows += sweep("catenary", case_catenary, ps["catenary"], ["dt", "theta", "tol", "n_links"])
        print("the same with each wire solved as one chain (chain_solve=True)")
        rows += sweep("catenary, chains", case_catenary, dict(ps["catenary"], chain_solve=True),
                      ["dt", "tol"])
    if "sliding" in only:
        print("sliding sphere: max(|v/(5/7 v0) - 1|, |t_roll/t_exact - 1|)")
        rows += sweep("sliding", case_sliding, ps["sliding"], ["dt", "theta", "tol"])
    if "pile" in only:
        print("pile: |floor reaction / weight - 1| after settling")
        rows += sweep("pile", case_pile, ps["pile"], ["dt", "theta", "tol", "r"])
    if "triaxial" in only:
        p = ps["triaxial"]
        rf = p["reference"]
        with tempfile.TemporaryDirectory() as tmp:
            print(f"triaxial (box, scale {p['scale']}): reference run at tol {rf['tol']:g}, "
                  f"max_iter {rf['max_iter']}", flush=True)
            t = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ref = _triaxial(p, rf["dt"], rf["theta"], rf["tol"], rf["max_iter"], tmp)
            ref_wall = time.perf_counter() - t
            refd = dict(axial_strain=np.asarray(ref.axial_strain), deviator=np.asarray(ref.deviator))
            out["triaxial_reference"] = dict(
                wall_s=ref_wall, n_sand=ref.params.get("n_sand"), n_beads=ref.params.get("n_beads"),
                convergence={k: v for k, v in ref.convergence.items() if k != "non_converged_steps"},
                axial_strain=refd["axial_strain"].tolist(), deviator_Pa=refd["deviator"].tolist(),
                strain_rate=ref.params.get("strain_rate"))
            print(f"  reference: {ref_wall:.1f} s, {ref.convergence.get('steps')} steps, "
                  f"{ref.convergence.get('non_converged')} not converged, final q = "
                  f"{ref.deviator[-1]:.4g} Pa at eps_a = {ref.axial_strain[-1]:.4f}", flush=True)
            print("  RMS(q - q_ref) / mean |q_ref| over the common strain range")
            rows += sweep("triaxial", case_triaxial, p, ["dt", "theta", "tol"], extra=(refd, tmp))
            d = p["default"]
            for seed in p["other_seeds"]:
                out_s = _timed(case_triaxial, p, d["dt"], d["theta"], d["tol"], refd, tmp, seed)
                row = dict(case="triaxial", knob="sample", value=seed, default=False, **d, **out_s)
                rows.append(row)
                print(_fmt_row(row) + "   (another sample: the spread between samples)",
                      flush=True)

    out["machine"]["loadavg_end"] = list(os.getloadavg())
    out["busy"] = busy.finish()
    out["total_wall_s"] = time.perf_counter() - _T_START
    if core._engine_hash() != out["git"]["engine_sources_sha256"]:
        out["git"]["warning"] = "engine/ sources changed while the benchmark ran"
        print("WARNING: engine/ sources changed while the benchmark ran")

    print("\nsummary: error and wall time per knob value (default point marked *)")
    print(f"{'case':9s} {'knob':7s} {'value':>9s} {'error':>9s} {'wall [s]':>9s} {'sweeps/step':>11s} {'not conv.':>9s}")
    for r in rows:
        print(f"{r['case']:9s} {r['knob']:7s} {r['value']:9.3g} {r['error']:9.2e} {r['wall_s']:9.2f} "
              f"{r.get('sweeps_per_step', float('nan')):11.1f} {r.get('non_converged', 0):9d}"
              + (" *" if r["default"] else "")
              + (f"  plateau q error {r['plateau_error']:.2e}" if "plateau_error" in r else ""))
    od = Path(a.out_dir)
    od.mkdir(parents=True, exist_ok=True)
    base = f"tradeoff-{stamp.strftime('%Y%m%d-%H%M')}" + ("-quick" if a.quick else "")
    (od / f"{base}.json").write_text(json.dumps(out, indent=1, default=core._json_default))
    figure(rows, od / f"{base}.png")
    print(f"wrote {od / (base + '.json')} and {base}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
