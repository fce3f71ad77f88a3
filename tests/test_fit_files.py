"""`elastocell fit afm` on real instrument files (tests/data/afm, afmformats' public test files; README there):
reading with the tip position, the calibration options, the checks and flags, exit codes, maps.

References: afmformats' own columns (and nanite's ``compute_tip_position`` when nanite is installed) for the
tip position; the calibration's physics (F = k * deflection, deflection = sensitivity * signal) for the
overrides; synthetic curves of known E for the sphere-indenter Hertz estimate. The truth of a real curve is
unknown: validation/afm_nanite.py compares the fits with nanite's.
"""

import json
import logging
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import typer
from typer.testing import CliRunner

from elastocell.cli.fit import fit_app
from elastocell.inverse.fit import (
    MODULUS_FLOOR,
    WARNING_COLOR,
    CurveError,
    FitSettings,
    check_fit,
    fit_curve,
    fit_files,
    fit_hertz_sphere,
    hertz_sphere_force,
    read_curves,
)
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.compression import hertz_force

afmformats = pytest.importorskip("afmformats")

DATA = Path(__file__).resolve().parent / "data" / "afm"
app = typer.Typer()
app.add_typer(fit_app, name="fit")
runner = CliRunner()

# calibration the files lack (tests/data/afm/README.md: the values of afmformats' and nanite's own tests, or
# nominal ones for the calibration curve): (spring constant N/m, sensitivity m/V; NT-MDT: m/nA)
CALIBRATION = {
    "fmt-afm-workshop-fd_single_2018-08-01_13.06.09.csv": (20.0, 10e-9),
    "fmt-afm-workshop-fd_single_2021-10-22_14.16.csv": (20.0, None),
    "fmt-jpk-cl_calibration_force-save-2015.02.04-11.25.21.294.jpk-force": (0.05, 50e-9),
    "fmt-ntmdt-txt-fd_2015_01_17_gel4-0,1_mQ_adh_6B_Curve_DFL_Height_51.txt": (0.055, 61e-9),
}
FILES = sorted(p.name for p in DATA.iterdir() if p.suffix != ".md")
MAP = "fmt-jpk-fd_map2x2_extracted.jpk-force-map"


def test_the_data_folder_holds_every_format():
    assert len(FILES) == 10
    assert {Path(name).suffix for name in FILES} == {".csv", ".ibw", ".jpk-force", ".jpk-force-map",
                                                     ".jpk-qi-series", ".txt"}


def afmformats_curves(name):
    """The approach segments as afmformats gives them, with the calibration the file lacks (NT-MDT's
    sensitivity in afmformats' m/A: 61 nm/nA = 61 m/A)."""
    k, s = CALIBRATION.get(name, (None, None))
    meta = {}
    if k is not None:
        meta["spring constant"] = k
    if s is not None:
        meta["sensitivity"] = s * (1e9 if name.startswith("fmt-ntmdt") else 1.0)
    logging.getLogger("afmformats").setLevel(logging.CRITICAL)
    return afmformats.load_data(DATA / name, meta_override=meta, modality="force-distance")


@pytest.mark.parametrize("name", FILES)
def test_every_file_is_read_with_the_tip_position(name):
    """displacement = -(height (measured) + force/k): the piezo height minus the deflection, from afmformats'
    own columns, to rounding (1e-12 of the height); the deflection removed is not negligible on most files
    (0.08-0.57 um, against 0.5-30 um of travel) -- the piezo height was what elastocell read before."""
    k, s = CALIBRATION.get(name, (None, None))
    curves = read_curves(DATA / name, k, s)
    datasets = afmformats_curves(name)
    assert len(curves) == len(datasets) >= 1
    for curve, data in zip(curves, datasets, strict=True):
        assert not isinstance(curve, CurveError), curve
        segment = data.appr
        n = len(curve.displacement)
        height = np.asarray(segment["height (measured)"], dtype=float)[:n]  # Igor: float32
        force = np.asarray(segment["force"], dtype=float)[:n]
        k_used = data.metadata["spring constant"]
        tip = height + force / k_used
        scale = float(np.max(np.abs(height)))
        assert np.allclose(curve.displacement, -tip, rtol=0, atol=1e-12 * scale)
        assert np.allclose(curve.piezo_displacement, -height, rtol=0, atol=1e-12 * scale)
        assert np.array_equal(curve.force, force)
        assert curve.spring_constant == pytest.approx(k_used)
        assert curve.instrument and curve.format
        # the approach ends at the piezo's turning point (the Igor file holds approach and retract in one
        # segment: cut there, 5060 of 10097 points)
        assert int(np.argmax(-height)) == n - 1
    if name.endswith(".ibw"):
        assert len(curves[0].displacement) < len(datasets[0].appr["force"])


