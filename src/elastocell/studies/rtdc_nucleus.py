"""Beyond every RT-DC table: which modulus does real-time deformability cytometry assign a cell with a stiff
nucleus? Cells with a centred nucleus (stiffness ratios gamma = E_n/E_c of :data:`STIFFNESS_RATIOS`, size ratios
lambda = R_n/R of :data:`SIZE_RATIOS`) and the random cell flow through the RT-DC channel (the pipe scenario,
centred start, stationary shape); each one's (projected area, deformation) is read through a homogeneous table,
as dclab reads a measurement, in two ways:

- elastocell's own homogeneous cells at the same settings (same channel, resolution, mesh rule, duration and
  stop): the homogeneous deformation D_h(E) at the cell's radius, interpolated in log D - log E
  (:func:`read_modulus`); run at the same discretisation, the lattice and mesh errors of the cell and of its
  reading largely cancel. This is ``E_RTDC``.
- dclab's own LE-2D-FEM-19 (``dclab.features.emodulus.get_emodulus``, the cell's (area_um, deform) in the table's
  channel, flow rate and viscosity): ``E_RTDC,dclab``, NaN where the point lies outside the table (coverage is
  recorded). It carries elastocell's discretisation error against the axisymmetric FEM table (the homogeneous
  rows show it: their ``E_RTDC,dclab/E``).

Both are set beside the cytoplasm's E_c, the volume average E_eff = E_c gamma_eff (gamma_eff of the meshed cell,
``Cell.effective_stiffness_ratio``, the paper's equivalent) and the best-fit homogeneous modulus E_fit: the
homogeneous modulus whose whole stationary shape (D, eps_x - 1, eps_r - 1) comes closest in log (least squares;
:func:`fit_modulus`), where E_RTDC matches D alone.

The channel, flow and medium are LE-2D-FEM-19's (so that no scaling of the table enters): the cylinder of radius
R_ch = 1.094 x 10 um standing for the 20 um square channel, Q = 0.04 uL/s, eta = 15 mPa s; a cell of radius
6 um and E_c = 2 kPa (Ca_w = G R_ch/(2 mu_c) = 0.864, nu = 0.48). Every cell sees the same nominal pressure gradient
(``capillary_number_modulus="mu_c"``; each run holds the flow rate G drives through the ideal channel, as RT-DC); the homogeneous cell of modulus s E_c runs at Ca_w/s. The table's
moduli are of an incompressible solid (nu = 0.5): the modulus dclab reads is converted to the cell's Poisson
ratio at equal shear modulus, E = E_t 2 (1 + nu)/3.

Settings (:func:`settings`): full: R/dx 6 (the markers at R - 0.3 dx, the pipe's default), each run until its mean deformation over a unit of 1/gdot_w is
stationary to 1e-3 or 20 units of 1/gdot_w, one resolution (no extrapolation: the reading cancels the
discretisation error instead); quick: R/dx 5 for 4 units, two nucleus cells and two homogeneous ones (a smoke
test, far from stationary).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from elastocell.inverse.lut import FINAL_WINDOW, SQUARE_CHANNEL_RADIUS_FACTOR, capillary_number_wall
from elastocell.studies.base import Claim, Member, Run, Study, rows_per_run
from elastocell.studies.compression import new_figure, save_study_figure, verdict

NAME = "rtdc-nucleus"

CHANNEL_WIDTH_UM = 20.0
FLOW_RATE_UL_S = 0.04
VISCOSITY_MPA_S = 15.0
TABLE = "LE-2D-FEM-19"
"""dclab's table, read in its own channel, flow rate and viscosity (no scaling)."""

RADIUS_UM = 6.0
CYTOPLASM_KPA = 2.0
POISSON_RATIO = 0.48
CHANNEL_RADIUS_RATIO = SQUARE_CHANNEL_RADIUS_FACTOR * CHANNEL_WIDTH_UM / 2.0 / RADIUS_UM
CAPILLARY_NUMBER_WALL = capillary_number_wall(FLOW_RATE_UL_S * 1e-9, CHANNEL_RADIUS_RATIO * RADIUS_UM * 1e-6,
                                              VISCOSITY_MPA_S * 1e-3, CYTOPLASM_KPA * 1e3, POISSON_RATIO)
