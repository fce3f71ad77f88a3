"""Coupled lattice-Boltzmann / immersed-boundary stepping of an elastic cell (Numba backend).

Lattice units throughout (dx = dt = 1, rho0 = 1): every mesh node is a massless marker at X; each step (one
compiled chunk runs many):

1. clear the force density at the previous markers' supports, compute the elastic nodal forces
   f = -dE/dx at X, spread them to the force density;
2. one LB step with the force density; it stores the velocity its collision used,
   u = (sum c f + F/2)/rho (Guo half-force term), at the nodes of the markers' kernel supports;
3. interpolate that u at X; 4. X += u dt;
5. with the volume projection (``volume_correction="projection"``), the surface markers moved along the gradient of
   the volume they enclose so that it is the undeformed cell's again (:func:`_project_volume`).

The projection answers the immersed boundary's leak: the interpolated velocity is not divergence-free, so fluid
crosses the marker surface and a cell's volume drifts, although the fluid inside it is incompressible (the drift
grows with the deformation: docs/theory.md, "Volume conservation"). The correction is kinematic: no force, no
stiffness, so the stability limit of the step is unchanged; the volume it restores is reported
(:attr:`ImmersedCell.volume_restored`), so the leak stays visible.
"""

from __future__ import annotations

import math
import warnings

# =========================================================================== shear flow
import numpy as np
from numba import njit

from elastocell.body.mesh import outward_surface_triangles
from elastocell.coupling import ibm
from elastocell.coupling.elastic_forces import VOLUMETRIC_CODES, ElasticForces, elastic_forces
from elastocell.coupling.markers import MarkerState, marker_radius, raise_flow_failure
from elastocell.lattice import Lattice, LatticeParams
from elastocell.lattice import kernels as lb_kernels


