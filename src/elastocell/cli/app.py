"""Command line: ``elastocell COMMAND`` (names shared with the Python API), one typer application.

A user error (impossible input) exits with code 2 and one line naming the parameter and its allowed
range, before any meshing; never a traceback. Every option is declared once in :mod:`elastocell.cli.options`.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import typer

from elastocell.cli.common import user_errors
from elastocell.cli.fit import fit_app, mastercurve_app
from elastocell.cli.fit_rtdc import fit_rtdc_command  # noqa: F401 (registers `fit rtdc` on fit_app)
from elastocell.cli.indent import indent
from elastocell.cli.lut import lut, shipped_luts
from elastocell.cli.options import CELL, FLOW_CELL, opt, plain, takes
from elastocell.cli.study import reproduce, study_app
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.flow import shear_mesh_size
from elastocell.parameters.units import ParameterError, parse_quantity, parse_temperature
from elastocell.version import __version__

HELP = """elastocell: mechanics of living cells, hyperelastic bodies with a nucleus, in silico.

compress: AFM plate compression, force against deformation (--compare: with the homogeneous equivalent).

indent: a bead (rigid sphere) pressed into a cell on a dish: a suspended sphere, an adherent cap or a layer.

equivalent: the effective Young's modulus of a heterogeneous cell.

shear, pipe: a cell in shear flow or in pressure-driven capillary flow (lattice Boltzmann + immersed boundary).

fit afm, fit shear: Young's modulus from AFM force curves, or from the deformation in shear flow.

lut: look-up table for RT-DC (dclab) from pipe-flow runs over cell radii and moduli; shipped-luts: the tables
that ship with elastocell (elastocell.register_lut() registers them with dclab).

study, reproduce: the paper's figures as studies run on Dask, one or all of them.

mastercurve: master curves of a homogeneous cell (compression, shear), shipped, cached or computed.

bench: lattice-Boltzmann throughput of this machine.

A bare number is in the option's documented unit (each --help says which); the --radius and --youngs-modulus
of a simulated cell, and indent's --indenter-radius, --cap-height and --layer-thickness, are dimensionless
(units of R and E_c) unless given with a unit (8um, 1kPa)."""

app = typer.Typer(add_completion=False, no_args_is_help=True, help=HELP)


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"elastocell {__version__}")
        raise typer.Exit()


@app.callback()
def _main(version: bool = typer.Option(False, "--version", help="Print the version and exit.", is_eager=True,
                                       callback=_print_version, show_default="off")) -> None:
    pass


def _cell(cell: dict):
    """CellParameters from the CELL OPTIONS (``cell``: the dict of :data:`elastocell.cli.options.CELL`)."""
    return cell_parameters(**{name: plain(value) for name, value in cell.items()})


def _uniform_flow_mesh(cell: dict, resolution: float) -> dict:
    """The flow scenarios' mesh: edges of 2 dx, uniform, unless given."""
    cell = dict(cell)
    if cell["mesh_size"] is None:
        cell["mesh_size"] = shear_mesh_size(resolution) if resolution > 0 else 0.5
    for name in ("pole_size", "interface_size"):  # uniform: no plate contacts to refine for
        if cell[name] is None:
            cell[name] = cell["mesh_size"]
    return cell


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
@takes("out", CELL, "delta_max", "steps", "equivalent", "compare", "axisymmetric",
       opt("resume", help="Continue an interrupted curve from DIR/checkpoint.npz (same options)."), "quiet")
