"""The paper's Fig. 1a as a study: the nucleus cell, the random cell and the homogeneous equivalent, cut through
their centre and coloured by the stiffness ratio of each tetrahedron; its table lists each model's mesh and
volume-averaged modulus (no simulation)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from elastocell.body.cell import Cell
from elastocell.parameters.cell import cell_parameters
from elastocell.studies.base import Claim, Study
from elastocell.studies.compression import new_figure, percent, save_study_figure, settings

MODELS = (
    ("nucleus cell (gamma 10, lambda 0.5)", {"stiffness_ratio": 10, "size_ratio": 0.5}, False),
    ("random cell (gamma_i ~ U[1, 10])", {"random": True, "seed": 0}, False),
    ("homogeneous equivalent of the nucleus cell", {"stiffness_ratio": 10, "size_ratio": 0.5}, True),
)


def _cell(options: dict, equivalent: bool, quick: bool):

    mesh_options = {k: v for k, v in settings(quick).items() if k in ("element", "mesh_size")}
    parameters = cell_parameters(**mesh_options, **options)
    body = Cell.from_parameters(parameters)
    return parameters, (body.equivalent() if equivalent else body)


def cross_section(nodes: np.ndarray, tetrahedra: np.ndarray, axis: int = 1, level: float = 0.0):
    """Polygons where the plane x_axis = level cuts the tetrahedra (corner nodes): (indices of the cut
    tetrahedra, list of (k, 2) vertex arrays in the two other coordinates). Vectorised over tetrahedra."""
    corners = nodes[tetrahedra[:, :4]]  # (e, 4, 3)
    height = corners[:, :, axis] - level
    cut = (height.min(1) < 0) & (height.max(1) > 0)
    corners, height = corners[cut], height[cut]
    other = [i for i in range(3) if i != axis]
    edges = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])
    a, b = height[:, edges[:, 0]], height[:, edges[:, 1]]
    crosses = (a * b) < 0
    t = np.divide(a, a - b, out=np.zeros_like(a), where=crosses)
    points = corners[:, edges[:, 0]] + t[..., None] * (corners[:, edges[:, 1]] - corners[:, edges[:, 0]])
    polygons = []
    for mask, pts in zip(crosses, points[..., other], strict=True):  # 3 or 4 points per cut tetrahedron
        p = pts[mask]
        centre = p.mean(0)
        order = np.argsort(np.arctan2(p[:, 1] - centre[1], p[:, 0] - centre[0]))
        polygons.append(p[order])
    return np.flatnonzero(cut), polygons


def models_table(pairs, directory: Path, quick: bool = False):
    import pandas as pd

    rows = []
    for label, options, equivalent in MODELS:
        parameters, body = _cell(options, equivalent, quick)
        volume_fraction = parameters.nucleus.volume_fraction() if parameters.random is None else np.nan
        analytic = (1 + (parameters.nucleus.stiffness_ratio - 1) * volume_fraction if parameters.random is None
                    else (parameters.random.low + parameters.random.high) / 2)
        weights = body.element_volumes / body.volume
        # the random cell's volume average is a weighted mean of independent U[1, 10] draws: its standard error
        spread = (parameters.random.high - parameters.random.low) / np.sqrt(12) if parameters.random is not None else 0
        rows.append({"model": label, "equivalent": equivalent, **body.mesh.counts(),
                     "effective_stiffness_ratio_standard_error": float(spread * np.sqrt(np.sum(weights ** 2))),
                     "effective_stiffness_ratio": float(body.effective_stiffness_ratio),
                     "effective_stiffness_ratio_analytic": float(analytic),
                     "stiffness_ratio_min": float(body.youngs_moduli.min()),
                     "stiffness_ratio_max": float(body.youngs_moduli.max()),
                     "element_order": body.mesh.order, "options": str(options)})
    return pd.DataFrame(rows)


def plot_models(frame, directory: Path, stem: str, quick: bool | None = None) -> list[Path]:
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    quick = bool(frame["element_order"].iloc[0] == 1) if quick is None else quick
    figure, axes = new_figure(1, 3)
    norm = plt.Normalize(1, 10)
    for axis, (label, options, equivalent) in zip(axes[0], MODELS, strict=True):
        _, body = _cell(options, equivalent, quick)
        cut, polygons = cross_section(body.mesh.nodes, body.mesh.elements)
        collection = PolyCollection(polygons, array=body.youngs_moduli[cut], cmap="viridis", norm=norm,
                                    edgecolor="k", linewidth=0.15)
        axis.add_collection(collection)
        axis.set_xlim(-1.05, 1.05)
        axis.set_ylim(-1.05, 1.05)
        axis.set_aspect("equal")
        axis.set_title(label, fontsize=9)
        axis.set_xlabel("x/R")
        axis.set_ylabel("z/R")
    figure.colorbar(collection, ax=axes[0].tolist(), label=r"stiffness ratio $E_i/E_c$", shrink=0.8)
    return save_study_figure(figure, directory, stem)


def claims_models(frame) -> list[Claim]:
    out = []
    for _, row in frame.iterrows():
        if row["equivalent"]:
            continue
        error = row["effective_stiffness_ratio"] / row["effective_stiffness_ratio_analytic"] - 1
        standard_error = float(row.get("effective_stiffness_ratio_standard_error", 0.0) or 0.0)
        if standard_error > 0:  # random cell: a sample of the distribution, judged statistically
            z = (row["effective_stiffness_ratio"] - row["effective_stiffness_ratio_analytic"]) / standard_error
            out.append(Claim(
                "cell-models", f"The {row['model']}: its volume-averaged modulus estimates the mean of U[1, 10], "
                "E_eff/E_c = 5.5 (the equivalent uses the cell's own volume average).", "Sec. 2.2",
                f"meshed cell: {row['effective_stiffness_ratio']:.4f} ({row['n_elements']} elements), standard error "
                f"of a volume-weighted mean of U[1, 10] draws {standard_error:.4f}: {z:+.2f} standard errors",
                "agree" if abs(z) <= 2 else "partly" if abs(z) <= 3 else "disagree",
                "agree if within 2 standard errors, partly within 3", {"z": z}))
            continue
        out.append(Claim(
            "cell-models", f"Volume-averaged modulus of the {row['model']}: E_eff/E_c = "
            f"{row['effective_stiffness_ratio_analytic']:.4g} (1 + (gamma - 1) lambda^3).",
            "Sec. 2.2, Eq. (4)", f"meshed cell: {row['effective_stiffness_ratio']:.4f} ({row['n_elements']} elements); "
            f"relative difference {percent(error)}",
            "agree" if abs(error) <= 0.01 else "partly" if abs(error) <= 0.03 else "disagree",
            "agree if the mesh's volume average is within 1 % of the analytic value, partly within 3 %",
            {"meshed": row["effective_stiffness_ratio"], "analytic": row["effective_stiffness_ratio_analytic"]}))
    return out


STUDY = Study("cell-models", "The three cell models", "fig-cell-model",
              "Cut-away views (plane y = 0) of the nucleus cell, the random cell and the homogeneous equivalent, "
              "coloured by stiffness ratio; mesh counts and volume-averaged moduli.",
              lambda quick: [], models_table, plot_models, claims_models)
