"""From a measured compression curve to a Young's modulus: least-squares fits to the master curve and to Hertz.

Geometry: parallel plates (docs/theory.md). The plate's approach ``displacement`` (m, increasing towards the cell)
and the ``force`` (N) are converted to ``delta = (displacement - contact_point) / (2 R)`` (the gap is
``h = 2R - (displacement - contact_point)``, so ``delta = 1 - h/(2R)``) and fitted by
``F = E R^2 f(delta)`` with ``f`` the homogeneous master curve (:mod:`elastocell.inverse.mastercurve`) or Hertz's
two-contact law ``f = 4/(3(1-nu^2)) delta^(3/2)``.

Contact point (``contact_point="auto"``):
1. Baseline: the mean force over the first ``baseline_fraction`` (20 %) of the approach (sorted by
   displacement; with ``baseline_tilt`` a straight line instead -- its slope, extrapolated over the contact
   region, adds a tilt that is only worth it when the baseline is long and clearly tilted); the residual
   standard deviation is the force noise ``sigma``. The baseline is subtracted from the whole curve.
2. First guess: the last point whose corrected force is below ``threshold * sigma`` (5 sigma). The force
   rises as delta^1.5, so this crossing is late; it is moved back by extrapolating F^(2/3) (linear in the
   displacement for Hertz) over the next points (up to 5 % of the force range, at most 50 points) to zero force.
3. Refinement: E and the contact point are fitted together by least squares over every point up to
   ``delta_max`` (points before contact are predicted to carry no force), re-selecting the points with the
   refined contact point until the selection settles (at most 6 fits), together with a constant force offset (what the baseline
   left), so that the baseline's uncertainty enters E's.
A numeric ``contact_point`` fixes it and only E is fitted.

Uncertainty: a 95 % confidence interval from the fit's covariance (Student t, ``s^2 (J^T J)^-1``) and,
with ``bootstrap=N``, a residual bootstrap (percentile interval of N refits to fitted curve + resampled
residuals). ``chi_square`` uses the baseline noise ``sigma``.

Many files: :func:`fit_files` runs one Dask task per file (:mod:`elastocell.simulation.distributed`) with ``workers`` or
``scheduler``, or by itself from :data:`DASK_AUTO_MIN_FILES` files on; ``fits.csv`` is the same either way.

Shear flow: :func:`fit_shear` inverts the shear master curve D(Ca) (:mod:`elastocell.inverse.mastercurve_shear`) for
Ca = eta shear_rate / mu, then mu = shear_stress / Ca and E = 2 mu (1 + nu), with an interval from D's
uncertainty and the curve's error; :func:`fit_shear_cells` writes ``shear_fits.csv`` for many cells.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from elastocell.api.plotting import plt
from elastocell.body.effective_moduli import hashin_shtrikman_upper
from elastocell.files import replace_atomically, save_figure, software_versions, write_json
from elastocell.inverse.mastercurve import MasterCurve, load_master_curve
from elastocell.inverse.mastercurve_shear import load_shear_master_curve
from elastocell.parameters.units import ParameterError, parse_quantity
from elastocell.scenarios.compression import hertz_force
from elastocell.simulation.distributed import TaskFailure, check_execution, default_workers, run_tasks

PLAIN_SUFFIXES = (".csv", ".txt", ".tsv")


class CurveError(ValueError):
    """A curve that cannot be fitted (bad file, no contact, ...): the message names the file."""


@dataclass(frozen=True)
class FitSettings:
    radius: float  # m
    poisson_ratio: float = 0.48
    material: str = "neo-hookean"
    geometry: str = "parallel-plates"
    model: str = "both"  # master | hertz | both
    delta_max: float = 0.75
    contact_point: float | None = None  # m; None = auto
    bootstrap: int = 0
    seed: int = 0
    baseline_fraction: float = 0.2
    threshold: float = 5.0
    baseline_tilt: bool = False
    nucleus_size_ratio: float | None = None
    stiffness_ratio: float | None = None

    def __post_init__(self):
        if not (math.isfinite(self.radius) and self.radius > 0):
            raise ParameterError("radius", f"must be > 0, got {self.radius}")
        if not (math.isfinite(self.poisson_ratio) and -1 < self.poisson_ratio < 0.5):
            raise ParameterError("poisson_ratio", f"must be in (-1, 0.5), got {self.poisson_ratio}")
        if self.geometry != "parallel-plates":
            raise ParameterError("geometry", f"only parallel-plates is supported, got {self.geometry!r}")
        if self.model not in ("master", "hertz", "both"):
            raise ParameterError("model", f"must be master, hertz or both, got {self.model!r}")
        if not 0 < self.delta_max <= 0.75:
            raise ParameterError("delta_max", f"must be in (0, 0.75] (the master curve's range), got {self.delta_max}")
        if self.contact_point is not None and not math.isfinite(self.contact_point):
            raise ParameterError("contact_point", f"must be finite, got {self.contact_point}")
        if self.bootstrap < 0:
            raise ParameterError("bootstrap", f"must be >= 0, got {self.bootstrap}")
        if not 0.02 <= self.baseline_fraction <= 0.8:
            raise ParameterError("baseline_fraction", f"must be in [0.02, 0.8], got {self.baseline_fraction}")
        if not self.threshold > 0:
            raise ParameterError("threshold", f"must be > 0, got {self.threshold}")
        if (self.nucleus_size_ratio is None) != (self.stiffness_ratio is None):
            raise ParameterError("nucleus_size_ratio", "give both --nucleus-size-ratio and --stiffness-ratio, or neither")
        if self.nucleus_size_ratio is not None:
            if not 0 < self.nucleus_size_ratio < 1:
                raise ParameterError("nucleus_size_ratio", f"must be in (0, 1), got {self.nucleus_size_ratio}")
            if not (math.isfinite(self.stiffness_ratio) and self.stiffness_ratio > 0):
                raise ParameterError("stiffness_ratio", f"must be > 0, got {self.stiffness_ratio}")


def parse_length(value, parameter: str) -> float:
    """A length in metres from '8um', '8e-6 m' or a bare number (in um, the bare-number unit of a length)."""
    magnitude, _ = parse_quantity(value, "m", parameter)
    return magnitude


# ---------------------------------------------------------------- reading


def read_curves(path: Path) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """``[(name, displacement_m, force_N), ...]`` of the approach segment(s) in ``path``.

    Plain CSV/TSV with the columns ``displacement`` and ``force``; otherwise (or if those columns are absent
    and afmformats can read the file) afmformats' formats: the approach segment, displacement = -tip position
    (piezo height minus cantilever deflection), so it increases towards the sample.
    """
    path = Path(path)
    if not path.exists():
        raise CurveError(f"{path}: no such file")
    if path.suffix.lower() in PLAIN_SUFFIXES:
        plain = _read_plain(path)
        if plain is not None:
            return [(path.stem, *plain)]
    try:
        import afmformats
    except ImportError:
        afmformats = None
    if afmformats is None or path.suffix.lower() not in afmformats.supported_extensions:
        if path.suffix.lower() in PLAIN_SUFFIXES:
            raise CurveError(f"{path}: missing column(s) 'displacement' and/or 'force' (plain CSV needs both)")
        hint = "" if afmformats is not None else " (install afmformats for AFM file formats)"
        raise CurveError(f"{path}: unsupported file type {path.suffix!r}{hint}")
    try:
        datasets = afmformats.load_data(path, modality="force-distance")
    except (Exception, afmformats.errors.AFMFileFormatError, afmformats.errors.MissingMetaDataError) as error:
        # afmformats raises many types for foreign files, some derived from BaseException
        if path.suffix.lower() in PLAIN_SUFFIXES:
            raise CurveError(f"{path}: missing column(s) 'displacement' and/or 'force' (plain CSV needs both)") from None
        raise CurveError(f"{path}: afmformats cannot read it ({type(error).__name__}: {error})") from None
    curves = []
    for index, data in enumerate(datasets):
        segment = data.appr
        columns = set(data.columns)
        if "tip position" in columns:
            displacement = -np.asarray(segment["tip position"], dtype=float)
        elif "height (measured)" in columns:
            displacement = -np.asarray(segment["height (measured)"], dtype=float)
        else:
            raise CurveError(f"{path}: curve {index} has no tip position or height column")
        force = np.asarray(segment["force"], dtype=float)
        name = path.stem if len(datasets) == 1 else f"{path.stem}_{index:04d}"
        curves.append((name, displacement, force))
    if not curves:
        raise CurveError(f"{path}: no force-distance curve in the file")
    return curves


def _read_plain(path: Path):
    import pandas as pd

    try:
        table = pd.read_csv(path, sep=None, engine="python", comment="#")
    except Exception as error:
        raise CurveError(f"{path}: cannot read as CSV ({type(error).__name__}: {error})") from None
    columns = {str(c).strip().lower(): c for c in table.columns}
    if "displacement" not in columns or "force" not in columns:
        return None
    try:
        displacement = pd.to_numeric(table[columns["displacement"]], errors="raise").to_numpy(float)
        force = pd.to_numeric(table[columns["force"]], errors="raise").to_numpy(float)
    except (ValueError, TypeError):
        raise CurveError(f"{path}: non-numeric values in 'displacement' or 'force'") from None
    return displacement, force


def _clean(name: str, displacement: np.ndarray, force: np.ndarray):
    finite = np.isfinite(displacement) & np.isfinite(force)
    displacement, force = displacement[finite], force[finite]
    if len(displacement) < 10:
        raise CurveError(f"{name}: needs at least 10 finite points, got {len(displacement)}")
    if displacement[-1] <= displacement[0]:
        raise CurveError(f"{name}: displacement must increase towards the cell (it decreases from first to last row)")
    order = np.argsort(displacement, kind="stable")
    return displacement[order], force[order]


# ---------------------------------------------------------------- contact point


@dataclass
class Baseline:
    slope: float
    intercept: float
    sigma: float
    n_points: int

    def __call__(self, displacement):
        return self.slope * np.asarray(displacement) + self.intercept


def fit_baseline(displacement: np.ndarray, force: np.ndarray, fraction: float = 0.2, tilt: bool = False) -> Baseline:
    """Force offset (and, with ``tilt``, slope) of the first ``fraction`` of the approach, and its noise."""
    n = max(5, int(round(fraction * len(displacement))))
    if tilt:
        slope, intercept = np.polyfit(displacement[:n], force[:n], 1)
    else:
        slope, intercept = 0.0, float(np.mean(force[:n]))
    residual = force[:n] - (slope * displacement[:n] + intercept)
    sigma = float(np.sqrt(np.sum(residual**2) / max(n - (2 if tilt else 1), 1)))
    return Baseline(float(slope), float(intercept), sigma, n)


def estimate_contact_point(displacement: np.ndarray, force: np.ndarray, fraction: float = 0.2,
                           threshold: float = 5.0, name: str = "curve", tilt: bool = False) -> tuple[float, Baseline]:
    """First guess of the contact point: the last point whose baseline-corrected force is below
    ``threshold`` times the baseline noise (see the module docstring). Returns ``(contact, baseline)``."""
    baseline = fit_baseline(displacement, force, fraction, tilt)
    corrected = force - baseline(displacement)
    level = threshold * baseline.sigma
    if level <= 0:  # noise-free data: a tiny fraction of the largest force
        level = 1e-9 * max(float(np.abs(corrected).max()), 1e-300)
    below = np.nonzero(corrected <= level)[0]
    if len(below) == 0 or below[-1] >= len(displacement) - 3 or corrected[-1] <= level:
        raise CurveError(f"{name}: no contact found (the force never rises above {threshold:g} sigma of the "
                         f"baseline, sigma = {baseline.sigma:.3g} N)")
    crossing = below[-1]
    contact = float(displacement[crossing])
    # extrapolate F^(2/3), linear in (displacement - contact) near contact (Hertz), back to zero force
    after = np.arange(crossing + 1, len(displacement))
    window = after[corrected[after] <= level + 0.05 * (corrected.max() - level)][:50]
    if len(window) >= 3:
        slope, intercept = np.polyfit(displacement[window], np.cbrt(corrected[window]) ** 2, 1)
        if slope > 0:
            contact = float(np.clip(-intercept / slope, displacement[0], contact))
    return contact, baseline


# ---------------------------------------------------------------- least squares


def _model_function(model: str, curve: MasterCurve | None, poisson_ratio: float):
    if model == "master":
        return curve
    return lambda delta: hertz_force(np.maximum(delta, 0.0), poisson_ratio)


def fit_model(displacement: np.ndarray, force: np.ndarray, radius: float, f, delta_max: float,
              contact_guess: float, fit_contact: bool = True, sigma: float = float("nan"), bootstrap: int = 0,
              seed: int = 0) -> dict:
    """Least-squares fit of ``force = b + E R^2 f((displacement - c)/(2R))``: E, the force offset b (residual
    baseline, informed by the points before contact) and, if ``fit_contact``, the contact point c.

    Every point with ``(displacement - c)/(2R) <= delta_max`` is used (before contact f = 0).
    """
    from scipy import stats
    from scipy.optimize import least_squares

    index_contact = 1 if fit_contact else None
    index_offset = 2 if fit_contact else 1

    def unpack(parameters, modulus_scale, contact0, force_scale):
        modulus = parameters[0] * modulus_scale
        contact = contact0 + (parameters[index_contact] * radius if fit_contact else 0.0)
        return modulus, contact, parameters[index_offset] * force_scale

    def predict(parameters, modulus_scale, contact0, force_scale, d):
        modulus, contact, offset = unpack(parameters, modulus_scale, contact0, force_scale)
        return offset + modulus * radius**2 * f(np.maximum(d - contact, 0.0) / (2 * radius))

    def solve(d, y, modulus_scale, contact0, force_scale, start):
        def residual(parameters):
            return (predict(parameters, modulus_scale, contact0, force_scale, d) - y) / force_scale

        lower = [1e-8] + [-np.inf] * (len(start) - 1)
        return least_squares(residual, start, jac="3-point", bounds=(lower, [np.inf] * len(start)),
                             xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=400)

    contact, previous = contact_guess, None
    for _ in range(6):  # select the points with the current contact and fit, until the selection settles
        mask = (displacement - contact) / (2 * radius) <= delta_max + 1e-12
        if previous is not None and np.array_equal(mask, previous):
            break
        previous = mask
        d, y = displacement[mask], force[mask]
        if (d > contact).sum() < 3:
            raise CurveError("fewer than 3 points in contact below delta_max")
        contact0 = contact
        force_scale = max(float(np.abs(y).max()), 1e-300)
        delta_last = (d[-1] - contact0) / (2 * radius)
        modulus_scale = max(float(y[-1]), 1e-300) / (radius**2 * float(f(np.array([delta_last]))[0]))
        start = np.zeros(index_offset + 1)
        start[0] = 1.0
        result = solve(d, y, modulus_scale, contact0, force_scale, start)
        modulus, contact, offset = unpack(result.x, modulus_scale, contact0, force_scale)
    n, p = len(y), len(result.x)
    residuals = result.fun * force_scale
    ssr = float(np.sum(residuals**2))
    dof = max(n - p, 1)
    try:
        jac = result.jac * force_scale
        covariance = np.linalg.inv(jac.T @ jac) * ssr / dof
        modulus_std = math.sqrt(max(covariance[0, 0], 0.0)) * modulus_scale
        contact_std = math.sqrt(max(covariance[1, 1], 0.0)) * radius if fit_contact else 0.0
    except np.linalg.LinAlgError:
        modulus_std, contact_std = float("nan"), float("nan")
    t = float(stats.t.ppf(0.975, dof))
    predicted = predict(result.x, modulus_scale, contact0, force_scale, d)
    out = {
        "youngs_modulus": modulus, "youngs_modulus_std": modulus_std,
        "youngs_modulus_ci_low": modulus - t * modulus_std, "youngs_modulus_ci_high": modulus + t * modulus_std,
        "contact_point": contact, "contact_point_std": contact_std, "force_offset": offset,
        "delta_max": float((d.max() - contact) / (2 * radius)), "n_points": n,
        "n_points_in_contact": int((d > contact).sum()),
        "chi_square": ssr / sigma**2 if sigma > 0 else float("nan"),
        "reduced_chi_square": ssr / sigma**2 / dof if sigma > 0 else float("nan"),
        "rms_residual": math.sqrt(ssr / n), "converged": bool(result.success),
        "fitted_points": (d, y - offset, predicted - offset),
    }
    if bootstrap:
        rng = np.random.default_rng(seed)
        moduli = []
        for _ in range(bootstrap):
            sample = predicted + rng.choice(residuals, size=n, replace=True)
            replica = solve(d, sample, modulus_scale, contact0, force_scale, result.x)
            moduli.append(replica.x[0] * modulus_scale)
        out["youngs_modulus_bootstrap_ci_low"] = float(np.percentile(moduli, 2.5))
        out["youngs_modulus_bootstrap_ci_high"] = float(np.percentile(moduli, 97.5))
    return out


def fit_curve(name: str, displacement, force, settings: FitSettings, curve: MasterCurve | None = None) -> dict:
    """Fit one curve; returns a dict (fits.csv row plus ``_plot`` data)."""
    displacement, force = _clean(name, np.asarray(displacement, float), np.asarray(force, float))
    start = time.perf_counter()
    try:
        guess, baseline = estimate_contact_point(displacement, force, settings.baseline_fraction,
                                                 settings.threshold, name, settings.baseline_tilt)
    except CurveError:
        if settings.contact_point is None:
            raise
        baseline = fit_baseline(displacement, force, settings.baseline_fraction, settings.baseline_tilt)
    corrected = force - baseline(displacement)
    fit_contact = settings.contact_point is None
    contact0 = guess if fit_contact else settings.contact_point
    if curve is None and settings.model in ("master", "both"):
        curve = load_master_curve(settings.poisson_ratio, settings.material)
    row = {"file": name, "radius": settings.radius, "poisson_ratio": settings.poisson_ratio}
    fits = {}
    for model in ("master", "hertz"):
        if settings.model not in (model, "both"):
            continue
        try:
            fits[model] = fit_model(displacement, corrected, settings.radius,
                                    _model_function(model, curve, settings.poisson_ratio), settings.delta_max,
                                    contact0, fit_contact, baseline.sigma, settings.bootstrap, settings.seed)
        except CurveError as error:
            raise CurveError(f"{name}: {error}") from None
    primary = fits["master"] if "master" in fits else fits["hertz"]
    for key in ("youngs_modulus", "youngs_modulus_ci_low", "youngs_modulus_ci_high", "contact_point",
                "delta_max", "youngs_modulus_std", "contact_point_std", "chi_square", "reduced_chi_square",
                "rms_residual", "n_points", "n_points_in_contact", "converged", "youngs_modulus_bootstrap_ci_low",
                "youngs_modulus_bootstrap_ci_high"):
        if key in primary:
            row[key] = primary[key]
    row["model"] = "master" if "master" in fits else "hertz"
    hertz = fits.get("hertz")
    nan = float("nan")
    row["youngs_modulus_hertz"] = hertz["youngs_modulus"] if hertz else nan
    row["youngs_modulus_hertz_ci_low"] = hertz["youngs_modulus_ci_low"] if hertz else nan
    row["youngs_modulus_hertz_ci_high"] = hertz["youngs_modulus_ci_high"] if hertz else nan
    row["contact_point_hertz"] = hertz["contact_point"] if hertz else nan
    row["chi_square_hertz"] = hertz["chi_square"] if hertz else nan
    row["contact_point_initial_guess"] = contact0
    row["baseline_sigma"] = baseline.sigma
    if "master" in fits and curve is not None:
        row["master_curve_relative_error"] = float(curve.relative_error_at(fits["master"]["delta_max"]))
    if settings.nucleus_size_ratio is not None:
        row.update(heterogeneous_moduli(row, settings.nucleus_size_ratio, settings.stiffness_ratio,
                                        settings.poisson_ratio))
    row["fit_time_s"] = time.perf_counter() - start
    row["_plot"] = {"displacement": displacement, "force": corrected, "fits": fits, "radius": settings.radius}
    return row


def heterogeneous_moduli(row: dict, size_ratio: float, stiffness_ratio: float, poisson_ratio: float = 0.48) -> dict:
    """E_c = E_eff / (1 + (G - 1) L^3) and E_n = G E_c (the paper's volume average, spherical nucleus), and E_c
    with the Hashin-Shtrikman upper bound E_eff/E_c (``*_hashin_shtrikman_upper``). The equivalent-modulus study
    (README) found the volume average closest for gamma <= 5 (errors 7-12 %) and the HS upper bound for gamma 10
    and 20 (-9 % and +16 %, against +12 % and +58 % for the volume average)."""

    factor = 1.0 + (stiffness_ratio - 1.0) * size_ratio**3
    phi = size_ratio**3
    factor_hs = hashin_shtrikman_upper([1.0, stiffness_ratio], [1.0 - phi, phi], poisson_ratio)
    out = {"effective_stiffness_ratio": factor, "effective_stiffness_ratio_hashin_shtrikman_upper": factor_hs,
           "nucleus_size_ratio": size_ratio, "stiffness_ratio": stiffness_ratio}
    for suffix in ("", "_ci_low", "_ci_high"):
        value = row.get(f"youngs_modulus{suffix}", float("nan"))
        out[f"youngs_modulus_cytoplasm{suffix}"] = value / factor
        out[f"youngs_modulus_nucleus{suffix}"] = stiffness_ratio * value / factor
        out[f"youngs_modulus_cytoplasm_hashin_shtrikman_upper{suffix}"] = value / factor_hs
    return out


# ---------------------------------------------------------------- plots and files


def plot_fit(path: Path, row: dict) -> None:

    data = row["_plot"]
    radius = data["radius"]
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(6.4, 6), sharex=True, height_ratios=[3, 1],
                                         constrained_layout=True)
    micro = 1e6
    top.plot(data["displacement"] * micro, data["force"] * 1e9, ".", ms=2, color="0.5", label="data (baseline removed)")
    styles = {"master": ("C0", "master curve"), "hertz": ("C3", "Hertz")}
    for model, fit in data["fits"].items():
        d, y, predicted = fit["fitted_points"]
        color, label = styles[model]
        top.plot(d * micro, predicted * 1e9, "-", color=color,
                 label=f"{label}: E = {fit['youngs_modulus']:.4g} Pa "
                       f"[{fit['youngs_modulus_ci_low']:.4g}, {fit['youngs_modulus_ci_high']:.4g}]")
        top.axvline(fit["contact_point"] * micro, color=color, lw=0.8, ls=":")
        bottom.plot(d * micro, (y - predicted) * 1e9, ".", ms=2, color=color, label=label)
    top.set_ylabel("force (nN)")
    top.set_title(f"{row['file']}: R = {radius * micro:.3g} um, delta up to {row['delta_max']:.3f}")
    top.legend(fontsize=8)
    bottom.axhline(0, color="k", lw=0.6)
    bottom.set_xlabel("displacement (um)")
    bottom.set_ylabel("residual (nN)")
    for axis in (top, bottom):
        axis.grid(alpha=0.3)
    save_figure(figure, path, dpi=110)
    plt.close(figure)


CONTRACT_COLUMNS = ["file", "youngs_modulus", "youngs_modulus_ci_low", "youngs_modulus_ci_high", "contact_point",
                    "delta_max", "youngs_modulus_hertz"]


def expand_paths(paths) -> list[Path]:
    """Files as given; a directory contributes its readable files (plain CSV and afmformats' extensions)."""
    try:
        import afmformats

        extensions = set(afmformats.supported_extensions) | set(PLAIN_SUFFIXES)
    except ImportError:
        extensions = set(PLAIN_SUFFIXES)
    out = []
    for path in map(Path, paths):
        if path.is_dir():
            out += sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in extensions)
        else:
            out.append(path)
    return out


DASK_AUTO_MIN_FILES = {"plots": 150, "no_plots": 1200}
"""Without ``scheduler``/``workers``, files run through a local Dask cluster (one worker per core) only from
this many files on, and only with at least 2 cores: where the plain loop would take about a minute (measured
per file: 0.05 s to read and fit, 0.43-0.5 s with its PNG). Measured on the 2-core development machine while a
second job kept both cores busy (load average 4-6): a 2-worker cluster costs 12 s before the first result
(2 files: 13.5 s against 1.8 s in process) and was slower than the loop in every case tried (400 files without
plots: 38.8 s against 19.1 s; 40 files with plots: 36.6 s against 17.1 s), so on a loaded machine ask for it
only on a cluster with free cores (``--scheduler``) or with ``--workers``."""


def _fit_path(path: Path, settings: FitSettings, curve: MasterCurve | None, plot_directory: Path | None) -> list:
    """Fit every curve of one file: ``[(name, row or None, error message or None), ...]`` in file order;
    ``[(None, None, message)]`` when the file cannot be read. Plots go to ``plot_directory/<name>.png``."""
    out = []
    try:
        curves = read_curves(path)
    except CurveError as error:
        return [(None, None, str(error))]
    for name, displacement, force in curves:
        try:
            row = fit_curve(name, displacement, force, settings, curve)
        except CurveError as error:
            message = str(error)
            if message.startswith(f"{name}: "):
                message = message[len(name) + 2:]
            out.append((name, None, message if str(path) in message else f"{path}: {message}"))
            continue
        row["source"] = str(path)
        if plot_directory is not None:
            plot_fit(plot_directory / f"{name}.png", row)
        out.append((name, row, None))
    return out


@functools.lru_cache(maxsize=8)
def _worker_master_curve(poisson_ratio: float, material: str) -> MasterCurve:
    """The master curve, read once per worker process (a task per file would otherwise re-read it)."""
    return load_master_curve(poisson_ratio, material)


def _fit_file_task(item) -> list:
    """One Dask task: the curves of one file (its plots in a private folder ``out/.plots-<index>``, renamed by
    the caller once names are made unique in input order); rows without their plot data (small results)."""
    index, path, settings, out, plots = item
    curve = _worker_master_curve(settings.poisson_ratio, settings.material) if settings.model != "hertz" else None
    plot_directory = None
    if plots:
        plot_directory = Path(out) / f".plots-{index:06d}"
        plot_directory.mkdir(parents=True, exist_ok=True)
    results = _fit_path(Path(path), settings, curve, plot_directory)
    for _, row, _ in results:
        if row is not None:
            row.pop("_plot", None)
    return results


def fit_files(paths, settings: FitSettings, out: Path, plots: bool = True, progress: bool = False,
              scheduler: str | None = None, workers: int | None = None, dask: bool | None = None) -> dict:
    """Fit every curve of every file; write ``out/fits.csv``, ``out/<curve>.png``, ``out/fit_settings.json``.

    Returns ``{"rows": [...], "errors": [(file, message), ...], "wall_time_s": ..., "execution": ...}``.
    Execution: with ``scheduler`` (a Dask address) or ``workers`` (local cluster of that many processes), or
    with at least :data:`DASK_AUTO_MIN_FILES` files (150 with plots, 1200 without) on a machine with 2+ cores,
    one Dask task per file (:func:`elastocell.simulation.distributed.run_tasks`); otherwise a plain loop in this process.
    ``dask=True/False`` forces either (False: the loop whatever the number of files). Rows keep the input
    order either way (files as given, curves in file order), and duplicate curve names get ``_1``, ``_2``, ...
    in that order, so ``fits.csv`` does not depend on the execution. With a remote scheduler ``out`` must be
    on a file system the workers share (the tasks write the plots).
    """
    import pandas as pd


    check_execution(scheduler, workers)
    start = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    curve = load_master_curve(settings.poisson_ratio, settings.material) if settings.model != "hertz" else None
    files = expand_paths(paths)
    if not files:
        raise ParameterError("file", "no input files")
    if dask is False and (scheduler is not None or workers is not None):
        raise ParameterError("workers", "dask=False (in process) cannot take a scheduler or workers")
    use_dask = scheduler is not None or workers is not None or (
        len(files) >= DASK_AUTO_MIN_FILES["plots" if plots else "no_plots"] and default_workers() >= 2
        if dask is None else dask)
    if scheduler is not None:
        execution = f"dask scheduler {scheduler} (one task per file)"
    elif use_dask:
        execution = f"dask local cluster, {workers or default_workers()} worker process(es) (one task per file)"
    else:
        execution = "plain loop (one process)"
    per_file: list[list | None] = [None] * len(files)
    if use_dask:

        items = [(i, str(path), settings, str(out), plots) for i, path in enumerate(files)]
        for index, result in run_tasks(_fit_file_task, items, scheduler=scheduler, workers=workers,
                                       progress=progress and len(files) > 3, description="fitting"):
            if isinstance(result, TaskFailure):
                result = [(None, None, f"{files[index]}: {result}")]
            per_file[index] = result
    else:
        bar = None
        if progress and len(files) > 3:
            from rich.progress import Progress

            bar = Progress(transient=True)
            bar.start()
            task = bar.add_task("fitting", total=len(files))
        try:
            for index, path in enumerate(files):
                per_file[index] = _fit_path(path, settings, curve, None)  # plotted below, named uniquely
                if bar is not None:
                    bar.advance(task)
        finally:
            if bar is not None:
                bar.stop()
    rows, errors, used_names = [], [], set()
    for index, path in enumerate(files):
        for name, row, message in per_file[index]:
            if name is None:  # the file could not be read
                errors.append((str(path), message))
                continue
            unique, counter = name, 1  # a curve that failed keeps its name reserved too
            while unique in used_names:
                unique = f"{name}_{counter}"
                counter += 1
            used_names.add(unique)
            if row is None:
                errors.append((str(path), message))
                continue
            row["file"] = unique
            if plots and use_dask:
                source = out / f".plots-{index:06d}" / f"{name}.png"
                if source.exists():
                    source.replace(out / f"{unique}.png")
            elif plots:
                plot_fit(out / f"{unique}.png", row)
            rows.append(row)
        if use_dask and plots:
            folder = out / f".plots-{index:06d}"
            if folder.is_dir():
                for leftover in folder.iterdir():
                    leftover.unlink()
                folder.rmdir()
    table = [{k: v for k, v in row.items() if k != "_plot"} for row in rows]
    table += [{"file": Path(f).stem, "source": f, "error": message} for f, message in errors]
    frame = pd.DataFrame(table)
    for column in CONTRACT_COLUMNS:
        if column not in frame:
            frame[column] = np.nan
    frame = frame[CONTRACT_COLUMNS + [c for c in frame.columns if c not in CONTRACT_COLUMNS]]
    replace_atomically(out / "fits.csv", lambda temporary: frame.to_csv(temporary, index=False, float_format="%.8g"))
    versions = software_versions()
    try:
        import afmformats

        versions["afmformats"] = afmformats.__version__
    except ImportError:
        pass
    wall = time.perf_counter() - start
    write_json(out / "fit_settings.json", {
        "settings": asdict(settings), "files": [str(p) for p in files],
        "master_curve": (curve.metadata | {"poisson_ratio": curve.poisson_ratio, "material": curve.material,
                                           "hertz_blend_below": curve.hertz_blend_below}) if curve else None,
        "delta_definition": "delta = (displacement - contact_point) / (2 R) = 1 - h/(2R)",
        "contact_point_estimator": "baseline line on the first baseline_fraction of the approach; first guess the "
                                   "last point below threshold*sigma; refined with E by least squares",
        "heterogeneous_conversion": None if settings.nucleus_size_ratio is None else (
            "E_c = E_eff / (1 + (gamma - 1) lambda^3), E_n = gamma E_c (volume average, spherical centred nucleus). "
            "Measured (equivalent-modulus study, full compression, p2 meshes; README): the best homogeneous modulus "
            "of a centred-nucleus cell is 1.233/1.611/1.896/2.127 E_c for gamma 2/5/10/20 (lambda 0.5) against the "
            "volume average 1.124/1.496/2.115/3.354, so E_c from the volume average is 10 % too high (gamma 2) to "
            "37 % too low (gamma 20). Recommended: the volume average for gamma <= 5 (closest in 11 of 13 cells, "
            "median error 7.7 %), the Hashin-Shtrikman upper bound (columns *_hashin_shtrikman_upper) for gamma >= "
            "10 (errors -9 % and +16 % at gamma 10 and 20)."),
        "execution": execution, "dask_auto_min_files": DASK_AUTO_MIN_FILES, "n_curves": len(rows),
        "n_errors": len(errors), "wall_time_s": wall, "software": versions,
    })
    return {"rows": rows, "errors": errors, "wall_time_s": wall, "files": files, "execution": execution}


# ---------------------------------------------------------------- shear flow: D -> Ca -> mu, E

SHEAR_CONTRACT_COLUMNS = ["cell", "deformation", "shear_stress", "capillary_number", "shear_modulus",
                          "shear_modulus_ci_low", "shear_modulus_ci_high", "youngs_modulus", "youngs_modulus_ci_low",
                          "youngs_modulus_ci_high"]


def parse_shear_stress(value, parameter: str = "shear_stress") -> float:
    """A stress in Pa: '12Pa', '0.012 kPa' or a plain number (Pa)."""
    return parse_quantity(value, "Pa", parameter)[0]


def parse_rate(value, parameter: str) -> float:
    """An (angular) rate in 1/s: '1000/s', '150 rad/s' or a plain number (1/s). A frequency in Hz (cycles per
    second) is converted to an angular frequency (times 2 pi)."""
    magnitude, physical = parse_quantity(value, "1/s", parameter)
    if physical and "hz" in str(value).lower():
        magnitude *= 2.0 * math.pi
    return magnitude


def _finite_nonnegative(value, parameter: str) -> float:
    value = float(value)
    if not (math.isfinite(value) and value >= 0):
        raise ParameterError(parameter, f"must be finite and >= 0, got {value}")
    return value


def _interval_in_log(centre: float, low: float, high: float, relative_sigma: float, z: float) -> tuple[float, float]:
    """Widen [low, high] around ``centre`` (positive) by an independent relative standard uncertainty, in
    quadrature on the log scale."""
    if relative_sigma == 0:
        return low, high
    spread = z * relative_sigma
    lower = math.log(centre / low) if low > 0 else math.inf
    upper = math.log(high / centre) if math.isfinite(high) else math.inf
    return (centre * math.exp(-math.hypot(lower, spread)) if math.isfinite(lower) else 0.0,
            centre * math.exp(math.hypot(upper, spread)) if math.isfinite(upper) else math.inf)


def _invert(curve, name: str, observed: float, sigma_observed: float, z: float) -> dict:
    """Ca and its interval for one observable: the observable's uncertainty and the master curve's error at
    the estimate (its error column e read as the half-width of a uniform distribution: sigma = e/sqrt(3), the
    GUM's type-B rule for a bound), combined in quadrature, mapped through the inverse curve (nonlinear; a bound that leaves
    the curve is extrapolated along its end slope, or 0 / nan below it)."""
    ca = curve.capillary_number(observed, name)
    sigma_curve = float(curve.error(name, ca)) / math.sqrt(3.0)  # a bound-like estimate: uniform within +-error
    sigma = math.hypot(sigma_observed, sigma_curve)
    ends = [curve.capillary_number(observed + sign * z * sigma, name, extrapolate=True) for sign in (-1, 1)]
    low, high = min(ends), max(ends)
    return {"capillary_number": ca, "capillary_number_ci_low": low, "capillary_number_ci_high": high,
            "sigma": sigma, "sigma_curve": sigma_curve,
            "extrapolated": bool(observed + z * sigma > curve.range(name)[1] or observed - z * sigma < curve.range(name)[0])}


def fit_shear(deformation, shear_stress, deformation_error=0.0, shear_stress_error=0.0,
              tank_treading_frequency=None, tank_treading_frequency_error=0.0, shear_rate=None, radius=None,
              poisson_ratio: float = 0.48, material: str = "neo-hookean", confidence: float = 0.95,
              curve=None, cell=None) -> dict:
    """Shear modulus and Young's modulus of a cell from its stationary Taylor deformation in shear flow.

    deformation: D = (a - b)/(a + b) of the stationary cell (docs/theory.md); deformation_error: its standard
    uncertainty (1 sigma). shear_stress: tau = eta * shear_rate of the flow (Pa; '12Pa' accepted);
    shear_stress_error: its standard uncertainty (Pa). The shear master curve D(Ca) is inverted for
    Ca = eta shear_rate / mu = tau / mu, so mu = tau / Ca and E = 2 mu (1 + nu).

    Interval (``confidence``, default 95 %): sigma = sqrt(deformation_error^2 + e_curve^2/3) with e_curve the master
    curve's error column at the estimate (read as the half-width of a uniform distribution; it is the size of the
    Richardson correction, 5-10 % of D, see :mod:`elastocell.inverse.mastercurve_shear`); [D - z sigma, D + z sigma] is mapped
    through the inverse curve (so the interval is asymmetric; a lower bound D - z sigma <= 0 gives an unbounded
    upper modulus); the shear stress's relative uncertainty is added in quadrature on the log scale.

    tank_treading_frequency (angular, rad/s; needs shear_rate, 1/s): a second observable. Its ratio to the
    shear rate is inverted on the curve's tank-treading column for an independent Ca (``*_tank_treading``
    columns) and compared with D's (``tank_treading_z``: difference over the combined standard
    uncertainty, linearised; ``tank_treading_consistent``: |z| <= z of the confidence level). The primary
    estimate stays D's: the frequency varies weakly with Ca (0.49 to 0.39 of the shear rate between Ca 0.05 and
    0.3 at R/dx = 8) and depends on the cell's internal viscosity, which the master curve fixes at the outer
    fluid's (viscosity ratio 1). ``shear_modulus_combined`` is the inverse-variance weighted mean of the two
    log-moduli, meaningful only when they are consistent and the viscosity ratio is near 1.
    radius: recorded only (Ca and D are dimensionless; the result does not depend on it).
    Raises ParameterError (naming ``deformation``/``tank_treading_frequency``) outside the curve's range.
    """
    from scipy.stats import norm


    if not 0 < confidence < 1:
        raise ParameterError("confidence", f"must be in (0, 1), got {confidence}")
    curve = curve if curve is not None else load_shear_master_curve(poisson_ratio, material)
    poisson_ratio = curve.poisson_ratio
    deformation = float(deformation)
    tau = parse_shear_stress(shear_stress)
    deformation_error = _finite_nonnegative(deformation_error, "deformation_error")
    tau_error = _finite_nonnegative(parse_shear_stress(shear_stress_error, "shear_stress_error"),
                                    "shear_stress_error")
    if not (math.isfinite(tau) and tau > 0):
        raise ParameterError("shear_stress", f"must be > 0, got {tau}")
    low, high = curve.range("deformation")
    if not (math.isfinite(deformation) and low < deformation <= high):
        raise ParameterError("deformation", f"{deformation:g} is outside the shear master curve's range "
                                            f"({low:g}, {high:.4g}] (nu={poisson_ratio:g}, Ca up to {curve.ca_max:g})")
    z = float(norm.ppf(0.5 + confidence / 2))
    estimate = _invert(curve, "deformation", deformation, deformation_error, z)
    ca = estimate["capillary_number"]
    factor = 2.0 * (1.0 + poisson_ratio)
    mu = tau / ca
    mu_low = tau / estimate["capillary_number_ci_high"]
    mu_high = tau / estimate["capillary_number_ci_low"] if estimate["capillary_number_ci_low"] > 0 else math.inf
    mu_low, mu_high = _interval_in_log(mu, mu_low, mu_high, tau_error / tau, z)
    row = {"cell": cell, "deformation": deformation, "deformation_error": deformation_error, "shear_stress": tau,
           "shear_stress_error": tau_error, "capillary_number": ca,
           "capillary_number_ci_low": estimate["capillary_number_ci_low"],
           "capillary_number_ci_high": estimate["capillary_number_ci_high"],
           "shear_modulus": mu, "shear_modulus_ci_low": mu_low, "shear_modulus_ci_high": mu_high,
           "youngs_modulus": factor * mu, "youngs_modulus_ci_low": factor * mu_low,
           "youngs_modulus_ci_high": factor * mu_high, "poisson_ratio": poisson_ratio, "confidence": confidence,
           "master_curve_deformation_error": float(curve.error("deformation", ca)),
           "master_curve_relative_error": float(curve.error("deformation", ca)) / deformation,
           "ci_extrapolated": estimate["extrapolated"],
           "capillary_number_small_deformation": deformation / 1.25,
           "youngs_modulus_small_deformation": factor * tau * 1.25 / deformation,
           "inclination_deg_predicted": float(curve.value("inclination_deg", ca)),
           "tank_treading_frequency_predicted": float(curve.value("tank_treading_frequency", ca)),
           "radius": float("nan") if radius is None else parse_length(radius, "radius")}
    if tank_treading_frequency is not None:
        if shear_rate is None:
            raise ParameterError("shear_rate", "--tank-treading-frequency needs --shear-rate (to normalise it)")
        rate = parse_rate(shear_rate, "shear_rate")
        if not (math.isfinite(rate) and rate > 0):
            raise ParameterError("shear_rate", f"must be > 0, got {rate}")
        omega = parse_rate(tank_treading_frequency, "tank_treading_frequency") / rate
        omega_error = _finite_nonnegative(parse_rate(tank_treading_frequency_error, "tank_treading_frequency_error"),
                                          "tank_treading_frequency_error") / rate
        t_low, t_high = curve.range("tank_treading_frequency")
        if not t_low <= omega <= t_high:
            raise ParameterError("tank_treading_frequency",
                                 f"{omega:.4g} x shear rate is outside the shear master curve's range [{t_low:.4g}, "
                                 f"{t_high:.4g}] x shear rate (angular frequency in rad/s; Hz is converted)")
        try:
            second = _invert(curve, "tank_treading_frequency", omega, omega_error, z)
        except ValueError as error:
            raise ParameterError("tank_treading_frequency", str(error)) from None
        ca_t = second["capillary_number"]
        mu_t = tau / ca_t if ca_t > 0 else math.inf
        t_ci = (second["capillary_number_ci_low"], second["capillary_number_ci_high"])
        mu_t_low = tau / t_ci[1] if t_ci[1] > 0 and math.isfinite(t_ci[1]) else 0.0
        mu_t_high = tau / t_ci[0] if t_ci[0] > 0 else math.inf
        mu_t_low, mu_t_high = _interval_in_log(mu_t, mu_t_low, mu_t_high, tau_error / tau, z) \
            if math.isfinite(mu_t) else (mu_t_low, mu_t_high)
        # linearised standard uncertainties of Ca from each observable (slopes of the curve at the estimates)
        h = 1e-4 * curve.ca_max
        slope_d = float(curve.value("deformation", ca + h) - curve.value("deformation", max(ca - h, 0.0))) / (
            ca + h - max(ca - h, 0.0))
        slope_t = float(curve.value("tank_treading_frequency", ca_t + h)
                        - curve.value("tank_treading_frequency", max(ca_t - h, 0.0))) / (ca_t + h - max(ca_t - h, 0.0))
        sigma_ca_d = estimate["sigma"] / abs(slope_d)
        sigma_ca_t = second["sigma"] / abs(slope_t) if slope_t != 0 else math.inf
        z_score = (ca_t - ca) / math.hypot(sigma_ca_d, sigma_ca_t) if math.isfinite(sigma_ca_t) else 0.0
        row.update({
            "tank_treading_frequency": omega * rate, "shear_rate": rate, "tank_treading_over_shear_rate": omega,
            "tank_treading_over_shear_rate_error": omega_error, "capillary_number_tank_treading": ca_t,
            "capillary_number_tank_treading_ci_low": t_ci[0], "capillary_number_tank_treading_ci_high": t_ci[1],
            "shear_modulus_tank_treading": mu_t, "shear_modulus_tank_treading_ci_low": mu_t_low,
            "shear_modulus_tank_treading_ci_high": mu_t_high, "youngs_modulus_tank_treading": factor * mu_t,
            "tank_treading_z": z_score, "tank_treading_consistent": bool(abs(z_score) <= z),
            "viscosity_implied": tau / rate,
        })
        # inverse-variance mean of log mu (relative sigmas of Ca; the common shear-stress error adds afterwards)
        if ca_t > 0 and math.isfinite(sigma_ca_t):
            w_d, w_t = (ca / sigma_ca_d) ** 2, (ca_t / sigma_ca_t) ** 2
            log_mu = (w_d * math.log(mu) + w_t * math.log(mu_t)) / (w_d + w_t)
            spread = math.hypot(z / math.sqrt(w_d + w_t), z * tau_error / tau)
            row.update({"shear_modulus_combined": math.exp(log_mu),
                        "shear_modulus_combined_ci_low": math.exp(log_mu - spread),
                        "shear_modulus_combined_ci_high": math.exp(log_mu + spread)})
    return row


SHEAR_TABLE_COLUMNS = {"deformation": "deformation", "shear_stress": "shear_stress",
                       "deformation_error": "deformation_error", "shear_stress_error": "shear_stress_error",
                       "tank_treading_frequency": "tank_treading_frequency",
                       "tank_treading_frequency_error": "tank_treading_frequency_error", "shear_rate": "shear_rate",
                       "radius": "radius", "cell": "cell"}


def read_shear_table(path) -> list[dict]:
    """Rows of a CSV of cells: columns ``deformation``, ``shear_stress`` (Pa), optional ``deformation_error``,
    ``shear_stress_error``, ``tank_treading_frequency`` (rad/s), ``tank_treading_frequency_error``,
    ``shear_rate`` (1/s), ``radius`` (um), ``cell`` (a name; default: the row number from 1)."""
    import pandas as pd

    path = Path(path)
    if not path.is_file():
        raise ParameterError("table", f"{path}: no such file")
    try:
        frame = pd.read_csv(path, comment="#", sep=None, engine="python")
    except Exception as error:
        raise ParameterError("table", f"{path}: cannot read as CSV ({type(error).__name__}: {error})") from None
    frame.columns = [str(c).strip().lower() for c in frame.columns]
    missing = [c for c in ("deformation", "shear_stress") if c not in frame.columns]
    if missing:
        raise ParameterError("table", f"{path}: missing column(s) {', '.join(missing)} (needs deformation, "
                                      "shear_stress)")
    if frame.empty:
        raise ParameterError("table", f"{path}: no rows")
    rows = []
    for index, record in enumerate(frame.to_dict("records"), start=1):
        row = {key: record[column] for column, key in SHEAR_TABLE_COLUMNS.items()
               if column in record and not (isinstance(record[column], float) and math.isnan(record[column]))}
        row.setdefault("cell", str(index))
        row["cell"] = str(row["cell"])
        rows.append(row)
    return rows


def fit_shear_cells(cells: list[dict], out: Path, poisson_ratio: float = 0.48, material: str = "neo-hookean",
                    confidence: float = 0.95, source: str | None = None) -> dict:
    """:func:`fit_shear` for every cell (dicts of its keyword arguments); writes ``out/shear_fits.csv`` (one row
    per cell, input order) and ``out/fit_settings.json``. A cell outside the curve's range refuses the whole
    input with a ParameterError naming the cell (``table``) or the option (single cell)."""
    import pandas as pd


    start = time.perf_counter()
    curve = load_shear_master_curve(poisson_ratio, material)
    rows = []
    for cell in cells:
        try:
            rows.append(fit_shear(**cell, poisson_ratio=poisson_ratio, material=material, confidence=confidence,
                                  curve=curve))
        except ParameterError as error:
            if source is None:
                raise
            raise ParameterError("table", f"{source} cell {cell.get('cell')}: {error.parameter}: "
                                          f"{str(error).split(': ', 1)[1]}") from None
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    frame = pd.DataFrame(rows)
    frame = frame[SHEAR_CONTRACT_COLUMNS + [c for c in frame.columns if c not in SHEAR_CONTRACT_COLUMNS]]
    replace_atomically(out / "shear_fits.csv",
                        lambda temporary: frame.to_csv(temporary, index=False, float_format="%.8g"))
    wall = time.perf_counter() - start
    write_json(out / "fit_settings.json", {
        "kind": "shear", "poisson_ratio": poisson_ratio, "material": material, "confidence": confidence,
        "input": source or "command line", "cells": cells,
        "master_curve": curve.metadata | {"poisson_ratio": curve.poisson_ratio, "material": curve.material,
                                          "capillary_number_range": [0.0, curve.ca_max],
                                          "deformation_range": list(curve.range("deformation"))},
        "definitions": "Ca = eta shear_rate / mu = shear_stress / mu; mu = shear_stress / Ca; E = 2 mu (1 + nu); "
                       "D = (a - b)/(a + b) of the inertia-equivalent ellipsoid; tank-treading frequency = angular "
                       "velocity (rad/s), normalised by the shear rate",
        "uncertainty": "interval at `confidence`: sigma_D = sqrt(deformation_error^2 + master-curve error^2 / 3) "
                       "(the curve's error column read as a uniform half-width) mapped "
                       "through the inverse curve D(Ca); shear_stress_error added in quadrature on the log scale",
        "execution": "in process", "n_cells": len(rows), "wall_time_s": wall, "software": software_versions(),
    })
    return {"rows": rows, "wall_time_s": wall, "curve": curve}
