"""What the viewer reads: one run file (a history or a checkpoint), or a folder of runs.

:class:`RunSource` holds a run's model (read once), its frame index, its recorded curves and
the colour limits of each field over the whole history (read once per field, extended as a
followed run appends frames).  :func:`find_runs` lists the runs of a folder (a ``nscd
sweep`` or ``nscd paper`` output, or any folder of histories) with what each says of itself
(:func:`engine.io.history_meta`) and what the sweep tables beside them say (parameters,
status).  Everything here only reads: no file given to the viewer is written or changed.
"""
from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["RunSource", "RunEntry", "ViewInputError", "find_runs", "open_input", "FIELDS",
           "run_status", "curves_of", "field_values", "state_arrays"]


class ViewInputError(ValueError):
    """A path the viewer cannot show (the message names it and why)."""


#: Colour fields: name -> (layer, unit, label).  ``layer`` is the part carrying the field
#: (:mod:`workbench.meshes`): beads, wire or contacts; kind and group are categories.
FIELDS = {
    "kind": ("beads", "-", "kind"),
    "group": ("beads", "-", "group"),
    "speed": ("beads", "m/s", "speed"),
    "spin": ("beads", "rad/s", "spin"),
    "tension": ("wire", "N", "tension"),
    "strain": ("wire", "-", "link strain"),
    "normal_force": ("contacts", "N", "normal force"),
    "tangential_force": ("contacts", "N", "tangential force"),
}


def _norms(a) -> np.ndarray:
    a = np.asarray(a, float)
    return np.sqrt((a * a).sum(axis=-1)) if a.size else np.zeros(a.shape[:-1])


def field_values(name: str, model, arrays: dict) -> np.ndarray:
    """The values of colour field ``name`` in one frame's ``arrays`` (of
    :func:`engine.io.frame_arrays`), in SI units (the same numbers as
    :mod:`workbench.meshes`' arrays)."""
    ids = model.sphere_ids
    if name == "speed":
        return _norms(arrays["velocity"][ids])
    if name == "spin":
        return _norms(arrays["spin"][ids])
    if name == "tension":
        return np.asarray(arrays["link_tension"], float)
    if name == "strain":
        p = arrays["position"]
        length = _norms(p[model.link_i] - p[model.link_j])
        return length / model.link_ref_length - 1.0
    if name in ("normal_force", "tangential_force"):
        f, n = np.asarray(arrays["contact_force"], float), np.asarray(arrays["contact_normal"])
        fn = (f * n).sum(axis=1) if f.size else np.zeros(0)
        if name == "normal_force":
            return fn
        return _norms(f - fn[:, None] * n) if f.size else np.zeros(0)
    raise ValueError(f"no values for field {name!r}")


def state_arrays(model, state) -> dict:
    """A state's arrays named as :func:`engine.io.frame_arrays` names a frame's (a
    checkpoint's one state, for :func:`field_values`)."""
    c = state.contacts
    force = c.force if len(c) and state.last_dt else np.zeros((len(c), 3))
    return {"position": state.position, "velocity": state.velocity, "spin": state.spin,
            "link_tension": state.links.tension, "link_broken": state.links.broken,
            "contact_force": force, "contact_normal": c.normal, "contact_i": c.i,
            "contact_j": c.j}


_NEEDS = {"speed": ["velocity"], "spin": ["spin"], "tension": ["link_tension"],
          "strain": ["position"], "normal_force": ["contact_force", "contact_normal"],
          "tangential_force": ["contact_force", "contact_normal"]}


def curves_of(records) -> dict:
    """The run's recorded curves, by name: ``{name: (x, y, x label, y label)}`` plus
    ``"_step"``, ``"_time"`` and ``"_converged"`` per record.  Every run: kinetic energy
    [J] and NLGS sweeps and residual per recorded step against time [s]; the triaxial tests
    (records ``stress``, ``height``, ``stage``): deviator q and mean stress p [kPa] and the
    wire's equivalent stress [kPa] (:func:`engine.analysis.equivalent_stress`) against the
    axial strain 1 − H/H₀, H₀ the height at the start of the loading (the records of the
    isotropic stage before it are left out), and ``"_curve_records"`` (the records drawn)
    and ``"_strain"``, ``"_q"``, ``"_p"`` per record (NaN in the isotropic stage)."""
    from engine.analysis import loading_curves

    t = np.asarray(records.time, float)
    out = {"_step": np.asarray(records.step), "_converged": np.asarray(records.converged, bool),
           "_time": t,
           "kinetic_energy": (t, np.asarray(records.kinetic_energy, float), "time [s]",
                              "kinetic energy [J]"),
           "iterations": (t, np.asarray(records.iterations, float), "time [s]",
                          "NLGS sweeps per step"),
           "residual": (t, np.asarray(records.residual, float), "time [s]", "NLGS residual")}
    lc = loading_curves(records)
    if lc is not None:
        sel = lc["loading"]
        eps = lc["strain"][sel]
        out["deviator"] = (eps, lc["deviator"][sel] / 1e3, "axial strain [-]", "deviator q [kPa]")
        out["mean_stress"] = (eps, lc["mean_stress"][sel] / 1e3, "axial strain [-]",
                              "mean stress p [kPa]")
        if "wire_stress" in records.extra:
            out["wire_equivalent"] = (eps, lc["wire_equivalent"][sel] / 1e3, "axial strain [-]",
                                      "wire eq. stress [kPa]")
        out["_curve_records"] = sel
        out["_strain"], out["_q"], out["_p"] = (lc["strain"], lc["deviator"] / 1e3,
                                                lc["mean_stress"] / 1e3)
    return out


