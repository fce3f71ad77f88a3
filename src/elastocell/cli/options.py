"""Every option of the command line, declared once: name, type, default, help, units.

:data:`OPTIONS` maps each parameter name to its :class:`Opt` (the option's ``--name``, type, default, help and
units). A command lists the options it takes with :func:`takes`, by name, as a variant of a declared option
(:func:`opt`, for a command-specific default or help) or as a :class:`Group` (the CELL OPTIONS, passed to the
command as one dict). :data:`OPTION_NAMES` (parameter -> ``--option``, for error messages) is read from
:data:`OPTIONS`, so a variant can change a default or a help, never the name.

Every option's help ends with its units (``Units: ...``, or for a quantity what a bare number is in: one rule,
:data:`elastocell.parameters.units.BARE_UNITS`) and its default (``[default: ...]``, in parentheses when it is
described rather than literal).
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

import typer

from elastocell.parameters.cell import DEFAULT_MESH_SIZES
from elastocell.parameters.units import BARE_UNITS, MODULUS_SCALE, RADIUS_SCALE, parse_quantity


class NucleusShape(str, Enum):
    none = "none"
    sphere = "sphere"
    ellipsoid = "ellipsoid"


class AxisName(str, Enum):
    x = "x"
    y = "y"
    z = "z"


class Backend(str, Enum):
    numba = "numba"
    jax = "jax"


class Precision(str, Enum):
    float32 = "float32"
    float64 = "float64"


class ChannelShape(str, Enum):
    cylinder = "cylinder"
    square = "square"
    rectangle = "rectangle"


class ChannelWall(str, Enum):
    staircase = "staircase"
    interpolated = "interpolated"


class VolumeCorrection(str, Enum):
    none = "none"
    projection = "projection"


class StationaryObservable(str, Enum):
    strain_axial = "strain_axial"
    deformation = "deformation"


REQUIRED = ...


@dataclass(frozen=True)
class Opt:
    """One option (or argument) of the command line.

    quantity: the SI unit of a physical quantity (a key of BARE_UNITS); the option takes a string such as
    ``8um`` and a bare number is in that quantity's documented unit, or dimensionless in ``scale``.
    units: the units of a plain number option. shown: what a ``None`` default (or an off flag) means, shown as
    the default. listed: a comma-separated list of quantities. words: values accepted besides a quantity.
    """

    name: str
    annotation: Any
    default: Any
    help: str
    flag: str | None = None
    quantity: str | None = None
    scale: str | None = None
    units: str | None = None
    shown: str | None = None
    listed: bool = False
    words: tuple[str, ...] = ()
    argument: bool = False

    @property
    def option(self) -> str:
        """The name on the command line: ``--stiffness-ratio`` (an argument: ``NAME``; an on/off pair such as
        ``--extrapolate/--no-extrapolate``: its first name)."""
        if self.argument:
            return self.name.upper()
        return (self.flag or "--" + self.name.replace("_", "-")).split("/")[0]

    def but(self, **changes) -> Opt:
        """The same option with another default, help or units (never another name)."""
        if {"name", "flag", "argument"} & changes.keys():
            raise ValueError(f"{self.option}: a variant keeps the declared name")
        return dataclasses.replace(self, **changes)

    def help_text(self) -> str:
        text = self.help
        if self.quantity is not None:
            kind = BARE_UNITS[self.quantity]
            if self.scale is not None:
                bare = f"a bare number is dimensionless, in {self.scale}"
            else:
                bare = f"a bare number is in {kind.bare}"
            what = "Comma-separated quantities like" if self.listed else "A quantity like"
            text += f" {what} {kind.example}; {bare}."
        elif self.units is not None:
            text += f" Units: {self.units}."
        return text

    def parameter(self) -> inspect.Parameter:
        if self.argument:
            info = typer.Argument(self.default, help=self.help_text(), show_default=False)
        else:
            if self.default is None or self.default is False:
                if self.shown is None:
                    raise ValueError(f"{self.option}: say what its default means (shown=...)")
                show = self.shown
            else:
                show = True
            info = typer.Option(self.default, self.flag or self.option, help=self.help_text(), show_default=show)
        return inspect.Parameter(self.name, inspect.Parameter.KEYWORD_ONLY, default=info, annotation=self.annotation)


@dataclass(frozen=True)
class Group:
    """Options passed to the command as one dict, keyword ``name`` (``cell``: the CELL OPTIONS)."""

    name: str
    options: tuple[Opt, ...]

    def but(self, *variants: Opt, without: tuple[str, ...] = ()) -> Group:
        """The group with some options replaced by variants (same names) and some left out."""
        replaced = {v.name: v for v in variants}
        return Group(self.name, tuple(replaced.get(o.name, o) for o in self.options if o.name not in without))


def _declare(*options: Opt) -> dict[str, Opt]:
    table: dict[str, Opt] = {}
    for option in options:
        if option.name in table:
            raise ValueError(f"{option.option} declared twice")
        if (option.annotation in (float, float | None) or option.quantity) and not (
                option.units or option.quantity or option.argument):
            raise ValueError(f"{option.option}: a number needs its units")
        table[option.name] = option
    return table


_P2, _P1 = DEFAULT_MESH_SIZES["p2"], DEFAULT_MESH_SIZES["p1"]
_DIMENSIONLESS = "dimensionless"

OPTIONS: dict[str, Opt] = _declare(
    # ---------------------------------------------------------------- shared
    Opt("out", Path, REQUIRED, "Output directory."),
    Opt("quiet", bool, False, "No progress bar, no summary.", shown="off"),
    Opt("as_json", bool, False, "Print JSON.", flag="--json", shown="off"),
    Opt("quick", bool, False, "Coarse meshes and lattices: every study in minutes on a laptop (not converged).",
        shown="off"),
    Opt("scheduler", str | None, None, "Address of a running Dask scheduler (tcp://host:8786; tls://host:8786 "
        "takes its TLS files from DASK_DISTRIBUTED__COMM__TLS__CA_FILE, __CLIENT__CERT, __CLIENT__KEY). A scheduler "
        "runs the code it is sent: connect only to one you trust. See docs/usage/cluster.md.",
        shown="a local cluster"),
    Opt("workers", int | None, None, "Worker processes of the local Dask cluster.", shown="one per core"),
    Opt("backend", Backend, Backend.numba, "Compute engine: numba (fused CPU kernels, fastest on a CPU) or jax (the "
        "same physics on JAX's default device: a GPU when JAX has CUDA)."),
    # ---------------------------------------------------------------- CELL OPTIONS
    Opt("nucleus", NucleusShape, NucleusShape.sphere, "Inclusion shape."),
    Opt("stiffness_ratio", float, 2.0, "gamma = E_n/E_c (> 0).", units=_DIMENSIONLESS),
    Opt("size_ratio", float, 0.5, "lambda = R_n/R in (0, 1) (sphere).", units=_DIMENSIONLESS),
    Opt("offset", float, 0.0, "d: nucleus centre offset (lambda + d < 1).", units="R, the cell radius"),
    Opt("offset_axis", AxisName, AxisName.x, "Axis of the offset (plates are normal to z)."),
    Opt("semi_axes", tuple[float, float, float], (0.8, 0.4, 0.4),
        "Ellipsoid semi-axes A B C; A along --nucleus-axis.", units="R"),
    Opt("nucleus_axis", AxisName, AxisName.x, "Direction of the ellipsoid's first semi-axis."),
    Opt("random", bool, False, "Random cell: gamma_i ~ U[1, 10] per tetrahedron.", shown="off"),
    Opt("seed", int | None, None, "Seed of the random cell (needs --random).", shown="0"),
    Opt("mesh_size", float | None, None, "Element size far from the poles.", units="R",
        shown=f"{_P2['mesh_size']:g} for p2, {_P1['mesh_size']:g} for p1"),
    Opt("pole_size", float | None, None, "Element size at the plate contacts.", units="R",
        shown=f"{_P2['pole_size']:g} for p2, {_P1['pole_size']:g} for p1, or --mesh-size if finer"),
    Opt("interface_size", float | None, None, "Element size on the nucleus surface.", units="R",
        shown=f"{_P2['interface_size']:g} x --mesh-size/{_P2['mesh_size']:g} for p2, uniform for p1"),
    Opt("poisson_ratio", float, 0.48, "nu in (-1, 0.5).", units=_DIMENSIONLESS),
    Opt("youngs_modulus", str, "1", "E_c, the cytoplasm's Young's modulus (the default 1: results in units of E_c).",
        quantity="Pa", scale=MODULUS_SCALE),
    Opt("radius", str, "1", "R, the cell radius (the default 1: results in units of R).", quantity="m",
        scale=RADIUS_SCALE),
    Opt("material", str, "neo-hookean", "neo-hookean | mooney-rivlin."),
    Opt("element", str, "p2", "p2 (10-node, default) | p1 (4-node, the paper's)."),
    Opt("quadrature_degree", int | None, None, "p2 only: degree of the quadrature rule, 2 (4 points) to 9. 5: 25 "
        "points that include the nodes, so that no element folds at a node in a crushed soft layer, at about "
        "twice the time of a degree-2 curve.",
        shown="5 for a neo-Hookean cell whose nucleus is at least 5.5 times stiffer than the cytoplasm, else 2"),
    Opt("volumetric", str, "standard", "How J = det F enters the law. standard: at each quadrature point; p2: "
        "projected: L2-projected onto linear polynomials per element and the law evaluated on "
        "(J_bar/J)^(1/3) F (F-bar, relieves the volumetric locking of a crushed soft layer; needs a quadrature "
        "degree above 2); mean: the element's mean dilatation; p1, flows only: nodal: the volumetric part per "
        "node, from the volumes of its elements (the averaged nodal dilatation: linear tetrahedra that do not "
        "lock)."),
    # ---------------------------------------------------------------- compress
    Opt("delta_max", float, 0.75, "Final deformation delta = 1 - h/(2R) in (0, 1).", units=_DIMENSIONLESS),
    Opt("steps", int, 40, "Load steps (output rows after delta = 0)."),
    Opt("equivalent", bool, False, "Simulate the homogeneous equivalent instead.", shown="off"),
    Opt("compare", bool, False, "Also simulate the equivalent; write comparison.csv/png.", shown="off"),
    Opt("axisymmetric", bool, False, "Solve the body of revolution in its meridian plane (a cell symmetric about "
        "the plate normal; its own mesh, no VTK).", shown="off"),
    # ---------------------------------------------------------------- flows (shear, pipe)
    Opt("capillary_number", float | None, None, "Ca = eta*shear_rate/mu_c (mu_eff with --equivalent).",
        units=_DIMENSIONLESS, shown="required, or --viscosity with --shear-rate"),
    Opt("resolution", float, 8.0, "R/dx, lattice nodes per cell radius.", units="lattice nodes per R"),
    Opt("extrapolate", bool, True, "Also run --coarse-resolution (in DIR/resolution-<R/dx>/, beside "
        "DIR/resolution-<--resolution>/) and report the stationary values Richardson-extrapolated to dx -> 0 "
        "(order 2), with both resolutions' values and the size of the correction.",
        flag="--extrapolate/--no-extrapolate"),
    Opt("hold_flow_rate", bool, True, "Hold the flow rate at that of the nominal pressure gradient in the ideal "
        "channel (as RT-DC's syringe pump and dclab's tables), rescaling the body force after every record; "
        "--no-hold-flow-rate holds the pressure gradient instead (a periodic channel then slows behind the cell).",
        flag="--hold-flow-rate/--no-hold-flow-rate"),
    Opt("hydrodynamic_radius_correction", float, 0.0, "Place the markers on a sphere of radius R - c dx, so that "
        "the body the fluid sees (larger than the marker surface by about a kernel's reach) has radius R.",
        units="dx"),
    Opt("coarse_resolution", float | None, None, "R/dx of the cheaper run of --extrapolate; below --resolution.",
        units="lattice nodes per R", shown="6, when --resolution is above 6 (else no extrapolation)"),
    Opt("duration", float, 6.0, "Run length.", units="strain, shear_rate*t"),
    Opt("confinement", float, 0.2, "2R/H, cell diameter over the wall distance.", units=_DIMENSIONLESS),
    Opt("viscosity", str | None, None, "eta of the medium, with --shear-rate and a physical --youngs-modulus "
        "instead of --capillary-number.", quantity="Pa*s", shown="none: give --capillary-number"),
    Opt("shear_rate", str | None, None, "Shear rate of the flow.", quantity="1/s",
        shown="none: give --capillary-number"),
    Opt("wall_clock", float | None, None, "Stop after this wall-clock time.", units="s", shown="no limit"),
    Opt("stationary_tolerance", float | None, None, "Stop when the running mean of D changes less than this "
        "fraction.", units=_DIMENSIONLESS, shown="off: run the whole --duration"),
    Opt("record_interval", float, 0.05, "Strain between records.", units="strain, shear_rate*t"),
    Opt("checkpoint_every", int, 20, "Records between checkpoints."),
    Opt("vtk_interval", float, 1.0, "Strain between VTK snapshots.", units="strain, shear_rate*t"),
    Opt("resume", bool, False, "Continue from DIR/checkpoint.npz (same options).", shown="off"),
    Opt("capillary_number_wall", float | None, None, "Ca_w = G*R_ch/(2*mu_c) (mu_eff with --equivalent).",
        units=_DIMENSIONLESS, shown="required, or --pressure-gradient"),
    Opt("channel_radius_ratio", float, 2.0, "R_ch/R, channel over cell radius (> 1).", units=_DIMENSIONLESS),
    Opt("start_offset", float, 0.0, "r0/R_ch, initial distance of the cell from the axis.", units="R_ch"),
    Opt("pressure_gradient", str | None, None, "G, with a physical --radius and --youngs-modulus instead of "
        "--capillary-number-wall (with --hold-flow-rate, the flow rate G drives through the ideal channel is held).", quantity="Pa/m", shown="none: give --capillary-number-wall"),
    Opt("channel_shape", ChannelShape | None, None, "Cross-section: cylinder | square | rectangle (a duct of width "
        "W = 2 R_ch and height H, plane walls; RT-DC chips are square).",
        shown="square with --channel-width, rectangle with a different --channel-height, else cylinder"),
    Opt("channel_wall", ChannelWall, ChannelWall.interpolated, "How the lattice places a cylinder's wall: "
        "interpolated (interpolated bounce-back, the wall at R_ch on every link: the empty channel's profile error "
        "at most 0.3-1.0 % instead of 3.8-6.2 % of u_max) | staircase (bounce-back half-way to the nodes outside R_ch, the only "
        "wall of earlier versions). A duct's walls are the same either way."),
    Opt("volume_correction", VolumeCorrection, VolumeCorrection.none, "How the cell's volume is kept: none (the "
        "markers move with the fluid alone; the immersed boundary leaks, and a soft cell's volume drifts by up to "
        "several %) | projection (after every step the surface markers are moved back to the undeformed volume "
        "along its gradient; no force is added; the summary's volume_restored says how much it restored)."),
    Opt("channel_aspect_ratio", float | None, None, "H/W of a rectangular channel.", units=_DIMENSIONLESS,
        shown="1, or --channel-height/--channel-width"),
    Opt("channel_height", str | None, None, "Height H of a rectangular channel (with --channel-width).",
        quantity="m", shown="--channel-width: a square"),
    Opt("medium", str, "newtonian", "Suspending medium: newtonian | 0.49%MC-PBS | 0.59%MC-PBS | 0.83%MC-PBS (RT-DC "
        "buffers: shear-thinning power laws of Buyukurganci et al. 2022, as dclab) | power-law (with --flow-index)."),
    Opt("temperature", str | None, None, "Temperature of an MC-PBS medium (fit: 22-37 degC): 23degC, 23°C and "
        "296.15K are the same.", quantity="degC", shown="23degC"),
    Opt("flow_index", float | None, None, "Power-law index n of --medium power-law (eta ~ shear_rate^(n-1)).",
        units=_DIMENSIONLESS, shown="none"),
    Opt("channel_length", str | None, None, "Length L of a finite channel (RT-DC chips: about 300um, measured near "
        "the outlet): the cell starts undeformed at the inlet and is measured when it has travelled L (its own axial "
        "speed integrated over time); --duration is then the cap.", quantity="m",
        shown="none: the stationary state"),
    Opt("stationary_observable", StationaryObservable, StationaryObservable.strain_axial,
        "Observable of the stationary stop: strain_axial | deformation."),
    # ---------------------------------------------------------------- bench lattice
    Opt("size", int, 128, "Lattice size N (N^3 nodes, periodic); lattice nodes per side."),
    Opt("dtype", Precision, Precision.float32, "Population storage precision."),
    Opt("no_cell", bool, False, "Skip the run with an immersed cell.", shown="off"),
    Opt("threads", int | None, None, "Numba threads.", shown="all"),
    # ---------------------------------------------------------------- indent (and fit afm --geometry sphere-indenter)
    Opt("cell_shape", str, "sphere", "sphere (a suspended cell resting on the dish) | cap (an adherent cell: a "
        "spherical cap of base radius --radius and apex height --cap-height bonded to the dish) | layer (a tissue "
        "section or gel of thickness --layer-thickness bonded to the dish)."),
    Opt("indenter_radius", str, REQUIRED, "R_b, the radius of the spherical indenter (bead).", quantity="m",
        scale=RADIUS_SCALE),
    Opt("indenter", str, "sphere", "sphere (a bead of radius --indenter-radius) | cone (a sharp tip of half-angle "
        "--half-angle; axisymmetric solver) | pyramid (four-sided, face half-angle --half-angle, as the cone of the "
        "same cross-section area)."),
    Opt("half_angle", str | None, None, "Half-angle of the cone (axis to flank) or the pyramid's face half-angle "
        "(--indenter cone|pyramid).", quantity="deg", shown="required with --indenter cone|pyramid"),
    Opt("cap_height", str | None, None, "H, apex height of the cap (--cell-shape cap).", quantity="m",
        scale=RADIUS_SCALE, shown="--radius: a hemisphere"),
    Opt("layer_thickness", str | None, None, "h, thickness of the layer (--cell-shape layer).", quantity="m",
        scale=RADIUS_SCALE, shown="required with --cell-shape layer"),
    Opt("depth_max", float, 0.3, "Final indentation depth (indenter displacement after first contact).",
        units="R, the cell radius (the layer: R_b; under a cone or pyramid: h, its thickness)"),
    Opt("solver", str, "auto", "auto (the axisymmetric solver for a cell symmetric about z, the 3D tetrahedral cell "
        "for any other suspended sphere: random, offset nucleus, tilted ellipsoid) | 3d (--cell-shape sphere only; "
        "the mesh options apply) | axisymmetric."),
    # ---------------------------------------------------------------- mastercurve
    Opt("no_cache", bool, False, "Recompute even if shipped or cached.", shown="off"),
    # ---------------------------------------------------------------- fit afm
    Opt("files", list[Path], REQUIRED, "Curves: plain CSV (columns displacement in m, force in N) or afmformats "
        "files; a folder contributes its files.", argument=True),
    Opt("geometry", str, "parallel-plates", "parallel-plates (or plates) | sphere-indenter (a bead of radius "
        "--indenter-radius pressed into the cell on a dish; the x-axis is the bead's depth) | cone (a sharp tip of "
        "--half-angle on a layer, --cell-shape layer) | pyramid (a four-sided pyramid of face half-angle "
        "--half-angle on a layer, fitted as its area-equivalent cone)."),
    Opt("spring_constant", str | None, None, "Cantilever spring constant k: overrides the file's or supplies a "
        "missing one (force = k x deflection; afmformats recomputes it from the raw signal).", quantity="N/m",
        shown="the file's"),
    Opt("sensitivity", str | None, None, "Deflection sensitivity (InvOLS): overrides the file's or supplies a "
        "missing one (deflection = sensitivity x detector signal; NT-MDT: nm/nA).", quantity="m/V",
        shown="the file's"),
    Opt("model", str, "both", "master | hertz | both (master is youngs_modulus)."),
    Opt("contact_point", str, "auto", "auto, or the contact point's displacement.", quantity="m", words=("auto",)),
    Opt("bootstrap", int, 0, "Residual-bootstrap replicas for a second CI."),
    Opt("nucleus_size_ratio", float | None, None,
        "lambda: also fit E_c to the cell with its nucleus (axisymmetric solver, seconds, cached) and convert E "
        "(needs --stiffness-ratio).",
        units=_DIMENSIONLESS, shown="none: homogeneous"),
    Opt("baseline_fraction", float, 0.2, "Share of the approach for the baseline.", units=_DIMENSIONLESS),
    Opt("threshold", float, 5.0, "Contact: force above threshold*sigma of the baseline.",
        units="standard deviations of the baseline"),
    Opt("baseline_tilt", bool, False, "Subtract a sloped baseline (default: offset).", shown="off"),
    Opt("no_plots", bool, False, "Skip the per-curve PNGs (faster for many curves).", shown="off"),
    Opt("lut", list[str], REQUIRED, "Look-up table(s) of RT-DC: LE-2D-FEM-19 | HE-2D-FEM-22 | HE-3D-FEM-22 (dclab's), "
        "the identifier of a table elastocell ships (elastocell shipped-luts lists them), or a file in dclab's text "
        "format (elastocell lut writes one); repeat the option for several."),
    # ---------------------------------------------------------------- fit shear
    Opt("deformation", float | None, None, "Stationary Taylor deformation D = (a-b)/(a+b).",
        units=_DIMENSIONLESS, shown="none: give --table"),
    Opt("shear_stress", str | None, None, "tau = eta * shear rate.", quantity="Pa", shown="none: give --table"),
    Opt("deformation_error", float, 0.0, "Standard uncertainty of D (1 sigma).", units=_DIMENSIONLESS),
    Opt("shear_stress_error", str, "0", "Standard uncertainty of tau (1 sigma).", quantity="Pa"),
    Opt("tank_treading_frequency", str | None, None, "Angular frequency, rad/s (Hz is converted x 2 pi); needs "
        "--shear-rate. A second, independent estimate.", quantity="1/s", shown="none"),
    Opt("tank_treading_frequency_error", str, "0", "Its standard uncertainty (angular, rad/s).", quantity="1/s"),
    Opt("table", Path | None, None, "CSV of cells: deformation, shear_stress (Pa), optional deformation_error, "
        "shear_stress_error, tank_treading_frequency (rad/s), shear_rate (1/s), radius (um), cell; a bare "
        "number in a column is in that unit.", shown="none: one cell from the options"),
    Opt("confidence", float, 0.95, "Confidence level of the intervals.", units=_DIMENSIONLESS),
    # ---------------------------------------------------------------- lut
    Opt("channel_radius", str | None, None, "Radius R_ch of the cylindrical channel. Give this or "
        "--channel-width. The table is labelled for the square channel of width 2 R_ch/1.094.", quantity="m",
        shown="none: give --channel-width"),
    Opt("channel_width", str | None, None, "Width W of a square RT-DC channel: the cylinder R_ch = 1.094 W/2 "
        "stands for it (Mietke et al. 2015; dclab's LE-2D-FEM-19).", quantity="m",
        shown="none: give --channel-radius"),
    Opt("flow_rate", str, REQUIRED, "Flow rate Q.", quantity="m^3/s"),
    Opt("radii", str | None, None, "Cell radii.", quantity="m", listed=True, shown="3,4,5,6,7,8 um; --quick: 5,6 um"),
    Opt("moduli", str | None, None, "Young's moduli.", quantity="Pa", listed=True,
        shown="0.5,0.75,1,1.5,2,3,5 kPa; --quick: 1,2 kPa"),
    Opt("identifier", str | None, None, "LUT identifier for dclab.", shown="elastocell-<stem of --out>"),
    Opt("subdivisions", int, 8, "Rows per grid interval written between the computed points: ln area and ln deform "
        "bilinear in ln R and ln E within each grid cell whose four corners were computed (dclab reads a table "
        "linearly in area and deform, which between the grid's points overstates E by several per cent); 1: the "
        "computed points alone. The isoelastics are the computed points'.", units=_DIMENSIONLESS),
    # ---------------------------------------------------------------- study
    Opt("name", str, REQUIRED, "Study name (see `elastocell study list`).", argument=True),
    Opt("directory", Path, REQUIRED, "The --out directory of `study run`.", argument=True),
)

# parameter name -> its name on the command line, for one-line errors
OPTION_NAMES: dict[str, str] = {name: option.option for name, option in OPTIONS.items()}


def opt(name: str, **changes) -> Opt:
    """The declared option ``name``, with a command's own default, help or units."""
    return OPTIONS[name].but(**changes) if changes else OPTIONS[name]


