"""Look-up tables for deformability cytometry (elastocell lut): physics mapping, dclab format, refusals."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from elastocell.api.resolved import resolved_parameters
from elastocell.cli.app import app
from elastocell.inverse.lut import (
    capillary_number_wall,
    compute_lut,
    isoelastics_path,
    lut_metadata,
    plan,
    pressure_gradient,
    read_lut,
    runs_directory,
    wall_shear_rate,
    write_isoelastics,
    write_lut,
)
from elastocell.parameters.units import ParameterError

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[1]
BASE = ["lut", "--channel-radius", "10um", "--flow-rate", "0.04uL/s", "--viscosity", "15mPa*s"]


def test_flow_rate_to_capillary_number_by_hand():
    # Q = 0.04 uL/s = 4e-11 m^3/s, R_ch = 10 um, eta = 15 mPa s, E = 1 kPa, nu = 0.48
    g = 8 * 0.015 * 4e-11 / (math.pi * 1e-20)  # Pa/m
    assert pressure_gradient(4e-11, 1e-5, 0.015) == pytest.approx(g, rel=1e-12)
    assert g == pytest.approx(1.5279e8, rel=1e-4)
    mu = 1000 / (2 * 1.48)
    assert capillary_number_wall(4e-11, 1e-5, 0.015, 1000.0, 0.48) == pytest.approx(g * 1e-5 / (2 * mu), rel=1e-12)
    assert capillary_number_wall(4e-11, 1e-5, 0.015, 1000.0, 0.48) == pytest.approx(2.2613, rel=1e-4)
    assert wall_shear_rate(4e-11, 1e-5, 0.015) == pytest.approx(4 * 4e-11 / (math.pi * 1e-15), rel=1e-12)
    # the poiseuille flow rate of the pipe module inverts G
    from elastocell.scenarios.pipe import poiseuille_flow_rate

    assert poiseuille_flow_rate(g, 0.015, 1e-5) == pytest.approx(4e-11, rel=1e-12)


def test_power_law_keys_same_on_every_machine(monkeypatch):
    """A power-law duct point's key does not follow the last bits of q1(n), which an iterative sparse solve gives
    differently on different machines (1e-14 relative measured between two machines; 1e-12 is the solve's own
    tolerance): the same table keeps its finished points wherever it is resumed. A 1e-7 change (a different
    medium) still changes the key."""
    import elastocell.inverse.lut as lut_module

    def keys():
        points, _ = plan(None, "0.04uL/s", None, radii=[5], moduli=[2000], channel_width="20um",
                         channel_shape="square", medium="0.59%MC-PBS", temperature=23)
        return points[0]["key"]

    exact = keys()
    solve = lut_module.unit_flow_rate
    for change in (1 + 1e-12, 1 - 1e-12):
        monkeypatch.setattr(lut_module, "unit_flow_rate", lambda *a, change=change: solve(*a) * change)
        assert keys() == exact
    monkeypatch.setattr(lut_module, "unit_flow_rate", lambda *a: solve(*a) * (1 + 1e-7))
    assert keys() != exact


def test_plan_units_and_grid():
    points, settings = plan("10um", "0.04uL/s", "15mPa*s", radii="5, 6um", moduli="1kPa, 2kPa", quick=True)
    assert len(points) == 4
    assert settings["channel_radius_um"] == pytest.approx(10)
    assert settings["flow_rate_ul_s"] == pytest.approx(0.04)
    assert settings["viscosity_mpa_s"] == pytest.approx(15)
    first = points[0]
    assert first["radius_um"] == pytest.approx(5) and first["emodulus_kpa"] == pytest.approx(1)
    assert first["options"]["channel_radius_ratio"] == pytest.approx(2.0)
    assert first["options"]["start_offset"] == 0.0 and first["options"]["nucleus"] == "none"
    assert first["options"]["capillary_number_wall"] == pytest.approx(2.2613, rel=1e-4)
    # bare numbers read in um, uL/s, mPa s, Pa; keys change with the inputs
    same, _ = plan(10, 0.04, 15, radii=[5, 6], moduli=[1000, 2000], quick=True)
    assert [p["key"] for p in same] == [p["key"] for p in points]
    other, _ = plan(10, 0.08, 15, radii=[5, 6], moduli=[1000, 2000], quick=True)
    assert other[0]["key"] != points[0]["key"]
    full, settings = plan("10um", "0.04uL/s", "15mPa*s")
    assert len(full) == 48 and settings["resolution"] == 8 and settings["coarse_resolution"] is None
    # the default: one run per point at R/dx 8, the markers at R - 0.3 dx, both said in the point's options (so no
    # point made before, extrapolated or at c = 0, is taken for one of these)
    assert all(p["options"]["extrapolate"] is False for p in full)
    assert all(p["options"]["hydrodynamic_radius_correction"] == 0.3 for p in full)
    assert settings["hydrodynamic_radius_correction"] == 0.3
    # the default the pipe had before: the pair with the markers at R, said in the options
    earlier, settings = plan("10um", "0.04uL/s", "15mPa*s", extrapolate=True, hydrodynamic_radius_correction=0)
    assert settings["hydrodynamic_radius_correction"] == 0.0
    assert all(p["options"]["hydrodynamic_radius_correction"] == 0.0 for p in earlier)
    assert not {p["key"] for p in earlier} & {p["key"] for p in full}
    # the cylinder's wall, said in the options and the settings: the interpolated wall (default), or the staircase,
    # which resolves as the points made before the choice (their keys stay) and makes other points
    assert all(p["options"]["channel_wall"] == "interpolated" for p in full)
    staircase, staircase_settings = plan("10um", "0.04uL/s", "15mPa*s", channel_wall="staircase")
    assert all(p["options"]["channel_wall"] == "staircase" for p in staircase)
    assert all("channel_wall" not in resolved_parameters("pipe", p["options"])["flow"].model_dump() for p in staircase)
    assert staircase_settings["channel_wall"] == "staircase" and not {p["key"] for p in staircase} & {p["key"] for p in full}
    with pytest.raises(ParameterError, match="channel_wall"):
        plan("10um", "0.04uL/s", "15mPa*s", channel_wall="smooth")
    # a square duct's plane walls are the same either way: its points have one key whatever wall is asked for
    # (POINT_KEY_FORMAT 2: the duct's lattice is the channel's own width)
    for wall in (None, "staircase", "interpolated"):
        duct, _ = plan(None, "0.04uL/s", None, radii=[5], moduli=[2000], channel_width="20um", channel_shape="square",
                       medium="0.59%MC-PBS", temperature=23, channel_wall=wall)
        assert duct[0]["key"] == "R5um_E2kPa_2d6eb2ab1a"
    # extrapolated: a cell above R_ch/(1 + 2/6) = 7.5 um in R_ch = 10 um keeps the kernel's reach + 1 dx from the
    # wall at R/dx 8, not at the coarse R/dx 6: its points run at one resolution; the others are extrapolated; the
    # default grid's largest cell is the largest R/dx 8 takes (R_ch/R >= 1.25)
    full, settings = plan("10um", "0.04uL/s", "15mPa*s", extrapolate=True)
    assert settings["coarse_resolution"] == 6
    assert max(p["radius_um"] for p in full) > 7.5
    assert all(p["options"]["extrapolate"] is False for p in full if p["radius_um"] > 7.5)
    assert all(p["options"]["extrapolate"] is True for p in full if p["radius_um"] < 7.5)
    assert all(resolved_parameters("pipe", p["options"])["options"]["extrapolation"]["coarse_resolution"] == 6
               for p in full if p["radius_um"] < 7.5)
    # a square channel of width W stands for the cylinder R_ch = 1.094 W/2 (Mietke et al. 2015; dclab LE-2D-FEM-19)
    square, settings = plan(None, 0.04, 15, radii=[5], moduli=[1000], quick=True, channel_width="20um")
    assert settings["channel_radius_um"] == pytest.approx(10.94)
    assert square[0]["options"]["channel_radius_ratio"] == pytest.approx(10.94 / 5)
    assert lut_metadata(settings, "x")["channel_width"] == pytest.approx(20.0)
    for radius, width in ((None, None), ("10um", "20um")):
        with pytest.raises(ParameterError, match="channel_radius"):
            plan(radius, 0.04, 15, quick=True, channel_width=width)


def _fake_records():
    records = []
    for e in (1.0, 2.0):
        for r in (5.0, 6.0):
            records.append({"radius_um": r, "emodulus_kpa": e, "area_um": math.pi * r**2 * 1.01,
                            "deform": 0.05 * r / 5 / e})
    return records


def _settings():
    return plan("10um", "0.04uL/s", "15mPa*s", quick=True)[1]


def test_lut_file_header_and_columns(tmp_path):
    meta = lut_metadata(_settings(), "elastocell-test")
    path = write_lut(tmp_path / "lut.txt", _fake_records(), meta)
    text = path.read_text().splitlines()
    assert text[0].startswith("#")
    data, parsed, header = read_lut(path)
    assert header == ["area_um [um^2]", "deform", "emodulus [kPa]"]
    for key, value in (("channel_width_unit", "um"), ("flow_rate_unit", "uL/s"), ("fluid_viscosity_unit", "mPa s"),
                       ("identifier", "elastocell-test")):
        assert parsed[key] == value
    for key in ("channel_width", "flow_rate", "fluid_viscosity", "method", "model", "software", "date",
                "dimensionality", "summary"):
        assert key in parsed
    assert parsed["channel_width"] == pytest.approx(20.0 / 1.094)  # the square channel R_ch = 10 um stands for
    assert "square" in parsed["summary"].lower() and "cylindrical" in parsed["summary"].lower()
    assert data.shape == (4, 3)
    assert np.all(np.diff(data[:, 2]) >= 0)  # sorted by modulus, then area
    iso = write_isoelastics(isoelastics_path(tmp_path / "lut.txt"), _fake_records(), meta)
    iso_data, iso_meta, iso_header = read_lut(iso)
    assert iso.name == "lut_isoelastics.txt"
    assert iso_meta["lut identifier"] == "elastocell-test" and "identifier" not in iso_meta
    assert iso_header == header and iso_data.shape == (4, 3)


def test_dclab_loads_the_lut_and_isoelastics(tmp_path):
    dclab = pytest.importorskip("dclab")
    from dclab.features import emodulus

    meta = lut_metadata(_settings(), "elastocell-dclab-test")
    path = write_lut(tmp_path / "lut.txt", _fake_records(), meta)
    lut, loaded = emodulus.load_lut(str(path))
    assert lut.shape == (4, 3)
    assert loaded["column features"] == ["area_um", "deform", "emodulus"]
    emodulus.register_lut(path)
    assert "elastocell-dclab-test" in emodulus.load.EXTERNAL_LUTS
    iso = dclab.isoelastics.Isoelastics([])
    iso.load_data(write_isoelastics(tmp_path / "iso.txt", _fake_records(), meta))


@pytest.mark.parametrize("extra, option", [
    (["--flow-rate", "-0.04uL/s"], "--flow-rate"),
    (["--viscosity", "0"], "--viscosity"),
    (["--radii", "12"], "--radii"),
    (["--radii", "9.5"], "--radii"),
    (["--flow-rate", "0.04 kg"], "--flow-rate"),
    (["--workers", "0"], "--workers"),
    (["--channel-width", "20um"], "--channel-radius"),
    (["--identifier", "LE-2D-FEM-19"], "--identifier"),  # dclab's register_lut refuses its own tables' names
    (["--identifier", " "], "--identifier"),
    (["--resolution", "0"], "--resolution"),  # was a ZeroDivisionError
    (["--resolution", "-3"], "--resolution"),  # was blamed on --hydrodynamic-radius-correction
    (["--moduli", "1,2"], "--moduli"),  # 1 Pa: Ca_w beyond the pipe's limit, was named --capillary-number-wall
    (["--duration", "0.05"], "--duration"),  # under one record interval: each point failed after the lock was taken
    (["--subdivisions", "0"], "--subdivisions"),
    (["--subdivisions", "65"], "--subdivisions"),  # the rows grow as its square
])
def test_one_line_refusals(tmp_path, extra, option):
    _refused(BASE, extra, option, tmp_path)


def test_a_modulus_too_soft_for_the_flow_is_refused_with_the_bare_number_rule(tmp_path):
    """A bare modulus is in Pa: "1,2" meant as kPa makes Ca_w ~ 1e3; the refusal names --moduli, the point and the
    rule, and writes nothing."""
    result = runner.invoke(app, BASE + ["--out", str(tmp_path / "lut.txt"), "--quick", "--moduli", "1,2"])
    assert result.exit_code == 2
    assert "--moduli: R = 5 um, E = 1 Pa: the wall capillary number" in result.output
    assert "write 1kPa" in result.output
    assert not (tmp_path / "lut_runs").exists()


def _refused(base: list[str], extra: list[str], option: str, tmp_path) -> None:
    """``base`` with the pairs of ``extra`` replaced or added exits 2 with one line naming ``option``, and runs
    nothing."""
    args = base + ["--out", str(tmp_path / "lut.txt"), "--quick"]
    for i in range(0, len(extra), 2):  # replace or add
        if extra[i] in args:
            args[args.index(extra[i]) + 1] = extra[i + 1]
        else:
            args += extra[i:i + 2]
    result = runner.invoke(app, args)
    assert result.exit_code == 2
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"elastocell: error: {option}:"), result.output
    assert not (tmp_path / "lut_runs").exists()


def test_unknown_option_refused(tmp_path):
    result = runner.invoke(app, BASE + ["--out", str(tmp_path / "lut.txt"), "--bogus", "1"])
    assert result.exit_code == 2
    assert "No such option" in result.output


class _Client:
    """Stands in for a Dask client: runs the task in this process."""

    def submit(self, function, *args, pure=False):
        from concurrent.futures import Future

        future = Future()
        future.set_result(function(*args))
        return future


def test_quick_grid_end_to_end(tmp_path, monkeypatch):
    """Two tiny real runs (R/dx 4, 0.3 units of time) through compute_lut; the rerun reads them back."""
    import distributed

    monkeypatch.setattr(distributed, "as_completed", lambda futures: list(futures))
    out = tmp_path / "lut.txt"
    kwargs = dict(radii="5", moduli="1kPa,2kPa", quick=True, duration=0.3, client=_Client())
    result = compute_lut(out, "10um", "0.04uL/s", "15mPa*s", **kwargs)
    assert not result["failures"], result["failures"]
    data, meta, header = read_lut(out)
    # the 2 computed points and the 7 rows refined_rows puts between them (8 subdivisions by default)
    assert data.shape == (9, 3) and header[0] == "area_um [um^2]"
    assert {k: meta["elastocell"]["rows"][k] for k in ("computed", "interpolated", "subdivisions")} == {
        "computed": 2, "interpolated": 7, "subdivisions": 8}
    assert read_lut(tmp_path / "lut_isoelastics.txt")[0].shape == (2, 3)  # the computed points' lines
    assert np.all(np.isfinite(data)) and np.all(data[:, 0] > 0)
    # area in um^2: about pi R^2 for R = 5 um
    assert 0.5 * math.pi * 25 < data[0, 0] < 1.5 * math.pi * 25
    assert meta["elastocell"]["finished"] == 2
    assert len(meta["elastocell"]["not_stationary"]) == 2  # 0.3 units of time, no stationarity criterion
    runs = sorted((tmp_path / "lut_runs").iterdir())
    assert len(runs) == 2 and all((r / "point.json").exists() for r in runs)
    record = json.loads((runs[0] / "point.json").read_text())
    assert record["options"]["start_offset"] == 0.0
    again = compute_lut(out, "10um", "0.04uL/s", "15mPa*s", **kwargs)  # finished points are read back
    assert [r["wall_time_s"] for r in again["records"]] == [r["wall_time_s"] for r in result["records"]]


def test_a_point_reads_its_shape_over_the_final_window(tmp_path):
    # Reference: the definition (means over the last FINAL_WINDOW units of time), on a time series whose
    # deformation still rises over the second half, where the second-half mean would read low.
    from elastocell.inverse.lut import FINAL_WINDOW, final_shape

    time = np.linspace(0.0, 6.0, 61)
    deformation = 0.04 * (1.0 - np.exp(-time))
    area = 3.1 + 0.01 * time
    path = tmp_path / "timeseries.csv"
    np.savetxt(path, np.column_stack([time, deformation, area]), delimiter=",",
               header="time,deformation,projected_area", comments="")
    final = final_shape(path)
    last = time > time[-1] - FINAL_WINDOW
    assert final["deformation"] == pytest.approx(deformation[last].mean(), rel=1e-12)
    assert final["projected_area"] == pytest.approx(area[last].mean(), rel=1e-12)
    assert final["deformation_std"] == pytest.approx(deformation[last].std(), rel=1e-12)
    assert final["deformation"] > deformation[time >= 3.0].mean()


# --------------------------------------------------------------------------- square channel, MC-PBS medium
SQUARE = ["lut", "--channel-shape", "square", "--channel-width", "20um", "--flow-rate", "0.04uL/s"]


def test_driving_carries_the_flow_rate():
    """G of channel_driving, put back into the flow-rate laws, returns Q. References: the closed forms of the tube
    (Newtonian and power law), White's series for the Newtonian duct, and the finite-volume power-law duct solver
    run at other G, K and half-width than the unit problem q1(n) was solved for (the scaling law
    Q = q1 (G/K)^(1/n) a^(3+1/n)), on 48 cells against q1's 64: measured 8.4e-6 apart (tolerance 1e-4)."""
    from elastocell.inverse.lut import channel_driving
    from elastocell.lattice.rheology import PowerLaw, tube_flow_rate
    from elastocell.parameters.medium import mc_pbs
    from elastocell.scenarios.pipe import duct_flow_rate, finite_difference_duct_flow_rate

    fluid = mc_pbs("0.59%MC-PBS", 23.0)
    n, k = fluid.flow_index, fluid.consistency
    q, a = 4e-11, 1e-5
    tube = channel_driving("cylinder", a, q, fluid)
    assert tube_flow_rate(tube["pressure_gradient"], k, n, a) == pytest.approx(q, rel=1e-12)
    newtonian = channel_driving("square", a, q, None, 0.015)
    assert duct_flow_rate(newtonian["pressure_gradient"], 0.015, a, a) == pytest.approx(q, rel=1e-12)
    assert newtonian["wall_shear_rate"] == pytest.approx(newtonian["wall_shear_stress"] / 0.015, rel=1e-12)
    duct = channel_driving("square", a, q, fluid)
    assert duct["wall_shear_stress"] == pytest.approx(duct["pressure_gradient"] * 2 * a / 4, rel=1e-12)  # G W/4
    assert k * duct["wall_shear_rate"] ** n == pytest.approx(duct["wall_shear_stress"], rel=1e-12)
    # the same duct in other units: half-width 3, K = 2, G from the scaling law, solved directly
    scaled = channel_driving("square", 3.0, 5.0, type(fluid)(name="p", model="power-law", flow_index=n,
                                                             consistency=2.0))
    law = PowerLaw(n, 2.0, relaxation_time_min=0.5 + 3e-12, relaxation_time_max=0.5 + 3e9)
    solved = finite_difference_duct_flow_rate(law, scaled["pressure_gradient"], 3.0, 3.0, cells=48, tolerance=1e-12)
    assert solved == pytest.approx(5.0, rel=1e-4)


