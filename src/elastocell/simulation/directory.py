"""One run per output directory: a lock file that names its holder.

``with output_directory(out):`` creates ``out`` and holds ``out/.elastocell.lock`` (the holder's process id,
host and command) for the duration of a run, touching it every :data:`HEARTBEAT` seconds. A second run into
the same directory refuses with one line naming the holder; a lock left by a process that no longer exists on
this host, or one untouched for :data:`STALE_AFTER` seconds (its node died: on a cluster the run is then
recomputed elsewhere), is taken over with a warning.
The lock is created with ``O_CREAT | O_EXCL``, so two runs starting at the same instant cannot both win; a
stale lock is removed only by the run that first creates its takeover token (named after that lock's inode and
modification time, also with ``O_EXCL``), and only while the lock is still that same file, so two runs that
find the same stale lock cannot remove each other's fresh one (:func:`_take_over`).
A sweep's task that finds its directory held by another run (on a cluster: the same task, rescheduled after its
node died, whose lock still looks alive) waits for that lock to go stale: :func:`waiting_while_in_use`.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import socket
import sys
import threading
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from elastocell.parameters.units import ParameterError

LOCK_NAME = ".elastocell.lock"


class DirectoryInUse(ParameterError):
    """The output directory is held by another run that looks alive."""


def _process_alive(pid: int) -> bool:
    """Whether a process with this id exists on this host (signal 0 checks without sending anything)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by another user
        return True
    return True


