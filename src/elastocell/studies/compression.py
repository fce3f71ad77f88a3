"""The paper's compression figures as studies: stiffness ratio, normalised force and size ratio, nucleus position
and shape, Mooney-Rivlin (paper section 3.1 and appendix).

Deviation from the equivalent, everywhere: ``F(delta)/F_eq(delta) - 1`` on the deltas both curves reached
(equal to ``F*/F*_eq - 1``), over ``delta >= DELTA_MIN`` (below it both forces are tiny and their ratio is the
mesh's contact resolution, not the physics). Axes: the plates push along z; the paper's "x" (parallel to
the plates) is our x, its "y" (perpendicular to the plates) is our z.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from elastocell.files import save_figure as write_figure
from elastocell.studies.base import Claim, Member, Run, Study, rows_per_delta

DELTA_MIN = 0.05
LARGE_DELTA = 0.3  # "large deformation": where the paper's linear-axis figures show the curves apart
STIFFNESS_RATIOS = (1, 2, 5, 10, 20)
SIZE_RATIOS_FULL = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
SIZE_RATIOS_QUICK = (0.1, 0.3, 0.5, 0.7, 0.9)
OFFSET = 0.45
ELLIPSOID_SEMI_AXES = (0.8, 0.4, 0.4)  # the paper's a ~ 0.8 R, b = c ~ 0.4 R (volume 0.128 vs 0.125 R^3)
AXIS_LABEL = {"x": "x (parallel to the plates)", "z": "z (perpendicular; the paper's y)"}
# verdict thresholds on the largest |deviation| (fractions), stated in every claim
AGREE, PARTLY = 0.02, 0.05


def discretisations(quick: bool) -> dict[str, dict]:
    """Mesh and load-step options by discretisation, the primary (converged) one first.

    Full: the converged default (quadratic tetrahedra, 40 steps) and the paper's element, linear tetrahedra on
    the default p1 mesh (3,861 nodes for the reference cell), so that the report can say whether each claim
    survives on the converged discretisation and how far linear-element locking moved the curves. The second
    discretisation is run for the stiffness series and the random cell (where locking was measured to be worst;
    a p1 curve costs about twice a p2 one here). Quick: one coarse linear mesh (edge 0.3 R, 15 steps)."""
    if quick:
        return {"p1 coarse": {"element": "p1", "mesh_size": 0.3, "steps": 15, "vtk": False}}
    return {"p2": {}, "p1": {"element": "p1"}}


def settings(quick: bool) -> dict:
    """Options of the primary discretisation."""
    return next(iter(discretisations(quick).values()))


def cell_and_equivalent(quick: bool, labels: dict, all_discretisations: bool = False, **cell) -> list[Member]:
    """The cell and its homogeneous equivalent (same mesh, volume-averaged modulus), paired by ``pair``, on the
    primary discretisation, or on every one with ``all_discretisations`` (label ``discretisation``)."""
    pair = labels["cell"]
    members = []
    chosen = discretisations(quick)
    if not all_discretisations:
        chosen = dict([next(iter(chosen.items()))])
    for name, options in chosen.items():
        options = {**options, **cell}
        tags = {**labels, "pair": pair, "discretisation": name}
        members += [Member(Run.of("compress", **options), {**tags, "equivalent": False}),
                    Member(Run.of("compress", **options, equivalent=True), {**tags, "equivalent": True})]
    return members


def primary(frame):
    """The rows of the primary discretisation (all rows if the table has no discretisation column)."""
    if "discretisation" not in frame or frame.empty:
        return frame
    return frame[frame["discretisation"] == frame["discretisation"].iloc[0]]


def locking(frame) -> dict:
    """{discretisation: {cell: {delta: F/F_primary - 1}}} at delta 0.1, 0.3, 0.5, 0.7 for every other
    discretisation: how far it moves each cell's curve from the primary (converged) one."""
    if "discretisation" not in frame:
        return {}
    names = list(dict.fromkeys(frame["discretisation"]))
    reference = curves(frame[frame["discretisation"] == names[0]])
    out = {}
    for name in names[1:]:
        other = curves(frame[frame["discretisation"] == name])
        cells = {}
        for key, curve in other.items():
            if key in reference and not key[1]:
                delta, r = ratio(curve, reference[key])
                cells[key[0]] = {f"{d:g}": float(np.interp(d, delta, r) - 1) for d in (0.1, 0.3, 0.5, 0.7)
                                 if len(delta) and delta[0] <= d <= delta[-1]}
        out[name] = cells
    return out


