"""Run independent tasks (study runs, curve fits) through Dask: a local cluster by default, or an existing
scheduler.

    from elastocell.simulation.distributed import run_tasks
    for index, outcome in run_tasks(fit_one, paths, workers=2, description="fitting"):
        ...  # outcome is the task's return value, or a TaskFailure

Local cluster: one process per worker and one thread per process, because every task is already
whole-array compiled code (JAX, PARDISO, Numba) that brings its own threads; ``threads`` sets the thread
count each worker's kernels may use (``NUMBA_NUM_THREADS``, ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS``).
Its scheduler and workers listen on 127.0.0.1 only, and it has no dashboard unless ``dashboard`` asks for
one (the dashboard needs ``bokeh``).

An existing cluster (``scheduler="tcp://host:8786"``), e.g. started on a batch system with::

    dask scheduler                                   # on one node; prints tcp://HOST:8786
    dask worker tcp://HOST:8786 --nworkers 8 --nthreads 1   # on each compute node

needs elastocell installed on every worker and the output directory on a file system all workers share
(every task writes its own files there; the caller only collects small results). See
``docs/usage/cluster.md``.

Trust: a Dask scheduler runs the code it is sent (pickled functions), on its workers, as their user.
Connect only to a scheduler you trust, and do not let others reach yours: bind it to a private network
or 127.0.0.1, or make it require TLS. TLS: a ``tls://`` address with ``security`` (a
``distributed.Security`` holding the CA file and this client's certificate and key), or with Dask's own
configuration, which every ``distributed.Client`` reads when no ``security`` is given, e.g. from the
environment::

    DASK_DISTRIBUTED__COMM__TLS__CA_FILE=ca.pem
    DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT=client.pem
    DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY=client.key   # not needed when client.pem holds the key

(the command line's ``--scheduler tls://host:8786`` takes its TLS files this way).

Lost workers: a task whose worker dies (killed, out of memory, its batch job ended) is run again on another
worker by the Dask scheduler itself, up to ``distributed.scheduler.allowed-failures`` times (default 3;
the scheduler's own configuration); after that it is reported as a :class:`TaskFailure`
(``KilledWorker``) and the other tasks go on. A result is released as soon as it has been collected, so a
task that already finished is not run again when its worker dies later (and the tasks of elastocell read
a finished run's record back instead of repeating it).
"""

from __future__ import annotations

import os
import sys
import traceback
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

from elastocell.parameters.units import ParameterError
from elastocell.simulation.output import PlainProgress


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


LOCAL_HOST = "127.0.0.1"


def dashboard_address(dashboard: bool | str) -> str | None:
    """The local cluster's dashboard address: None (no dashboard) for False, a free port on 127.0.0.1 for
    True, or the address given (e.g. ``"127.0.0.1:8787"``; ``":8787"`` would listen on every interface)."""
    if dashboard is False or dashboard is None:
        return None
    if dashboard is True:
        return f"{LOCAL_HOST}:0"
    if not isinstance(dashboard, str) or not dashboard:
        raise ParameterError("dashboard", f"expected True, False or an address such as 127.0.0.1:8787, "
                                          f"got {dashboard!r}")
    return dashboard


@contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None, threads: int = 1, *,
                security=None, dashboard: bool | str = False):
    """A ``distributed.Client``: connected to ``scheduler``, or to a local cluster of ``workers`` processes
    (default: one per core) that is shut down on exit.

    The local cluster listens on 127.0.0.1 only (scheduler and workers) and opens a dashboard only when
    ``dashboard`` asks for it (:func:`dashboard_address`; ``client.dashboard_link`` then says where).
    ``security``: a ``distributed.Security`` for a TLS scheduler (``tls://host:8786``), or, for the local
    cluster, its TLS settings (``Security.temporary()``: encrypted with throwaway certificates); None: Dask's
    configuration (``distributed.comm.tls.*``, e.g. ``DASK_DISTRIBUTED__COMM__TLS__CA_FILE``).
    A scheduler runs the code it is sent: connect only to one you trust."""
    check_execution(scheduler, workers)
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        needs_tls = ParameterError("scheduler", f"{scheduler} needs TLS files: give security=distributed.Security("
                                   "...) or set DASK_DISTRIBUTED__COMM__TLS__CA_FILE, ..._TLS__CLIENT__CERT and "
                                   "..._TLS__CLIENT__KEY")
        if (str(scheduler).startswith("tls://") and security is None
                and not dask.config.get("distributed.comm.tls.ca-file", None)):
            # refused before a Client exists: a Client that fails half-built is finalised by a later garbage
            # collection, which can run inside another Client's event-loop start and deadlock it
            raise needs_tls
        try:
            client = Client(scheduler, timeout="20s", security=security)
        except (OSError, TimeoutError) as error:
            raise ParameterError("scheduler", f"cannot reach the Dask scheduler at {scheduler}: {error}") from None
        except TypeError as error:  # a tls:// address without usable certificates
            if "TLS" not in str(error):
                raise
            raise needs_tls from None
        try:
            yield client
        finally:
            client.close()
        return
    environment = {name: str(threads) for name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
                                                    "OPENBLAS_NUM_THREADS")}
    address = dashboard_address(dashboard)
    settings = {"distributed.worker.daemon": False, "logging.distributed": "error"}
    scheduler_options = {}
    if address is None:
        # Dask's nodes serve HTTP pages (cluster and task information, metrics) even without a dashboard: none
        # here, and the scheduler's (then empty) HTTP server on a free port of 127.0.0.1 instead of 8787
        settings.update({"distributed.scheduler.http.routes": [], "distributed.worker.http.routes": []})
        scheduler_options = {"dashboard": False, "dashboard_address": f"{LOCAL_HOST}:0"}
    with dask.config.set(settings):
        cluster = LocalCluster(n_workers=workers or default_workers(), threads_per_worker=1, processes=True,
                               host=LOCAL_HOST, dashboard_address=address, env=environment, silence_logs=40,
                               security=security, scheduler_kwargs=scheduler_options)
        client = Client(cluster, security=security)
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
              client=None, prepare: Callable[[], None] | None = None, security=None,
              dashboard: bool | str = False) -> Iterator[tuple[int, object]]:
    """Yield ``(index, result)`` for ``function(items[index])`` as the tasks finish, run on Dask.

    ``function`` must be importable by the workers (a module-level function). A raising task yields a
    :class:`TaskFailure` instead of its result; so does a task whose workers kept dying (``KilledWorker``:
    the scheduler already ran it again on other workers, ``distributed.scheduler.allowed-failures`` times).
    A task lost with its worker is run again by the scheduler, not by this function; a result is released
    once collected, so a finished task is not repeated when its worker dies afterwards.
    ``progress`` shows a rich progress bar (tasks done / total) on a terminal; elsewhere (a log file, a batch job)
    plain lines: at the start, on a finished task at most every ``PLAIN_PROGRESS_INTERVAL`` seconds, and at the end.
    ``prepare`` runs in this process before a local cluster starts (not with ``scheduler`` or ``client``),
    e.g. :func:`elastocell.scenarios.shear.compile_kernels` so that the workers load compiled kernels from the cache
    instead of compiling them all at once. ``security`` and ``dashboard``: as in :func:`dask_client` (not with
    ``client``).
    """
    items = list(items)
    if not items:
        return
    if client is None and scheduler is None and prepare is not None:
        prepare()
    if client is None:
        with dask_client(scheduler, workers, threads, security=security, dashboard=dashboard) as own:
            yield from run_tasks(function, items, description=description, progress=progress, client=own)
        return
    from distributed import as_completed

    futures = {client.submit(_guarded, function, item, pure=False): index for index, item in enumerate(items)}
    bar = plain = None
    if progress and not sys.stderr.isatty():  # a log file, a batch job: plain lines, at most one per interval
        plain = PlainProgress("tasks finished: {task.completed:.0f}", None)
        task = plain.add_task(description, total=len(items))
        plain.line(task)  # the start, at once
    elif progress:
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                       transient=True)
        bar.start()
        task = bar.add_task(description, total=len(items))
    finished = 0
    try:
        for future in as_completed(futures):
            index = futures.pop(future)  # this is the last reference: the scheduler forgets the task once
            try:                        # its result is here, and does not recompute it if its worker dies
                result = future.result()
            except Exception as error:  # KilledWorker (the task's workers kept dying), a cancelled task
                result = TaskFailure(type(error).__name__, str(error).splitlines()[0] if str(error) else "",
                                     traceback.format_exc())
            del future
            finished += 1
            if bar is not None:
                bar.advance(task)
            elif plain is not None:
                plain.update(task, completed=finished)
            yield index, result
    finally:
        if bar is not None:
            bar.stop()
        if plain is not None:
            plain.line(task)  # where it ended
