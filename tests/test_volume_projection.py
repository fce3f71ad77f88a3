"""The volume projection of the immersed cell (``volume_correction="projection"``): the enclosed volume and its
gradient, the projection step, and a pipe run that holds its volume where the plain one leaks."""

from __future__ import annotations

import numpy as np
import pytest

import elastocell
from elastocell.body.cell import Cell
from elastocell.body.mesh import outward_surface_triangles
from elastocell.body.observables import moments
from elastocell.coupling import immersed
from elastocell.scenarios.pipe import PipeFlowParameters, pipe_lattice_units, pipe_setup, run_pipe


@pytest.fixture(scope="module")
def cell():
    return Cell.from_parameters(elastocell.cell_parameters(nucleus="none", element="p1", mesh_size=0.5,
                                                           pole_size=0.5))


def _strained(cell, seed=0, size=0.05):
    x = 5.0 + 3.0 * cell.mesh.nodes
    return x + size * np.random.default_rng(seed).standard_normal(x.shape)


def test_the_enclosed_volume_is_the_tetrahedra_and_its_gradient_the_finite_difference(cell):
    # References: the volume of the tetrahedra (observables.moments) and central differences. V is linear in each
    # single coordinate, so the difference is exact but for round-off: measured 1.3e-8 at h = 1e-6 (V ~ 100).
    faces = outward_surface_triangles(cell.mesh.elements)
    x = _strained(cell)
    gradient = np.zeros_like(x)
    volume = immersed._enclosed_volume(x, faces, gradient)
    assert volume == pytest.approx(moments(x, cell.mesh.elements).volume, rel=1e-12)
    np.testing.assert_allclose(gradient.sum(axis=0), 0.0, atol=1e-12)  # a closed surface: no net gradient
    scratch, h = np.zeros_like(x), 1e-6
    for node in np.random.default_rng(1).choice(np.unique(faces), 6, replace=False):
        for axis in range(3):
            plus, minus = x.copy(), x.copy()
            plus[node, axis] += h
            minus[node, axis] -= h
            difference = (immersed._enclosed_volume(plus, faces, scratch)
                          - immersed._enclosed_volume(minus, faces, scratch)) / (2 * h)
            assert difference == pytest.approx(gradient[node, axis], abs=1e-7)


def test_the_projection_restores_the_volume_and_moves_only_the_surface_without_moving_the_centroid(cell):
    # A 0.6 % volume change (far above a step's leak, ~1e-7) is restored to second order in it: measured 1.3e-5
    # after one projection, 2e-10 after two; the surface moves along the gradient, whose sum is zero, so the mean
    # of the nodes stays (round-off, 1e-15).
    faces = outward_surface_triangles(cell.mesh.elements)
    surface = np.unique(faces)
    gradient = np.zeros((cell.mesh.n_nodes, 3))
    target = immersed._enclosed_volume(5.0 + 3.0 * cell.mesh.nodes, faces, gradient)
    x = _strained(cell)
    before = x.copy()
    change = immersed._enclosed_volume(x, faces, gradient) / target - 1
    assert abs(change) > 3e-3
    restored = immersed._project_volume(x, faces, surface, gradient, target)
    assert restored == pytest.approx(-change * target, rel=1e-12)
    assert abs(immersed._enclosed_volume(x, faces, gradient) / target - 1) < 3e-5
    immersed._project_volume(x, faces, surface, gradient, target)
    assert abs(immersed._enclosed_volume(x, faces, gradient) / target - 1) < 1e-9
    interior = np.setdiff1d(np.arange(cell.mesh.n_nodes), surface)
    np.testing.assert_array_equal(x[interior], before[interior])
    np.testing.assert_allclose(x.mean(axis=0), before.mean(axis=0), atol=1e-13)
    at_target = x.copy()
    immersed._project_volume(x, faces, surface, gradient, target)  # at the target: (almost) nothing to do
    assert np.abs(x - at_target).max() < 1e-9


def test_the_option_is_left_out_of_the_dump_when_off_and_refused_where_it_cannot_run():
    # the keys of runs made before the choice existed stay: "none" is not in the dump
    assert "volume_correction" not in PipeFlowParameters(capillary_number_wall=0.5).model_dump()
    assert PipeFlowParameters(capillary_number_wall=0.5,
                              volume_correction="projection").model_dump()["volume_correction"] == "projection"
    with pytest.raises(ValueError, match="Numba"):  # pydantic wraps the ParameterError
        PipeFlowParameters(capillary_number_wall=0.5, volume_correction="projection", backend="jax")
    with pytest.raises(ValueError):
        PipeFlowParameters(capillary_number_wall=0.5, volume_correction="penalty")
    quadratic = Cell.from_parameters(elastocell.cell_parameters(nucleus="none", element="p2", mesh_size=0.6,
                                                                pole_size=0.6))
    params = PipeFlowParameters(capillary_number_wall=0.5, resolution=4, channel_radius_ratio=2.5, box_length=6,
                                volume_correction="projection")
    with pytest.raises(ValueError, match="linear elements"):
        pipe_setup(quadratic, params, pipe_lattice_units(quadratic, params))


@pytest.mark.slow
def test_a_pipe_run_with_the_projection_holds_the_volume_the_plain_run_loses(cell):
    # The same soft cell (Ca_w 0.8, R/dx 4, square duct) with and without the projection for 3 units of 1/gdot_w.
    # Measured: the plain run's volume grows by 1.18e-3 (the immersed boundary's leak), the projected run's
    # changes by 5.8e-13 (round-off of the sum of the tetrahedra), and the projection took out 2.3e-3 V0 (its
    # `volume_restored` -2.28e-3: the leak adds volume). Tolerances: 1e-9 for the projected run; the plain run must
    # leak more than 5e-4 (else the check would show nothing); the restored volume within a factor 5 of the leak.
    common = dict(capillary_number_wall=0.8, resolution=4, channel_radius_ratio=2.5, box_length=6,
                  channel_shape="square", dtype="float64")
    plain = run_pipe(cell, PipeFlowParameters(**common), duration=3.0, record_interval=0.5)
    projected = run_pipe(cell, PipeFlowParameters(**common, volume_correction="projection"), duration=3.0,
                         record_interval=0.5)
    assert plain.summary["volume_change_max_abs"] > 5e-4
    assert "volume_restored" not in plain.summary
    assert projected.summary["volume_change_max_abs"] < 1e-9
    restored = projected.summary["volume_restored"]
    assert 0.2 < abs(restored) / plain.summary["volume_change_max_abs"] < 5
