"""The calibration certificate: one self-contained document to file with the unit and sign, printable on A4.

It carries what a production line signs: a certificate number, the unit id, the recording's and the
parameter table's SHA-256, the tolerance sheet and its SHA-256, the date and the recording's
conditions, the parameter table rounded to its sigma (:func:`report.rounding.parameter_display`)
with each judged parameter's limit and the margin left to it, the checks with their limits, the
warnings, the verdict against the sheet (when one was given), the build that computed it, and
fields for the engineer who prepared it and the one who approved it.  Printed, every page carries
the certificate number, the unit id and "page X of Y" (CSS page margin boxes); a heading is never left
alone at the foot of a page.

The HTML references nothing outside itself (plots are inline PNG ``data:`` URIs; no link, script,
style sheet or font to fetch), so that it reads the same offline and in ten years.
:func:`certificate_pdf` prints it to PDF directly (WeasyPrint, the optional extra ``pdf``).

**The certificate number** is ``CS-<YYYYMMDD>-<H>``: the calibration's date (UTC) and the first ten
hexadecimal digits of ``SHA-256("<unit id>\\n<YYYY-MM-DD>\\n<table SHA-256>")``, upper case
(:func:`certificate_number`).  Anyone holding the table can compute it again; another table (another
calibration, or the same one judged against another sheet, whose ``acceptance`` column differs)
gets another number.
"""

from __future__ import annotations

import base64
import hashlib
import html
import logging
import math

import pandas as pd

from ..core.errors import InputError
from ..core.extras import missing_extra
from ..core.text import plural
from .acceptance import allowances
from .rounding import parameter_display
from .tables import checks_frame

#: Column headings of the parameter table.
HEADINGS = {"value_natural": "value", "value_unit": "unit", "sigma_natural": "1-sigma", "sigma_unit": "sigma unit",
            "error_natural": "error", "error_over_sigma": "error/sigma"}
#: The kinds of certificate ``--certificate`` writes.
KINDS = ("html", "pdf")
#: Entries of the report's ``versions`` that the build identity already names.
OWN_VERSIONS = ("casadi-sins", "casadi-sins commit")


def certificate_number(unit_id: str | None, date: str, table_sha256: str | None) -> str:
    """``CS-<YYYYMMDD>-<10 hex digits>`` from the unit id, the calibration date (``YYYY-MM-DD``) and the
    table's SHA-256 (see the module docstring)."""
    day = str(date)[:10]
    digest = hashlib.sha256(f"{unit_id or ''}\n{day}\n{table_sha256 or ''}".encode("utf-8", "surrogatepass"))
    return f"CS-{day.replace('-', '')}-{digest.hexdigest()[:10].upper()}"


def _css_string(text: str) -> str:
    """A CSS string literal of any text: every character but letters, digits and a few marks escaped (no quote,
    backslash or ``</style>`` can end it)."""
    safe = " -_.:,()#+"
    return '"' + "".join(c if (c.isascii() and c.isalnum()) or c in safe else f"\\{ord(c):06x}"
                         for c in str(text)) + '"'


def style(number: str, unit: str) -> str:
    """The style sheet: A4 portrait, the certificate number and unit id atop every printed page and "page X of
    Y" at its foot, headings kept with what follows; colours that survive a black-and-white printer."""
    head = _css_string(f"Calibration certificate {number}")
    who = _css_string(f"unit {unit}")
    return f"""@page {{ size: A4 portrait; margin: 17mm 12mm 15mm 12mm;
  @top-left {{ content: {head}; font: 8pt "DejaVu Sans", Arial, sans-serif; color: #333; }}
  @top-right {{ content: {who}; font: bold 8pt "DejaVu Sans", Arial, sans-serif; }}
  @bottom-right {{ content: "page " counter(page) " of " counter(pages); font: 8pt "DejaVu Sans", Arial, sans-serif; }}
  @bottom-left {{ content: {who}; font: 8pt "DejaVu Sans", Arial, sans-serif; color: #333; }} }}
body {{ font-family: "DejaVu Sans", Arial, Helvetica, sans-serif; font-size: 9pt; color: #000; max-width: 186mm;
       margin: 0 auto; }}
h1 {{ font-size: 15pt; margin: 0 0 2mm 0; }}
h2 {{ font-size: 11pt; margin: 4.5mm 0 1.5mm 0; break-after: avoid; page-break-after: avoid; }}
section {{ break-before: auto; }}
section.keep {{ break-inside: avoid; page-break-inside: avoid; }}
table {{ border-collapse: collapse; width: 100%; }}
thead {{ display: table-header-group; }}
tr {{ break-inside: avoid; page-break-inside: avoid; }}
th, td {{ border: 0.3mm solid #777; padding: 0.5mm 1.3mm; text-align: left; vertical-align: top; }}
td.n {{ text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }}
td.limit {{ white-space: nowrap; }}
.verdict {{ font-size: 14pt; font-weight: bold; padding: 2mm 3mm; border: 0.8mm solid #000; display: inline-block;
            margin: 1mm 0; }}
.pass {{ background: #d9f2d9; }} .fail {{ background: #f7d4d4; }}
.fail-row td {{ font-weight: bold; background: #fbe9e9; }}
figure {{ margin: 0 0 3mm 0; break-inside: avoid; page-break-inside: avoid; }}
img {{ width: 100%; }}
.hash {{ font-family: "DejaVu Sans Mono", monospace; font-size: 7.5pt; word-break: break-all; }}
.small {{ font-size: 7.5pt; color: #333; }}
table.params {{ font-size: 7.8pt; }}
table.params th, table.params td {{ padding: 0.4mm 1mm; }}
table.sign td {{ height: 11mm; }}
table.sign th {{ width: 22%; }}"""