def test_dclab_fluid_viscosity_is_dclabs():
    # Reference: dclab's own viscosity of the medium in the square channel (Buyukurganci 2022, Kozicki shear rate)
    pytest.importorskip("dclab")
    from dclab.features.emodulus.viscosity import get_viscosity

    from elastocell.inverse.lut import dclab_viscosity
    from elastocell.parameters.medium import mc_pbs

    for name in ("0.49%MC-PBS", "0.59%MC-PBS", "0.83%MC-PBS"):
        for t in (22.0, 23.0, 37.0):
            for q, w in ((0.04, 20.0), (0.16, 30.0)):
                eta = get_viscosity(medium=name.replace("%", "% "), channel_width=w, flow_rate=q, temperature=t,
                                    model="buyukurganci-2022")
                ours = dclab_viscosity(mc_pbs(name, t), q * 1e-9, w * 1e-6)
                assert ours * 1e3 == pytest.approx(float(eta), rel=1e-10)


def test_plan_square_channel_in_mc_pbs():
    pytest.importorskip("dclab")
    from elastocell.inverse.lut import channel_driving
    from elastocell.parameters.medium import mc_pbs

    points, settings = plan(None, "0.04uL/s", None, radii="5um", moduli="1kPa,2kPa", quick=True,
                            channel_width="20um", channel_shape="square", medium="0.59% MC-PBS", temperature=23)
    options = points[0]["options"]
    assert options["channel_shape"] == "square" and options["medium"] == "0.59%MC-PBS"
    assert options["temperature"] == 23.0
    assert options["channel_radius_ratio"] == pytest.approx(2.0)  # W/(2R): the duct itself, no 1.094
    tau = channel_driving("square", 1e-5, 4e-11, mc_pbs("0.59%MC-PBS", 23.0))["wall_shear_stress"]
    assert options["capillary_number_wall"] == pytest.approx(tau / (1000 / (2 * 1.48)), rel=1e-12)  # tau_w/mu
    assert points[1]["options"]["capillary_number_wall"] == pytest.approx(options["capillary_number_wall"] / 2)
    from dclab.features.emodulus.viscosity import get_viscosity  # the metadata's fluid_viscosity is dclab's

    assert settings["viscosity_mpa_s"] == pytest.approx(get_viscosity(
        medium="0.59% MC-PBS", channel_width=20.0, flow_rate=0.04, temperature=23.0, model="buyukurganci-2022"))
    meta = lut_metadata(settings, "sq")
    assert meta["channel_width"] == pytest.approx(20.0)
    assert meta["fluid_flow_behaviour_index"] == pytest.approx(settings["flow_index"])
    assert meta["fluid_temperature"] == 23.0 and meta["medium"] == "0.59%MC-PBS"
    assert "square" in meta["summary"].lower() and "G W/4" in meta["summary"]
    # pipe's extrapolation options pass through (one run per point by default)
    assert options["extrapolate"] is False and settings["coarse_resolution"] is None  # --quick: R/dx 4, one run
    single, _ = plan(None, 0.04, None, radii=[5], moduli=[1000], resolution=8, channel_width="20um",
                     channel_shape="square", medium="0.59%MC-PBS", extrapolate=False)
    assert single[0]["options"]["extrapolate"] is False
    coarse, settings = plan(None, 0.04, None, radii=[5], moduli=[1000], resolution=8, channel_width="20um",
                            channel_shape="square", medium="0.59%MC-PBS", extrapolate=True, coarse_resolution=5)
    assert coarse[0]["options"]["coarse_resolution"] == 5 and settings["coarse_resolution"] == 5
    # a coarse resolution without the extrapolation it belongs to is refused, naming the option
    with pytest.raises(ParameterError, match="coarse_resolution.*extrapolat"):
        plan(None, 0.04, None, radii=[5], moduli=[1000], resolution=8, channel_width="20um", medium="0.59%MC-PBS",
             coarse_resolution=5)
    assert len({single[0]["key"], coarse[0]["key"], points[0]["key"]}) == 3
    # the Newtonian cylinder's points keep their keys (no channel or medium options added)
    cylinder, _ = plan("10um", "0.04uL/s", "15mPa*s", radii="5", moduli="1kPa", quick=True)
    assert "channel_shape" not in cylinder[0]["options"] and "medium" not in cylinder[0]["options"]


