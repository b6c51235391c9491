"""The ``nscd`` command.

::

    nscd demo [--out DIR] [--scale S]        a small TexSol cylinder triaxial test -> DIR/run.h5,
                                             PNG snapshots and figures, a ParaView series
    nscd run CONFIG.toml [--out DIR] [--view]  a test from a validated TOML file (--view: and
                                             its live viewer)
    nscd render RUN.h5 [--frames N|A:B|all] [--preset beads|wire|forces|torus] [--camera ...]
               [--window-size WxH] [--clim LO,HI] [--out PNG|DIR] [--movie FILE.mp4|.gif]
               [--axes] [--weak] [--color-by kind|speed|group] [--cut X,Y,Z]
    nscd export RUN.h5 OUTDIR                every frame of a history as VTU + a PVD, with
                                             each frame's step, time, strain and stresses
                                             as field data, and OUTDIR/open_in_paraview.py
                                             (paraview --script=...: the pipeline built)
    nscd info RUN.h5                         what a checkpoint or history holds
    nscd view PATH [--port N] [--host H] [--follow] [--mode server|client]
                                             the interactive viewer in the browser: a
                                             history, a checkpoint or a folder of runs
    nscd paper [--scale tiny|default|paper] [--out DIR] [--scheduler ADDRESS|serial]
               [--cluster NAME --cluster-option NAME=VALUE ... --workers N]
               [--only CLAIMS] [--threads T] [--reuse-only | --runs NAME,NAME]
                                             reproduce the paper's §3: DIR/report.md, figures,
                                             runs, series (workbench/paper/)
    nscd sweep TEST --grid NAME=V1,V2 ... [--out TABLE.json] [--scheduler ADDRESS|serial]
               [--cluster local|slurm|pbs|... --cluster-option NAME=VALUE ... --workers N]
                                             independent runs of a test on Dask (campaign)

A TOML file for ``nscd run``::

    test = "cylinder_triaxial"        # or "box_triaxial", "slope_deposit", "gravity_deposit",
                                       # "pullout_test"
    scale = 0.05                       # 1: the paper's size
    seed = 0
    [parameters]                       # the test function's keyword arguments
    pressure = 15e3
    axial_strain = 0.05
    [wire]
    law = "elastic"                    # "elastic", "rigid", "elastic_rod", "rigid_rod",
                                       # "brittle", "loose" (the beads with no link
                                       # force: a control) or "none" (sand only)
    stiffness = 1.0                    # [N], the elastic laws only
    prestrain = 0.0                    # ε₀, any law but "loose"
    # max_tension = 0.5                # [N], "brittle" only (required there)
    neighbour_contact = false          # true: linked beads also touch (Scene.add_wire;
                                       # left out: the test's own, true for pullout_test)

With ``sample = "DEPOSIT.h5"`` in ``[parameters]`` (a history or checkpoint; the triaxial
tests and slope_deposit) the test starts from that file's last state, its wire with the
state's own law: leave ``[wire]`` out then.

Unknown keys, wrong types and values out of range are reported together, each with its
field and the allowed range; nothing runs then.
"""
from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import warnings
from pathlib import Path
from typing import Literal, Optional

from pydantic import BaseModel, Field, ValidationError, model_validator

from engine.experiments.params import (PARAMS as _PARAMS, SEED_LIMIT, STEP_LIMIT,
                                       BoxParams,  # noqa: F401
                                       CylinderParams, DepositParams, SlopeParams,
                                       SolverParams, Strict as _Strict, TriaxialParams)

from .meshes import sample_cylinder  # noqa: F401  (numpy only; it lived here before)
from .render import CAMERAS, PRESETS  # noqa: E402  (no PyVista import: it is lazy there)


# ---------------------------------------------------------------- configuration files

class WireConfig(_Strict):
    law: Literal["elastic", "rigid", "elastic_rod", "rigid_rod", "brittle", "loose",
                 "none"] = Field(
        "elastic", description="elastic: ElasticWire, rigid: RigidWire (tension only); "
                               "elastic_rod, rigid_rod: either sign; brittle: an elastic "
                               "wire whose links break past max_tension; loose: the beads "
                               "with no link force (a control); none: sand only")
    stiffness: float = Field(1.0, gt=0, description="k [N], elastic laws only")
    prestrain: float = Field(0.0, gt=-1, le=1, description="ε₀ [-]: reference length g(0)/(1+ε₀)")
    max_tension: Optional[float] = Field(None, gt=0, description="[N], brittle only (required)")
    neighbour_contact: bool = Field(False, description="linked beads also touch like two "
                                                       "spheres (false: a slack link's beads "
                                                       "may overlap; left out: the test's "
                                                       "own, true for pullout_test)")

    @model_validator(mode="after")
    def _parameters_of_the_law(self):
        self.wire_law()              # a parameter the law has not (stiffness of 'rigid' ...)
        return self

    def wire_law(self):
        """The law object (:func:`engine.experiments.config.wire_spec`; None for "none")."""
        from engine.experiments.config import wire_spec

        given = {n: getattr(self, n) for n in ("stiffness", "prestrain", "max_tension")
                 if n in self.model_fields_set}
        return wire_spec(self.law, given.pop("stiffness", None), **given).to_law()


def _default_scale(test: str) -> float:
    """The ``scale`` default of the test function (``engine.experiments``)."""
    import inspect

    from engine import experiments
    return inspect.signature(getattr(experiments, test)).parameters["scale"].default


class RunConfig(_Strict):
    test: Literal["cylinder_triaxial", "box_triaxial", "slope_deposit", "gravity_deposit",
                  "pullout_test"]
    scale: Optional[float] = Field(None, gt=0, le=1.0,
                                   description="sample size (1: the paper's); default: the "
                                               "test function's own")
    seed: int = Field(0, ge=0, le=SEED_LIMIT)
    parameters: dict = {}
    wire: WireConfig = WireConfig()


