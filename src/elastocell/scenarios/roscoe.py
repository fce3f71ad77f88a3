"""Roscoe's finite-Ca steady state of a Kelvin-Voigt sphere in simple shear (R. Roscoe, J. Fluid Mech. 28,
273-293, 1967): the reference of the shear targets (validation/shear_targets.py, docs/theory.md "Shear flow").

Problem: a sphere of radius R of an incompressible Kelvin-Voigt solid (neo-Hookean elastic stress ``mu B``, B
the left Cauchy-Green tensor, plus a viscous stress ``2 eta_p E``) in unbounded Stokes simple shear
``u_x = shear_rate * y`` of a fluid of viscosity eta; capillary number ``Ca = eta * shear_rate / mu``, viscosity
ratio ``lambda = eta_p / eta``. Roscoe's steady state is an ellipsoid of semi-axes a1 >= a2 in the shear plane
(a1 inclined by theta from the flow direction towards the gradient) and a3 along the vorticity, fixed in space,
its material tank-treading along the ellipses of the shape, each point advancing its ellipse phase at the
frequency omega (a point of the shear-plane section is (a1 cos phi, a2 sin phi), phi = omega t): the interior
velocity gradient is uniform, in the shape's axes L12 = omega a1/a2, L21 = -omega a2/a1 (omega > 0 for the
rotation the flow imposes), and B = diag(a1^2, a2^2, a3^2)/R^2 is constant (the material moves by
F = diag(a_k/R) Q(t), Q a rotation). The interior stress is uniform, so the exterior problem is that of an
ellipsoidal inclusion with a uniform eigenstress, solved by Eshelby's equivalent inclusion (Jeffery's
ellipsoid in a viscous flow; Roscoe's section 3 does the same with Jeffery's harmonics). With
the eigenrate ``E* = (1 - lambda) E - dev(mu B) / (2 eta)`` of the equivalent inclusion in a fluid of
viscosity eta, the interior strain rate and spin are ``E = E_inf + S : E*``, ``W = W_inf + Pi : E*`` (S the
Eshelby tensor of an incompressible matrix, Pi its rotation tensor), which in the shape's axes read:

* diagonal (the interior strain rate has no diagonal part): ``Ca sin(2 theta)/2 = sum_k S_11kk dev(b)_k / 2``
  and ``-Ca sin(2 theta)/2 = sum_k S_22kk dev(b)_k / 2``, b_k = a_k^2/R^2 (the 33 equation follows);
* shear: ``omega (a1^2 - a2^2)/(2 a1 a2) (1 - 2 S_1212 (1 - lambda)) = cos(2 theta)/2``;
* spin: ``omega (a1^2 + a2^2)/(2 a1 a2) = 1/2 + (I_2 - I_1)/(4 pi) (1 - lambda) omega (a1^2 - a2^2)/(2 a1 a2)``

(frequencies in units of the shear rate, lengths in R, a1 a2 a3 = 1). S and Pi from the ellipsoid integrals
``I_i = 2 pi a1 a2 a3 int_0^inf ds / ((a_i^2 + s) Delta)``, ``I_ij`` with ``(a_i^2+s)(a_j^2+s)``,
``Delta = sqrt((a1^2+s)(a2^2+s)(a3^2+s))`` (Mura, Micromechanics of Defects in Solids, section 11):
``S_1111 = 3 a1^2 I_11/(4 pi)``, ``S_1122 = a2^2 I_12/(4 pi)``, ``S_1212 = (a1^2 + a2^2) I_12/(8 pi)``.

Known limits (tests/test_roscoe.py): Ca -> 0: D = (a1 - a2)/(a1 + a2) -> 5/4 Ca for every lambda (the
linear elastic sphere takes the uniform strain of the uniform interior stress; the interior viscosity does not
enter the diagonal equations), theta -> 45 deg with ``cos 2 theta = (3/2 + lambda) Ca`` at first order, omega
-> 1/2. lambda = 1: the interior is the outer fluid with an eigenstress on the diagonal only, so the shear
and spin are the far field's: ``omega = a1 a2 / (a1^2 + a2^2)``, ``cos 2 theta = (a1^2 - a2^2)/(a1^2 + a2^2)``
exactly. Rigid limit (lambda -> infinity): the spin equation is Jeffery's rotation of a rigid ellipsoid.

elastocell's cell (docs/theory.md): a compressible neo-Hookean solid with ``mu = E / (2 (1 + nu))`` (the same
mu in Ca) and nu = 0.48, filled with the outer fluid (lambda = 1). Its elastic stress under a uniform
deviatoric load is the same as the incompressible solid's at first order in the strain (a uniform deviatoric
stress gives the strain dev(sigma)/(2 mu) whatever nu), so nu enters at second order (a volume change of
order (mu/kappa) times the squared strain; kappa/mu = 24.7 at nu = 0.48). Its Taylor deformation uses the
largest and smallest semi-axes of the inertia-equivalent ellipsoid, which is (a1 - a2)/(a1 + a2) when a2 is
the smallest semi-axis (:attr:`RoscoeState.taylor_deformation_3d` reports the other one); its tank-treading
frequency is the rate of the ellipse phase, Roscoe's omega.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

QUADRATURE_NODES = 96
"""Gauss-Legendre nodes of the ellipsoid integrals (substitution s = (u/(1-u))^2 makes the integrand smooth on
(0, 1)); relative error below 1e-12 against Carlson's R_D for semi-axis ratios up to 4 (tests)."""


