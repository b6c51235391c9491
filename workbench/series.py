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

Each DataSet of the PVD carries ``name="beads"`` (``contacts``, ``wire``, ``walls``):
ParaView (5.11) shows these as the block names.

No VTK or PyVista is needed: files are written by :mod:`meshio` (binary, base64 inline,
uncompressed by default; ``compression="zlib"`` gives smaller, slower files).
"""
from __future__ import annotations

import os
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from . import meshes

__all__ = ["SeriesWriter", "sphere_mesh", "contact_mesh", "wire_mesh", "wall_mesh", "read_pvd",
           "PARTS"]

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

    Notes
    -----
    Frames are numbered in the order they are written (0, 1, ...), also across several
    :func:`engine.run` calls with the same writer; call :meth:`write` yourself to record
    the initial state.  The PVD ``timestep`` is ``state.time`` [s] written with ``repr``,
    so it reads back as the exact same float.
    """

    def __init__(self, out_dir, every: int = 100, name: str = "frame", *, walls: bool = True,
                 compression: str | None = None):
        if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
            raise ValueError(f"every must be an integer >= 1, got {every!r}")
        if not isinstance(name, str) or not name or os.sep in name:
            raise ValueError(f"name must be a non-empty file stem, got {name!r}")
        if compression not in (None, "zlib", "lzma"):
            raise ValueError(f"compression must be None, 'zlib' or 'lzma', got {compression!r}")
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.every = int(every)
        self.name = name
        self.walls = bool(walls)
        self.compression = compression
        self.frames = 0
        self._entries: list[tuple[float, int, str]] = []  # (time [s], part, file)

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

    def write(self, model, state) -> None:
        """Write the frame of ``state`` (one VTU per part) and rewrite the PVD."""
        t = float(state.time)
        for key, part in self.frame_parts(model, state).items():
            infix = "" if key == "beads" else f"_{key}"
            stem = f"{self.name}{infix}_{self.frames:06d}.vtu"
            meshio.write(self.out_dir / stem, part.to_meshio(), file_format="vtu",
                         compression=self.compression)
            self._entries.append((t, PARTS[key], stem))
        self.frames += 1
        self._write_pvd()

    def flush(self) -> None:
        """Rewrite the PVD collection (it is already rewritten after every frame)."""
        if self._entries:
            self._write_pvd()

    def close(self) -> None:
        self.flush()

    def _write_pvd(self) -> None:
        rows = "".join(
            f'    <DataSet timestep="{t!r}" group="" part="{part}" name="{_NAMES[part]}" '
            f'file={quoteattr(f)}/>\n'
            for t, part, f in self._entries)
        text = ('<?xml version="1.0"?>\n'
                '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
                '  <Collection>\n' + rows + '  </Collection>\n</VTKFile>\n')
        tmp = self.pvd_path.with_suffix(".pvd.tmp")
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, self.pvd_path)

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
