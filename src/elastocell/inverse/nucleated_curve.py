"""The nucleated cell's own force curve, for fitting E_c directly: F = E_c R^2 f(x; gamma, lambda).

A homogeneous master curve turns a measured force curve into the modulus of a homogeneous cell, E_hom; the
volume average (or the Hashin-Shtrikman bound) then converts E_hom into the cytoplasm's E_c. That conversion is
the paper's hypothesis, and it is measured not to hold exactly: E_hom/E_c depends on the loading and grows with
the deformation (docs/validation/afm.md, "Nucleus"). Here the curve of the cell with its nucleus itself is
computed, once per cell, geometry and Poisson ratio, by the axisymmetric solver
(:mod:`elastocell.scenarios.axisymmetric`), so that E_c is fitted without any conversion:

- ``parallel-plates``: a cell of radius R with a concentric spherical nucleus of radius lambda R and modulus
  gamma E_c between rigid frictionless plates, F/(E_c R^2) over delta = 1 - h/(2R) to delta 0.75
  (:func:`elastocell.scenarios.axisymmetric.compress_axisymmetric`, 40 steps);
- ``sphere-indenter``, ``cell_shape="sphere"``: the same cell resting on a rigid frictionless dish under a rigid
  bead of radius R_b on its axis, F/(E_c R^2) over depth/R to the master surface's depth range
  (:func:`elastocell.inverse.indentation_surface.depth_limit`, 20 steps);
- ``sphere-indenter``, ``cell_shape="cap"``: a spherical cap of base radius R and apex height H bonded to the
  dish, its nucleus (radius lambda R) centred on the axis at H/2.

The meridian mesh is the solver's default; against its own refinement (every size x 0.5,
docs/validation/axisymmetric.md: plates, lambda 0.5) the compression curve is within 0.10 % at delta <= 0.5 and
0.46 % at delta 0.7 for gamma <= 20. The first load step is computed again in :data:`FIRST_STEP_ROWS` steps: a
large or shallow nucleus raises the force over Hertz's within it (plates, lambda 0.7, gamma 5: 1.44 times Hertz at
delta 0.019), and a fit over a small window needs those rows (without them, fits to delta 0.025 of that cell read
E_c 2.5-4 % low). Below about a twentieth of the range the default mesh's contact steps (the force is within
+-1 % of a finer mesh's there) still move such a fit by up to 2 % (docs/validation/afm.md). Each row keeps the smallest volume ratio J of the
cell (:attr:`NucleatedCurve.min_volume_ratio`): the cytoplasm crushed between nucleus and plate loses volume under
the compressible law, and a fit that reaches J < :data:`COLLAPSE_VOLUME_RATIO` is flagged.
A layer or a cone (a homogeneous gel or tissue) has no nucleus, and a nucleus off the axis is not axisymmetric:
neither has a curve here.

Between rows the curve is interpolated like one curve of a master surface
(:func:`elastocell.inverse.indentation_surface.curve_function`): monotone cubics of its ratio to the small-depth
Hertz limit of the cytoplasm (plates: Hertz's two contacts; a bead: the surface's limit), which is 1 at zero
load. Each curve is a verified cache entry (``elastocell.files``) keyed by everything it is made from.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from elastocell.body.axisymmetric import (
    NUCLEUS_MARGIN,
    MeridianGeometry,
    MeridianMeshParameters,
    meridian_nucleus,
)
from elastocell.files import (
    cache_directory,
    curve_csv_text,
    parameter_hash,
    parse_curve_csv,
    read_cache_entry,
    write_cache_entry,
)
from elastocell.inverse.indentation_surface import curve_function, depth_limit
from elastocell.parameters.cell import cell_parameters
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.axisymmetric import (
    AxisymmetricError,
    AxisymmetricInterrupted,
    compress_axisymmetric,
)
from elastocell.scenarios.compression import hertz_force
from elastocell.scenarios.indentation import indentation_curve
from elastocell.version import __version__

FORMAT_VERSION = 2
PLATES_DELTA_MAX = 0.75
"""delta range of the plates' curve (the homogeneous master curve's)."""
STEPS = {"parallel-plates": 40, "sphere-indenter": 20}
"""Equal load steps of each geometry's curve (compression's and the master surface's stepping)."""
SHAPES = ("sphere", "cap")
"""The bead geometries with a nucleus: the suspended cell and the adherent cap."""
MIN_ROWS = 4
"""Fewest converged rows past zero load that a curve stopped early must have to be used."""
FIRST_STEP_ROWS = 8
"""Rows the first load step is resolved in (a short curve to the first step's load, merged)."""
COLLAPSE_VOLUME_RATIO = 0.5
"""J below which the fit flags the cell's volume collapse (``elastocell compress`` warns at the same J)."""


