"""The wire link laws' local solve (engine.solver.local.rod, wire, tension) against their
closed forms (Eq. 9, 11, 13, 15 after the change of variables of Eq. 8), for one link.

With u_f the link's local free velocity, W its Delassus diagonal, c = L/(k h²) the
compliance (0 for the rigid laws) and s = (g − L*)/h the length term, the end-of-step
normal velocity is u⁺ = u_f − W λ (tension λ positive pulls the beads together)."""
import numpy as np
import pytest

from engine.solver.local import rod, tension, wire

H = 1e-4


def _cases(seed=0, m=200):
    rng = np.random.default_rng(seed)
    W = rng.uniform(0.1, 10.0, m)             # 1/m_i + 1/m_j [1/kg]
    uf = rng.normal(0.0, 1e-2, m)             # [m/s]
    stretch = rng.normal(0.0, 1e-2, m)        # (g − L*)/h [m/s]
    L = rng.uniform(1e-4, 1e-3, m)            # [m]
    k = rng.uniform(1.0, 100.0, m)            # [N]
    return W, uf, stretch, L, k


def test_rigid_rod_keeps_the_next_length():
    """Rigid rod (c = 0): g + h u⁺ = L*, i.e. u⁺ = −s, any sign of λ."""
    for W, uf, s in zip(*_cases()[:3]):
        lam = rod(uf, s, 1.0 / W, 0.0, 1.0)
        assert uf - W * lam == pytest.approx(-s, rel=1e-12, abs=1e-15)


def test_elastic_rod_force_is_k_times_the_next_strain():
    """Elastic rod: T = λ/h = k (g + h u⁺ − L*)/L, in tension and in compression."""
    signs = set()
    for W, uf, s, L, k in zip(*_cases(1)):
        c = L / (k * H * H)
        lam = rod(uf, s, 1.0 / (W + c), 0.0, 1.0)
        strain = (H * s + H * (uf - W * lam)) / L        # (g − L* + h u⁺)/L
        assert lam / H == pytest.approx(k * strain, rel=1e-9, abs=1e-12)
        signs.add(np.sign(lam))
    assert signs == {-1.0, 1.0}


@pytest.mark.parametrize("elastic", [False, True])
def test_wires_pull_only_and_are_complementary(elastic):
    """Rigid and elastic wire: λ >= 0; λ > 0 is the rod's answer, λ = 0 where the rod would
    push (the wire is slack: its free next length is within L*, or its spring is not
    stretched)."""
    slack = taut = 0
    for W, uf, s, L, k in zip(*_cases(2)):
        c = L / (k * H * H) if elastic else 0.0
        lam = wire(uf, s, 1.0 / (W + c), 0.0, 1.0)
        bilateral = rod(uf, s, 1.0 / (W + c), 0.0, 1.0)
        assert lam >= 0.0
        if uf + s > 0.0:            # would stretch past L* with no tension
            assert lam == bilateral > 0.0
            taut += 1
        else:
            assert lam == 0.0
            slack += 1
    assert slack and taut


def test_relaxation_and_projection():
    """ω: λ = λ0 + ω (λ* − λ0) for the rods, then projected on λ >= 0 for the wires."""
    for W, uf, s in zip(*_cases(3)[:3]):
        for lam0 in (0.0, 1e-3, -1e-3):
            for om in (0.5, 1.0, 1.5):
                star = (uf + s) / W
                want = lam0 + om * (star - lam0)
                assert rod(uf, s, 1.0 / W, lam0, om) == pytest.approx(want, rel=1e-12, abs=1e-18)
                assert wire(uf, s, 1.0 / W, lam0, om) == pytest.approx(max(want, 0.0), rel=1e-12,
                                                                       abs=1e-18)
    assert tension(-1.0) == 0.0 and tension(2.0) == 2.0 and tension(0.0) == 0.0
