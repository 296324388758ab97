"""A real session no one here made: imucal's hand-turned MEMS Ferraris example (tests/fixtures/imucal-ferraris).

With the defaults it calibrates (exit 0); its biases and scale factors agree with imucal's own
calibration within 4.5 of our sigma (the comparable quantities: README.md of the fixture); the report
says what a unit of this grade can and cannot determine, and states the shortest rest it accepted.
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from casadi_sins.cli import main

pytestmark = pytest.mark.slow  # two calibrations of a real session, a minute or two each

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "imucal-ferraris"
#: The bar: agreement with imucal's table within this many of our sigma.
AGREEMENT_SIGMA = 4.5


def imucal_comparable() -> dict[str, float]:
    """imucal's biases and scale factors in our parameters (SI): ``S_i = 1 / M_ii``, ``B_i = b_i / M_ii`` with
    ``M = K R`` (imucal's ``raw = K R true + b``; our pulses are SI per interval already)."""
    cal = json.loads((FIXTURE / "imucal-calibration.json").read_text())
    out = {}
    for sensor, key, to_si in (("accel", "a", 1.0), ("gyro", "g", math.pi / 180.0)):
        diag = np.diag(np.array(cal[f"K_{key}"]) @ np.array(cal[f"R_{key}"]))
        for i, axis in enumerate("xyz"):
            out[f"{sensor}_scale_{axis}"] = 1.0 / diag[i]
            out[f"{sensor}_bias_{axis}"] = cal[f"b_{key}"][i] * to_si / diag[i]
    return out


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    out = tmp_path_factory.mktemp("ferraris") / "ferraris.csv"
    status = main(["calibrate", str(FIXTURE / "imucal-ferraris.toml"), "--out", str(out)])
    return status, out


def test_the_defaults_calibrate_it_and_agree_with_imucal(calibrated):
    status, out = calibrated
    assert status == 0
    report = json.loads(out.with_name("ferraris.report.json").read_text())
    rows = {r["parameter"]: r for r in report["parameters"]}
    z = {name: (rows[name]["value"] - ref) / rows[name]["sigma"] for name, ref in imucal_comparable().items()}
    worst = max(z, key=lambda n: abs(z[n]))
    assert abs(z[worst]) <= AGREEMENT_SIGMA, f"{worst}: {z[worst]:+.2f} sigma from imucal"


def test_the_report_says_what_this_grade_determines(calibrated):
    _, out = calibrated
    report = json.loads(out.with_name("ferraris.report.json").read_text())
    grade = report["grade"]
    assert not grade["earth_rate_reference"]  # a MEMS bias of 0.6 deg/s: the Earth rate is no reference
    assert grade["gyro_bias_sigma_deg_h"] > 0.1 * grade["horizontal_earth_rate_deg_h"]
    text = " ".join(grade["sentences"])
    assert "Gyro biases come from the rests" in text and "from the turns only" in text
    assert grade["largest_turn_per_sample_deg"] > 5.0 and "turn slower or sample faster" in text  # 870 deg/s by hand
    markdown = out.with_name("ferraris.report.md").read_text()
    assert "## What this unit and schedule determine" in markdown
    rest = next(c for c in report["checks"] if c["name"] == "shortest rest")
    assert rest["passed"] and rest["value"] < 5.0 and "measured accelerometer noise" in rest["detail"]


def test_segment_on_the_raw_csv_gives_a_description_that_calibrates(tmp_path, capsys):
    """No description at all: `segment` finds the hand-turned schedule (short rests, a 176-deg turn, moves
    about several axes) and its description calibrates with the defaults, in agreement with imucal."""
    described = tmp_path / "segmented.toml"
    assert main(["segment", str(FIXTURE / "ferraris.csv.gz"), "--rate", "102.4", "--latitude", "49.6",
                 "--height", "280", "--out", str(described)]) == 0
    assert "segmented as a session turned by hand" in capsys.readouterr().err  # a note: standard error
    out = tmp_path / "segmented.csv"
    assert main(["calibrate", str(described), "--out", str(out)]) == 0
    report = json.loads(out.with_name("segmented.report.json").read_text())
    rows = {r["parameter"]: r for r in report["parameters"]}
    z = [abs(rows[n]["value"] - ref) / rows[n]["sigma"] for n, ref in imucal_comparable().items()]
    assert max(z) <= AGREEMENT_SIGMA
