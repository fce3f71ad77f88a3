"""The README as a user follows it: every command line it shows names a real command with real options, its
quick start runs, and its Python snippets' names exist (the expensive ones are run at a smoke size)."""

from __future__ import annotations

import ast
import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import typer

import elastocell
from elastocell.cli.app import app

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README, flags=re.S)


def command_lines() -> list[str]:
    """Every ``elastocell ...`` line of the README's bash blocks (comments and continuations removed)."""
    lines = []
    for block in blocks("bash"):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split(" #")[0].strip()
            if "elastocell " in line and not line.startswith("pip install . &&"):
                lines.append(line[line.index("elastocell "):])
    return lines


def resolve(arguments: list[str]):
    """The click command a command line names (descending into groups) and its remaining arguments."""
    command = typer.main.get_command(app)
    while hasattr(command, "commands") and arguments and not arguments[0].startswith("-"):  # a group
        command, arguments = command.commands[arguments[0]], arguments[1:]
    return command, arguments


@pytest.mark.parametrize("line", command_lines())
def test_every_readme_command_names_existing_options(line):
    command, arguments = resolve(shlex.split(line)[1:])
    known = {name for parameter in command.params for name in parameter.opts + parameter.secondary_opts}
    used = {a.split("=")[0] for a in arguments if a.startswith("--")}
    assert used <= known | {"--help"}, f"{line}: unknown {sorted(used - known)}"


def test_readme_python_snippets_name_the_public_api():
    for block in blocks("python"):
        tree = ast.parse(block)
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "elastocell":
                assert hasattr(elastocell, node.attr), f"elastocell.{node.attr} in the README does not exist"


def test_readme_opens_with_the_two_commands():
    first = blocks("bash")[0].strip().splitlines()
    assert first == ["pip install . && elastocell compress --compare --out results/reference",
                     'pip install ".[test]" && python -m pytest -q']


@pytest.mark.slow
def test_quick_start_runs(tmp_path):
    """The quick start as written (in a temporary directory): it must finish, and quickly."""
    quick = blocks("bash")[1]
    for line in command_lines():
        if line.split(" #")[0] in quick:
            arguments = shlex.split(line)[1:]
            result = subprocess.run([sys.executable, "-m", "elastocell", *arguments], cwd=tmp_path,
                                    capture_output=True, text=True, timeout=600)
            assert result.returncode == 0, result.stderr[-2000:]
            if "--json" in arguments:
                assert json.loads(result.stdout)["effective_stiffness_ratio"] > 1
    assert (tmp_path / "quick" / "comparison.csv").exists()
