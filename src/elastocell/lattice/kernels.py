"""Compiled (Numba) D3Q19 kernels: one fused stream + collide + force + bounce-back step.

Memory layout
-------------
Populations live in one array ``A`` of shape ``(nx, ny, 19, nz_row)`` (``nz_row >= nz``,
rows padded to whole cache lines, padding unused), stored as deviations
``f_i - w_i`` from the rest equilibrium. ``z`` is the contiguous index.

Each thread owns whole x-planes and walks their z-lines (fixed x, y) in blocks of
``BLOCK`` nodes. A block is (1) gathered into a small per-thread buffer
(19 population rows plus scratch rows, a few kB, L1-resident), (2) collided in that
buffer and (3) scattered back. The buffer is one flat array whose rows sit at
compile-time-constant offsets ``row * BLOCK``: LLVM then knows exactly how rows are
spaced, proves the collision loops free of aliasing and vectorises them (no runtime
alias checks, no divisions but one reciprocal per node, no branches inside).

Streaming: the in-place AA pattern
----------------------------------
(Bailey et al. 2009) -- one array, no second lattice:

* even step (``_step_even``): at node x read ``f_i = A[x, i]``, collide, write the
  post-collision ``f*_i`` to ``A[x, opp(i)]`` (purely local);
* odd step (``_step_odd``): read ``f_i = A[x - c_i, opp(i)]`` (the post-collision value
  the neighbour stored in reversed order), collide, write ``f*_i`` to
  ``A[x + c_i, i]``. After an odd step the array is back in natural order,
  ``A[x, i] = f_i(x)`` (pre-collision, streamed).

Each node reads and writes exactly the same set of slots, so both steps are race
free in parallel and every slot is loaded and stored once per step: 2 x 19 values per
lattice update (152 B in float32, 304 B in float64) and no write-allocate traffic.

Boundaries (half-way bounce-back)
---------------------------------
A link from fluid node x along c_i into a solid node (or through a y-wall) reflects:
``f_opp(i)(x, t+1) = f*_i(x, t) - 2 w_i rho_w (c_i . u_w)/c_s^2`` with rho_w = rho0 = 1.
In the AA pattern this only touches the slot ``A[x, opp(i)]`` and only in odd
steps: the gather replaces the pull from the solid by ``A[x, j] + 6 w_j c_j . u_w``
(j = opp(i)), the scatter writes ``f*_i - 6 w_i c_i . u_w`` to ``A[x, opp(i)]``.
Solid nodes are never written (writes are restricted to the fluid runs of each
line); their slots are don't-care storage.

Collision (per node, relative storage f~ = f - w)
-------------------------------------------------
rho = 1 + sum f~_i,  u = (sum c_i f~_i + F/2) / rho,
feq~_i = w_i [ (rho - 1) + rho (3 c.u + 9/2 (c.u)^2 - 3/2 u^2) ],
Guo source S_i = w_i [ 3 (c_i - u).F + 9 (c_i.u)(c_i.F) ],
TRT on each pair (i, opp i): symmetric parts relax with omega+ = 1/tau+, antisymmetric
with omega- = 1/tau-, sources weighted by (1 - omega+-/2). BGK is omega- = omega+.

Arithmetic is done in the storage dtype; every constant comes from the ``consts``
array so float32 kernels never promote to float64.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .stencil import OPPOSITE, VELOCITIES, WEIGHTS

# indices into the ``consts`` array (all in the storage dtype)
K_OMEGA_PLUS = 0  # 1/tau+
K_OMEGA_MINUS = 1  # 1/tau-
K_SOURCE_PLUS = 2  # 1 - omega+/2
K_SOURCE_MINUS = 3  # 1 - omega-/2
K_GX = 4  # uniform body force density
K_GY = 5
K_GZ = 6
K_HALF = 7
K_ONE = 8
K_THREE = 9
K_NINE_HALVES = 10
K_THREE_HALVES = 11
K_NINE = 12
N_CONSTS = 13

BLOCK = 128
"""Nodes per block of a z-line (compile-time constant row spacing of the buffer)."""

# rows of the per-thread block buffer: 19 populations, then scratch
R_DRHO = 19  # rho - 1
R_RHO = 20  # rho
R_UX = 21  # u (half-force corrected)
R_UY = 22
R_UZ = 23
R_USQ = 24  # 3/2 u.u
R_UF = 25  # 3 u.F
R_FX = 26  # force density F = g + field
R_FY = 27
R_FZ = 28
N_ROWS = 29
BUFFER_LENGTH = N_ROWS * BLOCK

FASTMATH = False

U = np.uint64
"""Cast for z indices whose sign LLVM cannot prove: Numba skips the negative-index
wrap-around select for unsigned indices, which otherwise turns the contiguous copy
loops into gathers/scatters."""


def make_consts(omega_plus, omega_minus, body_force, dtype):
    """Pack the scalar constants of the kernels into an array of the storage dtype."""
    k = np.zeros(N_CONSTS, dtype=np.float64)
    k[K_OMEGA_PLUS] = omega_plus
    k[K_OMEGA_MINUS] = omega_minus
    k[K_SOURCE_PLUS] = 1.0 - 0.5 * omega_plus
    k[K_SOURCE_MINUS] = 1.0 - 0.5 * omega_minus
    k[K_GX], k[K_GY], k[K_GZ] = body_force
    k[K_HALF] = 0.5
    k[K_ONE] = 1.0
    k[K_THREE] = 3.0
    k[K_NINE_HALVES] = 4.5
    k[K_THREE_HALVES] = 1.5
    k[K_NINE] = 9.0
    return k.astype(dtype)


def stencil_tables(dtype):
    """(weights, float velocities, integer velocities, opposite) in the kernels' types."""
    return (
        WEIGHTS.astype(dtype),
        np.ascontiguousarray(VELOCITIES.astype(dtype)),
        np.ascontiguousarray(VELOCITIES.astype(np.int64)),
        OPPOSITE.astype(np.int64),
    )


