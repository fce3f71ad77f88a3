"""The command-line contract: names, files, columns, and one-line errors (exit code 2) before any meshing."""

import json
import subprocess
import sys

import numpy as np
import pytest
from typer.testing import CliRunner

from elastocell.cli.app import app

runner = CliRunner()


@pytest.mark.parametrize("arguments,parameter", [
    (["--size-ratio", "1.2"], "--size-ratio"),
    (["--size-ratio", "0.6", "--offset", "0.45"], "--offset"),
    (["--poisson-ratio", "0.5"], "--poisson-ratio"),
    (["--youngs-modulus", "-1kPa"], "--youngs-modulus"),
    (["--stiffness-ratio", "0"], "--stiffness-ratio"),
    (["--nucleus", "ellipsoid", "--semi-axes", "0.9", "0.5", "0.5", "--offset", "0.2"], "--semi-axes"),
    (["--delta-max", "1.0"], "--delta-max"),
    (["--material", "rubber"], "--material"),
    (["--element", "p3"], "--element"),
    (["--quadrature-degree", "10"], "--quadrature-degree"),
    (["--element", "p1", "--quadrature-degree", "5"], "--quadrature-degree"),
    (["--radius", "8 parsecs/s"], "--radius"),
])
def test_impossible_input_is_one_line_exit_2(tmp_path, arguments, parameter):
    result = runner.invoke(app, ["compress", "--out", str(tmp_path / "x"), *arguments])
    assert result.exit_code == 2
    lines = [line for line in result.output.strip().splitlines() if line]
    assert len(lines) == 1 and parameter in lines[0] and "Traceback" not in result.output
    assert not (tmp_path / "x").exists()  # refused before any work


