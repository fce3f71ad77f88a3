"""Immersed-boundary coupling: interpolation of the lattice velocity at markers and spreading of marker
forces to the lattice force density (lattice units: dx = dt = 1, rho0 = 1).

Every mesh node of the cell is a massless marker at a (continuous, unwrapped) position ``X`` in units of
dx; lattice node ``(i, j, k)`` sits at position ``(i, j, k)``. A separable kernel
``delta(r) = phi(r_x) phi(r_y) phi(r_z)`` couples a marker to the lattice nodes around it:

* ``trilinear`` (default; the 2-point kernel of the paper's group): ``phi(r) = 1 - |r|`` for ``|r| <= 1``;
  interpolation of a linear field is exact.
* ``peskin4`` (Peskin's 4-point cosine-free kernel): ``phi(r) = (3 - 2|r| + sqrt(1 + 4|r| - 4 r^2))/8`` for
  ``|r| <= 1`` and ``(5 - 2|r| - sqrt(-7 + 12|r| - 4 r^2))/8`` for ``1 <= |r| <= 2``.

Both satisfy ``sum_j phi(r - j) = 1`` and ``sum_j (r - j) phi(r - j) = 0``, so spreading conserves the total
force and the torque, and interpolation reproduces constant and linear fields.

Interpolation: ``U(X) = sum_n u(n) delta(n - X)``. Spreading: ``F(n) += f delta(n - X)`` (a force density,
force per dx^3). Boundaries: periodic in x and z; in y periodic for a lattice without walls, otherwise the
nodes beyond the walls (y < 0 or y > ny - 1) are dropped: a marker must stay a kernel half-width away from
the walls (the flow scenario guards this).

Half-force correction: the velocity read from the populations is ``u = (sum_i c_i f_i + F/2)/rho`` with
``F`` the force density the next step applies (Guo forcing), exactly what :meth:`Lattice.velocity`
returns; :func:`interpolate_lattice_velocity` evaluates it at the kernel nodes only (no full-lattice pass).

Every function here is compiled (Numba); no Python loop runs over markers or lattice nodes. Interpolation
is parallel over markers; spreading is a serial scatter-add (race free; a few microseconds per thousand
markers).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from elastocell.lattice.kernels import K_GX, K_GY, K_GZ

KERNELS = {"trilinear": 0, "peskin4": 1}
"""Kernel names and their compiled ids."""

KERNEL_SUPPORT = {"trilinear": 2, "peskin4": 4}
"""Number of lattice nodes a kernel touches per direction."""

_MAX_SUPPORT = 4


def kernel_id(kernel: str) -> int:
    """Compiled id of a kernel name; ValueError for an unknown one."""
    try:
        return KERNELS[kernel]
    except KeyError:
        raise ValueError(f"kernel must be one of {', '.join(KERNELS)}, got {kernel!r}") from None


def kernel_half_width(kernel: str) -> float:
    """Largest distance (dx) from a marker to a lattice node of its support: 1 (trilinear), 2 (peskin4)."""
    return KERNEL_SUPPORT[kernel] / 2.0


# --------------------------------------------------------------------------- 1D kernels
@njit(cache=True, inline="always", error_model="numpy")
def _phi(kernel, r):
    """phi(r) of the kernel (r in dx)."""
    a = abs(r)
    if kernel == 0:
        return 1.0 - a if a < 1.0 else 0.0
    if a <= 1.0:
        return (3.0 - 2.0 * a + math.sqrt(1.0 + 4.0 * a - 4.0 * a * a)) * 0.125
    if a < 2.0:
        return (5.0 - 2.0 * a - math.sqrt(max(-7.0 + 12.0 * a - 4.0 * a * a, 0.0))) * 0.125
    return 0.0


@njit(cache=True, inline="always", error_model="numpy")
def _stencil(kernel, s, w):
    """Fill w[0:n] with the weights of nodes base .. base + n - 1 for a marker at s; return (base, n)."""
    if kernel == 0:
        base = math.floor(s)
        t = s - base
        w[0] = 1.0 - t
        w[1] = t
        return int(base), 2
    base = math.floor(s) - 1
    for k in range(4):
        w[k] = _phi(kernel, s - (base + k))
    return int(base), 4


@njit(cache=True, inline="always", error_model="numpy")
def _wrap(i, n):
    i = i % n
    return i + n if i < 0 else i


def kernel_weights(kernel: str, r) -> np.ndarray:
    """phi(r) of a kernel, vectorised over r (dx); for tests and plots."""
    kid = kernel_id(kernel)
    r = np.asarray(r, dtype=np.float64)
    return _phi_array(kid, r.ravel()).reshape(r.shape)


@njit(cache=True, error_model="numpy")
def _phi_array(kernel, r):
    out = np.empty_like(r)
    for i in range(r.size):
        out[i] = _phi(kernel, r[i])
    return out


# --------------------------------------------------------------------------- kernel supports
_MAX_NODES = _MAX_SUPPORT**3


@njit(cache=True, error_model="numpy")
def _support_scratch():
    """(weights (3, _MAX_SUPPORT), node x, y, z indices and weights (_MAX_NODES each)) for :func:`_support`."""
    return (np.empty((3, _MAX_SUPPORT)), np.empty(_MAX_NODES, dtype=np.int64), np.empty(_MAX_NODES, dtype=np.int64),
            np.empty(_MAX_NODES, dtype=np.int64), np.empty(_MAX_NODES))


@njit(cache=True, inline="always", error_model="numpy")
def _support(kernel, position, nx, ny, nz, periodic_y, scratch):
    """The lattice nodes n = (ix, iy, iz) of the kernel support of a marker at ``position`` and their weights
    delta(n - X), written to ``scratch`` (see :func:`_support_scratch`); returns their number. Periodic in x and
    z; in y periodic if ``periodic_y``, else the nodes beyond the walls (y < 0 or y >= ny) are left out."""
    w, ix, iy, iz, weights = scratch
    bx, n = _stencil(kernel, position[0], w[0])
    by, _ = _stencil(kernel, position[1], w[1])
    bz, _ = _stencil(kernel, position[2], w[2])
    count = 0
    for b in range(n):
        y = by + b
        if periodic_y:
            y = _wrap(y, ny)
        elif y < 0 or y >= ny:
            continue
        for a in range(n):
            x = _wrap(bx + a, nx)
            wxy = w[0, a] * w[1, b]
            for c in range(n):
                ix[count] = x
                iy[count] = y
                iz[count] = _wrap(bz + c, nz)
                weights[count] = wxy * w[2, c]
                count += 1
    return count


# --------------------------------------------------------------------------- field interpolation
@njit(cache=True, inline="always", error_model="numpy")
def _interpolate_marker(field, positions, m, kernel, periodic_y, out, scratch):
    """out[m] = sum_n field(n) delta(n - X_m)."""
    count = _support(kernel, positions[m], field.shape[1], field.shape[2], field.shape[3], periodic_y, scratch)
    _, ix, iy, iz, weights = scratch
    ux = 0.0
    uy = 0.0
    uz = 0.0
    for j in range(count):
        w = weights[j]
        ux += w * field[0, ix[j], iy[j], iz[j]]
        uy += w * field[1, ix[j], iy[j], iz[j]]
        uz += w * field[2, ix[j], iy[j], iz[j]]
    out[m, 0] = ux
    out[m, 1] = uy
    out[m, 2] = uz


@njit(parallel=True, cache=True, error_model="numpy")
def _interpolate_field(field, positions, kernel, periodic_y, out):
    for m in prange(positions.shape[0]):
        _interpolate_marker(field, positions, m, kernel, periodic_y, out, _support_scratch())


@njit(cache=True, error_model="numpy")
def _interpolate_field_serial(field, positions, kernel, periodic_y, out):
    """The same without a parallel region (a few hundred markers in the coupled loop: cheaper than waking the
    threads)."""
    scratch = _support_scratch()
    for m in range(positions.shape[0]):
        _interpolate_marker(field, positions, m, kernel, periodic_y, out, scratch)


@njit(cache=True, error_model="numpy")
def _spread_field(forces, positions, kernel, periodic_y, field):
    """field[:, n] += f_m delta(n - X_m) (serial scatter-add)."""
    scratch = _support_scratch()
    _, ix, iy, iz, weights = scratch
    for m in range(positions.shape[0]):
        count = _support(kernel, positions[m], field.shape[1], field.shape[2], field.shape[3], periodic_y, scratch)
        fx = forces[m, 0]
        fy = forces[m, 1]
        fz = forces[m, 2]
        for j in range(count):
            w = weights[j]
            field[0, ix[j], iy[j], iz[j]] += w * fx
            field[1, ix[j], iy[j], iz[j]] += w * fy
            field[2, ix[j], iy[j], iz[j]] += w * fz


@njit(cache=True, error_model="numpy")
def _clear_field(positions, kernel, periodic_y, field):
    """Set the field to zero on the kernel support of every marker (undoes a spread at these positions)."""
    scratch = _support_scratch()
    _, ix, iy, iz, _ = scratch
    for m in range(positions.shape[0]):
        count = _support(kernel, positions[m], field.shape[1], field.shape[2], field.shape[3], periodic_y, scratch)
        for j in range(count):
            field[0, ix[j], iy[j], iz[j]] = 0.0
            field[1, ix[j], iy[j], iz[j]] = 0.0
            field[2, ix[j], iy[j], iz[j]] = 0.0


# --------------------------------------------------------------------------- velocity from populations
@njit(cache=True, inline="always", error_model="numpy")
def _node_velocity(A, parity, x, y, z, nz, force, has_field, consts, has_walls, wall_corr, cint, opp,
                   solid, has_solid):
    """u = (sum_i c_i f_i + F/2)/rho at node (x, y, z) from the AA storage (float64 result).

    parity 0: f~_i(x) = A[x, i]; parity 1: f~_i(x) = A[x - c_i, opp(i)] (periodic), replaced by the
    bounce-back value A[x, i] (+ moving-wall term) where x - c_i lies beyond a y-wall or in a solid node.
    """
    nx = A.shape[0]
    ny = A.shape[1]
    if has_solid and solid[x, y, z]:
        return 0.0, 0.0, 0.0
    drho = 0.0
    jx = 0.0
    jy = 0.0
    jz = 0.0
    for i in range(19):
        if parity == 0:
            f = np.float64(A[x, y, i, z])
        else:
            cy = cint[i, 1]
            if has_walls and y == 0 and cy == 1:
                f = np.float64(A[x, y, i, z]) + np.float64(wall_corr[0, i])
            elif has_walls and y == ny - 1 and cy == -1:
                f = np.float64(A[x, y, i, z]) + np.float64(wall_corr[1, i])
            else:
                xs = x - cint[i, 0]
                if xs < 0:
                    xs += nx
                elif xs >= nx:
                    xs -= nx
                ys = y - cy
                if ys < 0:
                    ys += ny
                elif ys >= ny:
                    ys -= ny
                zs = z - cint[i, 2]
                if zs < 0:
                    zs += nz
                elif zs >= nz:
                    zs -= nz
                if has_solid and solid[xs, ys, zs]:
                    f = np.float64(A[x, y, i, z])
                else:
                    f = np.float64(A[xs, ys, opp[i], zs])
        drho += f
        jx += cint[i, 0] * f
        jy += cint[i, 1] * f
        jz += cint[i, 2] * f
    fx = np.float64(consts[K_GX])
    fy = np.float64(consts[K_GY])
    fz = np.float64(consts[K_GZ])
    if has_field:
        fx += np.float64(force[0, x, y, z])
        fy += np.float64(force[1, x, y, z])
        fz += np.float64(force[2, x, y, z])
    inv_rho = 1.0 / (1.0 + drho)
    return (jx + 0.5 * fx) * inv_rho, (jy + 0.5 * fy) * inv_rho, (jz + 0.5 * fz) * inv_rho


@njit(parallel=True, cache=True, error_model="numpy")
def _interpolate_populations(A, parity, nz, force, has_field, consts, has_walls, wall_corr, cint, opp,
                             solid, has_solid, positions, kernel, out):
    """out[m] = sum_n u(n) delta(n - X_m) with u evaluated from the populations at the support nodes."""
    nx, ny = A.shape[0], A.shape[1]
    periodic_y = not has_walls
    for m in prange(positions.shape[0]):
        scratch = _support_scratch()
        count = _support(kernel, positions[m], nx, ny, nz, periodic_y, scratch)
        _, ix, iy, iz, weights = scratch
        ux = 0.0
        uy = 0.0
        uz = 0.0
        for j in range(count):
            vx, vy, vz = _node_velocity(A, parity, ix[j], iy[j], iz[j], nz, force, has_field, consts, has_walls,
                                        wall_corr, cint, opp, solid, has_solid)
            w = weights[j]
            ux += w * vx
            uy += w * vy
            uz += w * vz
        out[m, 0] = ux
        out[m, 1] = uy
        out[m, 2] = uz


# --------------------------------------------------------------------------- public API
def _positions(positions) -> np.ndarray:
    x = np.ascontiguousarray(positions, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"positions must have shape (n, 3), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("positions must be finite")
    return x


def interpolate(field, positions, kernel: str = "trilinear", periodic_y: bool = False) -> np.ndarray:
    """U(X_m) = sum_n field(n) delta(n - X_m) for a vector field (3, nx, ny, nz); returns (n, 3) float64.

    Periodic in x and z; in y periodic if ``periodic_y`` else nodes outside 0..ny-1 are dropped."""
    field = np.asarray(field)
    if field.ndim != 4 or field.shape[0] != 3:
        raise ValueError(f"field must have shape (3, nx, ny, nz), got {field.shape}")
    x = _positions(positions)
    out = np.empty((x.shape[0], 3))
    _interpolate_field(field, x, kernel_id(kernel), bool(periodic_y), out)
    return out


def spread(forces, positions, shape, kernel: str = "trilinear", periodic_y: bool = False, out=None,
           dtype=np.float64) -> np.ndarray:
    """Force density F(n) = sum_m f_m delta(n - X_m) on a lattice of ``shape`` (nx, ny, nz).

    forces, positions: (n, 3) (force in rho0 dx^4/dt^2, i.e. force density times dx^3; positions in dx).
    ``out`` (3, nx, ny, nz), if given, is added to in place and returned."""
    x = _positions(positions)
    f = np.ascontiguousarray(forces, dtype=np.float64)
    if f.shape != x.shape:
        raise ValueError(f"forces must have the shape of positions {x.shape}, got {f.shape}")
    if out is None:
        out = np.zeros((3,) + tuple(shape), dtype=dtype)
    elif out.shape != (3,) + tuple(shape):
        raise ValueError(f"out must have shape {(3,) + tuple(shape)}, got {out.shape}")
    _spread_field(f, x, kernel_id(kernel), bool(periodic_y), out)
    return out


def clear(field, positions, kernel: str = "trilinear", periodic_y: bool = False) -> None:
    """Zero ``field`` (3, nx, ny, nz) in place on the kernel support of every marker."""
    _clear_field(_positions(positions), kernel_id(kernel), bool(periodic_y), field)


def lattice_arguments(lattice) -> tuple:
    """The arguments the compiled population readers need from a :class:`~elastocell.lattice.Lattice`:
    ``(A, parity, nz, force, has_field, consts, has_walls, wall_corr, cint, opp, solid, has_solid)``.

    Uses the lattice's storage layout (AA pattern, ``(nx, ny, 19, nz_row)`` deviations); this is the one
    place outside ``elastocell.lattice`` that depends on it. It knows the half-way bounce-back only: a lattice
    with interpolated walls is read through ``Lattice.velocity`` (:func:`interpolate_lattice_velocity`)."""
    force, has_field = lattice._force_arguments()
    solid = lattice.solid
    has_solid = solid is not None
    if not has_solid:
        solid = np.zeros((1, 1, 1), dtype=np.bool_)
    return (
        lattice._storage, lattice._parity, lattice.shape[2], force, has_field, lattice._consts,
        lattice.params.has_walls, lattice._wall_corr, lattice._cint, lattice._opp, solid, has_solid,
    )  # fmt: skip


def interpolate_lattice_velocity(lattice, positions, kernel: str = "trilinear") -> np.ndarray:
    """Fluid velocity at the markers, (n, 3) float64 in dx/dt, including Guo's half-force term
    ``u = (sum_i c_i f_i + F/2)/rho`` with the current force (body force + field).

    Equal to ``interpolate(lattice.velocity(), positions)`` (up to the storage precision), but reads the
    populations at the support nodes only, so its cost scales with the markers, not with the lattice. A lattice
    with interpolated walls (``LatticeParams.wall_fraction``) is read through ``lattice.velocity()`` itself: its
    links' populations need the kernels' interpolation, which the support-node reader does not repeat."""
    if getattr(lattice, "_curved", False):
        return interpolate(lattice.velocity(), positions, kernel, periodic_y=not lattice.params.has_walls)
    x = _positions(positions)
    out = np.empty((x.shape[0], 3))
    _interpolate_populations(*lattice_arguments(lattice), x, kernel_id(kernel), out)
    return out
