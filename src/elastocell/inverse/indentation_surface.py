"""Master surfaces of bead indentation: the converged F/(E R^2) of a homogeneous cell over (depth/R, R_b/R), as data.

A rigid frictionless sphere of radius ``R_b`` pressed on the axis into a homogeneous suspended cell of radius ``R``
and Young's modulus ``E`` resting on a rigid frictionless dish (:func:`elastocell.scenarios.axisymmetric.
indent_axisymmetric`) pushes back with ``F = E R^2 s(depth/R, R_b/R; nu, law)``; ``depth`` is the bead's
displacement after first contact. ``s`` is computed once per Poisson ratio and law on two meridian meshes
at the indenter ratios :data:`INDENTER_RATIOS` on the solver's default meridian mesh, to the depth
:func:`depth_limit` (R_b for a small bead, at most R/2), and at :data:`MESH_CHECK_RATIOS` also on a mesh with every
size halved (:data:`MESHES`): their difference is the error estimate. The
ratios :data:`HELD_OUT_RATIOS` are computed too and stored in the same file, flagged ``held_out``: they are not
used by the interpolation and measure its error (tests/test_fit_indenter.py).

Interpolation: the surface is stored as ``g = s / s_Hertz``, with ``s_Hertz`` Hertz's two contacts in series (bead
on cell with R_eff = R_b R/(R_b + R), cell on dish; :func:`elastocell.scenarios.axisymmetric.
hertz_sphere_indentation_force`), which tends to 1 as depth -> 0 and varies slowly. ``g`` is interpolated by
monotone cubics (PCHIP) in log(R_b/R) at the same fraction x = depth/depth_limit(R_b/R) of each curve's range,
then in x with ``g(0) = 1``; outside the
tabulated ratios the call is refused (:class:`ParameterError` naming ``indenter_radius``).

The bonded layer (``cell_shape="layer"``, a gel or tissue section of thickness h on a rigid dish, laterally
:func:`elastocell.body.axisymmetric.layer_width` wide) is tabulated the same way with h as the length unit R:
``F = E h^2 s(depth/h, R_b/h)`` at the ratios R_b/h of :data:`LAYER`, to :func:`depth_limit` = min(h/2, R_b), its
meshes in units of R_b (the layer's own unit), ``s`` stored as its ratio to Hertz's sphere on a half-space
(:func:`elastocell.scenarios.axisymmetric.hertz_half_space_force`, the thick layer's limit). Caps have no surface.

File format: comment lines ``# {json}`` (metadata: the command, meshes, node counts, versions), then a CSV table
``indenter_ratio,depth,force_per_E_R2,error,held_out`` (units of R and E R^2; error NaN where the fine mesh was not
run).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from elastocell.body.axisymmetric import MeridianMeshParameters, layer_width
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
from elastocell.inverse.mastercurve import check_inputs, shipped_file, shipped_or_cached
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.axisymmetric import (
    AxisymmetricError,
    hertz_half_space_force,
    hertz_sphere_indentation_force,
    indent_axisymmetric,
)
from elastocell.scenarios.indentation import indentation_curve
from elastocell.version import __version__

CELL_SHAPES = ("sphere", "layer")
"""The cell shapes with a master surface."""
SHIPPED_POISSON_RATIOS = (0.48,)
INDENTER_RATIOS = (0.125, 0.25, 0.5, 1.0, 2.0, 4.0)
"""R_b/R of the tabulated curves (2-20 um beads on 5-15 um cells: 0.13-4)."""
HELD_OUT_RATIOS = (0.177, 0.707, 2.83)
"""R_b/R computed and stored but not interpolated: the interpolation error is measured on them."""
MESH_CHECK_RATIOS = (0.125, 1.0, 4.0)
"""R_b/R computed on the finer mesh too: the error estimate (interpolated in log(R_b/R) between them)."""
MESHES = {"default": MeridianMeshParameters(),
          "fine": MeridianMeshParameters(mesh_size=0.05, surface_size=0.02, pole_size=0.005)}
"""The surface is the default mesh's (the solver's default); the fine mesh halves every size."""
DEPTH_MAX = 0.5
DEPTH_PER_RATIO = 1.0
"""Each curve goes to depth = min(DEPTH_MAX, DEPTH_PER_RATIO R_b) (units of R): a small bead is tabulated to its
own radius (an AFM indentation rarely goes deeper), a large one to half the cell's radius."""
STEPS = 20
FORMAT_VERSION = 1


