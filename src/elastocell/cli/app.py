"""Command line: ``elastocell compress``, ``elastocell equivalent`` (names shared with the Python API).

A user error (impossible input) exits with code 2 and one line naming the parameter and its allowed
range, before any meshing; never a traceback.
"""

from __future__ import annotations

import json
import sys
from enum import Enum
from pathlib import Path

import typer

from elastocell.cli.common import OPTION_NAMES, user_errors
from elastocell.cli.fit import fit_app, mastercurve_app
from elastocell.cli.lut import lut
from elastocell.cli.study import reproduce, study_app
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.flow import shear_mesh_size
from elastocell.parameters.units import ParameterError, parse_quantity

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="elastocell: mechanics of living cells (AFM plate compression; homogeneous equivalents).")

class NucleusShape(str, Enum):
    none = "none"
    sphere = "sphere"
    ellipsoid = "ellipsoid"


class AxisName(str, Enum):
    x = "x"
    y = "y"
    z = "z"


def _cell_options(nucleus, stiffness_ratio, size_ratio, offset, offset_axis, semi_axes, nucleus_axis, random, seed,
                  mesh_size, pole_size, element, material, poisson_ratio, youngs_modulus, radius,
                  interface_size=None, quadrature_degree=None):

    return cell_parameters(
        nucleus=nucleus.value if isinstance(nucleus, Enum) else nucleus, stiffness_ratio=stiffness_ratio,
        size_ratio=size_ratio, offset=offset, offset_axis=getattr(offset_axis, "value", offset_axis),
        semi_axes=tuple(semi_axes), nucleus_axis=getattr(nucleus_axis, "value", nucleus_axis), random=random,
        seed=seed, mesh_size=mesh_size, pole_size=pole_size, interface_size=interface_size, element=element,
        quadrature_degree=quadrature_degree, material=material,
        poisson_ratio=poisson_ratio, youngs_modulus=youngs_modulus, radius=radius,
    )


# Shared CELL OPTIONS (typer needs them spelled out per command)
NUCLEUS = typer.Option(NucleusShape.sphere, "--nucleus", help="Inclusion shape.")
STIFFNESS = typer.Option(2.0, "--stiffness-ratio", help="gamma = E_n/E_c (> 0).")
SIZE = typer.Option(0.5, "--size-ratio", help="lambda = R_n/R in (0, 1) (sphere).")
OFFSET = typer.Option(0.0, "--offset", help="d: nucleus centre offset in units of R (lambda + d < 1).")
OFFSET_AXIS = typer.Option(AxisName.x, "--offset-axis", help="Axis of the offset (plates are normal to z).")
SEMI_AXES = typer.Option((0.8, 0.4, 0.4), "--semi-axes", help="Ellipsoid semi-axes A B C in units of R; A along --nucleus-axis.")
NUCLEUS_AXIS = typer.Option(AxisName.x, "--nucleus-axis", help="Direction of the ellipsoid's first semi-axis.")
RANDOM = typer.Option(False, "--random", help="Random cell: gamma_i ~ U[1, 10] per tetrahedron.")
SEED = typer.Option(0, "--seed", help="Seed of the random cell.")
MESH_SIZE = typer.Option(None, "--mesh-size", help="Element size far from the poles (units of R).")
POLE_SIZE = typer.Option(None, "--pole-size", help="Element size at the plate contacts (units of R).")
INTERFACE_SIZE = typer.Option(None, "--interface-size", help="Element size on the nucleus surface (units of R).")
POISSON = typer.Option(0.48, "--poisson-ratio", help="nu in (-1, 0.5).")
MODULUS = typer.Option("1", "--youngs-modulus", help="E_c, e.g. 1kPa (plain number: dimensionless).")
RADIUS = typer.Option("1", "--radius", help="R, e.g. 8um (plain number: dimensionless).")
MATERIAL = typer.Option("neo-hookean", "--material", help="neo-hookean | mooney-rivlin.")
ELEMENT = typer.Option("p2", "--element", help="p2 (10-node, default) | p1 (4-node, the paper's).")
QUADRATURE = typer.Option(None, "--quadrature-degree", help="p2 only: degree of the quadrature rule, 2 (4 points) "
                          "to 9. 5: 25 points that include the nodes, so that no element folds at a node in a crushed "
                          "soft layer, at about twice the time of a degree-2 curve. Default: 5 for a neo-Hookean cell "
                          "whose nucleus is at least 7 times stiffer than the cytoplasm, else 2.")
