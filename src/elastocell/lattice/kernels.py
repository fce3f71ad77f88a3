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

Details that were measured to matter (2-core AVX-512 machine, float32, 128^3):

* ``error_model="numpy"``: with Python's error model the reciprocal 1/rho carries a
  ZeroDivisionError branch and the moment loop stays scalar (~2x slower step);
* z indices go through ``U`` (uint64) where LLVM cannot prove them non-negative;
  Numba's negative-index wrap-around otherwise turns contiguous copies into
  gathers/scatters (copy loops 3-4x slower);
* the block buffer is 64-byte aligned and offset against 4K aliasing with the rows
  of A (``_block_buffer``; the odd step ~1.5x faster);
* shifted (c_z = +-1) copies run over whole rows and fix the periodic seam value
  afterwards instead of running n - 1 iterations, so LLVM's wide vector loop covers
  them (odd step at 64^3 ~1.3x faster). The one out-of-row read lands in the
  neighbouring row or in the margin the solver leaves around the storage.

Streaming: the in-place AA pattern
----------------------------------
(Bailey et al. 2009) -- one array, no second lattice:

* even step (``MODE_EVEN``): at node x read ``f_i = A[x, i]``, collide, write the
  post-collision ``f*_i`` to ``A[x, opp(i)]`` (purely local);
* odd step (``MODE_ODD``): read ``f_i = A[x - c_i, opp(i)]`` (the post-collision value
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

Interpolated (curved-wall) bounce-back (``curved``; coefficients in ``lattice.geometry``) stays race free:

* odd-step gather (bounce-back of the even collision): a near link (q < 1/2) weights the even step's
  f*_i(x), in A[x, opp(i)], with the population f_i(x) just pulled from x - c_i; a far link weights it with
  the even step's f*_opp(i)(x), which the even step kept in ``memory[link]`` (its slot belongs to the
  neighbour x - c_i in the odd step and may already be overwritten);
* odd-step scatter (bounce-back of the odd collision): a far link writes its whole value from this node's
  f*; a near link writes its part 2q f*_i(x), and the next local step adds (1 - 2q) A[x, i], the population
  that arrived along the link, before it collides. After an odd step (parity 0) the slot of a near link thus
  holds f_opp(i) - (1 - 2q) f_i: :meth:`elastocell.lattice.solver.Lattice.set_population_deviations` stores
  that form, and every local pass (step, export, moments) completes it.

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

from elastocell.lattice.rheology import relaxation_time_table, tabulated_relaxation_time
from elastocell.lattice.stencil import OPPOSITE, VELOCITIES, WEIGHTS

_tabulated_tau = njit(cache=True, inline="always", error_model="numpy")(tabulated_relaxation_time)

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
# medium (see ``lattice.rheology``): model 0 Newtonian (the rates above), 1 power law (rates per node)
K_MODEL = 13
K_FLOW_INDEX = 14  # n
K_THREE_K = 15  # 3 K (lattice units)
K_TAU_MIN = 16
K_TAU_MAX = 17
K_MAGIC = 18  # TRT Lambda; 0 for BGK (tau- = tau+)
K_THIRD = 19
N_CONSTS = 20
K_TABLE = N_CONSTS  # a power-law medium's tau table follows (``rheology.relaxation_time_table``)

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
R_OMEGA_PLUS = 29  # per-node 1/tau+ (power-law medium only)
R_OMEGA_MINUS = 30  # per-node 1/tau-
N_ROWS = 31
BUFFER_LENGTH = N_ROWS * BLOCK

FASTMATH = {"contract", "arcp", "reassoc", "nsz"}
"""LLVM fast-math flags of the kernels: fused multiply-adds, reciprocal and reassociation (no ``nnan``/``ninf``,
so a non-finite population still propagates and the runner's guards see it). Measured (128^3 float32, 2 threads):
the local (even) AA step 92 -> 116 MLUPS, the neighbour (odd) step unchanged at 73 MLUPS; the float64 reference
tests still agree to round-off."""

U = np.uint64
"""Cast for z indices whose sign LLVM cannot prove: Numba skips the negative-index
wrap-around select for unsigned indices, which otherwise turns the contiguous copy
loops into gathers/scatters."""

