"""One source per material law: every law of elastocell.body.materials.LAWS runs in compression and in flow.

The flow's compiled (Numba) forces exist for the laws of the decoupled Mooney-Rivlin family; each law says so in
its registry entry (``Law.compiled_parameters``). References: the JAX gradient of the law itself
(``Cell.internal_forces``, the forces compression differentiates), so tolerances are round-off; and, for the law
defined here, its first Piola stress in closed form.
"""

from __future__ import annotations

import warnings

import jax.numpy as jnp
import numpy as np
import pytest

import elastocell
from elastocell.body.cell import Cell
from elastocell.body.materials import (
    LAWS,
    bulk_modulus,
    first_piola_stress,
    float64,
    invariants,
    law,
    register_law,
    shear_modulus,
)
from elastocell.coupling import elastic_forces
from elastocell.parameters.units import ParameterError
from elastocell.scenarios import pipe as pipe_flow
from elastocell.scenarios import shear as shear_flow
from elastocell.scenarios.compression import CompressionParameters, compress

COMPILED = [name for name, entry in LAWS.items() if entry.has_compiled_kernel]


def coarse_cell(material: str, element: str) -> Cell:
    """A coarse cell with a stiffer nucleus (two moduli, so per-element parameters matter); seconds to build."""
    return Cell.from_parameters(elastocell.cell_parameters(
        nucleus="sphere", stiffness_ratio=3.0, element=element, material=material, mesh_size=0.5, pole_size=0.5,
        interface_size=0.5))


def strained(cell: Cell, seed: int = 5) -> np.ndarray:
    """Nodes under a random homogeneous deformation (det > 0.5) plus a small random displacement."""
    rng = np.random.default_rng(seed)
    deformation = np.eye(3) + 0.15 * rng.standard_normal((3, 3))
    assert np.linalg.det(deformation) > 0.5
    return cell.mesh.nodes @ deformation.T + 0.01 * rng.standard_normal(cell.mesh.nodes.shape)


# --------------------------------------------------------------------------- the compiled kernels
def test_the_built_in_laws_have_compiled_kernels():
    assert {"neo-hookean", "mooney-rivlin"} <= set(COMPILED)


@pytest.mark.parametrize("element", ["p1", "p2"])
@pytest.mark.parametrize("name", COMPILED)
def test_compiled_forces_of_every_law_with_a_kernel_equal_its_jax_gradient(name, element):
    # Reference: -Cell.internal_forces, the JAX autodiff of the law's strain energy, on a strained cell with a
    # nucleus (random homogeneous deformation plus noise; smallest det F 0.98 (p1), 0.70 (p2)). Round-off:
    # measured max |difference| / max |force| 1.3e-15 / 1.5e-15 (p1) and 1.0e-15 / 9.9e-16 (p2) for
    # neo-Hookean / Mooney-Rivlin; tolerance 1e-13.
    cell = coarse_cell(name, element)
    x = strained(cell)
    reference = -np.asarray(cell.internal_forces(x))
    forces, j_min = elastic_forces.ElasticForces(cell)(x)
    assert j_min > 0
    assert np.abs(forces - reference).max() <= 1e-13 * np.abs(reference).max()


# --------------------------------------------------------------------------- a law added by the user
def yeoh(deformation_gradient, c1, c2, c3, bulk):
    """Yeoh: W = c1 s + c2 s^2 + c3 s^3 + kappa/2 (J - 1)^2 with s = J^(-2/3) I1 - 3 (not of the compiled family)."""
    volume_ratio, first, _ = invariants(deformation_gradient)
    s = volume_ratio ** (-2.0 / 3.0) * first - 3.0
    return c1 * s + c2 * s**2 + c3 * s**3 + 0.5 * bulk * (volume_ratio - 1.0) ** 2


def yeoh_parameters(youngs_modulus, poisson_ratio, options):
    """c1 = mu/2 (the small-strain shear modulus is mu), c2 = mu, c3 = mu: a strongly stiffening law."""
    mu = shear_modulus(youngs_modulus, poisson_ratio)
    return np.column_stack([mu / 2, mu, mu, bulk_modulus(youngs_modulus, poisson_ratio)])


def yeoh_piola_closed_form(f, c1, c2, c3, bulk):
    """P = 2 W'(s) J^(-2/3) (F - I1/3 F^-T) + kappa (J - 1) J F^-T, W'(s) = c1 + 2 c2 s + 3 c3 s^2."""
    j = np.linalg.det(f)
    f_inv_t = np.linalg.inv(f).T
    i1 = np.trace(f.T @ f)
    s = j ** (-2 / 3) * i1 - 3
    slope = c1 + 2 * c2 * s + 3 * c3 * s**2
    return 2 * slope * j ** (-2 / 3) * (f - i1 / 3 * f_inv_t) + bulk * (j - 1) * j * f_inv_t


