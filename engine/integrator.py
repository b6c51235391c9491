"""Moreau–Jean θ-method, Eq. (3)-(4) of the paper (DESIGN.md §4 restores the h):

    v_free  = v_i + h M⁻¹ ((1-θ) F_i + θ F_{i+1})                      (Eq. 4, second line)
    v_{i+1} = v_free + M⁻¹ H p                                           (NLGS, Eq. 5)
    q_{i+1} = q_i + h ((1-θ) v_i + θ v_{i+1})                            (Eq. 4, first line)

The position update is split in two stages so that contacts are detected at the
θ-predicted configuration q_m = q_i + (1-θ) h v_i (LMGC90's "configuration TT"):
:func:`free_velocity` moves the positions to q_m and computes v_free; :func:`update`
completes q_{i+1} = q_m + θ h v_{i+1}.  A contact's end-of-step gap is then
g_m + θ h u_n and the next predicted gap g_m + h u_n; the velocity Signorini condition
u_n + max(g_m, 0)/h >= 0 of the NLGS keeps both >= 0 (see :mod:`engine.solver.local`).

External forces are constant over a step (gravity, force drives, pressure × area
evaluated at t_i), so the θ-weighting of F reduces to F_i.  Spheres do not need an
orientation: their spin is integrated (ω_free = ω_i: no torque, no gyroscopic term for
a spherical inertia) but no rotation is stored.
"""
from __future__ import annotations

from numba import njit

from .drivers import drive_forces, drive_velocities
from .model import FREE, LINE


@njit(cache=True)
def _free_velocity(pos, vel6, force, body_dof, body_line, body_mass, gx, gy, gz, h, theta):
    one_m = (1.0 - theta) * h
    for b in range(pos.shape[0]):
        # q_m = q_i + (1-θ) h v_i
        pos[b, 0] += one_m * vel6[b, 0]
        pos[b, 1] += one_m * vel6[b, 1]
        pos[b, 2] += one_m * vel6[b, 2]
        dof = body_dof[b]
        if dof == FREE:
            im = 1.0 / body_mass[b]
            vel6[b, 0] += h * (gx + im * force[b, 0])
            vel6[b, 1] += h * (gy + im * force[b, 1])
            vel6[b, 2] += h * (gz + im * force[b, 2])
        elif dof == LINE:
            lx = body_line[b, 0]
            ly = body_line[b, 1]
            lz = body_line[b, 2]
            dv = h / body_mass[b] * (force[b, 0] * lx + force[b, 1] * ly + force[b, 2] * lz)
            vel6[b, 0] += dv * lx
            vel6[b, 1] += dv * ly
            vel6[b, 2] += dv * lz


@njit(cache=True)
def _update(pos, vel6, h_theta):
    for b in range(pos.shape[0]):
        pos[b, 0] += h_theta * vel6[b, 0]
        pos[b, 1] += h_theta * vel6[b, 1]
        pos[b, 2] += h_theta * vel6[b, 2]


def free_velocity(model, state) -> None:
    """Stage 1 of a step: drives, θ-predicted configuration and free velocity (Eq. 4).

    On return ``state.position`` holds q_m = q_i + (1-θ) h v_i and ``state.vel6`` the free
    velocity; imposed velocities are set to their value at t_{i+1}.
    """
    o = model.options
    h = o.dt
    drive_forces(model, state)  # state.force at t_i (force drives, pressure × area)
    g = o.gravity
    _free_velocity(state.position, state.vel6, state.force, model.body_dof, model.body_line,
                   model.body_mass, g[0], g[1], g[2], h, o.theta)
    drive_velocities(model, state, state.time + h)  # imposed velocities at t_{i+1}


def update(model, state) -> None:
    """Last stage of a step: q_{i+1} = q_m + θ h v_{i+1}; time advances by h."""
    o = model.options
    _update(state.position, state.vel6, o.theta * o.dt)
    # compensated (Kahan) sum: after n steps, time is n·h to the last bit, not n rounding errors
    y = o.dt - state.time_compensation
    t = state.time + y
    state.time_compensation = (t - state.time) - y
    state.time = t
    state.step += 1
    state.last_dt = o.dt


__all__ = ["free_velocity", "update"]
