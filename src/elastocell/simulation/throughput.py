"""Throughput of the lattice-Boltzmann engine against this machine's memory roofline (``elastocell bench
lattice``; ``validation/lattice.py`` prints the full table with peers).

Everything is measured in the same process:

* memory bandwidth: a STREAM-like triad ``a = b + s c`` compiled with Numba (parallel) on float64 arrays of
  2^25 elements (3 x 256 MiB, far larger than the caches), counted as 24 B per element (STREAM convention);
* MLUPS (million lattice-node updates per second) of the fused, compiled step (``Lattice.step(n)``: one
  compiled call for n steps), best of several repeats, with the CPU use of that run (CPU seconds per wall
  second; below the thread count when other processes took part of the cores: the figure is then a lower
  bound);
* MLUPS with a cell: the same lattice carrying the reference cell (stiffness ratio 2, size ratio 0.5, every
  mesh node a marker; elastic forces, spreading, interpolation and marker motion inside the same compiled
  chunk, :meth:`elastocell.coupling.immersed.ImmersedCell.advance`);
* roofline: a D3Q19 update loads and stores 19 populations, 2 x 19 x 4 = 152 B in float32 and 304 B in
  float64, so MLUPS_roof = bandwidth / bytes per update.
"""

from __future__ import annotations

import time

import numpy as np

from elastocell.body.cell import Cell
from elastocell.coupling.immersed import ImmersedCell
from elastocell.lattice import Lattice, LatticeParams
from elastocell.parameters.cell import cell_parameters

TRIAD_ELEMENTS = 1 << 25
_bandwidth_cache: dict[int, float] = {}


def set_threads(threads: int | None = None) -> int:
    """Numba threads for the kernels (default: all Numba may use); returns the number set."""
    import numba

    threads = numba.config.NUMBA_NUM_THREADS if threads is None else max(1, min(threads, numba.config.NUMBA_NUM_THREADS))
    numba.set_num_threads(threads)
    return threads


def _triad_kernel():
    from numba import njit, prange

    @njit(parallel=True, cache=True)
    def triad(a, b, c, scalar):
        for i in prange(a.size):
            a[i] = b[i] + scalar * c[i]

    return triad


def stream_triad_bandwidth(elements: int = TRIAD_ELEMENTS, repeats: int = 8) -> float:
    """Best STREAM-triad bandwidth (GB/s, 1e9 B/s) with 24 B per float64 element."""
    if elements in _bandwidth_cache:
        return _bandwidth_cache[elements]
    triad = _triad_kernel()
    a, b, c = np.zeros(elements), np.ones(elements), np.full(elements, 2.0)
    triad(a, b, c, 3.0)  # compile + first touch
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        triad(a, b, c, 3.0)
        best = min(best, time.perf_counter() - start)
    _bandwidth_cache[elements] = 24.0 * elements / best / 1e9
    return _bandwidth_cache[elements]


def jax_triad_bandwidth(elements: int = TRIAD_ELEMENTS, repeats: int = 8) -> float:
    """Best triad a = b + s c bandwidth (GB/s, 3 arrays read or written per element) on JAX's default
    device: the roofline of the JAX backend, measured the same way as :func:`stream_triad_bandwidth`."""
    import jax
    import jax.numpy as jnp


    triad = jax.jit(lambda b, c, scalar: b + scalar * c)
    b = jnp.ones(elements)
    c = jnp.full(elements, 2.0)
    triad(b, c, 3.0).block_until_ready()
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        triad(b, c, 3.0).block_until_ready()
        best = min(best, time.perf_counter() - start)
    return 3.0 * elements * b.dtype.itemsize / best / 1e9


def bytes_per_update(dtype) -> int:
    """Minimum memory traffic of one D3Q19 node update (B): load and store 19 populations."""
    return 2 * 19 * np.dtype(dtype).itemsize


def _best_rate(advance, nodes: int, repeats: int, target_seconds: float) -> tuple[float, float]:
    """(best MLUPS, CPU seconds per wall second of that run) of ``advance(n_steps)``."""
    advance(2)  # compile (or load from the cache) and warm up
    start = time.perf_counter()
    advance(2)
    per_step = max(time.perf_counter() - start, 1e-6) / 2
    steps = max(2, 2 * int(target_seconds / per_step / 2))
    best, cpu_at_best = np.inf, 0.0
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        advance(steps)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        if wall < best:
            best, cpu_at_best = wall, cpu
    return nodes * steps / best / 1e6, cpu_at_best / best


