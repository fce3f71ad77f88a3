"""Quantities (elastocell.parameters.units): one rule for bare numbers, a tokeniser in front of pint, and hostile
strings refused in one line within a second.

Reference of the conversions: the SI definitions of the prefixes and units (1 um = 1e-6 m, 1 mPa*s = 1e-3 Pa*s,
1 uL = 1e-9 m^3, 1 cP = 1 mPa*s, 1 min = 60 s). Tolerance: relative 1e-12, the round-off of one or two float
multiplications by pint's conversion factors (measured: at most 2.2e-16 relative on these examples).
"""

import time

import pytest

from elastocell.parameters.units import (
    BARE_UNITS,
    MAX_LENGTH,
    MODULUS_SCALE,
    RADIUS_SCALE,
    ParameterError,
    parse_quantity,
    unit_names,
)

HOSTILE = ["9**9**9um", "1e999999um", "nan", "inf kPa", '__import__("os")', "9" * 10_000, "8 furlongs", "-inf",
           "8 um^99", "8 ((um))", "8 um)", "8 /", "um", "", "1e5e5", "8 um; rm -rf /", "0x10um", "\u0663um",
           "8 KPa m"]


@pytest.fixture(scope="module", autouse=True)
def pint_loaded():
    """pint's one-time import and registry (about 0.5 s) are not parse time."""
    parse_quantity("8um", "m", "radius")


@pytest.mark.parametrize("text, unit, expected", [
    ("8um", "m", 8e-6), ("8 um", "m", 8e-6), ("8e-6 m", "m", 8e-6), ("8e-6m", "m", 8e-6), ("8\u00b5m", "m", 8e-6),
    ("8\u03bcm", "m", 8e-6), ("8 micrometres", "m", 8e-6), ("+8.um", "m", 8e-6), (".5 mm", "m", 5e-4),
    ("15mPa*s", "Pa*s", 0.015), ("15 mPa.s", "Pa*s", 0.015), ("15 mPa s", "Pa*s", 0.015), ("1.5cP", "Pa*s", 1.5e-3),
    ("0.04uL/s", "m^3/s", 4e-11), ("2.4 uL/min", "m^3/s", 4e-11), ("1000/s", "1/s", 1000.0),
    ("300 rad/s", "1/s", 300.0), ("50Hz", "1/s", 50.0), ("1e5Pa/m", "Pa/m", 1e5), ("1kPa", "Pa", 1e3),
    ("1 kg/(m*s^2)", "Pa", 1.0), ("1 kg/(m s**2)", "Pa", 1.0), ("8 (um^2)^1/um", "m", 8e-6), ("0.05N/m", "N/m", 0.05),
    ("50 nm/V", "m/V", 5e-8), ("-8um", "m", -8e-6),
])
def test_quantities_with_units(text, unit, expected):
    magnitude, physical = parse_quantity(text, unit, "x")
    assert physical and magnitude == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("unit, bare", [(q.si, q.bare) for q in BARE_UNITS.values()])
def test_a_bare_number_is_in_the_documented_unit(unit, bare):
    with_unit = "2.5" + (bare[1:] if bare.startswith("1/") else " " + bare)  # 2.5 um, 2.5/s
    for value in (2.5, "2.5", "2.5e0"):
        assert parse_quantity(value, unit, "x") == parse_quantity(with_unit, unit, "x")


def test_the_documented_bare_units():
    """One unit per quantity for bare numbers, everywhere (command line and Python API)."""
    assert {q.si: q.bare for q in BARE_UNITS.values()} == {
        "m": "um", "Pa": "Pa", "Pa*s": "mPa*s", "1/s": "1/s", "m^3/s": "uL/s", "Pa/m": "Pa/m", "N/m": "N/m",
        "m/V": "nm/V", "deg": "deg", "degC": "degC"}
    assert parse_quantity(3, "Pa*s", "viscosity")[0] == pytest.approx(3e-3, rel=1e-12)


