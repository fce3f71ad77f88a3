"""``elastocell indent``: a rigid sphere (bead) pressed into a cell on a dish (see :mod:`elastocell.api.indentation`)."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from elastocell.cli.common import user_errors
from elastocell.cli.options import CELL, opt, plain, takes

# the 3D solver's poles (the bead's and the dish's contacts) are finer than compress's by default
INDENT_CELL = CELL.but(opt("pole_size", help="3D solver: element size at the bead and dish contacts.",
                           shown="0.35 x compress's default (scenarios.indentation.POLE_SIZE_FACTOR_3D)"))



@user_errors
@takes("out", "indenter", opt("indenter_radius", annotation=str | None, default=None,
                               shown="required with --indenter sphere"), "half_angle", "cell_shape", "cap_height", "layer_thickness", "depth_max",
       opt("steps", default=20, help="Load steps (output rows after depth = 0)."), "solver", INDENT_CELL,
       opt("resume", help="Continue an interrupted curve of the 3D solver from DIR/checkpoint.npz (same options)."),
       "quiet", "as_json")
def indent(out: Path, indenter: str, indenter_radius: str | None, half_angle: str | None, cell_shape: str, cap_height: str | None, layer_thickness: str | None,
           depth_max: float, steps: int, solver: str, cell: dict, resume: bool, quiet: bool, as_json: bool):
    """A rigid frictionless sphere of radius --indenter-radius (or, --indenter cone|pyramid, a sharp tip of
    --half-angle) pressed quasistatically into a cell on a rigid dish.
    A cell symmetric about the dish normal z runs the axisymmetric solver (its own meridian mesh: the mesh options
    do not apply); any other suspended sphere (--random, an offset nucleus, a tilted ellipsoid) the 3D tetrahedral
    cell of compress (--solver forces one; a cap or a layer must be axisymmetric). Writes indentation.csv (depth,
    force, force_per_Ec_R2, force_per_Eeff_R2), metadata.json (solver.solver: which ran), indentation.png and
    VTK."""
    from elastocell.api.indentation import (
        indent as run,  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
    )
    from elastocell.parameters.cell import (
        cell_parameters,  # lazy: a command loads pydantic models only when it runs
    )
    from elastocell.scenarios.axisymmetric import (  # lazy: a command loads JAX/Numba only when it runs (elastocell --help 0.3 s, not 2.5 s)
        AxisymmetricError,
        AxisymmetricInterrupted,
    )

    parameters = cell_parameters(**{name: plain(value) for name, value in cell.items()})
    try:
        summary = run(out, indenter_radius, cell=parameters, indenter=plain(indenter), half_angle=half_angle, cell_shape=plain(cell_shape), cap_height=cap_height,
                      layer_thickness=layer_thickness, depth_max=depth_max, steps=steps,
                      solver=plain(solver), resume=resume, progress=not (quiet or as_json))
    except AxisymmetricInterrupted as error:
        typer.echo(f"elastocell: {error}", err=True)
        raise typer.Exit(code=130) from None
    except AxisymmetricError as error:
        typer.echo(f"elastocell: indentation failed: {error}", err=True)
        raise typer.Exit(code=1) from None
    if as_json:
        typer.echo(json.dumps({key: summary[key] for key in ("label", "indentation", "length_unit", "units", "mesh",
                                                             "solver", "wall_time_s")}))
    elif not quiet:
        typer.echo(f"{summary['label']}: {summary['solver']['solver']} solver, {summary['mesh']['n_nodes']} nodes, curve in "
                   f"{summary['solver']['curve_time_s']:.1f} s -> {out}")
