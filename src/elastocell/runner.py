"""The simulation runner shared by the flow scenarios, and the shear-flow entry point ``shear``.

A :class:`FlowRun` owns one coupled system (:class:`~elastocell.flow.ImmersedCell`) and its recorded time
series. :meth:`FlowRun.run` advances it in compiled chunks of one record interval each and, between
chunks only (Python never loops over nodes or lattice cells):

* records the observables (one row of the time series, measured by the scenario);
* guards the state: an inverted element or non-finite populations (raised by the compiled steps), the cell
  within the kernel support of a wall (the scenario's geometry), non-finite fluid or a Mach number above the
  limit stop the run with a :class:`~elastocell.flow.FlowError` whose message names the likely cause and the
  parameter to change;
* calls the observers ``observer(row, run)`` (output writers, progress);
* checks the stop criteria (:class:`StopCriteria`: duration in the scenario's time unit, wall-clock limit,
  stationary running mean of a named observable);
* writes a checkpoint every ``checkpoint_every`` records: the complete state (populations in the solver's
  own storage, force field, marker positions, series, scenario state such as the tank-treading tracker) in
  one ``.npz`` written to a temporary file and moved into place with ``os.replace`` (atomic: a kill leaves
  the previous checkpoint intact). A run resumed from it repeats the lost records exactly (the compiled
  steps are deterministic), so its time series equals an uninterrupted run's.

A scenario is a thin subclass: :class:`ShearRun` here (plane Couette flow, time in strain units) and
:class:`elastocell.pipe_flow.PipeRun` (capillary flow, time in units of 1/gdot_w). It defines the lattice setup
(``lattice_units``, ``setup``), the time unit, the columns and how a row is measured, its wall guard, the
VTK slice and its summary. :func:`run_in_directory`, :func:`directory_summary` and :class:`VTKWriter` write
the output directory every scenario shares (``timeseries.csv``, ``summary.json``, ``vtk/``,
``checkpoint.npz``, a progress bar).

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

CHECKPOINT_VERSION = 3
"""Version of the checkpoint layout and fingerprint (3: the fingerprint hashes the flow parameters with sorted
keys, and the coupled step reads the marker velocities from the LB sweep; 2026-12-02)."""


@dataclass(frozen=True)
class StopCriteria:
    """When a run stops (whichever comes first).

    duration: run length in the scenario's time unit ``unit`` (> 0): strain shear_rate * t for shear flow,
        gdot_w t for pipe flow.
    wall_clock: seconds of wall time in this process (None: no limit).
    stationary_tolerance: stop once the mean of ``stationary_observable`` (a column of the scenario) over the
        last ``stationary_window`` (time unit) differs from the mean over the window before by less than this
        fraction of it (None: off). Checked only after ``2 * stationary_window``. The default window (1 strain)
        is about twice the relaxation of D measured for the reference cell at Ca = 0.1 (D within 1 % of its
        final value from strain 1 on).
    unit: the time unit, for messages.
    """

    duration: float = 10.0
    wall_clock: float | None = None
    stationary_tolerance: float | None = None
    stationary_observable: str = "taylor_deformation"
    stationary_window: float = 1.0
    unit: str = "strain"

    def __post_init__(self):
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise ParameterError("duration", f"must be > 0 ({self.unit}), got {self.duration}")
        if self.wall_clock is not None and not self.wall_clock > 0:
            raise ParameterError("wall_clock", f"must be > 0 seconds, got {self.wall_clock}")
        if self.stationary_tolerance is not None and not self.stationary_tolerance > 0:
            raise ParameterError("stationary_tolerance", f"must be > 0, got {self.stationary_tolerance}")
        if not self.stationary_window > 0:
            raise ParameterError("stationary_window", f"must be > 0 ({self.unit}), got {self.stationary_window}")

    def is_stationary(self, series: dict, time_column: str = "strain") -> bool:
        if self.stationary_tolerance is None:
            return False
        t = np.asarray(series[time_column])
        if t[-1] < 2 * self.stationary_window:
            return False
        values = np.asarray(series[self.stationary_observable])
        last = values[t > t[-1] - self.stationary_window]
        before = values[(t > t[-1] - 2 * self.stationary_window) & (t <= t[-1] - self.stationary_window)]
        if not (last.size and before.size):
            return False
        mean = last.mean()
        return abs(mean - before.mean()) <= self.stationary_tolerance * abs(mean)


class FlowRun:
    """A cell in a flow, advanced record by record (see the module docstring); base of the scenarios.

    A subclass sets :attr:`COLUMNS` (the first one is the time), :attr:`TIME_UNIT`, :attr:`RATE`,
    :attr:`DRIVING` (the parameter that sets the flow strength, named by the guards), the record-interval
    bounds, :attr:`PROGRESS` and defines ``lattice_units(cell, params)``, ``setup(cell, params, units)``,
    :meth:`_start` (reference state and the first record), :meth:`_measure` (a row
    after a chunk), :meth:`_check_walls`, :meth:`vtk_origin`, :meth:`vtk_slice` and ``summary``; optionally
    :meth:`_extra_state`/:meth:`_load_extra` for scenario state in the checkpoint.
    """

    COLUMNS: tuple[str, ...] = ()
    TIME_UNIT = "strain"
    WHEN = "strain {:.3g}"
    """How the guards name the moment of a failure (formatted with the current time)."""
    DRIVING = "capillary_number"
    RATE = "shear_rate"
    """The units' attribute holding the rate that makes time dimensionless (1/dt)."""
    DEFAULT_RECORD_INTERVAL = 0.05
    MAX_RECORD_INTERVAL: float | None = None
    RECORD_NOTE = ""
    PROGRESS: tuple[str, str, str] = ("strain {task.completed:.2f}", "taylor_deformation", "D")
    """Progress bar: time column format, the column shown, its label."""

    def __init__(self, cell, params, record_interval: float | None = None, units=None):
        record_interval = self.DEFAULT_RECORD_INTERVAL if record_interval is None else record_interval
        limit = self.MAX_RECORD_INTERVAL
        if not (math.isfinite(record_interval) and record_interval > 0 and (limit is None or record_interval <= limit)):
            bounds = "> 0" if limit is None else f"in (0, {limit:g}]"
            raise ParameterError("record_interval", f"must be {bounds} ({self.TIME_UNIT}{self.RECORD_NOTE}), "
                                 f"got {record_interval}")
        self.cell = cell
        self.params = params
        self.units = self.lattice_units(cell, params) if units is None else units
        self.system: ImmersedCell = self.setup(cell, params, self.units)
        self.steps_per_record = max(1, int(round(record_interval * self.steps_per_time)))
        self.record_interval = self.steps_per_record * self.time_per_step
        mesh = cell.mesh
        self._nucleus_mask = (mesh.region == 1) if bool((mesh.region == 1).any()) else None
        self.series: dict[str, list] = {name: [] for name in self.COLUMNS}
        self.elapsed = 0.0  # wall seconds spent advancing, over all sessions (checkpointed)
        self.session_elapsed = 0.0  # the same in this session only
        self.wall_time_before = 0.0  # wall seconds of the earlier sessions, up to their last checkpoint
        self._session_start = time.perf_counter()
        self.stop_reason = ""
        self._start()

    # ------------------------------------------------------------------ scenario hooks
    lattice_units: Callable
    setup: Callable

    @property
    def time_per_step(self) -> float:
        """The scenario's time per LB step: its rate (``units.<RATE>``, 1/dt) times dt."""
        return getattr(self.units, self.RATE)

    @property
    def steps_per_time(self) -> float:
        return 1.0 / self.time_per_step

    def _start(self) -> None:
        """Reference state (undeformed volume, ...) and the first record."""
        raise NotImplementedError

    def _measure(self) -> dict:
        """The row of every column after a chunk."""
        raise NotImplementedError

    def _check_walls(self) -> None:
        """Raise FlowError when the cell is within the kernel support of a wall."""

    def vtk_origin(self, x: np.ndarray) -> np.ndarray:
        """Origin of the displacement written to the cell snapshots (units of R)."""
        raise NotImplementedError

    def vtk_slice(self) -> tuple[int, float]:
        """(z index of the fluid slice, velocity unit in dx/dt) of the VTK fluid snapshots."""
        raise NotImplementedError

    def _extra_state(self) -> dict:
        return {}

    def _load_extra(self, data) -> None:
        pass

    # ------------------------------------------------------------------ state
    @property
    def time_column(self) -> str:
        return self.COLUMNS[0]

    @property
    def time(self) -> float:
        """Current time in the scenario's unit."""
        return self.system.time_step * self.time_per_step

    @property
    def n_records(self) -> int:
        return len(self.series[self.time_column])

    @property
    def wall_time_cumulative(self) -> float:
        """Wall seconds of this session (since the run was built) plus the earlier sessions'."""
        return self.wall_time_before + time.perf_counter() - self._session_start

    def _append(self, row: dict) -> dict:
        for name in self.COLUMNS:
            self.series[name].append(float(row[name]))
        return row

    # ------------------------------------------------------------------ guards
    def _check(self) -> None:
        """Guards between chunks: the cell near a wall, non-finite fluid, Mach number above its limit."""
        self._check_walls()
        lattice = self.system.lattice
        velocity = lattice.velocity()
        speed = float(np.sqrt(np.einsum("a...,a...->...", velocity, velocity)).max())
        when = self.WHEN.format(self.time)
        if not math.isfinite(speed):
            raise FlowError(
                f"the fluid became non-finite at {when}: the elastic forces are too stiff for the time step; "
                f"lower reynolds_number (the lattice shear rate) or raise {self.DRIVING}"
            )
        limit = lattice.params.velocity_limit
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
        row = self._append(self._measure())
        spent = time.perf_counter() - t0
        self.elapsed += spent
        self.session_elapsed += spent
        return row

    def run(self, stop: StopCriteria, observers: tuple[Callable, ...] = (), checkpoint: str | Path | None = None,
            checkpoint_every: int = 20) -> str:
        """Advance until a stop criterion holds; returns the reason ("duration", "wall_clock", "stationary").

        observers: ``observer(row, run)`` after every record. checkpoint: path of the ``.npz`` written every
        ``checkpoint_every`` records and when the run stops."""
        if checkpoint_every < 1:
            raise ParameterError("checkpoint_every", f"must be >= 1 record, got {checkpoint_every}")
        if stop.stationary_tolerance is not None and stop.stationary_observable not in self.COLUMNS:
            raise ParameterError("stationary_observable", f"must be one of {', '.join(self.COLUMNS[1:])}")
        session_start = time.perf_counter()
        n_target = int(math.ceil(stop.duration / self.record_interval - 1e-9))
        reason = "duration"
        while self.n_records - 1 < n_target:
            row = self.advance_record()
            for observer in observers:
                observer(row, self)
            if checkpoint is not None and (self.n_records - 1) % checkpoint_every == 0:
                self.save(checkpoint)
            if stop.is_stationary(self.series, self.time_column):
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

    def run_summary(self) -> dict:
        """What every scenario reports about the run itself: steps, stop reason, timings, lattice."""
        return {
            "steps": int(self.system.time_step),
            "stop_reason": self.stop_reason,
            "time_stepping_s": self.elapsed,
            "time_stepping_session_s": self.session_elapsed,
            "lattice": self.units.as_dict(),
            "reynolds_number": self.units.reynolds_number,
            "backend": self.system.backend,
            "device": getattr(self.system.lattice, "device", "cpu"),
        }

    # ------------------------------------------------------------------ checkpoints
    def fingerprint(self) -> str:
        """Hash of what a checkpoint must match: flow parameters, lattice units, mesh, moduli and law."""
        digest = hashlib.sha256()
        digest.update(json.dumps(self.params.model_dump(mode="json"), sort_keys=True).encode())
        digest.update(json.dumps(self.units.as_dict(), sort_keys=True, default=float).encode())
        digest.update(np.ascontiguousarray(self.cell.mesh.nodes).tobytes())
        digest.update(np.ascontiguousarray(self.cell.mesh.elements).tobytes())
        digest.update(np.ascontiguousarray(self.cell.youngs_moduli, dtype=np.float64).tobytes())
        digest.update(self.cell.law.name.encode())
        digest.update(np.ascontiguousarray(self.cell.material_parameters, dtype=np.float64).tobytes())
        degree = self.cell.parameters.mesh.quadrature_degree
        if degree not in (None, 2):  # the default keeps older fingerprints
            # degrees 4-5 changed rule in session 18 (14 points -> 25 with the nodes): not the same run
            digest.update(f"quadrature {degree}{' nodal 25' if degree in (4, 5) else ''}".encode())
        digest.update(str(self.steps_per_record).encode())
        return digest.hexdigest()

    def save(self, path: str | Path) -> None:
        """Write the complete state to ``path`` atomically (temporary file, then ``os.replace``)."""
        path = Path(path)
        arrays = {
            "version": np.array(CHECKPOINT_VERSION), "fingerprint": np.array(self.fingerprint()),
            "backend": np.array(self.system.backend), **self.system.state_arrays(), "volume0": np.array(self.volume0),
            "elapsed": np.array(self.elapsed), "wall_time": np.array(self.wall_time_cumulative),
        }  # fmt: skip
        arrays.update(self._extra_state())
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
            if int(data["version"]) != CHECKPOINT_VERSION:
                raise ParameterError("resume", f"{path} was written by another elastocell version: rerun without "
                                     "--resume")
            backend = str(data["backend"])
            if backend != self.system.backend:
                raise ParameterError(
                    "resume", f"{path} was written by the {backend} backend: resume with --backend {backend}"
                )
            if str(data["fingerprint"]) != self.fingerprint():
                raise ParameterError(
                    "resume", f"{path} was written for other cell or flow parameters: rerun without --resume "
                    "or with the original options",
                )
            self.system.load_state_arrays(data)
            self.volume0 = float(data["volume0"])
            self.elapsed = float(data["elapsed"])
            self.wall_time_before = float(data["wall_time"]) if "wall_time" in data.files else self.elapsed
            self._session_start = time.perf_counter()
            self.series = {name: [float(v) for v in data[f"series_{name}"]] for name in self.COLUMNS}
            self._load_extra(data)


