"""A cell with a stiff nucleus fitted three ways: E_c from its own curve (``youngs_modulus_cytoplasm_nucleated``)
against the conversions of the homogeneous fit (the volume average and the Hashin-Shtrikman upper bound), under
the plates and under a bead; and what the homogeneous equivalent's modulus is, in units of E_c, for each loading
and depth: the paper's question asked of the AFM measurement itself.

    nice python validation/nucleated_fit.py [--quick] [--noise 0.005]

Truth: the axisymmetric solver on its default meridian mesh with every size x 0.7 (a mesh the fit's own curve,
on the default mesh, does not share; between plates, lambda 0.5, gamma <= 20, the two differ by at most 0.07 % at
delta <= 0.5 and 0.33 % at delta 0.7, docs/validation/axisymmetric.md), its first step resolved in rows as the
fit's curve's is. Each truth curve is sampled as an instrument would (600 points, E_c = 1 kPa,
R = 8 um, 3 um of baseline before contact, Gaussian noise of 0.5 % of the largest force, seeds 0-2) and fitted
by ``elastocell.inverse.fit.fit_curve`` with the nucleus options up to each load: the contact point is fitted, as
for a measured curve. Writes its section of docs/validation/afm.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from page import Page

# jax's compilation cache tries ``from compression import zstd`` (Python 3.14's module): this directory's
# compression.py must not answer it
sys.path[:] = [entry for entry in sys.path if Path(entry or ".").resolve() != Path(__file__).resolve().parent]

from elastocell.body.axisymmetric import MeridianMeshParameters  # noqa: E402
from elastocell.inverse.fit import FitSettings, fit_curve  # noqa: E402
from elastocell.inverse.indentation_surface import curve_function  # noqa: E402
from elastocell.inverse.nucleated_curve import NucleatedCurve, curve_parameters  # noqa: E402
from elastocell.inverse.nucleated_curve import _compute as compute_curve  # noqa: E402

NU = 0.48
E_C = 1000.0  # Pa
R = 8e-6  # m
CONTACT = 3e-6  # m of baseline before contact
POINTS = 600
NOISE = 0.005  # of the largest force (--noise)
SEEDS = (0, 1, 2)
TRUTH_SCALE = 0.7
# (label, geometry, cell shape, R_b/R, H/R, lambda, gamma, loads fitted up to)
CASES = [
    ("plates", "parallel-plates", None, None, None, 0.5, 2.0, (0.1, 0.3, 0.5, 0.7)),
    ("plates", "parallel-plates", None, None, None, 0.5, 5.0, (0.1, 0.3, 0.5, 0.7)),
    ("plates", "parallel-plates", None, None, None, 0.5, 10.0, (0.1, 0.3, 0.5, 0.7)),
    ("plates", "parallel-plates", None, None, None, 0.5, 20.0, (0.1, 0.3, 0.5, 0.7)),
    ("plates", "parallel-plates", None, None, None, 0.7, 5.0, (0.025, 0.1, 0.3, 0.5, 0.7)),
    ("bead on a suspended cell", "sphere-indenter", "sphere", 0.707, None, 0.5, 2.0, (0.1, 0.2, 0.3, 0.5)),
    ("bead on a suspended cell", "sphere-indenter", "sphere", 0.707, None, 0.5, 10.0, (0.1, 0.2, 0.3, 0.5)),
    ("bead on a suspended cell", "sphere-indenter", "sphere", 0.25, None, 0.5, 5.0, (0.05, 0.1, 0.25)),
    ("bead on an adherent cap", "sphere-indenter", "cap", 0.5, 0.75, 0.3, 5.0, (0.02, 0.05, 0.1, 0.2)),
]
QUICK = [CASES[0], CASES[5]]


def truth_curve(geometry: str, shape: str | None, ratio: float | None, cap: float | None, size_ratio: float,
                stiffness_ratio: float):
    """(load, force) on the refined meridian mesh, to the fit's own curve's range, its first step resolved as the
    fit's curve resolves it (:func:`elastocell.inverse.nucleated_curve._compute`)."""
    parameters = curve_parameters(geometry, size_ratio, stiffness_ratio, NU, cell_shape=shape or "sphere",
                                  indenter_ratio=ratio, cap_ratio=cap)
    load, force, _, _ = compute_curve({**parameters, "mesh": MeridianMeshParameters().scaled(TRUTH_SCALE)})
    return load, force


