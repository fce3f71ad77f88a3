"""Stability and accuracy limits of the lattice Boltzmann scheme (lattice units)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from elastocell.lattice.stencil import SOUND_SPEED_SQUARED

SOUND_SPEED = math.sqrt(SOUND_SPEED_SQUARED)
"""c_s = 1/sqrt(3) lattice units (dx/dt)."""

DEFAULT_VELOCITY_LIMIT = 0.05
"""Default guard on the largest lattice velocity |u| (dx/dt), i.e. Mach number ~0.087.

The lattice Boltzmann equilibrium is a second-order expansion in Ma = |u|/c_s; the
compressibility error grows like Ma^2, so |u| < 0.05 keeps it below ~1 %."""


@dataclass(frozen=True)
class StabilityReport:
    """Result of :func:`check_stability`.

    Attributes
    ----------
    relaxation_time : float
        tau (time steps).
    max_velocity : float
        Largest lattice speed |u| (dx/dt).
    mach_number : float
        Ma = |u| / c_s (dimensionless).
    velocity_limit : float
        The guard |u| was compared with (dx/dt).
    relaxation_time_ok : bool
        tau > 1/2 (positive viscosity).
    velocity_ok : bool
        |u| < velocity_limit.
    """

    relaxation_time: float
    max_velocity: float
    mach_number: float
    velocity_limit: float
    relaxation_time_ok: bool
    velocity_ok: bool

    @property
    def stable(self) -> bool:
        """True when both the relaxation time and the velocity are inside the limits."""
        return self.relaxation_time_ok and self.velocity_ok

    def __bool__(self) -> bool:
        return self.stable


def mach_number(velocity: float) -> float:
    """Lattice Mach number Ma = |u| / c_s for a lattice speed |u| (dx/dt)."""
    return abs(float(velocity)) / SOUND_SPEED


def check_stability(
    relaxation_time: float,
    max_velocity: float,
    velocity_limit: float = DEFAULT_VELOCITY_LIMIT,
) -> StabilityReport:
    """Say whether (tau, max |u|) lies inside the usual lattice Boltzmann limits.

    Parameters
    ----------
    relaxation_time : float
        tau in time steps; the kinematic viscosity is nu = (tau - 1/2)/3 (dx^2/dt), so
        tau must exceed 1/2.
    max_velocity : float
        Largest expected lattice speed |u| in dx/dt.
    velocity_limit : float
        Guard on |u| (default 0.05 dx/dt, Ma ~ 0.087). Must be in (0, c_s).

    Returns
    -------
    StabilityReport
        Truthy when stable; carries the Mach number.
    """
    if not (0.0 < velocity_limit < SOUND_SPEED):
        raise ValueError(
            f"velocity_limit must be in (0, {SOUND_SPEED:.4f}) lattice units, got {velocity_limit!r}"
        )
    tau = float(relaxation_time)
    speed = abs(float(max_velocity))
    return StabilityReport(
        relaxation_time=tau,
        max_velocity=speed,
        mach_number=mach_number(speed),
        velocity_limit=float(velocity_limit),
        relaxation_time_ok=math.isfinite(tau) and tau > 0.5,
        velocity_ok=math.isfinite(speed) and speed < velocity_limit,
    )
