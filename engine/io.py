"""HDF5 files: checkpoints (:func:`save` / :func:`load`) and run histories (:class:`History`).

A **checkpoint** holds the whole :class:`~engine.model.Model` and the whole mutable
:class:`~engine.state.State`, including what the next step reads besides positions and
velocities: the warm-start impulses (``warm_key``, ``warm_impulse``), the wire link
impulses (also a warm start), the Verlet candidate-pair list and its reference positions,
the Kahan compensation of the time sum, the step counter and ``last_dt``.  A run
restarted from a checkpoint therefore continues **bit for bit** like the uninterrupted run.

A **history** (:class:`History`, a writer for :func:`engine.run`) appends per-step scalars
and, every N steps, frames (positions, velocities, spins, link tensions, contacts) to
resizable chunked datasets.  It stores the model once, so :func:`load` / :func:`load_model`
also accept a history file (the state is then rebuilt from a frame, for rendering and
analysis: it is not a restart point).  The file is written in HDF5's single-writer /
multiple-reader mode (SWMR) and flushed every interval: a crash, SIGINT or SIGTERM loses at
most the last interval and the file stays readable, also while the run goes on.

Every dataset has a ``unit`` attribute (SI, ASCII: ``m``, ``m/s``, ``N s``, ``-`` for
dimensionless values, codes, ids and flags).  The root carries ``format`` =
``"nscd-workbench"``, ``format_version`` (:data:`FORMAT_VERSION`) and ``content``
(``"checkpoint"`` or ``"history"``).  A file that is not HDF5, is truncated, belongs to
another program, lacks a required dataset or has a newer format version raises
:class:`FormatError` (a ``ValueError``) naming the file and the problem.

The layout is described in ``docs/io.md``.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
import uuid
from dataclasses import dataclass, field
from typing import Callable

import h5py
import numpy as np

from . import laws as _laws
from . import schedules as _schedules
from .errors import FileProblem, FormatError, RunLocked, WriteFailed  # noqa: F401  (engine.io.FileProblem)
from .files import free_bytes  # noqa: F401  (engine.io.free_bytes)
from .files import errno_of as _errno_of, h5_image, write_bytes, write_cause as _write_cause
from .model import SPHERE, Drive, Model, Options
from .analysis.energy import kinetic_energy  # noqa: F401  (engine.io.kinetic_energy)
from .analysis.network import wall_forces  # noqa: F401  (engine.io.wall_forces)
from .state import ContactBuffers, State, StepStats

#: Name written in the root attribute ``format``.
FORMAT_NAME = "nscd-workbench"
#: Version of the layout written by this module; files with a larger one are refused.
FORMAT_VERSION = 1


class NoRecords(FormatError):
    """A history whose first record is not written yet (a run that has just started, or
    was killed before it): not damage, so a reader may go on without the records."""


class _BadArgument(ValueError):
    """A bad argument of a reading function (not a problem of the file)."""


#: Free space [bytes] a history leaves on its disk beyond its next write's own size (HDF5
#: metadata and chunk allocation); a write that would go below it stops the run cleanly.
SPACE_MARGIN = 1 << 18


class _Headroom:
    """Disk space held for a history's next write, in a file beside it (``.NAME.reserve``).

    HDF5 cannot recover from a write that fails for want of space: the file's metadata
    stay unwritten, and the process may end in a segmentation fault.  So no write is
    attempted without room for it: :meth:`take` checks that the free space plus the space
    held covers the write, then frees what is held just before the write; :meth:`hold`
    takes it back afterwards (``posix_fallocate``).  Another program filling the disk in
    the meantime fills the space outside the reserve; the next :meth:`take` then stops the
    run cleanly."""

    def __init__(self, path: str):
        d, name = os.path.split(os.path.abspath(path))
        self.path = os.path.join(d, f".{name}.reserve")
        self.size = 0
        self.fd = None
        try:
            self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o644)
        except OSError:
            self.fd = None

    def hold(self, nbytes: int) -> None:
        """Hold ``nbytes`` (or as much as is there: a full disk is seen at :meth:`take`)."""
        if self.fd is None or nbytes <= self.size:
            return
        try:
            os.posix_fallocate(self.fd, 0, int(nbytes))
            self.size = int(nbytes)
        except OSError:
            pass

    def take(self, nbytes: int) -> int:
        """Free what is held for a write of ``nbytes``; returns the free space then, or
        raises nothing: the caller compares."""
        free = free_bytes(self.path) + (self.size if self.fd is not None else 0)
        if free >= nbytes and self.fd is not None and self.size:
            os.ftruncate(self.fd, 0)
            self.size = 0
        return free

    def __del__(self):
        self.close()

    def close(self) -> None:
        if getattr(self, "fd", None) is not None:
            os.close(self.fd)
            self.fd = None
            try:
                os.remove(self.path)
            except FileNotFoundError:
                pass


class _Lock:
    """An exclusive lock of a history for one writer (``flock`` on ``.NAME.lock`` beside it).

    The kernel drops the lock when its holder ends, however it ends: a killed run never
    blocks the next one (its lock file stays, unlocked).  The holder's pid, host and start
    time are written in the file, for the message the next writer gets."""

    def __init__(self, path: str):
        import fcntl
        import socket
        import time

        d, name = os.path.split(os.path.abspath(path))
        self.path = os.path.join(d, f".{name}.lock")
        os.makedirs(d, exist_ok=True)     # the run writes there
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                try:
                    who = os.read(fd, 200).decode(errors="replace").strip()
                finally:
                    os.close(fd)
                import errno

                raise RunLocked(errno.EBUSY, f"another run is writing this history "
                                f"({who or 'a process'}); wait for it to end, stop it, or "
                                f"write elsewhere", path) from None
            try:   # a holder that ended and removed the file between our open and flock
                same = os.fstat(fd).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        #: the file held a holder's note: a writer of this history was killed (its file may
        #: be torn; it is the killed run's and may be replaced)
        self.stale = bool(os.read(fd, 200).strip())
        try:
            os.lseek(fd, 0, os.SEEK_SET)
            os.ftruncate(fd, 0)
            os.write(fd, f"pid {os.getpid()} on {socket.gethostname()}, since "
                         f"{time.strftime('%Y-%m-%d %H:%M:%S')}".encode())
        except OSError as e:     # a full disk cannot take the note: the run cannot start
            os.remove(self.path)
            os.close(fd)
            from .files import failed

            raise failed(path, e, "the run cannot start: its lock file could not be "
                         "written") from None
        self.fd = fd

    def __del__(self):
        self.release()

    def release(self) -> None:
        if getattr(self, "fd", None) is not None:
            try:
                os.remove(self.path)      # while locked: the next writer re-checks the inode
            except FileNotFoundError:
                pass
            os.close(self.fd)
            self.fd = None


#: The history locks this process holds: absolute path -> [_Lock, holders].
_HELD: dict = {}


class HistoryLock:
    """This process's hold on the lock of a history (:func:`lock_history`); several holders
    in one process share one lock (a test holds it from its start, before it looks at its
    checkpoint, and its :class:`History` again), released with the last of them."""

    def __init__(self, key: str):
        self.key = key

    @property
    def stale(self) -> bool:
        """The lock was left by a writer that was killed (its history may be torn)."""
        entry = _HELD.get(self.key)
        return bool(entry and entry[0].stale)

    def release(self) -> None:
        key, self.key = self.key, None
        entry = _HELD.get(key) if key is not None else None
        if entry is not None:
            entry[1] -= 1
            if entry[1] == 0:
                del _HELD[key]
                entry[0].release()

    def __del__(self):
        try:
            self.release()
        except Exception:      # interpreter shutdown
            pass


def lock_history(path) -> HistoryLock:
    """Take the writer's lock of the history at ``path`` (``.NAME.lock`` beside it) for
    this process; :class:`RunLocked` (an OSError naming the holder) when another process
    holds it.  A killed holder's lock is free at once (the kernel drops it)."""
    key = os.path.abspath(os.fspath(path))
    entry = _HELD.get(key)
    if entry is None:
        entry = _HELD[key] = [_Lock(key), 0]
    entry[1] += 1
    return HistoryLock(key)


# -- units ---------------------------------------------------------------------------------
#: Unit of every Model array (SI, ASCII).
MODEL_UNITS = {
    "body_kind": "-", "body_group": "-", "body_radius": "m", "body_mass": "kg",
    "body_inertia": "kg m^2", "body_axis": "-", "body_height": "m", "body_caps": "-",
    "body_dof": "-", "body_line": "-",
    "body_dyn": "columns: 1/kg, 1/(kg m^2), m, -, -, -, -, -",
    "sphere_ids": "-", "wall_ids": "-", "pair_law": "-", "law_code": "-",
    "law_param": "per law: Coulomb (mu -); wire (stiffness N, prestrain -, max_tension N, unilateral -)",
    "link_i": "-", "link_j": "-", "link_law": "-", "link_ref_length": "m",
    "link_stiffness": "N", "link_max_tension": "N", "link_unilateral": "-", "link_order": "-",
    "body_next": "-",
}
#: Unit of every State dataset of a checkpoint.
STATE_UNITS = {
    "time": "s", "time_compensation": "s", "last_dt": "s",
    "position": "m", "vel6": "columns: m/s, m/s, m/s, rad/s, rad/s, rad/s", "force": "N",
    "load": "N", "drive_pressure": "Pa", "drive_area": "m^2",
    "pairs": "-", "pairs_ref": "m", "warm_key": "-", "warm_impulse": "N s",
    "link_i": "-", "link_j": "-", "link_impulse": "N s", "link_broken": "-",
    "link_normal": "-", "link_gap": "m", "link_excluded_next": "-",
}
#: Unit of the contact buffer fields (:class:`engine.state.ContactBuffers`).
CONTACT_UNITS = {
    "i": "-", "j": "-", "sub": "-", "key": "-", "frame": "-", "gap": "m", "mu": "-",
    "ri": "m", "rj": "m", "w": "columns: 1/kg, 1/kg, kg, kg", "gterm": "m/s",
    "impulse": "N s",
}
_DRIVE_UNITS = {"velocity": "m/s", "force": "N", "pressure": "Pa"}