"""Ca_w = G R_ch/(2 mu_c) of the cytoplasm in LE-2D-FEM-19's channel and flow (0.864)."""

STIFFNESS_RATIOS = (2, 5, 10)
SIZE_RATIOS = (0.3, 0.5, 0.7)
HOMOGENEOUS_RATIOS = (0.8, 1.0, 1.5, 2.25, 3.5, 5.0, 8.0)
"""E/E_c of the homogeneous reading cells (full): from below the cytoplasm (a nucleus cell's mesh may deform
slightly more than the homogeneous cytoplasm's: measured D 0.0508 for gamma 2, lambda 0.5 against 0.0500) to
above the stiffest E_eff (4.1 E_c; the random cell's meshed E_eff is 5.8 E_c)."""

QUICK_CELLS = ((2, 0.5), (10, 0.5))
QUICK_HOMOGENEOUS_RATIOS = (0.8, 2.5)

FULL_SETTINGS = {"resolution": 6.0, "extrapolate": False, "duration": 20.0, "stationary_tolerance": 1e-3,
                 "stationary_observable": "deformation", "vtk_interval": None}
QUICK_SETTINGS = {"resolution": 5.0, "duration": 4.0, "vtk_interval": None}


def settings(quick: bool) -> dict:
    """The pipe options every run of the study shares: the channel, the centred start, the stop."""
    return {**(QUICK_SETTINGS if quick else FULL_SETTINGS), "channel_radius_ratio": CHANNEL_RADIUS_RATIO,
            "start_offset": 0.0, "capillary_number_modulus": "mu_c"}


def members(quick: bool) -> list[Member]:
    base = settings(quick)
    cells = QUICK_CELLS if quick else [(g, s) for g in STIFFNESS_RATIOS for s in SIZE_RATIOS]
    out = [Member(Run.of("pipe", **base, capillary_number_wall=CAPILLARY_NUMBER_WALL, stiffness_ratio=float(g),
                         size_ratio=float(s)),
                  {"cell": f"gamma {g:g} lambda {s:g}", "kind": "nucleus", "stiffness_ratio": float(g),
                   "size_ratio": float(s), "modulus_ratio": np.nan}) for g, s in cells]
    if not quick:
        out.append(Member(Run.of("pipe", **base, capillary_number_wall=CAPILLARY_NUMBER_WALL, random=True, seed=0),
                          {"cell": "random", "kind": "random", "stiffness_ratio": np.nan, "size_ratio": np.nan,
                           "modulus_ratio": np.nan}))
    if not quick:  # the nucleus mesh with a nucleus as soft as the cytoplasm: what the mesh alone does to D
        out += [Member(Run.of("pipe", **base, capillary_number_wall=CAPILLARY_NUMBER_WALL, stiffness_ratio=1.0,
                              size_ratio=float(s)),
                       {"cell": f"gamma 1 lambda {s:g}", "kind": "mesh control", "stiffness_ratio": 1.0,
                        "size_ratio": float(s), "modulus_ratio": 1.0}) for s in SIZE_RATIOS]
    for ratio in QUICK_HOMOGENEOUS_RATIOS if quick else HOMOGENEOUS_RATIOS:
        out.append(Member(Run.of("pipe", **base, capillary_number_wall=CAPILLARY_NUMBER_WALL / ratio, nucleus="none"),
                          {"cell": f"homogeneous {ratio:g} E_c", "kind": "homogeneous", "stiffness_ratio": 1.0,
                           "size_ratio": 0.0, "modulus_ratio": float(ratio)}))
    return out


# =========================================================================== reading
SHAPE_COLUMNS = ("deformation", "projected_area", "strain_axial", "strain_radial")


