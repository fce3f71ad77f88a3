"""Master curves: the converged homogeneous compression curve F/(E R^2) against delta, as data.

A homogeneous sphere of Young's modulus ``E`` and radius ``R`` squeezed between two rigid frictionless plates
(``delta = 1 - h/(2R)``, docs/theory.md) pushes back with ``F = E R^2 f(delta; nu, law)``. ``f`` is computed once per
Poisson ratio and material law on two p2 meshes (:data:`MESHES`: sizes 0.35/0.1 and 0.25/0.05);
the finer gives the curve, the difference between the two its error estimate. Curves for nu = 0.45, 0.48, 0.49 (neo-Hookean) ship
with the package (``elastocell/data/mastercurve_*.csv``) so that fitting needs no simulation; others are
computed on demand by ``elastocell mastercurve compression`` and cached (``ELASTOCELL_CACHE``): a verified
cache entry (``elastocell.files``) keyed by the resolved parameters of the computation
(:func:`curve_parameters`: the cell of each mesh, the load stepping, the Hertz blend) and :data:`FORMAT_VERSION`;
a cached curve made from other parameters or damaged is reported once and computed again, never used.

Small deformations: a mesh under-resolves the contact patch when delta is small (nu = 0.48: the fine mesh is
6.9 % above Hertz at delta = 0.0125 and the two meshes differ by 9 % there, 3.4 % at 0.05, 1.0 % at 0.1).
Below ``hertz_blend_below`` (0.1) the curve is therefore Hertz's two-contact law times a ratio that goes
linearly from 1 at delta = 0 to the computed ratio f/f_Hertz at 0.1 (1.156 at nu = 0.48); above it, monotone
cubic (PCHIP) interpolation of log f against log delta. The error estimate below 0.1 is the blend's distance from
the fine mesh (2.5 % at delta = 0.05, nu = 0.48), at least the mesh difference at 0.1.

File format: comment lines ``# {json}`` (metadata: the command, meshes, node counts, versions), then a CSV
table ``delta,force_per_E_R2,error,force_per_E_R2_default_mesh``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from elastocell.body.cell import Cell
from elastocell.files import (
    cache_directory,
    curve_csv_text,
    parameter_hash,
    parse_curve_csv,
    read_cache_entry,
    read_curve_csv,
    software_versions,
    write_cache_entry,
    write_curve_csv,
)
from elastocell.parameters.cell import CellParameters, cell_parameters
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.compression import (
    CompressionParameters,
    compress,
    compression_parameters_for,
    hertz_force,
)
from elastocell.version import __version__

SHIPPED_POISSON_RATIOS = (0.45, 0.48, 0.49)
# (mesh_size, pole_size) of the two meshes: a coarser one ("default", the name of its key and CSV column) and a
# finer one; their difference is the error estimate
MESHES = {"default": (0.35, 0.1), "fine": (0.25, 0.05)}
POLE_RADIUS = 0.9  # the pole grading of the shipped curves
DELTA_MAX = 0.75
STEPS = 60
HERTZ_BLEND_BELOW = 0.1  # below: Hertz x linear ratio (the meshes differ by > 1 % there, see module doc)
FORMAT_VERSION = 1
"""Version of the curve CSV and of how a cached curve is computed from its parameters; raised when either
changes. Not raised for the p2 corner contact rule (``compression._surrounded``): it moved the homogeneous
reference cell's F by at most 1.6e-5 (validation/same_outputs.py), below these curves' mesh error."""


class CurveFile:
    """A curve stored as CSV text (``files.curve_csv_text``: one ``# {json}`` metadata line, then the table): a
    subclass gives ``_csv() -> (metadata, columns)`` and the classmethod ``_from_table(metadata, table)``."""

    def to_csv(self, path) -> None:
        write_curve_csv(Path(path), *self._csv())

    def csv_text(self) -> str:
        """The CSV file's text (what :meth:`to_csv` writes)."""
        return curve_csv_text(*self._csv())

    @classmethod
    def from_csv(cls, path):
        return cls._from_table(*read_curve_csv(path))

    @classmethod
    def from_csv_text(cls, text: str):
        return cls._from_table(*parse_curve_csv(text))


@dataclass
class MasterCurve(CurveFile):
    """f(delta) = F/(E R^2) of a homogeneous sphere between parallel plates.

    delta, force: the tabulated curve (fine mesh), starting at delta = 0; error: |fine - default mesh|.
    Call the object with delta (array) for the interpolated f; :meth:`error_at` for the error estimate.
    """

    delta: np.ndarray
    force: np.ndarray
    error: np.ndarray
    poisson_ratio: float
    material: str = "neo-hookean"
    hertz_blend_below: float = HERTZ_BLEND_BELOW
    metadata: dict = field(default_factory=dict)
    force_default_mesh: np.ndarray | None = None

    def __post_init__(self):
        from scipy.interpolate import PchipInterpolator

        self.delta = np.asarray(self.delta, dtype=float)
        self.force = np.asarray(self.force, dtype=float)
        self.error = np.asarray(self.error, dtype=float)
        keep = self.delta >= self.hertz_blend_below - 1e-12
        if keep.sum() < 4:
            raise ValueError("master curve: fewer than 4 tabulated points above the Hertz blend")
        self._start = float(self.delta[keep][0])
        self._end = float(self.delta[-1])
        self._log = PchipInterpolator(np.log(self.delta[keep]), np.log(self.force[keep]), extrapolate=True)
        self._ratio_start = float(self.force[keep][0] / hertz_force(self._start, self.poisson_ratio))
        # relative error: |fine - default| / fine above the blend; below it, the blend's distance from the fine
        # mesh, at least the mesh error at the blend's start (an estimate, not a bound: both meshes over-estimate
        # small-delta forces, and Hertz is exact only as delta -> 0)
        relative = self.error / np.where(self.force > 0, self.force, np.inf)
        below = (self.delta > 0) & ~keep
        if below.any():
            blend = self(self.delta[below])
            relative[below] = np.maximum(relative[keep][0], np.abs(blend / self.force[below] - 1))
        positive = self.delta > 0
        self._relative_error = PchipInterpolator(self.delta[positive], relative[positive])
        self._first = float(self.delta[positive][0])

    @property
    def delta_range(self) -> tuple[float, float]:
        return 0.0, self._end

    def __call__(self, delta) -> np.ndarray:
        delta = np.asarray(delta, dtype=float)
        out = np.zeros_like(delta)
        positive = delta > 0
        small = positive & (delta < self._start)
        large = delta >= self._start
        d = delta[small]
        ratio = 1.0 + (self._ratio_start - 1.0) * d / self._start
        out[small] = hertz_force(d, self.poisson_ratio) * ratio
        out[large] = np.exp(self._log(np.log(np.minimum(delta[large], self._end))))
        beyond = delta > self._end
        if beyond.any():  # continue with the last local power law (only used transiently by optimisers)
            slope = float(self._log.derivative()(np.log(self._end)))
            out[beyond] = np.exp(self._log(np.log(self._end))) * (delta[beyond] / self._end) ** slope
        return out

    def relative_error_at(self, delta) -> np.ndarray:
        """Estimated relative error of f: |fine - default mesh| / fine; below the Hertz blend the larger of that
        and |blend - fine| / fine; constant below the first tabulated delta."""
        delta = np.clip(np.asarray(delta, dtype=float), self._first, self._end)
        return np.abs(self._relative_error(delta))

    def _csv(self, force_default_mesh: np.ndarray | None = None) -> tuple[dict, dict]:
        force_default_mesh = self.force_default_mesh if force_default_mesh is None else force_default_mesh
        metadata = dict(self.metadata, poisson_ratio=self.poisson_ratio, material=self.material,
                        hertz_blend_below=self.hertz_blend_below, format_version=FORMAT_VERSION)
        columns = {"delta": self.delta, "force_per_E_R2": self.force, "error": self.error}
        if force_default_mesh is not None:
            columns["force_per_E_R2_default_mesh"] = force_default_mesh
        return metadata, columns

    def to_csv(self, path: Path, force_default_mesh: np.ndarray | None = None) -> None:
        write_curve_csv(Path(path), *self._csv(force_default_mesh))

    @classmethod
    def _from_table(cls, metadata: dict, table: dict) -> MasterCurve:
        return cls(delta=table["delta"], force=table["force_per_E_R2"], error=table["error"],
                   poisson_ratio=float(metadata["poisson_ratio"]), material=metadata.get("material", "neo-hookean"),
                   hertz_blend_below=float(metadata.get("hertz_blend_below", HERTZ_BLEND_BELOW)), metadata=metadata,
                   force_default_mesh=table.get("force_per_E_R2_default_mesh"))


def check_inputs(poisson_ratio: float, material: str) -> None:
    if not (np.isfinite(poisson_ratio) and -1 < poisson_ratio < 0.5):
        raise ParameterError("poisson_ratio", f"must be in (-1, 0.5), got {poisson_ratio}")
    if material not in ("neo-hookean", "mooney-rivlin"):
        raise ParameterError("material", f"must be neo-hookean or mooney-rivlin, got {material!r}")


def shipped_name(poisson_ratio: float, material: str = "neo-hookean") -> str:
    return f"mastercurve_compression_{material}_nu{poisson_ratio:.4f}.csv"


def curve_parameters(poisson_ratio: float, material: str = "neo-hookean", meshes: dict | None = None,
                     steps: int = STEPS, element: str = "p2") -> dict:
    """What a computed curve is made from, resolved: the homogeneous cell of every mesh (``CellParameters`` with
    the defaults filled in and the quadrature a compression uses), the load stepping and the Hertz blend."""
    cells = {name: compression_parameters_for(cell_parameters(
        nucleus="none", poisson_ratio=poisson_ratio, material=material, element=element, mesh_size=mesh_size,
        pole_size=pole_size, pole_radius=POLE_RADIUS)) for name, (mesh_size, pole_size) in (meshes or MESHES).items()}
    return {"cells": cells, "compression": CompressionParameters(delta_max=DELTA_MAX, steps=steps),
            "hertz_blend_below": HERTZ_BLEND_BELOW}


def cache_path(poisson_ratio: float, material: str = "neo-hookean", meshes: dict | None = None, steps: int = STEPS,
               element: str = "p2") -> Path:
    """The cache entry of a computed curve: named by the hash of its :func:`curve_parameters` and
    :data:`FORMAT_VERSION`."""
    return curve_cache_path("compression", curve_parameters(poisson_ratio, material, meshes, steps, element),
                            FORMAT_VERSION)


def read_cached(poisson_ratio: float, material: str = "neo-hookean", meshes: dict | None = None, steps: int = STEPS,
                element: str = "p2") -> MasterCurve | None:
    """The cached curve of these inputs, verified (None: none, or one that was damaged or made from other
    parameters, reported in a warning and removed)."""
    return read_cached_curve(MasterCurve, "compression", curve_parameters(poisson_ratio, material, meshes, steps,
                                                                          element), FORMAT_VERSION)


# -------------------------------------------------------------------- the cache of computed curves (both kinds)
def curve_cache_path(kind: str, parameters: dict, format_version: int) -> Path:
    """The cache entry of a ``kind`` ("compression", "shear") master curve made from ``parameters``: named by
    their hash (``files.parameter_hash``) with the curve's format version."""
    digest = parameter_hash(parameters, format_version=format_version)[:16]
    return cache_directory() / f"mastercurve-{kind}-{digest}.csv"


def read_cached_curve(curve_class: type[CurveFile], kind: str, parameters: dict, format_version: int):
    """The verified cache entry (``files.read_cache_entry``) of the ``kind`` curve made from ``parameters``, as a
    ``curve_class``; None when there is none (or it was damaged or made from other parameters: reported and
    removed)."""
    return read_cache_entry(curve_cache_path(kind, parameters, format_version), f"{kind} master curve", parameters,
                            format_version, lambda payload: curve_class.from_csv_text(payload.decode()))


def write_cached_curve(curve: CurveFile, kind: str, parameters: dict, format_version: int) -> None:
    """Store ``curve`` as the cache entry of the ``kind`` curve made from ``parameters``."""
    write_cache_entry(curve_cache_path(kind, parameters, format_version), curve.csv_text().encode(),
                      f"{kind} master curve", parameters, format_version)


def shipped_file(name: str):
    """The packaged data file ``name`` (``elastocell/data``), or None."""
    resource = resources.files("elastocell") / "data" / name
    return resource if resource.is_file() else None


def shipped_curve(curve_class: type[CurveFile], name: str):
    """The packaged curve file ``name`` as a ``curve_class``, or None."""
    resource = shipped_file(name)
    return None if resource is None else curve_class.from_csv(resource)


def shipped(poisson_ratio: float, material: str = "neo-hookean") -> MasterCurve | None:
    return shipped_curve(MasterCurve, shipped_name(poisson_ratio, material))


def shipped_or_cached(shipped_curve, cached: Callable[[], object], kind: str, poisson_ratio: float, material: str,
                      hint: str = "", shipped_ratios=SHIPPED_POISSON_RATIOS):
    """The shipped curve, else ``cached()`` (the verified cache entry, or None); otherwise a ParameterError naming
    the ``elastocell mastercurve KIND`` command that computes it."""
    if shipped_curve is not None:
        return shipped_curve
    curve = cached()
    if curve is not None:
        return curve
    shipped_list = ", ".join(f"{nu:g}" for nu in shipped_ratios)
    raise ParameterError(
        "poisson_ratio",
        f"no {kind} master curve for nu={poisson_ratio:g} ({material}); shipped: {shipped_list} (neo-hookean); "
        f"compute it with: elastocell mastercurve {kind} --poisson-ratio {poisson_ratio:g} --material {material}"
        + (f" ({hint})" if hint else ""))


def load_master_curve(poisson_ratio: float = 0.48, material: str = "neo-hookean") -> MasterCurve:
    """The shipped curve, else a cached one; otherwise a ParameterError naming the command that computes it."""
    check_inputs(poisson_ratio, material)
    return shipped_or_cached(shipped(poisson_ratio, material), lambda: read_cached(poisson_ratio, material),
                             "compression", poisson_ratio, material)


def compute_master_curve(poisson_ratio: float = 0.48, material: str = "neo-hookean", use_cache: bool = True,
                         progress=None, meshes: dict | None = None, steps: int = STEPS,
                         element: str = "p2") -> MasterCurve:
    """Compute (or read from the cache) the homogeneous curve on the default and the fine mesh.

    ``progress(mesh_name, delta)`` is called after each converged row. Returns the fine-mesh curve with
    ``error = |fine - default|``; the default-mesh forces are kept as ``force_default_mesh`` (a CSV column).
    ``meshes`` ({"default": (mesh_size, pole_size), "fine": ...}, default :data:`MESHES`), ``steps`` and
    ``element`` are part of the cache key.
    """

    check_inputs(poisson_ratio, material)
    meshes = meshes or MESHES
    parameters = curve_parameters(poisson_ratio, material, meshes, steps, element)
    if use_cache:
        cached = read_cached_curve(MasterCurve, "compression", parameters, FORMAT_VERSION)
        if cached is not None:
            return cached
    scenario: CompressionParameters = parameters["compression"]
    forces, info = {}, {}
    delta = None
    for name, (mesh_size, pole_size) in meshes.items():
        start = time.perf_counter()
        resolved: CellParameters = parameters["cells"][name]
        cell = Cell.from_parameters(resolved)
        result = compress(cell, scenario, progress=(lambda d, n=name: progress(n, d)) if progress else None)
        delta = result.delta
        forces[name] = result.force
        info[name] = {"mesh_size": mesh_size, "pole_size": pole_size, "pole_radius": POLE_RADIUS,
                      "n_nodes": int(cell.mesh.n_nodes),
                      "wall_time_s": round(time.perf_counter() - start, 2),
                      "unstable_rows": int(np.asarray(result.unstable).sum()),
                      "max_rigid_reaction": float(result.max_rigid_reaction)}
    fine, default = forces["fine"], forces["default"]
    curve = MasterCurve(
        delta=delta, force=fine, error=np.abs(fine - default), poisson_ratio=poisson_ratio, material=material,
        metadata={"command": f"elastocell mastercurve compression --poisson-ratio {poisson_ratio:g} "
                             f"--material {material}",
                  "quantity": "F/(E R^2) of a homogeneous sphere between rigid frictionless parallel plates, "
                              "delta = 1 - h/(2R); error = |fine - default mesh|",
                  "element": element, "steps": steps, "delta_max": DELTA_MAX, "meshes": info,
                  "elastocell_version": __version__, "software": software_versions()})
    curve.force_default_mesh = default
    if use_cache:
        write_cached_curve(curve, "compression", parameters, FORMAT_VERSION)
    return curve