# Visiting order of the 19 rows in the odd-step gather / scatter: sorted by the address
# of the row touched, (x -+ c_x, y -+ c_y, row), so each neighbour line is read or
# written in ascending memory order (friendlier to the hardware prefetchers).
GATHER_ORDER = np.array(
    sorted(range(19), key=lambda i: (-VELOCITIES[i, 0], -VELOCITIES[i, 1], OPPOSITE[i])), dtype=np.int64
)
SCATTER_ORDER = np.array(
    sorted(range(19), key=lambda i: (VELOCITIES[i, 0], VELOCITIES[i, 1], i)), dtype=np.int64
)


def make_consts(omega_plus, omega_minus, body_force, dtype, rheology=None, magic=0.0):
    """Pack the scalar constants of the kernels into an array of the storage dtype.

    ``rheology``: None (Newtonian: omega+- everywhere) or a :class:`~elastocell.lattice.rheology.PowerLaw`, whose
    tau+ each node reads from its own strain rate in the law's table (appended at :data:`K_TABLE`); ``magic`` the
    TRT Lambda then (0: BGK)."""
    k = np.zeros(N_CONSTS, dtype=np.float64)
    if rheology is not None:
        k[K_MODEL] = 1.0
        k[K_FLOW_INDEX] = rheology.flow_index
        k[K_THREE_K] = 3.0 * rheology.consistency
        k[K_TAU_MIN] = rheology.relaxation_time_min
        k[K_TAU_MAX] = rheology.relaxation_time_max
        k[K_MAGIC] = magic
    k[K_THIRD] = 1.0 / 3.0
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
    if rheology is not None:
        k = np.concatenate([k, relaxation_time_table(3.0 * rheology.consistency, rheology.flow_index,
                                                     rheology.relaxation_time_min, rheology.relaxation_time_max)])
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
def _moments_block(buf, nb, consts):
    """Moments of the nb nodes held in buf (rows 0..18: f~_i; R_FX..R_FZ: force F).

    Writes rho - 1, rho, u = (sum c_i f_i + F/2)/rho, 3/2 u.u and 3 u.F to the
    scratch rows R_DRHO .. R_UF.
    """
    half = consts[K_HALF]
    one = consts[K_ONE]
    three = consts[K_THREE]
    three_halves = consts[K_THREE_HALVES]
    B = BLOCK
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
        drho = (
            f0
            + (f1 + f2)
            + (f3 + f4)
            + (f5 + f6)
            + (f7 + f8)
            + (f9 + f10)
            + (f11 + f12)
            + (f13 + f14)
            + (f15 + f16)
            + (f17 + f18)
        )
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


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _collide_block(buf, nb, weights, cvel, consts):
    """TRT/BGK collision with Guo forcing of the nb nodes held in buf, in place.

    buf rows 0..18 hold f~_i = f_i - w_i (pre-collision on entry, post-collision on
    exit); rows R_FX..R_FZ must hold the force density F. A power-law medium (``consts[K_MODEL]`` 1) takes
    the rates of each node from its strain rate (:func:`_collide_block_local_rates`).
    """
    if consts[K_MODEL] != 0:
        _collide_block_local_rates(buf, nb, weights, cvel, consts)
        return
    half = consts[K_HALF]
    three = consts[K_THREE]
    nine_halves = consts[K_NINE_HALVES]
    nine = consts[K_NINE]
    omega_p = consts[K_OMEGA_PLUS]
    omega_m = consts[K_OMEGA_MINUS]
    source_p = consts[K_SOURCE_PLUS]
    source_m = consts[K_SOURCE_MINUS]
    B = BLOCK

    # 1) moments: density and the half-force corrected velocity
    _moments_block(buf, nb, consts)

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


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _local_rates_block(buf, nb, consts):
    """Per-node relaxation rates of a power-law medium (``lattice.rheology``) into rows R_OMEGA_PLUS/MINUS.

    Needs the moments rows (``_moments_block``). Pi = sum_i c_i c_i (f_i - f^eq_i) + (u F + F u)/2 from the
    pair sums f_i + f_opp(i) (only they carry second moments), m = 3 sqrt(2 Pi:Pi)/(2 rho), tau+ the clamped
    root of gdot tau(gdot) = m read from the law's table at log m (in float64), tau- = 1/2 + Lambda/(tau+ - 1/2)
    (TRT) or tau+ (BGK, Lambda 0)."""
    half = consts[K_HALF]
    third = consts[K_THIRD]
    tau_min = np.float64(consts[K_TAU_MIN])
    tau_max = np.float64(consts[K_TAU_MAX])
    magic = np.float64(consts[K_MAGIC])
    B = BLOCK
    for k in range(nb):
        s1 = buf[1 * B + k] + buf[2 * B + k]  # (+-1, 0, 0)
        s3 = buf[3 * B + k] + buf[4 * B + k]  # (0, +-1, 0)
        s5 = buf[5 * B + k] + buf[6 * B + k]  # (0, 0, +-1)
        s7 = buf[7 * B + k] + buf[8 * B + k]  # +-(1, 1, 0)
        s9 = buf[9 * B + k] + buf[10 * B + k]  # +-(1, -1, 0)
        s11 = buf[11 * B + k] + buf[12 * B + k]  # +-(1, 0, 1)
        s13 = buf[13 * B + k] + buf[14 * B + k]  # +-(1, 0, -1)
        s15 = buf[15 * B + k] + buf[16 * B + k]  # +-(0, 1, 1)
        s17 = buf[17 * B + k] + buf[18 * B + k]  # +-(0, 1, -1)
        drho = buf[R_DRHO * B + k]
        rho = buf[R_RHO * B + k]
        ux = buf[R_UX * B + k]
        uy = buf[R_UY * B + k]
        uz = buf[R_UZ * B + k]
        fx = buf[R_FX * B + k]
        fy = buf[R_FY * B + k]
        fz = buf[R_FZ * B + k]
        iso = third * drho  # sum c c (f^eq - w) = (rho - 1)/3 delta + rho u u
        pxx = s1 + s7 + s9 + s11 + s13 - iso - rho * ux * ux + ux * fx
        pyy = s3 + s7 + s9 + s15 + s17 - iso - rho * uy * uy + uy * fy
        pzz = s5 + s11 + s13 + s15 + s17 - iso - rho * uz * uz + uz * fz
        pxy = s7 - s9 - rho * ux * uy + half * (ux * fy + uy * fx)
        pxz = s11 - s13 - rho * ux * uz + half * (ux * fz + uz * fx)
        pyz = s15 - s17 - rho * uy * uz + half * (uy * fz + uz * fy)
        pp = np.float64(pxx * pxx + pyy * pyy + pzz * pzz + 2.0 * (pxy * pxy + pxz * pxz + pyz * pyz))
        rho64 = np.float64(rho)
        log_m = 0.5 * np.log(4.5 * pp / (rho64 * rho64))  # m = 3 sqrt(2 Pi:Pi)/(2 rho)
        tau = _tabulated_tau(log_m, consts, K_TABLE, tau_min, tau_max)
        tau_m = tau if magic == 0.0 else 0.5 + magic / (tau - 0.5)
        buf[R_OMEGA_PLUS * B + k] = 1.0 / tau
        buf[R_OMEGA_MINUS * B + k] = 1.0 / tau_m


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _collide_block_local_rates(buf, nb, weights, cvel, consts):
    """The collision of ``_collide_block`` with the relaxation rates of each node (power-law medium)."""
    half = consts[K_HALF]
    one = consts[K_ONE]
    three = consts[K_THREE]
    nine_halves = consts[K_NINE_HALVES]
    nine = consts[K_NINE]
    B = BLOCK
    _moments_block(buf, nb, consts)
    _local_rates_block(buf, nb, consts)
    w0 = weights[0]
    for k in range(nb):
        f = buf[k]
        omega_p = buf[R_OMEGA_PLUS * B + k]
        feq = w0 * (buf[R_DRHO * B + k] - buf[R_RHO * B + k] * buf[R_USQ * B + k])
        buf[k] = f + omega_p * (feq - f) - (one - half * omega_p) * w0 * buf[R_UF * B + k]
    for i in range(1, 19, 2):
        w = weights[i]
        cx = cvel[i, 0]
        cy = cvel[i, 1]
        cz = cvel[i, 2]
        row_i = i * B
        row_o = (i + 1) * B
        for k in range(nb):
            omega_p = buf[R_OMEGA_PLUS * B + k]
            omega_m = buf[R_OMEGA_MINUS * B + k]
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
            post_sym = f_sym + omega_p * (feq_sym - f_sym) + (one - half * omega_p) * src_sym
            post_asym = f_asym + omega_m * (feq_asym - f_asym) + (one - half * omega_m) * src_asym
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
def _gather_neighbours(
    A, buf, x, y, z0, nb, nz, line, has_walls, wall_corr, link_ptr, link_z, link_q, cint, opp,
    link_a, link_b, link_near, memory, curved,
):
    """Odd step: pull f_i(x) = A[x - c_i, opp(i)] (periodic) for the block, then replace
    pulls out of a y-wall or a solid node by the bounce-back value A[x, i] + wall_corr (with ``curved``, the
    interpolated value of ``lattice.geometry``: the even step's f* of the link, A[x, opp(i)], weighted with the
    population just pulled along the link (near) or with the even step's f*_opp(i)(x) kept in ``memory`` (far))."""
    nx = A.shape[0]
    ny = A.shape[1]
    z1 = z0 + nb
    for n in range(19):
        i = GATHER_ORDER[n]
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
        # Full-length copies (nb values, so LLVM's wide vector loop covers them); at the
        # periodic z seam one value is read from just outside the row (valid memory:
        # the neighbouring row or the margin around the storage, see ``solver``) and
        # then overwritten with the periodic image.
        if cz == 0:
            for z in range(z0, z1):
                buf[U(base + z)] = A[xs, ys, j, U(z)]
        elif cz == 1:  # comes from z - 1
            for z in range(z0, z1):
                buf[U(base + z)] = A[xs, ys, j, U(z - 1)]
            if z0 == 0:
                buf[U(base)] = A[xs, ys, j, U(nz - 1)]
        else:  # comes from z + 1
            for z in range(z0, z1):
                buf[U(base + z)] = A[xs, ys, j, U(z + 1)]
            if z1 == nz:
                buf[U(base + nz - 1)] = A[xs, ys, j, U(0)]
    if has_walls and (y == 0 or y == ny - 1):
        for i in range(19):
            cy = cint[i, 1]
            if (y == 0 and cy == 1) or (y == ny - 1 and cy == -1):  # leaves the wall
                c = wall_corr[0, i] if (y == 0 and cy == 1) else wall_corr[1, i]
                base = i * BLOCK - z0
                for z in range(z0, z1):
                    buf[U(base + z)] = A[x, y, i, U(z)] + c
    if not curved:
        for n in range(link_ptr[line], link_ptr[line + 1]):
            z = link_z[n]
            if z0 <= z < z1:
                j = opp[link_q[n]]  # population coming out of the solid
                buf[U(j * BLOCK + z - z0)] = A[x, y, j, U(z)]
        return
    for n in range(link_ptr[line], link_ptr[line + 1]):
        z = link_z[n]
        if z0 <= z < z1:
            i = link_q[n]  # population that went into the solid
            j = opp[i]  # population coming out of it
            k = z - z0
            second = buf[U(i * BLOCK + k)] if link_near[n] else memory[n]
            buf[U(j * BLOCK + k)] = link_a[n] * A[x, y, j, U(z)] + link_b[n] * second


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _scatter_neighbours(
    A,
    buf,
    x,
    y,
    z0,
    nb,
    nz,
    line,
    run_ptr,
    run_lo,
    run_hi,
    has_walls,
    wall_corr,
    link_ptr,
    link_z,
    link_q,
    cint,
    opp,
    link_a,
    link_b,
    link_near,
    curved,
):
    """Odd step: push A[x + c_i, i] = f*_i from the fluid nodes of the block; links into a
    y-wall or a solid node bounce back into A[x, opp(i)] (+ moving-wall term). With ``curved`` the bounce-back
    is interpolated (``lattice.geometry``): a far link writes its whole value from this node's f*; a near link
    writes its part 2q f*_i(x), completed by the next (local) step with the population streamed along the
    link (:func:`_complete_near_links`)."""
    nx = A.shape[0]
    ny = A.shape[1]
    z1 = z0 + nb
    for n in range(19):
        i = SCATTER_ORDER[n]
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
            elif lo == 0 and hi == nz:
                # whole periodic line in this block: full-length shifted copy whose one
                # out-of-row read (buffer margin / next buffer row) lands on the seam
                # value, which is then overwritten with its periodic image
                if cz == 1:
                    for z in range(nz):
                        A[xd, yd, i, U(z)] = buf[U(base + z - 1)]
                    A[xd, yd, i, U(0)] = buf[U(base + nz - 1)]
                else:
                    for z in range(nz):
                        A[xd, yd, i, U(z)] = buf[U(base + z + 1)]
                    A[xd, yd, i, U(nz - 1)] = buf[U(base)]
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
    if not curved:
        for n in range(link_ptr[line], link_ptr[line + 1]):
            z = link_z[n]
            if z0 <= z < z1:
                i = link_q[n]  # population heading into the solid
                A[x, y, opp[i], U(z)] = buf[U(i * BLOCK + z - z0)]
        return
    for n in range(link_ptr[line], link_ptr[line + 1]):
        z = link_z[n]
        if z0 <= z < z1:
            i = link_q[n]  # population heading into the solid
            j = opp[i]
            k = z - z0
            value = link_a[n] * buf[U(i * BLOCK + k)]
            if not link_near[n]:
                value += link_b[n] * buf[U(j * BLOCK + k)]
            A[x, y, j, U(z)] = value


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _complete_near_links(buf, z0, nb, line, link_ptr, link_z, link_q, link_b, link_near, opp):
    """Local (even) step, after the gather: a near link's returning population f_opp(i)(x), of which the odd
    step stored 2q f*_i(x), gains (1 - 2q) f_i(x) = (1 - 2q) f*_i(x - c_i), the population that arrived along
    the link."""
    z1 = z0 + nb
    for n in range(link_ptr[line], link_ptr[line + 1]):
        z = link_z[n]
        if link_near[n] and z0 <= z < z1:
            i = link_q[n]
            k = z - z0
            buf[U(opp[i] * BLOCK + k)] += link_b[n] * buf[U(i * BLOCK + k)]


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _remember_far_links(buf, z0, nb, line, link_ptr, link_z, link_q, link_near, opp, memory):
    """Local (even) step, after the collision: keep f*_opp(i)(x) of each far link for the next (odd) step's
    interpolated bounce-back, whose slot a neighbour overwrites in the meantime."""
    z1 = z0 + nb
    for n in range(link_ptr[line], link_ptr[line + 1]):
        z = link_z[n]
        if not link_near[n] and z0 <= z < z1:
            memory[n] = buf[U(opp[link_q[n]] * BLOCK + z - z0)]


