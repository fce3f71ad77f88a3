"""Shear-flow fits: the shipped shear master curve, D -> Ca -> mu, E with intervals, the CLI.

No flow is simulated here: every test uses the shipped nu = 0.48 curve (src/elastocell/data/
mastercurve_shear_neo-hookean_nu0.4800.csv, computed by ``python validation/mastercurves.py shear``).
"""

import json

import numpy as np
import pandas as pd
import pytest
import typer
from typer.testing import CliRunner

from elastocell.cli.fit import fit_app, mastercurve_app
from elastocell.inverse.fit import fit_shear
from elastocell.inverse.mastercurve_shear import ShearMasterCurve, load_shear_master_curve, richardson
from elastocell.parameters.units import ParameterError

app = typer.Typer()
app.add_typer(fit_app, name="fit")
app.add_typer(mastercurve_app, name="mastercurve")
runner = CliRunner()
TAU = 12.0  # Pa
NU = 0.48


@pytest.fixture(scope="module")
def curve():
    return load_shear_master_curve(NU)


def one_line_error(result, needle):
    lines = [line for line in result.output.strip().splitlines() if line]
    assert result.exit_code == 2, result.output
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert all(n in lines[0] for n in needle), lines[0]
    return lines[0]


def test_shipped_curve_is_sane(curve):
    """Reference: small-deformation theory D/Ca -> 5/4 (tolerance 5 %: the curve's first point is at Ca = 0.025,
    where D/Ca of a viscosity-ratio-1 cell is already a few % off the limit), D increasing with Ca, inclination
    below 45 deg and decreasing, tank-treading frequency below 1/2 (viscosity ratio 1); the raw columns of the
    two resolutions give the tabulated curve by Richardson extrapolation (exactly, rtol 1e-8: same formula)."""
    ca = curve.table["capillary_number"]
    d = curve.table["deformation"]
    assert d[0] / ca[0] == pytest.approx(1.25, rel=0.05)
    assert np.all(np.diff(d) > 0) and np.all(np.diff(curve.table["inclination_deg"]) < 0)
    assert np.all(curve.table["inclination_deg"] < 45.0)
    assert np.all(curve.table["tank_treading_frequency"] < 0.5)
    fine, coarse = curve.metadata["resolutions"][1], curve.metadata["resolutions"][0]
    assert np.allclose(richardson(curve.table[f"deformation_rdx{fine:g}"], curve.table[f"deformation_rdx{coarse:g}"],
                                  fine / coarse), d, rtol=1e-8)
    assert np.all(curve.table["deformation_error"] > 0)
    assert curve.metadata["runs"] and "command" in curve.metadata


@pytest.mark.parametrize("ca", [0.01, 0.025, 0.04, 0.1, 0.17, 0.3, 0.39])
def test_round_trip_recovers_the_modulus(curve, ca):
    """D = curve(Ca) at a known Ca -> Ca, mu = tau/Ca, E = 2 mu (1 + nu); reference: the known values, tolerance
    1e-7 relative (root finding on the curve's own interpolant; the interpolation error itself is the curve's
    error column, tested below)."""
    row = fit_shear(float(curve(ca)), TAU, curve=curve)
    assert row["capillary_number"] == pytest.approx(ca, rel=1e-7)
    assert row["shear_modulus"] == pytest.approx(TAU / ca, rel=1e-7)
    assert row["youngs_modulus"] == pytest.approx(2 * (1 + NU) * TAU / ca, rel=1e-7)
    assert row["shear_modulus_ci_low"] < row["shear_modulus"] < row["shear_modulus_ci_high"]


def test_interpolation_error_is_within_the_error_column(curve):
    """Leave one interior Ca out, interpolate D there from the others; reference: the tabulated D, tolerance: the
    curve's own error column at that Ca (the interpolation error must not exceed the discretisation error)."""
    ca = curve.table["capillary_number"]
    for k in range(1, ca.size - 1):
        keep = np.arange(ca.size) != k
        reduced = ShearMasterCurve({name: values[keep] for name, values in curve.table.items()}, NU)
        assert abs(float(reduced(ca[k])) - curve.table["deformation"][k]) <= curve.table["deformation_error"][k]


