"""Tests of the immersed-boundary coupling (elastocell.coupling.ibm) and the compiled elastic forces and coupled
stepping of elastocell.coupling.immersed, lattice units (dx = dt = 1, rho0 = 1).

References are exact identities of the discretisation (partition of unity and first-moment condition of the
kernels, the JAX autodiff forces of the cell model, the public-API slow path), so tolerances are round-off.
"""

from __future__ import annotations

import numpy as np
import pytest

import elastocell
from elastocell.body.cell import Cell
from elastocell.coupling import elastic_forces, ibm, immersed, markers
from elastocell.lattice import Lattice, LatticeParams
from elastocell.scenarios import shear as shear_scenario

KERNELS = ["trilinear", "peskin4"]


@pytest.fixture(scope="module")
def coarse_cells():
    """Coarse meshes (seconds to build, cached): {(element, law, nucleus): Cell}."""
    cells = {}
    for element in ("p1", "p2"):
        for law in ("neo-hookean", "mooney-rivlin"):
            for nucleus in ("none", "sphere"):
                params = elastocell.cell_parameters(nucleus=nucleus, element=element, material=law,
                                                    mesh_size=0.5, pole_size=0.5, interface_size=0.5,
                                                    **({"stiffness_ratio": 3.0} if nucleus == "sphere" else {}))
                cells[element, law, nucleus] = Cell.from_parameters(params)
    return cells