# --------------------------------------------------------------------------- collision
@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _load_force(buf, force, has_field, x, y, z0, nb, consts):
    """Force density rows of the block: F = g + field(x, y, z0 : z0 + nb)."""
    gx = consts[K_GX]
    gy = consts[K_GY]
    gz = consts[K_GZ]
    if has_field:
        for k in range(nb):
            buf[R_FX * BLOCK + k] = gx + force[0, x, y, U(z0 + k)]
            buf[R_FY * BLOCK + k] = gy + force[1, x, y, U(z0 + k)]
            buf[R_FZ * BLOCK + k] = gz + force[2, x, y, U(z0 + k)]
    else:
        for k in range(nb):
            buf[R_FX * BLOCK + k] = gx
            buf[R_FY * BLOCK + k] = gy
            buf[R_FZ * BLOCK + k] = gz


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _collide_block(buf, nb, weights, cvel, consts):
    """TRT/BGK collision with Guo forcing of the nb nodes held in buf, in place.

    buf rows 0..18 hold f~_i = f_i - w_i (pre-collision on entry, post-collision on
    exit); rows R_FX..R_FZ must hold the force density F.
    """
    half = consts[K_HALF]
    one = consts[K_ONE]
    three = consts[K_THREE]
    nine_halves = consts[K_NINE_HALVES]
    three_halves = consts[K_THREE_HALVES]
    nine = consts[K_NINE]
    omega_p = consts[K_OMEGA_PLUS]
    omega_m = consts[K_OMEGA_MINUS]
    source_p = consts[K_SOURCE_PLUS]
    source_m = consts[K_SOURCE_MINUS]
    B = BLOCK

    # 1) moments: density and the half-force corrected velocity
    for k in range(nb):
        f0 = buf[0 * B + k]
        f1 = buf[1 * B + k]
        f2 = buf[2 * B + k]
        f3 = buf[3 * B + k]
        f4 = buf[4 * B + k]
        f5 = buf[5 * B + k]
        f6 = buf[6 * B + k]
        f7 = buf[7 * B + k]
        f8 = buf[8 * B + k]
        f9 = buf[9 * B + k]
        f10 = buf[10 * B + k]
        f11 = buf[11 * B + k]
        f12 = buf[12 * B + k]
        f13 = buf[13 * B + k]
        f14 = buf[14 * B + k]
        f15 = buf[15 * B + k]
        f16 = buf[16 * B + k]
        f17 = buf[17 * B + k]
        f18 = buf[18 * B + k]
        drho = (f0 + (f1 + f2) + (f3 + f4) + (f5 + f6) + (f7 + f8) + (f9 + f10)
                + (f11 + f12) + (f13 + f14) + (f15 + f16) + (f17 + f18))
        # momentum sum_i c_i f_i, grouped by opposite pairs (i, i+1); see stencil.py
        jx = (f1 - f2) + (f7 - f8) + (f9 - f10) + (f11 - f12) + (f13 - f14)
        jy = (f3 - f4) + (f7 - f8) - (f9 - f10) + (f15 - f16) + (f17 - f18)
        jz = (f5 - f6) + (f11 - f12) - (f13 - f14) + (f15 - f16) - (f17 - f18)
        rho = one + drho
        inv_rho = one / rho
        fx = buf[R_FX * B + k]
        fy = buf[R_FY * B + k]
        fz = buf[R_FZ * B + k]
        ux = (jx + half * fx) * inv_rho
        uy = (jy + half * fy) * inv_rho
        uz = (jz + half * fz) * inv_rho
        buf[R_DRHO * B + k] = drho
        buf[R_RHO * B + k] = rho
        buf[R_UX * B + k] = ux
        buf[R_UY * B + k] = uy
        buf[R_UZ * B + k] = uz
        buf[R_USQ * B + k] = three_halves * (ux * ux + uy * uy + uz * uz)
        buf[R_UF * B + k] = three * (ux * fx + uy * fy + uz * fz)

    # 2) rest population (symmetric part only)
    w0 = weights[0]
    for k in range(nb):
        f = buf[k]
        feq = w0 * (buf[R_DRHO * B + k] - buf[R_RHO * B + k] * buf[R_USQ * B + k])
        buf[k] = f + omega_p * (feq - f) - source_p * w0 * buf[R_UF * B + k]

    # 3) the nine opposite pairs (i, i+1)
    for i in range(1, 19, 2):
        w = weights[i]
        cx = cvel[i, 0]
        cy = cvel[i, 1]
        cz = cvel[i, 2]
        row_i = i * B
        row_o = (i + 1) * B
        for k in range(nb):
            fi = buf[row_i + k]
            fo = buf[row_o + k]
            rho = buf[R_RHO * B + k]
            cu = cx * buf[R_UX * B + k] + cy * buf[R_UY * B + k] + cz * buf[R_UZ * B + k]
            cf = cx * buf[R_FX * B + k] + cy * buf[R_FY * B + k] + cz * buf[R_FZ * B + k]
            f_sym = half * (fi + fo)
            f_asym = half * (fi - fo)
            feq_sym = w * (buf[R_DRHO * B + k] + rho * (nine_halves * cu * cu - buf[R_USQ * B + k]))
            feq_asym = w * three * rho * cu
            src_sym = w * (nine * cu * cf - buf[R_UF * B + k])
            src_asym = w * three * cf
            post_sym = f_sym + omega_p * (feq_sym - f_sym) + source_p * src_sym
            post_asym = f_asym + omega_m * (feq_asym - f_asym) + source_m * src_asym
            buf[row_i + k] = post_sym + post_asym
            buf[row_o + k] = post_sym - post_asym


