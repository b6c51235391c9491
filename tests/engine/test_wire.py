"""Wire as a chain of beads: the four point–point laws of Eq. (7)-(15) against closed forms."""
import numpy as np
import pytest
from scipy.optimize import curve_fit

from engine import Scene, laws, run, step
from engine.validation import beaded_string
from tests.helpers import G, lattice_pile, settle

R_BEAD, RHO = 1e-3, 2000.0
M_BEAD = RHO * 4 / 3 * np.pi * R_BEAD ** 3


def _wire_scene(centers, law, fixed=(), gravity=(0, 0, -G), closed=False):
    s = Scene(gravity=gravity)
    beads = s.add_wire(centers, radius=R_BEAD, density=RHO, group="wire", law=law, closed=closed)
    s.interact("wire", "wire", None)
    if len(fixed):
        s.fix(beads[list(fixed)])
    return s, beads


# -- statics -------------------------------------------------------------------------------
@pytest.mark.parametrize("law", [laws.ElasticWire(stiffness=0.05), laws.ElasticRod(stiffness=0.05),
                                 laws.ElasticWire(stiffness=0.05, prestrain=0.02)],
                         ids=["elastic-wire", "elastic-rod", "elastic-wire-prestrained"])
def test_elastic_wire_stretched_by_a_hanging_mass(theta, law):
    """Extension = M g L₀ / k (within 1 %), L₀ = g(0)/(1+ε₀) (Eq. 7, 14)."""
    g0 = 10e-3
    s, b = _wire_scene([[0, 0, 0], [0, 0, -g0]], law, fixed=[0])
    model, state = s.compile(dt=1e-4, theta=theta, tol=1e-12)
    settle(model, state, 4000, ids=b[1:])
    L0 = g0 / (1 + law.prestrain)
    ext = state.links.length[0] - L0
    assert model.link_ref_length[0] == pytest.approx(L0, rel=1e-14)
    assert ext == pytest.approx(M_BEAD * G * L0 / law.stiffness, rel=0.01)
    assert state.links.tension[0] == pytest.approx(M_BEAD * G, rel=1e-6)


def _v_chain(n_links, span_ratio):
    """A V-shaped chain of ``n_links`` (even) links of length 2.2 r whose ends are
    ``span_ratio`` × its length apart.  Returns (centres, link length)."""
    a = 2.2 * R_BEAD
    half = n_links // 2
    phi = np.arccos(span_ratio)
    k = np.arange(n_links + 1)
    x = k * a * np.cos(phi)
    z = -(half - np.abs(k - half)) * a * np.sin(phi)
    return np.column_stack([x, np.zeros_like(x), z]), a


def _catenary(x, a, x0, c):
    return a * np.cosh((x - x0) / a) + c


def _hanging_chain(law, theta, n_links=30):
    pts, spacing = _v_chain(n_links, 0.7)
    s, b = _wire_scene(pts, law, fixed=[0, n_links])
    model, state = s.compile(dt=2e-4, theta=theta, tol=1e-10, max_iter=20000)
    settle(model, state, 6000, ids=b[1:-1])
    return model, state, b, spacing


@pytest.mark.parametrize("law", [laws.RigidRod(), laws.RigidWire()], ids=["rigid-rod", "rigid-wire"])
def test_hanging_chain_is_a_catenary(theta, law):
    """Fit y = a cosh((x-x0)/a) + c: RMS residual < 1 % of the sag; a = H/(μ g) within 2 %."""
    model, state, b, spacing = _hanging_chain(law, theta)
    x, z = state.position[b, 0], state.position[b, 2]
    sag = z[0] - z.min()
    (a, x0, c), _ = curve_fit(_catenary, x, z, p0=(x[-1] / 2, x[-1] / 2, z.min() - x[-1] / 2))
    rms = np.sqrt(np.mean((_catenary(x, a, x0, c) - z) ** 2))
    assert rms < 0.01 * sag
    L = state.links
    end = state.position[b[1]] - state.position[b[0]]
    H = L.tension[0] * abs(end[0]) / np.linalg.norm(end)  # horizontal tension, constant along
    mu = M_BEAD / spacing  # linear mass density [kg/m]
    assert a == pytest.approx(H / (mu * G), rel=0.02)
    np.testing.assert_allclose(L.length, spacing, rtol=1e-8)  # rigid: lengths kept
    assert np.all(L.tension > 0)