#: Per-step scalars of a history: name -> (dtype, unit).
HISTORY_SCALARS = {
    "time": (np.float64, "s"), "step": (np.int64, "-"), "kinetic_energy": (np.float64, "J"),
    "iterations": (np.int32, "-"), "residual": (np.float64, "-"), "converged": (np.int8, "-"),
    "n_contacts": (np.int32, "-"), "n_links": (np.int32, "-"),
    "max_overlap": (np.float64, "-"), "energy_gain": (np.float64, "J"),
    "natural_residual": (np.float64, "-"),
}
#: Records a history written before them lacks (read as NaN).
_LATER_SCALARS = ("max_overlap", "energy_gain", "natural_residual")


#: HDF5 file-format bounds: v1.10 objects carry metadata checksums and allow SWMR; files
#: stay readable by HDF5 >= 1.10.
LIBVER = ("v110", "v114")


def _dataset(group, name: str, data, unit: str, **kw):
    if np.ndim(data) > 0:  # a checksum per chunk: flipped bits give an error, not numbers
        kw.setdefault("fletcher32", True)
    d = group.create_dataset(name, data=data, **kw)
    d.attrs["unit"] = unit
    return d


def _appendable(group, name: str, tail: tuple, dtype, unit: str, rows: int):
    """An empty dataset of shape (0, *tail) that grows along axis 0 in chunks of ``rows``."""
    maxshape = (None,) + tuple(None if t == 0 else t for t in tail)
    chunks = (rows,) + tuple(max(t, 1) for t in tail)
    # no checksum filter: a chunk being rewritten when the writer is killed would then fail
    # its checksum and hide the records flushed before it
    return _dataset(group, name, np.zeros((0,) + tuple(tail), dtype), unit, maxshape=maxshape,
                    chunks=chunks, fletcher32=False)


def _root_attrs(f, content: str) -> None:
    from . import __version__

    f.attrs["format"] = FORMAT_NAME
    f.attrs["format_version"] = FORMAT_VERSION
    f.attrs["content"] = content
    f.attrs["engine_version"] = __version__
    f.attrs["units"] = "SI"


# -- model -------------------------------------------------------------------------------------
def _callable_name(fn) -> str:
    mod = getattr(fn, "__module__", None) or "?"
    return f"{mod}.{getattr(fn, '__qualname__', type(fn).__name__)}"


class UnsavedCallable:
    """Stands for a drive's Python callable that a history file could not store: a user's
    own law of time or area (the experiments' drives are schedules, :mod:`engine.schedules`,
    which files hold whole).

    Rendering and analysis work; stepping raises a ``ValueError`` saying what to supply
    (``load(path, callables={(body, "value" or "area"): fn})``).
    """

    def __init__(self, body: int, kind: str, what: str, name: str):
        self.body, self.kind, self.what, self.name = body, kind, what, name

    def __call__(self, *args, **kwargs):
        raise ValueError(f"the {self.what} of the {self.kind} drive on body {self.body} was the "
                         f"Python callable {self.name}, which a file cannot hold; pass it to "
                         f"engine.io.load(path, callables={{({self.body}, {self.what!r}): fn}})")

    def __repr__(self) -> str:
        return f"UnsavedCallable({self.name})"


def _write_model(g, model: Model, strict: bool) -> None:
    """Write ``model`` into group ``g``; ``strict``: a callable drive raises ValueError."""
    for f in dataclasses.fields(Model):
        v = getattr(model, f.name)
        if isinstance(v, np.ndarray):
            _dataset(g, f.name, v, MODEL_UNITS.get(f.name, "unspecified"))
    g.attrs["group_names"] = json.dumps(list(model.group_names))
    g.attrs["options"] = json.dumps(model.options.model_dump())
    g.attrs["laws"] = json.dumps([{"type": type(l).__name__, "params": l.model_dump()}
                                  for l in model.laws])
    dg = g.create_group("drives")
    dg.attrs["count"] = len(model.drives)
    for k, d in enumerate(model.drives):
        sub = dg.create_group(str(k))
        sub.attrs["body"] = int(d.body)
        sub.attrs["kind"] = d.kind
        for what, v, unit in (("value", d.value, _DRIVE_UNITS[d.kind]), ("area", d.area, "m^2")):
            if v is None:
                continue
            if isinstance(v, _schedules.Schedule):     # data: the file holds it whole
                sub.attrs[f"{what}_schedule"] = json.dumps(_schedules.to_dict(v))
                continue
            if callable(v):
                if strict:
                    raise ValueError(
                        f"{d.kind} drive on body {d.body}: {what} is a Python callable "
                        f"({_callable_name(v)}), which cannot be serialised in a checkpoint; "
                        f"give a constant {what} [{unit}] to save")
                sub.attrs[f"{what}_callable"] = _callable_name(v)
                continue
            _dataset(sub, what, np.asarray(v, dtype=float), unit)
            sub.attrs[f"{what}_scalar"] = bool(np.ndim(v) == 0)


def _read_model(g, callables=None) -> Model:
    callables = dict(callables or {})
    kw = {}
    for f in dataclasses.fields(Model):
        if f.name in ("group_names", "options", "laws", "drives"):
            continue
        if f.name not in g:
            raise KeyError(f"model/{f.name}")
        kw[f.name] = np.ascontiguousarray(g[f.name][()])
    kw["group_names"] = tuple(json.loads(g.attrs["group_names"]))
    kw["options"] = Options(**json.loads(g.attrs["options"]))
    law_list = []
    for entry in json.loads(g.attrs["laws"]):
        cls = getattr(_laws, entry["type"], None)
        if not (isinstance(cls, type) and issubclass(cls, _laws.Law)):
            raise FormatError(f"unknown law type {entry['type']!r} in model/laws")
        law_list.append(cls(**entry["params"]))
    kw["laws"] = tuple(law_list)
    dg = g["drives"]
    drives = []
    for k in range(int(dg.attrs["count"])):
        sub = dg[str(k)]
        body, kind = int(sub.attrs["body"]), str(sub.attrs["kind"])
        vals = {}
        for what in ("value", "area"):
            if what in sub:
                a = sub[what][()]
                vals[what] = float(a) if sub.attrs[f"{what}_scalar"] else np.asarray(a, float)
            elif f"{what}_schedule" in sub.attrs:
                vals[what] = _schedules.from_dict(json.loads(sub.attrs[f"{what}_schedule"]))
            elif f"{what}_callable" in sub.attrs:
                vals[what] = callables.pop((body, what), None) or UnsavedCallable(
                    body, kind, what, str(sub.attrs[f"{what}_callable"]))
            else:
                vals[what] = None
        drives.append(Drive(body=body, kind=kind, value=vals["value"], area=vals["area"]))
    if callables:
        raise _BadArgument(f"callables: no saved drive callable matches the keys {sorted(callables)}")
    kw["drives"] = tuple(drives)
    model = Model(**kw)
    _check_model(model)
    return model


def _check_model(m: Model) -> None:
    nb, nl = m.n_bodies, m.n_links
    for f in dataclasses.fields(Model):
        v = getattr(m, f.name)
        if isinstance(v, np.ndarray) and f.name.startswith("body_") and v.shape[:1] != (nb,):
            raise FormatError(f"model/{f.name} has shape {v.shape}, expected ({nb}, ...)")
        if isinstance(v, np.ndarray) and f.name.startswith("link_") and v.shape[:1] != (nl,):
            raise FormatError(f"model/{f.name} has shape {v.shape}, expected ({nl},)")
    ng = len(m.group_names)
    if m.pair_law.shape != (ng, ng):
        raise FormatError(f"model/pair_law has shape {m.pair_law.shape}, expected ({ng}, {ng})")
    sph = m.sphere_ids
    if sph.size and (np.any(sph < 0) or np.any(sph >= nb)):
        raise FormatError(f"model/sphere_ids point outside the model's {nb} bodies")
    for name, what in (("body_radius", "radius"), ("body_mass", "mass")):
        v = getattr(m, name)[sph]
        bad = sph[~(np.isfinite(v) & (v > 0))]
        if bad.size:
            raise FormatError(f"model/{name} of sphere {int(bad[0])} is "
                              f"{float(getattr(m, name)[bad[0]])!r}: a sphere's {what} is a "
                              f"positive number")
    for name in ("link_i", "link_j"):
        v = getattr(m, name)
        if v.size and (v.min() < 0 or v.max() >= nb):
            raise FormatError(f"model/{name} points outside the model's {nb} bodies")


# -- state -------------------------------------------------------------------------------------
#: State fields written by hand (the rest is generic: arrays, then plain numbers).
_STATE_SPECIAL = ("pairs", "pairs_ref", "n_pairs", "contacts_buf", "stats", "time", "step",
                  "last_dt", "time_compensation", "workspace")


