"""The shear-flow master curve: Taylor deformation D, inclination and tank-treading frequency against Ca.

A homogeneous neo-Hookean cell (Kelvin-Voigt: the immersed-boundary fluid fills it, viscosity ratio 1) in plane
Couette flow reaches a stationary tank-treading shape (docs/theory.md, "Shear flow"). Its stationary observables
depend only on the capillary number ``Ca = eta * shear_rate / mu`` (and nu, the material law and the
numerics), so measuring D gives Ca and, with the shear stress ``tau = eta * shear_rate``, the shear modulus
``mu = tau / Ca`` (:func:`elastocell.inverse.fit.fit_shear`).

Computation (:func:`compute_shear_master_curve`): the existing shear scenario (:func:`elastocell.shear`,
default flow: confinement 2R/H = 0.2, box 8R, the matched tau at particle Reynolds number <= 0.1, p1 mesh with edges 2 dx) is run
for every Ca of :data:`CAPILLARY_NUMBERS` at two resolutions R/dx (:data:`RESOLUTIONS`: 6 and the default 8)
for a strain of :data:`DURATION` (4); the stationary values are the means over the second half of each run
(strain 2..4; ``summary.json`` of the run). The lattice shear rate at these settings does not depend on Ca
(the Reynolds-number limit at tau 1 sets it: 2,160 LB steps per strain at R/dx = 6, 3,840 at 8; the matched
tau is 2 except at Ca 0.025 and 0.05 at R/dx 6 and 0.025 at 8, where the elastic step limit holds it lower).

Discretisation error and the tabulated curve: the excess of D/Ca over the small-Ca theory 5/4 falls like
(dx/R)^2 (README: D/Ca = 1.64, 1.46, 1.37, 1.32 at R/dx = 4, 6, 8, 10 and Ca = 0.05). The tabulated
curve is therefore the Richardson extrapolation of the two resolutions with order 2,
``X = X_8 + (X_8 - X_6) / ((8/6)^2 - 1)``, and its ``*_error`` columns are the size of that correction,
``|X - X_8|``: the distance of the finest run from the extrapolation. That is an estimate, not a bound: it
assumes the order-2 convergence measured at Ca = 0.05 holds at every Ca (two resolutions cannot check the
order), and it is conservative if the extrapolation is right (the extrapolated D/Ca at the smallest Ca can be
compared with 5/4, see the metadata's ``small_ca_check``). The raw columns of both resolutions are kept.
Measured for the shipped nu = 0.48 curve: the extrapolated D/Ca at the smallest Ca against 5/4 is the
metadata's ``small_ca_check`` (docs/validation/fit.md); against Roscoe's finite-Ca theory and with an R/dx 10
run at Ca = 0.3: docs/validation/shear_targets.md.

Small Ca: between Ca = 0 and the first tabulated Ca, D/Ca goes linearly from the theory's 5/4 to the first
tabulated value (the analogue of the compression curve's Hertz blend); above it, monotone cubic (PCHIP)
interpolation of D/Ca against Ca. Inclination and tank-treading frequency (angular velocity of the membrane
over the shear rate, positive for the rotation the flow imposes) are interpolated the same way (theory at
Ca -> 0: 45 degrees and 1/2 for an unbounded sphere; the viscosity ratio 1 of the immersed boundary lowers both
at first order in Ca).

File format: comment lines ``# {json}`` (metadata), then a CSV table with the columns of :data:`COLUMNS`.
"""

from __future__ import annotations

import json
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from elastocell.api.resolved import resolved_parameters
from elastocell.api.shear import shear
from elastocell.files import parameter_hash, software_versions, write_json
from elastocell.inverse.mastercurve import (
    CurveFile,
    curve_cache_path,
    read_cached_curve,
    shipped_curve,
    shipped_or_cached,
    write_cached_curve,
)
from elastocell.parameters.units import ParameterError
from elastocell.simulation.extrapolation import CONVERGENCE_ORDER, richardson
from elastocell.simulation.runner import resume_or_restart
from elastocell.version import __version__