@dataclass
class NucleatedCurve:
    """F/(E_c R^2) of a cell with a concentric nucleus against its load (``load``: delta for the plates, depth/R
    for a bead; rows from 0), computed to ``load_reached`` of ``load_requested``; call it with the load."""

    geometry: str
    load: np.ndarray
    force: np.ndarray
    load_requested: float
    metadata: dict = field(default_factory=dict)
    min_volume_ratio: np.ndarray | None = None

    def __post_init__(self):
        self.load = np.asarray(self.load, float)
        self.force = np.asarray(self.force, float)
        if self.min_volume_ratio is not None:
            self.min_volume_ratio = np.asarray(self.min_volume_ratio, float)
        info = self.metadata
        if self.geometry == "parallel-plates":
            nu = info["poisson_ratio"]
            self._limit = lambda x: hertz_force(np.maximum(np.asarray(x, float), 0.0), nu)
        else:
            self._limit = None
        self._function = self._interpolant()

    def _interpolant(self):
        from scipy.interpolate import PchipInterpolator

        if self._limit is None:
            info = self.metadata
            return curve_function(self.load, self.force, info["indenter_ratio"], info["poisson_ratio"],
                                  info["cell_shape"], info["cap_ratio"])
        positive = self.load > 0
        ratio = PchipInterpolator(np.r_[0.0, self.load[positive]],
                                  np.r_[1.0, self.force[positive] / self._limit(self.load[positive])])

        def f(x):
            x = np.clip(np.asarray(x, float), 0.0, self.load[-1])
            return self._limit(x) * ratio(x)

        return f

    @property
    def load_reached(self) -> float:
        return float(self.load[-1])

    def collapse_load(self, volume_ratio: float = COLLAPSE_VOLUME_RATIO) -> float:
        """The first load (delta or depth/R) at which some element's J is below ``volume_ratio``; inf if none."""
        if self.min_volume_ratio is None:
            return float("inf")
        below = np.flatnonzero(self.min_volume_ratio < volume_ratio)
        if not below.size:
            return float("inf")
        if below[0] == 0:
            return 0.0
        i = below[0]  # J crosses volume_ratio between rows i - 1 and i: linearly
        j0, j1 = self.min_volume_ratio[i - 1], self.min_volume_ratio[i]
        return float(self.load[i - 1] + (self.load[i] - self.load[i - 1]) * (j0 - volume_ratio) / (j0 - j1))

    def __call__(self, load) -> np.ndarray:
        return self._function(load)


def check_nucleus_fits(size_ratio: float, cell_shape: str = "sphere", cap_ratio: float | None = None) -> None:
    """Refuse (``nucleus_size_ratio``, one line) a nucleus of radius ``size_ratio`` R that does not lie inside the
    cell: in a cap of apex height ``cap_ratio`` R, centred on its axis at half its height, at least
    :data:`elastocell.body.axisymmetric.NUCLEUS_MARGIN` from its surface and base."""
    if not 0 < size_ratio < 1:
        raise ParameterError("nucleus_size_ratio", f"must be in (0, 1), got {size_ratio}")
    if cell_shape != "cap":
        return
    cell = cell_parameters(nucleus="sphere", size_ratio=float(size_ratio))
    # unvalidated: the cap's height range is the surface's and the solver's to refuse, under --cap-height
    geometry = MeridianGeometry.model_construct(shape="cap", height=float(cap_ratio))
    try:
        meridian_nucleus(cell, geometry)
    except ParameterError:
        raise ParameterError("nucleus_size_ratio", f"a nucleus of radius {size_ratio:g} R centred at half the cap's "
                                                   f"height does not fit inside a cap of height {cap_ratio:.3g} R "
                                                   f"(at least {NUCLEUS_MARGIN:g} R from its surface and base): "
                                                   "a smaller --nucleus-size-ratio") from None