@pytest.mark.parametrize("name", FILES)
def test_the_tip_position_is_nanites(name):
    """nanite's ``compute_tip_position`` on the same file gives the same tip position (to 1e-12 of the height;
    measured: 0 on every file but the Igor one, which nanite computes in its float32: 1e-7, measured 4e-8)."""
    nanite = pytest.importorskip("nanite")
    k, s = CALIBRATION.get(name, (None, None))
    meta = {key: value for key, value in (("spring constant", k), ("sensitivity", s)) if value is not None}
    if name.startswith("fmt-ntmdt") and s is not None:
        meta["sensitivity"] = s * 1e9
    logging.getLogger("afmformats").setLevel(logging.CRITICAL)
    group = nanite.load_group(DATA / name, meta_override=meta)
    for indentation, curve in zip(group, read_curves(DATA / name, k, s), strict=True):
        indentation.apply_preprocessing(["compute_tip_position"])
        tip = np.asarray(indentation.appr["tip position"])[:len(curve.displacement)]
        # nanite computes in the file's precision: float32 in the Igor file (eps 6e-8 of the height)
        relative = 1e-12 if tip.dtype == np.float64 else 1e-7
        assert np.allclose(curve.displacement, -tip, rtol=0, atol=relative * np.max(np.abs(tip)))


GEOMETRIES = {"parallel-plates": {}, "sphere-indenter": {"geometry": "sphere-indenter", "indenter_radius": "5um"}}


@pytest.mark.parametrize("geometry", GEOMETRIES)
@pytest.mark.parametrize("name", FILES)
def test_every_file_gets_a_finite_modulus_or_a_flag_with_a_reason(tmp_path, name, geometry):
    """fit_files on each file (with the calibration it lacks), between plates and under a 5 um bead on an 8 um
    cell: one row per curve; an accepted row (empty flag) has a finite positive E inside a finite positive interval
    no wider than E; a flagged one says why; no row reports E <= 0, E at the solver's floor or an interval bound
    below zero."""
    k, s = CALIBRATION.get(name, (None, None))
    settings = FitSettings(radius=8e-6, spring_constant=k, sensitivity=s, **GEOMETRIES[geometry])
    result = fit_files([DATA / name], settings, tmp_path, plots=False)
    assert not result["errors"]
    table = pd.read_csv(tmp_path / "fits.csv", dtype={"flag": str})
    table["flag"] = table["flag"].fillna("")
    assert len(table) == len(afmformats_curves(name))
    for _, row in table.iterrows():
        E, low, high = row["youngs_modulus"], row["youngs_modulus_ci_low"], row["youngs_modulus_ci_high"]
        if row["flag"] == "":
            assert np.isfinite([E, low, high]).all() and 0 < low < E < high and high - low <= E
        else:
            assert len(row["flag"]) > 10
        assert not (E <= 0) and not (low <= 0), row
    if name == "force-save-example.jpk-force":  # nanite's documented example: a clean curve, accepted
        assert table["flag"].iloc[0] == ""
    if geometry == "sphere-indenter":  # the surface's fit and Hertz's sphere beside it, on the bead's depth
        assert (table["geometry"] == "sphere-indenter").all() and np.isnan(table["delta_max"]).all()
        accepted = table[table["flag"] == ""]
        assert (accepted["depth_max"] > 0).all() and (accepted["youngs_modulus_hertz"] > 0).all()


def test_the_overrides_change_force_and_deflection_as_the_physics_says():
    """F = k * deflection, deflection = sensitivity * signal. JPK (afmformats recomputes from the raw volts)
    and Asylum (elastocell rescales from the file's calibration): k' = 2k doubles the force and leaves the
    deflection (so the tip position) as it was; s' = 3s triples the force and the deflection. Exact to rounding
    (rtol 1e-12)."""
    for name in ("fmt-jpk-fd_spot3-0192.jpk-force", "fmt-igor-fd_U3_3_p10004.ibw"):
        [base] = read_curves(DATA / name)
        k, s = base.spring_constant, base.sensitivity
        deflection = base.piezo_displacement - base.displacement
        [stiffer] = read_curves(DATA / name, spring_constant=2 * k)
        assert np.allclose(stiffer.force, 2 * base.force, rtol=1e-12, atol=0)
        assert np.allclose(stiffer.piezo_displacement - stiffer.displacement, deflection, rtol=1e-9, atol=1e-18)
        assert stiffer.spring_constant == pytest.approx(2 * k) and stiffer.sensitivity == pytest.approx(s)
        [sensitive] = read_curves(DATA / name, sensitivity=3 * s)
        assert np.allclose(sensitive.force, 3 * base.force, rtol=1e-12, atol=0)
        assert np.allclose(sensitive.piezo_displacement - sensitive.displacement, 3 * deflection, rtol=1e-9,
                           atol=1e-18)
        assert stiffer.calibration != "file"
    # NT-MDT: the signal is a current; F = k * s * signal
    name = "fmt-ntmdt-txt-fd_2015_01_17_gel4-0,1_mQ_adh_6B_Curve_DFL_Height_51.txt"
    [a] = read_curves(DATA / name, 0.055, 61e-9)
    [b] = read_curves(DATA / name, 0.11, 61e-9)
    [c] = read_curves(DATA / name, 0.055, 122e-9)
    assert np.allclose(b.force, 2 * a.force, rtol=1e-12) and np.allclose(c.force, 2 * a.force, rtol=1e-12)
    assert a.sensitivity == pytest.approx(61e-9)


