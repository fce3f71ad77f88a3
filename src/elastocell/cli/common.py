"""Shared pieces of the command line: one-line user errors (exit code 2) naming the option (its name from
:data:`elastocell.cli.options.OPTION_NAMES`)."""

from __future__ import annotations

import typer

from elastocell.cli.options import OPTION_NAMES
from elastocell.parameters.units import ParameterError


def fail(message: str) -> None:
    """One line on stderr, exit code 2."""
    typer.echo(f"elastocell: error: {message}".replace("\n", " "), err=True)
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
        except KeyboardInterrupt:  # Ctrl-C or SIGTERM: the run wrote what it had finished
            typer.echo("elastocell: interrupted; finished work is written, rerun with --resume to continue", err=True)
            raise typer.Exit(code=130) from None
        except Exception as error:  # anything unforeseen: one line, not a traceback (ELASTOCELL_DEBUG shows it)
            import os

            if os.environ.get("ELASTOCELL_DEBUG"):
                raise
            typer.echo(f"elastocell: error: {type(error).__name__}: {error}", err=True)
            raise typer.Exit(code=1) from None

    return wrapper
