"""The rtdc-nucleus study (the modulus RT-DC assigns a nucleus cell) and the nucleus options of the look-up
table."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from elastocell.cli.app import app
from elastocell.inverse.lut import compute_lut, plan, read_lut
from elastocell.parameters.units import ParameterError
from elastocell.studies import STUDIES
from elastocell.studies.base import read_study_table
from elastocell.studies.rtdc_nucleus import (
    CAPILLARY_NUMBER_WALL,
    fit_modulus,
    read_modulus,
    shape_vector,
    table_modulus,
)

LUT = ["lut", "--channel-radius", "10.94um", "--flow-rate", "0.04uL/s", "--viscosity", "15mPa*s", "--quick"]


# =========================================================================== reading through a table
def test_read_modulus_inverts_a_power_law_exactly():
    # Reference: D = 0.05 (E/E_c)^-1.2 is a straight line in log D - log E, which the log-log interpolation
    # reproduces to rounding (measured: 2e-16 relative).
    ratios = np.array([1.0, 1.5, 2.25, 3.5, 5.0])
    d = 0.05 * ratios**-1.2
    target = np.array([1.2, 3.0, 4.9])
    read = read_modulus(0.05 * target**-1.2, ratios, d)
    assert read == pytest.approx(target, rel=1e-12)
    assert np.isnan(read_modulus([0.06, 0.001], ratios, d)).all()  # outside the runs: no extrapolation
    assert np.isnan(read_modulus([0.03], ratios[:1], d[:1])).all()


def test_fit_modulus_recovers_a_homogeneous_shape_and_skips_a_sign_change():
    # Reference: shape vectors of power laws in E (exact in log-log, as above); the strain entry with a sign
    # change across the runs is left out, so the fit rests on the two others and still recovers s exactly up to
    # the search grid (2001 points over log 5: 8e-4 relative spacing).
    ratios = np.array([1.0, 2.0, 5.0])
    shapes = shape_vector(0.05 * ratios**-1.1, 1 + 0.03 * ratios**-1.0, 1 - 0.01 * ratios**-0.9)
    s = 2.7
    cell = shape_vector(0.05 * s**-1.1, 1 + 0.03 * s**-1.0, 1 - 0.01 * s**-0.9)
    assert fit_modulus(cell, ratios, shapes) == pytest.approx(s, rel=1e-3)
    shapes[0, 2] = 0.002  # eps_r - 1 changes sign between the runs: left out
    assert fit_modulus(cell, ratios, shapes) == pytest.approx(s, rel=1e-3)
    assert np.isnan(fit_modulus(cell, ratios[:1], shapes[:1]))


def test_dclab_reads_its_own_table_back():
    # Reference: rows of LE-2D-FEM-19 itself (dclab's load_lut, its own channel, flow and viscosity): read back at
    # a table node, dclab's interpolation returns the node's modulus, here converted to nu = 0.48 at equal shear
    # modulus: E_t x 2 (1.48)/3. Tolerance 1 % (measured: 0 at the nodes taken).
    from dclab.features.emodulus.load import load_lut

    table, meta = load_lut("LE-2D-FEM-19")
    assert meta["channel_width"] == 20.0 and meta["flow_rate"] == 0.04 and meta["fluid_viscosity"] == 15.0
    rows = table[(table[:, 0] > 90) & (table[:, 0] < 130) & (table[:, 1] > 0.01)][::50][:5]
    modulus, note = table_modulus(rows[:, 0], rows[:, 1])
    assert note == "" and len(rows) >= 3
    assert modulus == pytest.approx(rows[:, 2] * 2 * 1.48 / 3, rel=0.01)
    outside, _ = table_modulus([1.0], [0.5])
    assert np.isnan(outside[0])


# =========================================================================== the look-up table's nucleus options
def test_a_homogeneous_table_keeps_its_keys():
    # The run keys of the quick grid as the table computed them before the nucleus options existed (a cache
    # made then is read back, not recomputed): those runs held the pressure gradient with the markers at R on the
    # staircase wall, so a point holding G (hold_flow_rate=False) with c = 0 on the staircase (all three left out of
    # the parameters) keeps that key, and one of the defaults (the flow rate held, the markers at R - 0.3 dx, the
    # interpolated wall) has another.
    from elastocell.inverse.lut import point_key

    points, settings = plan("10.94um", "0.04uL/s", "15mPa*s", quick=True)
    held_g = [point_key(p["radius_um"], p["emodulus_kpa"],
                        {**p["options"], "hold_flow_rate": False, "hydrodynamic_radius_correction": 0.0,
                         "channel_wall": "staircase"})
              for p in points]
    assert held_g == ["R5um_E1kPa_66eca0adff", "R5um_E2kPa_25e4ba55e8", "R6um_E1kPa_755b393729",
                      "R6um_E2kPa_9b3eba19ac"]
    assert not set(held_g) & {p["key"] for p in points}
    assert points[0]["options"]["nucleus"] == "none" and "stiffness_ratio" not in points[0]["options"]
    assert settings["cell_model"] == "homogeneous"


def test_a_nucleated_table_plans_the_pipe_nucleus_cell():
    homogeneous, _ = plan("10.94um", "0.04uL/s", "15mPa*s", quick=True)
    points, settings = plan("10.94um", "0.04uL/s", "15mPa*s", quick=True, stiffness_ratio=5, size_ratio=0.6)
    options = points[0]["options"]
    assert (options["nucleus"], options["stiffness_ratio"], options["size_ratio"]) == ("sphere", 5.0, 0.6)
    # the same physical driving: Ca_w against the cytoplasm's mu_c, so emodulus is E_c
    assert options["capillary_number_wall"] == homogeneous[0]["options"]["capillary_number_wall"]
    assert {p["key"] for p in points}.isdisjoint({p["key"] for p in homogeneous})
    assert settings["cell_model"] == "nucleus"
    assert settings["volume_average_ratio"] == pytest.approx(1 + 4 * 0.6**3)
    default, _ = plan("10.94um", "0.04uL/s", "15mPa*s", quick=True, stiffness_ratio=5)
    assert default[0]["options"]["size_ratio"] == 0.5  # as pipe's nucleus cell
    with pytest.raises(ParameterError) as error:
        plan("10.94um", "0.04uL/s", "15mPa*s", quick=True, size_ratio=0.5)
    assert error.value.parameter == "size_ratio"


@pytest.mark.parametrize("extra, option", [
    (["--size-ratio", "0.5"], "--size-ratio"),
    (["--stiffness-ratio", "2", "--size-ratio", "1.5"], "--size-ratio"),
    (["--stiffness-ratio", "0"], "--stiffness-ratio"),
])
def test_nucleus_option_refusals(tmp_path, extra, option):
    result = CliRunner().invoke(app, LUT + ["--out", str(tmp_path / "lut.txt"), *extra])
    assert result.exit_code == 2, result.output
    line = result.output.strip().splitlines()[-1]
    assert option in line
    assert not (tmp_path / "lut_runs").exists()  # refused before any computing


class _Client:
    """Stands in for a Dask client: runs the task in this process."""

    def submit(self, function, *args, pure=False):
        from concurrent.futures import Future

        future = Future()
        future.set_result(function(*args))
        return future


def test_a_nucleated_table_runs_the_nucleus_cell(tmp_path, monkeypatch):
    """One tiny real run (R/dx 4, 0.1 units of time): the pipe run's own summary holds the nucleus, the table's
    metadata the cell model."""
    import distributed

    monkeypatch.setattr(distributed, "as_completed", lambda futures: list(futures))
    out = tmp_path / "lut.txt"
    result = compute_lut(out, "10.94um", "0.04uL/s", "15mPa*s", radii="6", moduli="2kPa", quick=True, duration=0.1,
                         client=_Client(), stiffness_ratio=10, size_ratio=0.5)
    assert not result["failures"], result["failures"]
    summary = json.loads(next((tmp_path / "lut_runs").rglob("summary.json")).read_text())
    assert summary["cell"]["nucleus"]["shape"] == "sphere"
    assert summary["cell"]["nucleus"]["stiffness_ratio"] == 10.0
    assert summary["effective_stiffness_ratio"] > 1.5  # gamma 10, lambda 0.5: 1 + 9/8 in the continuum
    data, meta, _ = read_lut(out)
    assert data.shape == (1, 3)
    assert meta["elastocell"]["cell_model"] == "nucleus"
    assert "gamma 10" in meta["model"] and "E_c" in meta["summary"]
    assert "stiff nucleus" in out.read_text().splitlines()[0]


# =========================================================================== the study
def test_the_study_is_registered():
    assert "rtdc-nucleus" in STUDIES
    result = CliRunner().invoke(app, ["study", "list"])
    assert "rtdc-nucleus" in result.output
    members = STUDIES["rtdc-nucleus"].members(False)
    cells = {(m.labels["stiffness_ratio"], m.labels["size_ratio"]) for m in members if m.labels["kind"] == "nucleus"}
    assert cells == {(g, s) for g in (2.0, 5.0, 10.0) for s in (0.3, 0.5, 0.7)}
    assert any(m.labels["kind"] == "random" for m in members)
    # every cell sees the cytoplasm's Ca_w (one pressure gradient); the homogeneous readers Ca_w/s
    for member in members:
        options = member.run.kwargs
        ratio = member.labels["modulus_ratio"]
        expected = CAPILLARY_NUMBER_WALL / ratio if member.labels["kind"] == "homogeneous" else CAPILLARY_NUMBER_WALL
        assert options["capillary_number_wall"] == pytest.approx(expected)
        assert options["start_offset"] == 0.0


@pytest.mark.slow
def test_quick_study_runs_and_a_stiffer_nucleus_reads_stiffer(tmp_path):
    """`elastocell study run rtdc-nucleus --quick` (4 runs at R/dx 5 for 4 units of 1/gdot_w; measured 21 s wall
    on the idle 2-core machine, warm Numba cache): table, figure and claims; at equal E_c and nucleus size, the gamma 10 cell deforms
    less than the gamma 2 cell and the homogeneous table reads it stiffer (a simulated outcome, not built in)."""
    result = CliRunner().invoke(app, ["study", "run", "rtdc-nucleus", "--quick", "--workers", "1", "--out",
                                      str(tmp_path), "--quiet"])
    assert result.exit_code == 0, result.output
    for suffix in (".png", ".pdf", ".csv", ".parquet", ".claims.json"):
        assert (tmp_path / f"rtdc-nucleus{suffix}").exists(), suffix
    frame, metadata = read_study_table(tmp_path, "rtdc-nucleus")
    assert metadata["quick"] is True and (frame["status"] == "complete").all()
    cells = frame[frame["kind"] == "nucleus"].set_index("stiffness_ratio")
    assert cells.loc[10.0, "deformation"] < cells.loc[2.0, "deformation"]
    assert cells.loc[10.0, "e_rtdc_over_ec"] > cells.loc[2.0, "e_rtdc_over_ec"]
    assert np.isfinite(cells["e_rtdc_over_ec"]).all() and np.isfinite(cells["e_eff_over_ec"]).all()
    homogeneous = frame[frame["kind"] == "homogeneous"]
    assert homogeneous["e_rtdc_over_ec"].to_numpy() == pytest.approx(homogeneous["modulus_ratio"].to_numpy())
    claims = json.loads((tmp_path / "rtdc-nucleus.claims.json").read_text())["claims"]
    stiffer = next(c for c in claims if "stiffer nucleus" in c["claim"])
    assert stiffer["verdict"] == "agree"
    dclab = next(c for c in claims if "LE-2D-FEM-19" in c["claim"])
    assert "covers" in dclab["measured"]  # the table's coverage is recorded