@dataclass(frozen=True)
class SurfaceGrid:
    """What a cell shape's surface tabulates: the ratios R_b/R (R: the shape's length unit), held-out and
    mesh-check ratios, the meshes (in the body's unit), the depth range min(depth_max R, depth_per_ratio R_b) and
    the load steps per curve."""

    ratios: tuple
    held_out: tuple
    mesh_check: tuple
    meshes: dict
    depth_max: float
    depth_per_ratio: float
    steps: int


LAYER = SurfaceGrid(ratios=(0.2, 0.4, 0.8, 1.4, 2.0), held_out=(0.28, 1.1), mesh_check=(0.4, 2.0),
                    meshes={"default": MeridianMeshParameters(), "fine": MeridianMeshParameters().scaled(0.7)},
                    depth_max=0.5, depth_per_ratio=0.5, steps=10)
"""The layer's surface: R_b/h 0.2-2 (a 2-20 um bead on a tissue section up to 5 R_b thick, or on a thin cell or gel
of a few um), to depth min(h/2, R_b/2), 10 load steps (R_b/h = 0.1, a layer 10 R_b thick and 24 R_b wide, stopped
without convergence at depth 0.44 R_b); meshes in units of R_b, the fine one every size x 0.7 at R_b/h
0.4 and 2 (the curves' cost on a shared 2-core machine bounds the grid; validation/indentation.py measures every
size x 0.5 at R_b/h = 0.4). Between and beyond the mesh-check ratios the error is interpolated, clamped."""
GRIDS = {"sphere": SurfaceGrid(INDENTER_RATIOS, HELD_OUT_RATIOS, MESH_CHECK_RATIOS, MESHES, DEPTH_MAX,
                               DEPTH_PER_RATIO, STEPS),
         "layer": LAYER}


def depth_limit(indenter_ratio, cell_shape: str = "sphere"):
    """The tabulated depth range at R_b/R (units of R): min(DEPTH_MAX, DEPTH_PER_RATIO R_b/R) (the layer: the
    same with :data:`LAYER`'s constants, R = h)."""
    grid = GRIDS[cell_shape]
    return np.minimum(grid.depth_max, grid.depth_per_ratio * np.asarray(indenter_ratio, float))


def small_depth_limit(depth, indenter_ratio, poisson_ratio: float = 0.48, cell_shape: str = "sphere"):
    """F/(E R^2) of Hertz's limit the surface is stored relative to: the two contacts in series (sphere on a
    dish), the sphere on a half-space (layer)."""
    if cell_shape == "layer":
        return hertz_half_space_force(depth, indenter_ratio, poisson_ratio)
    return hertz_sphere_indentation_force(depth, indenter_ratio, poisson_ratio)


def dimitriadis_bonded_force(depth, indenter_radius, thickness=1.0, poisson_ratio: float = 0.48):
    """F/E of a rigid sphere (radius R_b) pressed to ``depth`` into a layer of ``thickness`` h bonded to a rigid
    substrate, Dimitriadis et al. (2002, Biophys. J. 82, 2798, eq. 12 with the bonded alpha_0, beta_0 of nu):
    Hertz's half-space force times a series in chi = sqrt(R_b depth)/h (at nu = 0.5: 1 + 1.133 chi + 1.283 chi^2
    + 0.769 chi^3 + 0.0975 chi^4), a small-chi expansion."""
    chi = np.sqrt(indenter_radius * np.asarray(depth, float)) / thickness
    nu = poisson_ratio
    a0 = -(1.2876 - 1.4678 * nu + 1.3442 * nu**2) / (1 - nu)
    b0 = (0.6387 - 1.0277 * nu + 1.5164 * nu**2) / (1 - nu)
    factor = (1 - 2 * a0 / np.pi * chi + 4 * a0**2 / np.pi**2 * chi**2
              - 8 / np.pi**3 * (a0**3 + 4 * np.pi**2 * b0 / 15) * chi**3
              + 16 * a0 / np.pi**4 * (a0**3 + 3 * np.pi**2 * b0 / 5) * chi**4)
    return hertz_half_space_force(depth, indenter_radius, nu) * factor


