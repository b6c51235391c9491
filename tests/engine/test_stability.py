"""Stability at the extremes (issue 9, item 6).

Every parameter at the ends of its range either runs bounded (finite, no energy growth
beyond a stated bound, no escape through walls) or is refused with a ``ValueError`` naming
the field; a step that hits ``max_iter`` is reported (``StepStats.converged``,
``RunSummary.non_converged``, :class:`NonConvergenceWarning`), never hidden.

Ranges: θ ∈ {0.5, 1} (the ``theta`` fixture); h from 1e-7 to 1e-3 s; tol from 1e-2 to
1e-10; wire stiffness from 1e-2 N to 1e8 N and rigid; bead/grain mass ratio down to 1e-3.

Energy.  E = kinetic (translation + rotation) + gravity + elastic energy of the links,
the last taken from the solved tension as T² L / (2k) (the law T = k ε at the predicted
length; the end-of-step length at θ < 1 is a chord, shorter than the predicted one, and
would count a compression the law never saw).  Why E must not grow:

- deposit: contacts are perfectly inelastic (Signorini at velocity level) and frictional,
  walls are fixed, so the exact motion only loses energy; free flight under gravity keeps
  E exactly at θ = ½ and loses m g² (θ − ½) h t at θ > ½ (docs/engine.md).  Allowance:
  rounding, 1e-8 of the initial kinetic energy (seen: at most 2.4e-14 of it).
- swinging chain: no dissipation in the exact motion, so E is kept up to the scheme's
  error.  Allowance: 2 |θ − ½| M g v₀ h (the θ-shift of the reported positions, first
  order, zero at θ = ½) + 10 K₀ (Ω h)² (second order; Ω = 8 rad/s the swing rate)
  + 1e-9 K₀ (rounding).  Seen: at h = 1 ms, 1.0e-2 K₀ at θ = 1 against an allowance of
  0.22 K₀, and 1.25e-4 K₀ at θ = ½ against 6.4e-4 K₀; at h = 1e-5 s, 1.7e-5 K₀ and 1.2e-8 K₀.
"""
import warnings

import numpy as np
import pytest

from engine import Scene, laws, run, step
from engine.step import CallbackWriter, NonConvergenceWarning

G = 9.81
R = 1e-3                       # grain radius [m]
RHO = 2650.0                   # grain density [kg/m³]
R_BEAD, RHO_BEAD = 1e-3, 2000.0


# -- helpers -------------------------------------------------------------------------------
def _tiny_scene():
    s = Scene(gravity=(0, 0, -G))
    s.add_plane(group="wall")
    s.add_spheres([[0.0, 0.0, R]], R, density=RHO)
    s.interact("sand", "wall", laws.Coulomb(mu=0.3))
    return s


def _energy(model, state):
    """Kinetic + gravity + elastic (T² L / 2k) energy of every sphere and link [J]."""
    ids = model.sphere_ids
    m, inertia = model.body_mass[ids], model.body_inertia[ids]
    e = (0.5 * m @ (state.velocity[ids] ** 2).sum(1) + 0.5 * inertia @ (state.spin[ids] ** 2).sum(1)
         + G * m @ state.position[ids, 2])
    if model.n_links:
        k = model.link_stiffness
        el = np.isfinite(k)
        if el.any():
            T = state.links.tension[el]
            e += np.sum(T ** 2 * model.link_ref_length[el] / (2 * k[el]))
    return float(e)


def _kinetic(model, state):
    ids = model.sphere_ids
    return float(0.5 * model.body_mass[ids] @ (state.velocity[ids] ** 2).sum(1))


class _Watch:
    """Writer recording, after every step, the step's stats, the energy and whether all
    positions and velocities are finite (it reads the state, never writes it)."""

    def __init__(self):
        self.stats, self.energy, self.finite, self.min_gap = [], [], [], []

    def __call__(self, model, state):
        self.stats.append((state.step, state.stats))
        self.energy.append(_energy(model, state))
        self.finite.append(bool(np.isfinite(state.position).all() and np.isfinite(state.vel6).all()))
        g = state.contacts.gap
        self.min_gap.append(float(g.min()) if g.size else np.inf)


def _run_watched(model, state, steps):
    """run() with a recording writer; returns (summary, watch, warnings caught)."""
    w = _Watch()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        summary = run(model, state, steps, writers=[CallbackWriter(w, 1)], progress=False)
    return summary, w, caught