def _e(value) -> str:
    return html.escape("" if value is None else str(value))


def _cell(value) -> str:
    """A cell's HTML: a list is one line per item."""
    if isinstance(value, (list, tuple)):
        return "<br>".join(_e(v) for v in value)
    return _e(value)


def _rows(pairs) -> str:
    return "".join(f"<tr><th>{_e(k)}</th><td>{v}</td></tr>" for k, v in pairs)


def _frame_html(frame: pd.DataFrame, numeric: set[str], marks: dict[int, str] | None = None,
                table_class: str = "") -> str:
    head = "".join(f"<th>{_e(c)}</th>" for c in frame.columns)
    body = []
    for i, row in enumerate(frame.itertuples(index=False)):
        mark = f' class="{marks[i]}"' if marks and i in marks else ""
        cells = "".join(f'<td class="n">{_cell(v)}</td>' if c in numeric else
                        f'<td class="limit">{_cell(v)}</td>' if c == "limit" else f"<td>{_cell(v)}</td>"
                        for c, v in zip(frame.columns, row))
        body.append(f"<tr{mark}>{cells}</tr>")
    attribute = f' class="{table_class}"' if table_class else ""
    return f"<table{attribute}><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


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


def _margin_text(margin: float) -> str:
    return "no sigma" if not math.isfinite(margin) else f"{100 * margin:.0f} %"


def parameter_frame(data: dict) -> pd.DataFrame:
    """The parameter table of the certificate: the report's rounded table, each judged parameter's limits (one
    line each), the margin left to each limit (:func:`report.acceptance.allowances`) and its outcome."""
    table = parameter_display(data)
    acc = data.get("acceptance") or {}
    outcome, limits = acc.get("outcome") or {}, acc.get("limits") or {}
    rows = {p["parameter"]: p for p in data["parameters"]}
    texts, margins = [], []
    for name in table["parameter"]:
        found = allowances(name, rows[name]["value_natural"], rows[name]["sigma_natural"], limits.get(name) or {})
        texts.append([t for t, _ in found] or ["not judged" if "verdict" in data else "no sheet"])
        margins.append([_margin_text(m) for _, m in found] or [""])
    table["limit"] = texts
    table["margin"] = margins
    table["result"] = [outcome.get(n, "") for n in table["parameter"]]
    return table.rename(columns=HEADINGS)


def _identity(data: dict, number: str, unit: str) -> list[tuple[str, str]]:
    rec = data["recording"]
    acc = data.get("acceptance") or {}
    pairs = [("certificate number", f"<b>{_e(number)}</b>"), ("unit id", f"<b>{_e(unit)}</b>"),
             ("calibrated (UTC)", _e(data.get("created"))),
             ("parameter table", _e(data.get("table") or "(not named)")),
             ("table sha256", f'<span class="hash">{_e(data.get("table_sha256") or "(not recorded)")}</span>'),
             ("recording", _e(rec.get("source") or rec.get("name"))),
             ("recording sha256", f'<span class="hash">{_e(rec.get("sha256"))}</span>')]
    if "verdict" in data:
        pairs += [("tolerance sheet", _e(acc.get("sheet") or "(not named)")),
                  ("tolerance sheet sha256", f'<span class="hash">{_e(acc.get("sheet_sha256") or "(unreadable)")}'
                                             "</span>")]
    pairs += [("data", f"{rec['samples']} samples at {rec['rate_hz']:g} Hz, {plural(rec['groups'], 'group')}, "
                       f"{plural(rec['segments'], 'segment')}"),
              *_conditions(data),
              ("solver", f"{_e(data.get('solver'))}, {'converged' if data.get('converged') else 'NOT converged'}"
                         f", {data.get('iterations')} iterations; sigma: {_e(data.get('sigma_meaning'))}")]
    return pairs