def _lattice(size: int, dtype: str, backend: str = "numba"):

    lattice_class = Lattice
    if backend == "jax":
        from elastocell.lattice.jax_backend import (
            JaxLattice as lattice_class,  # lazy: JAX (about 1 s) only when the JAX backend is measured
        )
    return lattice_class(LatticeParams((size, size, size), relaxation_time=0.8, dtype=str(np.dtype(dtype))),
                         velocity=(0.01, 0.0, 0.0))


def lattice_mlups(size: int, dtype: str = "float32", repeats: int = 5, target_seconds: float = 0.5,
                  backend: str = "numba"):
    """(MLUPS, CPU use) of the pure LB step on a periodic size^3 lattice (TRT, no force): the fused Numba
    kernel, or the JAX step on JAX's default device (timed to completion on the device)."""
    lattice = _lattice(size, dtype, backend)
    if backend == "jax":
        def advance(n):
            lattice.step(n)
            lattice.deviations.block_until_ready()

        return _best_rate(advance, size**3, repeats, target_seconds)
    return _best_rate(lattice.step, size**3, repeats, target_seconds)


def lattice_with_cell_mlups(size: int, dtype: str = "float32", radius: float | None = None, repeats: int = 5,
                            target_seconds: float = 0.5, backend: str = "numba") -> tuple[float, float, int]:
    """(MLUPS, CPU use, markers) of the same lattice carrying the reference cell of radius R = size/8 dx
    (default), linear elements of about 2 dx, E_c = 1e-4 in lattice units (stable, small deformation)."""

    radius = size / 8.0 if radius is None else float(radius)
    mesh_size = min(0.5, max(2.0 / radius, 0.08))
    cell = Cell.from_parameters(cell_parameters(element="p1", mesh_size=mesh_size, pole_size=mesh_size,
                                                    interface_size=mesh_size))
    lattice = _lattice(size, dtype, backend)
    cell_class = ImmersedCell
    if backend == "jax":
        from elastocell.coupling.immersed_jax import (
            JaxImmersedCell as cell_class,  # lazy: JAX (about 1 s) only when the JAX backend is measured
        )
    system = cell_class(lattice, cell, centre=np.full(3, size / 2.0), radius=radius, youngs_modulus=1e-4)
    mlups, cpu = _best_rate(system.advance, size**3, repeats, target_seconds)
    return mlups, cpu, cell.mesh.n_nodes


def _device_name(backend: str) -> str:
    if backend == "jax":
        import jax

        return str(jax.devices()[0].device_kind)
    import platform

    return platform.processor() or platform.machine()


def run_benchmark(size: int = 128, dtype: str = "float32", with_cell: bool = True, threads: int | None = None,
                  backend: str = "numba") -> dict:
    """Measure bandwidth, pure-LB and with-cell MLUPS at size^3 in this process, on a backend: "numba" (the
    CPU kernels against a STREAM triad on the CPU) or "jax" (JAX's default device, against a triad on that
    device).

    Keys: ``mlups``, ``mlups_with_cell``, ``bandwidth_gbs`` (STREAM triad), ``roofline_fraction`` (mlups over
    bandwidth / bytes per update), ``roofline_mlups``, ``bytes_per_update``, ``with_cell_slowdown`` (pure over
    with-cell MLUPS), ``markers``, ``size``, ``dtype``, ``threads``, ``cpu_utilisation``.
    """
    threads = set_threads(threads)
    bandwidth = jax_triad_bandwidth() if backend == "jax" else stream_triad_bandwidth()
    mlups, cpu = lattice_mlups(size, dtype, backend=backend)
    nbytes = bytes_per_update(dtype)
    roofline = bandwidth * 1e9 / nbytes / 1e6
    result = {
        "size": int(size), "dtype": str(np.dtype(dtype)), "threads": threads, "bandwidth_gbs": bandwidth,
        "bytes_per_update": nbytes, "roofline_mlups": roofline, "mlups": mlups, "roofline_fraction": mlups / roofline,
        "cpu_utilisation": cpu, "mlups_with_cell": None, "with_cell_slowdown": None, "markers": 0,
        "backend": backend, "device": _device_name(backend),
    }
    if with_cell:
        with_cell_mlups, _, markers = lattice_with_cell_mlups(size, dtype, backend=backend)
        result.update(mlups_with_cell=with_cell_mlups, with_cell_slowdown=mlups / with_cell_mlups, markers=markers)
    return result
