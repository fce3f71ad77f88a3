"""The validation pages: every script in ``validation/`` prints its tables and writes them into its section of a
page under ``docs/validation/``, with a footer the script writes itself: the exact command, the machine (CPU,
cores, memory and the memory bandwidth measured in the same run), the software versions, the date and the wall
time. ``docs/validation/index.md`` is rewritten at the same time from what the pages hold.

A script uses it as::

    page = Page("shear", "shear.py", intro="What is measured, against which independent reference.")
    page.print("a line of the printed output")        # printed, and kept as preformatted text
    page.table(rows, "homogeneous cell")               # printed with | separators, kept as a Markdown table
    page.write()                                       # the section, its footer, and the index

A page holds one section per script (``PAGES``); each script replaces only its own section, between the
``<!-- section NAME -->`` and ``<!-- end NAME -->`` markers, so that a page whose scripts ran at different times
keeps every section with its own footer. ``python validation/page.py`` writes the pages and the index without
running anything: sections not generated yet name their command and say so.
"""

from __future__ import annotations

import json
import os
import platform
import re
import shlex
import sys
import time
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "validation"

# page -> (title, {script: (section heading, command that regenerates the section)})
PAGES: dict[str, tuple[str, dict[str, tuple[str, str]]]] = {
    "compression": ("Compression between plates", {
        "compression.py": ("Mesh convergence, and FElupe on the same problem",
                           "python validation/compression.py --meshes p1:0.2:0.05 p2:0.5:0.12 p2:0.35:0.08 "
                           "p2:0.2:0.05"),
        "felupe_peer.py": ("FElupe alone against Hertz", "python validation/felupe_peer.py --meshes 0.5:0.15,0.35:0.1"),
        "force_ratios.py": ("Nucleus cell over its homogeneous equivalent",
                            "python validation/force_ratios.py --element p2 --stiffness-ratio 2 10"),
        "compression_reach.py": ("Reach of a full curve for every cell", "python validation/compression_reach.py"),
    }),
    "axisymmetric": ("Axisymmetric solver as the truth for compression", {
        "axisymmetric.py": ("Its refinement",
                             "nice python validation/axisymmetric.py"),
        "felupe_axisymmetric.py": ("FElupe's axisymmetric mode beside it: error and time per curve",
                                   "nice python validation/felupe_axisymmetric.py"),
        "stiff_3d.py": ("The stiff nucleus in 3D: error budget and the polar layer",
                        "nice python validation/stiff_3d.py"),
        "stiff_volumetric.py": ("The stiff nucleus in 3D: the crushed layer's volumetric treatment",
                                "nice python validation/stiff_volumetric.py"),
        "stiff_mesh.py": ("The stiff nucleus in 3D: its refined mesh, the defaults and the size series against the truth",
                          "nice python validation/stiff_mesh.py"),
        "stiff_cost.py": ("The cost of a curve on the defaults, by stiffness ratio",
                          "nice python validation/stiff_cost.py"),
    }),
    "indentation": ("A bead indenting a cell on a dish", {
        "indentation.py": ("Hertz limits and mesh refinement", "nice python validation/indentation.py"),
        "indentation_layer.py": ("The bonded layer: width, refinement, closed forms and its master surface",
                                 "nice python validation/indentation_layer.py"),
        "indentation_3d.py": ("The 3D solver: against the axisymmetric one, Hertz, and cells only it can run",
                              "nice python validation/indentation_3d.py"),
        "indentation_cap.py": ("The adherent cap: refinement, Hertz, interpolation and round trip of its master "
                               "surface", "nice python validation/indentation_cap.py"),
    }),
    "indentation_cone": ("A cone or pyramid indenting a cell on a dish", {
        "indentation_cone.py": ("Sneddon's cone, refinement, the rounded apex and nanite's cone model",
                                "nice python validation/indentation_cone.py"),
    }),
    "startup": ("Start-up of a command in a new process", {
        "startup.py": ("Import, cell and first converged row, empty and warm caches",
                       "python validation/startup.py --code-path /tmp/baseline/src"),
    }),
    "lattice": ("Lattice Boltzmann throughput", {
        "lattice.py": ("D3Q19 kernel against the memory roofline, and lbmpy", "python validation/lattice.py"),
    }),
    "shear": ("Cell in shear flow", {
        "shear.py": ("Small-deformation theory, resolution, and the cost of a coupled step",
                     "python validation/shear.py --only split homogeneous resolution --resolution 6 "
                     "--resolutions 4 6 8 --duration 4"),
    }),
    "shear_targets": ("Shear targets against Roscoe's theory", {
        "shear_targets.py": ("Deformation, inclination and tank treading at Ca 0.05-0.3, viscosity ratio 1",
                             "nice python validation/shear_targets.py --run --threads 1 --page"),
    }),
    "flow_accuracy": ("Accuracy of the immersed-boundary flow", {
        "flow_accuracy.py": ("Held sphere (torque, stresslet, drag) and the cell against closed forms",
                             "python validation/flow_accuracy.py --page"),
        "flow_volumetric.py": ("The cell's Poisson ratio in shear flow: the discrete body's volumetric stiffness",
                               "nice python validation/flow_volumetric.py"),
    }),
    "flow_default": ("Cost of the flow defaults", {
        "flow_default_cost.py": ("elastocell shear at its defaults (R/dx 8 and 6, extrapolated) against one R/dx 8 run",
                                 "nice python validation/flow_default_cost.py --page"),
        "pipe_default_cost.py": ("elastocell pipe at its default in a cylinder (R/dx 8 and 6 extrapolated, six "
                                 "side views) against the single R/dx 8 run and the default issue 24 started from", "nice python validation/pipe_default_cost.py --page"),
    }),
    "pipe": ("Cell in pipe flow", {
        "pipe.py": ("Poiseuille flow, the centred cell, and the cost of a coupled step",
                    "python validation/pipe.py"),
        "pipe_shape.py": ("Where the cell takes the bullet shape",
                          "python validation/pipe_shape.py --ratios 2 4 --cell-capillary 0.5"),
    }),
    "medium": ("Shear-thinning medium and rectangular channels", {
        "medium.py": ("Power-law slab, rectangular duct and the cost of the power-law collision",
                      "python validation/medium.py --baseline-kernels /tmp/kernels_before.py"),
    }),
    "pipe_dclab": ("Pipe flow against dclab's LE-2D-FEM-19", {
        "pipe_references.py": ("The reference's own uncertainty: LE-2D-FEM-19 against the analytical LE-2D-ana-18",
                               "python validation/pipe_references.py"),
        "pipe_dclab.py": ("RT-DC deformation and area, one resolution and extrapolated",
                          "nice python validation/pipe_dclab.py"),
        "pipe_contour.py": ("Error sources: the measured outline and the staircase wall",
                            "nice python validation/pipe_contour.py"),
        "pipe_sphere.py": ("Error sources: a rigid sphere's hydrodynamic radius in the pipe",
                           "nice python validation/pipe_sphere.py --page"),
        "pipe_resolution.py": ("The cell under refinement and across meshes, with and without the radius correction",
                               "nice python validation/pipe_resolution.py"),
        "pipe_flow_rate.py": ("The flow rate held, as RT-DC's pump, against the pressure gradient held",
                              "nice python validation/pipe_flow_rate.py"),
        "pipe_stationary.py": ("The stationary shape at R/dx 8 with the flow rate held and the markers moved in "
                               "(the pipe's default), and the cell's Poisson ratio",
                               "nice python validation/pipe_stationary.py --poisson-ratios 0.48 0.49 --extra "
                               "6:3:0.3:8,6:3:0.4:8,6:3:0.45:8,6:3:0.495:8,6:3:0.48:10,6:3:0.49:10,6:3:0.48:8:p2,"
                               "6:3:0.49:8:p2"),
        "pipe_wall.py": ("The cylinder's wall: the staircase against interpolated bounce-back, empty and with the cell",
                         "nice python validation/pipe_wall.py --out /work/results/pipe-stationary"),
        "pipe_orientation.py": ("The cell's mesh turned: how much one orientation decides in a pipe",
                                "nice python validation/pipe_orientation.py --out /work/results/pipe-orientation"),
        "pipe_target.py": ("Issue 24's pipe target at the defaults (the pair and six views in a cylinder), run to t = "
                           "40/gdot_w (nearly stationary)", "nice python validation/pipe_target.py --out /work/results/pipe-target "
                           "--page"),
        "pipe_order.py": ("Does the pair converge as it assumes: R/dx 6, 8 and 10 at the cells where it meets the "
                          "target", "nice python validation/pipe_order.py --out /work/exp/pipe-order --page"),
        "pipe_outline_degree.py": ("Bullet shapes: why the (8, 6) pair is not trusted there, and the (10, 8) "
                                   "pair against the table; the outline read with other fit degrees and as the "
                                   "hull, at R/dx 6, 8, 10",
                                   "nice python validation/pipe_outline_degree.py --points 6:2,6.5:2.5 "
                                   "--resolutions 6 8 10 --out results/pipe-outline-degree --page"),
    }),
    "lut": ("RT-DC look-up table against dclab", {
        "lut_dclab.py": ("elastocell's points against dclab's LE-2D-FEM-19",
                         "python validation/lut_dclab.py --radii 6 --moduli 2,5 --duration 8 --workers 2 "
                         "--out /tmp/lut-dclab"),
    }),
    "lut_square": ("RT-DC look-up table in the square channel with MC-PBS, against dclab", {
        "lut_square.py": ("Square-channel MC-PBS points against dclab's HE-3D-FEM-22 and HE-2D-FEM-22",
                          "nice python validation/lut_square.py --radii 4,5,6,7 --moduli 1,1.5,2,3 --duration 20 "
                          "--workers 2 "
                          "--out /work/results/lut-square-r8"),
        "lut_cylinder.py": ("Cylinder MC-PBS points against dclab's HE-2D-FEM-22",
                            "nice python validation/lut_cylinder.py --radii 5,6 --moduli 2 --duration 20 "
                            "--workers 2 "
                            "--out /work/results/lut-cylinder-r8"),
        "lut_cylinder.py:interpolated": (
            "Cylinder MC-PBS points against dclab's HE-2D-FEM-22, the wall interpolated",
            "nice python validation/lut_cylinder.py --radii 5,6 --moduli 2 --duration 20 --workers 2 --channel-wall "
            "interpolated --out /work/results/lut-cylinder-r8-interp"),
        "lut_square_views.py": ("Square-channel points read from side views and extrapolated from R/dx 6 and 8",
                                "nice python validation/lut_square_views.py --workers 2 --views 2"),
        "lut_standard.py": ("The standard table's finished points against dclab's HE-3D-FEM-22",
                            "python validation/lut_standard.py compare --page"),
        "lut_relaxation.py": ("How long a point must run: the cell's relaxation in the channel",
                              "nice python validation/lut_relaxation.py --runs /work/results/lut-square-r8/lut_runs/R* "
                              "/work/results/lut-square-long/lut_runs/R5um_E1kPa_6766fc3991 "
                              "/work/results/pipe-stationary/*-p1-default-Rdx8-c0.3-t40-Q --cuts 10 15 20 30 40"),
        "lut_relaxation.py:standard": (
            "How long a point must run: the standard table's first points (a duct rounded to whole nodes, cap 60)",
            "nice python validation/lut_relaxation.py --section standard --runs /work/exp/rounded-duct-runs/R* "
            "--cuts 20 30 40 60"),
    }),
    "rtdc_nucleus": ("The modulus RT-DC assigns a cell with a stiff nucleus", {
        "rtdc_nucleus.py": ("Nucleus cells and the random cell read through homogeneous tables",
                            "nice python validation/rtdc_nucleus.py --dir /work/results/rtdc-nucleus-interp"),
    }),
    "rtdc": ("Real RT-DC measurements through look-up tables", {
        "rtdc_coverage.py": ("Coverage and moduli of dclab's test measurements, dclab's tables and elastocell's",
                             "python validation/rtdc_coverage.py --shipped"),
        "lut_grid.py": ("The default grid of elastocell lut and the events it covers", "python validation/lut_grid.py"),
    }),
    "fit": ("Fits of AFM curves and master curves", {
        "fit.py": ("Accuracy, Hertz's bias, interval coverage and cost of the AFM fit",
                   "python validation/fit.py --curves 200 --coverage 50"),
        "mastercurves.py": ("The shipped master curves", "python validation/mastercurves.py"),
        "afm_adhesion.py": ("The adhesion check: E's bias under an adhesion dip, and the curves flagged",
                            "python validation/afm_adhesion.py"),
    }),
    "afm": ("AFM fits of real instrument files against nanite", {
        "afm_nanite.py": ("elastocell's Hertz-sphere estimate beside nanite's fit, same curves, same contact point",
                          "python validation/afm_nanite.py"),
        "nucleated_fit.py": ("A cell with a nucleus: E_c from its own curve against the conversions",
                             "nice python validation/nucleated_fit.py"),
    }),
    "studies": ("Studies: their cost on Dask and their claims", {
        "studies.py": ("Wall time of the studies", "python validation/studies.py --run --workers 2"),
        "dask_scaling.py": ("Speed-up of a sweep through Dask", "python validation/dask_scaling.py --duration 10"),
        "claims.py": ("The paper's compression claims on the converged defaults",
                      "nice python validation/claims.py --dir paper"),
    }),
}