def stiffness_members(quick: bool) -> list[Member]:
    members = []
    for gamma in STIFFNESS_RATIOS:
        members += cell_and_equivalent(quick, {"series": "stiffness", "cell": f"gamma {gamma:g}",
                                               "stiffness_ratio": float(gamma), "size_ratio": 0.5},
                                       all_discretisations=True, stiffness_ratio=gamma, size_ratio=0.5)
    members += cell_and_equivalent(quick, {"series": "random", "cell": "random", "stiffness_ratio": np.nan,
                                           "size_ratio": np.nan}, all_discretisations=True, random=True, seed=0)
    return members


def size_members(quick: bool) -> list[Member]:
    members = []
    for size in SIZE_RATIOS_QUICK if quick else SIZE_RATIOS_FULL:
        members += cell_and_equivalent(quick, {"series": "size", "cell": f"lambda {size:g}", "stiffness_ratio": 2.0,
                                               "size_ratio": float(size)}, stiffness_ratio=2, size_ratio=size)
    return members


def reference_members(quick: bool) -> list[Member]:
    return cell_and_equivalent(quick, {"series": "reference", "cell": "reference", "stiffness_ratio": 2.0,
                                       "size_ratio": 0.5}, stiffness_ratio=2, size_ratio=0.5)


def position_shape_members(quick: bool) -> list[Member]:
    members = reference_members(quick)
    for axis in ("x", "z"):
        members += cell_and_equivalent(quick, {"series": "offset", "cell": f"offset {OFFSET:g} along {axis}",
                                               "stiffness_ratio": 2.0, "size_ratio": 0.5, "axis": axis},
                                       offset=OFFSET, offset_axis=axis)
        members += cell_and_equivalent(quick, {"series": "ellipsoid", "cell": f"ellipsoid along {axis}",
                                               "stiffness_ratio": 2.0, "size_ratio": np.nan, "axis": axis},
                                       nucleus="ellipsoid", semi_axes=ELLIPSOID_SEMI_AXES, nucleus_axis=axis)
    return members


def mooney_rivlin_members(quick: bool) -> list[Member]:
    members = []
    for gamma in (2, 10) if quick else (2, 5, 10, 20):
        for material in ("mooney-rivlin", "neo-hookean"):
            members += cell_and_equivalent(quick, {"series": material, "cell": f"{material} gamma {gamma:g}",
                                                   "stiffness_ratio": float(gamma), "size_ratio": 0.5,
                                                   "material": material},
                                           stiffness_ratio=gamma, size_ratio=0.5,
                                           **({} if material == "neo-hookean" else {"material": material}))
    return members


# =========================================================================== analysis helpers
def tidy(pairs, directory: Path, quick: bool = False):
    import pandas as pd

    return pd.DataFrame(rows_per_delta(pairs))


def curves(frame) -> dict:
    """{(pair, equivalent): (delta, F/(E_c R^2), F*)} for every run with rows."""
    out = {}
    if frame.empty or "pair" not in frame:
        return out
    for (pair, equivalent), group in frame.groupby(["pair", "equivalent"], sort=False):
        group = group.dropna(subset=["delta", "force_per_Ec_R2"]).sort_values("delta")
        if len(group) < 2:  # a failed run (one NaN row) or a curve that stopped at its first step
            continue
        out[(pair, bool(equivalent))] = (group["delta"].to_numpy(), group["force_per_Ec_R2"].to_numpy(),
                                         group["force_per_Eeff_R2"].to_numpy())
    return out


