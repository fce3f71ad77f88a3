"""Results on disk: tidy tables (CSV), metadata (JSON), meshes (VTK via meshio) for ParaView."""

from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from .mesh import CellMesh

VTK_CELL_TYPE = {1: "tetra", 2: "tetra10"}


def software_versions() -> dict:
    import gmsh
    import jax
    import meshio
    import scipy

    from . import __version__

    return {
        "elastocell": __version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "jax": jax.__version__,
        "gmsh": gmsh.__version__,
        "meshio": meshio.__version__,
    }


def _replace_atomically(path: Path, write) -> None:
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
    _replace_atomically(path, lambda temporary: temporary.write_text(text))


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
    _replace_atomically(path, lambda temporary: np.savetxt(temporary, data, delimiter=",", header=",".join(names),
                                                          comments="", fmt="%.10g"))


def write_curve_csv(path: Path, metadata: dict, columns: dict[str, np.ndarray]) -> None:
    """A curve as CSV: one ``# {json}`` metadata line, a header row, rows at 10 significant digits; atomic."""
    names = list(columns)
    lines = [f"# {json.dumps(metadata, sort_keys=True)}", ",".join(names)]
    lines += [",".join(f"{v:.10g}" for v in row)
              for row in np.column_stack([np.asarray(columns[k], dtype=float) for k in names])]
    _replace_atomically(Path(path), lambda temporary: temporary.write_text("\n".join(lines) + "\n"))


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


def write_vtk_series(directory: Path, stem: str, mesh: CellMesh, positions: np.ndarray, times: np.ndarray,
                     cell_data: list[dict[str, np.ndarray]]) -> Path:
    """One ``.vtu`` per state plus a ``.pvd`` collection (time = the scenario's parameter, e.g. delta)."""
    import meshio

    directory.mkdir(parents=True, exist_ok=True)
    cell_type = VTK_CELL_TYPE[mesh.order]
    entries = []
    for index, (x, t, data) in enumerate(zip(positions, times, cell_data, strict=True)):
        name = f"{stem}_{index:04d}.vtu"
        displacement = x - mesh.nodes
        meshio.Mesh(
            x, [(cell_type, mesh.elements)], point_data={"displacement": displacement},
            cell_data={k: [v] for k, v in data.items()},
        ).write(directory / name)
        entries.append(f'    <DataSet timestep="{float(t):.8g}" group="" part="0" file="{name}"/>')
    collection = directory / f"{stem}.pvd"
    collection.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n"
    )
    return collection


class Stopwatch:
    def __init__(self):
        self.start = time.perf_counter()

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.start