SHIPPED_POISSON_RATIOS = (0.48,)
CAPILLARY_NUMBERS = (0.025, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4)
RESOLUTIONS = (6.0, 8.0)  # R/dx: coarse, default (the default is ShearFlowParameters.resolution)
DURATION = 4.0  # strain; stationary means over the second half
SMALL_CA_DEFORMATION_SLOPE = 1.25  # D -> (5/4) Ca (Taylor/Roscoe, neo-Hookean sphere, Stokes flow)
SMALL_CA_INCLINATION_DEG = 45.0
SMALL_CA_TANK_TREADING = 0.5
FORMAT_VERSION = 1
"""Version of the curve CSV and of how a cached curve is computed from its parameters; raised when either
changes."""
OBSERVABLES = ("deformation", "inclination_deg", "tank_treading_frequency")
COLUMNS = ("capillary_number", "deformation", "deformation_error", "inclination_deg", "inclination_deg_error",
           "tank_treading_frequency", "tank_treading_frequency_error")


def check_inputs(poisson_ratio: float, material: str) -> None:
    if not (np.isfinite(poisson_ratio) and -1 < poisson_ratio < 0.5):
        raise ParameterError("poisson_ratio", f"must be in (-1, 0.5), got {poisson_ratio}")
    if material not in ("neo-hookean", "mooney-rivlin"):
        raise ParameterError("material", f"must be neo-hookean or mooney-rivlin, got {material!r}")


@dataclass
class ShearMasterCurve(CurveFile):
    """Stationary D, inclination (degrees) and tank-treading frequency (x shear rate) against Ca.

    ``table``: the CSV columns (at least :data:`COLUMNS`; raw per-resolution columns ``<name>_rdx<R>`` too).
    ``curve(ca)`` gives D; :meth:`value` any observable; :meth:`capillary_number` inverts D (or another
    monotone observable).
    """

    table: dict
    poisson_ratio: float
    material: str = "neo-hookean"
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        from scipy.interpolate import PchipInterpolator

        self.table = {k: np.asarray(v, dtype=float) for k, v in self.table.items()}
        ca = self.table["capillary_number"]
        order = np.argsort(ca)
        self.table = {k: v[order] for k, v in self.table.items()}
        ca = self.table["capillary_number"]
        if ca.size < 3 or ca[0] <= 0:
            raise ValueError("shear master curve: needs at least 3 capillary numbers > 0")
        self.ca_min, self.ca_max = float(ca[0]), float(ca[-1])
        self._interpolants = {}
        for name, at_zero in (("deformation", SMALL_CA_DEFORMATION_SLOPE), ("inclination_deg", SMALL_CA_INCLINATION_DEG),
                              ("tank_treading_frequency", SMALL_CA_TANK_TREADING)):
            values = self.table[name]  # PCHIP on the values themselves: monotone data stay monotone
            first = float(values[0] / ca[0]) if name == "deformation" else float(values[0])
            self._interpolants[name] = (PchipInterpolator(ca, values, extrapolate=True), at_zero, first)
            error = self.table[f"{name}_error"] / (values if name == "deformation" else 1.0)  # D: relative
            self._interpolants[f"{name}_error"] = (PchipInterpolator(ca, error, extrapolate=False), None,
                                                   float(error[0]))

    # ---------------------------------------------------------------- evaluation
    def value(self, name: str, ca) -> np.ndarray:
        """Observable ``name`` (deformation, inclination_deg, tank_treading_frequency) at Ca: PCHIP through the
        tabulated points (extrapolated with the end's cubic slightly beyond ca_max, for optimisers only); below
        the first tabulated Ca, linear from the small-Ca theory to the first point (for D: D/Ca linear from 5/4)."""
        interpolant, at_zero, first = self._interpolants[name]
        ca = np.asarray(ca, dtype=float)
        out = np.asarray(interpolant(np.clip(ca, self.ca_min, None)), dtype=float)
        small = ca < self.ca_min
        if small.any():
            c = np.clip(ca, 0.0, None)
            blend = at_zero + (first - at_zero) * c / self.ca_min
            out = np.where(small, blend * c if name == "deformation" else blend, out)
        return out

    def error(self, name: str, ca) -> np.ndarray:
        """The error column of ``name`` interpolated at Ca (PCHIP; for D its relative error, constant below the
        first tabulated Ca; constant beyond ca_max)."""
        ca = np.clip(np.asarray(ca, dtype=float), 0.0, self.ca_max)
        interpolant, _, first = self._interpolants[f"{name}_error"]
        scaled = np.where(ca < self.ca_min, first, np.abs(interpolant(np.clip(ca, self.ca_min, self.ca_max))))
        return scaled * self.value(name, ca) if name == "deformation" else scaled

    def __call__(self, ca) -> np.ndarray:
        return self.value("deformation", ca)

    def range(self, name: str = "deformation") -> tuple[float, float]:
        """The observable's values over 0 < Ca <= ca_max (deformation: (0, D(ca_max)))."""
        if name == "deformation":
            return 0.0, float(self(self.ca_max))
        values = self.value(name, np.linspace(0.0, self.ca_max, 401))
        return float(values.min()), float(values.max())

    def capillary_number(self, observed: float, name: str = "deformation", extrapolate: bool = False) -> float:
        """Ca at which observable ``name`` equals ``observed`` (it must be monotone in Ca over the curve).
        ``extrapolate``: beyond the range, continue along the end's local slope instead of returning nan."""
        from scipy.optimize import brentq

        grid = np.linspace(0.0, self.ca_max, 801)
        values = self.value(name, grid)
        step = np.diff(values)
        if not (np.all(step > 0) or np.all(step < 0)):
            raise ValueError(f"{name} is not monotone in Ca over the master curve")
        increasing = step[0] > 0
        low, high = (values[0], values[-1]) if increasing else (values[-1], values[0])
        if observed < low or observed > high:
            if not extrapolate:
                return float("nan")
            at_end = (observed > high) == increasing  # beyond ca_max
            if not at_end:  # below Ca = 0: the bound is Ca = 0
                return 0.0
            slope = (values[-1] - values[-2]) / (grid[-1] - grid[-2])
            return float(self.ca_max + (observed - values[-1]) / slope)
        if observed == values[0]:
            return 0.0
        return float(brentq(lambda c: float(self.value(name, c)) - observed, 0.0, self.ca_max, xtol=1e-12))

    # ---------------------------------------------------------------- files
    def _csv(self) -> tuple[dict, dict]:
        metadata = dict(self.metadata, poisson_ratio=self.poisson_ratio, material=self.material,
                        format_version=FORMAT_VERSION)
        names = list(COLUMNS) + [k for k in self.table if k not in COLUMNS]
        return metadata, {k: self.table[k] for k in names}

    @classmethod
    def _from_table(cls, metadata: dict, table: dict) -> ShearMasterCurve:
        return cls(table=table, poisson_ratio=float(metadata["poisson_ratio"]),
                   material=metadata.get("material", "neo-hookean"), metadata=metadata)


