"""VTU files per frame and a PVD collection that ParaView opens as a time series.

:class:`SeriesWriter` is an engine writer (``trigger(step)``, ``write(model, state)``,
``flush()``, ``close()``; see :func:`engine.run`).  Each frame it writes the parts built
by :mod:`workbench.meshes` (the same arrays the PyVista pictures of
:mod:`workbench.render` use):

* ``<name>_<frame>.vtu`` (PVD part 0): one VTK vertex per sphere at its centre, with point
  data ``radius`` [m], ``velocity`` (n, 3) [m/s], ``speed`` [m/s], ``spin`` (n, 3)
  [rad/s], ``kind`` (0 sand, 1 wire bead), ``group`` (index into ``model.group_names``)
  and ``body_id``;
* ``<name>_contacts_<frame>.vtu`` (PVD part 1): one line per contact of the last step,
  from the centre of sphere i to the centre of body j (sphere–sphere) or to the contact
  point (sphere–wall), with cell data ``normal_force`` (k,) [N] (>= 0, compression),
  ``tangential_force`` (k,) [N] (magnitude), ``force`` (k, 3) [N] (on i, global frame),
  ``kind`` (0 sand–sand, 1 sand–wire, 2 wire–wire, 3 sphere–wall), ``i``, ``j``, ``sub``
  and ``wall`` (1 when j is a wall).  A frame without contacts gets a file with no points
  and no cells (but every array): each frame has the same parts, so ParaView's block
  numbers stay put (its PVD reader numbers blocks by the parts present at a time step).
  meshio cannot read such an empty file back; VTK and ParaView can;
* ``<name>_wire_<frame>.vtu`` (PVD part 2), only for scenes with wires: one line per wire
  link between the two bead centres, with cell data ``tension`` (l,) [N] (> 0 in
  tension), ``broken`` (1 = broken for good), ``length`` [m], ``ref_length`` [m] (g_ref
  of Eq. 7), ``strain`` [-] and ``link_id``;
* ``<name>_walls_<frame>.vtu`` (PVD part 3), only for scenes with walls (and ``walls=True``):
  triangles of the plane patches and cylinders, with cell data ``body_id``, ``kind``
  (1 plane, 2 cylinder), ``group`` and ``sub`` (0 side, 1 bottom cap, 2 top cap).

The ``<name>.pvd`` file is rewritten (atomically) after every frame, so it stays valid
if the run is killed.  In ParaView: File > Open ``<name>.pvd``; show part 0 with the
"Point Gaussian" representation scaled by ``radius`` (or a Glyph filter, sphere glyphs
scaled by ``radius``), part 1 as lines coloured by ``normal_force``, part 2 coloured by
``tension``, part 3 with some opacity.  ``tests/workbench/test_paraview.py`` opens the
series with ParaView's own reader (``pvpython``).

Every VTU of a frame also carries **field data** (ParaView: the spreadsheet view's "Field
Data" attribute, or a Python Annotation): ``step`` (int64), ``time`` [s], one array
``group:<name>`` per group holding its id (``group:sand`` = 0, ...: the names of the ids of
the ``group`` arrays; integers, not a VTK string array, so that meshio still reads every
file), and what the caller adds (:meth:`SeriesWriter.write`'s ``fields``).
:func:`export_history` adds, for a test's history, its records at the frame's step (the
extras ``stress``, ``sand_stress``, ``wire_stress`` (9 components, row-major 3x3) [Pa,
tension positive], ``height`` [m], ``radius`` [m], ``volume`` [m^3], ``stage`` …) and for
the triaxial tests ``axial_strain`` [-] (compression positive), ``deviator`` q [Pa],
``mean_stress`` p [Pa] (compression positive) and ``wire_equivalent_stress`` ‖dev σ_w‖
[Pa] (:func:`engine.analysis.loading_curves`; NaN before the loading, and every record
value is NaN in a frame without a record at its step).  Numbers are stored in binary, so
they read back as the exact same floats.

:func:`export_history` (``nscd export``) and :meth:`SeriesWriter.close` also write
``open_in_paraview.py`` beside the PVD (:mod:`workbench.paraview_state`): ParaView opens the
series with the presets' pipeline in one command, ``paraview --script=open_in_paraview.py``.

Each DataSet of the PVD carries ``name="beads"`` (``contacts``, ``wire``, ``walls``):
ParaView (5.11) shows these as the block names.

No VTK or PyVista is needed: files are written by :mod:`meshio` (binary, base64 inline,
uncompressed by default; ``compression="zlib"`` gives smaller, slower files).
"""
from __future__ import annotations

