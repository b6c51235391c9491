"""Parallel NLGS (Options.threads, engine.solver.parallel) and the cache-friendly layout of
the serial sweep (engine.solver.nlgs.layout, the broadphase's cell order)."""
import numpy as np
import pytest

from engine import Scene, laws, step
from engine.model import Options
from engine.solver import nlgs

from tests.helpers import G, assert_option_refused, box_pile, same_converged_step, wire_under_lid


def fcc_packing(cells=(5, 5, 4), seed=7, shuffle=True, mu=0.3, tol=1e-10, max_iter=20000,
                threads=1):
    """Slightly compressed FCC packing on the floor of a box (every lattice neighbour is a
    contact), bodies numbered at random when ``shuffle``."""
    rng = np.random.default_rng(seed)
    r0 = 1e-3
    d = 2.0 * r0 * (1.0 - 0.0025)
    a = np.sqrt(2.0) * d
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    g = np.stack(np.meshgrid(*[np.arange(k) for k in cells], indexing="ij"), -1).reshape(-1, 1, 3)
    c = ((g + basis[None]) * a).reshape(-1, 3) + r0
    if shuffle:
        c = c[rng.permutation(len(c))]
    r = r0 * (1.0 + rng.uniform(-0.002, 0.002, len(c)))
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(c, r, density=2650.0)
    hi = c.max(axis=0) + r0
    hi[2] *= 3.0
    s.add_box((0, 0, 0), hi, group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=mu))
    s.interact("sand", "wall", laws.Coulomb(mu=mu))
    return s.compile(dt=1e-4, tol=tol, max_iter=max_iter, threads=threads)


# -- option ------------------------------------------------------------------------------
def test_serial_is_the_default():
    assert Options(dt=1e-3, alert=0.0, skin=1e-3).threads == 1
    model, _ = fcc_packing(cells=(2, 2, 2))
    assert model.options.threads == 1


@pytest.mark.parametrize("bad", [0, -1, 65, 2.5, "two", True, None])
def test_threads_is_validated(bad):
    assert_option_refused("threads", bad)
    model, _ = fcc_packing(cells=(2, 2, 2))
    with pytest.raises(ValueError, match="threads"):
        model.with_options(threads=bad)


# -- serial layout: a change of memory layout only ---------------------------------------
def test_local_layout_is_bit_identical(monkeypatch):
    """The serial sweep on the contact-ordered local copy of the body data gives exactly
    the same bits as on the global arrays."""
    model, state = fcc_packing(tol=1e-4, max_iter=300)
    other = state.copy()
    monkeypatch.setattr(nlgs, "LAYOUT_MIN_BODIES", 10**9)  # global arrays
    for _ in range(5):
        a = step(model, state)
    monkeypatch.setattr(nlgs, "LAYOUT_MIN_BODIES", 0)  # local layout
    for _ in range(5):
        b = step(model, other)
    assert (a.iterations, a.residual) == (b.iterations, b.residual)
    assert np.array_equal(state.vel6, other.vel6)
    assert np.array_equal(state.position, other.position)
    k = state.contacts_buf.count
    assert np.array_equal(state.contacts_buf.impulse[:k], other.contacts_buf.impulse[:k])


def test_cell_order_cache_is_a_function_of_the_last_build():
    """The sphere order of the narrowphase's wall loop, recomputed after a copy or a pickle
    (the state's workspace comes out empty), is that of the build: the run continues bit
    for bit."""
    import pickle

    model, state = fcc_packing(tol=1e-4, max_iter=300)
    for _ in range(3):
        step(model, state)
    assert state.workspace.sphere_order is not None and state.workspace.free_vel is not None
    other = state.copy()
    assert other.workspace.sphere_order is None and other.workspace.free_vel is None
    assert pickle.loads(pickle.dumps(state)).workspace.sphere_order is None
    for _ in range(3):
        step(model, state)
        step(model, other)
    assert np.array_equal(state.vel6, other.vel6)


# -- parallel: same physics --------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("at", [150, 700])
@pytest.mark.parametrize("threads", [2, 3, 4])
def test_parallel_step_matches_serial_within_tolerance(pile_states, threads, at):
    """From the same state, one converged step (tol 1e-10) on ``threads`` domains gives the
    serial velocities and per-body contact impulses to the solver tolerance, in about the
    same number of sweeps."""
    model, states = pile_states
    tight = model.with_options(tol=1e-10, max_iter=50000)
    par = tight.with_options(threads=threads)
    a, b, a_state, b_state = same_converged_step(tight, par, states[at])
    assert b.iterations <= 1.5 * a.iterations + 10
    # same contacts, in the same buffer order
    k = a_state.contacts_buf.count
    assert k > 100
    assert np.array_equal(a_state.contacts_buf.key[:k], b_state.contacts_buf.key[:k])


