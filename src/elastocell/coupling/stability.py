"""Limits on a flow's shear rate from the explicit elastic step, the particle Reynolds number and the lattice
speed: the largest eigenvalue of the stiffness-mobility product, the spacing and relaxation-time factors,
and :func:`shear_rate_limits`, shared by every flow scenario.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

# =========================================================================== shear flow
import numpy as np

from elastocell.coupling import ibm

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
    k = cell.reference_stiffness_matrix() * radius
    # fixed start vector and 5 significant digits: the same value on every call, so that the derived lattice
    # parameters (and a run resumed from a checkpoint) are reproducible
    start = np.ones(w.shape[0])
    value = float(eigs(w @ k, k=1, which="LR", return_eigenvectors=False, tol=1e-8, v0=start)[0].real)
    return float(f"{value:.5g}")


def reference_modulus_ratio(cell) -> float:
    """mu_ref / mu_c: gamma_eff for the homogeneous equivalent (Ca with mu_eff), 1 otherwise (Ca with mu_c)."""
    return cell.effective_stiffness_ratio if cell.is_equivalent else 1.0


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
