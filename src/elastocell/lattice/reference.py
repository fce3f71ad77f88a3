"""Plain NumPy reference step (textbook form, np.roll streaming), used to test the kernels.

It works on absolute populations f_i in the standard ``(19, nx, ny, nz)`` order and
implements the same physics as :mod:`elastocell.lattice.kernels` independently:
collide (TRT/BGK + Guo forcing) then stream with half-way bounce-back, or the interpolated one where the
parameters give a ``wall_fraction``. Slow; tests only.
"""

from __future__ import annotations

import numpy as np

from elastocell.lattice.params import LatticeParams
from elastocell.lattice.rheology import stress_norm
from elastocell.lattice.stencil import OPPOSITE, SOUND_SPEED_SQUARED, VELOCITIES, WEIGHTS, Q


def _bcast(weights_like, ndim):
    return weights_like.reshape((Q,) + (1,) * ndim)


def reference_collide(f: np.ndarray, params: LatticeParams, force: np.ndarray) -> np.ndarray:
    """Post-collision populations f* for pre-collision f (19, nx, ny, nz) and force F (3, ...)."""
    cs2 = SOUND_SPEED_SQUARED
    c = VELOCITIES.astype(np.float64)
    w = _bcast(WEIGHTS, 3)
    rho = f.sum(axis=0)
    u = (np.einsum("ia,i...->a...", c, f) + 0.5 * force) / rho
    cu = np.einsum("ia,a...->i...", c, u)
    cf = np.einsum("ia,a...->i...", c, force)
    usq = (u * u).sum(axis=0)
    uf = (u * force).sum(axis=0)
    feq = w * rho * (1.0 + cu / cs2 + cu**2 / (2 * cs2**2) - usq / (2 * cs2))
    # Guo source S_i = w_i [ (c_i - u).F / cs^2 + (c_i.u)(c_i.F) / cs^4 ]
    source = w * ((cf - uf) / cs2 + cu * cf / cs2**2)
    omega_p = 1.0 / params.relaxation_time_plus
    omega_m = 1.0 / params.relaxation_time_minus
    if params.rheology is not None:  # power law: tau+ of each node from Pi = sum c c (f - feq) + (uF + Fu)/2
        pi_neq = np.einsum("ia,ib,i...->ab...", c, c, f - feq) + 0.5 * (
            np.einsum("a...,b...->ab...", u, force) + np.einsum("a...,b...->ab...", force, u))
        tau = params.rheology.relaxation_time(stress_norm(pi_neq, rho))
        tau_m = tau if params.collision == "bgk" else 0.5 + params.magic / (tau - 0.5)
        omega_p, omega_m = 1.0 / tau, 1.0 / tau_m
    opp = OPPOSITE
    f_sym, f_asym = 0.5 * (f + f[opp]), 0.5 * (f - f[opp])
    e_sym, e_asym = 0.5 * (feq + feq[opp]), 0.5 * (feq - feq[opp])
    s_sym, s_asym = 0.5 * (source + source[opp]), 0.5 * (source - source[opp])
    return (
        f
        - omega_p * (f_sym - e_sym)
        - omega_m * (f_asym - e_asym)
        + (1.0 - 0.5 * omega_p) * s_sym
        + (1.0 - 0.5 * omega_m) * s_asym
    )


def reference_stream(f_post: np.ndarray, params: LatticeParams) -> np.ndarray:
    """Periodic streaming f_i(x) = f*_i(x - c_i) with half-way bounce-back at solid nodes and
    at the y-walls (moving-wall term 2 w_i rho0 (c_i.u_w)/c_s^2); solid nodes set to rest."""
    nx, ny, nz = params.shape
    f_new = np.empty_like(f_post)
    for i in range(Q):
        f_new[i] = np.roll(f_post[i], shift=tuple(VELOCITIES[i]), axis=(0, 1, 2))
    solid = params.solid
    if solid is not None:
        for i in range(1, Q):
            came_from_solid = np.roll(solid, shift=tuple(VELOCITIES[i]), axis=(0, 1, 2))  # solid[x - c_i]
            if params.has_walls and VELOCITIES[i, 1] != 0:
                came_from_solid[:, 0 if VELOCITIES[i, 1] > 0 else ny - 1, :] = False
            mask = came_from_solid & ~solid
            f_new[i][mask] = f_post[OPPOSITE[i]][mask]
            if params.wall_fraction is not None and mask.any():
                _interpolated_bounce_back(f_new, f_post, params, i, mask)
    if params.has_walls:
        bottom, top = (np.asarray(v, dtype=np.float64) for v in params.wall_velocity)
        for i in range(Q):
            ci = VELOCITIES[i].astype(np.float64)
            if VELOCITIES[i, 1] == 1:  # leaves the bottom wall into y = 0
                f_new[i][:, 0, :] = (
                    f_post[OPPOSITE[i]][:, 0, :] + 2 * WEIGHTS[i] * (ci @ bottom) / SOUND_SPEED_SQUARED
                )
            elif VELOCITIES[i, 1] == -1:  # leaves the top wall into y = ny - 1
                f_new[i][:, ny - 1, :] = (
                    f_post[OPPOSITE[i]][:, ny - 1, :] + 2 * WEIGHTS[i] * (ci @ top) / SOUND_SPEED_SQUARED
                )
    if solid is not None:
        f_new[:, solid] = WEIGHTS[:, None]
    return f_new


def _interpolated_bounce_back(f_new, f_post, params: LatticeParams, i: int, mask: np.ndarray) -> None:
    """Bouzidi, Firdaouss & Lallemand (2001), written out for the links arriving along c_i at the fluid nodes of
    ``mask`` from a solid node: the link goes out along c_k = -c_i with the wall at x + q c_k; with q < 1/2
    f_i(x) = 2q f*_k(x) + (1 - 2q) f*_k(x - c_k), else f_i(x) = f*_k(x)/(2q) + (1 - 1/(2q)) f*_i(x); half-way
    (f*_k(x)) where x - c_k is solid itself or beyond a y-wall."""
    k = OPPOSITE[i]
    nodes = np.argwhere(mask)
    q = np.asarray(params.wall_fraction(nodes.astype(np.float64),
                                        np.repeat(VELOCITIES[k][None].astype(np.float64), len(nodes), 0)))
    for (x, y, z), fraction in zip(nodes, q, strict=True):
        behind = np.array([x, y, z]) - VELOCITIES[k]
        if params.has_walls and not 0 <= behind[1] < params.shape[1]:
            continue
        bx, by, bz = behind % np.asarray(params.shape)
        if params.solid[bx, by, bz]:
            continue
        if fraction < 0.5:
            f_new[i, x, y, z] = 2 * fraction * f_post[k, x, y, z] + (1 - 2 * fraction) * f_post[k, bx, by, bz]
        else:
            f_new[i, x, y, z] = f_post[k, x, y, z] / (2 * fraction) + (1 - 1 / (2 * fraction)) * f_post[i, x, y, z]


def reference_step(
    f: np.ndarray, params: LatticeParams, force_density: np.ndarray | None = None
) -> np.ndarray:
    """One time step (collide, then stream + bounce-back) of absolute populations f (float64).

    force_density : (3, nx, ny, nz) field added to ``params.body_force`` (or None).
    """
    force = np.asarray(params.body_force, dtype=np.float64).reshape(3, 1, 1, 1) * np.ones((1,) + params.shape)
    if force_density is not None:
        force = force + force_density
    return reference_stream(reference_collide(np.asarray(f, dtype=np.float64), params, force), params)
