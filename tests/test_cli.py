"""The command-line contract: names, files, columns, and one-line errors (exit code 2) before any meshing."""

import json
import subprocess
import sys
import time
from enum import Enum

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

import elastocell.cli.options as options
import elastocell.inverse.lut as lut_module
from elastocell.cli.app import app
from elastocell.cli.options import OPTION_NAMES, OPTIONS
from elastocell.parameters.units import parse_quantity
from elastocell.version import __version__

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


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
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


# ---------------------------------------------------------------- the options: one declaration, one contract

# Every command's options, in --help order: name=default (name! when required). A contract: scripts use these.
EXPECTED_OPTIONS = {
    'bench lattice': '--size=128 --dtype=float32 --no-cell=False --threads=None --backend=numba --json=False',
    'compress': '--out! --nucleus=sphere --stiffness-ratio=2.0 --size-ratio=0.5 --offset=0.0 --offset-axis=x '
                '--semi-axes=0.8,0.4,0.4 --nucleus-axis=x --random=False --seed=None --mesh-size=None --pole-size=None '
                '--interface-size=None --poisson-ratio=0.48 --youngs-modulus=1 --radius=1 --material=neo-hookean '
                '--element=p2 --quadrature-degree=None --volumetric=standard --delta-max=0.75 --steps=40 --equivalent=False '
                '--compare=False --axisymmetric=False --resume=False --quiet=False',
    'equivalent': '--nucleus=sphere --stiffness-ratio=2.0 --size-ratio=0.5 --offset=0.0 --offset-axis=x '
                  '--semi-axes=0.8,0.4,0.4 --nucleus-axis=x --random=False --seed=None --mesh-size=None '
                  '--pole-size=None --interface-size=None --poisson-ratio=0.48 --youngs-modulus=1 --radius=1 '
                  '--material=neo-hookean --element=p2 --volumetric=standard --json=False',
    'fit afm': 'files! --radius=None --geometry=parallel-plates --cell-shape=sphere --indenter-radius=None '
               '--cap-height=None --layer-thickness=None --half-angle=None --depth-max=None --spring-constant=None '
               '--sensitivity=None '
               '--poisson-ratio=0.48 --material=neo-hookean '
               '--model=both --delta-max=0.75 --contact-point=auto --bootstrap=0 --seed=0 '
               '--nucleus-size-ratio=None --stiffness-ratio=None --baseline-fraction=0.2 --threshold=5.0 '
               '--baseline-tilt=False --out=fits --no-plots=False --scheduler=None --workers=None --quiet=False',
    'fit shear': '--deformation=None --shear-stress=None --deformation-error=0.0 --shear-stress-error=0 '
                 '--tank-treading-frequency=None --tank-treading-frequency-error=0 --shear-rate=None --radius=None '
                 '--table=None --poisson-ratio=0.48 --material=neo-hookean --confidence=0.95 --out=fits '
                 '--quiet=False',
    'fit rtdc': 'files! --lut=LE-2D-FEM-19 --medium=None --temperature=None --out=fits --no-plots=False '
                '--quiet=False',
    'indent': '--out! --indenter=sphere --indenter-radius=None --half-angle=None --cell-shape=sphere --cap-height=None --layer-thickness=None '
              '--depth-max=0.3 --steps=20 --solver=auto --nucleus=sphere --stiffness-ratio=2.0 --size-ratio=0.5 '
              '--offset=0.0 --offset-axis=x --semi-axes=0.8,0.4,0.4 --nucleus-axis=x --random=False --seed=None '
              '--mesh-size=None --pole-size=None --interface-size=None --poisson-ratio=0.48 --youngs-modulus=1 '
              '--radius=1 --material=neo-hookean --element=p2 --quadrature-degree=None --volumetric=standard --resume=False '
              '--quiet=False '
              '--json=False',
    'lut': '--channel-radius=None --channel-width=None --channel-shape=None --channel-height=None --channel-wall=interpolated --volume-correction=none --flow-rate! '
           '--viscosity=None --medium=newtonian --temperature=None --flow-index=None --channel-length=None '
           '--out! --radii=None '
           '--moduli=None --quick=False --stiffness-ratio=None --size-ratio=None --poisson-ratio=0.48 '
           '--material=neo-hookean --resolution=None '
           '--extrapolate=False --coarse-resolution=None --hydrodynamic-radius-correction=0.3 --duration=None '
           '--stationary-tolerance=None '
           '--identifier=None --subdivisions=8 --scheduler=None --workers=None --quiet=False',
    'mastercurve compression': '--poisson-ratio=0.48 --material=neo-hookean --out=None --no-cache=False '
                               '--quiet=False',
    'mastercurve shear': '--poisson-ratio=0.48 --material=neo-hookean --out=None --no-cache=False --quiet=False',
    'mastercurve indentation': '--poisson-ratio=0.48 --material=neo-hookean --out=None --no-cache=False '
                               '--quiet=False --workers=1 --cell-shape=sphere --indenter=sphere',
    'pipe': '--out! --capillary-number-wall=None --nucleus=sphere --stiffness-ratio=2.0 --size-ratio=0.5 '
            '--offset=0.0 --offset-axis=x --semi-axes=0.8,0.4,0.4 --nucleus-axis=x --random=False --seed=None '
            '--mesh-size=None --pole-size=None --interface-size=None --poisson-ratio=0.48 --youngs-modulus=1 '
            '--radius=1 --material=neo-hookean --element=p1 --volumetric=standard --equivalent=False --channel-radius-ratio=2.0 '
            '--start-offset=0.0 --resolution=8.0 --extrapolate=None --coarse-resolution=None '
            '--hold-flow-rate=True --hydrodynamic-radius-correction=0.3 --channel-shape=None '
            '--channel-wall=interpolated --volume-correction=none --channel-width=None --channel-height=None '
            '--channel-aspect-ratio=None --medium=newtonian --temperature=None --flow-index=None '
            '--channel-length=None --duration=10.0 --pressure-gradient=None --wall-clock=None '
            '--stationary-tolerance=None --stationary-observable=strain_axial --record-interval=0.1 '
            '--checkpoint-every=20 --vtk-interval=1.0 --resume=False --backend=numba --quiet=False',
    'reproduce': '--quick=False --scheduler=None --workers=None --out! --quiet=False',
    'shipped-luts': '',
    'shear': '--out! --capillary-number=None --nucleus=sphere --stiffness-ratio=2.0 --size-ratio=0.5 --offset=0.0 '
             '--offset-axis=x --semi-axes=0.8,0.4,0.4 --nucleus-axis=x --random=False --seed=None --mesh-size=None '
             '--pole-size=None --interface-size=None --poisson-ratio=0.48 --youngs-modulus=1 --radius=1 '
             '--material=neo-hookean --element=p1 --volumetric=standard --equivalent=False --resolution=8.0 '
             '--extrapolate=True --coarse-resolution=None --duration=6.0 '
             '--confinement=0.2 --viscosity=None --shear-rate=None --wall-clock=None --stationary-tolerance=None '
             '--record-interval=0.05 --checkpoint-every=20 --vtk-interval=1.0 --resume=False --backend=numba '
             '--quiet=False',
    'study list': '',
    'study plot': 'name! directory!',
    'study run': 'name! --quick=False --scheduler=None --workers=None --out! --quiet=False',
}