@njit(cache=True, error_model="numpy")
def _velocity_box(positions, support, box):
    """box[0:3] = lowest lattice index and box[3:6] = number of indices per axis of the kernel supports of all
    markers (unwrapped; the sweep takes them modulo the lattice)."""
    for a in range(3):
        lo = np.inf
        hi = -np.inf
        for m in range(positions.shape[0]):
            v = positions[m, a]
            lo = min(lo, v)
            hi = max(hi, v)
        first = int(math.floor(lo)) - (support // 2 - 1)
        last = int(math.floor(hi)) + support // 2
        box[a] = first
        box[3 + a] = last - first + 1


@njit(cache=True, error_model="numpy")
def _enclosed_volume(positions, faces, gradient):
    """V = sum over the triangles (a, b, c) of a . (b x c) / 6 (dx^3): the volume a closed triangulated surface
    encloses, taken about its first corner (round-off), signed by the triangles' orientation; ``gradient`` (n, 3)
    receives dV/dX (dx^2) at every node of the triangles (zero elsewhere): for a closed surface the sum over its
    triangles at node a of (b x c)/6, (a, b, c) in their cyclic order, which the origin does not change."""
    gradient[:, :] = 0.0
    o0 = positions[faces[0, 0], 0]
    o1 = positions[faces[0, 0], 1]
    o2 = positions[faces[0, 0], 2]
    volume = 0.0
    for f in range(faces.shape[0]):
        a, b, c = faces[f, 0], faces[f, 1], faces[f, 2]
        a0, a1, a2 = positions[a, 0] - o0, positions[a, 1] - o1, positions[a, 2] - o2
        b0, b1, b2 = positions[b, 0] - o0, positions[b, 1] - o1, positions[b, 2] - o2
        c0, c1, c2 = positions[c, 0] - o0, positions[c, 1] - o1, positions[c, 2] - o2
        bc0, bc1, bc2 = b1 * c2 - b2 * c1, b2 * c0 - b0 * c2, b0 * c1 - b1 * c0  # b x c
        ca0, ca1, ca2 = c1 * a2 - c2 * a1, c2 * a0 - c0 * a2, c0 * a1 - c1 * a0  # c x a
        ab0, ab1, ab2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0  # a x b
        volume += (a0 * bc0 + a1 * bc1 + a2 * bc2) / 6.0
        gradient[a, 0] += bc0 / 6.0
        gradient[a, 1] += bc1 / 6.0
        gradient[a, 2] += bc2 / 6.0
        gradient[b, 0] += ca0 / 6.0
        gradient[b, 1] += ca1 / 6.0
        gradient[b, 2] += ca2 / 6.0
        gradient[c, 0] += ab0 / 6.0
        gradient[c, 1] += ab1 / 6.0
        gradient[c, 2] += ab2 / 6.0
    return volume


@njit(cache=True, error_model="numpy")
def _project_volume(positions, faces, surface_nodes, gradient, target_volume):
    """Move the surface nodes along g = dV/dX so that the enclosed volume V is ``target_volume`` again:
    X += lambda g with lambda = (V0 - V) / sum |g|^2 (the least displacement that restores V to first order; the
    error left is second order in lambda, |dV/V| ~ 1e-14 for a step's leak). The interior nodes stay where they
    are and sum(lambda g) = 0: the centroid of the markers does not move. Returns V0 - V (dx^3), the volume
    restored."""
    volume = _enclosed_volume(positions, faces, gradient)
    norm2 = 0.0
    for i in range(surface_nodes.shape[0]):
        m = surface_nodes[i]
        norm2 += gradient[m, 0] ** 2 + gradient[m, 1] ** 2 + gradient[m, 2] ** 2
    restored = target_volume - volume
    lam = restored / norm2
    for i in range(surface_nodes.shape[0]):
        m = surface_nodes[i]
        positions[m, 0] += lam * gradient[m, 0]
        positions[m, 1] += lam * gradient[m, 1]
        positions[m, 2] += lam * gradient[m, 2]
    return restored


@njit(cache=True, error_model="numpy")
def _coupled_steps(
    n_steps, A, parity, nz, field, consts, has_walls, wall_corr, cint, opp, solid, has_solid,
    run_ptr, run_lo, run_hi, link_ptr, link_z, link_q, lb_weights, cvel, link_a, link_b, link_near, wall_memory,
    curved, fluid_velocity, box,
    positions, spread_positions, has_spread, forces, velocity, kernel, support,
    elements, gradients, weights, params, node_ptr, node_slots, eforce, j_elem, volumetric, reference_volume,
    node_reference_volume, node_bulk, volume, node_pressure, pressure,
    faces, surface_nodes, volume_gradient, target_volume,
):  # fmt: skip
    """Advance ``n_steps`` coupled LB + IBM steps in compiled code (see the module docstring).

    The LB step itself stores the velocity its collision used, u = (sum c f + F/2)/rho with this step's
    force density, at the fluid nodes of the markers' kernel supports (``fluid_velocity``, storage dtype,
    zero at solid nodes); the markers read it there, so no population is read twice.

    With ``target_volume`` > 0 every step ends with :func:`_project_volume` onto that volume (the surface
    ``faces`` and ``surface_nodes``; ``volume_gradient`` (n, 3) scratch); 0 leaves the markers where the fluid
    moved them.

    Returns (parity, steps done, smallest det F, largest marker speed, the volume restored in all (dx^3)); stops
    early (steps done < n_steps) when an element inverts or a marker velocity is not finite."""
    periodic_y = not has_walls
    j_min = np.inf
    max_speed = 0.0
    restored = 0.0
    n_markers = positions.shape[0]
    for step in range(n_steps):
        if has_spread:
            ibm._clear_field(spread_positions, kernel, periodic_y, field)
        j = elastic_forces(positions, elements, gradients, weights, params, node_ptr, node_slots, eforce,
                           j_elem, volumetric, reference_volume, node_reference_volume, node_bulk, volume,
                           node_pressure, pressure, forces)
        if not j > 0.0:
            return parity, step, j, max_speed, restored
        j_min = min(j_min, j)
        ibm._spread_field(forces, positions, kernel, periodic_y, field)
        spread_positions[:, :] = positions
        has_spread = True
        _velocity_box(positions, support, box)
        lb_kernels._sweep(A, parity, nz, field, True, run_ptr, run_lo, run_hi, has_walls, wall_corr,
                          link_ptr, link_z, link_q, consts, lb_weights, cvel, cint, opp, link_a, link_b,
                          link_near, wall_memory, curved, fluid_velocity, box)
        parity = 1 - parity
        ibm._interpolate_field_serial(fluid_velocity, positions, kernel, periodic_y, velocity)
        for m in range(n_markers):
            vx = velocity[m, 0]
            vy = velocity[m, 1]
            vz = velocity[m, 2]
            speed = vx * vx + vy * vy + vz * vz
            if not speed < 1.0:  # NaN or absurd: the fluid blew up
                return parity, step + 1, -np.inf, np.sqrt(speed), restored
            max_speed = max(max_speed, speed)
            positions[m, 0] += vx
            positions[m, 1] += vy
            positions[m, 2] += vz
        if target_volume > 0.0:
            restored += _project_volume(positions, faces, surface_nodes, volume_gradient, target_volume)
    return parity, n_steps, j_min, np.sqrt(max_speed), restored


VOLUME_CORRECTIONS = ("none", "projection")
"""How a coupled step keeps the cell's volume: "none" (the markers move with the fluid alone) or "projection"
(:func:`_project_volume` after every step)."""


def immersed_cell(backend: str, lattice_params: LatticeParams, velocity, cell, units, kernel: str,
                  radius_correction: float = 0.0, volume_correction: str = "none"):
    """The coupled system on a backend ("numba" or "jax"): a lattice at the equilibrium of ``velocity``
    (3, nx, ny, nz) and the cell at ``units.centre`` with radius ``units.radius`` (dx) and modulus
    ``units.youngs_modulus`` (lattice units); its markers lie on a sphere of radius ``units.radius -
    radius_correction`` (:func:`~elastocell.coupling.markers.marker_radius`). A law without a compiled force kernel
    (``Law.has_compiled_kernel`` false) runs on "jax", whose forces are the autodiff of the law, with a warning.
    ``volume_correction``: :data:`VOLUME_CORRECTIONS`; the projection runs on "numba" only."""
    if volume_correction not in VOLUME_CORRECTIONS:
        raise ValueError(f"volume_correction must be one of {', '.join(VOLUME_CORRECTIONS)}, got "
                         f"{volume_correction!r}")
    if backend == "numba" and not cell.law.has_compiled_kernel:
        warnings.warn(f"the law {cell.law.name!r} has no compiled (Numba) force kernel: the flow runs on the JAX "
                      "backend, forces by autodiff of the law (on a CPU 10-16 times slower per step)", stacklevel=2)
        backend = "jax"
    elif backend == "numba" and cell.parameters.mesh.volumetric not in VOLUMETRIC_CODES:
        warnings.warn(f"the volumetric treatment {cell.parameters.mesh.volumetric!r} has no compiled (Numba) force "
                      "kernel: the flow runs on the JAX backend, forces by autodiff of the law (on a CPU 10-16 times "
                      "slower per step)", stacklevel=2)
        backend = "jax"
    if volume_correction != "none" and backend != "numba":
        raise ValueError(f"volume_correction {volume_correction!r} runs on the Numba backend only, not {backend!r}")
    if backend == "jax":
        from elastocell.coupling.immersed_jax import (  # lazy: JAX (about 1 s) only for backend='jax'
            JaxImmersedCell,
            JaxLattice,
        )

        lattice_class, cell_class = JaxLattice, JaxImmersedCell
    elif backend == "numba":
        lattice_class, cell_class = Lattice, ImmersedCell
    else:
        raise ValueError(f"backend must be 'numba' or 'jax', got {backend!r}")
    lattice = lattice_class(lattice_params)
    lattice.initialize(velocity=velocity)
    radius = marker_radius(units.radius, radius_correction)
    if volume_correction != "none":
        return cell_class(lattice, cell, units.centre, radius, units.youngs_modulus, kernel=kernel,
                          volume_correction=volume_correction)
    return cell_class(lattice, cell, units.centre, radius, units.youngs_modulus, kernel=kernel)


class ImmersedCell(MarkerState):
    """An elastic cell immersed in a lattice Boltzmann fluid (immersed boundary, every node a marker).

    Parameters
    ----------
    lattice : Lattice
        The fluid; its force density field is owned by the coupling from now on.
    cell : Cell
        The elastic body (mesh in units of R, moduli in units of E_c).
    centre : 3 floats
        Initial position of the mesh origin (dx).
    radius : float
        R in dx (the lattice's R/dx: the resolution, in a duct moved to make its width whole nodes).
    youngs_modulus : float
        E_c in lattice units (rho0 dx^2/dt^2).
    kernel : "trilinear" (default) or "peskin4".
    volume_correction : "none" (default) or "projection": after every step the surface markers are moved along
        the gradient of the volume they enclose back to the undeformed cell's (module docstring); linear
        elements only (the surface of quadratic ones is curved).

    State: :attr:`positions` (n_nodes, 3) in dx (unwrapped: periodic images are taken by the kernels),
    :attr:`time_step`. Lattice velocities are dx/dt; forces rho0 dx^4/dt^2.
    """

    backend = "numba"

    def __init__(self, lattice: Lattice, cell, centre, radius: float, youngs_modulus: float,
                 kernel: str = "trilinear", volume_correction: str = "none"):
        self.lattice = lattice
        self.cell = cell
        self.radius = float(radius)
        self.youngs_modulus = float(youngs_modulus)
        self.kernel = kernel
        self._kernel_id = ibm.kernel_id(kernel)
        self.centre0 = np.asarray(centre, dtype=np.float64)
        self.positions = np.ascontiguousarray(self.centre0 + self.radius * cell.mesh.nodes)
        self.forces = ElasticForces(cell, length_scale=self.radius, modulus_scale=self.youngs_modulus)
        n = cell.mesh.n_nodes
        self._spread_positions = np.zeros((n, 3))
        self._has_spread = False
        self._marker_forces = np.zeros((n, 3))
        self._velocity = np.zeros((n, 3))
        # the velocity the LB step stores at the markers' supports (storage dtype; solid nodes stay 0)
        self._fluid_velocity = np.zeros((3,) + lattice.shape, dtype=lattice.dtype)
        self._box = np.zeros(6, dtype=np.int64)
        if lattice.force_density is None:
            lattice.set_force_density(np.zeros((3,) + lattice.shape))
        else:
            lattice.force_density[...] = 0.0
        self.time_step = 0
        self.max_speed = 0.0
        """Largest marker speed |u| (dx/dt) seen in the last :meth:`advance`."""
        if volume_correction not in VOLUME_CORRECTIONS:
            raise ValueError(f"volume_correction must be one of {', '.join(VOLUME_CORRECTIONS)}, got "
                             f"{volume_correction!r}")
        if volume_correction != "none" and cell.mesh.order != 1:
            raise ValueError("volume_correction 'projection' needs linear elements (the surface of quadratic ones "
                             "is curved, its volume not that of the corner triangles)")
        self.volume_correction = volume_correction
        faces = outward_surface_triangles(cell.mesh.elements)
        self._volume_gradient = np.zeros((n, 3))
        self._surface_faces = faces
        self._surface_nodes = np.ascontiguousarray(np.unique(faces), dtype=np.int64)
        self.target_volume = (_enclosed_volume(self.positions, faces, self._volume_gradient)
                              if volume_correction == "projection" else 0.0)
        """V0 (dx^3), the volume the projection holds (that of the undeformed surface); 0 without it."""
        self.volume_restored = 0.0
        """The volume the projection has restored since the start (dx^3; > 0: it replaced volume the leak took)."""

    def advance(self, n_steps: int) -> None:
        """n_steps coupled steps in one compiled call; raises :class:`FlowError` on an inverted element or a
        non-finite fluid (the lattice is left at the step where it stopped)."""
        n_steps = int(n_steps)
        if n_steps <= 0:
            return
        lat = self.lattice
        tables = lat._tables()  # (run_ptr, run_lo, run_hi, has_walls, wall_corr, link_ptr, link_z, link_q,
        #                          consts, weights, cvel, cint, opp, link_a, link_b, link_near, memory, curved)
        (A, parity, nz, field, _, consts, has_walls, wall_corr, cint, opp, solid,
         has_solid) = ibm.lattice_arguments(lat)  # fmt: skip
        parity, done, j_min, max_speed, restored = _coupled_steps(
            n_steps, A, parity, nz, field, consts, has_walls, wall_corr, cint, opp, solid, has_solid,
            tables[0], tables[1], tables[2], tables[5], tables[6], tables[7], tables[9], tables[10], *tables[13:18],
            self._fluid_velocity, self._box, self.positions, self._spread_positions, self._has_spread,
            self._marker_forces, self._velocity, self._kernel_id, ibm.KERNEL_SUPPORT[self.kernel],
            *self.forces.arguments(), self._surface_faces, self._surface_nodes, self._volume_gradient,
            self.target_volume,
        )  # fmt: skip
        self.volume_restored += float(restored)
        lat._parity = int(parity)
        lat.time_step += int(done)
        self.time_step += int(done)
        self._has_spread = self._has_spread or done > 0 or not (j_min > 0)
        self.max_speed = float(max_speed)
        if not j_min > 0:
            raise_flow_failure(self.time_step, j_min, max_speed)

    def fluid_velocity_at(self, positions) -> np.ndarray:
        """The fluid velocity (half-force corrected) interpolated at points (n, 3) in dx."""
        return ibm.interpolate_lattice_velocity(self.lattice, positions, self.kernel)

    def state_arrays(self) -> dict:
        """The coupled state for a checkpoint (NumPy arrays)."""
        return {**self.lattice.state_arrays(), "positions": self.positions,
                "spread_positions": self._spread_positions, "has_spread": np.array(self._has_spread),
                "time_step": np.array(self.time_step), "max_speed": np.array(self.max_speed),
                **({"volume_restored": np.array(self.volume_restored)} if self.target_volume > 0 else {})}  # fmt: skip

    def load_state_arrays(self, data) -> None:
        self.lattice.load_state_arrays(data)
        self.positions[...] = data["positions"]
        self._spread_positions[...] = data["spread_positions"]
        self._has_spread = bool(data["has_spread"])
        self.time_step = int(data["time_step"])
        self.max_speed = float(data["max_speed"])
        self.volume_restored = float(data["volume_restored"]) if "volume_restored" in data else 0.0

    # ------------------------------------------------------------------ reference path (public APIs only)
    def advance_reference(self, n_steps: int) -> None:
        """The same coupled steps through public, uncompiled APIs (JAX forces of ``Cell.internal_forces``,
        full-lattice ``Lattice.velocity``, Python loop per step): slow, for verification only; without the volume
        projection."""
        if self.target_volume > 0:
            raise ValueError("advance_reference has no volume projection: build the cell with volume_correction "
                             "'none' to compare against it")
        lat = self.lattice
        periodic_y = not lat.params.has_walls
        scale = self.youngs_modulus * self.radius**2
        for _ in range(int(n_steps)):
            forces = -np.asarray(self.cell.internal_forces(self.positions / self.radius)) * scale
            field = ibm.spread(forces, self.positions, lat.shape, self.kernel, periodic_y)
            lat.set_force_density(field)
            self._has_spread = False  # the field was replaced, not cleared
            velocity = ibm.interpolate(lat.velocity(), self.positions, self.kernel, periodic_y)
            lat.step(1)
            self._marker_forces[...] = forces
            self._velocity[...] = velocity
            self.positions += velocity
            self.time_step += 1
