"""Run independent tasks (study runs, curve fits) through Dask: a local cluster by default, or an existing
scheduler.

    from elastocell.simulation.distributed import run_tasks
    for index, outcome in run_tasks(fit_one, paths, workers=2, description="fitting"):
        ...  # outcome is the task's return value, or a TaskFailure

Local cluster: one process per worker and one thread per process, because every task is already
whole-array compiled code (JAX, PARDISO, Numba) that brings its own threads; ``threads`` sets the thread
count each worker's kernels may use (``NUMBA_NUM_THREADS``, ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS``).

An existing cluster (``scheduler="tcp://host:8786"``), e.g. started on a batch system with::

    dask scheduler                                   # on one node; prints tcp://HOST:8786
    dask worker tcp://HOST:8786 --nworkers 8 --nthreads 1   # on each compute node

needs elastocell installed on every worker and the output directory on a file system all workers share
(every task writes its own files there; the caller only collects small results).
"""

from __future__ import annotations

import os
import traceback
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

from elastocell.parameters.units import ParameterError


@dataclass
class TaskFailure:
    """A task that raised: its exception's type and message (one line) and the traceback text."""

    error_type: str
    message: str
    traceback: str

    def __str__(self) -> str:
        return f"{self.error_type}: {self.message}"


def check_execution(scheduler: str | None, workers: int | None) -> None:
    """Refuse impossible execution settings before starting anything."""
    if scheduler is not None and workers is not None:
        raise ParameterError("workers", "give either --scheduler or --workers, not both")
    if workers is not None and workers < 1:
        raise ParameterError("workers", f"must be >= 1, got {workers}")
    if scheduler is not None and "://" not in scheduler and ":" not in scheduler:
        raise ParameterError("scheduler", f"expected an address such as tcp://host:8786, got {scheduler!r}")


def default_workers() -> int:
    """One worker per available core."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


@contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None, threads: int = 1):
    """A ``distributed.Client``: connected to ``scheduler``, or to a local cluster of ``workers`` processes
    (default: one per core) that is shut down on exit."""
    check_execution(scheduler, workers)
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="20s")
        except OSError as error:
            raise ParameterError("scheduler", f"cannot reach the Dask scheduler at {scheduler}: {error}") from None
        try:
            yield client
        finally:
            client.close()
        return
    environment = {name: str(threads) for name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
                                                    "OPENBLAS_NUM_THREADS")}
    with dask.config.set({"distributed.worker.daemon": False, "logging.distributed": "error"}):
        cluster = LocalCluster(n_workers=workers or default_workers(), threads_per_worker=1, processes=True,
                               dashboard_address=":0", env=environment, silence_logs=40)
        client = Client(cluster)
        try:
            yield client
        finally:
            client.close()
            cluster.close()


def _guarded(function: Callable, item):
    """Run one task; an exception becomes a TaskFailure so that one bad task does not stop the others."""
    try:
        return function(item)
    except Exception as error:  # noqa: BLE001 - reported per task
        return TaskFailure(type(error).__name__, str(error).splitlines()[0] if str(error) else "",
                           traceback.format_exc())


def run_tasks(function: Callable, items: Sequence, *, scheduler: str | None = None, workers: int | None = None,
              threads: int = 1, description: str = "running", progress: bool = False,
              client=None, prepare: Callable[[], None] | None = None) -> Iterator[tuple[int, object]]:
    """Yield ``(index, result)`` for ``function(items[index])`` as the tasks finish, run on Dask.

    ``function`` must be importable by the workers (a module-level function). A raising task yields a
    :class:`TaskFailure` instead of its result. ``progress`` shows a rich progress bar (tasks done / total).
    ``prepare`` runs in this process before a local cluster starts (not with ``scheduler`` or ``client``),
    e.g. :func:`elastocell.scenarios.shear.compile_kernels` so that the workers load compiled kernels from the cache
    instead of compiling them all at once.
    """
    items = list(items)
    if not items:
        return
    if client is None and scheduler is None and prepare is not None:
        prepare()
    if client is None:
        with dask_client(scheduler, workers, threads) as own:
            yield from run_tasks(function, items, description=description, progress=progress, client=own)
        return
    from distributed import as_completed

    futures = {client.submit(_guarded, function, item, pure=False): index for index, item in enumerate(items)}
    bar = None
    if progress:
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                       transient=True)
        bar.start()
        task = bar.add_task(description, total=len(items))
    try:
        for future in as_completed(futures):
            index = futures[future]
            try:
                result = future.result()
            except Exception as error:  # a worker died (memory, segfault): report it as this task's failure
                result = TaskFailure(type(error).__name__, str(error).splitlines()[0] if str(error) else "",
                                     traceback.format_exc())
            if bar is not None:
                bar.advance(task)
            yield index, result
    finally:
        if bar is not None:
            bar.stop()