def test_the_overrides_change_E_as_the_physics_says(tmp_path):
    """k' = 2k: the force doubles at the same tip positions, so E doubles (the fit is invariant to a force
    scale: measured ratio 2 to 1e-9; tolerance 1e-6). s' = 3s: force x3 and deflection x3; E equals the fit
    of the curve built by hand from the file's columns (piezo - 3 deflection, 3 F), to fits.csv's 8 digits."""
    name = "force-save-example.jpk-force"
    settings = FitSettings(radius=8e-6)
    [base] = read_curves(DATA / name)
    row = fit_curve(base.name, base.displacement, base.force, settings)
    out = tmp_path / "stiffer"
    result = runner.invoke(app, ["fit", "afm", str(DATA / name), "--radius", "8um", "--out", str(out), "--no-plots",
                                 "--spring-constant", f"{2 * base.spring_constant}N/m"])
    assert result.exit_code == 0, result.output
    stiffer = pd.read_csv(out / "fits.csv").iloc[0]
    assert stiffer["youngs_modulus"] / row["youngs_modulus"] == pytest.approx(2, rel=1e-6)
    assert stiffer["spring_constant"] == pytest.approx(2 * base.spring_constant)
    settings_json = json.loads((out / "fit_settings.json").read_text())
    assert settings_json["settings"]["spring_constant"] == pytest.approx(2 * base.spring_constant)
    assert settings_json["curves"][0]["spring_constant"] == pytest.approx(2 * base.spring_constant)
    # sensitivity: a bare number is in nm/V
    bare = base.sensitivity * 3 * 1e9
    out = tmp_path / "sensitive"
    result = runner.invoke(app, ["fit", "afm", str(DATA / name), "--radius", "8um", "--out", str(out), "--no-plots",
                                 "--sensitivity", f"{bare!r}"])
    assert result.exit_code == 0, result.output
    sensitive = pd.read_csv(out / "fits.csv").iloc[0]
    deflection = base.piezo_displacement - base.displacement
    by_hand = fit_curve("h", base.piezo_displacement - 3 * deflection, 3 * base.force, settings)
    assert sensitive["youngs_modulus"] == pytest.approx(by_hand["youngs_modulus"], rel=1e-7)  # fits.csv: 8 digits
    assert sensitive["sensitivity"] == pytest.approx(3 * base.sensitivity)
    assert abs(sensitive["youngs_modulus"] / row["youngs_modulus"] - 3) > 0.1  # not a plain scale: the tip moved


def test_files_without_calibration_say_so_and_take_it_from_the_options(tmp_path):
    """The AFM Workshop .csv goes to afmformats (not pandas) and afmformats' own error is reported, naming the
    options; with them it is read and fitted. The NT-MDT error names the missing calibration."""
    workshop = DATA / "fmt-afm-workshop-fd_single_2018-08-01_13.06.09.csv"
    ntmdt = DATA / "fmt-ntmdt-txt-fd_2015_01_17_gel4-0,1_mQ_adh_6B_Curve_DFL_Height_51.txt"
    no_k = DATA / "fmt-afm-workshop-fd_single_2021-10-22_14.16.csv"
    for path in (workshop, ntmdt, no_k):
        result = runner.invoke(app, ["fit", "afm", str(path), "--radius", "8um", "--out", str(tmp_path / "o")])
        lines = [line for line in result.output.strip().splitlines() if line]
        assert result.exit_code == 2, result.output
        assert len(lines) == 1 and path.name in lines[0] and "--spring-constant" in lines[0], lines
        assert "ParserError" not in lines[0] and "Expected" not in lines[0]
        if path != no_k:
            assert "afmformats" in lines[0] and "MissingMetaDataError" in lines[0]
    [curve] = read_curves(workshop, 20.0, 10e-9)
    assert curve.format.startswith("AFM workshop")
    signal = np.loadtxt(workshop, skiprows=11, delimiter=",")[:, 1]  # Extend T-B (V)
    assert np.allclose(curve.force, signal[:len(curve.force)] * 10e-9 * 20.0, rtol=1e-12)
    out = tmp_path / "workshop"
    result = runner.invoke(app, ["fit", "afm", str(workshop), "--radius", "8um", "--out", str(out), "--no-plots",
                                 "--spring-constant", "20", "--sensitivity", "10"])
    assert result.exit_code in (0, 3), result.output
    row = pd.read_csv(out / "fits.csv").iloc[0]
    assert row["spring_constant"] == 20.0 and row["sensitivity"] == pytest.approx(10e-9)
    assert "AFM workshop" in row["instrument"]


def test_a_map_gives_one_row_per_curve_and_records_the_reading(tmp_path):
    """Four curves, four rows (names _0000.._0003, curve_index 0..3), instrument, calibration, R and geometry
    in fits.csv and fit_settings.json; one PNG per curve."""
    out = tmp_path / "map"
    result = runner.invoke(app, ["fit", "afm", str(DATA / MAP), "--radius", "8um", "--out", str(out),
                                 "--geometry", "plates"])
    assert result.exit_code in (0, 3), result.output
    table = pd.read_csv(out / "fits.csv", keep_default_na=False)
    assert list(table["file"]) == [f"fmt-jpk-fd_map2x2_extracted_{i:04d}" for i in range(4)]
    assert list(table["curve_index"]) == [0, 1, 2, 3]
    assert set(table["instrument"]) == {"JPK00758-CellHesion-200"}
    assert np.allclose(table["spring_constant"], 0.015481694150356324)
    assert np.allclose(table["sensitivity"], 6.425794778156255e-08)
    assert set(table["geometry"]) == {"parallel-plates"} and np.allclose(table["radius"], 8e-6)
    assert {"youngs_modulus", "youngs_modulus_ci_low", "youngs_modulus_ci_high", "youngs_modulus_hertz",
            "contact_point", "flag"} <= set(table.columns)
    settings = json.loads((out / "fit_settings.json").read_text())
    assert len(settings["curves"]) == 4 and settings["settings"]["geometry"] == "parallel-plates"
    assert settings["curves"][0]["instrument"] == "JPK00758-CellHesion-200"
    assert len(list(out.glob("*.png"))) == 4