# options shared by the flow scenarios (shear, pipe)
FLOW_MESH_SIZE = typer.Option(None, "--mesh-size", help="Element size (units of R); default: 2 dx, uniform.")
FLOW_POLE_SIZE = typer.Option(None, "--pole-size", help="Element size at the poles; default: uniform.")
FLOW_INTERFACE_SIZE = typer.Option(None, "--interface-size", help="Element size on the nucleus surface; default: uniform.")
FLOW_ELEMENT = typer.Option("p1", "--element", help="p1 (4-node, the paper's; flow default) | p2 (10-node).")
FLOW_RESOLUTION = typer.Option(8.0, "--resolution", help="R/dx, lattice nodes per cell radius.")
WALL_CLOCK = typer.Option(None, "--wall-clock", help="Stop after this many seconds.")
CHECKPOINT_EVERY = typer.Option(20, "--checkpoint-every", help="Records between checkpoints.")
RESUME = typer.Option(False, "--resume", help="Continue from DIR/checkpoint.npz (same options).")
QUIET = typer.Option(False, "--quiet", help="No progress bar, no summary.")


class Backend(str, Enum):
    numba = "numba"
    jax = "jax"


BACKEND = typer.Option(Backend.numba, "--backend", help="Compute engine: numba (fused CPU kernels, fastest on a "
                       "CPU) or jax (the same physics on JAX's default device: a GPU when JAX has CUDA).")


def _warn_curves(summary: dict, name: str = "cell") -> None:
    """One warning line per curve and per problem found in its metadata: quadratic elements folded at a node
    (``solver.first_folded_delta``, see ``compression.min_nodal_jacobian``), and material that has lost half its
    volume somewhere (``solver.first_half_volume_delta``, see ``compression.min_volume_ratio``)."""
    curves = [(name, summary.get("solver", {}))]
    if "equivalent_summary" in summary:
        curves.append(("equivalent", summary["equivalent_summary"].get("solver", {})))
    for label, solver in curves:
        if solver.get("first_folded_delta") is not None:
            typer.echo(f"warning ({label}): quadratic elements folded at a node from delta = "
                       f"{solver['first_folded_delta']:.3f} on (min nodal det ratio {solver['min_nodal_jacobian']:.2f}); "
                       "the force there is an equilibrium of the discrete energy, check it on a finer mesh", err=True)
        if solver.get("first_half_volume_delta") is not None:
            typer.echo(f"warning ({label}): the material has lost half its volume somewhere from delta = "
                       f"{solver['first_half_volume_delta']:.3f} on (smallest J = det F {solver['min_volume_ratio']:.2f}): "
                       "the law's pressure cannot exceed its bulk modulus E/(3(1-2nu)), so a layer pressed harder "
                       "collapses in volume, which a water-filled cytoplasm would not", err=True)


