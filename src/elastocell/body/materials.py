"""Strain-energy functions W(F, params) per reference volume (compressible, decoupled).

``C = F^T F``, ``J = det F``, ``I1 = tr C``, ``I2 = ((tr C)^2 - tr C^2)/2``.

- neo-Hookean: ``W = mu/2 (J^(-2/3) I1 - 3) + kappa/2 (J - 1)^2``
- Mooney-Rivlin: ``W = mu1/2 (J^(-2/3) I1 - 3) + mu2/2 (J^(-4/3) I2 - 3) + kappa/2 (J - 1)^2``

with shear modulus ``mu = E/(2(1+nu))`` (``mu = mu1 + mu2``) and bulk modulus ``kappa = E/(3(1-2nu))``.
Each law is one function of the deformation gradient; stresses and stiffness follow by automatic
differentiation (JAX, float64). A new law is one new function plus its entry in ``LAWS``
(:func:`register_law`); it then runs in every scenario, compression and flow alike.

The flow's fast CPU path (:mod:`elastocell.coupling.elastic_forces`, Numba) has the first Piola stress of one
family written out by hand, the decoupled Mooney-Rivlin family
``W = mu1/2 (J^(-2/3) I1 - 3) + mu2/2 (J^(-4/3) I2 - 3) + kappa/2 (J - 1)^2``. A law of that family says so in
its entry (``Law.compiled_parameters``: its parameters as (mu1, mu2, kappa)); the tests hold every such law's
compiled forces to its JAX gradient. A flow with any other law runs on the JAX backend
(:mod:`elastocell.coupling.immersed_jax`), whose forces are the autodiff of the law itself.

Layout: a deformation gradient is an array ``F[i, j, *batch]``, the matrix in the first two axes and the
quadrature points after them (one point: shape (3, 3)). Every elementary operation of a law then runs over a
contiguous run of points, which XLA vectorises: the material tangent of the reference cell's default mesh
(11,988 points) took 12.8 ms this way against 28-39 ms with the points first (``F[*batch, i, j]``), the same
numbers to 4e-16.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from elastocell.parameters import cell as parameters_cell
from elastocell.parameters.units import ParameterError


def float64():
    """A context in which JAX computes in 64 bit, thread-local: elastocell's energies, forces and tangents are
    float64 while the process-wide ``jax_enable_x64`` stays as the user set it (importing elastocell changes
    no JAX setting)."""
    if hasattr(jax, "enable_x64"):
        return jax.enable_x64(True)
    from jax.experimental import enable_x64  # JAX < 0.5 has the context only here

    return enable_x64(True)


def computes_in_float64(target):
    """Run a function, or ``__init__`` and every public method and property of a class (inherited ones
    included), inside :func:`float64`: arrays the object makes and every computation it runs are 64 bit
    wherever it is used."""
    if not isinstance(target, type):
        @functools.wraps(target)
        def wrapped(*args, **kwargs):
            with float64():
                return target(*args, **kwargs)

        return wrapped
    inherited = {}
    for base in reversed(target.__mro__[:-1]):  # the class's own and inherited methods, not object's
        inherited.update(vars(base))
    for name, value in inherited.items():
        if name.startswith("_") and name != "__init__":
            continue
        if isinstance(value, property):
            setattr(target, name, property(*(computes_in_float64(f) if f else None
                                             for f in (value.fget, value.fset, value.fdel)), value.__doc__))
        elif callable(value) and not isinstance(value, (staticmethod, classmethod, type)):
            setattr(target, name, computes_in_float64(value))
    return target


def shear_modulus(youngs_modulus, poisson_ratio):
    """mu = E / (2 (1 + nu))."""
    return youngs_modulus / (2 * (1 + poisson_ratio))


def bulk_modulus(youngs_modulus, poisson_ratio):
    """kappa = E / (3 (1 - 2 nu))."""
    return youngs_modulus / (3 * (1 - 2 * poisson_ratio))


def determinant(matrix):
    """det of 3x3 matrices stored in the first two axes, ``matrix[i, j, *batch]``, by the cofactor expansion:
    exact to round-off and, unlike ``jnp.linalg.det`` (an LU factorisation), cheap to differentiate twice."""
    m = matrix
    return (m[0, 0] * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1])
            - m[0, 1] * (m[1, 0] * m[2, 2] - m[1, 2] * m[2, 0])
            + m[0, 2] * (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]))


def invariants(deformation_gradient):
    """(J, I1, I2) of ``F[i, j, *batch]``: J = det F, I1 = tr C, I2 = ((tr C)^2 - tr C^2)/2 with C = F^T F."""
    right_cauchy_green = jnp.einsum("ki...,kj...->ij...", deformation_gradient, deformation_gradient)
    volume_ratio = determinant(deformation_gradient)
    first = jnp.sum(deformation_gradient * deformation_gradient, axis=(0, 1))
    second = 0.5 * (first**2 - jnp.sum(right_cauchy_green * right_cauchy_green, axis=(0, 1)))
    return volume_ratio, first, second


def neo_hookean(deformation_gradient, shear, bulk):
    """W = mu/2 (J^(-2/3) I1 - 3) + kappa/2 (J - 1)^2 (per reference volume, units of E)."""
    volume_ratio, first, _ = invariants(deformation_gradient)
    return 0.5 * shear * (volume_ratio ** (-2.0 / 3.0) * first - 3.0) + 0.5 * bulk * (volume_ratio - 1.0) ** 2


def mooney_rivlin(deformation_gradient, shear_1, shear_2, bulk):
    """W = mu1/2 (J^(-2/3) I1 - 3) + mu2/2 (J^(-4/3) I2 - 3) + kappa/2 (J - 1)^2."""
    volume_ratio, first, second = invariants(deformation_gradient)
    return (
        0.5 * shear_1 * (volume_ratio ** (-2.0 / 3.0) * first - 3.0)
        + 0.5 * shear_2 * (volume_ratio ** (-4.0 / 3.0) * second - 3.0)
        + 0.5 * bulk * (volume_ratio - 1.0) ** 2
    )


@dataclass(frozen=True)
class Law:
    """A strain-energy law and how its parameters follow from (E, nu).

    energy: ``W(F, *params)`` in JAX for ``F[i, j, *batch]`` (one argument per law parameter).
    parameters: ``(E array (n,), nu, options) -> (n, n_params)`` array, the law's parameters per element
        (options: ``{"mooney_rivlin_mu1_fraction": ...}`` from the cell's material parameters).
    compiled_parameters: for a law of the decoupled Mooney-Rivlin family (module docstring), its parameters
        ``(n, n_params) -> (n, 3)`` as (mu1, mu2, kappa): the flow then computes its forces with the compiled
        kernel of :mod:`elastocell.coupling.elastic_forces`. None: no compiled kernel; the flow runs on the JAX
        backend.
    """

    name: str
    energy: Callable
    parameters: Callable  # (E array, nu, options) -> (n, n_params) array
    compiled_parameters: Callable | None = None  # (n, n_params) -> (n, 3) (mu1, mu2, kappa), or None

    def __call__(self, deformation_gradient, params):
        """W(F) for ``F[i, j, *batch]``, with the law's parameters along the first axis of ``params``
        (``params[k, *batch]``, broadcast against the batch)."""
        return self.energy(deformation_gradient, *[params[k] for k in range(params.shape[0])])

    @property
    def has_compiled_kernel(self) -> bool:
        """Whether the flow's compiled (Numba) force kernel computes this law."""
        return self.compiled_parameters is not None


def _neo_hookean_parameters(youngs_modulus, poisson_ratio, options):
    return np.column_stack([shear_modulus(youngs_modulus, poisson_ratio), bulk_modulus(youngs_modulus, poisson_ratio)])


def _neo_hookean_as_mooney_rivlin(params):
    """(mu, kappa) -> (mu1, mu2, kappa) = (mu, 0, kappa)."""
    return np.column_stack([params[:, 0], np.zeros(len(params)), params[:, 1]])


def _mooney_rivlin_parameters(youngs_modulus, poisson_ratio, options):
    fraction = options.get("mooney_rivlin_mu1_fraction", 0.25)
    mu = shear_modulus(youngs_modulus, poisson_ratio)
    return np.column_stack([fraction * mu, (1 - fraction) * mu, bulk_modulus(youngs_modulus, poisson_ratio)])


def _mooney_rivlin_as_mooney_rivlin(params):
    """(mu1, mu2, kappa) as they are."""
    return params[:, :3]


LAWS: dict[str, Law] = parameters_cell.LAWS
"""The strain-energy laws by name (a cell's ``material.law``); add one with :func:`register_law`. The dict is
:data:`elastocell.parameters.cell.LAWS`, where the cell's parameters check the name."""


def register_law(name: str, energy: Callable, parameters: Callable, compiled_parameters: Callable | None = None,
                 replace: bool = False) -> Law:
    """Add a law to :data:`LAWS` (arguments as :class:`Law`) and return it; a cell with ``material.law = name``
    then uses it in compression and in flow. A name already registered is refused unless ``replace``.

    Example (a Yeoh law, shear modulus mu = 2 c1 at small strain)::

        def yeoh(F, c1, c2, kappa):
            J, I1, _ = invariants(F)
            s = J ** (-2 / 3) * I1 - 3
            return c1 * s + c2 * s**2 + 0.5 * kappa * (J - 1) ** 2

        register_law("yeoh", yeoh, lambda E, nu, options: np.column_stack(
            [shear_modulus(E, nu) / 2, shear_modulus(E, nu) / 20, bulk_modulus(E, nu)]))
    """
    if not isinstance(name, str) or not name:
        raise ParameterError("material", f"a law's name must be a non-empty string, got {name!r}")
    if name in LAWS and not replace:
        raise ParameterError("material", f"a law named {name!r} is already registered (replace=True to replace it)")
    entry = Law(name, energy, parameters, compiled_parameters)
    LAWS[name] = entry
    return entry


register_law("neo-hookean", neo_hookean, _neo_hookean_parameters, _neo_hookean_as_mooney_rivlin)
register_law("mooney-rivlin", mooney_rivlin, _mooney_rivlin_parameters, _mooney_rivlin_as_mooney_rivlin)


def law(name: str) -> Law:
    try:
        return LAWS[name]
    except KeyError:
        raise ParameterError("material", f"must be one of {', '.join(LAWS)} (or a law added with "
                             f"elastocell.body.materials.register_law), got {name!r}") from None


@computes_in_float64
def first_piola_stress(material: Law, deformation_gradient, params):
    """P = dW/dF (units of E) at one point: F of shape (3, 3), params of shape (n_params,)."""
    return jax.grad(lambda f: material(f, params))(deformation_gradient)


@computes_in_float64
def material_tangent(material: Law, deformation_gradient, params):
    """A = d^2 W / dF dF, ``A[i, j, k, l, *batch]`` (units of E), for ``F[i, j, *batch]``: the forward
    derivatives of the first Piola stress along the nine unit directions. The points are independent, so the
    gradient of the summed energy is each point's P and one pass over all points gives each column."""
    stress = jax.grad(lambda f: jnp.sum(material(f, params)))
    batch = deformation_gradient.shape[2:]
    directions = jnp.eye(9).reshape((9, 3, 3) + (1,) * len(batch))
    columns = jax.vmap(
        lambda direction: jax.jvp(stress, (deformation_gradient,),
                                  (jnp.broadcast_to(direction, deformation_gradient.shape),))[1]
    )(directions)  # [(k l), i, j, *batch]
    return jnp.moveaxis(columns.reshape((3, 3, 3, 3) + batch), (0, 1), (2, 3))