def test_small_deformation_limit(curve):
    """At D = 0.005 (Ca ~ 0.004) the curve is the theory blend: E within 1 % of the small-deformation estimate
    E = 2 (1 + nu) tau 5/4 / D (the blend reaches the theory linearly as Ca -> 0)."""
    row = fit_shear(0.005, TAU, curve=curve)
    assert row["youngs_modulus"] == pytest.approx(row["youngs_modulus_small_deformation"], rel=0.01)


def test_error_propagation_is_monotone_and_sane(curve):
    """Reference: the interval brackets the estimate; widens monotonically with D's uncertainty and with the
    shear stress's; with no measurement error it is the master-curve error alone, whose relative half-width is
    about z * relative curve error / sqrt(3) (the error column read as a uniform half-width; tolerance: a factor
    1.5, the inverse curve is nonlinear); E's interval is
    mu's times 2 (1 + nu) (rtol 1e-12)."""
    d = float(curve(0.1))
    widths = []
    for error in (0.0, 0.002, 0.005, 0.01, 0.02):
        row = fit_shear(d, TAU, deformation_error=error, curve=curve)
        assert row["shear_modulus_ci_low"] < row["shear_modulus"] < row["shear_modulus_ci_high"]
        widths.append(row["shear_modulus_ci_high"] - row["shear_modulus_ci_low"])
        for suffix in ("", "_ci_low", "_ci_high"):
            assert row[f"youngs_modulus{suffix}"] == pytest.approx(2 * (1 + NU) * row[f"shear_modulus{suffix}"],
                                                                  rel=1e-12)
    assert np.all(np.diff(widths) > 0)
    base = fit_shear(d, TAU, curve=curve)
    relative = (base["shear_modulus_ci_high"] - base["shear_modulus_ci_low"]) / (2 * base["shear_modulus"])
    expected = 1.96 * base["master_curve_relative_error"] / np.sqrt(3.0)
    assert expected / 1.5 < relative < 1.5 * expected
    stressed = fit_shear(d, TAU, shear_stress_error=0.05 * TAU, curve=curve)
    assert stressed["shear_modulus_ci_low"] < base["shear_modulus_ci_low"]
    assert stressed["shear_modulus_ci_high"] > base["shear_modulus_ci_high"]
    # a lower bound of D at or below zero leaves the modulus unbounded above
    huge = fit_shear(0.01, TAU, deformation_error=0.01, curve=curve)
    assert huge["shear_modulus_ci_high"] == np.inf and huge["shear_modulus_ci_low"] > 0


def test_tank_treading_second_observable(curve):
    """The frequency the curve predicts at the D-based Ca gives the same Ca back (rtol 1e-6), z = 0 and a
    consistent flag; a frequency far from it (0.5 x shear rate with a small error at Ca = 0.3) is flagged."""
    ca, rate = 0.2, 500.0
    omega = float(curve.value("tank_treading_frequency", ca)) * rate
    row = fit_shear(float(curve(ca)), TAU, 0.005, tank_treading_frequency=omega, tank_treading_frequency_error=2.0,
                    shear_rate=rate, curve=curve)
    assert row["capillary_number_tank_treading"] == pytest.approx(ca, rel=1e-6)
    assert row["tank_treading_z"] == pytest.approx(0.0, abs=1e-4) and row["tank_treading_consistent"]
    assert row["shear_modulus_combined"] == pytest.approx(TAU / ca, rel=1e-5)
    far = float(curve.value("tank_treading_frequency", 0.05)) * rate
    row = fit_shear(float(curve(0.3)), TAU, 0.002, tank_treading_frequency=f"{far}rad/s",
                    tank_treading_frequency_error=0.5, shear_rate=f"{rate}/s", curve=curve)
    assert not row["tank_treading_consistent"]
    with pytest.raises(ParameterError, match="shear-rate"):
        fit_shear(0.1, TAU, tank_treading_frequency=100.0, curve=curve)


def test_out_of_range_is_refused(curve):
    low, high = curve.range()
    for value in (0.0, -0.1, high * 1.01, 0.95):
        with pytest.raises(ParameterError) as error:
            fit_shear(value, TAU, curve=curve)
        assert error.value.parameter == "deformation" and f"{high:.4g}" in str(error.value)