class ConfigError(ValueError):
    pass


def _format_errors(e: ValidationError, cls, prefix="") -> list[str]:
    from engine.checks import describe

    return [f"  {describe(err, cls, prefix)}" for err in e.errors()]


#: The largest run file read [bytes]: a run file of the longest form is a few kB.
RUN_FILE_MAX_BYTES = 1 << 20


def load_config(path) -> tuple[RunConfig, BaseModel]:
    """Read and validate a TOML run file; ConfigError lists every problem, those of the
    top level and those of ``[parameters]`` together."""
    import tomllib

    from engine.io import FormatError, regular_file

    try:
        regular_file(path, max_bytes=RUN_FILE_MAX_BYTES)
        with open(path, "rb") as f:
            text = f.read().decode("utf-8-sig")      # a byte-order mark some editors write
        raw = tomllib.loads(text)
    except FormatError as e:
        raise ConfigError(str(e))
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such file")
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, not a TOML file")
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: not a text file (not UTF-8: {e.reason} at byte {e.start})")
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: not valid TOML: {e}")
    except RecursionError:
        raise ConfigError(f"{path}: its tables or arrays are nested too deep to read (a run "
                          f"file nests two levels)")
    return validate_config(raw, path)


def validate_config(raw: dict, path="run file") -> tuple[RunConfig, BaseModel]:
    """:func:`load_config` on the table a TOML file holds: (top level, ``[parameters]``)
    validated, or ConfigError listing every problem (``path`` names the file)."""
    problems = []
    cfg = None
    try:
        cfg = RunConfig(**raw)
    except ValidationError as e:
        problems += _format_errors(e, RunConfig)
    test = cfg.test if cfg is not None else raw.get("test")
    if not isinstance(test, str):    # test = [] or 3: reported above, no parameters to read
        test = None
    params = None
    if test in _PARAMS and isinstance(raw.get("parameters", {}), dict):
        try:
            params = _PARAMS[test](**raw.get("parameters", {}))
        except ValidationError as e:
            problems += _format_errors(e, _PARAMS[test], "parameters.")
    if (params is not None and test != "gravity_deposit"    # (its sample is a name)
            and getattr(params, "sample", None) is not None
            and isinstance(raw.get("wire"), dict) and raw["wire"].get("law", "elastic") != "none"):
        problems.append("  wire: a [wire] law with parameters.sample: the start state's links "
                        "keep their own law and reference lengths; leave [wire] out (or "
                        "law = \"none\" for a state without a wire)")
    if not problems and params is not None:
        try:                        # the test's config (what runs), built from the file
            file_config(cfg, params, Path("."), progress=False)
        except ValueError as e:
            problems.append("  " + str(e).removeprefix(f"{test}: "))
    if problems:
        where = f" ({test})" if test in _PARAMS else ""
        raise ConfigError(f"{path}: {len(problems)} problem(s){where}\n" + "\n".join(problems))
    return cfg, params


def config_help() -> str:
    """The TOML format of ``nscd run`` and every test's parameters with their defaults and
    allowed values, read from the validating models (``nscd run --help``)."""
    from engine.checks import allowed

    lines = ["A TOML file: test, scale, seed, [parameters] (the test's keyword arguments) "
             "and [wire]:", ""]
    lines += ["  " + x for x in __doc__.split("A TOML file for ``nscd run``::")[1]
              .split("Unknown keys")[0].strip("\n").splitlines()]

    def table(cls, skip=()):
        out = []
        for name, f in cls.model_fields.items():
            if name in skip:
                continue
            rng = allowed(cls, name)
            default = "required" if f.is_required() else f"default {f.default!r}"
            desc = f" — {f.description}" if f.description else ""
            out.append(f"  {name}: {default}" + (f"; {rng}" if rng else "") + desc)
        return out

    scales = ", ".join(f"{t} {_default_scale(t):g}" for t in _PARAMS)
    lines += (["", "Top level:"] + [x + (f" ({scales})" if x.startswith("  scale:") else "")
                                      for x in table(RunConfig, skip=("parameters", "wire"))]
              + ["", "[wire]:"] + table(WireConfig))
    for test, cls in _PARAMS.items():
        lines += ["", f"[parameters] of {test}:"] + table(cls)
    return "\n".join(lines)


def run_config(cfg: RunConfig, params: BaseModel, out: Path, progress=True):
    """Run the test of a validated run file (:func:`file_config`) into ``out/run.h5``."""
    return file_config(cfg, params, out, progress).run()


def file_config(cfg: RunConfig, params: BaseModel, out: Path, progress=True):
    """The test's config (:mod:`engine.experiments.config`) of a validated run file: its
    ``[parameters]`` are the config's parts' fields by their keyword names, ``[wire]`` its
    wire, the top level its scale and seed; the history ``out/run.h5``."""
    from engine.experiments.config import CONFIGS

    kw = params.model_dump(exclude_none=True)
    law = cfg.wire.wire_law()
    kw["wire"] = law is not None
    if (cfg.test != "gravity_deposit" and kw.get("sample") is not None
            and "wire" not in cfg.model_fields_set):
        kw["wire"], law = True, None        # the start state's own wire, if it has one
    if law is not None:
        kw["wire_law"] = law
        if "neighbour_contact" in cfg.wire.model_fields_set:   # else the test's own default
            kw["neighbour_contact"] = cfg.wire.neighbour_contact
    scale = _default_scale(cfg.test) if cfg.scale is None else cfg.scale
    return CONFIGS[cfg.test].from_kwargs(scale=scale, seed=cfg.seed, history=str(out / "run.h5"),
                                         progress=progress, **kw)