def _commands():
    """(command path, click command) of every leaf command."""
    found = []

    def walk(command, path):
        for name, sub in sorted(getattr(command, "commands", {}).items()):
            walk(sub, [*path, name])
        if path and not hasattr(command, "commands"):
            found.append((" ".join(path), command))

    walk(typer.main.get_command(app), [])
    return found


def _listing(command) -> str:
    words = []
    for param in command.params:
        default = param.default.value if isinstance(param.default, Enum) else param.default
        if isinstance(default, tuple | list):
            default = ",".join(map(str, default))
        words.append(f"{param.opts[0]}{'!' if param.required else '=' + str(default)}")
    return " ".join(words)


def test_every_command_keeps_its_options_and_defaults():
    assert {path: _listing(command) for path, command in _commands()} == EXPECTED_OPTIONS


def test_option_names_for_errors_come_from_the_one_declaration():
    assert OPTION_NAMES == {name: option.option for name, option in OPTIONS.items()}
    for path, command in _commands():
        for param in command.params:
            assert OPTION_NAMES[param.name] in (param.opts[0], param.name.upper()), (path, param.name)


def test_version():
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and result.output.strip() == f"elastocell {__version__}"
    completed = subprocess.run([sys.executable, "-m", "elastocell", "--version"], capture_output=True, text=True)
    assert completed.returncode == 0 and completed.stdout.strip() == f"elastocell {__version__}"