def _assert_non_convergence_reported(model, summary, watch, caught):
    """Every step that stopped at max_iter is listed by the run, and only those; a run with
    any such step warns with NonConvergenceWarning and says so in its summary."""
    tol, cap = model.options.tol, model.options.max_iter
    hit = []
    for n, st in watch.stats:
        assert st.converged == (st.residual < tol)
        if not st.converged:
            # it stopped because of the cap, not silently early (a step that solved again
            # for late contacts counts the sweeps of every solve, the last one hitting it)
            assert st.iterations == cap if st.late_contacts == 0 else st.iterations >= cap
            hit.append(n)
    assert summary.non_converged == hit
    warned = [c for c in caught if issubclass(c.category, NonConvergenceWarning)]
    if hit:
        assert warned and "did NOT converge" in str(warned[0].message)
        assert "did NOT converge" in str(summary)
    else:
        assert not warned and "all steps converged" in str(summary)


# -- refused parameters ----------------------------------------------------------------------
@pytest.mark.parametrize("field, value", [
    ("dt", 0.0), ("dt", -1e-4), ("dt", np.inf), ("dt", np.nan),
    ("theta", 0.49), ("theta", 1.01), ("theta", np.nan),
    ("tol", 0.0), ("tol", -1e-6), ("tol", np.nan), ("tol", np.inf),
    ("max_iter", 0), ("max_iter", 10**9 + 1), ("max_iter", 2**63), ("max_iter", 2**64 + 1),
    ("max_iter", 1e20), ("relax", 0.0), ("relax", 2.0), ("relax", np.nan),
])
def test_option_out_of_range_is_refused_naming_the_field(field, value):
    kw = dict(dt=1e-4, theta=0.5, tol=1e-6, max_iter=100)
    kw[field] = value
    with pytest.raises(ValueError, match=field):
        _tiny_scene().compile(**kw)


@pytest.mark.parametrize("make, field", [
    (lambda: laws.ElasticWire(stiffness=0.0), "stiffness"),
    (lambda: laws.ElasticWire(stiffness=-1.0), "stiffness"),
    (lambda: laws.ElasticWire(stiffness=np.inf), "stiffness"),   # rigid is RigidWire()
    (lambda: laws.ElasticWire(stiffness=np.nan), "stiffness"),
    (lambda: laws.ElasticRod(stiffness=0.0), "stiffness"),
    (lambda: laws.ElasticWire(stiffness=1.0, prestrain=-1.0), "prestrain"),
    (lambda: laws.RigidWire(prestrain=np.nan), "prestrain"),
    (lambda: laws.BrittleElasticWire(stiffness=1.0, max_tension=0.0), "max_tension"),
], ids=["k=0", "k<0", "k=inf", "k=nan", "rod k=0", "prestrain=-1", "prestrain=nan",
        "max_tension=0"])
def test_wire_law_out_of_range_is_refused_naming_the_field(make, field):
    with pytest.raises(ValueError, match=field):
        make()


@pytest.mark.parametrize("field, value", [("radius", 0.0), ("radius", np.nan),
                                          ("density", 0.0), ("density", -1.0)])
def test_bead_size_or_density_out_of_range_is_refused(field, value):
    kw = dict(radius=R_BEAD, density=RHO_BEAD)
    kw[field] = value
    s = Scene()
    with pytest.raises(ValueError, match=field):
        s.add_wire([[0, 0, 0], [3e-3, 0, 0]], law=laws.RigidWire(), **kw)


def test_extreme_but_valid_options_are_accepted():
    for kw in (dict(dt=1e-7, tol=1e-10, theta=0.5), dict(dt=1e-3, tol=1e-2, theta=1.0),
               dict(dt=1e-7, tol=1e-2, theta=1.0, max_iter=1)):
        model, _ = _tiny_scene().compile(**kw)
        for k, v in kw.items():
            assert getattr(model.options, k) == v


# -- max_iter hit: reported ------------------------------------------------------------------
def _packed_deposit(theta, dt, tol, max_iter, n=3, v_rms=0.05, seed=0):
    """n³ equal grains (r = 1 mm) on a simple cubic lattice, every neighbour touching (gap
    0), in a box whose floor and walls touch the outer grains, with random velocities of
    ``v_rms`` [m/s] per component: every contact is active from the first step."""
    rng = np.random.default_rng(seed)
    g = R + 2 * R * np.arange(n)
    X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, R, density=RHO, velocities=rng.normal(0.0, v_rms, pts.shape))
    box = s.add_box((0, 0, 0), (2 * R * n, 2 * R * n, 0.1), group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=0.4))
    s.interact("sand", "wall", laws.Coulomb(mu=0.4))
    model, state = s.compile(dt=dt, theta=theta, tol=tol, max_iter=max_iter)
    return model, state, box


