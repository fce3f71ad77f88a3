"""Look-up tables (LUTs) for real-time deformability cytometry (RT-DC), in dclab's text format.

    from elastocell.inverse.lut import compute_lut
    compute_lut("lut.txt", channel_radius="10um", flow_rate="0.04uL/s", viscosity="15mPa*s", quick=True)

Every (cell radius R, Young's modulus E) grid point is one centred pipe-flow run
(:func:`elastocell.api.pipe.pipe`, ``start_offset=0``, homogeneous cell; with ``stiffness_ratio`` and
``size_ratio`` a cell with a centred nucleus, whose table reads the cytoplasm's E_c) driven to a stationary shape. The
physical flow fixes the dimensionless driving:

    Poiseuille in a cylinder:   Q = pi G R_ch^4 / (8 eta)   ->   G = 8 eta Q / (pi R_ch^4)
    shear modulus:              mu = E / (2 (1 + nu))
    wall capillary number:      Ca_w = G R_ch / (2 mu)       (= eta gdot_w / mu, gdot_w = G R_ch / (2 eta))
    confinement:                R_ch / R

and the stationary side-view contour gives the table's columns: ``area_um`` = the projected area times R^2 (um^2;
the pipe scenario's side-view outline: the smooth surface fitted through the surface nodes, or a quadratic cell's
own curved surface, projected on the x-y plane), ``deform`` = the deformation (1 - circularity of that outline), both averaged over the last unit of 1/gdot_w (:data:`FINAL_WINDOW`), ``emodulus`` = E (kPa). A run
stops once the mean deformation over that window differs from the window before by less than the tolerance.

Channel: by default a cylinder of radius R_ch. A square channel of width W stands for the cylinder of radius
R_ch = 1.094 W/2 (:data:`SQUARE_CHANNEL_RADIUS_FACTOR`), the equivalent radius of Mietke et al. 2015 (Biophys. J.
109, 2023, supplement S3) with which the axisymmetric FEM of dclab's own LE-2D-FEM-19 table was computed;
``--channel-width W`` uses it, and the metadata give ``channel_width`` = 2 R_ch/1.094, so a table made here and
LE-2D-FEM-19 describe the same channel. ``--channel-shape square`` runs the square duct itself (half-width
a = W/2 plays R_ch: R_ch/R = W/(2R)), as the RT-DC field and dclab's HE-3D-FEM-22 do.

Medium: Newtonian (``--viscosity``) or an MC-PBS preset (``--medium 0.59%MC-PBS --temperature 23``, power law
eta = K gdot^(n-1), :mod:`elastocell.parameters.medium`). For every channel and medium the driving is the one
that carries Q (:func:`channel_driving`):

    Q = q1(n) (G/K)^(1/n) a^(3 + 1/n)  ->  G        (K = eta, n = 1 for a Newtonian medium)
    tau_w = G a / 2   (the mean wall shear stress: G A = tau_w P; cylinder G R_ch/2, square G W/4)
    Ca_w = tau_w / mu,   unit of time 1/gdot_w with gdot_w = (tau_w/K)^(1/n)

with q1(n) the flow rate at G = K = a = 1: pi n/(3n+1) 2^(-1/n) for the cylinder (closed form), White's series
for the Newtonian square duct, and the finite-volume solution of the power-law duct
(:func:`elastocell.scenarios.pipe.finite_difference_duct_flow_rate`) for the shear-thinning one. These are the
dimensionless groups of the pipe scenario (its Ca_w = G R_ch/(2 mu); its power law matched to eta at gdot_w),
so (n, Ca_w, R_ch/R) fix a point. dclab rescales a table to other viscosities with ``fluid_viscosity``: for an
MC-PBS medium it is written as dclab computes it (the viscosity at the wall shear rate of Kozicki's formula,
``dclab.features.emodulus.viscosity.shear_rate_square_channel``), so a measurement in the table's own medium,
channel and flow rate is read unscaled.

File format (dclab ``dclab/features/emodulus/load.py``, ``load_mtext``; checked against dclab 0.73.4): comment
lines, the metadata as JSON between ``# BEGIN METADATA`` and ``# END METADATA`` (every line prefixed by
``# ``), then a last comment line with the tab-separated column names and units
(``area_um [um^2]``, ``deform``, ``emodulus [kPa]``), then the numbers. dclab requires ``channel_width``
(unit "um"), ``flow_rate`` ("uL/s"), ``fluid_viscosity`` ("mPa s"), and ``identifier`` for
``register_lut``; the isoelastics file (``dclab/isoelastics/__init__.py``, ``Isoelastics.load_data``) has the
same layout, one line per distinct ``emodulus`` value, and needs ``lut identifier``.

Runs: ``<stem>_runs/<key>/`` next to the output file (the pipe run's own files plus ``point.json``, written
last); a rerun reads finished points back and resumes unfinished ones from their checkpoint. The key holds a
hash of every input of the run, so changing the flow rate or the resolution makes new runs.
"""

from __future__ import annotations

import json
import math
import time
from datetime import date
from pathlib import Path

import numpy as np

from elastocell.api.pipe import pipe, run_state, transit_values
from elastocell.api.resolved import resolved_parameters
from elastocell.body.cell import Cell
from elastocell.coupling.immersed import VOLUME_CORRECTIONS
from elastocell.files import parameter_hash, replace_atomically, write_json
from elastocell.parameters.cell import cell_parameters, describe_cell
from elastocell.parameters.flow import flow_cell
from elastocell.parameters.medium import (
    KOZICKI_SQUARE,
    MC_PBS,
    MC_PBS_TEMPERATURES,
    Medium,
    canonical_name,
    medium,
)
from elastocell.parameters.units import ParameterError, parse_quantity, parse_temperature
from elastocell.scenarios.pipe import (
    CHANNEL_WALLS,
    PIPE_CHANNEL_WALL,
    PIPE_HYDRODYNAMIC_RADIUS_CORRECTION,
    PipeFlowParameters,
    PipeRun,
    pipe_lattice_units,
    unit_flow_rate,
)
from elastocell.scenarios.shear import compile_kernels
from elastocell.simulation.directory import output_directory
from elastocell.simulation.distributed import TaskFailure, check_execution, run_tasks
from elastocell.simulation.extrapolation import (
    coarse_resolution_of,
    extrapolate_values,
    part_directory,
    requested_coarse_resolution,
)
from elastocell.simulation.runner import StopCriteria, check_record_interval, resume_or_restart
from elastocell.version import __version__

POINT_FILE = "point.json"
"""Written last in a grid point's run directory: the point is finished."""

LUT_COLUMNS = ("area_um [um^2]", "deform", "emodulus [kPa]")

FULL = {"resolution": 8.0, "duration": 120.0, "stationary_tolerance": 1e-3}
"""The full grid's runs: R/dx 8, at most 120 units of 1/gdot_w each (stopping earlier once the mean deformation
over a unit of time is stationary to 1e-3); its radii and moduli are :func:`default_grid`'s. The cap is set by the
cell's relaxation: D(t) approaches its stationary value like exp(-t/tau), and in 0.59 % MC-PBS in the 20 um square
duct tau gdot_w is 10-16 Ca_w (docs/validation/lut_square.md, sections lut_relaxation.py): about 19 at the softest
default points (Ca_w 1.2), which a cap of 60 (3 tau) left still drifting, 1-5 % below their stationary
deformation (three points continued to it: D +5.4, +3.3, +1.2 %; E read through HE-3D-FEM-22 0.5-2.5 % lower).
120 is 6 tau there; the stationary stop itself leaves about tau x 1e-3 of D (2 % at tau 19). Stiff points stop on the criterion well
before the cap, and a point that still reaches it is listed as such (state ``cap``)."""

GRID_REFERENCE = {"cylinder": "LE-2D-FEM-19", "square": "HE-3D-FEM-22"}
"""dclab's table whose (area, deformation) region the default grid of a channel shape spans."""

DEFAULT_GRID_SIZE = (6, 8)
"""Radii x moduli of the default grid (48 runs). Measured with validation/lut_grid.py on the 20 um channel: 7 moduli
at log-D steps alone cover 45 of the 50 test events LE-2D-FEM-19 covers, E within 1.056 (median) and 1.446 (max) of
LE-2D-FEM-19's; with the eighth, one step softer, 47 of 50, 1.055 and 1.106."""

SQUARE_CHANNEL_RADIUS_FACTOR = 1.094
"""R_ch/(W/2) of the cylinder that stands for a square channel of width W (Mietke et al. 2015, supplement S3;
dclab's LE-2D-FEM-19 table)."""

QUICK_RADII_UM = (5.0, 6.0)
QUICK_MODULI_KPA = (1.0, 2.0)
QUICK = {"resolution": 4.0, "duration": 1.0, "stationary_tolerance": None}
"""The --quick grid (tests): 2 x 2 runs at R/dx 4 for one unit of time; far from converged."""


# =========================================================================== physics
def pressure_gradient(flow_rate: float, channel_radius: float, viscosity: float) -> float:
    """G = 8 eta Q / (pi R_ch^4) (SI: m^3/s, m, Pa s -> Pa/m): Poiseuille flow in a cylinder."""
    return 8.0 * viscosity * flow_rate / (math.pi * channel_radius**4)


def capillary_number_wall(flow_rate: float, channel_radius: float, viscosity: float, youngs_modulus: float,
                          poisson_ratio: float) -> float:
    """Ca_w = G R_ch / (2 mu), mu = E / (2 (1 + nu)) (SI inputs)."""
    shear_modulus = youngs_modulus / (2.0 * (1.0 + poisson_ratio))
    return pressure_gradient(flow_rate, channel_radius, viscosity) * channel_radius / (2.0 * shear_modulus)