@dataclass
class RunEntry:
    """A run of a folder: its file, name (path relative to the folder), test, parameters
    and status (as the sweep table says, else from the file)."""

    path: str
    name: str
    test: str = "?"
    params: dict = field(default_factory=dict)
    status: str = "?"
    content: str = "history"

    def label(self) -> str:
        keys = ("wire", "k", "wire_law", "scale", "seed", "pressure", "wire_density")

        def text(k, v):          # a wire density [m/m³] as the paper says it, in km/m³
            if k == "wire_density" and isinstance(v, (int, float)) and v == v:
                return f"{v / 1e3:.3g} km/m³"
            return f"{v:g}" if isinstance(v, float) else str(v)

        shown = ", ".join(f"{k}={text(k, self.params[k])}" for k in keys if k in self.params)
        return f"{self.name} · {self.test} · {shown or 'no parameters recorded'} · {self.status}"


def run_status(path: str) -> str:
    """"complete"; "being written" or "not closed" (by the time of its last write) for a
    history still open for writing (its writer runs, or was killed); "unreadable".  Read
    without writing anything."""
    import h5py

    from engine.io import FormatError, regular_file

    try:
        regular_file(path)
    except (FormatError, OSError):
        return "unreadable"
    try:
        with h5py.File(path, "r"):
            return "complete"
    except OSError as e:
        if "already open for write" in str(e):
            age = time.time() - os.path.getmtime(path)
            return (f"being written (last write {age:.0f} s ago)" if age < 60
                    else f"not closed (writer stopped {age / 60:.0f} min ago?)")
        return "unreadable"


def _tables(folder: Path) -> dict:
    """{history stem: sweep-table row} of the sweep tables (JSON with ``cases``) in and
    beside ``folder``."""
    rows = {}
    for p in sorted(set(folder.glob("*.json")) | set(folder.glob("*/*.json"))
                    | set(folder.parent.glob("*.json"))):
        try:
            if p.stat().st_size > 64 << 20:
                continue
            data = json.loads(p.read_text())
        except (OSError, ValueError, UnicodeDecodeError):
            continue
        if isinstance(data, dict) and isinstance(data.get("cases"), list):
            for r in data["cases"]:
                if isinstance(r, dict) and isinstance(r.get("id"), str):
                    rows[r["id"]] = r
    return rows


def find_runs(folder, *, limit: int = 2000) -> list[RunEntry]:
    """The runs in ``folder`` and its sub-folders: every nscd-workbench history (``.h5``),
    and the checkpoints that have no history beside them; sorted by name.  Files that are
    not ours are skipped.  :class:`ViewInputError` when there is none."""
    from engine import io

    folder = Path(folder)
    if not folder.is_dir():
        raise ViewInputError(f"{folder}: not a folder")
    rows = _tables(folder)
    found = []
    for p in sorted(folder.rglob("*.h5")):
        if len(found) >= limit:
            break
        try:
            content, _ = io.file_content(p)
        except (OSError, ValueError):
            continue
        if content == "checkpoint" and p.name.endswith(".resume.h5") \
                and p.with_name(p.name[:-len(".resume.h5")] + ".h5").exists():
            continue                              # the checkpoint of a history listed
        e = RunEntry(path=str(p), name=str(p.relative_to(folder)), content=content)
        if content == "history":
            try:
                meta = io.history_meta(p)
            except (OSError, ValueError):
                meta = {}
            e.test = str(meta.get("test", "?"))
            e.params = dict(meta.get("params") or {})
            e.status = run_status(str(p))
        else:
            e.test, e.status = "checkpoint", "checkpoint (one state)"
        row = rows.get(p.stem)
        if row is not None:
            e.test = str(row.get("experiment", e.test))
            e.params = {**e.params, **(row.get("params") or {})}
            e.status = f"{row.get('status', '?')} (sweep); file {e.status}"
        found.append(e)
    if not found:
        raise ViewInputError(f"{folder}: no nscd-workbench run in this folder (no history or "
                             f"checkpoint .h5 file in it or below it)")
    return found


