"""Figures (matplotlib, non-interactive backend)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from elastocell.files import save_figure
from elastocell.scenarios.compression import hertz_force


def plot_compression(path: Path, curves: list[dict], poisson_ratio: float = 0.48, title: str = "") -> None:
    """Two panels: F/(E_c R^2) and F* = F/(E_eff R^2) against delta, with Hertz's limit.

    ``curves``: dicts with ``label``, ``delta``, ``force_per_Ec_R2``, ``force_per_Eeff_R2`` and optional ``style``.
    """
    figure, (left, right) = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
    for curve in curves:
        style = curve.get("style", {})
        left.plot(curve["delta"], curve["force_per_Ec_R2"], label=curve["label"], **style)
        right.plot(curve["delta"], curve["force_per_Eeff_R2"], label=curve["label"], **style)
    delta = np.linspace(0, 0.3, 50)
    right.plot(delta, hertz_force(delta, poisson_ratio), "k:", lw=1, label="Hertz (small delta)")
    left.set_ylabel(r"$F/(E_\mathrm{c} R^2)$")
    right.set_ylabel(r"$F^* = F/(E_\mathrm{eff} R^2)$")
    for axis in (left, right):
        axis.set_xlabel(r"deformation $\delta = 1 - h/2R$")
        axis.set_xlim(0, None)
        axis.set_ylim(0, None)
        axis.grid(alpha=0.3)
        axis.legend(fontsize=8)
    if title:
        figure.suptitle(title)
    save_figure(figure, path, dpi=130)
    plt.close(figure)