# ---------------------------------------------------------------- outputs of a run

def export_series(history, outdir, *, name="frame", progress=True) -> Path:
    """Every frame of a history file as VTU + a PVD collection + ``open_in_paraview.py``;
    returns the PVD path (:func:`workbench.series.export_history`, where it lives now)."""
    from .series import export_history

    return export_history(history, outdir, name=name, progress=progress)


def _n_frames(path) -> int:
    from engine import io
    return io.frame_count(path)


def render_frame(history, out, *, frame=-1, preset="beads", camera="iso", **options) -> Path:
    """:func:`workbench.frames.render_frame`, where it lives now (kept here by name)."""
    from .frames import render_frame as draw

    return draw(history, out, frame=frame, preset=preset, camera=camera, **options)


def figures_of(result, out: Path) -> list[Path]:
    """Standard figures of a test's result: stress–strain (the triaxial tests) and the
    solver's convergence (every test)."""
    from engine import io
    from . import figures

    paths = []
    if hasattr(result, "axial_strain"):
        paths.append(figures.stress_strain_figure([result], out / "stress_strain.png",
                                                  title=result.name))
    h = io.read_history(result.history, frames=False)
    paths.append(figures.convergence_figure(h.iterations, h.residual, out / "convergence.png",
                                            tol=result.params.get("tol"),
                                            max_iter=result.params.get("max_iter"),
                                            step=h.step, n_contacts=h.n_contacts,
                                            converged=h.converged))
    return paths


def _count(n, noun) -> str:
    return f"{n} {noun}" + ("" if n == 1 else "s")


def _flat(d: dict, head: str = "") -> dict:
    """A nested config as {"part.field": value} (a run's arguments for ``nscd info``)."""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{head}{k}."))
        else:
            out[f"{head}{k}"] = v
    return out


def info(path) -> str:
    import numpy as np

    from engine import io

    content, version = io.file_content(path)
    model = io.load_model(path)
    lines = [f"{path}: nscd-workbench {content}, format version {version}",
             f"  bodies {model.n_bodies} ({len(model.sphere_ids)} spheres, "
             f"{_count(len(model.wall_ids), 'wall')}), links {model.n_links}, groups "
             f"{', '.join(model.group_names)}",
             f"  options: dt={model.options.dt:g} s, theta={model.options.theta}, "
             f"tol={model.options.tol:g}, max_iter={model.options.max_iter}"]
    if content == "history":
        meta = io.history_meta(path)
        if meta.get("test"):
            lines.append(f"  test: {meta['test']}")
            for title, d in (("parameters", meta.get("params")),
                             ("its arguments", _flat(meta.get("config") or {}))):
                if d:
                    lines.append(f"  {title}: " + ", ".join(
                        f"{k}={v}" for k, v in d.items() if v is not None))
        h = io.read_history(path, frames=True)
        nc = int((~h.converged.astype(bool)).sum())
        lines.append(f"  records {h.n_records} (steps {h.step[0]}..{h.step[-1]}, t = "
                     f"{h.time[0]:.6g}..{h.time[-1]:.6g} s), frames {h.n_frames}")
        lines.append(f"  NLGS: mean {np.mean(h.iterations):.0f} sweeps, {nc} recorded steps "
                     f"not converged, max residual {np.max(h.residual):.3g}")
        if h.extra:
            lines.append("  extra records: " + ", ".join(
                f"{k} {tuple(v.shape[1:])} [{h.units.get(k, '?')}]" for k, v in h.extra.items()))
    else:
        _, state = io.load(path)
        lines.append(f"  state: step {state.step}, t = {state.time:.6g} s, "
                     f"{len(state.contacts)} contacts")
    return "\n".join(lines)


# ---------------------------------------------------------------- the commands

def cmd_demo(a) -> int:
    from engine.experiments import cylinder_triaxial

    problems = []  # the run file's checks, before anything is written
    for cls, kw in ((RunConfig, dict(test="cylinder_triaxial", scale=a.scale)),
                    (CylinderParams, dict(axial_strain=a.strain))):
        try:
            cls(**kw)
        except ValidationError as e:
            problems += [x.strip().replace("axial_strain", "--strain", 1)
                         .replace("scale", "--scale", 1) for x in _format_errors(e, cls)]
    if problems:
        raise ConfigError("; ".join(problems))
    out = folder_arg(a.out, "--out", "the demo's history, pictures and series go into it")
    print(f"nscd demo: a TexSol cylinder triaxial test at scale {a.scale} -> {out}/")
    res = cylinder_triaxial(a.scale, axial_strain=a.strain, history=str(out / "run.h5"),
                            frames=50, progress=True)
    print(res)
    paths = figures_of(res, out)
    for preset in PRESETS:
        paths.append(render_frame(res.history, out / f"{preset}.png", preset=preset))
    from .frames import write_movie     # the test in motion, one colour scale and camera

    paths.append(write_movie(res.history, out / "wire.mp4", preset="wire", fps=12))
    pvd = export_series(res.history, out / "series", name="cylinder")
    print("wrote:\n  " + "\n  ".join(str(p) for p in [out / "run.h5", *paths, pvd,
                                                      pvd.parent / "open_in_paraview.py"]))
    code = _interrupted(res, "demo")
    if code == 0:
        print(f"explore it in 3D (rotate, scrub the frames, clip, pick; in a browser):\n"
              f"  nscd view {out / 'run.h5'}     (.venv/bin/nscd from a fresh clone)")
        print(_paraview_hint(pvd))
    return code


