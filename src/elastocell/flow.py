"""Coupled lattice-Boltzmann / immersed-boundary stepping of an elastic cell, and the shear-flow scenario.

Lattice units throughout the stepping (dx = dt = 1, rho0 = 1): every mesh node is a massless marker
at X (dx); each step (one compiled chunk runs many):

1. clear the force density at the previous markers' supports, compute the elastic nodal forces
   f = -dE/dx at X (cell model in lattice units: E_lat, R_lat), spread them to the force density;
2. one LB step with the force density; it also stores the velocity its collision used,
   u = (sum c f + F/2)/rho with that force (Guo half-force term), at the nodes of the markers' kernel supports;
3. interpolate that u at X; 4. X += u dt.

Shear flow (DESIGN.md section 1): plane Couette flow between walls at y = -1/2 and y = ny - 1/2 moving
with -U and +U (shear_rate = 2U/ny), periodic in x and z, the cell centred in the channel. The capillary
number Ca = eta * shear_rate / mu_ref with mu_ref = mu_c = E_c/(2(1+nu)) (or mu_eff for the homogeneous
equivalent) fixes E_c in lattice units once the lattice shear rate is chosen (see
:func:`shear_lattice_units` for how).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit, prange

from . import ibm
from .lattice import Lattice, LatticeParams
from .lattice import kernels as lb_kernels
from .observables import RotationTracker
from .parameters import ParameterError

# =========================================================================== compiled elastic forces
# The cell model's strain-energy laws (elastocell.materials), differentiated by hand for the compiled
# coupling loop: P = dW/dF for
#   W = mu1/2 (J^(-2/3) I1 - 3) + mu2/2 (J^(-4/3) I2 - 3) + kappa/2 (J - 1)^2
# (neo-Hookean: mu2 = 0). Checked against the JAX autodiff forces of Cell.internal_forces in the tests.
#   P = mu1 J^(-2/3) (F - I1/3 F^-T) + mu2 J^(-4/3) (I1 F - F C - 2/3 I2 F^-T) + kappa (J - 1) J F^-T
COMPILED_LAWS = ("neo-hookean", "mooney-rivlin")


def compiled_law_parameters(cell) -> np.ndarray:
    """Per-element (mu1, mu2, kappa) in units of E_c for the compiled force kernel."""
    name = cell.law.name
    params = np.asarray(cell.material_parameters, dtype=np.float64)
    if name == "neo-hookean":
        return np.ascontiguousarray(np.column_stack([params[:, 0], np.zeros(len(params)), params[:, 1]]))
    if name == "mooney-rivlin":
        return np.ascontiguousarray(params[:, :3])
    raise NotImplementedError(f"no compiled force kernel for the law {name!r} (have {COMPILED_LAWS})")


@njit(cache=True, inline="always", error_model="numpy")
def _inverse_cube_root(j):
    """j^(-1/3) for j > 0 by Newton's iteration y <- y (4 - j y^3)/3 (libm's cbrt/pow cost ~40 ns here).

    Near j = 1 (|j - 1| < 0.2, every element at nu = 0.48) the start is the quadratic Taylor guess and two
    or three iterations reach round-off; otherwise the start (4 - j)/3 or 1/j lies below the root, from
    where the iteration rises monotonically. Exact to about one rounding unit."""
    s = j - 1.0
    if -0.2 < s < 0.2:
        y = 1.0 - s * (1.0 / 3.0) + s * s * (2.0 / 9.0)
    else:
        y = (4.0 - j) * (1.0 / 3.0) if j < 3.5 else 1.0 / j
    for _ in range(200):
        y_new = y * (4.0 - j * y * y * y) * (1.0 / 3.0)
        if abs(y_new - y) <= 4e-16 * y:
            return y_new
        y = y_new
    return y


@njit(parallel=True, cache=True, error_model="numpy")
def _element_forces(x, elements, gradients, weights, params, eforce, j_min):
    """eforce[e, k] = -dE_e/dx_k per element (parallel over elements); j_min[e] = min det F of element e."""
    n_el = elements.shape[0]
    n_q = gradients.shape[1]
    n_k = elements.shape[1]
    for e in prange(n_el):
        mu1 = params[e, 0]
        mu2 = params[e, 1]
        kappa = params[e, 2]
        jm = np.inf
        for k in range(n_k):
            eforce[e, k, 0] = 0.0
            eforce[e, k, 1] = 0.0
            eforce[e, k, 2] = 0.0
        for q in range(n_q):
            f00 = f01 = f02 = f10 = f11 = f12 = f20 = f21 = f22 = 0.0
            for k in range(n_k):
                nd = elements[e, k]
                x0 = x[nd, 0]
                x1 = x[nd, 1]
                x2 = x[nd, 2]
                g0 = gradients[e, q, k, 0]
                g1 = gradients[e, q, k, 1]
                g2 = gradients[e, q, k, 2]
                f00 += x0 * g0
                f01 += x0 * g1
                f02 += x0 * g2
                f10 += x1 * g0
                f11 += x1 * g1
                f12 += x1 * g2
                f20 += x2 * g0
                f21 += x2 * g1
                f22 += x2 * g2
            # cofactors: cof(F) = det(F) F^-T
            c00 = f11 * f22 - f12 * f21
            c01 = f12 * f20 - f10 * f22
            c02 = f10 * f21 - f11 * f20
            c10 = f02 * f21 - f01 * f22
            c11 = f00 * f22 - f02 * f20
            c12 = f01 * f20 - f00 * f21
            c20 = f01 * f12 - f02 * f11
            c21 = f02 * f10 - f00 * f12
            c22 = f00 * f11 - f01 * f10
            det = f00 * c00 + f01 * c01 + f02 * c02
            if not det > 0.0:  # inverted (or NaN): no force, reported through j_min
                jm = det if det == det else np.nan
                continue
            jm = min(jm, det)
            i1 = f00 * f00 + f01 * f01 + f02 * f02 + f10 * f10 + f11 * f11 + f12 * f12 + f20 * f20 + f21 * f21 + f22 * f22
            y = _inverse_cube_root(det)
            a1 = mu1 * y * y  # mu1 J^(-2/3)
            # P = a F - b (F C) + g cof(F)
            a = a1
            g = -a1 * i1 / 3.0 + kappa * (det - 1.0) * det
            fc00 = fc01 = fc02 = fc10 = fc11 = fc12 = fc20 = fc21 = fc22 = 0.0
            b = 0.0
            if mu2 != 0.0:
                m00 = f00 * f00 + f10 * f10 + f20 * f20  # C = F^T F
                m01 = f00 * f01 + f10 * f11 + f20 * f21
                m02 = f00 * f02 + f10 * f12 + f20 * f22
                m11 = f01 * f01 + f11 * f11 + f21 * f21
                m12 = f01 * f02 + f11 * f12 + f21 * f22
                m22 = f02 * f02 + f12 * f12 + f22 * f22
                i2 = 0.5 * (i1 * i1 - (m00 * m00 + m11 * m11 + m22 * m22 + 2.0 * (m01 * m01 + m02 * m02 + m12 * m12)))
                fc00 = f00 * m00 + f01 * m01 + f02 * m02
                fc01 = f00 * m01 + f01 * m11 + f02 * m12
                fc02 = f00 * m02 + f01 * m12 + f02 * m22
                fc10 = f10 * m00 + f11 * m01 + f12 * m02
                fc11 = f10 * m01 + f11 * m11 + f12 * m12
                fc12 = f10 * m02 + f11 * m12 + f12 * m22
                fc20 = f20 * m00 + f21 * m01 + f22 * m02
                fc21 = f20 * m01 + f21 * m11 + f22 * m12
                fc22 = f20 * m02 + f21 * m12 + f22 * m22
                a2 = mu2 * y * y * y * y  # mu2 J^(-4/3)
                a += a2 * i1
                b = a2
                g -= a2 * 2.0 / 3.0 * i2
            g /= det
            w = weights[e, q]
            p00 = a * f00 - b * fc00 + g * c00
            p01 = a * f01 - b * fc01 + g * c01
            p02 = a * f02 - b * fc02 + g * c02
            p10 = a * f10 - b * fc10 + g * c10
            p11 = a * f11 - b * fc11 + g * c11
            p12 = a * f12 - b * fc12 + g * c12
            p20 = a * f20 - b * fc20 + g * c20
            p21 = a * f21 - b * fc21 + g * c21
            p22 = a * f22 - b * fc22 + g * c22
            for k in range(n_k):
                g0 = gradients[e, q, k, 0]
                g1 = gradients[e, q, k, 1]
                g2 = gradients[e, q, k, 2]
                eforce[e, k, 0] -= w * (p00 * g0 + p01 * g1 + p02 * g2)
                eforce[e, k, 1] -= w * (p10 * g0 + p11 * g1 + p12 * g2)
                eforce[e, k, 2] -= w * (p20 * g0 + p21 * g1 + p22 * g2)
        j_min[e] = jm


@njit(parallel=True, cache=True, error_model="numpy")
def _gather_node_forces(eforce, node_ptr, node_slots, out):
    """out[n] = sum of eforce over the (element, local node) slots of node n (CSR; parallel, race free)."""
    flat = eforce.reshape(-1, 3)
    for n in prange(out.shape[0]):
        sx = 0.0
        sy = 0.0
        sz = 0.0
        for s in range(node_ptr[n], node_ptr[n + 1]):
            slot = node_slots[s]
            sx += flat[slot, 0]
            sy += flat[slot, 1]
            sz += flat[slot, 2]
        out[n, 0] = sx
        out[n, 1] = sy
        out[n, 2] = sz


@njit(cache=True, error_model="numpy")
def _elastic_forces(x, elements, gradients, weights, params, node_ptr, node_slots, eforce, j_elem, out):
    _element_forces(x, elements, gradients, weights, params, eforce, j_elem)
    _gather_node_forces(eforce, node_ptr, node_slots, out)
    j_min = np.inf
    for e in range(j_elem.shape[0]):
        v = j_elem[e]
        if not v > 0.0:
            return v
        j_min = min(j_min, v)
    return j_min


class ElasticForces:
    """Compiled nodal forces f = -dE/dx of a :class:`~elastocell.cell.Cell` (the same strain-energy law as
    ``Cell.internal_forces``, whose JAX autodiff it matches to round-off), in scaled units.

    Positions x are in units of ``length_scale`` (R = length_scale), forces in units of
    ``modulus_scale * length_scale^2`` with E_c = modulus_scale; e.g. lattice units: length_scale = R/dx,
    modulus_scale = E_c in lattice units. Cost: parallel over elements, then a race-free gather per node.
    """

    def __init__(self, cell, length_scale: float = 1.0, modulus_scale: float = 1.0):
        geometry = cell.geometry
        elements = np.ascontiguousarray(cell.mesh.elements, dtype=np.int64)
        self.elements = elements
        self.gradients = np.ascontiguousarray(geometry.shape_gradients / length_scale)
        self.weights = np.ascontiguousarray(geometry.weights * length_scale**3)
        self.params = np.ascontiguousarray(compiled_law_parameters(cell) * modulus_scale)
        n_nodes = cell.mesh.n_nodes
        slots = np.argsort(elements.ravel(), kind="stable")
        counts = np.bincount(elements.ravel(), minlength=n_nodes)
        self.node_ptr = np.zeros(n_nodes + 1, dtype=np.int64)
        np.cumsum(counts, out=self.node_ptr[1:])
        self.node_slots = slots.astype(np.int64)
        self._eforce = np.zeros(elements.shape + (3,))
        self._j = np.zeros(len(elements))

    def arguments(self) -> tuple:
        """The compiled kernel's arguments after x: (elements, gradients, weights, params, node_ptr,
        node_slots, element-force buffer, per-element det buffer)."""
        return (self.elements, self.gradients, self.weights, self.params, self.node_ptr, self.node_slots,
                self._eforce, self._j)

    def __call__(self, x: np.ndarray, out: np.ndarray | None = None) -> tuple[np.ndarray, float]:
        """(forces (n, 3), smallest det F); det F <= 0 or NaN flags an inverted element."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        if out is None:
            out = np.empty_like(x)
        j_min = _elastic_forces(x, *self.arguments(), out)
        return out, float(j_min)


