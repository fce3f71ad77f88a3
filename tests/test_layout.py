"""The package's layout is its data flow: imports run only downward through the stages, with no cycle and no
private name taken from another module (issue "One house"). Read from the sources with ``ast``; nothing is
imported."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "elastocell"

STAGES = (
    ("version", "files", "parameters"),
    ("solvers",),
    ("body",),
    ("lattice",),
    ("coupling",),
    ("simulation",),
    ("scenarios",),
    ("api",),
    ("inverse",),
    ("studies",),
    ("cli",),
)
"""Stages from the bottom up: a module may import its own stage and the stages below it."""


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def stage(module: str) -> int:
    """Index of a module's stage; the package's own ``__init__``/``__main__`` sit above every stage."""
    parts = module.split(".")
    if len(parts) == 1 or parts[1] in ("__main__",):
        return len(STAGES)
    for index, names in enumerate(STAGES):
        if parts[1] in names:
            return index
    raise AssertionError(f"{module} belongs to no stage: add it to STAGES in {__file__}")


def imports(path: Path):
    """(imported module, [names], line, at module level, text of the statement) of every elastocell import in a file."""
    module = module_name(path)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    source = path.read_text()
    tree = ast.parse(source)
    lines = source.splitlines()
    top = {id(node) for node in tree.body}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "elastocell":
                continue
            names = [alias.name for alias in node.names]
            text = "\n".join(lines[node.lineno - 1:node.end_lineno])
            # "from elastocell.x import y" where y is a submodule imports elastocell.x.y
            for name in names:
                sub = PACKAGE.parent / Path(*(target + "." + name).split("."))
                if sub.with_suffix(".py").exists() or (sub / "__init__.py").exists():
                    yield target + "." + name, [], node.lineno, id(node) in top, text
            yield target, names, node.lineno, id(node) in top, text
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "elastocell":
                    yield alias.name, [], node.lineno, id(node) in top, lines[node.lineno - 1]


def graph() -> dict[str, set[str]]:
    edges: dict[str, set[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        module = module_name(path)
        edges.setdefault(module, set())
        for target, *_ in imports(path):
            # importing a package runs its __init__, which is the package's own module
            if target != module and not module.startswith(target + ".") and target != "elastocell":
                edges[module].add(target)
    return edges


def test_every_module_in_a_stage_and_imports_only_downward():
    wrong = []
    for path in PACKAGE.rglob("*.py"):
        module = module_name(path)
        for target, _, line, *_ in imports(path):
            if target == "elastocell" or module.startswith(target + "."):
                continue
            if stage(target) > stage(module):
                wrong.append(f"{path.relative_to(PACKAGE)}:{line} {module} -> {target}")
    assert not wrong, "imports that run up the stages:\n" + "\n".join(sorted(wrong))


def test_no_import_cycle():
    edges = graph()
    cycles = []
    state: dict[str, int] = {}

    def visit(node, trail):
        state[node] = 1
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                cycles.append(" -> ".join(trail[trail.index(nxt):] + [nxt]))
            elif nxt not in state:
                visit(nxt, trail + [nxt])
        state[node] = 2

    for node in sorted(edges):
        if node not in state:
            visit(node, [node])
    assert not cycles, "import cycles:\n" + "\n".join(cycles)


def test_no_private_name_imported_from_another_module():
    private = []
    for path in PACKAGE.rglob("*.py"):
        for target, names, line, *_ in imports(path):
            private += [f"{path.relative_to(PACKAGE)}:{line} {target}.{name}" for name in names
                        if name.startswith("_") and name != "__version__"]
    assert not private, "private names imported across modules:\n" + "\n".join(sorted(private))


def test_imports_at_module_top_unless_marked_lazy():
    """An import inside a function is allowed only with a comment on its line saying why it is deferred
    (``# lazy: ...``, a measured start-up cost)."""
    hidden = []
    for path in PACKAGE.rglob("*.py"):
        for target, _, line, at_top, text in imports(path):
            if not at_top and "lazy:" not in text:
                hidden.append(f"{path.relative_to(PACKAGE)}:{line} {target}")
    assert not hidden, "function-level imports of elastocell modules without a '# lazy:' reason:\n" + "\n".join(
        sorted(set(hidden)))


def test_importing_elastocell_changes_no_jax_setting():
    """Importing any stage leaves JAX's process-wide precision and compilation cache as they were; a user's
    own JAX code keeps its float32 (elastocell computes in 64 bit inside its own context)."""
    import subprocess
    import sys

    script = """
import jax
before = (jax.config.jax_enable_x64, jax.config.jax_compilation_cache_dir)
import elastocell, elastocell.body.cell, elastocell.scenarios.compression, elastocell.coupling.immersed_jax
import elastocell.lattice.jax_backend, elastocell.api.compression, elastocell.studies, elastocell.cli
after = (jax.config.jax_enable_x64, jax.config.jax_compilation_cache_dir)
assert before == after, (before, after)
from elastocell.body.cell import Cell
cell = Cell.from_parameters(elastocell.cell_parameters(nucleus="none", element="p1", mesh_size=0.6, pole_size=0.6))
assert cell.internal_forces(cell.mesh.nodes * 1.01).dtype == "float64"
assert jax.config.jax_enable_x64 == before[0]
import jax.numpy as jnp
assert jnp.asarray(1.0).dtype == "float32"
print("ok")
"""
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and result.stdout.strip().endswith("ok"), result.stderr[-2000:]
