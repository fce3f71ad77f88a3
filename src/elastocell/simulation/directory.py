"""One run per output directory: a lock file that names its holder.

``with output_directory(out):`` creates ``out`` and holds ``out/.elastocell.lock`` (the holder's process id,
host and command) for the duration of a run, touching it every :data:`HEARTBEAT` seconds. A second run into
the same directory refuses with one line naming the holder; a lock left by a process that no longer exists on
this host, or one untouched for :data:`STALE_AFTER` seconds (its node died: on a cluster the run is then
recomputed elsewhere), is taken over with a warning.
The lock is created with ``O_CREAT | O_EXCL``, so two runs starting at the same instant cannot both win.
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
from pathlib import Path

from elastocell.parameters.units import ParameterError

LOCK_NAME = ".elastocell.lock"


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
    for _ in range(2):
        try:
            descriptor = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            other = _read_holder(lock)
            same_host = other.get("host") == holder["host"]
            dead = same_host and isinstance(other.get("pid"), int) and not _process_alive(other["pid"])
            # another host's lock: judged by its heartbeat (its node may have died); on this host by its pid only,
            # since a long compiled step that holds the GIL can delay the heartbeat of a live run
            silent = not same_host and _seconds_since_heartbeat(lock) > STALE_AFTER
            if dead or silent:
                reason = "which no longer runs" if dead else f"silent for more than {STALE_AFTER:.0f} s"
                warnings.warn(f"{out}: taking over the lock of process {other.get('pid', '?')} on "
                              f"{other.get('host', '?')}, {reason} (it was: {other.get('command', '?')})", stacklevel=3)
                with contextlib.suppress(FileNotFoundError):
                    lock.unlink()
                continue
            who = f"process {other.get('pid', '?')} on {other.get('host', '?')}" if other else "another run"
            raise ParameterError(parameter, f"{out} is in use by {who}; wait for it, choose another directory, "
                                            f"or delete {lock} if that run is gone") from None
        except OSError as error:
            raise ParameterError(parameter, f"cannot write to the output directory {out}: "
                                            f"{error.strerror or error}") from None
        with os.fdopen(descriptor, "w") as handle:
            json.dump(holder, handle)
        break
    else:  # pragma: no cover - the stale lock reappeared between unlink and create
        raise ParameterError(parameter, f"{out} is in use by another run that just started")
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


def _seconds_since_heartbeat(lock: Path) -> float:
    try:
        return time.time() - lock.stat().st_mtime
    except OSError:
        return 0.0


@contextlib.contextmanager
def interruptible():
    """SIGTERM (a batch system's or ``kill``'s stop) raises KeyboardInterrupt in the main thread while the block
    runs, so that a run stopped either way writes what it has (as on Ctrl-C); the previous handler is restored
    afterwards. Outside the main thread (a Dask worker) nothing changes."""
    import signal
    import threading

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