# =========================================================================== coupled stepping
class FlowError(RuntimeError):
    """A coupled run stopped: unstable or unphysical state; the message names the cause and the parameter
    to change."""


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
def _coupled_steps(
    n_steps, A, parity, nz, field, consts, has_walls, wall_corr, cint, opp, solid, has_solid,
    run_ptr, run_lo, run_hi, link_ptr, link_z, link_q, lb_weights, cvel, fluid_velocity, box,
    positions, spread_positions, has_spread, forces, velocity, kernel, support,
    elements, gradients, weights, params, node_ptr, node_slots, eforce, j_elem,
):  # fmt: skip
    """Advance ``n_steps`` coupled LB + IBM steps in compiled code (see the module docstring).

    The LB step itself stores the velocity its collision used, u = (sum c f + F/2)/rho with this step's
    force density, at the fluid nodes of the markers' kernel supports (``fluid_velocity``, storage dtype,
    zero at solid nodes); the markers read it there, so no population is read twice.

    Returns (parity, steps done, smallest det F, largest marker speed); stops early (steps done <
    n_steps) when an element inverts or a marker velocity is not finite."""
    periodic_y = not has_walls
    j_min = np.inf
    max_speed = 0.0
    n_markers = positions.shape[0]
    for step in range(n_steps):
        if has_spread:
            ibm._clear_field(spread_positions, kernel, periodic_y, field)
        j = _elastic_forces(positions, elements, gradients, weights, params, node_ptr, node_slots, eforce,
                            j_elem, forces)
        if not j > 0.0:
            return parity, step, j, max_speed
        j_min = min(j_min, j)
        ibm._spread_field(forces, positions, kernel, periodic_y, field)
        spread_positions[:, :] = positions
        has_spread = True
        _velocity_box(positions, support, box)
        lb_kernels._sweep(A, parity, nz, field, True, run_ptr, run_lo, run_hi, has_walls, wall_corr,
                          link_ptr, link_z, link_q, consts, lb_weights, cvel, cint, opp, fluid_velocity, box)
        parity = 1 - parity
        ibm._interpolate_field_serial(fluid_velocity, positions, kernel, periodic_y, velocity)
        for m in range(n_markers):
            vx = velocity[m, 0]
            vy = velocity[m, 1]
            vz = velocity[m, 2]
            speed = vx * vx + vy * vy + vz * vz
            if not speed < 1.0:  # NaN or absurd: the fluid blew up
                return parity, step + 1, -np.inf, np.sqrt(speed)
            max_speed = max(max_speed, speed)
            positions[m, 0] += vx
            positions[m, 1] += vy
            positions[m, 2] += vz
    return parity, n_steps, j_min, np.sqrt(max_speed)