def test_stiff_elastic_laws_approach_the_rigid_catenary():
    _, rigid, b, _ = _hanging_chain(laws.RigidWire(), 1.0)
    for law in (laws.ElasticWire(stiffness=1e3), laws.ElasticRod(stiffness=1e3)):
        _, el, _, _ = _hanging_chain(law, 1.0)
        drift = np.abs(el.position[b] - rigid.position[b]).max()
        sag = rigid.position[b[0], 2] - rigid.position[b, 2].min()
        assert drift < 1e-3 * sag


# -- dynamics ------------------------------------------------------------------------------
def test_vibrating_beaded_string_frequency(theta):
    """ω₁ = 2√(T/(m a)) sin(π/(2(N+1))) within 2 % (T = k ε₀), at h ω₁ ≈ 0.07."""
    r = beaded_string(theta=theta, dt=5e-4)
    assert r["omega"] == pytest.approx(r["omega_exact"], rel=0.02)


def test_beaded_string_frequency_error_is_second_order():
    """Halving h divides the frequency error by about 4 (seen: 8.8e-4 -> 2.2e-4)."""
    e1 = beaded_string(dt=1e-3)["rel_error"]
    e2 = beaded_string(dt=5e-4)["rel_error"]
    assert 3.0 < e1 / e2 < 5.0


@pytest.mark.slow
@pytest.mark.parametrize("law", [laws.RigidRod(), laws.RigidWire()], ids=["rigid-rod", "rigid-wire"])
def test_swinging_chain_keeps_its_length_and_energy(theta, law):
    """10 000 steps of a chain swinging about its fixed top bead: links keep their length
    to the solver tolerance (where the scheme imposes it: the θ-predicted configuration;
    at θ = 1 that is the step end) and the energy does not grow."""
    n, a = 16, 2.2 * R_BEAD
    pts = np.column_stack([np.zeros(n), np.zeros(n), -np.arange(n) * a])
    s, b = _wire_scene(pts, law, fixed=[0])
    model, state = s.compile(dt=1e-4, theta=theta, tol=1e-10, max_iter=20000)
    omega = 8.0  # [rad/s] about y through the top bead
    state.vel6[b, 0] = omega * (-pts[:, 2])
    m = model.body_mass[b]

    def energy():
        return 0.5 * m @ (state.velocity[b] ** 2).sum(1) + G * m @ state.position[b, 2]

    e0 = energy()
    scale = 0.5 * m @ (state.velocity[b] ** 2).sum(1)
    worst_pred, worst_end, e_max = 0.0, 0.0, e0
    step(model, state)  # the first predicted configuration comes from the initial state
    for _ in range(10_000):
        stats = step(model, state)
        assert stats.converged
        pred = state.link_gap / model.link_ref_length - 1  # at q_m, where Eq. (8) applies
        end = state.links.length / model.link_ref_length - 1
        if law.unilateral:  # a wire may go slack: only extension is forbidden
            pred, end = np.maximum(pred, 0), np.maximum(end, 0)
        worst_pred = max(worst_pred, np.abs(pred).max())
        worst_end = max(worst_end, end.max() if theta < 1 else np.abs(end).max())
        e_max = max(e_max, energy())
    assert worst_pred < 1e-8
    assert worst_end < 1e-8  # θ = 1.0: |Δℓ|; θ = 0.5: no stretching (chords are shorter)
    # θ = 0.5 conserves the energy to O(h²) (seen: 1e-6 of the kinetic energy over 3 000
    # steps); θ = 1 is first order: seen, swings of up to 1e-3 of it, either sign
    assert energy() - e0 < 2e-3 * scale
    assert e_max - e0 < 1e-2 * scale


def test_unilaterality_wire_slack_in_compression_rod_pushes_back(theta):
    """Compressed: a wire law gives zero force, a rod law pushes back (T = k ε < 0).
    Extended: both resist (T = k ε > 0).  Two beads, one fixed, one driven."""
    k, L = 0.1, 10e-3
    for sign in (-1, +1):  # compression, extension
        t = {}
        for name, law in (("wire", laws.ElasticWire(stiffness=k)), ("rod", laws.ElasticRod(stiffness=k))):
            s, b = _wire_scene([[0, 0, 0], [L, 0, 0]], law, fixed=[0], gravity=(0, 0, 0))
            v = 1e-3
            s.drive(b[1], velocity=(sign * v, 0, 0))
            model, state = s.compile(dt=1e-4, theta=theta)
            run(model, state, 100, progress=False)
            # the tension of the last step is k (ℓ⁺ − L)/L, ℓ⁺ the next predicted length
            strain = (state.link_gap[0] + model.options.dt * sign * v - L) / L
            t[name] = (state.links.tension[0], k * strain)
        if sign < 0:
            assert t["wire"][0] == 0.0
            assert t["rod"][0] == pytest.approx(t["rod"][1], rel=1e-9) and t["rod"][0] < 0
        else:
            for name in t:
                assert t[name][0] == pytest.approx(t[name][1], rel=1e-9) and t[name][0] > 0


