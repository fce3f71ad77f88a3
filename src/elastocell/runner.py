"""The simulation runner shared by the flow scenarios, and the shear-flow entry point ``shear``.

A :class:`ShearRun` owns one coupled system (:class:`~elastocell.flow.ImmersedCell`) and its recorded time
series. :meth:`ShearRun.run` advances it in compiled chunks of one record interval each and, between
chunks only (Python never loops over nodes or lattice cells):

* records the observables (one row of the time series, and the material-point angles for tank treading);
* guards the state: non-finite populations, a Mach number above the limit, an inverted element or a cell
  within the kernel support of a wall stop the run with a :class:`~elastocell.flow.FlowError` whose message
  names the likely cause and the parameter to change;
* calls the observers ``observer(row, run)`` (output writers, progress);
* checks the stop criteria (:class:`StopCriteria`: duration in strain units, wall-clock limit, stationary
  running mean);
* writes a checkpoint every ``checkpoint_every`` records: the complete state (populations in the solver's
  own storage, force field, marker positions, series, tracker) in one ``.npz`` written to a temporary
  file and moved into place with ``os.replace`` (atomic: a kill leaves the previous checkpoint intact).
  A run resumed from it repeats the lost records exactly (the compiled steps are deterministic), so its
  time series equals an uninterrupted run's.

:func:`shear` is the Python API behind ``elastocell shear``: it writes ``timeseries.csv``, ``summary.json``,
``taylor_deformation.png`` and VTK files (cell snapshots and the mid-plane fluid velocity) to a directory.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import ibm
from .flow import (
    FlowError,
    ImmersedCell,
    ShearFlowParameters,
    ShearUnits,
    shear_lattice_units,
    shear_setup,
    stationary_summary,
)
from .observables import RotationTracker, shape_observables
from .parameters import ParameterError

SERIES_COLUMNS = (
    "strain", "taylor_deformation", "inclination_deg", "volume_change", "centre_x", "centre_y", "centre_z",
    "nucleus_centre_x", "nucleus_centre_y", "nucleus_centre_z", "semi_axis_a", "semi_axis_b", "semi_axis_c",
    "max_speed",
)  # fmt: skip
"""Columns of the shear time series (see :class:`~elastocell.flow.ShearResult`)."""

CHECKPOINT_VERSION = 1


@dataclass(frozen=True)
class StopCriteria:
    """When a run stops (whichever comes first).

    duration: strain shear_rate * t (> 0).
    wall_clock: seconds of wall time in this process (None: no limit).
    stationary_tolerance: stop once the mean of ``stationary_observable`` over the last
        ``stationary_window`` (strain) differs from the mean over the window before by less than this
        fraction of it (None: off). Checked only after ``2 * stationary_window`` of strain. The default window
        (1 strain) is about twice the relaxation of D measured for the reference cell at Ca = 0.1 (D within
        1 % of its final value from strain 1 on).
    """

    duration: float = 10.0
    wall_clock: float | None = None
    stationary_tolerance: float | None = None
    stationary_observable: str = "taylor_deformation"
    stationary_window: float = 1.0

    def __post_init__(self):
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise ParameterError("duration", f"must be > 0 (strain), got {self.duration}")
        if self.wall_clock is not None and not self.wall_clock > 0:
            raise ParameterError("wall_clock", f"must be > 0 seconds, got {self.wall_clock}")
        if self.stationary_tolerance is not None and not self.stationary_tolerance > 0:
            raise ParameterError("stationary_tolerance", f"must be > 0, got {self.stationary_tolerance}")
        if not self.stationary_window > 0:
            raise ParameterError("stationary_window", f"must be > 0 (strain), got {self.stationary_window}")
        if self.stationary_observable not in SERIES_COLUMNS:
            raise ParameterError("stationary_observable", f"must be one of {', '.join(SERIES_COLUMNS)}")

    def is_stationary(self, series: dict) -> bool:
        if self.stationary_tolerance is None:
            return False
        strain = np.asarray(series["strain"])
        if strain[-1] < 2 * self.stationary_window:
            return False
        values = np.asarray(series[self.stationary_observable])
        last = values[strain > strain[-1] - self.stationary_window]
        before = values[(strain > strain[-1] - 2 * self.stationary_window) & (strain <= strain[-1] - self.stationary_window)]
        if not (last.size and before.size):
            return False
        mean = last.mean()
        return abs(mean - before.mean()) <= self.stationary_tolerance * abs(mean)


class ShearRun:
    """A cell in plane Couette flow, advanced record by record (see the module docstring).

    cell: :class:`~elastocell.cell.Cell` (its equivalent for an equivalent run); params: the flow;
    record_interval: strain between records (each record ends one compiled chunk of steps).
    """

    def __init__(self, cell, params: ShearFlowParameters, record_interval: float = 0.05,
                 units: ShearUnits | None = None):
        if not (math.isfinite(record_interval) and 0 < record_interval <= 1.0):
            raise ParameterError("record_interval", f"must be in (0, 1] strain (rotations are tracked), got {record_interval}")
        self.cell = cell
        self.params = params
        self.units = shear_lattice_units(cell, params) if units is None else units
        self.system: ImmersedCell = shear_setup(cell, params, self.units)
        self.steps_per_record = max(1, int(round(record_interval * self.units.steps_per_strain)))
        self.record_interval = self.steps_per_record * self.units.shear_rate
        mesh = cell.mesh
        self._nucleus_mask = (mesh.region == 1) if bool((mesh.region == 1).any()) else None
        self._surface = mesh.surface_nodes
        self._centre0 = self.units.centre / self.units.radius
        self.series: dict[str, list] = {name: [] for name in SERIES_COLUMNS}
        self.tracker = RotationTracker(plane=(0, 1))
        self.elapsed = 0.0  # wall seconds spent advancing, over all sessions (checkpointed)
        self.stop_reason = ""
        first = self._observe()
        self.volume0 = first.volume
        self._record(first, 0.0)

    # ------------------------------------------------------------------ state
    @property
    def strain(self) -> float:
        return self.system.time_step * self.units.shear_rate

    @property
    def n_records(self) -> int:
        return len(self.series["strain"])

    def _observe(self):
        return shape_observables(self.system.positions_in_radii(), self.cell.mesh.elements, self._nucleus_mask)

    def _record(self, obs, max_speed: float) -> dict:
        strain = self.strain
        nucleus = obs.nucleus_centre - self._centre0 if obs.nucleus_centre is not None else np.full(3, np.nan)
        centre = obs.centre - self._centre0
        row = {
            "strain": strain, "taylor_deformation": obs.taylor_deformation,
            "inclination_deg": obs.inclination_deg, "volume_change": obs.volume / self.volume0 - 1.0,
            "centre_x": centre[0], "centre_y": centre[1], "centre_z": centre[2],
            "nucleus_centre_x": nucleus[0], "nucleus_centre_y": nucleus[1], "nucleus_centre_z": nucleus[2],
            "semi_axis_a": obs.semi_axes[0], "semi_axis_b": obs.semi_axes[1], "semi_axis_c": obs.semi_axes[2],
            "max_speed": max_speed,
        }  # fmt: skip
        for name in SERIES_COLUMNS:
            self.series[name].append(float(row[name]))
        self.tracker.record(strain, self.system.positions_in_radii()[self._surface], obs.centre, obs.second_moment)
        return row

    # ------------------------------------------------------------------ guards
    def _check(self) -> None:
        """Guards between chunks: the cell near a wall, non-finite fluid, Mach number above its limit."""
        units, system = self.units, self.system
        y_mid = (units.shape[1] - 1) / 2.0
        gap = units.shape[1] / 2.0 - ibm.kernel_half_width(self.params.kernel) - 0.5
        if np.abs(system.positions[:, 1] - y_mid).max() > gap:
            raise FlowError(
                f"the cell reached a wall at strain {self.strain:.3g} (within the kernel support): lower "
                "confinement or capillary_number"
            )
        velocity = system.lattice.velocity()
        speed = float(np.sqrt(np.einsum("a...,a...->...", velocity, velocity)).max())
        if not math.isfinite(speed):
            raise FlowError(
                f"the fluid became non-finite at strain {self.strain:.3g}: the elastic forces are too stiff for "
                "the time step; lower reynolds_number (the lattice shear rate) or raise capillary_number"
            )
        limit = system.lattice.params.velocity_limit
        if speed > limit:
            raise FlowError(
                f"the lattice speed reached {speed:.3g} dx/dt (Mach {speed * math.sqrt(3):.3g}) above the limit "
                f"{limit:.3g}: lower velocity_limit or reynolds_number"
            )

    # ------------------------------------------------------------------ stepping
    def advance_record(self) -> dict:
        """One compiled chunk of ``steps_per_record`` steps, the guards, and one record."""
        t0 = time.perf_counter()
        self.system.advance(self.steps_per_record)
        self._check()
        row = self._record(self._observe(), self.system.max_speed)
        self.elapsed += time.perf_counter() - t0
        return row

    def run(self, stop: StopCriteria, observers: tuple[Callable] = (), checkpoint: str | Path | None = None,
            checkpoint_every: int = 20) -> str:
        """Advance until a stop criterion holds; returns the reason ("duration", "wall_clock", "stationary").

        observers: ``observer(row, run)`` after every record. checkpoint: path of the ``.npz`` written every
        ``checkpoint_every`` records and when the run stops."""
        if checkpoint_every < 1:
            raise ParameterError("checkpoint_every", f"must be >= 1 record, got {checkpoint_every}")
        session_start = time.perf_counter()
        n_target = int(math.ceil(stop.duration / self.record_interval - 1e-9))
        reason = "duration"
        while self.n_records - 1 < n_target:
            row = self.advance_record()
            for observer in observers:
                observer(row, self)
            if checkpoint is not None and (self.n_records - 1) % checkpoint_every == 0:
                self.save(checkpoint)
            if stop.is_stationary(self.series):
                reason = "stationary"
                break
            if stop.wall_clock is not None and time.perf_counter() - session_start >= stop.wall_clock:
                reason = "wall_clock"
                break
        self.stop_reason = reason
        if checkpoint is not None:
            self.save(checkpoint)
        return reason

    # ------------------------------------------------------------------ results
    def arrays(self) -> dict[str, np.ndarray]:
        return {name: np.asarray(values) for name, values in self.series.items()}

    def summary(self, transient: float | None = None) -> dict:
        """Stationary means and deviations over strain >= transient (default: the second half of the run),
        tank-treading frequency (units of the shear rate; positive for the clockwise rotation of
        u_x = shear_rate * y), lattice parameters and timings."""
        series = self.arrays()
        end = float(series["strain"][-1])
        transient = 0.5 * end if transient is None else float(transient)
        out = {"capillary_number": self.params.capillary_number, "equivalent": bool(self.cell.is_equivalent)}
        out.update(stationary_summary(series, transient))
        out["tank_treading_frequency"] = -self.tracker.angular_velocity(start=transient)
        out["duration_strain"] = end
        out["steps"] = int(self.system.time_step)
        out["stop_reason"] = self.stop_reason
        out["time_stepping_s"] = self.elapsed
        out["wall_time_per_strain_s"] = self.elapsed / end if end > 0 else float("nan")
        out["lattice"] = self.units.as_dict()
        out["reynolds_number"] = self.units.reynolds_number
        out["record_interval_strain"] = self.record_interval
        return out

    # ------------------------------------------------------------------ checkpoints
    def fingerprint(self) -> str:
        """Hash of what a checkpoint must match: flow parameters, lattice units, mesh and moduli."""
        digest = hashlib.sha256()
        digest.update(self.params.model_dump_json().encode())
        digest.update(json.dumps(self.units.as_dict(), sort_keys=True, default=float).encode())
        digest.update(np.ascontiguousarray(self.cell.mesh.nodes).tobytes())
        digest.update(np.ascontiguousarray(self.cell.mesh.elements).tobytes())
        digest.update(np.ascontiguousarray(self.cell.youngs_moduli, dtype=np.float64).tobytes())
        digest.update(self.cell.law.name.encode())
        digest.update(np.ascontiguousarray(self.cell.material_parameters, dtype=np.float64).tobytes())
        digest.update(str(self.steps_per_record).encode())
        return digest.hexdigest()

    def save(self, path: str | Path) -> None:
        """Write the complete state to ``path`` atomically (temporary file, then ``os.replace``)."""
        path = Path(path)
        system, lattice = self.system, self.system.lattice
        tracker = self.tracker.state()
        arrays = {
            "version": np.array(CHECKPOINT_VERSION),
            "fingerprint": np.array(self.fingerprint()),
            "storage": lattice._storage,
            "parity": np.array(lattice._parity),
            "lattice_time_step": np.array(lattice.time_step),
            "force_density": lattice.force_density,
            "positions": system.positions,
            "spread_positions": system._spread_positions,
            "has_spread": np.array(system._has_spread),
            "time_step": np.array(system.time_step),
            "max_speed": np.array(system.max_speed),
            "volume0": np.array(self.volume0),
            "elapsed": np.array(self.elapsed),
            "tracker_times": tracker["times"],
            "tracker_angles": tracker["angles"],
            "tracker_radii2": tracker["radii2"],
        }
        for name, values in self.series.items():
            arrays[f"series_{name}"] = np.asarray(values, dtype=np.float64)
        temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        with open(temporary, "wb") as handle:
            np.savez(handle, **arrays)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temporary, path)

    def load(self, path: str | Path) -> None:
        """Restore the state saved by :meth:`save` (same cell, parameters and record interval)."""
        with np.load(path, allow_pickle=False) as data:
            if int(data["version"]) != CHECKPOINT_VERSION or str(data["fingerprint"]) != self.fingerprint():
                raise ParameterError(
                    "resume", f"{path} was written for other cell or flow parameters: rerun without --resume "
                    "or with the original options",
                )
            system, lattice = self.system, self.system.lattice
            lattice._storage[...] = data["storage"]
            lattice._parity = int(data["parity"])
            lattice.time_step = int(data["lattice_time_step"])
            lattice.force_density[...] = data["force_density"]
            system.positions[...] = data["positions"]
            system._spread_positions[...] = data["spread_positions"]
            system._has_spread = bool(data["has_spread"])
            system.time_step = int(data["time_step"])
            system.max_speed = float(data["max_speed"])
            self.volume0 = float(data["volume0"])
            self.elapsed = float(data["elapsed"])
            self.series = {name: [float(v) for v in data[f"series_{name}"]] for name in SERIES_COLUMNS}
            self.tracker = RotationTracker.from_state(
                {"times": data["tracker_times"], "angles": data["tracker_angles"], "radii2": data["tracker_radii2"]}
            )


# =========================================================================== output writers
class VTKWriter:
    """Cell snapshots (``vtk/cell_NNNN.vtu``: displacement, stiffness ratio, region) and the fluid velocity
    in the shear plane through the cell centre (``vtk/fluid_NNNN.vtu``, quads), every ``interval`` strain,
    with ``.pvd`` collections written by :meth:`close`. Lengths in units of R (velocity in R shear_rate)."""

    def __init__(self, directory: Path, interval: float):
        self.directory = Path(directory)
        self.interval = float(interval)

    def __call__(self, row: dict, run: ShearRun) -> None:
        index = round(row["strain"] / self.interval)
        if abs(row["strain"] - index * self.interval) > 0.5 * run.record_interval:
            return
        self.write(index, run)

    def write(self, index: int, run: ShearRun) -> None:
        import meshio

        self.directory.mkdir(parents=True, exist_ok=True)
        mesh = run.cell.mesh
        x = run.system.positions_in_radii()
        cell_type = {1: "tetra", 2: "tetra10"}[mesh.order]
        meshio.Mesh(
            x, [(cell_type, mesh.elements)], point_data={"displacement": x - mesh.nodes - run._centre0},
            cell_data={"stiffness_ratio": [run.cell.youngs_moduli], "region": [mesh.region.astype(np.int32)]},
        ).write(self.directory / f"cell_{index:04d}.vtu")
        lattice = run.system.lattice
        nx, ny, nz = lattice.shape
        k = int(np.clip(round(float(np.mean(run.system.positions[:, 2]))) % nz, 0, nz - 1))
        u = lattice.velocity()[:, :, :, k] / (run.units.shear_rate * run.units.radius)  # (3, nx, ny)
        gx, gy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
        points = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, k)]).astype(float) / run.units.radius
        ids = np.arange(nx * ny).reshape(nx, ny)
        quads = np.column_stack([ids[:-1, :-1].ravel(), ids[1:, :-1].ravel(), ids[1:, 1:].ravel(), ids[:-1, 1:].ravel()])
        meshio.Mesh(points, [("quad", quads)], point_data={"velocity": u.reshape(3, -1).T}).write(
            self.directory / f"fluid_{index:04d}.vtu")

    def close(self, run: ShearRun) -> None:
        if not self.directory.exists():
            return
        for stem in ("cell", "fluid"):
            files = sorted(self.directory.glob(f"{stem}_*.vtu"))
            entries = [
                f'    <DataSet timestep="{int(f.stem.split("_")[1]) * self.interval:.8g}" group="" part="0" '
                f'file="{f.name}"/>' for f in files
            ]
            (self.directory / f"{stem}.pvd").write_text(
                '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")


def plot_taylor_deformation(path: Path, series: dict, summary: dict, title: str = "") -> None:
    """D and the inclination against strain, with the stationary mean over the averaging window."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (top, bottom) = plt.subplots(2, 1, figsize=(6.5, 5.5), sharex=True, constrained_layout=True)
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
    bottom.set_xlabel(r"strain $\dot\gamma t$")
    for axis in (top, bottom):
        axis.grid(alpha=0.3)
    if title:
        top.set_title(title, fontsize=9)
    figure.savefig(path, dpi=130)
    plt.close(figure)


