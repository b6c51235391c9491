"""One run of the report (:func:`paper_case`, on a Dask worker) and its curves file."""
from __future__ import annotations

import os

import numpy as np


def _law(wire, k):
    """(has a wire, its law) of a case (:func:`engine.experiments.config.wire_spec`)."""
    from engine.experiments.config import wire_spec

    if wire == "none":                       # (the slope's sand cases carry k = 1: unused)
        return False, None
    return True, wire_spec(wire, k).to_law()


def _write_curves(path, arrays: dict):
    from engine.files import h5_image, write_bytes

    def build(f):
        f.attrs["content"] = "paper-curves"
        for k, v in arrays.items():
            if v is not None:
                f.create_dataset(k, data=np.asarray(v))

    write_bytes(path, h5_image(build), "the curves could not be written")


def read_curves(path) -> dict:
    import h5py

    with h5py.File(path, "r") as f:
        return {k: f[k][()] for k in f}


def _outer_radius_profile(history, n_bins=8):
    """Outer radius of the sample's spheres per height bin, first and last frame (barrel)."""
    from engine import io

    out = {}
    for tag, frame in (("first", 0), ("last", -1)):
        model, state = io.load(history, frame=frame)
        ids = model.sphere_ids
        x, r = state.position[ids], model.body_radius[ids]
        z = x[:, 2]
        lo, hi = float((z - r).min()), float((z + r).max())
        edges = np.linspace(lo, hi, n_bins + 1)
        b = np.clip(np.digitize(z, edges) - 1, 0, n_bins - 1)
        rad = np.hypot(x[:, 0], x[:, 1]) + r
        prof = np.array([np.percentile(rad[b == i], 95) if np.any(b == i) else np.nan
                         for i in range(n_bins)])
        out[f"barrel_z_{tag}"] = 0.5 * (edges[1:] + edges[:-1]) - lo
        out[f"barrel_r_{tag}"] = prof
        out[f"barrel_step_{tag}"] = state.step
    return out


def paper_case(*, test: str, name: str, wire: str, k=None, seed: int = 0, runs_dir: str,
               checkpoint_every: int = 60, **params) -> dict:
    """One simulation of the report: run ``test`` (a name of :mod:`engine.experiments`),
    write its history ``runs_dir/name.h5`` and its curves ``runs_dir/name.curves.h5``, and
    return its scalars (what the sweep table keeps).  The deposits (hours each at the
    paper's scale) leave a checkpoint every ``checkpoint_every`` steps and when stopped,
    and go on from it when the case runs again (``resume``): a session, a job or a worker
    that ends mid-run loses at most that many steps."""
    from engine import experiments
    from workbench.campaign import not_interrupted, scalars_of

    os.makedirs(runs_dir, exist_ok=True)
    history = os.path.join(runs_dir, f"{name}.h5")
    curves = os.path.join(runs_dir, f"{name}.curves.h5")
    kw = _test_kwargs(test, wire, k, seed, history, checkpoint_every, params)
    res = not_interrupted(getattr(experiments, test)(**kw), name,
                          dict(test=test, seed=seed, **params))
    if test in ("slope_deposit", "gravity_deposit"):
        arr = _deposit_curves(res, test, name)
    elif test == "box_triaxial":
        arr = _box_curves(res)
    else:
        arr = _cylinder_curves(res, history)
    _write_curves(curves, arr)
    out = scalars_of(res)
    out.update(curves=curves, history=history, threads=int(kw.get("threads", 1)))
    if test == "slope_deposit":
        out["linear_slope_deg"] = float(arr["linear_slope_deg"])
    return out


def _test_kwargs(test, wire, k, seed, history, checkpoint_every, params) -> dict:
    """The keyword arguments of the test of a case."""
    has_wire, law = _law(wire, k)
    kw = dict(params, wire=has_wire, seed=seed, history=history, progress=False)
    if has_wire:
        kw["wire_law"] = law
    if test == "slope_deposit" and kw.get("wire_density") is None:
        kw.pop("wire_density", None)
    if test in ("slope_deposit", "gravity_deposit"):
        # hours at the paper's scale: a run stopped or killed goes on from its checkpoint
        # when the report is built again
        kw.update(checkpoint_every=checkpoint_every, resume=True)
    return kw


