"""elastocell's fits of real AFM files beside nanite's, on the same curves, in the same run.

    python validation/afm_nanite.py [--poisson-ratio 0.48] [--radius 8um]

The files are tests/data/afm (afmformats' public test files; their origin in the README there), with the
calibration a file lacks taken from afmformats' and nanite's own tests (tests/test_fit_files.py, CALIBRATION).
The truth of a real curve is unknown; the reference is nanite (https://github.com/AFM-analysis/nanite), an
independent implementation on the same reader (afmformats):

1. nanite's spherical-indenter fits with its defaults (preprocessing ``compute_tip_position``,
   ``correct_force_offset``, ``correct_tip_offset``, plus ``correct_split_approach_retract`` for a file whose
   approach holds the retract too; the contact point a fit parameter started from its ``deviation_from_baseline``
   estimate; its default ``weight_cp`` = 1 um, which down-weights the points within 1 um of the contact; the
   whole approach): Hertz's paraboloid ``hertz_para`` (F = 4/3 E/(1-nu^2) sqrt(R_b) d^(3/2)) and the Sneddon
   sphere ``sneddon_spher_approx``, with the same R_b and Poisson ratio.
2. elastocell's Hertz-sphere estimate (:func:`elastocell.inverse.fit.fit_hertz_sphere`, the same formula as
   ``hertz_para``, the ``youngs_modulus_hertz`` of the sphere-indenter fit) with nanite's ``hertz_para`` contact
   point fixed: what is left is the fit itself (weighting, baseline). Against nanite
   with ``weight_cp = 0`` (no weighting) the two should agree to the solvers' tolerance.
3. elastocell's Hertz-sphere estimate with its own contact point (change point, rise region) and its checks.
4. ``elastocell fit afm`` as the command runs it (parallel plates, --radius, master curve and Hertz), and the E
   it reports when the piezo height is read instead of the tip position (what elastocell read before).

5. The sphere-indenter fit (``--geometry sphere-indenter``, the master surface of a suspended cell of radius
   ``--radius`` on a dish) beside nanite's hertz_para and elastocell's Hertz estimate: at indentations below 10 %
   of R_b with nanite's contact point (nanite fitted with ``range_type="relative cp"``, ``weight_cp`` = 0), and
   over the whole curve with elastocell's own contact point and checks.
6. Synthetic: the computed curves held out of the master surface (E = 1), fitted by the surface, by Hertz on a
   half-space (nanite's model) and by Hertz's two contacts in series, up to depth/R = 0.1..0.5.
7. Round trip: those curves and the reference cell with a nucleus (computed here, R_b/R = 0.707), 0.5 % noise
   and a baseline before contact, in physical units, refitted by ``fit_curve``.

R_b: 18.64 um for force-save-example (nanite's documentation of that file); the other files do not name their
indenter, so both tools get the same nominal 5 um (E scales as R_b^-1/2 in both).
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import warnings
from pathlib import Path

import numpy as np
from page import Page

from elastocell.inverse.fit import (
    CurveError,
    FitSettings,
    fit_curve,
    fit_hertz_sphere,
    parse_length,
    read_curves,
)
from elastocell.inverse.indentation_surface import curve_function, load_indentation_surface
from elastocell.parameters.cell import cell_parameters
from elastocell.inverse.mastercurve import load_master_curve
from elastocell.scenarios.axisymmetric import hertz_sphere_indentation_force, indent_axisymmetric

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "afm"
sys.path.insert(0, str(ROOT / "tests"))
from test_fit_files import CALIBRATION  # noqa: E402  (one table of the calibrations the files lack)

BEAD = {"force-save-example.jpk-force": (18.64e-6, "18.64 (nanite's docs)")}
NOMINAL_BEAD = (5e-6, "5 (nominal)")


def nanite_fits(path: Path, index: int, k, s, bead: float, nu: float) -> dict:
    """nanite's hertz_para (default weight_cp and weight_cp = 0) and sneddon_spher_approx on curve ``index``:
    E and the contact point, the latter as elastocell's displacement (-(tip position))."""
    import nanite

    meta = {}
    if k is not None:
        meta["spring constant"] = k
    if s is not None:
        meta["sensitivity"] = s * (1e9 if path.name.startswith("fmt-ntmdt") else 1.0)
    out = {}
    for label, model, weight in (("hertz", "hertz_para", None), ("hertz_w0", "hertz_para", 0.0),
                                 ("sneddon", "sneddon_spher_approx", None), ("hertz_small", "hertz_para", 0.0)):
        indentation = nanite.load_group(path, meta_override=meta)[index]
        steps = ["compute_tip_position", "correct_force_offset", "correct_tip_offset"]
        if len(indentation.retr["force"]) == 0:  # one segment holds approach and retract (Igor)
            steps.append("correct_split_approach_retract")
        indentation.apply_preprocessing(["compute_tip_position"])
        raw = np.array(indentation["tip position"], dtype=float)
        indentation.apply_preprocessing(steps)
        offset = float(raw[0] - np.asarray(indentation["tip position"], dtype=float)[0])
        params = indentation.get_initial_fit_parameters(model_key=model)
        params["R"].value, params["nu"].value = bead, nu
        for parameter in params.values():  # nanite hashes its parameters and knows no numpy.float32 (Igor data)
            parameter.set(value=float(parameter.value))
        options = {"model_key": model, "params_initial": params}
        if weight is not None:
            options["weight_cp"] = weight
        if label == "hertz_small":  # indentations below 10 % of R_b (negative tip position is indentation)
            options.update(range_type="relative cp", range_x=(-0.1 * bead, 1.0))
        indentation.fit_model(**options)
        fitted = indentation.fit_properties
        if fitted.get("success"):
            out[label] = (float(fitted["params_fitted"]["E"].value),
                          -(float(fitted["params_fitted"]["contact_point"].value) + offset))
        else:
            out[label] = (math.nan, math.nan)
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--poisson-ratio", type=float, default=0.48)
    parser.add_argument("--radius", default="8um", help="cell radius for the parallel-plates command (table 2)")
    args = parser.parse_args()
    nu, radius = args.poisson_ratio, parse_length(args.radius, "radius")
    warnings.simplefilter("ignore")
    logging.getLogger("afmformats").setLevel(logging.CRITICAL)
    page = Page("afm", "afm_nanite.py", versions=("nanite", "afmformats", "lmfit"), intro=(
        "Every curve of the real files in `tests/data/afm` (afmformats' public test files: JPK single curves, a "
        "JPK force map and QI series, an Asylum .ibw, AFM Workshop .csv and an NT-MDT .txt; origin in the README "
        "there), fitted by nanite and by elastocell in the same run. Table 1: nanite's spherical-indenter fits "
        "with its defaults (contact point a fit parameter, points within 1 um of it down-weighted, the whole "
        "approach) beside elastocell's Hertz-sphere estimate F = 4/3 E/(1-nu^2) sqrt(R_b) d^(3/2) with nanite's "
        "contact point fixed, and with its own contact point and checks; the same R_b and nu = "
        f"{nu:g} in both: the `youngs_modulus_hertz` of the sphere-indenter fit. Table 2: "
        "`elastocell fit afm` as the command runs it (parallel plates, R = "
        f"{radius * 1e6:g} um), and the E it gives when the piezo height is read instead of the tip position. "
        "R_b is 18.64 um for force-save-example (nanite's documentation of that file) and a nominal 5 um for the "
        "others, whose files do not name the indenter (E scales as R_b^-1/2 in both tools). Table 3: the "
        "sphere-indenter fit (master surface of a suspended cell of radius --radius on a dish) beside nanite and "
        "elastocell's Hertz estimate. Table 4: what the surface captures at large indentation, on computed curves. "
        "Table 5: the round trip; the reference cell's E_c from its own curve (`youngs_modulus_cytoplasm_nucleated`) "
        "and from the conversions of the homogeneous fit."))
    curve = load_master_curve(nu)
    surface = load_indentation_surface(nu)
    sphere_rows, plate_rows, indenter_rows = [], [], []
    for path in sorted(p for p in DATA.iterdir() if p.suffix != ".md"):
        k, s = CALIBRATION.get(path.name, (None, None))
        bead, bead_label = BEAD.get(path.name, NOMINAL_BEAD)
        for index, item in enumerate(read_curves(path, k, s)):
            if isinstance(item, CurveError):
                page.print(f"{path.name} curve {index}: {item}")
                continue
            label = item.name if len(item.name) <= 40 else item.name[:18] + "..." + item.name[-18:]
            nanite = nanite_fits(path, index, k, s, bead, nu)
            e_nanite, c_nanite = nanite["hertz"]
            try:
                same = fit_hertz_sphere(item.displacement, item.force, bead, nu, contact_point=c_nanite)
                same_w0 = fit_hertz_sphere(item.displacement, item.force, bead, nu, contact_point=nanite["hertz_w0"][1])
            except (CurveError, ValueError) as error:
                page.print(f"{label}: elastocell at nanite's contact point: {error}")
                same = same_w0 = {"youngs_modulus": math.nan}
            try:
                own = fit_hertz_sphere(item.displacement, item.force, bead, nu)
            except CurveError as error:
                own = {"youngs_modulus": math.nan, "contact_point": math.nan, "flag": str(error).split(": ", 1)[-1]}
            sphere_rows.append({
                "curve": label, "R_b (um)": bead_label,
                "nanite Hertz E (Pa)": e_nanite, "nanite Sneddon E (Pa)": nanite["sneddon"][0],
                "elastocell Hertz E at nanite's contact (Pa)": same["youngs_modulus"],
                "difference": same["youngs_modulus"] / e_nanite - 1,
                "nanite Hertz E, weight_cp 0 (Pa)": nanite["hertz_w0"][0],
                "elastocell at that contact: difference": same_w0["youngs_modulus"] / nanite["hertz_w0"][0] - 1,
                "elastocell Hertz E, own contact (Pa)": own["youngs_modulus"],
                "own contact - nanite's (um)": 1e6 * (own["contact_point"] - c_nanite),
                "elastocell flag": own["flag"] or "accepted",
            })
            indenter_rows.append(indenter_row(item, label, bead, radius, nu, nanite, surface))
            settings = FitSettings(radius=radius, poisson_ratio=nu)
            try:
                tip = fit_curve(item.name, item.displacement, item.force, settings, curve)
                piezo = fit_curve(item.name, item.piezo_displacement, item.force, settings, curve)
            except CurveError as error:
                plate_rows.append({"curve": label, "flag": str(error).split(": ", 1)[-1]})
                continue
            plate_rows.append({
                "curve": label, "instrument": item.instrument, "k (N/m)": item.spring_constant,
                "E master (Pa)": tip["youngs_modulus"], "E Hertz (Pa)": tip["youngs_modulus_hertz"],
                "delta max": tip["delta_max"],
                "E from the piezo height / E": piezo["youngs_modulus"] / tip["youngs_modulus"]
                if tip["youngs_modulus"] == tip["youngs_modulus"] else math.nan,
                "flag": tip["flag"] or "accepted"})
    page.table(sphere_rows, f"1. Hertz sphere: nanite and elastocell on the same curves (nu = {nu:g})",
               formats={"nanite Hertz E (Pa)": ".4g", "nanite Sneddon E (Pa)": ".4g",
                        "elastocell Hertz E at nanite's contact (Pa)": ".4g", "difference": "+.2%",
                        "nanite Hertz E, weight_cp 0 (Pa)": ".4g", "elastocell at that contact: difference": "+.3%",
                        "elastocell Hertz E, own contact (Pa)": ".4g", "own contact - nanite's (um)": "+.3f"})
    same = np.array([r["difference"] for r in sphere_rows], float)
    unweighted = np.array([r["elastocell at that contact: difference"] for r in sphere_rows], float)
    own = np.array([r["elastocell Hertz E, own contact (Pa)"] / r["nanite Hertz E (Pa)"] - 1 for r in sphere_rows])
    accepted = np.array([r["elastocell flag"] == "accepted" for r in sphere_rows])
    page.print(f"elastocell at nanite's contact point against nanite (default weight_cp): median |difference| "
               f"{100 * np.nanmedian(np.abs(same)):.2f} %, largest {100 * np.nanmax(np.abs(same)):.2f} %")
    page.print(f"against nanite with weight_cp = 0 at its contact point: largest |difference| "
               f"{100 * np.nanmax(np.abs(unweighted)):.3f} %")
    page.print(f"elastocell with its own contact point against nanite: median |difference| "
               f"{100 * np.nanmedian(np.abs(own)):.1f} %, {accepted.sum()} of {len(accepted)} curves accepted by its "
               f"checks (accepted: median {100 * np.nanmedian(np.abs(own[accepted])):.1f} %, largest "
               f"{100 * np.nanmax(np.abs(own[accepted])):.1f} %)" if accepted.any() else "")
    own_w0 = np.array([r["elastocell Hertz E, own contact (Pa)"] / r["nanite Hertz E, weight_cp 0 (Pa)"] - 1
                       for r in sphere_rows])
    if accepted.any():
        page.print(f"the accepted curves against nanite with weight_cp = 0 (both fit the contact point over every "
                   f"point): largest |difference| {100 * np.nanmax(np.abs(own_w0[accepted])):.2f} %; the flagged "
                   f"ones: {', '.join(f'{100 * v:+.0f} %' for v in own_w0[~accepted])}")
    page.table(plate_rows, f"2. `elastocell fit afm` (parallel plates, R = {radius * 1e6:g} um, nu = {nu:g}) on the "
               "same curves, and E read from the piezo height instead of the tip position",
               formats={"k (N/m)": ".4g", "E master (Pa)": ".4g", "E Hertz (Pa)": ".4g", "delta max": ".3f",
                        "E from the piezo height / E": ".3f"})
    write_indenter_tables(page, indenter_rows, surface, radius, nu)
    round_trip_table(page, surface, nu)
    page.write()