import base64
import os
import re
import warnings
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from . import meshes
from engine.errors import WriteFailed

__all__ = ["SeriesWriter", "sphere_mesh", "contact_mesh", "wire_mesh", "wall_mesh", "read_pvd",
           "PARTS", "export_history", "frame_fields", "history_fields"]

#: The cell arrays of each part whose range over the series the state script's colour
#: limits take (:mod:`workbench.paraview_state`).
SCRIPT_RANGES = {"wire": ("tension",), "contacts": ("normal_force",)}

#: PVD part number of each kind of file.
PARTS = {"beads": 0, "contacts": 1, "wire": 2, "walls": 3}
_NAMES = {v: k for k, v in PARTS.items()}


def sphere_mesh(model, state) -> meshio.Mesh:
    """Spheres as VTK vertices at their centres, with their per-sphere data (see module doc)."""
    return meshes.bead_part(model, state).to_meshio()


def contact_mesh(model, state) -> meshio.Mesh | None:
    """Contacts of the last step as lines (see module doc); ``None`` when there are none.

    A line goes from the centre of sphere i to the centre of sphere j, or to the contact
    point when j is a wall (``model.body_kind[j] != 0``).
    """
    part = meshes.contact_part(model, state)
    return None if part is None else part.to_meshio()


def wire_mesh(model, state) -> meshio.Mesh | None:
    """Wire links as lines between bead centres (see module doc); ``None`` without wires."""
    part = meshes.wire_part(model, state)
    return None if part is None else part.to_meshio()


def wall_mesh(model, state) -> meshio.Mesh | None:
    """Walls as triangles (plane patches, cylinder sides and caps; see
    :func:`workbench.meshes.wall_part`); ``None`` without walls."""
    part = meshes.wall_part(model, state)
    return None if part is None else part.to_meshio()


