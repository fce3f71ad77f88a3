"""The D3Q19 lattice Boltzmann fluid in JAX: one code for the CPU and for any accelerator JAX drives.

:class:`JaxLattice` has the physics and the interface of :class:`~elastocell.lattice.Lattice` (TRT or BGK
collision, Guo forcing with a uniform body force plus a per-node force density, periodic boundaries,
half-way bounce-back on a solid mask and on moving plane walls at y = -1/2 and ny - 1/2), with the state held
by JAX on its default device: a CUDA or ROCm GPU when ``jax[cuda12]`` (or the ROCm build) is installed,
otherwise the CPU. The same tests run it against the NumPy reference step and the Numba kernels.

Storage: populations as deviations from the rest weights, d_i = f_i - w_i, in the standard
``(19, nx, ny, nz)`` order and the storage precision (float32 by default): storing deviations keeps float32
mass drift at the rounding level of the deviations, not of the weights.

One step (collide, then stream), written as whole-array operations that XLA fuses:

* moments: rho = 1 + sum_i d_i, u = (sum_i c_i d_i + F/2) / rho (Guo's half-force velocity);
* a power-law medium (``params.rheology``): omega+- of each node from its strain rate (:func:`local_rates`);
* TRT collision on the symmetric and antisymmetric parts, d*_i = d_i - omega+ (d_i^s - e_i^s)
  - omega- (d_i^a - e_i^a) + (1 - omega+/2) S_i^s + (1 - omega-/2) S_i^a with
  e_i = f^eq_i - w_i = w_i [(rho - 1) + rho (3 c_i.u + 9/2 (c_i.u)^2 - 3/2 u^2)] and the Guo source
  S_i = w_i [3 (c_i - u).F + 9 (c_i.u)(c_i.F)];
* streaming d_i(x) = d*_i(x - c_i) (periodic roll), replaced by the bounce-back value d*_opp(i)(x) on a link
  that starts in a solid node (with ``params.wall_fraction``, by its interpolated value, see
  :mod:`elastocell.lattice.geometry`), and by d*_opp(i)(x) + 6 w_i c_i.u_w on a link that leaves a moving wall.

A chunk of steps is one compiled ``lax.fori_loop``; Python acts only between chunks. On the CPU XLA runs this
at a fraction of the Numba kernel's speed (``elastocell bench lattice --backend jax`` measures both); the
JAX path exists for accelerators.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from elastocell.body.materials import computes_in_float64
from elastocell.lattice.geometry import build_line_geometry
from elastocell.lattice.params import LatticeParams, check_body_force
from elastocell.lattice.rheology import LOG_TWO, ROOT_ITERATIONS, SMALLEST_STRESS
from elastocell.lattice.solver import Lattice, step_count
from elastocell.lattice.stencil import OPPOSITE, VELOCITIES, WEIGHTS, Q


def default_device() -> str:
    """The platform JAX computes on by default: ``cpu``, ``gpu`` (CUDA/ROCm) or ``tpu``."""
    return jax.default_backend()


@jax.tree_util.register_pytree_node_class
class LatticeTables:
    """Per-lattice data of a step: relaxation rates and wall terms (static: part of the compiled program, compared
    by value, so lattices with the same parameters share it), the bounce-back masks and the uniform body force
    (device arrays passed to the compiled step, not baked into it: :meth:`JaxLattice.set_body_force` changes the
    force without recompiling; whether there is one at all is static)."""

    def __init__(self, params: LatticeParams | None, dtype=None):
        if params is None:  # unflattening
            return
        law = params.rheology
        self.has_rheology = law is not None
        self.rheology = (0.0,) * 5 if law is None else (
            float(law.flow_index), float(3.0 * law.consistency), float(law.relaxation_time_min),
            float(law.relaxation_time_max), 0.0 if params.collision == "bgk" else float(params.magic))
        nx, ny, nz = params.shape
        self.omega_plus = float(1.0 / params.relaxation_time_plus)
        self.omega_minus = float(1.0 / params.relaxation_time_minus)
        self.body_force = jnp.asarray(params.body_force, dtype=jnp.float64)
        """A leaf, not a static: :meth:`JaxLattice.set_body_force` changes it without recompiling."""
        self.has_body_force = any(float(g) != 0.0 for g in params.body_force)
        solid = params.solid
        self.has_solid = solid is not None and bool(solid.any())
        self.bounce = self.fluid = None
        if self.has_solid:
            bounce = np.zeros((Q, nx, ny, nz), dtype=bool)
            for i in range(1, Q):
                came_from_solid = np.roll(solid, shift=tuple(VELOCITIES[i]), axis=(0, 1, 2))  # solid[x - c_i]
                if params.has_walls and VELOCITIES[i, 1] != 0:  # the link crosses a y-wall, not the mask
                    came_from_solid[:, 0 if VELOCITIES[i, 1] > 0 else ny - 1, :] = False
                bounce[i] = came_from_solid & ~solid
            self.bounce = jnp.asarray(bounce)
            self.fluid = jnp.asarray(~solid)
        self.curved = self.has_solid and params.wall_fraction is not None
        self.link_a = self.link_b = self.link_near = None
        if self.curved:  # interpolated bounce-back, per arriving direction (lattice.geometry's coefficients)
            geometry = build_line_geometry(params.shape, solid, params.has_walls, params.wall_fraction)
            line = np.repeat(np.arange(nx * ny), np.diff(geometry.link_ptr))
            arriving = np.asarray(OPPOSITE)[geometry.link_q]
            where = (arriving, line // ny, line % ny, geometry.link_z)
            dtype = params.numpy_dtype
            a, b = np.ones((Q, nx, ny, nz), dtype), np.zeros((Q, nx, ny, nz), dtype)
            near = np.zeros((Q, nx, ny, nz), dtype=bool)
            a[where], b[where], near[where] = geometry.link_a, geometry.link_b, geometry.link_near
            self.link_a, self.link_b, self.link_near = jnp.asarray(a), jnp.asarray(b), jnp.asarray(near)
        self.has_walls = bool(params.has_walls)
        self.wall_bottom = self.wall_top = (0.0,) * Q
        if self.has_walls:
            bottom, top = (np.asarray(v, dtype=np.float64) for v in params.wall_velocity)
            self.wall_bottom = tuple(6.0 * WEIGHTS * (VELOCITIES @ bottom))  # for c_iy = +1, entering y = 0
            self.wall_top = tuple(6.0 * WEIGHTS * (VELOCITIES @ top))  # for c_iy = -1, entering y = ny - 1

    _STATIC = ("omega_plus", "omega_minus", "has_body_force", "has_solid", "has_walls",
               "wall_bottom", "wall_top", "has_rheology", "rheology", "curved")

    def tree_flatten(self):
        arrays = (self.bounce, self.fluid, self.body_force, self.link_a, self.link_b, self.link_near)
        return arrays, tuple(getattr(self, name) for name in self._STATIC)

    @classmethod
    def tree_unflatten(cls, static, arrays):
        tables = cls(None)
        tables.bounce, tables.fluid, tables.body_force, tables.link_a, tables.link_b, tables.link_near = arrays
        for name, value in zip(cls._STATIC, static, strict=True):
            setattr(tables, name, value)
        return tables


def moments(deviations, force, tables: LatticeTables):
    """(rho - 1, u) of deviations (19, nx, ny, nz) and the total force F (3, ...) or None; storage dtype."""
    drho = jnp.sum(deviations, axis=0)
    c = jnp.asarray(VELOCITIES, dtype=deviations.dtype)
    momentum = jnp.einsum("ia,i...->a...", c, deviations)
    if force is not None:
        momentum = momentum + 0.5 * force
    return drho, momentum / (1.0 + drho)


def total_force(field, tables: LatticeTables, shape, dtype):
    """F = uniform body force + force density field (3, nx, ny, nz), or None when both are absent."""
    if tables.has_body_force:
        g = jnp.asarray(tables.body_force, dtype=dtype).reshape(3, 1, 1, 1)
        return g + (jnp.zeros((3,) + tuple(shape), dtype) if field is None else field)
    return field


def local_rates(non_equilibrium, u, force, rho, tables: LatticeTables):
    """(omega+, omega-) per node of a power-law medium (:mod:`elastocell.lattice.rheology`):
    Pi = sum_i c_i c_i (f_i - f^eq_i) + (u F + F u)/2, m = 3 sqrt(2 Pi:Pi)/(2 rho), tau+ the clamped root of
    3K gdot^n + gdot/2 = m by Halley steps in log gdot (float64 where JAX computes in 64 bit; the Numba kernels read
    the same root from the law's table, :func:`~elastocell.lattice.rheology.relaxation_time_table`), tau- at the
    same magic."""
    n, three_k, tau_min, tau_max, magic = tables.rheology
    c = jnp.asarray(VELOCITIES, dtype=non_equilibrium.dtype)
    pi = jnp.einsum("ia,ib,i...->ab...", c, c, non_equilibrium)
    if force is not None:
        uf = jnp.einsum("a...,b...->ab...", u, force)
        pi = pi + 0.5 * (uf + jnp.swapaxes(uf, 0, 1))
    m = jnp.maximum(1.5 * jnp.sqrt(2.0 * jnp.sum(pi * pi, axis=(0, 1))) / rho, SMALLEST_STRESS)
    log_m = jnp.log(m)
    s = jnp.minimum(log_m + LOG_TWO, (log_m - np.log(three_k)) / n)
    for _ in range(ROOT_ITERATIONS):
        p = three_k * jnp.exp(n * s)
        g = 0.5 * jnp.exp(s)
        f0, f1, f2 = p + g - m, n * p + g, n * n * p + g
        s = s - 2.0 * f0 * f1 / (2.0 * f1 * f1 - f0 * f2)
    tau = jnp.clip(m * jnp.exp(-s), tau_min, tau_max)
    tau_minus = tau if magic == 0.0 else 0.5 + magic / (tau - 0.5)
    return (1.0 / tau).astype(non_equilibrium.dtype), (1.0 / tau_minus).astype(non_equilibrium.dtype)


def collide_and_stream(deviations, force, tables: LatticeTables):
    """One LB step of the deviations d_i = f_i - w_i (module docstring); ``force`` (3, ...) or None."""
    dtype = deviations.dtype
    w = jnp.asarray(WEIGHTS, dtype=dtype).reshape(Q, 1, 1, 1)
    c = jnp.asarray(VELOCITIES, dtype=dtype)
    drho, u = moments(deviations, force, tables)
    rho = 1.0 + drho
    cu = jnp.einsum("ia,a...->i...", c, u)
    usq = jnp.sum(u * u, axis=0)
    equilibrium = w * (drho + rho * (3.0 * cu + 4.5 * cu * cu - 1.5 * usq))
    opposite = np.asarray(OPPOSITE)
    omega_plus, omega_minus = tables.omega_plus, tables.omega_minus
    if tables.has_rheology:
        omega_plus, omega_minus = local_rates(deviations - equilibrium, u, force, rho, tables)
    sym = 0.5 * (deviations + deviations[opposite]) - 0.5 * (equilibrium + equilibrium[opposite])
    asym = 0.5 * (deviations - deviations[opposite]) - 0.5 * (equilibrium - equilibrium[opposite])
    post = deviations - omega_plus * sym - omega_minus * asym
    if force is not None:
        cf = jnp.einsum("ia,a...->i...", c, force)
        source = w * (3.0 * (cf - jnp.sum(u * force, axis=0)) + 9.0 * cu * cf)
        post = (post + (1.0 - 0.5 * omega_plus) * 0.5 * (source + source[opposite])
                + (1.0 - 0.5 * omega_minus) * 0.5 * (source - source[opposite]))  # fmt: skip
    rolled = [jnp.roll(post[i], shift=tuple(int(s) for s in VELOCITIES[i]), axis=(0, 1, 2)) for i in range(Q)]
    streamed = []
    for i in range(Q):
        shifted = rolled[i]
        if tables.has_solid and i > 0 and tables.curved:  # f_i(x) of the link along c_k = -c_i into the solid
            k = opposite[i]  # near: 2q f*_k(x) + (1-2q) f*_k(x - c_k); far: f*_k(x)/2q + (2q-1)/2q f*_i(x)
            second = jnp.where(tables.link_near[i], rolled[k], post[i])
            shifted = jnp.where(tables.bounce[i], tables.link_a[i] * post[k] + tables.link_b[i] * second, shifted)
        elif tables.has_solid and i > 0:
            shifted = jnp.where(tables.bounce[i], post[opposite[i]], shifted)
        if tables.has_walls and VELOCITIES[i, 1] == 1:  # leaves the bottom wall into y = 0
            shifted = shifted.at[:, 0, :].set(post[opposite[i]][:, 0, :] + dtype.type(tables.wall_bottom[i]))
        elif tables.has_walls and VELOCITIES[i, 1] == -1:  # leaves the top wall into y = ny - 1
            shifted = shifted.at[:, -1, :].set(post[opposite[i]][:, -1, :] + dtype.type(tables.wall_top[i]))
        streamed.append(shifted)
    new = jnp.stack(streamed)
    if tables.has_solid:
        new = jnp.where(tables.fluid, new, 0)
    return new


@jax.jit
def _run_steps(deviations, n_steps, field, tables: LatticeTables):
    shape = deviations.shape[1:]
    force = total_force(field, tables, shape, deviations.dtype)
    return jax.lax.fori_loop(0, n_steps, lambda _, d: collide_and_stream(d, force, tables), deviations)


@jax.jit
def _moments(deviations, field, tables: LatticeTables):
    force = total_force(field, tables, deviations.shape[1:], deviations.dtype)
    return moments(deviations, force, tables)


@computes_in_float64
class JaxLattice(Lattice):
    """:class:`~elastocell.lattice.Lattice` with its state and steps in JAX (module docstring).

    Same constructor, methods and units. :attr:`force_density` is a JAX array on the device (replace it with
    :meth:`set_force_density`; it cannot be written in place). ``device`` names the platform it runs on.
    """

    backend = "jax"

    def __init__(self, params: LatticeParams, density=1.0, velocity=(0.0, 0.0, 0.0)):
        if not isinstance(params, LatticeParams):
            raise TypeError(f"params must be a LatticeParams, got {type(params).__name__}")
        self.params = params
        self.dtype = params.numpy_dtype
        self.shape = tuple(params.shape)
        self.time_step = 0
        self._solid = params.solid
        self._tables_jax = LatticeTables(params)
        self._deviations = jnp.zeros((Q,) + self.shape, dtype=self.dtype)
        self._force_field = None
        self.device = default_device()
        self.initialize(density, velocity)

    # ------------------------------------------------------------------ state
    def set_population_deviations(self, deviations) -> None:
        f = np.asarray(deviations)
        if f.shape != (Q,) + self.shape:
            raise ValueError(f"populations must have shape {(Q,) + self.shape}, got {f.shape}")
        f = f.astype(self.dtype, copy=True)
        if self._solid is not None:
            f[:, self._solid] = 0
        self._deviations = jnp.asarray(f)

    def population_deviations(self) -> np.ndarray:
        out = np.array(self._deviations)
        if self._solid is not None:
            out[:, self._solid] = 0
        return out

    @property
    def deviations(self):
        """The device array of deviations f_i - w_i, (19, nx, ny, nz) (read-only use)."""
        return self._deviations

    @deviations.setter
    def deviations(self, value) -> None:
        self._deviations = value

    def set_force_density(self, force_density) -> None:
        if force_density is None:
            self._force_field = None
            return
        arr = jnp.asarray(force_density, dtype=self.dtype)
        if arr.shape != (3,) + self.shape:
            raise ValueError(f"force_density must have shape {(3,) + self.shape}, got {arr.shape}")
        if not bool(jnp.all(jnp.isfinite(arr))):
            raise ValueError("force_density must be finite")
        self._force_field = arr

    def _total_force(self) -> np.ndarray:
        g = np.asarray(self.params.body_force, dtype=np.float64).reshape(3, 1, 1, 1)
        if self._force_field is None:
            return g
        return g + np.asarray(self._force_field, dtype=np.float64)

    def set_body_force(self, body_force) -> None:
        """Replace the uniform body force (3 floats, rho0 dx/dt^2) from the next step on, without recompiling (the
        compiled steps read it as an argument); a lattice built without one cannot be given one."""
        if not self._tables_jax.has_body_force and any(float(c) != 0.0 for c in body_force):
            raise ValueError("a JAX lattice built without a body force cannot be given one (its compiled steps "
                             "leave it out)")
        self.params = check_body_force(self.params, body_force)
        self._tables_jax.body_force = jnp.asarray(self.params.body_force, dtype=jnp.float64)

    # ------------------------------------------------------------------ stepping
    def step(self, n: int = 1) -> None:
        """Advance n time steps in one compiled loop on the device."""
        n = step_count(n)
        if n == 0:
            return
        self._deviations = _run_steps(self._deviations, n, self._force_field, self._tables_jax)
        self.time_step += n

    def _moments(self) -> tuple[np.ndarray, np.ndarray]:
        drho, u = _moments(self._deviations, self._force_field, self._tables_jax)
        return np.asarray(drho), np.asarray(u)

    # ------------------------------------------------------------------ checkpoints
    def state_arrays(self) -> dict:
        """Everything :meth:`load_state_arrays` needs to continue (NumPy arrays): bit-identically on the CPU;
        on a GPU the scatter-add of the immersed cell sums in a varying order."""
        field = np.zeros((3,) + self.shape, self.dtype) if self._force_field is None else np.asarray(self._force_field)
        return {"populations": np.asarray(self._deviations), "lattice_time_step": np.array(self.time_step),
                "force_density": field, "has_force_density": np.array(self._force_field is not None)}

    def load_state_arrays(self, data) -> None:
        self._deviations = jnp.asarray(data["populations"], dtype=self.dtype)
        self.time_step = int(data["lattice_time_step"])
        has_field = bool(data["has_force_density"])
        self._force_field = jnp.asarray(data["force_density"], dtype=self.dtype) if has_field else None

    def __repr__(self) -> str:
        return "Jax" + super().__repr__() + f" on {self.device}"


__all__ = ["JaxLattice", "LatticeTables", "collide_and_stream", "default_device"]