def test_flags_colour_and_exit_code_when_no_curve_is_accepted(tmp_path):
    """A flat curve and the calibration curve (the cantilever on the bare substrate: nothing to measure) are
    flagged: exit code 3, one line; the flagged curve's plot carries the warning colour, an accepted one
    does not; one failing curve does not stop the others (a good synthetic curve beside a flat one: exit 0)."""
    x = np.linspace(0, 10e-6, 400)
    flat = tmp_path / "flat.csv"
    pd.DataFrame({"displacement": x, "force": 1e-11 * np.random.default_rng(0).normal(size=x.size)}).to_csv(
        flat, index=False)
    result = runner.invoke(app, ["fit", "afm", str(flat), "--radius", "8um", "--out", str(tmp_path / "f")])
    lines = [line for line in result.output.strip().splitlines() if line]
    assert result.exit_code == 3 and len(lines) == 1 and "no contact" in lines[0], result.output
    assert "no contact" in pd.read_csv(tmp_path / "f" / "fits.csv")["flag"].iloc[0]
    calibration = DATA / "fmt-jpk-cl_calibration_force-save-2015.02.04-11.25.21.294.jpk-force"
    result = runner.invoke(app, ["fit", "afm", str(calibration), "--radius", "8um", "--out", str(tmp_path / "c"),
                                 "--spring-constant", "0.05", "--sensitivity", "50"])
    lines = [line for line in result.output.strip().splitlines() if line]
    assert result.exit_code == 3 and len(lines) == 1 and "no curve accepted" in lines[0], result.output
    png = plt_pixels(tmp_path / "c" / f"{calibration.stem}.png")
    assert warning_pixels(png) > 200
    # a good curve beside the flat one
    displacement = np.linspace(0, 12e-6, 600)
    good = tmp_path / "good.csv"
    force = 1e3 * (8e-6) ** 2 * hertz_force(np.maximum(displacement - 5e-6, 0) / 16e-6, 0.48)  # E = 1 kPa
    pd.DataFrame({"displacement": displacement, "force": force + 1e-12 * np.random.default_rng(1).normal(
        size=displacement.size)}).to_csv(good, index=False)
    out = tmp_path / "mixed"
    result = runner.invoke(app, ["fit", "afm", str(good), str(flat), "--radius", "8um", "--out", str(out),
                                 "--model", "hertz"])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out / "fits.csv", keep_default_na=False)
    assert list(table["flag"] == "") == [True, False]
    assert warning_pixels(plt_pixels(out / "good.png")) < 20
    assert warning_pixels(plt_pixels(out / "flat.png")) > 200


def plt_pixels(path):
    import matplotlib.image

    return matplotlib.image.imread(str(path))[..., :3]


def warning_pixels(pixels) -> int:
    red = np.array([int(WARNING_COLOR[i:i + 2], 16) / 255 for i in (1, 3, 5)])
    return int(np.sum(np.all(np.abs(pixels - red) < 0.04, axis=-1)))


def fit_result(**changes):
    fit = {"youngs_modulus": 1000.0, "youngs_modulus_ci_low": 900.0, "youngs_modulus_ci_high": 1100.0,
           "contact_point": 5e-6, "contact_bounds": (4e-6, 6e-6), "n_points_in_contact": 100, "converged": True,
           "modulus_at_floor": False, "residual_runs_z": 0.0, "residual_systematic": 0.001}
    fit.update(changes)
    return fit


@pytest.mark.parametrize("changes,reason,nan", [
    ({}, None, ()),
    ({"youngs_modulus": 2.4e-290, "modulus_at_floor": True}, "no measurement",
     ("youngs_modulus", "youngs_modulus_ci_low", "youngs_modulus_ci_high")),
    ({"youngs_modulus": 1.9e4, "youngs_modulus_ci_low": -6.6e5, "youngs_modulus_ci_high": 7.0e5}, "below zero",
     ("youngs_modulus_ci_low",)),
    ({"youngs_modulus_ci_low": 100.0, "youngs_modulus_ci_high": 2000.0}, "wider than E", ()),
    ({"youngs_modulus_ci_high": float("nan")}, "no finite", ()),
    ({"contact_point": 3e-6}, "outside the region", ()),
    ({"contact_point": 6e-6}, "edge of the rise region", ()),
    ({"n_points_in_contact": 4}, "points in contact", ()),
    ({"residual_runs_z": -8.0, "residual_systematic": 0.1}, "structured residuals", ()),
    ({"residual_runs_z": -8.0, "residual_systematic": 0.005}, None, ()),  # significant, but a small misfit
    ({"converged": False}, "did not converge", ()),
    # a force in nN read as N: E x 1e9 (the bound: 1 GPa; the value stays, flagged)
    ({"youngs_modulus": 5e11, "youngs_modulus_ci_low": 4.9e11, "youngs_modulus_ci_high": 5.1e11},
     "not a cell, gel or tissue", ()),
    ({"youngs_modulus": 9e8, "youngs_modulus_ci_low": 8.9e8, "youngs_modulus_ci_high": 9.1e8}, None, ()),
])
def test_check_fit(changes, reason, nan):
    """Each check alone (the brief's cases: E = 2.4e-290 Pa, E = 1.9e4 Pa in [-6.6e5, 7.0e5]); values that
    are no result become NaN."""
    fit = fit_result(**changes)
    reasons = check_fit(fit)
    if reason is None:
        assert reasons == []
    else:
        assert len(reasons) >= 1 and any(reason in r for r in reasons), reasons
    for key in nan:
        assert np.isnan(fit[key])
    assert MODULUS_FLOOR < 1e-6