# -------------------------------------------------------------------- shipped, cached, computed
def shipped_name(poisson_ratio: float, material: str = "neo-hookean") -> str:
    return f"mastercurve_shear_{material}_nu{poisson_ratio:.4f}.csv"


def _run_options(poisson_ratio: float, material: str, ca: float, resolution: float, duration: float) -> dict:
    """The ``elastocell.shear`` options of one run of the curve (:func:`_run_one` calls it with them)."""
    return {"capillary_number": float(ca), "resolution": float(resolution), "duration": float(duration),
            "vtk_interval": None, "extrapolate": False, "nucleus": "none", "poisson_ratio": float(poisson_ratio), "material": material}


def curve_parameters(poisson_ratio: float, material: str = "neo-hookean", capillary_numbers=CAPILLARY_NUMBERS,
                     resolutions=RESOLUTIONS, duration: float = DURATION) -> dict:
    """What a computed curve is made from, resolved: every shear run's parameters
    (``api.resolved.resolved_parameters``: cell, flow, stop criteria, options with their defaults) and the
    extrapolation's order."""
    capillary_numbers = tuple(sorted(float(c) for c in capillary_numbers))
    resolutions = tuple(sorted(float(r) for r in resolutions))
    runs = [resolved_parameters("shear", _run_options(poisson_ratio, material, ca, resolution, duration))
            for resolution in resolutions for ca in capillary_numbers]
    return {"runs": runs, "convergence_order": CONVERGENCE_ORDER}


def cache_path(poisson_ratio: float, material: str = "neo-hookean", capillary_numbers=CAPILLARY_NUMBERS,
               resolutions=RESOLUTIONS, duration: float = DURATION) -> Path:
    """The cache entry of a computed curve: named by the hash of its :func:`curve_parameters` and
    :data:`FORMAT_VERSION`."""
    return curve_cache_path("shear", curve_parameters(poisson_ratio, material, capillary_numbers, resolutions,
                                                      duration), FORMAT_VERSION)