def test_dclab_interpolates_a_square_mc_pbs_table(tmp_path):
    """dclab reads a table written here (square channel, MC-PBS metadata) and interpolates E at a point inside it.
    Reference: the synthetic table's own law deform = 0.02 (r/5)^2 / E (kPa); a point between the grid lines reads
    back its E to the interpolation error (measured 0.9 %; tolerance 2 %), and at the table's own medium, channel and flow rate
    dclab applies no viscosity scaling."""
    pytest.importorskip("dclab")
    from dclab.features import emodulus

    _, settings = plan(None, "0.04uL/s", None, quick=True, channel_width="20um", channel_shape="square",
                       medium="0.59%MC-PBS", temperature=23, radii=[5], moduli=[1000])
    records = [{"radius_um": r, "emodulus_kpa": e, "area_um": math.pi * r**2, "deform": 0.02 * (r / 5) ** 2 / e}
               for e in (1.0, 1.25, 1.5, 2.0, 2.5, 3.0) for r in (4.5, 5.0, 5.5, 6.0, 6.5, 7.0)]
    path = write_lut(tmp_path / "square.txt", records, lut_metadata(settings, "elastocell-square-test"))
    r, e = 5.75, 1.75
    kwargs = dict(area_um=np.array([math.pi * r**2]), deform=np.array([0.02 * (r / 5) ** 2 / e]), channel_width=20.0,
                  flow_rate=0.04, px_um=0, temperature=23.0, visc_model="buyukurganci-2022", lut_data=str(path))
    found = emodulus.get_emodulus(medium="0.59% MC-PBS", **kwargs)
    assert found[0] == pytest.approx(e, rel=0.02)
    # dclab's scaling with the viscosity (a Newtonian medium of twice the table's viscosity: twice the modulus)
    doubled = emodulus.get_emodulus(medium=2 * settings["viscosity_mpa_s"], **{**kwargs, "temperature": None,
                                                                              "visc_model": None})
    assert doubled[0] == pytest.approx(2 * found[0], rel=1e-9)