def ratio(curve, reference, delta_min: float = DELTA_MIN):
    """(delta, F/F_reference) where both curves have rows and delta >= delta_min (reference interpolated)."""
    delta, force = curve[0], curve[1]
    if not len(delta) or not len(reference[0]):
        return np.array([]), np.array([])
    upper = min(delta[-1], reference[0][-1])
    keep = (delta >= delta_min) & (delta <= upper + 1e-12)
    return delta[keep], force[keep] / np.interp(delta[keep], reference[0], reference[1])


def deviations(frame) -> dict:
    """{pair: (delta, F/F_eq - 1)} for every cell with its equivalent."""
    table = curves(frame)
    out = {}
    for (pair, equivalent), curve in table.items():
        if not equivalent and (pair, True) in table:
            delta, r = ratio(curve, table[(pair, True)])
            out[pair] = (delta, r - 1)
    return out


def largest(deviation) -> float:
    return float(np.abs(deviation[1]).max()) if len(deviation[1]) else np.nan


def verdict(value: float, agree: float = AGREE, partly: float = PARTLY) -> str:
    if not np.isfinite(value):
        return "not measured"
    return "agree" if value <= agree else "partly" if value <= partly else "disagree"


def reached(frame, pair: str) -> str:
    rows = frame[(frame["pair"] == pair) & (~frame["equivalent"].astype(bool))]
    if rows.empty:
        return "no rows"
    value, status = rows["delta_reached"].iloc[0], rows["status"].iloc[0]
    return f"delta up to {value:.3f}" + ("" if status == "complete" else f" ({status})")


def percent(value: float) -> str:
    return f"{100 * value:.2f} %" if np.isfinite(value) else "n/a"


def _style(equivalent: bool, colour: str) -> dict:
    return {"color": colour, "lw": 1.4} if equivalent else {"color": colour, "marker": "o", "ms": 3, "ls": "none"}


def save_study_figure(figure, directory: Path, stem: str) -> list[Path]:
    import matplotlib.pyplot as plt

    paths = [directory / f"{stem}.png", directory / f"{stem}.pdf"]
    write_figure(figure, paths[0], dpi=140)
    write_figure(figure, paths[1])
    plt.close(figure)
    return paths


def _draw(axes, frame, pairs: list[str], value: int, deviation_axis=None, reference_pair=None):
    """Cells as markers, equivalents as lines (column ``value``: 1 = F/(E_c R^2), 2 = F*); deviations below."""
    table = curves(frame)
    devs = deviations(frame)
    for index, pair in enumerate(pairs):
        colour = f"C{index % 10}"
        for equivalent in (False, True):
            if (pair, equivalent) in table:
                curve = table[(pair, equivalent)]
                axes.plot(curve[0], curve[value], label=None if equivalent else pair, **_style(equivalent, colour))
        if deviation_axis is not None:
            if reference_pair is not None and (reference_pair, False) in table and (pair, False) in table:
                delta, r = ratio(table[(pair, False)], table[(reference_pair, False)])
                deviation_axis.plot(delta, 100 * (r - 1), color=colour, label=f"{pair} vs {reference_pair}")
            elif pair in devs:
                deviation_axis.plot(devs[pair][0], 100 * devs[pair][1], color=colour, label=pair)
    axes.set_xlabel(r"$\delta$")
    axes.set_ylabel(r"$F/(E_\mathrm{c}R^2)$" if value == 1 else r"$F^* = F/(E_\mathrm{eff}R^2)$")
    axes.grid(alpha=0.3)
    axes.legend(fontsize=7, title="markers: cell, lines: equivalent", title_fontsize=7)
    if deviation_axis is not None:
        deviation_axis.axhline(0, color="k", lw=0.8)
        deviation_axis.set_xlabel(r"$\delta$")
        deviation_axis.set_ylabel("deviation (%)")
        deviation_axis.grid(alpha=0.3)
        deviation_axis.legend(fontsize=7)


def new_figure(rows: int = 2, columns: int = 2):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(rows, columns, figsize=(5 * columns, 3.6 * rows), constrained_layout=True, squeeze=False)