def compile_kernels(dtypes=("float32",)) -> None:
    """Compile (or load from Numba's on-disk cache) the coupled-step kernels in this process, one tiny Couette
    step per storage dtype.

    Call it before starting several worker processes on one machine: they then load the cached kernels
    instead of compiling the same functions at once, which can leave Numba's cache inconsistent (a later run
    segfaults while loading it: numba issues 4807 and 10128; seen here once after parallel first runs).
    A few seconds when the cache is valid, about a minute per dtype otherwise."""
    from .api import cell_parameters
    from .cell import Cell

    cell = Cell.from_parameters(cell_parameters(nucleus="none", element="p1", mesh_size=0.6, pole_size=0.6))
    for dtype in dtypes:
        params = ShearFlowParameters(capillary_number=0.1, resolution=3, confinement=0.3, box_length=4,
                                     dtype=dtype)
        system = shear_setup(cell, params)
        system.advance(1)
        system.lattice.step(1)


def immersed_cell(backend: str, lattice_params: LatticeParams, velocity, cell, units, kernel: str):
    """The coupled system on a backend ("numba" or "jax"): a lattice at the equilibrium of ``velocity``
    (3, nx, ny, nz) and the cell at ``units.centre`` with radius ``units.radius`` (dx) and modulus
    ``units.youngs_modulus`` (lattice units)."""
    if backend == "jax":
        from .flow_jax import JaxImmersedCell, JaxLattice

        lattice_class, cell_class = JaxLattice, JaxImmersedCell
    elif backend == "numba":
        lattice_class, cell_class = Lattice, ImmersedCell
    else:
        raise ValueError(f"backend must be 'numba' or 'jax', got {backend!r}")
    lattice = lattice_class(lattice_params)
    lattice.initialize(velocity=velocity)
    return cell_class(lattice, cell, units.centre, units.radius, units.youngs_modulus, kernel=kernel)