def test_cli_single_cell_and_outputs(tmp_path, curve):
    d = float(curve(0.1))
    out = tmp_path / "o"
    result = runner.invoke(app, ["fit", "shear", "--deformation", f"{d!r}", "--shear-stress", "12Pa",
                                 "--deformation-error", "0.005", "--radius", "8um", "--out", str(out)])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out / "shear_fits.csv")
    assert list(table.columns[:10]) == ["cell", "deformation", "shear_stress", "capillary_number", "shear_modulus",
                                        "shear_modulus_ci_low", "shear_modulus_ci_high", "youngs_modulus",
                                        "youngs_modulus_ci_low", "youngs_modulus_ci_high"]
    assert table["shear_modulus"][0] == pytest.approx(120.0, rel=1e-6)
    assert table["radius"][0] == pytest.approx(8e-6)
    settings = json.loads((out / "fit_settings.json").read_text())
    assert settings["kind"] == "shear" and settings["poisson_ratio"] == NU
    assert settings["master_curve"]["deformation_range"][1] == pytest.approx(curve.range()[1])


def test_cli_table_keeps_order(tmp_path, curve):
    cas = [0.3, 0.05, 0.15]
    path = tmp_path / "cells.csv"
    pd.DataFrame({"cell": ["a", "b", "c"], "deformation": [float(curve(c)) for c in cas],
                  "shear_stress": [10.0, 20.0, 30.0], "deformation_error": [0.01, 0.0, 0.002]}).to_csv(path, index=False)
    result = runner.invoke(app, ["fit", "shear", "--table", str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(tmp_path / "o" / "shear_fits.csv", dtype={"cell": str})
    assert list(table["cell"]) == ["a", "b", "c"]
    assert np.allclose(table["shear_modulus"], np.array([10.0, 20.0, 30.0]) / cas, rtol=1e-6)


@pytest.mark.parametrize("arguments,needle", [
    (["--deformation", "0.95", "--shear-stress", "10Pa"], ["--deformation", "outside", "range"]),
    (["--deformation", "0", "--shear-stress", "10Pa"], ["--deformation", "range"]),
    (["--deformation", "0.1", "--shear-stress", "-1Pa"], ["--shear-stress"]),
    (["--deformation", "0.1", "--shear-stress", "10m"], ["--shear-stress"]),
    (["--deformation", "0.1"], ["--shear-stress", "missing"]),
    (["--deformation", "0.1", "--shear-stress", "10", "--poisson-ratio", "0.3"], ["--poisson-ratio", "compute it"]),
    (["--deformation", "0.1", "--shear-stress", "10", "--tank-treading-frequency", "50"], ["--shear-rate"]),
    (["--deformation", "0.1", "--shear-stress", "10", "--deformation-error", "-1"], ["--deformation-error"]),
])
def test_cli_impossible_input_is_one_line_exit_2(tmp_path, arguments, needle):
    result = runner.invoke(app, ["fit", "shear", *arguments, "--out", str(tmp_path / "o")])
    one_line_error(result, needle)


def test_cli_table_out_of_range_names_the_cell(tmp_path):
    path = tmp_path / "cells.csv"
    path.write_text("deformation,shear_stress\n0.1,10\n0.97,10\n")
    result = runner.invoke(app, ["fit", "shear", "--table", str(path), "--out", str(tmp_path / "o")])
    one_line_error(result, ["--table", "cell 2", "deformation", "range"])
    path.write_text("deformation,stress\n0.1,10\n")
    result = runner.invoke(app, ["fit", "shear", "--table", str(path), "--out", str(tmp_path / "o")])
    one_line_error(result, ["--table", "shear_stress"])


def test_mastercurve_shear_command_reads_the_shipped_curve(tmp_path):
    out = tmp_path / "curve.csv"
    result = runner.invoke(app, ["mastercurve", "shear", "--poisson-ratio", "0.48", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "shipped" in result.output
    again = ShearMasterCurve.from_csv(out)
    assert np.allclose(again.table["deformation"], load_shear_master_curve(NU).table["deformation"])