# --------------------------------------------------------------------------- streaming
@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _gather_local(A, buf, x, y, z0, nb):
    """Even step: f_i = A[x, i] for the block (plain copy)."""
    for i in range(19):
        for k in range(nb):
            buf[U(i * BLOCK + k)] = A[x, y, i, U(z0 + k)]


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _scatter_local(A, buf, x, y, z0, nb, line, run_ptr, run_lo, run_hi, opp):
    """Even step: A[x, opp(i)] = f*_i on the fluid nodes of the block."""
    z1 = z0 + nb
    for r in range(run_ptr[line], run_ptr[line + 1]):
        lo = max(run_lo[r], z0)
        hi = min(run_hi[r], z1)
        for i in range(19):
            j = opp[i]
            for z in range(lo, hi):
                A[x, y, j, U(z)] = buf[U(i * BLOCK + z - z0)]


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _gather_neighbours(A, buf, x, y, z0, nb, nz, line, has_walls, wall_corr,
                       link_ptr, link_z, link_q, cint, opp):
    """Odd step: pull f_i(x) = A[x - c_i, opp(i)] (periodic) for the block, then replace
    pulls out of a y-wall or a solid node by the bounce-back value A[x, i] + wall_corr."""
    nx = A.shape[0]
    ny = A.shape[1]
    z1 = z0 + nb
    for i in range(19):
        xs = x - cint[i, 0]
        if xs < 0:
            xs += nx
        elif xs >= nx:
            xs -= nx
        ys = y - cint[i, 1]
        if ys < 0:
            ys += ny
        elif ys >= ny:
            ys -= ny
        j = opp[i]
        base = i * BLOCK - z0  # buf index of node z is base + z
        cz = cint[i, 2]
        if cz == 0:
            for z in range(z0, z1):
                buf[U(base + z)] = A[xs, ys, j, U(z)]
        elif cz == 1:  # comes from z - 1
            start = z0
            if z0 == 0:
                buf[U(base)] = A[xs, ys, j, U(nz - 1)]
                start = 1
            for z in range(start, z1):
                buf[U(base + z)] = A[xs, ys, j, U(z - 1)]
        else:  # comes from z + 1
            stop = z1
            if z1 == nz:
                buf[U(base + nz - 1)] = A[xs, ys, j, U(0)]
                stop = nz - 1
            for z in range(z0, stop):
                buf[U(base + z)] = A[xs, ys, j, U(z + 1)]
    if has_walls and (y == 0 or y == ny - 1):
        for i in range(19):
            cy = cint[i, 1]
            if (y == 0 and cy == 1) or (y == ny - 1 and cy == -1):  # leaves the wall
                c = wall_corr[0, i] if (y == 0 and cy == 1) else wall_corr[1, i]
                base = i * BLOCK - z0
                for z in range(z0, z1):
                    buf[U(base + z)] = A[x, y, i, U(z)] + c
    for n in range(link_ptr[line], link_ptr[line + 1]):
        z = link_z[n]
        if z0 <= z < z1:
            j = opp[link_q[n]]  # population coming out of the solid
            buf[U(j * BLOCK + z - z0)] = A[x, y, j, U(z)]


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _scatter_neighbours(A, buf, x, y, z0, nb, nz, line, run_ptr, run_lo, run_hi, has_walls,
                        wall_corr, link_ptr, link_z, link_q, cint, opp):
    """Odd step: push A[x + c_i, i] = f*_i from the fluid nodes of the block; links into a
    y-wall or a solid node bounce back into A[x, opp(i)] (+ moving-wall term)."""
    nx = A.shape[0]
    ny = A.shape[1]
    z1 = z0 + nb
    for i in range(19):
        cy = cint[i, 1]
        base = i * BLOCK - z0
        if has_walls and ((y == 0 and cy == -1) or (y == ny - 1 and cy == 1)):
            j = opp[i]
            c = wall_corr[0, j] if y == 0 else wall_corr[1, j]
            for r in range(run_ptr[line], run_ptr[line + 1]):
                for z in range(max(run_lo[r], z0), min(run_hi[r], z1)):
                    A[x, y, j, U(z)] = buf[U(base + z)] + c
            continue
        xd = x + cint[i, 0]
        if xd < 0:
            xd += nx
        elif xd >= nx:
            xd -= nx
        yd = y + cy
        if yd < 0:
            yd += ny
        elif yd >= ny:
            yd -= ny
        cz = cint[i, 2]
        for r in range(run_ptr[line], run_ptr[line + 1]):
            lo = max(run_lo[r], z0)
            hi = min(run_hi[r], z1)
            if lo >= hi:
                continue
            if cz == 0:
                for z in range(lo, hi):
                    A[xd, yd, i, U(z)] = buf[U(base + z)]
            elif cz == 1:  # goes to z + 1
                stop = hi
                if hi == nz:
                    A[xd, yd, i, U(0)] = buf[U(base + nz - 1)]
                    stop = nz - 1
                for z in range(lo, stop):
                    A[xd, yd, i, U(z + 1)] = buf[U(base + z)]
            else:  # goes to z - 1
                start = lo
                if lo == 0:
                    A[xd, yd, i, U(nz - 1)] = buf[U(base)]
                    start = 1
                for z in range(start, hi):
                    A[xd, yd, i, U(z - 1)] = buf[U(base + z)]
    for n in range(link_ptr[line], link_ptr[line + 1]):
        z = link_z[n]
        if z0 <= z < z1:
            i = link_q[n]  # population heading into the solid
            A[x, y, opp[i], U(z)] = buf[U(i * BLOCK + z - z0)]


