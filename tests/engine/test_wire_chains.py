"""Each wire solved as one chain (``Options(chain_solve=True)``, issue 31 §1).

Every closed form of ``tests/engine/test_wire.py`` (catenary, beaded string, stretch,
unilaterality, brittle break, swinging chain, a wire in a sand pile ...) runs again here,
unchanged, with the chain solve on: the tests of that module are collected in this one with
``Scene.compile`` defaulting to ``chain_solve=True``.  Then the chain solve's own facts:
the same converged answer as the plain link sweeps at tol 1e-10 (positions and impulses,
the four laws, open and closed wires), far fewer sweeps on a long chain, on one thread or
two and inside Anderson mixing.
"""
import numpy as np
import pytest

from engine import Scene, laws, run
from tests.engine import test_wire as _closed_forms
from tests.engine.test_wire import R_BEAD, _v_chain, _wire_scene

# the closed forms, collected again in this module (with its autouse fixture below)
for _name in dir(_closed_forms):
    if _name.startswith("test_"):
        globals()[_name] = getattr(_closed_forms, _name)


@pytest.fixture(autouse=True)
def chain_solve(monkeypatch):
    """``Scene.compile(..., chain_solve=True)`` unless a test says otherwise."""
    compile_ = Scene.compile

    def with_chains(self, *args, **kw):
        kw.setdefault("chain_solve", True)
        return compile_(self, *args, **kw)

    monkeypatch.setattr(Scene, "compile", with_chains)


LAWS = [laws.RigidWire(), laws.ElasticWire(stiffness=0.05), laws.RigidRod(),
        laws.ElasticRod(stiffness=0.05)]


def _chain(law, closed, chain_solve, tol=1e-10, n_links=30):
    if closed:                          # a ring (buckled out of its plane), one bead fixed
        th = np.linspace(0, 2 * np.pi, n_links, endpoint=False)
        rr = n_links * 2.2 * R_BEAD / (2 * np.pi)
        pts = np.column_stack([rr * np.cos(th), rr * np.sin(th), 0.3 * rr * np.sin(2 * th)])
        s, b = _wire_scene(pts, law, fixed=[0], closed=True)
    else:                               # a V-shaped chain between two fixed ends
        pts, _ = _v_chain(n_links, 0.7)
        s, b = _wire_scene(pts, law, fixed=[0, n_links])
    return s.compile(dt=2e-4, theta=0.5, tol=tol, max_iter=20000, chain_solve=chain_solve)


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
@pytest.mark.parametrize("law", LAWS, ids=["rigid-wire", "elastic-wire", "rigid-rod",
                                           "elastic-rod"])
def test_chain_solve_converges_to_the_plain_sweeps_answer(law, closed):
    """40 steps of a falling chain at tol 1e-10: the same bead positions (within 1e-12 m:
    measured 1e-16 to 6e-15 m) and link impulses (within 1e-9 of the largest: measured
    1e-13 to 3e-11) as the plain Gauss–Seidel sweeps: both solve the same equations."""
    (m0, s0), (m1, s1) = _chain(law, closed, False), _chain(law, closed, True)
    assert not m0.options.chain_solve and m1.options.chain_solve
    run(m0, s0, 40, progress=False)
    run(m1, s1, 40, progress=False)
    assert np.abs(s0.position - s1.position).max() < 1e-12
    lam = np.abs(s0.link_impulse).max()
    assert lam > 0 and np.abs(s0.link_impulse - s1.link_impulse).max() < 1e-9 * lam


