"""The :class:`Lattice` state object: a D3Q19 lattice Boltzmann fluid in lattice units."""

from __future__ import annotations

import numpy as np

from elastocell.lattice import kernels
from elastocell.lattice.geometry import build_line_geometry
from elastocell.lattice.params import LatticeParams, check_body_force
from elastocell.lattice.stability import StabilityReport, check_stability
from elastocell.lattice.stencil import VELOCITIES, WEIGHTS, Q

_ALIGN_BYTES = 64


def _aligned_zeros(shape, dtype, align=_ALIGN_BYTES, margin=_ALIGN_BYTES):
    """Zero array whose first element sits on an ``align``-byte boundary, with at least
    ``margin`` bytes of valid memory before and after it (the kernels' seam reads)."""
    dtype = np.dtype(dtype)
    nbytes = int(np.prod(shape)) * dtype.itemsize
    raw = np.zeros(nbytes + align + 2 * margin, dtype=np.uint8)
    offset = margin + (-(raw.ctypes.data + margin)) % align
    return raw[offset : offset + nbytes].view(dtype).reshape(shape)


def equilibrium_deviation(density, velocity) -> np.ndarray:
    """Second-order equilibrium minus the rest weights, f^eq_i - w_i (float64).

    f^eq_i = w_i rho [1 + 3 c_i.u + 9/2 (c_i.u)^2 - 3/2 u^2].

    density : array (...) of rho (rho0 = 1); velocity : array (3, ...) of u (dx/dt).
    Returns an array (19, ...).
    """
    rho = np.asarray(density, dtype=np.float64)
    u = np.asarray(velocity, dtype=np.float64)
    cu = np.einsum("ia,a...->i...", VELOCITIES.astype(np.float64), u)
    usq = np.einsum("a...,a...->...", u, u)
    w = WEIGHTS.reshape((Q,) + (1,) * (cu.ndim - 1))
    return w * ((rho - 1.0) + rho * (3.0 * cu + 4.5 * cu * cu - 1.5 * usq))


def step_count(n) -> int:
    """n as a number of time steps (an integer >= 0); ValueError otherwise."""
    if int(n) != n or n < 0:
        raise ValueError(f"n (number of steps) must be an integer >= 0, got {n!r}")
    return int(n)