@pytest.mark.parametrize("extra, option", [
    (["--medium", "newtonian", "--viscosity", "15mPa*s", "--temperature", "23"], "--temperature"),
    (["--medium", "newtonian", "--viscosity", "15mPa*s", "--flow-index", "0.6"], "--flow-index"),
    (["--medium", "0.59%MC-PBS", "--temperature", "45"], "--temperature"),
    (["--medium", "0.59%MC-PBS", "--temperature", "15"], "--temperature"),
    (["--medium", "0.59%MC-PBS", "--viscosity", "15mPa*s"], "--viscosity"),
    (["--medium", "power-law", "--flow-index", "0.6"], "--medium"),
    (["--medium", "0.59%MC-PBS", "--channel-height", "30um"], "--channel-height"),
    (["--medium", "0.59%MC-PBS", "--channel-shape", "rectangle"], "--channel-shape"),
    (["--medium", "newtonian"], "--viscosity"),
    (["--medium", "0.59%MC-PBS", "--resolution", "8", "--coarse-resolution", "6"], "--coarse-resolution"),
    (["--medium", "0.59%MC-PBS", "--hydrodynamic-radius-correction", "-0.1"], "--hydrodynamic-radius-correction"),
])
def test_square_and_medium_refusals(tmp_path, extra, option):
    _refused(SQUARE, extra, option, tmp_path)