NOT_GENERATED = "not generated on this machine yet"
_SECTION = re.compile(r"<!-- section (?P<name>\S+) -->\n(?P<body>.*?)<!-- end (?P=name) -->\n", re.S)
_RUN = re.compile(r"<!-- run (?P<json>\{.*?\}) -->")


def page_of(script: str) -> str:
    for name, (_, scripts) in PAGES.items():
        if script in scripts:
            return name
    raise KeyError(f"{script} belongs to no page of validation/page.py's PAGES")


def command_line(argv: list[str] | None = None) -> str:
    """``python <script relative to the repository> <arguments>``, quoted as a shell would need it."""
    argv = list(sys.argv if argv is None else argv)
    script = Path(argv[0]).resolve()
    try:
        argv[0] = str(script.relative_to(ROOT))
    except ValueError:
        pass
    return "python " + shlex.join(argv)


def machine(bandwidth: float | None = None) -> dict:
    """CPU model, cores (and those this process may use), memory, and the STREAM-triad bandwidth (GB/s)."""
    model = platform.processor() or platform.machine()
    memory = None
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                memory = int(line.split()[1]) * 1024
                break
    except OSError:
        pass
    available = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {"cpu": model, "cores": os.cpu_count(), "cores_available": available, "memory_bytes": memory,
            "bandwidth_gb_s": bandwidth}


