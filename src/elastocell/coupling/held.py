"""Markers held at rest in a lattice-Boltzmann fluid: a rigid immersed body at a fixed place, the problem on
which the immersed boundary's accuracy is calibrated (the drag, torque and stresslet of a held sphere have
closed forms; docs/validation/flow_accuracy.md).

A marker is held by integral feedback: its force on the fluid is ``-k`` times the time integral of the fluid
velocity interpolated at it (the half-force-corrected velocity of :func:`ibm.interpolate_lattice_velocity`),
so at the steady state that velocity vanishes -- the no-slip condition of the immersed boundary, the same one
the cell's markers meet by moving with it. The gain is ``k = 0.05/lambda_max(W)``, W the kernel overlap
matrix of the markers (the velocity a unit force on one marker gives another in one step). The fluid keeps the
momentum it receives, so the loop integrates twice: measured on a sphere of 78 markers at R = 4 dx in shear,
0.5/lambda_max(W) diverges with the peskin4 kernel within 200 steps, 0.05/lambda_max(W) and 0.015/lambda_max(W)
both settle (torque to 1e-3 within about 1000 steps, the same value), and so does 0.16/lambda_max(W) with the
trilinear one. The steady state does not depend on the gain.
"""

from __future__ import annotations

import numpy as np

from elastocell.coupling import ibm
from elastocell.coupling.stability import kernel_overlap_matrix


class HeldMarkers:
    """Markers at fixed ``positions`` (n, 3) in dx, held at rest in ``lattice`` (its force density field is
    owned by them from now on); ``kernel`` the immersed-boundary kernel.

    :attr:`forces` (n, 3): the force each marker exerts on the fluid (rho0 dx^4/dt^2); the body feels
    ``-forces``."""

    def __init__(self, lattice, positions, kernel: str = "trilinear"):
        import scipy.sparse.linalg  # lazy: SciPy's sparse eigensolver only for a held body

        self.lattice = lattice
        self.positions = np.ascontiguousarray(positions, dtype=np.float64)
        self.kernel = kernel
        self.periodic_y = not lattice.params.has_walls
        overlap = kernel_overlap_matrix(self.positions, kernel)
        largest = float(scipy.sparse.linalg.eigsh(overlap, k=1, which="LA", return_eigenvectors=False)[0])
        self.gain = 0.05 / largest
        self.integral = np.zeros_like(self.positions)
        self.forces = np.zeros_like(self.positions)
        self.time_step = 0
        if lattice.force_density is None:
            lattice.set_force_density(np.zeros((3,) + lattice.shape))
        else:
            lattice.force_density[...] = 0.0

    def advance(self, n_steps: int) -> None:
        """n_steps LB steps, the markers' forces updated before each (a few calls per step: the fixed-body
        calibration problems have a few hundred markers on small lattices)."""
        field = self.lattice.force_density
        for _ in range(int(n_steps)):
            ibm.clear(field, self.positions, self.kernel, self.periodic_y)
            self.forces = -self.gain * self.integral
            ibm.spread(self.forces, self.positions, self.lattice.shape, self.kernel, self.periodic_y, out=field)
            self.integral += ibm.interpolate_lattice_velocity(self.lattice, self.positions, self.kernel)
            self.lattice.step(1)
            self.time_step += 1

    def torque(self, centre) -> np.ndarray:
        """Torque of the fluid on the body about ``centre`` (dx), (3,)."""
        return np.cross(self.positions - np.asarray(centre), -self.forces).sum(axis=0)

    def stresslet(self, centre) -> np.ndarray:
        """Symmetric force dipole the body exerts on the fluid about ``centre``, (3, 3):
        sum_m sym((X_m - centre) f_m)."""
        dipole = (self.positions - np.asarray(centre)).T @ self.forces
        return 0.5 * (dipole + dipole.T)
