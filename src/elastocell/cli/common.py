"""Shared pieces of the command line: one-line user errors (exit code 2) naming the option."""

from __future__ import annotations

import typer

from elastocell.parameters.units import ParameterError

# CLI option names for parameter names used in error messages
OPTION_NAMES = {
    "stiffness_ratio": "--stiffness-ratio", "size_ratio": "--size-ratio", "offset": "--offset",
    "semi_axes": "--semi-axes", "poisson_ratio": "--poisson-ratio", "youngs_modulus": "--youngs-modulus",
    "radius": "--radius", "mesh_size": "--mesh-size", "pole_size": "--pole-size", "interface_size": "--interface-size",
    "quadrature_degree": "--quadrature-degree",
    "delta_max": "--delta-max",
    "steps": "--steps", "material": "--material", "element": "--element", "random": "--random",
    "compare": "--compare",
    # shear
    "capillary_number": "--capillary-number", "resolution": "--resolution", "duration": "--duration",
    "confinement": "--confinement", "resume": "--resume", "wall_clock": "--wall-clock",
    "stationary_tolerance": "--stationary-tolerance", "record_interval": "--record-interval",
    "checkpoint_every": "--checkpoint-every", "vtk_interval": "--vtk-interval", "viscosity": "--viscosity",
    "shear_rate": "--shear-rate", "size": "--size", "threads": "--threads",
}


def fail(message: str) -> None:
    typer.echo(f"elastocell: error: {message}", err=True)
    raise typer.Exit(code=2)


def user_errors(function):
    """Turn ParameterError / pydantic validation errors into one line and exit code 2."""
    import functools

    from pydantic import ValidationError


    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        try:
            return function(*args, **kwargs)
        except ParameterError as error:
            fail(f"{OPTION_NAMES.get(error.parameter, error.parameter)}: {str(error).split(': ', 1)[1]}")
        except ValidationError as error:
            first = error.errors()[0]
            cause = (first.get("ctx") or {}).get("error")
            if isinstance(cause, ParameterError):
                fail(f"{OPTION_NAMES.get(cause.parameter, cause.parameter)}: {str(cause).split(': ', 1)[1]}")
            location = ".".join(str(p) for p in first.get("loc", ()))
            fail(f"{location or 'input'}: {first.get('msg')}")
        except OSError as error:
            fail(f"cannot write or read {error.filename or ''}: {error.strerror or error}")
        except typer.Exit:
            raise
        except Exception as error:  # anything unforeseen: one line, not a traceback (ELASTOCELL_DEBUG shows it)
            import os

            if os.environ.get("ELASTOCELL_DEBUG"):
                raise
            typer.echo(f"elastocell: error: {type(error).__name__}: {error}", err=True)
            raise typer.Exit(code=1) from None

    return wrapper
