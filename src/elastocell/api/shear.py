"""``elastocell.shear``, the API behind ``elastocell shear``: writes ``timeseries.csv``, ``summary.json``,
``taylor_deformation.png`` and VTK files (cell snapshots and the mid-plane fluid velocity) to a directory,
and resumes from its checkpoint. By default a run at R/dx above 6 is two runs, at R/dx 6 and at the resolution,
whose stationary values are Richardson-extrapolated (``elastocell.simulation.extrapolation``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from elastocell.body.cell import Cell, enable_compilation_cache
from elastocell.files import Stopwatch, write_json
from elastocell.parameters.cell import describe_cell
from elastocell.parameters.flow import flow_cell
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.shear import (
    ShearFlowParameters,
    ShearRun,
    plot_taylor_deformation,
)
from elastocell.simulation.directory import interruptible, output_directory
from elastocell.simulation.extrapolation import (
    requested_coarse_resolution,
    run_extrapolated,
)
from elastocell.simulation.output import directory_summary, run_in_directory, warn_if_not_stationary
from elastocell.simulation.runner import StopCriteria, check_record_interval, check_run_cost

EXTRAPOLATED = ("taylor_deformation_mean", "inclination_deg_mean", "tank_treading_frequency")
"""The stationary values an extrapolated run reports extrapolated (the others are the finer run's)."""


# =========================================================================== API
def shear(
    out: str | Path,
    capillary_number: float,
    cell=None,
    equivalent: bool = False,
    resolution: float | None = None,
    duration: float = 6.0,
    resume: bool = False,
    progress: bool = True,
    wall_clock: float | None = None,
    stationary_tolerance: float | None = None,
    record_interval: float = 0.05,
    checkpoint_every: int = 20,
    vtk_interval: float | None = 1.0,
    flow_options: dict | None = None,
    capillary_number_modulus: str = "reference",
    extrapolate: bool = True,
    coarse_resolution: float | None = None,
    **cell_options,
) -> dict:
    """A cell in plane Couette flow; writes ``out/timeseries.csv``, ``summary.json``,
    ``taylor_deformation.png``, ``vtk/`` and ``checkpoint.npz``; returns the summary.

    capillary_number: Ca = eta shear_rate / mu_c (mu_eff = gamma_eff mu_c with ``equivalent``).
    cell: :class:`~elastocell.parameters.cell.CellParameters` or the CELL OPTIONS of ``cell_parameters``; without
    an explicit mesh size the mesh is uniform with edges of 2 dx (``elastocell.parameters.flow.shear_mesh_size``) and linear
    tetrahedra (``element="p1"``) unless another element is given.
    capillary_number_modulus: "reference" (Ca against the simulated cell's mu: mu_eff with ``equivalent``) or
    "mu_c" (Ca against the described cell's mu_c, as physical eta, shear rate and E_c give it; with
    ``equivalent`` the run then uses Ca_eff = Ca / gamma_eff, the same physical shear rate).
    resolution: R/dx (default 8). duration: strain shear_rate * t. resume: continue from
    ``out/checkpoint.npz`` (same options) if it exists. flow_options: further :class:`ShearFlowParameters`.
    extrapolate, coarse_resolution: run R/dx ``coarse_resolution`` (default 6, only when the resolution is above
    it) too, in ``out/resolution-<R/dx>/`` beside ``out/resolution-<resolution>/`` (each resumable, each with
    its own time series, checkpoint and VTK files), and report D, the inclination and the tank-treading
    frequency extrapolated to dx -> 0 with order 2 (``summary["extrapolation"]``; the top-level time series and
    plot are the finer run's). Without cell= the mesh (edges 2 dx) follows each resolution.
    """

    flow_options = dict(flow_options or {})
    if resolution is not None:
        flow_options["resolution"] = resolution
    params = ShearFlowParameters(capillary_number=capillary_number, **flow_options)
    coarse = requested_coarse_resolution(extrapolate, params.resolution, coarse_resolution)
    if coarse is None:
        return _single(out, capillary_number, cell, equivalent, params, duration, resume, progress, wall_clock,
                       stationary_tolerance, record_interval, checkpoint_every, vtk_interval,
                       capillary_number_modulus, cell_options)[0]

    def run_part(directory, r, label, wall_clock_left):
        return _single(directory, capillary_number, cell, equivalent,
                       ShearFlowParameters(**{**params.model_dump(), "resolution": r}), duration, resume, progress,
                       wall_clock_left, stationary_tolerance, record_interval, checkpoint_every, vtk_interval,
                       capillary_number_modulus, cell_options, label)

    summary, fine, series = run_extrapolated(out, params.resolution, coarse, run_part, EXTRAPOLATED,
                                             wall_clock=wall_clock)
    if summary["extrapolation"].get("pending"):
        return summary
    plot_taylor_deformation(Path(out) / "taylor_deformation.png", series, fine,
                            title=f"{summary['label']}, Ca = {summary['capillary_number']:g}, R/dx = "
                                  f"{params.resolution:g}; extrapolated D = {summary['taylor_deformation_mean']:.4g}")
    return summary


def _single(out, capillary_number, cell, equivalent, params, duration, resume, progress, wall_clock,
            stationary_tolerance, record_interval, checkpoint_every, vtk_interval, capillary_number_modulus,
            cell_options, part: str = "") -> tuple[dict, dict]:
    """One run at ``params.resolution`` in ``out`` (:func:`shear`'s arguments; ``part`` labels its progress):
    (its summary, its time series)."""
    stop = StopCriteria(duration=duration, wall_clock=wall_clock, stationary_tolerance=stationary_tolerance)
    check_record_interval(duration, ShearRun.DEFAULT_RECORD_INTERVAL if record_interval is None else record_interval,
                          ShearRun.TIME_UNIT)
    if vtk_interval is not None and not vtk_interval > 0:
        raise ParameterError("vtk_interval", f"must be > 0 (strain), got {vtk_interval}")
    if capillary_number_modulus not in ("reference", "mu_c"):
        raise ParameterError("capillary_number_modulus", f"must be 'reference' or 'mu_c', got {capillary_number_modulus!r}")
    cell = flow_cell(cell, cell_options, params.resolution)
    clock = Stopwatch()
    if not (isinstance(checkpoint_every, int) and checkpoint_every >= 1):
        raise ParameterError("checkpoint_every", f"must be a whole number >= 1 (records), got {checkpoint_every}")
    enable_compilation_cache()
    body = Cell.from_parameters(cell)
    capillary_number_mu_c = capillary_number if capillary_number_modulus == "mu_c" else None
    if equivalent:
        body = body.equivalent()
        if capillary_number_modulus == "mu_c":  # same physical shear rate: Ca_eff = eta shear_rate / mu_eff
            capillary_number = capillary_number / body.effective_stiffness_ratio
            params = ShearFlowParameters(**{**params.model_dump(), "capillary_number": capillary_number})
    run = ShearRun(body, params, record_interval=record_interval)
    check_run_cost(stop.duration * run.units.steps_per_strain * float(np.prod(run.units.shape)))
    with output_directory(out) as out, interruptible():
        resumed, vtk = run_in_directory(run, out, stop, resume=resume, progress=progress,
                                        description=f"shear Ca={capillary_number:g}{part}", checkpoint_every=checkpoint_every,
                                        vtk_interval=vtk_interval)
        label = "homogeneous equivalent" if equivalent else describe_cell(cell)
        summary = {"scenario": "shear", "label": label}
        summary.update(run.summary())
        summary["capillary_number_mu_c"] = capillary_number_mu_c if capillary_number_mu_c is not None else (
            capillary_number * body.effective_stiffness_ratio if equivalent else capillary_number)
        summary.update(directory_summary(run, body, cell, params, clock, resumed, equivalent))
        write_json(out / "summary.json", summary)
        warn_if_not_stationary(summary, out)
        plot_taylor_deformation(out / "taylor_deformation.png", run.arrays(), summary,
                                title=f"{label}, Ca = {capillary_number:g}, R/dx = {params.resolution:g}")
        if vtk is not None:
            vtk.close(run)
    return summary, run.arrays()
