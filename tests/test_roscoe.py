"""Roscoe's steady state of a Kelvin-Voigt sphere in shear (elastocell.scenarios.roscoe) against its known limits:
Carlson's elliptic integral for the ellipsoid integrals, the small-deformation theory (D -> 5/4 Ca, theta -> 45
deg, omega -> 1/2) at every viscosity ratio, the exact kinematics of viscosity ratio 1, and the rigid limit
(Taylor's high-viscosity drop, D -> 5/(4 lambda), aligned with the flow, rotating at half the shear rate)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import elliprd

from elastocell.scenarios.roscoe import ellipsoid_integrals, roscoe_steady_state

AXES = np.array([[1.0, 1.0, 1.0], [1.5, 0.8, 1 / 1.2], [3.0, 0.5, 1 / 1.5], [4.0, 0.25, 1.0]])


def test_ellipsoid_integrals_match_carlson_and_the_identities():
    """I_i = 2 pi a1 a2 a3 (2/3) R_D(a_j^2, a_k^2, a_i^2) (Carlson); I_1 + I_2 + I_3 = 4 pi and
    3 I_11 + I_12 + I_13 = 4 pi / a1^2 (Mura, section 11). Measured: relative error 4e-15 for I_i
    and the identities with 96 nodes, up to the axis ratio 16 of the last row."""
    got = ellipsoid_integrals(AXES, [[1, 0, 0], [0, 1, 0], [0, 0, 1], [2, 0, 0], [1, 1, 0], [1, 0, 1]])
    a1, a2, a3 = AXES.T
    volume = 2 * np.pi * a1 * a2 * a3 * 2 / 3
    carlson = np.stack([volume * elliprd(a2**2, a3**2, a1**2), volume * elliprd(a1**2, a3**2, a2**2),
                        volume * elliprd(a1**2, a2**2, a3**2)], axis=-1)
    np.testing.assert_allclose(got[:, :3], carlson, rtol=1e-12)
    np.testing.assert_allclose(got[:, :3].sum(axis=1), 4 * np.pi, rtol=1e-12)
    np.testing.assert_allclose(3 * got[:, 3] + got[:, 4] + got[:, 5], 4 * np.pi / a1**2, rtol=1e-12)
    np.testing.assert_allclose(got[0, 3:], 4 * np.pi / 5, rtol=1e-12)  # sphere: I_ij = 4 pi / (5 a^2)


@pytest.mark.parametrize("ratio", [0.0, 1.0, 5.0])
def test_small_ca_is_the_small_deformation_theory_at_every_viscosity_ratio(ratio):
    """Ca -> 0: D/Ca -> 5/4 (Taylor; Goddard & Miller; the interior viscosity does not enter at first order),
    cos 2 theta -> (3/2 + lambda) Ca, omega -> 1/2. The corrections are O(Ca^2) relative: measured at
    Ca = 1e-3, |D/Ca - 5/4| = 1.1e-6, 3.6e-6, 2.6e-5 at lambda = 0, 1, 5; |cos 2 theta / Ca - (3/2 + lambda)|
    <= 2.0e-4 and |omega - 1/2| <= 6.6e-6 (lambda = 5)."""
    ca = 1e-3
    state = roscoe_steady_state(ca, ratio)
    assert state.residual < 1e-10
    assert abs(state.taylor_deformation / ca - 1.25) < 1e-4
    assert abs(np.cos(2 * np.radians(state.inclination_deg)) / ca - (1.5 + ratio)) < 1e-3
    assert abs(state.tank_treading_frequency - 0.5) < 2e-5
    assert state.semi_axes[0] > state.semi_axes[2] > state.semi_axes[1]


def test_viscosity_ratio_one_tank_treads_with_the_far_field_shear_and_spin():
    """lambda = 1: the interior is the outer fluid plus a diagonal eigenstress, so the interior shear and spin are
    the far field's: omega = a1 a2/(a1^2 + a2^2) and cos 2 theta = (a1^2 - a2^2)/(a1^2 + a2^2) exactly (to the
    solver's tolerance; measured 6e-13 up to Ca = 0.6). D falls below 5/4 Ca as Ca grows and the vorticity axis
    stays between the in-plane axes (elastocell's 3D D is the in-plane one)."""
    ca = np.array([0.05, 0.1, 0.2, 0.3, 0.6])
    state = roscoe_steady_state(ca, 1.0)
    a1, a2, a3 = np.moveaxis(state.semi_axes, -1, 0)
    np.testing.assert_allclose(state.tank_treading_frequency, a1 * a2 / (a1**2 + a2**2), atol=1e-10)
    np.testing.assert_allclose(np.cos(2 * np.radians(state.inclination_deg)), (a1**2 - a2**2) / (a1**2 + a2**2),
                               atol=1e-10)
    np.testing.assert_allclose(a1 * a2 * a3, 1.0, rtol=1e-12)
    assert np.all(np.diff(state.taylor_deformation / ca) < 0) and np.all(state.taylor_deformation < 1.25 * ca)
    assert np.all(np.diff(state.inclination_deg) < 0) and np.all(np.diff(state.tank_treading_frequency) < 0)
    np.testing.assert_allclose(state.taylor_deformation_3d, state.taylor_deformation, rtol=1e-12)


def test_rigid_limit_is_taylors_high_viscosity_drop():
    """lambda -> infinity at fixed Ca: the tank treading is too costly, the viscous stress dominates the elastic
    one (lambda Ca >> 1) and the particle behaves as Taylor's (1934) very viscous drop: D -> 5/(4 lambda),
    aligned with the flow (theta -> 0), rotating almost rigidly at half the shear rate (Jeffery's sphere).
    Measured at lambda = 1e4: lambda D / (5/4) - 1 = 1.0e-4, theta = 0.029, 0.0096, 0.0029 deg at Ca = 0.1,
    0.3, 1, omega - 1/2 = -1.25e-4; at lambda = 100 and Ca = 0.3, lambda D / (5/4) - 1 = 0.9 %."""
    ca = np.array([0.1, 0.3, 1.0])
    state = roscoe_steady_state(ca, 1e4)
    np.testing.assert_allclose(state.taylor_deformation * 1e4 / 1.25, 1.0, rtol=1e-3)
    assert np.all(state.inclination_deg < 0.05) and np.all(state.inclination_deg > 0)
    np.testing.assert_allclose(state.tank_treading_frequency, 0.5, atol=3e-4)
    moderate = roscoe_steady_state(0.3, [1.0, 3.0, 10.0, 100.0])  # D and theta fall with lambda
    assert np.all(np.diff(moderate.taylor_deformation) < 0) and np.all(np.diff(moderate.inclination_deg) < 0)


def test_impossible_inputs_are_refused():
    with pytest.raises(ValueError, match="capillary_number"):
        roscoe_steady_state(0.0)
    with pytest.raises(ValueError, match="viscosity_ratio"):
        roscoe_steady_state(0.1, -1.0)
