"""Geometry of a state as meshes: beads, wire links, contact force lines, walls.

Two layers share one set of arrays:

* :func:`bead_part`, :func:`wire_part`, :func:`contact_part`, :func:`wall_part` build a
  :class:`Part` (points, cells of one VTK type, point and cell data) with numpy only.
  :mod:`workbench.series` writes these parts to VTU with meshio, so a ParaView frame and a
  PyVista picture carry the very same arrays.
* :func:`beads`, :func:`wire`, :func:`contacts`, :func:`walls` (and :func:`scene`) wrap
  them as :class:`pyvista.PolyData`; PyVista is imported inside these functions only, so
  importing this module stays cheap (DESIGN.md §6: lazy GL imports).

Arrays (SI units)
-----------------
beads (one vertex per sphere, point data)
    ``radius`` [m], ``velocity`` (n, 3) [m/s], ``speed`` [m/s], ``spin`` (n, 3) [rad/s],
    ``kind`` (:data:`BEAD_SAND` = 0 or :data:`BEAD_WIRE` = 1: the sphere belongs to a wire
    link), ``group`` (index into ``model.group_names``), ``body_id``.
wire (one line per link, from bead i to bead j, cell data)
    ``tension`` [N] (> 0 in tension, the engine's sign convention), ``broken`` (1 = broken
    for good), ``length`` [m], ``ref_length`` [m] (g_ref of Eq. 7), ``strain`` [-]
    (length / ref_length - 1), ``link_id``.
contacts (one line per contact of the last step, cell data)
    ``normal_force`` fn [N] (>= 0, compression), ``tangential_force`` ft [N] (magnitude
    of the friction force), ``force`` (k, 3) [N] (on i, global frame), ``kind``
    (:data:`CONTACT_SAND_SAND` 0, :data:`CONTACT_SAND_WIRE` 1, :data:`CONTACT_WIRE_WIRE`
    2, :data:`CONTACT_WALL` 3), ``i``, ``j``, ``sub`` (which wall surface, see
    :class:`engine.state.ContactBuffers`) and ``wall`` (1 when j is a wall).  A line goes
    from the centre of sphere i to the centre of sphere j, or to the contact point when j
    is a wall.
walls (triangles, cell data)
    ``body_id``, ``kind`` (``model.body_kind``: 1 plane, 2 cylinder), ``group``, ``sub``
    (0 plane / cylinder side, 1 bottom cap, 2 top cap).  Planes are infinite; they are
    drawn as the patch of the scene's bounding box (padded by ``margin``) that lies on the
    inner side of every other plane, so the five planes of
    :meth:`engine.Scene.add_box` draw as an open box.  Cylinders are drawn as ``resolution``
    facets around, with their closed caps.

Line parts give each line its own two points (2 k points for k lines), so a point array
equal to the cell value (e.g. a tube radius) is constant along a line.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Part", "BEAD_SAND", "BEAD_WIRE", "CONTACT_SAND_SAND", "CONTACT_SAND_WIRE",
           "CONTACT_WIRE_WIRE", "CONTACT_WALL", "bead_kind", "bead_part", "wire_part",
           "contact_part", "wall_part", "scene_bounds", "sample_cylinder", "fallen", "beads",
           "wire", "contacts",
           "walls", "scene"]

#: Bead ``kind`` codes.
BEAD_SAND, BEAD_WIRE = 0, 1
#: Contact ``kind`` codes.
CONTACT_SAND_SAND, CONTACT_SAND_WIRE, CONTACT_WIRE_WIRE, CONTACT_WALL = 0, 1, 2, 3

_PLANE, _CYLINDER = 1, 2  # engine.model.PLANE, CYLINDER (not imported: keep this module light)
_CAP_BOTTOM, _CAP_TOP = 1, 2

#: VTK cell type of each part kind, and its number of points per cell.
_CELL_SIZE = {"vertex": 1, "line": 2, "triangle": 3}


@dataclass(frozen=True)
class Part:
    """Points, cells of one type and their data: one piece of a frame.

    Attributes
    ----------
    points : (n, 3) float64 [m]
    cell_type : str
        ``"vertex"``, ``"line"`` or ``"triangle"``.
    cells : (m, p) int64
        Point indices of each cell (p = 1, 2 or 3).
    point_data, cell_data : dict of str -> array
        Arrays of length n and m (a second axis for vectors).
    """

    points: np.ndarray
    cell_type: str
    cells: np.ndarray
    point_data: dict = field(default_factory=dict)
    cell_data: dict = field(default_factory=dict)

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_cells(self) -> int:
        return int(self.cells.shape[0])

    def to_meshio(self):
        """The part as a :class:`meshio.Mesh` (what :mod:`workbench.series` writes)."""
        import meshio

        return meshio.Mesh(points=self.points, cells=[(self.cell_type, self.cells)],
                           point_data=dict(self.point_data),
                           cell_data={k: [v] for k, v in self.cell_data.items()})

    def to_polydata(self):
        """The part as a :class:`pyvista.PolyData` with the same arrays."""
        import pyvista as pv

        m = self.n_cells
        p = _CELL_SIZE[self.cell_type]
        conn = np.hstack([np.full((m, 1), p, np.int64), self.cells]).ravel()
        kw = {"vertex": "verts", "line": "lines", "triangle": "faces"}[self.cell_type]
        mesh = pv.PolyData(self.points.copy(), **{kw: conn})
        for k, v in self.point_data.items():
            mesh.point_data[k] = v
        for k, v in self.cell_data.items():
            mesh.cell_data[k] = v
        return mesh


def _f64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def _line_cells(k: int) -> np.ndarray:
    return np.arange(2 * k, dtype=np.int64).reshape(k, 2)


def bead_kind(model) -> np.ndarray:
    """(nb,) int8: :data:`BEAD_WIRE` for spheres in a wire link, else :data:`BEAD_SAND`
    (walls get :data:`BEAD_SAND` too; use ``model.body_kind`` to tell them apart)."""
    k = np.full(model.n_bodies, BEAD_SAND, np.int8)
    k[model.link_i] = BEAD_WIRE
    k[model.link_j] = BEAD_WIRE
    return k


def bead_part(model, state) -> Part:
    """Spheres as vertices at their centres with their data (see module doc)."""
    ids = model.sphere_ids
    n = ids.shape[0]
    v = _f64(state.velocity[ids])
    return Part(
        points=_f64(state.position[ids]), cell_type="vertex",
        cells=np.arange(n, dtype=np.int64).reshape(n, 1),
        point_data={
            "radius": _f64(model.body_radius[ids]),
            "velocity": v,
            "speed": np.sqrt((v * v).sum(axis=1)),
            "spin": _f64(state.spin[ids]),
            "kind": bead_kind(model)[ids].astype(np.int32),
            "group": model.body_group[ids].astype(np.int32),
            "body_id": ids.astype(np.int32),
        })


def wire_part(model, state) -> Part | None:
    """Wire links as lines from bead i to bead j (see module doc); ``None`` without wires."""
    links = state.links
    k = len(links)
    if k == 0:
        return None
    points = np.empty((2 * k, 3))
    points[0::2] = state.position[links.i]
    points[1::2] = state.position[links.j]
    ref = _f64(model.link_ref_length)
    return Part(
        points=points, cell_type="line", cells=_line_cells(k),
        cell_data={
            "tension": _f64(links.tension),
            "broken": links.broken.astype(np.int32),
            "length": _f64(links.length),
            "ref_length": ref,
            "strain": links.length / ref - 1.0,
            "link_id": np.arange(k, dtype=np.int32),
        })


def contact_part(model, state, *, empty: bool = False) -> Part | None:
    """Contacts of the last step as lines (see module doc); ``None`` when there are none
    (or before the first step, when forces are undefined), or a part with no points and
    no cells (but every array) when ``empty`` is true."""
    c = state.contacts
    k = len(c)
    if k == 0 or not state.last_dt:
        if not empty:
            return None
        z = np.zeros(0)
        zi = np.zeros(0, np.int32)
        return Part(points=np.zeros((0, 3)), cell_type="line", cells=np.zeros((0, 2), np.int64),
                    cell_data={"normal_force": z, "tangential_force": z,
                               "force": np.zeros((0, 3)), "kind": zi, "i": zi, "j": zi,
                               "sub": zi, "wall": zi})
    wall = model.body_kind[c.j] != 0
    end = state.position[c.j].copy()
    end[wall] = c.point[wall]
    points = np.empty((2 * k, 3))
    points[0::2] = state.position[c.i]
    points[1::2] = end
    force = _f64(c.force)
    fn = _f64(c.normal_force)
    ft_vec = force - fn[:, None] * c.normal
    bk = bead_kind(model)
    n_wire = (bk[c.i] == BEAD_WIRE).astype(np.int8) + (bk[c.j] == BEAD_WIRE) * ~wall
    kind = np.where(wall, CONTACT_WALL, n_wire).astype(np.int32)  # 0, 1, 2 wire beads; 3 wall
    return Part(
        points=points, cell_type="line", cells=_line_cells(k),
        cell_data={
            "normal_force": fn,
            "tangential_force": np.sqrt((ft_vec * ft_vec).sum(axis=1)),
            "force": force,
            "kind": kind,
            "i": c.i.astype(np.int32),
            "j": c.j.astype(np.int32),
            "sub": c.sub.astype(np.int32),
            "wall": wall.astype(np.int32),
        })


def fallen(model, state) -> np.ndarray:
    """(n_spheres,) bool, in ``model.sphere_ids`` order: the free spheres that have fallen
    off the scene, i.e. lie wholly beyond every fixed sphere along gravity by more than
    their own diameter (a floor of fixed beads has an edge; a plane has none).  Without
    gravity or fixed spheres nothing has fallen.  (The slope deposit's grains that roll
    off the rubber floor's edge fall for the rest of the run: far below the heap, they
    would set the framing of its pictures.)"""
    ids = model.sphere_ids
    out = np.zeros(ids.size, bool)
    g = np.asarray(model.options.gravity, float)
    gn = float(np.linalg.norm(g))
    if ids.size == 0 or gn == 0.0:
        return out
    g = g / gn
    depth = state.position[ids] @ g                      # larger: further down
    r = model.body_radius[ids]
    fixed = model.body_dof[ids] != 0                     # engine.model.FREE = 0
    if not fixed.any():
        return out
    low = float((depth[fixed] + r[fixed]).max())         # the lowest point of the supports
    out = ~fixed & (depth - r > low + 2 * r)
    # every free sphere beyond the supports: they are the scene (a fall), not strays
    return out if not out[~fixed].all() else np.zeros(ids.size, bool)


def scene_bounds(model, state, *, free_only: bool = False) -> np.ndarray:
    """(2, 3) [m]: lower and upper corner of the box holding the spheres (with their
    radii; not those that have fallen off the scene, :func:`fallen`), the cylinders and
    the reference points of the planes.  ``free_only``: leave the fixed spheres out too
    (what the pictures frame: a slope's heap, not the whole floor of fixed beads it
    spreads on), unless every sphere is fixed."""
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    keep = ~fallen(model, state)
    if free_only:
        free = model.body_dof[model.sphere_ids] == 0
        if (keep & free).any():
            keep &= free
    ids = model.sphere_ids[keep]
    if ids.size:
        p, r = state.position[ids], model.body_radius[ids][:, None]
        lo = np.minimum(lo, (p - r).min(axis=0))
        hi = np.maximum(hi, (p + r).max(axis=0))
    for w in model.wall_ids:
        x = state.position[w]
        if model.body_kind[w] == _CYLINDER:
            a = model.body_axis[w]
            ends = np.array([x, x + model.body_height[w] * a])
            ext = model.body_radius[w] * np.sqrt(np.clip(1.0 - a * a, 0.0, 1.0))
            lo = np.minimum(lo, ends.min(axis=0) - ext)
            hi = np.maximum(hi, ends.max(axis=0) + ext)
        else:
            lo = np.minimum(lo, x)
            hi = np.maximum(hi, x)
    if not np.all(np.isfinite(lo)):
        return np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]])
    return np.array([lo, hi])


def sample_cylinder(model, state):
    """The vertical cylinder about the z axis holding every sphere (for the torus preset
    when the scene has no cylinder wall: a confined cylindrical sample)."""
    from engine.prep import Cylinder

    ids = model.sphere_ids
    x, r = state.position[ids], model.body_radius[ids]
    z0 = float((x[:, 2] - r).min())
    return Cylinder(float((np.hypot(x[:, 0], x[:, 1]) + r).max()),
                    float((x[:, 2] + r).max()) - z0, center=(0.0, 0.0, z0))


def _basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors orthogonal to the unit vector ``n`` and to each other
    (deterministic: built from the world axis least aligned with n)."""
    e = np.eye(3)[int(np.argmin(np.abs(n)))]
    u = np.cross(n, e)
    u /= np.linalg.norm(u)
    return u, np.cross(n, u)


