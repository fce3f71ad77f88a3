"""Validated parameters of a D3Q19 lattice Boltzmann run (lattice units).

Lattice units: grid spacing dx = 1, time step dt = 1, reference density rho0 = 1,
c_s^2 = 1/3. A relaxation time tau (time steps) gives the kinematic viscosity
nu = (tau - 1/2) / 3 (dx^2/dt).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from elastocell.lattice.rheology import PowerLaw
from elastocell.lattice.stability import DEFAULT_VELOCITY_LIMIT, SOUND_SPEED

DEFAULT_MAGIC = 3.0 / 16.0
"""TRT magic parameter Lambda = (tau+ - 1/2)(tau- - 1/2); 3/16 puts half-way bounce-back
walls exactly half-way for Poiseuille flow."""

CollisionName = Literal["trt", "bgk"]


def viscosity_from_relaxation_time(relaxation_time: float) -> float:
    """nu = (tau - 1/2) / 3 in dx^2/dt."""
    return (float(relaxation_time) - 0.5) / 3.0


def relaxation_time_from_viscosity(kinematic_viscosity: float) -> float:
    """tau = 3 nu + 1/2 in time steps."""
    return 3.0 * float(kinematic_viscosity) + 0.5


def _as_wall_vector(value, name: str) -> tuple[float, float, float]:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.array([float(arr), 0.0, 0.0])
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be a finite scalar (x-velocity) or a 3-vector, got {value!r}")
    if arr[1] != 0.0:
        raise ValueError(f"{name} must be tangential to the y-walls (y-component 0), got {tuple(arr)}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


@dataclass(frozen=True, eq=False)
class LatticeParams:
    """Parameters of a D3Q19 lattice Boltzmann fluid in lattice units.

    Give exactly one of ``relaxation_time`` (tau) and ``kinematic_viscosity`` (nu).

    Parameters
    ----------
    shape : (nx, ny, nz)
        Number of lattice nodes along x, y, z (each >= 1; >= 2 along y with walls).
    relaxation_time : float, optional
        tau (time steps), must be > 1/2.
    kinematic_viscosity : float, optional
        nu (dx^2/dt), must be > 0; tau = 3 nu + 1/2.
    collision : {"trt", "bgk"}
        Two-relaxation-time (default) or single-relaxation-time BGK collision.
    magic : float
        TRT magic parameter Lambda (default 3/16), > 0; ignored for BGK.
    dtype : {"float32", "float64"}
        Storage and arithmetic precision (float32 default). Populations are stored as
        deviations f_i - w_i from the rest equilibrium to limit round-off.
    wall_velocity : None or (bottom, top)
        None: periodic along y. Otherwise two plane walls located half-way, at
        y = -1/2 and y = ny - 1/2, with the given velocities (dx/dt); each entry is a
        scalar x-velocity or a tangential 3-vector (y-component 0). Couette: (-U, +U).
    solid : bool array (nx, ny, nz), optional
        Solid nodes; bounce-back on every fluid-solid link (walls at rest).
    wall_fraction : callable, optional
        Where the wall of ``solid`` crosses each fluid-solid link: ``q = wall_fraction(x, c)`` for the fluid
        nodes x (n, 3) and link directions c_i (n, 3) (float64, lattice units), the wall at x + q c_i with
        0 < q <= 1; the links then bounce back linearly interpolated (Bouzidi et al. 2001, see
        :mod:`elastocell.lattice.geometry`), so a curved wall is not a staircase. None (default): the wall lies
        half-way on every link (q = 1/2, plain bounce-back).
    body_force : 3 floats
        Uniform body-force density g (force per volume, rho0 dx/dt^2), added to any
        per-node force density field given later with ``Lattice.set_force_density``.
    velocity_limit : float
        Guard on lattice speeds |u| (dx/dt) accepted for walls and initial fields
        (default 0.05, Mach ~ 0.087); must be in (0, c_s).
    rheology : PowerLaw, optional
        A shear-thinning medium: every node relaxes with the tau+ of its own strain rate
        (:mod:`elastocell.lattice.rheology`); ``relaxation_time`` is then the reference tau (the initial
        state, the stability report). None (default): Newtonian, tau everywhere.
    """

    shape: tuple[int, int, int]
    relaxation_time: float | None = None
    kinematic_viscosity: float | None = None
    collision: CollisionName = "trt"
    magic: float = DEFAULT_MAGIC
    dtype: str = "float32"
    wall_velocity: tuple | None = None
    solid: np.ndarray | None = field(default=None, repr=False)
    body_force: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity_limit: float = DEFAULT_VELOCITY_LIMIT
    rheology: PowerLaw | None = None
    wall_fraction: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        # --- shape
        try:
            ok = len(self.shape) == 3 and all(float(n) == int(n) and int(n) >= 1 for n in self.shape)
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ValueError(f"shape must be three positive integers (nx, ny, nz), got {self.shape!r}")
        shape = tuple(int(n) for n in self.shape)
        set_(self, "shape", shape)
        # --- velocity guard
        limit = float(self.velocity_limit)
        if not (0.0 < limit < SOUND_SPEED):
            raise ValueError(
                f"velocity_limit must be in (0, {SOUND_SPEED:.4f}) lattice units (dx/dt), got {self.velocity_limit!r}"
            )
        set_(self, "velocity_limit", limit)
        # --- relaxation time / viscosity
        if (self.relaxation_time is None) == (self.kinematic_viscosity is None):
            raise ValueError(
                "give exactly one of relaxation_time (tau > 0.5) and kinematic_viscosity (nu > 0)"
            )
        if self.relaxation_time is not None:
            tau = float(self.relaxation_time)
            if not (math.isfinite(tau) and tau > 0.5):
                raise ValueError(
                    f"relaxation_time must be finite and > 0.5 (time steps), got {self.relaxation_time!r}"
                )
        else:
            nu = float(self.kinematic_viscosity)
            if not (math.isfinite(nu) and nu > 0.0):
                raise ValueError(
                    f"kinematic_viscosity must be finite and > 0 (dx^2/dt), got {self.kinematic_viscosity!r}"
                )
            tau = relaxation_time_from_viscosity(nu)
        set_(self, "relaxation_time", tau)
        set_(self, "kinematic_viscosity", viscosity_from_relaxation_time(tau))
        # --- collision model
        if self.collision not in ("trt", "bgk"):
            raise ValueError(f"collision must be 'trt' or 'bgk', got {self.collision!r}")
        magic = float(self.magic)
        if not (math.isfinite(magic) and magic > 0.0):
            raise ValueError(f"magic (TRT Lambda) must be finite and > 0, got {self.magic!r}")
        set_(self, "magic", magic)
        # --- dtype
        try:
            dt = np.dtype(self.dtype)
        except TypeError as exc:
            raise ValueError(f"dtype must be 'float32' or 'float64', got {self.dtype!r}") from exc
        if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
            raise ValueError(f"dtype must be 'float32' or 'float64', got {self.dtype!r}")
        set_(self, "dtype", dt.name)
        # --- walls
        if self.wall_velocity is not None:
            try:
                bottom, top = self.wall_velocity
            except (TypeError, ValueError) as exc:
                raise ValueError(
                    f"wall_velocity must be None or a pair (bottom, top), got {self.wall_velocity!r}"
                ) from exc
            walls = (
                _as_wall_vector(bottom, "wall_velocity[0] (bottom)"),
                _as_wall_vector(top, "wall_velocity[1] (top)"),
            )
            for name, w in zip(("wall_velocity[0] (bottom)", "wall_velocity[1] (top)"), walls, strict=True):
                speed = math.sqrt(sum(c * c for c in w))
                if speed >= limit:
                    raise ValueError(
                        f"{name} speed {speed:.4g} must be < velocity_limit={limit:g} (dx/dt, |u| < limit)"
                    )
            if shape[1] < 2:
                raise ValueError(f"shape[1] (ny) must be >= 2 with walls, got {shape[1]}")
            set_(self, "wall_velocity", walls)
        # --- solid mask
        if self.solid is not None:
            solid = np.asarray(self.solid)
            if solid.shape != shape:
                raise ValueError(f"solid must have shape {shape} (the lattice shape), got {solid.shape}")
            if solid.dtype != np.bool_:
                if not np.all((solid == 0) | (solid == 1)):
                    raise ValueError("solid must be a boolean mask (True = solid node)")
            solid = np.ascontiguousarray(solid, dtype=np.bool_).copy()
            solid.setflags(write=False)
            set_(self, "solid", solid if solid.any() else None)
        if self.wall_fraction is not None and not callable(self.wall_fraction):
            raise ValueError(f"wall_fraction must be None or a function q(x, c), got {self.wall_fraction!r}")
        # --- body force
        g = np.asarray(self.body_force, dtype=np.float64)
        if g.shape != (3,) or not np.all(np.isfinite(g)):
            raise ValueError(f"body_force must be three finite floats (gx, gy, gz), got {self.body_force!r}")
        set_(self, "body_force", tuple(float(c) for c in g))
        # --- medium
        if self.rheology is not None and not isinstance(self.rheology, PowerLaw):
            raise ValueError(f"rheology must be None (Newtonian) or a PowerLaw, got {self.rheology!r}")

    # ------------------------------------------------------------------ derived
    @property
    def relaxation_time_plus(self) -> float:
        """tau+ (symmetric moments; sets the viscosity) = tau."""
        return self.relaxation_time

    @property
    def relaxation_time_minus(self) -> float:
        """tau- (antisymmetric moments) = 1/2 + Lambda/(tau+ - 1/2) for TRT, = tau for BGK."""
        if self.collision == "bgk":
            return self.relaxation_time
        return 0.5 + self.magic / (self.relaxation_time - 0.5)

    @property
    def has_walls(self) -> bool:
        """True when plane walls bound the domain in y."""
        return self.wall_velocity is not None

    @property
    def numpy_dtype(self) -> np.dtype:
        return np.dtype(self.dtype)


def check_body_force(params: LatticeParams, body_force) -> LatticeParams:
    """``params`` with a new uniform body force (3 finite floats, rho0 dx/dt^2): a copy, so that a lattice changing
    its force mid-run leaves any other holder of the same parameters as it was (the solid mask is shared, not
    copied)."""
    g = np.asarray(body_force, dtype=np.float64)
    if g.shape != (3,) or not np.all(np.isfinite(g)):
        raise ValueError(f"body_force must be three finite floats (gx, gy, gz), got {body_force!r}")
    changed = copy.copy(params)
    object.__setattr__(changed, "body_force", tuple(float(c) for c in g))
    return changed
