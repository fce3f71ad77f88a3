"""What a study is, how its runs execute (through Dask, resumable) and how their results become one tidy table.

A :class:`Study` declares its runs (scenario + options, exactly the keyword arguments of the Python API, so
every run is reproducible with ``elastocell compress/shear/pipe``), the figure drawn from its table, and the
paper's claims it tests. Runs are identified by their resolved parameters (:attr:`Run.run_id`), so that studies
sharing a run (the reference cell appears in four figures) compute it once, and a killed study resumes: a run
whose ``run.json`` exists is not repeated, an interrupted flow run continues from its checkpoint.

Directory layout of ``elastocell study run NAME --out DIR`` (and of ``reproduce``, which runs every study):
``DIR/runs/<run_id>/`` (the scenario's own files plus ``run.json``), ``DIR/<name>.parquet`` and ``.csv`` (one
tidy table), ``DIR/<name>.png`` and ``.pdf``, ``DIR/<name>.claims.json``, and ``DIR/report.md`` / ``.html``.
"""

from __future__ import annotations

import functools
import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from elastocell.api.compression import compress
from elastocell.api.pipe import pipe
from elastocell.api.resolved import resolved_parameters
from elastocell.api.shear import shear
from elastocell.body.cell import Cell
from elastocell.files import parameter_hash, replace_atomically, write_json
from elastocell.parameters.cell import CellParameters, cell_parameters
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.compression import CompressionError
from elastocell.scenarios.shear import compile_kernels
from elastocell.simulation.distributed import TaskFailure, run_tasks
from elastocell.simulation.extrapolation import coarse_resolution_of, part_directory
from elastocell.simulation.runner import resume_or_restart
from elastocell.solvers.stiffness_kernel import compile_kernel

RUN_FILE = "run.json"


RUN_ID_FORMAT = 1
"""Version of what a run directory holds for given resolved parameters; raised when a change of the code makes
the runs of a study differ for the same parameters. Not raised for the p2 corner contact rule
(``compression._surrounded``: F within 1.6e-5 for the reference cell, 6.7e-5 for a stiffness ratio of 10 on a
coarse mesh, validation/same_outputs.py); the stiff nucleus's refined mesh changes the resolved parameters, and so
the run ids, by itself."""


@functools.lru_cache(maxsize=4096)
def _identity(run: Run) -> tuple[dict | None, str]:
    """(the resolved parameters of ``run``, or None for options the API refuses; the hash of its id)."""
    try:
        resolved = resolved_parameters(run.scenario, run.kwargs)
    except (ValueError, TypeError):  # an impossible run keeps an id of its options and fails with its own message
        return None, parameter_hash({"scenario": run.scenario, "unresolved options": run.kwargs},
                                    format_version=RUN_ID_FORMAT)
    return resolved, parameter_hash(resolved, format_version=RUN_ID_FORMAT)


@dataclass(frozen=True)
class Run:
    """One simulation: ``scenario`` ("compress", "shear" or "pipe") and the API keyword arguments."""

    scenario: str
    options: tuple  # sorted (name, value) pairs: hashable, stable

    @classmethod
    def of(cls, scenario: str, **options) -> Run:
        clean = {k: (tuple(v) if isinstance(v, list) else v) for k, v in options.items()}
        return cls(scenario, tuple(sorted(clean.items())))

    @property
    def kwargs(self) -> dict:
        return dict(self.options)

    @property
    def run_id(self) -> str:
        """Readable and unique: the scenario, the cell, the driving, then 10 hex digits of the hash of the run's
        full resolved parameters (``api.resolved.resolved_parameters``: cell with its mesh and quadrature, the
        scenario's model, every option with its default) and :data:`RUN_ID_FORMAT`. Runs that resolve to the
        same parameters share the id whatever options they spell out."""
        resolved, digest = _identity(self)
        if resolved is None:
            return f"{self.scenario}-{digest[:10]}"
        cell, options = resolved["cell"], resolved["options"]
        nucleus = cell.nucleus
        parts = [self.scenario]
        if cell.random is not None:
            parts.append(f"random{cell.random.seed}")
        elif nucleus.shape == "none":
            parts.append("homogeneous")
        else:
            parts.append(f"g{nucleus.stiffness_ratio:g}")
        if cell.material.law == "mooney-rivlin":
            parts.append("mr")
        if cell.random is None and nucleus.shape != "none":
            if nucleus.offset:
                parts.append(f"off{nucleus.offset:g}{nucleus.offset_axis}")
            if nucleus.shape == "ellipsoid":
                parts.append(f"ell{nucleus.nucleus_axis}")
        if options.get("equivalent"):
            parts.append("eq")
        flow = resolved.get("flow")
        for name, short in (("capillary_number", "ca"), ("capillary_number_wall", "caw")):
            if flow is not None and hasattr(flow, name):
                parts.append(f"{short}{getattr(flow, name):g}")
        return "-".join(parts) + "-" + digest[:10]