@app.command()
@user_errors
def compress(
    out: Path = typer.Option(..., "--out", help="Output directory."),
    nucleus: NucleusShape = NUCLEUS, stiffness_ratio: float = STIFFNESS, size_ratio: float = SIZE,
    offset: float = OFFSET, offset_axis: AxisName = OFFSET_AXIS, semi_axes: tuple[float, float, float] = SEMI_AXES,
    nucleus_axis: AxisName = NUCLEUS_AXIS, random: bool = RANDOM, seed: int = SEED,
    mesh_size: float | None = MESH_SIZE, pole_size: float | None = POLE_SIZE,  # noqa: UP007
    interface_size: float | None = INTERFACE_SIZE,  # noqa: UP007
    poisson_ratio: float = POISSON, youngs_modulus: str = MODULUS, radius: str = RADIUS,
    material: str = MATERIAL, element: str = ELEMENT,
    quadrature_degree: int | None = QUADRATURE,  # noqa: UP007
    delta_max: float = typer.Option(0.75, "--delta-max", help="Final deformation in (0, 1)."),
    steps: int = typer.Option(40, "--steps", help="Load steps (output rows after delta = 0)."),
    equivalent: bool = typer.Option(False, "--equivalent", help="Simulate the homogeneous equivalent instead."),
    compare: bool = typer.Option(False, "--compare", help="Also simulate the equivalent; write comparison.csv/png."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar, no summary."),
):
    """Quasistatic compression between two rigid frictionless plates (delta from 0 to --delta-max)."""
    from elastocell.api.compression import (
        compress as run,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )
    from elastocell.scenarios.compression import (  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
        CompressionError,
        CompressionParameters,
    )

    cell = _cell_options(nucleus, stiffness_ratio, size_ratio, offset, offset_axis, semi_axes, nucleus_axis, random,
                         seed, mesh_size, pole_size, element, material, poisson_ratio, youngs_modulus, radius,
                         interface_size, quadrature_degree)
    CompressionParameters(delta_max=delta_max, steps=steps)  # validate before meshing
    try:
        summary = run(out, cell=cell, delta_max=delta_max, steps=steps, equivalent=equivalent, compare=compare,
                      progress=not quiet and sys.stderr.isatty())
    except CompressionError as error:
        typer.echo(f"elastocell: compression failed: {error}", err=True)
        for name, path in (("cell", out / "metadata.json"), ("equivalent", out / "equivalent" / "metadata.json")):
            if path.exists():  # the rows that were written
                _warn_curves(json.loads(path.read_text()), name)
        raise typer.Exit(code=1) from None
    if not quiet:
        typer.echo(f"{summary['label']}: gamma_eff = {summary['effective_stiffness_ratio']:.4f}, "
                   f"{summary['mesh']['n_nodes']} nodes, curve in {summary['solver']['curve_time_s']:.1f} s -> {out}")
        _warn_curves(summary)
        if "equivalent_summary" in summary:
            typer.echo(f"equivalent: curve in {summary['equivalent_summary']['solver']['curve_time_s']:.1f} s; "
                       f"force ratios in {out / 'comparison.csv'}, plot {out / 'comparison.png'}")


@app.command()
@user_errors
def shear(
    out: Path = typer.Option(..., "--out", help="Output directory."),
    capillary_number: float | None = typer.Option(  # noqa: UP007
        None, "--capillary-number", help="Ca = eta*shear_rate/mu_c (mu_eff with --equivalent)."),
    nucleus: NucleusShape = NUCLEUS, stiffness_ratio: float = STIFFNESS, size_ratio: float = SIZE,
    offset: float = OFFSET, offset_axis: AxisName = OFFSET_AXIS, semi_axes: tuple[float, float, float] = SEMI_AXES,
    nucleus_axis: AxisName = NUCLEUS_AXIS, random: bool = RANDOM, seed: int = SEED,
    mesh_size: float | None = FLOW_MESH_SIZE,  # noqa: UP007
    pole_size: float | None = FLOW_POLE_SIZE,  # noqa: UP007
    interface_size: float | None = FLOW_INTERFACE_SIZE,  # noqa: UP007
    poisson_ratio: float = POISSON, youngs_modulus: str = MODULUS, radius: str = RADIUS,
    material: str = MATERIAL,
    element: str = FLOW_ELEMENT,
    equivalent: bool = typer.Option(False, "--equivalent", help="Simulate the homogeneous equivalent (Ca with mu_eff)."),
    resolution: float = FLOW_RESOLUTION,
    duration: float = typer.Option(6.0, "--duration", help="Run length in strain units shear_rate*t."),
    confinement: float = typer.Option(0.2, "--confinement", help="2R/H, cell diameter over the wall distance."),
    viscosity: str | None = typer.Option(None, "--viscosity", help="Physical eta (e.g. 1mPa*s), with --shear-rate and a physical --youngs-modulus instead of --capillary-number."),  # noqa: UP007
    shear_rate: str | None = typer.Option(None, "--shear-rate", help="Physical shear rate (e.g. 100/s)."),  # noqa: UP007
    wall_clock: float | None = WALL_CLOCK,  # noqa: UP007
    stationary_tolerance: float | None = typer.Option(  # noqa: UP007
        None, "--stationary-tolerance", help="Stop when the running mean of D changes less than this fraction."),
    record_interval: float = typer.Option(0.05, "--record-interval", help="Strain between records."),
    checkpoint_every: int = CHECKPOINT_EVERY,
    vtk_interval: float = typer.Option(1.0, "--vtk-interval", help="Strain between VTK snapshots."),
    resume: bool = RESUME,
    backend: Backend = BACKEND,
    quiet: bool = QUIET,
):
    """A cell in plane Couette (shear) flow: lattice Boltzmann fluid + immersed boundary."""
    from elastocell.api.shear import (
        shear as run,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )
    from elastocell.coupling.markers import (
        FlowError,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )
    from elastocell.scenarios.shear import (
        ShearFlowParameters,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )
    from elastocell.simulation.runner import (
        StopCriteria,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )

    mesh_size = mesh_size if mesh_size is not None else _shear_mesh(resolution)
    pole_size = pole_size if pole_size is not None else mesh_size  # uniform: no plate contacts to refine for
    interface_size = interface_size if interface_size is not None else mesh_size
    cell = _cell_options(nucleus, stiffness_ratio, size_ratio, offset, offset_axis, semi_axes, nucleus_axis, random,
                         seed, mesh_size, pole_size, element, material, poisson_ratio, youngs_modulus, radius,
                         interface_size)
    if (viscosity is None) != (shear_rate is None):
        raise ParameterError("viscosity", "give both --viscosity and --shear-rate, or neither")
    if viscosity is not None:
        if capillary_number is not None:
            raise ParameterError("capillary_number", "give --capillary-number or --viscosity/--shear-rate, not both")
        eta, _ = parse_quantity(viscosity, "Pa*s", "viscosity")
        rate, _ = parse_quantity(shear_rate, "1/s", "shear_rate")
        if not cell.youngs_modulus_is_physical:
            raise ParameterError("youngs_modulus", "give a physical --youngs-modulus (e.g. 1kPa) with --viscosity")
        capillary_number = 2 * (1 + poisson_ratio) * eta * rate / cell.youngs_modulus  # Ca with mu_c
    if capillary_number is None:
        raise ParameterError("capillary_number", "required (or --viscosity with --shear-rate)")
    flow_options = {"confinement": confinement, "backend": backend.value}
    ShearFlowParameters(capillary_number=capillary_number, resolution=resolution, **flow_options)  # validate early
    StopCriteria(duration=duration, wall_clock=wall_clock, stationary_tolerance=stationary_tolerance)
    try:
        summary = run(out, capillary_number, cell=cell, equivalent=equivalent, resolution=resolution,
                      duration=duration, resume=resume, progress=not quiet and sys.stderr.isatty(),
                      wall_clock=wall_clock, stationary_tolerance=stationary_tolerance,
                      record_interval=record_interval, checkpoint_every=checkpoint_every, vtk_interval=vtk_interval,
                      flow_options=flow_options, capillary_number_modulus="mu_c" if viscosity is not None else "reference")
    except FlowError as error:
        typer.echo(f"elastocell: shear flow failed: {error}", err=True)
        raise typer.Exit(code=1) from None
    if not quiet:
        typer.echo(f"{summary['label']}: Ca = {capillary_number:g}, D = {summary['taylor_deformation_mean']:.4f} "
                   f"+- {summary['taylor_deformation_std']:.1e}, inclination {summary['inclination_deg_mean']:.1f} deg, "
                   f"tank treading {summary['tank_treading_frequency']:.3f} shear_rate, strain "
                   f"{summary['duration_strain']:.2f} in {summary['wall_time_s']:.1f} s -> {out}")


def _shear_mesh(resolution: float) -> float:

    return shear_mesh_size(resolution) if resolution > 0 else 0.5


@app.command("equivalent")
@user_errors
def equivalent_command(
    nucleus: NucleusShape = NUCLEUS, stiffness_ratio: float = STIFFNESS, size_ratio: float = SIZE,
    offset: float = OFFSET, offset_axis: AxisName = OFFSET_AXIS, semi_axes: tuple[float, float, float] = SEMI_AXES,
    nucleus_axis: AxisName = NUCLEUS_AXIS, random: bool = RANDOM, seed: int = SEED,
    mesh_size: float | None = MESH_SIZE, pole_size: float | None = POLE_SIZE,  # noqa: UP007
    interface_size: float | None = INTERFACE_SIZE,  # noqa: UP007
    poisson_ratio: float = POISSON, youngs_modulus: str = MODULUS, radius: str = RADIUS,
    material: str = MATERIAL, element: str = ELEMENT,
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
):
    """Effective (volume-averaged) Young's modulus of a cell: E_eff/E_c, volumes, mesh counts."""
    from elastocell.api.compression import (
        equivalent as run,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )

    cell = _cell_options(nucleus, stiffness_ratio, size_ratio, offset, offset_axis, semi_axes, nucleus_axis, random,
                         seed, mesh_size, pole_size, element, material, poisson_ratio, youngs_modulus, radius,
                         interface_size)
    summary = run(cell)
    if as_json:
        typer.echo(json.dumps(summary, indent=2))
        return
    for key, value in summary.items():
        typer.echo(f"{key}: {value}")


class StationaryObservable(str, Enum):
    strain_axial = "strain_axial"
    deformation = "deformation"


OPTION_NAMES.update({
    "stationary_observable": "--stationary-observable",
    "capillary_number_wall": "--capillary-number-wall", "channel_radius_ratio": "--channel-radius-ratio",
    "start_offset": "--start-offset", "pressure_gradient": "--pressure-gradient",
})


@app.command()
@user_errors
def pipe(
    out: Path = typer.Option(..., "--out", help="Output directory."),
    capillary_number_wall: float | None = typer.Option(  # noqa: UP007
        None, "--capillary-number-wall", help="Ca_w = G*R_ch/(2*mu_c) (mu_eff with --equivalent)."),
    nucleus: NucleusShape = NUCLEUS, stiffness_ratio: float = STIFFNESS, size_ratio: float = SIZE,
    offset: float = OFFSET, offset_axis: AxisName = OFFSET_AXIS, semi_axes: tuple[float, float, float] = SEMI_AXES,
    nucleus_axis: AxisName = NUCLEUS_AXIS, random: bool = RANDOM, seed: int = SEED,
    mesh_size: float | None = FLOW_MESH_SIZE,  # noqa: UP007
    pole_size: float | None = FLOW_POLE_SIZE,  # noqa: UP007
    interface_size: float | None = FLOW_INTERFACE_SIZE,  # noqa: UP007
    poisson_ratio: float = POISSON, youngs_modulus: str = MODULUS, radius: str = RADIUS,
    material: str = MATERIAL,
    element: str = FLOW_ELEMENT,
    equivalent: bool = typer.Option(False, "--equivalent", help="Simulate the homogeneous equivalent (Ca_w with mu_eff)."),
    channel_radius_ratio: float = typer.Option(2.0, "--channel-radius-ratio", help="R_ch/R, channel over cell radius (> 1)."),
    start_offset: float = typer.Option(0.0, "--start-offset", help="r0/R_ch, initial distance of the cell from the axis."),
    resolution: float = FLOW_RESOLUTION,
    duration: float = typer.Option(10.0, "--duration", help="Run length in units of 1/gdot_w (wall shear rate)."),
    pressure_gradient: str | None = typer.Option(None, "--pressure-gradient", help="Physical G (e.g. 1e5Pa/m), with a physical --radius and --youngs-modulus instead of --capillary-number-wall."),  # noqa: UP007
    wall_clock: float | None = WALL_CLOCK,  # noqa: UP007
    stationary_tolerance: float | None = typer.Option(  # noqa: UP007
        None, "--stationary-tolerance",
        help="Stop when the running mean of --stationary-observable over 1/gdot_w changes less than this fraction."),
    stationary_observable: StationaryObservable = typer.Option(
        "strain_axial", "--stationary-observable", help="Observable of the stationary stop: strain_axial | deformation."),
    record_interval: float = typer.Option(0.1, "--record-interval", help="Time between records (1/gdot_w)."),
    checkpoint_every: int = CHECKPOINT_EVERY,
    vtk_interval: float = typer.Option(1.0, "--vtk-interval", help="Time between VTK snapshots (1/gdot_w)."),
    resume: bool = RESUME,
    backend: Backend = BACKEND,
    quiet: bool = QUIET,
):
    """A cell in pressure-driven flow through a cylindrical capillary: migration and bullet shape."""
    from elastocell.api.pipe import (
        pipe as run,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )
    from elastocell.coupling.markers import (
        FlowError,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )
    from elastocell.scenarios.pipe import (
        PipeFlowParameters,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )
    from elastocell.simulation.runner import (
        StopCriteria,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )

    mesh_size = mesh_size if mesh_size is not None else _shear_mesh(resolution)
    pole_size = pole_size if pole_size is not None else mesh_size  # uniform: no plate contacts to refine for
    interface_size = interface_size if interface_size is not None else mesh_size
    cell = _cell_options(nucleus, stiffness_ratio, size_ratio, offset, offset_axis, semi_axes, nucleus_axis, random,
                         seed, mesh_size, pole_size, element, material, poisson_ratio, youngs_modulus, radius,
                         interface_size)
    if pressure_gradient is not None:
        if capillary_number_wall is not None:
            raise ParameterError("capillary_number_wall", "give --capillary-number-wall or --pressure-gradient, not both")
        g, _ = parse_quantity(pressure_gradient, "Pa/m", "pressure_gradient")
        if not (cell.youngs_modulus_is_physical and cell.radius_is_physical):
            raise ParameterError("pressure_gradient", "needs a physical --radius and --youngs-modulus (e.g. 8um, 1kPa)")
        # Ca_w = G R_ch / (2 mu_c), mu_c = E_c / (2 (1 + nu))
        capillary_number_wall = g * channel_radius_ratio * cell.radius * (1 + poisson_ratio) / cell.youngs_modulus
        if equivalent:  # the same G on the equivalent: Ca_w with mu_eff = gamma_eff mu_c
            from elastocell.api.compression import (
                equivalent as effective,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
            )

            capillary_number_wall /= effective(cell)["effective_stiffness_ratio"]
    if capillary_number_wall is None:
        raise ParameterError("capillary_number_wall", "required (or --pressure-gradient)")
    flow_options = {"channel_radius_ratio": channel_radius_ratio, "start_offset": start_offset, "resolution": resolution,
                    "backend": backend.value}
    PipeFlowParameters(capillary_number_wall=capillary_number_wall, **flow_options)  # validate early
    StopCriteria(duration=duration, wall_clock=wall_clock, stationary_tolerance=stationary_tolerance,
                 stationary_observable=stationary_observable.value, unit="units of 1/gdot_w")
    try:
        summary = run(out, capillary_number_wall, cell=cell, equivalent=equivalent, duration=duration, resume=resume,
                      progress=not quiet and sys.stderr.isatty(), wall_clock=wall_clock,
                      stationary_tolerance=stationary_tolerance, stationary_observable=stationary_observable.value,
                      record_interval=record_interval, checkpoint_every=checkpoint_every, vtk_interval=vtk_interval,
                      flow_options=flow_options)
    except FlowError as error:
        typer.echo(f"elastocell: pipe flow failed: {error}", err=True)
        raise typer.Exit(code=1) from None
    if not quiet:
        typer.echo(f"{summary['label']}: Ca_w = {capillary_number_wall:g}, eps_x = {summary['strain_axial_mean']:.4f} "
                   f"+- {summary['strain_axial_std']:.1e}, eps_r = {summary['strain_radial_mean']:.4f} "
                   f"+- {summary['strain_radial_std']:.1e}, r/R_ch {summary['radial_position_initial']:.3f} -> "
                   f"{summary['radial_position']:.3f}, t = {summary['duration']:.2f}/gdot_w in "
                   f"{summary['wall_time_s']:.1f} s -> {out}")


bench_app = typer.Typer(no_args_is_help=True, help="Measure this machine: lattice-Boltzmann throughput.")
app.add_typer(bench_app, name="bench")


class Precision(str, Enum):
    float32 = "float32"
    float64 = "float64"


@bench_app.command("lattice")
@user_errors
def bench_lattice(
    size: int = typer.Option(128, "--size", help="Lattice size N (N^3 nodes, periodic)."),
    dtype: Precision = typer.Option(Precision.float32, "--dtype", help="Population storage precision."),
    no_cell: bool = typer.Option(False, "--no-cell", help="Skip the run with an immersed cell."),
    threads: int | None = typer.Option(None, "--threads", help="Numba threads (default: all)."),  # noqa: UP007
    backend: Backend = BACKEND,
    as_json: bool = typer.Option(False, "--json", help="Print the figures as one JSON line (last line)."),
):
    """MLUPS of the fused D3Q19 step, with and without a cell, against the memory roofline measured in the
    same run (STREAM-like triad)."""
    from elastocell.simulation.throughput import (
        run_benchmark,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )

    if not 8 <= size <= 1024:
        raise ParameterError("size", f"must be in [8, 1024] lattice nodes per side, got {size}")
    if threads is not None and threads < 1:
        raise ParameterError("threads", f"must be >= 1, got {threads}")
    result = run_benchmark(size, dtype.value, with_cell=not no_cell, threads=threads, backend=backend.value)
    if as_json:
        typer.echo(json.dumps(result))
        return
    typer.echo(f"{result['size']}^3 {result['dtype']}, backend {result['backend']} on {result['device']}, "
               f"{result['threads']} threads: triad "
               f"{result['bandwidth_gbs']:.1f} GB/s -> roofline {result['roofline_mlups']:.1f} MLUPS "
               f"({result['bytes_per_update']} B/update)")
    typer.echo(f"pure LB: {result['mlups']:.1f} MLUPS = {100 * result['roofline_fraction']:.1f} % of the roofline "
               f"(CPU use {result['cpu_utilisation']:.2f} x)")
    if result["mlups_with_cell"] is not None:
        typer.echo(f"with a cell ({result['markers']} markers): {result['mlups_with_cell']:.1f} MLUPS, "
                   f"{result['with_cell_slowdown']:.2f} x slower than pure LB")



app.add_typer(mastercurve_app, name="mastercurve")
app.add_typer(fit_app, name="fit")


app.add_typer(study_app, name="study")
app.command("reproduce")(reproduce)


app.command("lut")(lut)


def _click_exceptions():
    """(UsageError, NoArgsIsHelpError, Abort) of the click that typer runs on (typer >= 0.26 vendors it)."""
    try:
        from typer._click import exceptions
    except ImportError:
        from click import exceptions

    class NoSuchException(Exception):
        """Stands in for NoArgsIsHelpError where click has none (click < 8.2)."""

    return exceptions.UsageError, getattr(exceptions, "NoArgsIsHelpError", NoSuchException), typer.Abort


def main(argv: list[str] | None = None) -> None:
    """The ``elastocell`` console command: the typer app, with a usage error (an unknown or missing option, a
    value of the wrong type) reported as one line naming the option, exit code 2, as every other user error."""
    usage_error, no_args_is_help, abort = _click_exceptions()
    try:
        code = app(args=argv, prog_name="elastocell", standalone_mode=False)
    except no_args_is_help as error:
        error.show()
        raise SystemExit(error.exit_code) from None
    except usage_error as error:
        command = error.ctx.command_path if error.ctx is not None else "elastocell"
        message = " ".join(error.format_message().split())
        typer.echo(f"elastocell: error: {message} (see '{command} --help')", err=True)
        raise SystemExit(2) from None
    except (abort, KeyboardInterrupt):
        typer.echo("elastocell: aborted", err=True)
        raise SystemExit(130) from None
    raise SystemExit(code if isinstance(code, int) and not isinstance(code, bool) else 0)


if __name__ == "__main__":  # pragma: no cover
    main()
