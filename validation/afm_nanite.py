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
   ``hertz_para``; the sphere-indenter fit proper arrives with the indentation scenario) with nanite's
   ``hertz_para`` contact point fixed: what is left is the fit itself (weighting, baseline). Against nanite
   with ``weight_cp = 0`` (no weighting) the two should agree to the solvers' tolerance.
3. elastocell's Hertz-sphere estimate with its own contact point (change point, rise region) and its checks.
4. ``elastocell fit afm`` as the command runs it (parallel plates, --radius, master curve and Hertz), and the E
   it reports when the piezo height is read instead of the tip position (what elastocell read before).

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
from elastocell.inverse.mastercurve import load_master_curve

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
                                 ("sneddon", "sneddon_spher_approx", None)):
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
        f"{nu:g} in both. This is elastocell's Hertz estimate for the sphere-indenter geometry, not its "
        "sphere-indenter fit (that needs the indentation scenario's master surfaces, not available yet). Table 2: "
        "`elastocell fit afm` as the command runs it (parallel plates, R = "
        f"{radius * 1e6:g} um), and the E it gives when the piezo height is read instead of the tip position. "
        "R_b is 18.64 um for force-save-example (nanite's documentation of that file) and a nominal 5 um for the "
        "others, whose files do not name the indenter (E scales as R_b^-1/2 in both tools)."))
    curve = load_master_curve(nu)
    sphere_rows, plate_rows = [], []
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
    page.write()


if __name__ == "__main__":
    main()