# --------------------------------------------------------------------------- full steps
@njit(parallel=True, cache=True, fastmath=FASTMATH, error_model="numpy")
def _step_even(A, nz, force, has_field, run_ptr, run_lo, run_hi, consts, weights, cvel, opp):
    """AA even step: local collision, f*_i written to A[x, opp(i)]."""
    nx = A.shape[0]
    ny = A.shape[1]
    for x in prange(nx):
        buf = np.empty(BUFFER_LENGTH, dtype=A.dtype)
        for y in range(ny):
            line = x * ny + y
            if run_ptr[line + 1] == run_ptr[line]:
                continue  # all solid
            for z0 in range(0, nz, BLOCK):
                nb = min(BLOCK, nz - z0)
                _gather_local(A, buf, x, y, z0, nb)
                _load_force(buf, force, has_field, x, y, z0, nb, consts)
                _collide_block(buf, nb, weights, cvel, consts)
                _scatter_local(A, buf, x, y, z0, nb, line, run_ptr, run_lo, run_hi, opp)


@njit(parallel=True, cache=True, fastmath=FASTMATH, error_model="numpy")
def _step_odd(A, nz, force, has_field, run_ptr, run_lo, run_hi, has_walls, wall_corr,
              link_ptr, link_z, link_q, consts, weights, cvel, cint, opp):
    """AA odd step: gather from the neighbours, collide, scatter back (natural order)."""
    nx = A.shape[0]
    ny = A.shape[1]
    for x in prange(nx):
        buf = np.empty(BUFFER_LENGTH, dtype=A.dtype)
        for y in range(ny):
            line = x * ny + y
            if run_ptr[line + 1] == run_ptr[line]:
                continue  # all solid
            for z0 in range(0, nz, BLOCK):
                nb = min(BLOCK, nz - z0)
                _gather_neighbours(A, buf, x, y, z0, nb, nz, line, has_walls, wall_corr,
                                   link_ptr, link_z, link_q, cint, opp)
                _load_force(buf, force, has_field, x, y, z0, nb, consts)
                _collide_block(buf, nb, weights, cvel, consts)
                _scatter_neighbours(A, buf, x, y, z0, nb, nz, line, run_ptr, run_lo, run_hi,
                                    has_walls, wall_corr, link_ptr, link_z, link_q, cint, opp)