def compress(out: Path, cell: dict, delta_max: float, steps: int, equivalent: bool, compare: bool,
             axisymmetric: bool, resume: bool, quiet: bool):
    """Quasistatic compression between two rigid frictionless plates (delta from 0 to --delta-max)."""
    from elastocell.api.compression import (
        compress as run,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )
    from elastocell.scenarios.compression import (  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
        CompressionError,
        CompressionInterrupted,
        CompressionParameters,
    )

    cell = _cell(cell)
    CompressionParameters(delta_max=delta_max, steps=steps)  # validate before meshing
    try:
        summary = run(out, cell=cell, delta_max=delta_max, steps=steps, equivalent=equivalent, compare=compare,
                      resume=resume, progress=not quiet, axisymmetric=axisymmetric)
    except CompressionInterrupted as error:  # the converged rows are written
        typer.echo(f"elastocell: {error}", err=True)
        raise typer.Exit(code=130) from None
    except CompressionError as error:
        typer.echo(f"elastocell: compression failed: {error}", err=True)
        for name, path in (("cell", out / "metadata.json"), ("equivalent", out / "equivalent" / "metadata.json")):
            if path.exists():  # the rows that were written
                _warn_curves(json.loads(path.read_text()), name)
        raise typer.Exit(code=1) from None
    if not quiet:
        solved = " (axisymmetric, meridian mesh)" if axisymmetric else ""
        typer.echo(f"{summary['label']}: gamma_eff = {summary['effective_stiffness_ratio']:.4f}, "
                   f"{summary['mesh']['n_nodes']} nodes{solved}, curve in {summary['solver']['curve_time_s']:.1f} s "
                   f"-> {out}")
        _warn_curves(summary)
        if "equivalent_summary" in summary:
            typer.echo(f"equivalent: curve in {summary['equivalent_summary']['solver']['curve_time_s']:.1f} s; "
                       f"force ratios in {out / 'comparison.csv'}, plot {out / 'comparison.png'}")


@app.command()
@user_errors
@takes("out", "capillary_number", FLOW_CELL,
       opt("equivalent", help="Simulate the homogeneous equivalent (Ca with mu_eff)."),
       "resolution", "extrapolate", "coarse_resolution", "duration", "confinement", "viscosity", "shear_rate",
       "wall_clock", "stationary_tolerance", "record_interval", "checkpoint_every", "vtk_interval", "resume", "backend",
       "quiet")
def shear(out: Path, capillary_number: float | None, cell: dict, equivalent: bool, resolution: float,
          extrapolate: bool, coarse_resolution: float | None, duration: float, confinement: float, viscosity: str | None, shear_rate: str | None,
          wall_clock: float | None, stationary_tolerance: float | None, record_interval: float,
          checkpoint_every: int, vtk_interval: float, resume: bool, backend, quiet: bool):
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
    from elastocell.simulation.extrapolation import (
        requested_coarse_resolution,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )
    from elastocell.simulation.runner import (
        StopCriteria,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )

    cell_options = {name: plain(value) for name, value in cell.items()}  # the mesh follows each resolution run
    cell = _cell(_uniform_flow_mesh(cell, resolution))
    if (viscosity is None) != (shear_rate is None):
        raise ParameterError("viscosity", "give both --viscosity and --shear-rate, or neither")
    if viscosity is not None:
        if capillary_number is not None:
            raise ParameterError("capillary_number", "give --capillary-number or --viscosity/--shear-rate, not both")
        eta, _ = parse_quantity(viscosity, "Pa*s", "viscosity")
        rate, _ = parse_quantity(shear_rate, "1/s", "shear_rate")
        if not cell.youngs_modulus_is_physical:
            raise ParameterError("youngs_modulus", "give a physical --youngs-modulus (e.g. 1kPa) with --viscosity")
        capillary_number = 2 * (1 + cell.material.poisson_ratio) * eta * rate / cell.youngs_modulus  # Ca with mu_c
    if capillary_number is None:
        raise ParameterError("capillary_number", "required (or --viscosity with --shear-rate)")
    flow_options = {"confinement": confinement, "backend": backend.value}
    ShearFlowParameters(capillary_number=capillary_number, resolution=resolution, **flow_options)  # validate early
    StopCriteria(duration=duration, wall_clock=wall_clock, stationary_tolerance=stationary_tolerance)
    requested_coarse_resolution(extrapolate, resolution, coarse_resolution)
    try:
        summary = run(out, capillary_number, equivalent=equivalent, resolution=resolution, extrapolate=extrapolate,
                      coarse_resolution=coarse_resolution, duration=duration, resume=resume, progress=not quiet,
                      wall_clock=wall_clock, stationary_tolerance=stationary_tolerance,
                      record_interval=record_interval, checkpoint_every=checkpoint_every, vtk_interval=vtk_interval,
                      flow_options=flow_options, capillary_number_modulus="mu_c" if viscosity is not None else "reference",
                      **cell_options)
    except FlowError as error:
        typer.echo(f"elastocell: shear flow failed: {error}", err=True)
        raise typer.Exit(code=1) from None
    if not quiet:
        typer.echo(f"{summary['label']}: Ca = {capillary_number:g}, D = {summary['taylor_deformation_mean']:.4f} "
                   f"+- {summary['taylor_deformation_std']:.1e}, inclination {summary['inclination_deg_mean']:.1f} deg, "
                   f"tank treading {summary['tank_treading_frequency']:.3f} shear_rate, strain "
                   f"{summary['duration_strain']:.2f} in {summary['wall_time_s']:.1f} s -> {out}")
        _echo_extrapolation(summary, ("taylor_deformation_mean", "D"), ("inclination_deg_mean", "inclination"),
                            ("tank_treading_frequency", "tank treading"))