def test_a_coarse_resolution_not_below_the_resolution_is_refused_with_the_extrapolation(tmp_path):
    result = runner.invoke(app, [*SQUARE, "--medium", "0.59%MC-PBS", "--resolution", "8", "--extrapolate",
                                 "--coarse-resolution", "9", "--out", str(tmp_path / "lut.txt")])
    assert result.exit_code == 2
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("elastocell: error: --coarse-resolution:"), result.output
    assert "below the resolution" in lines[0] and not (tmp_path / "lut_runs").exists()


def test_square_mc_pbs_options_reach_the_pipe_runs(tmp_path, monkeypatch):
    """One tiny real run (R/dx 4, 0.1 units of time) of the square MC-PBS table: the pipe run's own summary holds
    the duct, the medium and the temperature, and the table's metadata the medium."""
    import distributed

    monkeypatch.setattr(distributed, "as_completed", lambda futures: list(futures))
    out = tmp_path / "lut.txt"
    result = compute_lut(out, None, "0.04uL/s", None, radii="5", moduli="2kPa", quick=True, duration=0.1,
                         client=_Client(), channel_width="20um", channel_shape="square", medium="0.59%MC-PBS",
                         temperature=25)
    assert not result["failures"], result["failures"]
    run = next((tmp_path / "lut_runs").iterdir())
    summary = json.loads(next(run.rglob("summary.json")).read_text())
    assert summary["flow"]["channel_shape"] == "square"
    assert summary["flow"]["medium"] == "0.59%MC-PBS" and summary["flow"]["temperature"] == 25.0
    assert summary["flow"]["capillary_number_wall"] == pytest.approx(result["records"][0]["options"]
                                                                     ["capillary_number_wall"])
    data, meta, _ = read_lut(out)
    assert data.shape == (1, 3) and meta["elastocell"]["channel_shape"] == "square"
    assert meta["fluid_temperature"] == 25.0


def test_an_extrapolated_point_reads_both_resolutions(tmp_path):
    # Reference: Richardson's formula X = X_8 + (X_8 - X_6)/((8/6)^2 - 1) on the final-window means of each
    # resolution's time series (the pipe run's layout: resolution-<R/dx>/timeseries.csv and summary.json).
    from elastocell.inverse.lut import FINAL_WINDOW, point_shape

    time = np.linspace(0.0, 4.0, 41)
    for r, d in ((8, 0.030), (6, 0.026)):
        part = tmp_path / f"resolution-{r}"
        part.mkdir()
        np.savetxt(part / "timeseries.csv", np.column_stack([time, np.full_like(time, d), np.full_like(time, 3.0 + d)]),
                   delimiter=",", header="time,deformation,projected_area", comments="")
        (part / "summary.json").write_text(json.dumps({"stop_reason": "stationary" if r == 8 else "duration"}))
    summary = {"extrapolation": {"fine_resolution": 8.0, "coarse_resolution": 6.0}}
    final, stationary = point_shape(tmp_path, summary)
    ratio = (8 / 6) ** 2 - 1
    assert final["deformation"] == pytest.approx(0.030 + 0.004 / ratio, rel=1e-12)
    assert final["projected_area"] == pytest.approx(3.030 + 0.004 / ratio, rel=1e-12)
    assert final["extrapolation"]["values"]["deformation"]["coarse"] == pytest.approx(0.026)
    assert stationary == "cap"  # the coarse run reached its cap
    assert FINAL_WINDOW < time[-1]