def _write_state(g, state: State) -> None:
    arrays, numbers = [], {}
    for f in dataclasses.fields(State):
        v = getattr(state, f.name)
        if f.name in _STATE_SPECIAL or v is None:     # None: made when first needed
            continue
        if isinstance(v, np.ndarray):
            _dataset(g, f.name, v, STATE_UNITS.get(f.name, "unspecified"))
            arrays.append(f.name)
        elif isinstance(v, (bool, int, float, np.number)):
            numbers[f.name] = v.item() if isinstance(v, np.number) else v
        else:
            raise ValueError(f"state.{f.name}: engine.io does not know how to save a "
                             f"{type(v).__name__}")
    g.attrs["arrays"] = json.dumps(arrays)
    g.attrs["numbers"] = json.dumps(numbers)
    for name in ("time", "time_compensation", "last_dt"):
        _dataset(g, name, np.float64(getattr(state, name)), STATE_UNITS[name])
    g.attrs["step"] = int(state.step)
    # Verlet list: the next step reuses it unless a body moved more than skin/2, and the
    # order of its pairs sets the order of the contacts in the NLGS sweep
    g.attrs["n_pairs"] = int(state.n_pairs)
    g.attrs["pairs_cap"] = int(state.pairs.shape[0])
    _dataset(g, "pairs", state.pairs[:state.n_pairs], STATE_UNITS["pairs"])
    g.attrs["has_pairs_ref"] = state.pairs_ref is not None
    if state.pairs_ref is not None:
        _dataset(g, "pairs_ref", state.pairs_ref, STATE_UNITS["pairs_ref"])
    # contacts of the last step (what state.contacts shows; the next step recomputes them)
    c = state.contacts_buf
    cg = g.create_group("contacts")
    cg.attrs["cap"], cg.attrs["count"], cg.attrs["n_pair"] = int(c.cap), int(c.count), int(c.n_pair)
    for name in ContactBuffers._FIELDS:
        _dataset(cg, name, getattr(c, name)[:c.count], CONTACT_UNITS[name])
    g.attrs["stats"] = json.dumps(dataclasses.asdict(state.stats))


def _read_state(g, model: Model) -> State:
    known = {f.name for f in dataclasses.fields(State)}
    kw = {name: np.ascontiguousarray(g[name][()]) for name in json.loads(g.attrs["arrays"])}
    kw.update(json.loads(g.attrs["numbers"]))
    unknown = sorted(set(kw) - known)
    if unknown:  # dropping them could change the next step: refuse
        raise FormatError(f"state fields {unknown} are unknown to this engine (a file from a "
                          f"newer nscd-workbench?)")
    for name in ("position", "vel6"):
        if name not in kw:
            raise KeyError(f"state/{name}")
    state = State(**kw, time=float(g["time"][()]), step=int(g.attrs["step"]),
                  last_dt=float(g["last_dt"][()]),
                  time_compensation=float(g["time_compensation"][()]))
    n = int(g.attrs["n_pairs"])
    state.pairs = np.zeros((max(int(g.attrs["pairs_cap"]), n), 2), np.int32)
    state.pairs[:n] = g["pairs"][()]
    state.n_pairs = n
    state.pairs_ref = (np.ascontiguousarray(g["pairs_ref"][()])
                       if bool(g.attrs["has_pairs_ref"]) else None)
    cg = g["contacts"]
    k = int(cg.attrs["count"])
    c = ContactBuffers(max(int(cg.attrs["cap"]), k))
    for name in ContactBuffers._FIELDS:
        getattr(c, name)[:k] = cg[name][()]
    c.count, c.n_pair = k, int(cg.attrs["n_pair"])
    state.contacts_buf = c
    state.stats = StepStats(**json.loads(g.attrs["stats"]))
    _check_state(model, state)
    return state


def _check_state(model: Model, s: State) -> None:
    nb, nl = model.n_bodies, model.n_links
    want = {"position": (nb, 3), "vel6": (nb, 6), "force": (nb, 3), "link_impulse": (nl,),
            "link_broken": (nl,), "link_normal": (nl, 3), "link_gap": (nl,),
            "link_excluded_next": (nb,), "link_i": (nl,), "link_j": (nl,)}
    for name, shape in want.items():
        if getattr(s, name).shape != shape:
            raise FormatError(f"state/{name} has shape {getattr(s, name).shape}, expected {shape}")
    if s.warm_impulse.shape != (s.warm_key.shape[0], 3):
        raise FormatError("state/warm_impulse does not match state/warm_key")
    wk = s.warm_key
    if wk.size and (wk[0] < 0 or wk[-1] >= 4 * nb * nb or np.any(np.diff(wk) <= 0)):
        raise FormatError(f"state/warm_key must be strictly increasing contact keys in "
                          f"[0, 4 nb^2) = [0, {4 * nb * nb}) for this model's {nb} bodies")
    if s.pairs_ref is not None and s.pairs_ref.shape != (nb, 3):
        raise FormatError(f"state/pairs_ref has shape {s.pairs_ref.shape}, expected ({nb}, 3)")