@pytest.mark.slow
def test_parallel_contact_impulses_equal_serial_on_an_isostatic_column():
    """A column of spheres on a floor (unique impulses): every contact impulse equals the
    serial one within the solver tolerance."""
    r = 0.005
    out = []
    for threads in (1, 2):
        s = Scene(gravity=(0, 0, -G))
        s.add_plane(group="floor")
        s.add_spheres([[0, 0, r + 2 * r * k] for k in range(12)], r, density=2650.0)
        s.interact("sand", "sand", laws.Coulomb(mu=0.5))
        s.interact("sand", "floor", laws.Coulomb(mu=0.5))
        model, state = s.compile(dt=1e-4, tol=1e-10, max_iter=20000, threads=threads)
        for _ in range(50):
            st = step(model, state)
            assert st.converged
        c = state.contacts
        order = np.argsort(c.i * 100 + c.j)
        out.append(c.impulse[order])
    np.testing.assert_allclose(out[1], out[0], rtol=1e-8, atol=1e-8 * np.abs(out[0]).max())


@pytest.mark.slow
def test_parallel_pile_floor_reaction_is_the_weight():
    """A 300-grain pile deposited on 2 threads: at rest the floor carries the whole weight
    (rel 1e-3, as in test_contact_physics)."""
    model, state, box, _ = box_pile(300, 12e-3, tol=1e-6, max_iter=2000)
    model = model.with_options(threads=2)
    floor = box[0]
    ke = []
    for _ in range(800):
        st = step(model, state)
        v = state.velocity[model.sphere_ids]
        ke.append(0.5 * model.body_mass[model.sphere_ids] @ (v * v).sum(1))
    assert st.converged
    assert ke[-1] < 1e-6 * max(ke)  # at rest
    c = state.contacts
    weight = model.body_mass[model.sphere_ids].sum() * G
    assert c.normal_force[c.j == floor].sum() == pytest.approx(weight, rel=1e-3)


@pytest.mark.slow
def test_parallel_is_deterministic():
    model, state = fcc_packing(tol=1e-4, max_iter=300, threads=2)
    other = state.copy()
    for _ in range(3):
        step(model, state)
        step(model, other)
    assert np.array_equal(state.vel6, other.vel6)


@pytest.mark.slow
@pytest.mark.parametrize("solver", [{}, dict(hot_sweeps=2), dict(anderson=4)])
@pytest.mark.parametrize("threads", [2, 3])
def test_threaded_phases_equal_the_phases_in_turn(monkeypatch, threads, solver):
    """A pass below PARALLEL_SWEEP_MIN_CONTACTS runs its groups in turn on one thread; above
    it, one group per thread.  The groups of a phase share no body, so both give the same
    bits (velocities, contact and link impulses, sweeps), for the plain, hot and
    Anderson-mixed sweeps, on a packing and on the wire-and-lid scene.  Few sweeps: on
    these small scenes each threaded phase costs 0.1-2 ms with numba's TBB layer here."""
    from engine.solver import parallel

    opts = dict(tol=1e-12, max_iter=40, threads=threads)
    scenes = [lambda: fcc_packing(cells=(4, 4, 3), **opts),
              lambda: wire_under_lid(**opts)[:2]]
    for make in scenes:
        runs = []
        for min_par in (0, 10 ** 9):
            monkeypatch.setattr(parallel, "PARALLEL_SWEEP_MIN_CONTACTS", min_par)
            model, state = make()
            model = model.with_options(**solver)
            sweeps = [step(model, state).iterations for _ in range(3)]
            runs.append((sweeps, state))
        (sa, a), (sb, b) = runs
        assert sa == sb and min(sa) > 10
        assert np.array_equal(a.vel6, b.vel6)
        assert np.array_equal(a.contacts.impulse, b.contacts.impulse)
        assert np.array_equal(a.link_impulse, b.link_impulse)


