"""Command line: ``elastocell COMMAND``, one typer application whose commands mirror the Python API."""

from elastocell.cli.app import app, main

__all__ = ["app", "main"]