def pairs_of(frame, series: str) -> list[str]:
    return list(dict.fromkeys(frame.loc[frame["series"] == series, "pair"]))


# =========================================================================== compression-stiffness
def plot_stiffness(frame, directory: Path, stem: str) -> list[Path]:
    frame = primary(frame)
    figure, axes = new_figure(1, 2)
    pairs = pairs_of(frame, "stiffness") + pairs_of(frame, "random")
    _draw(axes[0][0], frame, pairs, 1, axes[0][1])
    axes[0][0].set_title(r"(a) force against deformation, $\lambda = 0.5$")
    axes[0][1].set_title(r"(b) $F/F_\mathrm{eq} - 1$")
    return save_study_figure(figure, directory, stem)


def claims_stiffness(frame) -> list[Claim]:
    devs = deviations(frame)
    table = curves(frame)
    out = []
    gammas = [g for g in STIFFNESS_RATIOS if f"gamma {g:g}" in devs]
    # force grows with gamma at the largest delta every cell reached
    gammas = [g for g in gammas if (f"gamma {g:g}", False) in table]
    common = min((table[(f"gamma {g:g}", False)][0][-1] for g in gammas), default=np.nan)
    forces = [float(np.interp(common, *table[(f"gamma {g:g}", False)][:2])) for g in gammas]
    monotone = bool(np.all(np.diff(forces) > 0)) if len(forces) > 1 else False
    out.append(Claim(
        "compression-stiffness", "Increasing the stiffness of the nucleus increases the force needed to compress "
        "the cell.", "Sec. 3.1, Fig. 2",
        "F/(E_c R^2) at delta = {:.3f}: {}".format(common, ", ".join(f"gamma {g}: {f:.4f}" for g, f in
                                                                    zip(gammas, forces, strict=True))),
        "agree" if monotone else "disagree" if forces else "not measured",
        "agree if F rises strictly with gamma at the largest delta all cells reached",
        {"delta": common, "forces": dict(zip(map(str, gammas), forces, strict=True))}))
    largest_all = {g: largest(devs[f"gamma {g:g}"]) for g in gammas}
    large = {g: largest(_from(devs[f"gamma {g:g}"], LARGE_DELTA)) for g in gammas}
    text = ", ".join(f"gamma {g}: {percent(v)} ({percent(large[g])} for delta >= {LARGE_DELTA}; "
                     f"{reached(frame, f'gamma {g:g}')})" for g, v in largest_all.items())
    value20, large20 = largest_all.get(20, np.nan), large.get(20, np.nan)
    out.append(Claim(
        "compression-stiffness", "Even for a nucleus 20 times stiffer than the cytoskeleton, the deviation from "
        "the homogeneous equivalent is not significant.", "Sec. 3.1, Fig. 2",
        f"largest |F/F_eq - 1| for delta >= {DELTA_MIN}: {text}", _tiered(value20, large20, PARTLY),
        f"on gamma 20: agree if <= {percent(PARTLY)} for delta >= {DELTA_MIN}; partly if only for delta >= "
        f"{LARGE_DELTA} (large deformation)", {"largest_deviation": largest_all, "large_delta": large}))
    value10, large10 = largest_all.get(10, np.nan), large.get(10, np.nan)
    others = [v for g, v in large.items() if g not in (1, 10)]
    smallest = bool(others) and large10 <= min(others)
    out.append(Claim(
        "compression-stiffness", "The gamma = 10 cell matches its homogeneous equivalent (E_eff = 2.125 E_c) "
        "perfectly, better than other stiffness ratios.", "Sec. 3.1, Fig. 2",
        f"gamma 10: largest deviation {percent(value10)} (delta >= {DELTA_MIN}), {percent(large10)} (delta >= "
        f"{LARGE_DELTA}); smallest among gamma 2, 5, 10, 20 for delta >= {LARGE_DELTA}: {smallest}; E_eff/E_c of the "
        f"meshed gamma-10 cell {_effective_ratio(frame, 'gamma 10'):.4f} (analytic 2.125)",
        "not measured" if not np.isfinite(value10) else
        ("agree" if value10 <= AGREE and smallest else "partly" if large10 <= PARTLY or smallest else "disagree"),
        f"agree if <= {percent(AGREE)} for delta >= {DELTA_MIN} and the smallest; partly if within "
        f"{percent(PARTLY)} or the smallest for delta >= {LARGE_DELTA}", {"largest_deviation": value10,
                                                                          "large_delta": large10}))
    slopes = {g: _slope(devs[f"gamma {g:g}"], DELTA_MIN) for g in gammas if g != 1}
    slopes_large = {g: _slope(devs[f"gamma {g:g}"], LARGE_DELTA) for g in gammas if g != 1}
    expected = {g: (1 if g < 10 else -1 if g > 10 else 0) for g in slopes}
    matches = [np.sign(slopes[g]) == expected[g] for g in slopes if expected[g] != 0 and np.isfinite(slopes[g])]
    out.append(Claim(
        "compression-stiffness", "For 1 < gamma < 10 the nucleus cell strain-hardens more than its equivalent "
        "(F/F_eq rises with delta); for gamma > 10 less.", "Sec. 3.1",
        f"slope of F/F_eq over delta >= {DELTA_MIN}: " + ", ".join(f"gamma {g}: {s:+.3f}" for g, s in slopes.items())
        + f"; over delta >= {LARGE_DELTA}: " + ", ".join(f"gamma {g}: {s:+.3f}" for g, s in slopes_large.items()),
        "not measured" if not matches else "agree" if all(matches) else "partly" if any(matches) else "disagree",
        f"sign of the least-squares slope of F/F_eq - 1 against delta (delta >= {DELTA_MIN}): + for gamma 2, 5; "
        "- for 20", {"slopes": slopes, "slopes_large_delta": slopes_large}))
    if "random" in devs:
        value = largest(devs["random"])
        out.append(Claim(
            "compression-stiffness", "The random cell matches its homogeneous equivalent excellently.",
            "Sec. 3.1, Figs. 2-3", f"largest deviation {percent(value)} ({reached(frame, 'random')}); "
            f"E_eff/E_c {_effective_ratio(frame, 'random'):.4f} (U[1, 10] mean 5.5)", verdict(value),
            f"agree if <= {percent(AGREE)}, partly if <= {percent(PARTLY)}", {"largest_deviation": value}))
    return out