def _clip(poly: np.ndarray, p: np.ndarray, n: np.ndarray, eps: float) -> np.ndarray:
    """Sutherland–Hodgman: the part of the convex polygon ``poly`` (m, 3) where
    n·(x − p) >= −eps."""
    if len(poly) == 0:
        return poly
    d = (poly - p) @ n + eps
    out = []
    for a in range(len(poly)):
        b = (a + 1) % len(poly)
        if d[a] >= 0:
            out.append(poly[a])
        if (d[a] >= 0) != (d[b] >= 0):
            t = d[a] / (d[a] - d[b])
            out.append(poly[a] + t * (poly[b] - poly[a]))
    return np.array(out).reshape(-1, 3)


def wall_part(model, state, *, margin: float = 0.05, resolution: int = 48) -> Part | None:
    """Walls as triangles (see module doc); ``None`` without walls.

    Parameters
    ----------
    margin : float >= 0
        Padding of the scene box that bounds the plane patches, as a fraction of its
        diagonal [-].
    resolution : int >= 3
        Facets around a cylinder.
    """
    walls_ = model.wall_ids
    if walls_.size == 0:
        return None
    resolution = int(resolution)
    if resolution < 3:
        raise ValueError(f"resolution must be >= 3, got {resolution}")
    lo, hi = scene_bounds(model, state)
    pad = float(margin) * float(np.linalg.norm(hi - lo))
    lo, hi = lo - pad, hi + pad
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    eps = 1e-9 * float(np.linalg.norm(hi - lo))
    planes = [w for w in walls_ if model.body_kind[w] == _PLANE]
    pts, tris, data = [], [], {"body_id": [], "kind": [], "group": [], "sub": []}

    def add(points, triangles, w, sub):
        base = sum(len(q) for q in pts)
        pts.append(points)
        tris.append(triangles + base)
        m = len(triangles)
        data["body_id"].append(np.full(m, w))
        data["kind"].append(np.full(m, model.body_kind[w]))
        data["group"].append(np.full(m, model.body_group[w]))
        data["sub"].append(np.full(m, sub))

    def fan(m):  # triangles of a convex polygon of m vertices, fanned from vertex 0
        return np.column_stack([np.zeros(m - 2, np.int64), np.arange(1, m - 1), np.arange(2, m)])

    for w in walls_:
        x, a = state.position[w], model.body_axis[w]
        u, v = _basis(a)
        if model.body_kind[w] == _PLANE:
            q = (corners - x) @ np.column_stack([u, v])
            (u0, v0), (u1, v1) = q.min(axis=0), q.max(axis=0)
            poly = np.array([x + s * u + t * v for s, t in ((u0, v0), (u1, v0), (u1, v1), (u0, v1))])
            for o in planes:
                if o != w and abs(model.body_axis[o] @ a) < 1.0 - 1e-9:
                    poly = _clip(poly, state.position[o], model.body_axis[o], eps)
            if len(poly) >= 3:
                add(poly, fan(len(poly)), w, 0)
        else:
            r, h = model.body_radius[w], model.body_height[w]
            phi = 2 * np.pi * np.arange(resolution) / resolution
            ring = r * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)
            side = np.vstack([x + ring, x + h * a + ring])
            i0 = np.arange(resolution)
            i1 = (i0 + 1) % resolution
            add(side, np.vstack([np.column_stack([i0, i1, i1 + resolution]),
                                 np.column_stack([i0, i1 + resolution, i0 + resolution])]), w, 0)
            for bit, sub, base in ((_CAP_BOTTOM, 1, x), (_CAP_TOP, 2, x + h * a)):
                if model.body_caps[w] & bit:
                    add(np.vstack([base, base + ring]),
                        np.column_stack([np.zeros(resolution, np.int64), i0 + 1, i1 + 1]), w, sub)
    if not tris:
        return None
    return Part(points=_f64(np.vstack(pts)), cell_type="triangle",
                cells=np.vstack(tris).astype(np.int64),
                cell_data={k: np.concatenate(v).astype(np.int32) for k, v in data.items()})


