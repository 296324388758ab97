"""``casadi-sins noise``: a description with one static segment, with none, a bare CSV; SI from a table or a
nominal scale, pulses without; the datasheet read back by the reader ``calibrate --noise`` uses; bad input in one
line with nothing written."""

import json

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.data.datasheet import read_datasheet
from casadi_sins.data.samples import samples_csv
from casadi_sins.model.noise import SensorNoise

RATE = 10.0
#: Pulse weights (rad/pulse, m/s/pulse), the paper's sizes.
GYRO_PULSE, ACCEL_PULSE = 9.85e-8, 3.5e-4
TABLE_ROWS = {"accel_bias_x": ("m/s^2", 0.0), "accel_bias_y": ("m/s^2", 0.0), "accel_bias_z": ("m/s^2", 0.0),
              "accel_misalign_yx": ("rad", 0.0), "accel_misalign_zx": ("rad", 0.0), "accel_misalign_zy": ("rad", 0.0),
              "gyro_bias_x": ("rad/s", 0.0), "gyro_bias_y": ("rad/s", 0.0), "gyro_bias_z": ("rad/s", 0.0),
              **{f"gyro_misalign_{k}": ("rad", 1e-3) for k in ("xy", "xz", "yx", "yz", "zx", "zy")},
              **{f"gyro_scale_{a}": ("rad/pulse", GYRO_PULSE) for a in "xyz"},
              **{f"accel_scale_{a}": ("m/s/pulse", ACCEL_PULSE) for a in "xyz"}}


@pytest.fixture(scope="module")
def pulses(static_increments):
    """25 minutes at rest at 10 Hz in pulses: navigation-grade white noise, a Gauss-Markov bias on gyro z and
    accelerometer x, Earth rate and gravity."""
    white = np.array([0.002 * np.pi / 180 / 60] * 3 + [15e-6 * 9.80665] * 3)  # rad/sqrt(s), m/s/sqrt(s)
    sigma = np.array([0.0, 0.0, 0.05 * np.pi / 180 / 3600, 20e-6 * 9.80665, 0.0, 0.0])
    mean = np.array([5e-5, 1e-5, 4e-5, 0.05, 0.02, 9.8])
    x = static_increments(RATE, 1500.0, white, 0.0, sigma, 60.0, seed=11, mean=mean)
    return x / np.array([GYRO_PULSE] * 3 + [ACCEL_PULSE] * 3)


def _write(folder, pulses, segments="", name="rest", rows=None):
    rows = slice(None) if rows is None else rows
    time = (np.arange(len(pulses)) + 1) / RATE
    keep = np.ones(len(time), bool)
    if rows is not None:
        keep = np.zeros(len(time), bool)
        keep[rows] = True
    (folder / f"{name}.csv").write_text(samples_csv(time[keep], pulses[keep, :3], pulses[keep, 3:]))
    (folder / f"{name}.toml").write_text(f'format = "sins-recording/1"\nname = "{name}"\ndata = "{name}.csv"\n'
                                         f'[site]\nlatitude_deg = 37.5\nheight_m = 0.0\n[imu]\nrate_hz = {RATE}\n'
                                         + segments)
    return folder / f"{name}.toml", folder / f"{name}.csv"


def _table(folder):
    path = folder / "unit.csv"
    path.write_text("parameter,unit,value,sigma\n" + "".join(f"{k},{u},{v!r},\n" for k, (u, v) in TABLE_ROWS.items()))
    return path