# -- opening -----------------------------------------------------------------------------------
def regular_file(path, max_bytes: int | None = None) -> str:
    """``path`` as a string when it names a regular file (of at most ``max_bytes``);
    FileNotFoundError, IsADirectoryError, or :class:`FormatError` on one line otherwise: a
    FIFO, a device or a socket is refused before it is opened (opening a FIFO blocks until
    a writer comes; reading /dev/zero never ends)."""
    import stat as _stat

    path = os.fspath(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise FileNotFoundError(f"no such file: {path!r}") from None
    if _stat.S_ISDIR(st.st_mode):
        raise IsADirectoryError(21, "is a folder, not a file", path)
    if not _stat.S_ISREG(st.st_mode):
        kind = ("a FIFO" if _stat.S_ISFIFO(st.st_mode) else "a socket"
                if _stat.S_ISSOCK(st.st_mode) else "a device" if _stat.S_ISCHR(st.st_mode)
                or _stat.S_ISBLK(st.st_mode) else "not a regular file")
        raise FormatError(f"{path}: {kind}, not a regular file: refused (it would be read "
                          f"forever or block)")
    if max_bytes is not None and st.st_size > max_bytes:
        raise FormatError(f"{path}: {st.st_size} bytes, more than the {max_bytes} a file of "
                          f"this kind may have: refused")
    return path


def _open_read(path) -> h5py.File:
    """Open an existing file for reading (SWMR read if a writer has it open or crashed).

    FileNotFoundError, IsADirectoryError, or :class:`FormatError` saying on one line why
    the file cannot be read: not HDF5 at all, locked by a program writing it, truncated."""
    path = regular_file(path)
    try:
        return h5py.File(path, "r")
    except OSError as e:
        first = e
    if "already open for write" in str(first):
        # a history still being written, or whose writer was killed: SWMR read mode
        # (only then: SWMR skips the end-of-file check, and a truncated file can hang HDF5)
        try:
            return h5py.File(path, "r", swmr=True)
        except OSError:
            pass
    text = str(first)
    if "unable to lock file" in text or "errno = 11" in text:
        raise FormatError(f"{path}: another program holds HDF5's lock on it (it is writing the "
                          f"file); read it when that program has closed it, or with "
                          f"HDF5_USE_FILE_LOCKING=FALSE")
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError as e:
        raise FormatError(f"{path}: cannot be read ({e.strerror})") from None
    if not h5py.is_hdf5(path):
        what = "an empty file" if not head else f"its first bytes are {head!r}"
        raise FormatError(f"{path}: not a readable HDF5 file ({what}, not HDF5's signature)")
    raise FormatError(f"{path}: not a readable HDF5 file (truncated or corrupt: "
                      f"{_write_cause(first)})")


def _check_root(f, path, content: str | None = None) -> str:
    fmt = f.attrs.get("format")
    if isinstance(fmt, bytes):
        fmt = fmt.decode()
    if fmt != FORMAT_NAME:
        raise FormatError(f"{path}: not an {FORMAT_NAME} file (root attribute 'format' is "
                          f"{fmt!r}, expected {FORMAT_NAME!r})")
    try:
        version = int(f.attrs["format_version"])
    except (KeyError, TypeError, ValueError):
        raise FormatError(f"{path}: missing or bad 'format_version' attribute") from None
    if version > FORMAT_VERSION:
        raise FormatError(f"{path}: format version {version} is newer than this engine reads "
                          f"(<= {FORMAT_VERSION}); upgrade nscd-workbench")
    if version < 1:
        raise FormatError(f"{path}: bad format version {version}")
    kind = str(f.attrs.get("content", ""))
    if kind not in ("checkpoint", "history"):
        raise FormatError(f"{path}: unknown content {kind!r} (expected 'checkpoint' or 'history')")
    if content is not None and kind != content:
        raise FormatError(f"{path}: is a {kind} file, expected a {content}")
    return kind


def _reading(path, fn):
    """Run ``fn(file)`` on an open file; HDF5 and layout errors become FormatError."""
    f = _open_read(path)
    try:
        return fn(f)
    except _BadArgument:
        raise
    except _READ_ERRORS as e:
        raise _format_error(path, e) from None
    finally:
        f.close()


#: What reading a damaged or foreign file raises (HDF5, layout, pydantic): a FormatError.
_READ_ERRORS = (FormatError, KeyError, OSError, TypeError, json.JSONDecodeError,
                AttributeError, ValueError, IndexError, RuntimeError)


def _format_error(path, e: Exception) -> FormatError:
    """The one-line FormatError naming ``path`` for an error met while reading it."""
    where = os.fspath(path)
    if isinstance(e, FormatError):
        return e if where in str(e) else type(e)(f"{where}: {e}")   # (NoRecords stays)
    if isinstance(e, ValueError) and not isinstance(e, json.JSONDecodeError):
        return FormatError(f"{where}: corrupt or incomplete file ({e})")  # pydantic, shapes
    return FormatError(f"{where}: corrupt or incomplete file ({type(e).__name__}: {e})")


def iter_frames(path, model: Model | None = None, *, contacts: bool = True):
    """Yield the state of every complete frame of a history, in order, as :func:`read_frame`
    rebuilds it, with the file opened and its model read (when ``model`` is None) once: for
    going through a whole history (``nscd export``).  The frames complete when it starts
    are the ones yielded."""
    f = _open_read(path)
    try:
        try:
            _check_root(f, path, "history")
            m = model if model is not None else _read_model(f["model"])
            n = _frame_count(f["frames"]) if "frames" in f else 0
        except _READ_ERRORS as e:
            raise _format_error(path, e) from None
        for k in range(n):
            try:
                state = _state_from_frame(f, m, k, contacts)
            except _READ_ERRORS as e:
                raise _format_error(path, e) from None
            yield state
    finally:
        f.close()


# -- checkpoint API ----------------------------------------------------------------------------
def _check_replaceable(path: str, content: str) -> None:
    """Refuse to replace a file at ``path`` unless it is an nscd-workbench file of
    ``content`` (FileExistsError, IsADirectoryError: one line naming it)."""
    if not os.path.lexists(path):
        return
    if os.path.isdir(path):
        raise IsADirectoryError(21, "is a folder, not a file", path)
    try:
        kind = _reading(path, lambda f: _check_root(f, path))
    except (FormatError, OSError) as e:
        kind = None
        why = str(e).removeprefix(f"{path}: ")
    else:
        why = f"it is a {kind} file"
    if kind != content:
        raise FileExistsError(17, f"exists and is not an nscd-workbench {content} ({why}); it "
                              f"is not replaced: remove it, or pass overwrite=True (nscd: "
                              f"--force)", path)


def save(path, model: Model, state: State, extra: dict | None = None, *,
         overwrite: bool = False) -> None:
    """Write a checkpoint of ``(model, state)`` to ``path`` (HDF5; replaced atomically).

    Everything the next step reads is stored, so ``load`` then ``run`` continues bit for
    bit like the uninterrupted run.  ``extra``: ``{name: array of numbers, or str}``
    stored beside them (what a driver needs to go on, e.g. an experiment's recorded
    curves), read back by :func:`load_extra`.  A file at ``path`` that is not a
    checkpoint is refused (FileExistsError) unless ``overwrite``.

    Raises
    ------
    ValueError
        ``model``/``state`` of the wrong type or size, or a drive whose value or area is a
        Python callable (it cannot be serialised; the drive is named).
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be an engine Model, got {type(model).__name__}")
    if not isinstance(state, State):
        raise ValueError(f"state must be an engine State, got {type(state).__name__}")
    if state.position.shape != (model.n_bodies, 3):
        raise ValueError(f"state.position has shape {state.position.shape}, but the model has "
                         f"{model.n_bodies} bodies")
    path = os.fspath(path)
    if not overwrite:
        _check_replaceable(path, "checkpoint")

    def build(f):
        _root_attrs(f, "checkpoint")
        _write_model(f.create_group("model"), model, strict=True)
        _write_state(f.create_group("state"), state)
        if extra:
            eg = f.create_group("extra")
            for name, v in extra.items():
                if isinstance(v, str):
                    eg.attrs[name] = v
                    continue
                v = np.asarray(v)
                if v.dtype.kind not in "biuf":
                    raise ValueError(f"extra[{name!r}]: numbers or a str, got {v.dtype}")
                eg.create_dataset(name, data=v)

    # built in memory (HDF5 never meets a full disk), then written and renamed into place:
    # a failed or killed save never spoils an older checkpoint
    write_bytes(path, h5_image(build, libver=LIBVER),
                "the checkpoint could not be written")


def load(path, frame: int = -1, callables: dict | None = None) -> tuple[Model, State]:
    """Read ``(model, state)`` from a checkpoint, or from a history file.

    Parameters
    ----------
    path : str or path
    frame : int
        History files: the frame whose state is rebuilt (default the last; a checkpoint's
        one state is frame -1 or 0, any other value is refused).  That
        state has positions, velocities, spins, time, step, link impulses and contacts
        (for rendering and analysis) but no warm start: it is not a bit-identical restart
        point.
    callables : dict, optional
        History files only: ``{(body, "value" | "area"): fn}`` re-supplying drive callables
        the file could not hold.

    Raises
    ------
    FileNotFoundError
    FormatError (a ValueError)
        Not HDF5, truncated, foreign, newer format version, or a missing/bad dataset.
    """
    def read(f):
        kind = _check_root(f, path)
        model = _read_model(f["model"], callables)
        if kind == "checkpoint":
            if isinstance(frame, (bool, np.bool_)) or frame not in (-1, 0):
                raise _BadArgument(f"{path} is a checkpoint, which holds one state: frame="
                                   f"{frame!r} applies to history files only (use -1 or 0)")
            return model, _read_state(f["state"], model)
        return model, _state_from_frame(f, model, frame)

    return _reading(path, read)


def load_extra(path) -> dict:
    """The ``extra`` arrays of a checkpoint written by :func:`save` ({} if none)."""
    def read(f):
        if _check_root(f, path) != "checkpoint":
            raise _BadArgument(f"{path} is not a checkpoint")
        if "extra" not in f:
            return {}
        eg = f["extra"]
        out = {k: v[()] for k, v in eg.items()}
        out.update({k: (v.decode() if isinstance(v, bytes) else str(v))
                    for k, v in eg.attrs.items()})
        return out

    return _reading(path, read)


def _run_id_of(f) -> str | None:
    rid = f.attrs.get("run_id")
    return rid.decode() if isinstance(rid, bytes) else (None if rid is None else str(rid))


def history_run_id(path) -> str | None:
    """The random id a :class:`History` file was written under (kept when a run resumes it;
    None for a file without one).  Reads a history whose writer is still running or was
    killed (SWMR)."""
    def read(f):
        if _check_root(f, path) != "history":
            raise _BadArgument(f"{path} is not a history")
        return _run_id_of(f)

    return _reading(path, read)


def history_meta(path) -> dict:
    """What a history says of its run (the ``meta`` given to :class:`History`: the test's
    name, its parameters, ``total_steps``); {} for a history written without it.  Reads a
    history whose writer is still running or was killed (SWMR)."""
    def read(f):
        if _check_root(f, path) != "history":
            raise _BadArgument(f"{path} is not a history")
        raw = f.attrs.get("run_meta")
        if raw is None:
            return {}
        out = json.loads(raw.decode() if isinstance(raw, bytes) else str(raw))
        return out if isinstance(out, dict) else {}

    return _reading(path, read)


def file_content(path) -> tuple[str, int]:
    """What an nscd-workbench file holds: (``"checkpoint"`` or ``"history"``, format
    version).  FileNotFoundError or :class:`FormatError` (naming the file) otherwise."""
    return _reading(path, lambda f: (_check_root(f, path), int(f.attrs["format_version"])))


def frame_count(path) -> int:
    """Frames :func:`load` can read from ``path``: a history's complete frames (0 before
    the first), 1 for a checkpoint."""
    def read(f):
        if _check_root(f, path) == "checkpoint":
            return 1
        return _frame_count(f["frames"]) if "frames" in f else 0

    return _reading(path, read)


def load_model(path, callables: dict | None = None) -> Model:
    """The model of a checkpoint or history file (see :func:`load`)."""
    def read(f):
        _check_root(f, path)
        return _read_model(f["model"], callables)

    return _reading(path, read)


class Checkpoint:
    """A writer for :func:`engine.run` saving a checkpoint when ``trigger(step)`` fires.

    ``path`` may contain ``{step}`` (e.g. ``"ckpt_{step:07d}.h5"``); otherwise the file is
    replaced each time (atomically).

    With updaters (schedules, servo walls, a membrane: :mod:`engine.trigger`), give it as
    the **last updater** instead (``run(..., updaters=[..., Checkpoint(path, n)])``; it has
    :meth:`update` too): the writers of a step run before its updaters, so a checkpoint
    saved as a writer holds the state without what they set at that step, and a run
    resumed from it would go on without it.
    """

    def __init__(self, path, trigger: Callable[[int], bool] | int = 1000):
        from .step import every

        self.path = os.fspath(path)
        self.trigger = every(trigger) if isinstance(trigger, (int, np.integer)) else trigger

    def write(self, model, state) -> None:
        save(self.path.format(step=state.step), model, state)

    update = write      # as the last updater: the state with what the updaters set


# -- history -----------------------------------------------------------------------------------
_FRAME_BODY = {"position": ("m", 3), "velocity": ("m/s", 3), "spin": ("rad/s", 3)}
_FRAME_CONTACT = {"i": (np.int32, (), "-"), "j": (np.int32, (), "-"), "sub": (np.int8, (), "-"),
                  "normal": (np.float64, (3,), "-"), "gap": (np.float64, (), "m"),
                  "force": (np.float64, (3,), "N")}
#: The datasets under ``frames/`` a frame's checksums cover, in the columns of
#: ``frames/crc32`` (one CRC-32 of each dataset's rows of the frame).
_FRAME_CRC = ("position", "velocity", "spin", "link_tension", "link_broken", "time", "step",
              "contact_start", "contact_count", *(f"contacts/{c}" for c in _FRAME_CONTACT))


def _crc(v) -> int:
    """CRC-32 of an array's bytes (as stored: the dataset's dtype, C order)."""
    import zlib

    return zlib.crc32(np.ascontiguousarray(v).view(np.uint8).reshape(-1))


def _row_crcs(columns: list) -> np.ndarray:
    """One CRC-32 per row over ``columns`` (arrays of one length, each in its stored
    dtype), chained in their order: a record's checksum."""
    import zlib

    n = len(columns[0]) if columns else 0
    flat = [np.ascontiguousarray(c).reshape(n, -1).view(np.uint8) for c in columns]
    out = np.empty(n, np.uint32)
    for r in range(n):
        crc = 0
        for c in flat:
            crc = zlib.crc32(c[r], crc)
        out[r] = crc
    return out