def final_means(directory: Path) -> dict:
    """Means of :data:`SHAPE_COLUMNS` over the last :data:`~elastocell.inverse.lut.FINAL_WINDOW` of a run's time
    series (the look-up table's rule: the stretch judged stationary when the run stopped on the criterion);
    NaN without a time series."""
    import pandas as pd

    path = Path(directory) / "timeseries.csv"
    if not path.exists():
        return {column: np.nan for column in SHAPE_COLUMNS}
    table = pd.read_csv(path)
    last = table[table["time"] > table["time"].iloc[-1] - FINAL_WINDOW]
    return {column: float(last[column].mean()) for column in SHAPE_COLUMNS}


def read_modulus(deformation, homogeneous_ratios, homogeneous_deformations) -> np.ndarray:
    """E/E_c of the homogeneous cell with deformation ``deformation``: the homogeneous D(E) interpolated linearly
    in log D - log E (D falls with E); NaN outside the homogeneous runs' range (no extrapolation)."""
    ratios = np.asarray(homogeneous_ratios, float)
    d = np.asarray(homogeneous_deformations, float)
    keep = np.isfinite(d) & (d > 0)
    target = np.atleast_1d(np.asarray(deformation, float))
    if keep.sum() < 2:
        return np.full(target.shape, np.nan)
    order = np.argsort(d[keep])
    log_d, log_e = np.log(d[keep][order]), np.log(ratios[keep][order])
    with np.errstate(invalid="ignore", divide="ignore"):
        x = np.log(target)
    inside = np.isfinite(x) & (x >= log_d[0]) & (x <= log_d[-1])
    out = np.full(target.shape, np.nan)
    out[inside] = np.exp(np.interp(x[inside], log_d, log_e))
    return out


def shape_vector(deformation, strain_axial, strain_radial) -> np.ndarray:
    """(D, eps_x - 1, eps_r - 1): the stationary shape's deformation and its two strains, each about proportional
    to Ca_w at small deformation (the strains' signs depend on the confinement: a bullet has eps_x < 1 < eps_r, a
    cell squeezed into a narrow channel stretches along it)."""
    return np.stack([np.asarray(deformation, float), np.asarray(strain_axial, float) - 1.0,
                     np.asarray(strain_radial, float) - 1.0], axis=-1)


def fit_modulus(cell_shape, homogeneous_ratios, homogeneous_shapes, samples: int = 2001) -> float:
    """E_fit/E_c: the homogeneous modulus whose shape vector (:func:`shape_vector`, each entry interpolated
    linearly in log|entry| - log E between the homogeneous runs) is closest to the cell's in the least-squares
    sense of the logs; searched on ``samples`` points of the homogeneous runs' range. An entry takes part where
    the cell and every homogeneous run give it one sign (no sign change to take a log of); NaN without such an
    entry or with fewer than two finished homogeneous runs."""
    ratios = np.asarray(homogeneous_ratios, float)
    shapes = np.asarray(homogeneous_shapes, float)
    cell = np.asarray(cell_shape, float)
    keep = np.all(np.isfinite(shapes), axis=1)
    if keep.sum() < 2 or not np.all(np.isfinite(cell)):
        return float("nan")
    shapes = shapes[keep]
    sign = np.sign(cell)
    same = (sign != 0) & np.all(np.sign(shapes) == sign, axis=0)
    if not same.any():
        return float("nan")
    order = np.argsort(ratios[keep])
    log_e = np.log(ratios[keep][order])
    log_o = np.log(np.abs(shapes[order][:, same]))
    grid = np.linspace(log_e[0], log_e[-1], samples)
    curves = np.stack([np.interp(grid, log_e, log_o[:, k]) for k in range(log_o.shape[1])], axis=1)
    cost = np.sum((curves - np.log(np.abs(cell[same]))) ** 2, axis=1)
    return float(np.exp(grid[np.argmin(cost)]))