class SeriesWriter:
    """Engine writer producing a ParaView series (VTU per frame + a PVD collection).

    Parameters
    ----------
    out_dir : path
        Directory of the ``.pvd`` and the ``.vtu`` files (created if missing).
    every : int >= 1
        Write when the step number is a multiple of ``every``.
    name : str
        Stem of the file names: ``<name>.pvd``, ``<name>_000012.vtu``,
        ``<name>_contacts_000012.vtu``, ``<name>_wire_000012.vtu``,
        ``<name>_walls_000012.vtu``.
    walls : bool
        Also write the walls (part 3) in every frame.
    compression : None, "zlib" or "lzma"
        Compression of the VTU data arrays (None: raw binary, the fastest to write; see
        ``bench/bench_render.py``).
    state_script : bool
        Write ``open_in_paraview.py`` beside the PVD on :meth:`flush` / :meth:`close`
        (:mod:`workbench.paraview_state`), with colour limits over the frames written.

    Notes
    -----
    Frames are numbered in the order they are written (0, 1, ...), also across several
    :func:`engine.run` calls with the same writer; call :meth:`write` yourself to record
    the initial state.  The PVD ``timestep`` is ``state.time`` [s] written with ``repr``,
    so it reads back as the exact same float.
    """

    def __init__(self, out_dir, every: int = 100, name: str = "frame", *, walls: bool = True,
                 compression: str | None = None, state_script: bool = True):
        if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
            raise ValueError(f"every must be an integer >= 1, got {every!r}")
        if not isinstance(name, str) or not name or os.sep in name:
            raise ValueError(f"name must be a non-empty file stem, got {name!r}")
        if compression not in (None, "zlib", "lzma"):
            raise ValueError(f"compression must be None, 'zlib' or 'lzma', got {compression!r}")
        self.out_dir = Path(out_dir)
        self._made_dir = not self.out_dir.exists()
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.every = int(every)
        self.name = name
        self.walls = bool(walls)
        self.compression = compression
        self.state_script = bool(state_script)
        self.frames = 0
        self._entries: list[tuple[float, int, str]] = []  # (time [s], part, file)
        #: {(part, array): [min, max]} over the frames written of the arrays the state
        #: script colours by (:data:`SCRIPT_RANGES`: its colour limits)
        self.ranges: dict[tuple[str, str], list[float]] = {}
        self._sizes: dict[str, float] = {}   # typical sizes [m] for the state script
        self._fields: set[str] = set()       # field data names written
        #: the VTU files this writer wrote, in order
        self.written: list[Path] = []

    @property
    def pvd_path(self) -> Path:
        """Path of the PVD collection."""
        return self.out_dir / f"{self.name}.pvd"

    def trigger(self, step: int) -> bool:
        return int(step) % self.every == 0

    def frame_parts(self, model, state) -> dict:
        """The parts of one frame, ``{"beads": Part, "contacts": Part, ...}`` (see
        :mod:`workbench.meshes`).  The set of parts is the same in every frame of a run
        (ParaView's PVD reader numbers its blocks by the parts present at a time step):
        ``contacts`` is an empty part when there are none; ``wire`` exists for scenes
        with links, ``walls`` for scenes with walls (and ``walls=True``)."""
        parts = {"beads": meshes.bead_part(model, state),
                 "contacts": meshes.contact_part(model, state, empty=True)}
        if model.n_links:
            parts["wire"] = meshes.wire_part(model, state)
        if self.walls and model.n_walls:
            parts["walls"] = meshes.wall_part(model, state)
        return parts

    def write_start(self, model, state) -> None:
        """The state a run starts from as the series' first frame (called by
        :func:`engine.run` before its first step), unless the series has frames already."""
        if self.frames == 0:
            self.write(model, state)

    def write(self, model, state, fields: dict | None = None) -> None:
        """Write the frame of ``state`` (one VTU per part) and rewrite the PVD.

        ``fields``: more field data for every part of this frame, ``{name: number or
        array}`` (numbers; one tuple of ``array.size`` components), besides ``step``,
        ``time`` and the group names (:func:`frame_fields`)."""
        if self.frames == 0:
            self._clear_older()
        t = float(state.time)
        fd = {**frame_fields(model, state), **(fields or {})}
        self._fields.update(fd)
        xml = _field_data_xml(fd, self.compression)
        for key, part in self.frame_parts(model, state).items():
            infix = "" if key == "beads" else f"_{key}"
            stem = f"{self.name}{infix}_{self.frames:06d}.vtu"
            _write_vtu(self.out_dir / stem, part, xml, self.compression)
            self.written.append(self.out_dir / stem)
            self._entries.append((t, PARTS[key], stem))
            self._track(key, part)
        if not self._sizes and model.sphere_ids.size:
            r = model.body_radius[model.sphere_ids]
            self._sizes = {"mean_radius": float(r.mean())}
            if model.n_links:
                from .meshes import bead_kind, BEAD_WIRE
                wire = model.sphere_ids[bead_kind(model)[model.sphere_ids] == BEAD_WIRE]
                if wire.size:
                    self._sizes["bead_radius"] = float(model.body_radius[wire].mean())
        self.frames += 1
        self._write_pvd()

    def _clear_older(self) -> None:
        """Before the first frame: remove an older series of the same name in the folder
        (its VTUs by their names, ``<name>[_part]_NNNNNN.vtu``, and its PVD), so that a
        shorter series does not leave the older one's last frames beside it; a warning
        says how many files went."""
        pattern = re.compile(rf"{re.escape(self.name)}(_(contacts|wire|walls))?_\d{{6}}\.vtu")
        old = [p for p in self.out_dir.iterdir() if pattern.fullmatch(p.name)]
        for p in old:
            p.unlink()
        if old or self.pvd_path.exists():
            self.pvd_path.unlink(missing_ok=True)
            warnings.warn(f"{self.out_dir}: replaced the older series {self.name!r} there "
                          f"({len(old)} VTU files and its {self.name}.pvd)", stacklevel=3)

    def _track(self, key, part) -> None:
        for name in SCRIPT_RANGES.get(key, ()):
            v = np.asarray(part.cell_data[name], float)
            v = v[np.isfinite(v)]
            if not v.size:
                continue
            lo, hi = float(v.min()), float(v.max())
            r = self.ranges.setdefault((key, name), [lo, hi])
            r[0], r[1] = min(r[0], lo), max(r[1], hi)

    def flush(self) -> None:
        """Rewrite the PVD collection (it is already rewritten after every frame) and the
        ParaView state script (``state_script``)."""
        if self._entries:
            self._write_pvd()
            if self.state_script:
                self.write_state_script()

    def write_state_script(self, path=None) -> Path:
        """Write ``open_in_paraview.py`` (or ``path``) for this series: see
        :func:`workbench.paraview_state.write_state_script`."""
        from .paraview_state import write_state_script

        return write_state_script(self.pvd_path, path, ranges=self.ranges, sizes=self._sizes,
                                  parts=sorted({_NAMES[p] for _, p, _ in self._entries},
                                               key=PARTS.get), fields=self._fields)

    def close(self) -> None:
        self.flush()

    def remove(self) -> int:
        """Remove what this writer wrote (its VTUs, its PVD, its state script); returns how
        many files went."""
        gone = 0
        for p in [*self.written, self.pvd_path, self.out_dir / "open_in_paraview.py"]:
            try:
                p.unlink()
                gone += 1
            except FileNotFoundError:
                pass
        self.written, self._entries, self.frames = [], [], 0
        if self._made_dir:
            try:
                self.out_dir.rmdir()          # the folder it made, if left empty
            except OSError:
                pass
        return gone

    def _write_pvd(self) -> None:
        rows = "".join(
            f'    <DataSet timestep="{t!r}" group="" part="{part}" name="{_NAMES[part]}" '
            f'file={quoteattr(f)}/>\n'
            for t, part, f in self._entries)
        text = ('<?xml version="1.0"?>\n'
                '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
                '  <Collection>\n' + rows + '  </Collection>\n</VTKFile>\n')
        from engine.files import write_text

        write_text(self.pvd_path, text)

    def __enter__(self) -> "SeriesWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read_pvd(path) -> list[dict]:
    """DataSet entries of a PVD file: dicts with ``timestep`` (float [s]), ``part`` (int)
    and ``file`` (absolute :class:`~pathlib.Path`)."""
    import xml.etree.ElementTree as ET

    path = Path(path)
    root = ET.parse(path).getroot()
    return [{"timestep": float(d.get("timestep")), "part": int(d.get("part", 0)),
             "file": path.parent / d.get("file")} for d in root.iter("DataSet")]