class History:
    """Writer for :func:`engine.run`: per-step scalars and periodic frames in an HDF5 file.

    Parameters
    ----------
    path : str or path
        File to create (an older history there is replaced; another file is refused, see
        ``overwrite``).  The writer holds the history's lock (:func:`lock_history`) until
        :meth:`close`: a second writer, in another process, gets :class:`RunLocked`.
    trigger : int or callable ``step -> bool``
        When a scalar record is taken (default: every step).
    frames : int >= 0
        A frame every ``frames`` steps (on multiples of it), and one of the state a run
        starts from (:meth:`write_start`); 0 = no frames.
    flush : int >= 1, optional
        Interval [steps] at which buffered records are written and the file flushed
        (default: ``frames`` if > 0, else 100).  A crash loses at most this many steps.
    extra : dict, optional
        ``{name: fn}`` or ``{name: (fn, unit)}``: ``fn(model, state)`` returns a scalar or
        an array of fixed shape (e.g. a stress tensor) recorded with the scalars.
    overwrite : bool
        Replace a file at ``path`` that is not an nscd-workbench history (by default such
        a file is refused, :class:`FileExistsError`; a history is replaced).
    resume_step : int, optional
        Go on writing the existing history at ``path`` from this step (a run restarted
        from a checkpoint of it, :func:`save`): its records and frames after the step are
        cut, and so are the ones at the step off the ``trigger`` / ``frames`` grid (a
        stopped run's record of its end state); the rest is kept.  Its extras must be
        ``extra``'s.

    Records (one per trigger): ``time`` [s], ``step``, ``kinetic_energy`` [J] (spheres),
    ``iterations``, ``residual``, ``converged``, ``n_contacts``, ``n_links`` (links carrying
    a non-zero impulse), ``wall_force`` (nw, 3) [N] (force on each wall, ``wall_ids``
    order), and the extras.  Frames: ``position``, ``velocity``, ``spin`` (nb, 3),
    ``link_tension`` (nl,) [N] (> 0 in tension), ``link_broken`` and the contacts (i, j,
    sub, normal, gap, force [N] on i, global frame).

    Use it as a context manager, or call :meth:`close`::

        with History("run.h5", frames=100) as h:
            run(model, state, 10_000, writers=[h])
        data = read_history("run.h5")
    """

    def __init__(self, path, *, trigger: Callable[[int], bool] | int = 1, frames: int = 100,
                 flush: int | None = None, extra: dict | None = None,
                 resume_step: int | None = None, meta: dict | None = None,
                 overwrite: bool = False):
        from .step import every

        self.path = os.fspath(path)
        self._trigger = every(trigger) if isinstance(trigger, (int, np.integer)) else trigger
        if not callable(self._trigger):
            raise ValueError(f"trigger must be an int >= 1 or a callable step -> bool, got {trigger!r}")
        if not isinstance(frames, (int, np.integer)) or frames < 0:
            raise ValueError(f"frames must be an integer >= 0 (0 = no frames), got {frames!r}")
        self.frames = int(frames)
        flush = (self.frames or 100) if flush is None else flush
        if not isinstance(flush, (int, np.integer)) or flush < 1:
            raise ValueError(f"flush must be an integer >= 1 [steps], got {flush!r}")
        self.flush_every = int(flush)
        self.extra = {}
        for name, spec in (extra or {}).items():
            fn, unit = spec if isinstance(spec, tuple) else (spec, "unspecified")
            if not isinstance(name, str) or not name or "/" in name or name in HISTORY_SCALARS:
                raise ValueError(f"extra: bad record name {name!r} (non-empty, no '/', not a "
                                 f"built-in record)")
            if not callable(fn):
                raise ValueError(f"extra[{name!r}] must be a callable (model, state) -> value")
            self.extra[name] = (fn, str(unit))
        self._ready = False
        self._buf: dict[str, list] = {}
        self._last_flush = None
        self._step_seen = None
        self._recorded_step = self._framed_step = None
        self.n_records = 0
        self.n_frames = 0
        self._mark = (0, 0, None)     # (records, frames, step) of the last complete flush
        self._room = None
        self._hold = 0
        self._row_bytes = 0
        self._start = None            # the start state (write_start), written with the first write
        if meta is not None:
            if not isinstance(meta, dict):
                raise ValueError(f"meta must be a dict (what the run is), got "
                                 f"{type(meta).__name__}")
            try:                  # values JSON cannot hold are stored as their str
                meta = json.dumps(meta, default=str, allow_nan=True)
            except (TypeError, ValueError) as e:
                raise ValueError(f"meta must be a JSON-serialisable dict: {e}") from None
        self._file = None
        self._fresh = False           # the file was created by this History (not resumed)
        self._crc = False             # the file has checksums (not an older one resumed)
        self._lock = lock_history(self.path)   # before the file is touched: one writer
        try:
            if resume_step is not None:
                self._reopen(int(resume_step))
            else:
                if not (overwrite or self._lock.stale):   # a killed run's may be torn
                    _check_replaceable(self.path, "history")
                self._create()
        except BaseException:
            self._lock.release()
            raise
        self._room = _Headroom(self.path)
        if resume_step is not None:
            return
        _root_attrs(self._file, "history")
        if meta is not None:
            self._file.attrs["run_meta"] = meta
        #: a random id of this history (kept when it is resumed): what a checkpoint of the
        #: run checks it goes on with (``engine.experiments.common.RestCheckpoint``)
        self.run_id = uuid.uuid4().hex
        self._file.attrs["run_id"] = self.run_id

    # writer protocol ------------------------------------------------------------------------
    def trigger(self, step: int) -> bool:
        return bool(self._trigger(step)) or (self.frames > 0 and step % self.frames == 0)

    def write(self, model, state) -> None:
        """Record the state after a complete step (called by :func:`engine.run`).

        Raises :class:`WriteFailed` when the disk cannot take the next flush (checked
        before writing: free space below its size plus :data:`SPACE_MARGIN`) or a write
        fails; the history then stops, complete up to its last flush."""
        self._begin(model, state)
        if self._last_flush is None:
            self._last_flush = state.step
        if self._trigger(state.step):
            self._record(model, state)
        if self.frames and state.step % self.frames == 0:
            self._guarded(state, self._frame, model, state)
            self.flush()
        elif state.step - self._last_flush >= self.flush_every:
            self.flush()

    def write_start(self, model, state) -> None:
        """The state a run starts from as the history's first frame (called by
        :func:`engine.run` before its first step), when the history has frames and holds no
        record or frame yet (a fresh file: a series then starts at t = 0; a resumed
        history, or one a test wrote its step 0 in, already has them).  A copy is kept and
        written with the first write (the extras are first evaluated on a stepped state)."""
        if not self.frames or self._file is None or self.n_records or self.n_frames \
                or (self._buf and self._buf["time"]) or self._start is not None:
            return
        import copy

        self._start = copy.deepcopy(state)

    def _begin(self, model, state) -> None:
        """What every write starts with: an open file, set up at the first one, then the
        start frame kept by :meth:`write_start`."""
        if self._file is None:
            raise ValueError(f"History({self.path!r}) is closed")
        if not self._ready:
            self._guarded(state, self._setup, model, state)
        start, self._start = self._start, None
        if start is not None and start.step < state.step:
            self._guarded(start, self._frame, model, start)
        self._step_seen = state.step

    def write_final(self, model, state) -> None:
        """Record the state reached, and write its frame when the history has frames, unless
        this step was recorded (framed) already: a run whose last step falls between two
        triggers keeps its end state.  Then flush."""
        self._begin(model, state)
        if self._recorded_step != state.step:
            self._record(model, state)
        if self.frames and self._framed_step != state.step:
            self._guarded(state, self._frame, model, state)
        self.flush()

    def flush(self) -> None:
        """Append the buffered records, flush the file to disk, then mark what it holds as
        complete (the ``committed`` dataset a reader trusts: a record or frame written after
        the last mark, by a run killed or stopped by a full disk, is left out)."""
        if self._file is None:
            return
        self._guarded(None, self._flush)

    def _flush(self) -> None:
        if self._ready and self._buf["time"]:
            self._need(len(self._buf["time"]) * self._row_bytes)
            g = self._file["records"]
            n0 = self.n_records
            k = len(self._buf["time"])
            cols = []
            for name, rows in self._buf.items():
                d = g[name]
                v = np.asarray(rows, dtype=d.dtype).reshape((k,) + d.shape[1:])
                d.resize(n0 + k, axis=0)
                d[n0:] = v
                cols.append(v)
                rows.clear()
            if self._crc:
                d = g["crc32"]
                d.resize(n0 + k, axis=0)
                d[n0:] = _row_crcs(cols)
            self.n_records = n0 + k
        if self._ready:
            self._last_flush = self._step_seen
        self._file.flush()
        if self._ready and (self.n_records, self.n_frames) != self._mark[:2]:
            d = self._file["committed"]
            r = d.shape[0]
            d.resize(r + 1, axis=0)
            d[r] = (self.n_records, self.n_frames)
            self._file.flush()
            self._mark = (self.n_records, self.n_frames, self._step_seen)
        self._room.hold(self._hold)       # the space of the next write, held

    def _need(self, nbytes: int) -> None:
        """Stop (:class:`WriteFailed`, ENOSPC) before a write of about ``nbytes`` that the
        disk cannot take with :data:`SPACE_MARGIN` to spare (twice the size: HDF5 allocates
        whole chunks); else free the space held for it (:class:`_Headroom`)."""
        import errno

        need = 2 * int(nbytes) + SPACE_MARGIN
        self._hold = max(self._hold, need)
        free = self._room.take(need)
        if free < need:
            raise WriteFailed(self.path, errno.ENOSPC,
                              f"the disk is full: {free / 1e6:.3g} MB free, less than the "
                              f"history's next write needs ({need / 1e6:.3g} MB with its "
                              f"margin)")

    def _guarded(self, state, fn, *args):
        """``fn(*args)``; a failed write (or too little space) closes the file, which keeps
        what its last flush marked complete, and raises :class:`WriteFailed` saying so."""
        try:
            return fn(*args)
        except (OSError, RuntimeError) as e:
            f, self._file = self._file, None
            self._buf = {k: [] for k in self._buf}
            self._room.close()
            try:
                f.close()
            except Exception:    # HDF5 could not write its metadata: nothing more to save
                pass
            n, m, last = self._mark
            if last is not None:
                kept = (f"it keeps {n} records and {m} frames, up to step {last} (its last "
                        f"complete flush)")
            elif self._fresh:        # nothing worth keeping: no file that looks like a run
                kept = "it held no complete record and was removed"
                try:
                    os.remove(self.path)
                except OSError:
                    kept = "it holds no complete record"
            else:
                kept = "it holds no complete record"
            self._lock.release()
            cause = e.strerror if isinstance(e, WriteFailed) else (
                f"a write failed: {_write_cause(e)}")
            step = "" if state is None else f" at step {state.step}"
            raise WriteFailed(self.path, _errno_of(e), f"the history stopped{step}: {cause}; "
                              f"{kept}") from None

    def close(self) -> None:
        """Flush and close the file (idempotent)."""
        if self._file is not None:
            try:
                self.flush()
            finally:
                if self._file is not None:
                    self._file.close()
                    self._file = None
                self._room.close()
                self._lock.release()

    def __enter__(self) -> "History":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # internals ----------------------------------------------------------------------------
    def _create(self) -> None:
        """Create the file, when the disk has room for its start (:data:`SPACE_MARGIN`):
        HDF5 must not meet a full disk (:class:`_Headroom`).  A failure leaves no file."""
        import errno

        free = free_bytes(self.path)
        if free < SPACE_MARGIN:
            raise WriteFailed(self.path, errno.ENOSPC,
                              f"the history cannot start: the disk is full ({free / 1e6:.3g} "
                              f"MB free, less than the {SPACE_MARGIN / 1e6:.3g} MB a history "
                              f"starts with)")
        try:
            self._file = h5py.File(self.path, "w", libver=LIBVER)
        except (OSError, RuntimeError) as e:
            if os.path.exists(self.path):
                os.remove(self.path)
            from .files import failed, is_write_error

            if is_write_error(e):
                raise failed(self.path, e, "the history cannot start") from None
            raise
        self._fresh = True

    def _reopen(self, step: int) -> None:
        """Go on writing an existing history from ``step`` (``resume_step``, a run restarted
        from a checkpoint of that step): the records and frames after it are cut (a killed
        run had written them before it died; the restarted run writes them again), and the
        extras must be the same as the file's.  The file is rewritten (a copy replacing it
        atomically): HDF5 refuses to reopen for writing a file whose SWMR writer was killed.
        The copy is built in memory and written with plain file I/O (:mod:`engine.files`):
        a full disk then stops the resume with :class:`WriteFailed` and the file as it was."""
        if not os.path.exists(self.path):
            raise FileNotFoundError(f"{self.path}: no history to resume")
        import glob
        import io as _io

        from .files import leftovers

        for old in [*glob.glob(glob.escape(self.path) + ".resume[0-9]*"),   # a killed resume's
                    *leftovers(self.path)]:
            os.remove(old)
        buf = _io.BytesIO()
        src = _open_read(self.path)
        try:
            _check_root(src, self.path, "history")
            if "records" not in src:
                raise FormatError(f"{self.path}: the history holds no record to resume from")
            names = json.loads(src["records"].attrs["extra"])
            if names != list(self.extra):
                raise ValueError(f"{self.path}: its extras {names} are not this history's "
                                 f"{list(self.extra)}")
            with h5py.File(buf, "w", libver=LIBVER) as dst:
                for k, v in src.attrs.items():
                    dst.attrs[k] = v
                self.run_id = _run_id_of(src)
                for k in src:
                    src.copy(src[k], dst, name=k)
                g, fg = dst["records"], dst["frames"]
                cols = [c for c in [*HISTORY_SCALARS, "wall_force", *names]
                        if c in g or c not in _LATER_SCALARS]
                # keep up to the last record the trigger takes at or before the step (the
                # record and frame a stopped run wrote of its end state off that grid go)
                n = _record_count(g, cols)
                steps = g["step"][:n]
                keep = np.flatnonzero((steps <= step)
                                      & np.array([bool(self._trigger(int(k))) for k in steps],
                                                 bool))
                n = int(keep[-1]) + 1 if keep.size else 0
                m = _frame_count(fg)
                fsteps = fg["step"][:m]
                keep = np.flatnonzero((fsteps <= step) & (self.frames > 0)
                                      & (fsteps % max(self.frames, 1) == 0))
                m = int(keep[-1]) + 1 if keep.size else 0
                nc = int(fg["contact_start"][m - 1] + fg["contact_count"][m - 1]) if m else 0
                self._crc = "crc32" in g and "crc32" in fg   # (an older file has none)
                for c in cols + (["crc32"] if self._crc else []):
                    g[c].resize(n, axis=0)
                for c in ["step", "time", "contact_start", "contact_count", *_FRAME_BODY,
                          "link_tension", "link_broken"] + (["crc32"] if self._crc else []):
                    fg[c].resize(m, axis=0)
                for c in _FRAME_CONTACT:
                    fg["contacts"][c].resize(nc, axis=0)
                self._extra_shape = {c: g[c].shape[1:] for c in names}
                last = (int(g["step"][n - 1]) if n else None,
                        int(fg["step"][m - 1]) if m else None)
                if "committed" not in dst:
                    _appendable(dst, "committed", (2,), np.int64, "-", 64)
                dst["committed"].resize(1, axis=0)
                dst["committed"][0] = (n, m)
                self._row_bytes = (sum(g[c].dtype.itemsize * int(np.prod(g[c].shape[1:]))
                                       for c in cols))
            src.close()
            write_bytes(self.path, buf.getvalue(), "the history could not be rewritten to "
                        "resume it")
        finally:
            src.close()
        self._file = h5py.File(self.path, "a", libver=LIBVER)
        try:
            self._file.swmr_mode = True
        except BaseException:
            self._file.close()
            raise
        self._buf = {c: [] for c in cols}
        self.n_records, self.n_frames = n, m
        self._recorded_step, self._framed_step = last
        self._mark = (n, m, last[0])
        self._ready = True

    def _setup(self, model, state) -> None:
        f = self._file
        first = {}  # evaluate the extras before writing anything: a failing one leaves no trace
        for name, (fn, unit) in self.extra.items():
            v = np.asarray(fn(model, state))
            if v.dtype.kind not in "biuf":
                raise ValueError(f"extra[{name!r}] must return numbers, got {v.dtype}")
            first[name] = v
        self._extra_shape = {name: v.shape for name, v in first.items()}
        self._need(sum(v.nbytes for v in vars(model).values() if isinstance(v, np.ndarray)))
        _write_model(f.create_group("model"), model, strict=False)
        g = f.create_group("records")
        rows = max(1, min(1024, self.flush_every))
        for name, (dtype, unit) in HISTORY_SCALARS.items():
            _appendable(g, name, (), dtype, unit, rows)
        nw, nb, nl = model.n_walls, model.n_bodies, model.n_links
        _appendable(g, "wall_force", (nw, 3), np.float64, "N", rows)
        _dataset(g, "wall_ids", model.wall_ids, "-")
        self._buf = {name: [] for name in HISTORY_SCALARS}
        self._buf["wall_force"] = []
        for name, (fn, unit) in self.extra.items():
            _appendable(g, name, first[name].shape, first[name].dtype, unit, rows)
            self._buf[name] = []
        self._row_bytes = (sum(np.dtype(t).itemsize for t, _ in HISTORY_SCALARS.values())
                           + 24 * nw + sum(v.nbytes for v in first.values()))
        g.attrs["extra"] = json.dumps(list(self.extra))
        # a CRC-32 per record over its columns, and per frame over each dataset's rows:
        # damage (zeroed or flipped bytes) is found on reading, naming the row and dataset
        cols = [*HISTORY_SCALARS, "wall_force", *self.extra]
        _appendable(g, "crc32", (), np.uint32, "-", rows).attrs["columns"] = json.dumps(cols)
        # (records, frames) after each complete flush; readers trust no more than the last
        _appendable(f, "committed", (2,), np.int64, "-", 64)
        fg = f.create_group("frames")
        fg.attrs["every"] = self.frames
        _appendable(fg, "step", (), np.int64, "-", 64)
        _appendable(fg, "time", (), np.float64, "s", 64)
        for name, (unit, w) in _FRAME_BODY.items():
            _appendable(fg, name, (nb, w), np.float64, unit, 1)
        _appendable(fg, "link_tension", (nl,), np.float64, "N", 1)
        _appendable(fg, "link_broken", (nl,), bool, "-", 1)
        _appendable(fg, "contact_start", (), np.int64, "-", 64)
        _appendable(fg, "contact_count", (), np.int64, "-", 64)
        cg = fg.create_group("contacts")
        for name, (dtype, tail, unit) in _FRAME_CONTACT.items():
            _appendable(cg, name, tail, dtype, unit, 4096)
        _appendable(fg, "crc32", (len(_FRAME_CRC),), np.uint32, "-", 64).attrs["datasets"] = \
            json.dumps(_FRAME_CRC)
        self._crc = True
        f.swmr_mode = True  # readers may follow the run; a crash leaves a readable file
        self._ready = True

    def _record(self, model, state) -> None:
        self._recorded_step = state.step
        st = state.stats
        row = {"time": state.time, "step": state.step,
               "kinetic_energy": kinetic_energy(model, state), "iterations": st.iterations,
               "residual": st.residual, "converged": st.converged, "n_contacts": st.n_contacts,
               "n_links": int(np.count_nonzero(state.link_impulse)),
               "max_overlap": getattr(st, "max_overlap", 0.0),
               "energy_gain": getattr(st, "energy_gain", 0.0),
               "natural_residual": (math.nan if getattr(st, "natural_residual", None) is None
                                    else st.natural_residual),
               "wall_force": wall_forces(model, state)}
        for name, (fn, _) in self.extra.items():
            v = np.asarray(fn(model, state))
            want = self._extra_shape[name]
            if v.shape != want:
                raise ValueError(f"extra[{name!r}] returned shape {v.shape}, expected {want} "
                                 f"(as at the first record)")
            row[name] = v
        for name, v in row.items():  # all or nothing: the columns stay the same length
            if name in self._buf:       # (a resumed older history lacks the later columns)
                self._buf[name].append(v)

    def _frame(self, model, state) -> None:
        c = state.contacts
        k = len(c)
        self._need(72 * model.n_bodies + 9 * model.n_links + 65 * max(k, 4096))
        self._framed_step = state.step
        fg = self._file["frames"]
        force = c.force if k and state.last_dt else np.zeros((k, 3))
        cg = fg["contacts"]
        n0 = cg["i"].shape[0]
        crc = {}
        for name, v in (("i", c.i), ("j", c.j), ("sub", c.sub), ("normal", c.normal),
                        ("gap", c.gap), ("force", force)):
            d = cg[name]
            v = np.asarray(v, dtype=d.dtype).reshape((k,) + d.shape[1:])
            d.resize(n0 + k, axis=0)
            d[n0:] = v
            crc[f"contacts/{name}"] = _crc(v)
        m = self.n_frames
        links = state.links
        for name, v in (("position", state.position), ("velocity", state.velocity),
                        ("spin", state.spin), ("link_tension", links.tension),
                        ("link_broken", links.broken), ("time", state.time),
                        ("step", state.step), ("contact_count", k), ("contact_start", n0)):
            d = fg[name]
            v = np.asarray(v, dtype=d.dtype).reshape(d.shape[1:])
            d.resize(m + 1, axis=0)
            d[m] = v
            crc[name] = _crc(v)
        if self._crc:
            d = fg["crc32"]
            d.resize(m + 1, axis=0)
            d[m] = [crc[name] for name in _FRAME_CRC]
        self.n_frames = m + 1


