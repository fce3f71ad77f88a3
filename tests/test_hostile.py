"""Hostile inputs to every command: NaN, infinities, wrong counts, conflicting options, bad and damaged files.
Each is refused with exit code 2 and one line naming the option (or the file), before any file is written, and
never with a traceback. Unit strings that could hang the parser are covered for every quantity option in
tests/test_cli.py."""

from __future__ import annotations

import pytest

from elastocell.cli.app import main


def run_command(arguments, capsys) -> tuple[int, str]:
    """The console command as a user runs it (usage errors formatted by ``main``): exit code and its output."""
    with pytest.raises(SystemExit) as stop:
        main(arguments)
    captured = capsys.readouterr()
    return stop.value.code, captured.out + captured.err

FLOW = ["--resolution", "3", "--duration", "0.1", "--quiet"]
LUT = ["--channel-radius", "10um", "--flow-rate", "0.04uL/s", "--viscosity", "15mPa*s"]

CASES = [
    # compress / equivalent: NaN, infinities, out-of-range counts and conflicting cell options
    (["compress", "--stiffness-ratio", "nan"], "--stiffness-ratio"),
    (["compress", "--stiffness-ratio", "inf"], "--stiffness-ratio"),
    (["compress", "--size-ratio", "-inf"], "--size-ratio"),
    (["compress", "--poisson-ratio", "nan"], "--poisson-ratio"),
    (["compress", "--delta-max", "nan"], "--delta-max"),
    (["compress", "--steps", "0"], "--steps"),
    (["compress", "--steps", "-5"], "--steps"),
    (["compress", "--mesh-size", "nan"], "--mesh-size"),
    (["compress", "--mesh-size", "0"], "--mesh-size"),
    (["compress", "--offset", "inf"], "--offset"),
    (["compress", "--semi-axes", "0.5", "nan", "0.4", "--nucleus", "ellipsoid"], "--semi-axes"),
    (["compress", "--random", "--stiffness-ratio", "5"], "--random"),
    (["compress", "--random", "--nucleus", "ellipsoid"], "--random"),
    (["compress", "--nucleus", "none", "--size-ratio", "0.3"], "--size-ratio"),
    (["compress", "--nucleus", "ellipsoid", "--size-ratio", "0.3"], "--size-ratio"),
    (["compress", "--equivalent", "--compare"], "--compare"),
    # options that nothing would read, given away from their defaults
    (["compress", "--seed", "3"], "--seed"),
    (["equivalent", "--seed", "3"], "--seed"),
    (["compress", "--seed", "0"], "--seed"),  # given, even at the default value, it is read by nothing
    (["compress", "--nucleus", "none", "--interface-size", "0.05"], "--interface-size"),
    (["compress", "--random", "--interface-size", "0.05"], "--interface-size"),
    (["shear", "--capillary-number", "0.1", "--nucleus", "none", "--interface-size", "0.05", *FLOW],
     "--interface-size"),
    (["pipe", "--capillary-number-wall", "0.2", "--stationary-observable", "deformation", *FLOW],
     "--stationary-observable"),
    (["compress", "--radius", "nan um"], "--radius"),
    (["compress", "--youngs-modulus", "-inf kPa"], "--youngs-modulus"),
    (["equivalent", "--stiffness-ratio", "nan"], "--stiffness-ratio"),
    (["equivalent", "--random", "--offset", "0.2"], "--random"),
    # shear / pipe
    (["shear", "--capillary-number", "nan", *FLOW], "--capillary-number"),
    (["shear", "--capillary-number", "inf", *FLOW], "--capillary-number"),
    (["shear", "--capillary-number", "1000", *FLOW], "--capillary-number"),
    (["shear", "--capillary-number", "0.1", "--resolution", "nan", "--quiet"], "--resolution"),
    (["shear", "--capillary-number", "0.1", "--duration", "-1", "--resolution", "3", "--quiet"], "--duration"),
    (["shear", "--capillary-number", "0.1", "--checkpoint-every", "0", *FLOW], "--checkpoint-every"),
    (["shear", "--capillary-number", "0.1", "--viscosity", "nan", *FLOW], "--viscosity"),
    (["shear", "--capillary-number", "0.1", "--duration", "1e9", "--resolution", "12", "--quiet"], "--duration"),
    (["pipe", "--capillary-number-wall", "nan", *FLOW], "--capillary-number-wall"),
    (["pipe", "--capillary-number-wall", "1e6", *FLOW], "--capillary-number-wall"),
    (["pipe", "--capillary-number-wall", "0.2", "--channel-radius-ratio", "0.5", *FLOW], "--channel-radius-ratio"),
    (["pipe", "--capillary-number-wall", "0.2", "--start-offset", "inf", *FLOW], "--start-offset"),
    # fit afm / fit shear: values and files
    (["fit", "afm", "{bad_jpk}", "--radius", "nan"], "--radius"),
    (["fit", "afm", "{bad_jpk}", "--radius", "8um", "--poisson-ratio", "inf"], "--poisson-ratio"),
    (["fit", "afm", "{bad_jpk}", "--radius", "8um", "--delta-max", "nan"], "--delta-max"),
    (["fit", "afm", "{missing}", "--radius", "8um"], "missing.csv"),
    (["fit", "shear", "--deformation", "nan", "--shear-stress", "1Pa"], "--deformation"),
    (["fit", "shear", "--deformation", "0.1", "--shear-stress", "inf Pa"], "--shear-stress"),
    (["fit", "shear", "--table", "{missing}"], "missing.csv"),
    # lut, study
    (["lut", "--out", "{out}/lut.txt", *LUT, "--radii", "nan", "--quick"], "--radii"),
    (["lut", "--out", "{out}/lut.txt", *LUT, "--moduli", "inf kPa", "--quick"], "--moduli"),
    (["lut", "--out", "{out}/lut.txt", "--channel-radius", "10um", "--flow-rate", "nan uL/s", "--viscosity", "15",
      "--quick"], "--flow-rate"),
    (["lut", "--out", "{out}/lut.txt", "--channel-radius", "10um", "--flow-rate", "0.04", "--viscosity", "-1",
      "--quick"], "--viscosity"),
    (["lut", "--out", "{out}/lut.txt", "--quick"], "--flow-rate"),
    (["study", "run", "no-such-study", "--out", "{out}/paper", "--quick"], "no-such-study"),
    (["study", "run", "cell-models", "--out", "{out}/paper", "--workers", "0", "--quick"], "--workers"),
]


