"""Segment edges next to slow handling, trimming in the API, and `segment` never raising (issue 16)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from casadi_sins.calibrate import calibrate
from casadi_sins.cli import main
from casadi_sins.core.earth import EARTH_RATE
from casadi_sins.core.errors import InputError
from casadi_sins.core.orientation import orientation_to_dcm
from casadi_sins.data.description import read_recording, write_recording
from casadi_sins.data.problem import GroupPlan, load_problem
from casadi_sins.data.recording import Recording, validate_schedule
from casadi_sins.data.segmentation import detect, refine, segment_recording
from casadi_sins.model.output import output_model
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.sim import simulate, write_simulation
from casadi_sins.sim.motion import MotionPiece
from casadi_sins.sim.simulate import true_increments

PROBLEMS = Path(__file__).resolve().parents[2] / "problems"
PAPER = dict(accel_noise_ug=50.0, gyro_noise_deg_h=0.01, accel_vrw_ug_rthz=0.0, gyro_arw_deg_rth=0.0)
NOISES = {"paper": PAPER, "navigation-grade": {}, "integer-pulses": {"quantize": True}}


@pytest.fixture(scope="module")
def handling():
    """Two groups with 60 s of slow handling by hand between them (navigation-grade noise)."""
    return simulate(load_problem(PROBLEMS / "segmentation-handling.toml"), seed=1).recording


@pytest.fixture(scope="module")
def handling_reference(handling):
    """The calibration with the true segments."""
    return calibrate(handling)


def found_segments(rec: Recording) -> Recording:
    return segment_recording(rec.time, rec.gyro, rec.accel, rec.rate_hz, rec.site, "found")[0]


def schedule(rec: Recording) -> list:
    return [(s.kind, s.group, s.orientation, s.axis, s.angle_deg) for s in rec.segments]


def inward_errors(true: Recording, found: Recording, beside: str | None = None) -> list[float]:
    """The error (s) of every static edge that meets motion, positive when the found static is shorter; only
    those beside ``"rotation"`` or ``"handling"`` when given."""
    out = []
    for i, (t, f) in enumerate(zip(true.segments, found.segments)):
        if not t.is_static:
            continue
        group = true.group_segments(t.group)
        if i > 0:
            out.append(("rotation" if t is not group[0] else "handling", f.start - t.start))
        if i < len(true.segments) - 1:
            out.append(("rotation" if t is not group[-1] else "handling", t.end - f.end))
    return [e for b, e in out if beside in (None, b)]


@pytest.mark.parametrize("noise", NOISES)
@pytest.mark.parametrize("name", ["segmentation-2groups", "segmentation-handling"])
def test_every_static_edge_is_found_within_0_1_s_on_the_safe_side(name, noise):
    rec = simulate(load_problem(PROBLEMS / f"{name}.toml").with_changes(**NOISES[noise]), seed=5).recording
    found = found_segments(rec)
    assert schedule(found) == schedule(rec)
    errors = np.array(inward_errors(rec, found))
    assert len(errors) == 16 and errors.min() >= 0.0 and errors.max() < 0.1, errors
    assert max(inward_errors(rec, found, "rotation")) < 0.011  # the paper's turns start sharply: to the sample


def test_found_segments_calibrate_as_the_true_ones_with_no_sway_warning(handling, handling_reference):
    result = calibrate(found_segments(handling))
    z = (result.parameters.values - handling_reference.parameters.values) / handling_reference.parameters.sigma
    assert np.abs(z).max() < 0.1
    assert not any("sway" in w or "trimmed" in w for w in result.warnings), result.warnings


def test_times_running_into_handling_or_a_turn_are_trimmed_as_such_in_the_api(handling, handling_reference):
    segs = list(handling.segments)  # static 3 ends 3 s into a turn; the statics beside the handling run 0.25 s into it
    segs[2], segs[3] = (dataclasses.replace(segs[2], end=segs[2].end + 3.0),
                        dataclasses.replace(segs[3], start=segs[3].start + 3.0))
    segs[8] = dataclasses.replace(segs[8], end=segs[8].end + 0.25)
    segs[9] = dataclasses.replace(segs[9], start=segs[9].start - 0.25)
    stated = dataclasses.replace(handling, segments=segs)
    fixed = refine(stated)
    errors = np.array(inward_errors(handling, fixed))
    assert errors.min() >= 0.0 and errors.max() < 0.1 and fixed.segments[2].end == handling.segments[2].end
    trims = [w for w in fixed.warnings if "trimmed" in w]
    assert [w.split(" (")[0] for w in trims] == ["segment 3", "segment 9", "segment 10"]
    assert all("still moving" in w and "edge" in w for w in trims)
    result = calibrate(stated)  # the API trims too: the warnings name the trimming, never a sway
    assert [w for w in result.warnings if "trimmed" in w] == trims
    assert not any("sway" in w for w in result.warnings)
    z = (result.parameters.values - handling_reference.parameters.values) / handling_reference.parameters.sigma
    assert np.abs(z).max() < 0.1


def test_true_descriptions_are_left_alone(handling, kang_sim):
    assert refine(kang_sim.recording) is kang_sim.recording  # the paper's recording: the same results as before
    assert refine(handling) is handling
    quantized = simulate(load_problem(PROBLEMS / "segmentation-2groups.toml").with_changes(quantize=True), seed=3)
    assert refine(quantized.recording) is quantized.recording


def test_groups_joined_without_handling_are_split_where_the_attitude_jumps(kang_problem):
    rec = simulate(kang_problem, seed=7).recording
    found, notes = segment_recording(rec.time, rec.gyro, rec.accel, rec.rate_hz, rec.site, "found")
    assert schedule(found) == schedule(rec)
    assert [s.start for s in found.segments if s.is_static and s is found.group_segments(s.group)[0]] == \
           [0.0, 430.0, 860.0]
    assert sum("jumps with no motion" in n for n in notes) == 2
    assert max(abs(a.start - b.start) + abs(a.end - b.end) for a, b in zip(found.segments, rec.segments)) < 1e-6


def test_a_jump_about_the_vertical_is_seen_in_the_earth_rate(kang_problem):
    """Group 1 ends NDW, group 2 starts EDN: gravity stays, only the heading jumps (by 90 deg)."""
    problem = dataclasses.replace(kang_problem, groups=(GroupPlan("NUE", ("+X", "+X")), GroupPlan("EDN", ("+Z", "+Z"))))
    rec = simulate(problem.with_changes(quantize=True), seed=1).recording
    found, notes = segment_recording(rec.time, rec.gyro, rec.accel, rec.rate_hz, rec.site, "found")
    assert schedule(found) == schedule(rec) and found.group_segments(2)[0].start == 320.0
    assert notes == ["320.00 s: the attitude jumps with no motion (groups joined without handling): a new group starts"]


def test_segment_finds_the_schedule_of_every_problem_and_the_command_of_the_paper_s(tmp_path, capsys):
    for path in sorted(PROBLEMS.glob("*.toml")):
        if 'format = "casadi-sins-problem/1"' not in path.read_text():
            continue  # error sheets of the modulation analysis live beside the problems
        problem = load_problem(path)
        if problem.duration > 3600.0:  # the 10 h file: its schedule with 60 s statics
            problem = dataclasses.replace(problem, timing=dataclasses.replace(problem.timing, static_s=60.0))
        rec = simulate(problem, seed=7).recording
        assert schedule(found_segments(rec)) == schedule(rec), path.name
    # the command on the default experiment's own recording (it crashed on the groups joined without handling)
    toml = write_simulation(simulate(load_problem(PROBLEMS / "kang2013.toml"), seed=7), tmp_path)
    out = tmp_path / "seg.toml"
    assert main(["segment", str(toml.with_suffix(".csv")), "--rate", "100", "--latitude", "37.5", "--out",
                 str(out)]) == 0
    captured = capsys.readouterr()
    # no error: on standard error only its notes (the groups joined without handling), never a failure
    assert all(line.startswith("note: ") for line in captured.err.splitlines())
    assert "21 segments in 3 groups" in captured.out
    assert schedule(read_recording(out)) == schedule(read_recording(toml))


def turns_of_45_deg(problem) -> Recording:
    """Four 60 s rests joined by turns of 45 deg about a level axis."""
    dt = 1.0 / problem.rate_hz
    attitude, pieces, t = orientation_to_dcm("NUE"), [], 0.0
    for k in range(4):
        pieces.append(MotionPiece(t, t + 60.0, attitude))
        if k < 3:
            pieces.append(MotionPiece(t + 60.0, t + 70.0, attitude, np.array([1.0, 0.0, 0.0]), np.radians(45.0)))
            attitude = pieces[-1].end_attitude
        t += 70.0
    n = int(round((t - 10.0) / dt))
    dtheta, dv = true_increments(pieces, n, dt, problem.site.earth_rate, problem.site.g)
    rng = np.random.default_rng(1)
    gyro, accel = output_model(dtheta + rng.standard_normal(dtheta.shape) * 5e-10,
                               dv + rng.standard_normal(dv.shape) * 5e-6, problem.truth.core, dt)
    first = dataclasses.replace(problem.segments()[0], start=0.0, end=60.0)
    return Recording("turns45", problem.site, problem.rate_hz, [first], np.round(np.arange(1, n + 1) * dt, 9),
                     gyro, accel)


def unusable(kind: str, problem, folder: Path) -> Path:
    """A recording with no usable schedule, written; the path of its data."""
    if kind == "rest only":
        changed = dataclasses.replace(problem, groups=(dataclasses.replace(problem.groups[0], rotations=()),))
    elif kind == "rests too short":
        changed = dataclasses.replace(problem, timing=dataclasses.replace(problem.timing, static_s=8.0, rotation_s=4.0))
    elif kind == "gyro bias 470x the Earth rate":
        values = dict(problem.truth.as_dict(), **{f"gyro_bias_{a}": 470.0 * EARTH_RATE / np.sqrt(3) for a in "xyz"})
        changed = dataclasses.replace(problem, truth=ParameterSet.from_dict(values))
    else:
        rec = turns_of_45_deg(problem)
        if kind == "noise only":
            rng = np.random.default_rng(2)
            rec = dataclasses.replace(rec, gyro=rng.standard_normal(rec.gyro.shape) * 3.0,
                                      accel=rng.standard_normal(rec.accel.shape) * 3.0)
        return write_recording(rec, folder / "rec.toml").with_suffix(".csv")
    return write_simulation(simulate(dataclasses.replace(changed, name="rec"), seed=1), folder).with_suffix(".csv")


@pytest.mark.parametrize("kind, reason", [
    ("rest only", r"no motion in the gyros"),
    ("noise only", r"no motion in the gyros"),
    ("turns of 45 deg", r"no turns of a multiple of 90 deg about one body axis \(gravity turned by 4[45]\.\d, 4[45]"),
])
def test_segment_says_why_in_one_line_when_there_is_no_schedule(kind, reason, kang_problem, tmp_path, capsys):
    data = unusable(kind, kang_problem, tmp_path)
    status = main(["segment", str(data), "--rate", "100", "--latitude", "37.5", "--out", str(tmp_path / "f.toml")])
    err = capsys.readouterr().err
    assert status == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith(f"casadi-sins segment: error: {data}: ")
    assert __import__("re").search(reason, err), err
    assert not (tmp_path / "f.toml").exists()


def test_bad_arguments_and_empty_schedules_are_input_errors(handling):
    with pytest.raises(InputError, match="positive number of seconds"):
        detect(handling.time, handling.gyro, handling.accel, 100.0, handling.site, min_static_s=float("nan"))
    with pytest.raises(InputError, match="no segments"):
        validate_schedule(dataclasses.replace(handling, segments=[]))


@pytest.mark.parametrize("kind", ["rests too short", "gyro bias 470x the Earth rate"])
def test_what_a_turntable_search_refuses_is_segmented_as_handled_by_default(kind, kang_problem, tmp_path, capsys):
    """Rests of 8 s, or gyros that do not resolve the Earth rate: with the defaults, the session is segmented
    as one turned by hand (a note says so): rests at any orientation and free moves; the description is valid
    and keeps every position of the paper (the jump between its groups, a simulation's, ends a group)."""
    data = unusable(kind, kang_problem, tmp_path)
    out = tmp_path / "f.toml"
    assert main(["segment", str(data), "--rate", "100", "--latitude", "37.5", "--out", str(out)]) == 0
    assert "segmented as a session turned by hand" in capsys.readouterr().err  # a note: standard error
    rec = read_recording(out)
    assert len(rec.static_segments) >= 12 and all(s.is_free for s in rec.segments)


def test_the_advice_of_a_rests_refusal_works(kang_problem, tmp_path, capsys):
    """A stated shortest rest keeps the turntable search, whose refusal names the option; following it works."""
    data = unusable("rests too short", kang_problem, tmp_path)
    args = ["segment", str(data), "--rate", "100", "--latitude", "37.5", "--out", str(tmp_path / "f.toml")]
    assert main(args + ["--min-static-s", "20"]) == 2
    err = capsys.readouterr().err
    assert "the longest lasts 8 s: rests too short" in err and "--min-static-s sets the shortest" in err
    assert main(args + ["--min-static-s", "7"]) == 0 and len(read_recording(tmp_path / "f.toml").static_segments) == 12


def test_the_advice_of_a_turntable_refusal_of_a_mems_bias_works(kang_problem, tmp_path, capsys):
    data = unusable("gyro bias 470x the Earth rate", kang_problem, tmp_path)
    args = ["segment", str(data), "--rate", "100", "--latitude", "37.5", "--out", str(tmp_path / "f.toml")]
    assert main(args + ["--min-static-s", "20"]) == 2
    assert "without --min-static-s, segment also tries it as a session turned by hand" in capsys.readouterr().err
    assert main(args) == 0
