"""Throughput of the D3Q19 lattice Boltzmann kernel against the machine's memory roofline.

Run::

    python validation/lattice.py                 # 64^3 and 128^3, float32 and float64, + lbmpy
    python validation/lattice.py --sizes 128 --dtypes float32 --no-lbmpy

Everything is measured in the same run:

* memory bandwidth: a STREAM-like triad ``a = b + s c`` compiled with Numba (parallel)
  on float64 arrays of 2^25 elements (3 x 256 MiB, far larger than the caches),
  counted as 24 B per element (STREAM convention);
* MLUPS (million lattice-node updates per second) of the fused, compiled step
  (``Lattice.step(n)``, one compiled call for n steps), best of several repeats, with
  the CPU use of that run (CPU seconds / wall second; < threads means other processes
  took part of the cores, so the figure is a lower bound);
* roofline: a D3Q19 update must load and store 19 populations, 2 x 19 x 4 = 152 B
  in float32 and 304 B in float64, so MLUPS_roof = bandwidth / bytes per update;
* optionally lbmpy's generated D3Q19 TRT kernel (C + OpenMP, two lattices, SoA
  layout) at 128^3 in float32, timed alone (no ghost-layer exchange), if lbmpy
  imports; otherwise a note is printed.

The measurements live in :mod:`elastocell.simulation.throughput` (also behind ``elastocell bench lattice``); this
script adds the table over sizes and precisions and the peer (lbmpy) in the same run, and writes them into
docs/validation/lattice.md (``validation/page.py``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

try:
    import elastocell  # noqa: F401
except ImportError:  # running from a source checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from page import Page

from elastocell.simulation.throughput import (
    TRIAD_ELEMENTS,
    run_benchmark,
    set_threads,
    stream_triad_bandwidth,
)

THREADS = 2
THREADS_SETTING = {"threads": THREADS}  # changed by --threads


def _set_threads() -> int:
    return set_threads(THREADS_SETTING["threads"])


def time_lbmpy(size: int = 128, dtype="float32", repeats: int = 5) -> tuple[float | None, str]:
    """MLUPS of lbmpy's generated D3Q19 TRT kernel (pull, two lattices), or (None, reason)."""
    try:
        import pystencils as ps
        from lbmpy import LBMConfig, LBMOptimisation, LBStencil, Method, Stencil, create_lb_function
    except Exception as exc:  # not installed / broken install
        return None, f"lbmpy not available ({type(exc).__name__}: {exc}); install with `pip install lbmpy`"
    try:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            dtype = str(np.dtype(dtype))
            src = ps.fields(f"src(19): {dtype}[3D]", layout="fzyx")
            dst = ps.fields(f"dst(19): {dtype}[3D]", layout="fzyx")
            config = LBMConfig(
                stencil=LBStencil(Stencil.D3Q19),
                method=Method.TRT,
                relaxation_rate=1.0 / 0.8,
                compressible=True,
            )
            optimisation = LBMOptimisation(symbolic_field=src, symbolic_temporary_field=dst, cse_global=True)
            kernel_config = ps.CreateKernelConfig(data_type=dtype, cpu_openmp=_set_threads())
            kernel = create_lb_function(
                lbm_config=config, lbm_optimisation=optimisation, config=kernel_config
            )
        n = size + 2  # one ghost layer each side
        # fzyx: population index slowest, x fastest
        a = np.zeros((19, n, n, n), dtype).transpose(3, 2, 1, 0)
        a[...] = np.array([1 / 3] + [1 / 18] * 6 + [1 / 36] * 12, dtype=dtype)
        b = a.copy(order="K")
        kernel(src=a, dst=b)
        best = np.inf
        for _ in range(repeats):
            t = time.perf_counter()
            kernel(src=a, dst=b)
            best = min(best, time.perf_counter() - t)
            a, b = b, a
        return size**3 / best / 1e6, "lbmpy kernel (C/OpenMP, SoA, two lattices), timed alone"
    except Exception as exc:
        return None, f"lbmpy kernel generation/run failed ({type(exc).__name__}: {exc})"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[64, 128])
    parser.add_argument("--dtypes", nargs="+", default=["float32", "float64"])
    parser.add_argument("--no-lbmpy", action="store_true", help="skip the lbmpy comparison")
    parser.add_argument("--no-cell", action="store_true", help="skip the runs with an immersed cell")
    parser.add_argument("--threads", type=int, default=THREADS, help="Numba threads (default 2)")
    parser.add_argument("--backends", nargs="+", default=["numba"], choices=["numba", "jax"],
                        help="numba (CPU kernels) and/or jax (JAX's default device, its own triad roofline)")
    args = parser.parse_args(argv)

    page = Page("lattice", "lattice.py", intro=(
        "Million lattice-node updates per second (MLUPS) of elastocell's fused D3Q19 lattice-Boltzmann step "
        "against the machine's memory roofline, both measured in this run: a D3Q19 update must load and store 19 "
        "populations (152 B in float32, 304 B in float64), so the roofline is the STREAM-triad bandwidth over "
        "those bytes. With an immersed cell, the same lattice carries a coupled cell (its markers, the elastic "
        "forces, spreading and interpolation). The independent peer is lbmpy's generated D3Q19 TRT kernel "
        "(C + OpenMP, two lattices) at 128^3 in float32, timed alone, where lbmpy is installed. The MLUPS are the "
        "best of several repeats; a CPU use below the thread count means other processes held part of the cores "
        "(a lower bound then)."), versions=("numba", "lbmpy", "pystencils"))
    THREADS_SETTING["threads"] = args.threads
    threads = _set_threads()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    bandwidth = stream_triad_bandwidth()
    page.print(f"threads: {threads}   load average (1 min) before the run: {load:.2f} on {os.cpu_count()} CPUs")
    page.print(f"STREAM triad (numba, parallel, 3 x {TRIAD_ELEMENTS * 8 / 2**20:.0f} MiB): {bandwidth:.1f} GB/s")
    results, rows = {}, []
    for backend, size, dtype in ((b, s, d) for b in args.backends for s in args.sizes for d in args.dtypes):
        r = run_benchmark(size, dtype, with_cell=not args.no_cell, threads=threads, backend=backend)
        if backend == "numba":
            results[(size, r["dtype"])] = r
        with_cell = r["mlups_with_cell"] is not None
        rows.append({"backend": backend, "size": f"{size}^3", "dtype": r["dtype"], "MLUPS": r["mlups"],
                     "B/update": r["bytes_per_update"], "roof MLUPS": r["roofline_mlups"],
                     "of roof": r["roofline_fraction"], "CPU use": r["cpu_utilisation"],
                     "+cell MLUPS": r["mlups_with_cell"] if with_cell else None,
                     "markers": r["markers"] if with_cell else None,
                     "slowdown": r["with_cell_slowdown"] if with_cell else None})
        print(f"  done {backend} {size}^3 {r['dtype']}: {r['mlups']:.1f} MLUPS", flush=True)
    page.table(rows, "D3Q19 step against the roofline", formats={
        "MLUPS": ".1f", "roof MLUPS": ".1f", "of roof": ".1%", "CPU use": ".2f", "+cell MLUPS": ".1f",
        "slowdown": ".2f"})
    if args.no_lbmpy:
        page.print("lbmpy: skipped (--no-lbmpy)")
    else:
        mlups, note = time_lbmpy(128, "float32")
        if mlups is None:
            page.print(f"lbmpy: skipped -- {note}")
        else:
            ours = results.get((128, "float32")) or run_benchmark(128, "float32", with_cell=False, threads=threads)
            page.table([{"code": "lbmpy", "size": "128^3", "dtype": "float32", "MLUPS": mlups, "note": note},
                        {"code": "elastocell", "size": "128^3", "dtype": "float32", "MLUPS": ours["mlups"],
                         "note": f"elastocell / lbmpy = {ours['mlups'] / mlups:.2f}"}],
                       "Peer: lbmpy", formats={"MLUPS": ".1f"})
    page.write()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
