"""The package gives the numbers recorded in ``tests/data/same_outputs/expected.json``.

Runs ``validation/same_outputs.py --check`` in process: a fixed set of cheap compression, flow, LUT and fit runs
compared with the recorded outputs to round-off (tolerances in the script; each run's recording commit is named
in the file). About a minute on 2 cores, plus Numba's first compilation of the flow kernels after an install.
"""

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "validation" / "same_outputs.py"
EXPECTED = Path(__file__).resolve().parent / "data" / "same_outputs" / "expected.json"


def _load_script():
    spec = importlib.util.spec_from_file_location("same_outputs", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_outputs_are_those_recorded(tmp_path, monkeypatch):
    if not EXPECTED.exists():
        pytest.skip(f"no recorded outputs at {EXPECTED}")
    same_outputs = _load_script()
    monkeypatch.setenv("ELASTOCELL_CACHE", str(tmp_path / "cache"))  # run_all sets both; restored after the test
    monkeypatch.setenv("ELASTOCELL_NO_VTK", "1")
    lines = []
    ok = same_outputs.check(EXPECTED, tmp_path / "runs", echo=lines.append, failures_only=True)
    assert ok, "\n".join(lines)
