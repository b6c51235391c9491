"""Scene: the mutable builder that compiles into a static Model and a mutable State.

Every input check lives here, so that a user meets a ``ValueError`` naming the field and
its allowed range (or the offending ids), never a numba traceback.
"""
from __future__ import annotations

import math
import numbers

import numpy as np

from . import laws as _laws
from .contact.broadphase import build_pairs
from .model import (CAP_BOTTOM, CAP_TOP, CYLINDER, FREE, IMPOSED, LINE, MAX_OVERLAP,
                    OVERLAP_TOL, PLANE, SPHERE, Drive, Model, Options, pack_body_dyn)
from .schedules import Schedule
from .state import State

#: Overlap allowed at compile time, as a fraction of the smaller radius.
OVERLAP_TOLERANCE = 0.01
#: Largest density [kg/m³] of a body: 4 000 times osmium's (22 590 kg/m³), room for mass
#: scaling.  Beyond, products of masses overflow in the solver (a density of 1e308 sank a
#: sphere through the floor, every step "converged").
MAX_DENSITY = 1e8
#: Body masses [kg] the solver's products of masses and impulses hold (squares < 1e300).
MASS_RANGE = (1e-100, 1e100)


def _numbers(value, name: str):
    """``value`` unchanged; a ValueError naming ``name`` if it is, or holds, strings or
    bools (which numpy would turn into numbers: ``"2650"`` → 2650, ``True`` → 1 m)."""
    from .checks import _not_a_number

    what = _not_a_number(value)
    if what is None and isinstance(value, np.ndarray) and value.dtype == object:
        what = next((w for w in map(_not_a_number, value.ravel()) if w), None)
    if what:
        raise ValueError(f"{name} must be numbers, got {what}: {value!r}"[:300])
    return value


def _as_array(value, name: str, dtype=float) -> np.ndarray:
    """``value`` as a numpy array of numbers; a ValueError naming ``name`` for strings,
    bools, or what is not numbers at all (a dict, ragged lists, None)."""
    try:
        return np.asarray(_numbers(value, name), dtype=dtype)
    except (TypeError, ValueError, OverflowError) as e:
        if isinstance(e, ValueError) and str(e).startswith(name):
            raise
        raise ValueError(f"{name} must be numbers, got {value!r}"[:300]) from None


def _finite_array(value, name: str, shape_tail: tuple, dtype=float) -> np.ndarray:
    a = _as_array(value, name, dtype)
    if a.size == 0 and a.ndim == 1:             # [] : no rows (a filter that kept none)
        a = a.reshape((0, *shape_tail))
    if a.ndim != 1 + len(shape_tail) or a.shape[1:] != shape_tail:
        want = "(n, " + ", ".join(map(str, shape_tail)) + ")" if shape_tail else "(n,)"
        raise ValueError(f"{name} must have shape {want}, got {a.shape}")
    bad = ~np.isfinite(a).all(axis=tuple(range(1, a.ndim)))     # per row (none: empty)
    if bad.any():
        raise ValueError(f"{name} must be finite; non-finite rows at ids {np.flatnonzero(bad)[:10].tolist()}")
    return a


