"""The certificate a quality engineer signs: limits and margins, both hashes, a reproducible certificate number,
approval fields, the unit id and "page X of Y" on every printed page, headings kept with what follows, the build
named once; printed to PDF directly (read back: its text and page count)."""

from __future__ import annotations

import hashlib
import json
import re
from html.parser import HTMLParser

import pytest

from casadi_sins.cli import main
from casadi_sins.core.version import build_identity
from casadi_sins.data.tables import read_table
from casadi_sins.model import registry as R
from casadi_sins.report.certificate import certificate_number
from casadi_sins.sim import simulate, write_simulation

HEADINGS = ("Unit and recording", "Parameters", "Checks", "Warnings", "Software", "Approval", "Plots")


class _Text(HTMLParser):
    """The text of a page, and the cells of its parameter table (class params) by row."""

    def __init__(self):
        super().__init__()
        self.text, self.rows, self._in_params, self._cell = [], [], False, None

    def handle_starttag(self, tag, attrs):
        if tag == "table" and ("class", "params") in attrs:
            self._in_params = True
        elif self._in_params and tag == "tr":
            self.rows.append([])
        elif self._in_params and tag in ("td", "th"):
            self._cell = []
        elif tag == "br" and self._cell is not None:
            self._cell.append("\n")

    def handle_endtag(self, tag):
        if tag == "table":
            self._in_params = False
        elif tag in ("td", "th") and self._cell is not None:
            self.rows[-1].append("".join(self._cell))
            self._cell = None

    def handle_data(self, data):
        self.text.append(data)
        if self._cell is not None:
            self._cell.append(data)


@pytest.fixture(scope="module")
def judged(tmp_path_factory, short_problem):
    """A unit calibrated against a sheet with sigma and value limits, with an HTML certificate."""
    tmp = tmp_path_factory.mktemp("cert")
    rec = write_simulation(simulate(short_problem, seed=23), tmp / "rec")
    sheet = tmp / "sheet.toml"
    sheet.write_text('format = "casadi-sins-tolerance/1"\n[accept.sigma]\n"gyro bias" = 1.0\n"accel scale" = 50.0\n'
                     '[accept.value]\n"accel bias" = 1e5\n"gyro scale" = [0.001, 1.0]\n')
    assert main(["calibrate", str(rec), "--out", str(tmp / "P.csv"), "--unit-id", "SN-77", "--tolerance", str(sheet),
                 "--certificate", "--quiet"]) == 0
    page = (tmp / "P.certificate.html").read_text(encoding="utf-8")
    parser = _Text()
    parser.feed(page)
    return tmp, rec, sheet, page, parser


def test_every_judged_parameter_has_its_limit_and_margin(judged):
    tmp, _, _, _, parser = judged
    head, *rows = parser.rows
    assert head[:5] == ["parameter", "value", "unit", "1-sigma", "sigma unit"] and "limit" in head and "margin" in head
    by_name = {r[0]: dict(zip(head, r)) for r in rows}
    assert set(by_name) == set(R.NAMES)
    table = read_table(tmp / "P.csv")
    for name, sigma in zip(table.names, table.natural_sigma()):
        row = by_name[name]
        if name.startswith("gyro_bias"):  # sigma limit 1 deg/h: the margin is the part of it left
            assert row["limit"] == "σ ≤ 1 deg/h"
            assert row["margin"] == f"{100 * (1.0 - sigma):.0f} %"
        elif name.startswith("gyro_scale"):
            assert row["limit"] == "value 0.001 … 1 arcsec/pulse" and row["margin"].endswith("%")
        elif name.startswith("accel_scale"):
            assert row["limit"] == "σ ≤ 50 ppm" and row["margin"] == f"{100 * (1.0 - sigma / 50.0):.0f} %"
        elif name.startswith("accel_bias"):
            assert row["limit"] == "|value| ≤ 100000 ug"
        else:
            assert row["limit"] == "not judged" and row["margin"] == ""
        assert row["result"] == ("" if row["limit"] == "not judged" else "pass")


