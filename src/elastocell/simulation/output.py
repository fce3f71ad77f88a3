"""The output directory every flow run shares: ``timeseries.csv``, ``summary.json``, ``checkpoint.npz``,
VTK snapshots (``vtk/``, cell and fluid slice) for ParaView, time-series figures and the progress bar.
"""

from __future__ import annotations

import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from elastocell.body.mesh import CellMesh
from elastocell.files import save_figure, software_versions, write_table
from elastocell.parameters.units import ParameterError
from elastocell.simulation.runner import FlowRun, StopCriteria


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
            write_pvd(self.directory / f"{stem}.pvd",
                      [(index * self.interval, path.name) for index, path in self._snapshots(stem)])


def progress_bar(enabled: bool, time_format: str = "strain {task.completed:.2f}", label: str | None = "D"):
    """Progress of a long run: a rich progress bar showing the time and one observable (task field ``value``,
    none when ``label`` is None) on a terminal; elsewhere (a log file, a batch job, a pipe) one plain line at most
    every :data:`PLAIN_PROGRESS_INTERVAL` seconds and at the end; a null context when not ``enabled``."""
    from contextlib import nullcontext

    if not enabled:
        return nullcontext(None)
    if not sys.stderr.isatty():
        return PlainProgress(time_format, label)
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    columns = [TextColumn("{task.description}"), BarColumn(), TextColumn(time_format)]
    if label is not None:
        columns.append(TextColumn(f"{label} {{task.fields[value]:.4f}}"))
    return Progress(*columns, TimeElapsedColumn(), TimeRemainingColumn())


PLAIN_PROGRESS_INTERVAL = 10.0
"""Seconds between two progress lines when the output is not a terminal."""


class PlainProgress:
    """The part of rich's ``Progress`` the runs use (``add_task``, ``update``, a context), written as plain
    lines to standard error for output that is not a terminal: ``description: strain 1.20 of 6 (20 %), D 0.0623,
    34 s``."""

    def __init__(self, time_format: str, label: str | None, interval: float = PLAIN_PROGRESS_INTERVAL):
        self.time_format, self.label, self.interval = time_format, label, interval
        self.tasks: dict[int, dict] = {}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        for task_id in self.tasks:
            self.line(task_id)
        return False

    def add_task(self, description: str, total: float | None = None, completed: float = 0.0, **fields) -> int:
        task_id = len(self.tasks)
        self.tasks[task_id] = {"description": description, "total": total, "completed": completed,
                               "fields": fields, "start": time.perf_counter(), "printed": time.perf_counter()}
        return task_id

    def update(self, task_id: int, completed: float | None = None, **fields) -> None:
        task = self.tasks[task_id]
        if completed is not None:
            task["completed"] = completed
        task["fields"].update(fields)
        if time.perf_counter() - task["printed"] >= self.interval:
            self.line(task_id)

    def line(self, task_id: int) -> None:
        """Write the task's line now."""
        task = self.tasks[task_id]
        task["printed"] = time.perf_counter()

        class View:  # what rich's format strings read: task.completed, task.fields
            completed, fields = task["completed"], task["fields"]

        text = self.time_format.format(task=View)
        if task["total"]:
            text += f" of {task['total']:g} ({100 * task['completed'] / task['total']:.0f} %)"
        if self.label is not None and "value" in task["fields"]:
            text += f", {self.label} {task['fields']['value']:.4g}"
        print(f"{task['description']}: {text}, {time.perf_counter() - task['start']:.0f} s", file=sys.stderr,
              flush=True)


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
    save_figure(figure, path, dpi=130)
    plt.close(figure)


def vtk_enabled() -> bool:
    import os

    return os.environ.get("ELASTOCELL_NO_VTK", "") == ""


def von_mises(stress: np.ndarray) -> np.ndarray:
    deviator = stress - np.trace(stress, axis1=1, axis2=2)[:, None, None] * np.eye(3) / 3
    return np.sqrt(1.5 * np.sum(deviator * deviator, axis=(1, 2)))

VTK_CELL_TYPE = {1: "tetra", 2: "tetra10"}


def write_vtk_series(directory: Path, stem: str, mesh: CellMesh, positions: np.ndarray, times: np.ndarray,
                     cell_data: list[dict[str, np.ndarray]]) -> Path:
    """One ``.vtu`` per state plus a ``.pvd`` collection (time = the scenario's parameter, e.g. delta)."""
    import meshio

    directory.mkdir(parents=True, exist_ok=True)
    cell_type = VTK_CELL_TYPE[mesh.order]
    entries = []
    for index, (x, t, data) in enumerate(zip(positions, times, cell_data, strict=True)):
        name = f"{stem}_{index:04d}.vtu"
        displacement = x - mesh.nodes
        meshio.Mesh(
            x, [(cell_type, mesh.elements)], point_data={"displacement": displacement},
            cell_data={k: [v] for k, v in data.items()},
        ).write(directory / name)
        entries.append((float(t), name))
    collection = directory / f"{stem}.pvd"
    write_pvd(collection, entries)
    return collection


def write_pvd(path: Path, entries: list[tuple[float, str]]) -> None:
    """A ParaView ``.pvd`` collection of ``(time, file name)`` entries (files beside it)."""
    lines = [f'    <DataSet timestep="{t:.8g}" group="" part="0" file="{name}"/>' for t, name in entries]
    path.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                    + "\n".join(lines) + "\n  </Collection>\n</VTKFile>\n")


def run_in_directory(run: FlowRun, out: Path, stop: StopCriteria, *, resume: bool, progress: bool,
                     description: str, checkpoint_every: int = 20,
                     vtk_interval: float | None = 1.0) -> tuple[bool, VTKWriter | None]:
    """Drive ``run`` to ``stop`` with the outputs every scenario writes: ``out/checkpoint.npz`` (resumed from
    when ``resume`` and it exists), ``out/timeseries.csv`` (rewritten at every checkpoint, and with every
    record up to a failure), VTK snapshots every ``vtk_interval`` and a progress bar. Returns (resumed, the
    VTK writer or None); the caller writes the summary and closes the writer."""

    if vtk_interval is not None and not vtk_interval > 0:
        raise ParameterError("vtk_interval", f"must be > 0 ({run.TIME_UNIT}), got {vtk_interval}")
    checkpoint = out / "checkpoint.npz"
    resumed = bool(resume and checkpoint.exists())
    if resumed:
        run.load(checkpoint)
    observers: list[Callable] = []
    vtk = VTKWriter(out / "vtk", vtk_interval) if vtk_interval is not None and vtk_enabled() else None
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


def warn_if_not_stationary(summary: dict, out: Path) -> None:
    """One warning when the summary's averaging window is not stationary (its means describe a transient),
    naming the observables that drift and by how much against their bound."""
    if summary.get("stationary", True):
        return
    drifting = [f"{name} drifts by {v['drift']:.3g} (bound {v['drift_limit']:.3g})" if np.isfinite(v["drift"])
                else f"{name}: fewer than 4 records to judge"
                for name, v in summary.get("stationary_observables", {}).items() if not v["stationary"]]
    warnings.warn(f"{out / 'summary.json'}: the averaged window is not stationary ({'; '.join(drifting)}); its "
                  "means describe a transient: run longer (duration)", stacklevel=3)