def garcia_bonded_force(depth, indenter_radius, thickness=1.0, poisson_ratio: float = 0.48):
    """F/E of the same bonded layer by Garcia & Garcia (2018, Biophys. J. 114, 2923)'s bottom-effect correction of
    a paraboloid, 1 + 1.133 chi + 1.497 chi^2 + 1.469 chi^3 + 0.755 chi^4 (derived for nu = 0.5; applied here to
    Hertz at ``poisson_ratio``)."""
    chi = np.sqrt(indenter_radius * np.asarray(depth, float)) / thickness
    factor = 1 + 1.133 * chi + 1.497 * chi**2 + 1.469 * chi**3 + 0.755 * chi**4
    return hertz_half_space_force(depth, indenter_radius, poisson_ratio) * factor


def curve_function(depth, force, indenter_ratio: float, poisson_ratio: float = 0.48, cell_shape: str = "sphere"):
    """s(depth) of one computed curve (rows from depth 0, units of R and E R^2): PCHIP in depth of its ratio to
    :func:`small_depth_limit` (1 at depth 0), clamped to the last depth; what the surface does along one
    tabulated ratio."""
    from scipy.interpolate import PchipInterpolator

    depth, force = np.asarray(depth, float), np.asarray(force, float)
    positive = depth > 0
    hertz = small_depth_limit(depth[positive], indenter_ratio, poisson_ratio, cell_shape)
    ratio = PchipInterpolator(np.r_[0.0, depth[positive]], np.r_[1.0, force[positive] / hertz])

    def s(x):
        x = np.clip(np.asarray(x, float), 0.0, depth[-1])
        return small_depth_limit(x, indenter_ratio, poisson_ratio, cell_shape) * ratio(x)

    return s


