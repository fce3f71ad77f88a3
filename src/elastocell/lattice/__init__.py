"""D3Q19 lattice Boltzmann fluid engine (lattice units: dx = dt = 1, rho0 = 1, c_s^2 = 1/3).

Quick start::

    from elastocell.lattice import Lattice, LatticeParams
    params = LatticeParams(shape=(4, 32, 4), relaxation_time=0.8, wall_velocity=(-0.01, 0.01))
    fluid = Lattice(params)
    fluid.step(2000)
    u = fluid.velocity()          # (3, nx, ny, nz), dx/dt

Collision: TRT (magic Lambda = 3/16 by default) or BGK; Guo forcing with a uniform
body force and/or a per-node force density field; periodic boundaries, half-way
bounce-back on a solid mask and on moving plane walls at y = -1/2, ny - 1/2.
Kernels: one fused, compiled (Numba, parallel) step with in-place AA streaming.
Medium: Newtonian (one tau), or a shear-thinning power law whose tau each node takes from its own strain rate
inside the collision (``LatticeParams(..., rheology=PowerLaw(n, K))``, :mod:`elastocell.lattice.rheology`).
"""

from elastocell.lattice.params import (
    DEFAULT_MAGIC,
    LatticeParams,
    relaxation_time_from_viscosity,
    viscosity_from_relaxation_time,
)
from elastocell.lattice.rheology import PowerLaw
from elastocell.lattice.solver import Lattice, equilibrium_deviation
from elastocell.lattice.stability import (
    DEFAULT_VELOCITY_LIMIT,
    SOUND_SPEED,
    StabilityReport,
    check_stability,
    mach_number,
)
from elastocell.lattice.stencil import OPPOSITE, SOUND_SPEED_SQUARED, VELOCITIES, WEIGHTS, Q

__all__ = [
    "DEFAULT_MAGIC",
    "DEFAULT_VELOCITY_LIMIT",
    "OPPOSITE",
    "Q",
    "SOUND_SPEED",
    "SOUND_SPEED_SQUARED",
    "VELOCITIES",
    "WEIGHTS",
    "Lattice",
    "LatticeParams",
    "PowerLaw",
    "StabilityReport",
    "check_stability",
    "equilibrium_deviation",
    "mach_number",
    "relaxation_time_from_viscosity",
    "viscosity_from_relaxation_time",
]
