"""Strain-energy functions W(F, params) per reference volume (compressible, decoupled).

``C = F^T F``, ``J = det F``, ``I1 = tr C``, ``I2 = ((tr C)^2 - tr C^2)/2``.

- neo-Hookean: ``W = mu/2 (J^(-2/3) I1 - 3) + kappa/2 (J - 1)^2``
- Mooney-Rivlin: ``W = mu1/2 (J^(-2/3) I1 - 3) + mu2/2 (J^(-4/3) I2 - 3) + kappa/2 (J - 1)^2``

with shear modulus ``mu = E/(2(1+nu))`` (``mu = mu1 + mu2``) and bulk modulus ``kappa = E/(3(1-2nu))``.
Each law is one function of the deformation gradient; stresses and stiffness follow by automatic
differentiation (JAX, float64). A new law is one new function plus its entry in ``LAWS``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402


def shear_modulus(youngs_modulus, poisson_ratio):
    """mu = E / (2 (1 + nu))."""
    return youngs_modulus / (2 * (1 + poisson_ratio))


def bulk_modulus(youngs_modulus, poisson_ratio):
    """kappa = E / (3 (1 - 2 nu))."""
    return youngs_modulus / (3 * (1 - 2 * poisson_ratio))


def determinant(matrix):
    """det of 3x3 matrices (last two axes) by the cofactor expansion: exact to round-off and, unlike
    ``jnp.linalg.det`` (an LU factorisation), cheap to differentiate twice."""
    m = matrix
    return (m[..., 0, 0] * (m[..., 1, 1] * m[..., 2, 2] - m[..., 1, 2] * m[..., 2, 1])
            - m[..., 0, 1] * (m[..., 1, 0] * m[..., 2, 2] - m[..., 1, 2] * m[..., 2, 0])
            + m[..., 0, 2] * (m[..., 1, 0] * m[..., 2, 1] - m[..., 1, 1] * m[..., 2, 0]))


def _invariants(deformation_gradient):
    right_cauchy_green = jnp.swapaxes(deformation_gradient, -1, -2) @ deformation_gradient
    volume_ratio = determinant(deformation_gradient)
    first = jnp.trace(right_cauchy_green, axis1=-2, axis2=-1)
    second = 0.5 * (first**2 - jnp.sum(right_cauchy_green * right_cauchy_green, axis=(-2, -1)))
    return volume_ratio, first, second


def neo_hookean(deformation_gradient, shear, bulk):
    """W = mu/2 (J^(-2/3) I1 - 3) + kappa/2 (J - 1)^2 (per reference volume, units of E)."""
    volume_ratio, first, _ = _invariants(deformation_gradient)
    return 0.5 * shear * (volume_ratio ** (-2.0 / 3.0) * first - 3.0) + 0.5 * bulk * (volume_ratio - 1.0) ** 2


def mooney_rivlin(deformation_gradient, shear_1, shear_2, bulk):
    """W = mu1/2 (J^(-2/3) I1 - 3) + mu2/2 (J^(-4/3) I2 - 3) + kappa/2 (J - 1)^2."""
    volume_ratio, first, second = _invariants(deformation_gradient)
    return (
        0.5 * shear_1 * (volume_ratio ** (-2.0 / 3.0) * first - 3.0)
        + 0.5 * shear_2 * (volume_ratio ** (-4.0 / 3.0) * second - 3.0)
        + 0.5 * bulk * (volume_ratio - 1.0) ** 2
    )


@dataclass(frozen=True)
class Law:
    """A strain-energy law and how its parameters follow from (E, nu)."""

    name: str
    energy: Callable
    parameters: Callable  # (E array, nu, options) -> (n, n_params) array

    def __call__(self, deformation_gradient, params):
        """W(F) with ``params`` the last axis of parameters (broadcast against F's leading axes)."""
        return self.energy(deformation_gradient, *[params[..., k] for k in range(params.shape[-1])])


def _neo_hookean_parameters(youngs_modulus, poisson_ratio, options):
    return np.column_stack([shear_modulus(youngs_modulus, poisson_ratio), bulk_modulus(youngs_modulus, poisson_ratio)])


def _mooney_rivlin_parameters(youngs_modulus, poisson_ratio, options):
    fraction = options.get("mooney_rivlin_mu1_fraction", 0.25)
    mu = shear_modulus(youngs_modulus, poisson_ratio)
    return np.column_stack([fraction * mu, (1 - fraction) * mu, bulk_modulus(youngs_modulus, poisson_ratio)])


LAWS = {
    "neo-hookean": Law("neo-hookean", neo_hookean, _neo_hookean_parameters),
    "mooney-rivlin": Law("mooney-rivlin", mooney_rivlin, _mooney_rivlin_parameters),
}


def law(name: str) -> Law:
    try:
        return LAWS[name]
    except KeyError:
        raise ValueError(f"material: must be one of {', '.join(LAWS)}, got {name!r}") from None


def first_piola_stress(material: Law, deformation_gradient, params):
    """P = dW/dF (units of E)."""
    return jax.grad(lambda f: material(f, params))(deformation_gradient)