def wall_shear_rate(flow_rate: float, channel_radius: float, viscosity: float) -> float:
    """gdot_w = G R_ch / (2 eta) = 4 Q / (pi R_ch^3) (1/s): the unit of time of the runs is 1/gdot_w."""
    return pressure_gradient(flow_rate, channel_radius, viscosity) * channel_radius / (2.0 * viscosity)


LUT_CHANNELS = ("cylinder", "square")
"""Channel shapes a table can be made for (a rectangle is a pipe option only)."""

DCLAB_KOZICKI_B = 0.6671
"""b of the Kozicki wall shear rate as dclab's ``shear_rate_square_channel`` writes it (the literature's 0.6771 is
:data:`elastocell.parameters.medium.KOZICKI_SQUARE`): the metadata's ``fluid_viscosity`` is dclab's own."""


def channel_driving(channel: str, half_width: float, flow_rate: float, fluid: Medium | None,
                    viscosity: float | None = None) -> dict:
    """The flow that carries Q (m^3/s) through the cylinder of radius ``half_width`` (m) or the square duct of
    width 2 ``half_width``: ``pressure_gradient`` G (Pa/m), ``wall_shear_stress`` tau_w = G a/2 (Pa), and
    ``wall_shear_rate`` gdot_w = (tau_w/K)^(1/n) (1/s, the unit of time of the runs); a Newtonian medium by its
    ``viscosity`` (Pa s), a power law by ``fluid`` (K, n)."""
    if fluid is None or fluid.is_newtonian:
        k, n = float(viscosity), 1.0
    else:
        k, n = float(fluid.consistency), float(fluid.flow_index)
    a = float(half_width)
    if channel == "cylinder" and n == 1.0:  # Poiseuille, written as the table's keys were always computed
        g = pressure_gradient(flow_rate, a, k)
    else:
        g = k * (flow_rate / (unit_flow_rate_of_keys(channel, n) * a ** (3.0 + 1.0 / n))) ** n
    tau = g * a / 2.0
    return {"pressure_gradient": g, "wall_shear_stress": tau, "wall_shear_rate": (tau / k) ** (1.0 / n)}


UNIT_FLOW_RATE_DIGITS = 9
"""Significant digits q1(n) keeps where a table's points are computed from it: the power law's duct value comes
from an iterative sparse solve whose last bits differ between machines (1e-14 relative measured), and everything
computed from q1 (Ca_w, a transit's duration) is part of a point's key, which must be the same on every machine."""


def unit_flow_rate_of_keys(channel: str, flow_index: float) -> float:
    """q1(n) (:func:`~elastocell.scenarios.pipe.unit_flow_rate`) as a table's keys use it: the closed forms as they
    are, the power law's duct value rounded to :data:`UNIT_FLOW_RATE_DIGITS` significant digits."""
    q1 = unit_flow_rate(channel, flow_index)
    if channel == "cylinder" or flow_index == 1.0:
        return q1
    return float(f"{q1:.{UNIT_FLOW_RATE_DIGITS}g}")


def dclab_viscosity(fluid: Medium, flow_rate: float, channel_width: float) -> float:
    """The viscosity (Pa s) dclab assigns a power-law medium in a square channel of width W (m) at Q (m^3/s):
    K gdot^(n-1) at gdot = (8 Q/W^3)(0.6671 + 0.2121/n) (:data:`DCLAB_KOZICKI_B`)."""
    n = fluid.flow_index
    rate = 8.0 * flow_rate / channel_width**3 * (DCLAB_KOZICKI_B + KOZICKI_SQUARE[0] / n)
    return fluid.consistency * rate ** (n - 1.0)


# =========================================================================== inputs
def _positive(value, unit: str, name: str) -> float:
    """A positive quantity in SI ``unit``; a bare number is in its documented unit (parse_quantity: um, uL/s,
    mPa*s, Pa)."""
    magnitude, _ = parse_quantity(value, unit, name)
    if not (math.isfinite(magnitude) and magnitude > 0):
        raise ParameterError(name, f"must be > 0, got {value}")
    return magnitude


def _list(values, unit: str, name: str) -> list[float]:
    """Comma-separated values (or a sequence), each a quantity or a bare number in its documented unit."""
    if isinstance(values, str):
        values = [v for v in values.replace(";", ",").split(",") if v.strip()]
    values = list(values)
    if not values:
        raise ParameterError(name, "give at least one value")
    out = sorted({_positive(v, unit, name) for v in values})
    return out


CELL_KEYS = ("nucleus", "stiffness_ratio", "size_ratio", "material", "poisson_ratio")
"""The CELL OPTIONS of a grid point's pipe run (the mesh follows its resolution)."""


def cell_model(stiffness_ratio: float | None = None, size_ratio: float | None = None) -> dict:
    """The cell options of the table's runs: a homogeneous cell (``{"nucleus": "none"}``, the table's keys as
    they always were) or, with ``stiffness_ratio`` gamma = E_n/E_c, a centred spherical nucleus of size ratio
    lambda = R_n/R (``size_ratio``, default 0.5 as ``pipe``); checked by ``cell_parameters`` (the path of
    ``elastocell pipe``)."""
    if stiffness_ratio is None:
        if size_ratio is not None:
            raise ParameterError("size_ratio", "sets the nucleus of a nucleated cell model: give --stiffness-ratio "
                                 "with it (without both the table is for a homogeneous cell)")
        return {"nucleus": "none"}
    cell = {"nucleus": "sphere", "stiffness_ratio": float(stiffness_ratio),
            "size_ratio": 0.5 if size_ratio is None else float(size_ratio)}
    from pydantic import ValidationError

    try:
        cell_parameters(**cell)  # the CELL OPTIONS' own refusals (gamma > 0, lambda in (0, 1)), named
    except ValidationError as error:
        cause = (error.errors()[0].get("ctx") or {}).get("error")
        if isinstance(cause, ParameterError):
            raise cause from None
        raise
    return cell


def cell_settings(cell: dict, poisson_ratio: float) -> dict:
    """What the table's metadata says of the cell model: ``cell_model`` "homogeneous" or "nucleus" (with gamma,
    lambda and the volume average E_eff/E_c = 1 + (gamma - 1) lambda^3 of the continuum cell; the table's
    ``emodulus`` is then the cytoplasm's E_c)."""
    if cell["nucleus"] == "none":
        return {"cell_model": "homogeneous"}
    gamma, size = cell["stiffness_ratio"], cell["size_ratio"]
    return {"cell_model": "nucleus", "nucleus_stiffness_ratio": gamma, "nucleus_size_ratio": size,
            "volume_average_ratio": 1.0 + (gamma - 1.0) * size**3,
            "cell_description": describe_cell(cell_parameters(**cell, poisson_ratio=float(poisson_ratio)))}


POINT_KEY_FORMAT = {"cylinder": 1, "duct": 2}
"""Version of what a grid point's run directory holds for given resolved parameters (part of its key), by channel:
a duct's 2 is its lattice of the channel's own width (``scenarios.pipe.duct_cell_radius``), not the width rounded to
whole nodes; the cylinder's runs did not change, and its points keep their keys."""


def point_key(radius_um: float, emodulus_kpa: float, options: dict) -> str:
    """Run directory name: readable radius and modulus plus a hash of the pipe run's full resolved parameters
    (``api.resolved.resolved_parameters("pipe", options)``: cell, flow, stop criteria, every option with its
    default) and the channel's :data:`POINT_KEY_FORMAT`."""
    channel = "cylinder" if options.get("channel_shape", "cylinder") == "cylinder" else "duct"
    digest = parameter_hash(resolved_parameters("pipe", options), format_version=POINT_KEY_FORMAT[channel])[:10]
    return f"R{radius_um:g}um_E{emodulus_kpa:g}kPa_{digest}"


def channel_radius_from(channel_radius=None, channel_width=None, channel_shape: str | None = None,
                        channel_height=None) -> float:
    """R_ch (m) from exactly one of ``channel_radius`` (the cylinder's) or ``channel_width`` (a square RT-DC
    channel's W: R_ch = 1.094 W/2 for the cylinder that stands for it, W/2 with ``channel_shape`` "square");
    quantities or numbers in um. A rectangle (``channel_height`` other than W) is refused."""
    shape = channel_shape_of(channel_shape)
    if shape == "square" and channel_width is None:
        raise ParameterError("channel_width", "a square channel is given by its width W (--channel-width)")
    if (channel_radius is None) == (channel_width is None):
        raise ParameterError("channel_radius", "give either the channel radius or the width of a square channel "
                             "(--channel-width), not both and not neither")
    if channel_height is not None:
        if channel_width is None:
            raise ParameterError("channel_height", "needs --channel-width (a square channel: the height equals it)")
        w = _positive(channel_width, "m", "channel_width")
        h = _positive(channel_height, "m", "channel_height")
        if abs(h - w) > 1e-9 * w:
            raise ParameterError("channel_height", f"the look-up table supports square channels only (H = W), got "
                                 f"W = {w * 1e6:g} um, H = {h * 1e6:g} um")
    if channel_width is not None:
        factor = 1.0 if shape == "square" else SQUARE_CHANNEL_RADIUS_FACTOR
        return factor * _positive(channel_width, "m", "channel_width") / 2.0
    return _positive(channel_radius, "m", "channel_radius")


def channel_shape_of(channel_shape) -> str:
    """"cylinder" (default) or "square"; a rectangle is refused (a look-up table is for one width)."""
    shape = "cylinder" if channel_shape is None else str(getattr(channel_shape, "value", channel_shape))
    if shape not in LUT_CHANNELS:
        raise ParameterError("channel_shape", f"the look-up table supports {' and '.join(LUT_CHANNELS)} channels, "
                             f"got {shape!r}")
    return shape