@dataclass
class IndentationSurface:
    """s(depth, R_b/R) = F/(E R^2) of a homogeneous suspended cell (or layer, R = h) indented by a bead (lengths
    in R).

    indenter_ratio, depth, force, error: the tabulated rows (error = |fine - default mesh|, NaN where the fine mesh
    was not run), one per (ratio, step), the steps of every ratio at the same fractions of its
    :func:`depth_limit`; held_out: rows not used by the interpolation.
    Call with (depth, indenter_ratio) for the interpolated s; :meth:`curve` for s(depth) at one ratio.
    """

    indenter_ratio: np.ndarray
    depth: np.ndarray
    force: np.ndarray
    error: np.ndarray
    poisson_ratio: float
    material: str = "neo-hookean"
    cell_shape: str = "sphere"
    held_out: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        for name in ("indenter_ratio", "depth", "force", "error"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=float))
        held = np.zeros(len(self.depth), bool) if self.held_out is None else np.asarray(self.held_out) > 0.5
        self.held_out = held
        use = ~held
        self.ratios = np.unique(self.indenter_ratio[use])
        fractions = self.depth[use] / depth_limit(self.indenter_ratio[use], self.cell_shape)
        self.fractions = np.unique(np.round(fractions, 9))
        if len(self.ratios) < 2 or len(self.fractions) < 4:
            raise ValueError("indentation surface: fewer than 2 ratios or 4 depths")
        grid = np.full((len(self.ratios), len(self.fractions)), np.nan)
        relative = np.full_like(grid, np.nan)
        rows = np.searchsorted(self.ratios, self.indenter_ratio[use])
        columns = np.searchsorted(self.fractions, np.round(fractions, 9))
        hertz = self.hertz(self.depth[use], self.indenter_ratio[use])
        positive = self.depth[use] > 0
        grid[rows, columns] = np.where(positive, self.force[use] / np.where(positive, hertz, 1.0), 1.0)
        relative[rows, columns] = np.where(positive, self.error[use] / np.where(positive, self.force[use], 1.0), 0.0)
        if not np.all(np.isfinite(grid)):
            raise ValueError("indentation surface: the table is not a full (ratio, depth fraction) grid")
        self._ratio_grid = grid
        checked = np.all(np.isfinite(relative), axis=1)
        self._checked_ratios, self._relative_grid = self.ratios[checked], relative[checked]

    def hertz(self, depth, indenter_ratio) -> np.ndarray:
        """Hertz's limit F/(E R^2) (:func:`small_depth_limit`) of the surface."""
        return small_depth_limit(np.maximum(np.asarray(depth, float), 0.0), np.asarray(indenter_ratio, float),
                                 self.poisson_ratio, self.cell_shape)

    @property
    def ratio_range(self) -> tuple[float, float]:
        return float(self.ratios[0]), float(self.ratios[-1])

    def depth_max(self, indenter_ratio: float) -> float:
        """The tabulated depth range at R_b/R (units of R)."""
        return float(depth_limit(self._check_ratio(indenter_ratio), self.cell_shape))

    def _check_ratio(self, indenter_ratio: float) -> float:
        indenter_ratio = float(indenter_ratio)
        low, high = self.ratio_range
        if not low * (1 - 1e-9) <= indenter_ratio <= high * (1 + 1e-9):
            unit = "h" if self.cell_shape == "layer" else "R"
            raise ParameterError("indenter_radius", f"R_b/{unit} = {indenter_ratio:.4g} is outside the "
                                 f"{self.cell_shape}'s indentation master surface's range [{low:g}, {high:g}]")
        return indenter_ratio

    @staticmethod
    def _across(ratios: np.ndarray, grid: np.ndarray, indenter_ratio: float) -> np.ndarray:
        """``grid`` (one row per ratio) interpolated by PCHIP in log(R_b/R) at one ratio (clamped to ``ratios``)."""
        from scipy.interpolate import PchipInterpolator

        if len(ratios) == 1:
            return grid[0]
        where = np.clip(np.log(indenter_ratio), np.log(ratios[0]), np.log(ratios[-1]))
        return PchipInterpolator(np.log(ratios), grid, axis=0)(where)

    def curve(self, indenter_ratio: float):
        """s(depth) at one R_b/R: a function of depth (units of R, array), continued beyond the tabulated depth
        with its last local power law (only used transiently by optimisers)."""
        from scipy.interpolate import PchipInterpolator

        indenter_ratio = self._check_ratio(indenter_ratio)
        end = float(depth_limit(indenter_ratio, self.cell_shape))
        ratio = PchipInterpolator(self.fractions * end, self._across(self.ratios, self._ratio_grid, indenter_ratio))
        last = float(self.hertz(end, indenter_ratio) * ratio(end))
        slope = 1.5 + float(ratio.derivative()(end) / ratio(end)) * end

        def s(depth):
            depth = np.maximum(np.asarray(depth, float), 0.0)
            inside = np.minimum(depth, end)
            out = self.hertz(inside, indenter_ratio) * ratio(inside)
            return np.where(depth > end, last * (np.maximum(depth, end) / end) ** slope, out)

        return s

    def __call__(self, depth, indenter_ratio: float) -> np.ndarray:
        return self.curve(indenter_ratio)(depth)

    def relative_error_at(self, depth, indenter_ratio: float) -> np.ndarray:
        """|fine - default mesh| / default at the mesh-check ratios, interpolated in log(R_b/R) (clamped) and
        linearly in the depth fraction; NaN without a fine-mesh curve."""
        indenter_ratio = self._check_ratio(indenter_ratio)
        if not len(self._checked_ratios):
            return np.full(np.shape(depth), np.nan)
        column = self._across(self._checked_ratios, self._relative_grid, indenter_ratio)
        return np.abs(np.interp(np.asarray(depth, float) / depth_limit(indenter_ratio, self.cell_shape),
                                self.fractions, column))

    def held_out_curves(self) -> dict[float, tuple[np.ndarray, np.ndarray]]:
        """{R_b/R: (depth, s)} of the held-out rows."""
        out = {}
        for ratio in np.unique(self.indenter_ratio[self.held_out]):
            rows = self.held_out & (self.indenter_ratio == ratio)
            out[float(ratio)] = (self.depth[rows], self.force[rows])
        return out

    def _csv(self) -> tuple[dict, dict]:
        metadata = dict(self.metadata, poisson_ratio=self.poisson_ratio, material=self.material,
                        cell_shape=self.cell_shape, format_version=FORMAT_VERSION)
        columns = {"indenter_ratio": self.indenter_ratio, "depth": self.depth, "force_per_E_R2": self.force,
                   "error": self.error}
        columns["held_out"] = self.held_out.astype(float)
        return metadata, columns

    def to_csv(self, path: Path) -> None:
        write_curve_csv(Path(path), *self._csv())

    def csv_text(self) -> str:
        return curve_csv_text(*self._csv())

    @classmethod
    def from_csv(cls, path) -> IndentationSurface:
        return cls._from_table(*read_curve_csv(path))

    @classmethod
    def from_csv_text(cls, text: str) -> IndentationSurface:
        return cls._from_table(*parse_curve_csv(text))

    @classmethod
    def _from_table(cls, metadata: dict, table: dict) -> IndentationSurface:
        return cls(indenter_ratio=table["indenter_ratio"], depth=table["depth"], force=table["force_per_E_R2"],
                   error=table["error"], poisson_ratio=float(metadata["poisson_ratio"]),
                   material=metadata.get("material", "neo-hookean"), cell_shape=metadata.get("cell_shape", "sphere"),
                   held_out=table.get("held_out"), metadata=metadata)


