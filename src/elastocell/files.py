"""Results on disk: atomic writes, JSON metadata, tidy CSV tables and curves, the versions of the software that
made them, the cache directory, and a stopwatch.
"""

from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from elastocell.version import __version__


def software_versions() -> dict:
    import gmsh
    import jax
    import meshio
    import scipy


    return {
        "elastocell": __version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "jax": jax.__version__,
        "gmsh": gmsh.__version__,
        "meshio": meshio.__version__,
    }


def replace_atomically(path: Path, write) -> None:
    """``write(temporary_path)``, then rename over ``path``: a killed run leaves the old file or the new one,
    never a truncated one."""
    path = Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(temporary)
        os.replace(temporary, path)
    finally:
        if temporary.exists():
            temporary.unlink()


def _finite_or_null(value):
    """NaN and infinities become null: strict JSON has no NaN."""
    if isinstance(value, dict):
        return {key: _finite_or_null(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_null(item) for item in value]
    if isinstance(value, (float, np.floating)) and not np.isfinite(value):
        return None
    return value


def write_json(path: Path, payload: dict) -> None:
    """JSON (indented; NaN written as null), replaced atomically."""
    text = json.dumps(_finite_or_null(json.loads(json.dumps(payload, default=_json_default))), indent=2,
                      allow_nan=False) + "\n"
    replace_atomically(path, lambda temporary: temporary.write_text(text))


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot serialise {type(value)}")


def write_table(path: Path, columns: dict[str, np.ndarray]) -> None:
    """CSV with a header row, full float precision."""
    names = list(columns)
    data = np.column_stack([np.asarray(columns[name], dtype=float) for name in names])
    replace_atomically(path, lambda temporary: np.savetxt(temporary, data, delimiter=",", header=",".join(names),
                                                          comments="", fmt="%.10g"))


def write_curve_csv(path: Path, metadata: dict, columns: dict[str, np.ndarray]) -> None:
    """A curve as CSV: one ``# {json}`` metadata line, a header row, rows at 10 significant digits; atomic."""
    names = list(columns)
    lines = [f"# {json.dumps(metadata, sort_keys=True)}", ",".join(names)]
    lines += [",".join(f"{v:.10g}" for v in row)
              for row in np.column_stack([np.asarray(columns[k], dtype=float) for k in names])]
    replace_atomically(Path(path), lambda temporary: temporary.write_text("\n".join(lines) + "\n"))


def read_curve_csv(path) -> tuple[dict, dict[str, np.ndarray]]:
    """(metadata, {column: values}) of a file written by :func:`write_curve_csv` (a path or a resource)."""
    text = path.read_text() if hasattr(path, "read_text") else Path(path).read_text()
    metadata, rows, names = {}, [], None
    for line in text.splitlines():
        if line.startswith("#"):
            metadata.update(json.loads(line[1:]))
        elif names is None:
            names = line.strip().split(",")
        elif line.strip():
            rows.append([float(v) for v in line.split(",")])
    return metadata, dict(zip(names, np.array(rows).T, strict=True))


class Stopwatch:
    def __init__(self):
        self.start = time.perf_counter()

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.start


def save_figure(figure, path: Path, **options) -> None:
    """``figure.savefig`` written atomically (format from the suffix): a full disk or a kill leaves the previous
    figure or none, never a truncated one; a failed write raises OSError naming the file."""
    path = Path(path)
    try:
        replace_atomically(path, lambda temporary: figure.savefig(temporary, format=path.suffix.lstrip(".") or None,
                                                                  **options))
    except OSError as error:
        raise OSError(error.errno, f"cannot write {path}: {error.strerror or error}", str(path)) from None