@pytest.fixture(scope="module")
def yeoh_cell():
    """A coarse p1 cell of the Yeoh law, registered through the public mechanism and removed afterwards."""
    register_law("yeoh-test", yeoh, yeoh_parameters)
    try:
        yield Cell.from_parameters(elastocell.cell_parameters(nucleus="sphere", stiffness_ratio=3.0, element="p1",
                                                              material="yeoh-test", mesh_size=0.6, pole_size=0.6,
                                                              interface_size=0.6))
    finally:
        LAWS.pop("yeoh-test")


def test_a_registered_law_is_the_cells_law_and_has_no_compiled_kernel(yeoh_cell):
    # Reference: the closed-form Yeoh stress. Round-off: measured max |dP| 1.1e-16 against |P| ~ 1; tolerance 1e-12.
    assert yeoh_cell.law is law("yeoh-test") and not yeoh_cell.law.has_compiled_kernel
    params = yeoh_parameters(np.array([1.0]), 0.48, {})[0]
    f = np.eye(3) + 0.2 * np.random.default_rng(1).standard_normal((3, 3))
    with float64():
        stress = np.asarray(first_piola_stress(yeoh_cell.law, jnp.asarray(f), jnp.asarray(params)))
    np.testing.assert_allclose(stress, yeoh_piola_closed_form(f, *params), atol=1e-12)
    with pytest.raises(ValueError, match="backend='jax'"):
        elastic_forces.ElasticForces(yeoh_cell)
    with pytest.raises(ParameterError, match="already registered"):
        register_law("yeoh-test", yeoh, yeoh_parameters)
    with pytest.raises(Exception, match="must be one of"):
        elastocell.cell_parameters(material="no-such-law")


def check_coupled_forces(system, steps: int):
    """Strain the cell (a random 0.01 dx kick of every node, so that the forces are not round-off of a cell at
    rest), advance ``steps`` coupled steps and return the largest difference, relative to the largest force,
    between the marker forces of the last step (taken at the positions before it) and the JAX gradient of the
    law there, in lattice units E_c R^2."""
    system.positions += 0.01 * np.random.default_rng(6).standard_normal(system.positions.shape)
    system.advance(steps - 1)
    before = system.positions.copy()
    system.advance(1)
    assert system.time_step == steps and np.all(np.isfinite(system.positions))
    assert np.abs(system.positions - before).max() > 0  # the flow carries the cell
    reference = -np.asarray(system.cell.internal_forces(before / system.radius)) * system.youngs_modulus * system.radius**2
    return np.abs(system.marker_forces - reference).max() / np.abs(reference).max()


def test_a_registered_law_runs_in_shear_flow_on_the_jax_backend_with_one_warning(yeoh_cell):
    # Reference: Cell.internal_forces at the markers (the law's JAX gradient), scaled by E_c R^2. Round-off (the
    # same gradient traced inside the coupled loop, where XLA orders the operations differently): measured max
    # difference 4.6e-14 of the largest force; tolerance 1e-12. Tiny lattice (R = 3 dx), 4 steps.
    params = shear_flow.ShearFlowParameters(capillary_number=0.05, resolution=3.0, confinement=0.3, box_length=4.0)
    assert params.backend == "numba"
    with pytest.warns(UserWarning, match="no compiled") as caught:
        system = shear_flow.shear_setup(yeoh_cell, params)
    assert len(caught) == 1 and system.backend == "jax"
    assert check_coupled_forces(system, 4) <= 1e-12


def test_a_registered_law_runs_in_pipe_flow(yeoh_cell):
    # As the shear test (measured 4.4e-14; tolerance 1e-12): Poiseuille flow in a channel of solid walls,
    # R = 3 dx, 4 steps. The JAX backend asked for explicitly runs without a warning.
    params = pipe_flow.PipeFlowParameters(capillary_number_wall=0.2, resolution=3, channel_radius_ratio=2.5,
                                          box_length=4, backend="jax")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        system = pipe_flow.pipe_setup(yeoh_cell, params)
    assert system.backend == "jax"
    assert check_coupled_forces(system, 4) <= 1e-12


def test_a_registered_law_compresses(yeoh_cell):
    # Reference: the neo-Hookean cell of the same mesh and small-strain shear modulus (Yeoh's c1 = mu/2). The
    # Yeoh law stiffens with strain (c2 = c3 = mu > 0): its plate force is the larger, the more so the larger
    # delta, and the ratio tends to 1 as delta -> 0. Measured ratio 1.065 at delta = 0.05, 1.175 at 0.1; the
    # first row is held below 1.1.
    result = compress(yeoh_cell, CompressionParameters(delta_max=0.1, steps=2))
    assert len(result.delta) == 3 and np.all(np.diff(result.force) > 0)
    neo_hookean = Cell(yeoh_cell.parameters.model_copy(update={"material": yeoh_cell.parameters.material.model_copy(
        update={"law": "neo-hookean"})}), yeoh_cell.mesh, yeoh_cell.youngs_moduli)
    reference = compress(neo_hookean, CompressionParameters(delta_max=0.1, steps=2))
    ratio = result.force[1:] / reference.force[1:]
    assert 1 < ratio[0] < min(ratio[1], 1.1)
