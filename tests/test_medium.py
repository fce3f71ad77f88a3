"""Shear-thinning medium and rectangular channels: kernels against the NumPy reference, closed forms, presets.

References: the power-law slab profile u(y) and flow rate (closed form, lattice.rheology), the Newtonian duct
series (White, Viscous Fluid Flow, eqs. 3-48/3-49), Kozicki et al.'s square-duct relation for power-law liquids
(exact at n = 1, an approximation otherwise), dclab's MC-PBS viscosity. Figures vs resolution:
validation/medium.py -> docs/validation/medium.md.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from numba import njit

from elastocell.body.cell import Cell
from elastocell.lattice import Lattice, LatticeParams
from elastocell.lattice.kernels import _tabulated_tau  # the reader the Numba kernels inline
from elastocell.lattice.reference import reference_step
from elastocell.lattice.rheology import (
    TABLE_HEADER,
    TABLE_MAX_NODES,
    TABLE_TOLERANCE,
    PowerLaw,
    local_relaxation_time,
    relaxation_time_table,
    tube_flow_rate,
)
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.medium import KOZICKI_SQUARE, mc_pbs, medium
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.pipe import (
    PipeFlowParameters,
    channel_geometry,
    channel_profile,
    duct_error,
    duct_flow_rate,
    finite_difference_duct_flow_rate,
    pipe_lattice_units,
    power_law_slab_error,
    run_pipe,
)


# ----------------------------------------------------------------------------------------- kernels
@pytest.mark.parametrize("backend", ["numba", "jax"])
@pytest.mark.parametrize("collision", ["trt", "bgk"])
def test_power_law_step_equals_the_reference_step(collision, backend):
    """Reference: the NumPy step with the same per-node tau (float64), walls, solid nodes and a force field.
    Measured max difference 3.3e-16 (JAX) and 1.7e-14 (Numba, whose tau is read from the law's table, relative error
    about 4e-11 at n = 0.6); the power law moves the populations by 3.2e-3 from the Newtonian step at the reference
    tau, so the test sees the per-node tau."""
    if backend == "jax":
        pytest.importorskip("jax")
        from elastocell.lattice.jax_backend import JaxLattice as lattice_class
    else:
        lattice_class = Lattice
    rng = np.random.default_rng(1)
    shape = (5, 6, 7)
    solid = np.zeros(shape, bool)
    solid[:, :, 0] = True
    solid[2, 3, 4] = True
    params = LatticeParams(shape, relaxation_time=0.9, collision=collision, dtype="float64", solid=solid,
                           body_force=(1e-4, 2e-5, 0.0), wall_velocity=(0.01, -0.01),
                           rheology=PowerLaw.matching(0.6, 0.1, 1e-3))
    lattice = lattice_class(params)
    lattice.initialize(velocity=rng.normal(0, 0.01, (3,) + shape))
    force = rng.normal(0, 1e-4, (3,) + shape)
    lattice.set_force_density(force)
    f = newtonian = lattice.populations.copy()
    newtonian_params = LatticeParams(shape, relaxation_time=0.9, collision=collision, dtype="float64", solid=solid,
                                     body_force=(1e-4, 2e-5, 0.0), wall_velocity=(0.01, -0.01))
    for _ in range(3):
        f = reference_step(f, params, force)
        newtonian = reference_step(newtonian, newtonian_params, force)
    lattice.step(3)
    assert np.abs(lattice.populations - f)[:, ~solid].max() < 1e-13
    assert np.abs(newtonian - f)[:, ~solid].max() > 1e-3


def test_local_tau_spans_the_law_and_is_clamped():
    """tau from the Halley solve equals the root of 3K gdot^n + gdot/2 = m (bisection); the clamp holds."""
    law = PowerLaw(0.5, 0.01, 0.52, 10.0)
    m = np.logspace(-8, 0, 40)
    tau = law.relaxation_time(m)
    gdot = m / tau
    inside = (tau > 0.52) & (tau < 10.0)
    assert inside.sum() > 10 and (~inside).sum() > 0  # both regimes are exercised
    residual = 3 * law.consistency * gdot[inside] ** law.flow_index + gdot[inside] / 2 - m[inside]
    assert np.abs(residual / m[inside]).max() < 1e-6
    assert tau.min() >= 0.52 and tau.max() <= 10.0
    assert local_relaxation_time(np.array(0.0), 0.03, 0.5, 0.52, 10.0) == 10.0  # fluid at rest: tau_max


@njit(error_model="numpy")
def _read_table(log_m, table, tau_min, tau_max):
    out = np.empty_like(log_m)
    for i in range(log_m.size):
        out[i] = _tabulated_tau(log_m[i], table, 0, tau_min, tau_max)
    return out


@pytest.mark.parametrize("flow_index", [0.1, 0.2, 1 / 3, 0.4, 0.5, 0.586, 0.8, 0.95, 0.99, 0.999, 1.0, 1.001, 1.3, 2.0])
def test_the_kernels_tau_table_is_the_root_to_its_measured_error(flow_index):
    """Reference: the clamped root of 3K gdot^n + gdot/2 = m by Halley steps polished to round-off (8 instead of
    3), over every m from the floor 1e-20 to 1e20 (and beyond: held there), at consistencies whose nominal tau
    lies inside the clamp and beyond it (viscosity 3.5 and 0.005: at n = 0.999 and 1.001 the law is then at one
    clamp for every m, a table of one tau). Tolerance: float64 TABLE_TOLERANCE (measured worst 1.4e-10, at n =
    1/2), float32 1.2e-7 (measured 5.9e-8: tau rounded to float32). A wrong slope in the table leaves errors of
    order h^2 = 2e-4."""
    for viscosity in (1e-3, 0.005, 0.1, 1.0, 3.5):
        law = PowerLaw.matching(flow_index, viscosity, 1e-3)
        three_k = 3.0 * law.consistency
        table = relaxation_time_table(three_k, flow_index, 0.52, 10.0)
        log_m = np.linspace(math.log(1e-20), math.log(1e20), 100_001)
        exact = local_relaxation_time(np.exp(log_m), three_k, flow_index, 0.52, 10.0, iterations=8)
        for dtype, tolerance in ((np.float64, TABLE_TOLERANCE), (np.float32, 1.2e-7)):
            read = _read_table(log_m, table.astype(dtype), 0.52, 10.0)
            assert np.abs(read / exact - 1).max() < tolerance, (viscosity, dtype)
        below, above = _read_table(np.array([-1e3, 1e3]), table, 0.52, 10.0)
        assert below == pytest.approx(exact[0], rel=TABLE_TOLERANCE)  # at rest: the floor's tau
        assert above == pytest.approx(exact[-1], rel=TABLE_TOLERANCE)
        assert np.isnan(_read_table(np.array([np.nan]), table, 0.52, 10.0)[0])  # a blown-up node stays NaN
        assert table.size <= TABLE_HEADER + 2 * TABLE_MAX_NODES


def test_power_law_of_index_one_is_the_newtonian_fluid():
    """n = 1 with K = nu: tau = 3K + 1/2 at every node, the Newtonian step up to the root solve's round-off
    (measured: identical, 0.0, in float64 after 200 steps in a square duct)."""
    shape, solid, _, _ = channel_geometry("square", 4.0, 1.0, 3)
    lattices = [Lattice(LatticeParams(shape, relaxation_time=0.8, dtype="float64", solid=solid,
                                      body_force=(1e-5, 0.0, 0.0), rheology=law))
                for law in (None, PowerLaw(1.0, 0.1))]
    for lattice in lattices:
        lattice.step(200)
    u0, u1 = (lattice.velocity()[0] for lattice in lattices)
    assert u0.max() > 0 and np.abs(u1 - u0).max() < 1e-12 * u0.max()


# ----------------------------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("flow_index", [1.0, 0.6])
def test_power_law_slab_against_the_closed_form(flow_index):
    """Slab of 16 nodes, half-way walls. Measured: n = 1 profile exact to 4e-11 (TRT magic 3/16), flow rate
    +0.20 % (the node sum of a parabola); n = 0.6 profile L2 0.41 %, flow rate -0.21 %, second order in dx
    (8 nodes: 1.7 %, -0.83 %; 32: 0.10 %, -0.05 %)."""
    err = power_law_slab_error(16, flow_index)
    assert abs(err["flow_rate_error"]) < 0.003
    assert err["profile_l2_error"] < (1e-8 if flow_index == 1.0 else 0.006)
    coarse = power_law_slab_error(8, flow_index)
    assert abs(coarse["flow_rate_error"]) > 3 * abs(err["flow_rate_error"])  # converges (~4x per doubling)


def test_newtonian_square_duct_against_the_series():
    """Series of White eqs. 3-48/3-49. Measured: a = 4 dx flow rate +1.41 %, profile L2 0.40 %; a = 8 dx
    +0.37 %, 0.088 % (second order)."""
    err = duct_error(8.0)
    assert abs(err["flow_rate_error"]) < 0.005
    assert err["profile_l2_error"] < 0.0012
    assert duct_flow_rate(1.0, 1.0, 1.0, 1.0) / 16 == pytest.approx(0.035144, rel=1e-4)  # Q eta/(G W^4)


def test_power_law_square_duct_flow_rate_against_kozicki_and_finite_volumes():
    """Reference: an independent finite-volume solution of the same clamped law (32^2 cells; 0.094 % from the
    Newtonian series at 64^2). Measured (n = 0.6, a = 8 dx): lattice vs finite volumes +1.1e-4; both lie 5.1 %
    above Kozicki et al.'s (1966) Q = a^3 (G a/(2K))^(1/n)/(b + a_k/n), an approximation for n != 1 (5.4 % at
    n = 0.586, 11.5 % at n = 0.4 in validation/medium.py)."""
    n, a = 0.6, 8.0
    shape, _, a, b = channel_geometry("square", a, 1.0, 1)
    nu, rate = 1.0 / 6.0, 1e-3
    law = PowerLaw.matching(n, nu, rate)
    g = 2 * nu * rate / a
    q = channel_profile(shape, "square", a, b, g, 1.0, law).sum()
    ak, bk = KOZICKI_SQUARE
    q_kozicki = a**3 * (g * a / (2 * law.consistency)) ** (1 / n) / (bk + ak / n)
    assert q / q_kozicki - 1 == pytest.approx(0.051, abs=0.01)
    q_fv = finite_difference_duct_flow_rate(law, g, a, b, 32)
    assert q / q_fv - 1 == pytest.approx(0.0, abs=1e-3)
    newtonian = PowerLaw(1.0, nu)
    assert finite_difference_duct_flow_rate(newtonian, g, a, b, 64) / duct_flow_rate(g, nu, a, b) - 1 == (
        pytest.approx(0.0, abs=2e-3))


def test_power_law_tube_error_follows_the_newtonian_staircase():
    """Closed form Q = pi n/(3n+1) (G/2K)^(1/n) R^(3+1/n). The staircase cylinder's error is first order and
    erratic in R; measured at R = 8 dx: Newtonian +4.68 %, n = 0.586 +4.55 % (validation/medium.py)."""
    nu, rate, radius = 1.0 / 6.0, 1e-3, 8.0
    shape, _, a, b = channel_geometry("cylinder", radius, 1.0, 1)
    errors = []
    for n in (1.0, 0.586):
        law = PowerLaw.matching(n, nu, rate)
        g = 2 * nu * rate / radius
        q = channel_profile(shape, "cylinder", a, b, g, 1.0, law).sum()
        errors.append(q / tube_flow_rate(g, law.consistency, n, radius) - 1)
    assert errors[0] == pytest.approx(0.0468, abs=0.002)
    assert errors[1] == pytest.approx(errors[0], abs=0.005)


# ----------------------------------------------------------------------------------------- presets
def test_mc_pbs_presets_match_dclab():
    """Reference: dclab's get_viscosity_mc_pbs_buyukurganci_2022 (mPa s) at dclab's own wall shear rate."""
    viscosity = pytest.importorskip("dclab.features.emodulus.viscosity")
    for name, dclab_name in (("0.49%MC-PBS", "0.49% MC-PBS"), ("0.59%MC-PBS", "0.59% MC-PBS"),
                             ("0.83%MC-PBS", "0.83% MC-PBS")):
        for temperature in (22.0, 23.0, 30.0):
            fluid = mc_pbs(name, temperature)
            rate = viscosity.shear_rate_square_channel(0.04, 20.0, fluid.flow_index)
            expected = viscosity.get_viscosity_mc_pbs_buyukurganci_2022(dclab_name, 20.0, 0.04, temperature)
            assert fluid.viscosity(rate) * 1e3 == pytest.approx(expected, rel=1e-12)
    assert 0.5 < mc_pbs("0.59%MC-PBS", 23).flow_index < 0.7
    assert medium("0.59% MC-PBS").name == "0.59%MC-PBS"


@pytest.mark.parametrize(("args", "parameter"), [
    (("ketchup",), "medium"), (("0.59%MC-PBS", 150.0), "temperature"), (("newtonian", None, 0.5), "flow_index"),
    (("power-law",), "flow_index"), (("power-law", None, 5.0), "flow_index"),
])
def test_impossible_media_are_refused(args, parameter):
    with pytest.raises(ParameterError) as info:
        medium(*args)
    assert info.value.parameter == parameter


def test_preset_outside_its_fit_warns():
    with pytest.warns(UserWarning, match="extrapolated"):
        mc_pbs("0.49%MC-PBS", 40.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mc_pbs("0.49%MC-PBS", 23.0)


# ----------------------------------------------------------------------------------------- pipe scenario
SMALL = dict(resolution=4, channel_radius_ratio=2.5, box_length=6)


@pytest.fixture(scope="module")
def cell():
    return Cell.from_parameters(cell_parameters(nucleus="none", element="p1", mesh_size=0.6, pole_size=0.6))


@pytest.mark.parametrize(("options", "parameter"), [
    (dict(channel_shape="square", channel_aspect_ratio=2.0), "channel_aspect_ratio"),
    (dict(channel_shape="rectangle", channel_aspect_ratio=0.3), "channel_aspect_ratio"),
    (dict(medium="honey"), "medium"),
])
def test_pipe_refuses_impossible_channels_and_media(options, parameter):
    with pytest.raises(ValueError, match=f"{parameter}: "):
        PipeFlowParameters(capillary_number_wall=0.5, **SMALL, **options)


def test_square_channel_units_follow_the_duct_series(cell):
    """The empty square channel's lattice flow rate against the series at the same G (measured +1.1 % at
    a = 10 dx, the lattice's second-order error) and the centre speed 2 kappa gdot_w a (kappa = 0.2947)."""
    params = PipeFlowParameters(capillary_number_wall=0.5, channel_shape="square", **SMALL)
    units = pipe_lattice_units(cell, params)
    a = units.channel_radius
    assert units.channel_half_height == a == 10.0
    profile = channel_profile(units.shape, "square", a, a, units.body_force, units.relaxation_time, None)
    q = duct_flow_rate(units.body_force, units.viscosity, a, a)
    assert profile.sum() / q - 1 == pytest.approx(0.0, abs=0.02)
    assert units.centre_speed == pytest.approx(2 * 0.29468 * units.wall_shear_rate * a, rel=1e-4)
    assert profile.max() / units.centre_speed == pytest.approx(1.0, abs=0.01)


