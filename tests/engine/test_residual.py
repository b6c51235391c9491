"""Siconos's natural-map residual (engine.solver.residual, issue 31 §2).

Facts: it is 0 (to round-off) where a contact satisfies Signorini + Coulomb exactly (a
sphere resting on a floor, a sphere sliding on it: closed forms); it equals an independent
numpy evaluation of fc3d_compute_error's formula, built from the Delassus matrix
W = H M⁻¹ Hᵀ and the free velocity q (u = W r + q); it falls with the Quad tolerance; it is
None and changes nothing when not asked; it reaches the histories.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from engine import Scene, laws, run, step
from engine.io import History, read_history
from engine.model import DYN_INV_INERTIA, DYN_INV_MASS


def _sphere_on_floor(vx=0.0, mu=0.4):
    s = Scene(gravity=(0.0, 0.0, -9.81))
    b = s.add_spheres([[0.0, 0.0, 1e-3]], [1e-3], density=2650.0, group="sand")
    s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    s.interact("sand", "wall", laws.Coulomb(mu=mu))
    model, state = s.compile(dt=1e-4, tol=1e-12, max_iter=100, natural_residual=True)
    state.velocity[b[0]] = (vx, 0.0, 0.0)
    return model, state


def test_a_sphere_at_rest_on_a_floor_has_no_residual():
    model, state = _sphere_on_floor()
    for _ in range(5):
        st = step(model, state)
    assert st.n_contacts == 1
    # r = m g h exactly, u_n = 0: the natural map is 0 up to round-off of q = g h
    assert st.natural_residual < 1e-12


def test_a_sliding_sphere_has_no_residual():
    # sliding at 0.1 m/s with μ = 0.4: r_T = -μ r_n u_T/|u_T|, u_n = 0: e = 0 exactly
    model, state = _sphere_on_floor(vx=0.1)
    st = step(model, state)
    st = step(model, state)
    assert st.n_contacts == 1
    c = state.contacts_buf
    pn, pt, ps = c.impulse[0]
    assert math.hypot(pt, ps) == pytest.approx(0.4 * pn, rel=1e-12)   # it slides
    assert st.natural_residual < 1e-12


def _pile(max_iter, tol=1e-4, natural=True, steps=3000):
    rng = np.random.default_rng(3)
    n = 60
    c = np.stack([rng.uniform(-1.5e-3, 1.5e-3, n), rng.uniform(-1.5e-3, 1.5e-3, n),
                  0.4e-3 + np.arange(n) * 0.75e-3], 1)
    s = Scene(gravity=(0.0, 0.0, -9.81))
    s.add_spheres(c, rng.uniform(0.2e-3, 0.35e-3, n), density=2650.0, group="sand")
    s.add_box(lo=(-2e-3, -2e-3, 0), hi=(2e-3, 2e-3, 60e-3), group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=0.3))
    s.interact("sand", "wall", laws.Coulomb(mu=0.5))
    model, state = s.compile(dt=5e-5, tol=1e-4, max_iter=1000)
    for _ in range(steps):
        step(model, state)
    probe, _ = s.compile(dt=5e-5, tol=tol, max_iter=max_iter, natural_residual=natural)
    return probe, state


def _numpy_natural_map(model, state):
    """fc3d_compute_error's formula, written out independently: W and q from H."""
    c = state.contacts_buf
    n = c.count
    F, ci, cj, ri, rj = c.frame[:n], c.i[:n], c.j[:n], c.ri[:n], c.rj[:n]
    H = np.zeros((3 * n, 6 * model.n_bodies))
    for a in range(n):
        nv, tv, sv = F[a, 0:3], F[a, 3:6], F[a, 6:9]
        i, j = 6 * ci[a], 6 * cj[a]
        H[3 * a, i:i + 3] += nv
        H[3 * a, j:j + 3] -= nv
        H[3 * a + 1, i:i + 3] += tv
        H[3 * a + 1, j:j + 3] -= tv
        H[3 * a + 1, i + 3:i + 6] -= ri[a] * sv
        H[3 * a + 1, j + 3:j + 6] -= rj[a] * sv
        H[3 * a + 2, i:i + 3] += sv
        H[3 * a + 2, j:j + 3] -= sv
        H[3 * a + 2, i + 3:i + 6] += ri[a] * tv
        H[3 * a + 2, j + 3:j + 6] += rj[a] * tv
    inv = np.repeat(model.body_dyn[:, [DYN_INV_MASS, DYN_INV_INERTIA]], 3, axis=1).ravel()
    W = H @ (inv[:, None] * H.T)
    q = H @ state.workspace.free_vel.ravel()
    q[0::3] += c.gterm[:n]
    r = c.impulse[:n].ravel()
    u = (W @ r + q).reshape(-1, 3)
    # u from W r + q is the velocity the sweeps left (the Delassus model of the step)
    u_state = (H @ state.vel6.ravel()).reshape(-1, 3)
    u_state[:, 0] += c.gterm[:n]
    assert np.abs(u - u_state).max() < 1e-9 * np.abs(u).max()
    e2 = 0.0
    for a in range(n):
        m = c.mu[a]
        rn, rt, rs = c.impulse[a]
        x = np.array([rn - u[a, 0] - m * math.hypot(u[a, 1], u[a, 2]),
                      rt - u[a, 1], rs - u[a, 2]])
        nt = math.hypot(x[1], x[2])
        if nt <= m * x[0]:
            y = x
        elif m * nt <= -x[0]:
            y = np.zeros(3)
        else:
            y0 = (x[0] + m * nt) / (1 + m * m)
            y = np.array([y0, m * y0 * x[1] / nt, m * y0 * x[2] / nt])
        e2 += float(((c.impulse[a] - y) ** 2).sum())
    return math.sqrt(e2) / float(np.linalg.norm(q))


def test_equals_fc3d_compute_error_written_out_with_the_delassus_matrix():
    model, state = _pile(max_iter=3)        # three sweeps: far from converged
    st = step(model, state)
    assert st.n_contacts > 100 and not st.converged
    ref = _numpy_natural_map(model, state)
    assert ref > 1e-8                        # a real, non-zero residual is compared
    assert st.natural_residual == pytest.approx(ref, rel=1e-9)


def test_falls_with_the_quad_tolerance_and_changes_nothing_when_not_asked():
    loose, state = _pile(max_iter=5000, tol=1e-3)
    tight, _ = _pile(max_iter=5000, tol=1e-9, steps=0)
    a = step(loose, state.copy())
    b = step(tight, state.copy())
    # (the tight solve may stop at max_iter: a hyperstatic pile converges slowly in Quad)
    assert a.converged and b.residual < 1e-2 * a.residual
    assert b.natural_residual < 1e-3 * a.natural_residual
    # off (the default): NaN, and the same step bit for bit
    off, _ = _pile(max_iter=5000, tol=1e-3, natural=False, steps=0)
    s_on, s_off = state.copy(), state.copy()
    on_stats, off_stats = step(loose, s_on), step(off, s_off)
    assert off_stats.natural_residual is None
    assert on_stats.iterations == off_stats.iterations
    assert np.array_equal(s_on.vel6, s_off.vel6) and np.array_equal(s_on.position, s_off.position)


def test_the_history_records_it(tmp_path):
    model, state = _pile(max_iter=1000, steps=300)
    path = tmp_path / "h.h5"
    with History(path, trigger=2, frames=2) as h:
        run(model, state, steps=6, writers=[h], progress=False)
    h = read_history(path)
    assert h.natural_residual.shape == h.residual.shape
    assert np.all(np.isfinite(h.natural_residual)) and np.all(h.natural_residual >= 0)
