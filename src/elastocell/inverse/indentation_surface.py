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
(:func:`elastocell.scenarios.axisymmetric.hertz_half_space_force`, the thick layer's limit).

The adherent cap (``cell_shape="cap"``, a spherical cap of base radius R and apex height H bonded to the dish) is
tabulated at a few heights H/R (:data:`CAP_HEIGHTS`), each like the sphere (R the base radius), to the depth
((H/2)^-2 + R_b^-2)^(-1/2), ``s`` stored as its ratio to Hertz's bead on the cap's curved apex; between the heights
it is interpolated in H (:class:`CapIndentationSurface`), outside them refused (``cap_height``). Its file adds a
``cap_height`` column.

The cone on the bonded layer (``cell_shape="cone-layer"``, ``elastocell mastercurve indentation --indenter cone
--cell-shape layer``; a rigid cone of half-angle alpha, :func:`elastocell.scenarios.indentation.cone_curve`) is
tabulated the same way with ``indenter_ratio`` = tan(alpha) at the angles of :data:`CONE_LAYER`, h the length unit,
to depth h/4, ``s`` stored as its ratio to Sneddon's cone on a half-space
(:func:`elastocell.scenarios.axisymmetric.sneddon_cone_force`).

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
    software_versions,
    write_cache_entry,
)
from elastocell.inverse.mastercurve import CurveFile, check_inputs, shipped_file, shipped_or_cached
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.axisymmetric import (
    AxisymmetricError,
    hertz_half_space_force,
    hertz_sphere_indentation_force,
    indent_axisymmetric,
    sneddon_cone_force,
)
from elastocell.scenarios.indentation import cone_curve, cone_mesh, indentation_curve
from elastocell.version import __version__

CELL_SHAPES = ("sphere", "cap", "layer")
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


LAYER = SurfaceGrid(ratios=(0.01, 0.025, 0.05, 0.1, 0.2, 0.4, 0.8, 1.4, 2.0), held_out=(0.07, 0.28, 1.1),
                    mesh_check=(0.01, 0.4, 2.0),
                    meshes={"default": MeridianMeshParameters(), "fine": MeridianMeshParameters().scaled(0.7)},
                    depth_max=0.5, depth_per_ratio=0.5, steps=10)
"""The layer's surface: R_b/h 0.01-2, from the half-space (a bead on a gel or tissue block 100 R_b thick, whose
bottom effect is below 0.8 %: Dimitriadis's 1 + 1.133 chi at chi = sqrt(R_b d)/h <= 0.007) to a thin cell or gel
of a few um under a 2-20 um bead, to depth min(h/2, R_b/2), 10 load steps; meshes in units of R_b, the fine one
every size x 0.7 at R_b/h 0.01, 0.4 and 2 (validation/indentation.py measures every size x 0.5 at R_b/h = 0.4).
Between and beyond the mesh-check ratios the error is interpolated, clamped. A layer thicker than 100 R_b takes
the R_b/h = 0.01 row relative to Hertz (:data:`LAYER_HALF_SPACE_BELOW`)."""
LAYER_HALF_SPACE_BELOW = 0.01
"""R_b/h below which a layer is a half-space: its F/F_Hertz is the thickest tabulated layer's (the bottom effect
that row still holds, < 0.8 % at d <= R_b/2, is the error of that reading)."""
CAP = SurfaceGrid(ratios=INDENTER_RATIOS, held_out=(), mesh_check=(),
                  meshes={"default": MeridianMeshParameters(), "fine": MeridianMeshParameters().scaled(0.7)},
                  depth_max=0.5, depth_per_ratio=1.0, steps=10)
