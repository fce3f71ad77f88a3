"""A finite channel (``channel_length``): the pipe run ends where the cell has travelled L, a longer channel reads a
shape closer to the stationary one, impossible lengths are refused in one line, and the look-up table says which
state each point is in while a stationary table keeps its keys."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from elastocell.api.pipe import TransitStop, channel_length_of, pipe, run_state, transit_values
from elastocell.cli.app import app
from elastocell.inverse.lut import lut_metadata, plan, point_key, point_state
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.units import ParameterError

CHEAP = {"resolution": 4, "extrapolate": False, "radius": "5um", "progress": False, "vtk_interval": None,
         "channel_wall": "staircase"}
"""R/dx 4, one resolution, a 5 um cell in the default cylinder (R_ch/R = 2) with the staircase wall, as the
numbers below were measured (the stationary reference needs the stationarity stop to be met within the run's
30 units, which it was on the staircase)."""


# =========================================================================== the stop and the state
def test_the_transit_stop_ends_at_the_first_record_past_the_length():
    stop = TransitStop(duration=10.0, channel_length=2.0)
    assert stop.reached({"axial_position": [0.0, 1.5, 1.99]}) == ""
    assert stop.reached({"axial_position": [0.0, 1.5, 2.01]}) == "transit"
    assert stop.reached({"axial_position": []}) == ""
    assert run_state("transit", 300.0) == "transit 300 um"
    assert run_state("stationary", None) == "stationary"
    assert run_state("duration", 300.0) == run_state("wall_clock", None) == "cap"


def test_transit_values_interpolate_at_the_length():
    series = {name: np.array([0.0, 1.0, 2.0]) for name in ("time", "deformation", "projected_area", "strain_axial",
                                                            "strain_radial", "strain_transverse", "axial_velocity",
                                                            "radial_position", "volume_change")}
    series["axial_position"] = np.array([0.0, 1.0, 3.0])
    values = transit_values(series, 2.0)
    assert values["time"] == pytest.approx(1.5) and values["deformation"] == pytest.approx(1.5)
    assert transit_values(series, 5.0)["time"] == 2.0  # short of the length: the last record


@pytest.mark.parametrize("length, message", [
    ("0um", "must be > 0"), ("-30um", "must be > 0"), ("8um", "shorter than the cell's diameter"),
    ("3K", "not a length"),
])
def test_impossible_lengths_are_refused(length, message):
    cell = cell_parameters(radius="5um")
    with pytest.raises(ParameterError) as error:
        channel_length_of(length, cell)
    assert error.value.parameter == "channel_length" and message in str(error.value)
    assert channel_length_of("10um", cell) == pytest.approx(2.0)  # exactly the diameter is possible
    assert channel_length_of(None, cell) is None


def test_a_length_needs_a_physical_radius():
    with pytest.raises(ParameterError, match="physical --radius"):
        channel_length_of("30um", cell_parameters())


@pytest.mark.parametrize("extra, option", [
    (["--channel-length", "0um", "--radius", "5um"], "--channel-length"),
    (["--channel-length", "6um", "--radius", "5um"], "--channel-length"),
    (["--channel-length", "30um"], "--channel-length"),  # a dimensionless cell
    (["--channel-length", "30furlong", "--radius", "5um"], "--channel-length"),
])
def test_the_command_line_refuses_in_one_line(tmp_path, extra, option):
    result = CliRunner().invoke(app, ["pipe", "--out", str(tmp_path / "run"), "--capillary-number-wall", "0.2",
                                      "--resolution", "4", "--no-extrapolate", *extra])
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and option in lines[0], result.output
    assert not (tmp_path / "run").exists()  # before anything ran


def test_a_duration_too_short_for_the_length_is_refused(tmp_path):
    # the centre-line speed covers gdot_w R_ch/2 = 1 R per unit time at R_ch/R 2: 2 units cannot carry L = 4 R
    with pytest.raises(ParameterError) as error:
        pipe(tmp_path / "run", 0.2, duration=2.0, channel_length="20um", **CHEAP)
    assert error.value.parameter == "duration" and "too short" in str(error.value)


# =========================================================================== the look-up table
def test_a_stationary_table_keeps_its_keys_and_a_transit_table_says_its_state():
    stationary, settings = plan("10.94um", "0.04uL/s", "15mPa*s", quick=True)
    # the keys of points holding the flow rate with the markers at R on the staircase wall (made before the markers'
    # default moved to R - 0.3 dx and the wall's to the interpolated one) stay theirs; those of the defaults are new;
    # those of a table made when the pipe held G are tests/test_rtdc_nucleus.py's
    assert [point_key(p["radius_um"], p["emodulus_kpa"], {**p["options"], "hydrodynamic_radius_correction": 0.0,
                                                          "channel_wall": "staircase"})
            for p in stationary] == ["R5um_E1kPa_06a997ed5d", "R5um_E2kPa_ab4f69e493", "R6um_E1kPa_f0243abf7b",
                                     "R6um_E2kPa_e3eb218077"]
    assert [p["key"] for p in stationary] == ["R5um_E1kPa_96fd6034e3", "R5um_E2kPa_4f9415c43b",
                                              "R6um_E1kPa_91431c60d5", "R6um_E2kPa_a863f05917"]
    # the defaults before the interpolated wall: the staircase said, the keys those points had
    assert [point_key(p["radius_um"], p["emodulus_kpa"], {**p["options"], "channel_wall": "staircase"})
            for p in stationary] == ["R5um_E1kPa_c72d4ad82e", "R5um_E2kPa_6ae5a507cd",
                                     "R6um_E1kPa_2d6ad0df5c", "R6um_E2kPa_7b80bac60c"]
    assert settings["state"] == "stationary" and "channel_length" not in stationary[0]["options"]
    transit, settings = plan("10.94um", "0.04uL/s", "15mPa*s", quick=True, channel_length="300um")
    assert {p["key"] for p in transit}.isdisjoint({p["key"] for p in stationary})
    options = transit[0]["options"]
    assert options["channel_length"] == pytest.approx(300.0) and options["radius"] == "5um"
    assert options["stationary_tolerance"] is None
    assert settings["state"] == "transit 300 um" and settings["channel_length_um"] == pytest.approx(300.0)
    # the cap: 1.5 times the transit at the mean speed Q/A, in units of 1/gdot_w = 1/(4 Q/(pi R_ch^3))
    assert options["duration"] == pytest.approx(1.5 * 300e-6 * 4 / 10.94e-6)
    metadata = lut_metadata(settings, "x")
    assert metadata["summary"].startswith("Shape at the end of a channel 300 um long")
    assert lut_metadata(plan("10.94um", "0.04uL/s", "15mPa*s", quick=True)[1], "x")["summary"].startswith(
        "Stationary shape")
    assert point_state({"stationary": True}) == "stationary" and point_state({"stationary": False}) == "cap"
    assert point_state({"state": "transit 300 um", "stationary": False}) == "transit 300 um"


@pytest.mark.parametrize("kwargs, name", [
    ({"channel_length": "0um"}, "channel_length"), ({"channel_length": "10um"}, "channel_length"),
    ({"channel_length": "300um", "stationary_tolerance": 1e-3}, "stationary_tolerance"),
])
def test_the_table_refuses_impossible_lengths(kwargs, name):
    with pytest.raises(ParameterError) as error:
        plan("10.94um", "0.04uL/s", "15mPa*s", quick=True, **kwargs)  # the largest cell: 12 um across
    assert error.value.parameter == name


# =========================================================================== a cheap run
@pytest.mark.slow
def test_the_run_stops_at_the_length_and_a_longer_channel_approaches_the_stationary_shape(tmp_path):
    # R/dx 4, Ca_w 0.2, R_ch/R 2 (about 40 s on 2 shared cores). Reference: the same cell's stationary shape (the
    # stationarity stop, deformation steady to 1e-3), the limit of an infinitely long channel.
    stationary = pipe(tmp_path / "stationary", 0.2, duration=30.0, stationary_tolerance=1e-3,
                      stationary_observable="deformation", **CHEAP)
    assert stationary["state"] == "stationary"
    d_stationary = stationary["deformation_mean"]

    short = pipe(tmp_path / "transit", 0.2, duration=30.0, channel_length="10um", **CHEAP)  # L = 2R
    series = json.loads((tmp_path / "transit" / "summary.json").read_text())
    assert short["state"] == series["state"] == "transit 10 um" and short["stop_reason"] == "transit"
    travelled = np.loadtxt(tmp_path / "transit" / "timeseries.csv", delimiter=",", skiprows=1,
                           usecols=_column(tmp_path / "transit", "axial_position"))
    step = np.diff(travelled).max()  # one record interval's travel
    assert travelled[-2] < 2.0 <= travelled[-1] <= 2.0 + step

    # the same directory resumed with a longer channel continues the trajectory to L = 6R
    long = pipe(tmp_path / "transit", 0.2, duration=30.0, channel_length="30um", resume=True, **CHEAP)
    assert long["state"] == "transit 30 um"
    travelled = np.loadtxt(tmp_path / "transit" / "timeseries.csv", delimiter=",", skiprows=1,
                           usecols=_column(tmp_path / "transit", "axial_position"))
    assert travelled[-2] < 6.0 <= travelled[-1] <= 6.0 + step
    d_short, d_long = short["transit"]["deformation"], long["transit"]["deformation"]
    # measured: D = 0.00348 at L = 2R, 0.003829 at 6R, 0.003825 stationary (its second-half mean): -9.0 % and
    # +0.1 %, so the distance to the stationary value falls 90-fold; the records themselves scatter by about 0.5 %
    assert abs(d_long - d_stationary) < 0.25 * abs(d_short - d_stationary)
    assert d_long == pytest.approx(d_stationary, rel=0.02)
    assert d_short < d_long  # the shape is still growing at the end of a short channel


def _column(directory, name: str) -> int:
    header = (directory / "timeseries.csv").read_text().splitlines()[0].split(",")
    return header.index(name)


class _Client:
    """Stands in for a Dask client: runs the task in this process."""

    def submit(self, function, *args, pure=False):
        from concurrent.futures import Future

        future = Future()
        future.set_result(function(*args))
        return future


@pytest.mark.slow
def test_a_transit_table_reads_each_point_at_the_end_of_the_channel(tmp_path, monkeypatch):
    # one point (R = 5 um, E = 2 kPa, R/dx 4) in a channel 12 um long: about 3 units of 1/gdot_w (13 s on 2 shared cores)
    import distributed

    from elastocell.inverse.lut import compute_lut, read_lut

    monkeypatch.setattr(distributed, "as_completed", lambda futures: list(futures))
    out = tmp_path / "lut.txt"
    result = compute_lut(out, "10um", "0.04uL/s", "15mPa*s", radii="5", moduli="2kPa", quick=True,
                         channel_length="12um", client=_Client())
    assert not result["failures"], result["failures"]
    data, meta, _ = read_lut(out)
    (record,) = result["records"]
    assert meta["elastocell"]["state"] == "transit 12 um" and meta["elastocell"]["not_stationary"] == []
    assert meta["elastocell"]["point_states"] == {record["key"]: "transit 12 um"}
    summary = json.loads((tmp_path / "lut_runs" / record["key"] / "summary.json").read_text())
    assert summary["stop_reason"] == "transit" and summary["channel_length_r"] == pytest.approx(2.4)
    # the table's row is the shape where the cell had travelled L, not a mean over the run's end
    assert data[0, 1] == pytest.approx(summary["transit"]["deformation"], rel=1e-6)
    assert data[0, 0] == pytest.approx(summary["transit"]["projected_area"] * 25, rel=1e-6)