@njit(cache=True, error_model="numpy")
def _in_box(i, lo, size, n):
    """Whether lattice index i (0 <= i < n) lies in the periodic range lo, lo + 1, ..., lo + size - 1."""
    return size >= n or (i - lo) % n < size


@njit(cache=True, error_model="numpy")
def _store_velocity(buf, out, x, y, z0, nb, nz, line, run_ptr, run_lo, run_hi, box):
    """out[0:3, x, y, z] = u (the half-force corrected velocity the collision used) on the fluid nodes of the
    block inside the box's z range; rows R_UX..R_UZ of buf hold u (see ``_moments_block``)."""
    z1 = z0 + nb
    for r in range(run_ptr[line], run_ptr[line + 1]):
        for z in range(max(run_lo[r], z0), min(run_hi[r], z1)):
            if _in_box(z, box[2], box[5], nz):
                k = z - z0
                out[0, x, y, U(z)] = buf[R_UX * BLOCK + k]
                out[1, x, y, U(z)] = buf[R_UY * BLOCK + k]
                out[2, x, y, U(z)] = buf[R_UZ * BLOCK + k]


# --------------------------------------------------------------------------- block buffer
@njit(cache=True, error_model="numpy")
def _gcd(a, b):
    while b:
        a, b = b, a % b
    return a