def cmd_run(a) -> int:
    try:
        cfg, params = load_config(a.config)
    except ConfigError as e:
        print(bounded(f"nscd run: {e}"), file=sys.stderr)
        return 2
    out = folder_arg(a.out, "--out", "the run's run.h5 and figures go into it") if a.out \
        else Path("out") / Path(a.config).stem
    target = out / "run.h5"
    from engine.io import lock_history

    out.mkdir(parents=True, exist_ok=True)
    lock = lock_history(target)         # (a run writing there is refused before anything moves)
    try:
        return _run_into(a, cfg, params, out, target)
    finally:
        lock.release()


def _above_the_bar(line: str) -> None:
    """Print ``line`` above a progress bar being drawn (it was glued to the bar's end)."""
    from tqdm import tqdm

    tqdm.write(line)
    sys.stdout.flush()


def keep_earlier_run(target: Path, resume: bool, force: bool) -> Path | None:
    """Before ``nscd run`` writes ``target``: a history already there that this run does
    not go on from (no ``resume``, or no checkpoint beside it) is kept as ``run.N.h5`` (the
    first free N) and its new name returned, unless ``force`` (then it is replaced); a file
    that is not a history is removed with ``force`` (and refused by the writer without)."""
    from engine.experiments.common import RestCheckpoint
    from engine.io import FormatError, file_content

    if not target.is_file():
        return None
    try:
        kind = file_content(target)[0]
    except (FormatError, OSError):
        kind = None
    if kind != "history":
        if force:
            target.unlink()
        return None
    checkpoint = target.with_name(target.stem + RestCheckpoint.SUFFIX)
    if (resume and checkpoint.is_file()) or force:
        return None                     # resumed from there, or replaced as asked
    n = 1
    while (kept := target.with_name(f"{target.stem}.{n}{target.suffix}")).exists():
        n += 1
    os.replace(target, kept)
    return kept


def _run_into(a, cfg, params, out: Path, target: Path) -> int:
    """:func:`cmd_run` once the folder is this process's."""
    kept = keep_earlier_run(target, bool(getattr(params, "resume", False)), a.force)
    if kept is not None:
        print(f"nscd run: the earlier {target.name} is kept as {kept} (--force replaces it)",
              flush=True)
    beside = None
    if a.view:
        from .view.live import ViewerBeside

        beside = ViewerBeside(out / "run.h5", announce=_above_the_bar).start()
    try:
        res = run_config(cfg, params, out)
        print(res)
        print("wrote:\n  " + "\n  ".join(str(p) for p in [res.history, *figures_of(res, out)]))
        code = _interrupted(res, "run")
        if beside is not None and code == 0:
            beside.wait()
    finally:
        if beside is not None:
            beside.close()
    return code


def _interrupted(res, command) -> int:
    """0, or :data:`INTERRUPTED` with a line on stderr for a run Ctrl-C / SIGTERM stopped
    (its result and figures are written above)."""
    if not res.convergence.get("interrupted"):
        return 0
    print(f"nscd {command}: interrupted after {res.convergence['steps']} steps; what it "
          f"computed is above", file=sys.stderr)
    return INTERRUPTED


def _numbers(text, n, what, flag):
    """``"A,B"`` (``n`` numbers, ``x`` also separates) as floats, or ValueError naming the
    flag."""
    parts = [p for p in text.replace("x", ",").split(",") if p.strip()]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        vals = []
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise ValueError(f"{flag} {text!r}: expected {what}")
    return vals


#: Suffixes of the files the workbench writes or reads: a folder argument ending in one
#: names a file, which cannot be what was meant (:func:`folder_arg`).
FILE_SUFFIXES = (".h5", ".hdf5", ".png", ".jpg", ".jpeg", ".pvd", ".vtu", ".json", ".mp4",
                 ".gif", ".toml", ".md", ".py")


def folder_arg(value, flag: str, holds: str) -> Path:
    """The folder argument ``flag`` (``holds``: what goes into it), refused in one line
    when a file is at that path or its name ends like a file's (:data:`FILE_SUFFIXES`:
    ``--out run.h5`` would make a folder named ``run.h5``)."""
    p = Path(value)
    if p.exists() and not p.is_dir():
        raise ValueError(f"{flag} {value}: a file is there, and {flag} is a folder ({holds})")
    if p.suffix.lower() in FILE_SUFFIXES and not p.is_dir():
        raise ValueError(f"{flag} {value}: names a {p.suffix} file, and {flag} is a folder "
                         f"({holds}): give a folder name")
    return p


def render_options(a) -> dict:
    """The picture options of ``nscd render`` checked (one line naming the flag when bad)."""
    opts = {}
    if a.window_size is not None:
        w, h = _numbers(a.window_size, 2, "WIDTHxHEIGHT in pixels (e.g. 1600x1200)",
                        "--window-size")
        if not (w == int(w) and h == int(h) and 16 <= w <= 8192 and 16 <= h <= 8192):
            raise ValueError(f"--window-size {a.window_size!r}: width and height are whole "
                             f"pixels in [16, 8192]")
        opts["window_size"] = (int(w), int(h))
    if a.clim is not None:
        lo, hi = _numbers(a.clim, 2, "LOW,HIGH (the colour scale's limits, in the field's "
                                     "unit)", "--clim")
        if not hi > lo:
            raise ValueError(f"--clim {a.clim!r}: HIGH must be above LOW")
        if a.preset == "beads" and a.color_by != "speed":
            raise ValueError(f"--clim {a.clim!r}: --preset beads colours by "
                             f"{a.color_by or 'kind'}, which has no scale: add --color-by speed")
        opts["clim"] = (lo, hi)
    if a.color_by is not None:
        if a.preset != "beads":
            raise ValueError(f"--color-by is for --preset beads (got --preset {a.preset})")
        opts["color_by"] = a.color_by
    if a.cut is not None:
        if a.preset != "beads":
            raise ValueError(f"--cut is for --preset beads (got --preset {a.preset})")
        opts["cut"] = tuple(_numbers(a.cut, 3, "X,Y,Z (the side of the sample left out)",
                                     "--cut"))
    if getattr(a, "weak", False):
        if a.preset != "forces":
            raise ValueError(f"--weak is for --preset forces (got --preset {a.preset})")
        opts["weak"] = True
    if getattr(a, "axes", False):
        if a.preset == "torus":
            raise ValueError("--axes is for the 3D presets: the torus map's section always "
                             "has its axes in mm")
        opts["axes"] = True
    return opts