def table_modulus(area_um, deform) -> tuple[np.ndarray, str]:
    """(E in kPa at the cell's Poisson ratio, note): dclab's LE-2D-FEM-19 read at (area_um, deform) in its own
    channel, flow rate and viscosity, converted from the table's nu = 0.5 at equal shear modulus; NaN outside
    the table. The note is empty, or says why dclab gave nothing."""
    area_um = np.atleast_1d(np.asarray(area_um, float))
    deform = np.atleast_1d(np.asarray(deform, float))
    out = np.full(area_um.shape, np.nan)
    ok = np.isfinite(area_um) & np.isfinite(deform)
    if not ok.any():
        return out, ""
    try:
        from dclab.features import emodulus

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            e_table = emodulus.get_emodulus(area_um=area_um[ok].copy(), deform=deform[ok].copy(),
                                            medium=VISCOSITY_MPA_S, channel_width=CHANNEL_WIDTH_UM,
                                            flow_rate=FLOW_RATE_UL_S, px_um=0, temperature=None, lut_data=TABLE)
    except Exception as error:  # dclab refuses or is absent: the dclab column stays NaN, the reason is recorded
        return out, f"dclab: {type(error).__name__}: {error}"
    out[ok] = np.asarray(e_table, float) * 2.0 * (1.0 + POISSON_RATIO) / 3.0
    return out, ""


def rtdc_table(pairs, directory: Path, quick: bool = False):
    """One row per run: labels, status, the final-window shape, area_um = A R^2, and the moduli over E_c:
    ``e_rtdc_over_ec`` (elastocell's homogeneous reading), ``e_rtdc_dclab_over_ec`` (LE-2D-FEM-19),
    ``e_eff_over_ec`` (gamma_eff), ``e_fit_over_ec`` (whole shape), and E_RTDC over E_eff and E_fit."""
    import pandas as pd

    keys = ("capillary_number_wall", "capillary_number_wall_mu_c", "effective_stiffness_ratio", "stop_reason",
            "stationary", "volume_change_max_abs", "resolution", "nodes")
    frame = pd.DataFrame(rows_per_run(pairs, keys))
    shapes = [final_means(Path(directory) / path) for path in frame["run_directory"]]
    for column in SHAPE_COLUMNS:
        frame[column] = [s[column] for s in shapes]
    frame.loc[frame["status"] != "complete", list(SHAPE_COLUMNS)] = np.nan
    frame["stationary"] = frame["stop_reason"] == "stationary"
    frame["area_um"] = frame["projected_area"] * RADIUS_UM**2
    frame["e_eff_over_ec"] = np.where(frame["kind"] == "homogeneous", frame["modulus_ratio"],
                                      frame["effective_stiffness_ratio"].astype(float))
    homogeneous = frame[(frame["kind"] == "homogeneous") & frame["deformation"].notna()].sort_values("modulus_ratio")
    ratios = homogeneous["modulus_ratio"].to_numpy(float)
    frame["e_rtdc_over_ec"] = read_modulus(frame["deformation"].to_numpy(float), ratios,
                                           homogeneous["deformation"].to_numpy(float))
    dclab, note = table_modulus(frame["area_um"].to_numpy(float), frame["deformation"].to_numpy(float))
    frame["e_rtdc_dclab_over_ec"] = dclab / CYTOPLASM_KPA
    frame["dclab_note"] = note
    reference = shape_vector(homogeneous["deformation"], homogeneous["strain_axial"], homogeneous["strain_radial"])
    cells = shape_vector(frame["deformation"], frame["strain_axial"], frame["strain_radial"])
    frame["e_fit_over_ec"] = [fit_modulus(c, ratios, reference) for c in cells]
    # the mesh correction: D of the cell times D(homogeneous mesh, E_c)/D(its nucleus mesh at gamma 1)
    reference = homogeneous[homogeneous["modulus_ratio"] == 1.0]["deformation"]
    controls = frame[(frame["kind"] == "mesh control") & frame["deformation"].notna()]
    factor = {float(c["size_ratio"]): float(reference.iloc[0]) / float(c["deformation"])
              for _, c in controls.iterrows()} if len(reference) else {}
    corrected = [d * factor[float(size)] if kind == "nucleus" and float(size) in factor else np.nan
                 for d, size, kind in zip(frame["deformation"], frame["size_ratio"], frame["kind"], strict=True)]
    frame["e_rtdc_mesh_corrected_over_ec"] = read_modulus(np.asarray(corrected, float), ratios,
                                                          homogeneous["deformation"].to_numpy(float))
    frame["e_rtdc_over_eeff"] = frame["e_rtdc_over_ec"] / frame["e_eff_over_ec"]
    frame["e_rtdc_dclab_over_eeff"] = frame["e_rtdc_dclab_over_ec"] / frame["e_eff_over_ec"]
    frame["e_rtdc_over_efit"] = frame["e_rtdc_over_ec"] / frame["e_fit_over_ec"]
    # where E_RTDC lies between the cytoplasm (0) and the volume average (1)
    with np.errstate(invalid="ignore", divide="ignore"):
        frame["position_ec_to_eeff"] = (frame["e_rtdc_over_ec"] - 1.0) / (frame["e_eff_over_ec"] - 1.0)
    frame["radius_um"] = RADIUS_UM
    frame["cytoplasm_kpa"] = CYTOPLASM_KPA
    return frame