class Lattice:
    """D3Q19 lattice Boltzmann fluid (TRT or BGK, Guo forcing, half-way or interpolated bounce-back).

    Lattice units throughout: dx = dt = 1, rho0 = 1, c_s^2 = 1/3; velocities in dx/dt,
    force densities in rho0 dx/dt^2, kinematic viscosity nu = (tau - 1/2)/3 in dx^2/dt.

    Parameters
    ----------
    params : LatticeParams
        Validated run parameters.
    density : float or array (nx, ny, nz), optional
        Initial density rho (default 1).
    velocity : 3 floats or array (3, nx, ny, nz), optional
        Initial velocity u (default 0); see :meth:`initialize`.

    Notes
    -----
    Populations are stored in an ``(nx, ny, 19, nz_row)`` array of deviations
    ``f_i - w_i`` and streamed in place with the AA pattern (see
    :mod:`elastocell.lattice.kernels`). Read them through :attr:`populations` or
    :meth:`population_deviations` (standard ``(19, nx, ny, nz)`` order).
    """

    def __init__(self, params: LatticeParams, density=1.0, velocity=(0.0, 0.0, 0.0)):
        if not isinstance(params, LatticeParams):
            raise TypeError(f"params must be a LatticeParams, got {type(params).__name__}")
        self.params = params
        self.dtype = params.numpy_dtype
        nx, ny, nz = params.shape
        self.shape = (nx, ny, nz)
        lanes = _ALIGN_BYTES // self.dtype.itemsize
        self._nz_row = -(-nz // lanes) * lanes  # rows padded to whole cache lines
        self._storage = _aligned_zeros((nx, ny, Q, self._nz_row), self.dtype)
        self._parity = 0
        self.time_step = 0
        """Number of time steps taken since the last :meth:`initialize` (dt)."""

        self._geometry = build_line_geometry(self.shape, params.solid, params.has_walls, params.wall_fraction)
        g = self._geometry
        self._curved = params.wall_fraction is not None and g.n_links > 0
        self._link_a = g.link_a.astype(self.dtype)
        self._link_b = g.link_b.astype(self.dtype)
        self._link_near = g.link_near.copy()
        self._wall_memory = np.zeros(g.n_links, dtype=self.dtype)  # far links' f*_opp(i) of the last even step
        self._solid = params.solid
        self._consts = kernels.make_consts(
            1.0 / params.relaxation_time_plus,
            1.0 / params.relaxation_time_minus,
            params.body_force,
            self.dtype,
            params.rheology,
            0.0 if params.collision == "bgk" else params.magic,
        )
        self._weights, self._cvel, self._cint, self._opp = kernels.stencil_tables(self.dtype)
        # bounce-back correction for a population j leaving a wall: 2 w_j rho_w (c_j.u_w)/c_s^2
        wall_corr = np.zeros((2, Q), dtype=np.float64)
        if params.has_walls:
            for side, u_wall in enumerate(params.wall_velocity):
                wall_corr[side] = 6.0 * WEIGHTS * (VELOCITIES @ np.asarray(u_wall))
        self._wall_corr = wall_corr.astype(self.dtype)
        self._no_field = np.zeros((3, 1, 1, 1), dtype=self.dtype)  # placeholder: no force field
        self._no_output = np.zeros((Q, 1, 1, 1), dtype=self.dtype)  # placeholder: no export
        self._force_field: np.ndarray | None = None
        self.initialize(density, velocity)

    # ------------------------------------------------------------------ properties
    @property
    def relaxation_time(self) -> float:
        """tau (time steps)."""
        return self.params.relaxation_time

    @property
    def kinematic_viscosity(self) -> float:
        """nu = (tau - 1/2)/3 (dx^2/dt)."""
        return self.params.kinematic_viscosity

    @property
    def solid(self) -> np.ndarray | None:
        """Boolean solid mask (nx, ny, nz) or None."""
        return self._solid

    @property
    def force_density(self) -> np.ndarray | None:
        """The per-node force density field F (3, nx, ny, nz) in rho0 dx/dt^2, or None.

        This is the solver's own array: writing into it in place (e.g. when an immersed
        boundary spreads forces) changes the force of the next steps."""
        return self._force_field

    # ------------------------------------------------------------------ state
    def initialize(self, density=1.0, velocity=(0.0, 0.0, 0.0)) -> None:
        """Set every node to the equilibrium of (rho, u) and reset :attr:`time_step`.

        density : float or (nx, ny, nz) array, rho > 0 (rho0 = 1).
        velocity : 3 floats or (3, nx, ny, nz) array, u in dx/dt, |u| < velocity_limit.

        With a force present the equilibrium is built with u - F/(2 rho) so that
        :meth:`velocity` returns exactly ``u``. Solid nodes are set to rest (rho0, 0).
        """
        rho = np.broadcast_to(np.asarray(density, dtype=np.float64), self.shape)
        u = np.asarray(velocity, dtype=np.float64)
        if u.shape == (3,):
            u = u.reshape(3, 1, 1, 1)
        try:
            u = np.broadcast_to(u, (3,) + self.shape)
        except ValueError as exc:
            raise ValueError(f"velocity must be 3 floats or an array of shape {(3,) + self.shape}") from exc
        if not np.all(np.isfinite(rho)) or np.any(rho <= 0.0):
            raise ValueError("density must be finite and > 0 (rho0 = 1 lattice units)")
        if not np.all(np.isfinite(u)):
            raise ValueError("velocity must be finite")
        speed = float(np.sqrt(np.einsum("a...,a...->...", u, u)).max())
        if speed >= self.params.velocity_limit:
            raise ValueError(
                f"velocity: max |u| = {speed:.4g} must be < velocity_limit={self.params.velocity_limit:g} dx/dt"
            )
        u_eq = u - 0.5 * self._total_force() / rho
        f = equilibrium_deviation(rho, u_eq)
        self.set_population_deviations(f)
        self.time_step = 0

    def set_population_deviations(self, deviations) -> None:
        """Overwrite the state with pre-collision populations f_i - w_i, shape (19, nx, ny, nz)."""
        f = np.asarray(deviations)
        if f.shape != (Q,) + self.shape:
            raise ValueError(f"populations must have shape {(Q,) + self.shape}, got {f.shape}")
        nz = self.shape[2]
        self._storage[..., :nz] = np.moveaxis(f, 0, 2)
        self._storage[..., nz:] = 0
        self._parity = 0
        if self._curved:  # a near link's slot holds f_opp(i) - (1 - 2q) f_i at parity 0 (see ``kernels``)
            g = self._geometry
            near = g.link_near
            line = np.repeat(np.arange(g.link_ptr.size - 1), np.diff(g.link_ptr))[near]
            x, y, z = line // self.shape[1], line % self.shape[1], g.link_z[near]
            i = g.link_q[near]
            self._storage[x, y, self._opp[i], z] = (f[self._opp[i], x, y, z]
                                                    - g.link_b[near] * f[i, x, y, z]).astype(self.dtype)
            self._wall_memory[:] = 0
        if self._solid is not None:
            # solid nodes at rest; the mask indexes (x, y, z), storage is (x, y, q, z)
            view = np.moveaxis(self._storage[..., :nz], 2, 0)
            view[:, self._solid] = 0

    def set_populations(self, populations) -> None:
        """Overwrite the state with absolute pre-collision populations f_i, shape (19, nx, ny, nz)."""
        f = np.asarray(populations, dtype=np.float64)
        self.set_population_deviations(f - WEIGHTS.reshape(Q, 1, 1, 1))

    def population_deviations(self) -> np.ndarray:
        """Pre-collision populations minus weights, f_i - w_i, shape (19, nx, ny, nz), storage dtype.

        Solid nodes read as rest (0)."""
        nx, ny, nz = self.shape
        out = np.empty((Q, nx, ny, nz), dtype=self.dtype)
        kernels.natural_populations(self._storage, self._parity, nz, self._tables(), out)
        if self._solid is not None:
            out[:, self._solid] = 0
        return out

    @property
    def populations(self) -> np.ndarray:
        """Pre-collision populations f_i (absolute, float64), shape (19, nx, ny, nz)."""
        return self.population_deviations().astype(np.float64) + WEIGHTS.reshape(Q, 1, 1, 1)

    # ------------------------------------------------------------------ forcing
    def set_force_density(self, force_density) -> None:
        """Set the per-node body-force density F (3, nx, ny, nz) in rho0 dx/dt^2, or None.

        It acts in addition to ``params.body_force``; the values are copied into the
        solver's own array (see :attr:`force_density`)."""
        if force_density is None:
            self._force_field = None
            return
        arr = np.asarray(force_density)
        if arr.shape != (3,) + self.shape:
            raise ValueError(f"force_density must have shape {(3,) + self.shape}, got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError("force_density must be finite")
        if self._force_field is None:
            self._force_field = np.empty((3,) + self.shape, dtype=self.dtype)
        np.copyto(self._force_field, arr, casting="unsafe")

    def set_body_force(self, body_force) -> None:
        """Replace the uniform body force (3 floats, rho0 dx/dt^2) from the next step on (the kernels read it from
        their constants; no recompilation)."""
        self.params = check_body_force(self.params, body_force)
        self._consts[kernels.K_GX], self._consts[kernels.K_GY], self._consts[kernels.K_GZ] = self.params.body_force

    def _total_force(self) -> np.ndarray:
        """F_total = body_force + field, float64, broadcastable to (3, nx, ny, nz)."""
        g = np.asarray(self.params.body_force, dtype=np.float64).reshape(3, 1, 1, 1)
        if self._force_field is None:
            return g
        return g + self._force_field.astype(np.float64)

    def _force_arguments(self) -> tuple[np.ndarray, bool]:
        """(force field or placeholder, has_field) for the kernels."""
        if self._force_field is None:
            return self._no_field, False
        return self._force_field, True

    def _tables(self) -> tuple:
        """Geometry and constant tables in the order the kernels take them."""
        g = self._geometry
        return (
            g.run_ptr, g.run_lo, g.run_hi, self.params.has_walls, self._wall_corr,
            g.link_ptr, g.link_z, g.link_q,
            self._consts, self._weights, self._cvel, self._cint, self._opp,
            self._link_a, self._link_b, self._link_near, self._wall_memory, self._curved,
        )  # fmt: skip

    # ------------------------------------------------------------------ time stepping
    def step(self, n: int = 1) -> None:
        """Advance n time steps (one compiled call; stream + collide + force + bounce-back)."""
        n = step_count(n)
        if n == 0:
            return
        self._parity = kernels.run_steps(
            self._storage,
            n,
            self._parity,
            self.shape[2],
            *self._force_arguments(),
            *self._tables(),
            self._no_output,
        )
        self.time_step += n

    # ------------------------------------------------------------------ checkpoints
    backend = "numba"

    def state_arrays(self) -> dict:
        """Everything :meth:`load_state_arrays` needs to continue bit-identically (NumPy arrays)."""
        field = np.zeros((3,) + self.shape, self.dtype) if self._force_field is None else self._force_field
        return {"storage": self._storage, "parity": np.array(self._parity),
                "lattice_time_step": np.array(self.time_step), "force_density": field,
                "has_force_density": np.array(self._force_field is not None), "wall_memory": self._wall_memory}

    def load_state_arrays(self, data) -> None:
        self._storage[...] = data["storage"]
        if "wall_memory" in data and data["wall_memory"].shape == self._wall_memory.shape:
            self._wall_memory[...] = data["wall_memory"]
        elif self._curved:
            raise ValueError("the state has no wall memory for this lattice's interpolated walls")
        self._parity = int(data["parity"])
        self.time_step = int(data["lattice_time_step"])
        self.set_force_density(data["force_density"] if bool(data["has_force_density"]) else None)

    # ------------------------------------------------------------------ observables
    def _moments(self) -> tuple[np.ndarray, np.ndarray]:
        """(rho - 1, u) from one compiled pass, storage dtype, solid nodes not yet masked."""
        nx, ny, nz = self.shape
        out = np.empty((4, nx, ny, nz), dtype=self.dtype)
        kernels.moments(self._storage, self._parity, nz, *self._force_arguments(), self._tables(), out)
        return out[0], out[1:]

    def density(self) -> np.ndarray:
        """rho = sum_i f_i (rho0 = 1), shape (nx, ny, nz), float64; solid nodes read 1.

        Computed (compiled) as 1 + sum_i (f_i - w_i) in the storage precision."""
        drho, _ = self._moments()
        rho = 1.0 + drho.astype(np.float64)
        if self._solid is not None:
            rho[self._solid] = 1.0
        return rho

    def velocity(self) -> np.ndarray:
        """u = (sum_i c_i f_i + F/2) / rho in dx/dt, shape (3, nx, ny, nz), float64.

        The half-force term (Guo) uses the current force (body force + field), i.e. the
        force the next step will apply. Computed in the storage precision by one compiled
        pass. Solid nodes read 0."""
        _, u = self._moments()
        u = u.astype(np.float64)
        if self._solid is not None:
            u[:, self._solid] = 0.0
        return u

    def total_mass(self) -> float:
        """Sum of rho over fluid nodes (rho0 dx^3), accumulated in float64."""
        rho = self.density()
        if self._solid is not None:
            return float(rho[~self._solid].sum())
        return float(rho.sum())

    def stability(self) -> StabilityReport:
        """:func:`check_stability` for the current tau and the largest |u| on the lattice."""
        u = self.velocity()
        speed = float(np.sqrt(np.einsum("a...,a...->...", u, u)).max())
        return check_stability(self.relaxation_time, speed, self.params.velocity_limit)

    def __repr__(self) -> str:
        p = self.params
        return (
            f"Lattice(shape={self.shape}, tau={p.relaxation_time:g}, collision={p.collision!r}, "
            f"dtype={p.dtype}, walls={p.has_walls}, solid_nodes="
            f"{0 if self._solid is None else int(self._solid.sum())}, time_step={self.time_step})"
        )
