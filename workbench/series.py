"""VTU files per frame and a PVD collection that ParaView opens as a time series.

:class:`SeriesWriter` is an engine writer (``trigger(step)``, ``write(model, state)``,
``flush()``, ``close()``; see :func:`engine.run`).  Each frame it writes

* ``<name>_<frame>.vtu`` (PVD part 0): one VTK vertex per sphere at its centre, with point
  data ``radius`` [m], ``velocity`` (n, 3) [m/s], ``spin`` (n, 3) [rad/s], ``group``
  (index into ``model.group_names``), ``kind`` (``model.body_kind``) and ``body_id``;
* ``<name>_contacts_<frame>.vtu`` (PVD part 1), only when the step had contacts: one line
  per contact, from the centre of sphere i to the centre of body j (sphere–sphere) or to
  the contact point (sphere–wall), with cell data ``normal_force`` (k,) [N] (>= 0,
  compression), ``force`` (k, 3) [N] (on i, global frame), ``i``, ``j``, ``sub`` and
  ``wall`` (1 when j is a wall);
* ``<name>_wire_<frame>.vtu`` (PVD part 2), only for scenes with wires: one line per wire
  link between the two bead centres, with cell data ``tension`` (l,) [N] (> 0 in
  tension), ``broken`` (1 = broken for good), ``length`` [m] and ``ref_length`` [m] (g_ref
  of Eq. 7).

The ``<name>.pvd`` file is rewritten (atomically) after every frame, so it stays valid
if the run is killed.  In ParaView: File > Open ``<name>.pvd``; show part 0 with the
"Point Gaussian" representation scaled by ``radius`` (or a Glyph filter, sphere glyphs
scaled by ``radius``), part 1 as lines coloured by ``normal_force``.

No VTK or PyVista is needed: files are written by :mod:`meshio`.
"""
from __future__ import annotations

import os
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

__all__ = ["SeriesWriter", "sphere_mesh", "contact_mesh", "wire_mesh", "read_pvd"]


def sphere_mesh(model, state) -> meshio.Mesh:
    """Spheres as VTK vertices at their centres, with their per-sphere data (see module doc)."""
    ids = model.sphere_ids
    n = ids.shape[0]
    return meshio.Mesh(
        points=np.ascontiguousarray(state.position[ids], dtype=np.float64),
        cells=[("vertex", np.arange(n, dtype=np.int64).reshape(n, 1))],
        point_data={
            "radius": np.ascontiguousarray(model.body_radius[ids], dtype=np.float64),
            "velocity": np.ascontiguousarray(state.velocity[ids], dtype=np.float64),
            "spin": np.ascontiguousarray(state.spin[ids], dtype=np.float64),
            "group": model.body_group[ids].astype(np.int32),
            "kind": model.body_kind[ids].astype(np.int32),
            "body_id": ids.astype(np.int32),
        },
    )


def contact_mesh(model, state) -> meshio.Mesh | None:
    """Contacts of the last step as lines (see module doc); ``None`` when there are none.

    A line goes from the centre of sphere i to the centre of sphere j, or to the contact
    point when j is a wall (``model.body_kind[j] != 0``).
    """
    c = state.contacts
    k = len(c)
    if k == 0 or not state.last_dt:
        return None
    wall = model.body_kind[c.j] != 0
    end = state.position[c.j].copy()
    end[wall] = c.point[wall]
    points = np.empty((2 * k, 3))
    points[0::2] = state.position[c.i]
    points[1::2] = end
    force = c.force
    return meshio.Mesh(
        points=points,
        cells=[("line", np.arange(2 * k, dtype=np.int64).reshape(k, 2))],
        cell_data={
            "normal_force": [np.ascontiguousarray(c.normal_force, dtype=np.float64)],
            "force": [np.ascontiguousarray(force, dtype=np.float64)],
            "i": [c.i.astype(np.int32)],
            "j": [c.j.astype(np.int32)],
            "sub": [c.sub.astype(np.int32)],
            "wall": [wall.astype(np.int32)],
        },
    )


def wire_mesh(model, state) -> meshio.Mesh | None:
    """Wire links as lines between bead centres (see module doc); ``None`` without wires."""
    links = state.links
    k = len(links)
    if k == 0:
        return None
    points = np.empty((2 * k, 3))
    points[0::2] = state.position[links.i]
    points[1::2] = state.position[links.j]
    return meshio.Mesh(
        points=points,
        cells=[("line", np.arange(2 * k, dtype=np.int64).reshape(k, 2))],
        cell_data={
            "tension": [np.ascontiguousarray(links.tension, dtype=np.float64)],
            "broken": [links.broken.astype(np.int32)],
            "length": [np.ascontiguousarray(links.length, dtype=np.float64)],
            "ref_length": [np.ascontiguousarray(model.link_ref_length, dtype=np.float64)],
        },
    )


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
        ``<name>_contacts_000012.vtu``.

    Notes
    -----
    Frames are numbered in the order they are written (0, 1, ...), also across several
    :func:`engine.run` calls with the same writer; call :meth:`write` yourself to record
    the initial state.  The PVD ``timestep`` is ``state.time`` [s] written with ``repr``,
    so it reads back as the exact same float.
    """

    def __init__(self, out_dir, every: int = 100, name: str = "frame"):
        if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
            raise ValueError(f"every must be an integer >= 1, got {every!r}")
        if not isinstance(name, str) or not name or os.sep in name:
            raise ValueError(f"name must be a non-empty file stem, got {name!r}")
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.every = int(every)
        self.name = name
        self.frames = 0
        self._entries: list[tuple[float, int, str]] = []  # (time [s], part, file)

    @property
    def pvd_path(self) -> Path:
        """Path of the PVD collection."""
        return self.out_dir / f"{self.name}.pvd"

    def trigger(self, step: int) -> bool:
        return int(step) % self.every == 0

    def write(self, model, state) -> None:
        """Write the frame of ``state`` (spheres, and contact lines if any) and the PVD."""
        t = float(state.time)
        stem = f"{self.name}_{self.frames:06d}.vtu"
        meshio.write(self.out_dir / stem, sphere_mesh(model, state), file_format="vtu")
        self._entries.append((t, 0, stem))
        lines = contact_mesh(model, state)
        if lines is not None:
            stem = f"{self.name}_contacts_{self.frames:06d}.vtu"
            meshio.write(self.out_dir / stem, lines, file_format="vtu")
            self._entries.append((t, 1, stem))
        wire = wire_mesh(model, state)
        if wire is not None:
            stem = f"{self.name}_wire_{self.frames:06d}.vtu"
            meshio.write(self.out_dir / stem, wire, file_format="vtu")
            self._entries.append((t, 2, stem))
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
            f'    <DataSet timestep="{t!r}" group="" part="{part}" file={quoteattr(f)}/>\n'
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