@njit(cache=True, error_model="numpy")
def run_steps(A, n_steps, parity, nz, force, has_field, run_ptr, run_lo, run_hi, has_walls,
              wall_corr, link_ptr, link_z, link_q, consts, weights, cvel, cint, opp):
    """Advance n_steps time steps inside compiled code; returns the new AA parity
    (0: A in natural order, 1: A holds post-collision values in reversed order)."""
    for _ in range(n_steps):
        if parity == 0:
            _step_even(A, nz, force, has_field, run_ptr, run_lo, run_hi, consts, weights, cvel, opp)
            parity = 1
        else:
            _step_odd(A, nz, force, has_field, run_ptr, run_lo, run_hi, has_walls, wall_corr,
                      link_ptr, link_z, link_q, consts, weights, cvel, cint, opp)
            parity = 0
    return parity


@njit(parallel=True, cache=True, error_model="numpy")
def natural_populations(A, parity, nz, has_walls, wall_corr, link_ptr, link_z, link_q, cint, opp, out):
    """Write the pre-collision populations f~_i(x) in natural order into out (19, nx, ny, nz).

    For parity 1 this performs the pending streaming (with bounce-back) without
    modifying A."""
    nx = A.shape[0]
    ny = A.shape[1]
    for x in prange(nx):
        buf = np.empty(BUFFER_LENGTH, dtype=A.dtype)
        for y in range(ny):
            for z0 in range(0, nz, BLOCK):
                nb = min(BLOCK, nz - z0)
                if parity == 0:
                    _gather_local(A, buf, x, y, z0, nb)
                else:
                    _gather_neighbours(A, buf, x, y, z0, nb, nz, x * ny + y, has_walls, wall_corr,
                                       link_ptr, link_z, link_q, cint, opp)
                for i in range(19):
                    for k in range(nb):
                        out[i, x, y, U(z0 + k)] = buf[i * BLOCK + k]