def ellipsoid_integrals(semi_axes, powers) -> np.ndarray:
    """``2 pi a1 a2 a3 int_0^inf ds / (prod_k (a_k^2 + s)^p_k Delta(s))`` for every row of ``powers``.

    semi_axes: (..., 3); powers: (m, 3) whole exponents p_k. Returns (..., m). I_1 is powers (1, 0, 0), I_12
    is (1, 1, 0), I_11 is (2, 0, 0)."""
    a2 = np.asarray(semi_axes, dtype=float)[..., None, :] ** 2  # (..., 1, 3)
    u, w = np.polynomial.legendre.leggauss(QUADRATURE_NODES)
    u, w = 0.5 * (u + 1.0), 0.5 * w
    s = (u / (1.0 - u)) ** 2  # (n,)
    ds = 2.0 * u / (1.0 - u) ** 3 * w
    shifted = a2 + s[:, None]  # (..., n, 3)
    delta = np.sqrt(np.prod(shifted, axis=-1))  # (..., n)
    powers = np.asarray(powers, dtype=float)
    terms = np.prod(shifted[..., None, :] ** -powers, axis=-1)  # (..., n, m)
    volume = np.sqrt(np.prod(a2[..., 0, :], axis=-1))[..., None]  # a1 a2 a3
    return 2.0 * np.pi * volume * np.einsum("...nm,...n,n->...m", terms, 1.0 / delta, ds)


CONVERGED = 1e-10
"""Largest |equation| of a solved point; points left above it are returned as nan."""

_POWERS = np.array([[1, 0, 0], [0, 1, 0], [2, 0, 0], [0, 2, 0], [1, 1, 0], [1, 0, 1], [0, 1, 1]])
"""I_1, I_2, I_11, I_22, I_12, I_13, I_23."""


def _residuals(x: np.ndarray, ca: np.ndarray, ratio: np.ndarray) -> np.ndarray:
    """The four steady-state equations (module docstring) at unknowns x = (ln a1, ln a2, theta, omega), (..., 4)."""
    a1, a2 = np.exp(x[..., 0]), np.exp(x[..., 1])
    theta, omega = x[..., 2], x[..., 3]
    a3 = 1.0 / (a1 * a2)
    axes = np.stack([a1, a2, a3], axis=-1)
    i1, i2, i11, i22, i12, i13, i23 = np.moveaxis(ellipsoid_integrals(axes, _POWERS), -1, 0)
    b = axes**2
    dev = b - b.mean(axis=-1, keepdims=True)
    four_pi = 4.0 * np.pi
    s11 = np.stack([3 * a1**2 * i11, a2**2 * i12, a3**2 * i13], axis=-1) / four_pi  # S_11kk
    s22 = np.stack([a1**2 * i12, 3 * a2**2 * i22, a3**2 * i23], axis=-1) / four_pi  # S_22kk
    s1212 = (a1**2 + a2**2) * i12 / (2 * four_pi)
    stretch = (a1**2 - a2**2) / (2 * a1 * a2)
    spin = (a1**2 + a2**2) / (2 * a1 * a2)
    shear = omega * stretch
    return np.stack([
        ca * np.sin(2 * theta) - np.sum(s11 * dev, axis=-1),
        -ca * np.sin(2 * theta) - np.sum(s22 * dev, axis=-1),
        shear * (1.0 - 2.0 * s1212 * (1.0 - ratio)) - 0.5 * np.cos(2 * theta),
        omega * spin - 0.5 - (i2 - i1) / four_pi * (1.0 - ratio) * shear,
    ], axis=-1)