def check_cases(cases, fixed=None) -> None:
    """Validate every case of a report through its test's config
    (:meth:`engine.experiments.config.TestConfig.from_kwargs`) before anything runs: a case
    with a parameter out of range or a wire its law cannot have is refused, on one line
    naming the case, the field, its value and the allowed range."""
    from engine.experiments.config import CONFIGS

    for c in cases:
        p = dict(c, **(fixed or {}))
        test, name, wire, k = p.pop("test"), p.pop("name"), p.pop("wire"), p.pop("k", None)
        seed, runs_dir = p.pop("seed", 0), p.pop("runs_dir", ".")
        try:
            kw = _test_kwargs(test, wire, k, seed, os.path.join(runs_dir, f"{name}.h5"),
                              p.pop("checkpoint_every", 60), p)
            CONFIGS[test].from_kwargs(**kw)
        except (ValueError, KeyError) as e:
            raise ValueError(f"paper case {name!r}: {e}") from None


def _deposit_curves(res, test, name) -> dict:
    """A deposit's curves: the heap's profile (slope) or the settling (mould), and the
    wire's statistics before and after."""
    from engine.analysis import max_slope

    arr = {}
    if test == "slope_deposit":
        p = res.profile
        if p is None:
            raise RuntimeError(f"{name}: {res.params['profile_error']}")
        arr.update(r=p.r, height=p.height, pressure=p.pressure,
                   height_fit=p.height_fit.coeffs, pressure_fit=p.pressure_fit.coeffs,
                   max_slope_deg=p.max_slope_deg,
                   linear_slope_deg=max_slope(p.r, p.height, 1)[1])
    else:
        arr.update(time=res.time, kinetic_energy=res.kinetic_energy,
                   settlement=res.settlement, slack_share=res.slack_share,
                   at_rest=res.at_rest)
    if res.wire_before is not None:
        for when, st, hists in (("before", res.wire_before, res.histograms_before),
                                ("after", res.wire_after, res.histograms_after)):
            arr[f"orientation_{when}"] = st.orientation
            arr[f"tortuosity_{when}"] = st.tortuosity
            arr[f"wire_length_{when}"] = st.length
            for plane, (edges, w) in hists.items():
                arr[f"hist_{when}_{plane}_edges"] = edges
                arr[f"hist_{when}_{plane}_weights"] = w
    return arr


def _triaxial_curves(res) -> dict:
    return dict(axial_strain=res.axial_strain, deviator=res.deviator,
                volumetric_strain=res.volumetric_strain, mean_stress=res.mean_stress,
                wire_equivalent=res.wire_equivalent, wire_stress=res.wire_stress)


def _box_curves(res) -> dict:
    """A box triaxial's curves, the wire stress of its halves and its best-fit strains."""
    arr = _triaxial_curves(res)
    for half in ("upper", "lower"):
        arr[f"wire_stress_{half}"] = res.extra.get(f"wire_stress_{half}")
    for part, s in res.extra.get("best_fit_strain", {}).items():
        arr[f"strain_{part}_principal"] = s.principal
        arr[f"strain_{part}_tensor"] = s.tensor
    return arr


def _cylinder_curves(res, history) -> dict:
    """A cylinder triaxial's curves, its last toroidal map, its H and its barrel profile."""
    arr = _triaxial_curves(res)
    maps = res.extra.get("torus_maps") or {}
    if maps:
        e = max(maps)
        m = maps[e]
        arr.update(torus_strain=e, torus_r_edges=m.r_edges, torus_z_edges=m.z_edges,
                   torus_equivalent=m.equivalent, torus_slab_equivalent=m.slab_equivalent())
    H = res.extra.get("H")
    if H is not None:
        arr.update(H=H.H, H_intercept=H.intercept, H_start=H.start, H_r2=H.r2)
    try:
        arr.update(_outer_radius_profile(history))
    except Exception:  # noqa: BLE001 - no frame recorded: no barrel profile
        pass
    return arr


# The sweep table keys each case by its function's module and name
# ("workbench.paper.paper_case", workbench.campaign.case_key): the name it had before the package
# was split, so that the tables and runs of earlier builds are still found and reused.
paper_case.__module__ = "workbench.paper"