"""The adherent cap's surface at each of :data:`CAP_HEIGHTS`: R_b/R 0.125-4 (R the base radius; 2-20 um beads on
5-15 um base radii: 0.13-4), to depth ((H/2)^-2 + R_b^-2)^(-1/2) (a smooth min(H/2, R_b); ``depth_max`` in units of
the apex height H), 10 load steps;
the fine mesh (every size x 0.7) at :data:`CAP_MESH_CHECK`, the held-out curves at :data:`CAP_HELD_OUT` (the
cost of the curves on a shared 2-core machine bounds the grid)."""
CAP_HEIGHTS = (0.3, 0.4, 0.5, 0.75, 1.0)
"""H/R of the tabulated caps: a spread adherent cell (fibroblast, epithelial cell: 3-6 um high over a 10-20 um base
radius, H/R 0.3-0.5, where the surface changes fastest with H: tabulated closer) up to a rounded, weakly adherent
one (H/R 0.75) and the hemisphere (1). Between them the surface is interpolated in H (PCHIP at the same depth
fraction); outside [0.3, 1] the fit is refused."""
CAP_HELD_OUT = ((0.5, 0.707), (0.625, 1.0), (0.35, 2.5), (0.55, 0.6), (0.85, 0.2))
"""(H/R, R_b/R) computed and stored held out: a bead radius between the tabulated ones on a tabulated height, a
height between the tabulated ones under a tabulated bead, and three caps on neither: the interpolation's error."""
CAP_MESH_CHECK = ((0.3, 0.125), (0.3, 4.0), (1.0, 0.125))
"""(H/R, R_b/R) computed on the fine mesh too (the thinnest cap under the smallest and the largest bead, the
hemisphere under the smallest); the cap's mesh error at a depth fraction is the largest of theirs."""
CONE_ANGLES = (20.0, 30.0, 45.0, 60.0, 75.0)
"""Half-angles (degrees) of the cone layer's surface: sharp tips (20-30) to blunt ones; 37.5 degrees (near a
35 degree pyramid's equivalent cone, 38.3) held out; below 20 degrees the apex's elements fold before the depth
h/4."""
CONE_LAYER = SurfaceGrid(ratios=tuple(float(np.tan(np.radians(a))) for a in CONE_ANGLES),
                         held_out=(float(np.tan(np.radians(37.5))),),
                         mesh_check=(float(np.tan(np.radians(20.0))), float(np.tan(np.radians(45.0)))),
                         meshes={"default": cone_mesh("layer", 37.5, 0.25),
                                 "fine": cone_mesh("layer", 37.5, 0.25).scaled(0.7)},
                         depth_max=0.25, depth_per_ratio=1e9, steps=10)
"""The cone on the layer: ``indenter_ratio`` = tan(alpha) at :data:`CONE_ANGLES` (37.5 degrees held out), to
depth h/4, 10 load steps, on the cone's default layer mesh (:func:`elastocell.scenarios.indentation.cone_mesh`, in
units of s = h/4 max(tan(alpha), 1)), checked at every size x 0.7 at 20 degrees (the sharpest, the least resolved)
and 45 degrees."""
GRIDS = {"sphere": SurfaceGrid(INDENTER_RATIOS, HELD_OUT_RATIOS, MESH_CHECK_RATIOS, MESHES, DEPTH_MAX,
                               DEPTH_PER_RATIO, STEPS),
         "cap": CAP, "layer": LAYER, "cone-layer": CONE_LAYER}


def depth_limit(indenter_ratio, cell_shape: str = "sphere", cap_height=None):
    """The tabulated depth range at R_b/R (units of R): min(DEPTH_MAX, DEPTH_PER_RATIO R_b/R) (the layer: the
    same with :data:`LAYER`'s constants, R = h; the cap: the smooth minimum ((H/2)^-2 + R_b^-2)^(-1/2), ``cap_height``
    H/R needed)."""
    grid = GRIDS[cell_shape]
    if cell_shape == "cap":  # smooth in R_b and H, so that the curves' depth fractions are (no kink at R_b = H/2)
        reach, bead = grid.depth_max * np.asarray(cap_height, float), grid.depth_per_ratio * np.asarray(
            indenter_ratio, float)
        return (reach**-2 + bead**-2) ** -0.5
    return np.minimum(grid.depth_max, grid.depth_per_ratio * np.asarray(indenter_ratio, float))


def cap_sphere_radius(cap_height):
    """Radius (units of R, the base radius) of the sphere a cap of apex height H is cut from: (1 + H^2) / (2 H)."""
    cap_height = np.asarray(cap_height, float)
    return (1 + cap_height**2) / (2 * cap_height)


def small_depth_limit(depth, indenter_ratio, poisson_ratio: float = 0.48, cell_shape: str = "sphere",
                      cap_height=None):
    """F/(E R^2) of Hertz's limit the surface is stored relative to: the two contacts in series (sphere on a
    dish), the sphere on a half-space (layer), the bead on the cap's curved apex (cap: Hertz's two spheres,
    R_eff = R_b R_c / (R_b + R_c) with R_c :func:`cap_sphere_radius`, on a half-space)."""
    if cell_shape == "layer":
        return hertz_half_space_force(depth, indenter_ratio, poisson_ratio)
    if cell_shape == "cone-layer":  # indenter_ratio = tan(alpha)
        return sneddon_cone_force(depth, np.arctan(indenter_ratio), poisson_ratio)
    if cell_shape == "cap":
        apex = cap_sphere_radius(cap_height)
        indenter_ratio = np.asarray(indenter_ratio, float)
        return hertz_half_space_force(depth, indenter_ratio * apex / (indenter_ratio + apex), poisson_ratio)
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


