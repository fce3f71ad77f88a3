"""Fit accuracy, Hertz's bias against the fitted delta range, CI coverage, and timings.

    python validation/fit.py [--nu 0.48] [--curves 1000] [--coverage 50] [--out DIR]

Synthetic curves come from the shipped master curve: E = 1 kPa, R = 8 um, contact at 5 um after a 5 um
baseline, Gaussian force noise (a fraction of the largest force), 600 points. The tables go into
docs/validation/fit.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from page import Page

from elastocell.inverse.fit import FitSettings, fit_curve, fit_files
from elastocell.inverse.mastercurve import load_master_curve

E, R, CONTACT = 1000.0, 8e-6, 5e-6


def synthetic(curve, delta_max, noise_fraction, seed, n=600):
    displacement = np.linspace(0.0, CONTACT + 2 * R * delta_max, n)
    force = E * R**2 * curve(np.maximum(displacement - CONTACT, 0) / (2 * R))
    rng = np.random.default_rng(seed)
    return displacement, force + rng.normal(0.0, noise_fraction * force.max(), n)


def felupe_check(curve, nu, mesh_size, pole_size, delta_max=0.7, *, page):
    """Independent data: FElupe's curve of the same sphere (validation/felupe_peer.py), in physical units with
    0.5 % noise, fitted by the shipped master curve and by Hertz."""
    from felupe_peer import felupe_compression_curve
    from scipy.interpolate import PchipInterpolator

    peer = felupe_compression_curve(mesh_size, pole_size, delta_max=0.75, n_steps=60, poisson_ratio=nu)
    page.print(f"FElupe {mesh_size}:{pole_size}: {peer['n_nodes']} nodes, {peer['wall_time_s']:.0f} s, "
               f"converged {peer['converged']}")
    delta, force = np.asarray(peer["delta"]), np.asarray(peer["force_per_E_R2"])
    keep = np.r_[True, np.diff(delta) > 0]
    interpolate = PchipInterpolator(delta[keep], force[keep])
    for d in (0.1, 0.3, 0.5, 0.7):
        page.print(f"  delta {d}: FElupe {float(interpolate(d)):.4f}, shipped master {float(curve(np.array([d]))[0]):.4f}")
    for limit in (0.3, delta_max):
        displacement = np.linspace(0.0, CONTACT + 2 * R * limit, 600)
        d = np.maximum(displacement - CONTACT, 0) / (2 * R)
        clean = E * R**2 * interpolate(d)
        for noise in (0.0, 0.005):
            rng = np.random.default_rng(0)
            data = clean + rng.normal(0, noise * clean.max(), len(d)) if noise else clean
            row = fit_curve("felupe", displacement, data,
                            FitSettings(radius=R, poisson_ratio=nu, model="both", delta_max=limit), curve)
            page.print(f"  up to delta {limit}, noise {100 * noise:g} %: master E/E_true - 1 = "
                       f"{100 * (row['youngs_modulus'] / E - 1):+.2f} % (CI {row['youngs_modulus_ci_low']:.1f}-"
                       f"{row['youngs_modulus_ci_high']:.1f} Pa), Hertz {100 * (row['youngs_modulus_hertz'] / E - 1):+.1f} %, "
                       f"contact {1e6 * (row['contact_point'] - CONTACT):+.3f} um")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--nu", type=float, default=0.48)
    parser.add_argument("--curves", type=int, default=1000)
    parser.add_argument("--coverage", type=int, default=50)
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--felupe", default=None, help="MESH_SIZE:POLE_SIZE: fit an independent FElupe curve")
    args = parser.parse_args()
    page = Page("fit", "fit.py", intro=(
        "Synthetic AFM curves made from the shipped master curve (E = 1 kPa, R = 8 um, contact at 5 um after a "
        "5 um baseline, Gaussian force noise as a fraction of the largest force, 600 points) are fitted back; the "
        "truth they are measured against is the E and contact point they were made with. Hertz's closed form is "
        "fitted to the same curves, so its bias against the fitted delta range shows what the master curve "
        "corrects. The coverage counts how often the 95 % interval holds the true E over independent noise "
        "seeds. Timings: one curve, and many curves through `fit_files` in this process and on a 2-worker local "
        "Dask cluster (its start included). With `--felupe`, the curve fitted is instead FElupe's (a peer FE "
        "code, `validation/felupe_peer.py`) for the same sphere: data the master curve was not made from."),
        versions=("felupe", "dask", "distributed"))
    curve = load_master_curve(args.nu)
    if args.felupe:
        felupe_check(curve, args.nu, *map(float, args.felupe.split(":")), page=page)
        page.write()
        return

    rows_bias = []
    for delta_max in (0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.75):
        rows = [fit_curve("b", *synthetic(curve, delta_max, 0.002, seed),
                          FitSettings(radius=R, poisson_ratio=args.nu, model="both", delta_max=delta_max), curve)
                for seed in range(5)]
        rows_bias.append({"delta_max": delta_max,
                          "E_master / E - 1": np.mean([r["youngs_modulus"] for r in rows]) / E - 1,
                          "E_Hertz / E - 1": np.mean([r["youngs_modulus_hertz"] for r in rows]) / E - 1,
                          "Hertz contact - true (um)": 1e6 * (np.mean([r["contact_point_hertz"] for r in rows]) - CONTACT)})
    page.table(rows_bias, f"Hertz bias against the fitted range (nu = {args.nu}, noise 0.2 % of the largest force, "
               "E and contact fitted by both models; mean of 5 seeds)",
               formats={"delta_max": ".2f", "E_master / E - 1": "+.2%", "E_Hertz / E - 1": "+.1%",
                        "Hertz contact - true (um)": "+.3f"})
    rows_fixed = []
    for delta_max in (0.05, 0.1, 0.3, 0.5, 0.75):
        rows = [fit_curve("b", *synthetic(curve, delta_max, 0.002, seed),
                          FitSettings(radius=R, poisson_ratio=args.nu, model="hertz", delta_max=delta_max,
                                      contact_point=CONTACT), curve) for seed in range(5)]
        rows_fixed.append({"delta_max": delta_max,
                           "E_Hertz / E - 1": np.mean([r["youngs_modulus"] for r in rows]) / E - 1})
    page.table(rows_fixed, "Hertz with the contact point fixed at the truth",
               formats={"delta_max": ".2f", "E_Hertz / E - 1": "+.1%"})

    if args.coverage:
        inside, errors, widths = 0, [], []
        for seed in range(args.coverage):
            row = fit_curve("c", *synthetic(curve, 0.75, 0.01, 1000 + seed),
                            FitSettings(radius=R, poisson_ratio=args.nu, model="master"), curve)
            inside += row["youngs_modulus_ci_low"] <= E <= row["youngs_modulus_ci_high"]
            errors.append(row["youngs_modulus"] / E - 1)
            widths.append((row["youngs_modulus_ci_high"] - row["youngs_modulus_ci_low"]) / 2 / E)
        page.heading("Interval coverage")
        page.print(f"CI coverage (noise 1 %, delta to 0.75, {args.coverage} seeds): {inside}/{args.coverage} inside "
                   f"the 95 % CI; mean error {100 * np.mean(errors):+.2f} %, rms "
                   f"{100 * np.sqrt(np.mean(np.square(errors))):.2f} %, mean CI half-width {100 * np.mean(widths):.2f} %")

    page.heading("Cost")
    displacement, force = synthetic(curve, 0.75, 0.01, 7)
    settings = FitSettings(radius=R, poisson_ratio=args.nu, model="both")
    fit_curve("warm", displacement, force, settings, curve)
    start = time.perf_counter()
    for _ in range(20):
        fit_curve("t", displacement, force, settings, curve)
    page.print(f"one curve (600 points, master + Hertz): {(time.perf_counter() - start) / 20 * 1e3:.1f} ms")

    if args.curves:
        with tempfile.TemporaryDirectory() as folder:
            folder = Path(folder)
            for index in range(args.curves):
                d, f = synthetic(curve, 0.75, 0.01, index)
                pd.DataFrame({"displacement": d, "force": f}).to_csv(folder / f"c{index:04d}.csv", index=False)
            out = args.out or folder / "fits"
            for label, options in (("in process", {"dask": False}), ("Dask, 2 local workers", {"workers": 2})):
                start = time.perf_counter()
                result = fit_files([folder], settings, out, plots=False, **options)
                wall = time.perf_counter() - start
                table = pd.read_csv(Path(out) / "fits.csv")
                page.print(f"{args.curves} curves via fit_files (read CSV + both fits, no plots, {label}): {wall:.1f} s; "
                           f"E median {table['youngs_modulus'].median():.1f} Pa, errors {len(result['errors'])}")
            start = time.perf_counter()
            fit_files(sorted(folder.glob("c000*.csv"))[:5], settings, folder / "plots", plots=True)
            page.print(f"5 curves with plots: {time.perf_counter() - start:.1f} s")
    page.write()

if __name__ == "__main__":
    main()