# =========================================================================== figure
def _cells(frame, kind: str = "nucleus"):
    return frame[(frame["kind"] == kind) & (frame["status"] == "complete")]


def plot_rtdc(frame, directory: Path, stem: str) -> list[Path]:
    """(a, b) E_RTDC/E_c and E_RTDC/E_eff against the stiffness ratio, one line per size ratio; (c, d) the same
    against the size ratio, one line per stiffness ratio. Filled: elastocell's homogeneous reading; open:
    LE-2D-FEM-19; crosses: elastocell's reading with the mesh correction (where the gamma 1 control ran); dashed
    (a, c): E_eff/E_c; grey band: the random cell."""
    figure, axes = new_figure(2, 2)
    cells = _cells(frame)
    random = _cells(frame, "random")
    for row, (x, group) in enumerate((("stiffness_ratio", "size_ratio"), ("size_ratio", "stiffness_ratio"))):
        for index, value in enumerate(sorted(cells[group].unique())):
            part = cells[cells[group] == value].sort_values(x)
            colour = f"C{index}"
            label = f"{'lambda' if group == 'size_ratio' else 'gamma'} {value:g}"
            for column, axis in (("e_rtdc_over_ec", axes[row][0]), ("e_rtdc_over_eeff", axes[row][1])):
                axis.plot(part[x], part[column], "o-", color=colour, label=f"{label}, elastocell table")
                dclab = column.replace("e_rtdc", "e_rtdc_dclab")
                axis.plot(part[x], part[dclab], "o", mfc="none", color=colour, label=f"{label}, {TABLE}")
                if "e_rtdc_mesh_corrected_over_ec" in part:
                    corrected = part["e_rtdc_mesh_corrected_over_ec"].to_numpy(float)
                    if column == "e_rtdc_over_eeff":
                        corrected = corrected / part["e_eff_over_ec"].to_numpy(float)
                    if np.isfinite(corrected).any():
                        axis.plot(part[x], corrected, "x:", color=colour, label=f"{label}, mesh-corrected")
            axes[row][0].plot(part[x], part["e_eff_over_ec"], "--", color=colour, lw=1, label=f"{label}, E_eff/E_c")
        for column, axis in (("e_rtdc_over_ec", axes[row][0]), ("e_rtdc_over_eeff", axes[row][1])):
            for _, cell in random.iterrows():
                if np.isfinite(cell[column]):
                    axis.axhline(cell[column], color="0.6", lw=3, alpha=0.5, label="random cell")
            axis.axhline(1.0, color="k", lw=0.8)
            axis.set_xlabel(r"stiffness ratio $\gamma = E_n/E_c$" if x == "stiffness_ratio"
                            else r"size ratio $\lambda = R_n/R$")
            axis.grid(alpha=0.3)
        axes[row][0].set_ylabel(r"$E_\mathrm{RTDC}/E_c$")
        axes[row][1].set_ylabel(r"$E_\mathrm{RTDC}/E_\mathrm{eff}$")
    axes[0][0].set_title("(a) against the cytoplasm's modulus")
    axes[0][1].set_title("(b) against the volume average")
    axes[1][0].set_title("(c)")
    axes[1][1].set_title("(d)")
    for axis in (axes[0][0], axes[1][0]):
        axis.legend(fontsize=6, ncol=2)
    figure.suptitle(f"Modulus a homogeneous RT-DC table assigns a nucleus cell (R = {RADIUS_UM:g} um, E_c = "
                    f"{CYTOPLASM_KPA:g} kPa, {CHANNEL_WIDTH_UM:g} um channel, {FLOW_RATE_UL_S:g} uL/s)", fontsize=9)
    return save_study_figure(figure, directory, stem)


