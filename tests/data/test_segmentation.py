"""Segmentation from the signals, and approximate segment times (issue 11)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from casadi_sins.calibrate import calibrate_nlp
from casadi_sins.cli import main
from casadi_sins.core.errors import InputError
from casadi_sins.data.description import read_recording, write_recording
from casadi_sins.data.problem import load_problem
from casadi_sins.data.segmentation import refine, segment_recording
from casadi_sins.sim import simulate

PROBLEM = Path(__file__).resolve().parents[2] / "problems" / "segmentation-2groups.toml"


@pytest.fixture(scope="module")
def two_groups():
    """2 groups, mixed axes, a 180 deg and a negative turn, statics 60-140 s, handling between the groups."""
    return simulate(load_problem(PROBLEM), seed=2)


def test_segments_letters_and_the_calibration_match_the_true_description(two_groups):
    rec = two_groups.recording
    found, notes = segment_recording(rec.time, rec.gyro, rec.accel, rec.rate_hz, rec.site, "found")
    assert len(found.segments) == len(rec.segments) and found.group_ids == [1, 2]
    for true, seg in zip(rec.segments, found.segments):
        assert (seg.kind, seg.group, seg.orientation, seg.axis, seg.angle_deg) == \
               (true.kind, true.group, true.orientation, true.axis, true.angle_deg)
        assert abs(seg.start - true.start) < 0.2 and abs(seg.end - true.end) < 0.2, (seg.describe(), true.describe())
    assert any("handling" in note for note in notes)
    a, b = calibrate_nlp(rec).parameters, calibrate_nlp(found).parameters
    assert np.abs((a.values - b.values) / a.sigma).max() < 0.1


def test_segment_command_writes_a_description_that_validates(two_groups, tmp_path, capsys):
    path = write_recording(two_groups.recording, tmp_path / "data" / "r.toml")
    out = tmp_path / "found" / "r-found.toml"
    assert main(["segment", str(path.with_suffix(".csv")), "--rate", "100", "--latitude", "37.5",
                 "--out", str(out)]) == 0
    rec = read_recording(out)
    assert len(rec.segments) == 16 and rec.segments[5].axis == "+Y" and rec.segments[5].angle_deg == 180.0
    assert "wrote" in capsys.readouterr().out


def test_approximate_times_are_trimmed_and_motion_inside_a_static_is_refused(two_groups):
    rec = two_groups.recording
    segs = list(rec.segments)
    # static 3 said to last 2 s into the next rotation (a log's approximate time)
    segs[2] = dataclasses.replace(segs[2], end=segs[2].end + 2.0)
    segs[3] = dataclasses.replace(segs[3], start=segs[3].start + 2.0)
    fixed = refine(dataclasses.replace(rec, segments=segs))
    assert abs(fixed.segments[2].end - rec.segments[2].end) < 0.2 and fixed.segments[3].start == fixed.segments[2].end
    assert any("trimmed" in w and "segment 3" in w for w in fixed.warnings)
    # a static segment over a whole rotation
    segs = list(rec.segments)
    merged = dataclasses.replace(segs[2], end=segs[4].end)
    bad = dataclasses.replace(rec, segments=segs[:2] + [merged] + segs[5:])
    bad.segments = [dataclasses.replace(s, number=i + 1) for i, s in enumerate(bad.segments)]
    with pytest.raises(InputError, match=r"segment 3 .* holds motion inside it"):
        refine(bad)


def test_a_swaying_base_and_integer_pulses_do_not_confuse_the_segmentation():
    """The sway spoils the Earth rate the gyro pulses are sized by; the turns size them again."""
    problem = load_problem(PROBLEM).with_changes(sway_amplitude_arcsec=(20.0, 120.0), quantize=True)
    rec = simulate(problem, seed=4).recording
    found, _ = segment_recording(rec.time, rec.gyro, rec.accel, rec.rate_hz, rec.site, "found")
    assert [(s.kind, s.orientation, s.axis, s.angle_deg) for s in found.segments] == \
           [(s.kind, s.orientation, s.axis, s.angle_deg) for s in rec.segments]
    assert max(abs(a.start - b.start) for a, b in zip(found.segments, rec.segments)) < 0.2
