"""The mutable part of a simulation, updated in place by :func:`engine.step`.

Every array is a plain numpy array in SI units.  Contact data live in fixed-capacity
buffers with a count; a kernel that needs more room reports it and the caller grows the
buffer and runs the kernel again, so no contact is ever dropped (jax-md's overflow flag).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class StepStats:
    """What one step reports.

    Attributes
    ----------
    iterations : int
        NLGS sweeps done (0 when there was nothing to solve).
    residual : float
        Final value of the convergence norm (see :func:`engine.solver.nlgs.sweep`) [-].
    converged : bool
        ``residual < tol`` was reached within ``max_iter`` sweeps.
    n_contacts : int
        Active contacts solved in this step.
    rebuilt : bool
        The candidate-pair list was rebuilt in this step.
    late_contacts : int
        Contacts that the free velocities left open but the solved ones closed (a grain
        stopped under a falling one at a large time step): added, and the step solved
        again (:func:`engine.step.step`).  Their sweeps are in ``iterations``.
    max_overlap : float
        Largest overlap of the step's contacts (at the predicted configuration where they
        were detected) / the smaller radius of the two bodies [-] (:mod:`engine.sanity`).
    overlap_pair : (int, int)
        Its two bodies ((-1, -1) without overlap).
    energy_gain : float [J]
        Kinetic energy of the free spheres after the step minus that of their free motion:
        the work of the reactions, <= 0 for contacts and rigid links
        (:func:`engine.sanity.reaction_gain`).
    free_energy : float [J]
        Kinetic energy of the free spheres' free motion (the reference of ``energy_gain``).
    natural_residual : float
        Siconos's natural-map residual of the solved step (:mod:`engine.solver.residual`)
        when ``Options.natural_residual`` is on, else None [-].
    """

    iterations: int = 0
    residual: float = 0.0
    converged: bool = True
    n_contacts: int = 0
    rebuilt: bool = False
    late_contacts: int = 0
    max_overlap: float = 0.0
    overlap_pair: tuple = (-1, -1)
    energy_gain: float = 0.0
    free_energy: float = 0.0
    natural_residual: float | None = None

    def __post_init__(self):
        self.overlap_pair = tuple(int(x) for x in self.overlap_pair)   # a file gives a list


class ContactBuffers:
    """Fixed-capacity contact arrays (capacity ``cap``), the first ``count`` rows valid.

    Attributes
    ----------
    i, j : (cap,) int32
        Candidate body (always a sphere) and antagonist body (sphere or wall).
    sub : (cap,) int8
        Which surface of the antagonist: 0 plane / sphere / cylinder side, 1 cylinder
        bottom cap, 2 cylinder top cap.
    key : (cap,) int64
        Identity of the contact across steps, for the warm start.
    frame : (cap, 9) float64 [-]
        Local frame rows n, t, s; n points from j to i.
    gap : (cap,) float64 [m]
        Gap at the θ-predicted configuration (negative = overlap).
    mu : (cap,) float64 [-]
        Friction coefficient of the contact's law.
    ri, rj : (cap,) float64 [m]
        Lever arms (radii) of i and j (0 for walls).
    w : (cap, 4) float64
        W_nn, W_tt [1/kg] (diagonal of the Delassus block W_αα = H_αᵀ M⁻¹ H_α in (n, t, s),
        W_ss = W_tt) and their inverses [kg] (0 when both bodies are immobile).
    gterm : (cap,) float64 [m/s]
        max(gap, 0)/h, the gap term of the velocity Signorini condition.
    impulse : (cap, 3) float64 [N·s]
        Impulse on i in the local frame (n, t, s); -impulse acts on j.
    """

    _FIELDS = {
        "i": (np.int32, ()), "j": (np.int32, ()), "sub": (np.int8, ()), "key": (np.int64, ()),
        "frame": (np.float64, (9,)), "gap": (np.float64, ()), "mu": (np.float64, ()),
        "ri": (np.float64, ()), "rj": (np.float64, ()), "w": (np.float64, (4,)),
        "gterm": (np.float64, ()), "impulse": (np.float64, (3,)),
    }

    def __init__(self, cap: int):
        self.count = 0
        self.n_pair = 0  # the first n_pair contacts are sphere–sphere, the rest sphere–wall
        self.allocate(cap)

    def allocate(self, cap: int) -> None:
        """(Re)allocate every array with capacity ``cap`` (content is discarded)."""
        self.cap = int(cap)
        for name, (dtype, shape) in self._FIELDS.items():
            setattr(self, name, np.zeros((self.cap,) + shape, dtype=dtype))


class Workspace:
    """What a step keeps between calls to save work, and nothing else: never saved in a
    file, and a copy or a pickle of it is empty (each field is rebuilt when missing, with
    the same result).

    Attributes
    ----------
    free_vel : (nb, 6) float64 or None
        The free velocities of the last step (Eq. 4), before its solve: kept for the late
        contact check (:func:`engine.contact.late_contacts_possible`).
    sphere_order : (pairs_ref, (n_spheres,) int32) or None
        The spheres in the cell order of the broadphase build at ``pairs_ref`` (the order
        the narrowphase visits sphere–wall pairs in), valid while ``state.pairs_ref`` is
        that array.
    anderson : engine.solver.anderson.Workspace or None
        The Anderson mixing's history buffers (``Options.anderson > 0``).
    projection : tuple of arrays or None
        The position correction's buffers (``Options.overlap_tol``,
        :mod:`engine.solver.projection`): displacements, pseudo-impulses, flags, gaps.
    """

    __slots__ = ("free_vel", "sphere_order", "anderson", "projection")

    def __init__(self):
        self.free_vel = None
        self.sphere_order = None
        self.anderson = None
        self.projection = None

    def __reduce__(self):
        return (Workspace, ())

    def __repr__(self) -> str:
        return "Workspace()"


@dataclass
class State:
    """Mutable state of a simulation.

    Attributes (nb bodies)
    ----------------------
    time : float [s]
    step : int
    position : (nb, 3) float64 [m]
        Sphere centres; for walls the reference point (plane point, cylinder base centre).
    velocity : (nb, 3) float64 [m/s]
        View on the first three columns of ``vel6``.
    spin : (nb, 3) float64 [rad/s]
        View on the last three columns of ``vel6``.
    vel6 : (nb, 6) float64
        Translational and angular velocity packed per body (what the kernels update).
    force : (nb, 3) float64 [N]
        External force applied during the last step (gravity excluded): ``load`` plus the
        force and pressure drives.
    load : (nb, 3) float64 [N]
        External loads set by the user between steps (e.g. the confinement of free-surface
        particles, :class:`engine.drivers.Confinement`); they stay until changed.
    drive_pressure : (nb,) float64 [Pa] or None
        Current pressure of each pressure-driven wall (0 for other bodies), from its
        drive's schedule (:mod:`engine.schedules`) or set by an updater; what the next step
        applies.  None until :func:`engine.schedules.drive_values` makes it (Scene.compile does).
    drive_area : (nb,) float64 [m²] or None
        Current area of each pressure-driven wall (0 elsewhere), likewise.
    contacts_buf : ContactBuffers
        Active contacts of the last step.
    pairs : (cap, 2) int32 ; n_pairs : int
        Candidate sphere–sphere pairs of the broadphase (closer than alert + skin).
    pairs_ref : (nb, 3) float64 [m]
        Positions at the last broadphase build.
    pairs_margin : float [m]
        Surface distance of that build (0: alert + skin, as in files written before it was
        kept); larger when a fast step widened it (:func:`engine.contact.rebuild_pairs`).
    warm_key : (k,) int64 sorted ; warm_impulse : (k, 3) float64 [N·s, global frame]
        Impulses of the previous step, for the warm start.
    stats : StepStats
        What the last step reported.
    link_i, link_j : (nl,) int32
        The beads of each wire link (copies of the model's, for :attr:`links`).
    link_impulse : (nl,) float64 [N·s]
        Impulse of each wire link over the last step, positive in tension (pulls i and j
        together); also the warm start of the next step.
    link_broken : (nl,) bool
        Links broken for good (brittle wires).
    link_normal : (nl, 3) float64 ; link_gap : (nl,) float64 [m]
        Unit vector from j to i and centre distance at the θ-predicted configuration of
        the last step.
    link_excluded_next : (nb,) int32
        ``model.body_next`` with broken links removed: the linked pairs that get no contact.
    last_dt : float [s]
        Length of the last step (0 before the first), to turn impulses into forces.
    time_compensation : float [s]
        Running compensation of the Kahan sum that accumulates ``time``.
    workspace : Workspace
        What a step keeps between calls to save work (not saved; empty in a copy).
    """

    position: np.ndarray
    vel6: np.ndarray
    time: float = 0.0
    step: int = 0
    force: np.ndarray = None
    load: np.ndarray = None
    drive_pressure: np.ndarray = None
    drive_area: np.ndarray = None
    contacts_buf: ContactBuffers = None
    pairs: np.ndarray = None
    n_pairs: int = 0
    pairs_ref: np.ndarray = None
    pairs_margin: float = 0.0
    warm_key: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    warm_impulse: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    stats: StepStats = field(default_factory=StepStats)
    link_i: np.ndarray = None
    link_j: np.ndarray = None
    link_impulse: np.ndarray = None
    link_broken: np.ndarray = None
    link_normal: np.ndarray = None
    link_gap: np.ndarray = None
    link_excluded_next: np.ndarray = None
    last_dt: float = 0.0
    time_compensation: float = 0.0
    workspace: Workspace = field(default_factory=Workspace, repr=False, compare=False)

    def __post_init__(self):
        nb = self.position.shape[0]
        for name, shape, dtype in (("link_i", (0,), np.int32), ("link_j", (0,), np.int32),
                                   ("link_impulse", (0,), float), ("link_broken", (0,), bool),
                                   ("link_normal", (0, 3), float), ("link_gap", (0,), float)):
            if getattr(self, name) is None:
                setattr(self, name, np.zeros(shape, dtype))
        if self.link_excluded_next is None:
            self.link_excluded_next = -np.ones(nb, np.int32)
        if self.force is None:
            self.force = np.zeros((nb, 3))
        if self.load is None:
            self.load = np.zeros((nb, 3))
        if self.contacts_buf is None:
            self.contacts_buf = ContactBuffers(max(64, 4 * nb))
        if self.pairs is None:
            self.pairs = np.zeros((max(64, 8 * nb), 2), np.int32)

    # -- views --------------------------------------------------------------------------
    @property
    def velocity(self) -> np.ndarray:
        return self.vel6[:, :3]

    @velocity.setter
    def velocity(self, value) -> None:
        self.vel6[:, :3] = value

    @property
    def spin(self) -> np.ndarray:
        return self.vel6[:, 3:]

    @spin.setter
    def spin(self, value) -> None:
        self.vel6[:, 3:] = value

    @property
    def links(self) -> "LinksView":
        """Wire links with their length and tension (see :class:`LinksView`)."""
        return LinksView(self)

    @property
    def contacts(self) -> "ContactsView":
        """Active contacts of the last step, in the global frame (see :class:`ContactsView`)."""
        return ContactsView(self)

    def copy(self) -> "State":
        """A deep copy (for restarts and comparisons), with an empty :class:`Workspace`."""
        import copy

        return copy.deepcopy(self)


class ContactsView:
    """Read-only view of the active contacts of the last step (k contacts).

    Attributes
    ----------
    i, j : (k,) int32
        The two bodies; the force acts on i, its opposite on j.
    normal : (k, 3) [-]
        Unit normal from j to i.
    point : (k, 3) [m]
        Contact point (middle of the gap, on the normal line through i's centre).
    gap : (k,) [m]
        Gap at the θ-predicted configuration of the step (negative = overlap).
    impulse : (k, 3) [N·s]
        Impulse on i in the local frame (n, t, s).
    force : (k, 3) [N]
        Mean force on i over the step, global frame (impulse / h).
    normal_force : (k,) [N]
        Normal component of ``force`` (>= 0, compression).
    """

    def __init__(self, state: State):
        c = state.contacts_buf
        k = c.count
        self.i = c.i[:k].copy()
        self.j = c.j[:k].copy()
        self.sub = c.sub[:k].copy()
        fr = c.frame[:k]
        self.normal = fr[:, 0:3].copy()
        self.gap = c.gap[:k].copy()
        self.impulse = c.impulse[:k].copy()
        self.impulse_global = (self.impulse[:, 0:1] * fr[:, 0:3] + self.impulse[:, 1:2] * fr[:, 3:6]
                               + self.impulse[:, 2:3] * fr[:, 6:9])
        ri = c.ri[:k]
        self.point = state.position[self.i] - (ri + 0.5 * self.gap)[:, None] * self.normal
        if np.any(c.rj[:k] == 0.0):  # walls: the point lies on the wall surface
            wall = c.rj[:k] == 0.0
            self.point[wall] = (state.position[self.i[wall]]
                                - (ri[wall] + self.gap[wall])[:, None] * self.normal[wall])
        self.dt = state.last_dt

    def __len__(self) -> int:
        return int(self.i.shape[0])

    @property
    def force(self) -> np.ndarray:
        if not self.dt:
            raise ValueError("contact forces need the step length; run at least one step first")
        return self.impulse_global / self.dt

    @property
    def normal_force(self) -> np.ndarray:
        if not self.dt:
            raise ValueError("contact forces need the step length; run at least one step first")
        return self.impulse[:, 0] / self.dt


class LinksView:
    """Read-only view of the wire links (l links), tension positive.

    Attributes
    ----------
    i, j : (l,) int32
        The two beads of each link (j follows i along the wire).
    length : (l,) [m]
        Current centre distance ‖x_i − x_j‖.
    tension : (l,) [N]
        Mean tension over the last step (impulse / h), > 0 in tension, < 0 for a
        compressed rod; 0 for a broken link.
    broken : (l,) bool
    """

    def __init__(self, state: State):
        self.i = state.link_i.copy()
        self.j = state.link_j.copy()
        d = state.position[self.i] - state.position[self.j]
        self.length = np.sqrt((d * d).sum(axis=1))
        self.tension = state.link_impulse / state.last_dt if state.last_dt else np.zeros(len(self.i))
        self.broken = state.link_broken.copy()

    def __len__(self) -> int:
        return int(self.i.shape[0])