def indenter_row(item, label: str, bead: float, radius: float, nu: float, nanite: dict, surface) -> dict:
    """Table 3's row: nanite's hertz_para below 10 % of R_b, elastocell's sphere-indenter fit and Hertz estimate
    there at nanite's contact point, and the sphere-indenter fit over the whole curve with its own contact."""
    e_small, c_small = nanite["hertz_small"]
    ratio = bead / radius
    small = 0.1 * bead / radius  # depth/R
    row = {"curve": label, "R_b/R": ratio, "nanite Hertz E, depth < 0.1 R_b (Pa)": e_small}
    try:
        fixed = fit_curve(item.name, item.displacement, item.force, FitSettings(
            radius=radius, poisson_ratio=nu, geometry="sphere-indenter", indenter_radius=bead,
            contact_point=f"{c_small}m", depth_max=small), surface)
        row["elastocell Hertz / nanite"] = fixed["youngs_modulus_hertz"] / e_small
        row["elastocell surface / nanite"] = fixed["youngs_modulus"] / e_small
    except (CurveError, ValueError) as error:
        row["elastocell Hertz / nanite"] = row["elastocell surface / nanite"] = math.nan
        row["flag (whole curve)"] = str(error).split(": ", 1)[-1]
    # the suspended cell's two Hertz contacts in series against one contact on a half-space at the same depth
    row["Hertz half-space / series (prediction)"] = float(
        hertz_sphere_force_ratio(small, ratio, nu))
    try:
        own = fit_curve(item.name, item.displacement, item.force, FitSettings(
            radius=radius, poisson_ratio=nu, geometry="sphere-indenter", indenter_radius=bead), surface)
        row.update({"surface E, whole curve (Pa)": own["youngs_modulus"],
                    "Hertz E, whole curve (Pa)": own["youngs_modulus_hertz"],
                    "depth max (um)": own.get("depth_max", math.nan) * 1e6,
                    "own contact - nanite's (um)": 1e6 * (own["contact_point"] - c_small),
                    "flag (whole curve)": own["flag"] or "accepted"})
    except (CurveError, ValueError) as error:
        row["flag (whole curve)"] = str(error).split(": ", 1)[-1]
    return row