@dataclass
class HistoryData:
    """Arrays of a history file (:func:`read_history`); n records, f frames, nw walls.

    Records: ``time`` (n,) [s], ``step`` (n,), ``kinetic_energy`` (n,) [J], ``iterations``,
    ``residual``, ``converged`` (bool), ``n_contacts``, ``n_links``, ``max_overlap`` (n,)
    (largest contact overlap / smaller radius; NaN in a file written before it),
    ``energy_gain`` (n,) [J] (the work of the step's reactions on the free spheres,
    :func:`engine.sanity.reaction_gain`; NaN in a file written before it),
    ``natural_residual`` (n,) (Siconos's stopping measure, :mod:`engine.solver.residual`;
    NaN unless ``Options.natural_residual`` was on), ``wall_force``
    (n, nw, 3) [N] for the walls ``wall_ids``, ``extra`` {name: (n, ...)}.
    Frames: ``frame_step``, ``frame_time`` (f,) [s], ``position``, ``velocity``, ``spin``
    (f, nb, 3) [m, m/s, rad/s], ``link_tension`` (f, nl) [N], ``link_broken`` (f, nl);
    contacts of frame k: :meth:`contacts`.
    ``units``: the ``unit`` attribute of every array read.
    """

    time: np.ndarray
    step: np.ndarray
    kinetic_energy: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    converged: np.ndarray
    n_contacts: np.ndarray
    n_links: np.ndarray
    max_overlap: np.ndarray
    energy_gain: np.ndarray
    natural_residual: np.ndarray
    wall_force: np.ndarray
    wall_ids: np.ndarray
    extra: dict = field(default_factory=dict)
    frame_step: np.ndarray = None
    frame_time: np.ndarray = None
    position: np.ndarray = None
    velocity: np.ndarray = None
    spin: np.ndarray = None
    link_tension: np.ndarray = None
    link_broken: np.ndarray = None
    contact_start: np.ndarray = None
    contact_count: np.ndarray = None
    contact_arrays: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)

    @property
    def n_records(self) -> int:
        return int(self.time.shape[0])

    @property
    def n_frames(self) -> int:
        return 0 if self.frame_step is None else int(self.frame_step.shape[0])

    def contacts(self, k: int) -> dict:
        """Contacts of frame ``k``: ``{"i", "j", "sub", "normal", "gap", "force"}`` arrays."""
        k = range(self.n_frames)[k]
        a = int(self.contact_start[k])
        b = a + int(self.contact_count[k])
        return {name: v[a:b] for name, v in self.contact_arrays.items()}