@dataclass(frozen=True)
class RoscoeState:
    """Roscoe's steady state (arrays broadcast over the inputs).

    semi_axes (..., 3): a1, a2 (shear plane, a1 >= a2), a3 (vorticity), units of R, a1 a2 a3 = 1;
    inclination_deg: theta, from the flow direction towards the gradient; tank_treading_frequency: omega /
    shear rate (rate of the ellipse phase); residual: largest |equation| left."""

    capillary_number: np.ndarray
    viscosity_ratio: np.ndarray
    semi_axes: np.ndarray
    inclination_deg: np.ndarray
    tank_treading_frequency: np.ndarray
    residual: np.ndarray

    @property
    def taylor_deformation(self) -> np.ndarray:
        """D = (a1 - a2)/(a1 + a2), the shear-plane semi-axes."""
        a1, a2 = self.semi_axes[..., 0], self.semi_axes[..., 1]
        return (a1 - a2) / (a1 + a2)

    @property
    def taylor_deformation_3d(self) -> np.ndarray:
        """D from the largest and smallest of the three semi-axes (elastocell's definition)."""
        return (self.semi_axes.max(axis=-1) - self.semi_axes.min(axis=-1)) / (
            self.semi_axes.max(axis=-1) + self.semi_axes.min(axis=-1))


def _newton(x: np.ndarray, ca: np.ndarray, ratio: np.ndarray, iterations: int = 60,
            tolerance: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """Damped Newton on every point at once (finite-difference Jacobian, batched 4x4 solves)."""
    step = 1e-7
    for _ in range(iterations):
        f = _residuals(x, ca, ratio)
        norm = np.max(np.abs(f), axis=-1)
        if np.all(norm < tolerance):
            break
        columns = [(_residuals(x + step * np.eye(4)[k], ca, ratio) - f) / step for k in range(4)]
        jacobian = np.stack(columns, axis=-1)  # (..., 4 equations, 4 unknowns)
        dx = -np.linalg.solve(jacobian, f[..., None])[..., 0]
        damping = np.ones(norm.shape)
        for _ in range(30):  # halve the step where it does not lower the residual
            trial = x + damping[..., None] * dx
            worse = np.max(np.abs(_residuals(trial, ca, ratio)), axis=-1) > norm
            worse &= norm >= tolerance
            if not worse.any():
                break
            damping = np.where(worse, 0.5 * damping, damping)
        x = np.where((norm >= tolerance)[..., None], x + damping[..., None] * dx, x)
    return x, np.max(np.abs(_residuals(x, ca, ratio)), axis=-1)


def roscoe_steady_state(capillary_number, viscosity_ratio=1.0, continuation_steps: int = 8) -> RoscoeState:
    """Roscoe's steady shape, inclination and tank-treading frequency at every (Ca, lambda) (broadcast).

    Ca = eta shear_rate / mu > 0, lambda = eta_p / eta >= 0. Solved by Newton from the first-order solution
    at Ca/continuation_steps, continued in ``continuation_steps`` equal steps of Ca (all points at once); a
    point whose equations are not solved to :data:`CONVERGED` is nan."""
    ca, ratio = np.broadcast_arrays(np.asarray(capillary_number, dtype=float),
                                    np.asarray(viscosity_ratio, dtype=float))
    if np.any(~np.isfinite(ca)) or np.any(ca <= 0):
        raise ValueError(f"capillary_number must be > 0, got {capillary_number}")
    if np.any(~np.isfinite(ratio)) or np.any(ratio < 0):
        raise ValueError(f"viscosity_ratio must be >= 0, got {viscosity_ratio}")
    x = None
    for k in range(1, continuation_steps + 1):
        c = ca * k / continuation_steps
        if x is None:  # first order, cot 2 theta = (3/2 + lambda) Ca, D = 5/4 Ca sin 2 theta, omega = 1/2
            theta = 0.5 * np.arctan2(1.0, (1.5 + ratio) * c)
            stretch = 1.25 * c * np.sin(2 * theta)
            x = np.stack([np.log1p(stretch), np.log1p(-stretch), theta, 0.5 + 0 * c], axis=-1)
        x, residual = _newton(x, c, ratio)
    x = np.where((residual < CONVERGED)[..., None], x, np.nan)
    a1, a2 = np.exp(x[..., 0]), np.exp(x[..., 1])
    return RoscoeState(capillary_number=ca, viscosity_ratio=ratio,
                       semi_axes=np.stack([a1, a2, 1.0 / (a1 * a2)], axis=-1),
                       inclination_deg=np.degrees(x[..., 2]), tank_treading_frequency=x[..., 3],
                       residual=residual)
