"""Richardson extrapolation of a flow run's stationary values from two lattice resolutions.

The discretisation error of the lattice-Boltzmann + immersed-boundary flows falls like (dx/R)^2 (the cell's
D/Ca in shear flow at Ca = 0.05: docs/validation/flow_accuracy.md), so a value X_h computed at spacing h and
X_H at the coarser spacing H = ratio * h combine to the h -> 0 estimate

    X = X_h + (X_h - X_H) / (ratio**order - 1),   order = CONVERGENCE_ORDER = 2.

The size of the correction, ``|X - X_h|``, is the uncertainty estimate reported with it: the distance of the
finer run from the extrapolation. It is an estimate, not a bound: it assumes the order-2 convergence holds for
the value at hand (two resolutions cannot check the order).
"""

from __future__ import annotations

import numpy as np

CONVERGENCE_ORDER = 2.0  # D/Ca - 5/4 ~ (dx/R)^2, docs/validation/flow_accuracy.md
DEFAULT_COARSE_RESOLUTION = 6.0  # R/dx of the cheap second run; with the default 8 it costs ~0.25x the fine run


def richardson(fine, coarse, ratio: float, order: float = CONVERGENCE_ORDER):
    """Richardson extrapolation of ``fine`` (spacing h) and ``coarse`` (spacing ratio * h) to h -> 0."""
    fine, coarse = np.asarray(fine, float), np.asarray(coarse, float)
    return fine + (fine - coarse) / (ratio**order - 1.0)


def extrapolate_values(fine: dict, coarse: dict, fine_resolution: float, coarse_resolution: float,
                       order: float = CONVERGENCE_ORDER) -> dict:
    """Extrapolate every numeric value present in both ``fine`` and ``coarse`` (resolutions R/dx, the ratio of
    spacings is ``fine_resolution / coarse_resolution``); returns ``{name: {"value", "fine", "coarse",
    "correction"}}`` with ``correction = |value - fine|`` (the uncertainty estimate, see the module)."""
    ratio = float(fine_resolution) / float(coarse_resolution)
    out = {}
    for name, f in fine.items():
        c = coarse.get(name)
        if isinstance(f, bool) or isinstance(c, bool) or not isinstance(f, (int, float)) \
                or not isinstance(c, (int, float)):
            continue
        value = float(richardson(f, c, ratio, order))
        out[name] = {"value": value, "fine": float(f), "coarse": float(c), "correction": abs(value - float(f))}
    return out


__all__ = ["CONVERGENCE_ORDER", "DEFAULT_COARSE_RESOLUTION", "richardson", "extrapolate_values"]