def hertz_sphere_force_ratio(depth: float, ratio: float, nu: float) -> float:
    """F of a sphere of radius ratio on a half-space over F of the two contacts in series (bead on the cell, cell
    on the dish), at the same depth (units of R, E = 1)."""
    half_space = 4 / (3 * (1 - nu**2)) * math.sqrt(ratio) * depth**1.5
    return half_space / float(hertz_sphere_indentation_force(depth, ratio, nu))


def write_indenter_tables(page: Page, rows: list[dict], surface, radius: float, nu: float) -> None:
    page.table(rows, f"3. Sphere indenter: nanite's hertz_para and elastocell on the same curves (cell radius R = "
               f"{radius * 1e6:g} um, nu = {nu:g}); first three ratios at depths below 0.1 R_b with nanite's "
               "contact point (nanite weight_cp 0, range relative cp)",
               formats={"R_b/R": ".3g", "nanite Hertz E, depth < 0.1 R_b (Pa)": ".4g",
                        "elastocell Hertz / nanite": ".4f", "elastocell surface / nanite": ".3f",
                        "Hertz half-space / series (prediction)": ".3f", "surface E, whole curve (Pa)": ".4g",
                        "Hertz E, whole curve (Pa)": ".4g", "depth max (um)": ".3g",
                        "own contact - nanite's (um)": "+.3f"})
    hertz = np.array([r["elastocell Hertz / nanite"] for r in rows], float)
    surface_ratio = np.array([r["elastocell surface / nanite"] for r in rows], float)
    predicted = np.array([r["Hertz half-space / series (prediction)"] for r in rows], float)
    finite = np.isfinite(hertz)
    page.print(f"below 0.1 R_b at nanite's contact point: elastocell's Hertz estimate against nanite's hertz_para: "
               f"largest |difference| {100 * np.nanmax(np.abs(hertz - 1)):.2f} % ({finite.sum()} of {len(rows)} "
               f"curves fitted); the surface fit against nanite: {np.nanmin(surface_ratio):.3f} to "
               f"{np.nanmax(surface_ratio):.3f}, against the prediction of the two contacts in series (the "
               f"suspended cell also meets the dish; its curvature R_eff = R_b R/(R_b + R)): "
               f"surface/nanite over prediction {np.nanmin(surface_ratio / predicted):.3f} to "
               f"{np.nanmax(surface_ratio / predicted):.3f}")
    synthetic = []
    for ratio, (depth, force) in sorted(surface.held_out_curves().items()):
        for limit in (0.1, 0.2, 0.3, 0.4, 0.5):
            if limit > depth[-1] + 1e-9:
                continue
            keep = (depth > 0) & (depth <= limit + 1e-9)
            d, f = depth[keep], force[keep]
            s = surface.curve(ratio)(d)
            half = 4 / (3 * (1 - nu**2)) * math.sqrt(ratio) * d**1.5
            series = hertz_sphere_indentation_force(d, ratio, nu)
            synthetic.append({"R_b/R": ratio, "depth max / R": limit, "surface fit E / E": lsq(s, f),
                              "Hertz half-space E / E": lsq(half, f), "Hertz in series E / E": lsq(series, f)})
    page.table(synthetic, f"4. Large indentation: computed curves held out of the surface (E = 1, nu = {nu:g}) "
               "fitted by least squares (E only, contact known) up to depth max",
               formats={"R_b/R": ".3g", "depth max / R": ".1f", "surface fit E / E": ".4f",
                        "Hertz half-space E / E": ".3f", "Hertz in series E / E": ".3f"})