def test_max_iter_hit_is_reported_by_step_and_run(theta):
    """tol = 1e-10 with max_iter = 3 on 27 touching grains: every step stops at the cap;
    step() says converged=False, run() lists the steps and warns."""
    model, state, _ = _packed_deposit(theta, 1e-4, 1e-10, 3)
    st = step(model, state)
    assert not st.converged and st.iterations == 3 and st.residual >= 1e-10
    with pytest.warns(NonConvergenceWarning, match="did NOT converge") as rec:
        summary = run(model, state, 20, progress=False)
    assert summary.non_converged == list(range(2, 22))
    assert summary.max_residual >= 1e-10
    said = [str(r.message) for r in rec if r.category is NonConvergenceWarning]
    assert len(said) == 1 and "20 steps did NOT converge" in said[0]


# -- a small deposit -----------------------------------------------------------------------
@pytest.mark.parametrize("tol", [1e-2, 1e-6, 1e-10])
@pytest.mark.parametrize("dt", [1e-7, 1e-5, 1e-3])
def test_packed_deposit_stays_bounded(theta, dt, tol):
    """27 touching grains, random velocities, 150 steps, max_iter 200: finite; E never
    above E₀ + 1e-8 K₀ (inelastic contacts, fixed walls: see the module docstring); no
    grain through the floor or a wall by more than (1 − θ) h max|v₀| + g h² + 1e-4 r (the
    two known first-step and late-activation overlaps, see the xfail tests at the end: seen
    5.8e-5 m at θ = ½, h = 1 ms, max|v₀| = 0.116 m/s; plus what a loose tol leaves: seen
    1.1e-8 m at tol 1e-2); steps at max_iter reported."""
    model, state, box = _packed_deposit(theta, dt, tol, 200)
    e0, k0 = _energy(model, state), _kinetic(model, state)
    slack = (1 - theta) * dt * np.abs(state.velocity).max() + G * dt ** 2 + 1e-4 * R
    summary, w, caught = _run_watched(model, state, 150)
    assert all(w.finite)
    assert max(w.energy) - e0 <= 1e-8 * k0
    p = state.position[model.sphere_ids]
    assert p[:, 2].min() > R - slack
    assert p[:, :2].min() > R - slack and p[:, :2].max() < 6 * R - R + slack
    _assert_non_convergence_reported(model, summary, w, caught)


@pytest.mark.parametrize("tol", [1e-2, 1e-6])
@pytest.mark.parametrize("dt", [1e-4, 1e-3])
def test_falling_deposit_stays_bounded(theta, dt, tol):
    """27 grains dropped from a loose lattice (0.2 r apart, jittered), 300 steps (0.3 s
    at h = 1 ms: they land and pile up; at h = 1 ms a grain moves up to about 2 r per step
    at impact): finite, E ≤ E₀ + 1e-8 K₀ (K₀ the kinetic energy of the 5 cm/s random
    start), nothing through the floor or walls by more than 2 % of r."""
    rng = np.random.default_rng(1)
    n, d = 3, 2.4 * R
    g = 1.2 * R + d * np.arange(n)
    X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel() + 0.5 * R])
    pts[:, :2] += rng.uniform(-0.15 * R, 0.15 * R, (len(pts), 2))
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, R, density=RHO, velocities=rng.normal(0, 0.05, pts.shape))
    s.add_box((0, 0, 0), (n * d, n * d, 0.1), group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=0.4))
    s.interact("sand", "wall", laws.Coulomb(mu=0.4))
    model, state = s.compile(dt=dt, theta=theta, tol=tol, max_iter=300)
    e0, k0 = _energy(model, state), _kinetic(model, state)
    summary, w, caught = _run_watched(model, state, 300)
    assert all(w.finite)
    assert max(w.energy) - e0 <= 1e-8 * k0
    p = state.position[model.sphere_ids]
    assert p[:, 2].min() > 0.98 * R
    assert p[:, :2].min() > 0.98 * R and p[:, :2].max() < n * d - 0.98 * R
    if dt == 1e-3:  # 0.3 s: it has landed, and lost most of its energy
        assert p[:, 2].max() < 2 * n * R + R
        assert w.energy[-1] < e0
    _assert_non_convergence_reported(model, summary, w, caught)


