"""``elastocell indent`` on the 3D solver (:mod:`elastocell.scenarios.indentation_3d`): the choice of the solver,
the exact contact's invariants, the 3D force against the axisymmetric solver, the heterogeneous cells it exists
for (energy bounds), interruption and resume. The default mesh's error is measured by
``validation/indentation_3d.py`` (docs/validation/indentation.md); these tests run coarse meshes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from elastocell.body.cell import Cell
from elastocell.cli.app import app
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.indentation import (
    POLE_RADIUS_3D,
    POLE_SIZE_FACTOR_3D,
    indentation_cell_3d,
    indentation_curve,
    indentation_geometry,
    indentation_solver,
)
from elastocell.scenarios.indentation_3d import Indentation3DInterrupted, indent_3d

runner = CliRunner()
COARSE = {"mesh_size": 0.6, "pole_size": 0.2}  # 600 nodes (p2)
BEAD = 0.5


def coarse_cell(**options) -> Cell:
    return Cell.from_parameters(cell_parameters(**options, **COARSE))


@pytest.mark.parametrize("options,shape,solver,expected", [
    ({"nucleus": "none"}, "sphere", "auto", "axisymmetric"),
    ({}, "sphere", "auto", "axisymmetric"),  # the centred reference nucleus
    ({"random": True}, "sphere", "auto", "3d"),
    ({"offset": 0.2, "offset_axis": "y"}, "sphere", "auto", "3d"),
    ({"offset": 0.2, "offset_axis": "z"}, "sphere", "auto", "axisymmetric"),
    ({"nucleus": "ellipsoid"}, "sphere", "auto", "3d"),  # its first semi-axis along x
    ({"nucleus": "none"}, "sphere", "3d", "3d"),
    ({"nucleus": "none", "mesh_size": 0.3}, "sphere", "3d", "3d"),
])
def test_the_solver_is_chosen_by_the_cell(options, shape, solver, expected):
    geometry, _ = indentation_geometry(shape, BEAD)
    assert indentation_solver(solver, cell_parameters(**options), geometry) == expected


@pytest.mark.parametrize("options,shape,solver,option", [
    ({"random": True}, "cap", "auto", "random"),  # the 3D solver runs the suspended sphere only
    ({"nucleus": "none"}, "cap", "3d", "solver"),
    ({"random": True}, "sphere", "axisymmetric", "random"),
    ({"nucleus": "none", "mesh_size": 0.3}, "sphere", "auto", "mesh_size"),  # the 3D mesh on the meridian path
    ({"nucleus": "none"}, "sphere", "2d", "solver"),
])
def test_impossible_solver_choices_name_the_option(options, shape, solver, option):
    geometry, _ = indentation_geometry(shape, BEAD, cap_height=1.0 if shape == "cap" else None)
    with pytest.raises(ParameterError) as error:
        indentation_solver(solver, cell_parameters(**options), geometry)
    assert error.value.parameter == option


def test_the_3d_indentation_refines_the_default_pole_size_only():
    default = cell_parameters(nucleus="none")
    assert indentation_cell_3d(default).mesh.pole_size == pytest.approx(default.mesh.pole_size * POLE_SIZE_FACTOR_3D)
    given = cell_parameters(nucleus="none", pole_size=0.1)
    assert indentation_cell_3d(given).mesh.pole_size == 0.1
    assert indentation_cell_3d(default).mesh.mesh_size == default.mesh.mesh_size
    # the p2 poles' refinement reaches further (POLE_RADIUS_3D) unless a pole radius or size is given; p1 keeps
    # its own
    assert indentation_cell_3d(default).mesh.pole_radius == POLE_RADIUS_3D
    assert indentation_cell_3d(cell_parameters(nucleus="none", pole_radius=1.0)).mesh.pole_radius == 1.0
    assert indentation_cell_3d(given).mesh.pole_radius == given.mesh.pole_radius
    linear = cell_parameters(nucleus="none", element="p1")
    assert indentation_cell_3d(linear).mesh.pole_radius == linear.mesh.pole_radius


@pytest.mark.slow
def test_contact_is_exact_and_the_curve_resumes():
    """Homogeneous cell, coarse mesh, bead 0.5 R to depth 0.1 R in 2 steps. Invariants of the exact contact:
    no surface node inside the bead or below the dish (to round-off), the bead's force equal to the dish's
    (equilibrium of the free body; the pins hold no z dof), the force at depth 0.1 R within the coarse mesh's
    error of the axisymmetric solver (measured +14.5 % at 0.05 R, +13.4 % at 0.1 R on this 600-node mesh, the
    coarse 3D mesh being too stiff; the tolerance 20 %). A curve interrupted after its first row and resumed ends where
    the uninterrupted one does (measured: equal to 1e-9)."""
    cell = coarse_cell(nucleus="none")
    result = indent_3d(cell, BEAD, 0.1, steps=2)
    np.testing.assert_allclose(result.force_support[1:], result.force[1:], rtol=1e-6)
    x = result.positions[-1]
    centre = np.array([0.0, 0.0, 1.0 + BEAD - 0.1])
    assert (np.linalg.norm(x - centre, axis=1) >= BEAD - 1e-10).all()
    assert (x[:, 2] >= -1 - 1e-10).all()
    assert result.contact_radius[-1] > 0.05
    axisymmetric = indentation_curve(cell_parameters(nucleus="none"), "sphere", BEAD, depth_max=0.1, steps=2)
    error = result.force[1:] / axisymmetric.force[1:] - 1
    print("3D / axisymmetric - 1:", error)
    assert np.all((error > 0) & (error < 0.2))

    def stop_after_first_row(rows):
        if len(rows.load) == 2:
            raise KeyboardInterrupt

    with pytest.raises(Indentation3DInterrupted) as interrupted:
        indent_3d(cell, BEAD, 0.1, steps=2, on_row=stop_after_first_row)
    partial = interrupted.value.partial
    assert len(partial.load) == 2
    resumed = indent_3d(cell, BEAD, 0.1, steps=2, resume_from=partial)
    np.testing.assert_allclose(resumed.load, result.load)
    np.testing.assert_allclose(resumed.force, result.force, rtol=1e-6)


@pytest.mark.slow
def test_random_cell_energy_lies_between_the_homogeneous_bounds(tmp_path):
    """The random cell (E_e/E_c ~ U[1, 10]) through the CLI (auto: the 3D solver), coarse mesh, to depth 0.1 R.
    Reference: the energy is E times a function of the deformation and the feasible set does not depend on the
    moduli, so the minimum energy at a depth is monotone in every element's modulus: W_hom(E_c) <= W <=
    W_hom(10 E_c) on the same mesh (exact bounds, no tolerance beyond round-off). Measured: W/W_hom 5.40 and 5.17,
    F/F_hom 5.24 and 5.04 at depth 0.05 and 0.1 (E_eff/E_c = 5.91 on this mesh)."""
    out = tmp_path / "random"
    result = runner.invoke(app, ["indent", "--out", str(out), "--indenter-radius", "0.5", "--random",
                                 "--mesh-size", "0.6", "--pole-size", "0.2", "--depth-max", "0.1", "--steps", "2",
                                 "--quiet"])
    assert result.exit_code == 0, result.output
    metadata = json.loads((out / "metadata.json").read_text())
    assert metadata["solver"]["solver"] == "3d" and metadata["solver"]["requested"] == "auto"
    assert metadata["complete"] and metadata["mesh"]["element"] == "10-node tetrahedron"
    table = np.genfromtxt(out / "indentation.csv", delimiter=",", names=True)
    assert (out / "vtk" / "indentation.pvd").exists() and (out / "indentation.png").stat().st_size > 0

    random = coarse_cell(random=True, seed=0)
    homogeneous = coarse_cell(nucleus="none")
    curve = indent_3d(random, BEAD, 0.1, steps=2)
    reference = indent_3d(homogeneous, BEAD, 0.1, steps=2)
    np.testing.assert_allclose(table["force_per_Ec_R2"], curve.force, rtol=1e-6)
    energy = np.array([random.energy(x) for x in curve.positions[1:]])
    energy_hom = np.array([homogeneous.energy(x) for x in reference.positions[1:]])
    ratio = energy / energy_hom
    print("W/W_hom", ratio, "F/F_hom", curve.force[1:] / reference.force[1:], "E_eff", random.effective_stiffness_ratio)
    assert np.all((ratio >= 1) & (ratio <= random.youngs_moduli.max()))
    assert np.all(curve.force[1:] > reference.force[1:])


@pytest.mark.slow
def test_an_interrupted_3d_curve_resumes_from_its_checkpoint(tmp_path, monkeypatch):
    """``elastocell.indent`` interrupted after its first row keeps it in ``checkpoint.npz`` (metadata
    ``complete: false``); ``resume=True`` continues to the last row and removes the checkpoint; a resume with
    other options is refused naming --resume; a complete curve is read back."""
    import elastocell.api.indentation as api
    from elastocell.scenarios.axisymmetric import AxisymmetricInterrupted

    real = api.indent_3d

    def interrupted_after_first_row(*args, on_row=None, **kwargs):
        def stop(rows):
            on_row(rows)
            if len(rows.load) == 2:
                raise KeyboardInterrupt

        return real(*args, on_row=stop, **kwargs)

    options = {"indenter_radius": 0.5, "random": True, "depth_max": 0.1, "steps": 2, "progress": False, **COARSE}
    out = tmp_path / "curve"
    monkeypatch.setattr(api, "indent_3d", interrupted_after_first_row)
    with pytest.raises(AxisymmetricInterrupted, match="--resume"):
        api.indent(out, **options)
    monkeypatch.setattr(api, "indent_3d", real)
    assert json.loads((out / "metadata.json").read_text())["complete"] is False
    assert (out / "checkpoint.npz").exists()
    first = np.genfromtxt(out / "indentation.csv", delimiter=",", names=True)
    with pytest.raises(ParameterError) as error:
        api.indent(out, **{**options, "steps": 3}, resume=True)
    assert error.value.parameter == "resume"
    summary = api.indent(out, **options, resume=True)
    assert summary["complete"] and not (out / "checkpoint.npz").exists()
    table = np.genfromtxt(out / "indentation.csv", delimiter=",", names=True)
    assert len(table) == 3
    np.testing.assert_array_equal(table[:2], first)
    assert api.indent(out, **options, resume=True)["fingerprint"] == summary["fingerprint"]


@pytest.mark.slow
def test_no_surface_corner_lifts_into_a_dimple_under_the_bead_or_on_the_dish():
    """A 6-node triangle's corner takes no share of a uniform pressure (docs/theory.md, 'Contact of quadratic
    surfaces'): released by the sign of its own multiplier, corners inside the contact lifted off (measured on this
    mesh at depth 0.1 R: 6 of the 12 corners among mid-side nodes on the bead, gaps up to 9.7e-4 R; 12 of 18 on the
    dish, up to 4.1e-4 R). Every such corner lies on its obstacle, to round-off."""
    from elastocell.body.mesh import corners_surrounded, surface_corner_edges

    cell = Cell.from_parameters(cell_parameters(nucleus="none", mesh_size=0.4, pole_size=0.05))
    result = indent_3d(cell, BEAD, 0.1, steps=4)
    x = result.positions[-1]
    corners, edge_nodes = surface_corner_edges(cell.mesh.elements)
    bead = np.linalg.norm(x - [0.0, 0.0, 1.0 + BEAD - result.load[-1]], axis=1) - BEAD
    for gap in (bead, x[:, 2] + 1.0):
        on = np.zeros(cell.mesh.n_nodes, dtype=bool)
        on[cell.mesh.surface_nodes] = np.abs(gap[cell.mesh.surface_nodes]) < 1e-9
        inside = corners_surrounded(on, corners, edge_nodes)
        assert inside.sum() >= 10
        assert np.abs(gap[inside]).max() < 1e-9
