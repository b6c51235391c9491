"""Drivers: imposed velocity, imposed force and imposed pressure on bodies.

* velocity: the body's translational velocity is imposed (a constant (3,) [m/s] or a
  callable of time); it does not rotate and no force moves it.
* force: a constant or time-dependent force [N] added to the body's external force.  On a
  wall, the wall then moves along the force's line of action only, with its own mass.
* pressure: on a plane, the force p · A · n [N] along the plane normal n (towards the
  spheres), A [m²] the current wall area; the plane moves along n with its own mass.  The
  current p and A are in the State (``state.drive_pressure``, ``state.drive_area``, per
  body, :func:`drive_values`), set from the drive's schedules (:mod:`engine.schedules`:
  a constant, a :class:`~engine.schedules.Ramp` advanced by
  :class:`~engine.schedules.FollowSchedules`, a :class:`~engine.schedules.Servo` set by an
  updater such as :class:`BoxFaces` or :class:`MembraneUpdater`); a Python callable given
  instead (``t -> p``, ``(model, state) -> A``) is evaluated at every step, as before
  schedules existed, and cannot be saved in a checkpoint.

Walls feel no gravity; a driven wall's mass only sets its inertia.
"""
from __future__ import annotations

import math

import numpy as np

from .errors import ConfinementError  # noqa: F401  (its home until 2026-12-05)
from .schedules import drive_values  # noqa: F401  (here until 2026-12-05)
from .trigger import Updater, as_trigger


def _vector(value, what: str) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{what} must be 3 finite numbers, got {value!r}")
    return v


def drive_forces(model, state) -> None:
    """Fill ``state.force`` [N] with ``state.load`` plus the force and pressure drives at the
    current time (a pressure drive: its current pressure and area in the state,
    :func:`drive_values`, or its callables evaluated now)."""
    f = state.force
    f[:] = state.load
    t = state.time
    pressure, areas = drive_values(model, state) if model.drives else (None, None)
    for d in model.drives:
        if d.kind == "force":
            f[d.body] += _vector(d.at(t), f"force drive on body {d.body} at t={t:g} s")
        elif d.kind == "pressure":
            p = float(d.value(t)) if callable(d.value) else float(pressure[d.body])
            area = float(d.area(model, state)) if callable(d.area) else float(areas[d.body])
            if not np.isfinite(p):
                by = f" (not set yet by {d.value.by})" if hasattr(d.value, "by") else ""
                raise ValueError(f"pressure drive on body {d.body}: the pressure must be "
                                 f"finite [Pa], got {p!r} at t={t:g} s{by}")
            if not np.isfinite(area) or area < 0.0:
                by = f" (not set yet by {d.area.by})" if hasattr(d.area, "by") else ""
                raise ValueError(f"pressure drive on body {d.body}: area must be finite and "
                                 f">= 0 m², got {area!r} at t={t:g} s{by}")
            f[d.body] += p * area * model.body_axis[d.body]


def drive_velocities(model, state, t: float) -> None:
    """Set the imposed velocities at time ``t`` [s]."""
    for d in model.drives:
        if d.kind == "velocity":
            state.vel6[d.body, :3] = _vector(d.at(t), f"velocity drive on body {d.body} at t={t:g} s")


