"""A cell in plane Couette (shear) flow (paper section 2.6; docs/theory.md, "Shear flow").

Walls at y = -1/2 and y = ny - 1/2 move with -U and +U (shear_rate = 2U/ny), periodic in x and z, the cell
centred in the channel. The capillary number Ca = eta * shear_rate / mu_ref with mu_ref = mu_c = E_c/(2(1+nu))
(or mu_eff for the homogeneous equivalent) fixes E_c in lattice units once the lattice shear rate is chosen
(:func:`shear_lattice_units`). :class:`ShearRun` records the Taylor deformation, inclination, tank-treading
and volume change in strain units.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

# =========================================================================== shear flow
import numpy as np
from pydantic import model_validator  # noqa: E402

from elastocell.body.cell import Cell
from elastocell.body.observables import RotationTracker, shape_observables
from elastocell.coupling import ibm
from elastocell.coupling.immersed import ImmersedCell, immersed_cell
from elastocell.coupling.markers import FlowError
from elastocell.coupling.stability import shear_rate_limits
from elastocell.lattice import LatticeParams
from elastocell.parameters.cell import cell_parameters, require
from elastocell.parameters.flow import FlowLatticeParameters, check_capillary_number
from elastocell.parameters.units import ParameterError
from elastocell.simulation.output import save_time_series_figure, time_series_figure
from elastocell.simulation.runner import FlowRun, StopCriteria, stationary_summary, window_verdict


def compile_kernels(dtypes=("float32",)) -> None:
    """Compile (or load from Numba's on-disk cache) the coupled-step kernels in this process, one tiny Couette
    step per storage dtype.

    Call it before starting several worker processes on one machine: they then load the cached kernels
    instead of compiling the same functions at once, which can leave Numba's cache inconsistent (a later run
    segfaults while loading it: numba issues 4807 and 10128; seen here once after parallel first runs).
    A few seconds when the cache is valid, about a minute per dtype otherwise."""

    cell = Cell.from_parameters(cell_parameters(nucleus="none", element="p1", mesh_size=0.6, pole_size=0.6))
    for dtype in dtypes:
        params = ShearFlowParameters(capillary_number=0.1, resolution=3, confinement=0.3, box_length=4,
                                     dtype=dtype)
        system = shear_setup(cell, params)
        system.advance(1)
        system.lattice.step(1)


class ShearFlowParameters(FlowLatticeParameters):
    """Plane Couette (shear) flow of a cell; numbers are dimensionless unless stated.

    capillary_number: Ca = eta * shear_rate / mu_ref, mu_ref = mu_c = E_c/(2(1+nu)) (mu_eff = gamma_eff mu_c
        for the homogeneous equivalent cell).
    resolution: R/dx (lattice nodes per cell radius). Default 8 from the resolution study (homogeneous p1
        cell, mesh edge 2 dx, Ca = 0.05, confinement 0.2, box 8R; this study and the two below at tau 1,
        Re_p 0.1, the defaults then): D/Ca = 1.639, 1.460, 1.365, 1.324 at
        R/dx = 4, 6, 8, 10; the excess over Taylor's 5/4 falls like (dx/R)^2 and the extrapolation gives
        1.243-1.251. R/dx = 8 is 9 % above the limit at a third of the cost of R/dx = 10 (6 % above; cost ~ R^5:
        R^3 nodes and R^2 steps per strain at a fixed Reynolds number).
    confinement: 2R/H, the fraction of the channel height H (wall to wall) the undeformed cell fills.
        Default 0.2 from the confinement study (R/dx = 4, box 8R, Ca = 0.05): D/Ca = 1.620, 1.639, 1.848 at
        2R/H = 0.1, 0.2, 0.4, i.e. +1 % at 0.2 and +14 % at 0.4 relative to 0.1.
    box_length: periodic length of the box along x (flow) and z (vorticity), in units of R. Default 8 from
        the same study: D/Ca = 1.58 (5R), 1.639 (8R), 1.663 (12R) -- the periodic images lower D.
    relaxation_time: LB relaxation time tau (time steps); the kinematic viscosity is (tau - 1/2)/3 dx^2/dt.
        None (the default): :func:`matched_relaxation_time`, the largest tau up to
        :data:`MATCHED_RELAXATION_TIME_MAX` that keeps the lattice shear rate (the cost) tau 1 would have under
        the same limits, i.e. a particle Reynolds number up to three times lower at the same cost. The steady
        state depends on the Reynolds number and not on tau (TRT with the magic parameter): at Ca 0.3, R/dx 6,
        tau 1 and tau 3 at Re_p 0.02 agree within 0.03 % in D and the tank treading and 0.005 degrees in
        inclination, while Re_p 0.1 -> 0.02 raises the tank treading by 1.1 % and lowers D by 1.0 %
        (docs/validation/shear_targets.md).
    reynolds_number: upper limit of the particle Reynolds number shear_rate R^2 / nu (Stokes regime).
    velocity_limit: upper limit of the wall speed |U| (dx/dt).
    kernel: immersed-boundary kernel ("trilinear", the paper's 2-point one, or "peskin4").
    hydrodynamic_radius_correction: c in dx: the markers lie on a sphere of radius R - c dx, so that the
        body the fluid sees (larger than the marker surface by a constant of the kernel and the marker spacing:
        0.28-0.36 dx for trilinear with edges of 2 dx at R/dx = 4-8, 0.36-0.49 dx with edges of 1.33 dx,
        0.15-0.25 dx with edges of 2.4-3 dx, 0.6-0.9 dx for peskin4, measured at tau 1 and not re-measured at the
        matched tau; docs/validation/flow_accuracy.md) has radius R: 0.3 puts the held sphere's
        torque within 2 % of Stokes' at R/dx = 4-8. It corrects the
        cell's size in the flow (drag, torque, confinement), not D/Ca, which depends on the ratio of the
        hydrodynamic to the elastic radius (measured: D/Ca rises from 1.670 to 1.734 with c = 0.3 at R/dx = 4).
        Default 0: markers at R.
    lattice_shear_rate: impose the shear rate in lattice units (1/dt) instead of choosing the largest
        allowed one; refused if it breaks a limit.
    max_steps_per_strain: refuse a run needing more LB steps per unit strain (1/shear_rate).
    dtype: LB storage precision.
    backend: compute engine: "numba" (fused compiled CPU kernels, the fastest on a CPU) or "jax" (the same
        physics in JAX on its default device: a GPU when JAX has CUDA/ROCm, else the CPU).
    """

    automatic_relaxation_time: ClassVar[bool] = True

    capillary_number: float
    relaxation_time: float | None = None
    confinement: float = 0.2
    hydrodynamic_radius_correction: float = 0.0
    lattice_shear_rate: float | None = None
    max_steps_per_strain: float = 1.0e6

    @model_validator(mode="after")
    def _check(self) -> ShearFlowParameters:
        check_capillary_number(self.capillary_number, "capillary_number", MAX_CAPILLARY_NUMBER,
                               VALIDATED_CAPILLARY_NUMBER, f"the small-deformation estimate D = 5/4 Ca = "
                               f"{1.25 * self.capillary_number:.3g} is far beyond any shape the cell's mesh can follow",
                               "Taylor deformation D ~ 0.5 and more beyond it")
        require(math.isfinite(self.confinement) and 0 < self.confinement < 1, "confinement",
                f"2R/H must be in (0, 1), got {self.confinement}")
        require(math.isfinite(self.hydrodynamic_radius_correction)
                and 0 <= self.hydrodynamic_radius_correction < 0.5 * self.resolution,
                "hydrodynamic_radius_correction", f"must be in [0, R/2) = [0, {0.5 * self.resolution:g}) dx, "
                f"got {self.hydrodynamic_radius_correction}")
        if self.lattice_shear_rate is not None:
            require(math.isfinite(self.lattice_shear_rate) and self.lattice_shear_rate > 0, "lattice_shear_rate",
                    f"must be > 0 (1/dt), got {self.lattice_shear_rate}")
        _check_wall_gap(self)  # before any meshing
        return self


@dataclass(frozen=True)
class ShearUnits:
    """Lattice parameters of a shear-flow run and the conversion to the cell model's units.

    Lattice units: dx = R/resolution, dt = one LB step, rho0 = 1. ``shape`` (nx, ny, nz); walls at
    y = -1/2 and ny - 1/2 move with -/+ ``wall_speed``; ``shear_rate`` = 2 wall_speed / ny (1/dt);
    ``viscosity`` eta = nu (rho0 dx^2/dt); ``youngs_modulus`` E_c (rho0 dx^2/dt^2) so that
    eta * shear_rate / mu_ref = Ca; ``steps_per_strain`` = 1/shear_rate.
    ``limits`` the shear rates each constraint allows (1/dt); ``limiting`` names the binding one.
    """

    radius: float
    shape: tuple[int, int, int]
    relaxation_time: float
    viscosity: float
    shear_rate: float
    wall_speed: float
    youngs_modulus: float
    reference_shear_modulus: float
    reynolds_number: float
    confinement: float
    stiffness_mobility: float
    stability_number: float
    min_node_spacing: float
    limits: dict = field(default_factory=dict)
    limiting: str = ""

    @property
    def steps_per_strain(self) -> float:
        return 1.0 / self.shear_rate

    @property
    def centre(self) -> np.ndarray:
        """Initial cell centre (dx): mid-box in x and z, the zero-velocity plane y = (ny - 1)/2."""
        nx, ny, nz = self.shape
        return np.array([nx / 2.0, (ny - 1) / 2.0, nz / 2.0])

    def as_dict(self) -> dict:
        out = {k: getattr(self, k) for k in (
            "radius", "relaxation_time", "viscosity", "shear_rate", "wall_speed", "youngs_modulus",
            "reference_shear_modulus", "reynolds_number", "confinement", "stiffness_mobility",
            "stability_number", "min_node_spacing", "limiting")}  # fmt: skip
        out["shape"] = list(self.shape)
        out["steps_per_strain"] = self.steps_per_strain
        out["limits"] = dict(self.limits)
        return out


def _check_wall_gap(params: ShearFlowParameters) -> None:
    """Refuse a channel whose walls lie within the kernel support (+1 dx) of the undeformed cell."""
    radius = float(params.resolution)
    ny = int(round(2.0 * radius / params.confinement))
    half_width = ibm.kernel_half_width(params.kernel)
    gap = ny / 2.0 - radius  # distance from the undeformed cell to a wall (dx)
    if gap < half_width + 1.0:
        raise ParameterError(
            "confinement",
            f"the walls are {gap:.2f} dx from the cell at confinement {params.confinement} and resolution "
            f"{params.resolution}; need >= {half_width + 1:g} dx (kernel half-width + 1): lower confinement",
        )


MATCHED_RELAXATION_TIME_MAX = 2.0
"""The largest tau :func:`matched_relaxation_time` chooses: a third of the Reynolds number of tau 1 where the
Reynolds number sets the shear rate (the homogeneous cell at Ca >= 0.04 at R/dx 8)."""


def matched_relaxation_time(cell, radius: float, params: ShearFlowParameters, ny: int) -> tuple[float, float, str]:
    """(tau, the lattice shear rate, the limit that sets it) of the automatic relaxation time: the shear rate of
    tau 1 under ``params``' limits (or its ``lattice_shear_rate``) is kept, and tau raised (up to
    :data:`MATCHED_RELAXATION_TIME_MAX`) as far as the elastic step limit allows at that rate. That limit falls
    like 1/nu (E_c in lattice units grows with the viscosity at a fixed Ca and rate; c(tau) = 1 from tau 0.9),
    the Reynolds number's rises like nu: where the elastic limit already binds at tau 1 (a stiff nucleus, low Ca)
    tau stays 1, so no run takes more steps than at tau 1."""
    rates = shear_rate_limits(cell, radius, 1.0, params.capillary_number, params.kernel, params.reynolds_number,
                              params.velocity_limit, ny)
    if params.lattice_shear_rate is None:
        limiting = min(rates.limits, key=rates.limits.get)
        rate = rates.limits[limiting]
    else:
        limiting, rate = "lattice_shear_rate", float(params.lattice_shear_rate)
    largest = rates.viscosity * rates.limits["elastic_stability"] / rate * (1 - 1e-9)
    tau = min(MATCHED_RELAXATION_TIME_MAX, max(1.0, 0.5 + 3.0 * largest))
    return float(tau), float(rate), limiting


def shear_lattice_units(cell, params: ShearFlowParameters) -> ShearUnits:
    """Derive the lattice parameters of a shear run from (Ca, R/dx, confinement) and the limits.

    With R = resolution (dx), H = ny = round(2R/confinement), nu = (tau - 1/2)/3 = eta, the shear rate is the
    largest one that keeps (1) the particle Reynolds number shear_rate R^2/nu <= reynolds_number, (2) the wall
    speed shear_rate H/2 <= velocity_limit, and (3) the explicit elastic step stable:
    E_c * lambda_max(W K) <= C0 c(tau) c(d) (see :data:`STABILITY_CONSTANT`), where E_c follows from Ca:
    mu_ref = eta shear_rate / Ca, E_c = 2 (1 + nu_p) mu_ref / (mu_ref/mu_c). Raises ParameterError when the
    geometry cannot hold the cell, when ``lattice_shear_rate`` breaks a limit, or when the run would need
    more than ``max_steps_per_strain`` steps per unit strain.
    """
    radius = float(params.resolution)
    ny = int(round(2.0 * radius / params.confinement))
    n_side = int(round(params.box_length * radius))
    _check_wall_gap(params)
    tau = params.relaxation_time
    automatic = tau is None
    if automatic:
        tau, matched_rate, matched_limit = matched_relaxation_time(cell, radius, params, ny)
    ca = params.capillary_number
    rates = shear_rate_limits(cell, radius, tau, ca, params.kernel, params.reynolds_number,
                              params.velocity_limit, ny)
    viscosity, modulus_per_rate, limits = rates.viscosity, rates.modulus_per_rate, rates.limits
    stiffness_mobility, spacing, stability_number = rates.stiffness_mobility, rates.spacing, rates.stability_number
    if automatic and params.lattice_shear_rate is None:  # tau 1's rate, named by the limit that set it there
        limiting, shear_rate = matched_limit, min(matched_rate, *limits.values())
    elif params.lattice_shear_rate is None:
        limiting = min(limits, key=limits.get)
        shear_rate = limits[limiting]
    else:
        shear_rate = float(params.lattice_shear_rate)
        limiting = "lattice_shear_rate"
        for name, value in limits.items():
            if shear_rate > value * (1 + 1e-12):
                what = {
                    "reynolds_number": f"gives a particle Reynolds number {shear_rate * radius**2 / viscosity:.3g} > "
                    f"{params.reynolds_number}",
                    "velocity_limit": f"gives wall speeds {shear_rate * ny / 2:.3g} dx/dt > {params.velocity_limit}",
                    "elastic_stability": "makes the explicit elastic step unstable (E_c lambda_max(W K) = "
                    f"{shear_rate * modulus_per_rate * stiffness_mobility:.3g} > {stability_number:.3g})",
                }[name]
                raise ParameterError("lattice_shear_rate", f"{shear_rate:.4g} {what}; use <= {value:.4g}")
    if 1.0 / shear_rate > params.max_steps_per_strain:
        raise ParameterError(
            "capillary_number",
            f"Ca = {ca} needs {1 / shear_rate:.3g} LB steps per unit strain at resolution {params.resolution} "
            f"(limited by {limiting}), more than max_steps_per_strain = {params.max_steps_per_strain:.3g}: "
            "raise capillary_number, lower resolution or use a coarser mesh",
        )
    youngs_modulus = modulus_per_rate * shear_rate
    return ShearUnits(
        radius=radius,
        shape=(n_side, ny, n_side),
        relaxation_time=tau,
        viscosity=viscosity,
        shear_rate=shear_rate,
        wall_speed=shear_rate * ny / 2.0,
        youngs_modulus=youngs_modulus,
        reference_shear_modulus=viscosity * shear_rate / ca,
        reynolds_number=shear_rate * radius**2 / viscosity,
        confinement=2.0 * radius / ny,
        stiffness_mobility=stiffness_mobility,
        stability_number=youngs_modulus * stiffness_mobility,
        min_node_spacing=spacing,
        limits=limits,
        limiting=limiting,
    )


@dataclass
class ShearResult:
    """Time series and stationary summary of a shear run.

    series: columns (arrays of equal length): strain (t * shear_rate), taylor_deformation,
    inclination_deg, volume_change (V/V0 - 1), centre_x/y/z (units of R, relative to the initial centre),
    nucleus_centre_x/y/z (same, NaN without a nucleus), semi_axis_a/b/c (R), max_speed (dx/dt).
    summary: stationary means and standard deviations over strain >= transient, the tank-treading angular
    frequency (units of the shear rate), the lattice parameters and timings.
    """

    series: dict
    summary: dict
    units: ShearUnits
    tracker: RotationTracker

    def to_frame(self):
        import pandas as pd

        return pd.DataFrame(self.series)


def shear_setup(cell, params: ShearFlowParameters, units: ShearUnits | None = None) -> ImmersedCell:
    """Lattice (Couette profile already established) and the immersed cell at the channel centre."""
    units = shear_lattice_units(cell, params) if units is None else units
    nx, ny, nz = units.shape
    u = units.wall_speed
    lattice_params = LatticeParams(units.shape, relaxation_time=units.relaxation_time, dtype=params.dtype,
                                   wall_velocity=(-u, u), velocity_limit=max(params.velocity_limit, u) * 1.2)
    profile = -u + 2.0 * u * (np.arange(ny) + 0.5) / ny
    velocity = np.zeros((3,) + units.shape)
    velocity[0] = profile[None, :, None]
    return immersed_cell(params.backend, lattice_params, velocity, cell, units, params.kernel,
                         params.hydrodynamic_radius_correction)


def run_shear(
    cell,
    params: ShearFlowParameters,
    duration: float = 10.0,
    record_interval: float = 0.05,
    transient: float | None = None,
    callback=None,
) -> ShearResult:
    """Run a cell in plane Couette flow for ``duration`` units of strain (shear_rate * t), in memory.

    Observables are recorded every ``record_interval`` of strain (each record ends one compiled chunk);
    ``transient`` (default duration/2) is the strain after which the stationary means and the
    tank-treading frequency are taken. ``callback(record: dict, system: ImmersedCell)`` runs after every
    record. Raises :class:`FlowError` if the run turns unstable or the cell reaches a wall. The runner
    (:class:`elastocell.scenarios.shear.ShearRun`) adds checkpoints, other stop criteria and output files.
    """

    start = time.perf_counter()
    stop = StopCriteria(duration=duration)
    run = ShearRun(cell, params, record_interval=record_interval)
    observers = () if callback is None else (lambda row, current: callback(row, current.system),)
    run.run(stop, observers=observers)
    summary = run.summary(0.5 * duration if transient is None else transient)
    summary["wall_time_s"] = time.perf_counter() - start
    return ShearResult(series=run.arrays(), summary=summary, units=run.units, tracker=run.tracker)

MAX_CAPILLARY_NUMBER = 10.0
"""Largest shear capillary number accepted: 5/4 Ca = 12.5, a deformation no tetrahedral cell survives."""

VALIDATED_CAPILLARY_NUMBER = 1.0
"""Above this capillary number a run is warned about: beyond the range the shear validation covers."""

STATIONARY_OBSERVABLES = ("taylor_deformation", "inclination_deg")
"""Observables whose averaging window the summary judges (``stationary`` in ``summary.json``)."""

SERIES_COLUMNS = (
    "strain", "taylor_deformation", "inclination_deg", "volume_change", "centre_x", "centre_y", "centre_z",
    "nucleus_centre_x", "nucleus_centre_y", "nucleus_centre_z", "semi_axis_a", "semi_axis_b", "semi_axis_c",
    "max_speed",
)  # fmt: skip
"""Columns of the shear time series (see :class:`~elastocell.scenarios.shear.ShearResult`)."""


class ShearRun(FlowRun):
    """A cell in plane Couette flow (time in strain units shear_rate * t).

    cell: :class:`~elastocell.body.cell.Cell` (its equivalent for an equivalent run); params: the flow;
    record_interval: strain between records (each record ends one compiled chunk of steps).
    """

    COLUMNS = SERIES_COLUMNS
    TIME_UNIT = "strain"
    WHEN = "strain {:.3g}"
    DRIVING = "capillary_number"
    RATE = "shear_rate"
    DEFAULT_RECORD_INTERVAL = 0.05
    MAX_RECORD_INTERVAL = 1.0
    RECORD_NOTE = "; rotations are tracked"
    PROGRESS = ("strain {task.completed:.2f}", "taylor_deformation", "D")
    lattice_units = staticmethod(shear_lattice_units)
    setup = staticmethod(shear_setup)
    units: ShearUnits
    params: ShearFlowParameters

    @property
    def strain(self) -> float:
        return self.time

    def _start(self) -> None:
        self._surface = self.cell.mesh.surface_nodes
        self._centre0 = self.units.centre / self.system.radius  # the marker radius (positions_in_radii)
        self.tracker = RotationTracker(plane=(0, 1))
        first = self._observe()
        self.volume0 = first.volume
        self._append(self._row(first, 0.0))

    def _observe(self):
        return shape_observables(self.system.positions_in_radii(), self.cell.mesh.elements, self._nucleus_mask)

    def _measure(self) -> dict:
        return self._row(self._observe(), self.system.max_speed)

    def _row(self, obs, max_speed: float) -> dict:
        strain = self.strain
        nucleus = obs.nucleus_centre - self._centre0 if obs.nucleus_centre is not None else np.full(3, np.nan)
        centre = obs.centre - self._centre0
        self.tracker.record(strain, self.system.positions_in_radii()[self._surface], obs.centre, obs.second_moment)
        return {
            "strain": strain, "taylor_deformation": obs.taylor_deformation,
            "inclination_deg": obs.inclination_deg, "volume_change": obs.volume / self.volume0 - 1.0,
            "centre_x": centre[0], "centre_y": centre[1], "centre_z": centre[2],
            "nucleus_centre_x": nucleus[0], "nucleus_centre_y": nucleus[1], "nucleus_centre_z": nucleus[2],
            "semi_axis_a": obs.semi_axes[0], "semi_axis_b": obs.semi_axes[1], "semi_axis_c": obs.semi_axes[2],
            "max_speed": max_speed,
        }  # fmt: skip

    def _check_walls(self) -> None:
        units, system = self.units, self.system
        y_mid = (units.shape[1] - 1) / 2.0
        gap = units.shape[1] / 2.0 - ibm.kernel_half_width(self.params.kernel) - 0.5
        if np.abs(system.positions[:, 1] - y_mid).max() > gap:
            raise FlowError(
                f"the cell reached a wall at strain {self.strain:.3g} (within the kernel support): lower "
                "confinement or capillary_number"
            )

    def vtk_origin(self, x: np.ndarray) -> np.ndarray:
        return self._centre0

    def vtk_slice(self) -> tuple[int, float]:
        nz = self.system.lattice.shape[2]
        k = int(np.clip(round(float(np.mean(self.system.positions[:, 2]))) % nz, 0, nz - 1))
        return k, self.units.shear_rate * self.units.radius

    def _extra_state(self) -> dict:
        tracker = self.tracker.state()
        return {"tracker_times": tracker["times"], "tracker_angles": tracker["angles"],
                "tracker_radii2": tracker["radii2"]}

    def _load_extra(self, data) -> None:
        self.tracker = RotationTracker.from_state(
            {"times": data["tracker_times"], "angles": data["tracker_angles"], "radii2": data["tracker_radii2"]}
        )

    # ------------------------------------------------------------------ results
    def summary(self, transient: float | None = None) -> dict:
        """Stationary means and deviations over strain >= transient (default: the second half of the run),
        tank-treading frequency (units of the shear rate; positive for the clockwise rotation of
        u_x = shear_rate * y), lattice parameters and timings."""
        series = self.arrays()
        end = float(series["strain"][-1])
        transient = 0.5 * end if transient is None else float(transient)
        out = {"capillary_number": self.params.capillary_number, "equivalent": bool(self.cell.is_equivalent)}
        out.update(stationary_summary(series, transient))
        out.update(window_verdict(series, np.asarray(series["strain"]) >= transient, STATIONARY_OBSERVABLES))
        out["tank_treading_frequency"] = -self.tracker.angular_velocity(start=transient)
        out["duration_strain"] = end
        out.update(self.run_summary())
        out["wall_time_per_strain_s"] = self.elapsed / end if end > 0 else float("nan")
        out["record_interval_strain"] = self.record_interval
        return out


def plot_taylor_deformation(path: Path, series: dict, summary: dict, title: str = "") -> None:
    """D and the inclination against strain, with the stationary mean over the averaging window."""
    figure, top, bottom = time_series_figure()
    strain = np.asarray(series["strain"])
    top.plot(strain, series["taylor_deformation"], lw=1.2, label="D")
    start = summary.get("transient_strain", 0.0)
    mean = summary.get("taylor_deformation_mean", np.nan)
    top.hlines(mean, start, strain[-1], colors="k", linestyles="--", lw=1,
               label=f"mean {mean:.4g} (strain >= {start:.3g})")
    top.set_ylabel("Taylor deformation D")
    top.legend(fontsize=8)
    bottom.plot(strain, series["inclination_deg"], lw=1.2, color="C1")
    bottom.set_ylabel("inclination (deg)")
    save_time_series_figure(path, figure, r"strain $\dot\gamma t$", title)
