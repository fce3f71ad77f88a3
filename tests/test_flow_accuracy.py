"""The immersed boundary's hydrodynamic radius and its correction (elastocell.coupling.held,
elastocell.coupling.markers.marker_radius, ShearFlowParameters.hydrodynamic_radius_correction).

Reference: Stokes' torque on a sphere held in simple shear, T_z = -4 pi eta R^3 gdot (Kim & Karrila,
Microhydrodynamics, 1991); the walls (2R/H = 0.2) and periodic images (box 8R) change it by ~1e-3.
validation/flow_accuracy.py measures the same problem at R/dx = 4, 6, 8 (docs/validation/flow_accuracy.md).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import elastocell
from elastocell.body import observables
from elastocell.body.cell import Cell
from elastocell.coupling import ibm
from elastocell.coupling.held import HeldMarkers
from elastocell.coupling.markers import marker_radius
from elastocell.scenarios import shear as shear_scenario


@pytest.fixture(scope="module")
def coarse_cell():
    """Homogeneous p1 ball, 78 nodes (mesh size 0.5 R: edges of 2 dx at R/dx = 4)."""
    return Cell.from_parameters(elastocell.cell_parameters(nucleus="none", element="p1", mesh_size=0.5,
                                                           pole_size=0.5))


def test_markers_lie_at_the_corrected_radius_and_the_cell_starts_at_rest(coarse_cell):
    # Reference: the mesh's surface nodes lie on the unit sphere, so the markers' largest distance from the
    # centre is R - c exactly (round-off).
    params = shear_scenario.ShearFlowParameters(capillary_number=0.1, resolution=4,
                                                hydrodynamic_radius_correction=0.3)
    run = shear_scenario.ShearRun(coarse_cell, params)
    distance = np.linalg.norm(run.system.positions - run.units.centre, axis=1)
    assert distance.max() == pytest.approx(3.7, abs=1e-12)
    assert run.system.radius == pytest.approx(3.7)
    # the centre columns are in units of the marker radius: the first record is the mesh's own centroid
    centroid = observables.moments(coarse_cell.mesh.nodes, coarse_cell.mesh.elements).centre
    assert run.series["centre_x"][0] == pytest.approx(centroid[0], abs=1e-12)
    assert run.series["centre_y"][0] == pytest.approx(centroid[1], abs=1e-12)
    assert marker_radius(8.0) == 8.0


@pytest.mark.parametrize("value", [-0.1, 2.0, float("nan")])
def test_an_impossible_correction_names_the_parameter(value):
    with pytest.raises(ValueError, match="hydrodynamic_radius_correction"):
        shear_scenario.ShearFlowParameters(capillary_number=0.1, resolution=4, hydrodynamic_radius_correction=value)
    with pytest.raises(ValueError):
        marker_radius(4.0, value)


def _held_sphere_torque(cell, correction: float, steps: int = 960) -> float:
    params = shear_scenario.ShearFlowParameters(capillary_number=0.05, resolution=4, dtype="float64")
    units = shear_scenario.shear_lattice_units(cell, params)
    lattice = shear_scenario.shear_setup(cell, params, units).lattice
    sphere = HeldMarkers(lattice, units.centre + marker_radius(4.0, correction) * cell.mesh.nodes)
    sphere.advance(steps)
    # held: the fluid velocity at the markers is a small fraction of the shear velocity across the sphere
    slip = np.abs(ibm.interpolate_lattice_velocity(lattice, sphere.positions)).max()
    assert slip < 0.01 * units.shear_rate * 4.0
    return float(sphere.torque(units.centre)[2] / (-4.0 * math.pi * units.viscosity * units.shear_rate * 4.0**3))


def test_held_sphere_with_corrected_markers_has_the_nominal_hydrodynamic_radius(coarse_cell):
    # Measured (validation/flow_accuracy.py --only torque --resolutions 4 --corrections 0.3; R/dx = 4, trilinear,
    # edges 2 dx, 960 steps): T/T_Stokes = 0.9827 with the markers at R - 0.3 dx (1.2445 at R: the test below).
    # Tolerance 2.5 %: the measured 1.7 % and the 0.2 % still to settle after 960 steps.
    torque = _held_sphere_torque(coarse_cell, 0.3)
    assert torque == pytest.approx(1.0, abs=0.025)


@pytest.mark.slow
def test_held_sphere_hydrodynamic_radius_exceeds_the_marker_radius(coarse_cell):
    # Measured (validation/flow_accuracy.py --only torque --resolutions 4): T/T_Stokes = 1.2445 with the markers
    # at R (R_h = R + 0.30 dx; 1.2417 fully settled after 3000 steps). A 24 % excess: the uncorrected immersed
    # boundary is a larger sphere. Tolerance 0.01 (the settling).
    torque = _held_sphere_torque(coarse_cell, 0.0)
    assert torque == pytest.approx(1.2445, abs=0.01)
