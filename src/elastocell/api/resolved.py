"""The resolved parameters of an API call: what ``elastocell.compress``, ``shear`` or ``pipe`` computes for given
keyword arguments, with every default filled in, as parameter models.

    resolved_parameters("compress", {"stiffness_ratio": 20})
    # {"scenario": "compress", "cell": CellParameters(... mesh sizes of DEFAULT_MESH_SIZES, quadrature_degree=5),
    #  "compression": CompressionParameters(delta_max=0.75, steps=40, ...), "options": {"equivalent": False, ...}}

A run id (``studies.base.Run.run_id``), a LUT point key and the shear master curve's cache key hash this
(``elastocell.files.parameter_hash``), so that two calls that compute the same thing have one key whatever
options they spelled out, and a call whose defaults resolve differently has another. The cell is built as the
API builds it (``cell_parameters``, then ``compression_parameters_for`` for compression, ``flow_cell`` for the
flows); the options that only say how a run is watched or continued (:data:`NOT_COMPUTED`) are left out.
"""

from __future__ import annotations

import dataclasses
import inspect

from elastocell.api.compression import compress
from elastocell.api.pipe import extrapolated_by_default, pipe
from elastocell.api.shear import shear
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.flow import flow_cell
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.compression import CompressionParameters, compression_parameters_for
from elastocell.scenarios.pipe import PipeFlowParameters
from elastocell.scenarios.shear import ShearFlowParameters
from elastocell.simulation.extrapolation import CONVERGENCE_ORDER, coarse_resolution_of
from elastocell.simulation.runner import StopCriteria

NOT_COMPUTED = ("out", "progress", "resume", "checkpoint_every")
"""API options that do not change what a run computes: where it writes, its progress bar, whether it continues a
checkpoint, how often it writes one."""

UNSET_LEFT_OUT = ("channel_length",)
"""API options left out of the resolved parameters when None (the pipe's stationary state): a run that does not
use them resolves as one that cannot."""

FUNCTIONS = {"compress": compress, "shear": shear, "pipe": pipe}


def _bound(scenario: str, options: dict) -> dict:
    """The keyword arguments of the API function with its defaults applied; the cell options under
    ``cell_options``."""
    if scenario not in FUNCTIONS:
        raise ParameterError("scenario", f"must be one of {', '.join(FUNCTIONS)}, got {scenario!r}")
    signature = inspect.signature(FUNCTIONS[scenario])
    bound = signature.bind(**{"out": None, **options})
    bound.apply_defaults()
    arguments = dict(bound.arguments)
    for name in NOT_COMPUTED:
        arguments.pop(name, None)
    for name in UNSET_LEFT_OUT:
        if name in arguments and arguments[name] is None:
            arguments.pop(name)
    return arguments


def resolved_parameters(scenario: str, options: dict) -> dict:
    """The parameter models of ``elastocell.<scenario>(out, **options)`` ("compress", "shear" or "pipe"):
    ``cell`` (CellParameters), the scenario's model (``compression``, or ``flow`` and the fields of its
    ``StopCriteria`` as ``stop``, less the unit's name) and the remaining options with their defaults. Raises
    what the API raises for an impossible option (ParameterError, ValueError, TypeError)."""
    arguments = _bound(scenario, options)
    cell, cell_options = arguments.pop("cell"), arguments.pop("cell_options")
    if cell is not None and cell_options:
        raise ParameterError("cell", f"give either cell= or cell options, not both ({', '.join(cell_options)})")
    if scenario == "compress":
        cell = compression_parameters_for(cell or cell_parameters(**cell_options))
        compression = CompressionParameters(delta_max=arguments.pop("delta_max"), steps=arguments.pop("steps"))
        return {"scenario": scenario, "cell": cell, "compression": compression, "options": arguments}
    flow_options = dict(arguments.pop("flow_options") or {})
    names = (("resolution",) if scenario == "shear" else
             ("channel_radius_ratio", "start_offset", "resolution", "hold_flow_rate", "hydrodynamic_radius_correction",
              "channel_wall", "volume_correction"))
    for name in names:
        value = arguments.pop(name)
        if value is not None:
            flow_options[name] = value
    if scenario == "pipe" and (flow_options.get("channel_shape") or arguments.get("channel_shape")
                               or "cylinder") != "cylinder":
        flow_options["channel_wall"] = "staircase"  # a duct's plane walls are the same either way: one key, the
        #                                             one its runs had before the choice existed
    stop = {"duration": arguments.pop("duration"), "wall_clock": arguments.pop("wall_clock"),
            "stationary_tolerance": arguments.pop("stationary_tolerance")}
    if scenario == "shear":
        flow = ShearFlowParameters(capillary_number=arguments.pop("capillary_number"), **flow_options)
    else:
        flow = PipeFlowParameters(capillary_number_wall=arguments.pop("capillary_number_wall"), **flow_options)
        stop["stationary_observable"] = arguments.pop("stationary_observable")
    criteria = StopCriteria(**stop)
    stop = {field.name: getattr(criteria, field.name) for field in dataclasses.fields(criteria) if field.name != "unit"}
    hull_stop = arguments.pop("hull_stop", False)  # left out when off: the runs made before the choice existed
    stop.pop("hull_stop")
    if hull_stop:
        stop["hull_stop"] = True
    # a single-resolution run resolves without the extrapolation options (whether extrapolate was off or could not
    # apply: the same computation, one key); an extrapolated one names its coarse resolution
    extrapolate = arguments.pop("extrapolate")
    if extrapolate is None:  # the pipe's default follows its channel (the shape given beside flow_options too)
        shape = {name: arguments[name] for name in ("channel_shape", "channel_aspect_ratio")
                 if arguments.get(name) is not None}
        extrapolate = extrapolated_by_default(PipeFlowParameters(**{**dict(flow), **shape}))
    coarse = coarse_resolution_of(extrapolate, flow.resolution, arguments.pop("coarse_resolution"))
    if coarse is not None:
        arguments["extrapolation"] = {"coarse_resolution": coarse, "order": CONVERGENCE_ORDER}
    cell = flow_cell(cell, cell_options, flow.resolution)
    return {"scenario": scenario, "cell": cell, "flow": flow, "stop": stop, "options": arguments}