def test_geometry_names(tmp_path):
    """plates is parallel-plates (same E); sphere-indenter without --indenter-radius is refused in one line."""
    name = DATA / "fmt-jpk-fd_spot3-0192.jpk-force"
    rows = []
    for geometry in ("parallel-plates", "plates"):
        out = tmp_path / geometry
        result = runner.invoke(app, ["fit", "afm", str(name), "--radius", "8um", "--out", str(out), "--no-plots",
                                     "--geometry", geometry])
        assert result.exit_code == 0, result.output
        rows.append(pd.read_csv(out / "fits.csv").iloc[0])
    assert rows[0]["youngs_modulus"] == rows[1]["youngs_modulus"] and rows[1]["geometry"] == "parallel-plates"
    result = runner.invoke(app, ["fit", "afm", str(name), "--radius", "8um", "--out", str(tmp_path / "s"),
                                 "--geometry", "sphere-indenter"])
    lines = [line for line in result.output.strip().splitlines() if line]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert "--indenter-radius" in lines[0] and "required with --geometry sphere-indenter" in lines[0]


def test_hertz_sphere_estimate_returns_the_modulus_of_a_hertz_sphere_curve():
    """F = 4/3 E/(1-nu^2) sqrt(R_b) d^(3/2) (R_b 18.64 um, E 500 Pa, 2 um of indentation, noise 1 % of the
    largest force, 20 seeds): E within 3 % and inside its 95 % interval in at least 17 of 20 (measured: largest
    error 1.2 %, 19 of 20 inside); with the true contact point given, within 2 %."""
    bead, E, contact = 18.64e-6, 500.0, 10e-6
    x = np.linspace(0, contact + 2e-6, 800)
    clean = E * hertz_sphere_force(x - contact, 0.48, bead)
    inside = 0
    for seed in range(20):
        force = clean + 0.01 * clean.max() * np.random.default_rng(seed).normal(size=x.size)
        fit = fit_hertz_sphere(x, force, bead, 0.48)
        assert fit["youngs_modulus"] == pytest.approx(E, rel=0.03) and fit["flag"] == ""
        inside += fit["youngs_modulus_ci_low"] <= E <= fit["youngs_modulus_ci_high"]
        fixed = fit_hertz_sphere(x, force, bead, 0.48, contact_point=contact)
        assert fixed["youngs_modulus"] == pytest.approx(E, rel=0.02)
    assert inside >= 17


# ---------------------------------------------------------------- the audit's defects (one test each)

WORKSHOP_2021 = DATA / "fmt-afm-workshop-fd_single_2021-10-22_14.16.csv"
NTMDT = DATA / "fmt-ntmdt-txt-fd_2015_01_17_gel4-0,1_mQ_adh_6B_Curve_DFL_Height_51.txt"
EXAMPLE = DATA / "force-save-example.jpk-force"


def hertz_curve(path, force_scale=1.0, displacement_scale=1.0, seed=1):
    """A plain CSV of a Hertz plate curve (E = 1 kPa, R = 8 um, contact at 5 um, noise 1 pN), its columns
    multiplied by the scales (1: SI, as the format wants)."""
    displacement = np.linspace(0, 12e-6, 600)
    force = 1e3 * (8e-6) ** 2 * hertz_force(np.maximum(displacement - 5e-6, 0) / 16e-6, 0.48)
    force = force + 1e-12 * np.random.default_rng(seed).normal(size=displacement.size)
    pd.DataFrame({"displacement": displacement * displacement_scale, "force": force * force_scale}).to_csv(
        path, index=False)
    return displacement, force