def test_both_hashes_and_a_reproducible_certificate_number(judged):
    tmp, _, sheet, _, parser = judged
    text = " ".join(parser.text)
    table_hash = hashlib.sha256((tmp / "P.csv").read_bytes()).hexdigest()
    sheet_hash = hashlib.sha256(sheet.read_bytes()).hexdigest()
    assert table_hash in text and sheet_hash in text
    report = json.loads((tmp / "P.report.json").read_text())
    number = certificate_number("SN-77", report["created"][:10], table_hash)
    assert re.fullmatch(r"CS-\d{8}-[0-9A-F]{10}", number) and number in text
    assert report["certificate"] == {"number": number, "file": "P.certificate.html"}
    assert report["table_sha256"] == table_hash and number in (tmp / "P.report.md").read_text()
    assert number == certificate_number("SN-77", report["created"], table_hash)  # a date-time gives its day
    others = {certificate_number("SN-78", report["created"][:10], table_hash),
              certificate_number("SN-77", "2031-01-01", table_hash),
              certificate_number("SN-77", report["created"][:10], "0" * 64)}
    assert number not in others and len(others) == 3


def test_approval_fields_page_numbers_and_the_build_once(judged):
    _, _, _, page, parser = judged
    text = " ".join(parser.text)
    for field in ("prepared by", "approved by", "signature", "date"):
        assert field in text
    style = page[page.index("<style>"):page.index("</style>")]
    assert '"page " counter(page) " of " counter(pages)' in style
    assert '"unit SN-77"' in style  # in the page margin boxes: on every printed page
    assert "@top-left" in style and "@bottom-right" in style
    assert re.search(r"h2 \{[^}]*break-after: avoid", style)
    software = text[text.index("Software"):text.index("command:")]
    assert software.count(build_identity()) == 1 and software.count("casadi-sins") == 1


def test_a_hostile_unit_id_stays_inside_the_style_strings(tmp_path, short_problem):
    rec = write_simulation(simulate(short_problem, seed=24), tmp_path / "rec")
    unit = 'SN"}</style><script>x</script>'
    assert main(["calibrate", str(rec), "--out", str(tmp_path / "P.csv"), "--unit-id", unit, "--certificate",
                 "--quiet"]) == 0
    page = (tmp_path / "P.certificate.html").read_text(encoding="utf-8")
    assert "<script>" not in page and page.count("</style>") == 1


def test_the_pdf_certificate_reads_back(judged, tmp_path):
    """--certificate pdf writes the PDF directly: A4 pages, each with the certificate number, the unit id and
    "page X of Y"; every section on it; no page ending on a heading."""
    pytest.importorskip("weasyprint")
    pypdf = pytest.importorskip("pypdf")
    tmp, rec, sheet, _, _ = judged
    out = tmp_path / "Q.csv"
    assert main(["calibrate", str(rec), "--out", str(out), "--unit-id", "SN-77", "--tolerance", str(sheet),
                 "--certificate", "pdf", "--quiet"]) == 0
    assert not (tmp_path / "Q.certificate.html").exists()
    reader = pypdf.PdfReader(tmp_path / "Q.certificate.pdf")
    pages = [p.extract_text() for p in reader.pages]
    number = json.loads((tmp_path / "Q.report.json").read_text())["certificate"]["number"]
    assert 2 <= len(pages) <= 6
    for k, text in enumerate(pages):
        assert f"page {k + 1} of {len(pages)}" in text and "unit SN-77" in text and number in text
        assert abs(float(reader.pages[k].mediabox.width) - 595.3) < 1 and abs(float(reader.pages[k].mediabox.height)
                                                                            - 841.9) < 1  # A4 in points
        body = [line.strip() for line in text.splitlines() if line.strip() and not line.startswith(("page ", "unit "))
                and "Calibration certificate" not in line]
        assert body and body[-1] not in HEADINGS, f"page {k + 1} ends on the heading {body[-1]!r}"
    whole = "\n".join(pages)
    assert all(h in whole for h in HEADINGS) and "VERDICT: PASS" in whole and "approved by" in whole
    assert hashlib.sha256(out.read_bytes()).hexdigest() in whole.replace("\n", "")
