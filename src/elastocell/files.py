"""Results on disk: atomic writes, JSON metadata, tidy CSV tables and curves, the versions of the software that
made them, parameter hashes, the verified cache, and a stopwatch.

Parameter hashes (:func:`parameter_hash`): what a run id, a checkpoint fingerprint, a LUT point key or a cache
key identifies is the full, resolved parameter model (defaults filled in), written as canonical JSON
(:func:`canonical_json`), plus one format version per kind of artefact, raised when the code that makes the
artefact changes what it contains.

Cache entries (:func:`write_cache_entry`, :func:`read_cache_entry`) under :func:`cache_directory`: one file, a
first line ``# {json}`` (the kind, its format version, the canonical parameters it was made from, the sha256
and length of the payload), then the payload (an ``.npz`` archive, a curve CSV). A reader checks all of it
before the payload is parsed; an entry made from other parameters, or truncated, emptied or altered, is reported
in one warning naming the file, removed and made again.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import platform
import threading
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from elastocell.version import __version__


def software_versions() -> dict:
    import gmsh
    import jax
    import meshio
    import scipy


    return {
        "elastocell": __version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "jax": jax.__version__,
        "gmsh": gmsh.__version__,
        "meshio": meshio.__version__,
    }


def replace_atomically(path: Path, write) -> None:
    """``write(temporary_path)`` to a temporary file beside ``path``, flushed to disk (fsync), then renamed over
    ``path`` (``os.replace``) and the directory synced: a killed run or a power cut leaves the old file or the
    new one, never a truncated one. The temporary name holds the process and thread, so concurrent writers of one
    path do not share it."""
    path = Path(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    try:
        write(temporary)
        with open(temporary, "rb+") as handle:
            os.fsync(handle.fileno())
        os.replace(temporary, path)
        _sync_directory(path.parent)
    finally:
        if temporary.exists():
            temporary.unlink()


def _sync_directory(directory: Path) -> None:
    """fsync a directory, so that a rename in it is on disk (where the system allows opening one)."""
    try:
        descriptor = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(descriptor)
    except OSError:
        pass
    finally:
        os.close(descriptor)


def _finite_or_null(value):
    """NaN and infinities become null: strict JSON has no NaN."""
    if isinstance(value, dict):
        return {key: _finite_or_null(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_null(item) for item in value]
    if isinstance(value, (float, np.floating)) and not np.isfinite(value):
        return None
    return value


def write_json(path: Path, payload: dict) -> None:
    """JSON (indented; NaN written as null), replaced atomically."""
    text = json.dumps(_finite_or_null(json.loads(json.dumps(payload, default=_json_default))), indent=2,
                      allow_nan=False) + "\n"
    replace_atomically(path, lambda temporary: temporary.write_text(text))


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot serialise {type(value)}")


def write_table(path: Path, columns: dict[str, np.ndarray]) -> None:
    """CSV with a header row, full float precision."""
    names = list(columns)
    data = np.column_stack([np.asarray(columns[name], dtype=float) for name in names])
    replace_atomically(path, lambda temporary: np.savetxt(temporary, data, delimiter=",", header=",".join(names),
                                                          comments="", fmt="%.10g"))


def curve_csv_text(metadata: dict, columns: dict[str, np.ndarray]) -> str:
    """A curve as CSV text: one ``# {json}`` metadata line, a header row, rows at 10 significant digits."""
    names = list(columns)
    lines = [f"# {json.dumps(metadata, sort_keys=True)}", ",".join(names)]
    lines += [",".join(f"{v:.10g}" for v in row)
              for row in np.column_stack([np.asarray(columns[k], dtype=float) for k in names])]
    return "\n".join(lines) + "\n"


def write_curve_csv(path: Path, metadata: dict, columns: dict[str, np.ndarray]) -> None:
    """:func:`curve_csv_text` written atomically."""
    text = curve_csv_text(metadata, columns)
    replace_atomically(Path(path), lambda temporary: temporary.write_text(text))


def parse_curve_csv(text: str) -> tuple[dict, dict[str, np.ndarray]]:
    """(metadata, {column: values}) of :func:`curve_csv_text`'s text (every ``# {json}`` line adds metadata)."""
    metadata, rows, names = {}, [], None
    for line in text.splitlines():
        if line.startswith("#"):
            metadata.update(json.loads(line[1:]))
        elif names is None:
            names = line.strip().split(",")
        elif line.strip():
            rows.append([float(v) for v in line.split(",")])
    if names is None or not rows:
        raise ValueError("no table")
    return metadata, dict(zip(names, np.array(rows).T, strict=True))


def read_curve_csv(path) -> tuple[dict, dict[str, np.ndarray]]:
    """(metadata, {column: values}) of a file written by :func:`write_curve_csv` (a path or a resource)."""
    return parse_curve_csv(path.read_text() if hasattr(path, "read_text") else Path(path).read_text())


# =========================================================================== parameter hashes
def _plain(value):
    """JSON-ready data of a parameter value: a pydantic model as ``model_dump(mode="json")``, a dataclass as its
    fields, NumPy scalars and arrays as numbers and lists, tuples as lists, mapping keys as strings."""
    if hasattr(value, "model_dump"):
        return _plain(value.model_dump(mode="json"))
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _plain({f.name: getattr(value, f.name) for f in dataclasses.fields(value)})
    if isinstance(value, dict):
        return {str(key): _plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(item) for item in value]
    if isinstance(value, (np.generic, np.ndarray)):
        return _plain(value.tolist())
    if isinstance(value, Path):
        return str(value)
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if hasattr(value, "__float__"):
        return float(value)
    raise TypeError(f"cannot write a {type(value).__name__} as a parameter")


