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

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="elastocell: mechanics of living cells (AFM plate compression; homogeneous equivalents).")

# CLI option names for parameter names used in error messages
_OPTION_NAMES = {
    "stiffness_ratio": "--stiffness-ratio", "size_ratio": "--size-ratio", "offset": "--offset",
    "semi_axes": "--semi-axes", "poisson_ratio": "--poisson-ratio", "youngs_modulus": "--youngs-modulus",
    "radius": "--radius", "mesh_size": "--mesh-size", "pole_size": "--pole-size", "delta_max": "--delta-max",
    "steps": "--steps", "material": "--material", "element": "--element", "random": "--random",
    "compare": "--compare",
}


class NucleusShape(str, Enum):
    none = "none"
    sphere = "sphere"
    ellipsoid = "ellipsoid"


class AxisName(str, Enum):
    x = "x"
    y = "y"
    z = "z"


def _fail(message: str) -> None:
    typer.echo(f"elastocell: error: {message}", err=True)
    raise typer.Exit(code=2)


def _user_errors(function):
    """Turn ParameterError / pydantic validation errors into one line and exit code 2."""
    import functools

    from pydantic import ValidationError

    from .parameters import ParameterError

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        try:
            return function(*args, **kwargs)
        except ParameterError as error:
            _fail(f"{_OPTION_NAMES.get(error.parameter, error.parameter)}: {str(error).split(': ', 1)[1]}")
        except ValidationError as error:
            first = error.errors()[0]
            cause = (first.get("ctx") or {}).get("error")
            if isinstance(cause, ParameterError):
                _fail(f"{_OPTION_NAMES.get(cause.parameter, cause.parameter)}: {str(cause).split(': ', 1)[1]}")
            location = ".".join(str(p) for p in first.get("loc", ()))
            _fail(f"{location or 'input'}: {first.get('msg')}")
        except OSError as error:
            _fail(f"cannot write or read {error.filename or ''}: {error.strerror or error}")
        except typer.Exit:
            raise
        except Exception as error:  # anything unforeseen: one line, not a traceback (ELASTOCELL_DEBUG shows it)
            import os

            if os.environ.get("ELASTOCELL_DEBUG"):
                raise
            typer.echo(f"elastocell: error: {type(error).__name__}: {error}", err=True)
            raise typer.Exit(code=1) from None

    return wrapper