def check_bool(name: str, value) -> bool:
    """``value`` as a bool; a ValueError naming ``name`` if it is not True or False (a 0, 1
    or "yes" is refused: a flag set by mistake)."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _vec3(value, name: str, unit: bool = False) -> np.ndarray:
    a = _as_array(value, name)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be 3 finite numbers, got {value!r}")
    if unit:
        n = np.linalg.norm(a)
        if n == 0.0:
            raise ValueError(f"{name} must be a non-zero vector, got {value!r}")
        a = a / n
    return a


def _positive(value, name: str, unit: str) -> float:
    try:
        v = float(_numbers(value, name))
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number > 0 {unit}, got {value!r}") from None
    if not np.isfinite(v) or v <= 0.0:
        raise ValueError(f"{name} must be finite and > 0 {unit}, got {value!r}")
    return v


class Scene:
    """Builder of a simulation: bodies, groups, laws (the see table), fixities and drives.

    Parameters
    ----------
    gravity : 3 floats [m/s²]
        Gravity applied to free spheres.

    Examples
    --------
    >>> s = Scene()
    >>> floor = s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    >>> ball = s.add_spheres([[0, 0, 1e-3]], 1e-3, density=2650.0, group="sand")
    >>> s.interact("sand", "wall", laws.Coulomb(mu=0.5))
    >>> model, state = s.compile(dt=1e-4)
    """

    def __init__(self, gravity=(0.0, 0.0, -9.81)):
        self.gravity = tuple(_vec3(gravity, "gravity"))
        self._kind: list[int] = []
        self._group: list[int] = []
        self._radius: list[float] = []
        self._mass: list[float] = []
        self._axis: list[np.ndarray] = []
        self._height: list[float] = []
        self._caps: list[int] = []
        self._pos: list[np.ndarray] = []
        self._vel: list[np.ndarray] = []
        self._spin: list[np.ndarray] = []
        self._groups: dict[str, int] = {}
        self._pairs: dict[tuple[str, str], object] = {}
        self._fixed: set[int] = set()
        self._drives: dict[int, Drive] = {}
        self._drive_mass: dict[int, float] = {}
        # (i, j, law, position along its wire, whether i and j touch like two spheres)
        # (bead i, bead j, law, position along its wire, neighbour contact, reference
        # length [m] or nan: g(0)/(1+ε₀))
        self._links: list[tuple[int, int, object, int, bool, float]] = []

    # -- bodies ------------------------------------------------------------------------------
    def _group_index(self, group) -> int:
        if not isinstance(group, str) or not group:
            raise ValueError(f"group must be a non-empty string, got {group!r}")
        return self._groups.setdefault(group, len(self._groups))

    @property
    def n_bodies(self) -> int:
        return len(self._kind)

    def add_spheres(self, centers, radii, density, group: str = "sand", velocities=None,
                    spins=None) -> np.ndarray:
        """Add rigid spheres.

        Parameters
        ----------
        centers : (n, 3) [m]
        radii : float or (n,) [m], > 0
        density : float [kg/m³], > 0
        group : str
        velocities, spins : (n, 3) [m/s], [rad/s], optional initial values

        Returns
        -------
        (n,) int32 body ids.
        """
        c = _finite_array(centers, "centers", (3,))
        n = c.shape[0]
        if np.ndim(radii) == 0:
            r0 = float(_numbers(radii, "radii"))
            if not (math.isfinite(r0) and r0 > 0.0):
                raise ValueError(f"radii must be finite and > 0 m, got {radii!r}")
            r = np.full(n, r0)
        else:
            r = _finite_array(radii, "radii", ())
        if r.shape != (n,):
            raise ValueError(f"radii must be a scalar or have shape ({n},), got {r.shape}")
        bad = np.flatnonzero(~(np.isfinite(r) & (r > 0.0)))
        if bad.size:
            raise ValueError(f"radii must be finite and > 0 m; bad values at ids {bad[:10].tolist()}")
        rho = _positive(density, "density", "[kg/m³]")
        if rho > MAX_DENSITY:
            raise ValueError(f"density = {density!r}: must be at most {MAX_DENSITY:g} kg/m³ "
                             f"(beyond, the solver's products of masses overflow)")
        v = np.zeros((n, 3)) if velocities is None else _finite_array(velocities, "velocities", (3,))
        w = np.zeros((n, 3)) if spins is None else _finite_array(spins, "spins", (3,))
        if v.shape[0] != n or w.shape[0] != n:
            raise ValueError(f"velocities and spins must have shape ({n}, 3)")
        g = self._group_index(group)
        first = self.n_bodies
        mass = rho * 4.0 / 3.0 * np.pi * r ** 3
        bad = np.flatnonzero(~((mass >= MASS_RANGE[0]) & (mass <= MASS_RANGE[1])))
        if bad.size:
            raise ValueError(f"radii and density give masses outside [{MASS_RANGE[0]:g}, "
                             f"{MASS_RANGE[1]:g}] kg (the solver's products of masses overflow)"
                             f" at ids {bad[:10].tolist()}: e.g. {mass[bad[0]]:g} kg")
        for k in range(n):
            self._kind.append(SPHERE)
            self._group.append(g)
            self._radius.append(float(r[k]))
            self._mass.append(float(mass[k]))
            self._axis.append(np.zeros(3))
            self._height.append(0.0)
            self._caps.append(0)
            self._pos.append(c[k].copy())
            self._vel.append(v[k].copy())
            self._spin.append(w[k].copy())
        return np.arange(first, first + n, dtype=np.int32)

    def add_wire(self, centers, radius, density, group: str = "wire", law=None,
                 closed: bool = False, neighbour_contact: bool = False,
                 reference_lengths=None) -> np.ndarray:
        """Add a wire: a chain of beads (spheres) linked i -> i+1 by a wire law (Eq. 7-15).

        Parameters
        ----------
        centers : (n, 3) [m], n >= 2
            Bead centres in order along the wire.
        radius : float [m], > 0
            Bead radius (the beads touch sand, walls and other beads like spheres).
        density : float [kg/m³], > 0
            Bead density: the wire mass is the sum of the bead masses.
        group : str
        law : engine.laws.WireLaw
            ``RigidRod()``, ``ElasticRod(k, ε₀)``, ``RigidWire()``, ``ElasticWire(k, ε₀)`` or
            ``BrittleElasticWire(k, ε₀, max_tension)``.  Each link's reference length is
            g_ref = g(0)/(1+ε₀) with g(0) its initial centre distance (Eq. 7).
        closed : bool
            Also link the last bead to the first.
        neighbour_contact : bool
            False (default): linked beads get no contact with each other, so a slack wire
            link lets its two beads overlap.  True: they also touch like any two spheres,
            with the group's own law (``interact(group, group, law)``; with
            ``interact(group, group, None)``, no contact): the beads stay solid.  A link's
            law acts towards its reference length L, the contact only below 2 r_w; with
            L > 2 r_w (the samples': L = 2 r_w + gap) they never fight, and ``compile``
            refuses a link whose L is below 2 r_w (a prestrain too large).
        reference_lengths : (n − 1,) or (n,) if closed [m], > 0, optional
            The links' reference lengths L, in place of g(0)/(1+ε₀): a wire taken from a
            saved state keeps its own (:mod:`engine.experiments.start`).  Its slack links
            may then let neighbour beads overlap (without ``neighbour_contact``), which a
            new wire may not.

        Returns
        -------
        (n,) int32 bead ids.
        """
        neighbour_contact = check_bool("neighbour_contact", neighbour_contact)
        if not isinstance(law, _laws.WireLaw):
            raise ValueError(f"law must be a wire law (RigidRod, ElasticRod, RigidWire, "
                             f"ElasticWire, BrittleElasticWire), got {law!r}")
        c = _finite_array(centers, "centers", (3,))
        if c.shape[0] < 2:
            raise ValueError(f"a wire needs at least 2 beads, got {c.shape[0]}")
        if closed and c.shape[0] < 3:
            raise ValueError(f"a closed wire needs at least 3 beads, got {c.shape[0]} (two "
                             f"would be linked twice, to each other)")
        r = _positive(radius, "radius", "[m]")
        nxt = np.roll(c, -1, axis=0) if closed else c[1:]
        d = np.linalg.norm(c[:len(nxt)] - nxt, axis=1)
        ref = np.full(len(nxt), np.nan)
        if reference_lengths is not None:
            ref = _finite_array(reference_lengths, "reference_lengths", ())
            if ref.shape != (len(nxt),) or not np.all(ref > 0):
                raise ValueError(f"reference_lengths must be {len(nxt)} lengths > 0 [m] (one "
                                 f"per link), got shape {ref.shape}")
        bad = np.flatnonzero(d < 2 * r * (1 - OVERLAP_TOLERANCE))
        if bad.size and (reference_lengths is None or neighbour_contact):
            raise ValueError(f"wire beads overlap their neighbour by more than "
                             f"{OVERLAP_TOLERANCE:.0%} of the radius (centre distance < "
                             f"{2 * r * (1 - OVERLAP_TOLERANCE):.6g} m) at links {bad[:10].tolist()}")
        ids = self.add_spheres(c, r, density, group=group)
        for k in range(len(nxt)):
            self._links.append((int(ids[k]), int(ids[(k + 1) % len(ids)]), law, k,
                                bool(neighbour_contact), float(ref[k])))
        return ids

    def _add_wall(self, kind, point, axis, radius, height, caps, group) -> int:
        g = self._group_index(group)
        self._kind.append(kind)
        self._group.append(g)
        self._radius.append(radius)
        self._mass.append(np.inf)
        self._axis.append(axis)
        self._height.append(height)
        self._caps.append(caps)
        self._pos.append(point)
        self._vel.append(np.zeros(3))
        self._spin.append(np.zeros(3))
        return self.n_bodies - 1

    def add_plane(self, point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), group: str = "wall") -> int:
        """Add an infinite rigid plane; spheres live on the side its ``normal`` points to.

        Planes are fixed unless driven (:meth:`drive`).  Returns the body id.
        """
        return self._add_wall(PLANE, _vec3(point, "point"), _vec3(normal, "normal", unit=True),
                              0.0, 0.0, 0, group)

    def add_cylinder(self, center=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), radius=1.0, height=1.0,
                     group: str = "wall", bottom: bool = True, top: bool = False) -> int:
        """Add a rigid cylindrical container; spheres touch its inner surface.

        Parameters
        ----------
        center : 3 floats [m]
            Centre of the **base** (bottom end); the cylinder spans ``center`` to
            ``center + height * axis``.
        axis : 3 floats
            Direction from the bottom to the top end (normalised).
        radius, height : float [m], > 0
        bottom, top : bool
            Whether the bottom and top end caps are closed (flat discs).

        Returns the body id.  The side wall acts on spheres whose centre lies between the
        two ends (no rim contact).
        """
        caps = (CAP_BOTTOM if bottom else 0) | (CAP_TOP if top else 0)
        return self._add_wall(CYLINDER, _vec3(center, "center"), _vec3(axis, "axis", unit=True),
                              _positive(radius, "radius", "[m]"), _positive(height, "height", "[m]"),
                              caps, group)

    def add_box(self, lo, hi, group: str = "wall", top: bool = False) -> np.ndarray:
        """Add the floor and four side walls (and the lid if ``top``) of the box [lo, hi].

        Returns the plane ids in the order floor, x-, x+, y-, y+ (, lid).
        """
        lo = _vec3(lo, "lo")
        hi = _vec3(hi, "hi")
        if np.any(hi <= lo):
            raise ValueError(f"box needs hi > lo on every axis, got lo={lo.tolist()}, hi={hi.tolist()}")
        ids = [self.add_plane(lo, (0, 0, 1), group), self.add_plane(lo, (1, 0, 0), group),
               self.add_plane(hi, (-1, 0, 0), group), self.add_plane(lo, (0, 1, 0), group),
               self.add_plane(hi, (0, -1, 0), group)]
        if top:
            ids.append(self.add_plane(hi, (0, 0, -1), group))
        return np.asarray(ids, dtype=np.int32)

    # -- interactions, fixities, drives ---------------------------------------------------
    def interact(self, group_a: str, group_b: str, law, *, replace: bool = False) -> None:
        """Declare the law between two groups (the see table); ``law=None`` = no interaction.

        Every pair of groups that can touch needs a declaration (checked at compile time).
        A pair is one pair in either order: declaring it again with another law is refused
        (which one was meant?) unless ``replace=True``.
        """
        for g in (group_a, group_b):
            if not isinstance(g, str) or not g:
                raise ValueError(f"group names must be non-empty strings, got {g!r}")
        if law is not None and not isinstance(law, _laws.Law):
            raise ValueError(f"law must be an engine.laws law or None, got {law!r}")
        if law is not None and law.code != _laws.COULOMB:
            raise ValueError(f"interact({group_a!r}, {group_b!r}): {type(law).__name__} is a "
                             f"wire law; wire laws go on Scene.add_wire links, contacts take "
                             f"Coulomb")
        key = tuple(sorted((group_a, group_b)))
        if key in self._pairs and self._pairs[key] != law and not replace:
            raise ValueError(f"interact({group_a!r}, {group_b!r}): the pair has a law already "
                             f"({self._pairs[key]!r}; either order is the same pair): pass "
                             f"replace=True to replace it with {law!r}")
        self._pairs[key] = law

    def _check_ids(self, ids, name: str = "ids") -> np.ndarray:
        a = np.atleast_1d(np.asarray(ids))
        if a.size and not np.issubdtype(a.dtype, np.integer):
            raise ValueError(f"{name} must be integer body ids, got dtype {a.dtype}")
        bad = a[(a < 0) | (a >= self.n_bodies)]
        if bad.size:
            raise ValueError(f"{name}: unknown body ids {bad[:10].tolist()} "
                             f"(valid: 0..{self.n_bodies - 1})")
        return a.astype(np.int64)

    def fix(self, ids) -> None:
        """Impose a zero velocity (and spin) on bodies ``ids``."""
        for b in self._check_ids(ids).tolist():
            if b in self._drives:
                raise ValueError(f"body {b} is driven; it cannot also be fixed")
            self._fixed.add(b)

    def drive(self, body: int, *, velocity=None, force=None, pressure=None, mass=None,
              area=None) -> None:
        """Drive one body: exactly one of ``velocity``, ``force`` or ``pressure``.

        Parameters
        ----------
        body : int
        velocity : (3,) [m/s] or callable t -> (3,)
            Imposed translational velocity (the body does not rotate).
        force : (3,) [N] or callable t -> (3,)
            Imposed external force.  On a wall, the wall moves along the force's line of
            action with mass ``mass``.
        pressure : float [Pa], schedule or callable t -> float
            Planes only: force p · A · n along the plane normal (towards the spheres); the
            plane moves along its normal with mass ``mass``.  A schedule
            (:mod:`engine.schedules`: ``Constant``, ``Ramp``, ``Servo``) is data, saved
            with the model; its current value is ``state.drive_pressure[body]``.
        mass : float [kg], > 0
            Required for a force- or pressure-driven wall.
        area : float [m²], schedule or callable (model, state) -> float
            Current wall area, required with ``pressure`` (a ``Servo``: set by an updater,
            ``state.drive_area[body]``).  A callable is evaluated at every step and cannot
            be saved in a checkpoint.
        """
        b = int(self._check_ids(body, "body")[0])
        given = [k for k, v in (("velocity", velocity), ("force", force), ("pressure", pressure))
                 if v is not None]
        if len(given) != 1:
            raise ValueError(f"drive needs exactly one of velocity, force or pressure; got {given}")
        kind = given[0]
        value = {"velocity": velocity, "force": force, "pressure": pressure}[kind]
        if b in self._fixed:
            raise ValueError(f"body {b} is fixed; it cannot also be driven")
        if b in self._drives:
            raise ValueError(f"body {b} already has a {self._drives[b].kind} drive")
        is_wall = self._kind[b] != SPHERE
        if isinstance(value, Schedule) and kind != "pressure":
            raise ValueError(f"{kind}: a schedule ({type(value).__name__}) drives a pressure "
                             f"only; give a {kind} (3,) or a callable of time")
        if not callable(value) and not isinstance(value, Schedule):
            if kind == "pressure":
                if not isinstance(value, numbers.Real) or not np.isfinite(value):
                    raise ValueError(f"pressure must be a finite number [Pa], got {value!r}")
                value = float(value)
            else:
                value = _vec3(value, kind)
        if kind == "pressure":
            if self._kind[b] != PLANE:
                raise ValueError(f"pressure drives apply to planes; body {b} is a "
                                 f"{['sphere', 'plane', 'cylinder'][self._kind[b]]}")
            if area is None:
                raise ValueError("pressure drive needs area= [m²] (a float or a callable "
                                 "(model, state) -> float)")
            if not callable(area) and not isinstance(area, Schedule):
                area = _positive(area, "area", "[m²]")
        elif area is not None:
            raise ValueError("area= is only meaningful with a pressure drive")
        if kind in ("force", "pressure") and is_wall:
            self._drive_mass[b] = _positive(mass, "mass", "[kg] (a force- or pressure-driven wall "
                                            "needs its own mass)")
        elif mass is not None:
            raise ValueError("mass= is only meaningful for a force- or pressure-driven wall")
        if kind == "force" and is_wall and not callable(value) and not np.any(value):
            raise ValueError("force on a wall must be non-zero (it sets the wall's line of motion)")
        self._drives[b] = Drive(body=b, kind=kind, value=value, area=area)

    # -- compile --------------------------------------------------------------------------
    def _see_table(self, dof):
        names = list(self._groups)
        ng = len(names)
        declared = set(name for pair in self._pairs for name in pair)
        unknown = sorted(declared - set(names))
        if unknown:
            raise ValueError(f"interact: unknown group names {unknown}; groups are {names}")
        kind = np.asarray(self._kind, dtype=np.int8)
        group = np.asarray(self._group, dtype=np.int16)
        law_list: list = []
        pair_law = -np.ones((ng, ng), np.int16)
        for (a, b), law in self._pairs.items():
            if law is None:
                continue
            if law not in law_list:
                law_list.append(law)
            ia, ib = self._groups[a], self._groups[b]
            pair_law[ia, ib] = pair_law[ib, ia] = law_list.index(law)
        # which pairs of groups can touch: spheres with spheres, spheres with walls, when
        # at least one side can move
        spheres = kind == SPHERE
        has_sphere = np.zeros(ng, bool)
        has_wall = np.zeros(ng, bool)
        mobile = np.zeros(ng, bool)
        for g in range(ng):
            in_g = group == g
            has_sphere[g] = np.any(in_g & spheres)
            has_wall[g] = np.any(in_g & ~spheres)
            mobile[g] = np.any(in_g & spheres & (dof != IMPOSED))
        missing = []
        for a in range(ng):
            for b in range(a, ng):
                key = tuple(sorted((names[a], names[b])))
                if key in self._pairs:
                    continue
                both_sph = has_sphere[a] and has_sphere[b] and (a != b or np.sum((group == a) & spheres) > 1)
                sph_wall = (has_sphere[a] and has_wall[b] and mobile[a]) or \
                           (has_sphere[b] and has_wall[a] and mobile[b])
                if (both_sph and (mobile[a] or mobile[b])) or sph_wall:
                    missing.append(key)
        if missing:
            raise ValueError("pairs of groups that can touch have no declared law: "
                             + ", ".join(f"({a!r}, {b!r})" for a, b in missing)
                             + "; declare each with Scene.interact(a, b, law) or law=None")
        law_code = np.asarray([l.code for l in law_list], np.int16).reshape(-1)
        law_param = np.asarray([l.params() for l in law_list], float).reshape(-1, _laws.N_PARAM)
        if law_param.shape[0] == 0:  # kernels index law_param[law] only for law >= 0
            law_param = np.zeros((1, _laws.N_PARAM))
        return names, pair_law, law_code, law_param, tuple(law_list)

    def _check_overlaps(self, pos, radius, kind, axis, height, caps, sphere_ids,
                        group=None, pair_law=None) -> None:
        # linked beads that get no contact may overlap (a slack link of a saved state)
        excluded = -np.ones(pos.shape[0], np.int32)
        for lk in self._links:
            if not lk[4]:
                excluded[lk[0]] = lk[1]
        if sphere_ids.size >= 2:
            allpairs = np.zeros((1, 1), np.int16)
            grp = np.zeros(pos.shape[0], np.int16)
            out = np.zeros((4 * sphere_ids.size + 64, 2), np.int32)
            while True:
                n = build_pairs(pos, radius, grp, allpairs, excluded,
                                sphere_ids.astype(np.int32), 0.0, out)
                if n <= out.shape[0]:
                    break
                out = np.zeros((int(1.3 * n) + 64, 2), np.int32)
            p = out[:n]
            d = np.linalg.norm(pos[p[:, 0]] - pos[p[:, 1]], axis=1)
            overlap = radius[p[:, 0]] + radius[p[:, 1]] - d
            bad = overlap > OVERLAP_TOLERANCE * np.minimum(radius[p[:, 0]], radius[p[:, 1]])
            if bad.any():
                worst = p[bad][:10].tolist()
                raise ValueError(f"{int(bad.sum())} pairs of spheres overlap by more than "
                                 f"{OVERLAP_TOLERANCE:.0%} of the smaller radius, e.g. ids {worst}")
        for w in np.flatnonzero(kind != SPHERE):
            seen = sphere_ids
            if pair_law is not None:
                # a sphere whose group has no law with the wall's never touches it: it may
                # lie behind it (a wire passing through a wall that holds only the sand)
                seen = sphere_ids[pair_law[group[sphere_ids], group[w]] >= 0]
            x = pos[seen] - pos[w]
            r = radius[seen]
            a = axis[w]
            h = x @ a
            if kind[w] == PLANE:
                gaps = [h - r]
            else:
                inside = (h >= 0) & (h <= height[w])
                rho = np.linalg.norm(x - h[:, None] * a, axis=1)
                gaps = [np.where(inside, radius[w] - rho - r, np.inf)]
                if caps[w] & CAP_BOTTOM:
                    gaps.append(np.where(rho < radius[w], h - r, np.inf))
                if caps[w] & CAP_TOP:
                    gaps.append(np.where(rho < radius[w], height[w] - h - r, np.inf))
            for g in gaps:
                bad = -g > OVERLAP_TOLERANCE * r
                if bad.any():
                    raise ValueError(f"{int(bad.sum())} spheres penetrate wall {w} by more than "
                                     f"{OVERLAP_TOLERANCE:.0%} of their radius, e.g. ids "
                                     f"{seen[bad][:10].tolist()}")

    def compile(self, dt: float, theta: float = 0.5, tol: float = 1e-4, max_iter: int = 1000,
                relax: float = 1.0, alert: float | None = None, skin: float | None = None,
                threads: int = 1, anderson: int = 0, hot_sweeps: int = 0,
                max_overlap: float = MAX_OVERLAP, chain_solve: bool = False,
                natural_residual: bool = False, contact_compliance: float = 0.0,
                overlap_tol: float | None = OVERLAP_TOL, overlap_sweeps: int = 50):
        """Freeze the scene into a :class:`Model` and its initial :class:`State`.

        Parameters
        ----------
        dt : float [s], > 0
        theta : float in [0.5, 1]
        tol : float > 0 ; max_iter : int >= 1 ; relax : float in (0, 2)
            NLGS tolerance (Quad norm), sweep cap and relaxation ω (> 1: over-relaxation,
            :attr:`engine.model.Options.relax`).
        max_overlap : float > 0
            Largest contact overlap, as a fraction of the smaller radius, past which a run
            stops with an error (:attr:`engine.model.Options.max_overlap`).
        alert, skin : float [m]
            Alert distance (default 0.1 × smallest sphere radius) and Verlet skin (default
            0.5 × smallest radius).
        threads : int in [1, 64]
            NLGS threads (:attr:`engine.model.Options.threads`; 1 = serial, the default).
        anderson : int in [0, 16]
            Depth of the Anderson acceleration of the NLGS sweeps
            (:attr:`engine.model.Options.anderson`).
        hot_sweeps : int in [0, 8]
            Re-sweeps of the contacts that changed most after each full sweep
            (:attr:`engine.model.Options.hot_sweeps`; unmixed: anderson = 0).
        chain_solve : bool
            Solve each wire as one chain in every sweep
            (:attr:`engine.model.Options.chain_solve`; default False).
        natural_residual : bool
            Also report each step's natural-map residual, Siconos's stopping measure
            (:attr:`engine.model.Options.natural_residual`; default False).
        contact_compliance : float in [0, 1]
            ε, the contacts' normal compliance as a fraction of their Delassus diagonal
            (:attr:`engine.model.Options.contact_compliance`; 0, the default: rigid).
        overlap_tol : float in (0, 1] or None ; overlap_sweeps : int >= 1
            The position correction after each step (:mod:`engine.solver.projection`,
            :attr:`engine.model.Options.overlap_tol`; None: none).

        Raises
        ------
        ValueError
            Bad option (field and range named), unknown group names, pairs of groups that
            can touch with no declared law, spheres overlapping by more than 1 % of the
            smaller radius (ids named), spheres penetrating walls (those whose groups
            interact: a sphere may lie behind a wall its group has no law with).
        """
        nb = self.n_bodies
        if nb == 0:
            raise ValueError("the scene has no bodies")
        kind = np.asarray(self._kind, np.int8)
        radius = np.asarray(self._radius, float)
        sphere_ids = np.flatnonzero(kind == SPHERE).astype(np.int32)
        rmin = float(radius[sphere_ids].min()) if sphere_ids.size else 1e-3
        opts = Options(dt=dt, theta=theta, tol=tol, max_iter=max_iter, relax=relax,
                       alert=0.1 * rmin if alert is None else alert,
                       skin=0.5 * rmin if skin is None else skin, gravity=self.gravity,
                       threads=threads, anderson=anderson, hot_sweeps=hot_sweeps,
                       max_overlap=max_overlap, chain_solve=chain_solve,
                       natural_residual=natural_residual,
                       contact_compliance=contact_compliance, overlap_tol=overlap_tol,
                       overlap_sweeps=overlap_sweeps)

        dof = np.where(kind == SPHERE, FREE, IMPOSED).astype(np.int8)
        line = np.zeros((nb, 3))
        mass = np.asarray(self._mass, float).copy()
        axis = np.asarray(self._axis, float).reshape(nb, 3)
        for b in self._fixed:
            dof[b] = IMPOSED
        vel = np.asarray(self._vel, float).reshape(nb, 3).copy()
        spin = np.asarray(self._spin, float).reshape(nb, 3).copy()
        for b, d in self._drives.items():
            if d.kind == "velocity":
                dof[b] = IMPOSED
                vel[b] = _vec3(d.at(0.0), f"velocity drive on body {b}")
                spin[b] = 0.0
            elif kind[b] != SPHERE:
                dof[b] = LINE
                mass[b] = self._drive_mass[b]
                if d.kind == "pressure":
                    line[b] = axis[b]
                else:
                    f0 = _vec3(d.at(0.0), f"force drive on body {b}")
                    if not np.any(f0):
                        raise ValueError(f"force drive on wall {b} is zero at t=0; it sets the line of motion")
                    line[b] = f0 / np.linalg.norm(f0)
        for b in self._fixed:
            vel[b] = 0.0
            spin[b] = 0.0

        names, pair_law, law_code, law_param, law_objs = self._see_table(dof)
        pos = np.asarray(self._pos, float).reshape(nb, 3)
        height = np.asarray(self._height, float)
        caps = np.asarray(self._caps, np.int8)
        self._check_overlaps(pos, radius, kind, axis, height, caps, sphere_ids,
                             np.asarray(self._group, np.int16), pair_law)

        link_i = np.asarray([lk[0] for lk in self._links], np.int32)
        link_j = np.asarray([lk[1] for lk in self._links], np.int32)
        lp = np.asarray([lk[2].params() for lk in self._links], float).reshape(-1, _laws.N_PARAM)
        link_pos = np.asarray([lk[3] for lk in self._links], np.int64)
        g0 = np.linalg.norm(pos[link_i] - pos[link_j], axis=1) if len(self._links) else np.zeros(0)
        given = np.asarray([lk[5] for lk in self._links], float)
        ref = np.where(np.isnan(given), g0 / (1.0 + lp[:, 1]), given) if len(self._links) \
            else np.zeros(0)
        body_next = -np.ones(nb, np.int32)      # the linked pairs that get no contact
        apart = np.asarray([not lk[4] for lk in self._links], bool)
        if len(self._links) and not apart.all():
            # a link that pulls its beads closer than the contact lets them would fight it
            bad = np.flatnonzero(~apart & (ref < (radius[link_i] + radius[link_j])
                                           * (1 - 1e-9)))
            if bad.size:
                raise ValueError(
                    f"neighbour_contact: the reference length g(0)/(1+ε₀) of links "
                    f"{bad[:10].tolist()} is below the sum of their beads' radii (down to "
                    f"{(ref[bad] / (radius[link_i] + radius[link_j])[bad]).min():.4f} of it): "
                    f"the link would pull its beads into their contact; lower the prestrain "
                    f"or space the beads")
        body_next[link_i[apart]] = link_j[apart]
        inertia = np.full(nb, np.inf)
        inertia[sphere_ids] = 0.4 * mass[sphere_ids] * radius[sphere_ids] ** 2
        body_dyn = pack_body_dyn(kind, mass, inertia, radius, dof, line)
        model = Model(
            body_kind=kind, body_group=np.asarray(self._group, np.int16), body_radius=radius,
            body_mass=mass, body_inertia=inertia, body_axis=axis, body_height=height,
            body_caps=caps, body_dof=dof, body_line=line, body_dyn=body_dyn,
            sphere_ids=sphere_ids, wall_ids=np.flatnonzero(kind != SPHERE).astype(np.int32),
            group_names=tuple(names), pair_law=pair_law, law_code=law_code, law_param=law_param,
            laws=law_objs, drives=tuple(self._drives[b] for b in sorted(self._drives)),
            link_i=link_i, link_j=link_j,
            link_law=np.asarray([lk[2].code for lk in self._links], np.int16),
            link_ref_length=ref, link_stiffness=lp[:, 0].copy(),
            link_max_tension=lp[:, 2].copy(), link_unilateral=lp[:, 3].astype(np.int8),
            link_order=np.argsort(link_pos % 2, kind="stable").astype(np.int32),
            body_next=body_next, options=opts)
        nl = link_i.shape[0]
        state = State(position=pos.copy(), vel6=np.ascontiguousarray(np.hstack([vel, spin])),
                      link_i=link_i.copy(), link_j=link_j.copy(), link_impulse=np.zeros(nl),
                      link_broken=np.zeros(nl, bool), link_normal=np.zeros((nl, 3)),
                      link_gap=np.zeros(nl), link_excluded_next=body_next.copy())
        return model, state


__all__ = ["Scene", "OVERLAP_TOLERANCE"]
