"""Temperatures as quantities: ``23degC``, ``23°C``, ``296.15K`` and the bare number 23 (degC, the bare-number rule
of ``elastocell.parameters.units``) are one temperature wherever one is parsed: ``lut``, ``pipe``, ``fit rtdc``."""

import pytest
from typer.testing import CliRunner

from elastocell.api.pipe import pipe
from elastocell.cli.app import app
from elastocell.inverse.lut import plan
from elastocell.parameters.units import BARE_UNITS, ParameterError, parse_temperature

SAME = ["23degC", "23°C", "296.15K", "296.15 kelvin", "23 celsius", 23, "23", 23.0]


@pytest.mark.parametrize("value", SAME)
def test_spellings_of_one_temperature(value):
    assert parse_temperature(value) == pytest.approx(23.0, abs=1e-12)


def test_a_bare_temperature_is_in_degc():
    assert BARE_UNITS["degC"].bare == "degC"
    assert parse_temperature(None) is None
    assert parse_temperature("0K") == pytest.approx(-273.15)


@pytest.mark.parametrize("value, reason", [
    ("23m", "not a temperature"), ("23degC/s", "not a temperature"), ("23 C", "unknown unit"),
    ("23mK", "unknown unit"), ("-1K", "absolute zero"), ("-300", "absolute zero"), ("nan", "not a finite"),
    ("warm", "no number"),
])
def test_what_is_not_a_temperature_is_refused(value, reason):
    with pytest.raises(ParameterError) as error:
        parse_temperature(value)
    assert error.value.parameter == "temperature" and reason in str(error.value)


def test_kelvin_is_no_length():
    from elastocell.parameters.units import parse_quantity

    with pytest.raises(ParameterError, match="not a length"):
        parse_quantity("8K", "m", "radius")


@pytest.mark.parametrize("value", ["23degC", "296.15K", "23°C"])
def test_the_table_reads_every_spelling(value):
    _, settings = plan(None, "0.04uL/s", None, quick=True, channel_width="20um", channel_shape="square",
                       medium="0.59%MC-PBS", temperature=value)
    _, bare = plan(None, "0.04uL/s", None, quick=True, channel_width="20um", channel_shape="square",
                   medium="0.59%MC-PBS", temperature=23)
    assert settings["temperature_c"] == pytest.approx(23.0)
    assert settings["consistency_pa_s_n"] == pytest.approx(bare["consistency_pa_s_n"], rel=1e-12)


def test_the_table_refuses_a_temperature_outside_the_fit_in_kelvin():
    with pytest.raises(ParameterError, match="22-37 degC"):
        plan(None, "0.04uL/s", None, quick=True, channel_width="20um", channel_shape="square",
             medium="0.59%MC-PBS", temperature="273.15K")


def test_pipe_takes_a_temperature_quantity(tmp_path):
    with pytest.raises(ParameterError) as error:  # refused before anything runs
        pipe(tmp_path / "run", 0.2, medium="0.59%MC-PBS", temperature="23 furlong", resolution=4, extrapolate=False)
    assert error.value.parameter == "temperature"
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("command", [
    ["lut", "--channel-width", "20um", "--channel-shape", "square", "--flow-rate", "0.04uL/s", "--medium",
     "0.59%MC-PBS", "--quick", "--out", "OUT/lut.txt"],
    ["pipe", "--capillary-number-wall", "0.2", "--medium", "0.59%MC-PBS", "--resolution", "4", "--no-extrapolate",
     "--out", "OUT/pipe"],
    ["fit", "rtdc", "OUT/none.rtdc", "--out", "OUT/fits"],
])
@pytest.mark.parametrize("value", ["23 furlong", "-5K"])
def test_every_command_refuses_a_temperature_in_one_line(tmp_path, command, value):
    args = [a.replace("OUT", str(tmp_path)) for a in command] + ["--temperature", value]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and "--temperature" in lines[0], result.output
    assert not any(tmp_path.iterdir())  # before anything ran or was written