@pytest.mark.parametrize("neighbour_contact", [False, True], ids=["apart", "touching"])
def test_slack_link_beads_overlap_unless_they_touch(neighbour_contact, tmp_path):
    """Two beads of a wire standing one on the other on a floor, the link slack: by default
    linked beads have no contact and the top bead falls through its neighbour onto the floor;
    with ``neighbour_contact`` it rests on it, centres 2 r apart (the Signorini condition,
    within tol), carrying its weight m g, and the wire stays slack (T = 0).  The option
    survives a save/load (the model's excluded pairs)."""
    from engine.io import load, save

    gap = 0.2 * R_BEAD
    s = Scene(gravity=(0, 0, -G))
    b = s.add_wire([[0, 0, R_BEAD], [0, 0, 3 * R_BEAD + gap]], radius=R_BEAD, density=RHO,
                   law=laws.ElasticWire(stiffness=0.1), neighbour_contact=neighbour_contact)
    s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    s.interact("wire", "wall", laws.Coulomb(mu=0.3))
    s.interact("wire", "wire", laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=1e-4, tol=1e-10)
    run(model, state, 3000, progress=False)
    z = state.position[b, 2]
    assert state.links.tension[0] == 0.0
    if neighbour_contact:
        assert z[1] - z[0] == pytest.approx(2 * R_BEAD, rel=1e-4)
        c = state.contacts
        top = np.flatnonzero(((c.i == b[0]) & (c.j == b[1])) | ((c.i == b[1]) & (c.j == b[0])))
        assert len(top) == 1
        assert c.normal_force[top[0]] == pytest.approx(M_BEAD * G, rel=1e-4)
    else:
        # both on the floor, the top bead through the bottom one (its centre within r of it)
        assert z == pytest.approx([R_BEAD, R_BEAD], rel=1e-3)
    assert bool(state.link_excluded_next[b[0]] == b[1]) == (not neighbour_contact)
    save(tmp_path / "w.h5", model, state)
    m2, s2 = load(tmp_path / "w.h5")
    np.testing.assert_array_equal(m2.body_next, model.body_next)
    np.testing.assert_array_equal(s2.link_excluded_next, state.link_excluded_next)


def test_neighbour_contact_must_be_a_bool_and_not_fight_the_link():
    with pytest.raises(ValueError, match="neighbour_contact must be True or False, got 'yes'"):
        Scene().add_wire([[0, 0, 0], [0, 0, 3e-3]], radius=R_BEAD, density=RHO,
                         law=laws.RigidWire(), neighbour_contact="yes")
    # L = 2.2 r / 1.2 < 2 r: the rod would hold its beads overlapping against their contact
    s = Scene()
    s.add_wire([[0, 0, 0], [0, 0, 2.2 * R_BEAD]], radius=R_BEAD, density=RHO,
               law=laws.ElasticRod(stiffness=1.0, prestrain=0.2), neighbour_contact=True)
    s.interact("wire", "wire", laws.Coulomb(mu=0.3))
    with pytest.raises(ValueError, match=r"reference length .* of links \[0\] is below the "
                                         r"sum of their beads' radii \(down to 0\.9167"):
        s.compile(dt=1e-4)