class Confinement:
    """A pressure on the free surface of a cylindrical sample, applied to its outer particles
    (the paper's §3.3 procedure "which applies a confinement loading on free surface
    particles").

    The lateral surface is cut into angular sectors × height layers; in each cell the
    particle reaching farthest from the axis (‖x − axis‖ + r) is a surface particle.  The
    surface particles share the total force p × 2π R H (H the sample height) in
    proportion to their cross-sections π r², each along −e_r; R is the mean outer radius
    ρ = ‖x − axis‖ + r of the surface particles weighted by those forces.  :meth:`apply` writes these forces into ``state.load`` (and
    clears the previous ones); call it every few steps as the sample deforms.

    Parameters
    ----------
    pressure : float [Pa], >= 0
    ids : (n,) int            the particles of the sample (sand and wire beads).
    center : (x, y) [m]       the vertical axis.
    cell : float [m]          target size of a cell (default the mean diameter, about one
                              surface particle per cell).
    max_growth : float > 1 or None
        :meth:`apply` raises :class:`ConfinementError` when the radius R exceeds this
        factor times its value at the first :meth:`apply` (default 1.5; None: never).  An
        escaped grain counts as a surface particle, so R and the membrane's total force run
        away together: seen on samples of about 250 grains, where R grew 150-200 times and
        the run went on to a meaningless end.  A sample that holds together bulges by a few
        per cent.
    start_radius : float [m] > 0 or None
        The radius ``max_growth`` is measured against (None: the first :meth:`apply`'s).
        Going on from a checkpoint, give the first run's :attr:`start_radius`.

    The membrane owns the loads of its particles: the first :meth:`apply` clears them all
    (so a new Confinement on a state read from a checkpoint takes over the loads the saved
    one left), each later one those of the previous surface particles.
    """

    def __init__(self, pressure: float, ids, *, center=(0.0, 0.0), cell: float | None = None,
                 max_growth: float | None = 1.5, start_radius: float | None = None):
        p = float(pressure)
        if not (np.isfinite(p) and p >= 0):
            raise ValueError(f"pressure must be finite and >= 0 [Pa], got {pressure!r}")
        if max_growth is not None:
            try:
                g = float(max_growth)
            except (TypeError, ValueError):
                g = float("nan")
            if not (np.isfinite(g) and g > 1.0):
                raise ValueError(f"max_growth must be a finite factor > 1 (or None), got "
                                 f"{max_growth!r}")
            max_growth = g
        self.max_growth = max_growth
        if start_radius is not None:
            r0 = float(start_radius) if isinstance(start_radius, (int, float, np.number)) \
                and not isinstance(start_radius, bool) else float("nan")
            if not (np.isfinite(r0) and r0 > 0):
                raise ValueError(f"start_radius must be a radius > 0 [m] (or None), got "
                                 f"{start_radius!r}")
            start_radius = r0
        self.start_radius = start_radius
        self.applied = False            # the first apply clears the loads of all the ids
        self.pressure = p
        self.ids = np.asarray(ids, dtype=np.int64)
        if self.ids.size == 0:
            raise ValueError("ids: the confined sample has no particle")
        self.center = np.asarray(center, dtype=float)
        self.cell = cell
        self.surface = np.zeros(0, np.int64)
        self.area = self.radius = self.height = 0.0

    def geometry(self, model, state):
        """(outer radius ρ, angle θ, z bottom, z top) of the sample's particles."""
        x = state.position[self.ids]
        r = model.body_radius[self.ids]
        dx, dy = x[:, 0] - self.center[0], x[:, 1] - self.center[1]
        return np.hypot(dx, dy) + r, np.arctan2(dy, dx), (x[:, 2] - r).min(), (x[:, 2] + r).max()

    def apply(self, model, state) -> float:
        """Recompute the surface particles and their loads; returns the loaded area [m²].

        Raises :class:`ConfinementError` (loads unchanged) when the radius has run away
        (``max_growth``)."""
        rho, theta, z0, z1 = self.geometry(model, state)
        rad = model.body_radius[self.ids]
        cell = 2.0 * rad.mean() if self.cell is None else float(self.cell)
        outer = rho > np.percentile(rho, 75)
        if not outer.any():             # a quarter or more tied at the largest radius
            outer = rho >= np.percentile(rho, 75)
        R = float(np.median(rho[outer]))
        n_sec = max(4, int(round(2 * np.pi * R / cell)))
        n_lay = max(1, int(round((z1 - z0) / cell)))
        z = state.position[self.ids, 2]
        sec = ((theta + np.pi) / (2 * np.pi) * n_sec).astype(np.int64) % n_sec
        lay = np.clip(((z - z0) / (z1 - z0) * n_lay).astype(np.int64), 0, n_lay - 1)
        cell_id = sec * n_lay + lay
        # the farthest particle of each cell, leaving out particles that left the sample
        # (farther than 2 mean diameters beyond the median surface): loading one of those
        # inwards throws it through the sample (seen on a 190-grain sample)
        top = self._outermost(rho, cell_id)
        R_med = float(np.median(rho[top]))
        keep = rho <= R_med + 4.0 * rad.mean()
        top = np.flatnonzero(keep)[self._outermost(rho[keep], cell_id[keep])]
        # the total force is p × 2π R H, R the median outer radius of the surface
        # particles, shared in proportion to each particle's cross-section π r²: a cell's
        # share on one small grain accelerated it by ~1e5 m/s² and grains were thrown
        # through the sample (seen at scale 0.03 and 0.1)
        # R is the force-weighted mean outer radius: then Σ ρ_i F_i = p 2π R² H and the
        # Weber stress (Eq. 18) of the volume π R² H reads σ_rr = −p exactly at equilibrium
        r_top = rad[top]
        w = r_top ** 2 / np.sum(r_top ** 2)
        R_surf = float(np.dot(w, rho[top]))
        self._check_growth(R_surf, state)
        area = 2 * np.pi * R_surf * (z1 - z0) * w
        return self._load(state, top, theta, area, r_top, R_surf, z1 - z0)

    def _check_growth(self, R, state) -> None:
        if self.start_radius is None:
            self.start_radius = R
        elif self.max_growth is not None and not R <= self.max_growth * self.start_radius:
            raise ConfinementError(
                f"the confinement radius grew from {1e3 * self.start_radius:.3g} mm to "
                f"{1e3 * R:.3g} mm (more than max_growth = {self.max_growth:g} times; "
                f"grains left the membrane) at step {state.step}")

    def _load(self, state, top, theta, area, lever, R, height) -> float:
        """Load particles ``top`` (indices into ``ids``) by p × ``area`` each along −e_r
        (clearing the previous loads); ``lever`` [m]: the distance from each centre to the
        membrane along e_r (the branch of its membrane "contact")."""
        f = self.pressure * area
        state.load[self.ids if not self.applied else self.ids[self.surface]] = 0.0
        self.applied = True
        self.surface = top
        er = np.stack([np.cos(theta[top]), np.sin(theta[top]), np.zeros(top.size)], 1)
        state.load[self.ids[top]] = -f[:, None] * er
        self._force = f
        self._er = er
        self._lever = np.asarray(lever, float)
        self.area = float(area.sum())
        self.radius = float(R)                                 # outer envelope [m]
        self.height = float(height)
        return self.area

    @staticmethod
    def _outermost(rho, cell_id):
        order = np.lexsort((rho, cell_id))
        last = np.r_[cell_id[order][1:] != cell_id[order][:-1], True]
        return order[last]

    def membrane_stress(self, model) -> np.ndarray:
        """Σ_surface (−r e_r) ⊗ f over the loaded particles [N·m] (tension positive once
        divided by −V): the part of the Weber sum (Eq. 18) of the membrane "contacts",
        whose branch goes from the particle centre to its outer edge, like a wall contact's."""
        if self.surface.size == 0:
            return np.zeros((3, 3))
        branch = -self._lever[:, None] * self._er
        force = -self._force[:, None] * self._er
        return np.einsum("ka,kb->ab", branch, force)


