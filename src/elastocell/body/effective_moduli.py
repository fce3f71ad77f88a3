"""Effective Young's modulus of a composite of isotropic phases with one Poisson ratio: the paper's volume average
and the classical estimates of the theory of composites.

All take the phases' stiffness ratios ``gamma_i = E_i/E_c`` and volume fractions ``phi_i`` (summing to 1) and
return ``E*/E_c``. With a common Poisson ratio nu, bulk and shear moduli are K = E/(3(1 - 2 nu)) and
mu = E/(2(1 + nu)), and E* = 9 K* mu*/(3 K* + mu*).

- Voigt (uniform strain; the paper's volume average): E* = sum phi_i E_i, an upper bound.
- Reuss (uniform stress): 1/E* = sum phi_i/E_i, a lower bound.
- Hashin-Shtrikman bounds (Walpole's form for well-ordered phases): the lower bound takes the softest phase as
  reference and equals the Mori-Tanaka estimate of stiff inclusions in a soft matrix (the nucleus cell); the
  upper bound takes the stiffest.
- Self-consistent (Hill, Budiansky): the reference medium is the composite itself (fixed point).
"""

from __future__ import annotations

import numpy as np

ESTIMATES = ("voigt", "reuss", "hashin_shtrikman_lower", "hashin_shtrikman_upper", "self_consistent")


def _phases(stiffness_ratios, volume_fractions):
    gamma = np.atleast_1d(np.asarray(stiffness_ratios, dtype=float))
    phi = np.atleast_1d(np.asarray(volume_fractions, dtype=float))
    if gamma.shape != phi.shape or np.any(gamma <= 0) or np.any(phi < 0) or not np.isclose(phi.sum(), 1.0):
        raise ValueError("need positive stiffness ratios and non-negative volume fractions summing to 1")
    return gamma, phi


def _bulk_shear(youngs, poisson_ratio):
    return youngs / (3 * (1 - 2 * poisson_ratio)), youngs / (2 * (1 + poisson_ratio))


def _youngs(bulk, shear):
    return 9 * bulk * shear / (3 * bulk + shear)


def _walpole(bulk, shear, phi, bulk_ref, shear_ref):
    """HS-type effective (K, mu) for the reference medium (K_ref, mu_ref)."""
    k = 1.0 / np.sum(phi / (bulk + 4.0 / 3.0 * shear_ref)) - 4.0 / 3.0 * shear_ref
    zeta = shear_ref / 6.0 * (9 * bulk_ref + 8 * shear_ref) / (bulk_ref + 2 * shear_ref)
    m = 1.0 / np.sum(phi / (shear + zeta)) - zeta
    return k, m


def voigt(stiffness_ratios, volume_fractions, poisson_ratio: float = 0.48) -> float:
    gamma, phi = _phases(stiffness_ratios, volume_fractions)
    return float(np.sum(phi * gamma))


def reuss(stiffness_ratios, volume_fractions, poisson_ratio: float = 0.48) -> float:
    gamma, phi = _phases(stiffness_ratios, volume_fractions)
    return float(1.0 / np.sum(phi / gamma))


def hashin_shtrikman_lower(stiffness_ratios, volume_fractions, poisson_ratio: float = 0.48) -> float:
    gamma, phi = _phases(stiffness_ratios, volume_fractions)
    bulk, shear = _bulk_shear(gamma, poisson_ratio)
    return float(_youngs(*_walpole(bulk, shear, phi, bulk.min(), shear.min())))


def hashin_shtrikman_upper(stiffness_ratios, volume_fractions, poisson_ratio: float = 0.48) -> float:
    gamma, phi = _phases(stiffness_ratios, volume_fractions)
    bulk, shear = _bulk_shear(gamma, poisson_ratio)
    return float(_youngs(*_walpole(bulk, shear, phi, bulk.max(), shear.max())))


def self_consistent(stiffness_ratios, volume_fractions, poisson_ratio: float = 0.48, tolerance: float = 1e-12,
                    iterations: int = 500) -> float:
    """Fixed point of the Walpole map with the composite as its own reference, started from Voigt."""
    gamma, phi = _phases(stiffness_ratios, volume_fractions)
    bulk, shear = _bulk_shear(gamma, poisson_ratio)
    k, m = np.sum(phi * bulk), np.sum(phi * shear)
    for _ in range(iterations):
        k_new, m_new = _walpole(bulk, shear, phi, k, m)
        if abs(k_new - k) <= tolerance * k and abs(m_new - m) <= tolerance * m:
            break
        k, m = 0.5 * (k + k_new), 0.5 * (m + m_new)
    return float(_youngs(k_new, m_new))


def all_estimates(stiffness_ratios, volume_fractions, poisson_ratio: float = 0.48) -> dict[str, float]:
    """{name: E*/E_c} for every estimate of :data:`ESTIMATES`."""
    return {name: globals()[name](stiffness_ratios, volume_fractions, poisson_ratio) for name in ESTIMATES}


def uniform_phases(low: float, high: float, count: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """A continuous gamma ~ U[low, high] as ``count`` equal-volume phases (midpoint rule)."""
    gamma = low + (high - low) * (np.arange(count) + 0.5) / count
    return gamma, np.full(count, 1.0 / count)
