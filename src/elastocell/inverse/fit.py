"""From a measured force curve to a Young's modulus: instrument files, a robust contact point, least-squares fits
to the master curve and to Hertz, and the checks that say when a fit cannot be trusted.

Geometry: parallel plates (docs/theory.md; ``plates`` is the same). The plate's approach ``displacement`` (m,
increasing towards the cell) and the ``force`` (N) are converted to ``delta = (displacement - contact_point) / (2 R)``
(the gap is ``h = 2R - (displacement - contact_point)``, so ``delta = 1 - h/(2R)``) and fitted by
``F = E R^2 f(delta)`` with ``f`` the homogeneous master curve (:mod:`elastocell.inverse.mastercurve`) or Hertz's
two-contact law ``f = 4/(3(1-nu^2)) delta^(3/2)``. ``sphere-indenter``: a bead of radius R_b
(``indenter_radius``) pressed into a suspended cell on a dish; the displacement after contact is the bead's depth
and ``F = E R^2 s(depth/R, R_b/R)`` with ``s`` the master surface (:mod:`elastocell.inverse.indentation_surface`),
Hertz's sphere on a half-space ``F = 4/3 E/(1-nu^2) sqrt(R_b) d^(3/2)`` beside it (``youngs_modulus_hertz``, the
formula of :func:`fit_hertz_sphere`); the same contact point, intervals and checks as the plates. ``cone``: a cone of
half-angle alpha (``half_angle``) pressed into a layer of thickness h bonded to the dish, ``F = E h^2
s(depth/h, tan(alpha))`` with the cone layer's master surface, Sneddon's cone on a half-space
``F = 2/pi E/(1-nu^2) tan(alpha) d^2`` beside it (``youngs_modulus_hertz``). ``pyramid``: a four-sided pyramid of
face half-angle ``half_angle`` (the sharp tip of most AFM cantilevers), fitted as its area-equivalent
cone (:func:`elastocell.scenarios.indentation.pyramid_equivalent_cone`).

Reading (:func:`read_curves`): a ``.csv``/``.tsv``/``.txt`` whose header names the columns ``displacement`` (m)
and ``force`` (N) is elastocell's plain CSV, read as it is (its displacement is the plate's own); a force above
:data:`PLAIN_FORCE_MAX` (1 mN) or a displacement span above :data:`PLAIN_DISPLACEMENT_SPAN_MAX` (1 mm) is a
column in another unit (nN, um) and the file is refused, naming it. Every other file
goes to afmformats (JPK ``.jpk-force``/``-force-map``/``-qi-series``/``-qi-data``, Asylum ``.ibw``, AFM Workshop
``.csv``, NT-MDT ``.txt``, afmformats' ``.tab``/``.h5``), and afmformats' own error is the one reported. Each
curve's approach segment (cut at the piezo's turning point) becomes the tip's displacement towards the sample,
``displacement = -(tip position)`` with ``tip position = height (measured) + force / k``: the piezo height minus
the cantilever's deflection, the convention of afmformats and of nanite's ``compute_tip_position`` (a file's own
``tip position`` column is used as it is). Without the deflection removed, the cantilever's bending counts as
indentation and E comes out too low. ``spring_constant`` (N/m) and ``sensitivity`` (m/V) override the file's
calibration or supply a missing one, with ``F = k * deflection`` and ``deflection = sensitivity * signal``: afmformats
recomputes the force from the raw detector signal where its reader takes them (JPK, AFM Workshop, NT-MDT; the
NT-MDT signal is a photodiode current in nA, so its sensitivity is in nm/nA: ``"61nm/nA"`` or a bare 61 (a
value written in nm/V is taken as that number of nm/nA, as before), held in m/nA, fits.csv's
``sensitivity_unit``; a sensitivity given per ampere is refused for a file of any other maker, whose signal is a
voltage); for the other formats the signal is recovered from the file's own calibration,
``signal = F / (k_file s_file)``, and ``F = k s signal``. An AFM Workshop file that stores force in nN has no
signal to rescale: ``k`` then only turns the force into the deflection, and a sensitivity does not apply
(detected by reading the file again with it doubled: the force stays; fits.csv's ``calibration`` says so and its
``sensitivity`` is NaN).

Contact point (``contact_point="auto"``, :func:`estimate_contact`):
1. Baseline: the first ``baseline_fraction`` (20 %) of the approach (sorted by displacement), its mean (with
   ``baseline_tilt`` a straight line); the force noise ``sigma`` is 1.4826 times the median absolute deviation of
   its residuals (the standard deviation of Gaussian noise, unmoved by spikes). The baseline is subtracted.
2. Noise exit: the point after which the corrected force stays above ``threshold * sigma`` (5 sigma) and above
   :data:`RISE_FRACTION` (5 %) of its largest value (a slow foot or a drifting baseline stays before it). No rise
   above ``threshold * sigma`` (fewer than 3 points, or not at the end): "no contact".
3. Change point: a piecewise model, a flat baseline and then a power law, ``F = b + a (x - c)^p`` for ``x > c``
   (``a >= 0``, ``p`` in 1..2.5), fitted by linear least squares for each candidate ``c`` between the first point
   and the noise exit (coarse to fine) to the curve up to 30 % of its largest force. Its ``c`` is the first guess.
4. The rise region ``[c - max(x_exit - c, 5 spacings), x_exit]``: the contact must lie where the force leaves the
   noise. The final fit keeps its contact point inside it (a contact point on its edge is flagged).
5. Refinement: E, the contact point and a constant force offset (what the baseline left) are fitted together by
   least squares over every point up to ``delta_max``, re-selecting the points with the refined contact point
   until the selection settles (at most 6 fits), so that the baseline's uncertainty enters E's.
A numeric ``contact_point`` fixes it and only E (and the offset) is fitted.

Uncertainty: a 95 % confidence interval from the fit's covariance (Student t, ``s^2 (J^T J)^-1``), widened for
correlated noise by ``sqrt((1 + rho)/(1 - rho))`` with ``rho`` the lag-1 autocorrelation of the residuals before
contact (the AR(1) effective sample size; ``noise_correlation_inflation``; measured on synthetic curves with AR(1)
noise: coverage 0.45 at rho = 0.9 without it, 0.95 with it), and,
with ``bootstrap=N``, a residual bootstrap (percentile interval of N refits to fitted curve + resampled
residuals). ``chi_square`` uses the baseline noise ``sigma``.

Checks (:func:`check_fit`, every fit): a curve that fails one gets a non-empty ``flag`` in ``fits.csv`` (its
reasons, separated by ``; ``), is drawn in a warning colour, and a value that is no result (E not finite or
positive, E at the solver's lower bound, an interval bound below zero) is written as NaN:
- the contact point inside the rise region and not on its edge;
- E finite, positive and above the solver's floor; its interval finite with both bounds > 0 and not wider
  than E itself (``ci_high - ci_low <= E``);
- E at most :data:`PLAUSIBLE_MODULUS_MAX` (1 GPa): above it no cell, gel or tissue, a unit or calibration error;
- at least :data:`MIN_POINTS_IN_CONTACT` points in contact;
- residuals without structure: the signs of the in-contact residuals, taken one per correlation length of the
  baseline noise (so coloured noise is not mistaken for a misfit), have a runs-test z above
  :data:`RUNS_Z_LIMIT`, or the misfit is small (the rms of the residuals smoothed over a twentieth of the contact
  region, below :data:`SYSTEMATIC_LIMIT` of the largest fitted force);
- no adhesion dip (:func:`adhesion_dip`): flagged where the force's running median falls below the baseline
  around contact by more than both :data:`ADHESION_DIP_SIGMAS` of the baseline's noise and
  :data:`ADHESION_DIP_LIMIT` of the largest fitted force (a snap-in, an adhesive tip or a baseline drifting into
  contact biases E high).
A curve that cannot be fitted at all (no contact, too few points, a fixed contact point outside the curve's
displacement range, a curve of a map afmformats cannot convert) is a row with NaN values and its reason as the
flag; an unexpected exception while fitting one curve (a bug) is such a row flagged "fit failed: <type>:
<message> (an internal error: please report it)", and the other curves go on; a file that cannot be read is a row
flagged "unreadable" with its ``error``, in the file's place among the rows. The command exits with code 2 when a
file cannot be read (after fitting the others), 3 when no curve was accepted.

Many files: :func:`fit_files` runs one Dask task per file (:mod:`elastocell.simulation.distributed`) with ``workers`` or
``scheduler``, or by itself from :data:`DASK_AUTO_MIN_FILES` files on; ``fits.csv`` is the same either way.

Shear flow: :func:`fit_shear` inverts the shear master curve D(Ca) (:mod:`elastocell.inverse.mastercurve_shear`) for
Ca = eta shear_rate / mu, then mu = shear_stress / Ca and E = 2 mu (1 + nu), with an interval from D's
uncertainty and the curve's error; :func:`fit_shear_cells` writes ``shear_fits.csv`` for many cells.
"""

from __future__ import annotations

import functools
import logging
import math
import re
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from elastocell.api.plotting import plt
from elastocell.body.effective_moduli import hashin_shtrikman_upper
from elastocell.files import replace_atomically, save_figure, software_versions, write_json
from elastocell.inverse.indentation_surface import (
    IndentationSurface,
    check_shape,
    depth_limit,
    load_indentation_surface,
    surface_shape,
)
from elastocell.inverse.mastercurve import MasterCurve, load_master_curve
from elastocell.inverse.mastercurve_shear import load_shear_master_curve
from elastocell.inverse.nucleated_curve import (
    COLLAPSE_VOLUME_RATIO,
    NucleatedCurve,
    check_nucleus_fits,
    nucleated_curve,
    volume_fraction,
)
from elastocell.parameters.units import ParameterError, parse_quantity
from elastocell.scenarios.axisymmetric import AxisymmetricInterrupted, sneddon_cone_force
from elastocell.scenarios.compression import hertz_force
from elastocell.scenarios.indentation import pyramid_equivalent_cone
from elastocell.simulation.distributed import TaskFailure, check_execution, default_workers, run_tasks

PLAIN_SUFFIXES = (".csv", ".txt", ".tsv")
GEOMETRIES = {"parallel-plates": "parallel-plates", "plates": "parallel-plates", "sphere-indenter": "sphere-indenter",
              "cone": "cone", "pyramid": "pyramid"}
"""Accepted ``geometry`` names and what they mean (``plates`` is an alias)."""
CONES = ("cone", "pyramid")
"""The sharp tips, fitted to the cone layer's master surface (a pyramid as its area-equivalent cone)."""
INDENTERS = ("sphere-indenter", *CONES)
"""The geometries whose x-axis is an indenter's depth (fitted to a master surface)."""

RISE_FRACTION = 0.05
"""The contact point lies before the force has risen above this fraction of its largest value (and above
``threshold`` sigma of the baseline noise): a slow foot or a drifting baseline stays within the rise region."""
MIN_POINTS_IN_CONTACT = 10
"""Fewer points in contact than this (below delta_max) and the fit is flagged."""
RUNS_Z_LIMIT = -3.29
"""Runs test on the signs of the in-contact residuals (one per correlation length of the baseline noise): fewer
runs than chance by more than 3.29 standard deviations (two-sided p = 0.001) is structure; it is flagged when the
misfit is also above :data:`SYSTEMATIC_LIMIT`."""
SYSTEMATIC_LIMIT = 0.02
"""The smoothed in-contact residual's rms over the largest fitted force above which structure is flagged.
Measured: 520 synthetic curves of the right model with white or AR(1) noise (rho up to 0.98, 0.5-5 % of the
largest force) reach at most 1.6 % (none flagged; coloured noise alone reaches runs z = -5.4, which is why the
runs test is not enough on its own); the wrong model (master-curve data fitted by Hertz to delta 0.75, and the
reverse) 6.6-9.3 %; the real curves of tests/data/afm 0.1-2.0 % where accepted (parallel plates, R = 8 um)."""

ADHESION_DIP_POINTS = 5
"""Points of the running median in which an adhesion dip is sought (one or two glitch points are no dip)."""
MEDIAN_OF_FIVE_SPREAD = 0.536
"""The standard deviation of the median of 5 independent Gaussian samples over theirs (0.5354 measured on 2e6 draws)."""
ADHESION_DIP_SIGMAS = 5.0
"""An adhesion dip must lie this many standard deviations of the baseline's own running median below it."""
ADHESION_DIP_LIMIT = 0.02
"""The depth of an adhesion dip, over the largest fitted force, above which the fit is flagged. Measured (``python
validation/afm_adhesion.py``, docs/validation/fit.md) on synthetic plate curves (Hertz to delta 0.3) with a DMT-like
adhesion (an attraction before contact and the same pull-off force in contact): E comes out high by 1.4 % per % of
dip (1.3 % at 1 %, 6.9 % at 5 %, 13.6 % at 10 %; the sphere-indenter's Hertz estimate the same) and the other checks
flag none up to 5 %; a 2 % dip biases E by about 3 %. Flagged at 1 % noise: 2 of 10 curves at a 2 % dip, 9 of 10 at
3 %, all from 5 %; none of 100 curves without adhesion at 0.3-3 % noise (largest 4.2 sigma) and no glitch of 1 or 2
points. The real curves of tests/data/afm (fitted as plates, R = 8 um): the JPK cell curves 0.2-1.2 % (1.6-3.0
sigma); flagged the NT-MDT gel file named "adh" (7.3 %, 28 sigma) and the AFM Workshop 2018 curve whose baseline
drifts down into contact (6.2 %, 7.7 sigma)."""

