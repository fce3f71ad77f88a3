"""``elastocell.pipe``, the API behind ``elastocell pipe``: writes ``timeseries.csv``, ``summary.json``, a plot
and VTK files to a directory, and resumes from its checkpoint. The markers sit at R - 0.3 dx
(:data:`~elastocell.scenarios.pipe.PIPE_HYDRODYNAMIC_RADIUS_CORRECTION`, which says why). In a cylinder with the
cell on its axis a run is by default two runs, at R/dx 6 and at the resolution (8), whose stationary values are
Richardson-extrapolated (``elastocell.simulation.extrapolation``), the RT-DC reading taken from six side views; in a
duct, or off the axis, one run at the resolution (:func:`extrapolated_by_default` says why).

A finite channel (``channel_length``, RT-DC's measurement region near the outlet): the cell starts undeformed on its
path at the inlet and the run ends when the distance it has travelled, its own axial speed integrated over time
(the ``axial_position`` of its volume centroid; the periodic lattice makes the channel's length no part of the
geometry), reaches the length L: :class:`TransitStop`. The summary's ``state`` says which state a run reports:
"stationary" (the stationarity stop), "transit L um" (the end of the channel) or "cap" (the duration or wall clock
ran out first).
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from elastocell.body.cell import Cell, enable_compilation_cache
from elastocell.files import Stopwatch, write_json
from elastocell.parameters.cell import describe_cell
from elastocell.parameters.flow import flow_cell
from elastocell.parameters.units import ParameterError, parse_quantity, parse_temperature
from elastocell.scenarios.pipe import STATIONARY_OBSERVABLES, PipeFlowParameters, PipeRun, plot_pipe
from elastocell.simulation.directory import interruptible, output_directory
from elastocell.simulation.extrapolation import (
    part_directory,
    requested_coarse_resolution,
    run_extrapolated,
)
from elastocell.simulation.output import directory_summary, run_in_directory, warn_if_not_stationary
from elastocell.simulation.runner import StopCriteria, check_record_interval, check_run_cost

EXTRAPOLATED = ("strain_axial_mean", "strain_radial_mean", "strain_transverse_mean", "deformation_mean",
                "projected_area_mean", "deformation_views_mean", "projected_area_views_mean", "axial_velocity_mean")
"""The stationary shape and velocity an extrapolated run reports extrapolated (the others, the radial migration
among them, are the finer run's)."""

TRANSIT_COLUMNS = ("deformation", "projected_area", "strain_axial", "strain_radial", "strain_transverse",
                   "axial_velocity", "radial_position", "volume_change", "deformation_views", "projected_area_views")
"""The observables a transit run reports at the end of the channel (``summary["transit"]``; NaN for a column a
series written before it existed lacks)."""


OUTLINE_EXTRAPOLATED = ("deformation_mean", "projected_area_mean", "deformation_views_mean",
                        "projected_area_views_mean")
"""The side-view readings among :data:`EXTRAPOLATED`: an extrapolation whose runs read records of their averaging
windows on the nodes' hull reports these, or those of them the hull reached, as the finer run's
(:func:`outline_guarded`)."""


def extrapolated_by_default(params: PipeFlowParameters) -> bool:
    """Whether ``pipe`` extrapolates when ``extrapolate`` is not given: in a cylinder with the cell started on the
    axis, yes (R/dx 8 and 6, Richardson, read from the six side views); in a square or rectangular duct, or for a
    cell started off the axis, no (one run).

    Measured (docs/validation/pipe_dclab.md, section "pipe_orientation.py"; LE-2D-FEM-19's cylinder, the
    stationary shape at t = 40/gdot_w): the six-view D of two cells at R/R_ch 0.55 and 0.70 converges at order
    1.85 and 4.5 over R/dx 6, 8, 10, its 8/6 extrapolation lies within 10 % of the table in D and area at 6 of 6
    pairs (one run at R/dx 8: +14 to +24 % in D), at 1.39x the single run's CPU time (docs/validation/
    flow_default.md, section "pipe_default_cost.py", which also reads the command's default duration). In the square duct R/dx 8
    alone is within 2 % in E of R/dx 10 at both points checked, while R/dx 6 is not in the asymptotic range there and
    the 8/6 extrapolation moves E 7-17 % from HE-3D-FEM-22 (docs/validation/lut_square.md, section
    "lut_square_views.py"). A run at R/dx <= 6 has no cheaper partner and runs alone either way."""
    return params.channel_shape == "cylinder" and params.start_offset == 0.0


def pipe_coarse_resolution(extrapolate: bool | None, params: PipeFlowParameters,
                           coarse_resolution: float | None) -> float | None:
    """The coarse R/dx of a pipe run, or None for one run: ``extrapolate`` None takes
    :func:`extrapolated_by_default`; a ``coarse_resolution`` given where that default is one run is refused in one
    line saying so (a ParameterError), as is one given with ``extrapolate`` False."""
    if extrapolate is None:
        if coarse_resolution is not None and not extrapolated_by_default(params):
            raise ParameterError("coarse_resolution", f"{coarse_resolution} is the cheaper run of an extrapolation, "
                                 "which is off by default in a square or rectangular duct and for a cell started "
                                 "off the axis: give --extrapolate (extrapolate=True) with it, or leave it out")
        extrapolate = extrapolated_by_default(params)
    return requested_coarse_resolution(bool(extrapolate), params.resolution, coarse_resolution)


FINER_PAIR = (10.0, 8.0)
"""(R/dx, coarse R/dx) of the pair the outline guard advises where the default pair's coarser run does not resolve
the outline (bullet-shaped cells, D about 0.05 in LE-2D-FEM-19's cylinder; :func:`outline_guarded`)."""


def outline_guarded(summary: dict, parts: dict[float, dict]) -> bool:
    """Keep an extrapolation's outline readings (:data:`OUTLINE_EXTRAPOLATED`) at the finer run's where a run's
    outline was not resolved, reading by reading:

    - all four where the coarser run read a record of its averaging window on the nodes' hull, in the view along z
      (``outline_fallback_records``) or in any side view (``outline_fallback_views_records``);
    - ``deformation_mean`` and ``projected_area_mean`` (the view along z) where the finer run's view along z did;
    - ``deformation_views_mean`` and ``projected_area_views_mean`` where the finer run read every side view of a
      record on the hull (``outline_hull_views_records``; a summary without it counts any side view): only then
      is its mean the hull's, since :func:`~elastocell.body.observables.mean_side_view` leaves the hull's views
      out where any view is fitted.

    The hull's D carries the mesh-scale roughness, not the lattice's (dx/R)^2 error, so a difference involving it
    is no discretisation error to extrapolate (measured: the R/dx 6 outline of cells of D above 0.045 falls back to
    the hull and their extrapolated D errs -92 to +69 % against LE-2D-FEM-19, section "pipe_orientation.py"); and a
    coarser run whose fit leaves the trusted band in some views is not yet in the asymptotic range (measured at D
    about 0.05, section "pipe_outline_degree.py": the pipe's six-view D at R/dx 6, 8, 10 reads 0.0580, 0.0584,
    0.0555 at 6 um / 2 kPa, no (dx/R)^2 trend from 6 to 8, while the (10, 8) pair, whose coarser run reads every
    view on the fit, lands at +5.5 % in D and -3.2 % in area from the table, and at +2.3 and -1.2 % at 6.5 um /
    2.5 kPa). The finer run's views on the hull alone do not stop its six-view extrapolation (at R/dx 10 there:
    111 of 201 records had one to five of six views on the hull, none all six; the fitted views' mean D 0.05551
    against 0.05550 for the fit read in every view).

    Changes ``summary`` in place (each kept value back to the finer run's, its correction NaN,
    ``extrapolation["outline_guard"]`` saying which and why) and returns True where it kept any."""
    extrapolation = summary["extrapolation"]
    fine = float(extrapolation["fine_resolution"])
    coarse = min(float(r) for r in parts)
    counts = {float(r): (int(part.get("outline_fallback_records") or 0),
                         int(part.get("outline_fallback_views_records") or 0),
                         part.get("outline_hull_views_records"))
              for r, part in parts.items()}  # (view along z, any side view, every side view or None) per run
    coarse_unresolved = counts[coarse][0] + counts[coarse][1] > 0
    kept = set()
    if coarse_unresolved:
        kept.update(OUTLINE_EXTRAPOLATED)
    if counts[fine][0]:
        kept.update(("deformation_mean", "projected_area_mean"))
    if counts[fine][1] if counts[fine][2] is None else counts[fine][2]:  # without the count: any side view
        kept.update(("deformation_views_mean", "projected_area_views_mean"))
    kept &= set(extrapolation["values"])
    if not kept:
        return False
    extrapolation["outline_kept"] = [name for name in OUTLINE_EXTRAPOLATED if name in kept]
    for name in extrapolation["outline_kept"]:
        value = extrapolation["values"][name]["fine"]  # the finer run's, in memory (a JSON null would be NaN)
        summary[name] = value
        summary[f"{name}_correction"] = float("nan")
        extrapolation["values"][name] = {**extrapolation["values"][name], "value": value, "correction": float("nan")}
    runs = "; ".join(f"R/dx {r:g}: {counts[float(r)][0]} (view along z), {counts[float(r)][1]} (any side view) and "
                     f"{'?' if counts[float(r)][2] is None else counts[float(r)][2]} (every side view) of "
                     f"{part.get('stationary_records', '?')} records" for r, part in sorted(parts.items()))
    why = (f"the R/dx {coarse:g} run's outline is not resolved" if coarse_unresolved
           else f"the R/dx {fine:g} run's reading used the hull")
    advice = ""
    if coarse_unresolved and coarse < FINER_PAIR[1]:  # a finer pair resolves such a cell
        advice = (f"; for a cell whose R/dx {coarse:g} outline is not resolved, the pair R/dx {FINER_PAIR[0]:g} "
                  f"and {FINER_PAIR[1]:g} (resolution={FINER_PAIR[0]:g}, coarse_resolution={FINER_PAIR[1]:g}; "
                  f"--resolution {FINER_PAIR[0]:g} --coarse-resolution {FINER_PAIR[1]:g}) read D and area within 6 % "
                  "of LE-2D-FEM-19 at the two such cells measured, at about 3 times the default pair's lattice "
                  "updates (docs/validation/pipe_dclab.md, section pipe_outline_degree.py)")
    extrapolation["outline_guard"] = (
        f"records of the averaging windows were read on the nodes' hull ({runs}): {why}, so "
        f"{', '.join(extrapolation['outline_kept'])} are the R/dx {fine:g} run's, not "
        f"extrapolated (the other values are){advice}")
    return True


def rtdc_extrapolated(summary: dict) -> bool:
    """Whether the RT-DC reading of a pipe summary (:func:`rtdc_reading`) is extrapolated: an extrapolation that
    is not pending and whose outline guard did not keep that reading's deformation at the finer run's."""
    extrapolation = summary.get("extrapolation") or {}
    if not extrapolation or extrapolation.get("pending"):
        return False
    name = "deformation_views_mean" if rtdc_reading(summary)[2] == "side views" else "deformation_mean"
    kept = extrapolation.get("outline_kept", OUTLINE_EXTRAPOLATED if extrapolation.get("outline_guard") else ())
    return name not in kept


def rtdc_reading(summary: dict) -> tuple[float, float, str]:
    """(D, projected area / R^2, which reading) of a pipe summary: the side views' mean where the whole averaging
    window has it (``deformation_views_mean``), else the view along z (``deformation_mean``)."""
    views = summary.get("deformation_views_mean")
    if views is not None and math.isfinite(views):
        return float(views), float(summary["projected_area_views_mean"]), "side views"
    return float(summary["deformation_mean"]), float(summary["projected_area_mean"]), "view along z"


@dataclass(frozen=True)
class TransitStop(StopCriteria):
    """The stop criteria plus the end of a finite channel: the run ends ("transit") at the first record whose
    travelled distance ``axial_position`` (units of R) reaches ``channel_length`` (units of R), so within one record
    interval of it."""

    channel_length: float = math.inf

    def reached(self, series: dict) -> str:
        distance = series["axial_position"]
        return "transit" if distance and distance[-1] >= self.channel_length else ""


def channel_length_of(channel_length, cell) -> float | None:
    """The channel length L in units of the cell radius R (None: the stationary state), from a quantity (a bare
    number in um) and the cell's physical radius; refuses L <= 0, L below the cell's diameter 2R and a cell
    without a physical radius, in one line."""
    if channel_length is None:
        return None
    length, _ = parse_quantity(channel_length, "m", "channel_length")
    if not length > 0:
        raise ParameterError("channel_length", f"must be > 0, got {channel_length}")
    if not cell.radius_is_physical:
        raise ParameterError("channel_length", "needs a physical --radius (e.g. 8um) to set L/R")
    if length < 2.0 * cell.radius:
        raise ParameterError("channel_length", f"L = {length * 1e6:g} um is shorter than the cell's diameter "
                             f"2R = {2e6 * cell.radius:g} um: the cell would not fit in the channel")
    return length / cell.radius


def run_state(stop_reason: str, channel_length_um: float | None) -> str:
    """"stationary", "transit L um", "hull" (its outline read on the nodes' hull: ``hull_stop``) or "cap": which
    state a run's values describe."""
    if stop_reason in ("stationary", "hull"):
        return stop_reason
    if stop_reason == "transit":
        return f"transit {channel_length_um:g} um"
    return "cap"


def transit_values(series: dict, channel_length: float) -> dict:
    """The observables :data:`TRANSIT_COLUMNS` and the time at the travelled distance ``channel_length`` (units of R),
    interpolated linearly between the two records around it (the last record's if the run ended short of it)."""
    distance = np.asarray(series["axial_position"], dtype=float)
    after = np.nonzero(distance >= channel_length)[0]
    names = [name for name in ("time",) + TRANSIT_COLUMNS if name in series]
    missing = {name: float("nan") for name in TRANSIT_COLUMNS if name not in series}
    if after.size == 0 or after[0] == 0:
        return {**{name: float(series[name][-1]) for name in names}, **missing}
    i = int(after[0])
    w = (channel_length - distance[i - 1]) / (distance[i] - distance[i - 1])
    return {**{name: float((1 - w) * series[name][i - 1] + w * series[name][i]) for name in names}, **missing}


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
    channel_wall: str | None = None,
    medium: str | None = None,
    temperature: float | str | None = None,
    flow_index: float | None = None,
    hold_flow_rate: bool | None = None,
    hydrodynamic_radius_correction: float | None = None,
    volume_correction: str | None = None,
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
    extrapolate: bool | None = None,
    coarse_resolution: float | None = None,
    channel_length: float | str | None = None,
    hull_stop: bool = False,
    **cell_options,
) -> dict:
    """A cell in a capillary; writes ``out/timeseries.csv``, ``summary.json``, ``pipe.png``, ``vtk/`` and
    ``checkpoint.npz`` (an extrapolated run: ``vtk/`` and ``checkpoint.npz`` in each ``out/resolution-<R/dx>/``);
    returns the summary.

    capillary_number_wall: Ca_w = G R_ch/(2 mu_c) (mu_eff with ``equivalent``). cell: CellParameters or the
    CELL OPTIONS of ``cell_parameters`` (default mesh: uniform p1 with edges of 2 dx, as shear flow).
    channel_shape: "cylinder" (default), "square" or "rectangle" (width 2 R_ch, height channel_aspect_ratio times
    the width). channel_wall: "interpolated" (default) or "staircase", how the lattice places a cylinder's wall
    (:data:`~elastocell.scenarios.pipe.CHANNEL_WALLS`). medium: "newtonian" (default), "0.49%MC-PBS", "0.59%MC-PBS", "0.83%MC-PBS" (at ``temperature``:
    "23degC", "23°C", "296.15K" or a bare number in degC) or "power-law" (with ``flow_index``); see :class:`PipeFlowParameters`.
    hold_flow_rate: hold the flow rate the nominal G drives through the ideal channel (default True, as RT-DC's
    pump) or, False, hold G. hydrodynamic_radius_correction: the markers at R - c dx (default 0.3). Both as
    :class:`PipeFlowParameters` (``elastocell pipe --hold-flow-rate/--no-hold-flow-rate``,
    ``--hydrodynamic-radius-correction``). volume_correction: "none" (default) or "projection", the cell's volume
    held by projecting the surface markers after every step (:class:`PipeFlowParameters`; ``--volume-correction``).
    duration: units of 1/gdot_w. resume: continue from ``out/checkpoint.npz`` (each part's) if it exists; a
    directory holding one run (a checkpoint, no ``resolution-*``) resumed with ``extrapolate`` None continues as
    that one run, with a warning.
    stationary_tolerance: stop once the running mean of ``stationary_observable`` ("strain_axial" or
    "deformation") over the last unit of time changes by less than this fraction of it (see
    :class:`~elastocell.simulation.runner.StopCriteria`). flow_options: further :class:`PipeFlowParameters`.
    capillary_number_modulus: "reference" (Ca_w against the simulated cell's mu: mu_eff with ``equivalent``)
    or "mu_c" (against the described cell's mu_c; with ``equivalent`` the run uses Ca_w / gamma_eff, i.e. the
    same nominal pressure gradient G as the heterogeneous cell, as the paper compares them; with
    ``hold_flow_rate`` each run holds the flow rate that G drives through the ideal channel).
    extrapolate, coarse_resolution: (default None: on in a cylinder with the cell on the axis, off otherwise,
    :func:`extrapolated_by_default`) run R/dx ``coarse_resolution`` (default 6, only when the
    resolution is above it) too, in ``out/resolution-<R/dx>/`` beside ``out/resolution-<resolution>/`` (each resumable, each with
    its own time series, checkpoint and VTK files), and report the stationary strains, deformation, projected
    area and axial velocity (:data:`EXTRAPOLATED`) extrapolated to dx -> 0 with order 2
    (``summary["extrapolation"]``; the top-level time series and plot are the finer run's); where the coarser run
    read averaged records on the nodes' hull, or the finer run's reading used it, the deformation and area stay the
    finer run's, with a warning (:func:`outline_guarded`, which says which readings). In a cylinder ``deformation_views_mean`` and ``projected_area_views_mean`` are the
    RT-DC reading (the six side views, extrapolated). Without cell= the
    mesh (edges 2 dx) follows each resolution.
    channel_length: a finite channel of length L (a quantity such as "300um"; a bare number in um; needs a physical
    radius): the run ends when the cell has travelled L (:class:`TransitStop`; ``duration`` is then the cap), and
    ``summary["transit"]`` holds its shape at L (with ``extrapolate``: the finer run's, each run's in its own
    directory); ``summary["state"]`` is "transit L um", or "cap" if the duration ran out first. None: the stationary state.
    hull_stop: end a run ("hull", state "hull") once its ``stationary_observable`` has been read on the nodes' hull
    for a whole unit of time (:class:`~elastocell.simulation.runner.StopCriteria`): ``lut``'s points, which a table
    then leaves out.
    """

    if stationary_tolerance is None and stationary_observable != "strain_axial":
        raise ParameterError("stationary_observable", "is read only by the stationarity stop; give "
                                                      "--stationary-tolerance (stationary_tolerance=) with it")
    flow_options = dict(flow_options or {})
    for name, value in (("channel_radius_ratio", channel_radius_ratio), ("start_offset", start_offset),
                        ("resolution", resolution), ("channel_shape", channel_shape),
                        ("channel_aspect_ratio", channel_aspect_ratio), ("channel_wall", channel_wall),
                        ("medium", medium),
                        ("temperature", parse_temperature(temperature)), ("flow_index", flow_index),
                        ("hold_flow_rate", hold_flow_rate),
                        ("hydrodynamic_radius_correction", hydrodynamic_radius_correction),
                        ("volume_correction", volume_correction)):
        if value is not None:
            if (name in ("hold_flow_rate", "hydrodynamic_radius_correction", "volume_correction")
                    and flow_options.get(name, value) != value):
                raise ParameterError(name, f"given twice, {value!r} and flow_options {flow_options[name]!r}")
            flow_options[name] = value
    params = PipeFlowParameters(capillary_number_wall=capillary_number_wall, **flow_options)
    if extrapolate is None and resume and (Path(out) / "checkpoint.npz").exists() \
            and not any(Path(out).glob("resolution-*")):
        warnings.warn(f"{out} holds one run at one resolution (its checkpoint.npz): resuming it as that one run, "
                      "not extrapolated; give extrapolate=True (--extrapolate) and another directory for the pair",
                      stacklevel=2)
        extrapolate = False
    coarse = pipe_coarse_resolution(extrapolate, params, coarse_resolution)
    length = channel_length_of(channel_length, flow_cell(cell, cell_options, params.resolution))
    arguments = (capillary_number_wall, cell, equivalent, duration, resume, progress, wall_clock, stationary_tolerance,
                 stationary_observable, record_interval, checkpoint_every, vtk_interval, capillary_number_modulus,
                 cell_options, length, hull_stop)
    if coarse is None:
        return _single(out, params, *arguments)[0]

    def run_part(directory, r, label, wall_clock_left):
        part_arguments = list(arguments)
        part_arguments[6] = wall_clock_left  # the whole call's wall clock, less what the finer run used
        return _single(directory, PipeFlowParameters(**{**dict(params), "resolution": r}), *part_arguments,
                       part=label)

    summary, fine, series = run_extrapolated(out, params.resolution, coarse, run_part, EXTRAPOLATED,
                                             wall_clock=wall_clock)
    if summary["extrapolation"].get("pending"):
        return summary
    parts = {params.resolution: fine,  # the finer run's summary in memory, the coarser one's from its directory
             coarse: json.loads((part_directory(out, coarse) / "summary.json").read_text())}
    if outline_guarded(summary, parts):
        write_json(Path(out) / "summary.json", summary)
        warnings.warn(f"{Path(out) / 'summary.json'}: {summary['extrapolation']['outline_guard']}", stacklevel=2)
    plot_pipe(Path(out) / "pipe.png", series, fine,
              title=f"{summary['label']}, {params.channel_shape} channel, {params.medium}, Ca_w = "
                    f"{summary['capillary_number_wall']:g}, R/dx = {params.resolution:g}; "
                    + ("extrapolated D" if rtdc_extrapolated(summary) else "D (the finer run's: outline on the hull)")
                    + f" = {rtdc_reading(summary)[0]:.4g}")
    return summary