def read_cached(poisson_ratio: float, material: str = "neo-hookean", capillary_numbers=CAPILLARY_NUMBERS,
                resolutions=RESOLUTIONS, duration: float = DURATION) -> ShearMasterCurve | None:
    """The cached curve of these inputs, verified (None: none, or one that was damaged or made from other
    parameters, reported in a warning and removed)."""
    return read_cached_curve(ShearMasterCurve, "shear", curve_parameters(poisson_ratio, material, capillary_numbers,
                                                                         resolutions, duration), FORMAT_VERSION)


def shipped(poisson_ratio: float, material: str = "neo-hookean") -> ShearMasterCurve | None:
    return shipped_curve(ShearMasterCurve, shipped_name(poisson_ratio, material))


def load_shear_master_curve(poisson_ratio: float = 0.48, material: str = "neo-hookean") -> ShearMasterCurve:
    """The shipped curve, else the cached one (default grid); otherwise a ParameterError naming the command."""
    check_inputs(poisson_ratio, material)
    return shipped_or_cached(shipped(poisson_ratio, material), lambda: read_cached(poisson_ratio, material),
                             "shear", poisson_ratio, material, "about 20 min on one core", SHIPPED_POISSON_RATIOS)


RUN_KEY_FILE = "curve_run.json"
"""Written beside a finished run's summary.json: the hash of the run's resolved parameters, checked before the
summary is reused."""


def _run_one(poisson_ratio: float, material: str, ca: float, resolution: float, duration: float,
             directory: Path, use_cache: bool) -> dict:
    """One shear run, or its summary.json from an earlier, finished run made from the same resolved parameters
    (``parameter_hash`` of ``resolved_parameters("shear", options)``, in :data:`RUN_KEY_FILE`). A summary made
    from other parameters (a ``work_directory`` shared by two curves) or without a key is reported and the run
    made again; an unfinished run continues from its checkpoint when the checkpoint matches."""

    options = _run_options(poisson_ratio, material, ca, resolution, duration)
    key = parameter_hash(resolved_parameters("shear", options), format_version=FORMAT_VERSION)
    summary_path, key_path = directory / "summary.json", directory / RUN_KEY_FILE
    if use_cache and summary_path.exists():
        try:
            summary = json.loads(summary_path.read_text())
            finished = summary.get("duration_strain", 0.0) >= duration - 1e-9
            recorded = json.loads(key_path.read_text()).get("parameter_hash") if key_path.exists() else None
        except (OSError, ValueError, AttributeError, TypeError) as error:
            warnings.warn(f"{summary_path} is not used ({type(error).__name__}: {error}); the run is made again",
                          stacklevel=2)
        else:
            if recorded == key and finished:
                return summary
            if recorded is not None or finished:  # an interrupted run has no key yet: it continues silently
                warnings.warn(f"{summary_path} is not used (made from other parameters than this run's, or without "
                              f"their hash in {RUN_KEY_FILE}); the run is made again", stacklevel=2)
    key_path.unlink(missing_ok=True)
    if use_cache:  # a checkpoint of other parameters does not match its fingerprint: the run starts afresh
        summary = resume_or_restart(shear, directory, progress=False, **options)
    else:
        summary = shear(directory, resume=False, progress=False, **options)
    write_json(key_path, {"parameter_hash": key})
    (directory / "checkpoint.npz").unlink(missing_ok=True)  # ~20 MB a run; a finished run is read from its summary
    return summary


