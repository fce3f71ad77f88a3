"""The paper's flow figures as studies: Taylor deformation against Ca in shear flow (section 3.2), the offset
nucleus in shear flow, and the centred cell in pipe flow (section 3.3).

Every heterogeneous cell and its equivalent see the same flow: Ca is defined with the cytoplasm's mu_c
(``capillary_number_modulus="mu_c"``), so the equivalent runs at Ca/gamma_eff, the same physical shear rate
or pressure gradient. Axes: shear flow along x, gradient along y, vorticity along z (the shear plane is
x-y); the pipe's axis is x.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from elastocell.scenarios.pipe import DEFAULT_CAPILLARY_NUMBER_WALL
from elastocell.studies.base import FLOW_SUMMARY_KEYS, Claim, Member, Run, Study, rows_per_run
from elastocell.studies.compression import new_figure, percent, save_study_figure, verdict

SHEAR_CA_FULL = (0.0125, 0.025, 0.05, 0.1, 0.2, 0.3)
SHEAR_CA_QUICK = (0.05, 0.2)  # at small Ca the stiff elements (random cell, gamma 10) need 2-6x more steps
SHEAR_STIFFNESS_RATIOS = (2, 5, 10)
OFFSET_CA_FULL = (0.05, 0.1, 0.2)
OFFSET_CA_QUICK = (0.3,)  # the 0.05 R gap between nucleus and surface needs ~17x more steps per strain (elastic stability) at Ca 0.1
PIPE_STIFFNESS_RATIOS = (1, 2, 10)
SMALL_DEFORMATION = 0.02  # the paper: below D = 0.02 the equivalent is inaccurate


def shear_settings(quick: bool, long: bool = False) -> dict:
    """R/dx 5 and a few strain units (quick), or the default R/dx 8 until D is stationary (full)."""
    if quick:
        return {"resolution": 5.0, "duration": 6.0 if long else 4.0, "vtk_interval": None,
                "capillary_number_modulus": "mu_c"}
    return {"duration": 24.0 if long else 12.0, "stationary_tolerance": None if long else 0.002,
            "vtk_interval": 2.0, "capillary_number_modulus": "mu_c"}


def pipe_settings(quick: bool) -> dict:
    if quick:
        return {"resolution": 5.0, "duration": 4.0, "vtk_interval": None, "capillary_number_modulus": "mu_c"}
    return {"duration": 10.0, "vtk_interval": 2.0, "capillary_number_modulus": "mu_c"}


def _pair(scenario: str, options: dict, labels: dict, equivalent: bool = True) -> list[Member]:
    members = [Member(Run.of(scenario, **options), {**labels, "equivalent": False})]
    if equivalent:
        members.append(Member(Run.of(scenario, **options, equivalent=True), {**labels, "equivalent": True}))
    return members


def shear_capillary_members(quick: bool) -> list[Member]:
    members = []
    for ca in SHEAR_CA_QUICK if quick else SHEAR_CA_FULL:
        base = {**shear_settings(quick), "capillary_number": ca}
        for gamma in SHEAR_STIFFNESS_RATIOS:
            members += _pair("shear", {**base, "stiffness_ratio": gamma, "size_ratio": 0.5},
                             {"cell": f"gamma {gamma:g}", "stiffness_ratio": float(gamma)})
        members += _pair("shear", {**base, "random": True, "seed": 0}, {"cell": "random", "stiffness_ratio": np.nan})
        members += _pair("shear", {**base, "nucleus": "none"}, {"cell": "homogeneous mu_c", "stiffness_ratio": 1.0},
                         equivalent=False)
    return members


def shear_offset_members(quick: bool) -> list[Member]:
    members = []
    for ca in OFFSET_CA_QUICK if quick else OFFSET_CA_FULL:
        base = {**shear_settings(quick, long=True), "capillary_number": ca, "stiffness_ratio": 2, "size_ratio": 0.5}
        members += _pair("shear", base, {"cell": "centred", "axis": ""})
        for axis, where in (("x", "in the shear plane"), ("z", "perpendicular to the shear plane")):
            members += _pair("shear", {**base, "offset": 0.45, "offset_axis": axis},
                             {"cell": f"offset 0.45 {where}", "axis": axis}, equivalent=False)
    return members


def pipe_members(quick: bool) -> list[Member]:

    base = {**pipe_settings(quick), "capillary_number_wall": DEFAULT_CAPILLARY_NUMBER_WALL}
    members = []
    for gamma in PIPE_STIFFNESS_RATIOS:
        members += _pair("pipe", {**base, "stiffness_ratio": gamma, "size_ratio": 0.5},
                         {"cell": f"gamma {gamma:g}", "stiffness_ratio": float(gamma)})
    members += _pair("pipe", {**base, "random": True, "seed": 0}, {"cell": "random", "stiffness_ratio": np.nan})
    return members


def shear_table(pairs, directory: Path, quick: bool = False):
    import pandas as pd


    return pd.DataFrame(rows_per_run(pairs, FLOW_SUMMARY_KEYS["shear"] + ("resolution", "nodes")))


def pipe_table(pairs, directory: Path, quick: bool = False):
    import pandas as pd


    return pd.DataFrame(rows_per_run(pairs, FLOW_SUMMARY_KEYS["pipe"] + ("resolution", "nodes")))


def _complete(frame):
    return frame[frame["status"] == "complete"]


def _series(frame, cell: str, equivalent: bool, x: str = "capillary_number_mu_c", y: str = "taylor_deformation_mean"):
    rows = _complete(frame)
    rows = rows[(rows["cell"] == cell) & (rows["equivalent"].astype(bool) == equivalent)].sort_values(x)
    return rows[x].to_numpy(float), rows[y].to_numpy(float)


# =========================================================================== shear-capillary
def plot_shear_capillary(frame, directory: Path, stem: str) -> list[Path]:
    figure, axes = new_figure(1, 2)
    left, right = axes[0]
    cells = [c for c in dict.fromkeys(frame["cell"]) if c != "homogeneous mu_c"]
    for index, cell in enumerate(cells):
        colour = f"C{index}"
        ca, d = _series(frame, cell, False)
        left.plot(ca, d, "o", color=colour, label=cell)
        ca_eq, d_eq = _series(frame, cell, True)
        left.plot(ca_eq, d_eq, ":", color=colour, lw=1.5)
        if len(ca) and len(ca_eq):
            common = np.intersect1d(ca, ca_eq)
            right.plot(common, 100 * (d[np.isin(ca, common)] / d_eq[np.isin(ca_eq, common)] - 1), "o-",
                       color=colour, label=cell)
    ca, d = _series(frame, "homogeneous mu_c", False)
    left.plot(ca, d, "k--", lw=1, label=r"homogeneous, $\mu_c$ throughout")
    left.axhspan(0, SMALL_DEFORMATION, color="0.9", zorder=0, label=f"D < {SMALL_DEFORMATION:g}")
    left.set_xscale("log")
    left.set_yscale("log")
    left.set_xlabel(r"Ca = $\eta\dot\gamma/\mu_c$")
    left.set_ylabel("stationary Taylor deformation D")
    left.set_title("(a) markers: cells, dotted: equivalents")
    left.legend(fontsize=7)
    right.axhline(0, color="k", lw=0.8)
    right.set_xscale("log")
    right.set_xlabel(r"Ca = $\eta\dot\gamma/\mu_c$")
    right.set_ylabel(r"$D/D_\mathrm{eq} - 1$ (%)")
    right.set_title("(b) deviation from the equivalent")
    right.legend(fontsize=7)
    for axis in (left, right):
        axis.grid(alpha=0.3, which="both")
    return save_study_figure(figure, directory, stem)


def _relative(frame, cell: str, reference_cell: str | None = None, reference_equivalent: bool = True):
    """(Ca, D, D_ref, D/D_ref - 1) on the Ca both series have."""
    ca, d = _series(frame, cell, False)
    ca_r, d_r = _series(frame, reference_cell or cell, reference_equivalent)
    common = np.intersect1d(ca, ca_r)
    d, d_r = d[np.isin(ca, common)], d_r[np.isin(ca_r, common)]
    return common, d, d_r, d / d_r - 1


def claims_shear_capillary(frame) -> list[Claim]:
    out = []
    cells = [c for c in dict.fromkeys(frame["cell"]) if c != "homogeneous mu_c"]
    large, values = {}, {}
    for cell in cells:
        ca, d, d_eq, dev = _relative(frame, cell)
        keep = d_eq >= SMALL_DEFORMATION
        values[cell] = {f"{c:g}": float(v) for c, v in zip(ca, dev, strict=True)}
        large[cell] = float(np.abs(dev[keep]).max()) if keep.any() else np.nan
    worst = max((v for v in large.values() if np.isfinite(v)), default=np.nan)
    out.append(Claim(
        "shear-capillary", "The stationary Taylor deformation of nucleus cells (gamma 2, 5, 10) and the random "
        "cell agrees with their homogeneous equivalents over a wide range of deformations (D >= 0.02).",
        "Sec. 3.2, Fig. 5", "largest |D/D_eq - 1| where D_eq >= 0.02: "
        + ", ".join(f"{c}: {percent(v)}" for c, v in large.items()), verdict(worst, 0.05, 0.15),
        "agree if every cell is within 5 %, partly within 15 %", {"deviation_by_ca": values}))
    ca, d, d_eq, dev = _relative(frame, "gamma 2")
    keep = d_eq >= SMALL_DEFORMATION
    out.append(Claim(
        "shear-capillary", "The gamma = 2 cell deforms slightly less than its equivalent (as in compression).",
        "Sec. 3.2", "D/D_eq - 1 for gamma 2: " + ", ".join(f"Ca {c:g}: {100 * v:+.2f} %" for c, v in
                                                           zip(ca, dev, strict=True)),
        "not measured" if not keep.any() else "agree" if np.all(dev[keep] < 0) else
        "partly" if np.any(dev[keep] < 0) else "disagree",
        "agree if D < D_eq at every Ca with D_eq >= 0.02", {}))
    closer, detail = [], []
    for cell in cells:
        ca, d, d_eq, _ = _relative(frame, cell)
        ca_h, _, d_h, _ = _relative(frame, cell, "homogeneous mu_c", False)
        small = [c for c in ca if c in ca_h and d[ca == c][0] < SMALL_DEFORMATION]
        for c in small:
            dc, deq, dh = d[ca == c][0], d_eq[ca == c][0], d_h[ca_h == c][0]
            closer.append(abs(dc - dh) < abs(dc - deq))
            detail.append(f"{cell} Ca {c:g}: D {dc:.4f}, equivalent {deq:.4f}, homogeneous mu_c {dh:.4f}")
    out.append(Claim(
        "shear-capillary", "Below D = 0.02 the equivalent is inaccurate: the cell's D approaches that of a "
        "homogeneous cell with mu_c throughout.", "Sec. 3.2",
        "; ".join(detail) if detail else "no run with D < 0.02",
        "not measured" if not closer else "agree" if all(closer) else "partly" if any(closer) else "disagree",
        "agree if, at every Ca where the cell's D < 0.02, it is closer to the mu_c cell's D than to the "
        "equivalent's", {}))
    if "gamma 10" in large:
        at_top = {}
        for cell in cells:
            ca, _, _, dev = _relative(frame, cell)
            if len(ca):
                at_top[cell] = float(abs(dev[-1]))
        best = min(at_top, key=at_top.get) if at_top else None
        out.append(Claim(
            "shear-capillary", "The gamma = 10 cell is surprisingly accurate at large deformation.", "Sec. 3.2",
            "|D/D_eq - 1| at the largest Ca: " + ", ".join(f"{c}: {percent(v)}" for c, v in at_top.items()),
            "not measured" if best is None else "agree" if at_top["gamma 10"] <= 0.02 else
            "partly" if best == "gamma 10" else "disagree",
            "agree if within 2 % at the largest Ca; partly if it is the closest cell there", at_top))
    return out


# =========================================================================== shear-offset
def _timeseries(directory: Path, run_directory: str):
    path = Path(directory) / run_directory / "timeseries.csv"
    if not path.exists():
        return None
    return np.genfromtxt(path, delimiter=",", names=True)


def plot_shear_offset(frame, directory: Path, stem: str) -> list[Path]:
    figure, axes = new_figure(1, 2)
    left, right = axes[0]
    rows = _complete(frame)
    first_ca = rows["capillary_number_mu_c"].min() if len(rows) else np.nan
    for index, (_, row) in enumerate(rows[rows["capillary_number_mu_c"] == first_ca].iterrows()):
        series = _timeseries(directory, row["run_directory"])
        if series is None:
            continue
        label = row["cell"] + (" (equivalent)" if row["equivalent"] else "")
        style = {"ls": "--"} if row["axis"] == "x" else {"ls": ":"} if row["equivalent"] else {}
        left.plot(series["strain"], series["taylor_deformation"], color=f"C{index}", lw=1.2, label=label, **style)
    left.set_xlabel(r"$t\dot\gamma$")
    left.set_ylabel("Taylor deformation D")
    left.set_title(f"(b) D against time, Ca = {first_ca:g}")
    left.legend(fontsize=7)
    for index, cell in enumerate(dict.fromkeys(frame["cell"])):
        for equivalent in (False, True):
            ca, d = _series(frame, cell, equivalent)
            if len(ca):
                right.plot(ca, d, ":" if equivalent else "o-", color=f"C{index}",
                           label=cell + (" (equivalent)" if equivalent else ""))
    right.set_xlabel(r"Ca = $\eta\dot\gamma/\mu_c$")
    right.set_ylabel("time-averaged D")
    right.set_title("(c) time average against Ca")
    right.legend(fontsize=7)
    for axis in (left, right):
        axis.grid(alpha=0.3)
    return save_study_figure(figure, directory, stem)


def claims_shear_offset(frame) -> list[Claim]:
    rows = _complete(frame)
    out = []
    if rows.empty:
        return out

    def pick(cell, equivalent=False):
        chosen = rows[(rows["cell"] == cell) & (rows["equivalent"].astype(bool) == equivalent)]
        return chosen.set_index("capillary_number_mu_c")

    parallel, perpendicular = pick("offset 0.45 in the shear plane"), pick("offset 0.45 perpendicular to the shear plane")
    centred, equivalent = pick("centred"), pick("centred", True)
    common = sorted(set(parallel.index) & set(perpendicular.index))
    ratios = {f"{c:g}": float(parallel.loc[c, "taylor_deformation_std"] /
                              max(perpendicular.loc[c, "taylor_deformation_std"], 1e-12)) for c in common}
    out.append(Claim(
        "shear-offset", "With the nucleus displaced in the shear plane, D oscillates (the bump travels around the "
        "tank-treading cell); displaced perpendicular to it, D is stationary.", "Sec. 3.2, Fig. 6b",
        "std of D over the stationary part, in-plane / perpendicular: "
        + ", ".join(f"Ca {c}: {r:.1f}x" for c, r in ratios.items()),
        "not measured" if not ratios else "agree" if min(ratios.values()) >= 3 else
        "partly" if max(ratios.values()) >= 3 else "disagree",
        "agree if the in-plane std exceeds the perpendicular one threefold at every Ca", ratios))
    common = sorted(set(perpendicular.index) & set(centred.index))
    same = {f"{c:g}": float(perpendicular.loc[c, "taylor_deformation_mean"] / centred.loc[c, "taylor_deformation_mean"]
                            - 1) for c in common}
    worst = max((abs(v) for v in same.values()), default=np.nan)
    out.append(Claim(
        "shear-offset", "The perpendicular offset gives the same stationary behaviour as the centred nucleus.",
        "Sec. 3.2, Fig. 6b", "D_perp/D_centred - 1: " + ", ".join(f"Ca {c}: {100 * v:+.2f} %" for c, v in same.items()),
        verdict(worst, 0.02, 0.05), "agree if within 2 %, partly within 5 %", same))
    devs = {}
    for name, table in (("in-plane", parallel), ("perpendicular", perpendicular)):
        for c in sorted(set(table.index) & set(equivalent.index)):
            devs[f"{name} Ca {c:g}"] = float(table.loc[c, "taylor_deformation_mean"] /
                                             equivalent.loc[c, "taylor_deformation_mean"] - 1)
    worst = max((abs(v) for v in devs.values()), default=np.nan)
    out.append(Claim(
        "shear-offset", "The time-averaged D of the off-centre nucleus cell is perfectly covered by the homogeneous "
        "equivalent.", "Sec. 3.2, Fig. 6c", "D_mean/D_eq - 1: " + ", ".join(f"{k}: {100 * v:+.2f} %" for k, v in
                                                                             devs.items()),
        verdict(worst, 0.02, 0.05), "agree if within 2 %, partly within 5 %", devs))
    return out


# =========================================================================== pipe-centred
def plot_pipe(frame, directory: Path, stem: str) -> list[Path]:
    figure, axes = new_figure(1, 2)
    left, right = axes[0]
    rows = _complete(frame)
    for shown, cell in enumerate(("gamma 2", "gamma 10")):
        for equivalent in (True, False):
            chosen = rows[(rows["cell"] == cell) & (rows["equivalent"].astype(bool) == equivalent)]
            if chosen.empty:
                continue
            path = Path(directory) / chosen["run_directory"].iloc[0] / "shape.npz"
            if not path.exists():
                continue
            with np.load(path) as data:
                x, nucleus = data["positions"], data["nucleus"]
            offset = 3.0 * shown
            _outline(left, x[:, :2] + [offset, 0], "0.6" if equivalent else "C2", fill=equivalent,
                     label=f"{cell} {'equivalent' if equivalent else 'cell'}")
            if not equivalent and nucleus.any():
                _outline(left, x[nucleus][:, :2] + [offset, 0], "C0", fill=False, label=f"{cell} nucleus")
    left.set_aspect("equal")
    left.set_xlabel("x/R (flow)")
    left.set_ylabel("y/R")
    left.set_title("(a) side views: equivalent (grey) and nucleus cell")
    left.legend(fontsize=6, loc="lower center", ncol=2)
    cells = list(dict.fromkeys(frame["cell"]))
    positions = {cell: index for index, cell in enumerate(cells)}
    for equivalent, marker, shift in ((False, "o", -0.08), (True, "s", 0.08)):
        chosen = rows[rows["equivalent"].astype(bool) == equivalent]
        x = np.array([positions[c] for c in chosen["cell"]]) + shift
        for column, colour in (("strain_axial", "C3"), ("strain_radial", "C0")):
            right.errorbar(x, chosen[f"{column}_mean"], yerr=chosen[f"{column}_std"], fmt=marker, color=colour,
                           mfc="none" if equivalent else colour,
                           label=f"{column.replace('_', ' ')} ({'equivalent' if equivalent else 'cell'})")
    right.axhline(1, color="k", lw=0.8)
    right.set_xticks(range(len(cells)), cells)
    right.set_ylabel(r"stationary strain $\epsilon_x$, $\epsilon_r$")
    right.set_title("(b) strains (error bars: std over the stationary part)")
    right.legend(fontsize=7)
    right.grid(alpha=0.3)
    return save_study_figure(figure, directory, stem)


def _outline(axis, points, colour, fill: bool, label: str):
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points)
    polygon = points[np.append(hull.vertices, hull.vertices[0])]
    if fill:
        axis.fill(polygon[:, 0], polygon[:, 1], color=colour, alpha=0.5, label=label)
    else:
        axis.plot(polygon[:, 0], polygon[:, 1], color=colour, lw=1.2, label=label)


def claims_pipe(frame) -> list[Claim]:
    rows = _complete(frame)
    out = []
    if rows.empty:
        return out
    table = {(r["cell"], bool(r["equivalent"])): r for _, r in rows.iterrows()}
    bullets = {f"{c}{' eq' if e else ''}": (float(r["strain_axial_mean"]), float(r["strain_radial_mean"]))
               for (c, e), r in table.items()}
    is_bullet = [ex < 1 < er for ex, er in bullets.values()]
    out.append(Claim(
        "pipe-centred", "On the axis the cell takes a stationary bullet-like shape: eps_x < 1 < eps_r.",
        "Sec. 3.3, Fig. 7", "(eps_x, eps_r): " + ", ".join(f"{k}: ({a:.4f}, {b:.4f})" for k, (a, b) in bullets.items()),
        "agree" if all(is_bullet) else "partly" if any(is_bullet) else "disagree",
        "agree if every cell has eps_x < 1 < eps_r", {k: list(v) for k, v in bullets.items()}))

    def strain_deviation(column):
        values = {}
        for (cell, equivalent), row in table.items():
            if not equivalent and (cell, True) in table:
                eq = table[(cell, True)][f"{column}_mean"]
                values[cell] = float((row[f"{column}_mean"] - eq) / max(abs(eq - 1), 1e-6))
        return values

    axial = strain_deviation("strain_axial")
    worst = max((abs(v) for v in axial.values()), default=np.nan)
    out.append(Claim(
        "pipe-centred", "The axial strain of the nucleus cell remains accurate (equal to its equivalent's).",
        "Sec. 3.3, Fig. 7b", "(eps_x - eps_x,eq)/|eps_x,eq - 1|: " + ", ".join(f"{c}: {100 * v:+.1f} %" for c, v in
                                                                               axial.items()),
        verdict(worst, 0.10, 0.30), "agree if the strain differences are within 10 % of the equivalent's strain "
        "|eps - 1|, partly within 30 %", axial))
    gammas = [g for g in PIPE_STIFFNESS_RATIOS if (f"gamma {g:g}", False) in table and (f"gamma {g:g}", True) in table]
    if len(gammas) >= 2:
        cell_r = [float(table[(f"gamma {g:g}", False)]["strain_radial_mean"]) - 1 for g in gammas]
        eq_r = [float(table[(f"gamma {g:g}", True)]["strain_radial_mean"]) - 1 for g in gammas]
        cell_span = max(cell_r) - min(cell_r)
        eq_span = max(eq_r) - min(eq_r)
        decreasing = bool(np.all(np.diff(eq_r) < 0))
        out.append(Claim(
            "pipe-centred", "The radial strain of the nucleus cell stays almost unchanged with gamma, while its "
            "equivalent's decreases (it is stiffer).", "Sec. 3.3, Fig. 7b",
            "eps_r - 1 by gamma " + "/".join(map(str, gammas)) + ": cell " + ", ".join(f"{v:.4f}" for v in cell_r)
            + "; equivalent " + ", ".join(f"{v:.4f}" for v in eq_r),
            "agree" if decreasing and cell_span < 0.5 * eq_span else "partly" if decreasing or cell_span < eq_span
            else "disagree", "agree if the equivalents' eps_r - 1 decreases with gamma and the cells' span is under "
            "half the equivalents'", {"cell": cell_r, "equivalent": eq_r}))
    if ("random", False) in table and ("random", True) in table:
        r, e = table[("random", False)], table[("random", True)]
        values = {c: float((r[f"{c}_mean"] - e[f"{c}_mean"]) / max(abs(e[f"{c}_mean"] - 1), 1e-6))
                  for c in ("strain_axial", "strain_radial")}
        out.append(Claim(
            "pipe-centred", "The random cell agrees excellently with its equivalent.", "Sec. 3.3, Fig. 7b",
            ", ".join(f"{c}: {100 * v:+.1f} % of |eps - 1|" for c, v in values.items()),
            verdict(max(abs(v) for v in values.values()), 0.10, 0.30),
            "agree if both strain differences are within 10 % of |eps_eq - 1|, partly within 30 %", values))
    return out


STUDIES = [
    Study("shear-capillary", "Taylor deformation against Ca in shear flow", "fig-shearflow",
          "Stationary D against Ca = eta shear_rate/mu_c for gamma 2, 5, 10 (lambda 0.5) and the random cell, "
          "their equivalents (same shear rate) and a homogeneous cell with mu_c.", shear_capillary_members,
          shear_table, plot_shear_capillary, claims_shear_capillary),
    Study("shear-offset", "Off-centre nucleus in shear flow", "fig-shearflow-offset",
          "D against time and its time average for the nucleus (gamma 2, lambda 0.5) displaced 0.45 R in the shear "
          "plane (x) and perpendicular to it (z), with the centred cell and its equivalent.", shear_offset_members,
          shear_table, plot_shear_offset, claims_shear_offset),
    Study("pipe-centred", "Centred cell in pipe flow", "fig-pipeflow-centered-deformation",
          "Stationary eps_x and eps_r (std as error bars) for gamma 1, 2, 10 and the random cell beside their "
          "equivalents (same nominal pressure gradient), and their side views.", pipe_members, pipe_table, plot_pipe,
          claims_pipe),
]
