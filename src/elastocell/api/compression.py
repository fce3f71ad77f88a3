"""``elastocell.compress`` and ``elastocell.equivalent``: the same names and options as the command line, writing
the same files.

    import elastocell
    result = elastocell.compress(out="results/reference")            # the paper's reference cell
    result = elastocell.compress(out="r/eq", equivalent=True)         # its homogeneous equivalent
    info = elastocell.equivalent(stiffness_ratio=10, size_ratio=0.5)  # E_eff/E_c of a cell
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from elastocell.api.plotting import plot_compression
from elastocell.body.axisymmetric import NUCLEUS, AxisymmetricCell, MeridianMeshParameters, meridian_nucleus
from elastocell.body.cell import Cell, enable_compilation_cache
from elastocell.files import (
    Stopwatch,
    array_digest,
    parameter_hash,
    replace_atomically,
    software_versions,
    write_json,
    write_table,
)
from elastocell.parameters.cell import (
    CellParameters,
    cell_parameters,
    describe_cell,
)
from elastocell.parameters.units import ParameterError
from elastocell.scenarios.axisymmetric import (
    AxisymmetricError,
    AxisymmetricInterrupted,
    AxisymmetricResult,
    compress_axisymmetric,
)
from elastocell.scenarios.compression import (
    CompressionError,
    CompressionInterrupted,
    CompressionParameters,
    CompressionResult,
    compression_parameters_for,
)
from elastocell.scenarios.compression import compress as compress_cell
from elastocell.simulation.directory import OutputSet, interruptible, output_directory
from elastocell.simulation.output import progress_bar, von_mises, vtk_enabled, write_vtk_series


def equivalent(cell: CellParameters | None = None, **cell_options) -> dict:
    """E_eff/E_c (``effective_stiffness_ratio``), volumes and mesh counts of a cell."""
    cell = cell or cell_parameters(**cell_options)
    enable_compilation_cache()
    body = Cell.from_parameters(cell)
    summary = body.summary()
    summary["effective_stiffness_ratio_analytic"] = (
        1 + (cell.nucleus.stiffness_ratio - 1) * cell.nucleus.volume_fraction()
        if cell.random is None else (cell.random.low + cell.random.high) / 2
    )
    summary["effective_youngs_modulus"] = summary["effective_stiffness_ratio"] * cell.youngs_modulus
    summary["mesh_quality"] = body.mesh.quality()
    return summary


def compress(
    out: str | Path,
    cell: CellParameters | None = None,
    delta_max: float = 0.75,
    steps: int = 40,
    equivalent: bool = False,
    compare: bool = False,
    vtk: bool = True,
    solver: str = "auto",
    progress: bool = True,
    resume: bool = False,
    axisymmetric: bool = False,
    **cell_options,
) -> dict:
    """Compress a cell between two plates and write ``out/compression.csv``, ``metadata.json``,
    ``compression.png`` and VTK files (``out/vtk/compression.pvd``).

    Unless the cell sets ``quadrature_degree``, a p2 neo-Hookean cell whose nucleus is at least 5.5 times stiffer
    than the cytoplasm uses the rule with the nodes (degree 5, see ``compression.compression_parameters_for``),
    and so does its equivalent; ``metadata.json`` records the degree. Such a cell on the default mesh sizes is
    compressed on the refined mesh of ``compression.STIFF_NUCLEUS_MESHES`` (a finer nucleus surface, and above
    stiffness ratio 10 a finer bulk), its equivalent on the same; ``metadata.json`` records the mesh. ``volumetric="projected"`` (or ``"mean"``)
    evaluates the law on F-bar with J projected per element (``MeshParameters.volumetric``, docs/theory.md), at
    degree 5 unless one is given; ``metadata.json`` records it with the mesh.

    equivalent: simulate the homogeneous equivalent of the described cell instead.
    compare: also simulate the equivalent (written to ``out/equivalent/``) and draw both in
    ``out/comparison.png`` with their force ratio in ``out/comparison.csv``.
    resume: continue an interrupted curve from ``out/checkpoint.npz`` (written after every converged row) when
    it was made with the same parameters; otherwise the curve starts at delta = 0.
    axisymmetric: solve the body of revolution in its meridian plane
    (:func:`~elastocell.scenarios.axisymmetric.compress_axisymmetric`, quadratic triangles, the default
    :class:`~elastocell.body.axisymmetric.MeridianMeshParameters`; the cell's 3D mesh options do not apply) for
    a cell axisymmetric about the plate normal; any other cell (random, nucleus offset across z, ellipsoid
    whose semi-axes across z differ) is refused naming why. Same files and columns, no VTK files;
    ``metadata.json`` says ``"solver": {"name": "axisymmetric", ...}`` and gives the meridian mesh.

    Every option is validated before a file is written. One run at a time per ``out`` (a lock; see
    :func:`elastocell.simulation.directory.output_directory`). Ctrl-C or SIGTERM during the curve writes the
    converged rows (``compression.csv``, a ``metadata.json`` with ``"complete": false`` and
    ``interrupted_at_delta``) and raises :class:`~elastocell.scenarios.compression.CompressionInterrupted`;
    ``resume=True`` continues from there.
    """
    if cell is not None and cell_options:
        raise ParameterError("cell", f"give either cell= or cell options, not both ({', '.join(cell_options)})")
    if compare and equivalent:
        raise ParameterError("compare", "--compare already runs the equivalent; do not combine it with --equivalent")
    cell = cell or cell_parameters(**cell_options)
    scenario = CompressionParameters(delta_max=delta_max, steps=steps)
    if axisymmetric:
        meridian_nucleus(cell)  # a cell not axisymmetric about z: one ParameterError before any file
        if cell.mesh.volumetric != "standard":
            raise ParameterError("volumetric", "sets how the 3D elements take J; the axisymmetric solver (its own "
                                               "meridian mesh of quadratic triangles) has no such option")
    else:
        cell = compression_parameters_for(cell)
    with output_directory(out) as out, interruptible():
        enable_compilation_cache()
        if axisymmetric:
            return _compress_axisymmetric(out, cell, scenario, equivalent, compare, solver, progress, resume)
        body = Cell.from_parameters(cell)
        primary = body.equivalent() if equivalent else body
        label = "homogeneous equivalent" if equivalent else describe_cell(cell)
        summary = _run_and_write(out, primary, scenario, cell, solver, progress, label, vtk, resume)
        if compare and not equivalent:
            other = _run_and_write(out / "equivalent", body.equivalent(), scenario, cell, solver, progress,
                                   "homogeneous equivalent", vtk, resume)
            _write_comparison(out, summary, other, cell)
            summary["equivalent_summary"] = other
    return summary


CHECKPOINT_FORMAT = 3
"""Layout of a compression ``checkpoint.npz`` (the rows of :class:`CompressionResult` and a fingerprint) and of
what the fingerprint hashes; raised when either changes, and when the solver's rows for the same inputs do (3: a
p2 surface corner among mid-side nodes pressed by a plate stays in contact), so that no curve continues or is
reused across such a change."""

CHECKPOINT_ARRAYS = ("delta", "force", "force_lower", "positions", "contact_nodes_upper", "unstable",
                     "min_nodal_jacobian", "min_volume_ratio")
"""The per-row arrays of :class:`CompressionResult` a checkpoint keeps."""


def _fingerprint(body: Cell | AxisymmetricCell, cell: CellParameters, scenario: CompressionParameters, solver: str,
                 **more) -> str:
    """The hash of everything that determines the curve: the resolved cell, the load steps, which body (cell
    or its equivalent), the solver, ``more`` (the meridian mesh parameters of the axisymmetric solver) and the
    sha256 of the body's mesh (nodes, elements) and element moduli, so that a mesh that changed under the same
    parameters (another mesher, another cached mesh) does not continue a curve made on the other."""
    arrays = array_digest(body.mesh.nodes, body.mesh.elements, np.asarray(body.youngs_moduli, dtype=np.float64))
    return parameter_hash(cell, scenario, {"equivalent": body.is_equivalent, "solver": solver, **more,
                                           "arrays": arrays}, format_version=CHECKPOINT_FORMAT)


def _finished_curve(out: Path, fingerprint: str) -> dict | None:
    """The metadata of the curve already complete in ``out`` with this fingerprint, or None. On resume such a
    curve is read back, not computed again: ``compare=True`` interrupted during the equivalent resumes the
    equivalent only."""
    try:
        summary = json.loads((out / "metadata.json").read_text())
    except (OSError, ValueError):
        return None
    complete = isinstance(summary, dict) and summary.get("complete") is True
    if complete and summary.get("fingerprint") == fingerprint and (out / "compression.csv").exists():
        return summary
    return None


def _save_checkpoint(path: Path, result: CompressionResult, fingerprint: str) -> None:
    def write(temporary: Path) -> None:
        with temporary.open("wb") as handle:  # a file object: np.savez would append .npz to the temporary name
            np.savez(handle, fingerprint=np.array(fingerprint),
                     counts=np.array([result.newton_iterations, result.substeps]),
                     scalars=np.array([result.max_rigid_reaction, result.wall_time]),
                     **{name: getattr(result, name) for name in CHECKPOINT_ARRAYS})

    replace_atomically(path, write)


def _load_checkpoint(path: Path, fingerprint: str, n_nodes: int) -> CompressionResult:
    """The rows of an interrupted curve; a damaged or foreign file is one ParameterError naming --resume."""
    try:
        with np.load(path, allow_pickle=False) as data:
            found = str(data["fingerprint"])
            arrays = {name: np.array(data[name]) for name in CHECKPOINT_ARRAYS}
            iterations, substeps = (int(v) for v in data["counts"])
            reaction, wall_time = (float(v) for v in data["scalars"])
    except Exception as error:  # truncated, garbled, not an npz, missing arrays, pickled objects
        raise ParameterError("resume", f"cannot continue from {path}: the file is damaged or not a compression "
                                       f"checkpoint ({type(error).__name__}); delete it to start again") from None
    _check_checkpoint(path, found, fingerprint, arrays, (n_nodes, 3))
    return CompressionResult(**arrays, newton_iterations=iterations, factorisations=0, analyses=0,
                             substeps=substeps, max_rigid_reaction=reaction, wall_time=wall_time, solver="",
                             history=[])


def _check_checkpoint(path: Path, found: str, fingerprint: str, arrays: dict, node_shape: tuple[int, int]) -> None:
    """A ParameterError naming --resume when the checkpoint's fingerprint is another curve's, or its per-row
    arrays disagree in length or its positions are not (rows, *node_shape)."""
    if found != fingerprint:
        raise ParameterError("resume", f"{path} belongs to a curve with other parameters; rerun with the same "
                                       "options, or delete it to start again")
    rows = len(arrays["positions"])
    if rows < 1 or arrays["positions"].shape != (rows, *node_shape) or any(len(a) != rows for a in arrays.values()):
        raise ParameterError("resume", f"cannot continue from {path}: its arrays are inconsistent; delete it to "
                                       "start again")


def _run_and_write(out: Path, body: Cell, scenario: CompressionParameters, cell: CellParameters, solver: str,
                   show_progress: bool, label: str, vtk: bool = True, resume: bool = False) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    clock = Stopwatch()
    checkpoint = out / "checkpoint.npz"
    fingerprint = _fingerprint(body, cell, scenario, solver)
    if resume and (finished := _finished_curve(out, fingerprint)) is not None:
        return finished
    start = _load_checkpoint(checkpoint, fingerprint, body.mesh.n_nodes) if resume and checkpoint.exists() else None
    with progress_bar(show_progress, "delta {task.completed:.3f}", label=None) as progress:
        if progress is not None:
            task = progress.add_task(f"compress {label}", total=scenario.delta_max)
            callback = lambda delta: progress.update(task, completed=delta)  # noqa: E731
        else:
            callback = None
        try:
            result = compress_cell(body, scenario, solver=solver, progress=callback, resume_from=start,
                                   on_row=lambda rows: _save_checkpoint(checkpoint, rows, fingerprint))
            failure = None
        except CompressionInterrupted as error:  # the converged rows, marked incomplete, then stop
            _write_interrupted(out, body, cell, scenario, label, solver, clock, error.partial)
            raise CompressionInterrupted(f"{error} in {out}; rerun with --resume to continue", error.partial) from None
        except CompressionError as error:  # keep every converged row, then report
            if error.partial is None or len(error.partial.delta) < 2:
                raise
            result, failure = error.partial, error
    table, gamma_eff = _table(result, body, cell)
    outputs = OutputSet()  # all or nothing: a failed write removes the others and names its file
    outputs.write(out / "compression.csv", write_table, table)

    outputs.write(out / "compression.png", plot_compression, [{"label": label, **table}], cell.material.poisson_ratio,
                  title=label)
    if vtk and vtk_enabled():
        stresses = [body.element_cauchy_stress(x) for x in result.positions]
        cell_data = [{
            "youngs_modulus": body.youngs_moduli * cell.youngs_modulus,
            "stiffness_ratio": body.youngs_moduli,
            "region": body.mesh.region.astype(np.int32),
            "cauchy_stress": s.reshape(-1, 9) * cell.youngs_modulus,
            "von_mises_stress": von_mises(s) * cell.youngs_modulus,
        } for s in stresses]
        outputs.write(out / "vtk", write_vtk_series, "compression", body.mesh, result.positions * cell.radius,
                      result.delta, cell_data)
    summary = _metadata(result, body, cell, scenario, label, gamma_eff, clock.elapsed, solver)
    _write_metadata(outputs, out, summary, fingerprint, failure, result.delta[-1])
    if failure is not None:
        raise CompressionError(f"{failure} (rows up to delta={result.delta[-1]:.4f} written to {out})", None)
    return summary


def _write_metadata(outputs: OutputSet, out: Path, summary: dict, fingerprint: str, failure, delta_reached) -> None:
    """The last file of a curve: ``metadata.json`` with ``complete`` (and the ``error`` that stopped it early),
    the curve's ``fingerprint`` (a complete curve is read back on resume, :func:`_finished_curve`) and
    ``delta_reached``; then the checkpoint goes, the curve being on disk in full."""
    summary.update(complete=failure is None, fingerprint=fingerprint, delta_reached=float(delta_reached))
    if failure is not None:
        summary["error"] = str(failure)
    outputs.write(out / "metadata.json", write_json, summary)
    (out / "checkpoint.npz").unlink(missing_ok=True)


def _compress_axisymmetric(out: Path, cell: CellParameters, scenario: CompressionParameters, equivalent: bool,
                           compare: bool, solver: str, progress: bool, resume: bool) -> dict:
    """:func:`compress` by the axisymmetric solver: the cell (or its equivalent), then with ``compare`` the
    equivalent in ``out/equivalent``."""
    mesh = MeridianMeshParameters()
    body = AxisymmetricCell.from_parameters(cell, mesh)
    primary = body.equivalent() if equivalent else body
    label = "homogeneous equivalent" if equivalent else describe_cell(cell)
    summary = _run_and_write_axisymmetric(out, primary, mesh, scenario, cell, solver, progress, label, resume)
    if compare and not equivalent:
        other = _run_and_write_axisymmetric(out / "equivalent", body.equivalent(), mesh, scenario, cell, solver,
                                            progress, "homogeneous equivalent", resume)
        _write_comparison(out, summary, other, cell)
        summary["equivalent_summary"] = other
    return summary


AXISYMMETRIC_ARRAYS = ("load", "force", "force_support", "contact_radius", "min_volume_ratio", "positions")
"""The per-row arrays of :class:`AxisymmetricResult` an axisymmetric checkpoint keeps."""


def _save_axisymmetric_checkpoint(path: Path, result: AxisymmetricResult, fingerprint: str) -> None:
    def write(temporary: Path) -> None:
        with temporary.open("wb") as handle:
            np.savez(handle, fingerprint=np.array(fingerprint), counts=np.array([result.newton_iterations,
                                                                                 result.substeps]),
                     scalars=np.array([result.wall_time]), **{name: getattr(result, name) for name in AXISYMMETRIC_ARRAYS})

    replace_atomically(path, write)


def _load_axisymmetric_checkpoint(path: Path, fingerprint: str, n_nodes: int) -> AxisymmetricResult:
    """The rows of an interrupted axisymmetric curve; a damaged or foreign file is one ParameterError naming
    --resume (as :func:`_load_checkpoint`)."""
    try:
        with np.load(path, allow_pickle=False) as data:
            found = str(data["fingerprint"])
            arrays = {name: np.array(data[name]) for name in AXISYMMETRIC_ARRAYS}
            iterations, substeps = (int(v) for v in data["counts"])
            wall_time = float(data["scalars"][0])
    except Exception as error:  # truncated, garbled, not an npz, missing arrays, pickled objects
        raise ParameterError("resume", f"cannot continue from {path}: the file is damaged or not an axisymmetric "
                                       f"compression checkpoint ({type(error).__name__}); delete it to start "
                                       "again") from None
    _check_checkpoint(path, found, fingerprint, arrays, (n_nodes, 2))
    return AxisymmetricResult(**arrays, newton_iterations=iterations, substeps=substeps, n_nodes=n_nodes,
                              wall_time=wall_time)


def _run_and_write_axisymmetric(out: Path, body: AxisymmetricCell, mesh: MeridianMeshParameters,
                                scenario: CompressionParameters, cell: CellParameters, solver: str,
                                show_progress: bool, label: str, resume: bool) -> dict:
    """One curve of the axisymmetric solver and its files: compression.csv, compression.png, metadata.json (the
    rows so far and ``"complete": false`` when interrupted or stopped, as :func:`_run_and_write`)."""
    out.mkdir(parents=True, exist_ok=True)
    clock = Stopwatch()
    checkpoint = out / "checkpoint.npz"
    fingerprint = _fingerprint(body, cell, scenario, solver, axisymmetric=mesh)
    if resume and (finished := _finished_curve(out, fingerprint)) is not None:
        return finished
    start = (_load_axisymmetric_checkpoint(checkpoint, fingerprint, body.mesh.n_nodes)
             if resume and checkpoint.exists() else None)
    with progress_bar(show_progress, "delta {task.completed:.3f}", label=None) as progress:
        task = progress.add_task(f"compress {label} (axisymmetric)", total=scenario.delta_max) if progress else None

        def on_row(rows: AxisymmetricResult) -> None:
            _save_axisymmetric_checkpoint(checkpoint, rows, fingerprint)
            if progress is not None:
                progress.update(task, completed=float(rows.load[-1]))

        failure = None
        try:
            result = compress_axisymmetric(body, scenario.delta_max, scenario.steps, solver=solver,
                                           resume_from=start, on_row=on_row)
        except AxisymmetricInterrupted as error:  # the converged rows, marked incomplete, then stop
            summary = _axisymmetric_metadata(error.partial, body, cell, scenario, label, clock.elapsed, mesh)
            write_table(out / "compression.csv", _table_of(error.partial.load, error.partial.force, body, cell))
            summary.update(complete=False, interrupted=True, interrupted_at_delta=float(error.partial.load[-1]),
                           delta_reached=float(error.partial.load[-1]))
            write_json(out / "metadata.json", summary)
            raise CompressionInterrupted(f"{error} in {out}; rerun with --resume to continue", None) from None
        except AxisymmetricError as error:  # keep every converged row, then report
            if error.partial is None or len(error.partial.load) < 2:
                raise CompressionError(str(error), None) from None
            result, failure = error.partial, error
    table = _table_of(result.load, result.force, body, cell)
    outputs = OutputSet()
    outputs.write(out / "compression.csv", write_table, table)
    outputs.write(out / "compression.png", plot_compression, [{"label": label, **table}], cell.material.poisson_ratio,
                  title=f"{label} (axisymmetric)")
    summary = _axisymmetric_metadata(result, body, cell, scenario, label, clock.elapsed, mesh)
    _write_metadata(outputs, out, summary, fingerprint, failure, result.load[-1])
    if failure is not None:
        raise CompressionError(f"{failure} (rows up to delta={result.load[-1]:.4f} written to {out})", None)
    return summary


def _table_of(delta: np.ndarray, force: np.ndarray, body: AxisymmetricCell, cell: CellParameters) -> dict:
    """The columns of ``compression.csv`` for an axisymmetric curve (those of :func:`_table`)."""
    gamma_eff = body.youngs_moduli[0] if body.is_equivalent else body.effective_stiffness_ratio
    return {"delta": delta, "force": force * cell.force_scale(), "force_per_Ec_R2": force,
            "force_per_Eeff_R2": force / gamma_eff}


def _axisymmetric_metadata(result: AxisymmetricResult, body: AxisymmetricCell, cell: CellParameters,
                           scenario: CompressionParameters, label: str, wall_time: float,
                           mesh: MeridianMeshParameters) -> dict:
    gamma_eff = float(body.youngs_moduli[0] if body.is_equivalent else body.effective_stiffness_ratio)
    return {
        "scenario": "compression",
        "label": label,
        "equivalent": body.is_equivalent,
        "cell": cell.model_dump(mode="json"),
        "compression": scenario.model_dump(mode="json"),
        "effective_stiffness_ratio": gamma_eff,
        "effective_youngs_modulus": gamma_eff * cell.youngs_modulus,
        "units": _units(cell),
        "element_order": 2,
        "mesh": {"kind": "meridian (6-node triangles)", "n_nodes": body.mesh.n_nodes,
                 "n_elements": body.mesh.n_elements, "n_nucleus_elements": int((body.mesh.region == NUCLEUS).sum()),
                 "volume": body.volume, "parameters": mesh.model_dump(mode="json")},
        "solver": {
            "name": "axisymmetric",
            "newton_iterations": result.newton_iterations,
            "substeps": result.substeps,
            "curve_time_s": result.wall_time,
            "max_plate_force_imbalance": float(np.abs(result.force - result.force_support).max()),
            "min_volume_ratio": float(result.min_volume_ratio.min()),
            "first_half_volume_delta": (float(result.load[np.argmax(result.min_volume_ratio < 0.5)])
                                        if (result.min_volume_ratio < 0.5).any() else None),
        },
        "wall_time_s": wall_time,
        "software": software_versions(),
    }


def _units(cell: CellParameters) -> dict:
    return {
        "force": {(True, True): "N", (True, False): "E_c m^2", (False, True): "Pa R^2",
                  (False, False): "E_c R^2"}[(cell.radius_is_physical, cell.youngs_modulus_is_physical)],
        "radius": cell.radius, "youngs_modulus": cell.youngs_modulus,
    }


def _table(result: CompressionResult, body: Cell, cell: CellParameters) -> tuple[dict, float]:
    """The columns of ``compression.csv`` and E_eff/E_c of the body."""
    gamma_eff = body.effective_stiffness_ratio if not body.is_equivalent else body.youngs_moduli[0]
    scale = cell.force_scale()
    return {
        "delta": result.delta,
        "force": result.force * scale,
        "force_per_Ec_R2": result.force,
        "force_per_Eeff_R2": result.force / gamma_eff,
    }, gamma_eff


def _write_interrupted(out: Path, body: Cell, cell: CellParameters, scenario: CompressionParameters, label: str,
                       solver: str, clock: Stopwatch, partial: CompressionResult) -> None:
    """The rows converged before an interruption, and metadata that says the curve is incomplete and where it
    stopped (the checkpoint beside them lets ``resume`` continue)."""
    table, gamma_eff = _table(partial, body, cell)
    write_table(out / "compression.csv", table)
    summary = _metadata(partial, body, cell, scenario, label, gamma_eff, clock.elapsed, solver)
    summary.update(complete=False, interrupted=True, interrupted_at_delta=float(partial.delta[-1]),
                   delta_reached=float(partial.delta[-1]))
    write_json(out / "metadata.json", summary)


def _metadata(result: CompressionResult, body: Cell, cell: CellParameters, scenario: CompressionParameters,
              label: str, gamma_eff: float, wall_time: float, solver: str) -> dict:
    return {
        "scenario": "compression",
        "label": label,
        "equivalent": body.is_equivalent,
        "cell": cell.model_dump(mode="json"),
        "compression": scenario.model_dump(mode="json"),
        "effective_stiffness_ratio": float(gamma_eff),
        "effective_youngs_modulus": float(gamma_eff * cell.youngs_modulus),
        "units": _units(cell),
        "element_order": body.mesh.order,
        "mesh": {**body.mesh.counts(), **body.mesh.quality(), "volume": body.volume},
        "solver": {
            "linear_solver": result.solver,
            "factorisation_precision": result.precision,
            "refinement_steps": result.refinements,
            "newton_iterations": result.newton_iterations,
            "factorisations": result.factorisations,
            "symbolic_analyses": result.analyses,
            "substeps": result.substeps,
            "max_pin_reaction_over_force": float(result.max_rigid_reaction),
            "max_plate_force_imbalance": float(np.abs(result.force - result.force_lower).max()),
            "curve_time_s": result.wall_time,
            # rows whose equilibrium is a saddle of the discrete energy (the branch from delta = 0 has lost
            # stability; a refined mesh may stay stable longer). None: every row is a minimum.
            "unstable_rows": int(result.unstable.sum()),
            "first_unstable_delta": (float(result.delta[np.argmax(result.unstable)])
                                     if result.unstable.any() else None),
            # rows where a quadratic element has folded at a node (det dx/dxi <= 0 there while positive at its
            # quadrature points, see compression.min_nodal_jacobian); None: none folded
            "min_nodal_jacobian": float(result.min_nodal_jacobian.min()),
            "folded_rows": int((result.min_nodal_jacobian <= 0).sum()),
            "first_folded_delta": (float(result.delta[np.argmax(result.min_nodal_jacobian <= 0)])
                                   if (result.min_nodal_jacobian <= 0).any() else None),
            # smallest volume ratio J = det F at a quadrature point, and the first delta where half the volume
            # is lost somewhere (see compression.min_volume_ratio); None: never
            "min_volume_ratio": float(result.min_volume_ratio.min()),
            "first_half_volume_delta": (float(result.delta[np.argmax(result.min_volume_ratio < 0.5)])
                                        if (result.min_volume_ratio < 0.5).any() else None),
        },
        "wall_time_s": wall_time,
        "software": software_versions(),
    }


def _write_comparison(out: Path, cell_summary: dict, equivalent_summary: dict, cell: CellParameters) -> None:

    a = np.genfromtxt(out / "compression.csv", delimiter=",", names=True)
    b = np.genfromtxt(out / "equivalent" / "compression.csv", delimiter=",", names=True)
    ratio = np.divide(a["force"], b["force"], out=np.full_like(a["force"], np.nan), where=b["force"] > 0)
    write_table(out / "comparison.csv", {"delta": a["delta"], "force_cell": a["force"],
                                         "force_equivalent": b["force"], "force_ratio": ratio})
    curves = [
        {"label": cell_summary["label"], "delta": a["delta"], "force_per_Ec_R2": a["force_per_Ec_R2"],
         "force_per_Eeff_R2": a["force_per_Eeff_R2"], "style": {"marker": "o", "ms": 3, "ls": "none"}},
        {"label": "homogeneous equivalent", "delta": b["delta"], "force_per_Ec_R2": b["force_per_Ec_R2"],
         "force_per_Eeff_R2": b["force_per_Eeff_R2"], "style": {"lw": 1.5}},
    ]
    plot_compression(out / "comparison.png", curves, cell.material.poisson_ratio,
                     title=f"{cell_summary['label']} vs its equivalent (gamma_eff={cell_summary['effective_stiffness_ratio']:.4f})")