@dataclass
class Member:
    """A run as a study sees it: the run and the labels that place it in the study's table and figure."""

    run: Run
    labels: dict


@dataclass
class Claim:
    """One statement of the paper beside what elastocell measured.

    verdict: "agree", "partly", "disagree", or "not measured" (with the reason in ``measured``); ``criterion``
    states the rule that turns the measurement into the verdict."""

    study: str
    claim: str
    source: str
    measured: str
    verdict: str
    criterion: str
    values: dict = field(default_factory=dict)
    discretisation: str = ""
    other_discretisations: dict = field(default_factory=dict)  # {name: {"verdict", "measured"}}


@dataclass
class Study:
    """A named study: its runs (full or quick), its figure and its claims, all from its tidy table."""

    name: str
    title: str
    figure: str  # the paper's figure label
    description: str
    members: Callable[[bool], list[Member]]
    table: Callable[[list[tuple[Member, dict]], Path, bool], object]  # (pairs, directory, quick) -> DataFrame
    plot: Callable[[object, Path, Path], list[Path]]  # (table, directory, out stem) -> files written
    claims: Callable[[object], list[Claim]] = lambda table: []
    by_discretisation: bool = False  # judge the claims on each discretisation of the table (compression)


# =========================================================================== executing one run
def execute_run(task: tuple[Run, str]) -> dict:
    """Run one simulation in ``runs/<run_id>`` (on a Dask worker); return its result record.

    A finished run (``run.json`` present) is read back, not repeated. Flow runs resume from their checkpoint.
    A compression curve that stops early keeps its converged rows (status "partial")."""
    run, runs_directory = task
    directory = Path(runs_directory) / run.run_id
    record_path = directory / RUN_FILE
    if record_path.exists():
        return json.loads(record_path.read_text())
    directory.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    options = run.kwargs
    record = {"run_id": run.run_id, "scenario": run.scenario, "options": options, "status": "complete",
              "error": None}
    if run.scenario == "compress":
        record.update(_execute_compression(directory, options))
    elif run.scenario in ("shear", "pipe"):
        record.update(_execute_flow(run.scenario, directory, options))
    else:
        raise ParameterError("scenario", f"unknown scenario {run.scenario!r}")
    record["wall_time_s"] = time.perf_counter() - start

    write_json(record_path, record)
    return record


def _execute_compression(directory: Path, options: dict) -> dict:

    out = {}
    try:
        summary = resume_or_restart(compress, directory, progress=False, **options)  # a lost run continues
    except CompressionError as error:
        summary = json.loads((directory / "metadata.json").read_text())
        out = {"status": "partial", "error": str(error).split(" (rows up to")[0]}
    table = np.genfromtxt(directory / "compression.csv", delimiter=",", names=True)
    solver = summary.get("solver", {})
    out.update({
        "effective_stiffness_ratio": summary["effective_stiffness_ratio"],
        "delta_reached": summary.get("delta_reached", float(table["delta"][-1])),
        "first_unstable_delta": solver.get("first_unstable_delta"),
        "nodes": summary["mesh"]["n_nodes"],
        "curve": {name: np.atleast_1d(table[name]).tolist()
                  for name in ("delta", "force_per_Ec_R2", "force_per_Eeff_R2")},
    })
    return out


