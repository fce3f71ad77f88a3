"""Richardson extrapolation of a flow run's stationary values from two lattice resolutions.

The discretisation error of the lattice-Boltzmann + immersed-boundary flows falls like (dx/R)^2 (the cell's
D/Ca in shear flow at Ca = 0.05: docs/validation/flow_accuracy.md), so a value X_h computed at spacing h and
X_H at the coarser spacing H = ratio * h combine to the h -> 0 estimate

    X = X_h + (X_h - X_H) / (ratio**order - 1),   order = CONVERGENCE_ORDER = 2.

The size of the correction, ``|X - X_h|``, is the uncertainty estimate reported with it: the distance of the
finer run from the extrapolation. It is an estimate, not a bound: it assumes the order-2 convergence holds for
the value at hand (two resolutions cannot check the order).

The flow runners (``elastocell.shear``, ``elastocell.pipe``) use it by default: :func:`coarse_resolution_of`
decides whether a run is extrapolated, :func:`run_extrapolated` makes both runs and merges their summaries.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from elastocell.files import Stopwatch, write_json, write_table
from elastocell.parameters.units import ParameterError
from elastocell.simulation.directory import output_directory

CONVERGENCE_ORDER = 2.0  # D/Ca - 5/4 ~ (dx/R)^2, docs/validation/flow_accuracy.md
DEFAULT_COARSE_RESOLUTION = 6.0  # R/dx of the cheaper run (its cost beside R/dx 8: docs/validation/flow_default.md)


def richardson(fine, coarse, ratio: float, order: float = CONVERGENCE_ORDER):
    """Richardson extrapolation of ``fine`` (spacing h) and ``coarse`` (spacing ratio * h) to h -> 0."""
    fine, coarse = np.asarray(fine, float), np.asarray(coarse, float)
    return fine + (fine - coarse) / (ratio**order - 1.0)


def extrapolate_values(fine: dict, coarse: dict, fine_resolution: float, coarse_resolution: float,
                       order: float = CONVERGENCE_ORDER) -> dict:
    """Extrapolate every numeric value present in both ``fine`` and ``coarse`` (resolutions R/dx, the ratio of
    spacings is ``fine_resolution / coarse_resolution``); returns ``{name: {"value", "fine", "coarse",
    "correction"}}`` with ``correction = |value - fine|`` (the uncertainty estimate, see the module)."""
    ratio = float(fine_resolution) / float(coarse_resolution)
    out = {}
    for name, f in fine.items():
        c = coarse.get(name)
        if isinstance(f, bool) or isinstance(c, bool) or not isinstance(f, (int, float)) \
                or not isinstance(c, (int, float)):
            continue
        value = float(richardson(f, c, ratio, order))
        out[name] = {"value": value, "fine": float(f), "coarse": float(c), "correction": abs(value - float(f))}
    return out


UNCERTAINTY = ("correction = |extrapolated - fine|, the distance of the finer run from the extrapolation: an estimate "
               "assuming convergence of order 2 in dx/R (measured for the cell's deformation in shear flow), not a "
               "bound")


def coarse_resolution_of(extrapolate: bool, resolution: float, coarse_resolution: float | None) -> float | None:
    """The coarse R/dx of a flow run, or None for a single-resolution run.

    ``extrapolate`` off: None. A ``coarse_resolution`` given must be > 0 and below ``resolution`` (a
    ParameterError naming it otherwise). Not given: :data:`DEFAULT_COARSE_RESOLUTION` when ``resolution`` is
    above it; a run at R/dx <= 6 (a quick, coarse run) has no cheaper partner and runs at its one resolution."""
    if not extrapolate:
        return None
    if coarse_resolution is None:
        return DEFAULT_COARSE_RESOLUTION if resolution > DEFAULT_COARSE_RESOLUTION else None
    coarse = float(coarse_resolution)
    if not (math.isfinite(coarse) and coarse > 0):
        raise ParameterError("coarse_resolution", f"must be > 0 (R/dx), got {coarse_resolution}")
    if coarse >= resolution:
        raise ParameterError("coarse_resolution", f"must be below the resolution {resolution:g} (R/dx), got "
                                                  f"{coarse:g}; or run without extrapolation")
    return coarse


def requested_coarse_resolution(extrapolate: bool, resolution: float, coarse_resolution: float | None) -> float | None:
    """:func:`coarse_resolution_of` for what a user asked: a ``coarse_resolution`` given without ``extrapolate``
    names the cheaper run of an extrapolation that will not run, and is refused (a ParameterError naming it)."""
    if coarse_resolution is not None and not extrapolate:
        raise ParameterError("coarse_resolution", f"{coarse_resolution} is the cheaper run of the extrapolation, "
                             "which is off: give --extrapolate (extrapolate=True) with it, or leave it out")
    return coarse_resolution_of(extrapolate, resolution, coarse_resolution)


def part_directory(out, resolution: float):
    """The sub-directory of one resolution of an extrapolated run: ``out/resolution-<R/dx>``."""
    return Path(out) / f"resolution-{resolution:g}"


def lattice_ratio(fine: dict, coarse: dict, fine_resolution: float, coarse_resolution: float) -> float:
    """dx_coarse/dx_fine of two runs: from the R/dx their lattices used (``summary["lattice"]["radius"]``) where
    both summaries hold it (a duct moves R/dx so that its width is whole nodes,
    :func:`elastocell.scenarios.pipe.duct_cell_radius`), else from the resolutions asked for. The cell meshes are
    made at the resolutions asked for, so in a duct they refine by that ratio, the lattice by this one (8/6 against
    8.12/5.88 at R 5.6 um in the 20 um duct): the weight follows the lattice, whose immersed boundary sets the
    leading (dx/R)^2 error (docs/theory.md)."""
    f, c = ((summary.get("lattice") or {}).get("radius") for summary in (fine, coarse))
    if f and c:
        return float(f) / float(c)
    return float(fine_resolution) / float(coarse_resolution)


def extrapolated_summary(fine: dict, coarse: dict, names: tuple[str, ...], fine_resolution: float,
                         coarse_resolution: float, series: str, order: float = CONVERGENCE_ORDER) -> dict:
    """The summary of an extrapolated run: the fine run's summary with the values ``names`` replaced by their
    extrapolation, each beside ``<name>_rdx<R>`` of both resolutions and ``<name>_correction`` (the uncertainty
    estimate, :data:`UNCERTAINTY`); ``stationary`` when both runs are; ``wall_time_s`` and
    ``wall_time_cumulative_s`` summed over both; and ``extrapolation``: order, resolutions, the values and what
    the time series is (``series``)."""
    ratio = lattice_ratio(fine, coarse, fine_resolution, coarse_resolution)
    values = extrapolate_values({n: fine[n] for n in names if n in fine}, coarse, ratio, 1.0, order)
    out = dict(fine)
    for name, entry in values.items():
        out[name] = entry["value"]
        out[f"{name}_rdx{fine_resolution:g}"] = entry["fine"]
        out[f"{name}_rdx{coarse_resolution:g}"] = entry["coarse"]
        out[f"{name}_correction"] = entry["correction"]
    if "stationary" in fine:
        out["stationary"] = bool(fine["stationary"]) and bool(coarse.get("stationary", True))
    for name in ("wall_time_s", "wall_time_cumulative_s"):
        if name in fine and name in coarse:
            out[name] = float(fine[name]) + float(coarse[name])
    out["extrapolation"] = {
        "method": f"Richardson, order {order:g} in dx/R", "order": float(order),
        "fine_resolution": float(fine_resolution), "coarse_resolution": float(coarse_resolution),
        "ratio": ratio,  # of the lattices' own R/dx
        "directories": [part_directory("", fine_resolution).name, part_directory("", coarse_resolution).name],
        "values": values, "uncertainty": UNCERTAINTY, "timeseries": series,
        "wall_time_s": {f"rdx{fine_resolution:g}": fine.get("wall_time_s"),
                        f"rdx{coarse_resolution:g}": coarse.get("wall_time_s")},
    }
    return out


def run_extrapolated(out, fine_resolution: float, coarse_resolution: float, run_part, names: tuple[str, ...],
                     order: float = CONVERGENCE_ORDER, wall_clock: float | None = None) -> tuple[dict, dict, dict]:
    """Both runs of an extrapolated flow run and its top-level outputs: ``run_part(directory, resolution,
    label, wall_clock)`` makes (or resumes) one resolution's run in :func:`part_directory`, stopping after
    ``wall_clock`` seconds (None: no limit), and returns (its summary, its time series); the finer run first, so
    that its cost is checked before anything is computed or written. ``wall_clock`` (s) is the whole call's
    budget: the second run gets what the first left. A run stopped by it (``stop_reason`` "wall_clock") ends the
    call there, before the next run starts: the returned summary is that run's, with ``extrapolation`` saying
    which run is pending (resume continues it), and no top-level file is written. Otherwise writes
    ``out/summary.json`` (:func:`extrapolated_summary`, ``wall_time_s`` of the whole call) and
    ``out/timeseries.csv`` (the finer run's). Returns (the summary, the finer run's summary and series)."""
    clock = Stopwatch()
    parts = {}  # each run holds its own directory's lock; nothing is written before the finer run's checks
    for index, resolution in enumerate((fine_resolution, coarse_resolution)):
        left = None if wall_clock is None else max(float(wall_clock) - clock.elapsed, 1e-3)  # > 0: a run checks it
        summary, series = run_part(part_directory(out, resolution), resolution,
                                   f" R/dx={resolution:g} ({index + 1}/2)", left)
        parts[resolution] = summary, series
        if summary.get("stop_reason") == "wall_clock":
            pending = {"pending": True, "order": float(order), "fine_resolution": float(fine_resolution),
                       "coarse_resolution": float(coarse_resolution),
                       "stopped_in": part_directory("", resolution).name,
                       "note": "stopped by the wall clock before both runs finished: the values are this run's, "
                               "not extrapolated; resume to continue"}
            return {**summary, "extrapolation": pending}, summary, series
    fine, series = parts[fine_resolution]
    with output_directory(out) as out:
        summary = extrapolated_summary(fine, parts[coarse_resolution][0], names, fine_resolution, coarse_resolution,
                                       f"the finer run's (R/dx {fine_resolution:g}), not extrapolated: only the "
                                       "stationary values are", order)
        summary["wall_time_s"] = clock.elapsed
        write_json(out / "summary.json", summary)
        write_table(out / "timeseries.csv", series)
    return summary, fine, series


__all__ = ["CONVERGENCE_ORDER", "DEFAULT_COARSE_RESOLUTION", "UNCERTAINTY", "richardson", "extrapolate_values",
           "lattice_ratio", "coarse_resolution_of", "part_directory", "extrapolated_summary", "run_extrapolated"]