def test_register_lut_registers_the_shipped_tables_in_dclab_by_one_call(tmp_path):
    """elastocell.register_lut() registers every lut_*.txt of the data directory with dclab under its identifier
    (here a data directory of one synthetic square MC-PBS table, law deform = 0.02 (r/5)^2/E); dclab then computes
    emodulus with "emodulus lut" set to it. Reference: the table's own law, read back to the interpolation error
    (measured 0.9 %, as test_dclab_interpolates_a_square_mc_pbs_table; tolerance 2 %). A second call is harmless;
    an unknown identifier, a directory without tables and a clash with another file are refused (ParameterError)."""
    pytest.importorskip("dclab")
    from dclab.features import emodulus

    import elastocell
    from elastocell.inverse.shipped_luts import register_lut, shipped_luts

    _, settings = plan(None, "0.04uL/s", None, quick=True, channel_width="20um", channel_shape="square",
                       medium="0.59%MC-PBS", temperature=23, radii=[5], moduli=[1000])
    records = [{"radius_um": r, "emodulus_kpa": e, "area_um": math.pi * r**2, "deform": 0.02 * (r / 5) ** 2 / e}
               for e in (1.0, 1.25, 1.5, 2.0, 2.5, 3.0) for r in (4.5, 5.0, 5.5, 6.0, 6.5, 7.0)]
    data = tmp_path / "data"
    data.mkdir()
    identifier = "elastocell-shipped-test"
    meta = lut_metadata(settings, identifier)
    path = write_lut(data / "lut_square_test.txt", records, meta)
    write_isoelastics(isoelastics_path(path), records, meta)
    (data / "mastercurve_other.csv").write_text("not a table\n")
    tables = shipped_luts(data)
    assert list(tables) == [identifier] and tables[identifier]["isoelastics"] == isoelastics_path(path)
    assert register_lut(directory=data) == {identifier: path}
    assert register_lut(identifier, directory=data) == {identifier: path}  # again: harmless
    r, e = 5.75, 1.75
    found = emodulus.get_emodulus(area_um=np.array([math.pi * r**2]), deform=np.array([0.02 * (r / 5) ** 2 / e]),
                                  medium="0.59% MC-PBS", channel_width=20.0, flow_rate=0.04, px_um=0, temperature=23.0,
                                  visc_model="buyukurganci-2022", lut_data=identifier)
    assert found[0] == pytest.approx(e, rel=0.02)
    with pytest.raises(ParameterError, match="identifier"):
        register_lut("elastocell-none", directory=data)
    with pytest.raises(ParameterError, match="ships no look-up table"):
        register_lut(directory=tmp_path)
    other = tmp_path / "other"
    other.mkdir()
    write_lut(other / "lut_clash.txt", records, meta)
    write_lut(other / "lut_a_fresh.txt", records, lut_metadata(settings, "elastocell-shipped-fresh"))
    with pytest.raises(ParameterError, match="already holds"):
        register_lut(directory=other)
    assert "elastocell-shipped-fresh" not in emodulus.load.EXTERNAL_LUTS  # refused before any was registered
    assert elastocell.register_lut is register_lut and elastocell.shipped_luts is shipped_luts
    emodulus.load.EXTERNAL_LUTS.pop(identifier)


def test_the_standard_table_ships_with_the_tables_scaled_from_it(tmp_path):
    """validation/lut_standard.py ship on synthetic finished points (law deform = 0.02 (r/5)^2/E): refused while a
    point is unfinished or the table file is missing, then the standard table and the two scaled ones are written,
    register in dclab, and read one 20 um / 0.04 uL/s event as the same modulus (reference: dclab scales any table
    to the measurement as ship scaled them; measured equal to 3e-7, the files' 7 digits; tolerance 1e-5 against
    the law, whose interpolation at a grid node is exact). The scaled metadata name their origin and carry none of
    the standard table's run keys at the top of their settings."""
    pytest.importorskip("dclab")
    import importlib.util

    from dclab.features import emodulus

    from elastocell.inverse.lut import isoelastics_path, refined_rows, write_isoelastics
    from elastocell.inverse.shipped_luts import register_lut

    spec = importlib.util.spec_from_file_location("lut_standard", ROOT / "validation" / "lut_standard.py")
    standard = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(standard)
    tables, data = tmp_path / "tables", tmp_path / "data"
    data.mkdir()
    points, settings = standard.plan_of(standard.STANDARD)
    out = tables / f"{standard.table_name(standard.STANDARD)}.txt"
    records = []
    for point in points:
        r, e = point["radius_um"], point["emodulus_kpa"]
        record = {"key": point["key"], "radius_um": r, "emodulus_kpa": e, "area_um": math.pi * r**2,
                  "deform": 0.02 * (r / 5) ** 2 / e, "state": "stationary"}
        (runs_directory(out) / point["key"]).mkdir(parents=True)
        if point is not points[-1]:
            (runs_directory(out) / point["key"] / "point.json").write_text(json.dumps(record))
        records.append(record)
    with pytest.raises(SystemExit, match="1 of 48 points"):
        standard.ship(tables, data)
    (runs_directory(out) / points[-1]["key"] / "point.json").write_text(json.dumps(records[-1]))
    with pytest.raises(SystemExit, match="run `python validation/lut_standard.py run` once"):
        standard.ship(tables, data)
    meta = lut_metadata(settings, f"elastocell-{out.stem}")
    refined = refined_rows(records)  # as compute_lut writes it
    meta["elastocell"] = {**settings, "failed": [], "point_states": {p["key"]: "stationary" for p in points},
                          "rows": {"computed": len(records), "interpolated": len(refined) - len(records)}}
    write_lut(out, records, meta)
    with pytest.raises(SystemExit, match="is not the table of the 48 finished points"):
        standard.ship(tables, data)  # its rows are not the counted ones
    write_lut(out, refined, meta)
    write_isoelastics(isoelastics_path(out), records, meta)
    standard.ship(tables, data)
    shipped = register_lut(directory=data)
    assert len(shipped) == 3
    try:
        r, e = 6.5, 2.5
        found = [emodulus.get_emodulus(area_um=np.array([math.pi * r**2]), deform=np.array([0.02 * (r / 5) ** 2 / e]),
                                       medium="0.59% MC-PBS", channel_width=20.0, flow_rate=0.04, px_um=0,
                                       temperature=23.0, visc_model="buyukurganci-2022", lut_data=name)[0]
                 for name in shipped]
        assert found == pytest.approx([e] * 3, rel=1e-5)
        _, scaled, _ = read_lut(data / "lut_square_30um_0.16uLs_0.59MC-PBS_23C.txt")
        assert scaled["channel_width"] == pytest.approx(30.0) and scaled["flow_rate"] == pytest.approx(0.16)
        assert scaled["summary"].startswith(f"Scaled from elastocell-{out.stem}")
        assert "point_states" not in scaled["elastocell"] and "default_grid" not in scaled["elastocell"]
        assert set(scaled["elastocell"]["scaled_from_points"]["point_states"]) == {p["key"] for p in points}
    finally:
        for name in shipped:
            emodulus.load.EXTERNAL_LUTS.pop(name, None)


