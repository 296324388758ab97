"""Acceptance at calibration time: the tolerance sheet's limits, the verdict, the exit status, the certificate."""

import json
import re
from html.parser import HTMLParser

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.core.errors import InputError
from casadi_sins.core.units import UG
from casadi_sins.data.tables import read_table
from casadi_sins.data.tolerance import read_tolerance_sheet
from casadi_sins.model import registry as R
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.report.acceptance import judge
from casadi_sins.sim import simulate, write_simulation

SHEET = 'format = "casadi-sins-tolerance/1"\n'


def sheet(tmp_path, body: str, name="sheet.toml"):
    path = tmp_path / name
    path.write_text(SHEET + body)
    return path


@pytest.fixture(scope="module")
def unit(tmp_path_factory, short_problem):
    """A simulated unit's recording and its calibration with a certificate (the gyro-bias sigma known)."""
    tmp = tmp_path_factory.mktemp("unit")
    rec = write_simulation(simulate(short_problem, seed=21), tmp / "rec")
    out = tmp / "P.csv"
    assert main(["calibrate", str(rec), "--out", str(out), "--unit-id", "SN<42>&", "--certificate", "--quiet"]) == 0
    sigma = read_table(out).natural_sigma()[list(R.NAMES).index("gyro_bias_x"):][:3]
    return tmp, rec, out, sigma


def test_a_gyro_bias_sigma_limit_the_unit_misses_fails_with_exit_3_and_the_table_marked(unit, capsys):
    tmp, rec, _, sigma = unit
    tight = sheet(tmp, f'[accept.sigma]\n"gyro bias" = {0.5 * sigma.max():.6g}\n', "tight.toml")
    out = tmp / "F.csv"
    assert main(["calibrate", str(rec), "--out", str(out), "--tolerance", str(tight), "--quiet"]) == 3
    assert "verdict: FAIL" in capsys.readouterr().out
    report = json.loads((tmp / "F.report.json").read_text())
    assert report["verdict"] == "fail"
    assert any("gyro_bias" in r and "sigma" in r for r in report["acceptance"]["reasons"])
    marks = dict(np.loadtxt(out, delimiter=",", skiprows=1, usecols=(0, 6), dtype=str))
    assert "fail" in {marks[f"gyro_bias_{a}"] for a in "xyz"}
    assert {v for k, v in marks.items() if not k.startswith("gyro_bias")} == {""}  # only judged ones marked
    assert np.allclose(read_table(out).values, read_table(unit[2]).values)  # the table still written, readable


def test_a_loose_sheet_passes_with_exit_0(unit):
    tmp, rec, _, sigma = unit
    loose = sheet(tmp, f'[accept.sigma]\n"gyro bias" = {2 * sigma.max():.6g}\n[accept.value]\n"accel bias" = 1e6\n'
                  '"gyro scale" = [0.001, 1000.0]\n', "loose.toml")
    assert main(["calibrate", str(rec), "--out", str(tmp / "L.csv"), "--tolerance", str(loose), "--quiet"]) == 0
    report = json.loads((tmp / "L.report.json").read_text())
    assert report["verdict"] == "pass" and report["acceptance"]["reasons"] == []
    assert report["acceptance"]["judged"] == 9