def cmd_render(a) -> int:
    from .frames import MOVIE_SUFFIXES, render_frames, write_movie

    opts = render_options(a)
    frames = a.frames if a.frames is not None else (a.frame if a.frame is not None else -1)
    stem = f"{Path(a.run).stem}_{a.preset}"           # in the current folder by default
    if a.movie is not None:
        if a.out is not None:
            raise ValueError("--movie writes one file: give it the path, not --out")
        if Path(a.movie).suffix.lower() not in MOVIE_SUFFIXES:
            raise ValueError(f"--movie {a.movie!r}: the file must end in "
                             f"{' or '.join(MOVIE_SUFFIXES)}")
        print(write_movie(a.run, a.movie, frames="all" if a.frames is None else a.frames,
                          preset=a.preset, camera=a.camera,
                          fps=10.0 if a.fps is None else a.fps, **opts))
        return 0
    if a.fps is not None:
        raise ValueError(f"--fps {a.fps:g}: frames per second are for --movie (PNGs have none)")
    from engine import io
    from .frames import parse_frames

    several = len(parse_frames(frames, io.frame_count(a.run))) > 1
    if several:
        out = folder_arg(a.out, "--out", "several frames go into it as frame_NNNN.png") \
            if a.out else stem
    elif a.out and (Path(a.out).is_dir() or a.out.endswith(("/", os.sep))):
        out = Path(a.out) / f"{stem}.png"       # a folder given: the picture goes inside
    else:
        out = a.out or stem + ".png"
    paths = render_frames(a.run, out, frames=frames, preset=a.preset, camera=a.camera, **opts)
    print(paths[0] if len(paths) == 1 else f"{Path(out)}: {len(paths)} frames")
    return 0


def _paraview_hint(pvd) -> str:
    from .paraview_state import SCRIPT_NAME

    return (f"open it in ParaView with the pipeline built (beads, wire tension, force chains, "
            f"walls):\n  paraview --script={Path(pvd).parent / SCRIPT_NAME}")


def cmd_export(a) -> int:
    folder_arg(a.outdir, "OUTDIR", f"the VTU files and {a.name}.pvd go into it; the .pvd's "
                                   f"name is --name")
    pvd = export_series(a.run, a.outdir, name=a.name)
    print(pvd)
    print(_paraview_hint(pvd))
    return 0


def cmd_view(a) -> int:
    from .view import is_loopback, serve

    if not is_loopback(a.host):
        warnings.warn(f"--host {a.host} is not a loopback address: anyone who can reach this "
                      f"machine on that interface can see the runs served", RuntimeWarning)
    if a.port is not None and not 0 <= a.port <= 65535:
        raise ValueError(f"--port {a.port}: a port is 0..65535 (0 or none: a free one)")

    def announce(url):
        print(f"nscd view: {url}  (Ctrl-C stops it)", flush=True)

    if a.follow:
        # a run is being written beside it: Mesa's llvmpipe renders on one thread, so the
        # viewer leaves the other cores to the writer (unless the caller chose)
        os.environ.setdefault("LP_NUM_THREADS", "1")

    serve(a.path, host=a.host, port=a.port or 0, follow=a.follow, mode=a.mode,
          shots=a.shots, announce=announce)
    print("nscd view: stopped", file=sys.stderr)
    return INTERRUPTED   # the server runs until Ctrl-C or SIGTERM stops it


def cmd_info(a) -> int:
    print(info(a.run))
    return 0


def cmd_paper(a) -> int:
    from .paper import build_report

    folder_arg(a.out, "--out", "the report, its figures, runs and series go into it")
    rep = build_report(a.out, a.scale, scheduler=cluster_from_args(a), render=not a.no_render,
                       only=a.only, threads=a.threads, reuse_only=a.reuse_only, runs=a.runs)
    counts = {}
    for c in rep.claims:
        counts[c.status] = counts.get(c.status, 0) + 1
    print(f"nscd paper: {rep.path} ({len(rep.claims)} claims: "
          + ", ".join(f"{n} {k}" for k, n in sorted(counts.items()))
          + f"; {len(rep.figures)} figures; {rep.wall_time:.0f} s)")
    for p in rep.problems:
        print(f"  problem: {p}", file=sys.stderr)
    return 0 if not rep.table.failed else 1


def _value(text):
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    return {"true": True, "false": False, "none": None}.get(text.lower(), text)


def parse_grid(items) -> dict:
    """``["k=0.1,1,10", "seed=0,1", "scale=0.05"]`` -> {"k": [0.1, 1, 10], ...}."""
    grid = {}
    for it in items or []:
        if "=" not in it:
            raise ValueError(f"--grid {it!r}: expected NAME=V1,V2,...")
        name, vals = it.split("=", 1)
        name = name.strip()
        if not name.isidentifier():
            raise ValueError(f"--grid {it!r}: {name!r} is not a parameter name")
        if name in grid:
            raise ValueError(f"--grid {it!r}: {name} is given twice; give its values once, "
                             f"comma-separated ({name}=V1,V2)")
        grid[name] = [_value(v.strip()) for v in vals.split(",") if v.strip()]
        if not grid[name]:
            raise ValueError(f"--grid {it!r}: no value")
    return grid