def test_a_tilted_baseline_on_the_igor_curve_is_a_flag_not_a_crash(tmp_path):
    """Regression: the change-point scan under a tilted baseline met a candidate before every point with p = 1,
    whose power-law column is the baseline's slope itself, and np.linalg.solve raised LinAlgError "Singular
    matrix" (fit_curve raised it before the Schur-complement test). Now the curve is fitted and flagged (its
    contact point is on the rise region's edge: measured), and the command exits 3, not with a traceback or a
    "fit failed" row."""
    [curve] = read_curves(DATA / "fmt-igor-fd_U3_3_p10004.ibw")
    row = fit_curve(curve.name, curve.displacement, curve.force, FitSettings(radius="8um", baseline_tilt=True))
    assert row["flag"] and "fit failed" not in row["flag"]
    out = tmp_path / "tilt"
    result = runner.invoke(app, ["fit", "afm", str(DATA / "fmt-igor-fd_U3_3_p10004.ibw"), "--radius", "8um",
                                 "--baseline-tilt", "--no-plots", "--out", str(out)])
    assert result.exit_code == 3, result.output
    flag = pd.read_csv(out / "fits.csv", keep_default_na=False)["flag"].iloc[0]
    assert flag and "fit failed" not in flag and "LinAlgError" not in flag


def test_a_contact_point_outside_the_curve_says_so_with_the_range_in_um(tmp_path):
    """--contact-point 500 um on force-save-example (displacement -78.3 to -48.5 um, from read_curves): a
    flagged row whose flag names the contact point and the curve's range in um (the range printed to 6 digits,
    as read_curves gives it), exit code 3; below the range too."""
    [curve] = read_curves(EXAMPLE)
    low, high = curve.displacement.min() * 1e6, curve.displacement.max() * 1e6
    for contact in ("500um", f"{low - 10:.6g}um"):
        out = tmp_path / contact
        result = runner.invoke(app, ["fit", "afm", str(EXAMPLE), "--radius", "10um", "--contact-point", contact,
                                     "--no-plots", "--out", str(out)])
        assert result.exit_code == 3, result.output
        flag = pd.read_csv(out / "fits.csv")["flag"].iloc[0]
        assert f"--contact-point {float(contact[:-2]):.6g} um is outside the curve's displacement range" in flag
        assert f"({low:.6g} to {high:.6g} um)" in flag
    # inside the range the fixed contact point is fitted as before (a finite E)
    row = fit_curve(curve.name, curve.displacement, curve.force,
                    FitSettings(radius="10um", contact_point=f"{(low + high) / 2}um"))
    assert np.isfinite(row["youngs_modulus"])