def _software(data: dict) -> str:
    """The build identity once, then the versions it does not name."""
    others = ", ".join(f"{k} {v}" for k, v in (data.get("versions") or {}).items() if k not in OWN_VERSIONS)
    return (f"<p class=\"small\">{_e(data.get('software'))}" + (f"; with {_e(others)}" if others else "")
            + f"<br>command: {_e(data.get('command') or '')}</p>")


SIGNATURES = """<table class="sign"><thead><tr><th></th><th>name</th><th>signature</th><th>date</th></tr></thead>
<tbody><tr><th>prepared by</th><td></td><td></td><td></td></tr>
<tr><th>approved by</th><td></td><td></td><td></td></tr></tbody></table>"""


def certificate_html(data: dict, plots: dict[str, bytes] | None = None) -> str:
    """The certificate of a calibration as HTML text, from its report data (:func:`report.calibration.report_data`,
    with ``table_sha256``) and PNG plots (``{caption: png bytes}``, inlined)."""
    unit = data.get("unit_id") or "(no unit id given)"
    number = (data.get("certificate") or {}).get("number") or certificate_number(
        data.get("unit_id"), str(data.get("created")), data.get("table_sha256"))
    table = parameter_frame(data)
    marks = {i: "fail-row" for i, a in enumerate(table["result"]) if a == "fail"}
    numeric = {HEADINGS[c] for c in ("value_natural", "sigma_natural", "error_natural", "error_over_sigma")}
    numeric.add("margin")
    warnings = "".join(f"<li>{_e(w)}</li>" for w in data.get("warnings", [])) or "<li>none</li>"
    images = "".join(f'<figure><img alt="{_e(c)}" src="data:image/png;base64,{base64.b64encode(b).decode()}">'
                     f"<figcaption class=\"small\">{_e(c)}</figcaption></figure>" for c, b in (plots or {}).items())
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>Calibration certificate {_e(number)}: unit {_e(unit)}</title>
<style>{style(number, unit)}</style></head>
<body>
<h1>Calibration certificate {_e(number)}: unit {_e(unit)}</h1>
{_verdict_html(data)}
<section class="keep"><h2>Unit and recording</h2>
<table>{_rows(_identity(data, number, unit))}</table></section>
<section><h2>Parameters</h2>
{_frame_html(table, numeric, marks, "params")}
<p class="small">Values rounded to the second significant digit of their sigma (natural units; scale-factor sigma in
ppm of the value); the full values are in the parameter table CSV. Margin: the part of the allowance left, 100 % at
the ideal (no sigma; a value of 0, or the middle of an allowed range), 0 at the limit, negative beyond it.</p>
</section>
<section><h2>Checks</h2>
{_checks_html(data)}</section>
<section class="keep"><h2>Warnings</h2>
<ul>{warnings}</ul></section>
<section class="keep"><h2>Software</h2>
{_software(data)}</section>
<section class="keep"><h2>Approval</h2>
{SIGNATURES}
<p class="small">Certificate number: CS-, the calibration date, and the first ten hexadecimal digits of
SHA-256(unit id, date, table SHA-256), each on its own line: reproducible from the table.</p></section>
{f'<section><h2>Plots</h2>{images}</section>' if images else ''}
</body></html>
"""


def certificate_pdf(page: str) -> bytes:
    """The certificate's HTML printed to PDF (A4, page numbers and unit id on every page) by WeasyPrint.

    Nothing is fetched: the page is self-contained, and any other URL is refused.

    Raises
    ------
    InputError
        When WeasyPrint (the optional extra ``pdf``) is not installed or cannot load its libraries.
    """
    try:
        import weasyprint
    except (ImportError, OSError) as exc:  # OSError: the package is there, its Pango library is not
        raise InputError(None, missing_extra("--certificate pdf", "pdf", "WeasyPrint", exc)) from None

    if hasattr(weasyprint, "URLFetcher"):  # WeasyPrint 68 and later
        fetcher = weasyprint.URLFetcher(allowed_protocols=("data",))
    else:
        def fetcher(url: str, *args, **kwargs):
            if url.startswith("data:"):
                return weasyprint.default_url_fetcher(url, *args, **kwargs)
            raise ValueError(f"the certificate fetches nothing ({url[:40]})")
    logger = logging.getLogger("weasyprint")
    level = logger.level
    logger.setLevel(logging.ERROR)  # its notes on CSS it does not use are not the user's business
    try:
        return weasyprint.HTML(string=page, url_fetcher=fetcher).write_pdf()
    finally:
        logger.setLevel(level)