def check_shape(cell_shape: str) -> str:
    if cell_shape not in ("sphere", "cap", "layer"):
        raise ParameterError("cell_shape", f"must be sphere, cap or layer, got {cell_shape!r}")
    if cell_shape not in CELL_SHAPES:
        raise ParameterError("cell_shape", f"{cell_shape}: no master surface for this cell shape (the cap's is not "
                                           "computed); available: " + ", ".join(CELL_SHAPES))
    return cell_shape


def shipped_name(poisson_ratio: float, material: str = "neo-hookean", cell_shape: str = "sphere") -> str:
    return f"mastercurve_indentation_{cell_shape}_{material}_nu{poisson_ratio:.4f}.csv"


def surface_parameters(poisson_ratio: float, material: str = "neo-hookean", cell_shape: str = "sphere") -> dict:
    """What a computed surface is made from, resolved: the homogeneous cell, the meshes, ratios and stepping
    (the layer: also its width rule, 2 h + 4 R_b)."""
    grid = GRIDS[cell_shape]
    parameters = {"cell": cell_parameters(nucleus="none", poisson_ratio=poisson_ratio, material=material),
                  "cell_shape": cell_shape, "meshes": grid.meshes, "ratios": sorted(grid.ratios + grid.held_out),
                  "held_out": sorted(grid.held_out), "mesh_check": sorted(grid.mesh_check),
                  "depth_max": grid.depth_max, "depth_per_ratio": grid.depth_per_ratio, "steps": grid.steps}
    if cell_shape == "layer":
        parameters["layer_width"] = layer_width(1.0 / np.array(grid.ratios + grid.held_out)).tolist()
    return parameters


def cache_path(poisson_ratio: float, material: str = "neo-hookean", cell_shape: str = "sphere") -> Path:
    digest = parameter_hash(surface_parameters(poisson_ratio, material, cell_shape),
                            format_version=FORMAT_VERSION)[:16]
    return cache_directory() / f"mastercurve-indentation-{digest}.csv"


def read_cached(poisson_ratio: float, material: str = "neo-hookean",
                cell_shape: str = "sphere") -> IndentationSurface | None:
    return read_cache_entry(cache_path(poisson_ratio, material, cell_shape), "indentation master surface",
                            surface_parameters(poisson_ratio, material, cell_shape), FORMAT_VERSION,
                            lambda payload: IndentationSurface.from_csv_text(payload.decode()))


def shipped(poisson_ratio: float, material: str = "neo-hookean", cell_shape: str = "sphere") -> IndentationSurface | None:
    resource = shipped_file(shipped_name(poisson_ratio, material, cell_shape))
    return None if resource is None else IndentationSurface.from_csv(resource)


def load_indentation_surface(poisson_ratio: float = 0.48, material: str = "neo-hookean",
                             cell_shape: str = "sphere") -> IndentationSurface:
    """The shipped surface, else a cached one; otherwise a ParameterError naming the command that computes it."""
    check_inputs(poisson_ratio, material)
    check_shape(cell_shape)
    return shipped_or_cached(shipped(poisson_ratio, material, cell_shape),
                             lambda: read_cached(poisson_ratio, material, cell_shape), "indentation", poisson_ratio,
                             material, shipped_ratios=SHIPPED_POISSON_RATIOS)


def _indentation_curve(task) -> tuple:
    """One curve of the surface (a process-pool task): (ratio, mesh name, depth, force, info)."""
    cell, cell_shape, ratio, name, mesh, steps = task
    start = time.perf_counter()
    limit = float(depth_limit(ratio, cell_shape))
    if cell_shape == "layer":  # R = h: the layer of thickness 1, meshed in its own unit R_b
        result = indentation_curve(cell, "layer", ratio, layer_thickness=1.0, depth_max=limit, steps=steps,
                                   mesh=mesh)
    else:
        result = indent_axisymmetric(cell, ratio, limit, steps=steps, mesh=mesh)
    if result.load[-1] < limit - 1e-9:
        raise AxisymmetricError(f"R_b/R = {ratio}: stopped at depth {result.load[-1]}", result)
    return ratio, name, result.load, result.force, {"n_nodes": int(result.n_nodes), "substeps": int(result.substeps),
                                                    "wall_time_s": round(time.perf_counter() - start, 2)}