def canonical_json(value) -> str:
    """One text per parameter value: :func:`_plain` data, keys sorted, no spaces, floats as Python's shortest
    round-trip form (so equal models give equal text, whatever the order their fields were given in)."""
    return json.dumps(_plain(value), sort_keys=True, separators=(",", ":"), allow_nan=True)


def parameter_hash(*parts, format_version: int) -> str:
    """sha256 (hex) of the canonical JSON of ``parts`` (resolved parameter models, dicts of plain values) and the
    artefact's ``format_version``: the key of a run, a checkpoint, a LUT point or a cache entry."""
    text = canonical_json({"format": int(format_version), "parameters": list(parts)})
    return hashlib.sha256(text.encode()).hexdigest()


def array_digest(*arrays) -> str:
    """sha256 (hex) of the bytes of ``arrays`` in order (C order, their own dtypes): what a checkpoint's
    fingerprint adds for the mesh and moduli a run was made with."""
    digest = hashlib.sha256()
    for array in arrays:
        digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()


# =========================================================================== the verified cache
def cache_directory() -> Path:
    """Where meshes and other reusable results are cached (``ELASTOCELL_CACHE`` overrides; else
    ``$XDG_CACHE_HOME/elastocell`` or ``~/.cache/elastocell``)."""
    root = os.environ.get("ELASTOCELL_CACHE")
    if root:
        path = Path(root)
    else:
        path = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "elastocell"
    path.mkdir(parents=True, exist_ok=True)
    return path


def _entry_header(kind: str, parameters, format_version: int) -> dict:
    return {"kind": kind, "format": int(format_version), "parameters": json.loads(canonical_json(parameters))}


def write_cache_entry(path: Path, payload: bytes, kind: str, parameters, format_version: int) -> None:
    """Store ``payload`` as the cache entry ``path`` of ``kind`` made from ``parameters``: a ``# {json}`` line
    (kind, format version, the canonical parameters, the payload's sha256 and length), then the payload; written
    atomically (:func:`replace_atomically`)."""
    header = {**_entry_header(kind, parameters, format_version), "sha256": hashlib.sha256(payload).hexdigest(),
              "bytes": len(payload)}
    data = b"# " + json.dumps(header, sort_keys=True).encode() + b"\n" + bytes(payload)
    replace_atomically(Path(path), lambda temporary: temporary.write_bytes(data))


def _entry_problem(data: bytes, kind: str, parameters, format_version: int) -> tuple[str | None, bytes]:
    """(what is wrong with the entry ``data``, or None; its payload)."""
    line, newline, payload = data.partition(b"\n")
    if not data:
        return "it is empty", b""
    try:
        if not (newline and line.startswith(b"# ")):
            raise ValueError
        header = json.loads(line[2:].decode())
        found = {key: header[key] for key in ("kind", "format", "parameters")}
        checksum, length = str(header["sha256"]), int(header["bytes"])
    except (ValueError, KeyError, TypeError, UnicodeDecodeError):
        return "its header is unreadable", b""
    if canonical_json(found) != canonical_json(_entry_header(kind, parameters, format_version)):
        if found["kind"] != kind or found["format"] != int(format_version):
            return f"it is a {found['kind']} entry of format {found['format']}", b""
        return "it was made from other parameters", b""
    if len(payload) != length:
        return f"it holds {len(payload)} of its {length} bytes", b""
    if hashlib.sha256(payload).hexdigest() != checksum:
        return "its content does not match its checksum", b""
    return None, payload


def read_cache_entry(path: Path, kind: str, parameters, format_version: int, parse: Callable[[bytes], object]):
    """``parse(payload)`` of the cache entry ``path`` when it is the ``kind`` entry made from ``parameters`` and
    intact; None when there is no entry. An entry made from other parameters, of another kind or format, cut
    short, emptied or altered (or whose payload ``parse`` refuses) is never used: one warning names the file and
    what is wrong, the file is removed, and None tells the caller to make the artefact again."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    except OSError as error:
        problem, payload = f"it cannot be read ({error.strerror or error})", b""
    else:
        problem, payload = _entry_problem(data, kind, parameters, format_version)
    if problem is None:
        try:
            return parse(payload)
        except Exception as error:  # noqa: BLE001 - whatever a damaged payload raises, it is not used
            problem = f"its payload cannot be read ({type(error).__name__}: {error})"
    warnings.warn(f"cache entry {path} is not used: {problem}; it is removed and made again", stacklevel=3)
    path.unlink(missing_ok=True)
    return None


class Stopwatch:
    def __init__(self):
        self.start = time.perf_counter()

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.start


def save_figure(figure, path: Path, **options) -> None:
    """``figure.savefig`` written atomically (format from the suffix): a full disk or a kill leaves the previous
    figure or none, never a truncated one; a failed write raises OSError naming the file."""
    path = Path(path)
    try:
        replace_atomically(path, lambda temporary: figure.savefig(temporary, format=path.suffix.lstrip(".") or None,
                                                                  **options))
    except OSError as error:
        raise OSError(error.errno, error.strerror or str(error), str(path)) from None