def lut_medium(name=None, temperature=None, flow_index=None, viscosity=None) -> tuple[Medium, float | None]:
    """(medium, Newtonian viscosity in Pa s or None) of the table: "newtonian" needs ``viscosity`` and takes no
    temperature or flow index; an MC-PBS preset takes ``temperature`` (degC, within its fit, default 23) and no
    viscosity; the bare "power-law" is refused (its consistency K sets the physical flow and is no option)."""
    key = canonical_name("newtonian" if name is None else name)
    parse_temperature(temperature)  # a temperature that is none is refused as such, whatever the medium
    if key == "power-law":
        raise ParameterError("medium", "a table needs the medium's consistency K as well as n: use an MC-PBS preset "
                             f"({', '.join(MC_PBS)}) or newtonian with --viscosity")
    if key == "newtonian":
        if flow_index is not None:
            raise ParameterError("flow_index", "a Newtonian medium has n = 1; a shear-thinning table takes an "
                                 "MC-PBS preset (--medium 0.59%MC-PBS)")
        if temperature is not None:
            raise ParameterError("temperature", "sets an MC-PBS medium's K and n; a Newtonian medium is given by "
                                 "--viscosity")
        if viscosity is None:
            raise ParameterError("viscosity", "required with a Newtonian medium (or give --medium 0.59%MC-PBS)")
        return medium(key, None, flow_index), _positive(viscosity, "Pa*s", "viscosity")
    if viscosity is not None:
        raise ParameterError("viscosity", f"the {key} medium sets its own shear-rate dependent viscosity: give "
                             "--temperature, not --viscosity")
    temperature = parse_temperature(temperature)
    if temperature is not None:
        t = temperature
        lo, hi = MC_PBS_TEMPERATURES
        if not (math.isfinite(t) and lo <= t <= hi):
            raise ParameterError("temperature", f"must be within the MC-PBS fit, {lo:g}-{hi:g} degC, got "
                                 f"{temperature}")
    return medium(key, temperature, flow_index), None


def plan(channel_radius=None, flow_rate=None, viscosity=None, radii=None, moduli=None, quick: bool = False,
         poisson_ratio: float = 0.48, material: str = "neo-hookean", resolution: float | None = None,
         duration: float | None = None, stationary_tolerance: float | None = None,
         channel_width=None, channel_shape=None, channel_height=None, medium=None, temperature=None,
         flow_index=None, extrapolate: bool = False, coarse_resolution: float | None = None,
         stiffness_ratio: float | None = None, size_ratio: float | None = None,
         channel_length=None, hydrodynamic_radius_correction: float | None = None,
         channel_wall: str | None = None, volume_correction: str | None = None) -> tuple[list[dict], dict]:
    """Check every input and return (grid points, settings); raises ParameterError (named option) on an
    impossible one, before anything runs. Each point holds its key and the keyword arguments of ``pipe``.
    ``channel_width`` (a square channel's W) replaces ``channel_radius`` (give None for it); ``channel_shape``
    "square" runs the duct itself; ``medium`` an MC-PBS preset at ``temperature`` replaces ``viscosity``;
    ``extrapolate``/``coarse_resolution`` as ``pipe`` (default off: each point one run at ``resolution`` with the
    pipe's markers at R - 0.3 dx; on: two runs, R/dx 6 and ``resolution``, whose final shapes are
    Richardson-extrapolated; a point at R/dx <= 6 is one run); ``hydrodynamic_radius_correction``: c, the markers
    at R - c dx (default :data:`~elastocell.scenarios.pipe.PIPE_HYDRODYNAMIC_RADIUS_CORRECTION`; 0 with
    ``extrapolate`` is the default the pipe had before); ``stiffness_ratio``, ``size_ratio``:
    the nucleated cell model (:func:`cell_model`; the moduli are then the cytoplasm's E_c); ``channel_length``: the
    shape at the end of a channel of that length (:func:`transit_length`) instead of the stationary shape;
    ``channel_wall``: how the lattice places a cylinder's wall, "interpolated" (default, the pipe's) or "staircase"
    (:data:`~elastocell.scenarios.pipe.CHANNEL_WALLS`; a square duct's walls are the same either way);
    ``volume_correction``: "none" (default) or "projection", the pipe's (each point's cell volume held by projecting
    its surface markers after every step; a point's key says which, so points of the two never mix)."""
    from pydantic import ValidationError


    shape = channel_shape_of(channel_shape)
    cell = cell_model(stiffness_ratio, size_ratio)
    r_ch = channel_radius_from(channel_radius, channel_width, shape, channel_height)
    if flow_rate is None:
        raise ParameterError("flow_rate", "required (the pump's flow rate, e.g. 0.04uL/s)")
    q = _positive(flow_rate, "m^3/s", "flow_rate")
    fluid, eta = lut_medium(medium, temperature, flow_index, viscosity)
    defaults = QUICK if quick else FULL
    if not (math.isfinite(poisson_ratio) and -1 < poisson_ratio < 0.5):
        raise ParameterError("poisson_ratio", f"must be in (-1, 0.5), got {poisson_ratio}")
    resolution = defaults["resolution"] if resolution is None else float(resolution)
    if not (math.isfinite(resolution) and resolution > 0):
        raise ParameterError("resolution", f"must be > 0 (lattice nodes per cell radius R/dx), got {resolution:g}")
    width = 2.0 * r_ch if shape == "square" else 2.0 * r_ch / SQUARE_CHANNEL_RADIUS_FACTOR
    viscosity_mpa_s = 1e3 * (eta if eta is not None else dclab_viscosity(fluid, q, width))
    grid = None
    if not quick and (radii is None or moduli is None):
        grid = default_grid(shape, width * 1e6, r_ch * 1e6, q * 1e9, viscosity_mpa_s, resolution,
                            {} if shape == "cylinder" else {"channel_shape": shape})
    radii_m = _list(radii if radii is not None else
                    [f"{r}um" for r in (QUICK_RADII_UM if quick else grid["radii_um"])], "m", "radii")
    moduli_pa = _list(moduli if moduli is not None else
                      [f"{e}kPa" for e in (QUICK_MODULI_KPA if quick else grid["moduli_kpa"])], "Pa", "moduli")
    flow_cell(None, {**cell, "material": material, "poisson_ratio": float(poisson_ratio)}, resolution)  # refusals
    duration_given = duration
    duration = defaults["duration"] if duration is None else float(duration)
    if not (math.isfinite(duration) and duration > 0):
        raise ParameterError("duration", f"must be > 0 (units of 1/gdot_w), got {duration}")
    tolerance = defaults["stationary_tolerance"] if stationary_tolerance is None else float(stationary_tolerance)
    if tolerance is not None and not (math.isfinite(tolerance) and tolerance > 0):
        raise ParameterError("stationary_tolerance", f"must be > 0, got {tolerance}")
    too_large = [r for r in radii_m if r >= r_ch]
    if too_large:
        raise ParameterError("radii", f"a cell of radius {too_large[0] * 1e6:g} um does not fit in a channel of "
                             f"radius {r_ch * 1e6:g} um (need R < R_ch)")
    length = transit_length(channel_length, max(radii_m))
    if length is not None:
        if stationary_tolerance is not None:
            raise ParameterError("stationary_tolerance", "stops at a stationary shape; a table for a finite channel "
                                 "(--channel-length) reads each cell at the end of the channel")
        tolerance = None
    # the pipe options that differ from the defaults the earlier points were made with (a cylinder in a Newtonian
    # medium added none; the markers at R - c dx now add c, so that no point made at c = 0 is taken for one)
    flow = {} if shape == "cylinder" else {"channel_shape": shape}
    correction = (PIPE_HYDRODYNAMIC_RADIUS_CORRECTION if hydrodynamic_radius_correction is None
                  else float(hydrodynamic_radius_correction))
    if not (math.isfinite(correction) and 0 <= correction < 0.5 * resolution):
        raise ParameterError("hydrodynamic_radius_correction", f"must be in [0, R/2) = [0, {0.5 * resolution:g}) dx "
                             f"at R/dx {resolution:g}, got {hydrodynamic_radius_correction}")
    flow["hydrodynamic_radius_correction"] = correction
    wall = PIPE_CHANNEL_WALL if channel_wall is None else str(channel_wall)
    if wall not in CHANNEL_WALLS:
        raise ParameterError("channel_wall", f"must be one of {', '.join(CHANNEL_WALLS)}, got {channel_wall!r}")
    if shape == "cylinder":  # said in full; the staircase resolves as runs before the choice (their keys stay)
        flow["channel_wall"] = wall
    correction_method = "none" if volume_correction is None else str(volume_correction)
    if correction_method not in VOLUME_CORRECTIONS:
        raise ParameterError("volume_correction", f"must be one of {', '.join(VOLUME_CORRECTIONS)}, got "
                             f"{volume_correction!r}")
    if correction_method != "none":  # "none" as the points made before the choice existed: their keys stay
        flow["volume_correction"] = correction_method
    if not fluid.is_newtonian:
        flow.update(medium=fluid.name, temperature=fluid.temperature)
    coarse = requested_coarse_resolution(bool(extrapolate), resolution, coarse_resolution)
    extrapolation = {"extrapolate": bool(extrapolate)}  # said in full: pipe's default is one resolution
    if extrapolate and coarse_resolution is not None:
        extrapolation["coarse_resolution"] = coarse
    driving = channel_driving(shape, r_ch, q, fluid, eta)
    transit = {}
    if length is not None:  # the cap: the transit at the channel's mean speed, 1.5 times (a centred cell is faster)
        area = math.pi * r_ch**2 if shape == "cylinder" else 4.0 * r_ch**2
        cap = TRANSIT_CAP * length * driving["wall_shear_rate"] * area / q
        transit = {"channel_length": length * 1e6}
        if duration_given is None:
            duration = cap
    check_record_interval(duration, PipeRun.DEFAULT_RECORD_INTERVAL, PipeRun.TIME_UNIT,
                          "each point records its shape every interval")
    points = []
    for radius in radii_m:
        ratio = r_ch / radius
        try:  # the pipe scenario's own refusals (ratio range, wall gap at this resolution)
            PipeFlowParameters(capillary_number_wall=1.0, channel_radius_ratio=ratio, resolution=resolution, **flow)
        except (ParameterError, ValidationError) as error:
            if isinstance(error, ValidationError):
                error = (error.errors()[0].get("ctx") or {}).get("error", error)
            if not isinstance(error, ParameterError):
                raise
            name = "radii" if error.parameter == "channel_radius_ratio" else error.parameter
            raise ParameterError(name, f"cell radius {radius * 1e6:g} um in a channel of radius {r_ch * 1e6:g} um: "
                                 f"{str(error).split(': ', 1)[1]}") from None
        single = {}  # a cell too close to the wall for the coarse run: this radius runs at one resolution
        if coarse is not None and not _fits(ratio, coarse, flow):
            single = {"extrapolate": False}
        for modulus in moduli_pa:
            if shape == "cylinder" and eta is not None:  # Poiseuille: the table's keys as they were computed
                ca = capillary_number_wall(q, r_ch, eta, modulus, poisson_ratio)
            else:
                ca = driving["wall_shear_stress"] * 2.0 * (1.0 + poisson_ratio) / modulus  # tau_w / mu
            options = {"capillary_number_wall": ca, "channel_radius_ratio": ratio, "start_offset": 0.0,
                       "resolution": resolution, "duration": duration, "stationary_tolerance": tolerance,
                       "stationary_observable": "deformation", **cell, "material": material,
                       "poisson_ratio": float(poisson_ratio), **flow, **extrapolation, **single}
            if transit:  # the transit needs the cell's physical radius (L/R)
                options.update(transit, radius=f"{radius * 1e6:g}um")
            try:
                key = point_key(radius * 1e6, modulus * 1e-3, options)
            except (ParameterError, ValidationError) as error:  # the pipe's refusal of this point, by the option
                if isinstance(error, ValidationError):
                    error = (error.errors()[0].get("ctx") or {}).get("error", error)
                if not isinstance(error, ParameterError):
                    raise
                name = "moduli" if error.parameter == "capillary_number_wall" else error.parameter
                what, hint = ("the wall capillary number Ca_w = tau_w/mu ", f" (a bare modulus is in Pa: write "
                              f"{modulus:g}kPa for kPa)") if name == "moduli" else ("", "")
                raise ParameterError(name, f"R = {radius * 1e6:g} um, E = {modulus:g} Pa: {what}"
                                     f"{str(error).split(': ', 1)[1]}{hint}") from None
            points.append({"key": key, "radius_um": radius * 1e6, "emodulus_kpa": modulus * 1e-3, "options": options})
    settings = {"channel_shape": shape, "channel_radius_um": r_ch * 1e6, "channel_width_um": width * 1e6,
                "flow_rate_ul_s": q * 1e9, "viscosity_mpa_s": viscosity_mpa_s, **fluid.as_dict(),
                "pressure_gradient_pa_m": driving["pressure_gradient"],
                "wall_shear_stress_pa": driving["wall_shear_stress"],
                "wall_shear_rate_1_s": driving["wall_shear_rate"], "poisson_ratio": float(poisson_ratio),
                "material": material, "resolution": resolution, "coarse_resolution": coarse, "duration": duration,
                "hydrodynamic_radius_correction": correction,
                "channel_wall": wall if shape == "cylinder" else "plane (half-way)",
                "stationary_tolerance": tolerance, "quick": bool(quick), **cell_settings(cell, poisson_ratio),
                "state": "stationary" if length is None else f"transit {length * 1e6:g} um"}
    if correction_method != "none":
        settings["volume_correction"] = correction_method
    if grid is not None:
        settings["default_grid"] = {k: v for k, v in grid.items() if k != "table"}
    if length is not None:
        settings["channel_length_um"] = length * 1e6
    return points, settings