QUANTITIES = {
    "sphere": "F/(E R^2) of a homogeneous suspended sphere on a rigid dish indented by a rigid frictionless bead of "
              "radius R_b = indenter_ratio R",
    "layer": "F/(E h^2) (column force_per_E_R2, R = h) of a homogeneous layer of thickness h bonded to a rigid dish, "
             "2 h + 4 R_b wide, indented by a rigid frictionless bead of radius R_b = indenter_ratio h; meshes in "
             "units of R_b"}


def compute_indentation_surface(poisson_ratio: float = 0.48, material: str = "neo-hookean",
                                cell_shape: str = "sphere", use_cache: bool = True, progress=None,
                                workers: int = 1) -> IndentationSurface:
    """Compute (or read from the cache) the surface: one indentation curve per ratio on the default mesh, and on
    the fine mesh at the mesh-check ratios (:data:`GRIDS`), ``workers`` processes at a time.

    ``progress(ratio, mesh_name, seconds)`` is called after each curve. A curve that stops before its depth limit
    raises :class:`AxisymmetricError` (the table must be a full grid)."""
    from concurrent.futures import ProcessPoolExecutor

    check_inputs(poisson_ratio, material)
    check_shape(cell_shape)
    parameters = surface_parameters(poisson_ratio, material, cell_shape)
    if use_cache:
        cached = read_cached(poisson_ratio, material, cell_shape)
        if cached is not None:
            return cached
    grid = GRIDS[cell_shape]
    tasks = [(parameters["cell"], cell_shape, ratio, name, mesh, grid.steps) for ratio in parameters["ratios"]
             for name, mesh in grid.meshes.items() if name == "default" or ratio in grid.mesh_check]
    tasks.sort(key=lambda task: task[3] != "fine")  # the longest first
    curves, info = {}, {}
    with ProcessPoolExecutor(max(1, workers)) as pool:
        for ratio, name, depth, force, details in pool.map(_indentation_curve, tasks):
            curves[ratio, name] = (depth, force)
            info[f"{ratio:g}/{name}"] = details
            if progress:
                progress(ratio, name, details["wall_time_s"])
    columns = {key: [] for key in ("indenter_ratio", "depth", "force", "error", "held_out")}
    for ratio in parameters["ratios"]:
        depth, force = curves[ratio, "default"]
        fine = curves.get((ratio, "fine"), (None, np.full(len(depth), np.nan)))[1]
        columns["indenter_ratio"] += [ratio] * len(depth)
        columns["depth"] += list(depth)
        columns["force"] += list(force)
        columns["error"] += list(np.abs(np.asarray(fine) - force))
        columns["held_out"] += [float(ratio in grid.held_out)] * len(depth)
    surface = IndentationSurface(
        **{key: np.array(values) for key, values in columns.items()}, poisson_ratio=poisson_ratio,
        material=material, cell_shape=cell_shape,
        metadata={"command": f"elastocell mastercurve indentation --poisson-ratio {poisson_ratio:g} "
                             f"--material {material}" + ("" if cell_shape == "sphere" else
                                                         f" --cell-shape {cell_shape}"),
                  "quantity": QUANTITIES[cell_shape] + "; depth (units of R) = the bead's displacement after first "
                              "contact; default mesh; error = |fine - default mesh|",
                  "meshes": {name: mesh.model_dump() for name, mesh in grid.meshes.items()},
                  "curves": info, "steps": grid.steps, "depth_max": grid.depth_max,
                  "depth_per_ratio": grid.depth_per_ratio, **({"layer_width": "2 h + 4 R_b"} if cell_shape ==
                                                              "layer" else {}),
                  "elastocell_version": __version__, "software": software_versions()})
    if use_cache:
        write_cache_entry(cache_path(poisson_ratio, material, cell_shape), surface.csv_text().encode(),
                          "indentation master surface", parameters, FORMAT_VERSION)
    return surface
