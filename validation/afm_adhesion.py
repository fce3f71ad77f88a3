"""The adhesion check of the AFM fit: how much an adhesion dip biases E, and which curves the check flags.

    python validation/afm_adhesion.py [--seeds 10]

1. Synthetic plate curves (Hertz to delta 0.3, E = 1 kPa, R = 8 um, 600 points, Gaussian noise a fraction of the
   largest force) with a DMT-like adhesion: an attraction -F_a exp(-(c - x)/20 nm) before contact and the pull-off
   force -F_a in contact, F_a a fraction of the largest force. Reference: the E the curve was made with. For each
   fraction: E's bias (mean over the seeds), how many curves the other checks flag, how many the adhesion check flags;
   and the same adhesion under the sphere-indenter's Hertz estimate (a 5 um bead, 1.5 um deep).
2. The real files of tests/data/afm (fitted as plates, R = 8 um, with the calibration the tests supply): the dip
   each reads, in sigma of its baseline's running median and in % of its largest fitted force, and whether the
   adhesion check flags it.

The tables go into docs/validation/fit.md (``validation/page.py``); the constants of the check
(``ADHESION_DIP_*`` in elastocell.inverse.fit) quote them.
"""

from __future__ import annotations

import argparse
import logging
import warnings
from pathlib import Path

import numpy as np
from page import Page

from elastocell.inverse.fit import (
    ADHESION_DIP_LIMIT,
    ADHESION_DIP_SIGMAS,
    CurveError,
    FitSettings,
    fit_curve,
    fit_hertz_sphere,
    hertz_sphere_force,
    read_curves,
)
from elastocell.scenarios.compression import hertz_force

E, R, CONTACT = 1000.0, 8e-6, 5e-6
DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "afm"
CALIBRATION = {  # (spring constant N/m, sensitivity as --sensitivity takes it): tests/test_fit_files.py's
    "fmt-afm-workshop-fd_single_2018-08-01_13.06.09.csv": (20.0, 10e-9),
    "fmt-afm-workshop-fd_single_2021-10-22_14.16.csv": (20.0, None),
    "fmt-jpk-cl_calibration_force-save-2015.02.04-11.25.21.294.jpk-force": (0.05, 50e-9),
    "fmt-ntmdt-txt-fd_2015_01_17_gel4-0,1_mQ_adh_6B_Curve_DFL_Height_51.txt": (0.055, "61nm/nA"),
}


def dmt_curve(adhesion_fraction: float, seed: int, noise_fraction: float, delta_max: float = 0.3,
              reach: float = 20e-9):
    displacement = np.linspace(0.0, CONTACT + 2 * R * delta_max, 600)
    force = E * R**2 * hertz_force(np.maximum(displacement - CONTACT, 0) / (2 * R), 0.48)
    pull_off = adhesion_fraction * force.max()
    attraction = np.where(displacement < CONTACT, -pull_off * np.exp(-(CONTACT - displacement) / reach), -pull_off)
    rng = np.random.default_rng(seed)
    return displacement, force + attraction + rng.normal(0.0, noise_fraction * force.max(), len(force))


def other_reasons(flag: str) -> bool:
    """Whether a fits.csv flag holds a reason other than the adhesion check's."""
    return any(reason and not reason.startswith("adhesion:") for reason in flag.split("; "))


def synthetic(page: Page, seeds: int) -> None:
    settings = FitSettings(radius=R, model="hertz", delta_max=0.3)
    rows = []
    for noise in (0.01, 0.003):
        for fraction in (0.0, 0.01, 0.02, 0.03, 0.05, 0.1, 0.2):
            fits = [fit_curve("dmt", *dmt_curve(fraction, seed, noise), settings) for seed in range(seeds)]
            moduli = np.array([fit["youngs_modulus"] for fit in fits])
            rows.append({"noise [% of F_max]": f"{100 * noise:g}", "pull-off [% of F_max]": f"{100 * fraction:g}",
                         "E/E_true - 1 [%]": f"{100 * (np.nanmean(moduli) / E - 1):+.1f}",
                         "range [%]": f"{100 * (np.nanmin(moduli) / E - 1):+.1f} to "
                                      f"{100 * (np.nanmax(moduli) / E - 1):+.1f}",
                         "dip [% of F_max]": f"{100 * np.mean([f['adhesion_dip_fraction'] for f in fits]):.2f}",
                         "dip [sigma]": f"{np.mean([f['adhesion_dip_sigmas'] for f in fits]):.1f}",
                         "flagged by another check": f"{sum(other_reasons(f['flag']) for f in fits)}/{seeds}",
                         "flagged adhesion": f"{sum('adhesion' in f['flag'] for f in fits)}/{seeds}"})
    page.table(rows, f"Synthetic Hertz curves with a DMT-like adhesion, {seeds} noise seeds each (flagged as "
                     f"adhesion above {ADHESION_DIP_SIGMAS:g} sigma and {100 * ADHESION_DIP_LIMIT:g} % of F_max)")