def _from(deviation, delta_from: float):
    """The part of a (delta, deviation) pair at delta >= delta_from."""
    keep = deviation[0] >= delta_from
    return deviation[0][keep], deviation[1][keep]


def _tiered(whole: float, large: float, threshold: float) -> str:
    """agree: within threshold over the whole range; partly: only at large deformation; else disagree."""
    if not np.isfinite(whole):
        return "not measured"
    return "agree" if whole <= threshold else "partly" if large <= threshold else "disagree"


def _slope(deviation, delta_from: float = 0.3) -> float:
    delta, value = deviation
    keep = delta >= delta_from
    return float(np.polyfit(delta[keep], value[keep], 1)[0]) if keep.sum() >= 3 else np.nan


def _effective_ratio(frame, pair: str) -> float:
    rows = frame[(frame["pair"] == pair) & (~frame["equivalent"].astype(bool))]
    return float(rows["effective_stiffness_ratio"].iloc[0]) if not rows.empty else np.nan


# =========================================================================== compression-normalised
def plot_normalised(frame, directory: Path, stem: str) -> list[Path]:
    frame = primary(frame)
    figure, axes = new_figure(2, 2)
    _draw(axes[0][0], frame, pairs_of(frame, "stiffness") + pairs_of(frame, "random"), 2, axes[1][0])
    _draw(axes[0][1], frame, pairs_of(frame, "size"), 2, axes[1][1])
    axes[0][0].set_title(r"(a) $F^*$, stiffness ratios ($\lambda$ = 0.5) and random cell")
    axes[0][1].set_title(r"(b) $F^*$, size ratios ($\gamma$ = 2)")
    return save_study_figure(figure, directory, stem)