# =========================================================================== claims
def _range(values) -> str:
    values = np.asarray(values, float)
    values = values[np.isfinite(values)]
    if not values.size:
        return "n/a"
    return f"{values.min():.3f}-{values.max():.3f} (median {np.median(values):.3f})"


def _caveat(frame) -> str:
    rows = frame[frame["status"] == "complete"]
    capped = rows[~rows["stationary"].astype(bool)]
    failed = frame[frame["status"] != "complete"]
    parts = []
    if len(capped):
        parts.append(f"{len(capped)} of {len(rows)} runs reached the duration cap before a stationary shape "
                     "(transient means): " + ", ".join(capped["cell"]))
    if len(failed):
        parts.append(f"{len(failed)} runs failed: " + ", ".join(failed["cell"]))
    return "; ".join(parts)


def claims_rtdc(frame) -> list[Claim]:
    cells = _cells(frame)
    read = cells[np.isfinite(cells["e_rtdc_over_ec"].astype(float))]
    caveat = _caveat(frame)
    controls = _cells(frame, "mesh control")
    if not controls.empty:  # what the nucleus mesh alone does: a gamma = 1 cell read through the homogeneous runs
        caveat = "; ".join(filter(None, [caveat, "mesh controls (gamma 1 on the nucleus meshes) read as E_RTDC/E_c "
                                         + ", ".join(f"{c}: {v:.3f}" for c, v in zip(controls["cell"],
                                                                                    controls["e_rtdc_over_ec"],
                                                                                    strict=True))]))
    note = f" [{caveat}]" if caveat else ""
    out = []
    if read.empty:
        missing = "no nucleus cell's deformation lies within the homogeneous runs' range"
        return [Claim(NAME, "A homogeneous RT-DC table reads a nucleus cell's volume average E_eff.",
                      "issue 25 (beyond the paper)", missing + note, "not measured", "", {})]
    e_c, e_eff = read["e_rtdc_over_ec"].to_numpy(float), read["e_rtdc_over_eeff"].to_numpy(float)
    position = read["position_ec_to_eeff"].to_numpy(float)
    closer_eff = int(np.sum(np.abs(np.log(e_eff)) < np.abs(np.log(e_c))))
    per_cell = {c: {"e_rtdc_over_ec": float(a), "e_rtdc_over_eeff": float(b), "e_eff_over_ec": float(g),
                    "e_fit_over_ec": float(f), "position_ec_to_eeff": float(p), "stationary": bool(s)}
                for c, a, b, g, f, p, s in zip(read["cell"], e_c, e_eff, read["e_eff_over_ec"], read["e_fit_over_ec"],
                                               position, read["stationary"], strict=True)}
    which = ("the volume average E_eff" if np.nanmedian(position) > 0.5 else "the cytoplasm's E_c"
             if np.nanmedian(position) < 0.5 else "halfway between E_c and E_eff")
    summary = (f"over {len(read)} nucleus cells: E_RTDC/E_c {_range(e_c)}, E_RTDC/E_eff {_range(e_eff)}; "
               f"(E_RTDC - E_c)/(E_eff - E_c) {_range(position)} (0: the cytoplasm, 1: the volume average); "
               f"E_RTDC is closer (in log) to E_eff than to E_c for {closer_eff} of {len(read)}; RT-DC measures "
               f"nearer {which}")
    worst_eff = float(np.max(np.abs(e_eff - 1)))
    out.append(Claim(NAME, "A homogeneous RT-DC table reads a nucleus cell's volume average E_eff (the paper's "
                     "equivalent modulus).", "issue 25 (beyond the paper)", summary + note,
                     verdict(worst_eff, 0.10, 0.30), "agree if |E_RTDC/E_eff - 1| <= 10 % for every nucleus cell, "
                     "partly within 30 %", per_cell))
    corrected = read["e_rtdc_mesh_corrected_over_ec"].to_numpy(float) if "e_rtdc_mesh_corrected_over_ec" in read \
        else np.full(len(read), np.nan)
    if np.isfinite(corrected).any():
        gamma_eff = read["e_eff_over_ec"].to_numpy(float)
        with np.errstate(invalid="ignore", divide="ignore"):
            moved = (corrected - 1) / (gamma_eff - 1)
        out[-1].measured += (f"; with the mesh correction (D times D_hom(E_c)/D of the gamma 1 control on the same "
                             f"nucleus mesh): E_RTDC/E_c {_range(corrected)}, E_RTDC/E_eff "
                             f"{_range(corrected / gamma_eff)}, (E_RTDC - E_c)/(E_eff - E_c) {_range(moved)}")
        out[-1].values["mesh_corrected"] = {c: float(v) for c, v in zip(read["cell"], corrected, strict=True)}
    out.append(Claim(NAME, "A homogeneous RT-DC table reads a nucleus cell's cytoplasm modulus E_c.",
                     "issue 25 (beyond the paper)", f"E_RTDC/E_c {_range(e_c)}" + note,
                     verdict(float(np.max(np.abs(e_c - 1))), 0.10, 0.30),
                     "agree if |E_RTDC/E_c - 1| <= 10 % for every nucleus cell, partly within 30 %", {}))
    fit = read["e_rtdc_over_efit"].to_numpy(float)
    out.append(Claim(NAME, "The RT-DC modulus (from the deformation alone) equals the best-fit homogeneous modulus "
                     "of the whole stationary shape (D, eps_x, eps_r).", "issue 25 (beyond the paper)",
                     f"E_RTDC/E_fit {_range(fit)}; E_fit/E_c {_range(read['e_fit_over_ec'])}" + note,
                     verdict(float(np.nanmax(np.abs(fit - 1))) if np.isfinite(fit).any() else np.nan, 0.10, 0.30),
                     "agree if |E_RTDC/E_fit - 1| <= 10 % for every nucleus cell, partly within 30 %", {}))
    out.append(_stiffer_nucleus_claim(cells, note))
    out.append(_dclab_claim(frame, note))
    random = _cells(frame, "random")
    if not random.empty:
        r = random.iloc[0]
        out.append(Claim(NAME, "A homogeneous RT-DC table reads the random cell's volume average E_eff.",
                         "issue 25 (beyond the paper)",
                         f"random cell: E_RTDC/E_c {r['e_rtdc_over_ec']:.3f}, E_eff/E_c {r['e_eff_over_ec']:.3f}, "
                         f"E_RTDC/E_eff {r['e_rtdc_over_eeff']:.3f}, E_fit/E_c {r['e_fit_over_ec']:.3f}" + note,
                         verdict(abs(float(r["e_rtdc_over_eeff"]) - 1), 0.10, 0.30),
                         "agree if |E_RTDC/E_eff - 1| <= 10 %, partly within 30 %", {}))
    return out