PLAUSIBLE_MODULUS_MAX = 1e9
"""Pa: a fitted E above this (1 GPa; bone is about 20 GPa, the stiffest cells and tissues measured by AFM reach
MPa) is no cell, gel or tissue, and is flagged: a force or displacement in the wrong unit, or a wrong calibration,
gives such numbers (a plain CSV's force in nN read as N multiplies E by 1e9)."""
PLAIN_FORCE_MAX = 1e-3
"""N: the largest |force| of a plain CSV (in N) that is read; AFM forces are pN to uN, so a larger value is a
force in another unit (nN, pN) and the file is refused."""
PLAIN_DISPLACEMENT_SPAN_MAX = 1e-3
"""m: the largest displacement span of a plain CSV (in m) that is read; an AFM approach travels nm to tens of
um, so a larger span is a displacement in another unit (um, nm) and the file is refused."""
LENGTH_BOUNDS = {"radius": (1e-7, 1e-3, "a cell radius"), "cap_height": (1e-7, 1e-3, "a cap height"),
                 "indenter_radius": (1e-8, 1e-3, "an indenter radius"),
                 "layer_thickness": (1e-8, 1e-2, "a layer thickness")}
"""(lowest, highest in m, what it is) of each length :class:`FitSettings` takes: a value outside is a length in
another unit than meant (``--radius 8e-6`` is 8 pm: a bare number is in um) and is refused."""

# makers whose afmformats reader recomputes the force from the raw signal with a user's calibration
_RECALIBRATING_READERS = ("JPK Instruments", "AFM workshop", "NT-MDT Spectrum Instruments")
_NTMDT = "NT-MDT Spectrum Instruments"
_WORKSHOP = "AFM workshop"  # its files hold a detector signal in V or a force in nN (then no calibration applies)


class CurveError(ValueError):
    """A curve that cannot be fitted (bad file, no contact, ...): the message names the file."""


LEGACY_SI_BELOW = 1e-3
"""A bare number below this given to :class:`FitSettings` as a cell or indenter radius, cap height or layer
thickness (in um, no such length is under 1 nm) or as a sensitivity (nm/V) is read as the SI value (m, m/V) that
callers of the Python API passed before the bare-number rule applied here: unambiguous by its size."""


def _setting(value, unit: str, parameter: str, legacy: bool = False) -> float | None:
    """A FitSettings value in SI: None as it is, a quantity ('8um', '50nm/V') converted, a bare number in its
    quantity's documented unit (``elastocell.parameters.units.BARE_UNITS``), or with ``legacy`` a bare number
    below :data:`LEGACY_SI_BELOW` as SI."""
    if value is None:
        return None
    if legacy and isinstance(value, (int, float)) and not isinstance(value, bool) and abs(value) < LEGACY_SI_BELOW:
        return float(value)
    return parse_quantity(value, unit, parameter)[0]


_PER_CURRENT = re.compile(r"\s*([+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)\s*([pnu\u00b5\u03bcm]?m)\s*/\s*"
                          r"([pnu\u00b5\u03bcm]?)A\s*")
_CURRENT_PREFIXES = {"": 1.0, "m": 1e-3, "u": 1e-6, "\u00b5": 1e-6, "\u03bc": 1e-6, "n": 1e-9, "p": 1e-12}


def _sensitivity_setting(value) -> tuple[float | None, str | None]:
    """A FitSettings sensitivity and its unit: a length per current (``'61nm/nA'``, ``'61 m/A'``: NT-MDT, whose
    detector signal is a photodiode current) in m/nA, the number a bare value (nm/nA) gives, with ``"m/nA"``;
    anything else as :func:`_setting` reads a sensitivity (m/V, with the legacy SI rule) with ``"m/V"`` (None:
    no sensitivity, ``(None, None)``). parse_quantity has no ampere: the per-current spelling is read here."""
    if value is None:
        return None, None
    if isinstance(value, str) and len(value) <= 64:
        match = _PER_CURRENT.fullmatch(value)
        if match is not None:
            metres = parse_quantity(match[1] + match[2], "m", "sensitivity")[0]
            return metres / _CURRENT_PREFIXES[match[3]] * 1e-9, "m/nA"
    return _setting(value, "m/V", "sensitivity", legacy=True), "m/V"


def _check_length(name: str, value: float | None) -> None:
    """Refuse (ParameterError naming ``name``) a length outside :data:`LENGTH_BOUNDS`."""
    if value is None or name not in LENGTH_BOUNDS:
        return
    low, high, noun = LENGTH_BOUNDS[name]
    if not low <= value <= high:
        raise ParameterError(name, f"{value * 1e6:.4g} um is outside [{low * 1e6:g}, {high * 1e6:g}] um, the range "
                                   f"of {noun} (a bare number is in um: 8 is 8 um, and on the command line 8e-6 is "
                                   "8 pm; give the unit, e.g. 8um)")


NUMBER_FIELDS = {"poisson_ratio": "dimensionless", "delta_max": "delta = 1 - h/(2R)",
                 "depth_max": "units of R, the layer's h", "baseline_fraction": "a share of the approach",
                 "threshold": "baseline standard deviations", "nucleus_size_ratio": "lambda = R_n/R",
                 "stiffness_ratio": "gamma = E_n/E_c"}
"""The :class:`FitSettings` fields that are plain numbers (no unit), with what they are measured in."""