class ShearRun(FlowRun):
    """A cell in plane Couette flow (time in strain units shear_rate * t).

    cell: :class:`~elastocell.cell.Cell` (its equivalent for an equivalent run); params: the flow;
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
        self._centre0 = self.units.centre / self.units.radius
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
        out["tank_treading_frequency"] = -self.tracker.angular_velocity(start=transient)
        out["duration_strain"] = end
        out.update(self.run_summary())
        out["wall_time_per_strain_s"] = self.elapsed / end if end > 0 else float("nan")
        out["record_interval_strain"] = self.record_interval
        return out


# =========================================================================== output directory
class VTKWriter:
    """Cell snapshots (``vtk/cell_NNNN.vtu``: displacement, stiffness ratio, region) and the fluid velocity
    on the x-y plane of :meth:`FlowRun.vtk_slice` (``vtk/fluid_NNNN.vtu``, quads, with the solid mask when
    the lattice has one), every ``interval`` (the scenario's time unit), with ``.pvd`` collections written by
    :meth:`close`. Lengths in units of R, velocity in the scenario's unit.

    :meth:`start` removes the snapshots a previous run left in the directory beyond the current time (all of
    them on a fresh start), so that the collections list this run's snapshots only."""

    def __init__(self, directory: Path, interval: float):
        self.directory = Path(directory)
        self.interval = float(interval)

    def _snapshots(self, stem: str) -> list[tuple[int, Path]]:
        found = []
        for path in self.directory.glob(f"{stem}_*.vtu"):
            index = path.stem.split("_", 1)[1]
            if index.isdigit():
                found.append((int(index), path))
        return sorted(found)

    def start(self, run: FlowRun, resumed: bool) -> None:
        """Clear stale snapshots (later than the run's current time) and write the first one on a fresh start."""
        if self.directory.exists():
            for stem in ("cell", "fluid"):
                for index, path in self._snapshots(stem):
                    if index * self.interval > run.time + 0.5 * run.record_interval:
                        path.unlink()
        if not resumed:
            self.write(0, run)

    def __call__(self, row: dict, run: FlowRun) -> None:
        t = row[run.time_column]
        index = round(t / self.interval)
        if abs(t - index * self.interval) > 0.5 * run.record_interval:
            return
        self.write(index, run)

    def write(self, index: int, run: FlowRun) -> None:
        import meshio

        from .io import VTK_CELL_TYPE

        self.directory.mkdir(parents=True, exist_ok=True)
        mesh = run.cell.mesh
        x = run.system.positions_in_radii()
        meshio.Mesh(
            x, [(VTK_CELL_TYPE[mesh.order], mesh.elements)], point_data={"displacement": x - mesh.nodes - run.vtk_origin(x)},
            cell_data={"stiffness_ratio": [run.cell.youngs_moduli], "region": [mesh.region.astype(np.int32)]},
        ).write(self.directory / f"cell_{index:04d}.vtu")
        lattice = run.system.lattice
        nx, ny, nz = lattice.shape
        k, velocity_unit = run.vtk_slice()
        u = lattice.velocity()[:, :, :, k] / velocity_unit  # (3, nx, ny)
        gx, gy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
        points = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, k)]).astype(float) / run.units.radius
        ids = np.arange(nx * ny).reshape(nx, ny)
        quads = np.column_stack([ids[:-1, :-1].ravel(), ids[1:, :-1].ravel(), ids[1:, 1:].ravel(), ids[:-1, 1:].ravel()])
        point_data = {"velocity": u.reshape(3, -1).T}
        if lattice.solid is not None:
            point_data["solid"] = lattice.solid[:, :, k].ravel().astype(np.int32)
        meshio.Mesh(points, [("quad", quads)], point_data=point_data).write(self.directory / f"fluid_{index:04d}.vtu")

    def close(self, run: FlowRun | None = None) -> None:
        """Write ``cell.pvd`` and ``fluid.pvd`` listing the snapshots in the directory."""
        if not self.directory.exists():
            return
        for stem in ("cell", "fluid"):
            entries = [
                f'    <DataSet timestep="{index * self.interval:.8g}" group="" part="0" file="{path.name}"/>'
                for index, path in self._snapshots(stem)
            ]
            (self.directory / f"{stem}.pvd").write_text(
                '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")


def progress_bar(enabled: bool, time_format: str = "strain {task.completed:.2f}", label: str = "D"):
    """A rich progress bar showing the time and one observable (task field ``value``), or a null context."""
    from contextlib import nullcontext

    if not enabled:
        return nullcontext(None)
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    return Progress(TextColumn("{task.description}"), BarColumn(), TextColumn(time_format),
                    TextColumn(f"{label} {{task.fields[value]:.4f}}"), TimeElapsedColumn(), TimeRemainingColumn())


def flow_cell(cell, cell_options: dict, resolution: float):
    """The CellParameters of a flow run: ``cell`` or the CELL OPTIONS of ``cell_parameters``; without an
    explicit mesh size the mesh is uniform with edges of 2 dx (``flow.shear_mesh_size``) and linear
    tetrahedra (``element="p1"``) unless another element is given."""
    from .api import cell_parameters
    from .flow import shear_mesh_size

    if cell is not None and cell_options:
        raise ParameterError("cell", f"give either cell= or cell options, not both ({', '.join(cell_options)})")
    if cell is not None:
        return cell
    cell_options = dict(cell_options)
    cell_options.setdefault("element", "p1")
    if cell_options.get("mesh_size") is None:
        cell_options["mesh_size"] = shear_mesh_size(resolution)
    if cell_options.get("pole_size") is None:  # uniform: no plate contacts to refine for
        cell_options["pole_size"] = cell_options["mesh_size"]
    if cell_options.get("interface_size") is None:
        cell_options["interface_size"] = cell_options["mesh_size"]
    return cell_parameters(**cell_options)


def resume_or_restart(simulate: Callable, out: Path, **options) -> dict:
    """``simulate(out=out, resume=True, **options)`` for a sweep's run directory (keyed by its options): continue
    from the checkpoint if it is there and compatible, otherwise (a checkpoint an older elastocell or another
    backend wrote) delete it and run from the start. ``--resume`` on the command line refuses such a checkpoint
    instead, because the user asked for that run to continue."""
    try:
        return simulate(out=out, resume=True, **options)
    except ParameterError as error:
        if error.parameter != "resume":
            raise
    (Path(out) / "checkpoint.npz").unlink(missing_ok=True)
    return simulate(out=out, resume=False, **options)


def run_in_directory(run: FlowRun, out: Path, stop: StopCriteria, *, resume: bool, progress: bool,
                     description: str, checkpoint_every: int = 20,
                     vtk_interval: float | None = 1.0) -> tuple[bool, VTKWriter | None]:
    """Drive ``run`` to ``stop`` with the outputs every scenario writes: ``out/checkpoint.npz`` (resumed from
    when ``resume`` and it exists), ``out/timeseries.csv`` (rewritten at every checkpoint, and with every
    record up to a failure), VTK snapshots every ``vtk_interval`` and a progress bar. Returns (resumed, the
    VTK writer or None); the caller writes the summary and closes the writer."""
    from .api import _vtk_enabled
    from .io import write_table

    if vtk_interval is not None and not vtk_interval > 0:
        raise ParameterError("vtk_interval", f"must be > 0 ({run.TIME_UNIT}), got {vtk_interval}")
    checkpoint = out / "checkpoint.npz"
    resumed = bool(resume and checkpoint.exists())
    if resumed:
        run.load(checkpoint)
    observers: list[Callable] = []
    vtk = VTKWriter(out / "vtk", vtk_interval) if vtk_interval is not None and _vtk_enabled() else None
    if vtk is not None:
        vtk.start(run, resumed)
        observers.append(vtk)

    def write_series(row, current):
        if (current.n_records - 1) % checkpoint_every == 0:
            write_table(out / "timeseries.csv", current.arrays())

    observers.append(write_series)
    time_format, column, label = run.PROGRESS
    with progress_bar(progress, time_format, label) as bar:
        if bar is not None:
            task = bar.add_task(description, total=stop.duration, completed=run.time, value=run.series[column][-1])
            observers.append(lambda row, current: bar.update(task, completed=row[current.time_column],
                                                             value=row[column]))
        try:
            run.run(stop, observers=tuple(observers), checkpoint=checkpoint, checkpoint_every=checkpoint_every)
        finally:
            write_table(out / "timeseries.csv", run.arrays())  # every record, also up to a failure
    return resumed, vtk


def directory_summary(run: FlowRun, body, cell, params, clock, resumed: bool, equivalent: bool) -> dict:
    """The summary entries every scenario writes after its own: the reference modulus, resume and wall
    times (``wall_time_s`` this session, ``wall_time_cumulative_s`` over the sessions of a resumed run,
    beside ``time_stepping_s``/``time_stepping_session_s`` of :meth:`FlowRun.run_summary`), the inputs
    and software versions."""
    from .io import software_versions

    return {
        "effective_stiffness_ratio": body.effective_stiffness_ratio,
        "reference_modulus": "mu_eff" if equivalent else "mu_c",
        "resumed": resumed,
        "wall_time_s": clock.elapsed,
        "wall_time_cumulative_s": run.wall_time_cumulative,
        "cell": cell.model_dump(mode="json"),
        "flow": params.model_dump(mode="json"),
        "mesh": {**body.mesh.counts(), "element_order": body.mesh.order},
        "software": software_versions(),
    }


def time_series_figure():
    """A figure of two panels sharing the time axis (the layout of the flow scenarios' plots)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (top, bottom) = plt.subplots(2, 1, figsize=(6.5, 5.5), sharex=True, constrained_layout=True)
    return figure, top, bottom


def save_time_series_figure(path: Path, figure, xlabel: str, title: str = "") -> None:
    """Label the time axis, grid both panels, title, write and close the figure of :func:`time_series_figure`."""
    import matplotlib.pyplot as plt

    top, bottom = figure.axes[:2]
    bottom.set_xlabel(xlabel)
    for axis in (top, bottom):
        axis.grid(alpha=0.3)
    if title:
        top.set_title(title, fontsize=9)
    figure.savefig(path, dpi=130)
    plt.close(figure)


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
    from .api import _describe
    from .cell import Cell
    from .io import Stopwatch, write_json

    flow_options = dict(flow_options or {})
    if resolution is not None:
        flow_options["resolution"] = resolution
    params = ShearFlowParameters(capillary_number=capillary_number, **flow_options)
    stop = StopCriteria(duration=duration, wall_clock=wall_clock, stationary_tolerance=stationary_tolerance)
    if vtk_interval is not None and not vtk_interval > 0:
        raise ParameterError("vtk_interval", f"must be > 0 (strain), got {vtk_interval}")
    if capillary_number_modulus not in ("reference", "mu_c"):
        raise ParameterError("capillary_number_modulus", f"must be 'reference' or 'mu_c', got {capillary_number_modulus!r}")
    cell = flow_cell(cell, cell_options, params.resolution)
    clock = Stopwatch()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    body = Cell.from_parameters(cell)
    capillary_number_mu_c = capillary_number if capillary_number_modulus == "mu_c" else None
    if equivalent:
        body = body.equivalent()
        if capillary_number_modulus == "mu_c":  # same physical shear rate: Ca_eff = eta shear_rate / mu_eff
            capillary_number = capillary_number / body.effective_stiffness_ratio
            params = ShearFlowParameters(**{**params.model_dump(), "capillary_number": capillary_number})
    run = ShearRun(body, params, record_interval=record_interval)
    resumed, vtk = run_in_directory(run, out, stop, resume=resume, progress=progress,
                                    description=f"shear Ca={capillary_number:g}", checkpoint_every=checkpoint_every,
                                    vtk_interval=vtk_interval)
    label = "homogeneous equivalent" if equivalent else _describe(cell)
    summary = {"scenario": "shear", "label": label}
    summary.update(run.summary())
    summary["capillary_number_mu_c"] = capillary_number_mu_c if capillary_number_mu_c is not None else (
        capillary_number * body.effective_stiffness_ratio if equivalent else capillary_number)
    summary.update(directory_summary(run, body, cell, params, clock, resumed, equivalent))
    write_json(out / "summary.json", summary)
    plot_taylor_deformation(out / "taylor_deformation.png", run.arrays(), summary,
                            title=f"{label}, Ca = {capillary_number:g}, R/dx = {params.resolution:g}")
    if vtk is not None:
        vtk.close(run)
    return summary