def versions(extra: tuple[str, ...] = ()) -> dict:
    """``elastocell.files.software_versions()`` and the installed version of each distribution in ``extra``
    (peers, dclab, dask); "not installed" where it is not."""
    from elastocell.files import software_versions

    found = software_versions()
    for name in extra:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "not installed"
    return found


def _cell(value, spec: str | None) -> str:
    if value is None:
        return ""
    if spec is not None and isinstance(value, (int, float)) and not isinstance(value, bool):
        return format(value, spec)
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def markdown_table(rows: list[dict], columns: list[str] | None = None, formats: dict | None = None) -> str:
    columns = columns or list(rows[0])
    formats = formats or {}
    lines = ["| " + " | ".join(str(c).replace("|", "\\|") for c in columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        lines.append("| " + " | ".join(_cell(row.get(c), formats.get(c)).replace("|", "\\|") for c in columns) + " |")
    return "\n".join(lines)


class Page:
    """One script's section of a validation page: what it prints, kept for the page, and the footer."""

    def __init__(self, page: str | None = None, script: str | None = None, intro: str = "",
                 versions: tuple[str, ...] = ()):
        self.start = time.perf_counter()
        self.date = datetime.now(timezone.utc)
        self.load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
        self.script = script or Path(sys.argv[0]).name
        self.page = page or page_of(self.script)
        self.intro = intro
        self.extra_versions = versions
        self.blocks: list[tuple[str, object]] = []  # ("text", [lines]) | ("markdown", str) | ("heading", str)

    def print(self, *parts, end: str = "\n") -> None:
        """``print`` that also keeps the text for the page (preformatted, as printed)."""
        text = " ".join(str(p) for p in parts) + end
        print(text, end="", flush=True)
        if self.blocks and self.blocks[-1][0] == "text":
            self.blocks[-1][1].append(text)
        else:
            self.blocks.append(("text", [text]))

    def heading(self, text: str) -> None:
        print(f"\n{text}", flush=True)
        self.blocks.append(("heading", text))

    def table(self, rows: list[dict], heading: str | None = None, columns: list[str] | None = None,
              formats: dict | None = None, echo: bool = True) -> None:
        """Print ``rows`` (dicts) with ``|`` separators (unless ``echo`` is false: the script printed them its
        own way) and keep them as a Markdown table under ``heading``; columns named ``_...`` are left out."""
        if heading and echo:
            self.heading(heading)
        elif heading:
            self.blocks.append(("heading", heading))
        if not rows:
            return
        columns = columns or [c for c in rows[0] if not str(c).startswith("_")]
        formats = formats or {}
        if echo:
            print(" | ".join(columns))
            for row in rows:
                print(" | ".join(_cell(row.get(c), formats.get(c)) for c in columns))
            sys.stdout.flush()
        self.blocks.append(("markdown", markdown_table(rows, columns, formats)))

    def _body(self) -> str:
        parts = []
        for kind, content in self.blocks:
            if kind == "heading":
                parts.append(f"**{content.strip().rstrip(':')}**")
            elif kind == "markdown":
                parts.append(content.strip("\n"))
            else:
                text = "".join(content).strip("\n")
                if text.strip():
                    parts.append("```text\n" + text + "\n```")
        return "\n\n".join(parts)

    def write(self) -> Path:
        """Write this section (and the footer) into its page, and rewrite the index; returns the page's path."""
        wall = time.perf_counter() - self.start
        from elastocell.simulation.throughput import TRIAD_ELEMENTS, stream_triad_bandwidth

        bandwidth = stream_triad_bandwidth()  # cached if the script measured it already
        host = machine(bandwidth)
        software = versions(self.extra_versions)
        command = command_line()
        record = {"command": command, "wall_s": round(wall, 1), "date": self.date.strftime("%Y-%m-%d %H:%M UTC")}
        memory = f"{host['memory_bytes'] / 2**30:.1f} GiB memory" if host["memory_bytes"] else "memory unknown"
        cores = f"{host['cores']} cores" + (f" ({host['cores_available']} available to the run)"
                                            if host["cores_available"] != host["cores"] else "")
        load = (f"; load average (1 min) {self.load:.2f} at the start, {os.getloadavg()[0]:.2f} at the end"
                if self.load is not None else "")
        footer = "\n".join([
            f"- Generated by `{command}` on {record['date']}, wall time {wall:.0f} s.",
            f"- Machine: {host['cpu']}, {cores}, {memory}; memory bandwidth {bandwidth:.1f} GB/s (STREAM triad, "
            f"3 x {TRIAD_ELEMENTS * 8 // 2**20} MiB, measured in this run){load}.",
            "- Software: " + ", ".join(f"{k} {v}" for k, v in software.items()) + ".",
        ])
        heading = PAGES[self.page][1].get(self.script, (self.script, ""))[0]
        section = (f"## {heading}\n\n<!-- run {json.dumps(record)} -->\n\n"
                   + (self.intro.strip() + "\n\n" if self.intro else "")
                   + self._body() + "\n\n" + footer + "\n")
        path = write_section(self.page, self.script, section)
        write_index()
        print(f"\nwrote {path.relative_to(ROOT)} and {(DOCS / 'index.md').relative_to(ROOT)}", flush=True)
        return path


def _placeholder(page: str, script: str) -> str:
    heading, command = PAGES[page][1][script]
    return (f"## {heading}\n\n*{NOT_GENERATED.capitalize()}.* `validation/{script}` writes this section; "
            f"for example:\n\n    {command}\n")


def read_sections(page: str) -> dict[str, str]:
    path = DOCS / f"{page}.md"
    text = path.read_text() if path.exists() else ""
    return {m["name"]: m["body"] for m in _SECTION.finditer(text)}


def write_section(page: str, script: str | None = None, section: str | None = None) -> Path:
    """Rewrite ``docs/validation/<page>.md`` with ``section`` as the section of ``script`` (the others kept;
    those never generated as placeholders)."""
    from elastocell.files import replace_atomically

    title, scripts = PAGES[page]
    sections = read_sections(page)
    if script is not None:
        sections[script] = section
    names = list(scripts) + [name for name in sections if name not in scripts]
    text = f"# {title}\n\n" + "\n".join(
        f"<!-- section {name} -->\n{sections.get(name) or _placeholder(page, name)}<!-- end {name} -->\n"
        for name in names)
    DOCS.mkdir(parents=True, exist_ok=True)
    path = DOCS / f"{page}.md"
    replace_atomically(path, lambda temporary: temporary.write_text(text))
    return path


def write_index() -> Path:
    """``docs/validation/index.md``: every page and section, the command that regenerates it (the one recorded
    on the page where it was generated) and its wall time on this machine."""
    from elastocell.files import replace_atomically

    lines = ["# Validation", "",
             "Each page compares elastocell against an independent reference (a closed form, a peer code, dclab's "
             "table) or measures its cost, and each section is written by the script in `validation/` named "
             "beside it, with the command, the machine, the software and the wall time in its footer. A command "
             "with fewer or smaller cases than the script's defaults is a reduced run; its section says so by "
             "its command. Run the scripts one at a time: the timings are of the whole machine.", "",
             "| page | section | command | wall time on this machine |", "|---|---|---|---|"]
    for page, (title, scripts) in PAGES.items():
        sections = read_sections(page)
        for script, (heading, command) in scripts.items():
            run = _RUN.search(sections.get(script, ""))
            if run:
                record = json.loads(run["json"])
                command, when = record["command"], f"{record['wall_s']:.0f} s ({record['date'][:10]})"
            else:
                when = NOT_GENERATED
            lines.append(f"| [{title}]({page}.md) | {heading} | `{command}` | {when} |")
    path = DOCS / "index.md"
    DOCS.mkdir(parents=True, exist_ok=True)
    replace_atomically(path, lambda temporary: temporary.write_text("\n".join(lines) + "\n"))
    return path


def main() -> None:
    """Write every page (keeping the generated sections, placeholders for the others) and the index."""
    for page in PAGES:
        write_section(page)
    write_index()
    print(f"wrote {len(PAGES)} pages and the index under {DOCS.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
