"""Per-line boundary bookkeeping for the compiled kernels.

The kernels work on z-lines (fixed x, y). For each line ``line = x * ny + y`` we keep,
in compressed-row (CSR) form:

* the *fluid runs*: half-open z ranges [lo, hi) of consecutive fluid nodes; only
  these are written, so solid nodes are never touched;
* the *solid links*: (z, i) for every fluid node (x, y, z) whose neighbour x + c_i is
  a solid node (half-way bounce-back); links through the y-walls are handled
  separately by the kernels and are not listed;
* for every solid link, the coefficients of its (linearly interpolated) bounce-back.

Interpolated bounce-back (Bouzidi, Firdaouss & Lallemand, Phys. Fluids 13, 3452, 2001)
-------------------------------------------------------------------------------------
With the wall at x_w = x + q c_i on the link from fluid node x into the solid (0 < q <= 1), the population
that comes back is, i' = opp(i), f* post-collision:

* q < 1/2 ("near"): f_i'(x, t+1) = 2q f*_i(x, t) + (1 - 2q) f*_i(x - c_i, t), and f*_i(x - c_i, t) is the
  population f_i(x, t+1) that x receives by streaming;
* q >= 1/2 ("far"): f_i'(x, t+1) = f*_i(x, t)/(2q) + (2q - 1)/(2q) f*_i'(x, t).

Each link stores ``link_a`` (2q or 1/(2q)), ``link_b`` (1 - 2q or (2q - 1)/(2q)) and ``link_near``. The half-way
wall is q = 1/2: a = 1, b = 0, both forms plain bounce-back. A link whose node x - c_i is itself solid (a gap of
one node) or beyond a y-wall falls back to q = 1/2: the interpolation would need a population that is itself
bounced back. The scheme does not conserve mass exactly (the pipe's runs lose about 1e-10 of the fluid's mass per
step: docs/validation/pipe_dclab.md, section "pipe_wall.py").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from elastocell.lattice.stencil import VELOCITIES, Q


@dataclass(frozen=True)
class LineGeometry:
    run_ptr: np.ndarray  # (nx*ny + 1,) int64
    run_lo: np.ndarray  # (n_runs,) int64
    run_hi: np.ndarray  # (n_runs,) int64
    link_ptr: np.ndarray  # (nx*ny + 1,) int64
    link_z: np.ndarray  # (n_links,) int64
    link_q: np.ndarray  # (n_links,) int64, direction pointing into the solid
    link_a: np.ndarray  # (n_links,) float64, interpolation weight of f*_i(x)
    link_b: np.ndarray  # (n_links,) float64, weight of the second population (see module docstring)
    link_near: np.ndarray  # (n_links,) bool, q < 1/2

    @property
    def n_links(self) -> int:
        return int(self.link_z.size)


def _csr_pointer(line_ids: np.ndarray, n_lines: int) -> np.ndarray:
    counts = np.bincount(line_ids, minlength=n_lines)
    ptr = np.zeros(n_lines + 1, dtype=np.int64)
    np.cumsum(counts, out=ptr[1:])
    return ptr


def link_coefficients(fraction: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(a, b, near) of the interpolated bounce-back for wall fractions q in (0, 1] (module docstring)."""
    q = np.asarray(fraction, dtype=np.float64)
    near = q < 0.5
    a = np.where(near, 2.0 * q, 1.0 / (2.0 * q))
    b = np.where(near, 1.0 - 2.0 * q, (2.0 * q - 1.0) / (2.0 * q))
    return a, b, near


def build_line_geometry(shape, solid: np.ndarray | None, has_walls: bool, wall_fraction=None) -> LineGeometry:
    """Fluid runs and solid links of every z-line for a solid mask (or None).

    wall_fraction: None (every wall half-way between nodes) or a function q(x, c) of the fluid nodes x (n, 3)
    and the link directions c (n, 3), both float64 in lattice units, giving the fraction 0 < q <= 1 of each link
    at which the wall lies (see :class:`elastocell.lattice.params.LatticeParams`)."""
    nx, ny, nz = shape
    n_lines = nx * ny
    empty = np.zeros(0, dtype=np.int64)
    if solid is None or not solid.any():
        return LineGeometry(
            run_ptr=np.arange(n_lines + 1, dtype=np.int64),
            run_lo=np.zeros(n_lines, dtype=np.int64),
            run_hi=np.full(n_lines, nz, dtype=np.int64),
            link_ptr=np.zeros(n_lines + 1, dtype=np.int64),
            link_z=empty,
            link_q=empty.copy(),
            link_a=np.zeros(0),
            link_b=np.zeros(0),
            link_near=np.zeros(0, dtype=bool),
        )
    fluid = ~solid
    padded = np.zeros((nx, ny, nz + 2), dtype=np.int8)
    padded[:, :, 1:-1] = fluid
    d = np.diff(padded, axis=2)
    sx, sy, sz = np.nonzero(d == 1)  # run starts, C order = line order then z order
    _, _, ez = np.nonzero(d == -1)  # run ends (exclusive), same order
    run_ptr = _csr_pointer(sx * ny + sy, n_lines)

    lines, xs, ys, zs, qs = [], [], [], [], []
    for i in range(1, Q):
        c = VELOCITIES[i]
        neighbour_solid = np.roll(solid, shift=(-c[0], -c[1], -c[2]), axis=(0, 1, 2))  # solid[x + c_i]
        if has_walls and c[1] != 0:  # the neighbour lies beyond a y-wall: not a mask link
            neighbour_solid[:, 0 if c[1] < 0 else ny - 1, :] = False
        lx, ly, lz = np.nonzero(fluid & neighbour_solid)
        lines.append(lx * ny + ly)
        xs.append(lx)
        ys.append(ly)
        zs.append(lz)
        qs.append(np.full(lz.size, i, dtype=np.int64))
    line_ids = np.concatenate(lines)
    order = np.argsort(line_ids, kind="stable")
    nodes = np.stack([np.concatenate(xs), np.concatenate(ys), np.concatenate(zs)], axis=1)[order]
    directions = np.concatenate(qs)[order]
    fraction = np.full(directions.size, 0.5)
    if wall_fraction is not None and directions.size:
        c = VELOCITIES[directions].astype(np.float64)
        fraction = np.asarray(wall_fraction(nodes.astype(np.float64), c), dtype=np.float64)
        if fraction.shape != directions.shape or not np.all((fraction > 0.0) & (fraction <= 1.0)):
            bad = fraction[~((fraction > 0.0) & (fraction <= 1.0))] if fraction.shape == directions.shape else fraction
            raise ValueError("wall_fraction must give one q in (0, 1] per solid link (the wall must cross every "
                             f"link from a fluid node into a solid node), got {np.ravel(bad)[:3]}")
        behind = nodes - VELOCITIES[directions]  # x - c_i
        beyond_wall = has_walls & ((behind[:, 1] < 0) | (behind[:, 1] >= ny))
        behind %= np.asarray(shape)  # periodic
        fraction = np.where(solid[behind[:, 0], behind[:, 1], behind[:, 2]] | beyond_wall, 0.5, fraction)
    link_a, link_b, link_near = link_coefficients(fraction)
    return LineGeometry(
        run_ptr=run_ptr,
        run_lo=sz.astype(np.int64),
        run_hi=ez.astype(np.int64),
        link_ptr=_csr_pointer(line_ids, n_lines),
        link_z=np.ascontiguousarray(np.concatenate(zs)[order], dtype=np.int64),
        link_q=np.ascontiguousarray(directions, dtype=np.int64),
        link_a=link_a,
        link_b=link_b,
        link_near=link_near,
    )