def _read_holder(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


@contextlib.contextmanager
def output_directory(out, parameter: str = "out"):
    """Create ``out`` (and its parents) and hold its lock while the block runs; release it afterwards, also on
    an exception or an interruption. Raises :class:`ParameterError` (one line, naming ``parameter``) when
    another live run holds the directory, or when it cannot be created or written."""
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ParameterError(parameter, f"cannot create the output directory {out}: {error.strerror or error}") from None
    lock = out / LOCK_NAME
    holder = {"pid": os.getpid(), "host": socket.gethostname(), "command": " ".join(sys.argv)[:500]}
    for _ in range(TAKEOVER_ATTEMPTS):
        try:
            descriptor = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                seen = lock.stat()
            except FileNotFoundError:  # released in between: try again
                continue
            other = _read_holder(lock)
            same_host = other.get("host") == holder["host"]
            dead = same_host and isinstance(other.get("pid"), int) and not _process_alive(other["pid"])
            # another host's lock: judged by its heartbeat (its node may have died); on this host by its pid only,
            # since a long compiled step that holds the GIL can delay the heartbeat of a live run
            silent = not same_host and time.time() - seen.st_mtime > STALE_AFTER
            if dead or silent:
                if _take_over(lock, seen):
                    reason = "which no longer runs" if dead else f"silent for more than {STALE_AFTER:.0f} s"
                    warnings.warn(f"{out}: taking over the lock of process {other.get('pid', '?')} on "
                                  f"{other.get('host', '?')}, {reason} (it was: {other.get('command', '?')})",
                                  stacklevel=3)
                else:  # another run is taking over (or took over) the same stale lock: look again
                    time.sleep(0.05)
                continue
            who = f"process {other.get('pid', '?')} on {other.get('host', '?')}" if other else "another run"
            raise DirectoryInUse(parameter, f"{out} is in use by {who}; wait for it, choose another directory, "
                                            f"or delete {lock} if that run is gone") from None
        except OSError as error:
            raise ParameterError(parameter, f"cannot write to the output directory {out}: "
                                            f"{error.strerror or error}") from None
        with os.fdopen(descriptor, "w") as handle:
            json.dump(holder, handle)
        break
    else:  # pragma: no cover - other runs kept taking the lock between our attempts
        raise DirectoryInUse(parameter, f"{out} is in use by another run that just started")
    stop = threading.Event()
    beat = threading.Thread(target=_heartbeat, args=(lock, stop), daemon=True, name="elastocell-lock-heartbeat")
    beat.start()
    try:
        yield out
    finally:
        stop.set()
        beat.join()
        if _read_holder(lock).get("pid") == holder["pid"]:
            with contextlib.suppress(FileNotFoundError):
                lock.unlink()


HEARTBEAT = 15.0
"""Seconds between two touches of a held lock (its modification time says the holder is alive)."""

STALE_AFTER = 8 * HEARTBEAT
"""A lock untouched for longer belongs to a run that is gone: its node died, so its process id cannot be checked
from here. It is taken over with a warning."""


def _heartbeat(lock: Path, stop: threading.Event) -> None:
    while not stop.wait(HEARTBEAT):
        with contextlib.suppress(OSError):
            os.utime(lock)


TAKEOVER_ATTEMPTS = 20
"""How often :func:`output_directory` looks at the lock again while other runs take over the same stale lock."""


def _take_over(lock: Path, seen: os.stat_result) -> bool:
    """Remove the stale lock ``seen`` (its stat when it was judged stale) unless another run is removing it or
    has already replaced it. Returns whether this run may now create the lock.

    The takeover token, created with ``O_EXCL`` and named after the lock's inode and modification time, lets
    one run only check and remove that very file; the check (same inode and modification time as judged)
    keeps a run that judged the lock before another replaced it from removing the replacement (it returns False
    and looks again). A token older
    than :data:`STALE_AFTER` (its run died within the few milliseconds a takeover takes) is removed."""
    token = lock.with_name(f"{lock.name}.takeover-{seen.st_ino}-{seen.st_mtime_ns}")
    try:
        os.close(os.open(token, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644))
    except FileExistsError:
        with contextlib.suppress(OSError):
            if time.time() - token.stat().st_mtime > STALE_AFTER:
                token.unlink()
        return False
    try:
        now = lock.stat()
        if (now.st_ino, now.st_mtime_ns) != (seen.st_ino, seen.st_mtime_ns):
            return False  # already replaced by another run
        lock.unlink()
    except FileNotFoundError:
        pass
    finally:
        with contextlib.suppress(FileNotFoundError):
            token.unlink()
    return True


def waiting_while_in_use(function: Callable, *args, patience: float | None = None, **kwargs):
    """``function(*args, **kwargs)``; while it raises :class:`DirectoryInUse`, call it again every
    :data:`HEARTBEAT` seconds, for at most ``patience`` seconds (default: :data:`STALE_AFTER` and two
    heartbeats, long enough for the lock of a run whose node died to go stale and be taken over).

    For a sweep's task on a cluster: rescheduled after its node died, it meets that node's lock, which still
    looks alive for up to STALE_AFTER; a lock of a run that stays alive (on this host: its process exists) is
    still refused after ``patience``."""
    patience = STALE_AFTER + 2 * HEARTBEAT if patience is None else patience
    deadline = time.monotonic() + patience
    while True:
        try:
            return function(*args, **kwargs)
        except DirectoryInUse:
            if time.monotonic() >= deadline:
                raise
            time.sleep(min(HEARTBEAT, max(deadline - time.monotonic(), 0.0)))


@contextlib.contextmanager
def interruptible():
    """SIGTERM (a batch system's or ``kill``'s stop) raises KeyboardInterrupt in the main thread while the block
    runs, so that a run stopped either way writes what it has (as on Ctrl-C); the previous handler is restored
    afterwards. Outside the main thread (a Dask worker) nothing changes."""
    import signal

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


class OutputSet:
    """The files one result consists of, written all or nothing: ``write(path, writer, ...)`` calls
    ``writer(path, ...)``; when a write fails (a full disk, a read-only directory) the files this set already
    wrote are removed and the error names the file that failed, so nothing is left that looks complete."""

    def __init__(self):
        self.written: list[Path] = []

    def write(self, path, writer, *args, **kwargs):
        path = Path(path)
        try:
            result = writer(path, *args, **kwargs)
        except OSError as error:
            self.discard()
            raise OSError(error.errno, error.strerror or str(error), str(path)) from None
        self.written.append(path)
        return result

    def discard(self) -> None:
        for path in self.written:
            with contextlib.suppress(OSError):
                if path.is_dir():
                    shutil.rmtree(path)
                else:
                    path.unlink()
        self.written.clear()