@dataclass(frozen=True)
class FitSettings:
    """What ``elastocell fit afm`` fits, under the CLI's names.

    Quantities follow the CLI's rule: a string with a unit (``radius="8um"``, ``spring_constant="50mN/m"``,
    ``sensitivity="50nm/V"``) or a bare number in its documented unit (lengths in um, spring constant N/m,
    sensitivity nm/V; NT-MDT, whose signal is a current: ``"61nm/nA"`` or a bare number in nm/nA). Lengths given
    as SI floats (``radius=8e-6``) keep working: a radius, indenter radius, cap height or layer thickness, or a
    sensitivity, below :data:`LEGACY_SI_BELOW` cannot be meant in um or nm/V and is read as metres (m/V); then
    each length must lie within :data:`LENGTH_BOUNDS` (a cell radius and cap height 0.1 um to 1 mm, an indenter
    radius 10 nm to 1 mm, a layer thickness 10 nm to 10 mm). ``contact_point`` has no such reading (any value can
    be a contact point): bare, it is in um; ``"auto"`` (any case) is None. After construction every field holds
    SI floats (m, N/m, m/V; a sensitivity given per ampere: m/nA, :attr:`sensitivity_unit`), as fits.csv and
    fit_settings.json record.

    An option that does not apply to the geometry is refused, naming it, rather than ignored: the plates take no
    ``indenter_radius``, ``cap_height``, ``layer_thickness``, ``depth_max`` or ``cell_shape`` other than sphere;
    the indenters no ``delta_max`` other than 0.75; the sphere no ``cap_height`` or ``layer_thickness``, the cap no
    ``layer_thickness``, the layer (and the cone's) no ``cap_height``. ``model="hertz"`` with the nucleus options
    is refused (the nucleated fit needs the master curve or surface).

    geometry: ``parallel-plates`` (``plates``) or ``sphere-indenter`` (a bead of radius ``indenter_radius``, needed,
    pressed into a cell of shape ``cell_shape`` on a dish; the x-axis is the bead's depth). ``delta_max`` limits the
    plate fit (delta <= 0.75), ``depth_max`` (units of R; default the master surface's range) the indenter fit.
    ``cell_shape="layer"``: a layer of thickness ``layer_thickness`` (needed) bonded to the dish; its length unit is
    h (``length_unit``, ``depth_max`` in units of h) and ``radius`` is not needed (recorded when given).
    ``cell_shape="cap"``: an adherent cell, a spherical cap of base radius ``radius`` and apex height
    ``cap_height`` (both needed; H/R in the cap surface's range) bonded to the dish.
    """

    radius: float | str | None = None  # m after construction; needed except by the layer
    poisson_ratio: float = 0.48
    material: str = "neo-hookean"
    geometry: str = "parallel-plates"
    model: str = "both"  # master | hertz | both
    delta_max: float = 0.75
    contact_point: float | str | None = None  # m after construction; None = auto
    bootstrap: int = 0
    seed: int = 0
    baseline_fraction: float = 0.2
    threshold: float = 5.0
    baseline_tilt: bool = False
    nucleus_size_ratio: float | None = None
    stiffness_ratio: float | None = None
    spring_constant: float | str | None = None  # N/m; None = the file's
    sensitivity: float | str | None = None  # m/V after construction; None = the file's
    indenter_radius: float | str | None = None  # m after construction, R_b of the spherical probe
    cell_shape: str = "sphere"  # sphere-indenter: sphere | cap | layer
    cap_height: float | str | None = None  # m after construction (recorded; cap)
    layer_thickness: float | str | None = None  # m after construction (recorded; layer)
    depth_max: float | None = None  # units of R (sphere-indenter); None = the master surface's range
    half_angle: float | str | None = None  # degrees after construction (cone; pyramid: the face's)

    def __post_init__(self):
        for name in ("bootstrap", "seed"):  # whole numbers: a string of one is read, anything else refused
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int):
                try:
                    number = float(value)
                except (TypeError, ValueError):
                    number = math.nan
                if not (math.isfinite(number) and number == int(number)):
                    raise ParameterError(name, f"a whole number, got {value!r}")
                object.__setattr__(self, name, int(number))
        for name, unit in NUMBER_FIELDS.items():  # plain numbers: a string of one is read, anything else refused
            value = getattr(self, name)
            if value is None or (isinstance(value, (int, float)) and not isinstance(value, bool)):
                continue
            try:
                object.__setattr__(self, name, float(value))
            except (TypeError, ValueError):
                raise ParameterError(name, f"a plain number ({unit}), got {value!r}") from None
        if isinstance(self.contact_point, str) and self.contact_point.strip().lower() == "auto":
            object.__setattr__(self, "contact_point", None)  # the CLI's default spelling
        sensitivity, sensitivity_unit = _sensitivity_setting(self.sensitivity)
        object.__setattr__(self, "sensitivity", sensitivity)
        object.__setattr__(self, "_sensitivity_unit", sensitivity_unit)  # not a field: m/V or m/nA, as given
        for name, unit, legacy in (("radius", "m", True), ("contact_point", "m", False),
                                   ("spring_constant", "N/m", False),
                                   ("indenter_radius", "m", True), ("cap_height", "m", True),
                                   ("layer_thickness", "m", True)):
            object.__setattr__(self, name, _setting(getattr(self, name), unit, name, legacy))
        for name in ("radius", "spring_constant", "sensitivity", "indenter_radius", "cap_height", "layer_thickness"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise ParameterError(name, f"must be > 0, got {value}")
            _check_length(name, value)
        resolved = GEOMETRIES.get(str(self.geometry).strip().lower())
        layer = resolved in INDENTERS and self.cell_shape == "layer"
        if resolved in CONES:
            surface_shape(self.cell_shape, "cone")  # the layer's surface only: named before --radius would be
        if resolved is not None:  # an option the geometry ignores: named before what the geometry needs
            self._refuse_what_does_not_apply(resolved)
        if self.radius is None and not layer:
            raise ParameterError("radius", "required (the cell radius, e.g. 8um)")
        if not (math.isfinite(self.poisson_ratio) and -1 < self.poisson_ratio < 0.5):
            raise ParameterError("poisson_ratio", f"must be in (-1, 0.5), got {self.poisson_ratio}")
        geometry = GEOMETRIES.get(str(self.geometry).strip().lower())
        if geometry is None:
            raise ParameterError("geometry", f"must be parallel-plates (or plates), sphere-indenter, cone or pyramid, got "
                                             f"{self.geometry!r}")
        object.__setattr__(self, "geometry", geometry)
        if self.half_angle is not None:
            if geometry not in CONES:
                raise ParameterError("half_angle", "applies to --geometry cone or pyramid only")
            object.__setattr__(self, "half_angle", parse_quantity(self.half_angle, "deg", "half_angle")[0])
        if geometry in CONES:
            if self.indenter_radius is not None:
                raise ParameterError("indenter_radius", f"is the bead's radius; --geometry {geometry} has "
                                                        "--half-angle")
            if self.half_angle is None:
                raise ParameterError("half_angle", f"required with --geometry {geometry} (e.g. "
                                                   f"{'20deg' if geometry == 'cone' else '35deg, the face half-angle'})")
            if not 0 < self.half_angle < 90:
                raise ParameterError("half_angle", f"must be in (0, 90) degrees, got {self.half_angle:g}")
            if self.layer_thickness is None:
                raise ParameterError("layer_thickness", f"required with --geometry {geometry} (e.g. 5um)")
            if self.depth_max is not None and not 0 < self.depth_max <= 1:
                raise ParameterError("depth_max", f"must be in (0, 1] (units of h), got {self.depth_max}")
        if geometry == "sphere-indenter":
            if self.indenter_radius is None:
                raise ParameterError("indenter_radius", "required with --geometry sphere-indenter (e.g. 5um)")
            check_shape(self.cell_shape)
            if layer and self.layer_thickness is None:
                raise ParameterError("layer_thickness", "required with --cell-shape layer (e.g. 50um)")
            if self.cell_shape == "cap" and self.cap_height is None:
                raise ParameterError("cap_height", "required with --cell-shape cap (the cell's apex height above "
                                                   "the dish, e.g. 4um)")
            if self.depth_max is not None and not 0 < self.depth_max <= 1:
                raise ParameterError("depth_max", f"must be in (0, 1] (units of {'h' if layer else 'R'}), got "
                                                  f"{self.depth_max}")
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
            if geometry in CONES or (geometry == "sphere-indenter" and self.cell_shape == "layer"):
                raise ParameterError("nucleus_size_ratio", "a layer (a gel or tissue section) is homogeneous: the "
                                                           "nucleus options apply to --geometry plates or "
                                                           "sphere-indenter with --cell-shape sphere or cap")
            check_nucleus_fits(self.nucleus_size_ratio, "cap" if self.cap_ratio is not None else "sphere",
                               self.cap_ratio)
            if not (math.isfinite(self.stiffness_ratio) and self.stiffness_ratio > 0):
                raise ParameterError("stiffness_ratio", f"must be > 0, got {self.stiffness_ratio}")
            if self.model == "hertz":
                raise ParameterError("model", "hertz fits no cell with a nucleus: the nucleated fit "
                                              "(--nucleus-size-ratio, --stiffness-ratio) needs the master curve or "
                                              "surface; use --model master or both")

    def _refuse_what_does_not_apply(self, geometry: str) -> None:
        """A ParameterError naming the first option given that ``geometry`` (resolved) and ``cell_shape`` do not
        use, and saying which geometry it belongs to: an option silently ignored would fit something else than
        the user described."""
        given = {name: getattr(self, name) is not None for name in ("indenter_radius", "cap_height",
                                                                    "layer_thickness", "depth_max")}
        if geometry == "parallel-plates":
            belongs = {"indenter_radius": "--geometry sphere-indenter (the bead's radius)",
                       "cap_height": "--geometry sphere-indenter --cell-shape cap",
                       "layer_thickness": "--geometry sphere-indenter, cone or pyramid with --cell-shape layer",
                       "depth_max": "--geometry sphere-indenter, cone or pyramid (the plates fit up to --delta-max)"}
            for name, where in belongs.items():
                if given[name]:
                    raise ParameterError(name, f"does not apply to --geometry parallel-plates: it belongs to {where}")
            if self.cell_shape != "sphere":
                raise ParameterError("cell_shape", f"{self.cell_shape!r} does not apply to --geometry "
                                                   "parallel-plates (a suspended cell between plates): it belongs to "
                                                   "--geometry sphere-indenter, cone or pyramid")
            return
        default = self.__dataclass_fields__["delta_max"].default
        if self.delta_max != default:
            raise ParameterError("delta_max", f"does not apply to --geometry {geometry}: it belongs to --geometry "
                                              "parallel-plates; an indenter is fitted up to --depth-max")
        shape = self.cell_shape
        if geometry in CONES and given["cap_height"]:
            raise ParameterError("cap_height", f"does not apply to --geometry {geometry} (a layer): it belongs to "
                                               "--geometry sphere-indenter --cell-shape cap")
        if geometry == "sphere-indenter":
            check_shape(shape)
            for name, shapes in (("cap_height", ("cap",)), ("layer_thickness", ("layer",))):
                if given[name] and shape not in shapes:
                    raise ParameterError(name, f"does not apply to --cell-shape {shape}: it belongs to --geometry "
                                               f"sphere-indenter --cell-shape {shapes[0]}")

    @property
    def sensitivity_unit(self) -> str | None:
        """The unit ``sensitivity`` holds: ``"m/V"``, ``"m/nA"`` when it was given per ampere (``'61nm/nA'``, for
        NT-MDT files only), None without a sensitivity."""
        return getattr(self, "_sensitivity_unit", None if self.sensitivity is None else "m/V")

    @property
    def length_unit(self) -> float:
        """R of ``F = E R^2 f``: the cell radius, the layer's thickness h (sphere-indenter or cone,
        ``cell_shape="layer"``)."""
        if self.geometry in INDENTERS and self.cell_shape == "layer":
            return self.layer_thickness
        return self.radius

    @property
    def cap_ratio(self) -> float | None:
        """H/R of the adherent cap (sphere-indenter, ``cell_shape="cap"``): apex height over base radius."""
        if self.geometry == "sphere-indenter" and self.cell_shape == "cap":
            return self.cap_height / self.radius
        return None

    @property
    def nucleus_volume_fraction(self) -> float | None:
        """phi: the nucleus's share of the cell's volume (lambda^3; in a cap, of the cap's volume); None without
        a nucleus."""
        if self.nucleus_size_ratio is None:
            return None
        return volume_fraction(self.nucleus_size_ratio, "cap" if self.cap_ratio is not None else "sphere",
                               self.cap_ratio)

    @property
    def cone_half_angle(self) -> float | None:
        """alpha (degrees) of the cone fitted: ``half_angle`` for a cone, the area-equivalent cone's for a pyramid
        (tan(alpha) = 2/sqrt(pi) tan(face half-angle)); None for a bead or the plates."""
        if self.geometry == "pyramid":
            return pyramid_equivalent_cone(self.half_angle)
        return self.half_angle if self.geometry == "cone" else None

    @property
    def indenter_ratio(self) -> float:
        """R_b/R of the sphere-indenter geometry (the layer: R_b/h); the cone's tan(alpha), its surface's key."""
        if self.geometry in CONES:
            return math.tan(math.radians(self.cone_half_angle))
        return self.indenter_radius / self.length_unit


def parse_length(value, parameter: str) -> float:
    """A length in metres from '8um', '8e-6 m' or a bare number (in um, the bare-number unit of a length)."""
    magnitude, _ = parse_quantity(value, "m", parameter)
    return magnitude


def parse_spring_constant(value, parameter: str = "spring_constant") -> float:
    """A spring constant in N/m from '0.05N/m', '50 mN/m' or a bare number (N/m)."""
    return parse_quantity(value, "N/m", parameter)[0]


def parse_sensitivity(value, parameter: str = "sensitivity") -> float:
    """A deflection sensitivity in m/V from '50nm/V' or a bare number (nm/V); NT-MDT's per current, '61nm/nA', in
    m/nA (the number the bare 61 gives)."""
    if isinstance(value, str) and len(value) <= 64 and _PER_CURRENT.fullmatch(value):
        return _sensitivity_setting(value)[0]
    return parse_quantity(value, "m/V", parameter)[0]


# ---------------------------------------------------------------- reading


@dataclass
class Curve:
    """One approach curve: ``displacement`` (m, towards the sample: the tip's for an instrument file) and
    ``force`` (N), with where it came from and the calibration it was read with."""

    name: str
    displacement: np.ndarray
    force: np.ndarray
    source: str = ""
    index: int = 0
    piezo_displacement: np.ndarray | None = None  # m, -(height (measured)): before the deflection is removed
    instrument: str = ""
    format: str = "plain CSV"
    spring_constant: float = float("nan")  # N/m
    sensitivity: float = float("nan")  # m/V (NT-MDT: m/nA): sensitivity_unit
    calibration: str = "file"
    position: str = "displacement column"
    sensitivity_unit: str = ""  # "m/V", "m/nA" (NT-MDT: its signal is a current); "" (plain CSV) none

    def info(self) -> dict:
        """The columns fits.csv records about the curve's reading."""
        return {"source": self.source, "curve_index": self.index, "instrument": self.instrument,
                "format": self.format, "spring_constant": self.spring_constant, "sensitivity": self.sensitivity,
                "sensitivity_unit": self.sensitivity_unit, "calibration": self.calibration,
                "position": self.position}


def read_curves(path: Path, spring_constant: float | None = None, sensitivity: float | None = None,
                sensitivity_unit: str | None = None) -> list[Curve]:
    """Every approach curve in ``path`` (see the module docstring): elastocell's plain CSV, or afmformats'
    formats with the tip position; ``spring_constant`` (N/m) and ``sensitivity`` (m/V; NT-MDT m/nA) override or
    supply the file's calibration. ``sensitivity_unit="m/nA"`` (a sensitivity given per ampere,
    :attr:`FitSettings.sensitivity_unit`) is refused for a file whose signal is a voltage (every maker but NT-MDT).
    Raises CurveError naming the file (with afmformats' own error for its formats)."""
    path = Path(path)
    if not path.exists():
        raise CurveError(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix in PLAIN_SUFFIXES and _looks_plain(path):
        if spring_constant is not None or sensitivity is not None:
            raise CurveError(f"{path}: a plain CSV holds force and displacement, no detector signal: "
                             "--spring-constant and --sensitivity do not apply to it")
        displacement, force = _read_plain(path)
        return [Curve(path.stem, displacement, force, source=str(path))]
    import afmformats  # noqa: F401  (a dependency; imported here because it takes 0.5 s)

    if suffix not in afmformats.supported_extensions:
        if suffix in PLAIN_SUFFIXES:
            raise CurveError(f"{path}: missing column(s) 'displacement' and/or 'force' (plain CSV needs both)")
        raise CurveError(f"{path}: unsupported file type {path.suffix!r} (plain CSV, or afmformats' "
                         f"{', '.join(afmformats.supported_extensions)})")
    return _read_afmformats(path, spring_constant, sensitivity, sensitivity_unit)


def _looks_plain(path: Path) -> bool:
    """Whether the first line that is not blank or a ``#`` comment names the columns displacement and force."""
    try:
        with open(path, encoding="utf-8") as handle:
            for _, line in zip(range(200), handle, strict=False):
                text = line.strip()
                if not text or text.startswith("#"):
                    continue
                names = {token.strip("\"' ").lower() for token in re.split(r"[,;\t ]+", text)}
                return {"displacement", "force"} <= names
    except (UnicodeDecodeError, OSError):
        return False
    return False


def _read_plain(path: Path):
    import pandas as pd

    try:
        table = pd.read_csv(path, sep=None, engine="python", comment="#")
    except Exception as error:
        raise CurveError(f"{path}: cannot read as CSV ({type(error).__name__}: {error})") from None
    columns = {str(c).strip().strip("\"'").lower(): c for c in table.columns}
    if "displacement" not in columns or "force" not in columns:
        raise CurveError(f"{path}: missing column(s) 'displacement' and/or 'force' (plain CSV needs both)")
    try:
        displacement = pd.to_numeric(table[columns["displacement"]], errors="raise").to_numpy(float)
        force = pd.to_numeric(table[columns["force"]], errors="raise").to_numpy(float)
    except (ValueError, TypeError):
        raise CurveError(f"{path}: non-numeric values in 'displacement' or 'force'") from None
    # the plain CSV is in SI: a force in nN or a displacement in um would give a wrong modulus by powers of 1e3
    finite_force = force[np.isfinite(force)]
    largest = float(np.max(np.abs(finite_force))) if finite_force.size else 0.0
    if largest > PLAIN_FORCE_MAX:
        raise CurveError(f"{path}: the force column reaches {largest:.4g} N, above {PLAIN_FORCE_MAX:g} N: a plain "
                         "CSV's force is in N (AFM forces are pN to uN); convert it to N, e.g. nN x 1e-9")
    finite_displacement = displacement[np.isfinite(displacement)]
    span = float(np.ptp(finite_displacement)) if finite_displacement.size else 0.0
    if span > PLAIN_DISPLACEMENT_SPAN_MAX:
        raise CurveError(f"{path}: the displacement column spans {span:.4g} m, above {PLAIN_DISPLACEMENT_SPAN_MAX:g} "
                         "m: a plain CSV's displacement is in m (an AFM approach travels nm to tens of um); convert "
                         "it to m, e.g. um x 1e-6")
    return displacement, force


def _afmformats_error(path: Path, error: BaseException) -> CurveError:
    import afmformats

    message = f"{path}: afmformats cannot read it ({type(error).__name__}: {error})"
    if isinstance(error, afmformats.errors.MissingMetaDataError) or "sensitivity" in str(error) \
            or "spring constant" in str(error):
        message += "; give --spring-constant and --sensitivity"
    if path.suffix.lower() in PLAIN_SUFFIXES:
        message += "; not elastocell's plain CSV either (missing column(s) 'displacement' and/or 'force')"
    return CurveError(message)


def _load_afmformats(path: Path, meta_override: dict):
    """afmformats.load_data without its logged tracebacks (its own exception is raised, and reported)."""
    import afmformats

    logger = logging.getLogger("afmformats")
    level = logger.level
    logger.setLevel(logging.CRITICAL + 1)
    try:
        return afmformats.load_data(path, meta_override=meta_override, modality="force-distance")
    finally:
        logger.setLevel(level)


def _read_afmformats(path: Path, spring_constant: float | None, sensitivity: float | None,
                     sensitivity_unit: str | None = None) -> list[Curve]:
    import warnings

    import afmformats

    try:
        recipe = afmformats.formats.get_recipe(path, modality="force-distance")
        maker = recipe["maker"]
    except BaseException as error:  # afmformats raises many types for foreign files
        if isinstance(error, (KeyboardInterrupt, SystemExit)):
            raise
        raise _afmformats_error(path, error) from None
    if sensitivity is not None and sensitivity_unit == "m/nA" and maker != _NTMDT:
        raise CurveError(f"{path}: --sensitivity is given per ampere ({sensitivity * 1e9:.4g} nm/nA, for NT-MDT's "
                         f"photodiode current) but this file's ({maker}) detector signal is a voltage: give it in "
                         "nm/V")
    overridden = spring_constant is not None or sensitivity is not None
    recalibrates = maker in _RECALIBRATING_READERS
    override = {}
    if recalibrates:
        if spring_constant is not None:
            override["spring constant"] = spring_constant
        if sensitivity is not None:  # NT-MDT's signal is in nA and afmformats takes m/A: nm/nA = 1e9 * (m/nA)
            override["sensitivity"] = sensitivity * (1e9 if maker == _NTMDT else 1.0)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            datasets = _load_afmformats(path, override)
    except BaseException as error:
        if isinstance(error, (KeyboardInterrupt, SystemExit)):
            raise
        raise _afmformats_error(path, error) from None
    force_in_file = False
    if override and maker == _WORKSHOP:  # a file of force in nN: the calibration does not enter the force
        force_in_file = _calibration_leaves_the_force(path, override, datasets)
    curves = []
    for index, data in enumerate(datasets):
        name = path.stem if len(datasets) == 1 else f"{path.stem}_{index:04d}"
        try:
            curves.append(_afmformats_curve(data, name, str(path), index, maker, spring_constant, sensitivity,
                                            overridden and not recalibrates, force_in_file))
        except CurveError as error:
            curves.append(CurveError(f"{path}: curve {index}: {error}"))
    if not curves:
        raise CurveError(f"{path}: no force-distance curve in the file")
    if all(isinstance(curve, CurveError) for curve in curves):  # the file's calibration, not one curve
        raise CurveError(str(curves[0]).replace(f"{path}: curve 0: ", f"{path}: ", 1))
    return curves


def _calibration_leaves_the_force(path: Path, override: dict, datasets) -> bool:
    """Whether afmformats' force of ``path`` stays the same when the calibration in ``override`` changes: the file
    holds a force (AFM Workshop's ``Force(nN)`` columns), not a detector signal, so a given sensitivity does not
    apply and a spring constant only turns the force into the deflection. Probed by reading the file again with
    the sensitivity (else the spring constant) doubled: a signal's force doubles, a stored force does not."""
    import warnings

    key = "sensitivity" if "sensitivity" in override else "spring constant"
    probe = dict(override, **{key: 2 * override[key]})
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            probed = _load_afmformats(path, probe)
    except Exception:  # the first reading worked with these keys: the probe should too; if not, assume a signal
        return False
    if len(probed) != len(datasets):
        return False
    for first, second in zip(datasets, probed, strict=True):
        if "force" not in first.columns or "force" not in second.columns:
            return False
        if not np.array_equal(np.asarray(first["force"], float), np.asarray(second["force"], float), equal_nan=True):
            return False
    return True


def _afmformats_curve(data, name: str, source: str, index: int, maker: str, spring_constant, sensitivity,
                      rescale: bool, force_in_file: bool = False) -> Curve:
    """One afmformats dataset as a Curve (tip position; calibration overridden or supplied). ``force_in_file``:
    the file holds a force that the calibration does not change (:func:`_calibration_leaves_the_force`)."""
    metadata = data.metadata
    columns = set(data.columns)
    file_k = metadata.get("spring constant")
    file_s = metadata.get("sensitivity")
    segment = data.appr
    if "force" not in columns:
        raise CurveError("no force column")
    force = np.asarray(segment["force"], dtype=float)
    if "height (measured)" in columns:
        height, position = np.asarray(segment["height (measured)"], dtype=float), "tip"
    elif "height (piezo)" in columns:
        height, position = np.asarray(segment["height (piezo)"], dtype=float), "tip (from the piezo's set height)"
    else:
        height, position = None, ""
    calibration = "file"
    k, s = file_k, file_s
    if rescale:  # the reader does not recompute: the signal from the file's calibration, F = k s signal
        k = spring_constant if spring_constant is not None else file_k
        s = sensitivity if sensitivity is not None else file_s
        missing = [label for label, value in (("spring constant", file_k), ("sensitivity", file_s)) if not value]
        if missing:
            raise CurveError(f"the file has no {' or '.join(missing)} to recover the detector signal from, so "
                             "--spring-constant/--sensitivity cannot rescale its force")
        force = force * (k / file_k) * (s / file_s)
        calibration = "rescaled by elastocell from the file's calibration (signal = F/(k_file s_file))"
    elif force_in_file:  # say what the options did: the force is the file's
        calibration = "the file's force (no detector signal to recompute it from)"
        if spring_constant is not None:
            calibration += "; the spring constant given turns it into the deflection F/k (tip position)"
        if sensitivity is not None:
            calibration += "; the sensitivity given did not apply"
            s = None  # no sensitivity entered the force
    elif spring_constant is not None or sensitivity is not None:
        calibration = "recomputed by afmformats from the raw signal"
    if maker == _NTMDT and s:
        s = s * 1e-9  # afmformats' m/A back to m per nA
    if "tip position" in data.columns_innate and not rescale and spring_constant is None:
        tip = np.asarray(segment["tip position"], dtype=float)
        position = "tip (the file's tip position)"
    else:
        if height is None:
            raise CurveError("no height column")
        if not k:
            raise CurveError("no spring constant in the file: the tip position (piezo height minus the deflection "
                             "F/k) needs one; give --spring-constant")
        tip = height + force / k  # nanite's compute_tip_position: piezo height minus deflection
    piezo = -height if height is not None else None
    displacement = -tip
    # the approach ends where the piezo turns (some readers put the whole curve in the approach segment)
    reach = piezo if piezo is not None else displacement
    finite = np.isfinite(reach)
    if finite.any():
        turn = int(np.nanargmax(np.where(finite, reach, -np.inf)))
        displacement, force = displacement[:turn + 1], force[:turn + 1]
        piezo = piezo[:turn + 1] if piezo is not None else None
    instrument = str(metadata.get("instrument") or metadata.get("software") or maker)
    return Curve(name, displacement, force, source=source, index=index, piezo_displacement=piezo,
                 instrument=instrument, format=str(metadata.get("format", maker)),
                 spring_constant=float(k) if k else float("nan"), sensitivity=float(s) if s else float("nan"),
                 calibration=calibration, position=position + " = piezo height - deflection"
                 if "file's" not in position else position, sensitivity_unit="m/nA" if maker == _NTMDT else "m/V")


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
    """Force offset (and, with ``tilt``, slope) of the first ``fraction`` of the approach, and its noise
    (1.4826 x the median absolute deviation of the residuals; their standard deviation if that is 0, as on a
    coarsely quantised signal)."""
    n = max(5, int(round(fraction * len(displacement))))
    if tilt:
        slope, intercept = np.polyfit(displacement[:n], force[:n], 1)
    else:
        slope, intercept = 0.0, float(np.mean(force[:n]))
    residual = force[:n] - (slope * displacement[:n] + intercept)
    sigma = 1.4826 * float(np.median(np.abs(residual - np.median(residual))))
    if not sigma > 0:
        sigma = float(np.sqrt(np.sum(residual**2) / max(n - (2 if tilt else 1), 1)))
    return Baseline(float(slope), float(intercept), sigma, n)


@dataclass
class ContactEstimate:
    """The contact point's first guess (change point), the rise region that bounds it, and the baseline."""

    contact: float
    lower: float  # m: the rise region [lower, upper]
    upper: float  # m: the noise exit, where the force has left the baseline noise for good
    baseline: Baseline
    level: float  # N: threshold * sigma
    exponent: float  # p of the change-point model


def _change_point(x: np.ndarray, y: np.ndarray, low: float, high: float, tilt: bool) -> tuple[float, float]:
    """``c`` (and ``p``) of the least-squares piecewise model ``y = b (+ s x) + a max(x - c, 0)^p`` (a >= 0),
    ``c`` in [low, high], ``p`` in 1..2.5: candidates on a grid of 160 (on bin means of at most 2000 points),
    refined three times (41 candidates around the best, on every point)."""
    exponents = (1.0, 1.25, 1.5, 1.75, 2.0, 2.5)
    scale = max(float(x[-1] - x[0]), 1e-300)
    u = (x - x[0]) / scale  # a well-conditioned abscissa
    lo, hi = (low - x[0]) / scale, (high - x[0]) / scale
    if len(u) > 4000:  # the coarse pass on bin means: the shape, at a fraction of the cost
        groups = len(u) // 2000 + 1
        cut = len(u) // groups * groups
        coarse = u[:cut].reshape(-1, groups).mean(axis=1), y[:cut].reshape(-1, groups).mean(axis=1)
    else:
        coarse = u, y

    def scan(uu, yy, candidates):
        # the power-law term is zero before the earliest candidate: sums over those points are the baseline's
        first = int(np.searchsorted(uu, candidates.min(), side="right"))
        tail_u, tail_y = uu[first:], yy[first:]
        sums = {"1": float(len(uu)), "x": float(uu.sum()), "xx": float(uu @ uu), "y": float(yy.sum()),
                "xy": float(uu @ yy), "yy": float(yy @ yy)}
        t = np.maximum(tail_u[None, :] - candidates[:, None], 0.0)
        log_t = np.full_like(t, -np.inf)
        np.log(t, out=log_t, where=t > 0)
        best = (math.inf, None, None)
        for p in exponents:
            g = np.exp(p * log_t)
            g_sum, gg, gy = g.sum(axis=1), np.einsum("ij,ij->i", g, g), g @ tail_y
            m = len(candidates)
            if tilt:
                gx = g @ tail_u
                gram = np.empty((m, 3, 3))
                gram[:, 0, 0], gram[:, 0, 1], gram[:, 1, 1] = sums["1"], sums["x"], sums["xx"]
                gram[:, 0, 2], gram[:, 1, 2], gram[:, 2, 2] = g_sum, gx, gg
                rhs = np.stack([np.full(m, sums["y"]), np.full(m, sums["xy"]), gy], axis=1)
            else:
                gram = np.empty((m, 2, 2))
                gram[:, 0, 0], gram[:, 0, 1], gram[:, 1, 1] = sums["1"], g_sum, gg
                rhs = np.stack([np.full(m, sums["y"]), gy], axis=1)
            k = gram.shape[1]
            for i in range(k):
                for j in range(i):
                    gram[:, i, j] = gram[:, j, i]
            # the power-law term must not lie in the baseline's span (a candidate before every point with p = 1
            # under a tilted baseline is the slope itself: a singular system): the part of g that the baseline
            # columns cannot represent (a Schur complement) must be a real share of g
            basis = gram[:, :k - 1, :k - 1]
            cross = gram[:, :k - 1, k - 1]
            if tilt:
                determinant = sums["1"] * sums["xx"] - sums["x"] ** 2
                projected = (sums["xx"] * cross[:, 0] ** 2 - 2 * sums["x"] * cross[:, 0] * cross[:, 1]
                             + sums["1"] * cross[:, 1] ** 2) / max(determinant, 1e-300)
            else:
                projected = cross[:, 0] ** 2 / basis[:, 0, 0]
            usable = (gg > 0) & (gg - projected > 1e-9 * gg)
            gram[~usable] = np.eye(k)
            coefficients = np.linalg.solve(gram, rhs[..., None])[..., 0]
            ssr = sums["yy"] - np.sum(coefficients * rhs, axis=1)
            ssr[~usable | (coefficients[:, -1] < 0) | ~np.isfinite(ssr)] = np.inf  # the force rises after contact
            i = int(np.argmin(ssr))
            if ssr[i] < best[0]:
                best = (float(ssr[i]), float(candidates[i]), p)
        return best

    candidates = np.linspace(lo, hi, 160)
    _, c, p = scan(*coarse, candidates)
    if c is None:
        return high, 1.5
    step = candidates[1] - candidates[0]
    for _ in range(3):
        candidates = np.linspace(max(lo, c - 2 * step), min(hi, c + 2 * step), 41)
        step = candidates[1] - candidates[0]
        _, refined, exponent = scan(u, y, candidates)
        if refined is not None:
            c, p = refined, exponent
    return float(x[0] + c * scale), float(p)


def estimate_contact(displacement: np.ndarray, force: np.ndarray, fraction: float = 0.2, threshold: float = 5.0,
                     name: str = "curve", tilt: bool = False) -> ContactEstimate:
    """The contact point's first guess and its rise region (steps 1-4 of the module docstring); displacement
    sorted and increasing. Raises CurveError ("no contact") when the force never leaves the baseline noise."""
    baseline = fit_baseline(displacement, force, fraction, tilt)
    corrected = force - baseline(displacement)
    level = threshold * baseline.sigma
    if level <= 0:  # noise-free data: a tiny fraction of the largest force
        level = 1e-9 * max(float(np.abs(corrected).max()), 1e-300)
    below = np.nonzero(corrected <= level)[0]
    if len(below) == 0 or below[-1] >= len(displacement) - 3 or corrected[-1] <= level:
        raise CurveError(f"{name}: no contact found (the force never rises above {threshold:g} sigma of the "
                         f"baseline, sigma = {baseline.sigma:.3g} N)")
    peak = float(corrected.max())
    # the noise exit: after it the force stays above the noise and above RISE_FRACTION of its largest value
    crossing = int(np.nonzero(corrected <= max(level, RISE_FRACTION * peak))[0][-1])
    upper = float(displacement[min(crossing + 1, len(displacement) - 1)])
    above = np.nonzero(corrected >= 0.3 * peak)[0]
    end = max(int(above[0]) if len(above) else len(displacement) - 1, crossing + 10)
    end = min(end, len(displacement) - 1)
    contact, exponent = _change_point(displacement[:end + 1], corrected[:end + 1], float(displacement[0]), upper,
                                      tilt)
    contact = min(contact, upper)
    spacing = float(np.median(np.diff(displacement))) if len(displacement) > 1 else 0.0
    lower = max(float(displacement[0]), contact - max(upper - contact, 5 * spacing))
    return ContactEstimate(contact, lower, upper, baseline, level, exponent)


def estimate_contact_point(displacement: np.ndarray, force: np.ndarray, fraction: float = 0.2,
                           threshold: float = 5.0, name: str = "curve", tilt: bool = False) -> tuple[float, Baseline]:
    """First guess of the contact point (the change point of :func:`estimate_contact`) and the baseline."""
    estimate = estimate_contact(displacement, force, fraction, threshold, name, tilt)
    return estimate.contact, estimate.baseline


# ---------------------------------------------------------------- least squares


def _model_function(model: str, curve, settings: FitSettings):
    """(f, limit) of ``F = E R^2 f(u)``, ``u = (displacement - c)/(2R)`` fitted up to ``u <= limit``.

    Plates: ``f`` the master curve (``curve``) or Hertz's two contacts, ``u = delta``. Sphere indenter (``u`` =
    depth/(2R)): ``f(u) = s(2u)`` with ``s`` the master surface (``curve``, an :class:`IndentationSurface`) at
    R_b/R, or Hertz's sphere on a half-space, ``F = 4/3 E/(1 - nu^2) sqrt(R_b) d^(3/2)``."""
    nu = settings.poisson_ratio
    if settings.geometry == "parallel-plates":
        if model == "master":
            return curve, settings.delta_max
        return (lambda delta: hertz_force(np.maximum(delta, 0.0), nu)), settings.delta_max
    ratio = settings.indenter_ratio
    shape = "cone-layer" if settings.geometry in CONES else settings.cell_shape
    tabulated = curve.depth_max(ratio) if curve is not None else float(depth_limit(ratio, shape, settings.cap_ratio))
    # the same window for the surface and its closed form; a --depth-max beyond the surface fits its range only
    depth_max = tabulated if settings.depth_max is None else min(settings.depth_max, tabulated)
    if model == "master":
        s = curve.curve(ratio)
        return (lambda u: s(2 * np.asarray(u, float))), depth_max / 2
    if settings.geometry in CONES:
        angle = math.atan(ratio)
        return (lambda u: sneddon_cone_force(np.maximum(2 * np.asarray(u, float), 0.0), angle, nu)), depth_max / 2
    return (lambda u: hertz_sphere_force(2 * np.asarray(u, float), nu, ratio)), depth_max / 2


def load_model(settings: FitSettings):
    """The master curve (plates) or the master surface (sphere indenter) of ``settings``; None for Hertz alone."""
    if settings.model == "hertz":
        return None
    if settings.geometry in INDENTERS:
        shape = "cone-layer" if settings.geometry in CONES else settings.cell_shape
        surface = load_indentation_surface(settings.poisson_ratio, settings.material, shape, settings.cap_ratio)
        try:  # a ratio outside the surface: refused before any file is read
            surface.depth_max(settings.indenter_ratio)
        except ParameterError as error:
            if settings.geometry != "pyramid":
                raise
            raise ParameterError("half_angle", f"a pyramid of face half-angle {settings.half_angle:.4g} deg is "
                                               f"fitted as its equivalent cone, and "
                                               f"{str(error).split(': ', 1)[1]}") from None
        return surface
    return load_master_curve(settings.poisson_ratio, settings.material)


def _lag_correlation(values: np.ndarray, lag: int) -> float:
    if len(values) <= lag + 2:
        return float("nan")
    centred = values - values.mean()
    denominator = float(np.sum(centred**2))
    return float(np.sum(centred[:-lag] * centred[lag:]) / denominator) if denominator > 0 else float("nan")


def residual_structure(contact_residuals: np.ndarray, baseline_residuals: np.ndarray, force_scale: float) -> dict:
    """Structure in the residuals of the points in contact, judged against the baseline noise's own colour.

    ``residual_lag1``/``residual_lag1_baseline``: lag-1 autocorrelations. ``residual_decorrelation``: the
    baseline noise's correlation length (the first lag, up to 50, where its autocorrelation falls below 0.2).
    ``residual_runs_z``: the Wald-Wolfowitz runs test on the signs of the in-contact residuals taken one per
    correlation length (negative: fewer runs than chance, a systematic misfit). ``residual_systematic``: the rms
    of the in-contact residuals smoothed over a twentieth of the contact region (at least a correlation length),
    over ``force_scale`` (the largest fitted force)."""
    contact_residuals = np.asarray(contact_residuals, float)
    baseline_residuals = np.asarray(baseline_residuals, float)
    step = 1
    if len(baseline_residuals) >= 20:
        for lag in range(1, min(50, len(baseline_residuals) // 4) + 1):
            step = lag
            if not _lag_correlation(baseline_residuals, lag) >= 0.2:
                break
    signs = np.sign(contact_residuals[::step])
    signs = signs[signs != 0]
    n_plus, n_minus = int(np.sum(signs > 0)), int(np.sum(signs < 0))
    n = n_plus + n_minus
    z = float("nan")
    if n_plus and n_minus and n > 2:
        runs = 1 + int(np.sum(signs[1:] != signs[:-1]))
        mean = 2.0 * n_plus * n_minus / n + 1
        variance = 2.0 * n_plus * n_minus * (2.0 * n_plus * n_minus - n) / (n**2 * (n - 1))
        z = (runs - mean) / math.sqrt(variance) if variance > 0 else float("nan")
    elif n > 2:
        z = -math.inf  # every residual on one side
    window = max(step, len(contact_residuals) // 20, 1)
    smooth = np.convolve(contact_residuals, np.ones(window) / window, mode="valid") if len(contact_residuals) else \
        np.zeros(1)
    return {"residual_lag1": _lag_correlation(contact_residuals, 1),
            "residual_lag1_baseline": _lag_correlation(baseline_residuals, 1),
            "residual_decorrelation": step, "residual_runs_z": z,
            "residual_systematic": float(np.sqrt(np.mean(smooth**2))) / force_scale if force_scale > 0 else
            float("nan")}


def fit_model(displacement: np.ndarray, force: np.ndarray, radius: float, f, delta_max: float,
              contact_guess: float, fit_contact: bool = True, sigma: float = float("nan"), bootstrap: int = 0,
              seed: int = 0, contact_bounds: tuple[float, float] | None = None) -> dict:
    """Least-squares fit of ``force = b + E R^2 f((displacement - c)/(2R))``: E, the force offset b (residual
    baseline, informed by the points before contact) and, if ``fit_contact``, the contact point c, within
    ``contact_bounds`` when given (the rise region).

    Every point with ``(displacement - c)/(2R) <= delta_max`` is used (before contact f = 0). Raises CurveError
    when fewer than 3 points are in contact or none carries a force above the baseline.
    """
    from scipy import stats
    from scipy.optimize import least_squares

    index_contact = 1 if fit_contact else None
    index_offset = 2 if fit_contact else 1
    low, high = contact_bounds if fit_contact and contact_bounds is not None else (-math.inf, math.inf)
    if high <= low:  # a region of one point: a sliver, so that the solver has an interval
        low, high = low - 1e-9 * radius, high + 1e-9 * radius

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

        lower = [MODULUS_FLOOR] + [-np.inf] * (len(start) - 1)
        upper = [np.inf] * len(start)
        if fit_contact:
            lower[1], upper[1] = (low - contact0) / radius, (high - contact0) / radius
        start = np.clip(start, lower, upper)
        return least_squares(residual, start, jac="3-point", bounds=(lower, upper),
                             xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=400)

    contact, previous = float(np.clip(contact_guess, low, high)), None
    for _ in range(6):  # select the points with the current contact and fit, until the selection settles
        mask = (displacement - contact) / (2 * radius) <= delta_max + 1e-12
        if previous is not None and np.array_equal(mask, previous):
            break
        previous = mask
        d, y = displacement[mask], force[mask]
        touching = d > contact
        if touching.sum() < 3:
            raise CurveError("fewer than 3 points in contact below delta_max")
        peak = float(y[touching].max())
        if not peak > 0:
            raise CurveError("no force above the baseline in contact below delta_max")
        contact0 = contact
        force_scale = max(float(np.abs(y).max()), 1e-300)
        delta_last = (d[-1] - contact0) / (2 * radius)
        modulus_scale = peak / (radius**2 * float(f(np.array([delta_last]))[0]))
        if not (math.isfinite(modulus_scale) and modulus_scale > 0):
            raise CurveError("the model carries no force over the points in contact")
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
    touching = d > contact
    structure = residual_structure(-residuals[touching], -residuals[~touching],
                                   float(np.max(np.abs(predicted[touching] - offset))))
    # correlated noise carries less information than its number of points: the AR(1) effective sample size
    # n (1 - rho)/(1 + rho), rho the lag-1 autocorrelation of the baseline's residuals, widens the interval
    rho = structure["residual_lag1_baseline"]
    rho = min(max(rho, 0.0), 0.999) if math.isfinite(rho) and (~touching).sum() >= 20 else 0.0
    inflation = math.sqrt((1.0 + rho) / (1.0 - rho))
    modulus_std, contact_std = modulus_std * inflation, contact_std * inflation
    out = {
        "youngs_modulus": modulus, "youngs_modulus_std": modulus_std,
        "youngs_modulus_ci_low": modulus - t * modulus_std, "youngs_modulus_ci_high": modulus + t * modulus_std,
        "contact_point": contact, "contact_point_std": contact_std, "force_offset": offset,
        "delta_max": float((d.max() - contact) / (2 * radius)), "n_points": n,
        "n_points_in_contact": int(touching.sum()),
        "chi_square": ssr / sigma**2 if sigma > 0 else float("nan"),
        "reduced_chi_square": ssr / sigma**2 / dof if sigma > 0 else float("nan"),
        "rms_residual": math.sqrt(ssr / n), "converged": bool(result.success),
        "modulus_at_floor": bool(result.x[0] <= 1.001 * MODULUS_FLOOR),
        "contact_bounds": (low, high) if fit_contact else None,
        "fitted_points": (d, y - offset, predicted - offset),
    }
    out.update(structure, noise_correlation_inflation=inflation)
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


MODULUS_FLOOR = 1e-8
"""The solver's lower bound on E over its scale (the modulus that puts the largest force on the last point):
an E there is no measurement and is flagged and written as NaN."""


def check_fit(fit: dict, region: tuple[float, float] | None = None) -> list[str]:
    """The reasons (empty: accepted) why ``fit`` (a :func:`fit_model` result) cannot be trusted; see the module
    docstring. ``region``: the rise region the contact point must lie in (default: the fit's bounds). Values that
    are no result are set to NaN in ``fit``."""
    reasons = []
    nan = float("nan")
    modulus = fit["youngs_modulus"]
    low, high = fit["youngs_modulus_ci_low"], fit["youngs_modulus_ci_high"]
    if not (math.isfinite(modulus) and modulus > 0) or fit.get("modulus_at_floor"):
        reasons.append("E is no measurement (at the solver's floor, zero or not finite)")
        fit["youngs_modulus"] = modulus = nan
        fit["youngs_modulus_ci_low"] = fit["youngs_modulus_ci_high"] = low = high = nan
    else:
        if not (math.isfinite(low) and math.isfinite(high)):
            reasons.append("no finite confidence interval")
        elif low <= 0:
            reasons.append(f"interval reaches below zero ({low:.3g} Pa)")
            fit["youngs_modulus_ci_low"] = low = nan
        if math.isfinite(low) and math.isfinite(high) and high - low > modulus:
            reasons.append(f"interval wider than E ({low:.3g} to {high:.3g} Pa for {modulus:.3g} Pa)")
        elif not math.isfinite(low) and math.isfinite(high) and high > 2 * modulus:
            reasons.append(f"interval wider than E (up to {high:.3g} Pa for {modulus:.3g} Pa)")
        if modulus > PLAUSIBLE_MODULUS_MAX:
            reasons.append(f"E = {modulus:.3g} Pa is above {PLAUSIBLE_MODULUS_MAX:.0e} Pa: not a cell, gel or tissue: "
                           "check the units and the calibration")
    for key in ("youngs_modulus_bootstrap_ci_low", "youngs_modulus_bootstrap_ci_high"):
        if key in fit and not (fit[key] > 0 and math.isfinite(modulus)):
            fit[key] = nan  # a bound at or below zero (or of no E) is no result either
    region = region or fit.get("contact_bounds")
    if region is not None and all(map(math.isfinite, region)):
        lower, upper = region
        contact = fit["contact_point"]
        tolerance = 1e-3 * max(upper - lower, 0.0) + 1e-15
        if not lower - tolerance <= contact <= upper + tolerance:
            reasons.append(f"contact point {contact * 1e6:.4g} um outside the region where the force leaves the "
                           f"baseline noise ({lower * 1e6:.4g} to {upper * 1e6:.4g} um)")
        elif fit.get("contact_bounds") is not None and (contact <= lower + tolerance or contact >= upper - tolerance):
            side = "before the rise" if contact <= lower + tolerance else "after the force left the noise"
            reasons.append(f"contact point on the edge of the rise region ({side}): the model does not follow the "
                           "curve's onset")
    if fit["n_points_in_contact"] < MIN_POINTS_IN_CONTACT:
        reasons.append(f"{fit['n_points_in_contact']} points in contact (fewer than {MIN_POINTS_IN_CONTACT})")
    z, systematic = fit.get("residual_runs_z", nan), fit.get("residual_systematic", nan)
    if z < RUNS_Z_LIMIT and systematic > SYSTEMATIC_LIMIT:
        reasons.append(f"structured residuals (runs test z = {z:.3g}, systematic misfit {100 * systematic:.3g} % "
                       "of the force): the model does not describe the curve")
    if not fit.get("converged", True):
        reasons.append("the least-squares fit did not converge")
    return reasons


def adhesion_dip(displacement: np.ndarray, corrected: np.ndarray, fit: dict, baseline: Baseline) -> dict:
    """The deepest dip of the baseline-corrected force below the baseline around contact: an adhesive or
    attractive tip (a snap-in before contact, a pull-off force in contact) or a baseline drifting down into
    contact, which a model without adhesion does not describe (it biases E high and moves the contact point).

    The minimum of the :data:`ADHESION_DIP_POINTS`-point running median of ``corrected`` (N; a median, so that one
    or two glitch points are no dip), from the end of the quiet part of the baseline window (the baseline window's
    points before the rise region, or before ``fit``'s contact point without one) to the onset (the first point
    past the contact point above a tenth of the largest fitted force): ``adhesion_dip`` its depth below the
    baseline (N, > 0 below it), ``adhesion_dip_sigmas`` that depth over the standard deviation of the same running
    median over the quiet part (1.4826 MAD: correlated noise is counted as it is), ``adhesion_dip_fraction`` over
    the largest fitted force. All NaN when the quiet part has fewer than 2 :data:`ADHESION_DIP_POINTS` points or
    fewer than :data:`ADHESION_DIP_POINTS` points lie between it and the onset."""
    nan = float("nan")
    k = ADHESION_DIP_POINTS
    fitted = fit["fitted_points"][2]
    force_max = float(np.max(fitted)) if len(fitted) else nan
    bounds = fit.get("contact_bounds")
    rise = bounds[0] if bounds is not None and math.isfinite(bounds[0]) else fit["contact_point"]
    quiet_end = min(baseline.n_points, int(np.searchsorted(displacement, rise)))
    onset = np.nonzero((displacement > fit["contact_point"]) & (corrected > 0.1 * force_max))[0]
    window = corrected[quiet_end:int(onset[0]) if len(onset) else len(corrected)]
    quiet = corrected[:quiet_end]
    if len(window) < k or len(quiet) < 2 * k or not force_max > 0:
        return {"adhesion_dip": nan, "adhesion_dip_sigmas": nan, "adhesion_dip_fraction": nan}
    windows = np.lib.stride_tricks.sliding_window_view
    depth = -float(np.median(windows(window, k), axis=1).min())
    medians = np.median(windows(quiet, k), axis=1)
    spread = 1.4826 * float(np.median(np.abs(medians - np.median(medians))))
    # no less than white noise's (the MAD of a short baseline's overlapping medians can come out low)
    spread = max(spread, MEDIAN_OF_FIVE_SPREAD * baseline.sigma if k == 5 else baseline.sigma / math.sqrt(k))
    if spread > 0:
        sigmas = depth / spread
    else:  # a noise-free baseline: any dip is beyond its noise, none is none
        sigmas = math.inf if depth > 0 else 0.0
    return {"adhesion_dip": depth, "adhesion_dip_sigmas": sigmas, "adhesion_dip_fraction": depth / force_max}


def adhesion_reasons(dip: dict) -> list[str]:
    """The flag of an :func:`adhesion_dip` deeper than :data:`ADHESION_DIP_SIGMAS` of the baseline's noise and
    than :data:`ADHESION_DIP_LIMIT` of the largest fitted force (empty: none)."""
    if not (dip["adhesion_dip_sigmas"] > ADHESION_DIP_SIGMAS and dip["adhesion_dip_fraction"] > ADHESION_DIP_LIMIT):
        return []
    return [f"adhesion: the force dips {dip['adhesion_dip'] * 1e9:.3g} nN below the baseline around contact "
            f"({100 * dip['adhesion_dip_fraction']:.2g} % of the largest fitted force, "
            f"{dip['adhesion_dip_sigmas']:.3g} sigma): snap-in, adhesive tip or drifting baseline, E biased high"]


def _geometry_columns(settings: FitSettings) -> dict:
    """The fits.csv columns that record the geometry (lengths in m; NaN where not given)."""
    nan = float("nan")
    return {"radius": nan if settings.radius is None else settings.radius, "poisson_ratio": settings.poisson_ratio,
            "geometry": settings.geometry,
            "indenter_radius": nan if settings.indenter_radius is None else settings.indenter_radius,
            "cell_shape": settings.cell_shape if settings.geometry in INDENTERS else "",
            "cap_height": nan if settings.cap_height is None else settings.cap_height,
            "layer_thickness": nan if settings.layer_thickness is None else settings.layer_thickness,
            **({"half_angle": settings.half_angle} if settings.geometry in CONES else {}),
            **({"cone_half_angle": settings.cone_half_angle} if settings.geometry == "pyramid" else {})}


def fit_curve(name: str, displacement, force, settings: FitSettings,
              curve: MasterCurve | IndentationSurface | None = None, nucleated: NucleatedCurve | None = None) -> dict:
    """Fit one curve; returns a dict (fits.csv row plus ``_plot`` data), ``flag`` empty when every check of
    :func:`check_fit` passed. Raises CurveError when nothing can be fitted (too few points, no contact).

    With the nucleus options (and a master curve or surface in ``settings.model``) E_c is also fitted to the
    nucleated cell's own curve (``nucleated``; None: :func:`load_nucleated_curve`), :func:`nucleated_columns`."""
    displacement, force = _clean(name, np.asarray(displacement, float), np.asarray(force, float))
    start = time.perf_counter()
    fit_contact = settings.contact_point is None
    if not fit_contact and not displacement[0] <= settings.contact_point < displacement[-1]:
        raise CurveError(f"{name}: --contact-point {settings.contact_point * 1e6:.6g} um is outside the curve's "
                         f"displacement range ({displacement[0] * 1e6:.6g} to {displacement[-1] * 1e6:.6g} um): "
                         "no point before or after it to fit")
    try:
        estimate = estimate_contact(displacement, force, settings.baseline_fraction, settings.threshold, name,
                                    settings.baseline_tilt)
    except CurveError:
        if fit_contact:
            raise
        estimate = None
    baseline = estimate.baseline if estimate is not None else fit_baseline(
        displacement, force, settings.baseline_fraction, settings.baseline_tilt)
    corrected = force - baseline(displacement)
    contact0 = estimate.contact if fit_contact else settings.contact_point
    region = (estimate.lower, estimate.upper) if estimate is not None else None
    if curve is None:
        curve = load_model(settings)
    row = {"file": name, "flag": "", **_geometry_columns(settings)}
    fits, flags = {}, {}
    for model in ("master", "hertz"):
        if settings.model not in (model, "both"):
            continue
        f, limit = _model_function(model, curve, settings)
        try:
            fits[model] = fit_model(displacement, corrected, settings.length_unit, f, limit, contact0, fit_contact,
                                    baseline.sigma, settings.bootstrap, settings.seed,
                                    contact_bounds=region if fit_contact else None)
        except CurveError as error:
            raise CurveError(f"{name}: {error}") from None
        flags[model] = check_fit(fits[model], region)
    primary = "master" if "master" in fits else "hertz"
    dip = adhesion_dip(displacement, corrected, fits[primary], baseline)
    for reasons in flags.values():
        reasons.extend(adhesion_reasons(dip))
    for key in ("youngs_modulus", "youngs_modulus_ci_low", "youngs_modulus_ci_high", "contact_point",
                "delta_max", "youngs_modulus_std", "contact_point_std", "chi_square", "reduced_chi_square",
                "rms_residual", "n_points", "n_points_in_contact", "converged", "youngs_modulus_bootstrap_ci_low",
                "youngs_modulus_bootstrap_ci_high", "residual_runs_z", "residual_systematic", "residual_lag1",
                "residual_lag1_baseline", "residual_decorrelation", "noise_correlation_inflation"):
        if key in fits[primary]:
            row[key] = fits[primary][key]
    row["flag"] = "; ".join(flags[primary])
    row["model"] = primary
    hertz = fits.get("hertz")
    nan = float("nan")
    row["youngs_modulus_hertz"] = hertz["youngs_modulus"] if hertz else nan
    row["youngs_modulus_hertz_ci_low"] = hertz["youngs_modulus_ci_low"] if hertz else nan
    row["youngs_modulus_hertz_ci_high"] = hertz["youngs_modulus_ci_high"] if hertz else nan
    row["contact_point_hertz"] = hertz["contact_point"] if hertz else nan
    row["chi_square_hertz"] = hertz["chi_square"] if hertz else nan
    row["flag_hertz"] = "; ".join(flags["hertz"]) if hertz else ""
    row["contact_point_initial_guess"] = contact0
    row["contact_region_low"] = region[0] if region else nan
    row["contact_region_high"] = region[1] if region else nan
    row["baseline_sigma"] = baseline.sigma
    row.update(dip)
    if settings.geometry in INDENTERS:  # the x-axis is the indenter's depth: u = depth/(2R)
        row["depth_max"] = row.pop("delta_max") * 2 * settings.length_unit
        row["delta_max"] = float("nan")
        if "master" in fits and curve is not None:
            row["master_curve_relative_error"] = float(curve.relative_error_at(
                fits["master"]["delta_max"] * 2, settings.indenter_ratio))
    elif "master" in fits and curve is not None:
        row["master_curve_relative_error"] = float(curve.relative_error_at(fits["master"]["delta_max"]))
    if settings.nucleus_size_ratio is not None:
        row.update(heterogeneous_moduli(row, settings.nucleus_size_ratio, settings.stiffness_ratio,
                                        settings.poisson_ratio, settings.nucleus_volume_fraction))
        if nucleated is None and settings.model != "hertz":
            nucleated = load_nucleated_curve(settings)
        if nucleated is not None:
            f, limit = _nucleated_function(nucleated, settings)
            scale = settings.length_unit * (2 if settings.geometry == "parallel-plates" else 1)

            def data_load(contact):  # the data's deepest load past ``contact``: delta or depth/R
                return float((displacement.max() - contact) / scale)

            try:
                fit = fit_model(displacement, corrected, settings.length_unit, f, limit, contact0, fit_contact,
                                baseline.sigma, contact_bounds=region if fit_contact else None)
            except CurveError as error:  # the homogeneous fit stands; the nucleated one says why it has no result
                row.update(nucleated_columns(None, [str(error)] + nucleated_reasons(
                    None, nucleated, settings, data_load(contact0)), row, settings, nucleated))
            else:
                fits["nucleated"] = fit
                row.update(nucleated_columns(fit, check_fit(fit, region) + adhesion_reasons(dip) + nucleated_reasons(
                    fit, nucleated, settings, data_load(fit["contact_point"])), row, settings, nucleated))
    row["fit_time_s"] = time.perf_counter() - start
    row["_plot"] = {"displacement": displacement, "force": corrected, "fits": fits, "radius": settings.length_unit,
                    "region": region}
    return row


def hertz_sphere_force(indentation, poisson_ratio: float = 0.48, bead_radius: float = 1.0):
    """Hertz's force per unit E of a rigid sphere of radius R_b indenting a half-space by d:
    ``F/E = 4/3 sqrt(R_b) d^(3/2) / (1 - nu^2)`` (nanite's ``hertz_para``; Sneddon's exact sphere differs by
    -d/(10 R_b) at first order)."""
    d = np.maximum(np.asarray(indentation, float), 0.0)
    return 4.0 / (3.0 * (1.0 - poisson_ratio**2)) * math.sqrt(bead_radius) * d**1.5


def fit_hertz_sphere(displacement, force, bead_radius: float, poisson_ratio: float = 0.48,
                     contact_point: float | None = None, indentation_max: float | None = None,
                     baseline_fraction: float = 0.2, threshold: float = 5.0, name: str = "curve") -> dict:
    """The sphere-indenter geometry's Hertz estimate: E of ``F = b + E hertz_sphere_force(x - c)`` fitted by
    least squares (E, the offset b and, unless ``contact_point`` is given, c within the rise region) over the
    points up to ``indentation_max`` past contact (default: all). Same baseline, contact estimate, interval and
    checks as :func:`fit_curve`; returns the fit's dict with ``flag``."""
    displacement, force = _clean(name, np.asarray(displacement, float), np.asarray(force, float))
    fit_contact = contact_point is None
    try:
        estimate = estimate_contact(displacement, force, baseline_fraction, threshold, name)
    except CurveError:
        if fit_contact:
            raise
        estimate = None
    baseline = estimate.baseline if estimate else fit_baseline(displacement, force, baseline_fraction)
    region = (estimate.lower, estimate.upper) if estimate else None
    # F = E R_b^2 f(u) with u = d / (2 R_b): f(u) = 4/(3(1-nu^2)) (2u)^(3/2)
    factor = 4.0 / (3.0 * (1.0 - poisson_ratio**2)) * 2.0**1.5

    def f(u):
        return factor * np.maximum(u, 0.0) ** 1.5

    span = indentation_max if indentation_max is not None else float(displacement[-1] - displacement[0])
    fit = fit_model(displacement, force - baseline(displacement), bead_radius, f, span / (2 * bead_radius),
                    estimate.contact if fit_contact else contact_point, fit_contact, baseline.sigma,
                    contact_bounds=region if fit_contact else None)
    dip = adhesion_dip(displacement, force - baseline(displacement), fit, baseline)
    fit["flag"] = "; ".join(check_fit(fit, region) + adhesion_reasons(dip))
    fit["baseline_sigma"] = baseline.sigma
    fit.update(dip)
    fit["indentation_max"] = fit.pop("delta_max") * 2 * bead_radius
    return fit


def heterogeneous_moduli(row: dict, size_ratio: float, stiffness_ratio: float, poisson_ratio: float = 0.48,
                         phi: float | None = None) -> dict:
    """E_c = E_eff / (1 + (G - 1) phi) and E_n = G E_c (the paper's volume average; phi the nucleus's volume
    fraction, L^3 in a sphere, :func:`elastocell.inverse.nucleated_curve.volume_fraction`), and E_c with the
    Hashin-Shtrikman upper bound E_eff/E_c (``*_hashin_shtrikman_upper``). Both are conversions of the homogeneous
    fit; the nucleated cell's own curve fits E_c without one (:func:`nucleated_columns`)."""

    phi = size_ratio**3 if phi is None else phi
    factor = 1.0 + (stiffness_ratio - 1.0) * phi
    factor_hs = hashin_shtrikman_upper([1.0, stiffness_ratio], [1.0 - phi, phi], poisson_ratio)
    out = {"effective_stiffness_ratio": factor, "effective_stiffness_ratio_hashin_shtrikman_upper": factor_hs,
           "nucleus_size_ratio": size_ratio, "stiffness_ratio": stiffness_ratio}
    for suffix in ("", "_ci_low", "_ci_high"):
        value = row.get(f"youngs_modulus{suffix}", float("nan"))
        out[f"youngs_modulus_cytoplasm{suffix}"] = value / factor
        out[f"youngs_modulus_nucleus{suffix}"] = stiffness_ratio * value / factor
        out[f"youngs_modulus_cytoplasm_hashin_shtrikman_upper{suffix}"] = value / factor_hs
    return out


@functools.lru_cache(maxsize=8)
def load_nucleated_curve(settings: FitSettings) -> NucleatedCurve | None:
    """The nucleated cell's own curve of ``settings`` (:func:`elastocell.inverse.nucleated_curve.nucleated_curve`:
    cached on disk, computed by the axisymmetric solver in seconds the first time); None without the nucleus
    options or with ``model="hertz"``."""
    if settings.nucleus_size_ratio is None or settings.model == "hertz":
        return None
    bead = settings.geometry == "sphere-indenter"
    try:
        return nucleated_curve(settings.geometry, settings.nucleus_size_ratio, settings.stiffness_ratio,
                               settings.poisson_ratio, settings.material, settings.cell_shape if bead else "sphere",
                               settings.indenter_ratio if bead else None, settings.cap_ratio)
    except AxisymmetricInterrupted as interruption:  # Ctrl-C or SIGTERM: nothing was cached or written
        raise KeyboardInterrupt(str(interruption)) from None


def _nucleated_window(nucleated: NucleatedCurve, settings: FitSettings) -> float:
    """The load the nucleated fit asks for, in the curve's unit: the plates' ``delta_max``, a bead's ``depth_max``
    (default the master surface's range, the curve's own)."""
    if settings.geometry == "parallel-plates":
        return settings.delta_max
    return nucleated.load_requested if settings.depth_max is None else min(settings.depth_max,
                                                                          nucleated.load_requested)


def _nucleated_function(nucleated: NucleatedCurve, settings: FitSettings):
    """(f, limit) of the nucleated cell's curve in :func:`_model_function`'s variable and window
    (:func:`_nucleated_window`, within the rows the curve reached)."""
    limit = min(_nucleated_window(nucleated, settings), nucleated.load_reached)
    if settings.geometry == "parallel-plates":
        return nucleated, limit
    return (lambda u: nucleated(2 * np.asarray(u, float))), limit / 2


def nucleated_reasons(fit: dict | None, nucleated: NucleatedCurve, settings: FitSettings,
                      data_load: float) -> list[str]:
    """What the nucleated cell's curve itself makes of its fit (``fit`` None: there was none): a window cut short
    where the curve stopped before the requested load while the data (``data_load``, their deepest load past the
    contact point, delta or depth/R) go further, and a window past the load where the cell's volume collapses (J <
    :data:`COLLAPSE_VOLUME_RATIO`: the compressible law's regime, README)."""
    reasons = []
    plates = settings.geometry == "parallel-plates"
    if nucleated.load_reached < min(_nucleated_window(nucleated, settings), data_load) - 1e-9:
        reasons.append(f"the nucleated cell's curve stops at {'delta' if plates else 'depth/R'} "
                       f"{nucleated.load_reached:.3g} ({nucleated.metadata.get('stopped', '')}): fitted up to there "
                       "at most")
    if fit is None:
        return reasons
    reached = fit["delta_max"] * (1 if plates else 2)  # the deepest point fitted, in the curve's load
    collapse = nucleated.collapse_load()
    if reached > collapse:
        reasons.append(f"the nucleated cell loses more than half its volume in places (J < "
                       f"{COLLAPSE_VOLUME_RATIO:g}) past {'delta' if plates else 'depth/R'} {collapse:.3g}: the "
                       f"compressible law's regime, not a water-filled cytoplasm (fit a smaller --"
                       f"{'delta' if plates else 'depth'}-max)")
    return reasons


def nucleated_columns(fit: dict | None, reasons: list[str], row: dict, settings: FitSettings,
                      nucleated: NucleatedCurve) -> dict:
    """The fits.csv columns of E_c fitted to the nucleated cell's own curve: ``youngs_modulus_cytoplasm_nucleated``
    (with ``_ci_low``, ``_ci_high``; NaN where :func:`check_fit` found no result), E_n = gamma E_c
    (``youngs_modulus_nucleus_nucleated``), its contact point, reduced chi-square and ``flag_nucleated`` (its
    reasons; empty: accepted), and ``effective_stiffness_ratio_fitted`` = E/E_c: the homogeneous equivalent's
    modulus (``youngs_modulus``) over the cytoplasm's, the conversion this measurement needs, beside the volume
    average's ``effective_stiffness_ratio``; ``nucleated_load_reached``: how far the nucleated curve was computed
    (delta, or depth/R)."""
    gamma = settings.stiffness_ratio
    nan = float("nan")
    fit = fit or {}
    out = {}
    for suffix in ("", "_ci_low", "_ci_high"):
        value = fit.get(f"youngs_modulus{suffix}", nan)
        out[f"youngs_modulus_cytoplasm_nucleated{suffix}"] = value
        out[f"youngs_modulus_nucleus_nucleated{suffix}"] = gamma * value
    out["contact_point_nucleated"] = fit.get("contact_point", nan)
    out["reduced_chi_square_nucleated"] = fit.get("reduced_chi_square", nan)
    out["flag_nucleated"] = "; ".join(reasons)
    out["effective_stiffness_ratio_fitted"] = row.get("youngs_modulus", nan) / out["youngs_modulus_cytoplasm_nucleated"]
    out["nucleated_load_reached"] = nucleated.load_reached
    return out


# ---------------------------------------------------------------- plots and files

WARNING_COLOR = "#d62728"


def plot_fit(path: Path, row: dict) -> None:
    """The curve, its fits and residuals; a flagged curve in :data:`WARNING_COLOR` with its reasons."""
    data = row["_plot"]
    radius = data["radius"]
    flagged = bool(row.get("flag"))
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(6.4, 6), sharex=True, height_ratios=[3, 1],
                                         constrained_layout=True)
    micro = 1e6
    top.plot(data["displacement"] * micro, data["force"] * 1e9, ".", ms=2,
             color="#f4a582" if flagged else "0.5", label="data (baseline removed)")
    styles = {"master": ("C0", "master surface" if row.get("geometry") in INDENTERS else "master curve"),
              "hertz": ("C2", "Sneddon" if row.get("geometry") in CONES else "Hertz"),
              "nucleated": ("C1", "nucleated cell (E_c)")}
    for model, fit in data["fits"].items():
        d, y, predicted = fit["fitted_points"]
        color, label = styles[model]
        top.plot(d * micro, predicted * 1e9, "-", color=WARNING_COLOR if flagged and model == row.get("model")
                 else color, label=f"{label}: E = {fit['youngs_modulus']:.4g} Pa "
                                   f"[{fit['youngs_modulus_ci_low']:.4g}, {fit['youngs_modulus_ci_high']:.4g}]")
        top.axvline(fit["contact_point"] * micro, color=color, lw=0.8, ls=":")
        bottom.plot(d * micro, (y - predicted) * 1e9, ".", ms=2, color=color, label=label)
    region = data.get("region")
    if region is not None:
        top.axvspan(region[0] * micro, region[1] * micro, color="0.85", alpha=0.5, lw=0, label="rise region")
        # show the contact and what follows it, with as much baseline before it
        x = data["displacement"]
        start = min([region[0]] + [fit["contact_point"] for fit in data["fits"].values()])
        left = max(float(x[0]), start - max(float(x[-1]) - start, region[1] - region[0]))
        top.set_xlim(left * micro, float(x[-1]) * micro + 0.02 * (float(x[-1]) - left) * micro)
        visible = x >= left
        if visible.any():
            low, high = float(data["force"][visible].min()), float(data["force"][visible].max())
            top.set_ylim((low - 0.05 * (high - low)) * 1e9, (high + 0.05 * (high - low)) * 1e9)
    top.set_ylabel("force (nN)")
    title = f"{row['file']}: R = {radius * micro:.3g} um, delta up to {row.get('delta_max', float('nan')):.3f}"
    if row.get("geometry") == "sphere-indenter":
        size = f"h = {radius * micro:.3g} um" if row.get("cell_shape") == "layer" else f"R = {radius * micro:.3g} um"
        title = (f"{row['file']}: {size}, bead R_b = {row['indenter_radius'] * micro:.3g} um, "
                 f"depth up to {row.get('depth_max', float('nan')) * micro:.3g} um")
    if row.get("geometry") in CONES:
        tip = f"cone {row.get('half_angle', float('nan')):.3g} deg"
        if row.get("geometry") == "pyramid":
            tip = (f"pyramid {row.get('half_angle', float('nan')):.3g} deg (cone "
                   f"{row.get('cone_half_angle', float('nan')):.3g})")
        title = (f"{row['file']}: h = {radius * micro:.3g} um, {tip}, "
                 f"depth up to {row.get('depth_max', float('nan')) * micro:.3g} um")
    if flagged:
        title = f"{row['file']}: FLAGGED\n" + "\n".join(_wrap(row["flag"], 90))
    top.set_title(title, fontsize=8 if flagged else None, color=WARNING_COLOR if flagged else "black")
    if flagged:
        for spine in top.spines.values():
            spine.set_edgecolor(WARNING_COLOR)
            spine.set_linewidth(1.5)
    top.legend(fontsize=8)
    bottom.axhline(0, color="k", lw=0.6)
    bottom.set_xlabel("displacement (um)")
    bottom.set_ylabel("residual (nN)")
    for axis in (top, bottom):
        axis.grid(alpha=0.3)
    save_figure(figure, path, dpi=110)
    plt.close(figure)


def _wrap(text: str, width: int) -> list[str]:
    import textwrap

    lines = textwrap.wrap(text, width)
    return lines if len(lines) <= 4 else [*lines[:3], lines[3][:width - 4] + " ..."]


CONTRACT_COLUMNS = ["file", "youngs_modulus", "youngs_modulus_ci_low", "youngs_modulus_ci_high", "contact_point",
                    "delta_max", "youngs_modulus_hertz", "flag"]


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


def _flagged_row(name: str, message: str, curve: Curve | None, settings: FitSettings) -> dict:
    """The fits.csv row of a curve that could not be fitted: NaN values, the reason as its flag."""
    nan = float("nan")
    row = {"file": name, "youngs_modulus": nan, "youngs_modulus_ci_low": nan, "youngs_modulus_ci_high": nan,
           "contact_point": nan, "delta_max": nan, "youngs_modulus_hertz": nan, "flag": message,
           **_geometry_columns(settings)}
    if curve is not None:
        row["_plot"] = {"displacement": np.asarray(curve.displacement, float), "force": np.asarray(curve.force, float),
                        "fits": {}, "radius": settings.length_unit, "region": None}
    return row


def _fit_path(path: Path, settings: FitSettings, curve: MasterCurve | None, plot_directory: Path | None,
              nucleated: NucleatedCurve | None = None) -> list:
    """Fit every curve of one file: ``[(name, row, None), ...]`` in file order (a curve that cannot be fitted is a
    row with its reason as the flag, an unexpected exception while fitting it (a bug) one flagged "fit failed:
    <type>: <message> (an internal error: please report it)"; one failing curve does not stop the others);
    ``[(None, None, message)]`` when the file cannot be read. Plots go to ``plot_directory/<name>.png``."""
    out = []
    try:
        curves = read_curves(path, settings.spring_constant, settings.sensitivity, settings.sensitivity_unit)
    except CurveError as error:
        return [(None, None, str(error))]
    except Exception as error:  # not KeyboardInterrupt/SystemExit: the other files go on
        return [(None, None, f"{path}: reading failed: {type(error).__name__}: {error} (an internal error: please "
                             "report it)")]
    for index, item in enumerate(curves):
        if isinstance(item, CurveError):  # a curve of a map afmformats could not convert
            name = f"{path.stem}_{index:04d}" if len(curves) > 1 else path.stem
            row, info = _flagged_row(name, str(item), None, settings), {"source": str(path), "curve_index": index}
        else:
            name, info = item.name, item.info()
            try:
                row = fit_curve(name, item.displacement, item.force, settings, curve, nucleated)
            except CurveError as error:
                message = str(error)
                if message.startswith(f"{name}: "):
                    message = message[len(name) + 2:]
                row = _flagged_row(name, message, item, settings)
            except Exception as error:  # not KeyboardInterrupt/SystemExit: one curve does not lose the batch
                row = _flagged_row(name, f"fit failed: {type(error).__name__}: {error} (an internal error: please "
                                         "report it)", item, settings)
        row.update(info)
        if plot_directory is not None and "_plot" in row:
            plot_fit(plot_directory / f"{name}.png", row)
        out.append((name, row, None))
    return out


@functools.lru_cache(maxsize=8)
def _worker_model(settings: FitSettings):
    """The master curve or surface, read once per worker process (a task per file would otherwise re-read it)."""
    return load_model(settings)


def _fit_file_task(item) -> list:
    """One Dask task: the curves of one file (its plots in a private folder ``out/.plots-<index>``, renamed by
    the caller once names are made unique in input order); rows without their plot data (small results)."""
    index, path, settings, out, plots, nucleated = item  # the nucleated curve travels with the task (a few kB)
    curve = _worker_model(settings)
    plot_directory = None
    if plots:
        plot_directory = Path(out) / f".plots-{index:06d}"
        plot_directory.mkdir(parents=True, exist_ok=True)
    results = _fit_path(Path(path), settings, curve, plot_directory, nucleated)
    for _, row, _ in results:
        if row is not None:
            row.pop("_plot", None)
    return results


def fit_files(paths, settings: FitSettings, out: Path, plots: bool = True, progress: bool = False,
              scheduler: str | None = None, workers: int | None = None, dask: bool | None = None) -> dict:
    """Fit every curve of every file; write ``out/fits.csv``, ``out/<curve>.png``, ``out/fit_settings.json``.

    ``fits.csv`` has one row per curve (a file that cannot be read: one row with ``flag`` "unreadable" and its
    ``error``, in the file's place); ``flag`` is empty for an accepted curve. Returns ``{"rows": [...], "accepted": n,
    "errors": [(file, message), ...], "wall_time_s": ..., "execution": ...}``; ``rows`` holds every curve's row,
    flagged ones included.
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
    curve = load_model(settings)  # a surface or a ratio it lacks is refused before anything is written
    files = expand_paths(paths)
    if not files:
        raise ParameterError("file", "no input files")
    nucleated = load_nucleated_curve(settings)  # computed once (seconds), before any file is read
    out.mkdir(parents=True, exist_ok=True)
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

        items = [(i, str(path), settings, str(out), plots, nucleated) for i, path in enumerate(files)]
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
                per_file[index] = _fit_path(path, settings, curve, None, nucleated)  # plotted below, named uniquely
                if bar is not None:
                    bar.advance(task)
        finally:
            if bar is not None:
                bar.stop()
    rows, errors, used_names, table = [], [], set(), []
    for index, path in enumerate(files):
        for name, row, message in per_file[index]:
            unique, counter = name if name is not None else path.stem, 1
            base = unique
            while unique in used_names:
                unique = f"{base}_{counter}"
                counter += 1
            used_names.add(unique)
            if name is None:  # the file could not be read: its row in its place
                errors.append((str(path), message))
                table.append({"file": unique, "source": str(path), "flag": "unreadable", "error": message})
                continue
            row["file"] = unique
            if plots and use_dask:
                source = out / f".plots-{index:06d}" / f"{name}.png"
                if source.exists():
                    source.replace(out / f"{unique}.png")
            elif plots and "_plot" in row:
                plot_fit(out / f"{unique}.png", row)
            rows.append(row)
            table.append({k: v for k, v in row.items() if k != "_plot"})
        if use_dask and plots:
            folder = out / f".plots-{index:06d}"
            if folder.is_dir():
                for leftover in folder.iterdir():
                    leftover.unlink()
                folder.rmdir()
    accepted = sum(1 for row in rows if not row.get("flag"))
    frame = pd.DataFrame(table)
    for column in CONTRACT_COLUMNS:
        if column not in frame:
            frame[column] = np.nan
    frame["flag"] = frame["flag"].fillna("").astype(str)
    # the columns in the order of a fitted curve's row, whatever row comes first; an unreadable file's error last
    fitted = list(dict.fromkeys(key for row in rows for key in row if key != "_plot"))
    rest = [c for c in fitted if c not in CONTRACT_COLUMNS and c in frame.columns]
    rest += [c for c in frame.columns if c not in CONTRACT_COLUMNS and c not in rest and c != "error"]
    frame = frame[CONTRACT_COLUMNS + rest + (["error"] if "error" in frame.columns else [])]
    replace_atomically(out / "fits.csv", lambda temporary: frame.to_csv(temporary, index=False, float_format="%.8g"))
    versions = software_versions()
    try:
        import afmformats

        versions["afmformats"] = afmformats.__version__
    except ImportError:
        pass
    wall = time.perf_counter() - start
    curve_keys = ("file", "source", "curve_index", "instrument", "format", "spring_constant", "sensitivity",
                  "sensitivity_unit", "calibration", "position", "flag")
    write_json(out / "fit_settings.json", {
        "settings": asdict(settings), "files": [str(p) for p in files],
        "curves": [{key: row.get(key) for key in curve_keys if key in row} for row in rows],
        "units": {"radius": "m", "indenter_radius": "m", "cap_height": "m", "layer_thickness": "m",
                  "depth_max": "m in fits.csv, units of R in settings (a layer, a cone: h)", "contact_point": "m", "spring_constant": "N/m",
                  "sensitivity": "m/V (NT-MDT: m/nA)", "youngs_modulus": "Pa",
                  "sensitivity_of_each_curve": "its sensitivity_unit column (m/V, or m/nA for NT-MDT)",
                  "sensitivity_given": settings.sensitivity_unit, "adhesion_dip": "N",
                  "adhesion_dip_sigmas": "baseline noise of the running median", "adhesion_dip_fraction":
                  "of the largest fitted force"},
        "master_curve": (curve.metadata | {"poisson_ratio": curve.poisson_ratio, "material": curve.material}
                         | ({"hertz_blend_below": curve.hertz_blend_below} if isinstance(curve, MasterCurve) else {})
                         ) if curve else None,
        "geometry": {"geometry": settings.geometry, "cell_shape": settings.cell_shape if
                     settings.geometry in INDENTERS else None, "indenter_radius": settings.indenter_radius,
                     "indenter_ratio": settings.indenter_ratio if settings.indenter_radius or settings.geometry in
                     CONES else None,  # R_b/R, R_b/h, or the cone's tan(alpha)
                     "cap_ratio": settings.cap_ratio,
                     **({"half_angle_deg": settings.half_angle} if settings.geometry in CONES else {}),
                     **({"cone_half_angle_deg": settings.cone_half_angle} if settings.geometry == "pyramid"
                        else {})},
        "delta_definition": "delta = (displacement - contact_point) / (2 R) = 1 - h/(2R); for an instrument file "
                            "displacement = -(tip position), tip position = height (measured) + force / k "
                            "(piezo height minus cantilever deflection)" if settings.geometry == "parallel-plates"
                            else "depth = displacement - contact_point (the indenter's depth after contact); "
                            "displacement = -(tip position), tip position = height (measured) + force / k",
        "contact_point_estimator": "baseline (mean, or line with baseline_tilt) on the first baseline_fraction of the "
                                   "approach, noise 1.4826 MAD; noise exit: the last point below threshold*sigma; "
                                   "change point of a flat-then-power-law model (p 1..2.5) up to 30 % of the "
                                   "largest force; refined with E by least squares inside the rise region "
                                   "[c - max(exit - c, 5 spacings), exit]",
        "checks": {"min_points_in_contact": MIN_POINTS_IN_CONTACT, "runs_z_limit": RUNS_Z_LIMIT,
                   "systematic_limit": SYSTEMATIC_LIMIT, "modulus_floor": MODULUS_FLOOR,
                   "interval": "finite, low > 0, high - low <= E", "contact": "inside the rise region, not on "
                   "its edge", "plausible_modulus_max": PLAUSIBLE_MODULUS_MAX,
                   "adhesion_dip": f"running median of {ADHESION_DIP_POINTS} points below the baseline by more than "
                   f"{ADHESION_DIP_SIGMAS:g} sigma of the baseline's own running median and "
                   f"{100 * ADHESION_DIP_LIMIT:g} % of the largest fitted force"},
        "nucleated_curve": None if nucleated is None else nucleated.metadata,
        "heterogeneous_conversion": None if settings.nucleus_size_ratio is None else (
            "youngs_modulus_cytoplasm_nucleated: E_c fitted to the nucleated cell's own curve (nucleated_curve: "
            "axisymmetric solver, concentric nucleus), no conversion; effective_stiffness_ratio_fitted = "
            "youngs_modulus / that E_c. Conversions of the homogeneous fit beside it: E_c = E_eff / (1 + (gamma - "
            "1) phi) (youngs_modulus_cytoplasm, volume average, phi the nucleus's volume fraction) and the "
            "Hashin-Shtrikman upper bound (*_hashin_shtrikman_upper); E_n = gamma E_c. The nucleated fit needs "
            "the master curve or surface: model hertz with a nucleus is refused."),
        "execution": execution, "dask_auto_min_files": DASK_AUTO_MIN_FILES, "n_curves": len(rows),
        "n_accepted": accepted, "n_flagged": len(rows) - accepted, "n_unreadable": len(errors),
        "n_errors": len(errors),  # the name earlier outputs used for n_unreadable
        "wall_time_s": wall, "software": versions,
    })
    return {"rows": rows, "accepted": accepted, "errors": errors, "wall_time_s": wall, "files": files,
            "execution": execution}


# ---------------------------------------------------------------- shear flow: D -> Ca -> mu, E

SHEAR_CONTRACT_COLUMNS = ["cell", "deformation", "shear_stress", "capillary_number", "shear_modulus",
                          "shear_modulus_ci_low", "shear_modulus_ci_high", "youngs_modulus", "youngs_modulus_ci_low",
                          "youngs_modulus_ci_high"]


def parse_shear_stress(value, parameter: str = "shear_stress") -> float:
    """A stress in Pa: '12Pa', '0.012 kPa' or a plain number (Pa)."""
    return parse_quantity(value, "Pa", parameter)[0]


def parse_rate(value, parameter: str, angular: bool = False) -> float:
    """A rate in 1/s: '1000/s', '1000Hz', '150 rad/s' or a plain number (1/s), as ``elastocell shear
    --shear-rate`` reads it (a shear rate given in Hz is that many per second). With ``angular`` (the
    tank-treading frequency, an angular frequency in rad/s) a frequency in Hz, cycles per second, is converted:
    times 2 pi."""
    magnitude, physical = parse_quantity(value, "1/s", parameter)
    if angular and physical and "hz" in str(value).lower():
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
        omega = parse_rate(tank_treading_frequency, "tank_treading_frequency", angular=True) / rate
        omega_error = _finite_nonnegative(parse_rate(tank_treading_frequency_error, "tank_treading_frequency_error",
                                                     angular=True),
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