@pytest.mark.parametrize("arguments, named", CASES, ids=[" ".join(a[:3]) + f" [{i}]" for i, (a, _) in enumerate(CASES)])
def test_hostile_input_is_one_line_exit_2_before_any_file(tmp_path, capsys, arguments, named):
    bad = tmp_path / "bad.jpk-force"
    bad.write_bytes(b"garbage\x00\x01 not a jpk file")
    out = tmp_path / "out"
    values = {"bad_jpk": str(bad), "missing": str(tmp_path / "missing.csv"), "out": str(out)}
    arguments = [a.format(**values) for a in arguments]
    if arguments[0] in ("compress", "shear", "pipe"):
        arguments = [arguments[0], "--out", str(out), *arguments[1:]]
    code, output = run_command(arguments, capsys)
    lines = [line for line in output.strip().splitlines() if line.strip()]
    assert code == 2, output
    assert len(lines) == 1 and named in lines[0], output
    assert "Traceback" not in output
    assert not out.exists() or not any(out.rglob("*.csv")), "refused after writing results"


def test_damaged_afm_file_is_reported_with_its_name_and_the_reason(tmp_path, capsys):
    """A damaged instrument file is not a crash: the row of that file says what is wrong, and with no curve
    accepted the command exits non-zero."""
    bad = tmp_path / "damaged.jpk-force"
    bad.write_bytes(b"PK\x03\x04 truncated zip")
    code, output = run_command(["fit", "afm", str(bad), "--radius", "8um", "--out", str(tmp_path / "fits"),
                                "--no-plots", "--quiet"], capsys)
    assert code != 0
    assert "damaged.jpk-force" in output and "Traceback" not in output


def test_options_at_their_defaults_or_read_are_not_refused():
    """The refusals of unread options fire only when an option is given away from its default: the random cell
    with a seed, a nucleus cell with an interface size, a cell without a nucleus in a flow (whose uniform mesh sets
    the interface size to the mesh size), and the stationarity stop with its observable are accepted."""
    from elastocell.parameters.cell import cell_parameters
    from elastocell.parameters.flow import flow_cell
    from elastocell.simulation.runner import StopCriteria

    assert cell_parameters(random=True, seed=3).random.seed == 3
    assert cell_parameters(random=True).random.seed == 0
    assert cell_parameters(nucleus="sphere", interface_size=0.05).mesh.interface_size == 0.05
    assert cell_parameters(nucleus="none", mesh_size=0.4, interface_size=0.4).nucleus.shape == "none"
    assert flow_cell(None, {"nucleus": "none"}, 6.0).nucleus.shape == "none"
    assert StopCriteria(stationary_tolerance=0.01, stationary_observable="deformation").stationary_tolerance == 0.01
