"""The pipe at its defaults against dclab's LE-2D-FEM-19 (axisymmetric FEM, the RT-DC field's standard table).

One cell of issue 24's pipe target (R = 6 um, E = 3 kPa, nu 0.48, in the table's cylinder R_ch = 1.094 x 10 um,
0.04 uL/s, 15 mPa s: Ca_w = 0.5757, R/R_ch = 0.55) run by ``elastocell.pipe`` with nothing but the cell and the
flow given: the R/dx 8 and 6 pair, read on six side views, to the command's default duration of 10/gdot_w (about
two minutes on two cores). The table is read as validation/pipe_target.py reads it (``table_readings``: the
deformation D_t on the isoelastic of the cell's shear modulus at the run's area, and the area on it at the run's
D). Measured (docs/validation/flow_default.md, section "pipe_default_cost.py", the same run): D -4.7 %, area
+3.2 %, E +2.3 %; R/dx 8 alone (the default before the pair) reads D +12.1 %, area -6.9 %, so the test fails on it.
"""

from __future__ import annotations

import importlib.util
import warnings
from pathlib import Path

import pytest

pytest.importorskip("dclab")

ROOT = Path(__file__).resolve().parents[1]
RADIUS_UM, MODULUS_KPA = 6.0, 3.0


def _validation(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "validation" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_default_pipe_reads_le_2d_fem_19_within_its_measured_error(tmp_path):
    """Each error within 1.3 % (E: 1.2 %) of its measured value (D -4.7 %, area +3.2 %, E +2.3 %; two runs of the
    page agree to the digits shown, so the margins are for other CPUs' rounding and the drift of a transient
    shape): D within -6.0 to -3.4 %, area +1.9 to +4.5 %, E +1.1 to +3.5 %; issue 24's target is 10 %."""
    import sys

    sys.path.insert(0, str(ROOT / "validation"))
    try:
        dclab_reading = _validation("pipe_dclab")
        reference = _validation("pipe_resolution")
    finally:
        sys.path.remove(str(ROOT / "validation"))
    from elastocell.api.pipe import pipe, rtdc_reading

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the window is not stationary at t = 10: said by the run, not tested here
        summary = pipe(tmp_path / "run", reference.wall_capillary_number(MODULUS_KPA), nucleus="none",
                       poisson_ratio=reference.POISSON_RATIO,
                       channel_radius_ratio=reference.CHANNEL_RADIUS_UM / RADIUS_UM, progress=False,
                       vtk_interval=None)
    assert summary["extrapolation"]["fine_resolution"] == 8 and summary["extrapolation"]["coarse_resolution"] == 6
    deform, area_r2, reading = rtdc_reading(summary)
    assert reading == "side views" and "outline_guard" not in summary["extrapolation"]
    area = area_r2 * RADIUS_UM**2
    e_t = 3 * MODULUS_KPA / (2 * (1 + reference.POISSON_RATIO))  # the table's E (nu 0.5) of the same shear modulus
    (d_t, a_t, e_table), = dclab_reading.table_readings([(area, deform, e_t)])
    assert deform / d_t - 1 == pytest.approx(-0.047, abs=0.013)
    assert area / a_t - 1 == pytest.approx(0.032, abs=0.013)
    assert e_table / e_t - 1 == pytest.approx(0.023, abs=0.012)