VOLUME_DRIFT = 0.005
"""|V/V0 - 1| above which a point's cell is listed as having drifted in volume (``elastocell.volume_drift``): the
immersed boundary's leak, without the projection. In the standard table's first computation the cells that kept
their shape (converged, symmetric, within 5 % of HE-3D-FEM-22 where inside it) stayed within 0.0034; those that
leaked reached 0.0073-0.033 and swelled (docs/validation/lut_square.md)."""

TRANSIT_CAP = 1.5
"""The duration cap of a transit run, in units of the transit time at the channel's mean speed Q/A: a centred cell
moves faster than the mean flow (about 1.6 times it at R/R_ch 0.5 in the cylinder: 0.81 u_max, u_max = 2 Q/A)."""


def transit_length(channel_length, largest_radius: float) -> float | None:
    """The channel length L (m) of a transit table (None: the stationary state), a quantity or a bare number in um;
    refused in one line when not > 0 or shorter than the largest cell's diameter."""
    if channel_length is None:
        return None
    length = _positive(channel_length, "m", "channel_length")
    if length < 2.0 * largest_radius:
        raise ParameterError("channel_length", f"L = {length * 1e6:g} um is shorter than the diameter of the "
                             f"largest cell, {2e6 * largest_radius:g} um")
    return length


def reference_table(shape: str, channel_width_um: float, flow_rate_ul_s: float, viscosity_mpa_s: float) -> np.ndarray:
    """dclab's table :data:`GRID_REFERENCE` of the channel shape (area_um, deform, emodulus in kPa), scaled to the
    channel width, flow rate and viscosity as dclab scales it (``scale_linear``: area ~ W^2, deformation unchanged,
    E ~ W^-3 Q eta)."""
    from dclab.features.emodulus import load, scale_linear  # lazy: dclab only where a default grid is made

    table, meta = load.load_lut(GRID_REFERENCE[shape])
    out = np.array(table, dtype=float)
    out[:, 0] = scale_linear.scale_area_um(out[:, 0], meta["channel_width"], channel_width_um)
    out[:, 2] = scale_linear.scale_emodulus(out[:, 2], meta["channel_width"], channel_width_um, meta["flow_rate"],
                                            flow_rate_ul_s, meta["fluid_viscosity"], viscosity_mpa_s)
    return out


def table_deformation(table: np.ndarray):
    """D(area_um, E) of a table (linear interpolation in log E; NaN outside its hull)."""
    from scipy.interpolate import LinearNDInterpolator  # lazy: the grid only

    scale = np.array([table[:, 0].max(), 1.0])
    points = np.column_stack([table[:, 0], np.log(table[:, 2])]) / scale
    interpolate = LinearNDInterpolator(points, table[:, 1])
    return lambda area, modulus: interpolate(np.column_stack(np.broadcast_arrays(
        np.asarray(area, dtype=float), np.log(np.asarray(modulus, dtype=float)))) / scale)


def default_grid(shape: str, channel_width_um: float, channel_radius_um: float, flow_rate_ul_s: float,
                 viscosity_mpa_s: float, resolution: float, flow: dict, size: tuple[int, int] = DEFAULT_GRID_SIZE) -> dict:
    """The default (radii, moduli) of a table: the region of dclab's table for the channel shape
    (:func:`reference_table`, scaled to the channel, flow rate and viscosity), where RT-DC events of that channel
    lie. Radii: from the smallest cell of that table, sqrt(area_min/pi), to the largest one the pipe scenario takes
    in the channel at ``resolution`` (or the table's largest), evenly spaced in area (0.1 um). Moduli: the
    deformation of the middle radius (a cell of area pi R^2 in the table) falls from its largest to its smallest
    value over the table's moduli; all moduli but the softest are placed at equal steps of its logarithm, and the
    softest one step of E further (smaller cells reach that largest deformation only at lower moduli); 2
    significant digits.
    E ~ 1/D roughly, so linear interpolation of E in D errs by the relative step in D: equal steps in log D give one
    interpolation error everywhere, with moduli sparse where the deformation changes slowly with E.
    Returns radii_um, moduli_kpa, the reference table's name and the deformation of each modulus at the middle
    radius."""
    n_radii, n_moduli = size
    table = reference_table(shape, channel_width_um, flow_rate_ul_s, viscosity_mpa_s)
    r_min = math.sqrt(table[:, 0].min() / math.pi)
    r_max = math.sqrt(table[:, 0].max() / math.pi)
    while r_max > r_min and not _fits(channel_radius_um / r_max, resolution, flow):
        r_max -= 0.01  # the largest cell the channel takes with the kernel's reach to the wall
    radii = np.sqrt(np.linspace(r_min**2, r_max**2, n_radii))
    radii = np.round(np.clip(radii, math.ceil(r_min * 10) / 10, math.floor(r_max * 10) / 10), 1)
    deformation = table_deformation(table)
    middle = math.pi * float(np.median(radii)) ** 2
    moduli = np.geomspace(table[:, 2].min(), table[:, 2].max(), 400)
    d = deformation(middle, moduli)
    keep = np.isfinite(d)
    moduli, d = moduli[keep], np.minimum.accumulate(d[keep])  # monotone in E (the table's own noise removed)
    targets = np.geomspace(d[0], d[-1], n_moduli - 1)
    chosen = np.interp(-targets, -d, moduli)
    chosen = np.concatenate([[chosen[0] ** 2 / chosen[1]], chosen])  # one step softer: smaller cells reach the
    # middle radius's largest deformation only at lower moduli
    chosen = np.array([float(f"{e:.2g}") for e in chosen])
    return {"radii_um": [float(r) for r in dict.fromkeys(radii)], "moduli_kpa": sorted(set(chosen.tolist())),
            "reference": GRID_REFERENCE[shape], "middle_radius_um": float(np.median(radii)),
            "deformation_at_middle_radius": [float(v) if np.isfinite(v) else None  # None: beyond the table
                                             for v in deformation(middle, sorted(set(chosen.tolist())))]}