FLOW_SUMMARY_KEYS = {
    "shear": ("capillary_number", "capillary_number_mu_c", "effective_stiffness_ratio", "taylor_deformation_mean",
              "taylor_deformation_std", "inclination_deg_mean", "inclination_deg_std", "tank_treading_frequency",
              "volume_change_max_abs", "transient_strain", "duration_strain", "stop_reason", "stationary",
              "reynolds_number"),
    "pipe": ("capillary_number_wall", "capillary_number_wall_mu_c", "effective_stiffness_ratio", "strain_axial_mean", "strain_axial_std",
             "strain_radial_mean", "strain_radial_std", "deformation_mean", "projected_area_mean",
             "radial_position", "volume_change_max_abs", "stop_reason", "stationary", "reynolds_number"),
}


def _execute_flow(scenario: str, directory: Path, options: dict) -> dict:
    simulate = shear if scenario == "shear" else pipe
    summary = resume_or_restart(simulate, directory, progress=False, **options)
    out = {key: summary.get(key) for key in FLOW_SUMMARY_KEYS[scenario]}
    out["resolution"] = summary.get("lattice", {}).get("radius")
    out["nodes"] = summary.get("mesh", {}).get("n_nodes")
    if scenario == "pipe":
        _save_final_shape(directory, summary, options)
    return out


def _save_final_shape(directory: Path, summary: dict, options: dict) -> None:
    """The final node positions relative to the cell centre, in units of R, and which nodes belong to the
    nucleus: the study's snapshot of the stationary shape (``shape.npz``)."""

    extrapolation = summary.get("extrapolation")  # an extrapolated run: the finer run's last state
    last = part_directory(directory, extrapolation["fine_resolution"]) if extrapolation else directory
    with np.load(last / "checkpoint.npz", allow_pickle=False) as data:
        positions = np.array(data["positions"])
    cell = CellParameters.model_validate(summary["cell"]) if "cell" in summary else cell_parameters()
    mesh = Cell.from_parameters(cell).mesh
    nucleus = np.zeros(len(mesh.nodes), dtype=bool)
    nucleus[np.unique(mesh.elements[mesh.region == 1])] = True
    radius = float(summary["lattice"]["radius"])
    relative = (positions - positions.mean(axis=0)) / radius
    np.savez(directory / "shape.npz", positions=relative, nucleus=nucleus)


# =========================================================================== running studies
def run_members(members: list[Member], out: Path, scheduler: str | None = None, workers: int | None = None,
                progress: bool = False, security=None) -> tuple[list[tuple[Member, dict]], list[tuple[str, str]], list[str]]:
    """Execute the distinct runs of ``members`` through Dask; return (member, record) pairs, failures and the
    ids of the runs executed now.

    Runs already finished in ``out/runs`` are read without starting a cluster."""

    runs_directory = Path(out) / "runs"
    runs_directory.mkdir(parents=True, exist_ok=True)
    distinct = list(dict.fromkeys(member.run for member in members))
    records, pending = {}, []
    for run in distinct:
        path = runs_directory / run.run_id / RUN_FILE
        if path.exists():
            records[run] = json.loads(path.read_text())
        else:
            pending.append(run)
    pending.sort(key=_expected_cost, reverse=True)  # longest first: better packing on the workers
    failures = []
    if pending:
        tasks = [(run, str(runs_directory)) for run in pending]
        flows = {run.kwargs.get("dtype", "float32") for run in pending if run.scenario in ("shear", "pipe")}
        compressions = any(run.scenario == "compress" for run in pending)

        def prepare():  # compile the Numba kernels once here, so that the workers only load them
            if flows:

                compile_kernels(sorted(flows))
            if compressions:

                compile_kernel()

        for index, result in run_tasks(execute_run, tasks, scheduler=scheduler, workers=workers, security=security,
                                       progress=progress, description=f"{len(pending)} runs", prepare=prepare):
            run = pending[index]
            if isinstance(result, TaskFailure):
                failures.append((run.run_id, str(result)))
                records[run] = {"run_id": run.run_id, "scenario": run.scenario, "options": run.kwargs,
                                "status": "failed", "error": str(result)}
            else:
                records[run] = result
    return [(member, records[member.run]) for member in members], failures, [run.run_id for run in pending]