def _progress_bar(enabled: bool):
    from contextlib import nullcontext

    if not enabled:
        return nullcontext(None)
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    return Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("strain {task.completed:.2f}"),
                    TextColumn("D {task.fields[d]:.4f}"), TimeElapsedColumn(), TimeRemainingColumn())


# =========================================================================== API
def shear(
    out: str | Path,
    capillary_number: float,
    cell=None,
    equivalent: bool = False,
    resolution: float | None = None,
    duration: float = 6.0,
    resume: bool = False,
    progress: bool = True,
    wall_clock: float | None = None,
    stationary_tolerance: float | None = None,
    record_interval: float = 0.05,
    checkpoint_every: int = 20,
    vtk_interval: float | None = 1.0,
    flow_options: dict | None = None,
    capillary_number_modulus: str = "reference",
    **cell_options,
) -> dict:
    """A cell in plane Couette flow; writes ``out/timeseries.csv``, ``summary.json``,
    ``taylor_deformation.png``, ``vtk/`` and ``checkpoint.npz``; returns the summary.

    capillary_number: Ca = eta shear_rate / mu_c (mu_eff = gamma_eff mu_c with ``equivalent``).
    cell: :class:`~elastocell.parameters.CellParameters` or the CELL OPTIONS of ``cell_parameters``; without
    an explicit mesh size the mesh is uniform with edges of 2 dx (``flow.shear_mesh_size``) and linear
    tetrahedra (``element="p1"``) unless another element is given.
    capillary_number_modulus: "reference" (Ca against the simulated cell's mu: mu_eff with ``equivalent``) or
    "mu_c" (Ca against the described cell's mu_c, as physical eta, shear rate and E_c give it; with
    ``equivalent`` the run then uses Ca_eff = Ca / gamma_eff, the same physical shear rate).
    resolution: R/dx (default 8). duration: strain shear_rate * t. resume: continue from
    ``out/checkpoint.npz`` (same options) if it exists. flow_options: further :class:`ShearFlowParameters`.
    """
    from .api import _describe, _vtk_enabled, cell_parameters
    from .cell import Cell
    from .io import Stopwatch, software_versions, write_json, write_table

    if cell is not None and cell_options:
        raise ParameterError("cell", f"give either cell= or cell options, not both ({', '.join(cell_options)})")
    flow_options = dict(flow_options or {})
    if resolution is not None:
        flow_options["resolution"] = resolution
    params = ShearFlowParameters(capillary_number=capillary_number, **flow_options)
    stop = StopCriteria(duration=duration, wall_clock=wall_clock, stationary_tolerance=stationary_tolerance)
    if vtk_interval is not None and not vtk_interval > 0:
        raise ParameterError("vtk_interval", f"must be > 0 (strain), got {vtk_interval}")
    if cell is None:
        from .flow import shear_mesh_size

        cell_options.setdefault("element", "p1")
        if cell_options.get("mesh_size") is None:
            cell_options["mesh_size"] = shear_mesh_size(params.resolution)
        if cell_options.get("pole_size") is None:  # uniform: no plate contacts to refine for
            cell_options["pole_size"] = cell_options["mesh_size"]
        cell = cell_parameters(**cell_options)
    clock = Stopwatch()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    body = Cell.from_parameters(cell)
    if capillary_number_modulus not in ("reference", "mu_c"):
        raise ParameterError("capillary_number_modulus", f"must be 'reference' or 'mu_c', got {capillary_number_modulus!r}")
    capillary_number_mu_c = capillary_number if capillary_number_modulus == "mu_c" else None
    if equivalent:
        body = body.equivalent()
        if capillary_number_modulus == "mu_c":  # same physical shear rate: Ca_eff = eta shear_rate / mu_eff
            capillary_number = capillary_number / body.effective_stiffness_ratio
            params = ShearFlowParameters(**{**params.model_dump(), "capillary_number": capillary_number})
    run = ShearRun(body, params, record_interval=record_interval)
    checkpoint = out / "checkpoint.npz"
    resumed = False
    if resume and checkpoint.exists():
        run.load(checkpoint)
        resumed = True
    observers = []
    vtk = VTKWriter(out / "vtk", vtk_interval) if vtk_interval is not None and _vtk_enabled() else None
    if vtk is not None:
        observers.append(vtk)
        if not resumed:
            vtk.write(0, run)

    def write_series(row, current):
        if (current.n_records - 1) % checkpoint_every == 0:
            write_table(out / "timeseries.csv", current.arrays())

    observers.append(write_series)
    label = "homogeneous equivalent" if equivalent else _describe(cell)
    with _progress_bar(progress) as bar:
        if bar is not None:
            task = bar.add_task(f"shear Ca={capillary_number:g}", total=duration, completed=run.strain,
                                d=run.series["taylor_deformation"][-1])
            observers.append(lambda row, current: bar.update(task, completed=row["strain"],
                                                             d=row["taylor_deformation"]))
        try:
            run.run(stop, observers=tuple(observers), checkpoint=checkpoint, checkpoint_every=checkpoint_every)
        except FlowError:
            write_table(out / "timeseries.csv", run.arrays())  # keep every record up to the failure
            raise
    series = run.arrays()
    write_table(out / "timeseries.csv", series)
    summary = {"scenario": "shear", "label": label}
    summary.update(run.summary())
    summary.update({
        "effective_stiffness_ratio": body.effective_stiffness_ratio,
        "reference_modulus": "mu_eff" if equivalent else "mu_c",
        "capillary_number_mu_c": capillary_number_mu_c if capillary_number_mu_c is not None else (
            capillary_number * body.effective_stiffness_ratio if equivalent else capillary_number),
        "resumed": resumed,
        "wall_time_s": clock.elapsed,
        "cell": cell.model_dump(mode="json"),
        "flow": params.model_dump(mode="json"),
        "mesh": {**body.mesh.counts(), "element_order": body.mesh.order},
        "software": software_versions(),
    })
    write_json(out / "summary.json", summary)
    plot_taylor_deformation(out / "taylor_deformation.png", series, summary,
                            title=f"{label}, Ca = {capillary_number:g}, R/dx = {params.resolution:g}")
    if vtk is not None:
        vtk.close(run)
    return summary
