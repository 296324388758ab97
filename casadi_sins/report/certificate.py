"""The calibration certificate: one self-contained HTML file to file with the unit, printable on A4.

It carries what a production line signs: the unit id, the recording's SHA-256, the date and the
recording's conditions, the parameter table rounded to its sigma (:func:`report.rounding.parameter_display`),
the checks, the warnings, the verdict against the tolerance sheet (when one was given) and the
software versions.  The plots are inline PNG ``data:`` URIs; the file references nothing outside
itself (no link, script, style sheet or font to fetch), so that it reads the same offline and in
ten years.
"""

from __future__ import annotations

import base64
import html
import math

import pandas as pd

from ..core.text import plural
from .rounding import parameter_display
from .tables import checks_frame

#: A4 portrait, the table on as few pages as it fits; colours that survive a black-and-white printer.
STYLE = """
@page { size: A4 portrait; margin: 14mm 12mm; }
body { font-family: "DejaVu Sans", Arial, Helvetica, sans-serif; font-size: 9.5pt; color: #000; max-width: 186mm;
       margin: 0 auto; }
h1 { font-size: 15pt; margin: 0 0 2mm 0; } h2 { font-size: 11.5pt; margin: 5mm 0 1.5mm 0; }
table { border-collapse: collapse; width: 100%; page-break-inside: auto; }
tr { page-break-inside: avoid; }
th, td { border: 0.3mm solid #777; padding: 0.6mm 1.5mm; text-align: left; vertical-align: top; }
td.n { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
.verdict { font-size: 14pt; font-weight: bold; padding: 2mm 3mm; border: 0.8mm solid #000; display: inline-block; }
.pass { background: #d9f2d9; } .fail { background: #f7d4d4; }
.fail-row td { font-weight: bold; background: #fbe9e9; }
img { width: 100%; page-break-inside: avoid; }
.hash { font-family: "DejaVu Sans Mono", monospace; font-size: 8pt; word-break: break-all; }
.small { font-size: 8pt; color: #333; }
""".strip()

#: Column headings of the parameter table.
HEADINGS = {"value_natural": "value", "value_unit": "unit", "sigma_natural": "1-sigma", "sigma_unit": "sigma unit",
            "error_natural": "error", "error_over_sigma": "error/sigma"}


def _e(value) -> str:
    return html.escape("" if value is None else str(value))


def _rows(pairs) -> str:
    return "".join(f"<tr><th>{_e(k)}</th><td>{v}</td></tr>" for k, v in pairs)


def _frame_html(frame: pd.DataFrame, numeric: set[str], marks: dict[int, str] | None = None) -> str:
    head = "".join(f"<th>{_e(c)}</th>" for c in frame.columns)
    body = []
    for i, row in enumerate(frame.itertuples(index=False)):
        cls = f' class="{marks[i]}"' if marks and i in marks else ""
        cells = "".join(f'<td class="n">{_e(v)}</td>' if c in numeric else f"<td>{_e(v)}</td>"
                        for c, v in zip(frame.columns, row))
        body.append(f"<tr{cls}>{cells}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _verdict_html(data: dict) -> str:
    if "verdict" not in data:
        return '<p class="verdict">NO VERDICT: no tolerance sheet given (<code>--tolerance</code>)</p>'
    acc = data.get("acceptance") or {}
    word = data["verdict"]
    reasons = "".join(f"<li>{_e(r)}</li>" for r in acc.get("reasons", []))
    return (f'<p class="verdict {_e(word)}">VERDICT: {_e(word.upper())}</p>'
            f'<p>against {_e(acc.get("sheet") or "the tolerance sheet")}: {acc.get("judged", 0)} parameters with a '
            f"limit{', failed: ' if reasons else ', all within their limits'}</p>"
            + (f"<ul>{reasons}</ul>" if reasons else ""))


def _conditions(data: dict) -> list[tuple[str, str]]:
    """The recording's conditions (temperature, ...) as the report gives them, and its site."""
    rec = data["recording"]
    pairs = [("site", f"latitude {rec['latitude_deg']:.6g} deg, gravity {rec['gravity_mps2']:.9g} m/s^2")]
    conditions = data.get("conditions") or {}
    if isinstance(conditions, dict):
        pairs += [(str(k), _e(v)) for k, v in conditions.items()]
    return pairs


def _checks_html(data: dict) -> str:
    checks = data.get("checks") or []
    if not checks:
        return "<p>none</p>"
    frame = checks_frame(checks)
    marks = {i: "fail-row" for i, p in enumerate(frame["passed"]) if p == "NO"}
    return _frame_html(frame, {"value", "limit"}, marks)


def certificate_html(data: dict, plots: dict[str, bytes] | None = None) -> str:
    """The certificate of a calibration as HTML text, from its report data (:func:`report.calibration.report_data`)
    and PNG plots (``{caption: png bytes}``, inlined)."""
    rec = data["recording"]
    unit = data.get("unit_id") or "(no unit id given)"
    table = parameter_display(data)
    outcome = (data.get("acceptance") or {}).get("outcome")
    if outcome is not None:
        table["acceptance"] = [outcome.get(n, "") for n in table["parameter"]]
    marks = {i: "fail-row" for i, n in enumerate(table["parameter"]) if (outcome or {}).get(n) == "fail"}
    table = table.rename(columns=HEADINGS)
    numeric = {HEADINGS[c] for c in ("value_natural", "sigma_natural", "error_natural", "error_over_sigma")}
    warnings = "".join(f"<li>{_e(w)}</li>" for w in data.get("warnings", [])) or "<li>none</li>"
    images = "".join(f'<figure><img alt="{_e(c)}" src="data:image/png;base64,{base64.b64encode(b).decode()}">'
                     f"<figcaption class=\"small\">{_e(c)}</figcaption></figure>" for c, b in (plots or {}).items())
    identity = [("unit id", f"<b>{_e(unit)}</b>"), ("recording", _e(rec.get("source") or rec.get("name"))),
                ("recording sha256", f'<span class="hash">{_e(rec.get("sha256"))}</span>'),
                ("calibrated", _e(data.get("created"))),
                ("data", f"{rec['samples']} samples at {rec['rate_hz']:g} Hz, {plural(rec['groups'], 'group')}, "
                         f"{plural(rec['segments'], 'segment')}"),
                *_conditions(data),
                ("solver", f"{_e(data.get('solver'))}, {'converged' if data.get('converged') else 'NOT converged'}"
                           f", {data.get('iterations')} iterations; sigma: {_e(data.get('sigma_meaning'))}")]
    versions = ", ".join(f"{k} {v}" for k, v in (data.get("versions") or {}).items())
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>Calibration certificate {_e(unit)}</title>
<style>{STYLE}</style></head>
<body>
<h1>Calibration certificate: unit {_e(unit)}</h1>
{_verdict_html(data)}
<h2>Unit and recording</h2>
<table>{_rows(identity)}</table>
<h2>Parameters</h2>
{_frame_html(table, numeric, marks)}
<p class="small">Values rounded to the second significant digit of their sigma (natural units; scale-factor sigma in
ppm of the value); the full values are in the parameter table CSV.</p>
<h2>Checks</h2>
{_checks_html(data)}
<h2>Warnings</h2>
<ul>{warnings}</ul>
{f'<h2>Plots</h2>{images}' if images else ''}
<h2>Software</h2>
<p class="small">{_e(data.get('software'))}; {_e(versions)}<br>command: {_e(data.get('command') or '')}</p>
</body></html>
"""