def _single(out, params, capillary_number_wall, cell, equivalent, duration, resume, progress, wall_clock,
            stationary_tolerance, stationary_observable, record_interval, checkpoint_every, vtk_interval,
            capillary_number_modulus, cell_options, channel_length=None, hull_stop: bool = False,
            part: str = "") -> tuple[dict, dict]:
    """One run at ``params.resolution`` in ``out`` (:func:`pipe`'s arguments, ``channel_length`` in units of R;
    ``part`` labels its progress): (its summary, its time series)."""
    if stationary_observable not in STATIONARY_OBSERVABLES:
        raise ParameterError("stationary_observable", f"must be one of {', '.join(STATIONARY_OBSERVABLES)}, "
                             f"got {stationary_observable!r}")
    stop = StopCriteria(duration=duration, wall_clock=wall_clock, stationary_tolerance=stationary_tolerance,
                        stationary_observable=stationary_observable, unit=PipeRun.TIME_UNIT, hull_stop=hull_stop)
    check_record_interval(duration, PipeRun.DEFAULT_RECORD_INTERVAL if record_interval is None else record_interval,
                          PipeRun.TIME_UNIT)
    if channel_length is not None:
        stop = TransitStop(**{**stop.__dict__, "channel_length": channel_length})
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
            params = PipeFlowParameters(**{**dict(params), "capillary_number_wall": capillary_number_wall})
        else:
            capillary_number_mu_c = capillary_number_wall * body.effective_stiffness_ratio
    run = PipeRun(body, params, record_interval=record_interval)
    check_run_cost(stop.duration * run.units.steps_per_time * float(np.prod(run.units.shape)))
    if channel_length is not None:  # not even the centre-line speed carries the cell through within the duration
        reach = duration * run.units.centre_speed / run.units.wall_shear_rate / run.units.radius  # units of R
        if reach < channel_length:
            raise ParameterError("duration", f"{duration:g}/gdot_w is too short for the channel length L = "
                                 f"{channel_length:.4g} R: even the centre-line speed covers only {reach:.4g} R; "
                                 f"give at least {duration * channel_length / reach:.3g}")
    with output_directory(out) as out, interruptible():
        resumed, vtk = run_in_directory(run, out, stop, resume=resume, progress=progress,
                                        description=f"pipe Ca_w={capillary_number_wall:g}{part}",
                                        checkpoint_every=checkpoint_every, vtk_interval=vtk_interval)
        label = "homogeneous equivalent" if equivalent else describe_cell(cell)
        summary = {"scenario": "pipe", "label": label}
        summary.update(run.summary())
        summary["capillary_number_wall_mu_c"] = capillary_number_mu_c
        if channel_length is not None:
            length_um = channel_length * body.parameters.radius * 1e6
            summary["channel_length_um"] = length_um
            summary["channel_length_r"] = channel_length
            summary["transit"] = transit_values(run.arrays(), channel_length)
        summary["state"] = run_state(run.stop_reason, length_um if channel_length is not None else None)
        summary.update(directory_summary(run, body, cell, params, clock, resumed, equivalent))
        write_json(out / "summary.json", summary)
        if summary.get("outline_fallback_records"):
            warnings.warn(f"{out / 'summary.json'}: the side view of {summary['outline_fallback_records']} of the "
                          f"{summary['stationary_records']} averaged records is the hull of the nodes, not the smooth "
                          "outline (its fit left the trusted band; first at time "
                          f"{summary['outline_fallback_first_time']:.3g}): deform there is biased high by the "
                          "mesh-scale roughness (column outline_fallback of timeseries.csv)", stacklevel=2)
        if channel_length is None:
            warn_if_not_stationary(summary, out)
        elif summary["state"] == "cap":
            warnings.warn(f"{out / 'summary.json'}: the cell travelled {run.series['axial_position'][-1]:.4g} R of "
                          f"the channel's {channel_length:.4g} R before the run stopped ({run.stop_reason}): its values "
                          "are not those at the end of the channel; run longer (duration)", stacklevel=2)
        plot_pipe(out / "pipe.png", run.arrays(), summary,
                  title=f"{label}, {params.channel_shape} channel, {params.medium}, Ca_w = {capillary_number_wall:g}, "
                        f"R_ch/R = {params.channel_radius_ratio:g}, "
                        f"r0/R_ch = {params.start_offset:g}, R/dx = {params.resolution:g}")
        if vtk is not None:
            vtk.close(run)
    return summary, run.arrays()