def clean(page: Page, seeds: int) -> None:
    """False alarms: curves without adhesion (many seeds), and glitches of 1-3 points 30 % of F_max deep."""
    settings = FitSettings(radius=R, model="hertz", delta_max=0.3)
    rows = []
    for noise in (0.003, 0.01, 0.03):
        fits = [fit_curve("clean", *dmt_curve(0.0, 1000 + seed, noise), settings) for seed in range(10 * seeds)]
        sigmas = [fit["adhesion_dip_sigmas"] for fit in fits]
        rows.append({"curves": f"no adhesion, {100 * noise:g} % noise", "n": len(fits),
                     "largest dip [sigma]": f"{max(sigmas):.2f}",
                     "largest dip [% of F_max]": f"{100 * max(f['adhesion_dip_fraction'] for f in fits):.2f}",
                     "flagged adhesion": sum("adhesion" in f["flag"] for f in fits)})
    for points in (1, 2, 3):
        displacement, force = dmt_curve(0.0, 1, 0.01)
        force[250:250 + points] -= 0.3 * force.max()
        fit = fit_curve("glitch", displacement, force, settings)
        rows.append({"curves": f"a glitch of {points} point(s) 30 % of F_max below, 1 % noise", "n": 1,
                     "largest dip [sigma]": f"{fit['adhesion_dip_sigmas']:.2f}",
                     "largest dip [% of F_max]": f"{100 * fit['adhesion_dip_fraction']:.2f}",
                     "flagged adhesion": int("adhesion" in fit["flag"])})
    page.table(rows, "False alarms: curves without adhesion, and glitches (the running median ignores 1-2 points)")


def sphere(page: Page, seeds: int) -> None:
    """The sphere-indenter's Hertz estimate (``fit_hertz_sphere``): a bead of 5 um, contact at 2 um, 1.5 um deep,
    1 % noise, the same DMT-like adhesion."""
    bead, contact = 5e-6, 2e-6
    rows = []
    for fraction in (0.0, 0.02, 0.05, 0.1):
        moduli, flagged = [], 0
        for seed in range(seeds):
            depth = np.linspace(0.0, contact + 1.5e-6, 600)
            force = E * hertz_sphere_force(depth - contact, 0.48, bead)
            pull_off = fraction * force.max()
            force = force + np.where(depth < contact, -pull_off * np.exp(-(contact - depth) / 20e-9), -pull_off)
            force += np.random.default_rng(seed).normal(0.0, 0.01 * force.max(), len(depth))
            fit = fit_hertz_sphere(depth, force, bead)
            moduli.append(fit["youngs_modulus"])
            flagged += "adhesion" in fit["flag"]
        rows.append({"pull-off [% of F_max]": f"{100 * fraction:g}",
                     "E/E_true - 1 [%]": f"{100 * (np.mean(moduli) / E - 1):+.1f}",
                     "flagged adhesion": f"{flagged}/{seeds}"})
    page.table(rows, f"The sphere-indenter's Hertz estimate (bead 5 um, 1.5 um deep, 1 % noise), {seeds} seeds")


def real(page: Page) -> None:
    logging.getLogger("afmformats").setLevel(logging.CRITICAL)
    rows = []
    for path in sorted(p for p in DATA.iterdir() if p.suffix != ".md"):
        k, s = CALIBRATION.get(path.name, (None, None))
        settings = FitSettings(radius="8um", spring_constant=k, sensitivity=s)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            curves = read_curves(path, settings.spring_constant, settings.sensitivity, settings.sensitivity_unit)
            for curve in curves:
                try:
                    fit = fit_curve(curve.name, curve.displacement, curve.force, settings)
                except CurveError as error:
                    rows.append({"curve": curve.name, "dip [sigma]": "-", "dip [% of F_max]": "-",
                                 "adhesion flagged": f"no fit: {str(error)[:60]}"})
                    continue
                rows.append({"curve": curve.name, "dip [sigma]": f"{fit['adhesion_dip_sigmas']:.1f}",
                             "dip [% of F_max]": f"{100 * fit['adhesion_dip_fraction']:.2f}",
                             "adhesion flagged": "yes" if "adhesion" in fit["flag"] else "no"})
    page.table(rows, "The real files of tests/data/afm (plates, R = 8 um; the other checks are not the question "
                     "here: most of these curves are not plate compressions)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=10, help="noise seeds per synthetic case")
    arguments = parser.parse_args()
    page = Page("fit", "afm_adhesion.py", intro=(
        "The adhesion check of `fit afm`: a dip of the baseline-corrected force below the baseline between the "
        "baseline window and the onset past the contact (the minimum of its 5-point running median) deeper than "
        f"{ADHESION_DIP_SIGMAS:g} standard deviations of the baseline window's own running median and "
        f"{100 * ADHESION_DIP_LIMIT:g} % of the largest fitted force is flagged. Reference for the synthetic "
        "curves: the E they were made with (Hertz, plates, to delta 0.3; a DMT-like adhesion: an attraction "
        "decaying over 20 nm before contact and the same pull-off force in contact). The real files' truth is "
        "unknown; the NT-MDT file is a gel curve its authors named 'adh'."))
    synthetic(page, arguments.seeds)
    clean(page, arguments.seeds)
    sphere(page, arguments.seeds)
    real(page)
    page.write()


if __name__ == "__main__":
    main()