def test_top_level_help_says_what_the_tool_does():
    text = " ".join(runner.invoke(app, ["--help"], env={"COLUMNS": "300"}).output.split())
    for group in ("compress:", "equivalent:", "shear, pipe:", "fit afm, fit shear:", "lut:", "study, reproduce:",
                  "mastercurve:", "bench:", "--version", "A bare number is in the option's documented unit"):
        assert group in text


def test_every_option_help_shows_its_default_and_units():
    """A default (literal, or described in parentheses where it is None or an off flag) or [required], and
    units for every number: 'Units: ...' or, for a quantity, what a bare number is in."""
    for path, command in _commands():
        for param in command.params:
            where = f"{path} {param.opts[0]}"
            assert param.required or param.show_default is True or isinstance(param.show_default, str), where
            if param.show_default is True and not param.required:
                assert param.default is not None and param.default is not False, where
            annotation = param.type_descriptor.annotation
            quantity = OPTIONS[param.name].quantity is not None
            if annotation is float or annotation == tuple[float, float, float] or quantity:
                assert "Units: " in param.help or "a bare number is" in param.help, where
    shown = " ".join(runner.invoke(app, ["shear", "--help"], env={"COLUMNS": "300"}).output.split())
    for text in ("[default: 0.48]", "[default: (off)]", "[default: (2 dx, uniform)]",
                 "A quantity like 15mPa*s; a bare number is in mPa*s.", "a bare number is dimensionless, in units of R",
                 "Units: strain, shear_rate*t. [default: 6.0]"):
        assert text in shown, text


# ---------------------------------------------------------------- hostile quantities: one line, exit code 2

HOSTILE = ["9**9**9um", "1e999999um", "nan", "inf kPa", '__import__("os")', "9" * 10_000, "8 furlongs",
           "wrong dimension"]