def raise_flow_failure(time_step: int, j_min: float, max_speed: float) -> None:
    """Raise the :class:`FlowError` of a chunk that stopped at ``time_step``: a non-finite fluid
    (``j_min`` = -inf or a non-finite marker speed) or an inverted element (det F = ``j_min`` <= 0)."""
    if j_min == -np.inf or not np.isfinite(max_speed):
        raise FlowError(
            f"the fluid became non-finite at step {time_step} (marker speed {max_speed:.3g} dx/dt): "
            "the elastic forces are too stiff for the time step; lower the lattice shear rate "
            "(reynolds_number) or raise capillary_number"
        )
    raise FlowError(
        f"an element inverted at step {time_step} (det F = {j_min:.3g}): the elastic time step is "
        "unstable or the deformation too large; lower the lattice shear rate (reynolds_number) or use "
        "a coarser mesh"
    )


class MarkerState:
    """What every backend's immersed cell exposes about its markers (positions in dx, radius R in dx)."""

    positions: np.ndarray
    radius: float
    _marker_forces: np.ndarray
    _velocity: np.ndarray

    @property
    def marker_forces(self) -> np.ndarray:
        """Elastic nodal forces -dE/dx at the last spread (rho0 dx^4/dt^2), (n_nodes, 3)."""
        return self._marker_forces

    @property
    def marker_velocities(self) -> np.ndarray:
        """Fluid velocity interpolated at the markers in the last step (dx/dt), (n_nodes, 3)."""
        return self._velocity

    def positions_in_radii(self) -> np.ndarray:
        """Node positions in units of R (origin at the lattice origin)."""
        return self.positions / self.radius


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
        R in dx (the resolution R/dx).
    youngs_modulus : float
        E_c in lattice units (rho0 dx^2/dt^2).
    kernel : "trilinear" (default) or "peskin4".

    State: :attr:`positions` (n_nodes, 3) in dx (unwrapped: periodic images are taken by the kernels),
    :attr:`time_step`. Lattice velocities are dx/dt; forces rho0 dx^4/dt^2.
    """

    backend = "numba"

    def __init__(self, lattice: Lattice, cell, centre, radius: float, youngs_modulus: float,
                 kernel: str = "trilinear"):
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

    def advance(self, n_steps: int) -> None:
        """n_steps coupled steps in one compiled call; raises :class:`FlowError` on an inverted element or a
        non-finite fluid (the lattice is left at the step where it stopped)."""
        n_steps = int(n_steps)
        if n_steps <= 0:
            return
        lat = self.lattice
        tables = lat._tables()  # (run_ptr, run_lo, run_hi, has_walls, wall_corr, link_ptr, link_z, link_q,
        #                          consts, weights, cvel, cint, opp)
        (A, parity, nz, field, _, consts, has_walls, wall_corr, cint, opp, solid,
         has_solid) = ibm.lattice_arguments(lat)  # fmt: skip
        parity, done, j_min, max_speed = _coupled_steps(
            n_steps, A, parity, nz, field, consts, has_walls, wall_corr, cint, opp, solid, has_solid,
            tables[0], tables[1], tables[2], tables[5], tables[6], tables[7], tables[9], tables[10],
            self._fluid_velocity, self._box, self.positions, self._spread_positions, self._has_spread,
            self._marker_forces, self._velocity, self._kernel_id, ibm.KERNEL_SUPPORT[self.kernel],
            *self.forces.arguments(),
        )  # fmt: skip
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
                "time_step": np.array(self.time_step), "max_speed": np.array(self.max_speed)}  # fmt: skip

    def load_state_arrays(self, data) -> None:
        self.lattice.load_state_arrays(data)
        self.positions[...] = data["positions"]
        self._spread_positions[...] = data["spread_positions"]
        self._has_spread = bool(data["has_spread"])
        self.time_step = int(data["time_step"])
        self.max_speed = float(data["max_speed"])

    # ------------------------------------------------------------------ reference path (public APIs only)
    def advance_reference(self, n_steps: int) -> None:
        """The same coupled steps through public, uncompiled APIs (JAX forces of ``Cell.internal_forces``,
        full-lattice ``Lattice.velocity``, Python loop per step): slow, for verification only."""
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


# =========================================================================== elastic time-step stability
STABILITY_CONSTANT = 0.6
"""C0 of the explicit elastic time-step limit ``E_lat * lambda_max(W K) <= C0 * c(tau) * c(d)``.