def predicted_table(grid: dict, shape: str, channel_width_um: float, flow_rate_ul_s: float,
                    viscosity_mpa_s: float) -> np.ndarray:
    """Where a grid's points would lie if the cells deformed as in the reference table (rows area_um, deform,
    emodulus in kPa): each (R, E) at area pi R^2 (the undeformed cell's; the runs read a few % more) with the
    deformation :func:`table_deformation` gives there; points outside that table are left out. For checking a
    grid's coverage without running it (validation/lut_grid.py, tests)."""
    table = reference_table(shape, channel_width_um, flow_rate_ul_s, viscosity_mpa_s)
    radii, moduli = np.meshgrid(grid["radii_um"], grid["moduli_kpa"], indexing="ij")
    area = np.pi * radii.ravel() ** 2
    deform = table_deformation(table)(area, moduli.ravel())
    rows = np.column_stack([area, deform, moduli.ravel()])
    return rows[np.isfinite(deform)]


def read_events(paths) -> list[dict]:
    """The events of RT-DC measurements (``.rtdc`` files, read by dclab) as :func:`grid_coverage` takes them: one
    dict per file (name, area_um, deform, channel_width in um, flow_rate in uL/s, px_um)."""
    import warnings

    import dclab  # lazy: dclab only for this check

    events = []
    for path in paths:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            data = dclab.new_dataset(str(path))
            events.append({"name": Path(path).name, "area_um": np.asarray(data["area_um"]),
                           "deform": np.asarray(data["deform"]),
                           "channel_width": float(data.config["setup"]["channel width"]),
                           "flow_rate": float(data.config["setup"]["flow rate"]),
                           "px_um": float(data.config["imaging"]["pixel size"])})
    return events


def grid_coverage(table: np.ndarray, events: list[dict], reference: str = "LE-2D-FEM-19",
                  viscosity_mpa_s: float = 15.0) -> dict:
    """Which RT-DC events a table (rows area_um, deform, emodulus; made for 20 um, 0.04 uL/s and ``viscosity_mpa_s``,
    such as :func:`predicted_table` of the default grid there) covers, against dclab's table ``reference``, both through
    dclab's ``get_emodulus`` (scaled to each file's channel width and flow rate, deformation corrected for the
    pixel size, no extrapolation; one Newtonian viscosity for both, which changes E, not coverage). ``events``: one
    dict per file (name, area_um, deform, channel_width, flow_rate, px_um). Returns per file and in all the events,
    those the reference covers, those both cover, and the ratio E_table/E_reference on them."""
    import warnings

    from dclab.features.emodulus import get_emodulus  # lazy: dclab only for this check

    meta = {"channel_width": 20.0, "flow_rate": 0.04, "fluid_viscosity": float(viscosity_mpa_s),
            "column features": ["area_um", "deform", "emodulus"]}
    rows, ratios = [], []
    for e in events:
        conditions = {"area_um": e["area_um"], "deform": e["deform"], "medium": 15.0, "temperature": None,
                      "channel_width": e["channel_width"], "flow_rate": e["flow_rate"], "px_um": e["px_um"]}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            theirs = get_emodulus(lut_data=reference, **conditions)
            ours = get_emodulus(lut_data=(table, meta), **conditions)
        covered, both = np.isfinite(theirs), np.isfinite(theirs) & np.isfinite(ours)
        ratios += list(ours[both] / theirs[both])
        rows.append({"file": e["name"], "channel_um": e["channel_width"], "flow_uL_s": e["flow_rate"],
                     "events": len(theirs), "reference": int(covered.sum()), "both": int(both.sum())})
    covered = sum(r["reference"] for r in rows)
    both = sum(r["both"] for r in rows)
    return {"files": rows, "events": sum(r["events"] for r in rows), "reference": covered, "both": both,
            "fraction": both / covered if covered else float("nan"), "ratios": np.asarray(ratios)}


def _fits(ratio: float, resolution: float, flow: dict) -> bool:
    """Whether the pipe scenario takes the centred cell at R_ch/R ``ratio`` and R/dx ``resolution``."""
    from pydantic import ValidationError

    try:
        PipeFlowParameters(capillary_number_wall=1.0, channel_radius_ratio=ratio, resolution=resolution, **flow)
    except (ParameterError, ValidationError):
        return False
    return True


def check_lattice(points: list[dict]) -> list[dict]:
    """The pipe scenario's lattice refusals for every point (steps per unit time, stability), before anything
    runs; returns per point the lattice shape, the LB steps per unit time 1/gdot_w and the lattice-node updates of
    the longest run (a cost measure). Raises ParameterError naming the point."""
    from pydantic import ValidationError


    cells, out = {}, []
    for point in points:
        options = point["options"]
        cell_options = {k: options[k] for k in CELL_KEYS if k in options}
        key = (options["resolution"], json.dumps(cell_options, sort_keys=True))
        if key not in cells:
            cells[key] = Cell.from_parameters(flow_cell(None, cell_options, options["resolution"]))
        try:
            flow = {k: v for k, v in options.items() if k in PipeFlowParameters.model_fields}
            params = PipeFlowParameters(**flow)
            units = pipe_lattice_units(cells[key], params)
            coarse = coarse_resolution_of(options.get("extrapolate", False), options["resolution"],
                                          options.get("coarse_resolution"))
            updates = float(np.prod(units.shape)) * units.steps_per_time * options["duration"]
            if coarse is not None:  # the coarse run of the extrapolation: its own cell and lattice
                coarse_cell = Cell.from_parameters(flow_cell(None, cell_options, coarse))
                coarse_units = pipe_lattice_units(coarse_cell, PipeFlowParameters(**{**flow, "resolution": coarse}))
                updates += float(np.prod(coarse_units.shape)) * coarse_units.steps_per_time * options["duration"]
        except (ParameterError, ValidationError) as error:
            if isinstance(error, ValidationError):
                error = (error.errors()[0].get("ctx") or {}).get("error", error)
            if not isinstance(error, ParameterError):
                raise
            raise ParameterError("moduli", f"R = {point['radius_um']:g} um, E = {point['emodulus_kpa']:g} kPa: "
                                 f"{str(error).split(': ', 1)[1]}") from None
        out.append({"key": point["key"], "shape": list(units.shape), "steps_per_time": units.steps_per_time,
                    "lattice_updates": updates})
    return out


# =========================================================================== one grid point
def _stop_window() -> float:

    return float(StopCriteria.stationary_window)


FINAL_WINDOW = _stop_window()
"""Units of 1/gdot_w at the end of a run over which a point's area and deformation are averaged: the stop
criterion's window (``runner.StopCriteria.stationary_window``), i.e. the stretch judged stationary when the run
stopped on the criterion (a run that reached its duration cap, or a --quick run, has no stationary stretch: the
window is then just its end, and the point is listed as not stationary). The pipe
summary's means over the second half would mix in the approach to the steady shape (measured: R = 5 um,
E = 2 kPa, 20 um channel, 0.04 uL/s: deformation 0.0365 over the second half against 0.039 at the end)."""


def final_shape(timeseries: Path, channel_length: float | None = None) -> dict:
    """Means of ``deformation`` and ``projected_area`` (and the deformation's standard deviation) over the last
    :data:`FINAL_WINDOW` of a pipe run's time series; with ``channel_length`` (units of R) their values where the
    cell had travelled that far (``api.pipe.transit_values``; the standard deviation is then 0).
    ``outline_fallback``: the share of those records whose side view is the nodes' hull, not the smooth outline
    (the pipe's column of that name; for a transit run 0 or 1, from the two records :func:`transit_values` reads;
    NaN, unknown, for a series written before the column existed)."""
    import pandas as pd

    table = pd.read_csv(timeseries)
    fallback = (table["outline_fallback"] if "outline_fallback" in table
                else pd.Series(float("nan"), index=table.index))
    if channel_length is not None:
        values = transit_values({c: table[c].to_numpy() for c in table.columns}, channel_length)
        after = np.nonzero(table["axial_position"].to_numpy() >= channel_length)[0]  # as transit_values picks
        rows = [len(table) - 1] if after.size == 0 or after[0] == 0 else [int(after[0]) - 1, int(after[0])]
        return {"deformation": values["deformation"], "deformation_std": 0.0,
                "projected_area": values["projected_area"], "outline_fallback": float(fallback.iloc[rows].max())}
    window = table["time"] > table["time"].iloc[-1] - FINAL_WINDOW
    last = table[window]
    return {"deformation": float(last["deformation"].mean()), "deformation_std": float(last["deformation"].std(ddof=0)),
            "projected_area": float(last["projected_area"].mean()), "outline_fallback": float(fallback[window].mean())}