def size_peak(frame) -> tuple[dict, float]:
    """Mean |F/F_eq - 1| per size ratio and the size ratio where it peaks."""
    devs = deviations(frame)
    means = {}
    for pair in pairs_of(frame, "size"):
        if pair in devs and len(devs[pair][1]):
            means[float(pair.split()[-1])] = float(np.abs(devs[pair][1]).mean())
    peak = max(means, key=means.get) if means else np.nan
    return means, peak


def claims_normalised(frame) -> list[Claim]:
    out = []
    table = curves(frame)
    equivalents = [table[k] for k in table if k[1]]
    if len(equivalents) > 1:
        delta = np.linspace(0.1, min(c[0][-1] for c in equivalents), 30)
        stack = np.array([np.interp(delta, c[0], c[2]) for c in equivalents])
        spread = float(((stack.max(0) - stack.min(0)) / stack.mean(0)).max())
        out.append(Claim(
            "compression-normalised", "With F* = F/(E_eff R^2) all homogeneous cells collapse onto one master "
            "curve.", "Sec. 3.1, Fig. 3a",
            f"largest relative spread of F* for delta >= 0.1 among the {len(equivalents)} homogeneous equivalents "
            f"(each on its own cell's mesh): {percent(spread)}", verdict(spread, 0.01, 0.03),
            "agree if <= 1 %, partly if <= 3 %; exact by scaling for homogeneous cells, so this measures the "
            "mesh-to-mesh differences", {"spread": spread}))
    devs = deviations(frame)
    means = {p: float(devs[p][1].mean()) for p in pairs_of(frame, "stiffness") if p in devs and p != "gamma 1"}
    signs = {np.sign(v) for v in means.values() if abs(v) > 1e-3}
    out.append(Claim(
        "compression-normalised", "Varying gamma does not give a consistent direction of the deviation from the "
        "master curve: it changes in different directions.", "Sec. 3.1, Fig. 3a",
        "mean F/F_eq - 1 over delta: " + ", ".join(f"{p}: {100 * v:+.2f} %" for p, v in means.items()),
        "not measured" if not means else "agree" if len(signs) > 1 else "disagree",
        "agree if the mean deviations (|.| > 0.1 %) have both signs", {"mean_deviation": means}))
    sizes = pairs_of(frame, "size")
    if sizes:
        bounded, worst = True, (np.inf, -np.inf)
        reference = _homogeneous_shell(frame, table)
        for pair in sizes:
            if (pair, False) in table and reference is not None:
                _, r = ratio(table[(pair, False)], reference)
                worst = (min(worst[0], r.min()), max(worst[1], r.max()))
                bounded &= bool(np.all((r >= 1 - 0.01) & (r <= 2 + 0.01)))
        out.append(Claim(
            "compression-normalised", "The size-ratio curves (gamma = 2) lie between the homogeneous cells with "
            "E_c and with 2 E_c.", "Sec. 3.1, Fig. 3b",
            f"F/F_hom(E_c) over all size ratios and deltas: {worst[0]:.4f} to {worst[1]:.4f}"
            if reference is not None else "no homogeneous E_c curve in this study",
            "not measured" if reference is None else "agree" if bounded else "disagree",
            "agree if 1 <= F/F_hom(E_c) <= 2 within 1 %", {"range": list(worst)}))
        means_size, peak = size_peak(frame)
        grid = sorted(means_size)
        step = min(np.diff(grid)) if len(grid) > 1 else np.nan
        out.append(Claim(
            "compression-normalised", "The deviation from the homogeneous description peaks near lambda = 0.7 "
            "(not at 0.79, equal volumes).", "Sec. 3.1, Fig. 3b inset",
            "mean |F/F_eq - 1| by size ratio: " + ", ".join(f"{s:g}: {percent(v)}" for s, v in means_size.items())
            + f"; peak at lambda = {peak:g}",
            "not measured" if not np.isfinite(peak) else "agree" if abs(peak - 0.7) <= step / 2 + 1e-9 else
            "partly" if abs(peak - 0.7) <= 1.5 * step else "disagree",
            f"agree if the peak of the sampled size ratios (step {step:g}) is the one nearest 0.7",
            {"mean_abs_deviation": means_size, "peak": peak}))
    return out