def frame_fields(model, state) -> dict:
    """The field data of every frame: ``step``, ``time`` [s] and ``group:<name>`` = the
    group's id, for each group of the model."""
    out = {"step": np.array([int(state.step)], np.int64), "time": np.array([float(state.time)])}
    out.update({f"group:{g}": np.array([k], np.int64) for k, g in enumerate(model.group_names)})
    return out


_VTU_TYPES = {"f": "Float64", "i": "Int64", "u": "Int64", "b": "Int64"}


def _encode(a: np.ndarray, compression) -> str:
    """A VTK XML ``format="binary"`` payload: base64 header (UInt32, meshio's header type)
    and data, raw or compressed as the file's ``compressor`` says (one block)."""
    raw = a.tobytes()
    if compression is None:
        return (base64.b64encode(np.uint32(len(raw)).tobytes())
                + base64.b64encode(raw)).decode()
    if compression == "zlib":
        import zlib
        comp = zlib.compress(raw)
    else:
        import lzma
        comp = lzma.compress(raw)
    head = np.array([1, len(raw), len(raw), len(comp)], np.uint32)
    return (base64.b64encode(head.tobytes()) + base64.b64encode(comp)).decode()


def _field_data_xml(fields: dict, compression) -> bytes:
    rows = []
    for name, v in fields.items():
        a = np.ravel(np.asarray(v))
        if a.dtype.kind not in _VTU_TYPES:
            raise ValueError(f"fields[{name!r}]: field data are numbers (a number or an array "
                             f"of them), got {v!r}")
        if a.size == 0:
            continue
        vt = _VTU_TYPES[a.dtype.kind]
        a = np.ascontiguousarray(a, "<f8" if vt == "Float64" else "<i8")
        rows.append(f'<DataArray type="{vt}" Name={quoteattr(name)} NumberOfComponents='
                    f'"{a.size}" NumberOfTuples="1" format="binary">'
                    f'{_encode(a, compression)}</DataArray>')
    return ("<FieldData>\n" + "\n".join(rows) + "\n</FieldData>\n").encode()


