"""Material law checks (docs/theory.md, "Verification ladder"). References: closed forms; tolerances are round-off
(1e-10) for closed forms and the O(h^2) central-difference error (~1e-7) for finite differences."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from elastocell.body.materials import (
    bulk_modulus,
    first_piola_stress,
    float64,
    law,
    material_tangent,
    shear_modulus,
)
from elastocell.solvers.stiffness_kernel import element_stiffness_matrices

NU = 0.48
E = 1.0
MU, KAPPA = shear_modulus(E, NU), bulk_modulus(E, NU)
RNG = np.random.default_rng(1)
F_RANDOM = np.eye(3) + 0.2 * RNG.standard_normal((3, 3))


@pytest.fixture(autouse=True)
def in_float64():
    """The laws are evaluated here directly, outside elastocell's entry points: in its 64-bit context."""
    with float64():
        yield


def neo_hookean_piola_closed_form(f, mu, kappa):
    """P = mu J^(-2/3) (F - I1/3 F^-T) + kappa (J - 1) J F^-T."""
    j = np.linalg.det(f)
    f_inv_t = np.linalg.inv(f).T
    i1 = np.trace(f.T @ f)
    return mu * j ** (-2 / 3) * (f - i1 / 3 * f_inv_t) + kappa * (j - 1) * j * f_inv_t


def test_neo_hookean_stress_matches_closed_form():
    p = first_piola_stress(law("neo-hookean"), jnp.asarray(F_RANDOM), jnp.array([MU, KAPPA]))
    np.testing.assert_allclose(np.asarray(p), neo_hookean_piola_closed_form(F_RANDOM, MU, KAPPA), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("name,params", [("neo-hookean", [MU, KAPPA]), ("mooney-rivlin", [0.25 * MU, 0.75 * MU, KAPPA])])
def test_stress_matches_finite_difference(name, params):
    material, params = law(name), jnp.array(params)
    p = np.asarray(first_piola_stress(material, jnp.asarray(F_RANDOM), params))
    h = 1e-6
    fd = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            dp, dm = F_RANDOM.copy(), F_RANDOM.copy()
            dp[i, j] += h
            dm[i, j] -= h
            fd[i, j] = (float(material(jnp.asarray(dp), params)) - float(material(jnp.asarray(dm), params))) / (2 * h)
    np.testing.assert_allclose(p, fd, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("name,params", [("neo-hookean", [MU, KAPPA]), ("mooney-rivlin", [0.25 * MU, 0.75 * MU, KAPPA])])
@pytest.mark.slow
def test_batched_tangent_equals_pointwise_hessian(name, params):
    """material_tangent over a batch (points last, per-point parameters) = jax.hessian of W at each point, to
    round-off (1e-12 relative)."""
    material = law(name)
    rng = np.random.default_rng(7)
    f = np.eye(3)[:, :, None, None] + 0.2 * rng.standard_normal((3, 3, 5, 4))
    scale = rng.uniform(1, 10, 5)  # a different modulus per element, broadcast over its 4 points
    batch_params = np.array(params)[:, None, None] * scale[None, :, None]
    tangent = np.asarray(material_tangent(material, jnp.asarray(f), jnp.asarray(batch_params)))
    hessian = jax.hessian(lambda ff, p: material(ff, p))
    for e in range(5):
        for q in range(4):
            point = np.asarray(hessian(jnp.asarray(f[:, :, e, q]), jnp.asarray(batch_params[:, e, 0])))
            np.testing.assert_allclose(tangent[..., e, q], point, rtol=1e-12, atol=1e-12 * np.abs(point).max())


def test_element_stiffness_kernel_equals_einsum():
    """The compiled contraction K_e[3a+i, 3b+k] = sum_q G_aj C_ijkl G_bl equals numpy's einsum, to round-off, for
    both element orders (10 nodes and 4 points, 4 nodes and 1 point). The tangent is read-only, as a cell passes
    it (one compiled signature)."""
    rng = np.random.default_rng(8)
    for nodes, points in ((10, 4), (4, 1)):
        tangents = rng.standard_normal((3, 3, 3, 3, 6, points))
        tangents.setflags(write=False)
        gradients = rng.standard_normal((nodes, 3, 6, points))
        expected = np.einsum("ajeq,ijkleq,bleq->eaibk", gradients, tangents, gradients).reshape(6, 3 * nodes, 3 * nodes)
        np.testing.assert_allclose(element_stiffness_matrices(tangents, gradients), expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name,params", [("neo-hookean", [MU, KAPPA]), ("mooney-rivlin", [0.25 * MU, 0.75 * MU, KAPPA])])
def test_linearised_moduli_equal_E_and_nu(name, params):
    """Small-strain tangent C = d2W/dF2 at F = I is isotropic with Lame mu and lambda of (E, nu)."""
    material, params = law(name), jnp.array(params)
    tangent = np.asarray(jax.hessian(lambda f: material(f, params))(jnp.eye(3)))
    mu_lin = tangent[0, 1, 0, 1] / 2 + tangent[0, 1, 1, 0] / 2
    lam = tangent[0, 0, 1, 1]
    youngs = mu_lin * (3 * lam + 2 * mu_lin) / (lam + mu_lin)
    poisson = lam / (2 * (lam + mu_lin))
    assert youngs == pytest.approx(E, rel=1e-10)
    assert poisson == pytest.approx(NU, rel=1e-10)


@pytest.mark.parametrize("name,params", [("neo-hookean", [MU, KAPPA]), ("mooney-rivlin", [0.25 * MU, 0.75 * MU, KAPPA])])
def test_simple_shear_cauchy_stress(name, params):
    """Isochoric simple shear F = I + g e1 (x) e2: sigma_xy = (mu1 + mu2) g exactly for both laws."""
    material, params = law(name), jnp.array(params)
    for g in (0.1, 0.5, 1.0):
        f = np.eye(3)
        f[0, 1] = g
        p = np.asarray(first_piola_stress(material, jnp.asarray(f), params))
        sigma = p @ f.T / np.linalg.det(f)
        assert sigma[0, 1] == pytest.approx(MU * g, rel=1e-10)


def test_uniaxial_incompressible_limit_stress():
    """Isochoric uniaxial stretch F = diag(s, s^-1/2, s^-1/2), neo-Hookean: sigma_xx - sigma_yy = mu (s^2 - 1/s)."""
    material = law("neo-hookean")
    for s in (0.6, 1.3, 2.0):
        f = np.diag([s, s**-0.5, s**-0.5])
        p = np.asarray(first_piola_stress(material, jnp.asarray(f), jnp.array([MU, KAPPA])))
        sigma = p @ f.T
        assert sigma[0, 0] - sigma[1, 1] == pytest.approx(MU * (s**2 - 1 / s), rel=1e-10)


def test_zero_energy_and_stress_under_rotation():
    q, _ = np.linalg.qr(RNG.standard_normal((3, 3)))
    q *= np.sign(np.linalg.det(q))
    for name, params in (("neo-hookean", [MU, KAPPA]), ("mooney-rivlin", [0.25 * MU, 0.75 * MU, KAPPA])):
        material = law(name)
        assert abs(float(material(jnp.asarray(q), jnp.array(params)))) < 1e-13
        assert np.abs(np.asarray(first_piola_stress(material, jnp.asarray(q), jnp.array(params)))).max() < 1e-12