def point_shape(directory: Path, summary: dict) -> tuple[dict, str]:
    """(final shape, state) of a point's pipe run in ``directory``: :func:`final_shape` of its time series (at the
    end of the channel for a transit run) and its state (``api.pipe.run_state``: "stationary", "transit L um", or
    "cap" when the duration ran out first); for an extrapolated run (``summary["extrapolation"]``) the final shapes
    of both resolutions' runs extrapolated to dx -> 0 (Richardson, order 2: ``extrapolation`` holds each value at
    both resolutions and the correction), "cap" unless both runs reached the state."""
    length = summary.get("channel_length_r")
    if "extrapolation" not in summary:
        return (final_shape(directory / "timeseries.csv", length),
                run_state(summary.get("stop_reason"), summary.get("channel_length_um")))
    fine_r = summary["extrapolation"]["fine_resolution"]
    coarse_r = summary["extrapolation"]["coarse_resolution"]
    shapes, states = {}, set()
    for r in (fine_r, coarse_r):
        part = part_directory(directory, r)
        shapes[r] = final_shape(part / "timeseries.csv", length)
        states.add(run_state(json.loads((part / "summary.json").read_text()).get("stop_reason"),
                             summary.get("channel_length_um")))
    state = states.pop() if len(states) == 1 else "cap"
    ratio = summary["extrapolation"].get("ratio", fine_r / coarse_r)  # of the lattices' own R/dx
    values = extrapolate_values({k: shapes[fine_r][k] for k in ("deformation", "projected_area")}, shapes[coarse_r],
                                ratio, 1.0)
    final = {k: v["value"] for k, v in values.items()}
    final["deformation_std"] = shapes[fine_r]["deformation_std"]
    final["outline_fallback"] = float(np.fmax(shapes[fine_r]["outline_fallback"],
                                              shapes[coarse_r]["outline_fallback"]))  # NaN only if both unknown
    final["extrapolation"] = {"fine_resolution": fine_r, "coarse_resolution": coarse_r, "values": values}
    return final, state


def point_state(record: dict) -> str:
    """A finished point's state ("stationary", "transit L um", "hull" or "cap"; a point.json without one: from its
    ``stationary`` flag)."""
    return record.get("state") or ("stationary" if record.get("stationary") else "cap")


ADOPT_TOLERANCE = 1e-9
"""Relative difference below which two numbers of a grid point's options are the same point: the last bits that a
key computed on another machine, or before :data:`UNIT_FLOW_RATE_DIGITS` rounded it, differ by (1e-10 measured)."""


def _same_options(recorded: dict | None, options: dict) -> bool:
    """Whether a finished point's recorded options are ``options`` up to :data:`ADOPT_TOLERANCE` in its numbers."""
    if not isinstance(recorded, dict) or set(recorded) != set(options):
        return False
    for name, value in options.items():
        other = recorded[name]
        numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (value, other))
        if numbers and not (value == other or abs(value - other) <= ADOPT_TOLERANCE * max(abs(value), abs(other))):
            return False
        if not numbers and value != other:
            return False
    return True


def adopt_finished_point(runs_directory: Path, point: dict) -> bool:
    """Give a finished run of the same grid point under another key ``point``'s key: a run whose recorded options
    equal ``point``'s up to :data:`ADOPT_TOLERANCE` (its key was computed on another machine, or by an older
    version, from the last bits of the same numbers) is renamed to ``point["key"]`` and its point.json given the
    key and options, so that a table resumed elsewhere keeps what it has computed. True when one was adopted."""
    target = runs_directory / point["key"]
    if target.exists() and any(target.iterdir()):  # a run under this key has started: it stands
        return False
    prefix = point["key"].rsplit("_", 1)[0] + "_"  # R<radius>um_E<modulus>kPa_: the same radius and modulus
    for marker in sorted(runs_directory.glob(f"{prefix}*/{POINT_FILE}")):
        if marker.parent == target:
            continue
        record = json.loads(marker.read_text())
        if _same_options(record.get("options"), point["options"]):
            if target.exists():
                target.rmdir()
            marker.parent.rename(target)
            write_json(target / POINT_FILE, {**record, "key": point["key"], "options": point["options"]})
            return True
    return False


def run_point(task: tuple[dict, str]) -> dict:
    """Run one grid point in ``runs_directory/<key>`` (a Dask task); a finished point is read back (also one
    finished under another key of the same options, :func:`adopt_finished_point`)."""
    point, runs_directory = task
    directory = Path(runs_directory) / point["key"]
    marker = directory / POINT_FILE
    if not marker.exists():
        adopt_finished_point(Path(runs_directory), point)
    if marker.exists():
        record = json.loads(marker.read_text())
        if "outline_fallback" not in record and (directory / "summary.json").exists():  # a point of an older grid
            summary = json.loads((directory / "summary.json").read_text())
            record["outline_fallback"] = point_shape(directory, summary)[0]["outline_fallback"]
        return record

    directory.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    options = dict(point["options"])  # the point's key hashes these as they are
    if options.get("stationary_tolerance") is None:
        options.pop("stationary_observable", None)  # read only by the stationarity stop, which is off
    if options.get("extrapolate") is False:  # a point too near the wall for the grid's coarse run: one resolution
        options = {k: v for k, v in options.items() if k != "coarse_resolution"}
    # hull_stop: a point whose reading has fallen back to the nodes' hull for a unit of time ends there (state
    # "hull"); the table leaves it out (:func:`compute_lut`), so running on to the cap would buy nothing. It is not an
    # option of the point's key: the stop only ends a run whose reading the table does not use.
    summary = resume_or_restart(pipe, directory, progress=False, vtk_interval=None, hull_stop=True, **options)
    radius = point["radius_um"]
    final, state = point_shape(directory, summary)
    record = {
        "key": point["key"], "radius_um": radius, "emodulus_kpa": point["emodulus_kpa"],
        "area_um": final["projected_area"] * radius**2,
        "deform": final["deformation"], "deform_std": final["deformation_std"],
        "outline_fallback": final["outline_fallback"],
        "extrapolation": final.get("extrapolation"),
        "final_window": FINAL_WINDOW,
        "deformation_mean_second_half": summary["deformation_mean"],
        "projected_area_mean": summary["projected_area_mean"],
        "projected_area_initial": summary.get("projected_area_initial"),
        "deformation_initial": summary.get("deformation_initial"),
        "strain_axial_mean": summary.get("strain_axial_mean"), "strain_radial_mean": summary.get("strain_radial_mean"),
        "strain_transverse_mean": summary.get("strain_transverse_mean"),
        "volume_change_max_abs": summary.get("volume_change_max_abs"),
        "stop_reason": summary.get("stop_reason"), "stationary": state == "stationary", "state": state,
        "window_stationary": summary.get("stationary"),
        "duration": summary.get("duration"),
        "steps": summary.get("steps"), "options": point["options"],
        "wall_time_s": time.perf_counter() - start,
    }
    if "volume_restored" in summary:  # the projection's (V0): the leak it answered
        record["volume_restored"] = summary["volume_restored"]
    write_json(marker, record)
    return record


# =========================================================================== output
def check_identifier(identifier: str | None) -> None:
    """Refuse (ParameterError ``identifier``) an identifier dclab cannot register: empty, or the name of one of
    dclab's own tables (``dclab.features.emodulus.load.get_internal_lut_names_dict``), which
    ``register_lut`` refuses as in use (without dclab installed: only the empty one)."""
    if identifier is None:
        return
    if not str(identifier).strip():
        raise ParameterError("identifier", "must not be empty")
    try:
        from dclab.features.emodulus.load import get_internal_lut_names_dict  # lazy: dclab only here
    except ImportError:  # without dclab (an optional extra) there is nothing to register with, nor to clash
        return
    if str(identifier) in get_internal_lut_names_dict():
        raise ParameterError("identifier", f"{identifier!r} is one of dclab's own tables "
                                           f"({', '.join(sorted(get_internal_lut_names_dict()))}), which "
                                           "dclab.features.emodulus.register_lut refuses as in use: choose another")


