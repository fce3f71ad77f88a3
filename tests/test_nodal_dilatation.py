"""The nodal dilatation of linear tetrahedra (``MeshParameters.volumetric`` nodal) and the compiled flow forces of
every volumetric treatment: the energy's definition, its forces on both flow backends, its reference stiffness
for the stability estimate, and the refusals."""

from __future__ import annotations

import jax
import numpy as np
import pytest

import elastocell
from elastocell.body.cell import Cell
from elastocell.body.materials import float64
from elastocell.coupling import elastic_forces
from elastocell.parameters.flow import flow_cell
from elastocell.parameters.units import ParameterError
from elastocell.scenarios import pipe as pipe_flow
from elastocell.scenarios import shear as shear_flow


def coarse_cell(element: str, volumetric: str, law: str = "neo-hookean", stiffness_ratio: float = 3.0) -> Cell:
    return Cell.from_parameters(elastocell.cell_parameters(
        nucleus="sphere", stiffness_ratio=stiffness_ratio, element=element, material=law, mesh_size=0.5,
        pole_size=0.5, interface_size=0.5, volumetric=volumetric))


def strained(cell: Cell, seed: int = 5, amplitude: float = 0.1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    deformation = np.eye(3) + amplitude * rng.standard_normal((3, 3))
    return cell.mesh.nodes @ deformation.T + 0.01 * rng.standard_normal(cell.mesh.nodes.shape)


def volumetric_energies(cell: Cell, x: np.ndarray) -> tuple[float, float]:
    """(sum_a V_a0 kappa/2 (J_a - 1)^2, sum_e V_e0 kappa/2 (J_e - 1)^2) in NumPy, for a uniform kappa = 1."""
    elements = cell.mesh.elements
    edges = x[elements[:, 1:4]] - x[elements[:, [0]]]
    volumes = np.linalg.det(edges) / 6.0
    reference = cell.element_volumes
    nodal = np.bincount(elements.ravel(), weights=np.repeat(volumes / 4, 4), minlength=cell.mesh.n_nodes)
    ratios = nodal / cell.nodal_reference_volumes
    return (float(np.sum(0.5 * cell.nodal_reference_volumes * (ratios - 1) ** 2)),
            float(np.sum(0.5 * reference * (volumes / reference - 1) ** 2)))


def test_nodal_volumetric_energy_is_the_averaged_nodal_dilatation():
    # References: (1) the energy written out in NumPy from its definition (node volumes V_a = sum of a quarter of
    # the current volumes of its tetrahedra): Cell.energy of the nodal cell minus that of the isochoric part alone
    # (the law at kappa's cell with J = 1 per point is W(J^(-1/3) F)); (2) Jensen: J_a - 1 is a weighted mean of
    # its elements' J_e - 1, so the nodal volumetric energy is at most the elements' one, and equal for a uniform
    # dilation. Round-off: measured 4e-16 relative; tolerance 1e-12.
    cell = coarse_cell("p1", "nodal", stiffness_ratio=1.0)
    kappa = cell.nodal_bulk_moduli
    np.testing.assert_allclose(kappa, kappa[0], rtol=1e-14)
    for seed in range(3):
        x = strained(cell, seed)
        nodal, elementwise = volumetric_energies(cell, x)
        assert 0 < nodal < elementwise
        standard = cell.with_standard_volumetric()
        with float64():
            isochoric = standard.energy(x) - kappa[0] * elementwise
            assert cell.energy(x) == pytest.approx(isochoric + kappa[0] * nodal, rel=1e-12)
    x = 1.07 * cell.mesh.nodes  # a uniform dilation: every J_a = J_e = 1.07^3, the standard energy
    with float64():
        assert cell.energy(x) == pytest.approx(cell.with_standard_volumetric().energy(x), rel=1e-12)
        assert cell.energy(x) == pytest.approx(0.5 * kappa[0] * cell.volume * (1.07**3 - 1) ** 2, rel=1e-12)


def test_nodal_bulk_moduli_are_volume_weighted_means():
    # Reference: sum_a kappa_a V_a0 = sum_e kappa_e V_e0 (each element's V_e0/4 goes to each of its four nodes
    # with its kappa_e) and min kappa_e <= kappa_a <= max kappa_e, on a cell whose nucleus is 10 times stiffer
    # (kappa_e from the law's own parameters). Round-off: tolerance 1e-12 relative.
    cell = coarse_cell("p1", "nodal", stiffness_ratio=10.0)
    bulk = cell.law.compiled_parameters(np.asarray(cell.material_parameters))[:, 2]
    assert bulk.max() / bulk.min() == pytest.approx(10.0)
    assert np.sum(cell.nodal_bulk_moduli * cell.nodal_reference_volumes) == pytest.approx(
        np.sum(bulk * cell.element_volumes), rel=1e-12)
    assert np.all(cell.nodal_bulk_moduli >= bulk.min() * (1 - 1e-12))
    assert np.all(cell.nodal_bulk_moduli <= bulk.max() * (1 + 1e-12))
    assert np.sum(cell.nodal_reference_volumes) == pytest.approx(cell.volume, rel=1e-12)


def test_nodal_cauchy_stress_is_the_isochoric_part_plus_the_nodal_pressure():
    # References: (1) a uniform deformation of a homogeneous cell has J_a = J_e and kappa_a = kappa_e, so the
    # stress is the standard element's (with a nucleus the interface nodes average kappa: not so); (2) the
    # isochoric part is traceless, so tr(sigma_e)/3 is the mean over the element's nodes of kappa_a (J_a - 1),
    # computed here in NumPy from the node volumes (a nucleus 10 times stiffer). Round-off: tolerance 1e-10
    # of the largest stress.
    homogeneous = coarse_cell("p1", "nodal", stiffness_ratio=1.0)
    uniform = homogeneous.mesh.nodes @ np.array([[1.1, 0.05, 0.0], [0.0, 0.95, 0.02], [0.03, 0.0, 0.98]]).T
    standard = homogeneous.with_standard_volumetric().element_cauchy_stress(uniform)
    np.testing.assert_allclose(homogeneous.element_cauchy_stress(uniform), standard,
                               atol=1e-10 * np.abs(standard).max())
    cell = coarse_cell("p1", "nodal", stiffness_ratio=10.0)
    x = strained(cell, 2)
    stress = cell.element_cauchy_stress(x)
    elements = cell.mesh.elements
    edges = x[elements[:, 1:4]] - x[elements[:, [0]]]
    volumes = np.linalg.det(edges) / 6.0
    ratios = np.bincount(elements.ravel(), weights=np.repeat(volumes / 4, 4)) / cell.nodal_reference_volumes
    pressure = np.mean((cell.nodal_bulk_moduli * (ratios - 1))[elements], axis=1)
    np.testing.assert_allclose(np.trace(stress, axis1=1, axis2=2) / 3, pressure, atol=1e-10 * np.abs(stress).max())


@pytest.mark.parametrize(("element", "volumetric"), [("p1", "nodal"), ("p2", "mean")])
@pytest.mark.parametrize("law", ["neo-hookean", "mooney-rivlin"])
def test_compiled_forces_of_each_volumetric_treatment_equal_jax_autodiff(element, volumetric, law):
    # Reference: -Cell.internal_forces (JAX autodiff of the cell's energy, the treatment included). Round-off:
    # measured 2.7e-15 relative to the largest force (p1 nodal) and 1.7e-15 (p2 mean); tolerance 1e-12. Also in
    # scaled (lattice) units, as the flows call it.
    from test_ibm import assert_compiled_forces_are_autodiff

    cell = coarse_cell(element, volumetric, law)
    x = strained(cell)
    forces = assert_compiled_forces_are_autodiff(cell, x)
    scale = np.abs(forces).max()
    # the treatment changes the forces: not the standard elements' (measured: differences of the size of the forces)
    standard, _ = elastic_forces.ElasticForces(cell.with_standard_volumetric())(x)
    assert np.abs(standard - forces).max() > 0.1 * scale


@pytest.mark.parametrize("stiffness_ratio", [1.0, 10.0])
def test_reference_stiffness_of_the_nodal_dilatation_is_the_hessian(stiffness_ratio):
    # Reference: the dense Hessian of Cell.energy by JAX autodiff at x = X (float64). Round-off: measured 4.6e-15
    # relative to the largest entry; tolerance 1e-12. A stiff nucleus makes the node bulk moduli differ.
    cell = coarse_cell("p1", "nodal", "mooney-rivlin", stiffness_ratio)
    with float64():
        energy = cell._compiled()["energy"]
        hessian = np.asarray(jax.hessian(lambda flat: energy(flat.reshape(-1, 3)))(cell.mesh.nodes.ravel()))
    stiffness = cell.reference_stiffness_matrix().toarray()
    np.testing.assert_allclose(stiffness, hessian, atol=1e-12 * np.abs(hessian).max())
    # averaging relieves the volumetric stiffness: the largest eigenvalue falls (measured 119 -> 18 at ratio 10)
    standard = cell.with_standard_volumetric().reference_stiffness_matrix().toarray()
    assert np.linalg.eigvalsh(stiffness)[-1] < 0.5 * np.linalg.eigvalsh(standard)[-1]


def test_nodal_dilatation_refusals(tmp_path):
    with pytest.raises(ValueError, match="p1 elements only"):
        elastocell.cell_parameters(element="p2", volumetric="nodal")
    with pytest.raises(ValueError, match="p2 elements only"):
        elastocell.cell_parameters(element="p1", volumetric="mean")
    cell = coarse_cell("p1", "nodal")
    with pytest.raises(ValueError, match="no element stiffness"):
        cell.element_stiffness(cell.mesh.nodes)
    with pytest.raises(ParameterError, match="flows only"):
        elastocell.compress("unused", element="p1", volumetric="nodal")
    with pytest.raises(ParameterError, match="flows only"):  # refused before its output directory is made
        elastocell.indent(tmp_path / "indent", indenter_radius=0.5, solver="3d", element="p1", volumetric="nodal",
                          nucleus="none")
    assert not (tmp_path / "indent").exists()
    # the axisymmetric solvers have their own meridian mesh: a treatment of the 3D elements is refused, not ignored
    with pytest.raises(ParameterError, match="axisymmetric solver"):
        elastocell.compress("unused", element="p1", volumetric="nodal", axisymmetric=True)
    with pytest.raises(ParameterError, match="axisymmetric solver"):
        elastocell.indent("unused", indenter_radius=0.5, volumetric="mean", nucleus="none")


def test_nodal_dilatation_on_the_jax_flow_backend_and_projected_falls_back_to_it():
    # Reference: Cell.internal_forces at the markers, scaled by E_c R^2 (tests/test_laws.py's check): the JAX
    # backend's coupled loop traces the same energy. Round-off: tolerance 1e-12 as there. A p2 cell with J
    # projected onto linear polynomials has no compiled kernel: the numba backend hands it to JAX with one warning.
    from test_laws import check_coupled_forces

    for backend in ("jax", "numba"):  # the numba loop calls the compiled kernel with its nodal pass
        nodal = coarse_cell("p1", "nodal")
        params = pipe_flow.PipeFlowParameters(capillary_number_wall=0.2, resolution=3, channel_radius_ratio=2.5,
                                              box_length=4, backend=backend)
        system = pipe_flow.pipe_setup(nodal, params)
        assert system.backend == backend
        assert check_coupled_forces(system, 4) <= 1e-12
    # a flow's projected J takes the rule of degree 5 (with 4 points the projection is the identity)
    parameters = flow_cell(None, {"element": "p2", "mesh_size": 0.6, "volumetric": "projected"}, 3.0)
    assert parameters.mesh.quadrature_degree == 5
    assert flow_cell(parameters, {}, 3.0).mesh.quadrature_degree == 5
    projected = Cell.from_parameters(parameters)
    params = shear_flow.ShearFlowParameters(capillary_number=0.05, resolution=3.0, confinement=0.3, box_length=4.0)
    with pytest.warns(UserWarning, match="no compiled") as caught:
        system = shear_flow.shear_setup(projected, params)
    assert len(caught) == 1 and system.backend == "jax"
    with pytest.raises(ValueError, match="backend='jax'"):
        elastic_forces.ElasticForces(projected)
