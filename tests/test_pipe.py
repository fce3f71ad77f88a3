"""Pipe (capillary) flow: the empty channel against Poiseuille, and a cell carried through it.

Tiny lattices (R = 4 dx, R_ch = 10 dx, 24 x 22 x 22 nodes) and a coarse p1 mesh (49 nodes) keep every
coupled run to a few seconds; the physics figures at the default resolution are in validation/pipe.py.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from elastocell.api.pipe import pipe
from elastocell.body.cell import Cell
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.flow import flow_cell
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.pipe import (
    PIPE_COLUMNS,
    PipeFlowParameters,
    PipeRun,
    channel_shape,
    channel_solid,
    empty_channel,
    flow_rate,
    migration_time,
    pipe_lattice_units,
    poiseuille_error,
    poiseuille_flow_rate,
    poiseuille_velocity,
    relax_to_steady,
    run_pipe,
)
from elastocell.simulation.runner import StopCriteria

SMALL = dict(resolution=4, channel_radius_ratio=2.5, box_length=6)


@pytest.fixture(scope="module")
def cell():
    return Cell.from_parameters(cell_parameters(nucleus="none", element="p1", mesh_size=0.6, pole_size=0.6))


# ----------------------------------------------------------------------------------------- empty channel
def test_closed_form():
    g, eta, r_ch = 2e-6, 0.2, 5.0
    r = np.linspace(0, r_ch, 2001)
    u = poiseuille_velocity(r, g, eta, r_ch)
    assert u[0] == pytest.approx(g * r_ch**2 / (4 * eta))
    assert u[-1] == 0.0
    q = np.trapezoid(2 * np.pi * r * u, r)
    assert q == pytest.approx(poiseuille_flow_rate(g, eta, r_ch), rel=1e-6)


def test_channel_mask_is_a_closed_cylinder():
    shape = channel_shape(6.0, 3)
    solid = channel_solid(shape, 6.0)
    assert solid.shape == shape
    assert solid[:, 0, :].all() and solid[:, -1, :].all() and solid[:, :, 0].all() and solid[:, :, -1].all()
    assert (solid == solid[:1]).all()  # invariant along the axis
    assert abs((~solid[0]).sum() / (np.pi * 36) - 1) < 0.05


@pytest.mark.parametrize(
    "radius, flow_rate_tol, profile_tol",
    [
        # measured (float64, tau = 1, steady): Q error +4.68 %, profile L2 error 4.21 % at R_ch = 8 dx
        (8.0, 0.05, 0.045),
        # measured: Q error +0.64 %, profile L2 error 0.95 % at R_ch = 16 dx (the default channel)
        (16.0, 0.01, 0.012),
    ],
)
def test_poiseuille_profile_and_flow_rate(radius, flow_rate_tol, profile_tol):
    """Staircase half-way bounce-back: first-order, non-monotone error (validation/pipe.py has the table)."""
    error = poiseuille_error(radius)
    assert abs(error["flow_rate_error"]) < flow_rate_tol
    assert error["profile_l2_error"] < profile_tol


def test_the_interpolated_wall_makes_poiseuille_flow_second_order():
    """Interpolated bounce-back (Bouzidi et al. 2001), the wall at r = R_ch on every link, against
    u = G (R_ch^2 - r^2)/(4 eta). Measured (float64, tau = 1, steady): profile L2 error 0.578 % at R_ch = 8 dx and
    0.0685 % at 16 dx (apparent order 3.1; the staircase: 4.21 % and 0.95 %), flow-rate error +0.73 % and +0.087 %
    (the sum over the nodes, a quadrature of the smooth profile). Tolerances: 1.25 x the measured errors, and an
    apparent order of at least 2 (second order, the method's)."""
    coarse, fine = (poiseuille_error(radius, wall="interpolated") for radius in (8.0, 16.0))
    assert coarse["profile_l2_error"] < 1.25 * 0.00578 and fine["profile_l2_error"] < 1.25 * 0.000685
    assert abs(coarse["flow_rate_error"]) < 1.25 * 0.0073 and abs(fine["flow_rate_error"]) < 1.25 * 0.00087
    assert np.log2(coarse["profile_l2_error"] / fine["profile_l2_error"]) >= 2.0


def test_the_channel_wall_is_refused_unknown_and_the_staircase_left_out_of_the_dump():
    """The interpolated wall is the default and is said in the dump (its runs are new runs); the staircase, the
    only wall of runs made before the choice, is left out, so that their keys stay valid."""
    assert PipeFlowParameters(capillary_number_wall=0.2).model_dump()["channel_wall"] == "interpolated"
    staircase = PipeFlowParameters(capillary_number_wall=0.2, channel_wall="staircase")
    assert "channel_wall" not in staircase.model_dump()
    duct = PipeFlowParameters(capillary_number_wall=0.2, channel_shape="square", channel_wall="interpolated")
    assert "channel_wall" not in duct.model_dump()  # a duct's plane walls are the same either way
    with pytest.raises(ValueError, match="channel_wall"):
        PipeFlowParameters(capillary_number_wall=0.2, channel_wall="smooth")


# ----------------------------------------------------------------------------------------- parameters
@pytest.mark.parametrize(
    "options, parameter",
    [
        (dict(capillary_number_wall=0.0), "capillary_number_wall"),
        (dict(capillary_number_wall=-1.0), "capillary_number_wall"),
        (dict(capillary_number_wall=float("nan")), "capillary_number_wall"),
        (dict(capillary_number_wall=0.2, channel_radius_ratio=1.0), "channel_radius_ratio"),
        (dict(capillary_number_wall=0.2, channel_radius_ratio=0.8), "channel_radius_ratio"),
        (dict(capillary_number_wall=0.2, channel_radius_ratio=2.0, start_offset=0.5), "start_offset"),
        (dict(capillary_number_wall=0.2, start_offset=-0.1), "start_offset"),
    ],
)
def test_impossible_input_is_refused(options, parameter):
    with pytest.raises(ValueError) as info:
        PipeFlowParameters(**options)
    assert parameter in str(info.value)


def test_wall_margin_is_enforced_before_computing():
    """The cell fits geometrically but the kernel would reach the wall: refused by the parameters."""
    with pytest.raises(ValueError, match="start_offset"):
        PipeFlowParameters(capillary_number_wall=0.2, start_offset=0.55, **SMALL)
    with pytest.raises(ValueError, match="channel_radius_ratio"):
        PipeFlowParameters(capillary_number_wall=0.2, resolution=4, channel_radius_ratio=1.2)


@pytest.mark.parametrize("radius_um", [3.1, 4.5, 5.6, 6.5, 7.3, 7.9])
def test_a_square_duct_lattice_is_the_channel_asked_for(cell, radius_um):
    """The standard table's radii in the 20 um square channel at R/dx 8: the lattice's duct half-width is exactly
    (R_ch/R) R in the run's own units (whole nodes across: rounding the width instead made it 0.4-1.6 % wider or
    1.2 % narrower), the cell's R/dx within 1/(4 R_ch/R) of the resolution asked for."""
    ratio = 10.0 / radius_um
    params = PipeFlowParameters(capillary_number_wall=0.2, resolution=8, channel_radius_ratio=ratio,
                                channel_shape="square", medium="0.59%MC-PBS", temperature=23)
    units = pipe_lattice_units(cell, params)
    assert units.channel_radius == pytest.approx(ratio * units.radius, rel=1e-12)
    assert abs(units.radius - 8) <= 1 / (4 * ratio) + 1e-12


def test_a_pair_extrapolates_with_its_lattices_own_spacing_ratio():
    """Richardson's weight uses the R/dx the two lattices ran at (a duct moves them to whole-node widths: R 5.6 um in
    the 20 um duct runs at 8.12 and 5.88 for the pair 8 and 6), not the pair asked for: D = D_f + (D_f - D_c)/(r^2 -
    1) with r = 8.12/5.88 (exact arithmetic; tolerance round-off); without the lattices' radii, r = 8/6."""
    from elastocell.simulation.extrapolation import extrapolated_summary

    fine, coarse = {"deformation": 0.03, "lattice": {"radius": 8.12}}, {"deformation": 0.026, "lattice": {"radius": 5.88}}
    summary = extrapolated_summary(fine, coarse, ("deformation",), 8.0, 6.0, "the finer run's")
    ratio = 8.12 / 5.88
    assert summary["deformation"] == pytest.approx(0.03 + 0.004 / (ratio**2 - 1), rel=1e-12)
    assert summary["extrapolation"]["ratio"] == pytest.approx(ratio, rel=1e-12)
    nominal = extrapolated_summary({"deformation": 0.03}, {"deformation": 0.026}, ("deformation",), 8.0, 6.0, "")
    assert nominal["deformation"] == pytest.approx(0.03 + 0.004 / ((8 / 6) ** 2 - 1), rel=1e-12)


def test_lattice_units(cell):
    params = PipeFlowParameters(capillary_number_wall=0.2, **SMALL)
    units = pipe_lattice_units(cell, params)
    eta = units.viscosity
    assert units.body_force * units.channel_radius / (2 * units.reference_shear_modulus) == pytest.approx(0.2)
    assert units.wall_shear_rate == pytest.approx(units.body_force * units.channel_radius / (2 * eta))
    assert units.reynolds_number <= params.reynolds_number * (1 + 1e-9)
    assert units.centre_speed <= params.velocity_limit
    assert units.stability_number <= 0.6 + 1e-12


def test_migration_time():
    t = np.arange(5.0)
    assert migration_time(t, [0.4, 0.3, 0.2, 0.1, 0.05]) == pytest.approx(2.0)
    assert np.isnan(migration_time(t, [0.0] * 5))


# ----------------------------------------------------------------------------------------- cell in the channel
@pytest.fixture(scope="module")
def centred_runs(cell):
    """The same cell at two Ca_w (the stiffer one has the smaller Ca_w at the same G), on the axis."""
    return {ca: run_pipe(cell, PipeFlowParameters(capillary_number_wall=ca, **SMALL), duration=4.0,
                         record_interval=0.5) for ca in (0.1, 0.4)}


@pytest.mark.slow
def test_centred_cell_stays_on_the_axis_and_becomes_stationary(centred_runs):
    result = centred_runs[0.1]
    s = result.series
    assert set(PIPE_COLUMNS) <= set(s)
    # measured on the default (interpolated) wall: these numbers, then the tolerances
    assert np.max(s["radial_position"]) < 0.01  # measured 0.0009 R_ch
    # carried by the flow: the body force acts in the coupled steps (measured 0.893 u_max)
    assert 0.6 < result.summary["axial_velocity_mean"] < 1.0
    # stationary: the strains change by less than 1e-3 over the last unit of time (measured 1.4e-4, 1.7e-4)
    for name in ("strain_axial", "strain_radial"):
        assert abs(s[name][-1] - s[name][-3]) < 1e-3
    # axisymmetric within the mesh's own asymmetry: radial (y) and transverse (z) extents agree
    assert abs(s["strain_radial"][-1] - s["strain_transverse"][-1]) < 0.01
    assert abs(result.summary["volume_change_max_abs"]) < 0.01


@pytest.mark.slow
def test_stiffer_cell_deforms_less(centred_runs):
    def distortion(result):
        s = result.series
        return abs(s["strain_axial"][-1] - 1) + abs(s["strain_radial"][-1] - 1)

    # measured at t = 4/gdot_w (interpolated wall): eps_x - 1 = 0.0036 (Ca_w = 0.1) and 0.0197 (Ca_w = 0.4)
    assert distortion(centred_runs[0.1]) < 0.5 * distortion(centred_runs[0.4])
    assert centred_runs[0.1].summary["deformation_mean"] < centred_runs[0.4].summary["deformation_mean"]


@pytest.mark.slow
def test_off_axis_cell_migrates_towards_the_axis(cell):
    params = PipeFlowParameters(capillary_number_wall=0.2, start_offset=0.3, **SMALL)
    result = run_pipe(cell, params, duration=5.0, record_interval=1.0)
    r = result.series["radial_position"]
    assert r[0] == pytest.approx(0.3, abs=0.005)
    assert np.all(np.diff(r[1:]) < 0)  # measured (interpolated wall): 0.299 -> 0.279 over 5/gdot_w
    assert r[-1] < r[0] - 0.015
    assert np.abs(result.series["centre_z"]).max() < 0.005  # stays in the plane of the offset


def test_pipe_api_writes_outputs_and_resumes(tmp_path, cell, monkeypatch):
    monkeypatch.setenv("ELASTOCELL_NO_VTK", "1")
    options = dict(nucleus="none", element="p1", mesh_size=0.6, pole_size=0.6, flow_options=SMALL,
                   record_interval=0.5, checkpoint_every=1, progress=False)
    full = pipe(tmp_path / "full", 0.2, duration=1.5, **options)
    pipe(tmp_path / "part", 0.2, duration=1.0, **options)
    resumed = pipe(tmp_path / "part", 0.2, duration=1.5, resume=True, **options)
    assert resumed["resumed"]
    a = np.genfromtxt(tmp_path / "full" / "timeseries.csv", delimiter=",", names=True)
    b = np.genfromtxt(tmp_path / "part" / "timeseries.csv", delimiter=",", names=True)
    assert len(a) == len(b) == 4
    for name in a.dtype.names:  # deterministic steps, complete checkpoint: bitwise equal (tolerance 0)
        np.testing.assert_array_equal(b[name], a[name], err_msg=name)
    summary = json.loads((tmp_path / "full" / "summary.json").read_text())
    for key in ("strain_axial_mean", "strain_axial_std", "strain_radial_mean", "strain_radial_std",
                "deformation_mean", "projected_area_mean", "radial_position", "lattice", "reynolds_number",
                "wall_time_s"):
        assert key in summary
    assert summary["strain_axial_mean"] == pytest.approx(full["strain_axial_mean"])
    assert (tmp_path / "full" / "pipe.png").exists()
    # timings: this session's wall time, and the stepping time over both sessions of the resumed run
    assert resumed["time_stepping_s"] >= resumed["time_stepping_session_s"] > 0
    assert resumed["wall_time_s"] > 0 and resumed["wall_time_cumulative_s"] > 0


def test_pipe_stationary_stop_and_a_fresh_run_lists_only_its_own_snapshots(tmp_path):
    # A centred cell settles within ~1/gdot_w (strains within 1e-4 of their final values from t = 2 on,
    # test_centred_cell_stays_on_the_axis_and_becomes_stationary): the running mean of eps_x over the last
    # unit of time then changes by far less than 1e-3, so a run asked for 20/gdot_w stops early.
    options = dict(nucleus="none", element="p1", mesh_size=0.6, pole_size=0.6, flow_options=SMALL,
                   record_interval=0.5, checkpoint_every=4, progress=False, vtk_interval=0.5)
    out = tmp_path / "run"
    summary = pipe(out, 0.1, duration=20.0, stationary_tolerance=1e-3, **options)
    assert summary["stop_reason"] == "stationary"
    assert 2.0 <= summary["duration"] < 20.0
    first = sorted(path.name for path in (out / "vtk").glob("cell_*.vtu"))
    assert len(first) == round(summary["duration"] / 0.5) + 1
    # a fresh (not resumed) shorter run in the same directory: the collection lists its 3 snapshots only
    pipe(out, 0.1, duration=1.0, **options)
    assert sorted(path.name for path in (out / "vtk").glob("cell_*.vtu")) == first[:3]
    assert (out / "vtk" / "cell.pvd").read_text().count("<DataSet") == 3
    assert (out / "vtk" / "fluid.pvd").read_text().count("<DataSet") == 3
    with pytest.raises(ParameterError, match="stationary_observable"):
        pipe(tmp_path / "x", 0.1, stationary_tolerance=1e-3, stationary_observable="volume_change", **options)
    with pytest.raises(ParameterError, match="stationary_observable"):  # read by nothing without a tolerance
        pipe(tmp_path / "y", 0.1, stationary_observable="deformation", **options)
    assert not (tmp_path / "y").exists()


def test_checkpoint_refuses_other_parameters(tmp_path, cell):
    run = PipeRun(cell, PipeFlowParameters(capillary_number_wall=0.2, **SMALL), record_interval=0.5)
    run.save(tmp_path / "c.npz")
    other = PipeRun(cell, PipeFlowParameters(capillary_number_wall=0.3, **SMALL), record_interval=0.5)
    with pytest.raises(ParameterError, match="resume"):
        other.load(tmp_path / "c.npz")


def test_a_checkpoint_written_before_the_side_view_columns_continues_with_nan_for_its_records(tmp_path, cell):
    # A checkpoint of the same layout version but without the columns PIPE_ADDED_COLUMNS names (written before
    # they existed) loads: those columns are NaN for its records and measured from the next record on.
    from elastocell.scenarios.pipe import PIPE_ADDED_COLUMNS

    params = PipeFlowParameters(capillary_number_wall=0.2, **SMALL)
    run = PipeRun(cell, params, record_interval=0.5)
    run.save(tmp_path / "c.npz")
    with np.load(tmp_path / "c.npz") as data:
        arrays = {name: data[name] for name in data.files if name.removeprefix("series_") not in PIPE_ADDED_COLUMNS}
    np.savez(tmp_path / "old.npz", **arrays)
    resumed = PipeRun(cell, params, record_interval=0.5)
    resumed.load(tmp_path / "old.npz")
    assert all(np.isnan(resumed.series[name]).all() for name in PIPE_ADDED_COLUMNS)
    resumed.advance_record()
    assert np.isfinite(resumed.series["deformation_views"][-1])
    assert resumed.series["outline_fallback_views"][-1] == 0.0
    assert len(resumed.series["deformation_views"]) == len(resumed.series["time"])
    summary = resumed.summary(transient=0.0)  # the window holds the record from before the resume:
    # no views mean rather than a partial one
    assert np.isnan(summary["deformation_views_mean"]) and np.isfinite(summary["deformation_mean"])
    other = {k: v for k, v in arrays.items() if k != "series_deformation"}  # a column that was always there
    np.savez(tmp_path / "damaged.npz", **other)
    with pytest.raises(ParameterError, match="resume"):
        PipeRun(cell, params, record_interval=0.5).load(tmp_path / "damaged.npz")


def test_the_side_views_averaged_are_those_the_channel_makes_equivalent():
    # A cylinder's centred cell is axisymmetric: every azimuth; a square duct's has its four-fold symmetry: the
    # views along z (RT-DC's camera) and y; a rectangle's only its own view along z; an off-axis cell's too.
    from elastocell.body.observables import OUTLINE_VIEWS
    from elastocell.scenarios.pipe import equivalent_side_views

    def views(**options):
        return equivalent_side_views(PipeFlowParameters(capillary_number_wall=0.2, **options))

    assert (views(), views(channel_shape="square"), views(channel_shape="rectangle", channel_aspect_ratio=1.5),
            views(start_offset=0.2), views(channel_shape="square", start_offset=0.2)) == (OUTLINE_VIEWS, 2, 1, 1, 1)


def test_checkpoint_fingerprint_ignores_field_order_and_a_sweep_restarts_a_stale_checkpoint(tmp_path, cell,
                                                                                        monkeypatch):
    # The fingerprint is of the parameter values, not of their declaration order; a checkpoint another version
    # wrote is refused by --resume but a sweep (resume_or_restart) starts that run afresh.
    from elastocell.simulation.runner import resume_or_restart

    params = PipeFlowParameters(capillary_number_wall=0.2, **SMALL)
    run = PipeRun(cell, params, record_interval=0.5)
    shuffled = PipeFlowParameters(**dict(reversed(list(params.model_dump().items()))))
    assert PipeRun(cell, shuffled, record_interval=0.5).fingerprint() == run.fingerprint()
    monkeypatch.setenv("ELASTOCELL_NO_VTK", "1")
    options = dict(capillary_number_wall=0.2, nucleus="none", element="p1", mesh_size=0.6, pole_size=0.6,
                   flow_options=SMALL, record_interval=0.5, progress=False, duration=0.5)
    out = tmp_path / "run"
    pipe(out, **options)
    with np.load(out / "checkpoint.npz") as data:
        arrays = dict(data)
    arrays["version"] = np.array(1)
    np.savez(out / "checkpoint.npz", **arrays)
    with pytest.raises(ParameterError, match="resume"):
        pipe(out, resume=True, **options)
    summary = resume_or_restart(pipe, out, **options)
    assert not summary["resumed"] and summary["duration"] == pytest.approx(0.5)


def test_a_sweep_restarts_only_the_run_of_a_pair_whose_checkpoint_cannot_continue(tmp_path):
    """resume_or_restart on an extrapolated pair whose coarser run's checkpoint another version wrote: that run
    starts afresh, the finer one continues from its own checkpoint (reference: each part's ``resumed`` flag and
    duration; before, both runs started again)."""
    from elastocell.simulation.runner import resume_or_restart

    options = dict(capillary_number_wall=0.2, nucleus="none", mesh_size=0.6, pole_size=0.6, resolution=5,
                   extrapolate=True, coarse_resolution=4, channel_radius_ratio=2.5, record_interval=0.1,
                   progress=False, vtk_interval=None)
    out = tmp_path / "run"
    pipe(out, duration=0.2, **options)
    stale = out / "resolution-4" / "checkpoint.npz"
    with np.load(stale) as data:
        arrays = dict(data)
    arrays["version"] = np.array(1)
    np.savez(stale, **arrays)
    with pytest.raises(ParameterError, match="resume") as refusal:
        pipe(out, duration=0.3, resume=True, **options)
    assert refusal.value.checkpoint == stale
    resume_or_restart(pipe, out, duration=0.3, **options)
    fine, coarse = (json.loads((out / part / "summary.json").read_text()) for part in ("resolution-5", "resolution-4"))
    assert fine["resumed"] and not coarse["resumed"]
    assert fine["duration"] == pytest.approx(0.3) and coarse["duration"] == pytest.approx(0.3)


@pytest.mark.parametrize(
    "arguments, option",
    [
        (["--capillary-number-wall", "-0.1"], "--capillary-number-wall"),
        (["--capillary-number-wall", "0.2", "--channel-radius-ratio", "1"], "--channel-radius-ratio"),
        (["--capillary-number-wall", "0.2", "--start-offset", "0.45"], "--start-offset"),
        ([], "--capillary-number-wall"),
        (["--capillary-number-wall", "0.2", "--stationary-tolerance", "0"], "--stationary-tolerance"),
        (["--capillary-number-wall", "0.2", "--channel-shape", "square", "--channel-aspect-ratio", "2"],
         "--channel-shape"),
        (["--capillary-number-wall", "0.2", "--channel-width", "20um"], "--channel-width"),
        (["--capillary-number-wall", "0.2", "--radius", "6um", "--channel-height", "20um"], "--channel-height"),
        (["--capillary-number-wall", "0.2", "--medium", "honey"], "--medium"),
        (["--capillary-number-wall", "0.2", "--medium", "0.59%MC-PBS", "--temperature", "150"], "--temperature"),
        (["--capillary-number-wall", "0.2", "--medium", "power-law"], "--flow-index"),
        (["--capillary-number-wall", "0.2", "--temperature", "30"], "--temperature"),  # Newtonian: no temperature
        (["--capillary-number-wall", "0.2", "--duration", "0.01"], "--duration"),  # under one record interval
        (["--capillary-number-wall", "0.2", "--medium", "power-law", "--flow-index", "0.6", "--temperature", "30"],
         "--temperature"),
        (["--capillary-number-wall", "0.2", "--resolution", "4", "--extrapolate", "--coarse-resolution", "4"],
         "--coarse-resolution"),
        (["--capillary-number-wall", "0.2", "--no-extrapolate", "--coarse-resolution", "6"], "--coarse-resolution"),
        (["--capillary-number-wall", "0.2", "--channel-shape", "square", "--coarse-resolution", "6"],
         "--coarse-resolution"),  # a duct's default is one resolution
    ],
)
def test_cli_refuses_impossible_input_in_one_line(tmp_path, arguments, option):
    from typer.testing import CliRunner

    from elastocell.cli.app import app

    result = CliRunner().invoke(app, ["pipe", *arguments, "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    lines = [line for line in result.output.strip().splitlines() if line]
    assert len(lines) == 1 and option in lines[0] and "Traceback" not in result.output
    assert not (tmp_path / "out").exists()


def test_cli_runs_and_writes_every_output(tmp_path):
    from typer.testing import CliRunner

    from elastocell.cli.app import app

    out = tmp_path / "run"
    result = CliRunner().invoke(app, [
        "pipe", "--nucleus", "none", "--mesh-size", "0.6", "--resolution", "4", "--channel-radius-ratio", "2.5",
        "--capillary-number-wall", "0.2", "--duration", "0.5", "--record-interval", "0.25", "--vtk-interval", "0.5",
        "--out", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    for name in ("timeseries.csv", "summary.json", "pipe.png", "vtk/cell.pvd", "vtk/fluid.pvd", "vtk/cell_0001.vtu",
                 "vtk/fluid_0001.vtu"):
        assert (out / name).exists(), name
    header = (out / "timeseries.csv").read_text().splitlines()[0].split(",")
    for column in ("time", "radial_position", "axial_velocity", "strain_axial", "strain_radial", "projected_area",
                   "deformation", "volume_change"):
        assert column in header
    assert "eps_x" in result.output


@pytest.mark.slow
def test_jax_backend_carries_the_cell_like_the_numba_kernels(cell):
    # Reference: the Numba backend on the same off-axis run (channel solid mask, body force, float64). The JAX
    # backend (the GPU path) is an independent implementation of the same steps, so the time series agree to
    # round-off accumulated over the run: measured max difference (interpolated wall) 8.9e-16 (volume change),
    # 1.1e-16 (axial velocity); tolerance 1e-9.
    series = {}
    for backend in ("numba", "jax"):
        params = PipeFlowParameters(capillary_number_wall=0.2, start_offset=0.3, dtype="float64", backend=backend,
                                    **SMALL)
        series[backend] = run_pipe(cell, params, duration=1.0, record_interval=0.5).series
    for name in ("radial_position", "axial_velocity", "strain_axial", "strain_radial", "volume_change"):
        np.testing.assert_allclose(series["jax"][name], series["numba"][name], rtol=0, atol=1e-9, err_msg=name)
    assert series["jax"]["radial_position"][-1] < series["jax"]["radial_position"][0]  # it moved


def test_cli_extrapolates_two_resolutions_by_richardson(tmp_path):
    # Reference: the Richardson formula X = X_f + (X_f - X_c) / ((R_f/R_c)^2 - 1), written out here, applied to the
    # two sub-runs' own summary.json (R/dx 4 and 3); the wiring must reproduce it to round-off.
    from typer.testing import CliRunner

    from elastocell.cli.app import app

    out = tmp_path / "run"
    result = CliRunner().invoke(app, [
        "pipe", "--nucleus", "none", "--resolution", "4", "--extrapolate", "--coarse-resolution", "3",
        "--channel-radius-ratio", "2.5",
        "--capillary-number-wall", "0.2", "--duration", "0.5", "--record-interval", "0.25", "--vtk-interval", "0.5",
        "--out", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    fine, coarse, top = (json.loads((out / name / "summary.json").read_text())
                         for name in ("resolution-4", "resolution-3", "."))
    assert fine["lattice"]["radius"] == 4 and coarse["lattice"]["radius"] == 3
    factor = 1.0 / ((4.0 / 3.0) ** 2 - 1.0)
    for name in ("strain_axial_mean", "strain_radial_mean", "deformation_mean", "projected_area_mean",
                 "axial_velocity_mean"):
        expected = fine[name] + (fine[name] - coarse[name]) * factor
        assert top[name] == pytest.approx(expected, rel=1e-12, abs=1e-15)
        assert top[f"{name}_rdx4"] == fine[name] and top[f"{name}_rdx3"] == coarse[name]
        assert top[f"{name}_correction"] == pytest.approx(abs(expected - fine[name]), rel=1e-12, abs=1e-15)
    assert top["radial_position"] == fine["radial_position"]  # migration: the finer run's
    assert top["extrapolation"]["order"] == 2 and "finer run's" in top["extrapolation"]["timeseries"]
    assert (out / "timeseries.csv").read_text() == (out / "resolution-4" / "timeseries.csv").read_text()
    assert (out / "pipe.png").exists() and "eps_x: " in result.output


@pytest.mark.parametrize("backend", ["numba", "jax"])
def test_set_body_force_changes_the_flow_without_a_new_lattice(backend):
    """Stokes flow is linear in its driving: doubling the body force of a relaxed empty channel doubles its flow
    rate (reference: the exact ratio 2; measured -2.8e-10 on the numba lattice, relaxed to 1e-9; tolerance 1e-7)."""
    from elastocell.lattice.jax_backend import JaxLattice

    lattice = empty_channel(6.0, 2, 1.0, 1e-6)
    if backend == "jax":
        numba_lattice, lattice = lattice, JaxLattice(lattice.params)
        lattice.set_population_deviations(numba_lattice.population_deviations())
    relax_to_steady(lattice, 1e-9)
    before = flow_rate(lattice)
    lattice.set_body_force((2e-6, 0.0, 0.0))
    relax_to_steady(lattice, 1e-9)
    assert flow_rate(lattice) / before == pytest.approx(2.0, abs=1e-7)
    assert lattice.params.body_force == (2e-6, 0.0, 0.0)


def test_a_jax_lattice_built_without_a_body_force_refuses_one():
    """The JAX lattice compiles its steps without the body-force term when built without one: giving it a force
    later would be silently ignored, so it is refused (a zero force is still accepted)."""
    from elastocell.lattice.jax_backend import JaxLattice

    lattice = JaxLattice(empty_channel(6.0, 2, 1.0, 0.0).params)
    lattice.set_body_force((0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="built without a body force"):
        lattice.set_body_force((1e-6, 0.0, 0.0))
    assert lattice.params.body_force == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("backend", ["numba", "jax"])
def test_the_flow_rate_is_held_at_the_ideal_channels(backend):
    """A cell of R/R_ch 0.67 slows a periodic channel driven by a fixed G: the flow rate falls to 0.88 of
    Poiseuille's for the nominal G (R/dx 4, 2 units of time). Held (the default), it stays at Poiseuille's: 0.9983
    at the last record (tolerance 3e-3, twice the measured gap), the body force 13 % above the nominal, and the cell
    deforms more (D 0.0179 against 0.0152; the same on both backends)."""
    cell = Cell.from_parameters(flow_cell(None, {"nucleus": "none"}, 4))
    held, fixed = (run_pipe(cell, PipeFlowParameters(capillary_number_wall=0.5, channel_radius_ratio=1.5,
                                                     resolution=4, hold_flow_rate=hold, backend=backend,
                                                     hydrodynamic_radius_correction=0.0,  # the markers at R and
                                                     channel_wall="staircase"),  # the staircase, as measured
                            duration=2.0).summary
                   for hold in (True, False))
    assert abs(held["flow_rate_ratio"] - 1.0) < 3e-3
    assert held["pressure_gradient_ratio"] > 1.1
    assert fixed["flow_rate_ratio"] < 0.9 and fixed["pressure_gradient_ratio"] == 1.0
    assert held["deformation_mean"] > 1.1 * fixed["deformation_mean"]


def test_cli_passes_the_flow_rate_hold_and_the_radius_correction(tmp_path):
    """``--no-hold-flow-rate``, ``--hydrodynamic-radius-correction`` and ``--channel-wall`` reach the run: the summary
    records a held pressure gradient (G/G_0 exactly 1), the markers' correction and the wall."""
    from typer.testing import CliRunner

    from elastocell.cli.app import app

    out = tmp_path / "run"
    result = CliRunner().invoke(app, [
        "pipe", "--nucleus", "none", "--mesh-size", "0.6", "--resolution", "4", "--channel-radius-ratio", "2.5",
        "--capillary-number-wall", "0.2", "--duration", "0.5", "--no-extrapolate", "--no-hold-flow-rate",
        "--hydrodynamic-radius-correction", "0.2", "--channel-wall", "staircase", "--vtk-interval", "0.5",
        "--out", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert "channel_wall" not in summary["flow"]  # the staircase, left out (the default is said: "interpolated")
    assert summary["hold_flow_rate"] is False and summary["pressure_gradient_ratio"] == 1.0
    # G held is what a run without the field always did: left out of the dump, so old run keys stay valid
    assert summary["flow"]["hydrodynamic_radius_correction"] == 0.2 and "hold_flow_rate" not in summary["flow"]


def test_the_command_line_and_the_api_share_the_pipe_defaults():
    """The markers at R - 0.3 dx and the extrapolation decided by the channel (a LUT: one run per point), whichever
    way the pipe is asked for: the command line's defaults are the API's (the CLI declares them without importing
    the scenario)."""
    import inspect

    import typer

    from elastocell.api.pipe import pipe
    from elastocell.cli.app import app
    from elastocell.inverse.lut import compute_lut
    from elastocell.scenarios.pipe import PIPE_HYDRODYNAMIC_RADIUS_CORRECTION, PipeFlowParameters

    commands = typer.main.get_command(app).commands
    cli = {param.name: param.default for param in commands["pipe"].params}
    assert PipeFlowParameters.model_fields["hydrodynamic_radius_correction"].default == 0.3
    assert cli["hydrodynamic_radius_correction"] == PIPE_HYDRODYNAMIC_RADIUS_CORRECTION
    assert cli["extrapolate"] is inspect.signature(pipe).parameters["extrapolate"].default is None  # by the channel
    lut = {param.name: param.default for param in commands["lut"].params}
    assert lut["extrapolate"] is inspect.signature(compute_lut).parameters["extrapolate"].default is False
    assert lut["hydrodynamic_radius_correction"] == PIPE_HYDRODYNAMIC_RADIUS_CORRECTION


def test_a_coarse_resolution_without_the_extrapolation_is_refused_by_the_api():
    from elastocell.api.pipe import pipe
    from elastocell.parameters.units import ParameterError

    with pytest.raises(ParameterError, match="coarse_resolution.*extrapolation, which is off"):
        pipe("never-written", 0.2, nucleus="none", coarse_resolution=6, extrapolate=False, progress=False)
    with pytest.raises(ParameterError, match="coarse_resolution.*extrapolation, which is off"):  # a duct: one run
        pipe("never-written", 0.2, nucleus="none", coarse_resolution=6, channel_shape="square", progress=False)
    assert not Path("never-written").exists()


@pytest.mark.parametrize("aspect_ratio", [7 / 23, 0.2, 0.5, 1.0, 2.0])
def test_the_power_law_duct_flow_rate_is_the_series_at_n_1(aspect_ratio):
    """The finite volumes behind a power-law duct's held flow rate, at n = 1, against the Newtonian series (White):
    at least 64 cells across the shorter side and the height a whole number of cells; measured +4.6e-4 to +9.4e-4
    over these aspects (the half-height rounded to 13-19 cells erred -6 % at 7/23 and +6 % at 0.2); tolerance 1.5e-3."""
    from elastocell.scenarios.pipe import duct_flow_rate, power_law_duct_unit_flow_rate

    exact = duct_flow_rate(1.0, 1.0, 1.0, aspect_ratio)
    assert power_law_duct_unit_flow_rate(1.0, aspect_ratio) / exact - 1 == pytest.approx(0.0, abs=1.5e-3)


def test_a_held_pressure_gradient_reaches_both_runs_of_an_extrapolated_pipe(tmp_path):
    """``hold_flow_rate=False`` is left out of the parameters' dump (G-held runs keep their old keys), so a model
    rebuilt from the dump would hold Q again: both resolutions of an extrapolated run must hold G."""
    from elastocell.api.pipe import pipe

    pipe(tmp_path / "run", 0.2, nucleus="none", mesh_size=0.6, pole_size=0.6, resolution=5, extrapolate=True,
         coarse_resolution=4, channel_radius_ratio=2.5, duration=0.3, record_interval=0.1, hold_flow_rate=False,
         hydrodynamic_radius_correction=0.0, progress=False, vtk_interval=None)
    for part in ("resolution-5", "resolution-4"):
        summary = json.loads((tmp_path / "run" / part / "summary.json").read_text())
        assert summary["hold_flow_rate"] is False and summary["pressure_gradient_ratio"] == 1.0, part
        # c = 0 is left out of the dump too, and the default is 0.3: both runs keep the markers at R
        assert "hydrodynamic_radius_correction" not in summary["flow"], part


@pytest.mark.parametrize(("flow", "expected"), [
    ({}, True), ({"start_offset": 0.2}, False), ({"channel_shape": "square"}, False),
    ({"channel_shape": "rectangle", "channel_aspect_ratio": 1.5}, False)])
def test_the_pipe_extrapolates_by_default_in_a_cylinder_with_the_cell_on_its_axis(flow, expected):
    """Where the six side views converge (the centred cell in a cylinder) the default is the R/dx 8 and 6 pair;
    in a duct R/dx 8 alone (docs/validation/lut_square.md, section lut_square_views.py), off the axis too."""
    from elastocell.api.pipe import extrapolated_by_default

    assert extrapolated_by_default(PipeFlowParameters(capillary_number_wall=0.5, **flow)) is expected


def _fake_parts(monkeypatch, hull_records: dict[float, int], hull_means: dict[float, int] | None = None,
                along_z: dict[float, int] | None = None):
    """Replace the pipe's one-resolution run by one writing a summary whose readings are 10 x R/dx (so the
    Richardson values are known), ``hull_records[R/dx]`` records with side views on the nodes' hull,
    ``along_z[R/dx]`` with the view along z there and, where ``hull_means`` names the R/dx,
    ``outline_hull_views_records`` (records with every view there); returns the calls."""
    import elastocell.api.pipe as api
    from elastocell.files import write_json

    calls = []

    def single(out, params, *arguments, part=""):
        r = params.resolution
        calls.append((params.channel_shape, r))
        Path(out).mkdir(parents=True, exist_ok=True)
        summary = {"resolution": r, "stop_reason": "duration", "label": "fake", "capillary_number_wall": 0.5,
                   "outline_fallback_records": (along_z or {}).get(r, 0),
                   "outline_fallback_views_records": hull_records.get(r, 0),
                   **{name: 10.0 * r for name in api.EXTRAPOLATED}}
        if hull_means is not None and r in hull_means:
            summary["outline_hull_views_records"] = hull_means[r]
        write_json(Path(out) / "summary.json", summary)
        return summary, {"time": np.array([0.0, 1.0]), "deformation": np.array([0.0, 0.0])}

    monkeypatch.setattr(api, "_single", single)
    monkeypatch.setattr(api, "plot_pipe", lambda *a, **k: None)
    return calls


def test_a_default_cylinder_run_is_the_extrapolated_pair_and_a_duct_run_one_resolution(tmp_path, monkeypatch):
    """The wiring of the default: a cylinder runs R/dx 8 then 6 and reports the Richardson values (reference:
    X_8 + (X_8 - X_6) / ((8/6)^2 - 1), written out, with X = 10 R/dx: 80 + 20 / (7/9) = 105.714...); a square duct
    runs R/dx 8 once."""
    import elastocell.api.pipe as api

    calls = _fake_parts(monkeypatch, {})
    summary = api.pipe(tmp_path / "cylinder", 0.5, nucleus="none", progress=False)
    assert calls == [("cylinder", 8.0), ("cylinder", 6.0)]
    for name in api.EXTRAPOLATED:
        assert summary[name] == pytest.approx(80.0 + 20.0 / (16.0 / 9.0 - 1.0), rel=1e-12)
    assert "outline_guard" not in summary["extrapolation"]
    calls.clear()
    summary = api.pipe(tmp_path / "square", 0.5, nucleus="none", channel_shape="square", progress=False)
    assert calls == [("square", 8.0)] and "extrapolation" not in summary


def test_an_extrapolation_with_hull_read_records_keeps_the_finer_runs_outline(tmp_path, monkeypatch):
    """Records read on the nodes' hull in either run (here 3 at R/dx 6): the deformation and area stay the R/dx 8
    run's (80), their corrections NaN, a warning and ``outline_guard`` say why; the strains and velocity are still
    extrapolated."""
    import elastocell.api.pipe as api

    _fake_parts(monkeypatch, {6.0: 3})
    with pytest.warns(UserWarning, match=r"nodes' hull \(R/dx 6: 0 \(view along z\), 3 \(any side view\) and \? \(every side view\)"):
        summary = api.pipe(tmp_path / "run", 0.5, nucleus="none", progress=False)
    for name in api.OUTLINE_EXTRAPOLATED:
        assert summary[name] == 80.0 and np.isnan(summary[f"{name}_correction"]), name
    assert summary["strain_axial_mean"] == pytest.approx(80.0 + 20.0 / (16.0 / 9.0 - 1.0), rel=1e-12)
    assert "R/dx 6 run's outline is not resolved" in summary["extrapolation"]["outline_guard"]
    assert "R/dx 8 run's" in summary["extrapolation"]["outline_guard"]
    on_disk = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert on_disk["deformation_views_mean"] == 80.0 and "outline_guard" in on_disk["extrapolation"]
    assert api.rtdc_reading(summary) == (80.0, 80.0, "side views")


Z, VIEWS = ("deformation_mean", "projected_area_mean"), ("deformation_views_mean", "projected_area_views_mean")


@pytest.mark.parametrize(("pair", "hull_records", "hull_means", "along_z", "kept", "advised"), [
    # the finer run: some side views on the hull, left out of its mean, none along z: all extrapolated
    ((8, 6), {8.0: 5}, {8.0: 0}, {}, (), False),
    # the finer run's view along z (view 0 of the side views) on the hull: that reading kept, the six views' mean not
    ((8, 6), {8.0: 5}, {8.0: 0}, {8.0: 2}, Z, False),
    # every view of a record of the finer run on the hull (so its view along z too): both kept
    ((8, 6), {8.0: 5}, {8.0: 1}, {8.0: 1}, Z + VIEWS, False),
    # a finer run's summary without the every-view count (older runs): any side view counts
    ((8, 6), {8.0: 5}, None, {}, VIEWS, False),
    # the coarser run: any side view on the hull, its outline is not resolved: all kept, the (10, 8) pair advised
    ((8, 6), {6.0: 5}, {6.0: 0}, {}, Z + VIEWS, True),
    # both runs failed: still the coarser run's failure, still advised
    ((8, 6), {6.0: 5, 8.0: 5}, {6.0: 0, 8.0: 1}, {8.0: 1}, Z + VIEWS, True),
    # the advised pair's coarser run failing: nothing finer to advise
    ((10, 8), {8.0: 5}, {8.0: 0}, {}, Z + VIEWS, False),
    # a (10, 6) pair whose R/dx 6 run failed: (10, 8) advised
    ((10, 6), {6.0: 5}, {6.0: 0}, {}, Z + VIEWS, True),
])
def test_the_outline_guard_keeps_each_reading_the_hull_reached(tmp_path, monkeypatch, pair, hull_records,
                                                               hull_means, along_z, kept, advised):
    """The guard keeps at the finer run's every outline reading where the coarser run read any view on the hull;
    the view along z where the finer run's did; the six views' mean where the finer run read every view of a record
    there (mean_side_view leaves the hull's views out otherwise). Reference for the others: X_f + (X_f - X_c) /
    ((f/c)^2 - 1) with X = 10 R/dx, written out."""
    import warnings

    import elastocell.api.pipe as api

    fine, coarse = pair
    _fake_parts(monkeypatch, hull_records, hull_means, along_z)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        summary = api.pipe(tmp_path / "run", 0.5, nucleus="none", progress=False, resolution=fine,
                           coarse_resolution=coarse)
    extrapolated = 10.0 * fine + 10.0 * (fine - coarse) / ((fine / coarse) ** 2 - 1.0)
    for name in Z + VIEWS:
        assert summary[name] == pytest.approx(10.0 * fine if name in kept else extrapolated, rel=1e-12), name
    guard = summary["extrapolation"].get("outline_guard", "")
    assert bool(guard) is bool(kept) and any("nodes' hull" in str(w.message) for w in caught) is bool(kept)
    assert ("--resolution 10 --coarse-resolution 8" in guard) is advised
    assert api.rtdc_extrapolated(summary) is ("deformation_views_mean" not in kept)


def test_a_pipe_summary_counts_the_records_with_every_side_view_on_the_hull():
    """``outline_hull_views_records``: records whose six views all fell back (their mean is the hull's);
    ``outline_fallback_views_records``: those with any; NaN (resumed from an older checkpoint) in neither
    (reference: counted by hand on the column below)."""
    from elastocell.scenarios.pipe import outline_hull_records

    assert outline_hull_records(np.array([6, 6, 1, 0, np.nan, 5]), 6) == (4, 2)
    assert outline_hull_records(np.array([2, 2, 1]), 2) == (3, 2)  # a duct: two views


def test_a_run_id_resolves_the_pipes_default_by_its_channel():
    """The run key follows what the API runs: a duct given as ``channel_shape`` (beside ``flow_options`` or in
    them) is one run, the same key as ``extrapolate=False``; a cylinder's default is the pair, the key of
    ``extrapolate=True``."""
    from elastocell.api.resolved import resolved_parameters
    from elastocell.studies.base import Run

    base = dict(capillary_number_wall=0.2, nucleus="none")
    square = {"channel_shape": "square"}
    assert Run.of("pipe", **base, **square).run_id == Run.of("pipe", **base, **square, extrapolate=False).run_id
    assert Run.of("pipe", **base, **square).run_id != Run.of("pipe", **base, **square, extrapolate=True).run_id
    for options in (square, {"flow_options": square}, {"start_offset": 0.2}):
        assert "extrapolation" not in resolved_parameters("pipe", {**base, **options})["options"], options
    assert resolved_parameters("pipe", base)["options"]["extrapolation"]["coarse_resolution"] == 6.0
    assert Run.of("pipe", **base).run_id == Run.of("pipe", **base, extrapolate=True).run_id
    assert Run.of("pipe", **base).run_id != Run.of("pipe", **base, extrapolate=False).run_id


def test_the_guard_keeps_a_finite_finer_value_when_a_part_wrote_none(tmp_path, monkeypatch):
    """A part's summary.json holds null for a views mean its window lacks (a run resumed from an older checkpoint):
    the guard takes the finer run's value from memory, and the command line prints the kept values as R/dx 8's."""
    import elastocell.api.pipe as api
    from elastocell.files import write_json

    def single(out, params, *arguments, part=""):
        r = params.resolution
        Path(out).mkdir(parents=True, exist_ok=True)
        summary = {"resolution": r, "stop_reason": "duration", "label": "fake", "capillary_number_wall": 0.5,
                   "outline_fallback_records": 2 if r == 6 else 0, "outline_fallback_views_records": 0,
                   **{name: 10.0 * r for name in api.EXTRAPOLATED}, "deformation_views_mean": float("nan")}
        write_json(Path(out) / "summary.json", summary)
        return summary, {"time": np.array([0.0, 1.0]), "deformation": np.array([0.0, 0.0])}

    monkeypatch.setattr(api, "_single", single)
    monkeypatch.setattr(api, "plot_pipe", lambda *a, **k: None)
    with pytest.warns(UserWarning, match="nodes' hull"):
        summary = api.pipe(tmp_path / "run", 0.5, nucleus="none", progress=False)
    assert summary["deformation_mean"] == 80.0 and np.isnan(summary["deformation_views_mean"])
    assert api.rtdc_reading(summary)[2] == "view along z"


def test_resuming_a_single_run_directory_with_the_default_continues_it_as_one_run(tmp_path, monkeypatch):
    """A directory written by one run (its checkpoint.npz, no resolution-* parts) resumed without saying
    ``extrapolate`` continues that run, with a warning, instead of starting the pair from nothing."""
    import elastocell.api.pipe as api

    calls = _fake_parts(monkeypatch, {})
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "checkpoint.npz").write_bytes(b"")
    with pytest.warns(UserWarning, match="holds one run.*not extrapolated"):
        api.pipe(tmp_path / "run", 0.5, nucleus="none", progress=False, resume=True)
    assert calls == [("cylinder", 8.0)]


def test_a_study_saves_the_finer_runs_last_shape_of_an_extrapolated_pipe(tmp_path):
    """A full pipe study's run is the extrapolated pair (R/dx 8, a centred cell in a cylinder): its shape.npz is
    the R/dx 8 run's last state (its checkpoint in resolution-8/), centred and in units of that run's R."""
    from elastocell.studies.base import _save_final_shape

    positions = np.arange(12.0).reshape(4, 3) * 8.0
    (tmp_path / "resolution-8").mkdir()
    np.savez(tmp_path / "resolution-8" / "checkpoint.npz", positions=positions)
    summary = {"extrapolation": {"fine_resolution": 8.0, "coarse_resolution": 6.0}, "lattice": {"radius": 8.0}}
    _save_final_shape(tmp_path, summary, {})
    with np.load(tmp_path / "shape.npz") as shape:
        np.testing.assert_allclose(shape["positions"], (positions - positions.mean(axis=0)) / 8.0)


def test_a_deformation_read_on_the_nodes_hull_is_never_stationary():
    # A flat deformation series is stationary; the same series whose last records were read on the nodes' hull
    # (outline_fallback 1) is not: a reading that switched to the hull looks flat while the smooth shape drifts (a
    # soft table point was stopped so, its window drifting 0.0286 against a bound of 0.0059).
    t = np.arange(0.0, 5.0, 0.1)
    series = {"time": t, "deformation": np.full(t.size, 0.05), "outline_fallback": np.zeros(t.size)}
    stop = StopCriteria(stationary_tolerance=1e-3, stationary_observable="deformation", unit=PipeRun.TIME_UNIT)
    assert stop.is_stationary(series, "time")
    series["outline_fallback"][-5:] = 1.0
    assert not stop.is_stationary(series, "time")
    series["outline_fallback"][:] = 1.0
    assert not stop.is_stationary(series, "time")
    series["outline_fallback"][:] = 0.0  # the hull left behind, beyond the two windows the stop compares
    series["outline_fallback"][:20] = 1.0
    assert stop.is_stationary(series, "time")
    # the strains are measured on the nodes, not the outline: the hull does not concern them
    series["strain_axial"] = np.full(t.size, 1.01)
    series["outline_fallback"][:] = 1.0
    assert StopCriteria(stationary_tolerance=1e-3, stationary_observable="strain_axial",
                        unit=PipeRun.TIME_UNIT).is_stationary(series, "time")
    # hull_stop: a whole window on the hull ends the run ("hull"); one smooth record in it does not
    hull = StopCriteria(stationary_tolerance=1e-3, stationary_observable="deformation", unit=PipeRun.TIME_UNIT,
                        hull_stop=True)
    assert hull.read_on_hull(series, "time")
    series["outline_fallback"][-3] = 0.0
    assert not hull.read_on_hull(series, "time")
    assert not StopCriteria(stationary_observable="strain_axial", hull_stop=True).read_on_hull(series, "time")