def _arc(n_links, a, span_ratio):
    """Bead centres on a circular arc sagging in the x-z plane, ``n_links`` chords ``a``,
    end distance ``span_ratio`` x the length (bench/bench_wire.py's chain)."""
    lo, hi = 1e-12, 2 * np.pi / n_links * (1 - 1e-9)
    for _ in range(200):
        m = 0.5 * (lo + hi)
        f = np.sin(n_links * m / 2) / (n_links * np.sin(m / 2)) - span_ratio
        lo, hi = (m, hi) if f > 0 else (lo, m)
    phi = 0.5 * (lo + hi)
    ang = -np.pi / 2 + (np.arange(n_links + 1) - n_links / 2) * phi
    pts = a / (2 * np.sin(phi / 2)) * np.column_stack([np.cos(ang), 0 * ang, np.sin(ang)])
    return pts - pts[0]


def _long_chain(pts, law, chain_solve, r=1e-4):
    s = Scene(gravity=(0.0, 0.0, -9.81))
    b = s.add_wire(pts, radius=r, density=1400.0, group="wire", law=law)
    s.interact("wire", "wire", None)
    s.fix(b[[0, -1]])
    model, state = s.compile(dt=5e-5, tol=1e-4, max_iter=20000, chain_solve=chain_solve)
    its = []
    for _ in range(30):
        run(model, state, 1, progress=False)
        its.append(state.stats.iterations)
    assert np.isfinite(state.position).all()
    return np.array(its)


@pytest.mark.parametrize("law", LAWS, ids=["rigid-wire", "elastic-wire", "rigid-rod",
                                           "elastic-rod"])
def test_a_long_chain_needs_a_few_sweeps_per_step(law):
    """bench_wire's 1 000-bead chain (an arc of end distance 0.8 x its length between
    fixed ends, under gravity, h = 50 µs, tol 1e-4): at most 20 sweeps per step over 30
    steps with the chain solve (measured: 2 in every step, all four laws; the plain sweeps
    took 1 960-2 220 on average, up to 17 000; issue 31's target: <= 20)."""
    its = _long_chain(_arc(999, 2.2e-4, 0.8), law, True)
    assert its.max() <= 20, its


def test_a_falling_wire_takes_a_few_sweeps_per_step():
    """A 1 000-bead rigid wire starting as a looser arc (chord 0.87 x its length), whose
    links go slack and taut as it falls.  Its slack links' impulses come out of the chain
    solve at round-off (1e-33 N s), and the Quad residual of such impulses, noise over
    noise, stayed of order 1 for thousands of sweeps until round-off impulses were set to
    0 (two steps of 8 919 and 10 014 sweeps then).  Measured over 30 steps: 58 sweeps in
    all (1 or 2 a step) against 71 083 with the plain link sweeps (up to 8 625 a step)."""
    n, a = 1000, 2.2e-4
    phi = np.linspace(-1.0, 1.0, n) * 0.9
    R = (n - 1) * a / 1.8
    pts = np.column_stack([R * np.sin(phi), np.zeros(n), R * (np.cos(phi) - 1.0)])
    pts *= a / np.linalg.norm(np.diff(pts, axis=0), axis=1).mean()
    chain, plain = (_long_chain(pts, laws.RigidWire(), cs) for cs in (True, False))
    assert chain.max() <= 20, chain
    assert chain.sum() < 0.01 * plain.sum(), (chain.sum(), plain.sum())


def test_a_straight_rigid_chain_between_fixed_ends_is_not_a_division_by_zero():
    """A straight rigid rod chain at rest between two fixed beads at its exact length: four
    links on three free beads' motion along the wire, a tension left undetermined, a
    singular tridiagonal system (a zero pivot).  The chain solve gives such a chain the
    plain Gauss–Seidel pass (numba raised ZeroDivisionError before): nothing moves and no
    link carries anything, as with the plain sweeps."""
    s, b = _wire_scene([[2e-3 * k, 0, 0] for k in range(5)], laws.RigidRod(), fixed=[0, 4],
                       gravity=(0, 0, 0))
    model, state = s.compile(dt=1e-4, tol=1e-8, max_iter=200, chain_solve=True)
    x0 = state.position.copy()
    run(model, state, 5, progress=False)
    assert np.array_equal(state.position, x0) and not state.link_impulse.any()