def test_brittle_wire_breaks_at_its_maximum_tension_and_not_before():
    """A bead hanging on a brittle wire is pulled down by a growing force F = ḟ t: the link
    breaks in the step whose tension first exceeds max_tension, then the bead falls free."""
    fmax, rate, dt = 1e-3, 0.02, 1e-4  # [N], [N/s], [s]
    law = laws.BrittleElasticWire(stiffness=0.5, max_tension=fmax)
    s, b = _wire_scene([[0, 0, 0], [0, 0, -5e-3]], law, fixed=[0])
    s.drive(b[1], force=lambda t: (0.0, 0.0, -rate * t))
    model, state = s.compile(dt=dt, tol=1e-12)
    tensions = []
    while not state.link_broken[0] and state.step < 20_000:
        step(model, state)
        tensions.append(state.link_impulse[0] / dt)
    tensions = np.asarray(tensions)
    assert state.link_broken[0] and state.links.broken[0]
    assert tensions[-1] > fmax and np.all(tensions[:-1] <= fmax)
    # quasi-static: tension ≈ M g + F(t); it breaks when that crosses fmax
    t_break = (fmax - M_BEAD * G) / rate
    assert state.time == pytest.approx(t_break, abs=0.01 * t_break)
    z = state.position[b[1], 2]
    run(model, state, 100, progress=False)
    assert state.links.tension[0] == 0.0 and state.position[b[1], 2] < z - 1e-6


def wire_in_a_sand_pile():
    """80 grains in an open box above a 5-bead slack elastic wire (ε₀ = −0.3) lying on the
    floor, its first bead fixed: (scene, beads), not compiled."""
    rng = np.random.default_rng(2)
    box = ((0, 0, 0), (12e-3, 12e-3, 0.1))
    pts, radii = lattice_pile(80, 1e-3, rng, box, gap=1.02)
    pts[:, 2] += 1.5e-3  # room for the wire on the floor
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, radii, density=2650.0, group="sand")
    wire_pts = np.column_stack([2e-3 + np.arange(5) * 2e-3, np.full(5, 6e-3), np.full(5, 0.5e-3)])
    beads = s.add_wire(wire_pts, radius=0.5e-3, density=1400.0, group="wire",
                       law=laws.ElasticWire(stiffness=1.0, prestrain=-0.3))
    s.add_box(*box, group="wall")
    for a, bb in (("sand", "sand"), ("sand", "wall"), ("wire", "sand"), ("wire", "wall"),
                  ("wire", "wire")):
        s.interact(a, bb, laws.Coulomb(mu=0.3))
    s.fix([beads[0]])
    return s, beads


@pytest.mark.slow
def test_wire_in_a_sand_pile_is_slack_then_pulled():
    """A slack wire (ε₀ < 0) buried in a settling pile carries no tension; pulling one end
    out (the other fixed) puts every link in tension."""
    s, beads = wire_in_a_sand_pile()
    t_pull, dt = 0.12, 2e-4
    s.drive(beads[-1], velocity=lambda t: (0.05 if t > t_pull else 0.0, 0.0, 0.0))
    model, state = s.compile(dt=dt, tol=1e-6, max_iter=3000)
    run(model, state, int(round(t_pull / dt)), progress=False)
    c = state.contacts
    assert np.isin(c.i, beads).any() or np.isin(c.j, beads).any()  # the sand rests on the wire
    # the wire law (Eq. 14) at the step's next predicted length ℓ⁺ = g_m + h u ≈ the
    # current length: slack links (ℓ < L) carry exactly nothing
    links = state.links
    slack = links.length < model.link_ref_length * (1 - 1e-6)
    assert slack.sum() >= 2
    assert np.all(links.tension[slack] == 0.0)
    assert np.all(links.tension >= 0.0)
    run(model, state, 400, progress=False)
    assert np.all(state.links.tension > 0)  # pulled taut


@pytest.mark.parametrize("law", [laws.RigidRod(), laws.RigidWire()], ids=["rigid-rod", "rigid-wire"])
def test_rigid_chain_stable_at_a_coarse_step(theta, law):
    """DESIGN.md's hazard: a 31-bead rigid chain hanging under gravity at h = 1 ms, where a
    prototype of Eq. (8) grew exponentially at θ = 0.5.  Here the energy never rises above
    its start by more than 1e-3 of the chain's weight × length over 3 s."""
    pts, a = _v_chain(30, 0.7)
    s, b = _wire_scene(pts, law, fixed=[0, 30])
    model, state = s.compile(dt=1e-3, theta=theta, tol=1e-6, max_iter=20000)
    m = model.body_mass[b]

    def energy():
        return 0.5 * m @ (state.velocity[b] ** 2).sum(1) + G * m @ state.position[b, 2]

    e0 = energy()
    scale = m.sum() * G * 30 * a
    e = []
    for _ in range(3000):
        step(model, state)
        e.append(energy() - e0)
    assert np.all(np.isfinite(state.position))
    assert max(e) < 1e-3 * scale
    assert e[-1] < 0.0  # it has settled below its start