def test_a_scale_keeps_a_bare_number_dimensionless():
    assert parse_quantity("2", "m", "radius", scale=RADIUS_SCALE) == (2.0, False)
    assert parse_quantity(2, "Pa", "youngs_modulus", scale=MODULUS_SCALE) == (2.0, False)
    assert parse_quantity("8um", "m", "radius", scale=RADIUS_SCALE) == (pytest.approx(8e-6, rel=1e-12), True)
    with pytest.raises(ParameterError, match="or a bare number in units of R, got '1kPa'"):
        parse_quantity("1kPa", "m", "radius", scale=RADIUS_SCALE)


def test_the_same_numbers_as_pint_reading_the_whole_string():
    """The canonical expression handed to pint gives bit-identical magnitudes to pint parsing the plain string
    (so tables written before the tokeniser are reproduced exactly)."""
    import pint

    registry = pint.UnitRegistry()
    for text, unit in (("8um", "m"), ("0.04uL/s", "m^3/s"), ("15mPa*s", "Pa*s"), ("10.94um", "m"),
                       ("1e5Pa/m", "Pa/m"), ("0.75kPa", "Pa"), ("20um", "m"), ("1000/s", "1/s")):
        assert parse_quantity(text, unit, "x")[0] == registry.Quantity(text).to(unit).magnitude


def test_every_unit_name_is_known_to_pint():
    import pint

    registry = pint.UnitRegistry()
    for name in unit_names():
        registry.parse_units(name.replace("\u00b5", "u"))


@pytest.mark.parametrize("unit", sorted(BARE_UNITS))
@pytest.mark.parametrize("text", HOSTILE + ["wrong dimension"], ids=lambda t: repr(t)[:24])
def test_hostile_strings_are_refused_in_one_line_within_a_second(text, unit):
    if text == "wrong dimension":
        text = "1kPa" if unit == "m" else "8um"
    start = time.perf_counter()
    with pytest.raises(ParameterError) as caught:
        parse_quantity(text, unit, "radius")
    elapsed = time.perf_counter() - start
    assert elapsed < 1.0
    kind = BARE_UNITS[unit]
    message = str(caught.value)
    assert message.startswith(f"radius: expected {kind.noun} like {kind.example} or a bare number in {kind.bare}, "
                              "got ")
    assert "\n" not in message and len(message) < 200, message


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf"), 10**400, None, [8], True])
def test_python_values_that_are_no_finite_number_are_refused(value):
    with pytest.raises(ParameterError, match="^radius: expected a length"):
        parse_quantity(value, "m", "radius")


def test_length_limit_and_the_reason_in_the_message():
    assert parse_quantity("8" + " " * (MAX_LENGTH - 4) + "um", "m", "x")[0] == pytest.approx(8e-6, rel=1e-12)
    with pytest.raises(ParameterError, match=f"longer than {MAX_LENGTH} characters"):
        parse_quantity("8" + " " * MAX_LENGTH + "um", "m", "x")
    with pytest.raises(ParameterError, match=r"\(unknown unit 'furlongs'\)"):
        parse_quantity("8 furlongs", "m", "x")
    with pytest.raises(ParameterError, match=r"\(kPa is not a length\)"):
        parse_quantity("1kPa", "m", "x")
    with pytest.raises(ParameterError, match=r"\(not a finite number\)"):
        parse_quantity("inf kPa", "Pa", "x")
    with pytest.raises(ParameterError, match=r"exponents are at most 4"):
        parse_quantity("8 um^9", "m", "x")


def test_the_python_api_reads_bare_numbers_by_the_same_rule():
    """cell_parameters: bare radius/modulus dimensionless; lut.plan: bare numbers in um, uL/s, mPa*s, Pa;
    fit.parse_length: bare number in um."""
    from elastocell.inverse.fit import parse_length
    from elastocell.inverse.lut import plan
    from elastocell.parameters.cell import cell_parameters

    cell = cell_parameters(radius=8, youngs_modulus="1kPa")
    assert (cell.radius, cell.radius_is_physical, cell.youngs_modulus, cell.youngs_modulus_is_physical) == \
        (8.0, False, 1000.0, True)
    assert parse_length("8", "radius") == parse_length("8um", "radius")
    bare = plan(10, 0.04, 15, radii=[5], moduli=[1000], quick=True)
    quantities = plan("10um", "0.04uL/s", "15mPa*s", radii="5um", moduli="1kPa", quick=True)
    assert bare == quantities
    assert bare[1]["viscosity_mpa_s"] == pytest.approx(15, rel=1e-12)