def lut_metadata(settings: dict, identifier: str) -> dict:
    """dclab's metadata keys (units as dclab asserts them; for a power law also those of dclab's HE-*-FEM-22
    tables) plus elastocell's own settings."""

    nu = settings["poisson_ratio"]
    square = settings.get("channel_shape") == "square"
    power_law = settings.get("medium_model") == "power-law"
    nucleated = settings.get("cell_model") == "nucleus"
    body = (f"a cell with a centred spherical nucleus (gamma = E_n/E_c = {settings.get('nucleus_stiffness_ratio'):g}, "
            f"lambda = R_n/R = {settings.get('nucleus_size_ratio'):g}; emodulus is the cytoplasm's E_c, the volume "
            f"average is {settings.get('volume_average_ratio'):.4g} E_c)" if nucleated else "a homogeneous cell")
    if square:
        channel = (f"{body} centred in a SQUARE channel (duct) of width W = {settings['channel_width_um']:g} "
                   "um, plane walls")
    else:
        channel = (f"{body} centred in a CYLINDRICAL channel of radius R_ch = "
                   f"{settings['channel_radius_um']:g} um; channel_width = 2 R_ch/1.094 is the width of the SQUARE "
                   "RT-DC channel it stands for (the equivalent radius of Mietke et al. 2015, as in dclab's "
                   "LE-2D-FEM-19)")
    if power_law:
        fluid = (f"{settings['medium']} at {settings['temperature_c']:g} degC, power law eta = K gdot^(n-1) with "
                 f"K = {settings['consistency_pa_s_n']:.5g} Pa s^n, n = {settings['flow_index']:.5g} (Buyukurganci "
                 "et al. 2022); fluid_viscosity is dclab's (K at the Kozicki wall shear rate)")
    else:
        fluid = "Newtonian fluid of viscosity fluid_viscosity"
    metadata = {
        "identifier": identifier,
        "channel_width": (settings["channel_width_um"] if "channel_width_um" in settings
                          else 2.0 * settings["channel_radius_um"] / SQUARE_CHANNEL_RADIUS_FACTOR),
        "channel_width_unit": "um",
        "flow_rate": settings["flow_rate_ul_s"],
        "flow_rate_unit": "uL/s",
        "fluid_viscosity": settings["viscosity_mpa_s"],
        "fluid_viscosity_unit": "mPa s",
        "date": date.today().isoformat(),
        "dimensionality": "3D",
        "method": ("LBM-IBM (lattice Boltzmann + immersed boundary, tetrahedral FEM cell"
                   + (", the cell's volume held by projecting its surface markers after every step"
                      if settings.get("volume_correction", "none") != "none" else "") + ")"),
        "model": (f"hyper-elastic solid ({settings['material']}, Poisson ratio {nu:g}"
                  + (f"; nucleus cell: gamma {settings['nucleus_stiffness_ratio']:g}, lambda "
                     f"{settings['nucleus_size_ratio']:g}, emodulus = E_c of the cytoplasm" if nucleated else "")
                  + ") / "
                  f"{'non-Newtonian' if power_law else 'Newtonian'} fluid"),
        "software": f"elastocell {__version__}",
        "authors": "elastocell",
        "summary": (
            f"{shape_read(settings)} of {channel}. {fluid}. Driving: flow_rate, held (the body force rescaled "
            "after every record); the pressure gradient G that carries it through the ideal channel sets the wall "
            "shear stress tau_w = G A/P (cylinder G R_ch/2, square G W/4), Ca_w = tau_w/mu. "
            "area_um and deform are the convex outline of the cell seen from the side (deform = 1 - "
            "circularity)."),
        "elastocell": settings,
    }
    if power_law:
        metadata.update({"fluid_consistency_coefficient": settings["consistency_pa_s_n"],
                         "fluid_consistency_coefficient_unit": "Pa s^n",
                         "fluid_flow_behaviour_index": settings["flow_index"],
                         "fluid_flow_behaviour_index_unit": "", "fluid_temperature": settings["temperature_c"],
                         "fluid_temperature_unit": "degC", "medium": settings["medium"]})
    return metadata


def shape_read(settings: dict) -> str:
    """What the table's shape is: "Stationary shape", or the shape at the end of a finite channel."""
    if settings.get("channel_length_um") is None:
        return "Stationary shape"
    return (f"Shape at the end of a channel {settings['channel_length_um']:g} um long (the cell started undeformed on "
            "the axis at the inlet; RT-DC's measurement region near the outlet)")


def _header(metadata: dict, comment: str) -> str:
    lines = [f"# {line}" if line else "#" for line in comment.splitlines()]
    lines += ["#", "# BEGIN METADATA"]
    lines += [f"# {line}" for line in json.dumps(metadata, indent=2, sort_keys=True).splitlines()]
    lines += ["# END METADATA", "#", "# " + "\t".join(LUT_COLUMNS)]
    return "\n".join(lines) + "\n"


def _rows(records: list[dict]) -> np.ndarray:
    table = np.array([[r["area_um"], r["deform"], r["emodulus_kpa"]] for r in records], dtype=float)
    if table.size == 0:
        return table.reshape(0, 3)
    return table[np.lexsort((table[:, 0], table[:, 2]))]  # by modulus, then area: isoelastic lines in order


REFINE_SUBDIVISIONS = 8
"""Rows per grid interval of the tables ``elastocell lut`` writes (``--subdivisions``, :func:`refined_rows`): on the
standard table the share of the common region with HE-3D-FEM-22 read within 5 % is 0.44, 0.78, 0.91 and 0.94 at
1, 2, 4 and 8, the median ratio moving by 0.001 from 4 to 8 (``python validation/lut_standard.py compare``,
docs/validation/lut_square.md)."""


REFINE_METHOD = ("between computed points, ln(area_um) and ln(deform) bilinear in (ln R, ln E) over each grid cell "
                 "whose four corners were computed (elastocell.inverse.lut.refined_rows)")
"""How the interpolated rows of a table are made (its metadata, ``elastocell.rows.method``)."""


MAX_SUBDIVISIONS = 64
"""The most rows per grid interval: the rows grow as its square (at 64, about 150,000 for the default grid's 35
cells), and dclab triangulates them all on every conversion."""


def check_subdivisions(subdivisions) -> int:
    """``subdivisions`` as a whole number from 1 to :data:`MAX_SUBDIVISIONS`, refused in one line otherwise."""
    try:
        number = float(subdivisions)
    except (TypeError, ValueError):
        number = float("nan")
    if isinstance(subdivisions, bool) or not number.is_integer() or not 1 <= number <= MAX_SUBDIVISIONS:
        raise ParameterError("subdivisions", f"{subdivisions}: a whole number from 1 to {MAX_SUBDIVISIONS} (1: the "
                                             "computed points alone)")
    return int(number)