# -- PyVista wrappers --------------------------------------------------------------------
def _poly(part: Part | None):
    import pyvista as pv

    return pv.PolyData() if part is None else part.to_polydata()


def beads(model, state):
    """:class:`pyvista.PolyData` of the spheres (vertices with :func:`bead_part`'s arrays)."""
    return _poly(bead_part(model, state))


def wire(model, state):
    """:class:`pyvista.PolyData` of the wire links (lines with :func:`wire_part`'s arrays);
    empty without wires."""
    return _poly(wire_part(model, state))


def contacts(model, state):
    """:class:`pyvista.PolyData` of the contact force lines (:func:`contact_part`); empty
    when there are no contacts."""
    return _poly(contact_part(model, state))


def walls(model, state, **options):
    """:class:`pyvista.PolyData` of the walls (triangles, :func:`wall_part`, same
    ``margin`` and ``resolution`` options); empty without walls."""
    return _poly(wall_part(model, state, **options))


def scene(model, state):
    """A :class:`pyvista.MultiBlock` with blocks ``beads``, ``wire``, ``contacts``, ``walls``."""
    import pyvista as pv

    mb = pv.MultiBlock()
    for name, f in (("beads", beads), ("wire", wire), ("contacts", contacts), ("walls", walls)):
        mb[name] = f(model, state)
    return mb