ROUND_TRIP = {"R": 8e-6, "E": 1000.0, "contact": 3e-6, "noise": 0.005, "points": 500}
"""The synthetic curves' cell radius (m), modulus (Pa), baseline length (m), noise (of the largest force)."""


def round_trip_table(page: Page, surface, nu: float) -> None:
    """Table 5: held-out homogeneous curves and the reference nucleus cell, noisy, refitted."""
    p = ROUND_TRIP
    curves = [(f"homogeneous, R_b/R = {ratio:g}", ratio, depth, force, None)
              for ratio, (depth, force) in sorted(surface.held_out_curves().items())]
    reference = cell_parameters(poisson_ratio=nu)
    result = indent_axisymmetric(reference, 0.707, 0.5, steps=20)
    nucleus = reference.nucleus
    for limit in (0.1, 0.2, 0.3, 0.5):
        keep = result.load <= limit + 1e-9
        curves.append((f"reference cell (nucleus lambda = {nucleus.size_ratio:g}, gamma = "
                       f"{nucleus.stiffness_ratio:g}), R_b/R = 0.707", 0.707, result.load[keep], result.force[keep],
                       nucleus))
    rows = []
    for label, ratio, depth, force, nucleus in curves:
        s = curve_function(depth, force, ratio, nu)
        displacement = np.linspace(0.0, p["contact"] + depth[-1] * p["R"], p["points"])
        clean = p["E"] * p["R"] ** 2 * s(np.maximum(displacement - p["contact"], 0.0) / p["R"])
        noisy = clean + p["noise"] * clean.max() * np.random.default_rng(1).standard_normal(len(clean))
        extra = {} if nucleus is None else {"nucleus_size_ratio": nucleus.size_ratio,
                                           "stiffness_ratio": nucleus.stiffness_ratio}
        fit = fit_curve(label, displacement, noisy, FitSettings(radius=p["R"], poisson_ratio=nu,
                        geometry="sphere-indenter", indenter_radius=ratio * p["R"], **extra), surface)
        rows.append({"curve": label, "depth max / R": depth[-1], "E fitted / E_c": fit["youngs_modulus"] / p["E"],
                     "E_c nucleated fit / E_c": fit.get("youngs_modulus_cytoplasm_nucleated", math.nan) / p["E"],
                     "E_c from the volume average / E_c": fit.get("youngs_modulus_cytoplasm", math.nan) / p["E"],
                     "E_c from HS upper / E_c":
                         fit.get("youngs_modulus_cytoplasm_hashin_shtrikman_upper", math.nan) / p["E"],
                     "Hertz E / E_c": fit["youngs_modulus_hertz"] / p["E"],
                     "contact error (nm)": 1e9 * (fit["contact_point"] - p["contact"]),
                     "flag": fit["flag"] or "accepted"})
    page.table(rows, f"5. Round trip: computed curves (E_c = {p['E']:g} Pa, R = {p['R'] * 1e6:g} um), "
               f"{100 * p['noise']:g} % noise, {p['contact'] * 1e6:g} um of baseline, refitted",
               formats={"depth max / R": ".3g", "E fitted / E_c": ".4f", "E_c nucleated fit / E_c": ".4f",
                        "E_c from the volume average / E_c": ".4f",
                        "E_c from HS upper / E_c": ".4f", "Hertz E / E_c": ".3f", "contact error (nm)": "+.1f"})


def lsq(model: np.ndarray, data: np.ndarray) -> float:
    """E of data = E model by least squares."""
    return float(np.sum(model * data) / np.sum(model * model))


if __name__ == "__main__":
    main()
