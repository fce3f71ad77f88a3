"""``elastocell.pipe``, the API behind ``elastocell pipe``: writes ``timeseries.csv``, ``summary.json``, a plot
and VTK files to a directory, and resumes from its checkpoint. By default a run at R/dx above 6 is two runs, at
R/dx 6 and at the resolution, whose stationary values are Richardson-extrapolated
(``elastocell.simulation.extrapolation``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from elastocell.body.cell import Cell, enable_compilation_cache
from elastocell.files import Stopwatch, write_json
from elastocell.parameters.cell import describe_cell
from elastocell.parameters.flow import flow_cell
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.pipe import STATIONARY_OBSERVABLES, PipeFlowParameters, PipeRun, plot_pipe
from elastocell.simulation.directory import interruptible, output_directory
from elastocell.simulation.extrapolation import coarse_resolution_of, run_extrapolated
from elastocell.simulation.output import directory_summary, run_in_directory, warn_if_not_stationary
from elastocell.simulation.runner import StopCriteria, check_run_cost

EXTRAPOLATED = ("strain_axial_mean", "strain_radial_mean", "strain_transverse_mean", "deformation_mean",
                "projected_area_mean", "axial_velocity_mean")
"""The stationary shape and velocity an extrapolated run reports extrapolated (the others, the radial migration
among them, are the finer run's)."""


def pipe(
    out: str | Path,
    capillary_number_wall: float,
    cell=None,
    equivalent: bool = False,
    channel_radius_ratio: float | None = None,
    start_offset: float | None = None,
    resolution: float | None = None,
    channel_shape: str | None = None,
    channel_aspect_ratio: float | None = None,
    medium: str | None = None,
    temperature: float | None = None,
    flow_index: float | None = None,
    duration: float = 10.0,
    resume: bool = False,
    progress: bool = True,
    wall_clock: float | None = None,
    stationary_tolerance: float | None = None,
    stationary_observable: str = "strain_axial",
    record_interval: float = 0.1,
    checkpoint_every: int = 20,
    vtk_interval: float | None = 1.0,
    flow_options: dict | None = None,
    capillary_number_modulus: str = "reference",
    extrapolate: bool = True,
    coarse_resolution: float | None = None,
    **cell_options,
) -> dict:
    """A cell in a capillary; writes ``out/timeseries.csv``, ``summary.json``, ``pipe.png``, ``vtk/`` and
    ``checkpoint.npz``; returns the summary.

    capillary_number_wall: Ca_w = G R_ch/(2 mu_c) (mu_eff with ``equivalent``). cell: CellParameters or the
    CELL OPTIONS of ``cell_parameters`` (default mesh: uniform p1 with edges of 2 dx, as shear flow).
    channel_shape: "cylinder" (default), "square" or "rectangle" (width 2 R_ch, height channel_aspect_ratio times
    the width). medium: "newtonian" (default), "0.49%MC-PBS", "0.59%MC-PBS", "0.83%MC-PBS" (at ``temperature``
    degC) or "power-law" (with ``flow_index``); see :class:`PipeFlowParameters`.
    duration: units of 1/gdot_w. resume: continue from ``out/checkpoint.npz`` if it exists.
    stationary_tolerance: stop once the running mean of ``stationary_observable`` ("strain_axial" or
    "deformation") over the last unit of time changes by less than this fraction of it (see
    :class:`~elastocell.simulation.runner.StopCriteria`). flow_options: further :class:`PipeFlowParameters`.
    capillary_number_modulus: "reference" (Ca_w against the simulated cell's mu: mu_eff with ``equivalent``)
    or "mu_c" (against the described cell's mu_c; with ``equivalent`` the run uses Ca_w / gamma_eff, i.e. the
    same pressure gradient G as the heterogeneous cell, as the paper compares them).
    extrapolate, coarse_resolution: run R/dx ``coarse_resolution`` (default 6, only when the resolution is above
    it) too, in ``out/resolution-<R/dx>/`` beside ``out/resolution-<resolution>/`` (each resumable, each with
    its own time series, checkpoint and VTK files), and report the stationary strains, deformation, projected
    area and axial velocity (:data:`EXTRAPOLATED`) extrapolated to dx -> 0 with order 2
    (``summary["extrapolation"]``; the top-level time series and plot are the finer run's). Without cell= the
    mesh (edges 2 dx) follows each resolution.
    """

    if stationary_tolerance is None and stationary_observable != "strain_axial":
        raise ParameterError("stationary_observable", "is read only by the stationarity stop; give "
                                                      "--stationary-tolerance (stationary_tolerance=) with it")
    flow_options = dict(flow_options or {})
    for name, value in (("channel_radius_ratio", channel_radius_ratio), ("start_offset", start_offset),
                        ("resolution", resolution), ("channel_shape", channel_shape),
                        ("channel_aspect_ratio", channel_aspect_ratio), ("medium", medium),
                        ("temperature", temperature), ("flow_index", flow_index)):
        if value is not None:
            flow_options[name] = value
    params = PipeFlowParameters(capillary_number_wall=capillary_number_wall, **flow_options)
    coarse = coarse_resolution_of(extrapolate, params.resolution, coarse_resolution)
    arguments = (capillary_number_wall, cell, equivalent, duration, resume, progress, wall_clock, stationary_tolerance,
                 stationary_observable, record_interval, checkpoint_every, vtk_interval, capillary_number_modulus,
                 cell_options)
    if coarse is None:
        return _single(out, params, *arguments)[0]

    def run_part(directory, r, label, wall_clock_left):
        part_arguments = list(arguments)
        part_arguments[6] = wall_clock_left  # the whole call's wall clock, less what the finer run used
        return _single(directory, PipeFlowParameters(**{**params.model_dump(), "resolution": r}), *part_arguments,
                       part=label)

    summary, fine, series = run_extrapolated(out, params.resolution, coarse, run_part, EXTRAPOLATED,
                                             wall_clock=wall_clock)
    if summary["extrapolation"].get("pending"):
        return summary
    plot_pipe(Path(out) / "pipe.png", series, fine,
              title=f"{summary['label']}, {params.channel_shape} channel, {params.medium}, Ca_w = "
                    f"{summary['capillary_number_wall']:g}, R/dx = {params.resolution:g}; extrapolated "
                    f"D = {summary['deformation_mean']:.4g}")
    return summary


def _single(out, params, capillary_number_wall, cell, equivalent, duration, resume, progress, wall_clock,
            stationary_tolerance, stationary_observable, record_interval, checkpoint_every, vtk_interval,
            capillary_number_modulus, cell_options, part: str = "") -> tuple[dict, dict]:
    """One run at ``params.resolution`` in ``out`` (:func:`pipe`'s arguments; ``part`` labels its progress):
    (its summary, its time series)."""
    if stationary_observable not in STATIONARY_OBSERVABLES:
        raise ParameterError("stationary_observable", f"must be one of {', '.join(STATIONARY_OBSERVABLES)}, "
                             f"got {stationary_observable!r}")
    stop = StopCriteria(duration=duration, wall_clock=wall_clock, stationary_tolerance=stationary_tolerance,
                        stationary_observable=stationary_observable, unit=PipeRun.TIME_UNIT)
    if vtk_interval is not None and not vtk_interval > 0:
        raise ParameterError("vtk_interval", f"must be > 0 (units of 1/gdot_w), got {vtk_interval}")
    cell = flow_cell(cell, cell_options, params.resolution)
    clock = Stopwatch()
    if not (isinstance(checkpoint_every, int) and checkpoint_every >= 1):
        raise ParameterError("checkpoint_every", f"must be a whole number >= 1 (records), got {checkpoint_every}")
    if capillary_number_modulus not in ("reference", "mu_c"):
        raise ParameterError("capillary_number_modulus", f"must be 'reference' or 'mu_c', got {capillary_number_modulus!r}")
    enable_compilation_cache()
    body = Cell.from_parameters(cell)
    capillary_number_mu_c = capillary_number_wall
    if equivalent:
        body = body.equivalent()
        if capillary_number_modulus == "mu_c":  # same G: Ca_w,eff = G R_ch / (2 mu_eff)
            capillary_number_wall = capillary_number_wall / body.effective_stiffness_ratio
            params = PipeFlowParameters(**{**params.model_dump(), "capillary_number_wall": capillary_number_wall})
        else:
            capillary_number_mu_c = capillary_number_wall * body.effective_stiffness_ratio
    run = PipeRun(body, params, record_interval=record_interval)
    check_run_cost(stop.duration * run.units.steps_per_time * float(np.prod(run.units.shape)))
    with output_directory(out) as out, interruptible():
        resumed, vtk = run_in_directory(run, out, stop, resume=resume, progress=progress,
                                        description=f"pipe Ca_w={capillary_number_wall:g}{part}",
                                        checkpoint_every=checkpoint_every, vtk_interval=vtk_interval)
        label = "homogeneous equivalent" if equivalent else describe_cell(cell)
        summary = {"scenario": "pipe", "label": label}
        summary.update(run.summary())
        summary["capillary_number_wall_mu_c"] = capillary_number_mu_c
        summary.update(directory_summary(run, body, cell, params, clock, resumed, equivalent))
        write_json(out / "summary.json", summary)
        warn_if_not_stationary(summary, out)
        plot_pipe(out / "pipe.png", run.arrays(), summary,
                  title=f"{label}, {params.channel_shape} channel, {params.medium}, Ca_w = {capillary_number_wall:g}, "
                        f"R_ch/R = {params.channel_radius_ratio:g}, "
                        f"r0/R_ch = {params.start_offset:g}, R/dx = {params.resolution:g}")
        if vtk is not None:
            vtk.close(run)
    return summary, run.arrays()
