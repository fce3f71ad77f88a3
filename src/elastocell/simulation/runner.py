"""The simulation runner shared by the flow scenarios.

A :class:`FlowRun` owns one coupled system and its recorded time series. :meth:`FlowRun.run` advances it in
compiled chunks of one record interval each and, between chunks only (Python never loops over nodes or
lattice cells):

* records the observables (one row of the time series, measured by the scenario);
* guards the state: an inverted element or non-finite populations (raised by the compiled steps), the cell
  within the kernel support of a wall, non-finite fluid or a Mach number above the limit stop the run with a
  :class:`~elastocell.coupling.markers.FlowError` whose message names the likely cause and the parameter to
  change;
* calls the observers ``observer(row, run)`` (output writers, progress);
* checks the stop criteria (:class:`StopCriteria`: duration in the scenario's time unit, wall-clock limit,
  stationary running mean of a named observable);
* writes a checkpoint every ``checkpoint_every`` records: the complete state in one ``.npz`` written to a
  temporary file and moved into place (atomic: a kill leaves the previous checkpoint intact). A run resumed
  from it repeats the lost records exactly (the compiled steps are deterministic).

A scenario is a thin subclass (:class:`elastocell.scenarios.shear.ShearRun`,
:class:`elastocell.scenarios.pipe.PipeRun`): lattice setup, time unit, columns, how a row is measured, its
wall guard, VTK slice and summary.
"""

from __future__ import annotations

import math
import os
import signal
import threading
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from elastocell.coupling.immersed import ImmersedCell
from elastocell.coupling.markers import FlowError
from elastocell.files import array_digest, parameter_hash, replace_atomically
from elastocell.parameters.units import ParameterError
from elastocell.simulation.directory import waiting_while_in_use

TYPICAL_UPDATE_RATE = 2.5e7
"""Lattice updates per second of the fused CPU kernels on a 2-core machine (the order ``validation/lattice.py``
measures), for the cost estimate a run is warned about."""

FASTEST_UPDATE_RATE = 3e9
"""Lattice updates per second of a large GPU (JAX backend), the most optimistic rate: a run that would need more
than a year even there is refused."""


def check_run_cost(lattice_updates: float, parameter: str = "duration") -> float:
    """Refuse a run that would take more than a year even at :data:`FASTEST_UPDATE_RATE`, warn about one that
    takes more than a day at :data:`TYPICAL_UPDATE_RATE`; returns the typical estimate (s)."""
    typical = lattice_updates / TYPICAL_UPDATE_RATE
    if lattice_updates / FASTEST_UPDATE_RATE > 365 * 86400:
        raise ParameterError(parameter, f"the run needs {lattice_updates:.2g} lattice updates: about "
                                        f"{typical / (365 * 86400):.3g} years on a CPU and more than a year on "
                                        "any GPU; shorten it or lower the resolution")
    if typical > 86400:
        warnings.warn(f"the run needs {lattice_updates:.2g} lattice updates: about {typical / 86400:.3g} days at "
                      f"{TYPICAL_UPDATE_RATE:.2g} updates/s (a 2-core CPU)", stacklevel=3)
    return typical


def check_record_interval(duration: float, record_interval: float, unit: str,
                          hint: str = "give a shorter --record-interval") -> None:
    """Refuse a ``duration`` shorter than one ``record_interval`` (both in ``unit``): a run advances record by
    record, so it would run a whole record interval, longer than it was asked to. ``hint``: what the user can do."""
    if math.isfinite(duration) and math.isfinite(record_interval) and 0 < duration < record_interval:
        raise ParameterError("duration", f"must be at least one record interval ({record_interval:g} {unit}): a run "
                             f"advances record by record; {hint}, got {duration:g}")


STATIONARY_DRIFT_TOLERANCE = 1e-3
"""Relative drift of a window's mean below which it counts as stationary however few records it has; the
default ``stationary_tolerance`` of the runners' stop criterion is the same fraction."""