def _cell_options(nucleus, stiffness_ratio, size_ratio, offset, offset_axis, semi_axes, nucleus_axis, random, seed,
                  mesh_size, pole_size, element, material, poisson_ratio, youngs_modulus, radius):
    from .api import cell_parameters

    return cell_parameters(
        nucleus=nucleus.value if isinstance(nucleus, Enum) else nucleus, stiffness_ratio=stiffness_ratio,
        size_ratio=size_ratio, offset=offset, offset_axis=getattr(offset_axis, "value", offset_axis),
        semi_axes=tuple(semi_axes), nucleus_axis=getattr(nucleus_axis, "value", nucleus_axis), random=random,
        seed=seed, mesh_size=mesh_size, pole_size=pole_size, element=element, material=material,
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
POISSON = typer.Option(0.48, "--poisson-ratio", help="nu in (-1, 0.5).")
MODULUS = typer.Option("1", "--youngs-modulus", help="E_c, e.g. 1kPa (plain number: dimensionless).")
RADIUS = typer.Option("1", "--radius", help="R, e.g. 8um (plain number: dimensionless).")
MATERIAL = typer.Option("neo-hookean", "--material", help="neo-hookean | mooney-rivlin.")
ELEMENT = typer.Option("p2", "--element", help="p2 (10-node, default) | p1 (4-node, the paper's).")


@app.command()
@_user_errors
def compress(
    out: Path = typer.Option(..., "--out", help="Output directory."),
    nucleus: NucleusShape = NUCLEUS, stiffness_ratio: float = STIFFNESS, size_ratio: float = SIZE,
    offset: float = OFFSET, offset_axis: AxisName = OFFSET_AXIS, semi_axes: tuple[float, float, float] = SEMI_AXES,
    nucleus_axis: AxisName = NUCLEUS_AXIS, random: bool = RANDOM, seed: int = SEED,
    mesh_size: float | None = MESH_SIZE, pole_size: float | None = POLE_SIZE,  # noqa: UP007
    poisson_ratio: float = POISSON, youngs_modulus: str = MODULUS, radius: str = RADIUS,
    material: str = MATERIAL, element: str = ELEMENT,
    delta_max: float = typer.Option(0.75, "--delta-max", help="Final deformation in (0, 1)."),
    steps: int = typer.Option(40, "--steps", help="Load steps (output rows after delta = 0)."),
    equivalent: bool = typer.Option(False, "--equivalent", help="Simulate the homogeneous equivalent instead."),
    compare: bool = typer.Option(False, "--compare", help="Also simulate the equivalent; write comparison.csv/png."),
    quiet: bool = typer.Option(False, "--quiet", help="No progress bar, no summary."),
):
    """Quasistatic compression between two rigid frictionless plates (delta from 0 to --delta-max)."""
    from .api import compress as run
    from .compression import CompressionError
    from .parameters import CompressionParameters

    cell = _cell_options(nucleus, stiffness_ratio, size_ratio, offset, offset_axis, semi_axes, nucleus_axis, random,
                         seed, mesh_size, pole_size, element, material, poisson_ratio, youngs_modulus, radius)
    CompressionParameters(delta_max=delta_max, steps=steps)  # validate before meshing
    try:
        summary = run(out, cell=cell, delta_max=delta_max, steps=steps, equivalent=equivalent, compare=compare,
                      progress=not quiet and sys.stderr.isatty())
    except CompressionError as error:
        typer.echo(f"elastocell: compression failed: {error}", err=True)
        raise typer.Exit(code=1) from None
    if not quiet:
        typer.echo(f"{summary['label']}: gamma_eff = {summary['effective_stiffness_ratio']:.4f}, "
                   f"{summary['mesh']['n_nodes']} nodes, curve in {summary['solver']['curve_time_s']:.1f} s -> {out}")
        if "equivalent_summary" in summary:
            typer.echo(f"equivalent: curve in {summary['equivalent_summary']['solver']['curve_time_s']:.1f} s; "
                       f"force ratios in {out / 'comparison.csv'}, plot {out / 'comparison.png'}")


@app.command("equivalent")
@_user_errors
def equivalent_command(
    nucleus: NucleusShape = NUCLEUS, stiffness_ratio: float = STIFFNESS, size_ratio: float = SIZE,
    offset: float = OFFSET, offset_axis: AxisName = OFFSET_AXIS, semi_axes: tuple[float, float, float] = SEMI_AXES,
    nucleus_axis: AxisName = NUCLEUS_AXIS, random: bool = RANDOM, seed: int = SEED,
    mesh_size: float | None = MESH_SIZE, pole_size: float | None = POLE_SIZE,  # noqa: UP007
    poisson_ratio: float = POISSON, youngs_modulus: str = MODULUS, radius: str = RADIUS,
    material: str = MATERIAL, element: str = ELEMENT,
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
):
    """Effective (volume-averaged) Young's modulus of a cell: E_eff/E_c, volumes, mesh counts."""
    from .api import equivalent as run

    cell = _cell_options(nucleus, stiffness_ratio, size_ratio, offset, offset_axis, semi_axes, nucleus_axis, random,
                         seed, mesh_size, pole_size, element, material, poisson_ratio, youngs_modulus, radius)
    summary = run(cell)
    if as_json:
        typer.echo(json.dumps(summary, indent=2))
        return
    for key, value in summary.items():
        typer.echo(f"{key}: {value}")


if __name__ == "__main__":  # pragma: no cover
    app()