def curve_parameters(geometry: str, size_ratio: float, stiffness_ratio: float, poisson_ratio: float = 0.48,
                     material: str = "neo-hookean", cell_shape: str = "sphere", indenter_ratio: float | None = None,
                     cap_ratio: float | None = None) -> dict:
    """What the curve is made from, resolved (the cache key): the nucleated cell, the geometry, the meridian mesh,
    the load range and stepping. Impossible combinations are refused in one line (:class:`ParameterError`)."""
    if geometry not in STEPS:
        raise ParameterError("geometry", f"a nucleus is modelled under the plates or a bead (sphere-indenter), not "
                                         f"{geometry}: a layer or a cone tip indents a homogeneous gel or tissue")
    if geometry == "sphere-indenter":
        if cell_shape not in SHAPES:
            raise ParameterError("cell_shape", f"the {cell_shape} is homogeneous (a gel or tissue section): give "
                                               f"no --nucleus-size-ratio/--stiffness-ratio, or --cell-shape sphere "
                                               f"or cap")
        if not (indenter_ratio and indenter_ratio > 0):
            raise ParameterError("indenter_radius", "required with a bead")
        if cell_shape == "cap" and not (cap_ratio and cap_ratio > 0):
            raise ParameterError("cap_height", "required with --cell-shape cap")
        check_nucleus_fits(size_ratio, cell_shape, cap_ratio)
    cell = cell_parameters(nucleus="sphere", size_ratio=float(size_ratio), stiffness_ratio=float(stiffness_ratio),
                           poisson_ratio=float(poisson_ratio), material=material)
    plates = geometry == "parallel-plates"
    load = PLATES_DELTA_MAX if plates else float(depth_limit(indenter_ratio, cell_shape, cap_ratio))
    return {"geometry": geometry, "cell": cell, "cell_shape": None if plates else cell_shape,
            "indenter_ratio": None if plates else float(indenter_ratio),
            "cap_ratio": float(cap_ratio) if not plates and cell_shape == "cap" else None,
            "mesh": MeridianMeshParameters(), "load_max": load, "steps": STEPS[geometry],
            "first_step_rows": FIRST_STEP_ROWS}


def _cache_path(parameters: dict):
    return cache_directory() / f"nucleated-curve-{parameter_hash(parameters, format_version=FORMAT_VERSION)[:16]}.csv"


def _solve(parameters: dict, load_max: float, steps: int):
    """The curve of ``parameters`` to ``load_max`` in ``steps`` equal steps (an interruption propagates)."""
    cell, mesh = parameters["cell"], parameters["mesh"]
    if parameters["geometry"] == "parallel-plates":
        return compress_axisymmetric(cell, load_max, steps=steps, mesh=mesh)
    return indentation_curve(cell, parameters["cell_shape"], parameters["indenter_ratio"],
                             cap_height=parameters["cap_ratio"], depth_max=load_max, steps=steps, mesh=mesh)