def curve_function(depth, force, indenter_ratio: float, poisson_ratio: float = 0.48, cell_shape: str = "sphere",
                   cap_height: float | None = None):
    """s(depth) of one computed curve (rows from depth 0, units of R and E R^2): PCHIP in depth of its ratio to
    :func:`small_depth_limit` (1 at depth 0), clamped to the last depth; what the surface does along one
    tabulated ratio."""
    from scipy.interpolate import PchipInterpolator

    depth, force = np.asarray(depth, float), np.asarray(force, float)
    positive = depth > 0
    hertz = small_depth_limit(depth[positive], indenter_ratio, poisson_ratio, cell_shape, cap_height)
    ratio = PchipInterpolator(np.r_[0.0, depth[positive]], np.r_[1.0, force[positive] / hertz])

    def s(x):
        x = np.clip(np.asarray(x, float), 0.0, depth[-1])
        return small_depth_limit(x, indenter_ratio, poisson_ratio, cell_shape, cap_height) * ratio(x)

    return s


@dataclass
class IndentationSurface(CurveFile):
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
    cap_height: float | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.cell_shape == "cap" and self.cap_height is None:
            raise ValueError("indentation surface: a cap's surface needs its cap_height")
        for name in ("indenter_ratio", "depth", "force", "error"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=float))
        held = np.zeros(len(self.depth), bool) if self.held_out is None else np.asarray(self.held_out) > 0.5
        self.held_out = held
        use = ~held
        self.ratios = np.unique(self.indenter_ratio[use])
        fractions = self.depth[use] / self.depth_limit(self.indenter_ratio[use])
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
                                 self.poisson_ratio, self.cell_shape, self.cap_height)

    def depth_fraction(self) -> np.ndarray:
        """Each row's depth over its curve's :func:`depth_limit`."""
        return self.depth / self.depth_limit(self.indenter_ratio)

    def depth_limit(self, indenter_ratio) -> np.ndarray:
        """:func:`depth_limit` of this surface's shape (and cap height), unchecked."""
        return depth_limit(indenter_ratio, self.cell_shape, self.cap_height)

    @property
    def ratio_range(self) -> tuple[float, float]:
        return float(self.ratios[0]), float(self.ratios[-1])

    def depth_max(self, indenter_ratio: float) -> float:
        """The tabulated depth range at R_b/R (units of R)."""
        return float(self.depth_limit(self._check_ratio(indenter_ratio)))

    def _check_ratio(self, indenter_ratio: float) -> float:
        indenter_ratio = float(indenter_ratio)
        low, high = self.ratio_range
        if not low * (1 - 1e-9) <= indenter_ratio <= high * (1 + 1e-9) and self.cell_shape == "cone-layer":
            raise ParameterError("half_angle", f"{np.degrees(np.arctan(indenter_ratio)):.4g} deg is outside the cone "
                                 f"layer's master surface's range [{np.degrees(np.arctan(low)):.3g}, "
                                 f"{np.degrees(np.arctan(high)):.3g}] deg")
        if self.cell_shape == "layer" and 0 < indenter_ratio < low and low <= LAYER_HALF_SPACE_BELOW:
            return indenter_ratio  # thicker than the thickest layer: the half-space (its row, clamped by _across)
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
        with its last local power law (only used transiently by optimisers: a fit's depth window is the
        tabulated range)."""
        from scipy.interpolate import PchipInterpolator

        indenter_ratio = self._check_ratio(indenter_ratio)
        end = float(self.depth_limit(indenter_ratio))
        ratio = PchipInterpolator(self.fractions * end, self._across(self.ratios, self._ratio_grid, indenter_ratio))
        last = float(self.hertz(end, indenter_ratio) * ratio(end))
        closed_form = 2.0 if self.cell_shape == "cone-layer" else 1.5  # Sneddon's cone ~ d^2, Hertz ~ d^1.5
        slope = closed_form + float(ratio.derivative()(end) / ratio(end)) * end

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
        return np.abs(np.interp(np.asarray(depth, float) / self.depth_limit(indenter_ratio),
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
        if self.cap_height is not None:
            metadata["cap_height"] = self.cap_height
        columns = {"indenter_ratio": self.indenter_ratio, "depth": self.depth, "force_per_E_R2": self.force,
                   "error": self.error}
        columns["held_out"] = self.held_out.astype(float)
        return metadata, columns

    @classmethod
    def _from_table(cls, metadata: dict, table: dict) -> IndentationSurface:
        return cls(indenter_ratio=table["indenter_ratio"], depth=table["depth"], force=table["force_per_E_R2"],
                   error=table["error"], poisson_ratio=float(metadata["poisson_ratio"]),
                   material=metadata.get("material", "neo-hookean"), cell_shape=metadata.get("cell_shape", "sphere"),
                   held_out=table.get("held_out"), cap_height=metadata.get("cap_height"), metadata=metadata)


@dataclass
class CapIndentationSurface(CurveFile):
    """The adherent cap's surface: F/(E R^2) over (depth/R, R_b/R) at each apex height H/R of :data:`CAP_HEIGHTS`
    (R the base radius), one table with a ``cap_height`` column.

    Each tabulated height is an :class:`IndentationSurface` (``surfaces[H]``); :meth:`at_height` gives the surface
    at any H in the tabulated range: ``g = s / s_Hertz`` (Hertz's bead on the cap's curved apex,
    :func:`small_depth_limit`) interpolated by PCHIP in H at the same (R_b/R, depth fraction) nodes (at a tabulated
    height: its own values); its mesh error at a depth fraction is the largest relative error of the mesh-check
    curves (:data:`CAP_MESH_CHECK`) there, for every ratio. The rows of :data:`CAP_HELD_OUT` are stored flagged
    ``held_out`` and used by neither interpolation.
    """

    cap_height: np.ndarray
    indenter_ratio: np.ndarray
    depth: np.ndarray
    force: np.ndarray
    error: np.ndarray
    poisson_ratio: float
    material: str = "neo-hookean"
    held_out: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)
    cell_shape = "cap"

    def __post_init__(self):
        for name in ("cap_height", "indenter_ratio", "depth", "force", "error"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=float))
        self.held_out = (np.zeros(len(self.depth), bool) if self.held_out is None
                         else np.asarray(self.held_out, float) > 0.5)
        self.heights = np.unique(self.cap_height[~self.held_out])
        self.surfaces = {}
        for height in self.heights:
            rows = self.cap_height == height
            self.surfaces[float(height)] = IndentationSurface(
                self.indenter_ratio[rows], self.depth[rows], self.force[rows], self.error[rows], self.poisson_ratio,
                self.material, "cap", self.held_out[rows], float(height), self.metadata)
        first = self.surfaces[float(self.heights[0])]
        if len(self.heights) < 2 or any(not (np.array_equal(surface.ratios, first.ratios) and np.allclose(
                surface.fractions, first.fractions)) for surface in self.surfaces.values()):
            raise ValueError("cap indentation surface: fewer than 2 heights, or heights on different grids")
        self.ratios, self.fractions = first.ratios, first.fractions

    @property
    def ratio_range(self) -> tuple[float, float]:
        return float(self.ratios[0]), float(self.ratios[-1])

    @property
    def height_range(self) -> tuple[float, float]:
        return float(self.heights[0]), float(self.heights[-1])

    def depth_fraction(self) -> np.ndarray:
        """Each row's depth over its curve's :func:`depth_limit`."""
        return self.depth / depth_limit(self.indenter_ratio, "cap", self.cap_height)

    def check_height(self, cap_height: float) -> float:
        cap_height = float(cap_height)
        low, high = self.height_range
        if not low * (1 - 1e-9) <= cap_height <= high * (1 + 1e-9):
            raise ParameterError("cap_height", f"H/R = {cap_height:.4g} (apex height over base radius) is outside "
                                 f"the cap's indentation master surface's range [{low:g}, {high:g}] (tabulated: "
                                 + ", ".join(f"{h:g}" for h in self.heights) + ")")
        return min(max(cap_height, low), high)

    def at_height(self, cap_height: float) -> IndentationSurface:
        """The surface of a cap of apex height ``cap_height`` (units of R) in the tabulated range (else a
        ParameterError naming ``cap_height``), interpolated in H (a tabulated height: its own values)."""
        from scipy.interpolate import PchipInterpolator

        cap_height = self.check_height(cap_height)
        surfaces = [self.surfaces[float(height)] for height in self.heights]
        ratio_grid = PchipInterpolator(self.heights, np.stack([s._ratio_grid for s in surfaces]), axis=0)(cap_height)
        ratio, fraction = np.meshgrid(self.ratios, self.fractions, indexing="ij")
        depth = fraction * depth_limit(ratio, "cap", cap_height)
        force = np.where(depth > 0, ratio_grid * small_depth_limit(depth, ratio, self.poisson_ratio, "cap",
                                                                    cap_height), 0.0)
        checked = [s._relative_grid for s in surfaces if len(s._checked_ratios)]
        relative = np.max(np.abs(np.concatenate(checked)), axis=0) if checked else np.full(len(self.fractions), np.nan)
        error = relative[None, :] * force
        return IndentationSurface(ratio.ravel(), depth.ravel(), force.ravel(), error.ravel(), self.poisson_ratio,
                                  self.material, "cap", None, cap_height,
                                  dict(self.metadata, interpolated_between_heights=[float(h) for h in self.heights]))

    def held_out_curves(self) -> dict[tuple[float, float], tuple[np.ndarray, np.ndarray]]:
        """{(H/R, R_b/R): (depth, s)} of the held-out rows."""
        out = {}
        pairs = zip(self.cap_height[self.held_out], self.indenter_ratio[self.held_out], strict=True)
        for height, ratio in sorted(set(pairs)):
            rows = self.held_out & (self.cap_height == height) & (self.indenter_ratio == ratio)
            out[float(height), float(ratio)] = (self.depth[rows], self.force[rows])
        return out

    def _csv(self) -> tuple[dict, dict]:
        metadata = dict(self.metadata, poisson_ratio=self.poisson_ratio, material=self.material, cell_shape="cap",
                        format_version=FORMAT_VERSION)
        return metadata, {"cap_height": self.cap_height, "indenter_ratio": self.indenter_ratio, "depth": self.depth,
                          "force_per_E_R2": self.force, "error": self.error, "held_out": self.held_out.astype(float)}

    @classmethod
    def _from_table(cls, metadata: dict, table: dict) -> CapIndentationSurface:
        return cls(cap_height=table["cap_height"], indenter_ratio=table["indenter_ratio"], depth=table["depth"],
                   force=table["force_per_E_R2"], error=table["error"],
                   poisson_ratio=float(metadata["poisson_ratio"]), material=metadata.get("material", "neo-hookean"),
                   held_out=table.get("held_out"), metadata=metadata)


SURFACE_CLASSES = {"sphere": IndentationSurface, "cap": CapIndentationSurface, "layer": IndentationSurface,
                   "cone-layer": IndentationSurface}


def surface_shape(cell_shape: str, indenter: str = "sphere") -> str:
    """The surface's key of a cell shape under an indenter: the shape itself for a bead, ``cone-layer`` for a cone
    on a layer (the one cone surface: another shape is refused)."""
    if indenter == "sphere":
        return check_shape(cell_shape)
    if indenter != "cone":
        raise ParameterError("indenter", f"must be sphere or cone, got {indenter!r}")
    if cell_shape != "layer":
        raise ParameterError("cell_shape", f"the cone's master surface is the layer's (--cell-shape layer), not "
                                           f"{cell_shape}")
    return "cone-layer"


def check_shape(cell_shape: str) -> str:
    if cell_shape == "cone-layer":
        return cell_shape
    if cell_shape not in CELL_SHAPES:
        raise ParameterError("cell_shape", f"must be sphere, cap or layer, got {cell_shape!r}")
    return cell_shape


def shipped_name(poisson_ratio: float, material: str = "neo-hookean", cell_shape: str = "sphere") -> str:
    return f"mastercurve_indentation_{cell_shape}_{material}_nu{poisson_ratio:.4f}.csv"


def surface_parameters(poisson_ratio: float, material: str = "neo-hookean", cell_shape: str = "sphere") -> dict:
    """What a computed surface is made from, resolved: the homogeneous cell, the meshes, ratios and stepping
    (the layer: also its width rule, 2 h + 4 R_b; the cap: its heights)."""
    grid = GRIDS[cell_shape]
    parameters = {"cell": cell_parameters(nucleus="none", poisson_ratio=poisson_ratio, material=material),
                  "cell_shape": cell_shape, "meshes": grid.meshes, "ratios": sorted(grid.ratios + grid.held_out),
                  "held_out": sorted(grid.held_out), "mesh_check": sorted(grid.mesh_check),
                  "depth_max": grid.depth_max, "depth_per_ratio": grid.depth_per_ratio, "steps": grid.steps}
    if cell_shape == "layer":
        parameters["layer_width"] = layer_width(1.0 / np.array(grid.ratios + grid.held_out)).tolist()
    if cell_shape == "cap":
        parameters.update(heights=list(CAP_HEIGHTS), held_out=list(CAP_HELD_OUT), mesh_check=list(CAP_MESH_CHECK))
    return parameters


def cache_path(poisson_ratio: float, material: str = "neo-hookean", cell_shape: str = "sphere") -> Path:
    digest = parameter_hash(surface_parameters(poisson_ratio, material, cell_shape),
                            format_version=FORMAT_VERSION)[:16]
    return cache_directory() / f"mastercurve-indentation-{digest}.csv"


def read_cached(poisson_ratio: float, material: str = "neo-hookean",
                cell_shape: str = "sphere") -> IndentationSurface | CapIndentationSurface | None:
    return read_cache_entry(cache_path(poisson_ratio, material, cell_shape), "indentation master surface",
                            surface_parameters(poisson_ratio, material, cell_shape), FORMAT_VERSION,
                            lambda payload: SURFACE_CLASSES[cell_shape].from_csv_text(payload.decode()))


def shipped(poisson_ratio: float, material: str = "neo-hookean",
            cell_shape: str = "sphere") -> IndentationSurface | CapIndentationSurface | None:
    resource = shipped_file(shipped_name(poisson_ratio, material, cell_shape))
    return None if resource is None else SURFACE_CLASSES[cell_shape].from_csv(resource)


def load_indentation_surface(poisson_ratio: float = 0.48, material: str = "neo-hookean",
                             cell_shape: str = "sphere", cap_height: float | None = None) -> IndentationSurface:
    """The shipped surface, else a cached one; otherwise a ParameterError naming the command that computes it.
    The cap: the surface at ``cap_height`` (H/R, required; :meth:`CapIndentationSurface.at_height`)."""
    check_inputs(poisson_ratio, material)
    check_shape(cell_shape)
    if cell_shape == "cap" and cap_height is None:
        raise ParameterError("cap_height", "required with --cell-shape cap (the apex height, e.g. 4um)")
    surface = shipped_or_cached(shipped(poisson_ratio, material, cell_shape),
                                lambda: read_cached(poisson_ratio, material, cell_shape), "indentation",
                                poisson_ratio, material, hint="" if cell_shape == "sphere" else
                                "with --indenter cone --cell-shape layer" if cell_shape == "cone-layer" else
                                f"with --cell-shape {cell_shape}", shipped_ratios=SHIPPED_POISSON_RATIOS)
    return surface.at_height(cap_height) if cell_shape == "cap" else surface


def curve_cache_parameters(task) -> dict:
    """What one curve of a surface is made from (the key of its cache entry, so that a stopped surface
    computation resumes from the curves it finished)."""
    cell, cell_shape, cap_height, ratio, name, mesh, steps = task[:7]
    return {"cell": cell, "cell_shape": cell_shape, "cap_height": cap_height, "indenter_ratio": ratio,
            "mesh": mesh, "steps": steps, "depth": float(depth_limit(ratio, cell_shape, cap_height))}


def _curve_cache_path(task) -> Path:
    digest = parameter_hash(curve_cache_parameters(task), format_version=FORMAT_VERSION)[:16]
    return cache_directory() / f"indentation-curve-{digest}.csv"


def _parse_curve(payload: bytes) -> tuple:
    metadata, table = parse_curve_csv(payload.decode())
    return table["depth"], table["force"], metadata


def surface_curve(task) -> tuple:
    """One curve of the surface (a process-pool task): (cap height, ratio, mesh name, depth, force, info), read
    from its cache entry when ``use_cache`` and there is one."""
    cell, cell_shape, cap_height, ratio, name, mesh, steps, use_cache = task
    kind = "indentation surface curve"
    if use_cache:
        cached = read_cache_entry(_curve_cache_path(task), kind, curve_cache_parameters(task), FORMAT_VERSION,
                                  _parse_curve)
        if cached is not None:
            return (cap_height, ratio, name) + cached
    start = time.perf_counter()
    limit = float(depth_limit(ratio, cell_shape, cap_height))
    if cell_shape == "cone-layer":  # R = h: the layer of thickness 1 under the cone of half-angle atan(ratio)
        result = cone_curve(cell, "layer", "cone", float(np.degrees(np.arctan(ratio))), layer_thickness=1.0,
                            depth_max=limit, steps=steps, mesh=mesh)
    elif cell_shape == "layer":  # R = h: the layer of thickness 1, meshed in its own unit R_b
        result = indentation_curve(cell, "layer", ratio, layer_thickness=1.0, depth_max=limit, steps=steps,
                                   mesh=mesh)
    elif cell_shape == "cap":
        result = indentation_curve(cell, "cap", ratio, cap_height=cap_height, depth_max=limit, steps=steps,
                                   mesh=mesh)
    else:
        result = indent_axisymmetric(cell, ratio, limit, steps=steps, mesh=mesh)
    if result.load[-1] < limit - 1e-9:
        raise AxisymmetricError(f"R_b/R = {ratio}: stopped at depth {result.load[-1]}", result)
    info = {"n_nodes": int(result.n_nodes), "substeps": int(result.substeps),
            "wall_time_s": round(time.perf_counter() - start, 2)}
    if use_cache:
        write_cache_entry(_curve_cache_path(task), curve_csv_text(info, {"depth": result.load,
                                                                         "force": result.force}).encode(),
                          kind, curve_cache_parameters(task), FORMAT_VERSION)
    return cap_height, ratio, name, result.load, result.force, info


def cap_curve(cap_height: float, indenter_ratio: float, mesh: MeridianMeshParameters | None = None,
              poisson_ratio: float = 0.48, material: str = "neo-hookean", use_cache: bool = True,
              cached_only: bool = False) -> tuple | None:
    """(depth, F/(E R^2), info) of a homogeneous cap (apex height ``cap_height``, R = 1) indented by a bead of
    radius ``indenter_ratio`` to the surface's depth range, :data:`CAP`'s stepping, on ``mesh`` (None: the
    default), through the surface's curve cache (the surface's own curves are read back, not recomputed);
    ``cached_only``: None when it is not in the cache."""
    cell = surface_parameters(poisson_ratio, material, "cap")["cell"]
    task = (cell, "cap", float(cap_height), float(indenter_ratio), "custom", mesh or MeridianMeshParameters(),
            CAP.steps, use_cache or cached_only)
    if cached_only and not _curve_cache_path(task).exists():
        return None
    return surface_curve(task)[3:]


QUANTITIES = {
    "sphere": "F/(E R^2) of a homogeneous suspended sphere on a rigid dish indented by a rigid frictionless bead of "
              "radius R_b = indenter_ratio R",
    "cap": "F/(E R^2) of a homogeneous spherical cap of base radius R and apex height cap_height R, its base bonded "
           "to a rigid dish, indented on its axis by a rigid frictionless bead of radius R_b = indenter_ratio R",
    "layer": "F/(E h^2) (column force_per_E_R2, R = h) of a homogeneous layer of thickness h bonded to a rigid dish, "
             "2 h + 4 R_b wide, indented by a rigid frictionless bead of radius R_b = indenter_ratio h; meshes in "
             "units of R_b",
    "cone-layer": "F/(E h^2) (column force_per_E_R2, R = h) of a homogeneous layer of thickness h bonded to a rigid "
                  "dish, 2 h + 4 s wide, indented by a rigid frictionless cone of half-angle alpha, "
                  "indenter_ratio = tan(alpha), its apex rounded by 1e-4 s; meshes in units of "
                  "s = h/4 max(tan(alpha), 1)"}


def surface_tasks(poisson_ratio: float, material: str = "neo-hookean", cell_shape: str = "sphere",
                  use_cache: bool = True) -> list[tuple]:
    """The curves of a surface, the fine-mesh ones first (the longest; the cap: its tabulated curves first, then
    the fine mesh, then the held-out curves): (cell, shape, cap height or None, ratio,
    mesh name, mesh, steps, use_cache)."""
    parameters = surface_parameters(poisson_ratio, material, cell_shape)
    grid = GRIDS[cell_shape]
    if cell_shape == "cap":
        pairs = [(height, ratio) for height in CAP_HEIGHTS for ratio in grid.ratios] + list(CAP_HELD_OUT)
        checked = set(CAP_MESH_CHECK)
    else:
        pairs = [(None, ratio) for ratio in parameters["ratios"]]
        checked = {(None, ratio) for ratio in grid.mesh_check}
    tasks = [(parameters["cell"], cell_shape, height, ratio, name, mesh, grid.steps, use_cache)
             for height, ratio in pairs
             for name, mesh in grid.meshes.items() if name == "default" or (height, ratio) in checked]
    if cell_shape == "cap":  # the tabulated curves first, then the fine mesh, then the held-out curves
        return sorted(tasks, key=lambda task: 1 if task[4] == "fine" else 2 * ((task[2], task[3]) in CAP_HELD_OUT))
    return sorted(tasks, key=lambda task: task[4] != "fine")


def compute_indentation_surface(poisson_ratio: float = 0.48, material: str = "neo-hookean",
                                cell_shape: str = "sphere", use_cache: bool = True, progress=None,
                                workers: int = 1) -> IndentationSurface | CapIndentationSurface:
    """Compute (or read from the cache) the surface: one indentation curve per ratio (the cap: per height and
    ratio) on the default mesh, and on the fine mesh at the mesh-check ratios (:data:`GRIDS`), ``workers``
    processes at a time; each finished curve is cached, so that a stopped computation resumes.

    ``progress(label, mesh_name, seconds)`` is called after each curve. A curve that stops before its depth limit
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
    curves, info = {}, {}
    with ProcessPoolExecutor(max(1, workers)) as pool:
        for height, ratio, name, depth, force, details in pool.map(
                surface_curve, surface_tasks(poisson_ratio, material, cell_shape, use_cache)):
            curves[height, ratio, name] = (depth, force)
            label = f"{ratio:g}" if height is None else f"{ratio:g} (H/R = {height:g})"
            info[f"{label}/{name}"] = details
            if progress:
                progress(label, name, details["wall_time_s"])
    columns = {key: [] for key in ("cap_height", "indenter_ratio", "depth", "force", "error", "held_out")}
    for height, ratio, _ in sorted(key for key in curves if key[2] == "default"):
        depth, force = curves[height, ratio, "default"]
        fine = curves.get((height, ratio, "fine"), (None, np.full(len(depth), np.nan)))[1]
        columns["cap_height"] += [np.nan if height is None else height] * len(depth)
        columns["indenter_ratio"] += [ratio] * len(depth)
        columns["depth"] += list(depth)
        columns["force"] += list(force)
        columns["error"] += list(np.abs(np.asarray(fine) - force))
        held = ratio in grid.held_out or (height, ratio) in CAP_HELD_OUT
        columns["held_out"] += [float(held)] * len(depth)
    metadata = {"command": f"elastocell mastercurve indentation --poisson-ratio {poisson_ratio:g} "
                           f"--material {material}" + ("" if cell_shape == "sphere" else " --indenter cone --cell-shape "
                                                       "layer" if cell_shape == "cone-layer"
                                                       else f" --cell-shape {cell_shape}"),
                "quantity": QUANTITIES[cell_shape] + "; depth (units of R) = the bead's displacement after first "
                            "contact; default mesh; error = |fine - default mesh|",
                "meshes": {name: mesh.model_dump() for name, mesh in grid.meshes.items()},
                "curves": info, "steps": grid.steps, "depth_max": grid.depth_max,
                "depth_per_ratio": grid.depth_per_ratio,
                **({"layer_width": "2 h + 4 R_b"} if cell_shape == "layer" else {}),
                **({"depth_range": "((H/2)^-2 + R_b^-2)^(-1/2)", "heights": list(CAP_HEIGHTS),
                    "held_out": list(CAP_HELD_OUT), "mesh_check": list(CAP_MESH_CHECK)} if cell_shape == "cap"
                   else {}),
                "elastocell_version": __version__, "software": software_versions()}
    arrays = {key: np.array(values) for key, values in columns.items()}
    if cell_shape == "cap":
        surface = CapIndentationSurface(**arrays, poisson_ratio=poisson_ratio, material=material, metadata=metadata)
    else:
        del arrays["cap_height"]
        surface = IndentationSurface(**arrays, poisson_ratio=poisson_ratio, material=material,
                                     cell_shape=cell_shape, metadata=metadata)
    if use_cache:
        write_cache_entry(cache_path(poisson_ratio, material, cell_shape), surface.csv_text().encode(),
                          "indentation master surface", parameters, FORMAT_VERSION)
    return surface
