"""The projected volume ratio of p2 tetrahedra (``MeshParameters.volumetric``: F-bar with J L2-projected per element
onto the linear polynomials, or onto the constants).

References: the projection's algebra (it reproduces the polynomials of its space and is idempotent); a uniform
deformation, for which J_bar = J, so energy and forces equal the standard formulation's to round-off (the
patch test); central finite differences of the energy and of the forces (the autodiff gradient and element
Hessian are those of the energy); and a compression against the standard formulation and the axisymmetric
solver on the same cell."""

import jax.numpy as jnp
import numpy as np
import pytest

from elastocell.body.cell import Cell
from elastocell.body.elements import dilatation_projections, reference_element
from elastocell.body.materials import float64
from elastocell.parameters.cell import cell_parameters
from elastocell.scenarios.compression import compression_parameters_for

COARSE = {"mesh_size": 0.8, "pole_size": 0.8, "interface_size": 0.8, "stiffness_ratio": 5, "quadrature_degree": 5}


def _cell(volumetric, **options):
    return Cell.from_parameters(cell_parameters(**{**COARSE, **options}, volumetric=volumetric))


@pytest.mark.parametrize("treatment, size", [("projected", 4), ("mean", 1)])
def test_projection_reproduces_its_polynomials_and_is_idempotent(treatment, size):
    rule = reference_element(2, 5)
    rng = np.random.default_rng(1)
    weights = rule.point_weights * rng.uniform(0.5, 2.0, (3, len(rule.points)))  # curved elements: any weights
    projection = dilatation_projections(treatment, rule.points, weights)
    basis = np.column_stack([np.ones(len(rule.points)), rule.points])[:, :size]
    assert np.abs(np.einsum("eqr,ra->eqa", projection, basis) - basis).max() < 1e-13
    assert np.abs(projection @ projection - projection).max() < 1e-13
    if treatment == "projected":  # 4 points, 4 linear polynomials: nothing left to project
        four = reference_element(2, 2)
        identity = dilatation_projections("projected", four.points, np.tile(four.point_weights, (2, 1)))
        assert np.abs(identity - np.eye(4)).max() < 1e-13
    assert dilatation_projections("standard", rule.points, weights) is None


@pytest.mark.parametrize("treatment", ["projected", "mean"])
def test_uniform_deformation_is_the_standard_formulation(treatment):
    """J_bar = J for a uniform deformation: the energies agree to round-off, and so do the forces (the projected
    pressure of a constant is that constant). Measured: 1e-15 relative."""
    cell, standard = _cell(treatment), _cell("standard")
    stretch = np.array([[1.1, 0.1, 0.0], [0.0, 0.9, 0.05], [0.02, 0.0, 0.7]])
    x = cell.mesh.nodes @ stretch.T
    assert cell.energy(x) == pytest.approx(standard.energy(x), rel=1e-12)
    forces = standard.internal_forces(x)
    assert np.abs(cell.internal_forces(x) - forces).max() < 1e-11 * np.abs(forces).max()


@pytest.mark.parametrize("treatment", ["projected", "mean"])
def test_gradient_and_hessian_match_finite_differences(treatment):
    """Central differences, h = 1e-6 (error ~h^2): measured 6e-8 relative on the energy's directional derivative
    (round-off of E ~ 1 over h) and 2e-9 on the Hessian-vector product (default mesh, stiffness ratio 20)."""
    cell = _cell(treatment)
    rng = np.random.default_rng(0)
    x = cell.mesh.nodes * np.array([1.05, 1.05, 0.8]) + 0.002 * rng.standard_normal(cell.mesh.nodes.shape)
    direction = rng.standard_normal(x.shape)
    h = 1e-6
    difference = (cell.energy(x + h * direction) - cell.energy(x - h * direction)) / (2 * h)
    assert np.sum(cell.internal_forces(x) * direction) == pytest.approx(difference, rel=1e-6)
    fd = (cell.internal_forces(x + h * direction) - cell.internal_forces(x - h * direction)).ravel() / (2 * h)
    k = cell.stiffness_matrix(x)
    assert np.abs(k @ direction.ravel() - fd).max() < 1e-6 * np.abs(fd).max()
    assert abs(k - k.T).max() < 1e-10 * abs(k).max()
    # the split Hessian (point tangents + coupling) against the element energies' autodiff Hessian: 5e-16 measured
    with float64():
        reference = np.asarray(cell._compiled()["element_hessians"](jnp.asarray(x)))
    assert np.abs(cell.element_stiffness(x) - reference).max() < 1e-12 * np.abs(reference).max()
    assert cell.energy(x) != pytest.approx(_cell("standard").energy(x), rel=1e-6)  # the projection acts


def test_projected_needs_more_than_four_points_and_a_compression_gives_them():
    # pydantic wraps the ParameterError in a ValueError
    with pytest.raises(ValueError, match="volumetric"):
        cell_parameters(quadrature_degree=2, volumetric="projected")
    with pytest.raises(ValueError, match="volumetric"):
        cell_parameters(element="p1", volumetric="mean")
    with pytest.raises(ValueError, match="volumetric"):
        cell_parameters(volumetric="bar")
    resolved = compression_parameters_for(cell_parameters(nucleus="none", volumetric="projected"))
    assert resolved.mesh.quadrature_degree == 5
    assert "volumetric" not in cell_parameters().mesh.model_dump()  # standard: cache and run keys unchanged