def _echo_extrapolation(summary: dict, *names: tuple[str, str]) -> None:
    """The lines of an extrapolated flow run: each value at both resolutions and the size of the correction."""
    extrapolation = summary.get("extrapolation")
    if not extrapolation:
        return
    if extrapolation.get("pending"):
        typer.echo(f"stopped by --wall-clock in {extrapolation['stopped_in']}/ before both resolutions finished: "
                   "not extrapolated; run again with --resume to continue")
        return
    fine, coarse = extrapolation["fine_resolution"], extrapolation["coarse_resolution"]
    typer.echo(f"extrapolated (Richardson, order {extrapolation['order']:g}) from R/dx = {fine:g} and {coarse:g}; "
               "uncertainty: the size of the correction, an estimate, not a bound")
    for name, label in names:
        value = extrapolation["values"].get(name)
        if value is None or value.get("value") is None or not math.isfinite(value["value"]):
            continue
        if value.get("correction") is None or not math.isfinite(value["correction"]):  # kept by the outline guard
            typer.echo(f"  {label}: {value['value']:.4g} (R/dx {fine:g}'s, not extrapolated: the outline was read "
                       "on the nodes' hull)")
            continue
        typer.echo(f"  {label}: {value['value']:.4g} (R/dx {fine:g}: {value['fine']:.4g}, R/dx {coarse:g}: "
                   f"{value['coarse']:.4g}, correction {value['correction']:.2g})")
        if abs(value["correction"]) > LARGE_CORRECTION * abs(value["value"]):
            typer.echo(f"warning: the {label} of R/dx {fine:g} and {coarse:g} differ so much that the correction is "
                       f"{100 * abs(value['correction']) / abs(value['value']):.0f} % of the value: the coarser run "
                       "is likely outside the (dx/R)^2 range and the extrapolation uncertain; compare a finer "
                       "--resolution", err=True)


LARGE_CORRECTION = 0.10
"""A correction above this fraction of its extrapolated value is warned about: the order-2 assumption then
carries a large share of the answer (pipe flow at R/dx 8 and 6: corrections of 40-60 % of D, and an apparent
order of 2.5-4.3, docs/validation/pipe_dclab.md)."""


@app.command("equivalent")
@user_errors
@takes(CELL.but(without=("quadrature_degree",)), "as_json")
def equivalent_command(cell: dict, as_json: bool):
    """Effective (volume-averaged) Young's modulus of a cell: E_eff/E_c, volumes, mesh counts."""
    from elastocell.api.compression import (
        equivalent as run,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )

    summary = run(_cell(cell))
    if as_json:
        typer.echo(json.dumps(summary, indent=2))
        return
    for key, value in summary.items():
        typer.echo(f"{key}: {value}")


