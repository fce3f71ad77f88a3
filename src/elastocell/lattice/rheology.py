"""Shear-thinning (power-law) fluid on the lattice: a relaxation time per node from the local strain rate.

The kinematic viscosity of a power-law liquid in lattice units is nu(gdot) = K gdot^(n-1) (dx^2/dt, gdot in 1/dt),
bounded to [nu_min, nu_max] by clamping the relaxation time tau = 3 nu + 1/2 to [tau_min, tau_max] (the
Newtonian plateaus that keep the scheme stable where the shear vanishes or is largest).

The strain rate comes from the populations of the node itself, inside the collision (no extra pass): with Guo
forcing the second moment of the non-equilibrium part obeys

    Pi_ab = sum_i c_ia c_ib (f_i - f^eq_i) + (u_a F_b + F_a u_b)/2 = -2 rho c_s^2 tau S_ab,

(Kruger et al., The Lattice Boltzmann Method, 2017, section 6.5) so the shear rate gdot = sqrt(2 S:S) =
m / tau with m = 3 sqrt(2 Pi:Pi) / (2 rho). Because tau itself depends on gdot, the node solves
gdot tau(gdot) = m, i.e. 3 K gdot^n + gdot/2 = m, for gdot: Halley's method on s = log gdot (the left side is
convex and increasing in s) from the upper bound min(2m, (m/3K)^(1/n)), :data:`ROOT_ITERATIONS` fixed
iterations (two exponentials each), then tau = m/gdot. Measured against a bracketing root finder (brentq) over
m in [1e-12, 10], n in [0.2, 2], 3K in [3e-3, 30]: relative error of tau 2e-5 after two iterations, 4e-15 after
three. Clamping the root's tau is the exact solution of the clamped law (both sides are monotone in gdot).

With TRT the symmetric moments relax with that tau+ and the antisymmetric ones with
tau- = 1/2 + Lambda/(tau+ - 1/2) at the same magic Lambda, so the half-way walls stay where they are for
every local viscosity.

The compiled CPU kernels do not solve the root at every node and step: the law's tau depends on m alone, so
they read it from a table of x = log m built once per lattice (:func:`relaxation_time_table`: the root polished
to round-off at nodes a power of two apart in x, with its exact derivative, dtau/dx = tau (n - 1)(tau - 1/2) /
(n (tau - 1/2) + 1/2)), by cubic Hermite interpolation (:func:`tabulated_relaxation_time`): one logarithm per
node instead of two logarithms and seven exponentials. Measured against the polished root over n in [0.1, 2]
and the default clamp: relative error of tau at most 1.4e-10 (:data:`TABLE_TOLERANCE`, tests/test_medium.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

ROOT_ITERATIONS = 3
"""Halley iterations per node for gdot tau(gdot) = m (two leave 2e-5 at n = 0.2, three round-off)."""

DEFAULT_TAU_RANGE = (0.52, 10.0)
"""Default clamp of the local relaxation time (TRT stays stable close to 1/2; nu_max/nu_min = 475)."""

LOG_TWO = math.log(2.0)

SMALLEST_STRESS = 1e-20
"""Floor on m (a node at rest): its tau is then tau_max."""

TABLE_SPACING = 1.0 / 64.0
"""Spacing h of :func:`relaxation_time_table` in x = log m for the flow indices whose tau(x) curves no faster than
exp(x |1 - n|/n) with |1 - n|/n <= 1 (n >= 1/2); below, h shrinks as n/|1 - n| (at n = 0.1, 1/1024). Always a power of
two, so that the nodes are exact in float32. A clamp range wider than :data:`TABLE_MAX_NODES` nodes at that h (far
wider than the default one) doubles h as often as needed, and the error grows as h^4 (4e-9 at n = 0.1 with tau in
[0.500001, 1e6])."""

TABLE_MAX_NODES = 8192
"""Most nodes of a table (64 KiB of tau and slopes in float32)."""

TABLE_HEADER = 5
"""The table's header: x0 (x of its first node), 1/h, the number of intervals, the lowest and highest x it reads
(x beyond is read there); then tau at each node, then h dtau/dx at each node."""

TABLE_TOLERANCE = 3e-10
"""Bound on the table's relative error in tau, float64 storage, with the default clamp (measured, the largest error
anywhere in m: 1.4e-10 at n = 1/2, 1.3e-10 at n = 1/3, 1.2e-10 at n = 0.2, where n/(1 - n)/64 is a power of two, down
to 4e-11 at n = 0.586 and below 1e-11 above n = 0.8; tests/test_medium.py); float32 storage rounds tau to 6e-8."""


@dataclass(frozen=True)
class PowerLaw:
    """A power-law fluid in lattice units: nu = ``consistency`` gdot^(``flow_index`` - 1), tau clamped to
    [``relaxation_time_min``, ``relaxation_time_max``]."""

    flow_index: float
    consistency: float
    relaxation_time_min: float = DEFAULT_TAU_RANGE[0]
    relaxation_time_max: float = DEFAULT_TAU_RANGE[1]

    def __post_init__(self) -> None:
        n, k = float(self.flow_index), float(self.consistency)
        lo, hi = float(self.relaxation_time_min), float(self.relaxation_time_max)
        if not (math.isfinite(n) and 0.1 <= n <= 2.0):
            raise ValueError(f"flow_index must be in [0.1, 2], got {self.flow_index!r}")
        if not (math.isfinite(k) and k > 0):
            raise ValueError(f"consistency must be > 0 (lattice units), got {self.consistency!r}")
        if not (0.5 < lo < hi and math.isfinite(hi)):
            raise ValueError(f"need 1/2 < relaxation_time_min < relaxation_time_max, got ({lo}, {hi})")

    @classmethod
    def matching(cls, flow_index: float, viscosity: float, shear_rate: float, **clamp) -> PowerLaw:
        """The power law whose viscosity is ``viscosity`` (dx^2/dt) at ``shear_rate`` (1/dt)."""
        return cls(flow_index, viscosity * shear_rate ** (1.0 - flow_index), **clamp)

    def viscosity(self, shear_rate):
        """nu(gdot) = K gdot^(n-1), clamped (dx^2/dt)."""
        nu = self.consistency * np.asarray(shear_rate, dtype=float) ** (self.flow_index - 1.0)
        return np.clip(nu, (self.relaxation_time_min - 0.5) / 3.0, (self.relaxation_time_max - 0.5) / 3.0)

    def relaxation_time(self, stress_norm):
        """tau of nodes with m = 3 sqrt(2 Pi:Pi)/(2 rho) (NumPy, float64; the JAX backend's algorithm, the root the
        Numba kernels' table holds)."""
        return local_relaxation_time(np.asarray(stress_norm, dtype=np.float64), 3.0 * self.consistency,
                                     self.flow_index, self.relaxation_time_min, self.relaxation_time_max)


def local_relaxation_time(m, three_k, n, tau_min, tau_max, iterations=ROOT_ITERATIONS,
                          smallest_stress=SMALLEST_STRESS):
    """Solve 3K gdot^n + gdot/2 = m by ``iterations`` Halley steps in s = log gdot; return the clamped
    tau = m/gdot (m floored at ``smallest_stress``).

    Works elementwise on NumPy arrays (and, compiled, on scalars)."""
    m = np.maximum(m, smallest_stress)
    log_m = np.log(m)
    s = np.minimum(log_m + LOG_TWO, (log_m - np.log(three_k)) / n)
    for _ in range(iterations):
        p = three_k * np.exp(n * s)
        g = 0.5 * np.exp(s)
        f0 = p + g - m  # G(s) and its first two derivatives
        f1 = n * p + g
        f2 = n * n * p + g
        s = s - 2.0 * f0 * f1 / (2.0 * f1 * f1 - f0 * f2)
    return np.minimum(np.maximum(m * np.exp(-s), tau_min), tau_max)


def relaxation_time_table(three_k: float, n: float, tau_min: float, tau_max: float) -> np.ndarray:
    """The table the compiled kernels read tau from (float64; layout :data:`TABLE_HEADER`).

    Its nodes x_j = x0 + j h (h a power of two, at most :data:`TABLE_SPACING`) cover the x = log m over which the
    clamped law is not at a clamp, one node beyond at each end; tau_j is the unclamped root (Halley steps to
    round-off), the slopes h dtau/dx its exact derivative, so the interpolant is smooth across the clamps, which
    :func:`tabulated_relaxation_time` applies after it. One constant tau where it is the same for every m from
    the floor to the cap: n = 1 (3K + 1/2, clamped), or a law at one clamp all the way (a nearly Newtonian law
    whose tau lies beyond the clamp)."""
    three_k, n, tau_min, tau_max = float(three_k), float(n), float(tau_min), float(tau_max)

    def constant(tau):
        return np.array([0.0, 1.0, 1.0, 0.0, 1.0, tau, tau, 0.0, 0.0])

    if n == 1.0:
        return constant(min(max(three_k + 0.5, tau_min), tau_max))

    def log_stress(tau):  # x at which the unclamped law's tau is ``tau``: gdot = ((tau - 1/2)/3K)^(1/(n-1))
        return math.log(tau) + math.log((tau - 0.5) / three_k) / (n - 1.0)

    clamp_lo, clamp_hi = sorted((log_stress(tau_min), log_stress(tau_max)))
    floor = math.log(SMALLEST_STRESS)  # below it the node is at rest (the floor of :func:`local_relaxation_time`)
    lo, hi = max(clamp_lo, floor), max(min(clamp_hi, -floor), floor + 1.0)  # m > 1/SMALLEST_STRESS never occurs
    if lo >= hi:  # at a clamp from the floor to the cap
        return constant(float(local_relaxation_time(np.array(1.0), three_k, n, tau_min, tau_max,
                                                    iterations=ROOT_ITERATIONS + 3)))
    spacing = 2.0 ** math.floor(math.log2(min(TABLE_SPACING, TABLE_SPACING * n / abs(1.0 - n))))
    while (hi - lo) / spacing + 3 > TABLE_MAX_NODES:
        spacing *= 2.0
    x0 = math.floor(lo / spacing) * spacing
    intervals = math.ceil((hi - x0) / spacing)
    x = x0 + spacing * np.arange(intervals + 1)
    tau = local_relaxation_time(np.exp(x), three_k, n, 0.5, np.inf, iterations=ROOT_ITERATIONS + 3,
                                smallest_stress=0.0)
    ceiling = 1e6 * tau_max  # far beyond the clamp: an absurd K overflows the root there (inf, NaN)
    tau = np.minimum(np.nan_to_num(tau, nan=ceiling, posinf=ceiling), ceiling)
    slope = spacing * tau * (n - 1.0) * (tau - 0.5) / (n * (tau - 0.5) + 0.5)
    # x is held at the floor and the cap; where a clamp of tau ends the range instead, at the table's end nodes
    # (which are multiples of h, exact in float32), beyond which the clamp reads the same tau
    read_lo = lo if lo > clamp_lo else x0
    read_hi = hi if hi < clamp_hi else x0 + intervals * spacing
    return np.concatenate([[x0, 1.0 / spacing, float(intervals), read_lo, read_hi], tau, slope])


def tabulated_relaxation_time(x, table, start, tau_min, tau_max):
    """tau at x = log m (a float) from ``table[start:]`` (:func:`relaxation_time_table`), clamped: cubic Hermite
    interpolation between the nodes around x, x beyond the table read at its end; NaN stays NaN. Scalars only
    (compiled inline in the kernels).

    Numba caches the kernels keyed on lattice/kernels.py alone: a change here (or to the table's layout) must come
    with a change to that file, or the cached kernels keep inlining the old reader."""
    if x != x:
        return x
    intervals = int(table[start + 2])
    x = min(max(x, np.float64(table[start + 3])), np.float64(table[start + 4]))
    u = min(max((x - np.float64(table[start])) * np.float64(table[start + 1]), 0.0), float(intervals))
    j = min(int(u), intervals - 1)
    t = u - j
    values = start + TABLE_HEADER
    slopes = values + intervals + 1
    p0 = np.float64(table[values + j])
    p1 = np.float64(table[values + j + 1])
    m0 = np.float64(table[slopes + j])
    m1 = np.float64(table[slopes + j + 1])
    c2 = 3.0 * (p1 - p0) - 2.0 * m0 - m1
    c3 = 2.0 * (p0 - p1) + m0 + m1
    tau = p0 + t * (m0 + t * (c2 + t * c3))
    return min(max(tau, tau_min), tau_max)


def stress_norm(pi_neq, rho):
    """m = 3 sqrt(2 Pi:Pi) / (2 rho) of Pi (3, 3, ...) and rho (...)."""
    return 1.5 * np.sqrt(2.0 * np.einsum("ab...,ab...->...", pi_neq, pi_neq)) / rho


# --------------------------------------------------------------------------- closed forms (verification)
def slab_velocity(y, body_force: float, consistency: float, flow_index: float, half_gap: float):
    """u(y) of a power-law liquid (nu = K gdot^(n-1), rho = 1) driven by G between plates at y = +-h:
    u = n/(n+1) (G/K)^(1/n) (h^(1+1/n) - |y|^(1+1/n))."""
    n = flow_index
    y = np.minimum(np.abs(np.asarray(y, dtype=float)), half_gap)
    return n / (n + 1.0) * (body_force / consistency) ** (1.0 / n) * (half_gap ** (1 + 1 / n) - y ** (1 + 1 / n))


def slab_flow_rate(body_force: float, consistency: float, flow_index: float, half_gap: float) -> float:
    """Flow rate per unit width of :func:`slab_velocity`: 2 n/(2n+1) (G/K)^(1/n) h^(2+1/n)."""
    n = flow_index
    return 2.0 * n / (2.0 * n + 1.0) * (body_force / consistency) ** (1.0 / n) * half_gap ** (2.0 + 1.0 / n)


def tube_flow_rate(body_force: float, consistency: float, flow_index: float, radius: float) -> float:
    """Flow rate of a power-law liquid driven by G through a tube of radius R (wall stress G R/2):
    Q = pi n/(3n+1) (G/(2K))^(1/n) R^(3+1/n)."""
    n = flow_index
    return math.pi * n / (3.0 * n + 1.0) * (body_force / (2.0 * consistency)) ** (1.0 / n) * radius ** (3.0 + 1.0 / n)