def parse_cluster_options(items) -> dict:
    """``["cores=2", "memory=4GB", "walltime=01:00:00"]`` -> {"cores": 2, "memory": "4GB",
    ...}: the options of a cluster's class (numbers, true/false/none, a JSON list, or
    text)."""
    import json

    opts = {}
    for it in items or []:
        if "=" not in it:
            raise ValueError(f"--cluster-option {it!r}: expected NAME=VALUE")
        name, text = (x.strip() for x in it.split("=", 1))
        if not name.isidentifier():
            raise ValueError(f"--cluster-option {it!r}: {name!r} is not an option name")
        if name in opts:
            raise ValueError(f"--cluster-option {it!r}: {name} is given twice")
        if text.startswith("["):
            try:
                opts[name] = json.loads(text)
            except ValueError:
                raise ValueError(f"--cluster-option {it!r}: not a JSON list") from None
        else:
            opts[name] = _value(text)
    return opts


def cluster_from_args(a):
    """Where ``nscd sweep`` / ``nscd paper`` run their cases: ``--scheduler`` (an address or
    "serial"), or ``--cluster`` by name with ``--cluster-option``s and ``--workers`` (a
    :class:`workbench.campaign.ClusterSpec`), or None (a LocalCluster of 2 workers)."""
    from workbench.campaign import cluster_spec

    options = parse_cluster_options(getattr(a, "cluster_option", None))
    if a.scheduler is not None and (a.cluster is not None or options):
        raise ValueError("--scheduler and --cluster / --cluster-option: give one of them "
                         "(--scheduler: a running scheduler or 'serial'; --cluster: a "
                         "cluster to start)")
    if a.scheduler is not None:
        return a.scheduler
    if a.cluster is None and not options and a.workers == 2:
        return None
    return cluster_spec(a.cluster or "local", options, a.workers)


#: The most cases ``nscd sweep`` runs without ``--max-cases`` (a grid is refused above it
#: before anything runs: 10⁶ cases were once accepted and ran silently for a minute).
MAX_CASES = 1000

#: The longest line of an error message printed [characters]; the rest is cut, and said.
MESSAGE_MAX = 400


def bounded(message: str, limit: int = MESSAGE_MAX) -> str:
    """``message`` with each line cut to ``limit`` characters (saying how many were cut)."""
    out = []
    for line in str(message).splitlines() or [""]:
        if len(line) > limit:
            line = f"{line[:limit]}… ({len(line) - limit} more characters)"
        out.append(line)
    return "\n".join(out)