def test_the_help_states_the_full_grids_duration():
    """`lut --help` shows the duration cap the code applies (``FULL``), not another number."""
    from elastocell.inverse.lut import FULL

    shown = " ".join(runner.invoke(app, ["lut", "--help"], env={"COLUMNS": "300"}).output.split())
    assert f"[default: ({FULL['duration']:g}, stopping earlier once stationary;" in shown


def test_the_python_api_takes_the_commands_names(tmp_path):
    """``elastocell.lut`` is ``elastocell lut``: a square channel in MC-PBS given by keywords alone (no Newtonian
    channel_radius or viscosity to pass) reaches the same checks; here dclab's own identifier, refused before
    anything runs; and flow_rate is required by name."""
    import elastocell

    with pytest.raises(ParameterError, match="identifier.*dclab's own"):
        elastocell.lut(tmp_path / "lut.txt", channel_width="20um", channel_shape="square", flow_rate="0.04uL/s",
                       medium="0.59%MC-PBS", identifier="HE-3D-FEM-22")
    with pytest.raises(ParameterError, match="flow_rate.*required"):
        elastocell.lut(tmp_path / "lut.txt", channel_width="20um", channel_shape="square", medium="0.59%MC-PBS",
                       quick=True)
    assert not (tmp_path / "lut_runs").exists()


def test_shipped_luts_lists_what_ships_and_an_empty_list_is_no_error():
    """``elastocell shipped-luts`` exits 0 either way: with no table shipped it says so (an empty listing is no
    error of the input, exit code 2's meaning); otherwise each shipped identifier is listed."""
    from elastocell.inverse.shipped_luts import shipped_luts

    result = runner.invoke(app, ["shipped-luts"])
    assert result.exit_code == 0, result.output
    found = shipped_luts()
    if not found:
        assert "ships no look-up table" in result.output
    for identifier in found:
        assert identifier in result.output


def test_dclabs_name_of_the_buffer_plans_the_same_table():
    """`--medium "CellCarrier B"` (dclab's name of 0.59 % MC-PBS) is the same table, point for point (run keys
    equal), as `--medium 0.59%MC-PBS`."""
    from elastocell.inverse.lut import plan

    common = {"channel_width": "20um", "channel_shape": "square", "temperature": 23, "radii": "5,6",
              "moduli": "1kPa,2kPa"}
    ours, _ = plan(None, "0.04uL/s", None, medium="0.59%MC-PBS", **common)
    dclabs, _ = plan(None, "0.04uL/s", None, medium="CellCarrier B", **common)
    assert [p["key"] for p in dclabs] == [p["key"] for p in ours]


def test_a_finished_point_under_an_older_key_of_the_same_options_is_adopted(tmp_path):
    """A table resumed on another machine (or after the keys' rounding changed) keeps its finished points: a
    point.json whose options differ from the plan's only by 1e-10 in Ca_w (what the re-keying of the standard table
    measured) is renamed to the new key and read back without running; one that differs by 1e-6, or in a text
    option, is a different point and is left alone."""
    from elastocell.inverse.lut import POINT_FILE, adopt_finished_point, run_point

    points, _ = plan(None, "0.04uL/s", None, radii=[5], moduli=[2000], channel_width="20um",
                     channel_shape="square", medium="0.59%MC-PBS", temperature=23)
    point = points[0]
    prefix = point["key"].rsplit("_", 1)[0]

    def finished(name, **changes):
        options = {**point["options"], **changes}
        directory = tmp_path / f"{prefix}_{name}"
        directory.mkdir()
        (directory / POINT_FILE).write_text(json.dumps({"key": directory.name, "deform": 0.01, "options": options}))
        return directory

    ca = point["options"]["capillary_number_wall"]
    far = finished("0000000001", capillary_number_wall=ca * (1 + 1e-6))
    other = finished("0000000002", medium="0.49%MC-PBS")
    assert not adopt_finished_point(tmp_path, point)
    near = finished("0000000003", capillary_number_wall=ca * (1 + 1e-10))
    record = run_point((point, str(tmp_path)))  # read back: nothing runs
    assert record["key"] == point["key"] and record["deform"] == 0.01 and record["options"] == point["options"]
    assert not near.exists() and (tmp_path / point["key"] / POINT_FILE).exists()
    assert far.exists() and other.exists()