Measured (trilinear and peskin4, p1 and p2, tau = 1, markers at least 1.1 dx apart, a quiescent periodic
lattice, every node perturbed by 0.02 dx; bisection on E_lat): the coupled scheme turns unstable at
E_lat * lambda_max(W K) = 1.3 - 3.0; C0 = 0.6. Rechecked over 3000 steps (R/dx = 4, mesh size 0.5 R): p1 (nodes
>= 1.1 dx apart) decays at 2x the limit, grows at 4x, blows up at 8x; p2 (0.55 dx) is stable at 1x but an element
inverts at 2x: the margin is below 2 for close p2 nodes."""


def relaxation_time_factor(relaxation_time: float) -> float:
    """c(tau) = min(1, (tau - 1/2)/0.4): the measured critical stiffness falls for tau < 0.9
    (x0.25 at tau = 0.6, x0.46 at tau = 0.7 relative to tau = 1; flat within +-15 % for tau in 0.8 - 2)."""
    return min(1.0, (float(relaxation_time) - 0.5) / 0.4)


def spacing_factor(min_spacing: float) -> float:
    """c(d) = min(1, d^3), d the smallest distance between two nodes of an element (dx): markers closer than
    a lattice spacing destabilise the compressive modes (measured x0.1 - x0.2 at d = 0.55 - 0.63 dx)."""
    return min(1.0, float(min_spacing) ** 3)


def minimum_node_spacing(cell) -> float:
    """Smallest distance between two nodes of one element (units of R)."""
    x = cell.mesh.nodes[cell.mesh.elements]  # (e, k, 3)
    k = x.shape[1]
    i, j = np.triu_indices(k, 1)
    return float(np.linalg.norm(x[:, i] - x[:, j], axis=-1).min())


def kernel_overlap_matrix(positions: np.ndarray, kernel: str = "trilinear"):
    """W_ij = sum_n delta(n - X_i) delta(n - X_j) (sparse, n_markers^2): the velocity a unit force on marker
    j gives marker i in one step (rho0 = 1), before the momentum spreads. Separable: a product of 1D
    overlaps over x, y, z (no periodic images: the cell is much smaller than the box)."""
    import scipy.sparse as sp
    from scipy.spatial import cKDTree

    support = ibm.KERNEL_SUPPORT[kernel]
    pairs = cKDTree(positions).query_pairs(r=support * math.sqrt(3.0), output_type="ndarray")
    i = np.concatenate([pairs[:, 0], pairs[:, 1], np.arange(len(positions))])
    j = np.concatenate([pairs[:, 1], pairs[:, 0], np.arange(len(positions))])
    value = np.ones(len(i))
    for d in range(3):
        a, b = positions[i, d], positions[j, d]
        base = np.floor(np.minimum(a, b)) - support
        overlap = np.zeros(len(i))
        for k in range(2 * support + 2):
            node = base + k
            overlap += ibm.kernel_weights(kernel, a - node) * ibm.kernel_weights(kernel, b - node)
        value *= overlap
    keep = value != 0
    return sp.csr_matrix((value[keep], (i[keep], j[keep])), shape=(len(positions),) * 2)


def stiffness_mobility_eigenvalue(cell, radius: float, kernel: str = "trilinear", offset=(0.3, 0.1, 0.2)) -> float:
    """lambda_max(W K) per unit E_lat: K the cell's reference stiffness in lattice units per unit E_c
    (K_dimensionless * R_lat), W the kernel overlap matrix (per Cartesian component) of the markers at
    ``offset + R_lat * X``. The explicit step is stable for E_lat * lambda_max(W K) below ~1.3 (measured)."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import eigs

    positions = np.asarray(offset) + radius * cell.mesh.nodes
    w = sp.kron(kernel_overlap_matrix(positions, kernel), sp.eye(3), format="csr")
    k = cell.stiffness_matrix(cell.mesh.nodes) * radius
    # fixed start vector and 5 significant digits: the same value on every call, so that the derived lattice
    # parameters (and a run resumed from a checkpoint) are reproducible
    start = np.ones(w.shape[0])
    value = float(eigs(w @ k, k=1, which="LR", return_eigenvectors=False, tol=1e-8, v0=start)[0].real)
    return float(f"{value:.5g}")


# =========================================================================== shear flow
from typing import Literal  # noqa: E402

from pydantic import BaseModel, ConfigDict, model_validator  # noqa: E402