def test_a_description_without_segments_gives_the_datasheet_that_reads_back(tmp_path, pulses, capsys):
    toml, _ = _write(tmp_path, pulses)
    out = tmp_path / "out"
    assert main(["noise", str(toml), "--params", str(_table(tmp_path)), "--out", str(out), "--no-progress"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["allan-accel.png", "allan-gyro.png", "datasheet.toml",
                                                     "noise.json", "noise.md"]
    doc = json.loads((out / "noise.json").read_text())
    assert doc["samples"] == len(pulses) and not doc["in_pulses"]
    sheet = read_datasheet(out / "datasheet.toml")
    natural = doc["datasheet"]
    for key, value in sheet.natural().items():  # the file holds what the report says, to its six digits
        if key in natural:
            np.testing.assert_allclose(value, natural[key], rtol=1e-5)
    for key in natural:
        assert sheet.natural()[key] is not None
    white = [doc["axes"][a]["white"]["value"] for a in ("gyro_x", "gyro_y", "gyro_z")]
    np.testing.assert_allclose(sheet.natural()["gyro_arw_deg_rth"], white, rtol=1e-5)
    np.testing.assert_allclose(white, 0.002, rtol=0.05)  # the truth, within a few of their standard errors
    out_text = capsys.readouterr().out
    assert "gyro_x" in out_text and "deg/sqrt(h)" in out_text and "datasheet.toml" in out_text


def test_the_datasheet_writer_round_trips_every_key(tmp_path):
    from casadi_sins.data.datasheet import datasheet_toml
    noise = SensorNoise(gyro_arw=np.array([1e-7, 2e-7, 3e-7]), accel_vrw=np.array([1e-4, 2e-4, 3e-4]),
                        gyro_quantization=np.array([1e-8, 0.0, 2e-8]), accel_quantization=np.array([1e-5, 1e-5, 1e-5]),
                        gyro_bias_instability=3e-8, gyro_bias_tau=432.1, accel_bias_instability=2e-5, accel_bias_tau=77.0)
    path = tmp_path / "sheet.toml"
    path.write_text(datasheet_toml(noise, ["a comment", "on two\nlines"]))
    back = read_datasheet(path)
    for key, value in noise.natural().items():
        np.testing.assert_allclose(back.natural()[key], value, rtol=1e-5)


def test_a_bare_csv_in_pulses_and_a_nominal_scale_agree_with_the_table(tmp_path, pulses, capsys):
    _, csv = _write(tmp_path, pulses)
    assert main(["noise", str(csv), "--rate", str(RATE), "--out", str(tmp_path / "p"), "--no-progress"]) == 0
    assert "in pulses" in capsys.readouterr().err
    assert not (tmp_path / "p" / "datasheet.toml").exists()
    in_pulses = json.loads((tmp_path / "p" / "noise.json").read_text())
    assert in_pulses["in_pulses"] and in_pulses["axes"]["gyro_x"]["white_unit"] == "pulse/sqrt(s)"
    assert main(["noise", str(csv), "--rate", str(RATE), "--scale", str(GYRO_PULSE), str(ACCEL_PULSE),
                 "--out", str(tmp_path / "s"), "--no-progress"]) == 0
    scaled = json.loads((tmp_path / "s" / "noise.json").read_text())
    gyro = in_pulses["axes"]["gyro_y"]["white"]["value"] * GYRO_PULSE / (np.pi / 180 / 60)
    assert scaled["axes"]["gyro_y"]["white"]["value"] == pytest.approx(gyro, rel=1e-9)
    accel = in_pulses["axes"]["accel_x"]["white"]["value"] * ACCEL_PULSE / 9.80665e-6
    assert scaled["axes"]["accel_x"]["white"]["value"] == pytest.approx(accel, rel=1e-9)


def test_one_static_segment_of_a_recording_with_motion_elsewhere(tmp_path, pulses):
    """The rest is the segment only: a turn after it is outside."""
    moving = pulses.copy()
    moving[-500:, 2] += 5000.0  # a turn in the last 50 s
    segments = ('[[segments]]\ngroup = 1\nkind = "static"\norientation = "NUE"\nstart_s = 0.0\nend_s = 1400.0\n'
                '[[segments]]\ngroup = 1\nkind = "rotation"\naxis = "+Z"\nangle_deg = 90.0\nstart_s = 1450.0\n'
                'end_s = 1460.0\n[[segments]]\ngroup = 1\nkind = "static"\norientation = "USE"\nstart_s = 1460.0\n'
                'end_s = 1500.0\n')
    toml, _ = _write(tmp_path, moving, segments)
    assert main(["noise", str(toml), "--out", str(tmp_path / "x"), "--no-progress"]) == 2  # two static segments
    assert main(["noise", str(toml), "--segment", "1", "--out", str(tmp_path / "o"), "--no-progress"]) == 0
    assert json.loads((tmp_path / "o" / "noise.json").read_text())["samples"] == 14000
    assert main(["noise", str(toml), "--segment", "3", "--out", str(tmp_path / "y"), "--no-progress"]) == 2  # 40 s
    assert main(["noise", str(toml), "--segment", "2", "--out", str(tmp_path / "z"), "--no-progress"]) == 2


@pytest.mark.parametrize("fault, words", [
    ("motion", "not at rest at 7"),
    ("gap", "line 3002"),
    ("short", "at least 600 s"),
    ("flat", "no noise to identify"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_written(tmp_path, pulses, capsys, fault, words):
    data, rows = pulses.copy(), None
    if fault == "motion":
        data[7000:7100, 1] += 3000.0  # a turn at 700 s
    elif fault == "gap":
        rows = np.r_[0:3000, 3001:len(pulses)]
    elif fault == "short":
        data = pulses[:5000]
    elif fault == "flat":
        data[:, 4] = 7.0  # a stuck counter
    toml, _ = _write(tmp_path, data, rows=rows)
    out = tmp_path / "out"
    assert main(["noise", str(toml), "--params", str(_table(tmp_path)), "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "casadi-sins noise: error:" in err[0] and words in err[0]
    assert not out.exists() or not any(out.iterdir())


def test_options_that_contradict_each_other_are_refused(tmp_path, pulses, capsys):
    toml, csv = _write(tmp_path, pulses)
    table = str(_table(tmp_path))
    out = str(tmp_path / "out")
    assert main(["noise", str(toml), "--params", table, "--scale", "1e-7", "3e-4", "--out", out]) == 2
    assert main(["noise", str(toml), "--rate", "10", "--out", out]) == 2
    assert main(["noise", str(csv), "--out", out]) == 2
    assert main(["noise", str(csv), "--rate", "10", "--scale", "0", "3e-4", "--out", out]) == 2
    assert "--rate" in capsys.readouterr().err