def test_equivalent_json_reports_effective_stiffness_ratio():
    result = runner.invoke(app, ["equivalent", "--stiffness-ratio", "10", "--mesh-size", "0.35", "--json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.output)
    assert payload["effective_stiffness_ratio"] == pytest.approx(2.125, rel=5e-3)
    assert payload["n_nodes"] > 0 and payload["volume"] == pytest.approx(4 / 3 * np.pi, rel=1e-3)


def test_compress_writes_the_contract_files(tmp_path):
    out = tmp_path / "run"
    result = runner.invoke(app, ["compress", "--out", str(out), "--delta-max", "0.1", "--steps", "2",
                                 "--mesh-size", "0.5", "--pole-size", "0.2", "--radius", "8um",
                                 "--youngs-modulus", "1kPa", "--compare", "--quiet"])
    assert result.exit_code == 0, result.output
    header = (out / "compression.csv").read_text().splitlines()[0]
    assert header == "delta,force,force_per_Ec_R2,force_per_Eeff_R2"
    table = np.genfromtxt(out / "compression.csv", delimiter=",", names=True)
    assert table["delta"][0] == 0 and len(table) == 3
    np.testing.assert_allclose(table["force"], table["force_per_Ec_R2"] * 1e3 * (8e-6) ** 2, rtol=1e-9)
    metadata = json.loads((out / "metadata.json").read_text())
    for key in ("effective_stiffness_ratio", "element_order", "mesh", "software", "wall_time_s", "cell"):
        assert key in metadata
    assert metadata["units"]["force"] == "N"
    assert (out / "compression.png").stat().st_size > 1000
    assert (out / "vtk" / "compression.pvd").exists() and len(list((out / "vtk").glob("*.vtu"))) == 3
    assert (out / "equivalent" / "compression.csv").exists() and (out / "comparison.png").exists()
    ratio = np.genfromtxt(out / "comparison.csv", delimiter=",", names=True)["force_ratio"]
    assert np.all(np.isfinite(ratio[1:]))


def test_compress_records_the_rule_with_the_nodes_for_a_stiff_nucleus_and_the_smallest_volume_ratio(tmp_path):
    """`elastocell compress --stiffness-ratio 10` takes degree 5 (compression.compression_parameters_for) for the
    cell and its equivalent, and the metadata records it with the smallest J; `--quadrature-degree 2` is kept."""
    for extra, degree in (([], 5), (["--quadrature-degree", "2"], 2)):
        out = tmp_path / f"run{degree}"
        result = runner.invoke(app, ["compress", "--out", str(out), "--delta-max", "0.1", "--steps", "2",
                                     "--stiffness-ratio", "10", "--mesh-size", "0.6", "--pole-size", "0.3",
                                     "--compare", "--quiet", *extra])
        assert result.exit_code == 0, result.output
        for path in (out / "metadata.json", out / "equivalent" / "metadata.json"):
            metadata = json.loads(path.read_text())
            assert metadata["cell"]["mesh"]["quadrature_degree"] == degree
            assert 0.5 < metadata["solver"]["min_volume_ratio"] < 1 and metadata["solver"]["first_half_volume_delta"] is None


def test_module_entry_point_help():
    completed = subprocess.run([sys.executable, "-m", "elastocell", "--help"], capture_output=True, text=True)
    assert completed.returncode == 0 and "compress" in completed.stdout


@pytest.mark.parametrize("arguments, named", [
    (["compress", "--bogus", "1"], "--bogus"),                  # unknown option
    (["compress", "--stiffness-ratio", "abc"], "--stiffness-ratio"),  # wrong type
    (["shear", "--capillary-number", "0.1", "--backend", "cuda"], "--backend"),  # not a choice
    (["compress"], "--out"),                                    # missing option
])
def test_usage_errors_are_one_line_naming_the_option_with_exit_code_2(tmp_path, arguments, named):
    # The console command (elastocell.cli.app:main, also behind python -m elastocell) reports click's usage errors
    # as one line, like every other user error, instead of a framed box.
    out = [] if arguments == ["compress"] else ["--out", str(tmp_path / "x")]
    completed = subprocess.run([sys.executable, "-m", "elastocell", *arguments, *out], capture_output=True, text=True)
    assert completed.returncode == 2
    lines = completed.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("elastocell: error:") and named in lines[0], completed.stderr
    assert not (tmp_path / "x").exists()


def test_equivalent_run_prints_summary_and_conflicting_flags_are_refused(tmp_path):
    result = runner.invoke(app, ["compress", "--out", str(tmp_path / "eq"), "--equivalent", "--delta-max", "0.05",
                                 "--steps", "1", "--mesh-size", "0.5", "--pole-size", "0.25"])
    assert result.exit_code == 0, result.output
    metadata = json.loads((tmp_path / "eq" / "metadata.json").read_text())
    assert metadata["equivalent"] is True and metadata["complete"] is True
    table = np.genfromtxt(tmp_path / "eq" / "compression.csv", delimiter=",", names=True)
    np.testing.assert_allclose(table["force_per_Eeff_R2"], table["force_per_Ec_R2"] / metadata["effective_stiffness_ratio"])
    refused = runner.invoke(app, ["compress", "--out", str(tmp_path / "x"), "--equivalent", "--compare"])
    assert refused.exit_code == 2 and "--compare" in refused.output


def test_bench_lattice_json_contract():
    """`elastocell bench lattice --json`: the last line is JSON with the contract keys, the roofline fraction
    is MLUPS over bandwidth / bytes per update (a consistency check; speed itself is never asserted)."""
    result = runner.invoke(app, ["bench", "lattice", "--size", "16", "--json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.output.strip().splitlines()[-1])
    for key in ("mlups", "mlups_with_cell", "bandwidth_gbs", "roofline_fraction"):
        assert payload[key] > 0
    assert payload["roofline_fraction"] == pytest.approx(
        payload["mlups"] / (payload["bandwidth_gbs"] * 1e3 / payload["bytes_per_update"]), rel=1e-9)
    assert payload["markers"] > 0
    refused = runner.invoke(app, ["bench", "lattice", "--size", "4"])
    assert refused.exit_code == 2 and "--size" in refused.output


def test_folded_elements_and_collapsed_volume_are_warned_in_one_line_each(capsys):
    from elastocell.cli.app import _warn_curves

    folded = {"first_folded_delta": 0.68, "min_nodal_jacobian": -0.36}
    _warn_curves({"solver": folded, "equivalent_summary": {"solver": {"first_folded_delta": None}}})
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "warning (cell)" in lines[0] and "0.680" in lines[0] and "-0.36" in lines[0]
    collapsed = {"first_half_volume_delta": 0.525, "min_volume_ratio": 0.09}
    _warn_curves({"solver": {}, "equivalent_summary": {"solver": collapsed}})
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "warning (equivalent)" in lines[0] and "0.525" in lines[0] and "0.09" in lines[0]
    _warn_curves({"solver": {"first_folded_delta": None, "first_half_volume_delta": None}})
    assert capsys.readouterr().err == ""