def _expected_cost(run: Run) -> float:
    options = run.kwargs
    if run.scenario == "compress":
        return 1.0
    resolved, _ = _identity(run)
    if resolved is not None:  # what the API will run: shear extrapolates by default, pipe by its channel
        resolution = resolved["flow"].resolution
        coarse = (resolved["options"].get("extrapolation") or {}).get("coarse_resolution")
    else:  # refused options: the run fails fast, any estimate will do
        resolution = options.get("resolution") or 8.0
        coarse = coarse_resolution_of(options.get("extrapolate"), resolution, options.get("coarse_resolution"))
    lattice_updates = sum((r / 5.0) ** 4 for r in (resolution, coarse) if r is not None)  # both runs when extrapolated
    return 10.0 * lattice_updates * float(options.get("duration", 6.0))


def flat_parameters(options: dict) -> dict:
    """Options as table columns: scalars as they are, anything else as JSON text."""
    return {f"option_{k}": (v if isinstance(v, (int, float, str, bool)) else json.dumps(v))
            for k, v in options.items()}


def rows_per_run(pairs: list[tuple[Member, dict]], scalar_keys: tuple[str, ...]) -> list[dict]:
    """One row per run: labels, status, the listed outputs, the run's options, its directory."""
    rows = []
    for member, record in pairs:
        row = {**member.labels, "run_id": record["run_id"], "status": record["status"],
               "error": record.get("error") or ""}
        row.update({key: record.get(key) for key in scalar_keys})
        row["wall_time_s"] = record.get("wall_time_s")
        row["run_directory"] = f"runs/{record['run_id']}"
        row.update(flat_parameters(record["options"]))
        rows.append(row)
    return rows


def rows_per_delta(pairs: list[tuple[Member, dict]]) -> list[dict]:
    """Compression: one row per converged delta of every run (tidy), labels and options repeated."""
    rows = []
    for member, record in pairs:
        base = {**member.labels, "run_id": record["run_id"], "status": record["status"],
                "error": record.get("error") or "", "effective_stiffness_ratio": record.get("effective_stiffness_ratio"),
                "delta_reached": record.get("delta_reached"), "nodes": record.get("nodes"),
                "wall_time_s": record.get("wall_time_s"), "run_directory": f"runs/{record['run_id']}",
                **flat_parameters(record["options"])}
        curve = record.get("curve") or {"delta": [np.nan], "force_per_Ec_R2": [np.nan], "force_per_Eeff_R2": [np.nan]}
        for delta, force_c, force_eff in zip(curve["delta"], curve["force_per_Ec_R2"], curve["force_per_Eeff_R2"],
                                             strict=True):
            rows.append({**base, "delta": delta, "force_per_Ec_R2": force_c, "force_per_Eeff_R2": force_eff})
    return rows


def write_study_table(frame, out: Path, name: str, metadata: dict) -> None:
    """``out/name.parquet`` (metadata in the schema) and ``out/name.csv``, each replaced atomically."""
    import pyarrow as pa
    import pyarrow.parquet as pq


    table = pa.Table.from_pandas(frame, preserve_index=False)
    table = table.replace_schema_metadata({**(table.schema.metadata or {}),
                                           b"elastocell": json.dumps(metadata, default=str).encode()})
    replace_atomically(out / f"{name}.parquet", lambda temporary: pq.write_table(table, temporary))
    replace_atomically(out / f"{name}.csv",
                        lambda temporary: frame.to_csv(temporary, index=False, float_format="%.8g"))


def read_study_table(out: Path, name: str):
    """The table written by :func:`write_study_table` and its metadata."""
    import pyarrow.parquet as pq

    path = Path(out) / f"{name}.parquet"
    if not path.exists():
        raise ParameterError("directory", f"{path} not found: run `elastocell study run {name} --out {out}` first")
    table = pq.read_table(path)
    metadata = json.loads((table.schema.metadata or {}).get(b"elastocell", b"{}"))
    return table.to_pandas(), metadata
