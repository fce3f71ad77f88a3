"""Results on disk: tidy tables (CSV), metadata (JSON), meshes (VTK via meshio) for ParaView."""

from __future__ import annotations

import json
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


def write_json(path: Path, payload: dict) -> None:
    path.write_text(json.dumps(payload, indent=2, sort_keys=False, default=_json_default) + "\n")


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
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.10g")


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