VARIANTS = [dict(threads=2), dict(anderson=4), dict(threads=2, anderson=4)]
VARIANT_IDS = ["2-threads", "anderson", "2-threads-anderson"]


@pytest.mark.slow
@pytest.mark.parametrize("variant", VARIANTS, ids=VARIANT_IDS)
def test_a_long_chain_needs_a_few_sweeps_on_threads_and_mixed(variant):
    """The chain solve in the parallel sweep's link phase and inside Anderson mixing: the
    1 000-bead rigid-wire arc of :func:`test_a_long_chain_needs_a_few_sweeps_per_step` at
    most 20 sweeps a step over 30 steps (the target of issue 31; measured: 2 in every step,
    each variant; the plain link sweeps take thousands)."""
    s = Scene(gravity=(0.0, 0.0, -9.81))
    b = s.add_wire(_arc(999, 2.2e-4, 0.8), radius=1e-4, density=1400.0, group="wire",
                   law=laws.RigidWire())
    s.interact("wire", "wire", None)
    s.fix(b[[0, -1]])
    model, state = s.compile(dt=5e-5, tol=1e-4, max_iter=20000, chain_solve=True,
                             hot_sweeps=0, **variant)
    assert model.options.chain_solve
    its = []
    for _ in range(30):
        run(model, state, 1, progress=False)
        its.append(state.stats.iterations)
    assert np.isfinite(state.position).all() and max(its) <= 20, its


def test_chain_solve_still_refuses_what_the_sweep_refuses():
    """The chain solve adds no conflict of its own (it runs with every variant since
    2026-12-05); the others' are still refused in one line."""
    s, _ = _wire_scene([[0, 0, 0], [0, 0, -1e-2]], laws.RigidWire(), fixed=[0])
    with pytest.raises(ValueError, match=r"hot_sweeps = 2 works with the unmixed sweep only"):
        s.compile(dt=1e-4, chain_solve=True, anderson=4, hot_sweeps=2)
    for kw in (dict(hot_sweeps=2), dict(anderson=4, hot_sweeps=0), dict(threads=2)):
        model, _ = s.compile(dt=1e-4, chain_solve=True, **kw)
        assert model.options.chain_solve


def _pile_positions(chain_solve, steps=150, **kw):
    s, beads = _closed_forms.wire_in_a_sand_pile()
    s.drive(beads[-1], velocity=(0.02, 0.0, 0.0))
    model, state = s.compile(dt=2e-4, tol=1e-10, max_iter=20000, chain_solve=chain_solve, **kw)
    run(model, state, steps, progress=False)
    return state.position.copy()


def test_chain_solve_with_hot_sweeps_in_a_sand_pile():
    """The chain solve inside the hot re-sweep loop (the tests' default hot_sweeps = 2):
    80 grains settling on an elastic wire whose far end is pulled out (the scene of
    test_wire's wire in a sand pile), 150 steps with and without the chain solve at tol
    1e-10: the same bead positions within 1e-9 m (both converge to the same equations)."""
    plain, chains = (_pile_positions(cs, hot_sweeps=2) for cs in (False, True))
    assert np.abs(plain - chains).max() < 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("variant", VARIANTS, ids=VARIANT_IDS)
def test_chain_solve_on_threads_and_mixed_in_a_sand_pile(variant):
    """The same pile with the chain solve on two threads (the parallel sweep's link phase),
    inside Anderson mixing, and both: the serial plain sweeps' bead positions within
    1e-9 m after 150 steps at tol 1e-10 (measured: 3.9e-14, 4.7e-13 and 1.2e-13 m), since every variant
    converges to the same equations."""
    plain = _pile_positions(False, hot_sweeps=0)
    chains = _pile_positions(True, hot_sweeps=0, **variant)
    assert np.abs(plain - chains).max() < 1e-9