class RunSource:
    """One run file as the viewer reads it.

    Attributes
    ----------
    path : str
    content : "history" or "checkpoint"
    model : engine Model (read once)
    meta : dict (:func:`engine.io.history_meta`; {} for a checkpoint)
    frame_step, frame_time : (f,) frames' steps and times [s] (a checkpoint: its one state)
    records : :class:`engine.io.HistoryData` without frames (None for a checkpoint)
    """

    def __init__(self, path):
        from engine import io

        self.path = os.fspath(path)
        p = Path(self.path)
        if not p.exists():
            raise ViewInputError(f"{self.path}: no such file or folder")
        if p.is_dir():
            raise ViewInputError(f"{self.path}: is a folder (give it to find_runs)")
        try:
            self.content, _ = io.file_content(self.path)
            self.model = io.load_model(self.path)
        except io.FormatError as e:
            raise ViewInputError(str(e)) from None
        self.meta = io.history_meta(self.path) if self.content == "history" else {}
        self._ranges: dict[str, tuple[float, float, int]] = {}
        self._checkpoint_state = None
        self.records = None
        self.frame_step = np.zeros(0, np.int64)
        self.frame_time = np.zeros(0)
        self.refresh()
        if self.n_frames == 0:
            raise ViewInputError(f"{self.path}: the history holds no frame to show (run with "
                                 f"frames > 0; its records: nscd info)")

    @property
    def name(self) -> str:
        return Path(self.path).name

    @property
    def n_frames(self) -> int:
        return int(self.frame_step.shape[0])

    def refresh(self) -> bool:
        """Read the frame index and the records again (a followed run); True when there
        are new frames or records."""
        from engine import io

        if self.content == "checkpoint":
            if self._checkpoint_state is None:
                _, self._checkpoint_state = io.load(self.path)
                st = self._checkpoint_state
                self.frame_step = np.array([st.step], np.int64)
                self.frame_time = np.array([st.time])
                return True
            return False
        try:
            steps, times = io.frame_index(self.path)
            rec = io.read_history(self.path, frames=False)
        except io.FormatError as e:
            if self.records is None:
                raise ViewInputError(str(e)) from None
            return False                       # a read between two flushes: next time
        new = len(steps) != self.n_frames or self.records is None \
            or rec.n_records != self.records.n_records
        self.frame_step, self.frame_time, self.records = steps, times, rec
        return new

    def state(self, k: int, *, contacts: bool = True):
        """The State of frame ``k`` (:func:`engine.io.read_frame`; ``contacts=False``:
        without its contacts, cheaper)."""
        from engine import io

        if self.content == "checkpoint":
            return self._checkpoint_state
        return io.read_frame(self.path, int(k), self.model, contacts=contacts)

    def field_range(self, name: str) -> tuple[float, float]:
        """(min, max) of colour field ``name`` over every frame read so far (read once;
        a followed run's new frames extend it)."""
        from engine import io

        if name in ("kind", "group"):
            return (0.0, 2.0) if name == "kind" else (0.0, float(len(self.model.group_names) - 1))
        lo, hi, seen = self._ranges.get(name, (np.inf, -np.inf, 0))
        if seen < self.n_frames:
            if self.content == "checkpoint":
                chunks = [state_arrays(self.model, self._checkpoint_state)]
            else:
                chunks = io.frame_arrays(self.path, _NEEDS[name], range(seen, self.n_frames))
            for arrays in chunks:
                v = field_values(name, self.model, arrays)
                v = v[np.isfinite(v)]
                if v.size:
                    lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
            self._ranges[name] = (lo, hi, self.n_frames)
        if not np.isfinite(lo):
            return (0.0, 1.0)
        if name in ("speed", "spin", "tension", "normal_force", "tangential_force"):
            lo = min(lo, 0.0) if name in ("tension",) else 0.0   # forces and speeds from 0
        return (lo, hi if hi > lo else lo + 1.0)


def open_input(path):
    """A path given to ``nscd view``: (RunSource, None) for a run file, or (None, [RunEntry])
    for a folder of runs.  :class:`ViewInputError` for anything else."""
    p = Path(path)
    if not p.exists():
        raise ViewInputError(f"{path}: no such file or folder")
    if p.is_dir():
        return None, find_runs(p)
    return RunSource(p), None