def cmd_sweep(a) -> int:
    from workbench.campaign import EXPERIMENTS, sweep, table_path

    if a.test not in EXPERIMENTS:
        raise ValueError(f"unknown test {a.test!r}; choose one of {', '.join(EXPERIMENTS)}")
    grid = parse_grid(a.grid)
    n = math.prod(len(v) for v in grid.values()) if grid else 1
    if n > a.max_cases:
        sizes = " × ".join(f"{k} {len(v)}" for k, v in grid.items())
        raise ValueError(f"the grid has {n} cases ({sizes}), more than --max-cases "
                         f"{a.max_cases}: give a larger --max-cases to run them all")
    where = cluster_from_args(a)
    out = table_path(a.out or Path("out") / f"sweep_{a.test}.json", a.test)
    table = sweep(a.test, grid, where, out=out, retries=a.retries,
                  fixed={"history_dir": str(out.with_suffix("")) + "_runs"},
                  n_workers=a.workers)
    for r in table.failed:
        print(f"failed: {r['id']} {r['params']}: {r['errors'][-1].splitlines()[0]}",
              file=sys.stderr)
    return 0 if not table.failed else 1


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="nscd", description="nscd-workbench: NSCD of sand and "
                                "wire (TexSol) — run the paper's tests, render and export runs.")
    sub = p.add_subparsers(dest="command", required=True)
    d = sub.add_parser("demo", help="a small TexSol cylinder triaxial: run.h5, PNGs, a ParaView series",
                       description=cmd_demo.__doc__ or "Run the demo.")
    d.add_argument("--out", default="out/demo", help="output directory (default out/demo)")
    d.add_argument("--scale", type=float, default=0.1,
                   help="sample scale, in (0, 1] (1 = the paper's 6 200 grains; default 0.1)")
    d.add_argument("--strain", type=float, default=0.05,
                   help="final axial strain, in (0, 0.5] (default 0.05)")
    d.set_defaults(fn=cmd_demo)
    r = sub.add_parser("run", help="run a test from a TOML configuration file",
                       description="Run a test from a validated TOML file (every problem is "
                                   "reported before anything runs).",
                       epilog=config_help(), formatter_class=argparse.RawDescriptionHelpFormatter)
    r.add_argument("config", help="TOML file (its keys below)")
    r.add_argument("--out", help="output directory (default out/<config stem>)")
    r.add_argument("--view", action="store_true",
                   help="start the viewer (nscd view RUN.h5 --follow, its own process) as soon "
                        "as the run has a frame, print its URL, and keep it after the run "
                        "until Ctrl-C")
    r.add_argument("--force", action="store_true",
                   help="replace OUT/run.h5 (by default an earlier run's history is kept "
                        "as OUT/run.N.h5, and a file that is not a history refuses the run)")
    r.set_defaults(fn=cmd_run)
    g = sub.add_parser("render", help="render frames of a run to PNG, or a movie (off-screen)",
                       description="Draw frames of a history (or a checkpoint) off-screen. "
                                   "Several frames share one colour scale (the field's range "
                                   "over them, unless --clim) and one camera.")
    g.add_argument("run", help="history (.h5) or checkpoint")
    g.add_argument("--frames", help="N (negative: from the end), A:B or A:B:S (B excluded), "
                                    "or all (default: the last; a movie: all)")
    g.add_argument("--frame", type=int, default=None, help=argparse.SUPPRESS)  # = --frames N
    g.add_argument("--preset", choices=PRESETS, default="beads",
                   help="what to draw (default beads)")
    g.add_argument("--camera", choices=tuple(CAMERAS), default="iso",
                   help="view direction (default iso)")
    g.add_argument("--window-size", metavar="WxH", help="picture size in pixels (default 800x600)")
    g.add_argument("--clim", metavar="LOW,HIGH", help="colour scale limits in the field's unit "
                                                     "(N for wire and forces, Pa for torus)")
    g.add_argument("--color-by", choices=("kind", "speed", "group"),
                   help="beads: colour by kind (default), speed [m/s] or group")
    g.add_argument("--cut", metavar="X,Y,Z", help="beads: leave out the sand on this side of "
                                                 "the centre (0,-1,0 with --camera front)")
    g.add_argument("--out", help="PNG for one frame, folder for several (default "
                                 "<run stem>_<preset>[.png] in the current folder)")
    g.add_argument("--movie", metavar="FILE.mp4|FILE.gif",
                   help="every frame (or --frames) into one movie instead of PNGs")
    g.add_argument("--fps", type=float, default=None,
                   help="movie frames per second (default 10; --movie only)")
    g.add_argument("--axes", action="store_true",
                   help="draw the bounds as axes with ticks in mm (beads, wire, forces)")
    g.add_argument("--weak", action="store_true",
                   help="forces: also draw the weak network (thin grey lines; default: the "
                        "strong network only, fn > mean fn)")
    g.set_defaults(fn=cmd_render)
    e = sub.add_parser("export", help="export every frame of a history to a ParaView series "
                       "and OUTDIR/open_in_paraview.py (paraview --script=OUTDIR/"
                       "open_in_paraview.py opens it with the pipeline built)")
    e.add_argument("run", help="history file (.h5) written by a run")
    e.add_argument("outdir", help="directory for the VTU files and the PVD collection")
    e.add_argument("--name", default="frame", help="file stem")
    e.set_defaults(fn=cmd_export)
    v = sub.add_parser("view", help="the interactive 3D viewer of a run (or a folder of runs) "
                                    "in the browser", description=(
        "Serve the interactive viewer on HOST:PORT and print its URL: rotate the sample, "
        "scrub through the frames, toggle layers, colour by a field, clip, pick, and see "
        "the run's curves (docs/view.md).  Nothing is written beside the input; "
        "screenshots go to --shots."))
    v.add_argument("path", help="a history (.h5), a checkpoint, or a folder of runs (a nscd "
                                "sweep / nscd paper output, or any folder of histories)")
    v.add_argument("--port", type=int, default=None, help="port (default: a free one)")
    v.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1; another one is reachable "
                        "from other machines: a warning says so)")
    v.add_argument("--follow", action="store_true",
                   help="show a run that is still being written: new frames and curve points "
                        "appear as they are flushed")
    from .view.app import DEFAULT_MODE, MODES
    v.add_argument("--mode", choices=MODES, default=DEFAULT_MODE,
                   help="client (default): rendered by the browser (vtk.js), the faster frame "
                        "changes on large runs (docs/view.md); server: rendered on this "
                        "machine with the pictures' pipeline (nscd render's beads)")
    v.add_argument("--shots", default="out/view", help="folder of the screenshots "
                                                       "(default out/view)")
    v.set_defaults(fn=cmd_view)
    i = sub.add_parser("info", help="summarise a checkpoint or history file")
    i.add_argument("run", help="history or checkpoint file (.h5)")
    i.set_defaults(fn=cmd_info)
    pp = sub.add_parser("paper", help="reproduce the paper's §3 (Fig. 7-16, Table 2): a "
                        "Markdown report with figures, runs and series")
    pp.add_argument("--scale", default="default", choices=("tiny", "default", "paper"),
                    help="tiny: smoke test (minutes); default: reduced samples (~10 min on 2 "
                         "cores); paper: the paper's sizes (Fig. 11-16: ~45 min on 2 cores; the slopes: "
                         "hours, use --only or --scheduler)")
    pp.add_argument("--out", default="out/paper", help="output directory (default out/paper)")
    _cluster_arguments(pp, "LocalCluster of 2 workers")
    pp.add_argument("--only", default=None, metavar="CLAIMS",
                    help="run and report these claims only: ids or figure prefixes, "
                         "comma-separated (e.g. fig14 or fig13c,fig14-rigid)")
    pp.add_argument("--threads", type=int, default=None,
                    help="NLGS threads of each run (default 1; 2 pays on a paper-scale slope "
                         "with --scheduler serial)")
    pp.add_argument("--no-render", action="store_true", help="skip the PyVista snapshots")
    pp.add_argument("--reuse-only", action="store_true",
                    help="start no run: score the runs already done in OUT and list the "
                         "others as not run (a paper-scale report between sessions)")
    pp.add_argument("--runs", metavar="NAME,NAME",
                    help="start only these runs of the claims chosen (if not done); score "
                         "them with the runs already done in OUT and list the others as not "
                         "run (a paper-scale report a few runs per session; the names are "
                         "the report's, e.g. slope_w400_seed2)")
    pp.set_defaults(fn=cmd_paper)
    sw = sub.add_parser("sweep", help="run a test over a grid of parameters on Dask")
    sw.add_argument("test", help="cylinder_triaxial, box_triaxial, slope_deposit, "
                                 "gravity_deposit or pullout_test")
    sw.add_argument("--grid", action="append", metavar="NAME=V1,V2",
                    help="a parameter and its values (repeat; the cases are the product); "
                         "wire=elastic|rigid|none and k=... [N] choose the wire law")
    sw.add_argument("--out", help="JSON table, or a folder to put sweep_<test>.json in "
                    "(default out/sweep_<test>.json; .h5 and the runs' folder beside it)")
    _cluster_arguments(sw, "LocalCluster")
    sw.add_argument("--retries", type=int, default=1, help="retries of a failed case (default 1)")
    sw.add_argument("--max-cases", type=int, default=MAX_CASES,
                    help=f"refuse a grid of more cases than this, before anything runs "
                         f"(default {MAX_CASES})")
    sw.set_defaults(fn=cmd_sweep)
    return p