class LayerCrown(Confinement):
    """The lateral confinement of LMGC90's public 3D membrane example, for comparison with
    :class:`Confinement` (issue 30 §2): the sample is cut into horizontal layers ``layer``
    [m] thick (default 2 × the largest radius); in each layer, of outer radius r_out (the
    largest ‖x − axis‖ + r of its particles), the crown is the particles whose centre is
    farther than r_out − 2 r_max from the axis (r_max the largest radius of the sample);
    each crown particle gets a radial inward force proportional to its radius, the layer's
    forces summing to p × 2π r_out t (t the layer's thickness).

    :attr:`radius` is the thickness-weighted mean of the layers' r_out (so that the total
    force is p × 2π R H); the membrane "contact" of a crown particle reaches from its centre
    to r_out (:meth:`membrane_stress`).  Same parameters and errors as :class:`Confinement`
    (``cell`` unused; ``layer`` instead).
    """

    def __init__(self, pressure: float, ids, *, center=(0.0, 0.0), layer: float | None = None,
                 max_growth: float | None = 1.5, start_radius: float | None = None):
        super().__init__(pressure, ids, center=center, max_growth=max_growth,
                         start_radius=start_radius)
        if layer is not None:
            t = float(layer)
            if not (np.isfinite(t) and t > 0):
                raise ValueError(f"layer must be a thickness > 0 [m] (or None), got {layer!r}")
        self.layer = layer

    def apply(self, model, state) -> float:
        rho, theta, z0, z1 = self.geometry(model, state)
        rad = model.body_radius[self.ids]
        r_max = float(rad.max())
        d = rho - rad                                   # centre distance from the axis
        t = 2 * r_max if self.layer is None else float(self.layer)
        n_lay = max(1, int(round((z1 - z0) / t)))
        thick = (z1 - z0) / n_lay
        z = state.position[self.ids, 2]
        lay = np.clip(((z - z0) / thick).astype(np.int64), 0, n_lay - 1)
        r_out = np.full(n_lay, -np.inf)
        np.maximum.at(r_out, lay, rho)
        crown = np.flatnonzero(d > r_out[lay] - 2 * r_max)
        # each layer's forces sum to p 2π r_out t, shared in proportion to the radii
        share = np.zeros(n_lay)
        np.add.at(share, lay[crown], rad[crown])
        occupied = np.isfinite(r_out)
        R = float(np.sum(r_out[occupied]) * thick / (z1 - z0))
        self._check_growth(R, state)
        area = 2 * np.pi * r_out[lay[crown]] * thick * rad[crown] / share[lay[crown]]
        return self._load(state, crown, theta, area, r_out[lay[crown]] - d[crown], R, z1 - z0)