def _compute(parameters: dict):
    """(load, force, min_volume_ratio, info) of the curve, computed: the first step in :data:`FIRST_STEP_ROWS`
    rows (if that fails, the curve goes without them, and ``info["stopped"]`` says so), then the whole range; a
    curve that stops early keeps its converged rows when it has :data:`MIN_ROWS` of them. Ctrl-C
    (:class:`AxisymmetricInterrupted`) is not a stop: it propagates, and nothing is cached."""
    load_max, steps = parameters["load_max"], parameters["steps"]
    start = time.perf_counter()
    stop = ""
    try:
        first = _solve(parameters, load_max / steps, parameters["first_step_rows"])
    except AxisymmetricInterrupted:
        raise
    except AxisymmetricError as error:  # the first step in rows failed: the curve without them
        first, stop = None, f"first step in rows: {error}"
    try:
        result = _solve(parameters, load_max, steps)
    except AxisymmetricInterrupted:
        raise
    except AxisymmetricError as error:
        result = error.partial
        if result is None or len(result.load) <= MIN_ROWS:
            raise ParameterError("stiffness_ratio", f"the nucleated cell's curve could not be computed ({error}); "
                                                    "fit without the nucleus options") from None
        stop = "; ".join(filter(None, (stop, str(error))))
    if first is None:
        load, force, volume = result.load, result.force, result.min_volume_ratio
    else:  # the first step's end is the curve's first row
        load = np.r_[first.load[:-1], result.load[1:]]
        force = np.r_[first.force[:-1], result.force[1:]]
        volume = np.r_[first.min_volume_ratio[:-1], result.min_volume_ratio[1:]]
    info = {"n_nodes": int(result.n_nodes), "wall_time_s": round(time.perf_counter() - start, 2),
            "min_volume_ratio": float(np.min(volume)), "stopped": stop}
    return load, force, volume, info


def nucleated_curve(geometry: str, size_ratio: float, stiffness_ratio: float, poisson_ratio: float = 0.48,
                    material: str = "neo-hookean", cell_shape: str = "sphere", indenter_ratio: float | None = None,
                    cap_ratio: float | None = None, use_cache: bool = True) -> NucleatedCurve:
    """The curve of the cell of nucleus ``size_ratio`` lambda and ``stiffness_ratio`` gamma under ``geometry``
    (``parallel-plates`` or ``sphere-indenter``; a bead: ``cell_shape`` sphere or cap, ``indenter_ratio`` R_b/R,
    ``cap_ratio`` H/R), read from the cache or computed (seconds) and cached."""
    parameters = curve_parameters(geometry, size_ratio, stiffness_ratio, poisson_ratio, material, cell_shape,
                                  indenter_ratio, cap_ratio)
    path = _cache_path(parameters)
    kind = "nucleated cell curve"
    entry = None
    if use_cache:
        entry = read_cache_entry(path, kind, parameters, FORMAT_VERSION, lambda payload: parse_curve_csv(
            payload.decode()))
    if entry is not None:
        info, table = entry
        load, force, volume = table["load"], table["force_per_Ec_R2"], table["min_volume_ratio"]
    else:
        load, force, volume, details = _compute(parameters)
        info = {"quantity": "F/(E_c R^2) of a cell with a concentric spherical nucleus (radius lambda R, modulus "
                            "gamma E_c), axisymmetric solver, default meridian mesh; load: delta (plates) or the "
                            "bead's depth/R",
                **{key: value for key, value in parameters.items() if key not in ("cell", "mesh")},
                "size_ratio": float(size_ratio), "stiffness_ratio": float(stiffness_ratio),
                "poisson_ratio": float(poisson_ratio), "material": material, **details,
                "elastocell_version": __version__}
        if use_cache:
            write_cache_entry(path, curve_csv_text(info, {"load": load, "force_per_Ec_R2": force,
                                                           "min_volume_ratio": volume}).encode(), kind,
                              parameters, FORMAT_VERSION)
    return NucleatedCurve(geometry, load, force, parameters["load_max"], dict(info), volume)


def volume_fraction(size_ratio: float, cell_shape: str = "sphere", cap_ratio: float | None = None) -> float:
    """phi: the nucleus's share of the cell's volume, lambda^3 in a sphere; in a cap of base radius R and apex
    height H, (4/3 pi lambda^3) / (pi H (3 + H^2) / 6) (lengths in R)."""
    if cell_shape == "cap":
        return (4.0 / 3.0 * size_ratio**3) / (cap_ratio * (3.0 + cap_ratio**2) / 6.0)
    return size_ratio**3