class _References(HTMLParser):
    """Every attribute that could fetch something, and the page's text."""

    def __init__(self):
        super().__init__()
        self.refs, self.text, self.tags = [], [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.refs += [(tag, k, v) for k, v in attrs if k in ("src", "href", "srcset", "data", "poster", "action")]

    def handle_data(self, data):
        self.text.append(data)


def test_the_certificate_is_self_contained_and_names_unit_hash_and_verdict(unit):
    tmp, rec, out, _ = unit
    page = (tmp / "P.certificate.html").read_text(encoding="utf-8")
    parser = _References()
    parser.feed(page)
    assert parser.refs and all(v.startswith("data:image/png;base64,") for _, _, v in parser.refs)
    assert not {"link", "script", "iframe", "object", "embed"} & set(parser.tags)
    text_only = re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", page)  # base64 may spell anything
    assert "url(" not in text_only and "@import" not in text_only and "http" not in text_only.lower()
    text = " ".join(parser.text)
    report = json.loads((tmp / "P.report.json").read_text())
    assert "SN<42>&" in text and report["recording"]["sha256"] in text  # escaped in HTML, exact in the text
    assert "NO VERDICT" in text and "@page { size: A4" in page
    assert all(name in text for name in R.NAMES)


def test_the_verdict_is_on_the_certificate(unit):
    tmp, rec, _, sigma = unit
    tight = sheet(tmp, f'[accept.sigma]\ngyro_bias_x = {0.5 * sigma[0]:.6g}\n', "x.toml")
    assert main(["calibrate", str(rec), "--out", str(tmp / "X.csv"), "--tolerance", str(tight), "--certificate",
                 "--quiet"]) == 3
    page = (tmp / "X.certificate.html").read_text(encoding="utf-8")
    assert "VERDICT: FAIL" in page and 'class="fail-row"' in page


def test_value_limits_and_a_parameter_overriding_its_group(tmp_path):
    s = read_tolerance_sheet(sheet(tmp_path, '[accept.value]\n"accel bias" = 100.0\naccel_bias_z = [-10.0, 900.0]\n'))
    values = np.where(R.SCALE_MASK, 1e-5, 0.0)
    values[list(R.NAMES).index("accel_bias_z")] = 500 * UG
    v = judge(ParameterSet(values, sigma=np.full(21, 1e-9)), s)
    assert v.passed and v.outcome["accel_bias_z"] == "pass"  # 500 ug: beyond the group's 100, within its own
    values[list(R.NAMES).index("accel_bias_x")] = -150 * UG
    v = judge(ParameterSet(values, sigma=np.full(21, 1e-9)), s)
    assert not v.passed and v.outcome["accel_bias_x"] == "fail" and "accel_bias_x" in v.reasons[0]


def test_a_sigma_limit_without_sigma_fails(tmp_path):
    s = read_tolerance_sheet(sheet(tmp_path, '[accept.sigma]\n"gyro misalignment" = 5\n'))
    v = judge(ParameterSet(np.where(R.SCALE_MASK, 1e-5, 0.0)), s)
    assert not v.passed and len(v.reasons) == 6 and "no sigma" in v.reasons[0]


@pytest.mark.parametrize("body, words", [
    ('[accept.sigma]\n"gyro bias" = -1\n', "line 3"),
    ('[accept.sigma]\ngyro_bias_q = 1\n', "neither a parameter nor a group"),
    ('[accept.value]\n"gyro scale" = [2.0, 1.0]\n', "low < high"),
    ('[accept.limits]\nx = 1\n', "unknown table [accept.limits]"),
])
def test_a_bad_acceptance_entry_is_named(tmp_path, body, words):
    with pytest.raises(InputError, match=None) as info:
        read_tolerance_sheet(sheet(tmp_path, body))
    assert words in str(info.value) and "sheet.toml" in str(info.value)


def test_calibrate_refuses_a_sheet_without_acceptance_limits_before_computing(tmp_path, capsys):
    path = sheet(tmp_path, '[change]\n"gyro bias" = 0.01\n')
    assert main(["calibrate", str(tmp_path / "missing.toml"), "--out", str(tmp_path / "P.csv"),
                 "--tolerance", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "sheet.toml" in err and "no acceptance limits" in err


def test_the_shipped_example_sheet_accepts_the_papers_unit(kang_nlp):
    from casadi_sins.problems import __file__ as problems_init
    from pathlib import Path

    s = read_tolerance_sheet(Path(problems_init).parent / "tolerance-navgrade.toml")
    assert len(s.accept_sigma) == 21 and s.change and s.drift_per_year
    v = judge(kang_nlp.parameters, s)
    assert v.passed, v.reasons
    sloppy = ParameterSet(kang_nlp.parameters.values, sigma=kang_nlp.parameters.sigma * 10)
    assert not judge(sloppy, s).passed  # ten times the schedule's sigma: refused