@pytest.mark.parametrize("scales, needle", [((1e9, 1.0), "nN x 1e-9"), ((1.0, 1e6), "um x 1e-6")])
def test_a_plain_csv_in_other_units_is_refused_naming_the_column(tmp_path, scales, needle):
    """Force in nN (values up to 32, read as N they gave E = 1e12 Pa) or displacement in um (a 12 m span: "fewer
    than 3 points in contact"): the file is unreadable, exit code 2, one line naming it and the column's unit; its
    row in fits.csv says so. The same curve in SI is read and fitted to E = 1 kPa (Hertz, its own model: 1 %)."""
    path = tmp_path / "curve.csv"
    hertz_curve(path, *scales)
    out = tmp_path / "o"
    result = runner.invoke(app, ["fit", "afm", str(path), "--radius", "8um", "--no-plots", "--out", str(out)])
    lines = [line for line in result.output.strip().splitlines() if line]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert "curve.csv" in lines[0] and needle in lines[0]
    row = pd.read_csv(out / "fits.csv").iloc[0]
    assert row["flag"] == "unreadable" and needle in row["error"]
    hertz_curve(path)
    result = runner.invoke(app, ["fit", "afm", str(path), "--radius", "8um", "--no-plots", "--model", "hertz",
                                 "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert pd.read_csv(out / "fits.csv")["youngs_modulus"].iloc[0] == pytest.approx(1e3, rel=0.01)


def test_a_modulus_above_a_gigapascal_is_flagged():
    """The Python API takes arrays as they are: the SI curve (E = 1 kPa) with its force in nN fits E = 1e12 Pa
    (the fit scales with the force: 1e9 x, to 1e-6), which is flagged "not a cell, gel or tissue"; the same curve
    in N is accepted."""
    displacement = np.linspace(0, 12e-6, 600)
    force = 1e3 * (8e-6) ** 2 * hertz_force(np.maximum(displacement - 5e-6, 0) / 16e-6, 0.48)
    force = force + 1e-12 * np.random.default_rng(1).normal(size=displacement.size)
    settings = FitSettings(radius="8um", model="hertz")
    good = fit_curve("si", displacement, force, settings)
    bad = fit_curve("nN", displacement, force * 1e9, settings)
    assert good["flag"] == ""
    assert bad["youngs_modulus"] == pytest.approx(1e9 * good["youngs_modulus"], rel=1e-6)
    assert "not a cell, gel or tissue" in bad["flag"] and "check the units" in bad["flag"]


def test_an_unexpected_error_in_one_curve_is_a_flagged_row_and_the_others_are_fitted(tmp_path, monkeypatch):
    """A bug that raises while one curve is fitted (simulated: fit_curve raises RuntimeError for that curve)
    becomes that curve's flagged row, "fit failed: RuntimeError: ... (an internal error: please report it)";
    the curve after it is fitted and accepted (E = 1 kPa, 1 %), and the command exits 0. KeyboardInterrupt still
    stops the batch."""
    import elastocell.inverse.fit as fit_module

    broken, good = tmp_path / "broken.csv", tmp_path / "good.csv"
    hertz_curve(broken)
    hertz_curve(good, seed=2)
    original = fit_module.fit_curve

    def fit_or_fail(name, *args, **kwargs):
        if name == "broken":
            raise RuntimeError("index 3 is out of bounds")
        return original(name, *args, **kwargs)

    monkeypatch.setattr(fit_module, "fit_curve", fit_or_fail)
    out = tmp_path / "o"
    result = runner.invoke(app, ["fit", "afm", str(broken), str(good), "--radius", "8um", "--model", "hertz",
                                 "--out", str(out)])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out / "fits.csv", keep_default_na=False)
    assert list(table["file"]) == ["broken", "good"]
    assert table["flag"].iloc[0] == ("fit failed: RuntimeError: index 3 is out of bounds (an internal error: please "
                                     "report it)")
    assert table["flag"].iloc[1] == "" and float(table["youngs_modulus"].iloc[1]) == pytest.approx(1e3, rel=0.01)
    assert (out / "broken.png").exists()  # drawn, in the warning colour, like any flagged curve

    def interrupt(name, *args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(fit_module, "fit_curve", interrupt)
    with pytest.raises(KeyboardInterrupt):
        fit_files([good], FitSettings(radius="8um"), tmp_path / "stopped", plots=False)


def test_an_unreadable_file_keeps_its_place_and_is_counted(tmp_path):
    """fitting.md: one row per curve in input order; an unreadable file is one row (flag "unreadable", its
    error) in its place, the others are fitted and written, and the command exits 2 naming each unreadable file;
    the summary line counts them."""
    first, last = tmp_path / "first.csv", tmp_path / "last.jpk-force"
    first.write_text("x,y\n1,2\n")
    last.write_bytes(b"PK\x03\x04 truncated")
    good = tmp_path / "good.csv"
    hertz_curve(good)
    out = tmp_path / "o"
    result = runner.invoke(app, ["fit", "afm", str(first), str(good), str(last), "--radius", "8um", "--model",
                                 "hertz", "--no-plots", "--out", str(out)])
    assert result.exit_code == 2, result.output
    table = pd.read_csv(out / "fits.csv", keep_default_na=False)
    assert list(table["file"]) == ["first", "good", "last"]
    assert list(table["flag"]) == ["unreadable", "", "unreadable"]
    assert table["error"].iloc[0] and table["error"].iloc[2] and table["error"].iloc[1] == ""
    assert "1 curve(s), 1 accepted, 0 flagged, 2 unreadable" in result.output
    errors = [line for line in result.output.splitlines() if line.startswith("elastocell: error:")]
    assert len(errors) == 2 and "first.csv" in errors[0] and "last.jpk-force" in errors[1]


def test_an_ntmdt_sensitivity_in_nm_per_na_is_the_bare_number(tmp_path):
    """NT-MDT's signal is a photodiode current: --sensitivity 61nm/nA (the --help's unit, refused before as
    "unknown unit 'nA'"), 61 m/A and 0.061um/nA give the force of the bare 61 (afmformats' own test value,
    61 nm/nA = 61 m/A), exactly; 122nm/nA doubles it (F = k s signal). A per-ampere sensitivity on a JPK file
    (a voltage signal) is refused naming the file. fits.csv says which unit each row's sensitivity holds."""
    [bare] = read_curves(NTMDT, 0.055, FitSettings(radius="8um", sensitivity=61).sensitivity)
    for text in ("61nm/nA", "61 m/A", "0.061um/nA"):
        settings = FitSettings(radius="8um", sensitivity=text)
        assert settings.sensitivity == pytest.approx(61e-9, rel=1e-12) and settings.sensitivity_unit == "m/nA"
        [curve] = read_curves(NTMDT, 0.055, settings.sensitivity, settings.sensitivity_unit)
        assert np.allclose(curve.force, bare.force, rtol=1e-12, atol=0) and curve.sensitivity_unit == "m/nA"
    double = FitSettings(radius="8um", sensitivity="122nm/nA")
    [curve] = read_curves(NTMDT, 0.055, double.sensitivity, double.sensitivity_unit)
    assert np.allclose(curve.force, 2 * bare.force, rtol=1e-12, atol=0)
    with pytest.raises(CurveError, match="per ampere.*nm/V"):
        read_curves(EXAMPLE, None, 61e-9, "m/nA")
    rows = []
    for text in ("61nm/nA", "61"):
        out = tmp_path / text.replace("/", "_")
        result = runner.invoke(app, ["fit", "afm", str(NTMDT), "--radius", "8um", "--spring-constant", "0.055",
                                     "--sensitivity", text, "--no-plots", "--out", str(out)])
        assert result.exit_code in (0, 3), result.output
        rows.append(pd.read_csv(out / "fits.csv").iloc[0])
    assert rows[0]["youngs_modulus"] == rows[1]["youngs_modulus"] and rows[0]["sensitivity"] == pytest.approx(61e-9)
    assert rows[0]["sensitivity_unit"] == rows[1]["sensitivity_unit"] == "m/nA"
    out = tmp_path / "jpk"
    result = runner.invoke(app, ["fit", "afm", str(EXAMPLE), "--radius", "8um", "--sensitivity", "61nm/nA",
                                 "--no-plots", "--out", str(out)])
    lines = [line for line in result.output.strip().splitlines() if line]
    assert result.exit_code == 2 and len(lines) == 1 and EXAMPLE.name in lines[0] and "per ampere" in lines[0]
    # one batch, both makers, a bare sensitivity: m/nA on the NT-MDT row, m/V on the JPK row
    out = tmp_path / "mixed"
    result = runner.invoke(app, ["fit", "afm", str(NTMDT), str(EXAMPLE), "--radius", "8um", "--spring-constant",
                                 "0.055", "--sensitivity", "61", "--no-plots", "--out", str(out)])
    assert result.exit_code in (0, 3), result.output
    table = pd.read_csv(out / "fits.csv")
    assert list(table["sensitivity_unit"]) == ["m/nA", "m/V"] and np.allclose(table["sensitivity"], 61e-9)


def test_a_workshop_file_of_force_says_the_sensitivity_did_not_apply(tmp_path):
    """The AFM Workshop 2021 file stores force in nN (afmformats reads it times 1e-9): --sensitivity 1000 leaves
    the force as it is (the file's column x 1e-9, exactly), and fits.csv says so (calibration: the file's force,
    the sensitivity given did not apply; sensitivity NaN), with the E of no sensitivity at all. The 2018 file (a
    signal in V) is recomputed with it (test_files_without_calibration_say_so_and_take_it_from_the_options)."""
    [without] = read_curves(WORKSHOP_2021, 20.0)
    [given] = read_curves(WORKSHOP_2021, 20.0, 1e-6)
    column = np.loadtxt(WORKSHOP_2021, skiprows=11, delimiter=",")[:, 1]  # Extend Force(nN)
    assert np.array_equal(given.force, without.force)
    assert np.allclose(given.force, column[:len(given.force)] * 1e-9, rtol=1e-12, atol=0)
    assert "did not apply" in given.calibration and np.isnan(given.sensitivity)
    assert "recomputed" not in given.calibration and "deflection" in given.calibration
    results = []
    for extra in ([], ["--sensitivity", "1000"]):
        out = tmp_path / str(len(extra))
        result = runner.invoke(app, ["fit", "afm", str(WORKSHOP_2021), "--radius", "8um", "--spring-constant", "20",
                                     *extra, "--no-plots", "--out", str(out)])
        assert result.exit_code in (0, 3), result.output
        results.append(pd.read_csv(out / "fits.csv").iloc[0])
    assert results[0]["youngs_modulus"] == results[1]["youngs_modulus"]
    assert "the sensitivity given did not apply" in results[1]["calibration"] and np.isnan(results[1]["sensitivity"])
    [signal] = read_curves(DATA / "fmt-afm-workshop-fd_single_2018-08-01_13.06.09.csv", 20.0, 10e-9)
    assert signal.calibration == "recomputed by afmformats from the raw signal"


def test_the_columns_of_fits_csv_do_not_depend_on_which_file_comes_first(tmp_path):
    """An unreadable file first (its row is in its place) must not move the columns: the contract columns, then a
    fitted curve's columns in their order, the unreadable file's ``error`` last."""
    unreadable = DATA / "fmt-jpk-cl_calibration_force-save-2015.02.04-11.25.21.294.jpk-force"  # no calibration
    good = DATA / "force-save-example.jpk-force"
    settings = FitSettings(radius="8um")
    fit_files([good], settings, tmp_path / "alone", plots=False, dask=False)
    fit_files([unreadable, good], settings, tmp_path / "both", plots=False, dask=False)
    alone = pd.read_csv(tmp_path / "alone" / "fits.csv")
    both = pd.read_csv(tmp_path / "both" / "fits.csv")
    assert list(both.columns) == list(alone.columns) + ["error"]
    assert both["flag"].tolist()[0] == "unreadable" and both["file"].tolist()[1] == "force-save-example"


def test_whole_number_settings_given_as_text_are_read():
    assert FitSettings(radius="8um", bootstrap="20", seed="3") == FitSettings(radius="8um", bootstrap=20, seed=3)
    with pytest.raises(ParameterError, match="bootstrap: a whole number"):
        FitSettings(radius="8um", bootstrap="2.5")


def test_the_real_adhesive_curve_is_flagged_and_the_cell_curves_are_not():
    """The NT-MDT gel file named "adh" dips about 7 % of its largest force below the baseline before contact
    (28 sigma of its baseline's moving average, measured): flagged as adhesion. The JPK cell curves (force-save
    example, spot3, the map) dip 0.1-1.0 % (2-3 sigma): not flagged for adhesion."""
    settings = FitSettings(radius="8um", sensitivity=61)
    [curve] = read_curves(NTMDT, 0.055, settings.sensitivity, settings.sensitivity_unit)
    row = fit_curve(curve.name, curve.displacement, curve.force, settings)
    assert "adhesion: the force dips" in row["flag"] and 0.05 < row["adhesion_dip_fraction"] < 0.1
    for path in (EXAMPLE, DATA / "fmt-jpk-fd_spot3-0192.jpk-force", DATA / "fmt-jpk-fd_map2x2_extracted.jpk-force-map"):
        for curve in read_curves(path):
            row = fit_curve(curve.name, curve.displacement, curve.force, FitSettings(radius="8um"))
            assert "adhesion" not in row["flag"] and row["adhesion_dip_fraction"] < 0.015, (curve.name, row["flag"])
