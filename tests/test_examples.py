"""The scripts in examples/ run end to end at their smoke size (ELASTOCELL_EXAMPLE_SMOKE=1) and write their files.

Each runs in a subprocess, as a user starts it, with its output directory in tmp_path.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # each example runs in a new process: about 90 s together

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"

# script -> files (relative to its output directory; glob patterns allowed) that a smoke run must leave
EXPECTED = {
    "reference_cell.py": ["compression.csv", "comparison.csv", "comparison.png", "metadata.json",
                          "equivalent/compression.csv"],
    "parameter_sweep.py": ["sweep.csv", "runs/*/run.json"],
    "shear_with_resume.py": ["timeseries.csv", "summary.json", "taylor_deformation.png", "checkpoint.npz"],
    "afm_fit.py": ["curves/*.csv", "fits.csv", "fit_settings.json", "*.png"],
    "lut_point.py": ["lut_point.json", "runs/*/point.json", "runs/*/timeseries.csv"],
}


def test_every_example_is_tested_and_documented():
    scripts = sorted(path.name for path in EXAMPLES.glob("*.py"))
    assert scripts == sorted(EXPECTED)
    readme = (EXAMPLES / "README.md").read_text()
    for name in scripts:
        text = (EXAMPLES / name).read_text()
        assert text.startswith('"""') and "ELASTOCELL_EXAMPLE_SMOKE" in text and "ELASTOCELL_EXAMPLE_OUT" in text
        assert name in readme


def _run(name: str, tmp_path: Path, *arguments: str) -> tuple[Path, str]:
    out = tmp_path / "out"
    env = {**os.environ, "ELASTOCELL_EXAMPLE_SMOKE": "1", "ELASTOCELL_EXAMPLE_OUT": str(out)}
    result = subprocess.run([sys.executable, str(EXAMPLES / name), *arguments], cwd=tmp_path, env=env,
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, f"{name} exited {result.returncode}\n{result.stdout}\n{result.stderr}"
    for pattern in EXPECTED[name]:
        assert list(out.glob(pattern)), f"{name}: nothing matches {out / pattern}\n{result.stdout}"
    assert not (tmp_path / "example-output").exists()  # everything went to ELASTOCELL_EXAMPLE_OUT
    return out, result.stdout


# All five at smoke size: 64 s on 2 cores (172 s while other jobs kept the load average at 10), so none is slow.
@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_example_runs_at_smoke_size(name, tmp_path):
    out, stdout = _run(name, tmp_path)
    if name == "shear_with_resume.py":
        assert json.loads((out / "summary.json").read_text())["resumed"] is True
        assert "Taylor deformation D" in stdout
    elif name == "parameter_sweep.py":
        assert len(list(out.glob("runs/*/run.json"))) == 2  # the cell and its equivalent
        assert "F/F_eq" in stdout
        _, again = _run(name, tmp_path)  # finished runs are read back, not computed again
        assert "0 curve(s) computed now, 2 read back" in again
    elif name == "reference_cell.py":
        assert "F/F_eq" in stdout
    elif name == "afm_fit.py":
        assert "E = " in stdout and "95 % interval" in stdout
    elif name == "lut_point.py":
        record = json.loads((out / "lut_point.json").read_text())
        assert record["area_um"] > 0 and record["deform"] >= 0