def _stiffer_nucleus_claim(cells, note: str) -> Claim:
    """At every size ratio with two or more stiffness ratios: the deformation falls and E_RTDC rises with gamma."""
    checks, detail = [], []
    for size in sorted(cells["size_ratio"].unique()):
        part = cells[cells["size_ratio"] == size].sort_values("stiffness_ratio")
        if len(part) < 2:
            continue
        d = part["deformation"].to_numpy(float)
        e = part["e_rtdc_over_ec"].to_numpy(float)
        falls = bool(np.all(np.diff(d) < 0))
        rises = bool(np.all(np.diff(e[np.isfinite(e)]) > 0))
        checks.append(falls and rises)
        detail.append(f"lambda {size:g}: gamma " + "/".join(f"{g:g}" for g in part["stiffness_ratio"]) + ": D "
                      + ", ".join(f"{v:.4f}" for v in d) + "; E_RTDC/E_c " + ", ".join(f"{v:.3f}" for v in e))
    return Claim(NAME, "At equal E_c and nucleus size, a stiffer nucleus deforms the cell less and raises the "
                 "modulus RT-DC assigns.", "issue 25 (beyond the paper)", "; ".join(detail) + note if detail else
                 "fewer than two stiffness ratios at one size ratio",
                 "not measured" if not checks else "agree" if all(checks) else "partly" if any(checks) else
                 "disagree", "agree if D falls and E_RTDC rises with gamma at every size ratio", {})