def test_cell_in_a_square_channel_of_mc_pbs(cell):
    """A centred cell in a square channel of 0.59 % MC-PBS: stays on the axis, moves downstream and is
    stretched along the flow (eps_x > 1) in 2/gdot_w; the empty channel's centre speed is below the Newtonian
    one at the same G and wall viscosity (shear thinning flattens the profile: measured 0.79)."""
    newtonian = pipe_lattice_units(cell, PipeFlowParameters(capillary_number_wall=0.5, channel_shape="square",
                                                            **SMALL))
    params = PipeFlowParameters(capillary_number_wall=0.5, channel_shape="square", medium="0.59%MC-PBS", **SMALL)
    result = run_pipe(cell, params, duration=2.0, record_interval=0.5)
    s = result.summary
    assert result.units.rheology is not None and s["flow_index"] == pytest.approx(mc_pbs("0.59%MC-PBS").flow_index)
    assert 0.6 < result.units.centre_speed / newtonian.centre_speed < 0.95
    assert s["radial_position"] < 0.01
    assert s["axial_position" if "axial_position" in s else "axial_velocity_mean"] > 0
    assert s["strain_axial_mean"] > 1.0
    assert math.isfinite(s["volume_change_max_abs"]) and s["volume_change_max_abs"] < 0.05


def test_every_dclab_name_of_an_mc_pbs_buffer_is_its_preset():
    """Reference: dclab's own alias table (``ALIAS_MEDIA``). Each of its names of an MC-PBS buffer ("CellCarrier B",
    "0.6% MC-PBS", ...) is the same preset here, so `lut --medium CellCarrierB` is the table dclab converts with;
    water is no preset of the lattice (its viscosity is Newtonian: --viscosity)."""
    from dclab.features.emodulus.viscosity import ALIAS_MEDIA

    from elastocell.parameters.medium import canonical_name

    buffers = {alias: name for alias, name in ALIAS_MEDIA.items() if "MC-PBS" in name}
    assert len(buffers) >= 20
    for alias, name in buffers.items():
        assert canonical_name(alias) == name.replace(" ", ""), alias
    with pytest.raises(ParameterError, match="unknown medium"):
        canonical_name("honey")