def _homogeneous_shell(frame, table):
    """F/(E_c R^2) of a homogeneous cell with E_c: the gamma = 1 cell if the study has it, else the equivalent
    of any cell rescaled by its E_eff/E_c (neo-Hookean forces scale with the modulus)."""
    if ("gamma 1", False) in table:
        return table[("gamma 1", False)][:2]
    for (_pair, equivalent), curve in table.items():
        if equivalent:
            return curve[0], curve[2]  # F* of a homogeneous cell is F/(E R^2) of one with E = E_c
    return None


# =========================================================================== compression-position-shape
def plot_position_shape(frame, directory: Path, stem: str) -> list[Path]:
    frame = primary(frame)
    figure, axes = new_figure(2, 2)
    _draw(axes[0][0], frame, ["reference"] + pairs_of(frame, "offset"), 1, axes[1][0], reference_pair="reference")
    _draw(axes[0][1], frame, ["reference"] + pairs_of(frame, "ellipsoid"), 1, axes[1][1], reference_pair="reference")
    axes[0][0].set_title(f"(a) nucleus offset {OFFSET:g} R (plates push along z)")
    axes[0][1].set_title("(b) equal-volume ellipsoidal nucleus (0.8, 0.4, 0.4) R")
    for axis in axes[1]:
        axis.set_ylabel(r"$F/F_\mathrm{ref} - 1$ (%)")
    return save_study_figure(figure, directory, stem)


def claims_position_shape(frame) -> list[Claim]:
    table = curves(frame)
    devs = deviations(frame)
    out = []
    if ("reference", False) not in table:
        return out
    for series, claim, source in (
            ("offset", "Moving the nucleus (gamma 2, lambda 0.5) to an offset of 0.45 R, parallel or perpendicular "
                       "to the plates, does not change the force: the curves overlap exactly.", "Sec. 3.1, Fig. 4a"),
            ("ellipsoid", "An equal-volume ellipsoidal nucleus (0.8, 0.4, 0.4) R, along x or y, has no notable "
                          "effect on the force.", "Sec. 3.1, Fig. 4b")):
        values, large = {}, {}
        for pair in pairs_of(frame, series):
            if (pair, False) in table:
                delta, r = ratio(table[(pair, False)], table[("reference", False)])
                values[pair] = float(np.abs(r - 1).max()) if len(r) else np.nan
                large[pair] = largest(_from((delta, r - 1), LARGE_DELTA))
        worst = max(values.values(), default=np.nan)
        worst_large = max(large.values(), default=np.nan)
        out.append(Claim("compression-position-shape", claim, source,
                         "largest |F/F_ref - 1|: " + ", ".join(
                             f"{p}: {percent(v)} ({percent(large[p])} for delta >= {LARGE_DELTA}; {reached(frame, p)})"
                             for p, v in values.items()),
                         _tiered(worst, worst_large, PARTLY),
                         f"agree if <= {percent(PARTLY)} for delta >= {DELTA_MIN}; partly if only for delta >= "
                         f"{LARGE_DELTA}", {"largest_change": values, "large_delta": large}))
    base = float(np.abs(devs["reference"][1]).mean()) if "reference" in devs else np.nan
    offsets = {p: float(np.abs(devs[p][1]).mean()) for p in pairs_of(frame, "offset") if p in devs}
    better = [v < base for v in offsets.values()]
    out.append(Claim(
        "compression-position-shape", "Moving the nucleus off-centre slightly increases the accuracy of the "
        "homogeneous description.", "Fig. 4a caption",
        f"mean |F/F_eq - 1|: centred {percent(base)}, " + ", ".join(f"{p}: {percent(v)}" for p, v in offsets.items()),
        "not measured" if not better else "agree" if all(better) else "partly" if any(better) else "disagree",
        "agree if every offset cell deviates less (on average over delta) from its equivalent than the centred one",
        {"centred": base, "offset": offsets}))
    return out