@njit(cache=True, error_model="numpy")
def _block_buffer(A):
    """A per-thread block buffer (BUFFER_LENGTH values), cache-line aligned and placed
    against 4K aliasing.

    The copy loops load from rows of A and store to rows of the buffer (or the
    reverse). A buffer that is not 64-byte aligned splits every vector access over two
    cache lines (measured: the whole step ~1.4x slower); a load that shares its low 12
    address bits with an earlier store is held back by the CPU (4K aliasing; measured
    up to 3-6x slower copies for short rows). Rows of A sit at multiples of ``g`` bytes
    modulo 4096 and so do the buffer rows, so the buffer is placed half a period (g/2,
    a multiple of 64 bytes) away from every row of A."""
    itemsize = A.itemsize
    g = _gcd(_gcd(A.shape[3] * itemsize, 4096), BLOCK * itemsize)
    margin = 64 // itemsize  # valid memory before the buffer (seam reads)
    big = np.empty(BUFFER_LENGTH + 4096 // itemsize + 2 * margin, dtype=A.dtype)
    shift = g // 2 if g >= 128 else 0  # keep the buffer 64-byte aligned
    target = (A.ctypes.data + shift) % g
    offset = (target - (big.ctypes.data + 64) % g) % g
    start = margin + offset // itemsize
    return big[start : start + BUFFER_LENGTH]


# --------------------------------------------------------------------------- full sweeps
MODE_EVEN = 0  # AA even step: local collision, f*_i written to A[x, opp(i)]
MODE_ODD = 1  # AA odd step: gather from neighbours, collide, scatter back (natural order)
MODE_EXPORT_EVEN = 2  # copy natural-order populations to ``out`` (A after an odd step)
MODE_EXPORT_ODD = 3  # stream the pending post-collision values into ``out`` (A after an even step)
MODE_MOMENTS_EVEN = 4  # out[0] = rho - 1, out[1:4] = u, A in natural order
MODE_MOMENTS_ODD = 5  # the same, A after an even step (pending streaming done on the fly)
NO_BOX = np.zeros(6, dtype=np.int64)
"""The ``box`` argument of a step that stores no velocity."""


@njit(parallel=True, cache=True, fastmath=FASTMATH, error_model="numpy")
def _sweep(
    A,
    mode,
    nz,
    force,
    has_field,
    run_ptr,
    run_lo,
    run_hi,
    has_walls,
    wall_corr,
    link_ptr,
    link_z,
    link_q,
    consts,
    weights,
    cvel,
    cint,
    opp,
    link_a,
    link_b,
    link_near,
    memory,
    curved,
    out,
    box,
):
    """One parallel pass over the lattice, by x-planes and z-blocks (see MODE_*).

    A single compiled function serves both AA steps and the exports (populations or
    moments) so that Numba compiles (and caches) one parallel region per dtype.

    In the step modes, ``box`` (int64[6]: lower corner lo_x, lo_y, lo_z and sizes n_x, n_y, n_z, periodic)
    with n_x > 0 makes the step also write the velocity u its collision used, ``(sum c_i f_i + F/2)/rho``, to
    ``out[0:3, x, y, z]`` (out: (>= 3, nx, ny, nz)) at the fluid nodes inside the box; other nodes of ``out``
    are left as they were. The immersed boundary reads the marker velocities there instead of re-reading the
    populations (see ``elastocell.coupling.immersed._coupled_steps``)."""
    nx = A.shape[0]
    ny = A.shape[1]
    local = mode == MODE_EVEN or mode == MODE_EXPORT_EVEN or mode == MODE_MOMENTS_EVEN
    export = mode >= MODE_EXPORT_EVEN
    moments = mode >= MODE_MOMENTS_EVEN
    store = not export and box[3] > 0
    for x in prange(nx):
        buf = _block_buffer(A)
        store_x = store and _in_box(x, box[0], box[3], nx)
        for y in range(ny):
            line = x * ny + y
            if not export and run_ptr[line + 1] == run_ptr[line]:
                continue  # all solid: nothing to update
            store_line = store_x and _in_box(y, box[1], box[4], ny)
            for z0 in range(0, nz, BLOCK):
                nb = min(BLOCK, nz - z0)
                if local:
                    _gather_local(A, buf, x, y, z0, nb)
                    if curved:
                        _complete_near_links(buf, z0, nb, line, link_ptr, link_z, link_q, link_b, link_near, opp)
                else:
                    _gather_neighbours(
                        A,
                        buf,
                        x,
                        y,
                        z0,
                        nb,
                        nz,
                        line,
                        has_walls,
                        wall_corr,
                        link_ptr,
                        link_z,
                        link_q,
                        cint,
                        opp,
                        link_a,
                        link_b,
                        link_near,
                        memory,
                        curved,
                    )
                if moments:
                    _load_force(buf, force, has_field, x, y, z0, nb, consts)
                    _moments_block(buf, nb, consts)
                    for k in range(nb):
                        out[0, x, y, U(z0 + k)] = buf[R_DRHO * BLOCK + k]
                        out[1, x, y, U(z0 + k)] = buf[R_UX * BLOCK + k]
                        out[2, x, y, U(z0 + k)] = buf[R_UY * BLOCK + k]
                        out[3, x, y, U(z0 + k)] = buf[R_UZ * BLOCK + k]
                    continue
                if export:
                    for i in range(19):
                        for k in range(nb):
                            out[i, x, y, U(z0 + k)] = buf[i * BLOCK + k]
                    continue
                _load_force(buf, force, has_field, x, y, z0, nb, consts)
                _collide_block(buf, nb, weights, cvel, consts)
                if store_line:
                    _store_velocity(buf, out, x, y, z0, nb, nz, line, run_ptr, run_lo, run_hi, box)
                if local:
                    if curved and mode == MODE_EVEN:
                        _remember_far_links(buf, z0, nb, line, link_ptr, link_z, link_q, link_near, opp, memory)
                    _scatter_local(A, buf, x, y, z0, nb, line, run_ptr, run_lo, run_hi, opp)
                else:
                    _scatter_neighbours(
                        A,
                        buf,
                        x,
                        y,
                        z0,
                        nb,
                        nz,
                        line,
                        run_ptr,
                        run_lo,
                        run_hi,
                        has_walls,
                        wall_corr,
                        link_ptr,
                        link_z,
                        link_q,
                        cint,
                        opp,
                        link_a,
                        link_b,
                        link_near,
                        curved,
                    )


@njit(cache=True, error_model="numpy")
def run_steps(
    A,
    n_steps,
    parity,
    nz,
    force,
    has_field,
    run_ptr,
    run_lo,
    run_hi,
    has_walls,
    wall_corr,
    link_ptr,
    link_z,
    link_q,
    consts,
    weights,
    cvel,
    cint,
    opp,
    link_a,
    link_b,
    link_near,
    memory,
    curved,
    out,
):
    """Advance n_steps time steps inside compiled code; returns the new AA parity
    (0: A in natural order, 1: A holds post-collision values in reversed order).
    ``out`` is unused here (any (19, 1, 1, 1) array of the storage dtype)."""
    no_box = np.zeros(6, dtype=np.int64)
    for _ in range(n_steps):
        _sweep(
            A,
            parity,
            nz,
            force,
            has_field,
            run_ptr,
            run_lo,
            run_hi,
            has_walls,
            wall_corr,
            link_ptr,
            link_z,
            link_q,
            consts,
            weights,
            cvel,
            cint,
            opp,
            link_a,
            link_b,
            link_near,
            memory,
            curved,
            out,
            no_box,
        )
        parity = 1 - parity
    return parity


def moments(A, parity, nz, force, has_field, tables, out):
    """Write rho - 1 to out[0] and u = (sum c_i f_i + F/2)/rho to out[1:4] (out: (4, nx, ny, nz)),
    from the pre-collision populations, in the storage dtype.

    tables = (run_ptr, run_lo, run_hi, has_walls, wall_corr, link_ptr, link_z, link_q,
    consts, weights, cvel, cint, opp, link_a, link_b, link_near, memory, curved), as for ``run_steps``."""
    mode = MODE_MOMENTS_ODD if parity else MODE_MOMENTS_EVEN
    _sweep(A, mode, nz, force, has_field, *tables, out, NO_BOX)


def natural_populations(A, parity, nz, tables, out):
    """Write the pre-collision populations f~_i(x) in natural order into out (19, nx, ny, nz).

    For parity 1 this performs the pending streaming (with bounce-back) without
    modifying A. ``tables`` as for :func:`moments`."""
    mode = MODE_EXPORT_ODD if parity else MODE_EXPORT_EVEN
    no_force = np.zeros((3, 1, 1, 1), dtype=A.dtype)
    _sweep(A, mode, nz, no_force, False, *tables, out, NO_BOX)