# -- a swinging chain ------------------------------------------------------------------------
CHAIN_LAWS = {
    "rigid-wire": laws.RigidWire(),
    "rigid-rod": laws.RigidRod(),
    "elastic-wire-k1e-2": laws.ElasticWire(stiffness=1e-2),
    "elastic-wire-k1e8": laws.ElasticWire(stiffness=1e8),
    "elastic-rod-k1e-2": laws.ElasticRod(stiffness=1e-2),
    "elastic-rod-k1e8": laws.ElasticRod(stiffness=1e8),
}


@pytest.mark.parametrize("dt", [1e-7, 1e-5, 1e-3])
@pytest.mark.parametrize("law", list(CHAIN_LAWS.values()), ids=list(CHAIN_LAWS))
def test_swinging_chain_stays_bounded(theta, dt, law):
    """A 16-bead chain (r = 1 mm, 2000 kg/m³, links 2.2 mm) swinging at Ω = 8 rad/s about
    its fixed top bead, 400 steps, tol 1e-8: finite, converged, E ≤ E₀ + the allowance of
    the module docstring; the rigid laws keep the length at the predicted configuration
    to 1e-6 (where Eq. 8 imposes it) and a soft wire (k = 1e-2 N: about 13 % strain at
    the top) stretches but stays below 50 %."""
    n, a, omega = 16, 2.2 * R_BEAD, 8.0
    pts = np.column_stack([np.zeros(n), np.zeros(n), -np.arange(n) * a])
    s = Scene(gravity=(0, 0, -G))
    b = s.add_wire(pts, radius=R_BEAD, density=RHO_BEAD, group="wire", law=law)
    s.interact("wire", "wire", None)
    s.fix(b[[0]])
    model, state = s.compile(dt=dt, theta=theta, tol=1e-8, max_iter=5000)
    state.vel6[b, 0] = omega * (-pts[:, 2])
    m = model.body_mass[b]
    e0, k0 = _energy(model, state), _kinetic(model, state)
    v0 = omega * (n - 1) * a
    allowance = 2 * abs(theta - 0.5) * m.sum() * G * v0 * dt + 10 * k0 * (omega * dt) ** 2 + 1e-9 * k0
    worst_pred = 0.0
    e_max = e0
    for k in range(400):
        st = step(model, state)
        assert st.converged
        assert np.isfinite(state.position).all() and np.isfinite(state.vel6).all()
        e_max = max(e_max, _energy(model, state))
        # the first predicted configuration q₀ + (1−θ) h v₀ comes from the initial state
        # (links stretched by O(h²): 8e-6 at θ = ½, h = 1 ms); from the second step on
        # Eq. (8) holds the length there
        if k > 0 and not np.isfinite(law.stiffness_value):
            worst_pred = max(worst_pred, np.abs(state.link_gap / model.link_ref_length - 1).max())
    assert e_max - e0 <= allowance
    strain = state.links.length / model.link_ref_length - 1
    assert worst_pred < 1e-6
    assert np.abs(strain).max() < 0.5


# -- light beads under heavy grains --------------------------------------------------------
def _grains_on_a_wire(ratio, theta, dt, max_iter):
    """A 9-bead elastic wire (r_b = 0.5 mm, k = 1 N) lying on a floor, three grains
    (r = 1 mm) released 0.2 mm above three of its beads; bead density set so that
    bead mass / grain mass = ``ratio``."""
    rb = 0.5e-3
    s = Scene(gravity=(0, 0, -G))
    s.add_plane(group="wall")
    x = np.arange(9) * 2.2 * rb
    beads = s.add_wire(np.column_stack([x, np.zeros(9), np.full(9, rb)]), radius=rb,
                       density=ratio * RHO * (R / rb) ** 3, group="wire",
                       law=laws.ElasticWire(stiffness=1.0))
    gx = np.array([2, 4, 6]) * 2.2 * rb
    grains = s.add_spheres(np.column_stack([gx, np.zeros(3), np.full(3, 2 * rb + R + 0.2e-3)]),
                           R, density=RHO)
    for p in (("sand", "sand"), ("sand", "wall"), ("wire", "sand"), ("wire", "wall"),
              ("wire", "wire")):
        s.interact(*p, laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=dt, theta=theta, tol=1e-6, max_iter=max_iter)
    return model, state, beads, grains


