"""Per-line boundary bookkeeping for the compiled kernels.

The kernels work on z-lines (fixed x, y). For each line ``line = x * ny + y`` we keep,
in compressed-row (CSR) form:

* the *fluid runs*: half-open z ranges [lo, hi) of consecutive fluid nodes; only
  these are written, so solid nodes are never touched;
* the *solid links*: (z, i) for every fluid node (x, y, z) whose neighbour x + c_i is
  a solid node (half-way bounce-back); links through the y-walls are handled
  separately by the kernels and are not listed.
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

    @property
    def n_links(self) -> int:
        return int(self.link_z.size)


def _csr_pointer(line_ids: np.ndarray, n_lines: int) -> np.ndarray:
    counts = np.bincount(line_ids, minlength=n_lines)
    ptr = np.zeros(n_lines + 1, dtype=np.int64)
    np.cumsum(counts, out=ptr[1:])
    return ptr


def build_line_geometry(shape, solid: np.ndarray | None, has_walls: bool) -> LineGeometry:
    """Fluid runs and solid links of every z-line for a solid mask (or None)."""
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
        )
    fluid = ~solid
    padded = np.zeros((nx, ny, nz + 2), dtype=np.int8)
    padded[:, :, 1:-1] = fluid
    d = np.diff(padded, axis=2)
    sx, sy, sz = np.nonzero(d == 1)  # run starts, C order = line order then z order
    _, _, ez = np.nonzero(d == -1)  # run ends (exclusive), same order
    run_ptr = _csr_pointer(sx * ny + sy, n_lines)

    lines, zs, qs = [], [], []
    for i in range(1, Q):
        c = VELOCITIES[i]
        neighbour_solid = np.roll(solid, shift=(-c[0], -c[1], -c[2]), axis=(0, 1, 2))  # solid[x + c_i]
        if has_walls and c[1] != 0:  # the neighbour lies beyond a y-wall: not a mask link
            neighbour_solid[:, 0 if c[1] < 0 else ny - 1, :] = False
        lx, ly, lz = np.nonzero(fluid & neighbour_solid)
        lines.append(lx * ny + ly)
        zs.append(lz)
        qs.append(np.full(lz.size, i, dtype=np.int64))
    line_ids = np.concatenate(lines)
    order = np.argsort(line_ids, kind="stable")
    return LineGeometry(
        run_ptr=run_ptr,
        run_lo=sz.astype(np.int64),
        run_hi=ez.astype(np.int64),
        link_ptr=_csr_pointer(line_ids, n_lines),
        link_z=np.ascontiguousarray(np.concatenate(zs)[order], dtype=np.int64),
        link_q=np.ascontiguousarray(np.concatenate(qs)[order], dtype=np.int64),
    )
