"""Beyond the paper: which equivalent modulus holds? For every heterogeneous cell of the compression and
shear-flow studies, the modulus of the homogeneous cell that best reproduces its response, beside the paper's
volume average (Voigt) and the classical estimates of composite theory (:mod:`elastocell.body.effective_moduli`).

Best fit, compression: a homogeneous (neo-Hookean or Mooney-Rivlin) cell's force scales with its modulus, so the
least-squares fit in log F over delta >= 0.05 is ``E_fit/E_c = gamma_eff exp(mean log(F/F_eq))`` with the
cell's equivalent on the same mesh as reference (mesh errors cancel). Shear flow: the homogeneous cell's
D(Ca) (the mu_c cell and every equivalent, Ca against its own modulus, interpolated in log-log) shifted in
Ca by the modulus ratio s: ``min_s sum (log D_cell(Ca_i) - log D_hom(Ca_i/s))^2``. Pipe flow runs a single
Ca_w, which cannot fix a modulus: not fitted.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from elastocell.body.cell import Cell
from elastocell.body.effective_moduli import ESTIMATES, all_estimates
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.flow import flow_cell
from elastocell.studies.base import Claim, Study
from elastocell.studies.compression import (
    DELTA_MIN,
    curves,
    new_figure,
    percent,
    save_study_figure,
    size_members,
    stiffness_members,
    tidy,
)
from elastocell.studies.flow import shear_capillary_members, shear_table

LABELS = {"voigt": "Voigt (paper: volume average)", "reuss": "Reuss", "hashin_shtrikman_lower": "HS lower",
          "hashin_shtrikman_upper": "HS upper", "self_consistent": "self-consistent"}


def members(quick: bool):
    return stiffness_members(quick) + size_members(quick) + shear_capillary_members(quick)


def _nucleus_phases(row_gamma: float, row_size: float, gamma_eff: float):
    """A nucleus cell's two phases with the meshed volume fraction phi = (gamma_eff - 1)/(gamma - 1), so that
    Voigt equals the simulated equivalent exactly (the random cell's phases: :func:`_mesh_phases`)."""
    phi = (gamma_eff - 1) / (row_gamma - 1) if row_gamma != 1 else row_size ** 3
    return np.array([1.0, row_gamma]), np.array([1 - phi, phi])


def compression_fits(frame) -> list[dict]:
    rows = []
    for discretisation in dict.fromkeys(frame.get("discretisation", ["-"])) if "discretisation" in frame else ["-"]:
        part = frame if discretisation == "-" else frame[frame["discretisation"] == discretisation]
        table = curves(part)
        seen = set()
        for (pair, equivalent), curve in table.items():
            if equivalent or (pair, True) not in table or pair == "gamma 1":
                continue
            reference = table[(pair, True)]
            keep = (curve[0] >= DELTA_MIN) & (curve[0] <= reference[0][-1] + 1e-12)
            if keep.sum() < 3:
                continue
            info = part[(part["pair"] == pair) & (~part["equivalent"].astype(bool))].iloc[0]
            identity = info.get("run_id", pair)
            if identity in seen:  # the same run in two series (gamma 2 = lambda 0.5)
                continue
            seen.add(identity)
            gamma_eff = float(info["effective_stiffness_ratio"])
            log_ratio = np.log(curve[1][keep] / np.interp(curve[0][keep], reference[0], reference[1]))
            fit = gamma_eff * float(np.exp(log_ratio.mean()))
            rows.append(_row("compression", pair, discretisation, info, gamma_eff, fit,
                             float(log_ratio.std()), float(curve[0][keep][-1])))
    return rows


def shear_fits(frame) -> list[dict]:
    rows = frame[frame["status"] == "complete"]
    homogeneous_ca, homogeneous_d = [], []
    for _, row in rows.iterrows():
        if row["cell"] == "homogeneous mu_c":
            homogeneous_ca.append(row["capillary_number_mu_c"])
        elif row["equivalent"]:
            homogeneous_ca.append(row["capillary_number_mu_c"] / row["effective_stiffness_ratio"])
        else:
            continue
        homogeneous_d.append(row["taylor_deformation_mean"])
    if len(homogeneous_ca) < 2:
        return []
    order = np.argsort(homogeneous_ca)
    log_ca, log_d = np.log(np.asarray(homogeneous_ca)[order]), np.log(np.asarray(homogeneous_d)[order])

    def log_homogeneous(ca):  # log-log interpolation, linear extrapolation at both ends
        x = np.log(ca)
        inside = np.interp(x, log_ca, log_d)
        low = log_d[0] + (x - log_ca[0]) * (log_d[1] - log_d[0]) / (log_ca[1] - log_ca[0])
        high = log_d[-1] + (x - log_ca[-1]) * (log_d[-1] - log_d[-2]) / (log_ca[-1] - log_ca[-2])
        return np.where(x < log_ca[0], low, np.where(x > log_ca[-1], high, inside))

    from scipy.optimize import minimize_scalar

    out = []
    cells = rows[(~rows["equivalent"].astype(bool)) & (rows["cell"] != "homogeneous mu_c")]
    for cell, group in cells.groupby("cell", sort=False):
        ca = group["capillary_number_mu_c"].to_numpy(float)
        d = group["taylor_deformation_mean"].to_numpy(float)
        def objective(log_s, ca=ca, d=d):
            return float(np.sum((np.log(d) - log_homogeneous(ca / np.exp(log_s))) ** 2))

        best = minimize_scalar(objective, bounds=(np.log(0.2), np.log(50.0)), method="bounded")
        info = group.iloc[0]
        residual = float(np.sqrt(best.fun / len(ca)))
        out.append(_row("shear", cell, str(info.get("discretisation", "-")), info,
                        float(info["effective_stiffness_ratio"]), float(np.exp(best.x)), residual, float(ca.max())))
    return out


SCENARIO_OPTIONS = ("steps", "delta_max", "vtk", "equivalent", "capillary_number", "capillary_number_modulus",
                    "resolution", "duration", "stationary_tolerance", "vtk_interval", "solver")


def _mesh_phases(info):
    """The random cell's own phases: every tetrahedron's stiffness ratio and volume fraction (rebuilt from the
    run's options; the mesh is cached), so that its Voigt value is the simulated equivalent's."""

    options = {k[len("option_"):]: v for k, v in info.items() if k.startswith("option_") and v == v and v is not None}
    options = {k: v for k, v in options.items() if k not in SCENARIO_OPTIONS}
    if "resolution" in info.index or "capillary_number_mu_c" in info.index:  # a flow run's cell
        resolution = info.get("resolution") or info.get("option_resolution")
        parameters = flow_cell(None, options, float(resolution))
    else:
        parameters = cell_parameters(**options)
    body = Cell.from_parameters(parameters)
    return body.youngs_moduli, body.element_volumes / body.volume


def _row(loading, cell, discretisation, info, gamma_eff, fit, residual, reach) -> dict:
    random = cell == "random"
    gamma = float(info.get("stiffness_ratio", np.nan)) if not random else np.nan
    size = float(info.get("size_ratio", 0.5)) if not random else np.nan
    stiffness, fractions = _mesh_phases(info) if random else _nucleus_phases(gamma, size, gamma_eff)
    estimates = all_estimates(stiffness, fractions)
    row = {"loading": loading, "cell": cell, "discretisation": discretisation, "stiffness_ratio": gamma,
           "size_ratio": size, "volume_fraction": float(fractions[-1]) if not random else np.nan,
           "best_fit": fit, "fit_residual_log": residual, "range_max": reach, **estimates}
    row.update({f"{name}_error": estimates[name] / fit - 1 for name in ESTIMATES})
    return row


def table(pairs, directory: Path, quick: bool = False):
    import pandas as pd


    compression = tidy([p for p in pairs if p[1]["scenario"] == "compress"], directory)
    shear = shear_table([p for p in pairs if p[1]["scenario"] == "shear"], directory)
    return pd.DataFrame(compression_fits(compression) + shear_fits(shear))


def plot(frame, directory: Path, stem: str) -> list[Path]:
    figure, axes = new_figure(1, 3)
    if frame.empty or "loading" not in frame:
        return save_study_figure(figure, directory, stem)
    by_gamma, by_size, errors = axes[0]
    compression = frame[frame["loading"] == "compression"]
    first = compression["discretisation"].iloc[0] if not compression.empty else "-"
    main = frame[frame["discretisation"].isin([first, "-"])]
    gamma_grid = np.linspace(1, 20, 60)
    for name, style in zip(ESTIMATES, ("-", "--", "-.", ":", (0, (5, 1))), strict=True):
        phi = 0.125
        by_gamma.plot(gamma_grid, [all_estimates([1, g], [1 - phi, phi])[name] for g in gamma_grid], color="k",
                      ls=style, lw=1, label=LABELS[name])
        sizes = np.linspace(0.05, 0.95, 40)
        by_size.plot(sizes, [all_estimates([1, 2], [1 - s ** 3, s ** 3])[name] for s in sizes], color="k",
                     ls=style, lw=1, label=LABELS[name])
    for loading, marker in (("compression", "o"), ("shear", "s")):
        part = main[(main["loading"] == loading) & (main["size_ratio"] == 0.5)]
        by_gamma.plot(part["stiffness_ratio"], part["best_fit"], marker, ms=6, mfc="none", label=f"best fit, {loading}")
        part = main[(main["loading"] == loading) & (main["stiffness_ratio"] == 2)]
        if not part.empty:
            by_size.plot(part["size_ratio"], part["best_fit"], marker, ms=6, mfc="none", label=f"best fit, {loading}")
    by_gamma.set_xlabel(r"stiffness ratio $\gamma$ ($\lambda$ = 0.5)")
    by_size.set_xlabel(r"size ratio $\lambda$ ($\gamma$ = 2)")
    for axis in (by_gamma, by_size):
        axis.set_ylabel(r"$E/E_c$")
        axis.grid(alpha=0.3)
        axis.legend(fontsize=6)
    width = 0.8 / max(1, main["loading"].nunique())
    for index, (loading, part) in enumerate(main.groupby("loading")):
        rms = [100 * float(np.sqrt(np.mean(part[f"{name}_error"] ** 2))) for name in ESTIMATES]
        errors.bar(np.arange(len(ESTIMATES)) + index * width, rms, width, label=loading)
    errors.set_xticks(np.arange(len(ESTIMATES)) + 0.4 - width / 2, [LABELS[n].split(" (")[0] for n in ESTIMATES],
                      rotation=30, fontsize=7)
    errors.set_ylabel("RMS error against the best fit (%)")
    errors.set_yscale("log")
    errors.legend(fontsize=7)
    errors.grid(alpha=0.3, axis="y")
    by_gamma.set_title("(a) best-fit modulus and estimates")
    by_size.set_title("(b) size-ratio sweep")
    errors.set_title("(c) which estimate to use")
    return save_study_figure(figure, directory, stem)


def recommendation(frame) -> dict:
    """Per loading, on the primary discretisation: each estimate's median and RMS relative error against the
    best fit and the number of cells where it is the closest; the best estimate by median error (the RMS is
    dominated by the stiffest nucleus), and the closest estimate per cell."""
    out = {}
    for loading, part in frame.groupby("loading", sort=False):
        if "discretisation" in part and part["discretisation"].nunique() > 1:
            part = part[part["discretisation"] == part["discretisation"].iloc[0]]
        errors = np.abs(part[[f"{name}_error" for name in ESTIMATES]].to_numpy(float))
        median = {name: float(np.median(errors[:, i])) for i, name in enumerate(ESTIMATES)}
        rms = {name: float(np.sqrt(np.mean(errors[:, i] ** 2))) for i, name in enumerate(ESTIMATES)}
        closest = [ESTIMATES[i] for i in errors.argmin(axis=1)]
        wins = {name: closest.count(name) for name in ESTIMATES}
        best = min(median, key=median.get)
        out[loading] = {"best": best, "best_median_error": median[best], "voigt_median_error": median["voigt"],
                        "median": median, "rms": rms, "wins": wins, "cells": len(part),
                        "closest_by_cell": dict(zip(part["cell"], closest, strict=True))}
    return out


def claims(frame) -> list[Claim]:
    out = []
    if frame.empty:
        return out
    for loading, result in recommendation(frame).items():
        voigt = result["voigt_median_error"]
        out.append(Claim(
            "equivalent-modulus", f"The volume-averaged (Voigt) modulus is the homogeneous equivalent ({loading}).",
            "Sec. 2.2, Eq. (4)", f"median |E_Voigt/E_fit - 1| over {result['cells']} cells: {percent(voigt)} "
                                 f"(RMS {percent(result['rms']['voigt'])}); closest estimate in "
                                 f"{result['wins']['voigt']} of {result['cells']} cells",
            "agree" if voigt <= 0.05 else "partly" if voigt <= 0.15 else "disagree",
            "agree if the median error is <= 5 %, partly if <= 15 %", result))
        out.append(Claim(
            "equivalent-modulus", f"Beyond the paper: the estimate an experimentalist should use ({loading}).",
            "this study", f"best by median error: {LABELS[result['best']]} ({percent(result['best_median_error'])}); "
                          + ", ".join(f"{LABELS[n].split(' (')[0]} median {percent(result['median'][n])}, RMS "
                                      f"{percent(result['rms'][n])}, closest in {result['wins'][n]}"
                                      for n in ESTIMATES)
                          + "; closest per cell: " + ", ".join(f"{c}: {LABELS[n].split(' (')[0]}"
                                                               for c, n in result["closest_by_cell"].items()),
            "agree" if result["best"] == "voigt" else "partly" if voigt <= 0.05 else "disagree",
            "agree if Voigt (the paper's choice) has the smallest median error; partly if another does but Voigt "
            "is within 5 %", result))
    return out


STUDY = Study("equivalent-modulus", "Which equivalent modulus holds", "beyond the paper",
              "Best-fit homogeneous modulus of every heterogeneous cell of the compression (stiffness and size "
              "series, random cell) and shear-flow studies, beside the Voigt (paper), Reuss, Hashin-Shtrikman and "
              "self-consistent estimates.", members, table, plot, claims)
