"""State shared by the coupled systems of every backend: the markers (one per mesh node), the failure of a
coupled run (:class:`FlowError`) and the message that names its likely cause.
"""

from __future__ import annotations

# =========================================================================== shear flow
import numpy as np


# =========================================================================== coupled stepping
class FlowError(RuntimeError):
    """A coupled run stopped: unstable or unphysical state; the message names the cause and the parameter
    to change."""


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


def marker_radius(radius: float, hydrodynamic_radius_correction: float = 0.0) -> float:
    """Radius (dx) of the sphere the markers of a cell of radius ``radius`` (dx) are placed on: ``radius -
    hydrodynamic_radius_correction``. An immersed boundary's kernel spreads its force over about a kernel
    half-width, so the body the fluid sees is larger than the marker surface (docs/theory.md, "Flow
    accuracy"); placing the markers that much further in gives a body of hydrodynamic radius ``radius``.
    The elastic body keeps its modulus; its size is the marker radius."""
    radius = float(radius)
    correction = float(hydrodynamic_radius_correction)
    if not (np.isfinite(correction) and 0.0 <= correction < 0.5 * radius):
        raise ValueError(f"the hydrodynamic radius correction must be in [0, R/2) = [0, {0.5 * radius:g}) dx, "
                         f"got {correction}")
    return radius - correction


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