def _write_vtu(path: Path, part, xml: bytes, compression) -> None:
    """The VTU of a part with the ``<FieldData>`` block first in its ``<UnstructuredGrid>``
    (meshio writes no field data to VTU, and writes to a path only), written beside
    ``path`` and renamed into place (:func:`engine.files.replacing`): a killed run or a
    full disk leaves no half-written frame."""
    from engine.files import replacing

    with replacing(path) as tmp:
        meshio.write(tmp, part.to_meshio(), file_format="vtu", compression=compression)
        data = tmp.read_bytes()
        tag = b"<UnstructuredGrid>"
        i = data.find(tag)
        if i < 0:
            raise RuntimeError(f"{path}: meshio wrote no <UnstructuredGrid> element")
        i += len(tag)
        with open(tmp, "wb") as f:
            f.write(data[:i])
            f.write(b"\n" + xml)
            f.write(data[i:])


def history_fields(history) -> tuple[np.ndarray, dict]:
    """(the step of each record, ``{name: (n_records, ...) array}``): what
    :func:`export_history` writes as field data for the frame recorded at a step (see the
    module doc); no steps and no fields for a checkpoint (it has no records)."""
    from engine import io
    from engine.analysis import loading_curves

    if io.file_content(history)[0] == "checkpoint":
        return np.zeros(0, np.int64), {}
    rec = io.read_history(history, frames=False)     # damaged records: FormatError
    out = {k: np.asarray(v) for k, v in rec.extra.items()
           if np.asarray(v).dtype.kind in "fiub"}
    lc = loading_curves(rec)
    if lc is not None:
        out.update(axial_strain=lc["strain"], deviator=lc["deviator"],
                   mean_stress=lc["mean_stress"])
        if "wire_stress" in rec.extra:
            out["wire_equivalent_stress"] = lc["wire_equivalent"]
    return np.asarray(rec.step, np.int64), out


def export_history(history, outdir, *, name: str = "frame", progress: bool = True,
                   compression: str | None = None) -> Path:
    """Every frame of a history file as VTU + a PVD collection + ``open_in_paraview.py``
    (``nscd export``); returns the PVD path.  Each frame's field data carry the test's
    records at its step (module doc)."""
    from engine import io

    n = io.frame_count(history)
    if n == 0:
        raise ValueError(f"{history}: the history holds no frame (run with frames > 0)")
    steps, fields = history_fields(history)
    model = io.load_model(history)
    w = SeriesWriter(outdir, every=1, name=name, compression=compression)
    it = io.iter_frames(history, model)
    if progress:
        from tqdm.auto import tqdm
        it = tqdm(it, total=n, unit="frame", desc="export")
    try:
        for state in it:
            at = np.flatnonzero(steps == int(state.step))
            extra = {}
            for key, v in fields.items():
                if at.size:
                    extra[key] = v[at[-1]]
                else:
                    extra[key] = np.full(v.shape[1:] or (1,), np.nan)
            w.write(model, state, fields=extra)
        w.close()
    except BaseException as e:    # no series that looks finished: what was written goes
        at, gone = w.frames, w.remove()
        said = f"the export stopped at frame {at} of {n} and removed the {gone} files it had " \
               f"written"
        if isinstance(e, WriteFailed):
            raise WriteFailed(e.filename, e.errno, f"{e.strerror}; {said}") from None
        if isinstance(e, io.FormatError):     # a damaged frame
            raise io.FormatError(f"{e}; {said}") from None
        raise
    return w.pvd_path