def compute_shear_master_curve(poisson_ratio: float = 0.48, material: str = "neo-hookean", use_cache: bool = True,
                               progress=None, capillary_numbers=CAPILLARY_NUMBERS, resolutions=RESOLUTIONS,
                               duration: float = DURATION, work_directory: Path | None = None) -> ShearMasterCurve:
    """Run the shear scenario over the Ca grid at the two resolutions and tabulate the Richardson extrapolation.

    Every run writes its usual directory under ``work_directory`` (default: the cache directory, keyed like
    the curve), so an interrupted computation resumes: finished runs made from the same parameters are read back
    from their summary.json (others are made again, :func:`_run_one`), an unfinished one continues from its
    checkpoint. ``progress(ca, resolution, summary)`` is called after
    each run. The curve is cached (``use_cache``) under :func:`cache_path`.
    """

    check_inputs(poisson_ratio, material)
    capillary_numbers = tuple(sorted(float(c) for c in capillary_numbers))
    resolutions = tuple(sorted(float(r) for r in resolutions))
    if len(resolutions) != 2:
        raise ParameterError("resolution", f"needs exactly two resolutions (coarse, fine), got {resolutions}")
    parameters = curve_parameters(poisson_ratio, material, capillary_numbers, resolutions, duration)
    if use_cache:
        cached = read_cached_curve(ShearMasterCurve, "shear", parameters, FORMAT_VERSION)
        if cached is not None:
            return cached
    if work_directory is None:
        work_directory = curve_cache_path("shear", parameters, FORMAT_VERSION).with_suffix("")
    work_directory = Path(work_directory)
    raw = {r: {name: [] for name in OBSERVABLES} for r in resolutions}
    runs = []
    for resolution in resolutions:
        for ca in capillary_numbers:
            start = time.perf_counter()
            directory = work_directory / f"ca{ca:.4f}_rdx{resolution:g}"
            summary = _run_one(poisson_ratio, material, ca, resolution, duration, directory, use_cache)
            raw[resolution]["deformation"].append(summary["taylor_deformation_mean"])
            raw[resolution]["inclination_deg"].append(summary["inclination_deg_mean"])
            raw[resolution]["tank_treading_frequency"].append(summary["tank_treading_frequency"])
            runs.append({"capillary_number": ca, "resolution": resolution,
                         "taylor_deformation_std": summary["taylor_deformation_std"],
                         "volume_change_max_abs": summary["volume_change_max_abs"],
                         "duration_strain": summary["duration_strain"],
                         "wall_time_s": round(summary.get("wall_time_cumulative_s", summary.get("wall_time_s", 0)), 1),
                         "this_call_s": round(time.perf_counter() - start, 1), "n_nodes": summary["mesh"]["n_nodes"],
                         "lattice_shape": (summary.get("lattice") or {}).get("shape")})
            if progress:
                progress(ca, resolution, summary)
    coarse, fine = resolutions
    ratio = fine / coarse
    table = {"capillary_number": np.array(capillary_numbers)}
    for name in OBSERVABLES:
        f, c = np.array(raw[fine][name]), np.array(raw[coarse][name])
        extrapolated = richardson(f, c, ratio)
        table[name] = extrapolated
        table[f"{name}_error"] = np.abs(extrapolated - f)
        table[f"{name}_rdx{fine:g}"] = f
        table[f"{name}_rdx{coarse:g}"] = c
    first = table["deformation"][0] / capillary_numbers[0]
    curve = ShearMasterCurve(table=table, poisson_ratio=poisson_ratio, material=material, metadata={
        "command": f"elastocell mastercurve shear --poisson-ratio {poisson_ratio:g} --material {material}",
        "quantity": "stationary Taylor deformation D, inclination (degrees) and tank-treading frequency (angular "
                    "velocity / shear rate) of a homogeneous cell in plane Couette flow against "
                    "Ca = eta shear_rate / mu; viscosity ratio 1 (immersed boundary)",
        "curve": f"Richardson extrapolation (order {CONVERGENCE_ORDER:g}) of R/dx = {fine:g} and {coarse:g}",
        "error": f"|extrapolated - R/dx {fine:g}| (size of the extrapolation's correction; an estimate assuming "
                 "order-2 convergence at every Ca, not a bound)",
        "resolutions": list(resolutions), "duration_strain": duration, "averaging": "strain >= duration/2",
        "flow": "elastocell.shear defaults (confinement 0.2, box 8R, the matched tau: tau 1's shear rate at Re_p <= 0.1, tau up to 2; trilinear kernel, float32)",
        "mesh": "p1, uniform, edge 2 dx (parameters.flow.shear_mesh_size), nucleus none",
        "small_ca_check": {"capillary_number": capillary_numbers[0], "deformation_over_ca_extrapolated": first,
                           "deformation_over_ca_fine": raw[fine]["deformation"][0] / capillary_numbers[0],
                           "theory": SMALL_CA_DEFORMATION_SLOPE},
        "runs": runs, "elastocell_version": __version__, "software": software_versions()})
    if use_cache:
        write_cached_curve(curve, "shear", parameters, FORMAT_VERSION)
    return curve


def deformation_over_ca_theory(ca) -> np.ndarray:
    """The small-deformation theory D = (5/4) Ca (for comparison; the master curve uses it only below ca_min)."""
    return SMALL_CA_DEFORMATION_SLOPE * np.asarray(ca, float)


__all__ = ["ShearMasterCurve", "compute_shear_master_curve", "load_shear_master_curve", "cache_path", "shipped",
           "shipped_name", "richardson"]
