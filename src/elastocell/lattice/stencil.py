"""The D3Q19 velocity set in lattice units (dx = dt = 1).

Ordering (index: lattice velocity c_i):

====  ===========  ====  ===========  ====  ===========
 0    ( 0,  0,  0)
 1    (+1,  0,  0)    2  (-1,  0,  0)
 3    ( 0, +1,  0)    4  ( 0, -1,  0)
 5    ( 0,  0, +1)    6  ( 0,  0, -1)
 7    (+1, +1,  0)    8  (-1, -1,  0)
 9    (+1, -1,  0)   10  (-1, +1,  0)
11    (+1,  0, +1)   12  (-1,  0, -1)
13    (+1,  0, -1)   14  (-1,  0, +1)
15    ( 0, +1, +1)   16  ( 0, -1, -1)
17    ( 0, +1, -1)   18  ( 0, -1, +1)
====  ===========  ====  ===========  ====  ===========

Every odd index ``i`` is paired with its opposite ``i + 1`` (``c_{i+1} = -c_i``); the
two-relaxation-time collision works on these nine pairs plus the rest population.
Weights: ``w_0 = 1/3``, ``w_i = 1/18`` for the six axis velocities and ``1/36`` for
the twelve diagonal ones. Speed of sound squared ``c_s^2 = 1/3``.
"""

from __future__ import annotations

import numpy as np

Q = 19
"""Number of discrete velocities."""

SOUND_SPEED_SQUARED = 1.0 / 3.0
"""c_s^2 in lattice units (dx^2/dt^2)."""

VELOCITIES = np.array(
    [
        (0, 0, 0),
        (1, 0, 0),
        (-1, 0, 0),
        (0, 1, 0),
        (0, -1, 0),
        (0, 0, 1),
        (0, 0, -1),
        (1, 1, 0),
        (-1, -1, 0),
        (1, -1, 0),
        (-1, 1, 0),
        (1, 0, 1),
        (-1, 0, -1),
        (1, 0, -1),
        (-1, 0, 1),
        (0, 1, 1),
        (0, -1, -1),
        (0, 1, -1),
        (0, -1, 1),
    ],
    dtype=np.int64,
)
"""Lattice velocities c_i, shape (19, 3), integer components in {-1, 0, 1}."""

WEIGHTS = np.array(
    [1.0 / 3.0] + [1.0 / 18.0] * 6 + [1.0 / 36.0] * 12,
    dtype=np.float64,
)
"""Quadrature weights w_i, shape (19,), summing to 1."""

OPPOSITE = np.array([0] + [i + 1 if i % 2 == 1 else i - 1 for i in range(1, Q)], dtype=np.int64)
"""Index of the opposite velocity: c[OPPOSITE[i]] == -c[i]."""


def _check_tables() -> None:
    assert VELOCITIES.shape == (Q, 3)
    assert np.all(VELOCITIES[OPPOSITE] == -VELOCITIES)
    assert abs(WEIGHTS.sum() - 1.0) < 1e-15
    # second-order isotropy: sum_i w_i c_ia c_ib = c_s^2 delta_ab
    second = np.einsum("i,ia,ib->ab", WEIGHTS, VELOCITIES, VELOCITIES)
    assert np.allclose(second, SOUND_SPEED_SQUARED * np.eye(3), atol=1e-15)


_check_tables()