# =========================================================================== compression-mooney-rivlin
def plot_mooney_rivlin(frame, directory: Path, stem: str) -> list[Path]:
    frame = primary(frame)
    figure, axes = new_figure(1, 2)
    _draw(axes[0][0], frame, pairs_of(frame, "mooney-rivlin"), 1, axes[0][1])
    devs = deviations(frame)
    for index, pair in enumerate(pairs_of(frame, "neo-hookean")):
        if pair in devs:
            axes[0][1].plot(devs[pair][0], 100 * devs[pair][1], color=f"C{index}", ls="--", lw=1,
                            label=pair)
    axes[0][1].legend(fontsize=7)
    axes[0][0].set_title(r"(a) Mooney-Rivlin, $\mu_1 = 0.25\mu$, $\mu_2 = 0.75\mu$")
    axes[0][1].set_title(r"(b) $F/F_\mathrm{eq} - 1$ (dashed: neo-Hookean)")
    return save_study_figure(figure, directory, stem)


def claims_mooney_rivlin(frame) -> list[Claim]:
    devs = deviations(frame)
    values = {}
    for pair in pairs_of(frame, "mooney-rivlin"):
        twin = pair.replace("mooney-rivlin", "neo-hookean")
        if pair in devs and twin in devs:
            values[pair.split(" ", 1)[1]] = (largest(devs[pair]), largest(devs[twin]))
    good = [mr <= nh + 0.01 for mr, nh in values.values()]
    return [Claim(
        "compression-mooney-rivlin", "With the Mooney-Rivlin law the homogeneous equivalent is as good as with "
        "the neo-Hookean law.", "Appendix, Fig. 8",
        "largest |F/F_eq - 1| (Mooney-Rivlin vs neo-Hookean): "
        + ", ".join(f"{g}: {percent(mr)} vs {percent(nh)}" for g, (mr, nh) in values.items()),
        "not measured" if not good else "agree" if all(good) else "partly" if any(good) else "disagree",
        "agree if, for every gamma, the Mooney-Rivlin deviation exceeds the neo-Hookean one by at most 1 point",
        {"largest_deviation": {g: list(v) for g, v in values.items()}})]


STUDIES = [
    Study("compression-stiffness", "Force against deformation for stiffness ratios 1-20 and the random cell",
          "fig-compression-1", "F/(E_c R^2) against delta for gamma 1, 2, 5, 10, 20 (lambda 0.5) and the random "
          "cell, each beside its homogeneous equivalent.", stiffness_members, tidy, plot_stiffness,
          claims_stiffness, by_discretisation=True),
    Study("compression-normalised", "Normalised force F* and the size-ratio sweep", "fig-compression-deviation",
          "F* against delta for the stiffness series and the random cell (a) and for size ratios 0.1-0.9 at "
          "gamma 2 (b), with the relative deviation from the equivalent.",
          lambda quick: stiffness_members(quick) + size_members(quick), tidy, plot_normalised, claims_normalised,
          by_discretisation=True),
    Study("compression-position-shape", "Nucleus position and shape", "fig-compression-ellipsoidal-inhomogeneity",
          "Nucleus offset 0.45 R along x and z, equal-volume ellipsoidal nucleus along x and z, against the "
          "centred reference (gamma 2, lambda 0.5).", position_shape_members, tidy, plot_position_shape,
          claims_position_shape, by_discretisation=True),
    Study("compression-mooney-rivlin", "Mooney-Rivlin cells", "fig-Mooney-Rivlin",
          "Nucleus cells with the Mooney-Rivlin law (mu1 = 0.25 mu, mu2 = 0.75 mu) beside their equivalents, "
          "compared with the neo-Hookean deviation.", mooney_rivlin_members, tidy, plot_mooney_rivlin,
          claims_mooney_rivlin, by_discretisation=True),
]