LUT = ["lut", "--channel-radius", "10um", "--flow-rate", "0.04uL/s", "--viscosity", "15mPa*s", "--quick"]
# (command, option, arguments before the hostile option) for every option that takes a quantity
QUANTITY_OPTIONS = [
    *[(command, option, [*command.split(), "--out", "{out}"] if command != "equivalent" else ["equivalent"])
      for command in ("compress", "equivalent", "shear", "pipe") for option in ("--radius", "--youngs-modulus")],
    ("shear", "--viscosity", ["shear", "--out", "{out}", "--shear-rate", "100/s", "--youngs-modulus", "1kPa"]),
    ("shear", "--shear-rate", ["shear", "--out", "{out}", "--viscosity", "1mPa*s", "--youngs-modulus", "1kPa"]),
    ("pipe", "--pressure-gradient", ["pipe", "--out", "{out}", "--radius", "8um", "--youngs-modulus", "1kPa"]),
    ("fit afm", "--radius", ["fit", "afm", "{out}/curve.csv", "--out", "{out}/fits"]),
    ("fit afm", "--contact-point", ["fit", "afm", "{out}/curve.csv", "--radius", "8um", "--out", "{out}/fits"]),
    *[("fit afm", option, ["fit", "afm", "{out}/curve.csv", "--radius", "8um", "--out", "{out}/fits"])
      for option in ("--spring-constant", "--sensitivity")],
    *[("fit shear", option, ["fit", "shear", "--out", "{out}", "--deformation", "0.1", "--shear-stress", "12Pa",
                             "--shear-rate", "1000/s", "--tank-treading-frequency", "400rad/s"])
      for option in ("--shear-stress", "--shear-stress-error", "--tank-treading-frequency",
                     "--tank-treading-frequency-error", "--shear-rate", "--radius")],
    *[("lut", option, [*LUT, "--out", "{out}/lut.txt"])
      for option in ("--channel-radius", "--flow-rate", "--viscosity", "--radii", "--moduli")],
    *[("fit afm", option, ["fit", "afm", "{out}/curve.csv", "--radius", "8um", "--geometry", "sphere-indenter",
                           "--indenter-radius", "5um", "--out", "{out}/fits"])
      for option in ("--indenter-radius", "--cap-height", "--layer-thickness")],
    *[("indent", option, ["indent", "--out", "{out}", "--indenter-radius", "0.5"])
      for option in ("--indenter-radius", "--radius", "--youngs-modulus", "--cap-height", "--layer-thickness")],
    *[("pipe", option, ["pipe", "--out", "{out}", "--radius", "8um", "--youngs-modulus", "1kPa"])
      for option in ("--channel-width", "--channel-height")],
    *[("lut", option, ["lut", "--flow-rate", "0.04uL/s", "--viscosity", "15mPa*s", "--quick", "--out",
                       "{out}/lut.txt", *(["--channel-width", "20um"] if option == "--channel-height" else [])])
      for option in ("--channel-width", "--channel-height")],
    *[(command, "--half-angle", arguments) for command, arguments in (
        ("indent", ["indent", "--out", "{out}", "--indenter", "cone", "--cell-shape", "layer", "--layer-thickness",
                    "10um", "--nucleus", "none"]),
        ("fit afm", ["fit", "afm", "{out}/curve.csv", "--geometry", "cone", "--cell-shape", "layer",
                     "--layer-thickness", "5um", "--out", "{out}/fits"]))],
    *[(command, option, arguments) for option in ("--temperature", "--channel-length") for command, arguments in (
        ("pipe", ["pipe", "--out", "{out}", "--radius", "8um", "--youngs-modulus", "1kPa", "--medium",
                  "0.59%MC-PBS"]),
        ("lut", [*LUT[:5], "--medium", "0.59%MC-PBS", "--quick", "--out", "{out}/lut.txt"]))],
    ("fit rtdc", "--temperature", ["fit", "rtdc", "{out}/m.rtdc", "--out", "{out}/fits"]),
]


def test_the_hostile_cases_cover_every_quantity_option():
    declared = {(path, param.opts[0]) for path, command in _commands() for param in command.params
                if OPTIONS[param.name].quantity is not None}
    assert {(command, option) for command, option, _ in QUANTITY_OPTIONS} == declared


@pytest.fixture()
def parse_timer(monkeypatch):
    """Every parse_quantity call of the command line (the options' own check and the LUT's lists), timed
    in-process; pint's one-time import and registry are loaded first (not parse time)."""
    parse_quantity("8um", "m", "radius")
    times = []

    def timed(*args, **kwargs):
        start = time.perf_counter()
        try:
            return parse_quantity(*args, **kwargs)
        finally:
            times.append(time.perf_counter() - start)

    monkeypatch.setattr(options, "parse_quantity", timed)
    monkeypatch.setattr(lut_module, "parse_quantity", timed)
    return times


@pytest.mark.parametrize("command, option, arguments", QUANTITY_OPTIONS, ids=[f"{c} {o}" for c, o, _ in QUANTITY_OPTIONS])
@pytest.mark.parametrize("text", HOSTILE, ids=lambda t: repr(t)[:20])
def test_a_hostile_quantity_is_one_line_exit_2_naming_the_option(tmp_path, parse_timer, command, option, arguments,
                                                                  text):
    if text == "wrong dimension":  # 1kPa where a length is expected, 8um anywhere else
        length = option in ("--radius", "--contact-point", "--channel-radius", "--channel-width", "--radii",
                            "--indenter-radius", "--cap-height", "--layer-thickness", "--channel-height",
                            "--channel-length")
        text = "1kPa" if length else "8um"
    out = tmp_path / "x"
    result = runner.invoke(app, [a.replace("{out}", str(out)) for a in arguments] + [option, text])
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.strip().splitlines() if line]
    assert len(lines) == 1 and lines[0].startswith(f"elastocell: error: {option}: expected "), result.output
    assert parse_timer and max(parse_timer) < 1.0
    assert not out.exists() or not any(out.iterdir())  # refused before any work