class FlowLatticeParameters(BaseModel):
    """Lattice and coupling settings shared by the flow scenarios (:class:`ShearFlowParameters`,
    ``pipe_flow.PipeFlowParameters``); each scenario documents their defaults and adds its own driving.

    resolution: R/dx in [2, 64]. box_length: periodic length in units of R (>= 2.5: the cell is 2R across).
    relaxation_time: LB tau in [0.55, 5]. reynolds_number: upper limit of the particle Reynolds number, in
    (0, 0.1] (Stokes regime). velocity_limit: upper limit of the largest fluid speed, in (0, 0.1] dx/dt.
    kernel, dtype, backend: immersed-boundary kernel, LB storage precision, compute engine.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    resolution: float = 8.0
    box_length: float = 8.0
    relaxation_time: float = 1.0
    reynolds_number: float = 0.1
    velocity_limit: float = 0.05
    kernel: Literal["trilinear", "peskin4"] = "trilinear"
    dtype: Literal["float32", "float64"] = "float32"
    backend: Literal["numba", "jax"] = "numba"

    @model_validator(mode="after")
    def _check_lattice(self) -> FlowLatticeParameters:
        def require(ok, name, message):
            if not ok:
                raise ParameterError(name, message)

        require(math.isfinite(self.resolution) and 2 <= self.resolution <= 64, "resolution",
                f"R/dx must be in [2, 64], got {self.resolution}")
        require(math.isfinite(self.box_length) and self.box_length >= 2.5, "box_length",
                f"must be >= 2.5 (units of R; the cell is 2R across), got {self.box_length}")
        require(math.isfinite(self.relaxation_time) and 0.55 <= self.relaxation_time <= 5, "relaxation_time",
                f"tau must be in [0.55, 5], got {self.relaxation_time}")
        require(math.isfinite(self.reynolds_number) and 0 < self.reynolds_number <= 0.1, "reynolds_number",
                f"the particle Reynolds number must be in (0, 0.1] (Stokes regime), got {self.reynolds_number}")
        require(math.isfinite(self.velocity_limit) and 0 < self.velocity_limit <= 0.1, "velocity_limit",
                f"must be in (0, 0.1] dx/dt, got {self.velocity_limit}")
        return self


class ShearFlowParameters(FlowLatticeParameters):
    """Plane Couette (shear) flow of a cell; numbers are dimensionless unless stated.

    capillary_number: Ca = eta * shear_rate / mu_ref, mu_ref = mu_c = E_c/(2(1+nu)) (mu_eff = gamma_eff mu_c
        for the homogeneous equivalent cell).
    resolution: R/dx (lattice nodes per cell radius). Default 8 from the resolution study (homogeneous p1
        cell, mesh edge 2 dx, Ca = 0.05, confinement 0.2, box 8R): D/Ca = 1.639, 1.460, 1.365, 1.324 at
        R/dx = 4, 6, 8, 10; the excess over Taylor's 5/4 falls like (dx/R)^2 and the extrapolation gives
        1.243-1.251. R/dx = 8 is 9 % above the limit at a third of the cost of R/dx = 10 (6 % above; cost ~ R^5:
        R^3 nodes and R^2 steps per strain at a fixed Reynolds number).
    confinement: 2R/H, the fraction of the channel height H (wall to wall) the undeformed cell fills.
        Default 0.2 from the confinement study (R/dx = 4, box 8R, Ca = 0.05): D/Ca = 1.620, 1.639, 1.848 at
        2R/H = 0.1, 0.2, 0.4, i.e. +1 % at 0.2 and +14 % at 0.4 relative to 0.1.
    box_length: periodic length of the box along x (flow) and z (vorticity), in units of R. Default 8 from
        the same study: D/Ca = 1.58 (5R), 1.639 (8R), 1.663 (12R) -- the periodic images lower D.
    relaxation_time: LB relaxation time tau (time steps); the kinematic viscosity is (tau - 1/2)/3 dx^2/dt.
    reynolds_number: upper limit of the particle Reynolds number shear_rate R^2 / nu (Stokes regime).
    velocity_limit: upper limit of the wall speed |U| (dx/dt).
    kernel: immersed-boundary kernel ("trilinear", the paper's 2-point one, or "peskin4").
    lattice_shear_rate: impose the shear rate in lattice units (1/dt) instead of choosing the largest
        allowed one; refused if it breaks a limit.
    max_steps_per_strain: refuse a run needing more LB steps per unit strain (1/shear_rate).
    dtype: LB storage precision.
    backend: compute engine: "numba" (fused compiled CPU kernels, the fastest on a CPU) or "jax" (the same
        physics in JAX on its default device: a GPU when JAX has CUDA/ROCm, else the CPU).
    """

    capillary_number: float
    confinement: float = 0.2
    lattice_shear_rate: float | None = None
    max_steps_per_strain: float = 1.0e6

    @model_validator(mode="after")
    def _check(self) -> ShearFlowParameters:
        def require(ok, name, message):
            if not ok:
                raise ParameterError(name, message)

        ca = self.capillary_number
        require(math.isfinite(ca) and ca > 0, "capillary_number", f"must be > 0, got {ca}")
        require(math.isfinite(self.confinement) and 0 < self.confinement < 1, "confinement",
                f"2R/H must be in (0, 1), got {self.confinement}")
        if self.lattice_shear_rate is not None:
            require(math.isfinite(self.lattice_shear_rate) and self.lattice_shear_rate > 0, "lattice_shear_rate",
                    f"must be > 0 (1/dt), got {self.lattice_shear_rate}")
        _check_wall_gap(self)  # before any meshing
        return self


@dataclass(frozen=True)
class ShearUnits:
    """Lattice parameters of a shear-flow run and the conversion to the cell model's units.

    Lattice units: dx = R/resolution, dt = one LB step, rho0 = 1. ``shape`` (nx, ny, nz); walls at
    y = -1/2 and ny - 1/2 move with -/+ ``wall_speed``; ``shear_rate`` = 2 wall_speed / ny (1/dt);
    ``viscosity`` eta = nu (rho0 dx^2/dt); ``youngs_modulus`` E_c (rho0 dx^2/dt^2) so that
    eta * shear_rate / mu_ref = Ca; ``steps_per_strain`` = 1/shear_rate.
    ``limits`` the shear rates each constraint allows (1/dt); ``limiting`` names the binding one.
    """

    radius: float
    shape: tuple[int, int, int]
    relaxation_time: float
    viscosity: float
    shear_rate: float
    wall_speed: float
    youngs_modulus: float
    reference_shear_modulus: float
    reynolds_number: float
    confinement: float
    stiffness_mobility: float
    stability_number: float
    min_node_spacing: float
    limits: dict = field(default_factory=dict)
    limiting: str = ""

    @property
    def steps_per_strain(self) -> float:
        return 1.0 / self.shear_rate

    @property
    def centre(self) -> np.ndarray:
        """Initial cell centre (dx): mid-box in x and z, the zero-velocity plane y = (ny - 1)/2."""
        nx, ny, nz = self.shape
        return np.array([nx / 2.0, (ny - 1) / 2.0, nz / 2.0])

    def as_dict(self) -> dict:
        out = {k: getattr(self, k) for k in (
            "radius", "relaxation_time", "viscosity", "shear_rate", "wall_speed", "youngs_modulus",
            "reference_shear_modulus", "reynolds_number", "confinement", "stiffness_mobility",
            "stability_number", "min_node_spacing", "limiting")}  # fmt: skip
        out["shape"] = list(self.shape)
        out["steps_per_strain"] = self.steps_per_strain
        out["limits"] = dict(self.limits)
        return out


DEFAULT_MESH_EDGE = 2.0
"""Default element edge of a shear-flow cell mesh, in lattice spacings (uniform mesh, no pole refinement).

Linear tetrahedra (the paper's model and the shear default) with edges of 2 dx keep the run limited by the
Reynolds number, not by the elastic time step; finer meshes raise the stiffness eigenvalue (and p2 mid-edge
nodes lie 1 dx apart), which the elastic stability limit then charges in time steps."""


def shear_mesh_size(resolution: float, edge: float = DEFAULT_MESH_EDGE) -> float:
    """Mesh size (units of R) for an element edge of ``edge`` dx at R/dx = ``resolution``, within [0.1, 0.6]."""
    return float(min(0.6, max(0.1, edge / float(resolution))))


def reference_modulus_ratio(cell) -> float:
    """mu_ref / mu_c: gamma_eff for the homogeneous equivalent (Ca with mu_eff), 1 otherwise (Ca with mu_c)."""
    return cell.effective_stiffness_ratio if cell.is_equivalent else 1.0


def _check_wall_gap(params: ShearFlowParameters) -> None:
    """Refuse a channel whose walls lie within the kernel support (+1 dx) of the undeformed cell."""
    radius = float(params.resolution)
    ny = int(round(2.0 * radius / params.confinement))
    half_width = ibm.kernel_half_width(params.kernel)
    gap = ny / 2.0 - radius  # distance from the undeformed cell to a wall (dx)
    if gap < half_width + 1.0:
        raise ParameterError(
            "confinement",
            f"the walls are {gap:.2f} dx from the cell at confinement {params.confinement} and resolution "
            f"{params.resolution}; need >= {half_width + 1:g} dx (kernel half-width + 1): lower confinement",
        )


@dataclass(frozen=True)
class RateLimits:
    """Largest lattice shear rates (1/dt) each Stokes-regime and stability limit allows, and the quantities
    they come from (see :func:`shear_rate_limits`)."""

    viscosity: float  # eta = (tau - 1/2)/3 (rho0 dx^2/dt)
    modulus_per_rate: float  # E_c per unit shear rate (rho0 dx^2/dt)
    stiffness_mobility: float  # lambda_max(W K) per unit E_lat
    spacing: float  # smallest node distance within an element (dx)
    stability_number: float  # C0 c(tau) c(d)
    limits: dict  # {"reynolds_number", "velocity_limit", "elastic_stability"}: rate (1/dt)


def shear_rate_limits(cell, radius: float, relaxation_time: float, capillary_number: float, kernel: str,
                      reynolds_number: float, velocity_limit: float, velocity_length: float) -> RateLimits:
    """Limits on a flow's reference shear rate gdot (shear rate; wall shear rate in a pipe), shared by every
    flow scenario: (1) particle Reynolds number gdot R^2/nu <= ``reynolds_number``, (2) the fastest lattice
    speed gdot velocity_length/2 <= ``velocity_limit`` (velocity_length: H for Couette walls at +-gdot H/2,
    R_ch for the Poiseuille centre line gdot_w R_ch/2), (3) the explicit elastic step stable,
    E_c lambda_max(W K) <= C0 c(tau) c(d), where Ca = eta gdot/mu_ref gives E_c = 2 (1 + nu) mu_ref/(mu_ref/mu_c)."""
    viscosity = (relaxation_time - 0.5) / 3.0
    poisson = cell.parameters.material.poisson_ratio
    modulus_per_rate = 2.0 * (1.0 + poisson) * viscosity / (capillary_number * reference_modulus_ratio(cell))
    stiffness_mobility = stiffness_mobility_eigenvalue(cell, radius, kernel)
    spacing = minimum_node_spacing(cell) * radius
    stability_number = STABILITY_CONSTANT * relaxation_time_factor(relaxation_time) * spacing_factor(spacing)
    limits = {
        "reynolds_number": reynolds_number * viscosity / radius**2,
        "velocity_limit": 2.0 * velocity_limit / velocity_length,
        "elastic_stability": stability_number / (stiffness_mobility * modulus_per_rate),
    }
    return RateLimits(viscosity, modulus_per_rate, stiffness_mobility, spacing, stability_number, limits)


def shear_lattice_units(cell, params: ShearFlowParameters) -> ShearUnits:
    """Derive the lattice parameters of a shear run from (Ca, R/dx, confinement) and the limits.

    With R = resolution (dx), H = ny = round(2R/confinement), nu = (tau - 1/2)/3 = eta, the shear rate is the
    largest one that keeps (1) the particle Reynolds number shear_rate R^2/nu <= reynolds_number, (2) the wall
    speed shear_rate H/2 <= velocity_limit, and (3) the explicit elastic step stable:
    E_c * lambda_max(W K) <= C0 c(tau) c(d) (see :data:`STABILITY_CONSTANT`), where E_c follows from Ca:
    mu_ref = eta shear_rate / Ca, E_c = 2 (1 + nu_p) mu_ref / (mu_ref/mu_c). Raises ParameterError when the
    geometry cannot hold the cell, when ``lattice_shear_rate`` breaks a limit, or when the run would need
    more than ``max_steps_per_strain`` steps per unit strain.
    """
    radius = float(params.resolution)
    ny = int(round(2.0 * radius / params.confinement))
    n_side = int(round(params.box_length * radius))
    _check_wall_gap(params)
    tau = params.relaxation_time
    ca = params.capillary_number
    rates = shear_rate_limits(cell, radius, tau, ca, params.kernel, params.reynolds_number,
                              params.velocity_limit, ny)
    viscosity, modulus_per_rate, limits = rates.viscosity, rates.modulus_per_rate, rates.limits
    stiffness_mobility, spacing, stability_number = rates.stiffness_mobility, rates.spacing, rates.stability_number
    if params.lattice_shear_rate is None:
        limiting = min(limits, key=limits.get)
        shear_rate = limits[limiting]
    else:
        shear_rate = float(params.lattice_shear_rate)
        limiting = "lattice_shear_rate"
        for name, value in limits.items():
            if shear_rate > value * (1 + 1e-12):
                what = {
                    "reynolds_number": f"gives a particle Reynolds number {shear_rate * radius**2 / viscosity:.3g} > "
                    f"{params.reynolds_number}",
                    "velocity_limit": f"gives wall speeds {shear_rate * ny / 2:.3g} dx/dt > {params.velocity_limit}",
                    "elastic_stability": "makes the explicit elastic step unstable (E_c lambda_max(W K) = "
                    f"{shear_rate * modulus_per_rate * stiffness_mobility:.3g} > {stability_number:.3g})",
                }[name]
                raise ParameterError("lattice_shear_rate", f"{shear_rate:.4g} {what}; use <= {value:.4g}")
    if 1.0 / shear_rate > params.max_steps_per_strain:
        raise ParameterError(
            "capillary_number",
            f"Ca = {ca} needs {1 / shear_rate:.3g} LB steps per unit strain at resolution {params.resolution} "
            f"(limited by {limiting}), more than max_steps_per_strain = {params.max_steps_per_strain:.3g}: "
            "raise capillary_number, lower resolution or use a coarser mesh",
        )
    youngs_modulus = modulus_per_rate * shear_rate
    return ShearUnits(
        radius=radius,
        shape=(n_side, ny, n_side),
        relaxation_time=tau,
        viscosity=viscosity,
        shear_rate=shear_rate,
        wall_speed=shear_rate * ny / 2.0,
        youngs_modulus=youngs_modulus,
        reference_shear_modulus=viscosity * shear_rate / ca,
        reynolds_number=shear_rate * radius**2 / viscosity,
        confinement=2.0 * radius / ny,
        stiffness_mobility=stiffness_mobility,
        stability_number=youngs_modulus * stiffness_mobility,
        min_node_spacing=spacing,
        limits=limits,
        limiting=limiting,
    )


@dataclass
class ShearResult:
    """Time series and stationary summary of a shear run.

    series: columns (arrays of equal length): strain (t * shear_rate), taylor_deformation,
    inclination_deg, volume_change (V/V0 - 1), centre_x/y/z (units of R, relative to the initial centre),
    nucleus_centre_x/y/z (same, NaN without a nucleus), semi_axis_a/b/c (R), max_speed (dx/dt).
    summary: stationary means and standard deviations over strain >= transient, the tank-treading angular
    frequency (units of the shear rate), the lattice parameters and timings.
    """

    series: dict
    summary: dict
    units: ShearUnits
    tracker: RotationTracker

    def to_frame(self):
        import pandas as pd

        return pd.DataFrame(self.series)


def shear_setup(cell, params: ShearFlowParameters, units: ShearUnits | None = None) -> ImmersedCell:
    """Lattice (Couette profile already established) and the immersed cell at the channel centre."""
    units = shear_lattice_units(cell, params) if units is None else units
    nx, ny, nz = units.shape
    u = units.wall_speed
    lattice_params = LatticeParams(units.shape, relaxation_time=units.relaxation_time, dtype=params.dtype,
                                   wall_velocity=(-u, u), velocity_limit=max(params.velocity_limit, u) * 1.2)
    profile = -u + 2.0 * u * (np.arange(ny) + 0.5) / ny
    velocity = np.zeros((3,) + units.shape)
    velocity[0] = profile[None, :, None]
    return immersed_cell(params.backend, lattice_params, velocity, cell, units, params.kernel)


def stationary_summary(series: dict, transient: float) -> dict:
    """Mean and standard deviation of the observables over strain >= transient."""
    strain = np.asarray(series["strain"])
    keep = strain >= transient
    out = {"transient_strain": float(transient), "stationary_records": int(keep.sum())}
    for name in ("taylor_deformation", "inclination_deg", "volume_change"):
        values = np.asarray(series[name])[keep]
        out[f"{name}_mean"] = float(values.mean()) if values.size else float("nan")
        out[f"{name}_std"] = float(values.std()) if values.size else float("nan")
    out["volume_change_max_abs"] = float(np.abs(series["volume_change"]).max())
    return out


def run_shear(
    cell,
    params: ShearFlowParameters,
    duration: float = 10.0,
    record_interval: float = 0.05,
    transient: float | None = None,
    callback=None,
) -> ShearResult:
    """Run a cell in plane Couette flow for ``duration`` units of strain (shear_rate * t), in memory.

    Observables are recorded every ``record_interval`` of strain (each record ends one compiled chunk);
    ``transient`` (default duration/2) is the strain after which the stationary means and the
    tank-treading frequency are taken. ``callback(record: dict, system: ImmersedCell)`` runs after every
    record. Raises :class:`FlowError` if the run turns unstable or the cell reaches a wall. The runner
    (:class:`elastocell.runner.ShearRun`) adds checkpoints, other stop criteria and output files.
    """
    from .runner import ShearRun, StopCriteria

    start = time.perf_counter()
    stop = StopCriteria(duration=duration)
    run = ShearRun(cell, params, record_interval=record_interval)
    observers = () if callback is None else (lambda row, current: callback(row, current.system),)
    run.run(stop, observers=observers)
    summary = run.summary(0.5 * duration if transient is None else transient)
    summary["wall_time_s"] = time.perf_counter() - start
    return ShearResult(series=run.arrays(), summary=summary, units=run.units, tracker=run.tracker)