@pytest.mark.parametrize("T", [2, 3])
def test_partition_puts_contacts_with_immobile_bodies_last(T):
    """partition: every contact in exactly one group; inside group g, start[g]..mid[g] are
    the contacts between two mobile bodies (swept without the guard) and mid[g]..start[g+1]
    the ones touching a fixed wall or fixed bead, each part in the buffer's order.  The
    wire-under-lid scene has both kinds, and a driven lid (shared group)."""
    from engine.model import DYN_INV_INERTIA, DYN_INV_MASS
    from engine.solver.parallel import partition

    model, state, lid = wire_under_lid(tol=1e-4, max_iter=300)
    for _ in range(3):
        step(model, state)
    c = state.contacts
    ci, cj = c.i.astype(np.int32), c.j.astype(np.int32)
    n, dyn = len(ci), model.body_dyn
    group, order = np.empty(n, np.int32), np.empty(n, np.int32)
    start, mid = np.empty(2 * T + 1, np.int64), np.empty(2 * T, np.int64)
    partition(n, T, ci, cj, dyn, dyn.shape[0], group, start, order, mid)
    assert np.array_equal(np.sort(order), np.arange(n))
    immobile = (dyn[:, DYN_INV_MASS] == 0.0) & (dyn[:, DYN_INV_INERTIA] == 0.0)
    touches = immobile[ci] | immobile[cj]
    assert touches.sum() > 0 and (~touches).sum() > 0
    for g in range(2 * T):
        part = order[start[g]:start[g + 1]]
        assert (group[part] == g).all()
        head, tail = order[start[g]:mid[g]], order[mid[g]:start[g + 1]]
        if g < 2 * T - 1:  # the shared group runs on one thread, with the full kernel
            assert not touches[head].any() and touches[tail].all()
        assert (np.diff(head) > 0).all() and (np.diff(tail) > 0).all()
    assert (group[cj == lid] == 2 * T - 1).all()


def _heap_on_fixed_beads(seed=3):
    """Grains on a floor of fixed beads (as the slope test's), spread by a few steps: many
    contacts touch a fixed sphere, none a wall."""
    from engine.experiments.slope import hex_floor

    rng = np.random.default_rng(seed)
    r = 2.5e-4
    floor = hex_floor(r, 6e-3)
    xy = rng.uniform(-4e-3, 4e-3, (900, 2))
    z = 3.2 * r + rng.uniform(0.0, 3e-3, 900)   # floor beads centred at z = r
    keep = np.ones(900, bool)  # drop the grains that overlap one placed before them
    pts = np.column_stack([xy, z])
    for a in range(900):
        if keep[a] and a:
            d = np.linalg.norm(pts[:a][keep[:a]] - pts[a], axis=1)
            keep[a] = d.min() > 2.0 * r
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts[keep], r, density=2650.0)
    rubber = s.add_spheres(floor, r, density=1000.0, group="rubber")
    s.fix(rubber)
    s.interact("rubber", "rubber", None)
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.interact("sand", "rubber", laws.Coulomb(mu=0.8))
    model, state = s.compile(dt=1e-4, tol=1e-4, max_iter=200)
    for _ in range(150):
        step(model, state)
    return model, state


def _box_packing():
    model, state = fcc_packing(cells=(6, 6, 5), tol=1e-4, max_iter=200)
    step(model, state)
    return model, state


@pytest.mark.parametrize("scene", [_heap_on_fixed_beads, _box_packing])
def test_partition_balances_the_interiors(scene):
    """The domains are cut where the contacts the bodies touch reach half, each contact
    counted half on each body or whole on its mobile one.  Then the two interiors (swept at
    once) differ by less than one body's share: at most twice the largest number of
    contacts of one mobile body (without a driven wall, whose contacts are shared).  On a
    heap on fixed beads and on a packing in a box.  Before 2026-12-05 the contacts with an
    immobile body were not counted, and on the paper-scale slope spread on its floor the
    interiors were 33 000 and 20 000 contacts (docs/speed.md)."""
    from engine.model import DYN_INV_MASS
    from engine.solver.kernels import layout
    from engine.solver.parallel import partition

    model, state = scene()
    c = state.contacts
    n, nb, T = len(c.i), model.n_bodies, 2
    fixed = model.body_dyn[:, DYN_INV_MASS] == 0.0
    ci, cj = c.i.astype(np.int32), c.j.astype(np.int32)
    on_floor = fixed[ci] ^ fixed[cj]
    assert on_floor.sum() > 0.05 * n, "the scene must have contacts with immobile bodies"
    loc, perm = np.full(nb, -1, np.int32), np.empty(nb, np.int32)
    li, lj = np.empty(n, np.int32), np.empty(n, np.int32)
    k = layout(n, ci, cj, 0, ci[:0], cj[:0], loc, perm, li, lj, li[:0], lj[:0])
    group, order = np.empty(n, np.int32), np.empty(n, np.int32)
    start, mid = np.empty(2 * T + 1, np.int64), np.empty(2 * T, np.int64)
    partition(n, T, li, lj, model.body_dyn[perm[:k]], k, group, start, order, mid)
    sizes = np.diff(start)
    solved = ~(fixed[ci] & fixed[cj])
    coordination = np.bincount(np.concatenate([ci[solved], cj[solved]]), minlength=nb)
    assert sizes[3] == 0                          # no shared contact: no driven wall
    assert sizes.sum() == n
    most = coordination[~fixed].max()               # (a wall touches many: not a body's share)
    assert abs(int(sizes[0]) - int(sizes[1])) <= 2 * most, sizes