@app.command()
@user_errors
@takes("out", "capillary_number_wall", FLOW_CELL,
       opt("equivalent", help="Simulate the homogeneous equivalent (Ca_w with mu_eff)."),
       "channel_radius_ratio", "start_offset", "resolution",
       opt("extrapolate", annotation=bool | None, default=None,
           shown="on in a cylinder with the cell on the axis (six side views), off in a duct or off the axis"),
       "coarse_resolution", "hold_flow_rate", opt("hydrodynamic_radius_correction", default=0.3),  # the API's
       "channel_shape", "channel_wall", "volume_correction",
       opt("channel_width", help="Width W of a square or rectangular channel, with a physical --radius: sets "
           "--channel-radius-ratio to W/(2R)."), "channel_height", "channel_aspect_ratio", "medium", "temperature",
       "flow_index", opt("channel_length", help="Length L of a finite channel, with a physical --radius (RT-DC chips: "
                         "about 300um, measured near the outlet): the run ends when the cell, started undeformed at "
                         "the inlet, has travelled L; --duration is then the cap."),
       opt("duration", default=10.0, units="1/gdot_w, gdot_w the wall shear rate"), "pressure_gradient",
       "wall_clock",
       opt("stationary_tolerance", help="Stop when the running mean of --stationary-observable over 1/gdot_w "
           "changes less than this fraction."),
       "stationary_observable",
       opt("record_interval", default=0.1, help="Time between records.", units="1/gdot_w"),
       "checkpoint_every",
       opt("vtk_interval", help="Time between VTK snapshots.", units="1/gdot_w"),
       "resume", "backend", "quiet")