CELL = Group("cell", tuple(OPTIONS[name] for name in (
    "nucleus", "stiffness_ratio", "size_ratio", "offset", "offset_axis", "semi_axes", "nucleus_axis", "random",
    "seed", "mesh_size", "pole_size", "interface_size", "poisson_ratio", "youngs_modulus", "radius", "material",
    "element", "quadrature_degree", "volumetric")))

# the flow scenarios' cell: uniform linear tetrahedra of edge 2 dx unless given
FLOW_CELL = CELL.but(
    opt("mesh_size", help="Element size.", shown="2 dx, uniform"),
    opt("pole_size", help="Element size at the poles.", shown="uniform"),
    opt("interface_size", help="Element size on the nucleus surface.", shown="uniform"),
    opt("element", default="p1", help="p1 (4-node, the paper's; flow default) | p2 (10-node)."),
    opt("volumetric", help="How J = det F enters the law. standard: at each point; p1: nodal: the volumetric part "
        "per node, from the volumes of its elements (the averaged nodal dilatation: linear tetrahedra that do not "
        "lock); p2: mean: the element's mean dilatation, projected: J projected onto linear polynomials per "
        "element (no compiled kernel: runs on the JAX backend)."),
    without=("quadrature_degree",))


def takes(*items: str | Opt | Group):
    """Give the decorated command the options ``items`` (in this order on its --help): names of :data:`OPTIONS`,
    variants (:func:`opt`) or groups (one dict keyword argument named after the group). Every quantity option
    given is parsed before the command runs (:func:`~elastocell.parameters.units.parse_quantity`, a
    ParameterError naming it), so an impossible one is refused even where the command would not use it; the
    command receives the string as typed (the Python API parses it with the same rule)."""
    options: list[Opt] = []
    groups: list[Group] = []
    for item in items:
        if isinstance(item, Group):
            groups.append(item)
            options.extend(item.options)
        else:
            options.append(OPTIONS[item] if isinstance(item, str) else item)
    names = [o.name for o in options]
    if len(set(names)) != len(names):
        raise ValueError(f"an option given twice in {names}")

    quantities = [o for o in options if o.quantity is not None and not o.listed]

    def decorate(function):
        @functools.wraps(function)
        def command(**values):
            for option in quantities:  # refuse an impossible quantity before any work, whether used or not
                value = values[option.name]
                if value is not None and str(value).strip().lower() not in option.words:
                    parse_quantity(value, option.quantity, option.name, scale=option.scale)
            for group in groups:
                values[group.name] = {o.name: values.pop(o.name) for o in group.options}
            return function(**values)

        parameters = [o.parameter() for o in options]
        command.__signature__ = inspect.Signature(parameters)
        command.__annotations__ = {p.name: p.annotation for p in parameters}
        return command

    return decorate


def plain(value):
    """An Enum option's value (``NucleusShape.sphere`` -> ``"sphere"``), other values as they are."""
    return value.value if isinstance(value, Enum) else value