@pytest.mark.slow
def test_parallel_with_wire_and_driven_wall():
    """Links (swept on one thread after the contacts) and a pressure-driven lid (its
    contacts are shared by every domain) give the serial result within tolerance."""
    res = []
    for threads in (1, 2):
        model, state, lid = wire_under_lid(threads=threads)
        for _ in range(15):
            st = step(model, state)
            assert st.converged
        res.append(state)
    a, b = res
    assert np.sum(a.contacts.j == lid) >= 3 and a.link_impulse.max() > 0.0
    assert np.sum(b.contacts.j == lid) == np.sum(a.contacts.j == lid)
    np.testing.assert_allclose(b.position, a.position, rtol=0, atol=1e-9)
    assert abs(b.position[lid, 2] - a.position[lid, 2]) < 1e-9
    np.testing.assert_allclose(b.link_impulse, a.link_impulse, rtol=0,
                               atol=1e-6 * np.abs(a.link_impulse).max() + 1e-15)


# -- parallel detection: the serial lists exactly ----------------------------------------
def _tube_scene():
    """Grains dropped in a capped cylinder, some touching its side and caps (three
    sub-contacts per sphere–cylinder pair)."""
    rng = np.random.default_rng(11)
    R, H, r = 6e-3, 8.2e-3, 5e-4
    k = np.arange(-6, 7) * 2.02 * r
    pts = np.stack(np.meshgrid(k, k, np.arange(8) * 2.02 * r + r, indexing="ij"), -1)
    pts = pts.reshape(-1, 3)
    pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= R - r]
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, r * rng.uniform(0.9, 1.0, len(pts)), density=2650.0)
    s.add_cylinder(center=(0, 0, 0), axis=(0, 0, 1), radius=R, height=H, group="wall",
                   bottom=True, top=True)
    s.interact("sand", "sand", laws.Coulomb(mu=0.3))
    s.interact("sand", "wall", laws.Coulomb(mu=0.2))
    return s.compile(dt=1e-4, tol=1e-4, max_iter=200)


_SCENES = {
    "fcc box": lambda: fcc_packing(cells=(6, 6, 5), tol=1e-4, max_iter=300),
    "wire under lid": lambda: wire_under_lid(tol=1e-4, max_iter=300)[:2],
    "capped tube": _tube_scene,
}


@pytest.mark.slow
@pytest.mark.parametrize("threads", [2, 3])
@pytest.mark.parametrize("scene", sorted(_SCENES))
def test_parallel_detection_gives_the_serial_lists(monkeypatch, scene, threads):
    """With threads > 1 the broadphase and the narrowphase run in chunks on several threads;
    the candidate pairs and the contacts (every field, in buffer order) are exactly those
    of one thread, including when the buffers start empty and must grow."""
    import engine.contact as contact

    monkeypatch.setattr(contact, "PARALLEL_DETECT_MIN_SPHERES", 0)
    model, state = _SCENES[scene]()
    for _ in range(3):
        step(model, state)
    par = model.with_options(threads=threads)
    assert contact._detect_threads(par) == threads and contact._detect_threads(model) == 1
    for empty in (False, True):
        a, b = state.copy(), state.copy()
        if empty:
            b.pairs = np.zeros((0, 2), np.int32)
            b.contacts_buf.allocate(0)
        contact.rebuild_pairs(model, a)
        contact.rebuild_pairs(par, b)
        assert a.n_pairs == b.n_pairs > 0
        assert np.array_equal(a.pairs[:a.n_pairs], b.pairs[:b.n_pairs])
        contact.detect(model, a)
        contact.detect(par, b)
        ca, cb = a.contacts_buf, b.contacts_buf
        assert (cb.count, cb.n_pair) == (ca.count, ca.n_pair)
        assert ca.count > ca.n_pair > 0  # both kinds present
        for f in ("i", "j", "sub", "key", "frame", "gap", "mu", "ri", "rj"):
            assert np.array_equal(getattr(ca, f)[:ca.count], getattr(cb, f)[:cb.count]), f


def test_parallel_detection_only_above_its_size():
    """A scene below PARALLEL_DETECT_MIN_SPHERES keeps the one-thread detection."""
    import engine.contact as contact

    model, _ = fcc_packing(cells=(2, 2, 2), threads=2)
    assert model.n_spheres < contact.PARALLEL_DETECT_MIN_SPHERES
    assert contact._detect_threads(model) == 1
