"""Start-up cost of a command in a new process: ``elastocell --help``, ``import elastocell``, and the time from
process start to the first converged row of a compression curve (the first Newton step's equilibrium), each in
a fresh interpreter, first with empty caches (the mesh, JAX's compilation cache and Numba's on-disk kernels all
built) and then again (what every later run pays).

    python validation/startup.py [--repeat 3] [--code-path SRC]

``--code-path`` runs another copy of the package with the same module layout (e.g. a checkout of another
commit: ``git worktree add /tmp/other <commit>`` and ``--code-path /tmp/other/src``) in the same run, so that
both are measured on the same machine at the same time. The cell is the homogeneous default p2 cell, whose curve the
README's first command computes; the row is delta = delta_max / steps.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from page import Page  # noqa: E402

FIRST_ROW = r"""
import time, json, sys
marks = {"interpreter": time.time()}
import elastocell
marks["import"] = time.time()
from elastocell import cell_parameters
from elastocell.body.cell import Cell, enable_compilation_cache
from elastocell.scenarios.compression import CompressionParameters, compress
enable_compilation_cache()
cell = Cell.from_parameters(cell_parameters(nucleus="none"))
marks["cell"] = time.time()

class FirstRow(Exception):
    pass

def progress(delta):
    marks["first_row"] = time.time()
    raise FirstRow

try:
    compress(cell, CompressionParameters(delta_max=0.75, steps=40), progress=progress)
except FirstRow:
    pass
print(json.dumps(marks))
"""


def run(code: str, environment: dict) -> tuple[float, dict]:
    """Wall time from spawning the interpreter, and the marks it printed (seconds since the spawn)."""
    start = time.time()
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=environment,
                            timeout=900)
    if result.returncode != 0:
        raise RuntimeError(result.stderr[-2000:])
    marks = json.loads(result.stdout.strip().splitlines()[-1]) if result.stdout.strip() else {}
    return time.time() - start, {name: value - start for name, value in marks.items()}


def help_time(environment: dict) -> float:
    start = time.time()
    subprocess.run([sys.executable, "-m", "elastocell", "--help"], capture_output=True, env=environment, check=True)
    return time.time() - start


def measure(label: str, code_path: str | None, repeat: int) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        environment = {**os.environ, "ELASTOCELL_CACHE": cache, "NUMBA_CACHE_DIR": str(Path(cache) / "numba")}
        if code_path:
            environment["PYTHONPATH"] = code_path
        for attempt in range(repeat + 1):
            state = "empty caches" if attempt == 0 else f"warm caches ({attempt})"
            _, marks = run(FIRST_ROW, environment)
            rows.append({"code": label, "run": state, "elastocell --help (s)": f"{help_time(environment):.2f}",
                         "import (s)": f"{marks['import']:.2f}", "cell built (s)": f"{marks['cell']:.2f}",
                         "first row (s)": f"{marks['first_row']:.2f}"})
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=2, help="warm-cache runs after the first (default 2)")
    parser.add_argument("--code-path", default=None, help="another copy of the package's src/ to measure too")
    args = parser.parse_args(argv)
    page = Page("startup", "startup.py", intro=(
        "Seconds from spawning a new interpreter: to the end of `import elastocell`, to a built default cell (p2, "
        "mesh from the cache after the first run), and to the first converged row of its compression curve "
        "(the first load step's Newton solve, including JAX's and Numba's compilation or their on-disk caches). "
        "The first run of each code starts with empty caches; the later ones are what every further command pays."))
    rows = []
    if args.code_path:
        rows += measure(f"--code-path {args.code_path}", args.code_path, args.repeat)
    rows += measure("this checkout", None, args.repeat)
    page.table(rows, "Start-up, new process each")
    page.write()


if __name__ == "__main__":
    main()