def _committed(f) -> tuple[int, int] | None:
    """(records, frames) the history's last complete flush marked (``committed``); None for
    a file written before the mark existed (then every row of full length is trusted)."""
    d = f.get("committed")
    if d is None:
        return None
    rows = d[()]
    if rows.shape[0] == 0:
        return 0, 0
    # a mark whose own write was lost reads as zeros (HDF5's fill value): the marks only grow
    return int(rows[:, 0].max()), int(rows[:, 1].max())


def _record_count(g, names) -> int:
    """Records fully written: every column has the row, and a flush marked it complete."""
    n = min(g[name].shape[0] for name in names)
    mark = _committed(g.file)
    return n if mark is None else min(n, mark[0])


def _frame_count(fg) -> int:
    """Frames fully written: every frame dataset has the row, its contacts exist, and a flush
    marked it complete (``committed``: a frame whose data a full disk lost reads as zeros)."""
    names = ["step", "time", "contact_start", "contact_count", *_FRAME_BODY, "link_tension",
             "link_broken"]
    n = min(fg[name].shape[0] for name in names)
    mark = _committed(fg.file)
    if mark is not None:
        n = min(n, mark[1])
    nc = min(fg["contacts"][name].shape[0] for name in _FRAME_CONTACT)
    start, count = fg["contact_start"][:n], fg["contact_count"][:n]
    while n and start[n - 1] + count[n - 1] > nc:
        n -= 1
    return n


def read_history(path, frames: bool = True) -> HistoryData:
    """Read a history file written by :class:`History` (also while it is being written or
    after its writer was killed: the incomplete tail is dropped).

    ``frames=False`` skips the frame arrays (positions, contacts...), which can be large.

    Raises FileNotFoundError, or :class:`FormatError` for a file that is not a history.
    """
    def read(f):
        _check_root(f, path, "history")
        if "records" not in f:  # created, but killed before the first record
            raise NoRecords("the history holds no record yet")
        g = f["records"]
        extra = json.loads(g.attrs["extra"])
        scalars = [c for c in HISTORY_SCALARS if c in g or c not in _LATER_SCALARS]
        names = [*scalars, "wall_force", *extra]
        n = _record_count(g, names)
        units = {name: str(g[name].attrs["unit"]) for name in names}
        rec = {name: g[name][:n] for name in names}
        _verify_records(g, rec, n)
        _check_monotone("records", rec["step"], rec["time"])
        for c in _LATER_SCALARS:
            if c not in rec:
                rec[c], units[c] = np.full(n, np.nan), HISTORY_SCALARS[c][1]
        data = HistoryData(**{name: rec[name] for name in HISTORY_SCALARS},
                           wall_force=rec["wall_force"], wall_ids=g["wall_ids"][()],
                           extra={name: rec[name] for name in extra}, units=units)
        data.converged = data.converged.astype(bool)
        if frames:
            fg = f["frames"]
            m = _frame_count(fg)
            data.frame_step, data.frame_time = fg["step"][:m], fg["time"][:m]
            data.position, data.velocity = fg["position"][:m], fg["velocity"][:m]
            data.spin = fg["spin"][:m]
            data.link_tension, data.link_broken = fg["link_tension"][:m], fg["link_broken"][:m]
            data.contact_start, data.contact_count = fg["contact_start"][:m], fg["contact_count"][:m]
            nc = int(data.contact_start[-1] + data.contact_count[-1]) if m else 0
            data.contact_arrays = {name: fg["contacts"][name][:nc] for name in _FRAME_CONTACT}
            _check_monotone("frames", data.frame_step, data.frame_time)
            for k in range(m):
                a, b = int(data.contact_start[k]), int(data.contact_count[k])
                _verify_frame(fg, k, {
                    "position": data.position[k], "velocity": data.velocity[k],
                    "spin": data.spin[k], "link_tension": data.link_tension[k],
                    "link_broken": data.link_broken[k], "time": data.frame_time[k],
                    "step": data.frame_step[k], "contact_start": data.contact_start[k],
                    "contact_count": data.contact_count[k],
                    **{f"contacts/{c}": v[a:a + b] for c, v in data.contact_arrays.items()}})
            for name in ("position", "velocity", "spin", "link_tension"):
                units[name] = str(fg[name].attrs["unit"])
            units["frame_time"] = "s"
            units.update({f"contact_{name}": u for name, (_, _, u) in _FRAME_CONTACT.items()})
        return data

    return _reading(path, read)


def read_frame(path, frame: int = -1, model: Model | None = None, *,
               contacts: bool = True) -> State:
    """The state of one frame of a history, as :func:`load` rebuilds it, for a ``model``
    read before (:func:`load_model`; read from the file when None): a viewer going through
    the frames reads the model once.  ``contacts=False`` leaves the frame's contacts out
    (the state has none; a paper-scale frame's 90 000 contacts are most of its reading
    time).  Reads a history being written (SWMR)."""
    def read(f):
        _check_root(f, path, "history")
        return _state_from_frame(f, model if model is not None else _read_model(f["model"]),
                                 frame, contacts)

    return _reading(path, read)


