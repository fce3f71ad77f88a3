"""The immersed cell in JAX: the coupled LB + IBM step of :mod:`elastocell.coupling.immersed` for any device JAX drives.

:class:`JaxImmersedCell` is :class:`~elastocell.coupling.immersed.ImmersedCell` with the fluid in a
:class:`~elastocell.lattice.jax_backend.JaxLattice` and every step on the device: the elastic nodal forces
-dE/dx from the cell's own JAX strain-energy function (:meth:`Cell.internal_forces`, the function the
compression solver differentiates), spreading with the same kernels (trilinear, peskin4) as a scatter-add,
interpolation of Guo's half-force velocity u = (sum_i c_i f_i + F/2)/rho at the markers from the populations at
the kernel nodes only, one LB step (:func:`~elastocell.lattice.jax_backend.collide_and_stream`), and the
markers moved by the interpolated velocity. A chunk of steps is one compiled ``lax.while_loop`` that stops at
the step where an element inverts or a marker speed stops being finite, as the Numba path does; positions,
marker forces and velocities come back to the host once per chunk.

Units: lattice units (dx = dt = 1, rho0 = 1); positions in dx, forces in rho0 dx^4/dt^2.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from elastocell.body.materials import computes_in_float64
from elastocell.coupling import ibm
from elastocell.coupling.markers import MarkerState, raise_flow_failure
from elastocell.lattice.jax_backend import JaxLattice, LatticeTables, collide_and_stream, total_force
from elastocell.lattice.stencil import VELOCITIES

__all__ = ["JaxImmersedCell", "JaxLattice"]


def _phi(kernel: str, r):
    """phi(r) of the kernel (r in dx), as :func:`elastocell.coupling.ibm.kernel_weights`."""
    a = jnp.abs(r)
    if kernel == "trilinear":
        return jnp.where(a < 1.0, 1.0 - a, 0.0)
    inner = (3.0 - 2.0 * a + jnp.sqrt(jnp.maximum(1.0 + 4.0 * a - 4.0 * a * a, 0.0))) * 0.125
    outer = (5.0 - 2.0 * a - jnp.sqrt(jnp.maximum(-7.0 + 12.0 * a - 4.0 * a * a, 0.0))) * 0.125
    return jnp.where(a <= 1.0, inner, jnp.where(a < 2.0, outer, 0.0))


def kernel_stencil(positions, shape, kernel: str, periodic_y: bool):
    """Flat lattice indices (n, s^3) of the kernel nodes of every marker and their weights (n, s^3).

    Periodic in x and z; in y periodic without walls, else nodes beyond the walls get weight 0."""
    support = ibm.KERNEL_SUPPORT[kernel]
    offsets = jnp.arange(support)
    base = jnp.floor(positions).astype(jnp.int32) - (support // 2 - 1)  # (n, 3)
    nodes = base[:, :, None] + offsets  # (n, 3, s)
    weights = _phi(kernel, positions[:, :, None] - nodes)  # (n, 3, s)
    nx, ny, nz = shape
    ix, iy, iz = nodes[:, 0] % nx, nodes[:, 1], nodes[:, 2] % nz
    wy = weights[:, 1]
    if periodic_y:
        iy = iy % ny
    else:
        wy = jnp.where((iy >= 0) & (iy < ny), wy, 0.0)
        iy = jnp.clip(iy, 0, ny - 1)
    flat = (ix[:, :, None, None] * ny + iy[:, None, :, None]) * nz + iz[:, None, None, :]
    w = weights[:, 0, :, None, None] * wy[:, None, :, None] * weights[:, 2, None, None, :]
    n = positions.shape[0]
    return flat.reshape(n, -1), w.reshape(n, -1)


def spread(forces, flat, weights, shape, dtype):
    """Force density (3, nx, ny, nz) of marker forces (n, 3) spread with the stencil of
    :func:`kernel_stencil` (a scatter-add; total force and torque conserved)."""
    size = int(np.prod(shape))
    contributions = (forces[:, :, None] * weights[:, None, :]).astype(dtype)  # (n, 3, s^3)
    field = jnp.zeros((3, size), dtype).at[:, flat.ravel()].add(jnp.moveaxis(contributions, 1, 0).reshape(3, -1))
    return field.reshape((3,) + tuple(shape))


def interpolate_velocity(deviations, force, flat, weights, fluid=None):
    """u = (sum_i c_i d_i + F/2)/(1 + sum_i d_i) at the kernel nodes (float64; 0 at solid nodes, where
    ``fluid`` (nx, ny, nz) is False), weighted to the markers (n, 3)."""
    q = deviations.shape[0]
    d = deviations.reshape(q, -1)[:, flat].astype(jnp.float64)  # (19, n, s^3)
    drho = jnp.sum(d, axis=0)
    momentum = jnp.einsum("ia,ins->ans", jnp.asarray(VELOCITIES, jnp.float64), d)
    if force is not None:
        momentum = momentum + 0.5 * force.reshape(3, -1)[:, flat].astype(jnp.float64)
    u = momentum / (1.0 + drho)
    if fluid is not None:
        u = jnp.where(fluid.reshape(-1)[flat], u, 0.0)
    return jnp.einsum("ans,ns->na", u, weights)


@partial(jax.jit, static_argnums=(4, 5, 7))
def _coupled_steps(n_steps, deviations, positions, scale, gradient, min_jacobian, tables: LatticeTables,
                   setup: tuple):  # fmt: skip
    """Up to n_steps coupled steps; stops after an inverted element or a non-finite/absurd marker speed.

    Returns (steps done, deviations, positions, field, marker forces, marker velocities, smallest det F,
    largest marker speed)."""
    shape, kernel, periodic_y, radius = setup
    dtype = deviations.dtype
    n = positions.shape[0]

    def body(carry):
        step, d, x, _, _, _, j_min, max_speed = carry
        j = min_jacobian(x / radius)
        forces = -gradient(x / radius) * scale
        flat, weights = kernel_stencil(x, shape, kernel, periodic_y)
        field = spread(forces, flat, weights, shape, dtype)
        force = total_force(field, tables, shape, dtype)
        velocity = interpolate_velocity(d, force, flat, weights, tables.fluid)
        speed = jnp.max(jnp.sum(velocity * velocity, axis=1))
        ok_elements = j > 0.0
        d_new = collide_and_stream(d, force, tables)
        moved = x + velocity
        # an inverted element stops before the step (as the Numba path); a bad speed after it
        d = jnp.where(ok_elements, d_new, d)
        x = jnp.where(ok_elements, moved, x)
        step_done = jnp.where(ok_elements, step + 1, step)
        j_min = jnp.minimum(j_min, j)
        max_speed = jnp.where(ok_elements, jnp.maximum(max_speed, speed), max_speed)
        return step_done, d, x, field, forces, velocity, j_min, max_speed

    def running(carry):
        step, _, _, _, _, _, j_min, max_speed = carry
        return (step < n_steps) & (j_min > 0.0) & (max_speed < 1.0)

    zeros = jnp.zeros((n, 3))
    init = (jnp.int32(0), deviations, positions, jnp.zeros((3,) + tuple(shape), dtype), zeros, zeros,
            jnp.inf, 0.0)  # fmt: skip
    return jax.lax.while_loop(running, body, init)


@computes_in_float64
class JaxImmersedCell(MarkerState):
    """An elastic cell immersed in a :class:`JaxLattice` (same parameters, state and units as
    :class:`~elastocell.coupling.immersed.ImmersedCell`, which documents them)."""

    backend = "jax"

    def __init__(self, lattice: JaxLattice, cell, centre, radius: float, youngs_modulus: float,
                 kernel: str = "trilinear"):  # fmt: skip
        if not isinstance(lattice, JaxLattice):
            raise TypeError(f"lattice must be a JaxLattice, got {type(lattice).__name__}")
        ibm.kernel_id(kernel)
        self.lattice = lattice
        self.cell = cell
        self.radius = float(radius)
        self.youngs_modulus = float(youngs_modulus)
        self.kernel = kernel
        self.centre0 = np.asarray(centre, dtype=np.float64)
        self.positions = np.ascontiguousarray(self.centre0 + self.radius * cell.mesh.nodes)
        n = cell.mesh.n_nodes
        self._marker_forces = np.zeros((n, 3))
        self._velocity = np.zeros((n, 3))
        lattice.set_force_density(np.zeros((3,) + lattice.shape))
        self.time_step = 0
        self.max_speed = 0.0
        kernels = cell._compiled()
        self._gradient, self._min_jacobian = kernels["gradient"], kernels["min_jacobian"]
        self._setup = (tuple(lattice.shape), kernel, not lattice.params.has_walls, self.radius)

    def fluid_velocity_at(self, positions) -> np.ndarray:
        """The fluid velocity (half-force corrected) interpolated at points (n, 3) in dx."""
        return ibm.interpolate(self.lattice.velocity(), positions, self.kernel, not self.lattice.params.has_walls)

    def advance(self, n_steps: int) -> None:
        """n_steps coupled steps in one compiled loop on the device; raises :class:`FlowError` as
        :meth:`ImmersedCell.advance` does."""
        n_steps = int(n_steps)
        if n_steps <= 0:
            return
        lat = self.lattice
        scale = self.youngs_modulus * self.radius**2
        done, deviations, positions, field, forces, velocity, j_min, max_speed = _coupled_steps(
            n_steps, lat.deviations, jnp.asarray(self.positions), scale, self._gradient, self._min_jacobian,
            lat._tables_jax, self._setup,
        )  # fmt: skip
        done = int(done)
        lat.deviations = deviations
        lat._force_field = field
        lat.time_step += done
        self.time_step += done
        self.positions[...] = np.asarray(positions)
        self._marker_forces[...] = np.asarray(forces)
        self._velocity[...] = np.asarray(velocity)
        j_min, max_speed = float(j_min), float(np.sqrt(float(max_speed)))
        self.max_speed = max_speed
        if not max_speed < 1.0:  # NaN or absurd: the fluid blew up (possibly in the chunk's last step)
            raise_flow_failure(self.time_step, -np.inf, max_speed)
        if done < n_steps:  # stopped before a step that would invert an element
            raise_flow_failure(self.time_step, j_min, max_speed)

    def state_arrays(self) -> dict:
        """The coupled state for a checkpoint (NumPy arrays)."""
        return {**self.lattice.state_arrays(), "positions": self.positions, "time_step": np.array(self.time_step),
                "max_speed": np.array(self.max_speed)}  # fmt: skip

    def load_state_arrays(self, data) -> None:
        self.lattice.load_state_arrays(data)
        self.positions[...] = data["positions"]
        self.time_step = int(data["time_step"])
        self.max_speed = float(data["max_speed"])
