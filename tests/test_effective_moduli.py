"""Composite estimates of the effective Young's modulus against closed forms and their ordering."""

import numpy as np
import pytest

from elastocell.body.effective_moduli import (
    all_estimates,
    hashin_shtrikman_lower,
    reuss,
    self_consistent,
    uniform_phases,
    voigt,
)


def test_volume_average_of_the_paper():
    """Eq. (4) of the paper: gamma 10, lambda 0.5 -> E_eff = 2.125 E_c (exact arithmetic)."""
    assert voigt([1, 10], [1 - 0.125, 0.125]) == pytest.approx(2.125, rel=1e-14)
    assert reuss([1, 10], [0.875, 0.125]) == pytest.approx(1 / (0.875 + 0.0125), rel=1e-14)


def test_one_phase_and_equal_phases_give_that_phase():
    for estimate in all_estimates([3.0, 3.0], [0.4, 0.6]).values():
        assert estimate == pytest.approx(3.0, rel=1e-10)


@pytest.mark.parametrize("gamma,phi", [(2, 0.125), (10, 0.125), (20, 0.343), (5, 0.729)])
def test_bounds_are_ordered(gamma, phi):
    e = all_estimates([1, gamma], [1 - phi, phi])
    assert e["reuss"] <= e["hashin_shtrikman_lower"] <= e["self_consistent"] <= e["hashin_shtrikman_upper"] \
        <= e["voigt"] + 1e-12


def test_hashin_shtrikman_lower_matches_hashins_incompressible_formula():
    """Reference: Hashin-Shtrikman lower bound on the shear modulus of a soft matrix (1) with stiff spheres (2),
    mu* = mu1 + phi2 / (1/(mu2 - mu1) + 6 (K1 + 2 mu1) phi1 / (5 mu1 (3 K1 + 4 mu1))); for nu -> 1/2 the
    composite is incompressible and E* = 3 mu*. Written here in this textbook form, independent of the
    Walpole form in the code; tolerance: the O(1 - 2 nu) compressibility at nu = 0.49999."""
    nu, gamma, phi = 0.49999, 10.0, 0.125
    mu1, mu2 = 1 / (2 * (1 + nu)), gamma / (2 * (1 + nu))
    k1 = 1 / (3 * (1 - 2 * nu))
    mu_star = mu1 + phi / (1 / (mu2 - mu1) + 6 * (k1 + 2 * mu1) * (1 - phi) / (5 * mu1 * (3 * k1 + 4 * mu1)))
    assert hashin_shtrikman_lower([1, gamma], [1 - phi, phi], nu) == pytest.approx(3 * mu_star, rel=1e-4)


def test_self_consistent_dilute_limit_and_random_cell():
    """Dilute limit: every estimate but Voigt/Reuss shares the first-order term in phi (Eshelby): for
    phi = 1e-4 the self-consistent and HS-lower values agree to O(phi^2)."""
    phi = 1e-4
    assert self_consistent([1, 10], [1 - phi, phi]) == pytest.approx(hashin_shtrikman_lower([1, 10], [1 - phi, phi]),
                                                                      abs=1e-7)
    gamma, fractions = uniform_phases(1, 10)
    assert voigt(gamma, fractions) == pytest.approx(5.5, rel=1e-12)
    assert reuss(gamma, fractions) == pytest.approx(9 / np.log(10), rel=1e-5)  # harmonic mean of U[1, 10]