def stationarity(values, tolerance: float = STATIONARY_DRIFT_TOLERANCE) -> dict:
    """Is the averaging window stationary? The drift is the difference between the means of its second and first
    halves. It is compared with the noise of those means, 3 sqrt(s1^2/n1 + s2^2/n2) (a series that only
    fluctuates drifts by about one such standard error), and with ``tolerance`` |mean| (a drift that small does not
    matter): the window is stationary when the drift is below the larger of the two. A series still rising
    linearly over the window drifts by sqrt(3 n) standard errors (n records), so it is not called stationary
    from 4 records on unless its rise stays below ``tolerance``.

    Returns ``{"stationary": bool, "drift": second-half mean - first-half mean, "drift_limit": the bound}``;
    fewer than 4 records give ``stationary: False`` (nothing to judge)."""
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    if values.size < 4:
        return {"stationary": False, "drift": float("nan"), "drift_limit": float("nan")}
    first, second = np.array_split(values, 2)
    drift = float(second.mean() - first.mean())
    noise = 3.0 * math.sqrt(first.var(ddof=1) / first.size + second.var(ddof=1) / second.size)
    limit = max(noise, tolerance * abs(float(values.mean())))
    return {"stationary": bool(abs(drift) <= limit), "drift": drift, "drift_limit": float(limit)}


def window_verdict(series: dict, keep, observables) -> dict:
    """The stationarity of each named observable over the records ``keep``, and ``stationary``: all of them.
    Keys: ``stationary``, ``stationary_observables`` (name -> {stationary, drift, drift_limit})."""
    verdicts = {name: stationarity(np.asarray(series[name])[keep]) for name in observables}
    return {"stationary": all(v["stationary"] for v in verdicts.values()), "stationary_observables": verdicts}


def stationary_summary(series: dict, transient: float) -> dict:
    """Mean and standard deviation of the observables over strain >= transient."""
    strain = np.asarray(series["strain"])
    keep = strain >= transient
    out = {"transient_strain": float(transient), "stationary_records": int(keep.sum())}
    for name in ("taylor_deformation", "inclination_deg", "volume_change"):
        values = np.asarray(series[name])[keep]
        out[f"{name}_mean"] = float(values.mean()) if values.size else float("nan")
        out[f"{name}_std"] = float(values.std()) if values.size else float("nan")
    out["volume_change_max_abs"] = float(np.abs(series["volume_change"]).max())
    return out

CHECKPOINT_VERSION = 6
"""Version of the checkpoint layout and of what its fingerprint (:meth:`FlowRun.fingerprint`) hashes; raised when
the state a checkpoint holds, or how a run continues from it, changes for the same parameters (5: a quadratic
cell's pipe outline is its elements' own surface, so that a resumed series does not switch outline; 6: the pipe's
series has the column outline_fallback). Columns a scenario adds later without raising it are its
``FlowRun.ADDED_COLUMNS``: a checkpoint without them loads, NaN in them for its records."""


class _StopAtRecord:
    """While a run records, SIGINT and SIGTERM only note that a stop was asked for; the run then ends at the next
    record boundary with a checkpoint of that record, so an interruption loses only the record in progress.
    Outside the main thread (a Dask worker) signals are left alone."""

    def __enter__(self):
        self.received = None
        self.previous = {}
        if threading.current_thread() is threading.main_thread():
            for number in (signal.SIGINT, signal.SIGTERM):
                self.previous[number] = signal.signal(number, self._note)
        return self

    def _note(self, number, frame):
        if self.received is not None:  # a second signal: stop now
            raise KeyboardInterrupt(f"signal {number}")
        self.received = number

    def __exit__(self, *exc):
        for number, handler in self.previous.items():
            signal.signal(number, handler)
        return False


OUTLINE_FALLBACK_OF = {"deformation": "outline_fallback", "projected_area": "outline_fallback",
                       "deformation_views": "outline_fallback_views", "projected_area_views": "outline_fallback_views"}