def pipe(out: Path, capillary_number_wall: float | None, cell: dict, equivalent: bool, channel_radius_ratio: float,
         start_offset: float, resolution: float, extrapolate: bool | None, coarse_resolution: float | None,
         hold_flow_rate: bool, hydrodynamic_radius_correction: float, channel_shape, channel_wall, volume_correction,
         channel_width: str | None,
         channel_height: str | None,
         channel_aspect_ratio: float | None, medium: str, temperature: str | None, flow_index: float | None,
         channel_length: str | None, duration: float, pressure_gradient: str | None,
         wall_clock: float | None, stationary_tolerance: float | None, stationary_observable, record_interval: float,
         checkpoint_every: int, vtk_interval: float, resume: bool, backend, quiet: bool):
    """A cell in pressure-driven flow through a cylindrical or square/rectangular channel, in a Newtonian or
    shear-thinning (MC-PBS) medium: migration and bullet shape."""
    from elastocell.api.pipe import (  # lazy: a command loads JAX/Numba only when it runs (--help 0.3 s, not 2.5 s)
        channel_length_of,
        pipe_coarse_resolution,
        rtdc_extrapolated,
        rtdc_reading,
    )
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

    cell_options = {name: plain(value) for name, value in cell.items()}  # the mesh follows each resolution run
    cell = _cell(_uniform_flow_mesh(cell, resolution))
    shape, channel_radius_ratio, channel_aspect_ratio = _pipe_channel(cell, channel_shape, channel_width, channel_height,
                                                                      channel_aspect_ratio, channel_radius_ratio)
    if pressure_gradient is not None:
        if capillary_number_wall is not None:
            raise ParameterError("capillary_number_wall", "give --capillary-number-wall or --pressure-gradient, not both")
        g, _ = parse_quantity(pressure_gradient, "Pa/m", "pressure_gradient")
        if not (cell.youngs_modulus_is_physical and cell.radius_is_physical):
            raise ParameterError("pressure_gradient", "needs a physical --radius and --youngs-modulus (e.g. 8um, 1kPa)")
        # Ca_w = G R_ch / (2 mu_c), mu_c = E_c / (2 (1 + nu))
        capillary_number_wall = (g * channel_radius_ratio * cell.radius * (1 + cell.material.poisson_ratio)
                                 / cell.youngs_modulus)
        if equivalent:  # the same G on the equivalent: Ca_w with mu_eff = gamma_eff mu_c
            from elastocell.api.compression import (
                equivalent as effective,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
            )

            capillary_number_wall /= effective(cell)["effective_stiffness_ratio"]
    if capillary_number_wall is None:
        raise ParameterError("capillary_number_wall", "required (or --pressure-gradient)")
    flow_options = {"channel_radius_ratio": channel_radius_ratio, "start_offset": start_offset, "resolution": resolution,
                    "backend": backend.value, "channel_shape": shape, "channel_aspect_ratio": channel_aspect_ratio,
                    "channel_wall": channel_wall.value, "volume_correction": volume_correction.value,
                    "medium": medium, "temperature": parse_temperature(temperature), "flow_index": flow_index}
    StopCriteria(duration=duration, wall_clock=wall_clock, stationary_tolerance=stationary_tolerance,
                 stationary_observable=stationary_observable.value, unit="units of 1/gdot_w")
    channel_length_of(channel_length, cell)  # refused in one line before anything runs
    params = PipeFlowParameters(capillary_number_wall=capillary_number_wall, hold_flow_rate=hold_flow_rate,
                                hydrodynamic_radius_correction=hydrodynamic_radius_correction, **flow_options)
    pipe_coarse_resolution(extrapolate, params, coarse_resolution)
    try:
        summary = run(out, capillary_number_wall, equivalent=equivalent, extrapolate=extrapolate,
                      coarse_resolution=coarse_resolution, duration=duration, resume=resume,
                      progress=not quiet, wall_clock=wall_clock,
                      stationary_tolerance=stationary_tolerance, stationary_observable=stationary_observable.value,
                      record_interval=record_interval, checkpoint_every=checkpoint_every, vtk_interval=vtk_interval,
                      flow_options=flow_options, channel_length=channel_length, hold_flow_rate=hold_flow_rate,
                      hydrodynamic_radius_correction=hydrodynamic_radius_correction, **cell_options)
    except FlowError as error:
        typer.echo(f"elastocell: pipe flow failed: {error}", err=True)
        raise typer.Exit(code=1) from None
    if not quiet:
        typer.echo(f"{summary['label']}: Ca_w = {capillary_number_wall:g}, eps_x = {summary['strain_axial_mean']:.4f} "
                   f"+- {summary['strain_axial_std']:.1e}, eps_r = {summary['strain_radial_mean']:.4f} "
                   f"+- {summary['strain_radial_std']:.1e}, r/R_ch {summary['radial_position_initial']:.3f} -> "
                   f"{summary['radial_position']:.3f}, t = {summary['duration']:.2f}/gdot_w in "
                   f"{summary['wall_time_s']:.1f} s -> {out}")
        if channel_length is not None:
            values = summary["transit"]
            typer.echo(f"state {summary['state']}: at L the deformation is {values['deformation']:.4f}, the "
                       f"projected area {values['projected_area']:.4f} R^2 (t = {values['time']:.3g}/gdot_w)")
        extrapolation = summary.get("extrapolation") or {}
        if channel_length is None and not extrapolation.get("pending"):
            deformation, area, reading = rtdc_reading(summary)
            typer.echo(f"RT-DC deformation {deformation:.4f}, projected area {area:.4f} R^2 (stationary means, "
                       f"{reading}" + (", extrapolated" if rtdc_extrapolated(summary) else "") + ")")
        _echo_extrapolation(summary, ("strain_axial_mean", "eps_x"), ("strain_radial_mean", "eps_r"),
                            ("deformation_mean", "deformation (view along z)"),
                            ("projected_area_mean", "projected area (view along z)"),
                            ("deformation_views_mean", "deformation (side views)"),
                            ("projected_area_views_mean", "projected area (side views)"))