def sampled(function, load_max: float, plates: bool, seed: int, noise: float = NOISE):
    """(displacement, force) of the curve up to ``load_max`` (delta or depth/R), as an instrument records it."""
    span = load_max * (2 * R if plates else R)
    x = np.linspace(0.0, CONTACT + span, POINTS)
    load = np.maximum(x - CONTACT, 0.0) / (2 * R if plates else R)
    clean = E_C * R**2 * function(load)
    return x, clean + noise * clean.max() * np.random.default_rng(seed).standard_normal(POINTS)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="two cells, one seed")
    parser.add_argument("--noise", type=float, default=NOISE, help="noise, share of the largest force")
    args = parser.parse_args()
    page = Page("afm", "nucleated_fit.py", intro=(
        "A cell with a concentric nucleus (size ratio lambda, stiffness ratio gamma) fitted as `elastocell fit afm` "
        "fits it with `--nucleus-size-ratio` and `--stiffness-ratio`: E_c from the nucleated cell's own curve "
        "(the axisymmetric solver, default meridian mesh; column `youngs_modulus_cytoplasm_nucleated`) beside "
        "E_c from the homogeneous fit converted by the volume average (`youngs_modulus_cytoplasm`) and by the "
        "Hashin-Shtrikman upper bound. Truth: the same solver with every meridian size x "
        f"{TRUTH_SCALE:g}; curves of {POINTS} points, E_c = {E_C:g} Pa, R = {R * 1e6:g} um, "
        f"{CONTACT * 1e6:g} um of baseline, noise {100 * args.noise:g} % of the largest force, seeds "
        f"{', '.join(map(str, SEEDS))} (and the same curves without noise); the contact point is fitted. E/E_c is the homogeneous fit's modulus "
        "over the true E_c (the effective stiffness ratio this measurement sees), beside the volume average's."))
    rows = []
    cases = QUICK if args.quick else CASES
    seeds = SEEDS[:1] if args.quick else SEEDS
    worst = {"nucleated": 0.0, "no noise": 0.0, "volume average": 0.0, "HS upper": 0.0}
    for label, geometry, shape, ratio, cap, size_ratio, stiffness_ratio, loads in cases:
        plates = geometry == "parallel-plates"
        load, force = truth_curve(geometry, shape, ratio, cap, size_ratio, stiffness_ratio)
        if plates:
            function = NucleatedCurve("parallel-plates", load, force, 0.75, {"poisson_ratio": NU})
        else:
            function = curve_function(load, force, ratio, NU, shape, cap)
        for limit in loads:
            if limit > load[-1] + 1e-9:
                continue
            results = {"nucleated": [], "volume average": [], "HS upper": [], "E/E_c": [], "shift": [],
                       "flags": set(), "homogeneous flags": set()}
            for seed in (None, *seeds):  # None: without noise
                x, y = sampled(function, limit, plates, seed or 0, 0.0 if seed is None else args.noise)
                extra = {"delta_max": limit} if plates else {
                    "indenter_radius": ratio * R, "cell_shape": shape, "depth_max": limit,
                    **({"cap_height": cap * R} if cap else {})}
                settings = FitSettings(radius=R, poisson_ratio=NU, geometry=geometry, nucleus_size_ratio=size_ratio,
                                       stiffness_ratio=stiffness_ratio, **extra)
                row = fit_curve(label, x, y, settings)
                if seed is None:
                    results["no noise"] = row["youngs_modulus_cytoplasm_nucleated"] / E_C - 1
                    continue
                results["nucleated"].append(row["youngs_modulus_cytoplasm_nucleated"] / E_C - 1)
                results["volume average"].append(row["youngs_modulus_cytoplasm"] / E_C - 1)
                results["HS upper"].append(row["youngs_modulus_cytoplasm_hashin_shtrikman_upper"] / E_C - 1)
                results["E/E_c"].append(row["youngs_modulus"] / E_C)
                results["shift"].append(1e9 * (row["contact_point"] - CONTACT))
                results["flags"].add(row["flag_nucleated"] or "accepted")
                results["homogeneous flags"].update(reason.split(" (")[0].split(":")[0]
                                                    for reason in row["flag"].split("; ") if reason)
            for key in worst:
                worst[key] = max(worst[key], np.max(np.abs(results[key])))
            span = lambda values: f"{100 * min(values):+.2f} .. {100 * max(values):+.2f} %"  # noqa: E731
            rows.append({"loading": label, "R_b/R": ratio if ratio else "", "H/R": cap if cap else "",
                         "lambda": size_ratio, "gamma": stiffness_ratio,
                         "fitted up to": f"{'delta' if plates else 'depth/R'} {limit:g}",
                         "E_c nucleated fit": span(results["nucleated"]),
                         "no noise": f"{100 * results['no noise']:+.2f} %",
                         "E_c volume average": span(results["volume average"]),
                         "E_c HS upper": span(results["HS upper"]),
                         "E/E_c": f"{np.mean(results['E/E_c']):.3f}",
                         "volume average E_eff/E_c": f"{row['effective_stiffness_ratio']:.3f}",
                         "homogeneous fit: contact shift (nm)": f"{np.mean(results['shift']):+.0f}",
                         "homogeneous fit flag": "; ".join(sorted(results["homogeneous flags"])) or "accepted",
                         "nucleated fit flag": "; ".join(sorted(results["flags"]))})
    page.table(rows, "E_c recovered from noisy curves of a nucleated cell (error over the seeds), and the "
                     "homogeneous equivalent's modulus E/E_c this measurement sees")
    page.print("largest |error| of E_c: " + ", ".join(f"{key} {100 * value:.2f} %" for key, value in worst.items()))
    page.write()


if __name__ == "__main__":
    main()