@pytest.mark.parametrize("ratio", [1.0, 1e-2, 1e-3])
@pytest.mark.parametrize("dt", [1e-5, 1e-3])
def test_heavy_grains_on_light_beads_stay_bounded(theta, dt, ratio):
    """Mass ratio bead/grain down to 1e-3, max_iter 20 000 (seen: at most a few hundred
    sweeps on the worst step): every step converges, finite, E ≤ E₀ + 1e-9 M g δ (δ the
    0.2 mm drop, M the grains' mass: inelastic impacts only lose energy), no contact
    overlaps by more than g h² (see the xfail test below), the wire stays on the floor."""
    model, state, beads, grains = _grains_on_a_wire(ratio, theta, dt, 20000)
    e0 = _energy(model, state)
    scale = model.body_mass[grains].sum() * G * 0.2e-3
    summary, w, caught = _run_watched(model, state, 300)
    assert all(w.finite)
    assert not summary.non_converged
    assert max(w.energy) - e0 <= 1e-9 * scale
    # an impact on a bead resting on the floor is activated late (xfail test at the end):
    # the overlap reaches up to g h² (seen 6.0e-6 m at h = 1 ms, every mass ratio), held
    assert min(w.min_gap) > -(G * dt ** 2 + 1e-9)
    assert state.position[beads, 2].min() > 0.5e-3 * 0.99
    assert state.position[grains, 2].min() > R  # they rest on the beads, not on the floor
    _assert_non_convergence_reported(model, summary, w, caught)


def test_light_beads_with_a_low_sweep_cap_report_it():
    """Mass ratio 1e-3 at h = 1 ms with max_iter 500: Gauss–Seidel needs more sweeps on
    the impact steps; those steps are reported, and the result stays bounded (finite, no
    energy growth, overlaps under 20 % of the bead radius: seen 6.3e-5 m = 12.5 % at the
    impact with the cap, 6.0e-6 m with enough sweeps)."""
    model, state, beads, grains = _grains_on_a_wire(1e-3, 0.5, 1e-3, 500)
    e0 = _energy(model, state)
    scale = model.body_mass[grains].sum() * G * 0.2e-3
    summary, w, caught = _run_watched(model, state, 300)
    assert summary.non_converged  # seen: 31 of 300 steps
    _assert_non_convergence_reported(model, summary, w, caught)
    assert all(w.finite)
    assert max(w.energy) - e0 <= 1e-9 * scale
    assert min(w.min_gap) > -0.2 * 0.5e-3


# -- known defects, documented (engine code is not changed here) ---------------------------
@pytest.mark.xfail(strict=True, reason=(
    "first step at theta < 1: q_m = q_0 + (1-theta) h v_0 is taken before any contact is "
    "solved, so a sphere whose initial velocity closes a gap within (1-theta) h ends inside "
    "the wall, and the overlap is then held for good (measured: r = 1 mm touching a plane, "
    "v0 = -0.1 m/s, theta = 0.5, h = 1 ms: overlap 5.0e-5 m = 5 % of r; started 2e-5 m "
    "above: 3.0e-5 m; theta = 1: 0)"))
def test_initial_velocity_into_a_wall_does_not_penetrate():
    s = Scene(gravity=(0, 0, 0))
    s.add_plane(group="wall")
    s.add_spheres([[0.0, 0.0, R]], R, density=RHO, velocities=[[0.0, 0.0, -0.1]])
    s.interact("sand", "wall", laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=1e-3, theta=0.5)
    run(model, state, 5, progress=False)
    assert state.position[1, 2] > R - 1e-9  # docs/engine.md: "an impact does not penetrate"


@pytest.mark.xfail(strict=True, reason=(
    "late activation of an impact on a supported body: the narrowphase's closing test "
    "g + h u_n < 0 uses the free velocities of both bodies, and the free velocity of a bead "
    "resting on the floor includes -g h that the floor contact will cancel, so a grain "
    "falling on it is activated one step late and ends with an overlap up to g h^2, held "
    "for good (measured: 1 mm grain dropped 0.2 mm onto a 0.5 mm bead lying on a plane, "
    "h = 1 ms, theta 0.5 or 1, any bead mass: overlap 6.0e-6 m = 1.2 % of the bead radius)"))
def test_impact_on_a_resting_bead_does_not_penetrate():
    model, state, beads, grains = _grains_on_a_wire(1.0, 1.0, 1e-3, 20000)
    worst = 0.0
    for _ in range(20):
        step(model, state)
        g = state.contacts.gap
        worst = min(worst, g.min() if g.size else 0.0)
    assert worst > -1e-9
