"""``elastocell.indent``: a rigid sphere (a bead of radius R_b) pressed into a cell on a dish, with the same names
and options as ``elastocell indent``, writing the same files.

    import elastocell
    elastocell.indent(out="r/bead", indenter_radius="5um", radius="8um", youngs_modulus="1kPa", nucleus="none")
    elastocell.indent(out="r/cap", cell_shape="cap", cap_height="4um", indenter_radius="2.5um", radius="10um",
                      size_ratio=0.3)
    elastocell.indent(out="r/gel", cell_shape="layer", layer_thickness="50um", indenter_radius="5um",
                      nucleus="none", depth_max=0.5)

The curve comes from the axisymmetric solver (:mod:`elastocell.scenarios.indentation`) for a cell symmetric
about z, and for any other suspended sphere (a random cell, an offset nucleus, a tilted ellipsoid) from the 3D
solver on the tetrahedral cell of ``elastocell compress`` (:mod:`elastocell.scenarios.indentation_3d`);
``solver="3d"`` or ``"axisymmetric"`` forces one. A cap or a layer must be axisymmetric.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from elastocell.body.axisymmetric import AxisymmetricCell, MeridianGeometry
from elastocell.body.cell import Cell
from elastocell.files import (
    Stopwatch,
    array_digest,
    parameter_hash,
    replace_atomically,
    save_figure,
    software_versions,
    write_json,
    write_table,
)
from elastocell.parameters.cell import CellParameters, cell_parameters, describe_cell
from elastocell.parameters.units import RADIUS_SCALE, ParameterError, parse_quantity
from elastocell.scenarios.axisymmetric import (
    AxisymmetricError,
    AxisymmetricInterrupted,
    AxisymmetricResult,
    hertz_half_space_force,
    hertz_sphere_indentation_force,
    sneddon_cone_force,
)
from elastocell.scenarios.indentation import (
    CONE_AXISYMMETRIC,
    INDENTERS,
    check_axisymmetric,
    check_depth,
    cone_body,
    cone_geometry,
    cone_half_angle,
    cone_tip_radius,
    indent_body,
    indentation_cell_3d,
    indentation_geometry,
    indentation_solver,
)
from elastocell.scenarios.indentation_3d import RESULT_ROWS, Indentation3DResult, indent_3d
from elastocell.simulation.directory import OutputSet, interruptible, output_directory
from elastocell.simulation.output import progress_bar, von_mises, vtk_enabled, write_vtk_series

LENGTH_UNIT = {"sphere": "R, the cell radius (--radius)", "cap": "R, the cap's base radius (--radius)",
               "layer": "R_b, the indenter radius (--indenter-radius)"}
"""What the length unit R of the outputs (depth, force_per_Ec_R2) is for each shape."""


def _length(value, name: str, cell: CellParameters) -> float | None:
    """A length option in units of R (the cell radius): a quantity with a unit over the physical radius, a bare
    number as it is."""
    if value is None:
        return None
    magnitude, physical = parse_quantity(value, "m", name, scale=RADIUS_SCALE)
    if physical and not cell.radius_is_physical:
        raise ParameterError(name, f"is a physical length ({value}) but --radius is not: give --radius with a unit "
                                   "too, or both as numbers in units of R")
    return magnitude / cell.radius if physical else magnitude


def indent(
    out: str | Path,
    indenter_radius: str | float | None = None,
    cell: CellParameters | None = None,
    cell_shape: str = "sphere",
    cap_height: str | float | None = None,
    layer_thickness: str | float | None = None,
    depth_max: float = 0.3,
    steps: int = 20,
    vtk: bool = True,
    solver: str = "auto",
    linear_solver: str = "auto",
    resume: bool = False,
    progress: bool = True,
    indenter: str = "sphere",
    half_angle: str | float | None = None,
    **cell_options,
) -> dict:
    """Press a rigid frictionless sphere of radius ``indenter_radius`` (``indenter="cone"`` or ``"pyramid"``: a
    cone of ``half_angle``, see :func:`_indent_cone`) into a cell on a rigid dish and write
    ``out/indentation.csv`` (``depth,force,force_per_Ec_R2,force_per_Eeff_R2``), ``metadata.json``,
    ``indentation.png`` and VTK, one file per row (``out/vtk/indentation_NNNN.vtu``: the meridian section, or the
    3D cell with ``out/vtk/indentation.pvd``).

    solver: ``auto`` (the axisymmetric solver for a cell symmetric about z, the 3D solver for any other
    suspended sphere), ``3d`` (``cell_shape="sphere"`` only; the mesh options of ``compress`` apply) or
    ``axisymmetric``. ``metadata.json`` says which ran (``solver.solver``). ``linear_solver``: the sparse solver
    (``auto``, ``pardiso``, ``superlu``).

    cell_shape: ``sphere`` (suspended, resting on the dish), ``cap`` (base radius ``radius``, apex height
    ``cap_height``, default a hemisphere, base bonded to the dish; the nucleus centred on the axis at half the
    apex height plus ``offset``) or ``layer`` (thickness ``layer_thickness``, bonded, homogeneous).
    Lengths: quantities (``"5um"``) or bare numbers in units of R (the cell radius); ``depth_max`` is in units of
    R (the layer: of R_b), as is the ``depth`` column unless the radius is physical (then metres, and the force
    in newtons when the modulus is too). For the layer R is R_b throughout the outputs.

    Every option is validated before a file is written; one run at a time per ``out``. Ctrl-C or SIGTERM writes
    the converged rows with ``"complete": false`` in the metadata and raises
    :class:`~elastocell.scenarios.axisymmetric.AxisymmetricInterrupted`. The 3D solver also keeps its converged
    rows in ``out/checkpoint.npz`` after every row: ``resume=True`` continues such a curve (same options) from
    its last row, and reads back a curve already complete; an axisymmetric curve (seconds) is not resumed.
    """
    if cell is not None and cell_options:
        raise ParameterError("cell", f"give either cell= or cell options, not both ({', '.join(cell_options)})")
    cell = cell or cell_parameters(**cell_options)
    if indenter != "sphere":
        return _indent_cone(out, cell, indenter, indenter_radius, half_angle, cell_shape, cap_height,
                            layer_thickness, depth_max, steps, vtk, solver, linear_solver, resume, progress)
    if half_angle is not None:
        raise ParameterError("half_angle", "applies to --indenter cone or pyramid only (a bead has --indenter-radius)")
    if indenter_radius is None:
        raise ParameterError("indenter_radius", "is required with --indenter sphere (the default)")
    if cell_shape == "layer" and not cell.radius_is_physical:  # the layer's unit is R_b: --radius is not needed
        magnitude, physical = parse_quantity(indenter_radius, "m", "indenter_radius", scale=RADIUS_SCALE)
        if physical:
            cell = cell.model_copy(update={"radius": magnitude, "radius_is_physical": True})
    bead = _length(indenter_radius, "indenter_radius", cell)
    cap = _length(cap_height, "cap_height", cell)
    layer = _length(layer_thickness, "layer_thickness", cell)
    geometry, unit = indentation_geometry(cell_shape, bead, cap, layer)
    depth = depth_max * unit  # the layer's depth_max is in units of R_b
    check_depth(geometry, unit, depth, steps)
    path = indentation_solver(solver, cell, geometry)
    if resume and path != "3d":
        raise ParameterError("resume", "continues a curve of the 3D solver only (this indentation runs the "
                                       "axisymmetric solver, whose curve takes seconds: run it again)")
    cell_3d = indentation_cell_3d(cell) if path == "3d" else None  # its refusals before the directory exists
    with output_directory(out) as out, interruptible():
        clock = Stopwatch()
        if path == "3d":
            body = Cell.from_parameters(cell_3d)
        else:
            body = AxisymmetricCell.from_parameters(cell, geometry=geometry)
        label = f"{describe_cell(cell)}, {cell_shape}, R_b = {bead * cell.radius:g}"
        checkpoint, fingerprint, start = out / "checkpoint.npz", None, None
        if path == "3d":
            fingerprint = _fingerprint(body, cell, bead, depth, steps, linear_solver)
            if resume and (finished := _finished_curve(out, fingerprint)) is not None:
                return finished
            if resume and checkpoint.exists():
                start = _load_checkpoint(checkpoint, fingerprint, body.mesh.n_nodes)
        with progress_bar(progress, "depth {task.completed:.3f}", label=None) as bar:
            callback = None
            if bar is not None:
                task = bar.add_task(f"indent {label}", total=depth)
                callback = lambda rows: bar.update(task, completed=float(rows.load[-1]) * unit)  # noqa: E731
            try:
                if path == "3d":
                    def on_row(rows, show=callback):
                        _save_checkpoint(checkpoint, rows, fingerprint)
                        if show is not None:
                            show(rows)

                    result = indent_3d(body, bead, depth, steps, solver=linear_solver, resume_from=start,
                                       on_row=on_row)
                else:
                    result = indent_body(body, geometry, unit, bead, depth, steps, solver=linear_solver,
                                         on_row=callback)
                failure = None
            except AxisymmetricInterrupted as error:
                _write(out, error.partial, body, cell, geometry, unit, bead, cap, layer, depth, steps, label, clock,
                       vtk, failure=error, interrupted=True, solver=solver)
                again = "; rerun with --resume to continue" if path == "3d" else ""
                raise AxisymmetricInterrupted(f"{error}; the converged rows are in {out}{again}",
                                              error.partial) from None
            except AxisymmetricError as error:
                if error.partial is None or len(error.partial.load) < 2:
                    raise
                result, failure = error.partial, error
        summary = _write(out, result, body, cell, geometry, unit, bead, cap, layer, depth, steps, label, clock, vtk,
                         failure=failure, solver=solver, fingerprint=fingerprint)
        checkpoint.unlink(missing_ok=True)  # the curve is on disk in full
    if failure is not None:
        raise AxisymmetricError(f"{failure} (rows up to depth={result.load[-1]:.4f} R written to {out})", None)
    return summary


def _indent_cone(out, cell: CellParameters, indenter: str, indenter_radius, half_angle, cell_shape: str,
                 cap_height, layer_thickness, depth_max: float, steps: int, vtk: bool, solver: str, linear_solver: str,
                 resume: bool, progress: bool) -> dict:
    """:func:`indent` with a cone (``indenter="cone"``, ``half_angle`` between the axis and the flank, a quantity
    like ``"20deg"``; a bare number is in degrees) or a four-sided pyramid (``"pyramid"``, ``half_angle`` the face
    half-angle; the cone of the same cross-section area) on the axisymmetric solver
    (:func:`elastocell.scenarios.indentation.cone_curve`). ``depth_max`` is in units of R (the layer: of its
    thickness h, the outputs' length unit; a physical ``layer_thickness`` makes them physical)."""
    if indenter not in INDENTERS:
        raise ParameterError("indenter", f"must be one of {', '.join(INDENTERS)}, got {indenter!r}")
    if indenter_radius is not None:
        raise ParameterError("indenter_radius", f"is the bead's radius; --indenter {indenter} has --half-angle")
    angle_given = None if half_angle is None else parse_quantity(half_angle, "deg", "half_angle")[0]
    angle = cone_half_angle(indenter, angle_given)
    if resume:
        raise ParameterError("resume", "continues a curve of the 3D solver only (a cone runs the axisymmetric "
                                       "solver: run it again)")
    indentation_solver(solver, cell, MeridianGeometry(), indenter)  # refuses --solver 3d
    if cell_shape == "layer" and not cell.radius_is_physical and layer_thickness is not None:
        magnitude, physical = parse_quantity(layer_thickness, "m", "layer_thickness", scale=RADIUS_SCALE)
        if physical:  # the layer's unit is h: --radius is not needed
            cell = cell.model_copy(update={"radius": magnitude, "radius_is_physical": True})
    cap = _length(cap_height, "cap_height", cell)
    layer = _length(layer_thickness, "layer_thickness", cell)
    unit = layer if cell_shape == "layer" and layer is not None else 1.0  # the outputs' length unit
    depth = depth_max * unit
    geometry, mesh_unit = cone_geometry(cell_shape, angle, depth, cap, layer)
    check_depth(geometry, mesh_unit, depth, steps)
    check_axisymmetric(cell, geometry, CONE_AXISYMMETRIC)
    rho = cone_tip_radius(angle, depth)
    tip = {"indenter": indenter, "half_angle_deg": float(angle_given), "equivalent_cone_half_angle_deg": angle,
           "tip_radius_per_R": rho, "tip": "apex rounded by a sphere of radius tip_radius (CONE_TIP_RADIUS x "
                                             "depth_max tan(alpha)); depth from the tip's first contact"}
    with output_directory(out) as out, interruptible():
        clock = Stopwatch()
        body, geometry, mesh_unit = cone_body(cell, cell_shape, angle, depth, cap, layer)
        label = f"{describe_cell(cell)}, {cell_shape}, {indenter} {angle_given:g} deg"
        with progress_bar(progress, "depth {task.completed:.3f}", label=None) as bar:
            callback = None
            if bar is not None:
                task = bar.add_task(f"indent {label}", total=depth)
                callback = lambda rows: bar.update(task, completed=float(rows.load[-1]) * mesh_unit)  # noqa: E731
            try:
                result = indent_body(body, geometry, mesh_unit, rho, depth, steps, solver=linear_solver,
                                     on_row=callback, half_angle=angle)
                failure = None
            except AxisymmetricInterrupted as error:
                _write(out, error.partial, body, cell, geometry, unit, 0.0, cap, layer, depth, steps, label, clock,
                       vtk, failure=error, interrupted=True, solver=solver, tip=tip)
                raise AxisymmetricInterrupted(f"{error}; the converged rows are in {out}", error.partial) from None
            except AxisymmetricError as error:
                if error.partial is None or len(error.partial.load) < 2:
                    raise
                result, failure = error.partial, error
        summary = _write(out, result, body, cell, geometry, unit, 0.0, cap, layer, depth, steps, label, clock, vtk,
                         failure=failure, solver=solver, tip=tip)
    if failure is not None:
        raise AxisymmetricError(f"{failure} (rows up to depth={result.load[-1] / unit:.4f} written to {out})", None)
    return summary


CHECKPOINT_FORMAT = 2
"""Version of what a 3D indentation checkpoint's fingerprint covers; raised when the solver's rows for the same
inputs change (2: a p2 surface corner among pressed mid-side nodes stays in contact)."""


def _fingerprint(body: Cell, cell: CellParameters, bead: float, depth: float, steps: int, linear_solver: str) -> str:
    """The hash of everything that determines a 3D curve: the resolved cell, the bead, the load steps, the sparse
    solver and the sha256 of the mesh and the element moduli (a mesh that changed under the same parameters does
    not continue a curve made on the other)."""
    arrays = array_digest(body.mesh.nodes, body.mesh.elements, np.asarray(body.youngs_moduli, dtype=np.float64))
    return parameter_hash(cell, {"indenter_radius": bead, "depth_max": depth, "steps": steps,
                                 "linear_solver": linear_solver, "arrays": arrays}, format_version=CHECKPOINT_FORMAT)


def _finished_curve(out: Path, fingerprint: str) -> dict | None:
    """The metadata of the 3D curve already complete in ``out`` with this fingerprint, or None."""
    try:
        summary = json.loads((out / "metadata.json").read_text())
    except (OSError, ValueError):
        return None
    if (isinstance(summary, dict) and summary.get("complete") is True and summary.get("fingerprint") == fingerprint
            and (out / "indentation.csv").exists()):
        return summary
    return None


def _save_checkpoint(path: Path, result: Indentation3DResult, fingerprint: str) -> None:
    def write(temporary: Path) -> None:
        with temporary.open("wb") as handle:  # a file object: np.savez would append .npz to the temporary name
            np.savez(handle, fingerprint=np.array(fingerprint),
                     counts=np.array([result.newton_iterations, result.substeps]),
                     wall_time=np.array(result.wall_time),
                     **{name: getattr(result, name) for name in RESULT_ROWS.values()})

    replace_atomically(path, write)


def _load_checkpoint(path: Path, fingerprint: str, n_nodes: int) -> Indentation3DResult:
    """The rows of an interrupted 3D curve; a damaged or foreign file is one ParameterError naming --resume."""
    try:
        with np.load(path, allow_pickle=False) as data:
            found = str(data["fingerprint"])
            arrays = {name: np.array(data[name]) for name in RESULT_ROWS.values()}
            iterations, substeps = (int(v) for v in data["counts"])
            wall_time = float(data["wall_time"])
    except Exception as error:  # truncated, garbled, not an npz, missing arrays, pickled objects
        raise ParameterError("resume", f"cannot continue from {path}: the file is damaged or not an indentation "
                                       f"checkpoint ({type(error).__name__}); delete it to start again") from None
    if found != fingerprint:
        raise ParameterError("resume", f"{path} belongs to a curve with other parameters; rerun with the same "
                                       "options, or delete it to start again")
    rows = len(arrays["positions"])
    if rows < 1 or arrays["positions"].shape != (rows, n_nodes, 3) or any(len(a) != rows for a in arrays.values()):
        raise ParameterError("resume", f"cannot continue from {path}: its arrays are inconsistent; delete it to "
                                       "start again")
    return Indentation3DResult(**arrays, newton_iterations=iterations, substeps=substeps, n_nodes=n_nodes,
                               wall_time=wall_time)


def _table(result: AxisymmetricResult, body: AxisymmetricCell | Cell, cell: CellParameters,
           unit: float) -> tuple[dict, float]:
    """The columns of ``indentation.csv`` (lengths in the shape's unit L, or metres; force F/(E_c L^2), or
    newtons when both scales are physical) and E_eff/E_c of the body: the volume-weighted mean of E/E_c over it,
    1 + (gamma - 1) phi with phi the nucleus's volume fraction of this body (the cap's, not the sphere's)."""
    gamma_eff = float(np.sum(body.element_volumes * body.youngs_moduli) / body.volume)
    length = unit * cell.radius if cell.radius_is_physical else 1.0
    force = result.force / unit**2
    return {
        "depth": result.load / unit * length,
        "force": force * cell.youngs_modulus * length**2,
        "force_per_Ec_R2": force,
        "force_per_Eeff_R2": force / gamma_eff,
    }, gamma_eff


def _write(out: Path, result: AxisymmetricResult, body: AxisymmetricCell | Cell, cell: CellParameters,
           geometry: MeridianGeometry, unit: float, bead: float, cap: float | None, layer: float | None, depth: float,
           steps: int, label: str, clock: Stopwatch, vtk: bool, failure: Exception | None = None,
           interrupted: bool = False, solver: str = "auto", fingerprint: str | None = None,
           tip: dict | None = None) -> dict:
    """Write the outputs; ``tip``: the cone's description (None: the bead of radius ``bead``)."""
    out.mkdir(parents=True, exist_ok=True)
    three_d = isinstance(body, Cell)
    table, gamma_eff = _table(result, body, cell, unit)
    outputs = OutputSet()
    outputs.write(out / "indentation.csv", write_table, table)
    if not interrupted:
        outputs.write(out / "indentation.png", plot_indentation, result, cell, geometry, unit, bead, label,
                      "3D" if three_d else "axisymmetric", tip)
        if vtk and vtk_enabled() and three_d:
            outputs.write(out / "vtk", write_cell_vtk, body, result, cell)
        elif vtk and vtk_enabled():
            outputs.write(out / "vtk", write_meridian_vtk, body, result.positions / unit, unit * cell.radius)
    summary = {
        "scenario": "indentation",
        "label": label,
        "cell": cell.model_dump(mode="json"),
        "indentation": {
            "indenter": ({"indenter": "sphere", "indenter_radius_per_R": bead} if tip is None else tip),
            "cell_shape": geometry.shape, "indenter_radius_per_R": bead if tip is None else None, "cap_height_per_R": cap,
            "layer_thickness_per_R": layer, "layer_thickness_per_indenter_radius": (
                geometry.height if geometry.shape == "layer" and tip is None else None),
            "layer_width_per_indenter_radius": (geometry.layer_extent if geometry.shape == "layer" and tip is None
                                                else None),
            **({"layer_width_per_thickness": geometry.layer_extent / geometry.height}
               if geometry.shape == "layer" and tip is not None else {}),
            "depth_max": depth / unit, "steps": steps,
            "nucleus_placement": ("centred on the axis at half the apex height plus the offset along z"
                                  if geometry.shape == "cap" else "as in the suspended cell (centre + offset along z)"
                                  if geometry.shape == "sphere" else None),
            "support": "frictionless dish" if geometry.shape == "sphere" else "base bonded to the dish",
        },
        "length_unit": (LENGTH_UNIT[geometry.shape] if tip is None or geometry.shape != "layer"
                        else "h, the layer thickness (--layer-thickness)"),
        "effective_stiffness_ratio": gamma_eff,
        "units": {
            "depth": "m" if cell.radius_is_physical else "R",
            "force": {(True, True): "N", (True, False): "E_c m^2", (False, True): "Pa R^2",
                      (False, False): "E_c R^2"}[(cell.radius_is_physical, cell.youngs_modulus_is_physical)],
            "radius": cell.radius, "youngs_modulus": cell.youngs_modulus,
            "R": unit * cell.radius,
        },
        "mesh": {"n_nodes": body.mesh.n_nodes, "n_elements": body.mesh.n_elements,
                 "n_nucleus_elements": int((body.mesh.region == 1).sum()),
                 "element": ({1: "4-node tetrahedron", 2: "10-node tetrahedron"}[body.mesh.order] if three_d
                             else "6-node triangle (meridian)"),
                 "volume_per_unit3": body.volume},
        "solver": {"solver": "3d" if three_d else "axisymmetric", "requested": solver,
                   "newton_iterations": result.newton_iterations,
                   "substeps": result.substeps, "curve_time_s": result.wall_time,
                   "min_volume_ratio": float(result.min_volume_ratio.min()),
                   "max_contact_radius_per_R": float(result.contact_radius.max() / unit),
                   **({"max_rigid_reaction": float(result.max_rigid_reaction.max()),
                       "rigid_modes": "x, y translation and rotations held at three interior nodes, as in compress "
                                      "(max_rigid_reaction: their largest reaction over the bead's force)"}
                      if three_d else {})},
        "complete": failure is None,
        "depth_reached": float(result.load[-1] / unit),
        "wall_time_s": clock.elapsed,
        "software": software_versions(),
    }
    if failure is not None:
        summary["error"] = str(failure)
    if fingerprint is not None:
        summary["fingerprint"] = fingerprint
    if interrupted:
        summary["interrupted"] = True
    outputs.write(out / "metadata.json", write_json, summary)
    return summary


def plot_indentation(path: Path, result: AxisymmetricResult, cell: CellParameters, geometry: MeridianGeometry,
                     unit: float, bead: float, label: str, solver: str = "axisymmetric", tip: dict | None = None) -> None:
    """F/(E_c R^2) against depth/R with the small-depth Hertz limit of the shape (two contacts in series for
    the suspended sphere; the half-space for a cap or a layer, an upper bound at depth for thin ones); under a
    cone (``tip``), Sneddon's half-space cone, the layer in units of its thickness h."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    depth, force = result.load / unit, result.force / unit**2
    nu = cell.material.poisson_ratio
    figure, axis = plt.subplots(figsize=(5.5, 4.2), constrained_layout=True)
    axis.plot(depth, force, "o-", ms=3, label=f"elastocell ({solver})")
    fine = np.linspace(0, depth[-1], 60)
    length = "R" if geometry.shape != "layer" else "R_b" if tip is None else "h"
    if tip is not None:
        axis.plot(fine, sneddon_cone_force(fine, np.radians(tip["equivalent_cone_half_angle_deg"]), nu), "k:",
                  label="Sneddon, cone on a half-space")
    elif geometry.shape == "sphere":
        axis.plot(fine, hertz_sphere_indentation_force(fine, bead, nu), "k:", label="Hertz, bead and dish in series")
    else:
        axis.plot(fine, hertz_half_space_force(fine, bead / unit, nu), "k:", label="Hertz, half-space")
    axis.set_xlabel(f"depth / {length}")
    axis.set_ylabel(r"$F/(E_\mathrm{c} R^2)$" if length == "R" else rf"$F/(E {length}^2)$")
    axis.set_xlim(0, None)
    axis.set_ylim(0, None)
    axis.grid(alpha=0.3)
    axis.legend(fontsize=8)
    axis.set_title(label, fontsize=9)
    save_figure(figure, path, dpi=130)
    plt.close(figure)


def write_cell_vtk(directory: Path, body: Cell, result, cell: CellParameters) -> Path:
    """The 3D cell at every row (``indentation_NNNN.vtu`` and ``indentation.pvd``, time = depth), in metres when
    the radius is physical: displacement, region, stiffness ratio, Cauchy and von Mises stress (as compress)."""
    cell_data = []
    for x in result.positions:
        stress = body.element_cauchy_stress(x)
        cell_data.append({"stiffness_ratio": body.youngs_moduli, "region": body.mesh.region.astype(np.int32),
                          "cauchy_stress": stress.reshape(-1, 9) * cell.youngs_modulus,
                          "von_mises_stress": von_mises(stress) * cell.youngs_modulus})
    return write_vtk_series(directory, "indentation", body.mesh, result.positions * cell.radius, result.load,
                            cell_data)


def write_meridian_vtk(directory: Path, body: AxisymmetricCell, positions: np.ndarray, length: float) -> Path:
    """One ``indentation_NNNN.vtu`` per row: the meridian section (x = r, y = z, in units of ``length``) as
    quadratic triangles with the displacement and the region (ParaView opens the numbered files as one time
    series; its Rotational Extrusion filter revolves the section about y into the body)."""
    import meshio

    directory.mkdir(parents=True, exist_ok=True)
    reference = np.column_stack([body.mesh.nodes, np.zeros(body.mesh.n_nodes)]) * length
    for index, x in enumerate(positions):
        points = np.column_stack([x, np.zeros(len(x))]) * length
        meshio.Mesh(points, [("triangle6", body.mesh.elements)],
                    point_data={"displacement": points - reference},
                    cell_data={"region": [body.mesh.region.astype(np.int32)],
                               "stiffness_ratio": [body.youngs_moduli]}).write(
            directory / f"indentation_{index:04d}.vtu")
    return directory
