"""``report.md`` and ``report.html``: every claim of the paper beside what elastocell measured, with a verdict."""

from __future__ import annotations

import html
import json
from collections import Counter
from pathlib import Path

from elastocell.studies.base import read_study_table
from elastocell.studies.registry import STUDIES, load_claims

VERDICT_MARK = {"agree": "agree", "partly": "partly", "disagree": "DISAGREE", "not measured": "not measured"}


def _studies_present(directory: Path) -> list[tuple[str, dict]]:

    present = []
    for name in STUDIES:
        if (directory / f"{name}.parquet").exists():
            _, metadata = read_study_table(directory, name)
            present.append((name, metadata))
    return present


def write_report(directory) -> Path:
    """Write ``directory/report.md`` and ``report.html`` from the tables and claims found there."""

    directory = Path(directory)
    studies = _studies_present(directory)
    claims = load_claims(directory)
    mode = json.loads((directory / "study_mode.json").read_text())["mode"] if (directory / "study_mode.json").exists() \
        else "unknown"
    counts = Counter(c.verdict for c in claims)
    lines = [
        "# elastocell: the paper's claims beside what was measured",
        "",
        "Paper: Wohlrab, Müller & Gekle, *Mechanical complexity of living cells can be mapped onto simple "
        "homogeneous equivalents*.",
        "",
        f"Mode: **{mode}**" + (" (coarse meshes and lattices: a first look; numbers carry their discretisation "
                               "error — run without `--quick` for the converged defaults)" if mode == "quick" else ""),
        "",
        "Verdicts: " + ", ".join(f"{counts.get(v, 0)} {v}" for v in ("agree", "partly", "disagree", "not measured")),
        "",
        "| study | claim (paper) | where | measured | verdict | other discretisations | criterion |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in claims:
        measured = (f"[{c.discretisation}] " if c.discretisation else "") + c.measured
        others = "; ".join(f"{name}: {o['verdict']} ({o['measured']})" for name, o in c.other_discretisations.items())
        lines.append("| " + " | ".join(_cell(x) for x in (c.study, c.claim, c.source, measured,
                                                            f"**{VERDICT_MARK.get(c.verdict, c.verdict)}**",
                                                            others or "-", c.criterion)) + " |")
    moved = _discretisation_lines(directory)
    if moved:
        lines += ["", "## Discretisation: how far other elements move the curves", "",
                  "F/F_primary - 1 of each cell at delta 0.1 / 0.3 / 0.5 / 0.7 (primary = the converged default; "
                  "p1 = linear tetrahedra, the paper's element, on the default p1 mesh).", ""] + moved
    lines += ["", "## Studies", ""]
    for name, metadata in studies:
        study = STUDIES[name]
        failed = metadata.get("failed_runs") or []
        lines += [f"### {name} ({study.figure})", "", study.description, "",
                  f"![{name}]({name}.png) — table `{name}.parquet` / `{name}.csv`, {metadata.get('runs', 0)} runs"
                  + (f", **{len(failed)} failed**: {', '.join(failed)}" if failed else "")
                  + f", created {metadata.get('created', '?')}, elastocell {metadata.get('elastocell_version', '?')}.",
                  ""]
    lines += ["Reproduce: `elastocell reproduce" + (" --quick" if mode == "quick" else "") + " --out DIR`; one study: "
              "`elastocell study run NAME --out DIR`; redraw: `elastocell study plot NAME DIR`.", ""]
    text = "\n".join(lines)
    (directory / "report.md").write_text(text)
    (directory / "report.html").write_text(_html(claims, studies, mode, counts))
    return directory / "report.md"


def _discretisation_lines(directory: Path) -> list[str]:

    lines = []
    for name in STUDIES:
        path = directory / f"{name}.claims.json"
        if not path.exists():
            continue
        for other, cells in (json.loads(path.read_text()).get("discretisation") or {}).items():
            for cell, values in cells.items():
                text = " / ".join(f"{100 * v:+.1f} %" for v in values.values())
                lines.append(f"- {name}, {cell}, {other}: {text} (delta {', '.join(values)})")
    return lines


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _html(claims, studies, mode: str, counts: Counter) -> str:
    colours = {"agree": "#d9f2d9", "partly": "#fff3cd", "disagree": "#f8d7da", "not measured": "#eeeeee"}
    rows = "\n".join(
        f"<tr style='background:{colours.get(c.verdict, '#fff')}'>" + "".join(
            f"<td>{html.escape(str(x))}</td>" for x in (
                c.study, c.claim, c.source, (f"[{c.discretisation}] " if c.discretisation else "") + c.measured,
                c.verdict, "; ".join(f"{n}: {o['verdict']}" for n, o in c.other_discretisations.items()) or "-",
                c.criterion))
        + "</tr>" for c in claims)
    figures = "\n".join(f"<h3>{html.escape(name)}</h3><img src='{html.escape(name)}.png' style='max-width:100%'>"
                        for name, _ in studies)
    summary = ", ".join(f"{counts.get(v, 0)} {v}" for v in ("agree", "partly", "disagree", "not measured"))
    return f"""<!doctype html>
<html><head><meta charset="utf-8"><title>elastocell report</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:auto}} td,th{{border:1px solid #999;padding:4px;
vertical-align:top;font-size:13px}} table{{border-collapse:collapse}}</style></head><body>
<h1>elastocell: the paper's claims beside what was measured</h1>
<p>Mode: <b>{html.escape(mode)}</b>. Verdicts: {html.escape(summary)}.</p>
<table><tr><th>study</th><th>claim (paper)</th><th>where</th><th>measured</th><th>verdict</th><th>other discretisations</th><th>criterion</th></tr>
{rows}
</table>
<h2>Figures</h2>
{figures}
</body></html>
"""
