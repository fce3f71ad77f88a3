"""The axisymmetric solver (body.axisymmetric, scenarios.axisymmetric): meridian mesh and energy of a body of
revolution, exact frictionless contact with plates and a sphere, and its physics against closed forms (patch
test, Hertz) and the 3D solver."""

from __future__ import annotations

import numpy as np
import pytest

from elastocell.body.axisymmetric import (
    AxisymmetricCell,
    MeridianMesh,
    MeridianMeshParameters,
    meridian_nucleus,
    shape_functions,
    triangle_rule,
)
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.units import ParameterError


def rectangle_mesh(nr: int = 4, nz: int = 5, height: float = 1.0, distortion: float = 0.2, seed: int = 0):
    """A 6-node triangle mesh of the meridian rectangle [0, 1] x [-height/2, height/2] (a solid cylinder of radius
    1), interior vertices moved at random by ``distortion`` of a cell, edge nodes at the edge midpoints."""
    rng = np.random.default_rng(seed)
    r = np.linspace(0, 1, 2 * nr + 1)
    z = np.linspace(-height / 2, height / 2, 2 * nz + 1)
    grid = np.stack(np.meshgrid(r, z, indexing="ij"), axis=-1)
    interior = np.zeros(grid.shape[:2], dtype=bool)
    interior[2:-2:2, 2:-2:2] = True
    cell = np.array([1 / nr, height / nz])
    grid[interior] += distortion * cell * rng.uniform(-1, 1, (interior.sum(), 2))
    grid[1::2, ::2] = 0.5 * (grid[:-1:2, ::2] + grid[2::2, ::2])
    grid[::2, 1::2] = 0.5 * (grid[::2, :-1:2] + grid[::2, 2::2])
    grid[1::2, 1::2] = 0.5 * (grid[:-1:2, :-1:2] + grid[2::2, 2::2])
    index = np.arange(grid.shape[0] * grid.shape[1]).reshape(grid.shape[:2])
    elements = []
    for i in range(nr):
        for j in range(nz):
            a, b, c, d = index[2 * i, 2 * j], index[2 * i + 2, 2 * j], index[2 * i + 2, 2 * j + 2], index[2 * i, 2 * j + 2]
            ab, bc, ca = index[2 * i + 1, 2 * j], index[2 * i + 2, 2 * j + 1], index[2 * i + 1, 2 * j + 1]
            cd, da = index[2 * i + 1, 2 * j + 2], index[2 * i, 2 * j + 1]
            elements += [(a, b, c, ab, bc, ca), (a, c, d, ca, cd, da)]
    nodes = grid.reshape(-1, 2)
    return MeridianMesh(nodes=nodes, elements=np.array(elements), region=np.zeros(len(elements), dtype=np.int8),
                        surface_nodes=np.flatnonzero(np.isclose(nodes[:, 0], 1.0)),
                        axis_nodes=np.flatnonzero(nodes[:, 0] == 0.0))


def neo_hookean_cauchy(stretches, youngs_modulus=1.0, poisson_ratio=0.48):
    """sigma = mu J^(-5/3) dev(b) + kappa (J - 1) I of the decoupled neo-Hookean law, for F = diag(stretches)."""
    mu = youngs_modulus / (2 * (1 + poisson_ratio))
    kappa = youngs_modulus / (3 * (1 - 2 * poisson_ratio))
    b = np.asarray(stretches, dtype=float) ** 2
    volume_ratio = float(np.prod(stretches))
    return mu * volume_ratio ** (-5 / 3) * (b - b.sum() / 3) + kappa * (volume_ratio - 1)


