"""Fit a Young's modulus to an AFM plate-compression force curve.

A synthetic curve is made from the shipped master curve F = E R^2 f(delta) of a homogeneous neo-Hookean sphere
(Poisson ratio 0.48) between parallel plates, with a true E, a contact point, a force offset (the baseline) and
Gaussian noise, and written as a plain CSV (columns ``displacement`` and ``force``, in m and N). ``fit_files``
then estimates the contact point and fits E to the master curve and to Hertz, with 95 % intervals from the fit's
covariance and from a residual bootstrap. Hertz, exact only at small delta, overestimates E at large delta.

Instrument files (JPK ``.jpk-force``, Asylum ``.ibw``, ... through afmformats) are read the same way: pass them on
the command line with the radius of the cell (their geometry must be plates squeezing a cell, not a tip indenting
one):

    python examples/afm_fit.py                    # full size: 3 noise levels, 200 bootstrap refits
    python examples/afm_fit.py curve.jpk-force --radius 8um     # also fit a measured file
    ELASTOCELL_EXAMPLE_SMOKE=1 python examples/afm_fit.py       # 1 curve, 20 bootstrap refits

Time: no simulation (the master curve ships with elastocell): 7.5 s of CPU at full size (54 s measured with the
cores shared with other jobs), about 12 s in smoke mode, mostly imports and plots.

Output: ``$ELASTOCELL_EXAMPLE_OUT`` (default ``example-output/afm_fit``, ``-smoke`` appended in smoke mode):
the curves (``curves/*.csv``), ``fits.csv``, one PNG per curve, ``fit_settings.json``; measured files in
``measured/``. Same as ``elastocell fit afm curves/*.csv --radius 8um --bootstrap 200 --out DIR``.
"""

import argparse
import os
from pathlib import Path

import numpy as np
import pandas as pd

from elastocell.inverse.fit import FitSettings, fit_files, parse_length
from elastocell.inverse.mastercurve import load_master_curve

SMOKE = os.environ.get("ELASTOCELL_EXAMPLE_SMOKE") == "1"
OUT = Path(os.environ.get("ELASTOCELL_EXAMPLE_OUT", "example-output/afm_fit" + ("-smoke" if SMOKE else "")))

E_TRUE = 1000.0       # Pa
RADIUS = 8e-6         # m
CONTACT = 4e-6        # m: where the plate touches the cell
OFFSET = 3e-10        # N: force baseline left by the instrument


def synthetic_curve(noise_fraction: float, seed: int, delta_max: float = 0.6, points: int = 800):
    """Approach from 0 to the contact point (baseline only) and on to delta_max = (d - contact)/(2R)."""
    master = load_master_curve(poisson_ratio=0.48)  # the shipped curve: no simulation needed
    displacement = np.linspace(0.0, CONTACT + 2 * RADIUS * delta_max, points)
    delta = np.maximum(displacement - CONTACT, 0.0) / (2 * RADIUS)
    force = E_TRUE * RADIUS**2 * master(delta)
    noise = np.random.default_rng(seed).normal(0.0, noise_fraction * force.max(), points)
    return pd.DataFrame({"displacement": displacement, "force": force + OFFSET + noise})


def report(rows):
    for row in rows:
        boot = (f", bootstrap [{row['youngs_modulus_bootstrap_ci_low']:.1f}, {row['youngs_modulus_bootstrap_ci_high']:.1f}]"
                if "youngs_modulus_bootstrap_ci_low" in row else "")
        print(f"{row['file']}: E = {row['youngs_modulus']:.1f} Pa, 95 % interval [{row['youngs_modulus_ci_low']:.1f}, "
              f"{row['youngs_modulus_ci_high']:.1f}]{boot}; contact {row['contact_point'] * 1e6:.3f} um, up to delta "
              f"{row['delta_max']:.2f}; Hertz: E = {row['youngs_modulus_hertz']:.1f} Pa"
              + (f" (check: {row['flag']})" if row.get("flag") else ""))


def main():
    parser = argparse.ArgumentParser(description="fit E to synthetic (and measured) AFM plate-compression curves")
    parser.add_argument("files", nargs="*", help="measured force curves (CSV or any format afmformats reads)")
    parser.add_argument("--radius", default="8um", help="cell radius of the measured curves (default 8um)")
    args = parser.parse_args()

    noise_levels = [0.01] if SMOKE else [0.005, 0.01, 0.02]
    settings = FitSettings(radius=RADIUS, poisson_ratio=0.48, model="both", bootstrap=20 if SMOKE else 200)

    curves = OUT / "curves"
    curves.mkdir(parents=True, exist_ok=True)
    paths = []
    for seed, noise in enumerate(noise_levels):
        path = curves / f"synthetic_noise{noise * 100:g}pct.csv"
        synthetic_curve(noise, seed).to_csv(path, index=False)
        paths.append(path)

    result = fit_files(paths, settings, OUT)  # fits.csv, one PNG per curve, fit_settings.json
    print(f"true E = {E_TRUE:g} Pa, contact {CONTACT * 1e6:g} um, R = {RADIUS * 1e6:g} um, noise relative to F_max:")
    report(result["rows"])

    if args.files:  # measured curves: the same fit with their cell radius
        measured = fit_files(args.files, FitSettings(radius=parse_length(args.radius, "radius"), bootstrap=0),
                             OUT / "measured")
        report(measured["rows"])
        for name, error in measured["errors"]:
            print(f"{name}: {error}")
    print(f"table: {OUT / 'fits.csv'}, plots: {OUT}/*.png")


if __name__ == "__main__":
    main()