# --------------------------------------------------------------------------- kernels
@pytest.mark.parametrize("kernel", KERNELS)
def test_kernel_partition_of_unity_and_zero_first_moment(kernel):
    # Reference: sum_j phi(r - j) = 1 and sum_j (r - j) phi(r - j) = 0 for every r (both kernels). Round-off.
    r = np.linspace(0.0, 1.0, 101)
    j = np.arange(-3, 4)
    phi = ibm.kernel_weights(kernel, r[:, None] - j[None, :])
    np.testing.assert_allclose(phi.sum(axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(((r[:, None] - j) * phi).sum(axis=1), 0.0, atol=1e-14)
    assert np.all(phi >= 0)
    assert ibm.kernel_weights(kernel, ibm.kernel_half_width(kernel)) == 0.0


@pytest.mark.parametrize("kernel", KERNELS)
def test_spreading_conserves_total_force_and_torque(kernel):
    # Reference: sum_n F(n) = sum_m f_m (partition of unity) and sum_n n x F(n) = sum_m X_m x f_m (zero first
    # moment), exact away from the walls. Round-off (measured 9e-15 on a total of 31, 1.7e-13 on a torque of 230).
    rng = np.random.default_rng(1)
    shape = (16, 16, 16)
    positions = rng.uniform(4.0, 11.0, (200, 3))
    forces = rng.standard_normal((200, 3))
    field = ibm.spread(forces, positions, shape, kernel)
    nodes = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"))
    total = field.reshape(3, -1).sum(axis=1)
    np.testing.assert_allclose(total, forces.sum(axis=0), rtol=1e-12, atol=1e-12)
    torque = np.cross(nodes.reshape(3, -1).T, field.reshape(3, -1).T).sum(axis=0)
    np.testing.assert_allclose(torque, np.cross(positions, forces).sum(axis=0), rtol=1e-12, atol=1e-11)
    # clearing the supports removes every trace of the spread
    ibm.clear(field, positions, kernel)
    assert not field.any()


@pytest.mark.parametrize("kernel", KERNELS)
def test_interpolation_of_a_linear_field_is_exact(kernel):
    # Reference: u(x) = a + B x; both kernels reproduce linear fields (first-moment condition). Round-off.
    rng = np.random.default_rng(2)
    shape = (12, 12, 12)
    a = rng.standard_normal(3)
    b = rng.standard_normal((3, 3))
    nodes = np.stack(np.meshgrid(*[np.arange(n, dtype=float) for n in shape], indexing="ij"))
    field = a[:, None, None, None] + np.einsum("ij,j...->i...", b, nodes)
    positions = rng.uniform(2.5, 8.5, (100, 3))
    values = ibm.interpolate(field, positions, kernel)
    np.testing.assert_allclose(values, a + positions @ b.T, atol=1e-12)


def test_periodic_images_and_spread_interpolate_adjointness():
    # Reference: spreading is the transpose of interpolation, <interp(u), f> = <u, spread(f)>, also for markers
    # across the periodic seams (unwrapped positions outside the box). Round-off.
    rng = np.random.default_rng(3)
    shape = (8, 10, 6)
    positions = rng.uniform(-10.0, 20.0, (50, 3))
    forces = rng.standard_normal((50, 3))
    u = rng.standard_normal((3,) + shape)
    for kernel in KERNELS:
        lhs = np.sum(ibm.interpolate(u, positions, kernel, periodic_y=True) * forces)
        rhs = np.sum(u * ibm.spread(forces, positions, shape, kernel, periodic_y=True))
        assert lhs == pytest.approx(rhs, rel=1e-12)
        shifted = positions + np.array(shape) * np.array([2, -1, 3])
        np.testing.assert_allclose(ibm.interpolate(u, shifted, kernel, periodic_y=True),
                                   ibm.interpolate(u, positions, kernel, periodic_y=True), atol=1e-12)


def test_invalid_inputs_raise_value_error():
    with pytest.raises(ValueError, match="kernel"):
        ibm.kernel_id("gaussian")
    with pytest.raises(ValueError, match="positions"):
        ibm.interpolate(np.zeros((3, 4, 4, 4)), np.zeros((5, 2)))
    with pytest.raises(ValueError, match="finite"):
        ibm.spread(np.zeros((1, 3)), np.full((1, 3), np.nan), (4, 4, 4))


@pytest.mark.parametrize("parity_steps", [0, 1])
@pytest.mark.parametrize("kernel", KERNELS)
def test_velocity_read_from_populations_equals_interpolated_lattice_velocity(parity_steps, kernel):
    # Reference: Lattice.velocity() (full-lattice pass, with Guo's half-force term) interpolated at the markers;
    # the compiled reader evaluates the same populations at the kernel support only, for either AA parity,
    # moving walls and a force field. float64: round-off (measured <= 2e-18 dx/dt).
    rng = np.random.default_rng(4)
    shape = (10, 12, 9)
    params = LatticeParams(shape, relaxation_time=0.9, dtype="float64", wall_velocity=(-0.01, 0.02))
    velocity = 0.01 * rng.standard_normal((3,) + shape)
    lattice = Lattice(params, velocity=velocity)
    lattice.set_force_density(1e-4 * rng.standard_normal((3,) + shape))
    lattice.step(3 + parity_steps)
    positions = rng.uniform([-5, 0.0, -5], [15, 11.0, 15], (60, 3))  # includes nodes next to the walls
    expected = ibm.interpolate(lattice.velocity(), positions, kernel)
    np.testing.assert_allclose(ibm.interpolate_lattice_velocity(lattice, positions, kernel), expected,
                               atol=1e-15)


@pytest.mark.parametrize("parity_steps", [0, 1])
def test_the_velocity_at_markers_near_an_interpolated_wall_is_the_lattices(parity_steps):
    # Reference: Lattice.velocity() interpolated at the markers, on a cylinder with interpolated bounce-back, at
    # either AA parity (after an odd step a near link's slot holds only part of its population, after an even
    # step a far link's value lives in the lattice's memory). float64: round-off (tolerance 1e-15 dx/dt).
    from elastocell.scenarios.pipe import channel_shape, channel_solid, cylinder_wall_fraction

    radius = 6.3
    shape = channel_shape(radius, 4)
    lattice = Lattice(LatticeParams(shape, relaxation_time=1.0, dtype="float64", solid=channel_solid(shape, radius),
                                    body_force=(1e-5, 0, 0), wall_fraction=cylinder_wall_fraction(shape, radius)))
    lattice.step(40 + parity_steps)
    rng = np.random.default_rng(2)
    positions = np.column_stack([rng.uniform(0, 4, 50), rng.uniform(1, shape[1] - 2, 50),
                                 rng.uniform(1, shape[2] - 2, 50)])
    expected = ibm.interpolate(lattice.velocity(), positions, "peskin4", periodic_y=True)
    np.testing.assert_allclose(ibm.interpolate_lattice_velocity(lattice, positions, "peskin4"), expected, atol=1e-15)


# --------------------------------------------------------------------------- compiled elastic forces
@pytest.mark.parametrize("element", ["p1", "p2"])
@pytest.mark.parametrize("law", ["neo-hookean", "mooney-rivlin"])
@pytest.mark.parametrize("nucleus", ["none", "sphere"])
def test_compiled_elastic_forces_equal_jax_autodiff(coarse_cells, element, law, nucleus):
    # Reference: -Cell.internal_forces (JAX autodiff of the same strain energy). Round-off: measured max error
    # 5e-16 relative to the largest force (p1 neo-Hookean); tolerance 1e-12 relative.
    cell = coarse_cells[element, law, nucleus]
    rng = np.random.default_rng(5)
    deformation = np.eye(3) + 0.15 * rng.standard_normal((3, 3))
    if np.linalg.det(deformation) < 0.5:
        deformation = np.eye(3) + 0.05 * rng.standard_normal((3, 3))
    x = cell.mesh.nodes @ deformation.T + 0.01 * rng.standard_normal(cell.mesh.nodes.shape)
    assert_compiled_forces_are_autodiff(cell, x)


def assert_compiled_forces_are_autodiff(cell, x: np.ndarray) -> np.ndarray:
    """The compiled forces at x equal -Cell.internal_forces to 1e-12 of the largest, in the cell's units and in
    scaled ones (positions in dx with R = 7.5 dx, E_c = 0.02: forces E_c R^2 times the dimensionless ones);
    returns them."""
    reference = -np.asarray(cell.internal_forces(x))
    forces, j_min = elastic_forces.ElasticForces(cell)(x)
    scale = np.abs(reference).max()
    np.testing.assert_allclose(forces, reference, atol=1e-12 * scale)
    assert j_min > 0
    scaled, _ = elastic_forces.ElasticForces(cell, length_scale=7.5, modulus_scale=0.02)(3.0 + 7.5 * x)
    np.testing.assert_allclose(scaled, 0.02 * 7.5**2 * reference, atol=1e-12 * 0.02 * 7.5**2 * scale)
    return forces


def test_compiled_forces_flag_inverted_elements(coarse_cells):
    cell = coarse_cells["p1", "neo-hookean", "none"]
    x = cell.mesh.nodes.copy()
    x[:, 0] *= -1.0  # a reflection inverts every element
    _, j_min = elastic_forces.ElasticForces(cell)(x)
    assert j_min < 0
    assert elastic_forces._inverse_cube_root(0.7) == pytest.approx(0.7 ** (-1 / 3), rel=1e-15)
    assert elastic_forces._inverse_cube_root(50.0) == pytest.approx(50.0 ** (-1 / 3), rel=1e-15)


# --------------------------------------------------------------------------- coupled stepping
@pytest.mark.slow
def test_markers_without_force_follow_a_uniform_flow_exactly(coarse_cells):
    # Reference: X(t) = X0 + u0 t. With E = 0 the markers carry no force; a uniform lattice flow stays uniform
    # and both kernels interpolate it exactly, across the periodic seams too. float64: round-off (measured
    # 1.3e-13 dx after 200 steps, positions ~10 dx).
    cell = coarse_cells["p2", "neo-hookean", "none"]
    u0 = np.array([0.03, -0.02, 0.01])
    for kernel in KERNELS:
        lattice = Lattice(LatticeParams((12, 12, 12), relaxation_time=0.8, dtype="float64"), velocity=u0)
        system = immersed.ImmersedCell(lattice, cell, centre=(5.3, 6.1, 5.7), radius=3.0, youngs_modulus=0.0,
                                   kernel=kernel)
        start = system.positions.copy()
        system.advance(150)
        system.advance(50)
        np.testing.assert_allclose(system.positions, start + 200 * u0, atol=1e-12)
        assert system.time_step == 200


@pytest.mark.parametrize("element, kernel", [("p1", "trilinear"), ("p2", "peskin4")])
def test_compiled_coupled_steps_match_the_public_api_reference(coarse_cells, element, kernel):
    # Reference: ImmersedCell.advance_reference, the same algorithm through public APIs (JAX forces,
    # full-lattice Lattice.velocity, ibm.spread/interpolate, Lattice.step), in Couette flow with moving walls.
    # float64: round-off (measured max |dX| 1.8e-15 dx after 6 steps, forces 7e-14 relative); tolerance 1e-12.
    cell = coarse_cells[element, "neo-hookean", "sphere"]
    params = shear_scenario.ShearFlowParameters(capillary_number=0.05, resolution=3.0, confinement=0.3, box_length=4.0,
                                      kernel=kernel, dtype="float64")
    units = shear_scenario.shear_lattice_units(cell, params)
    compiled = shear_scenario.shear_setup(cell, params, units)
    reference = shear_scenario.shear_setup(cell, params, units)
    rng = np.random.default_rng(6)
    kick = 0.01 * rng.standard_normal(compiled.positions.shape)  # start from a strained state: large forces
    compiled.positions += kick
    reference.positions += kick
    compiled.advance(2)
    compiled.advance(4)
    reference.advance_reference(6)
    np.testing.assert_allclose(compiled.positions, reference.positions, atol=1e-12)
    np.testing.assert_allclose(compiled.marker_forces, reference.marker_forces,
                               atol=1e-12 * np.abs(reference.marker_forces).max())
    np.testing.assert_allclose(compiled.lattice.velocity(), reference.lattice.velocity(), atol=1e-14)
    # the check is not trivial: the elastic forces are large (their spread velocity is not round-off)
    assert np.abs(reference.marker_forces).max() > 1e-4


@pytest.mark.parametrize("kernel", ["trilinear", "peskin4"])
def test_coupled_steps_across_periodic_seams_and_a_solid_wall_match_the_reference(coarse_cells, kernel):
    # Reference: ImmersedCell.advance_reference (full-lattice Lattice.velocity, ibm.interpolate). The compiled
    # loop reads the marker velocities from what the LB sweep stored in the box of the markers' kernel supports,
    # taken modulo the lattice: here the cell straddles the periodic x seam of a pipe (solid channel wall, body
    # force) with unwrapped positions below 0, so a wrong box, seam or solid-node value shows as an O(u) error.
    # float64 round-off: measured max |dX| ~1e-16 dx after 6 steps; tolerance 1e-12.
    from elastocell.scenarios import pipe as pipe_flow

    cell = coarse_cells["p1", "neo-hookean", "sphere"]
    params = pipe_flow.PipeFlowParameters(capillary_number_wall=0.2, resolution=4, channel_radius_ratio=2.5,
                                          box_length=6, kernel=kernel, dtype="float64")
    units = pipe_flow.pipe_lattice_units(cell, params)
    compiled = pipe_flow.pipe_setup(cell, params, units)
    reference = pipe_flow.pipe_setup(cell, params, units)
    shift = np.array([-compiled.positions[:, 0].mean(), 0.0, 0.0])  # centre on x = 0: half the cell at x < 0
    kick = 0.01 * np.random.default_rng(7).standard_normal(compiled.positions.shape)
    for system in (compiled, reference):
        system.positions += shift + kick
    assert compiled.positions[:, 0].min() < -1 and compiled.positions[:, 0].max() > 1
    compiled.advance(3)
    compiled.advance(3)
    reference.advance_reference(6)
    assert np.abs(reference.marker_velocities).max() > 1e-3  # the flow carries the cell: not a trivial check
    np.testing.assert_allclose(compiled.marker_velocities, reference.marker_velocities, atol=1e-14)
    np.testing.assert_allclose(compiled.positions, reference.positions, atol=1e-12)


@pytest.mark.parametrize("element, kernel, law", [("p1", "trilinear", "neo-hookean"), ("p2", "peskin4", "mooney-rivlin")])
@pytest.mark.slow
def test_jax_backend_coupled_steps_match_the_numba_kernels(coarse_cells, element, kernel, law):
    # Reference: the Numba coupled steps (themselves checked against the public-API path above). The JAX
    # backend (elastocell.coupling.immersed_jax, the path for GPUs) implements the same algorithm independently: JAX
    # autodiff forces, scatter-add spreading, moments at the kernel nodes, rolled streaming. Couette flow with
    # moving walls, a strained nucleus cell, float64, 6 steps in two chunks. Round-off: measured (p1,
    # trilinear, neo-Hookean) max |dX| 1.8e-15 dx, forces 1.1e-13 relative, lattice velocity 1.4e-16.
    cell = coarse_cells[element, law, "sphere"]
    params = shear_scenario.ShearFlowParameters(capillary_number=0.05, resolution=3.0, confinement=0.3, box_length=4.0,
                                      kernel=kernel, dtype="float64")
    units = shear_scenario.shear_lattice_units(cell, params)
    numba_system = shear_scenario.shear_setup(cell, params, units)
    jax_system = shear_scenario.shear_setup(cell, params.model_copy(update={"backend": "jax"}), units)
    assert jax_system.backend == "jax" and numba_system.backend == "numba"
    kick = 0.01 * np.random.default_rng(6).standard_normal(numba_system.positions.shape)
    numba_system.positions += kick
    jax_system.positions += kick
    for system in (numba_system, jax_system):
        system.advance(2)
        system.advance(4)
    np.testing.assert_allclose(jax_system.positions, numba_system.positions, atol=1e-12)
    np.testing.assert_allclose(jax_system.marker_forces, numba_system.marker_forces,
                               atol=1e-12 * np.abs(numba_system.marker_forces).max())
    np.testing.assert_allclose(jax_system.marker_velocities, numba_system.marker_velocities, atol=1e-14)
    np.testing.assert_allclose(jax_system.lattice.velocity(), numba_system.lattice.velocity(), atol=1e-14)
    assert jax_system.time_step == numba_system.time_step == 6
    assert np.abs(numba_system.marker_forces).max() > 1e-4  # large forces: the check is not trivial


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("geometry", ["walls", "solid"])
@pytest.mark.slow
def test_jax_spreading_and_interpolation_match_ibm_at_walls_and_solids(kernel, geometry):
    # Reference: elastocell.coupling.ibm (spread; interpolate_lattice_velocity, which reads u = 0 at solid nodes and drops
    # kernel nodes beyond the y-walls). Markers are placed where the kernel support crosses a y-wall or covers
    # solid nodes of a channel; random populations, force field and body force. float64 round-off (tolerance
    # 1e-13 on forces of order 1 and velocities of order 0.01).
    from elastocell.body.materials import float64
    from elastocell.coupling import immersed_jax as flow_jax
    from elastocell.lattice.jax_backend import JaxLattice

    with float64():  # the module functions run in 64 bit only inside elastocell's context
        rng = np.random.default_rng(11)
        shape = (9, 12, 10)
        if geometry == "walls":
            params = LatticeParams(shape, relaxation_time=0.8, dtype="float64", wall_velocity=(-0.01, 0.01))
            y = rng.choice([0.1, 0.6, 1.4, 10.2, 10.7, 10.95], 40)
        else:
            yy, zz = np.meshgrid(np.arange(shape[1]), np.arange(shape[2]), indexing="ij")
            solid = np.broadcast_to(((yy - 5.5) ** 2 + (zz - 4.5) ** 2 > 4.2**2)[None], shape).copy()
            params = LatticeParams(shape, relaxation_time=0.8, dtype="float64", solid=solid, body_force=(1e-3, 0, 0))
            y = rng.uniform(1.5, 9.5, 40)
        positions = np.column_stack([rng.uniform(-3, 12, 40), y, rng.uniform(0.5, 9.0, 40)])  # x unwrapped
        forces = rng.standard_normal((40, 3))
        periodic_y = not params.has_walls
        flat, weights = flow_jax.kernel_stencil(flow_jax.jnp.asarray(positions), shape, kernel, periodic_y)
        field = np.asarray(flow_jax.spread(flow_jax.jnp.asarray(forces), flat, weights, shape, np.float64))
        np.testing.assert_allclose(field, ibm.spread(forces, positions, shape, kernel, periodic_y), rtol=0, atol=1e-13)
        deviations = 0.01 * rng.standard_normal((19,) + shape)
        numba_lattice, jax_lattice = Lattice(params), JaxLattice(params)
        for lattice in (numba_lattice, jax_lattice):
            lattice.set_population_deviations(deviations)
            lattice.set_force_density(1e-3 * field)
        expected = ibm.interpolate_lattice_velocity(numba_lattice, positions, kernel)
        force = flow_jax.total_force(jax_lattice.force_density, jax_lattice._tables_jax, shape, np.float64)
        velocity = flow_jax.interpolate_velocity(jax_lattice.deviations, force, flat, weights, jax_lattice._tables_jax.fluid)
        np.testing.assert_allclose(np.asarray(velocity), expected, rtol=0, atol=1e-13)
        assert np.abs(expected).max() > 1e-3  # the check is not trivial


def _invert_first_element(system):
    element = system.cell.mesh.elements[0]
    system.positions[element[0]] = system.positions[element[1:4]].mean(axis=0) * 2 - system.positions[element[0]]


def _poison_fluid(system):
    system.lattice.set_population_deviations(np.full((19,) + system.lattice.shape, np.nan))


@pytest.mark.parametrize("backend", ["numba", "jax"])
@pytest.mark.parametrize("damage, message, steps_done", [(_invert_first_element, "inverted", 0),
                                                          (_poison_fluid, "non-finite", 1)])
def test_failures_stop_the_chunk_with_flow_error_on_both_backends(coarse_cells, backend, damage, message, steps_done):
    # Reference: the Numba path's semantics. A node pushed through its element makes det F <= 0: the chunk stops
    # before the first step. Non-finite populations give NaN marker velocities in the first (here also the last)
    # step of the chunk: the step is counted and the fluid is reported non-finite.
    cell = coarse_cells["p1", "neo-hookean", "none"]
    params = shear_scenario.ShearFlowParameters(capillary_number=0.05, resolution=3.0, confinement=0.3, box_length=4.0,
                                      backend=backend)
    system = shear_scenario.shear_setup(cell, params)
    damage(system)
    with pytest.raises(markers.FlowError, match=message):
        system.advance(1 if damage is _poison_fluid else 5)
    assert system.time_step == steps_done