def frame_index(path) -> tuple[np.ndarray, np.ndarray]:
    """(steps, times [s]) of the frames fully written in a history (also while it is being
    written: a frame half written is not counted)."""
    def read(f):
        _check_root(f, path, "history")
        if "frames" not in f:
            return np.zeros(0, np.int64), np.zeros(0)
        fg = f["frames"]
        m = _frame_count(fg)
        return fg["step"][:m], fg["time"][:m]

    return _reading(path, read)


def frame_arrays(path, names, frames=None):
    """Yield, frame by frame, ``{name: array}`` of the frame datasets ``names``:
    ``position``, ``velocity``, ``spin`` (nb, 3), ``link_tension``, ``link_broken`` (nl,),
    and the contacts' ``contact_i``, ``contact_j``, ``contact_normal``, ``contact_force``
    (k, ...) of that frame.  ``frames``: the frame indices (default all fully written).
    The file is open while the generator runs; one frame at a time is in memory (for
    ranges over a whole history)."""
    names = list(names)
    bad = [n for n in names if n not in (*_FRAME_BODY, "link_tension", "link_broken")
           and not (n.startswith("contact_") and n[8:] in _FRAME_CONTACT)]
    if bad:
        raise _BadArgument(f"frame_arrays: unknown array(s) {bad}")
    f = _open_read(path)
    try:
        try:
            _check_root(f, path, "history")
            if "frames" not in f:
                return
            fg = f["frames"]
            m = _frame_count(fg)
            start, count = fg["contact_start"][:m], fg["contact_count"][:m]
            nb = fg["position"].shape[1]
        except _READ_ERRORS as e:
            raise _format_error(path, e) from None
        ks = list(range(m)) if frames is None else [_frame_of(k, m, False) for k in frames]
        for k in ks:
            try:
                out = {}
                for n in names:
                    if n.startswith("contact_"):
                        a = int(start[k])
                        out[n] = fg["contacts"][n[8:]][a:a + int(count[k])]
                    else:
                        out[n] = fg[n][k]
                rows = {f"contacts/{n[8:]}" if n.startswith("contact_") else n: v
                        for n, v in out.items()}
                _verify_frame(fg, k, rows)
                _check_rows(k, nb, rows)
            except _READ_ERRORS as e:
                raise _format_error(path, e) from None
            yield out
    finally:
        f.close()


def _frame_of(frame, m: int, negative: bool = True) -> int:
    """The index in [0, m) of frame ``frame`` of a history of ``m`` frames (counted from
    the end when negative, if ``negative``); anything but an integer in range (a bool, a
    float, a string) refused by name (True was read as frame 1)."""
    lo = -m if negative else 0
    if (isinstance(frame, (bool, np.bool_)) or not isinstance(frame, (int, np.integer))
            or not lo <= frame < m):
        raise _BadArgument(f"frame = {frame!r}: must be an integer in [{lo}, {m - 1}] (the "
                           f"history holds {m} frames)")
    return int(frame) % m


def _check_frame(k: int, model: Model, body: dict, links: dict) -> None:
    """Frame ``k``'s body and link rows have the model's shapes and finite values (a
    damaged or foreign frame: FormatError naming the frame and the dataset)."""
    nb, nl = model.n_bodies, model.n_links
    for rows, shape, what in ((body, (nb, 3), f"{nb} bodies"), (links, (nl,), f"{nl} links")):
        for name, v in rows.items():
            if v.shape != shape:
                raise FormatError(f"frame {k}: frames/{name} has shape {v.shape}, the model "
                                  f"has {what}")
    _check_rows(k, nb, {**body, **links})


def _check_rows(k: int, nb: int, rows: dict) -> None:
    """Rows of frame ``k``, ``{dataset under frames/: array}``: finite numbers, and contact
    indices (``contacts/i``, ``contacts/j``) pointing at one of the ``nb`` bodies."""
    for where, v in rows.items():
        if where in ("contacts/i", "contacts/j"):
            if v.size and (v.min() < 0 or v.max() >= nb):
                raise FormatError(f"frame {k}: frames/{where} points outside the model's "
                                  f"{nb} bodies")
        elif v.dtype.kind == "f" and not np.all(np.isfinite(v)):
            raise FormatError(f"frame {k}: frames/{where} holds non-finite values (NaN or "
                              f"inf: a damaged frame, or a run that failed)")


def _verify_frame(fg, k: int, got: dict) -> None:
    """Frame ``k``'s rows ``{dataset under frames/: array as read}`` against the frame's
    checksums (``frames/crc32``; a file written before them has none): FormatError naming
    the frame and the first dataset whose bytes changed."""
    d = fg.get("crc32")
    if d is None or k >= d.shape[0]:
        return
    stored = d[k]
    names = json.loads(d.attrs["datasets"])
    for col, name in enumerate(names):
        if name in got and _crc(np.asarray(got[name], fg[name].dtype)) != int(stored[col]):
            raise FormatError(f"frame {k}: frames/{name} fails its checksum (the file is "
                              f"damaged; the other frames can still be read one by one)")


def _check_monotone(where: str, step, time) -> None:
    """Steps that grow and times that do not go back (a damaged or foreign history:
    FormatError naming the first row that breaks the order)."""
    bad = np.flatnonzero((np.diff(step) <= 0) | ~(np.diff(time) >= 0))
    if bad.size:
        r = int(bad[0]) + 1
        raise FormatError(f"{where}: row {r} (step {int(step[r])}, t = {float(time[r]):g} s) "
                          f"does not follow row {r - 1} (step {int(step[r - 1])}, t = "
                          f"{float(time[r - 1]):g} s): steps must grow and times not go back")


def _verify_records(g, rec: dict, n: int) -> None:
    """The ``n`` records read, ``{column: array}``, against their checksums
    (``records/crc32``): FormatError naming the first damaged record and its step."""
    d = g.get("crc32")
    if d is None or n == 0:
        return
    cols = json.loads(d.attrs["columns"])
    if any(c not in rec for c in cols):
        return
    stored = d[:n]
    bad = np.flatnonzero(_row_crcs([np.asarray(rec[c][:len(stored)], g[c].dtype)
                                    for c in cols]) != stored)
    if bad.size:
        r = int(bad[0])
        raise FormatError(f"records: record {r} of {n} fails its checksum (the file is "
                          f"damaged, {bad.size} records in all; its frames can still be read "
                          f"one by one)")


def _state_from_frame(f, model: Model, frame: int, contacts: bool = True) -> State:
    """A State rebuilt from a history frame (no warm start: not a restart point);
    ``contacts=False``: without the frame's contacts (none are read)."""
    from .contact.narrowphase import tangent_frames

    if "frames" not in f:
        raise FormatError("the history holds no frame")
    fg = f["frames"]
    m = _frame_count(fg)
    if m == 0:
        raise FormatError("the history holds no frame")
    k = _frame_of(frame, m)
    nb = model.n_bodies
    body = {name: fg[name][k] for name in _FRAME_BODY}
    links = {name: fg[name][k] for name in ("link_tension", "link_broken")}
    head = {name: fg[name][k] for name in ("time", "step", "contact_start", "contact_count")}
    _verify_frame(fg, k, {**body, **links, **head})
    _check_frame(k, model, body, links)
    vel6 = np.zeros((nb, 6))
    vel6[:, :3], vel6[:, 3:] = body["velocity"], body["spin"]
    h = model.options.dt
    # the link frame of the analysis (engine.analysis.weber_stress): unit vector from j to
    # i and centre distance, here at the frame's positions (frames do not store the
    # step's predicted configuration)
    pos_k = body["position"]
    d = pos_k[model.link_i] - pos_k[model.link_j]
    gap = np.linalg.norm(d, axis=1)
    normal = d / np.where(gap > 0, gap, 1.0)[:, None]
    state = State(position=np.ascontiguousarray(pos_k), vel6=vel6,
                  time=float(head["time"]), step=int(head["step"]), last_dt=h,
                  link_i=model.link_i.copy(), link_j=model.link_j.copy(),
                  link_impulse=links["link_tension"] * h, link_broken=links["link_broken"],
                  link_normal=normal, link_gap=gap)
    state.link_excluded_next = model.body_next.copy()
    state.link_excluded_next[model.link_i[state.link_broken]] = -1
    a, n = int(head["contact_start"]), int(head["contact_count"])
    if not contacts:
        n = 0
    cg = fg["contacts"]
    get = {name: cg[name][a:a + n] for name in _FRAME_CONTACT}
    if contacts:
        _verify_frame(fg, k, {f"contacts/{name}": v for name, v in get.items()})
    _check_rows(k, nb, {f"contacts/{name}": v for name, v in get.items()})
    c = ContactBuffers(max(64, n))
    c.i[:n], c.j[:n], c.sub[:n], c.gap[:n] = get["i"], get["j"], get["sub"], get["gap"]
    c.frame[:n] = tangent_frames(get["normal"])
    c.ri[:n] = model.body_radius[c.i[:n]]
    sph = model.body_kind[c.j[:n]] == SPHERE
    c.rj[:n] = np.where(sph, model.body_radius[c.j[:n]], 0.0)
    fr = c.frame[:n]
    p = get["force"] * h
    c.impulse[:n] = np.stack([(p * fr[:, 0:3]).sum(1), (p * fr[:, 3:6]).sum(1),
                              (p * fr[:, 6:9]).sum(1)], axis=1) if n else np.zeros((0, 3))
    c.count, c.n_pair = n, int(sph.sum())
    state.contacts_buf = c
    return state


__all__ = ["save", "load", "load_model", "file_content", "History", "HistoryData", "WriteFailed",
           "RunLocked", "lock_history", "HistoryLock",
           "free_bytes",
           "read_history", "history_run_id", "history_meta", "read_frame", "iter_frames",
           "frame_index",
           "frame_arrays", "Checkpoint", "FormatError", "NoRecords", "UnsavedCallable",
           "kinetic_energy", "wall_forces", "FORMAT_VERSION", "FORMAT_NAME"]