class BoxFaces(Updater):
    """The servo areas of a box's pressure-driven walls (``Servo("box faces")``), every
    ``every`` steps (default each step) and before a run's first step: side wall k of
    ``sides`` (x−, x+, y−, y+) gets the face H × w (H = z_top − z_floor, w the span of the
    other pair of sides), the top L_x × L_y, each from the walls' positions [m²]; so that
    p × A stays the stress p on the faces of a sample that deforms."""

    def __init__(self, floor: int, top: int, sides, every=1):
        self.floor, self.top = int(floor), int(top)
        self.sides = tuple(int(b) for b in sides)
        if len(self.sides) != 4:
            raise ValueError(f"BoxFaces: sides must be the 4 side walls (x-, x+, y-, y+), got "
                             f"{sides!r}")
        self.trigger = as_trigger(every, "BoxFaces")

    def start(self, model, state) -> None:
        self.update(model, state)

    def update(self, model, state) -> None:
        x = state.position
        s0, s1, s2, s3 = self.sides
        _, area = drive_values(model, state)
        H = x[self.top, 2] - x[self.floor, 2]
        for k, b in enumerate(self.sides):
            other, ax = ((s2, s3), 1) if k < 2 else ((s0, s1), 0)
            area[b] = H * (x[other[1], ax] - x[other[0], ax])
        area[self.top] = (x[s1, 0] - x[s0, 0]) * (x[s3, 1] - x[s2, 1])


class MembraneUpdater(Updater):
    """A :class:`Confinement` (or :class:`LayerCrown`) as an updater: every ``every`` steps
    (an int, or a callable ``step -> bool``) the membrane takes the current pressure of the
    drive on body ``pressure_of`` (the top plate's, so both follow one schedule), and
    :meth:`Confinement.apply` recomputes the surface particles' loads in ``state.load``; the
    top plate's area (``Servo("membrane")``) becomes π R², R the membrane's radius.
    :meth:`apply` does the same once, outside a run (the set-up).  What the next step reads
    (the loads, the plate's pressure and area) is in the State; going on from a checkpoint,
    a new membrane with the saved run's ``start_radius`` takes over (:class:`Confinement`)
    and the run goes on bit for bit."""

    def __init__(self, membrane: "Confinement", top: int, every=1):
        self.membrane, self.top = membrane, int(top)
        self.trigger = as_trigger(every, "MembraneUpdater")

    def apply(self, model, state) -> None:
        pressure, area = drive_values(model, state)
        self.membrane.pressure = float(pressure[self.top])
        self.membrane.apply(model, state)
        area[self.top] = math.pi * self.membrane.radius ** 2

    def update(self, model, state) -> None:
        self.apply(model, state)