def test_points_read_on_the_hull_are_left_out_of_the_table_and_listed(tmp_path, monkeypatch):
    """Four finished points (their point.json written beforehand, so nothing runs): the one whose final window was
    read on the nodes' hull is not a row of the table, is listed under elastocell.outline_fallback and is not counted
    as not stationary; the table's rows are the other three, and a point whose cell drifted in volume by more than
    VOLUME_DRIFT is listed under elastocell.volume_drift."""
    import distributed

    from elastocell.inverse.lut import POINT_FILE, VOLUME_DRIFT, plan

    monkeypatch.setattr(distributed, "as_completed", lambda futures: list(futures))
    out = tmp_path / "lut.txt"
    kwargs = dict(radii="5,6", moduli="1kPa,2kPa", quick=True)
    points, _ = plan("10um", "0.04uL/s", "15mPa*s", **kwargs)
    for index, point in enumerate(points):
        record = {"key": point["key"], "radius_um": point["radius_um"], "emodulus_kpa": point["emodulus_kpa"],
                  "area_um": math.pi * point["radius_um"] ** 2, "deform": 0.01 * (index + 1),
                  "outline_fallback": 1.0 if index == 0 else 0.0, "state": "hull" if index == 0 else "stationary",
                  "volume_change_max_abs": 2 * VOLUME_DRIFT if index == 2 else 1e-4, "options": point["options"]}
        (runs_directory(out) / point["key"]).mkdir(parents=True)
        (runs_directory(out) / point["key"] / POINT_FILE).write_text(json.dumps(record))
    result = compute_lut(out, "10um", "0.04uL/s", "15mPa*s", client=_Client(), subdivisions=1, **kwargs)
    hull = points[0]["key"]
    assert len(result["records"]) == 4 and result["outline_fallback"] == [hull]
    data, meta, _ = read_lut(out)
    assert len(data) == 3 and not np.any(np.isclose(data[:, 1], 0.01))  # the hull point's deform is no row
    assert meta["elastocell"]["finished"] == 4
    assert meta["elastocell"]["outline_fallback"] == [hull] and meta["elastocell"]["not_stationary"] == []
    assert meta["elastocell"]["volume_drift"] == [points[2]["key"]]


def test_the_shipped_standard_table_is_its_committed_points():
    """The standard table that ships (elastocell/data) is made of exactly the committed finished points of
    validation/tables (each run's point.json, kept in git): every point of the default grid finished, none failed
    or capped, the points read on the nodes' hull listed and left out, every other one a row with its area,
    deformation and modulus (to the text format's 7 significant digits), and between them the rows
    ``refined_rows`` interpolates from those points, as many as the metadata say. The scaled tables are dclab's
    scaling of it (test_the_standard_table_ships_with_the_tables_scaled_from_it checks that on synthetic points);
    the isoelastics are the computed points alone."""
    from elastocell.inverse.lut import REFINE_SUBDIVISIONS, refined_rows
    from elastocell.inverse.shipped_luts import shipped_luts

    stem = "lut_square_20um_0.04uLs_0.59MC-PBS_23C"
    table = shipped_luts()[f"elastocell-{stem}"]
    rows, metadata, _ = read_lut(table["path"])
    own = metadata["elastocell"]
    assert own["points"] == own["finished"] == 48 and not own["failed"] and not own["not_stationary"]
    runs = ROOT / "validation" / "tables" / f"{stem}_runs"
    points = {key: json.loads((runs / key / "point.json").read_text()) for key in own["point_states"]}
    hull = {key for key, point in points.items() if point["outline_fallback"] > 0}  # also read partly on the hull
    assert hull == set(own["outline_fallback"])
    kept = [p for k, p in points.items() if k not in hull]
    assert own["rows"]["computed"] == len(kept) == 48 - len(hull) and own["rows"]["subdivisions"] == REFINE_SUBDIVISIONS
    expected = sorted((r["area_um"], r["deform"], r["emodulus_kpa"]) for r in refined_rows(kept))
    assert len(rows) == len(expected) == own["rows"]["computed"] + own["rows"]["interpolated"]
    np.testing.assert_allclose(sorted(map(tuple, rows)), expected, rtol=1e-6)
    isoelastics, _, _ = read_lut(table["isoelastics"])
    np.testing.assert_allclose(sorted(map(tuple, isoelastics)),
                               sorted((p["area_um"], p["deform"], p["emodulus_kpa"]) for p in kept), rtol=1e-6)


def test_refined_rows_are_exact_for_a_power_law_and_stay_inside_computed_cells():
    """``refined_rows`` interpolates ln area and ln deform bilinearly in (ln R, ln E). Reference: a forward map that
    is a power law in R and E (deform = c R^2.5 E^-2.2, area = 1.01 pi R^2), which that interpolation reproduces to
    round-off (tolerance 1e-12 in ln deform). Counted on a 3 x 3 grid with one corner missing (as a point read on
    the hull): 8 computed points, 5 + 5 edges with a computed pair at each end (3 rows inside each at 4
    subdivisions), 3 complete cells (9 interior rows each): 65 rows; the incomplete cell gets none, so no row lies
    beyond the computed points' cells. 1 subdivision returns the computed points alone; 0 is refused."""
    from elastocell.inverse.lut import refined_rows

    def law(r, e):
        return {"radius_um": r, "emodulus_kpa": e, "area_um": 1.01 * math.pi * r**2, "deform": 0.02 * (r / 5) ** 2.5 / e**2.2}

    points = [law(r, e) for r in (3.0, 5.0, 7.0) for e in (1.0, 2.0, 4.0) if (r, e) != (7.0, 4.0)]
    rows = refined_rows(points, 4)
    assert len(rows) == 65 and rows[:8] == points and all(r["interpolated"] for r in rows[8:])
    radius = [math.sqrt(r["area_um"] / (1.01 * math.pi)) for r in rows]
    error = [abs(math.log(r["deform"]) - math.log(law(x, r["emodulus_kpa"])["deform"])) for r, x in zip(rows, radius, strict=True)]
    assert max(error) < 1e-12
    assert not any(x > 5.0 + 1e-9 and r["emodulus_kpa"] > 2.0 + 1e-9 for r, x in zip(rows, radius, strict=True))
    assert refined_rows(points, 1) == points
    with pytest.raises(ParameterError, match="subdivisions"):
        refined_rows(points, 0)
    # a radius none of whose points is here: with the planned grid its cells stay empty (only the edges along E
    # at R 3 and 7 um: 2 x 2 x 3 rows); without it R 3 and 7 um would be neighbours (3 edges along R, 3 rows each,
    # and 2 cells, 9 rows each, across the missing radius)
    outer = [law(r, e) for r in (3.0, 7.0) for e in (1.0, 2.0, 4.0)]
    assert len(refined_rows(outer, 4, ([3.0, 5.0, 7.0], [1.0, 2.0, 4.0]))) == 6 + 12
    assert len(refined_rows(outer, 4)) == 6 + 12 + 9 + 18