def _cluster_arguments(p, default):
    """``--scheduler``, ``--cluster``, ``--cluster-option`` and ``--workers`` of a command
    that runs a campaign (``nscd sweep``, ``nscd paper``)."""
    from workbench.campaign import CLUSTERS

    p.add_argument("--scheduler", default=None,
                   help=f"Dask scheduler address (default: a {default}; 'serial': no Dask)")
    p.add_argument("--cluster", default=None, choices=tuple(CLUSTERS),
                   help="start a cluster of this kind: local (a LocalCluster), a batch "
                        "system through dask-jobqueue (slurm, pbs, sge, lsf, moab, oar, "
                        "htcondor; each job runs workers), or jobqueue-local (the same job "
                        "scripts as local processes)")
    p.add_argument("--cluster-option", action="append", metavar="NAME=VALUE",
                   help="an option of the cluster's class (repeat), e.g. cores=2 memory=4GB "
                        "walltime=01:00:00 queue=normal account=myproject")
    p.add_argument("--workers", type=int, default=2,
                   help="workers of the cluster started (default 2)")


INTERRUPTED = 130  # the shell's code for a command stopped by SIGINT


def _internal(a, e: BaseException) -> int:
    """An error no message was written for (a bug of the workbench): one line saying so,
    exit 1; ``NSCD_TRACEBACK=1`` in the environment raises it with its traceback."""
    if os.environ.get("NSCD_TRACEBACK"):
        raise e
    where = e.__traceback__
    while where is not None and where.tb_next is not None:
        where = where.tb_next
    at = (f" at {Path(where.tb_frame.f_code.co_filename).name}:{where.tb_lineno}"
          if where is not None else "")
    print(bounded(f"nscd {a.command}: internal error ({type(e).__name__}{at}: "
                  f"{' '.join(str(e).split())}); please report it (NSCD_TRACEBACK=1 shows "
                  f"the traceback)"), file=sys.stderr)
    return 1


def main(argv=None) -> int:
    """Exit codes: 0 done; 1 a run failed (it did not converge, the sample came apart, a
    value became NaN: the message says where the history is), a write failed (a full disk)
    or an internal error (a bug: one line, ``NSCD_TRACEBACK=1`` for its traceback); 2 bad
    input (a file, a parameter); 130 stopped by Ctrl-C / SIGTERM (``nscd run`` still writes the figures of
    the steps run; a sweep keeps its finished cases); one line on stderr, no traceback."""
    from engine.experiments import ConfinementError, ConvergenceError
    from engine.io import WriteFailed
    from engine.step import SimulationError

    a = parser().parse_args(argv)

    def terminated(signum, frame):   # SIGTERM outside the steps, as Ctrl-C (the steps of
        from engine import stop        # a run catch both themselves and stop cleanly); the
        stop.request()                 # request stays, should the exception be swallowed
        raise KeyboardInterrupt        # (numba loading its cache): the run then stops

    try:
        old_term = signal.signal(signal.SIGTERM, terminated)
    except ValueError:                 # not the main thread (main() called from a thread)
        old_term = None

    def one_line(message, category, filename, lineno, file=None, line=None):
        from tqdm import tqdm  # above a progress bar, not inside it

        tqdm.write(f"nscd {a.command}: warning: {message}", file=file or sys.stderr)

    show, warnings.showwarning = warnings.showwarning, one_line
    try:
        return a.fn(a)
    except (ConvergenceError, ConfinementError, SimulationError) as e:
        print(f"nscd {a.command}: the run failed: {e}", file=sys.stderr)
        return 1
    except WriteFailed as e:  # a full disk: what was written is kept, marked complete
        print(bounded(f"nscd {a.command}: stopped: {e}"), file=sys.stderr)
        return 1
    except ValueError as e:
        print(bounded(f"nscd {a.command}: {e}"), file=sys.stderr)
        return 2
    except KeyboardInterrupt as e:   # Ctrl-C outside the steps (the engine stops those)
        print(f"nscd {a.command}: interrupted{f': {e}' if str(e) else ''}", file=sys.stderr)
        return INTERRUPTED
    except BrokenPipeError:  # `nscd info RUN.h5 | head`: the reader left, nothing to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except (OSError, RuntimeError) as e:  # a path that is a directory, exists already ...
        from engine.files import is_write_error, write_cause

        if not (isinstance(e, OSError) or is_write_error(e)):
            return _internal(a, e)
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        if is_write_error(e):     # a disk that refused a write no writer caught: exit 1
            print(bounded(f"nscd {a.command}: stopped: {where}a write failed "
                          f"({write_cause(e)})"), file=sys.stderr)
            return 1
        print(bounded(f"nscd {a.command}: {where}{e.strerror or e}"), file=sys.stderr)
        return 2
    except Exception as e:        # a bug of ours: one line, the traceback on demand
        return _internal(a, e)
    finally:
        warnings.showwarning = show
        if old_term is not None:
            signal.signal(signal.SIGTERM, old_term)


if __name__ == "__main__":
    sys.exit(main())