def refined_rows(points: list[dict], subdivisions: int = REFINE_SUBDIVISIONS,
                 grid: tuple[list[float], list[float]] | None = None) -> list[dict]:
    """The computed points of a table on its (R, E) grid and, between them, rows interpolated in the grid's
    parameters: each of ln(area_um) and ln(deform) is bilinear in (ln R, ln E) over every grid cell whose four
    corners were computed, at ``subdivisions`` equal steps of ln R and ln E (on a grid edge whose two ends were
    computed, linear along it). A cell with a missing corner (a point left out, e.g. read on the nodes' hull) gets
    no interior rows.

    Why: dclab reads a table by linear interpolation in (area, deform), where the modulus is far from linear (the
    deformation of a cell of one size falls about as E^-2 to E^-3), so between grid points that spacing overstates
    E; the forward map (R, E) -> (area, deform) is close to a power law in each interval, which this interpolation
    reproduces exactly. Left-one-out on the standard table's own points (each interior point predicted from its
    neighbours at twice the spacing): E error 0.4 % median, 2.6 % at most, against 27 % median for dclab's linear
    reading at that spacing (docs/validation/lut_square.md).

    ``points``: dicts with ``radius_um``, ``emodulus_kpa``, ``area_um``, ``deform`` (the computed ones, returned
    first, unchanged); the interpolated rows carry ``interpolated: True``. ``grid``: the planned (radii, moduli),
    so that a radius or modulus none of whose points is here leaves its cells empty instead of joining its
    neighbours into one cell (default: those of ``points``)."""
    subdivisions = check_subdivisions(subdivisions)
    shape = {(p["radius_um"], p["emodulus_kpa"]): (math.log(p["area_um"]), math.log(p["deform"])) for p in points
             if p["area_um"] > 0 and p["deform"] > 0}  # a point without a logarithm counts as missing
    radii, moduli = (sorted({r for r, _ in shape}), sorted({e for _, e in shape})) if grid is None else (
        sorted(set(grid[0])), sorted(set(grid[1])))
    steps = [k / subdivisions for k in range(subdivisions + 1)]
    rows: dict[tuple, dict] = {}

    def add(i: int, u: float, j: int, v: float, corners: list[tuple], weights: list[float]) -> None:
        key = (round(i + u, 9), round(j + v, 9))
        if key in rows or u in (0.0, 1.0) and v in (0.0, 1.0):  # a computed point, or a row already made
            return
        log_area = sum(w * shape[c][0] for c, w in zip(corners, weights, strict=True))
        log_deform = sum(w * shape[c][1] for c, w in zip(corners, weights, strict=True))
        emodulus = math.exp((1 - v) * math.log(moduli[j]) + v * math.log(moduli[j + 1])) if v else moduli[j]
        rows[key] = {"area_um": math.exp(log_area), "deform": math.exp(log_deform), "emodulus_kpa": emodulus,
                     "interpolated": True}

    for i in range(len(radii)):
        for j in range(len(moduli) - 1):
            edge = [(radii[i], moduli[j]), (radii[i], moduli[j + 1])]  # along E at one radius
            if all(c in shape for c in edge):
                for v in steps:
                    add(i, 0.0, j, v, edge, [1 - v, v])
    for i in range(len(radii) - 1):
        for j in range(len(moduli)):
            edge = [(radii[i], moduli[j]), (radii[i + 1], moduli[j])]  # along R at one modulus
            if all(c in shape for c in edge):
                for u in steps:
                    add(i, u, j, 0.0, edge, [1 - u, u])
        for j in range(len(moduli) - 1):
            cell = [(radii[i], moduli[j]), (radii[i + 1], moduli[j]), (radii[i], moduli[j + 1]),
                    (radii[i + 1], moduli[j + 1])]
            if all(c in shape for c in cell):
                for u in steps[1:-1]:
                    for v in steps[1:-1]:
                        add(i, u, j, v, cell, [(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v])
    return [dict(p) for p in points] + list(rows.values())


def write_lut(path: str | Path, records: list[dict], metadata: dict) -> Path:
    """The look-up table: dclab's commented-JSON text format, columns area_um, deform, emodulus."""
    path = Path(path)
    square = metadata.get("elastocell", {}).get("channel_shape") == "square"
    nucleated = metadata.get("elastocell", {}).get("cell_model") == "nucleus"
    comment = ("Look-up table for RT-DC computed with elastocell (pipe flow, centred "
               + ("cell with a stiff nucleus: emodulus is the cytoplasm's E_c" if nucleated else "homogeneous cell")
               + ").\n"
               + ("Square channel of width channel_width." if square else
                  "Approximation: cylindrical channel standing for a square one of width channel_width."))
    body = "".join(f"{a:.6e}\t{d:.6e}\t{e:.6e}\n" for a, d, e in _rows(records))
    path.parent.mkdir(parents=True, exist_ok=True)
    text = _header(metadata, comment) + body
    replace_atomically(path, lambda temporary: temporary.write_text(text))  # a killed run leaves no cut table
    return path


def write_isoelastics(path: str | Path, records: list[dict], metadata: dict) -> Path:
    """Isoelastics (lines of constant E in the area_um-deform plane) in dclab's isoelastics text format
    (same layout as the LUT, ``lut identifier`` instead of ``identifier``; one line per emodulus value)."""
    path = Path(path)
    meta = dict(metadata)
    meta["lut identifier"] = meta.pop("identifier")
    comment = "Isoelasticity lines computed with elastocell: one line per emodulus value, sorted by area."
    body = "".join(f"{a:.6e}\t{d:.6e}\t{e:.6e}\n" for a, d, e in _rows(records))
    text = _header(meta, comment) + body
    replace_atomically(path, lambda temporary: temporary.write_text(text))
    return path


def isoelastics_path(path: str | Path) -> Path:
    path = Path(path)
    return path.with_name(f"{path.stem}_isoelastics{path.suffix or '.txt'}")


def runs_directory(path: str | Path) -> Path:
    path = Path(path)
    return path.with_name(f"{path.stem}_runs")


def read_lut(path: str | Path) -> tuple[np.ndarray, dict, list[str]]:
    """(data (N, 3), metadata, column header) of a LUT or isoelastics file written here (as dclab reads it)."""
    meta_lines, header, inside = [], "", False
    for line in Path(path).read_text().splitlines():
        if not line.startswith("#"):
            break
        if line.startswith("# BEGIN METADATA"):
            inside = True
        elif line.startswith("# END METADATA"):
            inside = False
        elif inside:
            meta_lines.append(line.strip("#").strip())
        else:
            header = line
    data = np.loadtxt(path, ndmin=2)
    return data, json.loads("\n".join(meta_lines)), header.strip("# ").split("\t")


# =========================================================================== driver
def compute_lut(out: str | Path, channel_radius=None, flow_rate=None, viscosity=None, radii=None, moduli=None,
                quick: bool = False, poisson_ratio: float = 0.48, material: str = "neo-hookean",
                resolution: float | None = None, duration: float | None = None,
                stationary_tolerance: float | None = None, identifier: str | None = None,
                scheduler: str | None = None, workers: int | None = None, progress: bool = False,
                client=None, channel_width=None, security=None, channel_shape=None, channel_height=None,
                medium=None, temperature=None, flow_index=None, extrapolate: bool = False,
                coarse_resolution: float | None = None, stiffness_ratio: float | None = None,
                size_ratio: float | None = None, channel_length=None,
                hydrodynamic_radius_correction: float | None = None, channel_wall: str | None = None,
                volume_correction: str | None = None, subdivisions: int = REFINE_SUBDIVISIONS) -> dict:
    """Run the grid (Dask; resumable) and write ``out`` (the LUT) and ``<stem>_isoelastics.txt``. The table holds the
    computed points and the rows :func:`refined_rows` interpolates between them (``subdivisions`` per grid
    interval; 1: the computed points alone; counted under ``elastocell.rows``); the isoelastics are the computed
    points'. ``security``:
    a ``distributed.Security`` for a TLS scheduler (docs/usage/cluster.md).

    channel_radius, flow_rate, viscosity: quantities ("10um", "0.04uL/s", "15mPa*s") or numbers in um, uL/s,
    mPa s; or ``channel_radius=None`` and ``channel_width`` the width W of a square RT-DC channel (the cylinder
    R_ch = 1.094 W/2 stands for it; ``channel_shape="square"`` runs the square duct). ``medium``: "newtonian"
    (with ``viscosity``) or an MC-PBS preset at ``temperature`` degC (``viscosity=None``). ``extrapolate``,
    ``coarse_resolution``: as ``pipe`` (default off: each point one run at the resolution, the markers at
    R - 0.3 dx; on: each point at R/dx above 6 also runs R/dx 6 and its area and deformation are extrapolated to
    dx -> 0); ``hydrodynamic_radius_correction``: as :func:`plan`. radii, moduli: comma-separated lists or sequences (bare numbers in um
    and Pa); default the region of dclab's table for the channel (:func:`default_grid`, 6 x 8) or, with ``quick``,
    the 2 x 2 test grid. Returns a
    summary: paths, the finished records, the failed points (key and one-line error; left out of the table and
    rerun next time) and the keys of the points that hit the duration cap before the stationarity criterion
    (kept in the table, listed in the metadata under ``elastocell.not_stationary``: their shape is a transient
    mean, not a steady shape); points whose final window holds records read through the nodes' hull rather than
    the smooth outline (the pipe's ``outline_fallback``; the hull's deform is biased high, by 40 % at a soft cell of
    the standard table, and an extrapolation carries that bias either way) are left out of the table's rows,
    listed under ``elastocell.outline_fallback`` (also in the returned summary) and keep the share in their record
    (a point read on the hull for a whole unit of time stops there, state "hull": running on would not make it
    readable); events where only they would have placed a modulus are then outside the table. Points whose cell's
    volume changed by more than :data:`VOLUME_DRIFT` (the immersed boundary's leak: run them with
    ``volume_correction="projection"``) are listed under ``elastocell.volume_drift``. ``stiffness_ratio`` (gamma = E_n/E_c) and ``size_ratio`` (lambda = R_n/R, default
    0.5): a table for the cell with a centred spherical nucleus (the metadata's ``elastocell.cell_model``; its
    ``emodulus`` column is the cytoplasm's E_c); without them the cell is homogeneous. ``channel_length`` (a
    quantity, bare number in um): each point is read at the end of a channel of that length, the cell started
    undeformed at its inlet (``pipe``'s transit; no stationarity stop; ``duration`` is then the cap, by default
    :data:`TRANSIT_CAP` times the transit at the mean flow speed); the metadata's ``elastocell.state`` says
    "transit L um" ("stationary" without it) and ``elastocell.point_states`` each point's ("cap": the duration ran
    out first, also listed under ``not_stationary``)."""

    check_execution(scheduler, workers)
    out = Path(out)
    if out.exists() and out.is_dir():
        raise ParameterError("out", f"{out} is a directory; give a file name such as lut.txt")
    check_identifier(identifier)
    subdivisions = check_subdivisions(subdivisions)
    points, settings = plan(channel_radius, flow_rate, viscosity, radii, moduli, quick, poisson_ratio, material,
                            resolution, duration, stationary_tolerance, channel_width=channel_width,
                            channel_shape=channel_shape, channel_height=channel_height, medium=medium,
                            temperature=temperature, flow_index=flow_index, extrapolate=extrapolate,
                            coarse_resolution=coarse_resolution, stiffness_ratio=stiffness_ratio,
                            size_ratio=size_ratio, channel_length=channel_length,
                            hydrodynamic_radius_correction=hydrodynamic_radius_correction,
                            channel_wall=channel_wall, volume_correction=volume_correction)
    lattice = check_lattice(points)
    identifier = identifier or f"elastocell-{out.stem}"
    runs = runs_directory(out)
    with output_directory(runs, "out"):  # one LUT computation at a time in its runs directory
        start = time.perf_counter()
        records, failures = [], []
        tasks = [(point, str(runs)) for point in points]
        dtype = PipeFlowParameters.model_fields["dtype"].default  # the runs' LB storage precision
        for index, outcome in run_tasks(run_point, tasks, scheduler=scheduler, workers=workers, progress=progress, security=security,
                                        prepare=lambda: compile_kernels((dtype,)),
                                        description="LUT grid", client=client):
            if isinstance(outcome, TaskFailure):
                failures.append({"key": points[index]["key"], "error": str(outcome)})
            else:
                records.append(outcome)
        records.sort(key=lambda r: (r["emodulus_kpa"], r["radius_um"]))
        metadata = lut_metadata(settings, identifier)
        hull_outline = [r["key"] for r in records if r.get("outline_fallback", 0.0) > 0]
        rows = [r for r in records if r["key"] not in hull_outline]  # a reading on the hull is not the shape
        not_stationary = [r["key"] for r in rows if point_state(r) == "cap"]
        drifted = [r["key"] for r in rows if (r.get("volume_change_max_abs") or 0.0) > VOLUME_DRIFT]
        single = [p["key"] for p in points if settings["coarse_resolution"] is not None
                  and p["options"].get("extrapolate") is False]
        metadata["elastocell"] = {**settings, "points": len(points), "finished": len(records),
                                  "failed": [f["key"] for f in failures], "not_stationary": not_stationary,
                                  "not_extrapolated": single, "outline_fallback": hull_outline,
                                  "point_states": {r["key"]: point_state(r) for r in records}}
        if drifted:  # said only where there is something to say: the metadata of tables without it stay as they were
            metadata["elastocell"]["volume_drift"] = drifted
        result = {"lut": str(out), "isoelastics": str(isoelastics_path(out)), "runs": str(runs),
                  "records": records, "failures": failures, "wall_time_s": time.perf_counter() - start,
                  "identifier": identifier, "settings": settings, "lattice": lattice, "not_stationary": not_stationary,
                  "outline_fallback": hull_outline, "volume_drift": drifted}
        if rows:
            planned = ([p["radius_um"] for p in points], [p["emodulus_kpa"] for p in points])
            refined = refined_rows(rows, subdivisions, planned)
            metadata["elastocell"]["rows"] = {"computed": len(rows), "interpolated": len(refined) - len(rows),
                                              "subdivisions": subdivisions, "method": REFINE_METHOD}
            write_lut(out, refined, metadata)
            write_isoelastics(isoelastics_path(out), rows, metadata)
        return result
