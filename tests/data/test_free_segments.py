"""Sessions by hand in the recording format: rests at any orientation, free moves, no [[segments]] at all."""

import re

import pytest

from casadi_sins.cli import main
from casadi_sins.core.errors import InputError
from casadi_sins.data.description import read_recording, write_recording
from casadi_sins.data.refine import refine


@pytest.fixture(scope="module")
def written(hand_sim, tmp_path_factory):
    return write_recording(hand_sim.recording, tmp_path_factory.mktemp("hand") / "hand.toml")


def test_free_segments_are_written_without_letters_or_angles_and_read_back(written, hand_sim):
    text = written.read_text()
    assert "orientation" not in text and "axis" not in text and "angle_deg" not in text
    back = read_recording(written)
    assert [(s.kind, s.start, s.end, s.is_free) for s in back.segments] == \
           [(s.kind, s.start, s.end, True) for s in hand_sim.recording.segments]
    assert back.segments[0].describe() == "segment 1 (group 1, static free, 0-20 s)"
    assert back.segments[1].what == "free move"


def with_first(written, tmp_path, line: str, added: str):
    """The written description with ``added`` after the first ``line``, beside the same samples."""
    text = written.read_text()
    at = text.index(line) + len(line)
    path = tmp_path / "edited.toml"
    path.write_text((text[:at] + "\n" + added + text[at:]).replace('data = "hand.csv"',
                                                                   f'data = "{written.with_suffix(".csv")}"'))
    return path


def test_free_may_be_spelled_and_letters_mix_with_free_rests(written, tmp_path):
    path = with_first(written, tmp_path, 'kind = "static"', 'orientation = "free"')
    assert read_recording(path).segments[0].orientation is None


def test_a_rotation_with_an_axis_but_no_angle_is_refused_in_one_line(written, tmp_path):
    path = with_first(written, tmp_path, 'kind = "rotation"', 'axis = "+Z"')
    with pytest.raises(InputError, match=r"segment 2: a rotation gives both 'axis' and 'angle_deg', or neither"):
        read_recording(path)


def test_a_description_without_segments_is_segmented_when_read(written, tmp_path, capsys):
    text = written.read_text()
    head = text[:text.index("[[segments]]")]
    path = tmp_path / "bare.toml"
    path.write_text(head.replace('data = "hand.csv"', f'data = "{written.with_suffix(".csv")}"'))
    rec = read_recording(path)
    assert len(rec.static_segments) == 14 and all(s.is_free for s in rec.segments)
    assert rec.notes[0].endswith("no [[segments]]: the schedule was found from the samples") and not rec.warnings
    assert main(["validate", str(path)]) == 0
    captured = capsys.readouterr()  # the note is a diagnostic (standard error), the schedule a result
    assert "note:" in captured.err and "14 rests at any orientation joined by 13 free moves" in captured.out


def test_segment_takes_a_description_without_segments(written, tmp_path, capsys):
    text = written.read_text()
    bare = tmp_path / "bare.toml"
    bare.write_text(text[:text.index("[[segments]]")].replace('data = "hand.csv"',
                                                              f'data = "{written.with_suffix(".csv")}"')
                    .replace("[site]", "[site]\ngravity_mps2 = 9.81"))
    out = tmp_path / "found.toml"
    assert main(["segment", str(bare), "--out", str(out)]) == 0
    found = read_recording(out)
    assert found.site.gravity == 9.81 and found.rate_hz == 100.0 and len(found.static_segments) == 14
    assert refine(found) is found  # written as the calibration's check leaves it
    assert main(["segment", str(written.with_suffix(".csv")), "--out", str(out)]) == 2
    assert re.search(r"a CSV need --rate and --latitude", capsys.readouterr().err)