def test_triangle_rule_and_shape_functions():
    """The collapsed Gauss-Jacobi rule integrates x^a y^b exactly (a! b! / (a + b + 2)!) to degree 2n - 1; the
    6-node shape functions are a partition of unity, interpolate at their nodes and reproduce linear fields."""
    from math import factorial

    for n in (2, 3, 4):
        points, weights = triangle_rule(n)
        for a in range(2 * n):
            for b in range(2 * n - a):
                exact = factorial(a) * factorial(b) / factorial(a + b + 2)
                assert weights @ (points[:, 0] ** a * points[:, 1] ** b) == pytest.approx(exact, rel=1e-13, abs=1e-16)
    nodes = np.array([[0, 0], [1, 0], [0, 1], [0.5, 0], [0.5, 0.5], [0, 0.5]])
    values, gradients = shape_functions(nodes)
    np.testing.assert_allclose(values, np.eye(6), atol=1e-15)
    points = triangle_rule(3)[0]
    values, gradients = shape_functions(points)
    np.testing.assert_allclose(values.sum(axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(np.einsum("qk,kj->qj", values, nodes), points, atol=1e-14)
    np.testing.assert_allclose(np.einsum("qki,kj->qij", gradients, nodes), np.broadcast_to(np.eye(2), (9, 2, 2)).transpose(0, 2, 1),
                               atol=1e-14)


@pytest.mark.parametrize("stretches", [(1.1, 0.85), (0.9, 1.2)])
def test_patch_uniform_stretch_of_a_cylinder_gives_the_exact_stress(stretches):
    """Patch test on a distorted mesh of a solid cylinder (radius 1, height 1): r = lambda_r R, z = lambda_z Z is
    the exact solution for the tractions it needs (F = diag(lambda_r, lambda_z, lambda_r) everywhere, hoop stretch
    r/R = lambda_r). Every node off the loaded faces is force-free, the z ring force (dE/dx, the load applied) on the top face is
    sigma_zz pi lambda_r^2 and the r force on the mantle sigma_rr 2 pi lambda_r lambda_z (sigma the closed-form
    Cauchy stress of the neo-Hookean law), and E = W V: all to round-off (measured <= 4e-15 relative; 1e-12)."""
    mesh = rectangle_mesh()
    cell = AxisymmetricCell(cell_parameters(nucleus="none"), mesh, np.ones(mesh.n_elements))
    assert cell.volume == pytest.approx(np.pi, rel=1e-14)
    lr, lz = stretches
    x = mesh.nodes * np.array([lr, lz])
    forces = cell.internal_forces(x)
    sigma = neo_hookean_cauchy((lr, lz, lr))
    top = np.isclose(mesh.nodes[:, 1], 0.5)
    bottom = np.isclose(mesh.nodes[:, 1], -0.5)
    mantle = np.isclose(mesh.nodes[:, 0], 1.0)
    scale = abs(sigma).max() * np.pi
    inside = ~(top | bottom | mantle)
    assert np.abs(forces[inside]).max() < 1e-12 * scale
    assert np.abs(forces[(top | bottom) & ~mantle, 0]).max() < 1e-12 * scale  # no shear on the faces
    assert forces[top, 1].sum() == pytest.approx(sigma[1] * np.pi * lr**2, rel=1e-12)
    assert forces[bottom, 1].sum() == pytest.approx(-sigma[1] * np.pi * lr**2, rel=1e-12)
    assert forces[mantle, 0].sum() == pytest.approx(sigma[0] * 2 * np.pi * lr * lz, rel=1e-12)
    mu, kappa = 1 / (2 * 1.48), 1 / (3 * (1 - 0.96))
    volume_ratio = lr * lr * lz
    density = mu / 2 * (volume_ratio ** (-2 / 3) * (2 * lr**2 + lz**2) - 3) + kappa / 2 * (volume_ratio - 1) ** 2
    assert cell.energy(x) == pytest.approx(density * np.pi, rel=1e-12)


def test_a_pole_carries_none_of_a_uniform_pressure():
    """Why the contact holds a pole on a plate while its neighbour is held (scenarios.axisymmetric): under a
    uniform axial stress the ring force of the top face's axis node is zero, int_0^1 (1 - s)(1 - 2 s) s ds = 0
    (measured 4e-17 of the face's force; asserted 1e-12), while the face's other nodes carry all of it."""
    mesh = rectangle_mesh(distortion=0.0)
    cell = AxisymmetricCell(cell_parameters(nucleus="none"), mesh, np.ones(mesh.n_elements))
    forces = cell.internal_forces(mesh.nodes * np.array([1.0, 0.9]))
    top = np.flatnonzero(np.isclose(mesh.nodes[:, 1], 0.5))
    pole = top[mesh.nodes[top, 0] == 0.0]
    total = forces[top, 1].sum()
    assert abs(forces[pole, 1]).max() < 1e-12 * abs(total)
    assert np.all(np.abs(forces[np.setdiff1d(top, pole), 1]) > 1e-3 * abs(total))


def test_stiffness_is_the_derivative_of_the_forces():
    """The assembled element stiffness times a random direction equals the central difference of the forces
    (step 1e-6: the measured mismatch is 1e-8 of the largest entry, the difference's own truncation error)."""
    mesh = rectangle_mesh(3, 3)
    cell = AxisymmetricCell(cell_parameters(nucleus="none", material="mooney-rivlin"), mesh,
                            np.where(np.arange(mesh.n_elements) % 3 == 0, 5.0, 1.0))
    rng = np.random.default_rng(1)
    x = mesh.nodes * np.array([0.95, 1.1]) + 0.01 * rng.standard_normal(mesh.nodes.shape)
    x[mesh.axis_nodes, 0] = 0.0
    stiffness = cell.stiffness_pattern.assemble(cell.element_stiffness(x))
    direction = rng.standard_normal(x.size)
    step = 1e-6
    difference = (cell.internal_forces((x.ravel() + step * direction).reshape(-1, 2))
                  - cell.internal_forces((x.ravel() - step * direction).reshape(-1, 2))).ravel() / (2 * step)
    assert np.abs(stiffness @ direction - difference).max() < 1e-6 * np.abs(difference).max()


def test_meridian_mesh_has_the_volumes_of_cell_and_nucleus():
    """The curved 6-node mesh of the half-disk gives the ball's and the nucleus's volumes (revolved) to 1e-5
    (measured -2.2e-6 and 6.2e-7 on these sizes: the quadratic arcs' geometric error)."""
    parameters = cell_parameters(nucleus="ellipsoid", semi_axes=(0.6, 0.4, 0.4), nucleus_axis="z", offset=0.2,
                                 offset_axis="z")
    cell = AxisymmetricCell.from_parameters(parameters, MeridianMeshParameters(mesh_size=0.2, surface_size=0.05, pole_size=0.05,
                                                                                interface_size=0.08))
    assert cell.volume == pytest.approx(4 / 3 * np.pi, rel=1e-5)
    assert cell.element_volumes[cell.mesh.region == 1].sum() == pytest.approx(4 / 3 * np.pi * 0.6 * 0.4**2, rel=1e-5)
    assert np.all(cell.mesh.nodes[cell.mesh.axis_nodes, 0] == 0.0)
    np.testing.assert_allclose(np.linalg.norm(cell.mesh.nodes[cell.mesh.surface_nodes], axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("options, parameter", [
    ({"offset": 0.2}, "offset_axis"),
    ({"offset": 0.2, "offset_axis": "y"}, "offset_axis"),
    ({"nucleus": "ellipsoid"}, "nucleus_axis"),
    ({"nucleus": "ellipsoid", "nucleus_axis": "y", "semi_axes": (0.6, 0.4, 0.4)}, "nucleus_axis"),
    ({"random": True}, "random"),
])
def test_a_cell_not_axisymmetric_about_z_is_refused(options, parameter):
    with pytest.raises(ParameterError) as error:
        meridian_nucleus(cell_parameters(**options))
    assert error.value.parameter == parameter and "\n" not in str(error.value)


def test_cells_axisymmetric_about_z_are_accepted():
    assert meridian_nucleus(cell_parameters(nucleus="none")) is None
    assert meridian_nucleus(cell_parameters()) == (0.5, 0.5, 0.0)
    assert meridian_nucleus(cell_parameters(offset=0.2, offset_axis="z")) == (0.5, 0.5, 0.2)
    assert meridian_nucleus(cell_parameters(nucleus="ellipsoid", semi_axes=(0.7, 0.4, 0.4), nucleus_axis="z")) == (
        0.4, 0.7, 0.0)


HERTZ_MESH = MeridianMeshParameters(mesh_size=0.1, surface_size=0.02, pole_size=0.0025, pole_radius=0.3)


@pytest.mark.slow
def test_plates_small_deformation_tends_to_hertz():
    """Homogeneous cell between plates: F/F_Hertz (two contacts, 4/(3(1-nu^2)) delta^1.5) at delta = 0.005, 0.01,
    0.015, 0.02. Measured on this mesh (pole size 0.0025): 1.024, 1.039, 1.046, 1.054; with pole size 0.005: 1.030,
    1.038, 1.044, 1.052 (the node-to-plate discretisation moves the ratio by <= 0.6 %). The excess over Hertz shrinks
    with delta roughly like delta^(1/2) (the finite size of the ball adds a deflection linear in F to the Hertz
    approach): the test asserts each ratio within [1, 1 + 0.4 delta^(1/2) + 0.01] (0.038, 0.050, 0.059, 0.067) and
    that the excess at 0.005 is below the one at 0.02; the lower plate carries the same force to 1e-8."""
    from elastocell.scenarios.axisymmetric import compress_axisymmetric
    from elastocell.scenarios.compression import hertz_force

    result = compress_axisymmetric(cell_parameters(nucleus="none"), delta_max=0.02, steps=4, mesh=HERTZ_MESH)
    ratio = result.force[1:] / hertz_force(result.load[1:])
    print("F/F_Hertz", np.round(ratio, 5))
    assert np.all(ratio > 1) and np.all(ratio < 1 + 0.4 * np.sqrt(result.load[1:]) + 0.01)
    assert ratio[0] < ratio[-1]
    np.testing.assert_allclose(result.force_support[1:], result.force[1:], rtol=1e-8)


@pytest.mark.slow
def test_sphere_indentation_tends_to_hertz_in_series_with_the_dish():
    """A rigid sphere (R_b = 0.5 R) pressed into the homogeneous cell resting on a rigid dish: F(depth) against
    Hertz's two contacts in series (R_eff = R_b R/(R_b + R) at the sphere, R at the dish, depth the sum of both
    approaches). Measured at depth 0.005-0.02 (pole size 0.0025): 1.018, 1.018, 1.017, 1.023; pole size 0.005:
    1.005, 1.015, 1.025, 1.024 (each node entering contact moves the ratio by ~1 %: the contact radius at depth
    0.005 is 0.04 R, 16 edge nodes). Tolerance: within [0.99, 1.04] at every depth; the dish carries the same force
    to 1e-8."""
    from elastocell.scenarios.axisymmetric import hertz_sphere_indentation_force, indent_axisymmetric

    result = indent_axisymmetric(cell_parameters(nucleus="none"), 0.5, depth_max=0.02, steps=4, mesh=HERTZ_MESH)
    ratio = result.force[1:] / hertz_sphere_indentation_force(result.load[1:], 0.5)
    print("F/F_Hertz", np.round(ratio, 5))
    assert np.all((ratio > 0.99) & (ratio < 1.04))
    np.testing.assert_allclose(result.force_support[1:], result.force[1:], rtol=1e-8)
    assert 0 < result.contact_radius[-1] < 0.2


@pytest.mark.slow
def test_refinement_changes_the_force_little():
    """Reference cell (gamma 2, lambda 0.5), meshes scaled 1.4 and 1 from the defaults (1,537 and 2,688 nodes):
    measured F = 0.072772/0.072670 at delta 0.1 (0.14 %), 0.524126/0.524023 at 0.3 (0.02 %); the next finer mesh
    (0.7, 4,969 nodes) is within 0.06 % and 0.006 % of the default. Asserted: 0.3 % and 0.1 %."""
    from elastocell.scenarios.axisymmetric import compress_axisymmetric

    forces = []
    for factor in (1.4, 1.0):
        result = compress_axisymmetric(cell_parameters(), delta_max=0.3, steps=6,
                                       mesh=MeridianMeshParameters().scaled(factor))
        forces.append(result.force[[2, 6]])
    change = np.abs(forces[0] / forces[1] - 1)
    print("relative change", change)
    assert change[0] < 3e-3 and change[1] < 1e-3


@pytest.mark.slow
def test_three_dimensional_solver_agrees_within_its_discretisation_error():
    """The 3D solver (scenarios.compression, p2 tetrahedra, mesh 0.5 with poles 0.12, 1,263 nodes) against the
    axisymmetric one (default meridian mesh) on the homogeneous cell at delta = 0.1 and 0.3. The 3D mesh's own
    error, against its finest mesh (docs/validation/compression.md), is +1.88 % and +1.10 %; measured here
    +1.92 % and +1.18 % (the axisymmetric F is itself within 0.28 % and 0.01 % of the 3D Richardson limit).
    Asserted: the 3D force above the axisymmetric one by less than 2.5 % and 1.5 %."""
    from elastocell.body.cell import Cell
    from elastocell.scenarios.axisymmetric import compress_axisymmetric
    from elastocell.scenarios.compression import CompressionParameters, compress

    axisymmetric = compress_axisymmetric(cell_parameters(nucleus="none"), delta_max=0.3, steps=6)
    three = compress(Cell.from_parameters(cell_parameters(nucleus="none", mesh_size=0.5, pole_size=0.12)),
                     CompressionParameters(delta_max=0.3, steps=6))
    excess = three.force[[2, 6]] / axisymmetric.force[[2, 6]] - 1
    print("3D over axisymmetric", excess)
    assert 0 < excess[0] < 0.025 and 0 < excess[1] < 0.015


@pytest.mark.slow
@pytest.mark.parametrize("options", [dict(offset=0.2, offset_axis="z"),
                                     dict(nucleus="ellipsoid", semi_axes=(0.6, 0.4, 0.4), nucleus_axis="z")])
def test_offset_and_spheroidal_nuclei_compress_with_balanced_plate_forces(options):
    """A nucleus offset along z and a prolate spheroid along z: the curve runs and both plates carry the same
    force (equilibrium, 1e-8), stiffer than the homogeneous cell."""
    from elastocell.scenarios.axisymmetric import compress_axisymmetric

    coarse = MeridianMeshParameters().scaled(1.4)
    result = compress_axisymmetric(cell_parameters(stiffness_ratio=5, **options), delta_max=0.2, steps=4, mesh=coarse)
    homogeneous = compress_axisymmetric(cell_parameters(nucleus="none"), delta_max=0.2, steps=4, mesh=coarse)
    np.testing.assert_allclose(result.force_support[1:], result.force[1:], rtol=1e-8)
    assert np.all(result.force[1:] > homogeneous.force[1:])


@pytest.mark.slow
def test_a_stiff_nucleus_compresses_to_delta_075_with_the_poles_on_the_plates():
    """Stiffness ratio 20, size ratio 0.5, on the meridian mesh 4 times coarser than the default (288 nodes), 20
    steps: the curve reaches delta 0.75 (measured: it stopped at 0.631 when a pole's contact followed the sign of
    its own multiplier, whose consistent share of a uniform pressure is zero; the pole left the plate and its
    element folded), both poles lie on their plates at every row (gap < 1e-12 R) and both plates carry the same
    force (equilibrium; measured 1.3e-10 relative, asserted 1e-8), growing with delta."""
    from elastocell.scenarios.axisymmetric import compress_axisymmetric

    cell = AxisymmetricCell.from_parameters(cell_parameters(stiffness_ratio=20, size_ratio=0.5),
                                            MeridianMeshParameters().scaled(4))
    result = compress_axisymmetric(cell, delta_max=0.75, steps=20)
    assert result.load[-1] == pytest.approx(0.75)
    nodes = cell.mesh.nodes
    top, bottom = (int(np.flatnonzero((nodes[:, 0] == 0) & np.isclose(nodes[:, 1], z))[0]) for z in (1.0, -1.0))
    np.testing.assert_allclose(result.positions[:, top, 1], 1 - 2 * result.load, atol=1e-12)
    np.testing.assert_allclose(result.positions[:, bottom, 1], -1.0, atol=1e-12)
    np.testing.assert_allclose(result.force_support[1:], result.force[1:], rtol=1e-8)
    assert np.all(np.diff(result.force) > 0)


# ------------------------------------------------------------------------------------------- compress --axisymmetric
@pytest.fixture
def coarse_meridian_mesh(monkeypatch):
    """``compress --axisymmetric`` on a meridian mesh 4 times coarser than the default (every size x 4)."""
    import elastocell.api.compression as api

    monkeypatch.setattr(api, "MeridianMeshParameters", lambda: MeridianMeshParameters().scaled(4))


@pytest.mark.slow
def test_compress_axisymmetric_writes_the_files_of_compress(tmp_path, coarse_meridian_mesh):
    """The CLI path: the columns of compression.csv, the metadata naming the solver and the meridian mesh, the
    comparison with the equivalent (E_eff the exact volume average of the body of revolution: 1 + (gamma - 1)
    lambda^3 = 1.125, to the mesh's volume error), and the same forces as compress_axisymmetric itself."""
    import json

    from typer.testing import CliRunner

    from elastocell.cli.app import app
    from elastocell.scenarios.axisymmetric import compress_axisymmetric

    out = tmp_path / "run"
    result = CliRunner().invoke(app, ["compress", "--out", str(out), "--axisymmetric", "--delta-max", "0.1",
                                      "--steps", "2", "--stiffness-ratio", "2", "--radius", "8um",
                                      "--youngs-modulus", "1kPa", "--compare", "--quiet"])
    assert result.exit_code == 0, result.output
    assert (out / "compression.csv").read_text().splitlines()[0] == "delta,force,force_per_Ec_R2,force_per_Eeff_R2"
    table = np.genfromtxt(out / "compression.csv", delimiter=",", names=True)
    metadata = json.loads((out / "metadata.json").read_text())
    assert metadata["solver"]["name"] == "axisymmetric" and metadata["complete"]
    assert metadata["mesh"]["n_nodes"] > 0 and metadata["mesh"]["n_nucleus_elements"] > 0
    assert metadata["effective_stiffness_ratio"] == pytest.approx(1.125, rel=2e-3)
    np.testing.assert_allclose(table["force"], table["force_per_Ec_R2"] * 1e3 * (8e-6) ** 2, rtol=1e-9)
    np.testing.assert_allclose(table["force_per_Eeff_R2"], table["force_per_Ec_R2"] / metadata["effective_stiffness_ratio"])
    direct = compress_axisymmetric(cell_parameters(stiffness_ratio=2), 0.1, 2, mesh=MeridianMeshParameters().scaled(4))
    np.testing.assert_allclose(table["force_per_Ec_R2"], direct.force, rtol=1e-8)
    equivalent = json.loads((out / "equivalent" / "metadata.json").read_text())
    assert equivalent["equivalent"] and equivalent["solver"]["name"] == "axisymmetric"
    assert np.all(np.isfinite(np.genfromtxt(out / "comparison.csv", delimiter=",", names=True)["force_ratio"][1:]))
    assert not (out / "checkpoint.npz").exists() and not (out / "vtk").exists()


@pytest.mark.parametrize("arguments, named", [
    (["--random"], "--random"),
    (["--offset", "0.2"], "--offset-axis"),
])
def test_compress_axisymmetric_refuses_a_cell_not_symmetric_about_z_in_one_line(tmp_path, arguments, named):
    from typer.testing import CliRunner

    from elastocell.cli.app import app

    result = CliRunner().invoke(app, ["compress", "--out", str(tmp_path / "x"), "--axisymmetric", *arguments])
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and named in lines[0] and "axisymmetric" in lines[0], result.output
    assert not (tmp_path / "x").exists()


def test_compress_axisymmetric_interrupted_then_resumed_equals_the_whole_curve(tmp_path, coarse_meridian_mesh,
                                                                               monkeypatch):
    """Ctrl-C after the second row: the converged rows are written with "complete": false and a checkpoint;
    --resume continues from it to the rows of an uninterrupted curve (same load steps; to the solver's
    tolerance 1e-9)."""
    import json

    import elastocell.api.compression as api
    from elastocell.scenarios.axisymmetric import compress_axisymmetric

    original = api.compress_axisymmetric

    def interrupted(*args, on_row=None, **kwargs):
        def stop_after_two(rows):
            on_row(rows)
            if len(rows.load) == 3:
                raise KeyboardInterrupt

        return original(*args, on_row=stop_after_two, **kwargs)

    out = tmp_path / "run"
    monkeypatch.setattr(api, "compress_axisymmetric", interrupted)
    with pytest.raises(api.CompressionInterrupted):
        api.compress(out, axisymmetric=True, delta_max=0.15, steps=3, nucleus="none", progress=False)
    metadata = json.loads((out / "metadata.json").read_text())
    assert not metadata["complete"] and metadata["interrupted_at_delta"] == pytest.approx(0.1)
    assert (out / "checkpoint.npz").exists()
    monkeypatch.setattr(api, "compress_axisymmetric", original)
    with pytest.raises(ParameterError, match="resume"):  # another curve's checkpoint
        api.compress(out, axisymmetric=True, delta_max=0.15, steps=4, nucleus="none", progress=False, resume=True)
    summary = api.compress(out, axisymmetric=True, delta_max=0.15, steps=3, nucleus="none", progress=False,
                           resume=True)
    assert summary["complete"] and not (out / "checkpoint.npz").exists()
    table = np.genfromtxt(out / "compression.csv", delimiter=",", names=True)
    whole = compress_axisymmetric(cell_parameters(nucleus="none"), 0.15, 3, mesh=MeridianMeshParameters().scaled(4))
    np.testing.assert_allclose(table["force_per_Ec_R2"], whole.force, rtol=1e-7, atol=1e-12)