# ---------------------------------------------------------------- one rule for bare numbers


def test_a_bare_viscosity_is_in_mpa_s_in_shear_and_lut(monkeypatch, tmp_path):
    """shear --viscosity 15 is 15 mPa*s (Ca = 2 (1 + nu) eta gdot / E_c = 2 x 1.48 x 0.015 x 1000 / 300 = 0.148),
    the same as 15mPa*s, and as lut --viscosity 15."""
    import elastocell.api.shear as shear_api

    seen = []
    monkeypatch.setattr(shear_api, "shear", lambda out, ca, **kwargs: seen.append(ca) or {})
    for viscosity in ("15", "15mPa*s"):
        result = runner.invoke(app, ["shear", "--out", str(tmp_path / viscosity), "--viscosity", viscosity,
                                     "--shear-rate", "1000", "--youngs-modulus", "300Pa", "--quiet"])
        assert result.exit_code == 0, result.output
    assert seen == [pytest.approx(0.148, rel=1e-12)] * 2

    settings = []
    monkeypatch.setattr(lut_module, "compute_lut", lambda out, *args, **kwargs: settings.append(
        lut_module.plan(*args, radii=kwargs["radii"], moduli=kwargs["moduli"], quick=True,
                        channel_width=kwargs["channel_width"])[1]) or {"records": []})
    for viscosity in ("15", "15mPa*s"):
        runner.invoke(app, ["lut", "--channel-radius", "10", "--flow-rate", "0.04", "--viscosity", viscosity,
                            "--out", str(tmp_path / "lut.txt"), "--radii", "5", "--moduli", "1000", "--quiet"])
    assert len(settings) == 2 and settings[0] == settings[1]
    assert settings[0]["viscosity_mpa_s"] == pytest.approx(15, rel=1e-12)
    assert settings[0]["channel_radius_um"] == pytest.approx(10, rel=1e-12)


def test_a_bare_radius_is_in_um_in_fit_shear(tmp_path):
    """fit shear --radius 8 records 8 um (8e-6 m) like --radius 8um."""
    radii = []
    for radius in ("8", "8um"):
        out = tmp_path / radius
        result = runner.invoke(app, ["fit", "shear", "--deformation", "0.1", "--shear-stress", "12",
                                     "--radius", radius, "--out", str(out), "--quiet"])
        assert result.exit_code == 0, result.output
        radii.append(np.genfromtxt(out / "shear_fits.csv", delimiter=",", names=True)["radius"])
    assert radii[0] == radii[1] == pytest.approx(8e-6, rel=1e-12)


def test_the_console_prints_a_warning_as_one_line_and_gives_pythons_format_back(capsys):
    """``main`` formats warnings as one ``warning:`` line without the source location while a command runs, and
    restores Python's format for an in-process caller afterwards."""
    import warnings

    from elastocell.cli.app import _console_warning_format, main

    before = warnings.formatwarning
    console_warning = _console_warning_format()
    assert console_warning("K and n\n  are extrapolated", UserWarning, "/x/y.py", 3) == \
        "warning: K and n are extrapolated\n"
    # the same text again (a check repeated for each resolution of a run) is said once; another text is said
    assert console_warning("K and n are extrapolated", UserWarning, "/x/z.py", 4) == ""
    assert console_warning("run longer", UserWarning, "/x/y.py", 3) == "warning: run longer\n"
    with pytest.raises(SystemExit):
        main(["--version"])
    assert warnings.formatwarning is before