"""The column that says where a reading of the outline fell back to the nodes' hull (> 0 there)."""


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
        final value from strain 1 on). A reading of the cell's outline that fell back to the nodes' hull in either
        window (:data:`OUTLINE_FALLBACK_OF`: the pipe's deformation and projected area) is not stationary: the
        hull's reading is biased by the mesh's roughness, and one that switched to it can look flat while the
        smooth shape still drifts.
    hull_stop: stop ("hull") once every record of the last ``stationary_window`` read ``stationary_observable`` on
        the nodes' hull (after ``2 * stationary_window``): the outline can no longer be read smoothly at this
        resolution, and running on will not make the reading trustworthy (a look-up table's point, whose reading is
        then left out of the table).
    unit: the time unit, for messages.
    """

    duration: float = 10.0
    wall_clock: float | None = None
    stationary_tolerance: float | None = None
    stationary_observable: str = "taylor_deformation"
    stationary_window: float = 1.0
    unit: str = "strain"
    hull_stop: bool = False

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
        fallback = OUTLINE_FALLBACK_OF.get(self.stationary_observable)
        if fallback in series and np.any(np.asarray(series[fallback])[t > t[-1] - 2 * self.stationary_window] > 0):
            return False
        mean = last.mean()
        return abs(mean - before.mean()) <= self.stationary_tolerance * abs(mean)

    def read_on_hull(self, series: dict, time_column: str = "strain") -> bool:
        """Whether every record of the last ``stationary_window`` read ``stationary_observable`` on the nodes' hull
        (False before ``2 * stationary_window`` or for an observable not read on the outline)."""
        fallback = OUTLINE_FALLBACK_OF.get(self.stationary_observable)
        if fallback not in series:
            return False
        t = np.asarray(series[time_column])
        if t[-1] < 2 * self.stationary_window:
            return False
        window = np.asarray(series[fallback])[t > t[-1] - self.stationary_window]
        return bool(window.size and np.all(window > 0))

    def reached(self, series: dict) -> str:
        """A scenario's own end of the run (a subclass: e.g. the pipe's transit of a finite channel), named as the
        stop reason; "" to go on."""
        return ""


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
    ADDED_COLUMNS: tuple[str, ...] = ()
    """Columns of :attr:`COLUMNS` that a checkpoint of this :data:`CHECKPOINT_VERSION` may lack, written before they
    existed: loading it fills them with NaN for its records (the run continues; its later records have them)."""
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
        self.record_velocity = None  # the fluid velocity (3, nx, ny, nz; dx/dt) read by the last record's guards
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
        velocity = self.record_velocity = lattice.velocity()
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
        """Advance until a stop criterion holds; returns the reason ("duration", "wall_clock", "stationary", "hull"
        or the scenario's own, :meth:`StopCriteria.reached`).

        observers: ``observer(row, run)`` after every record. checkpoint: path of the ``.npz`` written every
        ``checkpoint_every`` records and when the run stops."""
        if checkpoint_every < 1:
            raise ParameterError("checkpoint_every", f"must be >= 1 record, got {checkpoint_every}")
        if stop.stationary_tolerance is not None and stop.stationary_observable not in self.COLUMNS:
            raise ParameterError("stationary_observable", f"must be one of {', '.join(self.COLUMNS[1:])}")
        session_start = time.perf_counter()
        n_target = int(math.ceil(stop.duration / self.record_interval - 1e-9))
        reason = "duration"
        with _StopAtRecord() as stop_signal:  # Ctrl-C/SIGTERM take effect after the record in progress
            while self.n_records - 1 < n_target:
                row = self.advance_record()
                for observer in observers:
                    observer(row, self)
                if checkpoint is not None and ((self.n_records - 1) % checkpoint_every == 0 or stop_signal.received):
                    self.save(checkpoint)
                if stop_signal.received:
                    raise KeyboardInterrupt(f"signal {stop_signal.received} at {self.time_column} {self.time:g}")
                if stop.reached(self.series):
                    reason = stop.reached(self.series)
                    break
                if stop.is_stationary(self.series, self.time_column):
                    reason = "stationary"
                    break
                if stop.hull_stop and stop.read_on_hull(self.series, self.time_column):
                    reason = "hull"
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
        """Hash of what a checkpoint must match (``files.parameter_hash`` with :data:`CHECKPOINT_VERSION`): the
        resolved flow parameters and cell parameters (mesh settings and quadrature degree included), the law,
        whether the body is the homogeneous equivalent, the lattice units, the steps per record, and the sha256
        of the mesh, the element moduli and the material constants the run was made with."""
        arrays = array_digest(self.cell.mesh.nodes, self.cell.mesh.elements,
                              np.asarray(self.cell.youngs_moduli, dtype=np.float64),
                              np.asarray(self.cell.material_parameters, dtype=np.float64))
        return parameter_hash(self.params, self.cell.parameters, {
            "law": self.cell.law.name, "equivalent": bool(self.cell.is_equivalent), "units": self.units.as_dict(),
            "steps_per_record": int(self.steps_per_record), "arrays": arrays},
            format_version=CHECKPOINT_VERSION)

    def save(self, path: str | Path) -> None:
        """Write the complete state to ``path`` atomically (``files.replace_atomically``)."""
        arrays = {
            "version": np.array(CHECKPOINT_VERSION), "fingerprint": np.array(self.fingerprint()),
            "backend": np.array(self.system.backend), **self.system.state_arrays(), "volume0": np.array(self.volume0),
            "elapsed": np.array(self.elapsed), "wall_time": np.array(self.wall_time_cumulative),
        }  # fmt: skip
        arrays.update(self._extra_state())
        for name, values in self.series.items():
            arrays[f"series_{name}"] = np.asarray(values, dtype=np.float64)

        def write(temporary: Path) -> None:
            with temporary.open("wb") as handle:  # a file object: np.savez would append .npz to the temporary name
                np.savez(handle, **arrays)

        replace_atomically(Path(path), write)

    def load(self, path: str | Path) -> None:
        """Restore the state saved by :meth:`save` (same cell, parameters and record interval). A damaged file
        (truncated, garbled, not a checkpoint, pickled objects) or a foreign one is a ParameterError naming
        ``resume`` and the file; nothing pickled is ever loaded."""
        try:
            self._load(path)
        except ParameterError as error:
            error.checkpoint = Path(path)  # which file cannot continue (a pair has one per run)
            raise
        except Exception as error:  # BadZipFile, EOFError, a missing array, wrong shapes, pickled objects
            refusal = ParameterError("resume", f"cannot continue from {path}: the file is damaged or not a checkpoint "
                                               f"of this run ({type(error).__name__}); delete it, or rerun without "
                                               "--resume to start again")
            refusal.checkpoint = Path(path)
            raise refusal from None

    def _load(self, path: str | Path) -> None:
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
            length = len(data[f"series_{self.time_column}"])
            self.series = {name: ([float(v) for v in data[f"series_{name}"]]
                                  if f"series_{name}" in data.files or name not in self.ADDED_COLUMNS
                                  else [float("nan")] * length) for name in self.COLUMNS}
            self._load_extra(data)


def resume_or_restart(simulate: Callable, out: Path, **options) -> dict:
    """``simulate(out=out, resume=True, **options)`` for a sweep's run directory (keyed by its options): continue
    from the checkpoint if it is there and compatible, otherwise (a checkpoint an older elastocell or another
    backend wrote) delete it and run from the start. Where the refusal names its file (``error.checkpoint``, as
    :meth:`load` sets it), only that file is deleted and the call resumed again, so that the other run of an
    extrapolated pair continues from its own checkpoint. ``--resume`` on the command line refuses such a
    checkpoint instead, because the user asked for that run to continue.

    A directory held by another run that looks alive is waited for (:func:`waiting_while_in_use`): on a
    cluster it is the lock of this same run on a node that died, until that lock goes stale."""
    out = Path(out)
    for _ in range(1 + sum(1 for _ in out.rglob("checkpoint.npz"))):
        try:
            return waiting_while_in_use(simulate, out=out, resume=True, **options)
        except ParameterError as error:
            if error.parameter != "resume":
                raise
            stale = getattr(error, "checkpoint", None)  # the file that cannot continue, where the run says so
            inside = stale is not None and Path(os.path.abspath(out)) in Path(os.path.abspath(stale)).parents
            if not inside or not (stale.is_file() or stale.is_symlink()):
                break
            stale.unlink()  # that file (a link itself, not its target) only: the other run of a pair keeps its own
    (out / "checkpoint.npz").unlink(missing_ok=True)
    return waiting_while_in_use(simulate, out=out, resume=False, **options)