def _dclab_claim(frame, note: str) -> Claim:
    """LE-2D-FEM-19's reading against elastocell's, with the table's read of elastocell's homogeneous cells as
    the calibration: E_dclab/E of the homogeneous runs, interpolated at the cell's deformation (log D), is what
    the discretisation error alone makes dclab read there."""
    rows = frame[frame["status"] == "complete"]
    covered = rows[np.isfinite(rows["e_rtdc_dclab_over_ec"].astype(float))]
    homogeneous = covered[covered["kind"] == "homogeneous"].sort_values("deformation")
    bias = (homogeneous["e_rtdc_dclab_over_ec"] / homogeneous["modulus_ratio"]).to_numpy(float)
    nucleus = covered[(covered["kind"] != "homogeneous") & np.isfinite(covered["e_rtdc_over_ec"].astype(float))]
    ratio = (nucleus["e_rtdc_dclab_over_ec"] / nucleus["e_rtdc_over_ec"]).to_numpy(float)
    if len(homogeneous) >= 2 and len(nucleus):
        bias_at = np.interp(np.log(nucleus["deformation"].to_numpy(float)),
                            np.log(homogeneous["deformation"].to_numpy(float)), bias)
        calibrated = ratio / bias_at
    else:
        calibrated = np.array([])
    reason = next((n for n in rows.get("dclab_note", []) if n), "")
    measured = (f"{TABLE} covers {len(covered)} of {len(rows)} runs{' (' + reason + ')' if reason else ''}; "
                f"homogeneous runs: E_dclab/E {_range(bias)} (elastocell's discretisation error against the table); "
                f"nucleus cells: E_RTDC,dclab/E_RTDC {_range(ratio)}, the same over the homogeneous runs' E_dclab/E "
                f"at the cell's deformation {_range(calibrated)}; E_RTDC,dclab/E_eff "
                f"{_range(nucleus['e_rtdc_dclab_over_eeff'])}")
    return Claim(NAME, f"dclab's {TABLE} read of the same cells agrees with elastocell's homogeneous reading, once "
                 "the table's read of elastocell's homogeneous cells at the same deformation is divided out.",
                 "issue 25 (beyond the paper)", measured + note,
                 verdict(float(np.max(np.abs(calibrated - 1))) if calibrated.size else np.nan, 0.05, 0.15),
                 "agree if E_RTDC,dclab/E_RTDC over the homogeneous runs' E_dclab/E at the cell's deformation is "
                 "within 5 % of 1 for every covered nucleus cell, partly within 15 %",
                 {"coverage": [len(covered), len(rows)]})


STUDY = Study(NAME, "The modulus RT-DC assigns a cell with a stiff nucleus", "beyond the paper (issue 25)",
              "Cells with a centred nucleus (gamma 2, 5, 10; lambda 0.3, 0.5, 0.7) and the random cell in RT-DC's "
              "20 um channel (LE-2D-FEM-19's cylinder, 0.04 uL/s, 15 mPa s), read through homogeneous tables "
              "(elastocell's at the same discretisation and dclab's LE-2D-FEM-19) beside E_c, the volume average "
              "E_eff and the best-fit homogeneous modulus.", members, rtdc_table, plot_rtdc, claims_rtdc)