def _pipe_channel(cell, shape, width: str | None, height: str | None, aspect: float | None,
                  radius_ratio: float) -> tuple[str, float, float]:
    """(channel_shape, channel_radius_ratio, channel_aspect_ratio) of the pipe options: the shape given or inferred
    (square with --channel-width, rectangle with a different height or an aspect ratio, else cylinder)."""
    if height is not None and width is None:
        raise ParameterError("channel_height", "needs --channel-width (the height is relative to the width)")
    if width is not None:
        if not cell.radius_is_physical:
            raise ParameterError("channel_width", "needs a physical --radius (e.g. 8um) to set R_ch/R = W/(2R)")
        w, _ = parse_quantity(width, "m", "channel_width")
        h = w if height is None else parse_quantity(height, "m", "channel_height")[0]
        if not (w > 0 and h > 0):
            raise ParameterError("channel_width", f"width and height must be > 0, got {width}, {height}")
        if aspect is not None and abs(aspect - h / w) > 1e-9:
            raise ParameterError("channel_aspect_ratio", "give --channel-height or --channel-aspect-ratio, not both")
        radius_ratio, aspect = w / (2.0 * cell.radius), h / w
    name = shape.value if shape is not None else (
        "rectangle" if aspect not in (None, 1.0) else "square" if width is not None else "cylinder")
    if name == "cylinder" and (width is not None or aspect not in (None, 1.0)):
        raise ParameterError("channel_shape", "a cylinder has no --channel-width/height/aspect: use --channel-radius-ratio")
    if name == "square" and aspect not in (None, 1.0):
        raise ParameterError("channel_shape", f"square needs H = W (H/W = {aspect:g}): use --channel-shape rectangle")
    return name, radius_ratio, 1.0 if aspect is None else float(aspect)


bench_app = typer.Typer(no_args_is_help=True, help="Measure this machine: lattice-Boltzmann throughput.")
app.add_typer(bench_app, name="bench")


@bench_app.command("lattice")
@user_errors
@takes("size", "dtype", "no_cell", "threads", "backend",
       opt("as_json", help="Print the figures as one JSON line (last line)."))
def bench_lattice(size: int, dtype, no_cell: bool, threads: int | None, backend, as_json: bool):
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
app.command("shipped-luts")(shipped_luts)
app.command("indent")(indent)


def _click_exceptions():
    """(UsageError, NoArgsIsHelpError, Abort) of the click that typer runs on (typer >= 0.26 vendors it)."""
    try:
        from typer._click import exceptions
    except ImportError:
        from click import exceptions

    class NoSuchException(Exception):
        """Stands in for NoArgsIsHelpError where click has none (click < 8.2)."""

    return exceptions.UsageError, getattr(exceptions, "NoArgsIsHelpError", NoSuchException), typer.Abort


def _console_warning_format():
    """A ``warnings.formatwarning`` for the console command: a warning is one line, ``warning: ...`` as the commands'
    own warnings, without the Python source location and line (what it says is for the user, not about the code),
    and a text said once: a check repeated for every resolution of a run (the medium's temperature range) does not
    print again (Python's own once-per-location registry is reset by every ``catch_warnings``)."""
    said = set()

    def console_warning(message, category, filename, lineno, line=None) -> str:
        text = " ".join(str(message).split())
        if text in said:
            return ""
        said.add(text)
        return f"warning: {text}\n"

    return console_warning


def main(argv: list[str] | None = None) -> None:
    """The ``elastocell`` console command: the typer app, with a usage error (an unknown or missing option, a
    value of the wrong type) reported as one line naming the option, exit code 2, as every other user error."""
    usage_error, no_args_is_help, abort = _click_exceptions()
    python_format, warnings.formatwarning = warnings.formatwarning, _console_warning_format()
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
    finally:  # an in-process caller of main() gets Python's format back
        warnings.formatwarning = python_format
    raise SystemExit(code if isinstance(code, int) and not isinstance(code, bool) else 0)


if __name__ == "__main__":  # pragma: no cover
    main()
