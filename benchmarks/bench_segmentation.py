"""Segment edges next to slow handling, and `segment` never raising (issue 16).

Run: ``OMP_NUM_THREADS=1 python benchmarks/bench_segmentation.py [--seeds 3] [--out results]`` (about 4 min
on 2 cores).  Writes ``results/segmentation-edges.csv`` (every case and seed) and
``results/segmentation-edges.md`` (the summary per case, and what ``casadi-sins segment`` says on every
problem's recording and on recordings with no usable schedule).

Per case and seed the recording is simulated, segmented from its signals alone
(:func:`data.segmentation.segment_recording`) and compared with the true description:

* the schedule (kinds, groups, letters, axes, angles) must be the true one;
* every static edge's error, *inward* (positive: the found static is shorter, on the safe side;
  negative: it runs into the motion), split into edges beside a rotation and beside handling
  between groups (the paper's layout has none: its groups meet with no motion at all);
* the calibration (:func:`calibrate.calibrate`, NLP) with the found segments against the one with
  the true segments, the largest difference in units of the latter's sigma, and its warnings
  (sway, trimming); for scale, the same difference when every true static edge beside motion is
  moved one sample inward (a description as right as the true one: which samples enter the static
  means and where the observations fall move the estimate by about a tenth of sigma, most with
  integer pulses).

Cases: ``segmentation-2groups`` (25 s handling, one turn), ``segmentation-handling`` (60 s of slow
handling by hand: slerps through random attitudes, minimum-jerk legs, about 15 deg/s peak) and the
paper's 12 positions with that handling between its groups, each with the paper's noise (white 50 ug
and 0.01 deg/h per sample), navigation-grade noise (VRW 15 ug/sqrt(Hz), ARW 0.002 deg/sqrt(h)), and
navigation-grade noise with integer pulses; and the paper's own recording (no handling).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from casadi_sins.calibrate import calibrate
from casadi_sins.cli import main
from casadi_sins.core.earth import EARTH_RATE
from casadi_sins.core.orientation import orientation_to_dcm
from casadi_sins.data.description import write_recording
from casadi_sins.data.problem import load_problem
from casadi_sins.data.recording import Recording
from casadi_sins.data.segmentation import segment_recording
from casadi_sins.model.output import output_model
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.report.tables import markdown_table
from casadi_sins.sim import simulate, write_simulation
from casadi_sins.sim.motion import MotionPiece
from casadi_sins.sim.simulate import true_increments

ROOT = Path(__file__).resolve().parents[1]
PROBLEMS = ROOT / "problems"
PAPER = dict(accel_noise_ug=50.0, gyro_noise_deg_h=0.01, accel_vrw_ug_rthz=0.0, gyro_arw_deg_rth=0.0)
NAVIGATION = dict(accel_noise_ug=0.0, gyro_noise_deg_h=0.0, accel_vrw_ug_rthz=15.0, gyro_arw_deg_rth=0.002)
NOISES = {"paper": PAPER, "navigation-grade": NAVIGATION, "navigation-grade, integer pulses": dict(NAVIGATION,
                                                                                                    quantize=True)}


def kang_with_handling():
    """The paper's layout with 60 s of slow handling by hand between its groups."""
    kang = load_problem(PROBLEMS / "kang2013.toml")
    timing = dataclasses.replace(kang.timing, gap_s=60.0, handling="minimum-jerk")
    return dataclasses.replace(kang, timing=timing, name="kang2013-handling")


def cases():
    """``(label, problem)`` of every case."""
    out = []
    for problem in (load_problem(PROBLEMS / "segmentation-2groups.toml"),
                    load_problem(PROBLEMS / "segmentation-handling.toml"), kang_with_handling()):
        out += [(f"{problem.name}, {noise}", problem.with_changes(**changes)) for noise, changes in NOISES.items()]
    out.append(("kang2013 (no handling), paper", load_problem(PROBLEMS / "kang2013.toml")))
    return out


def edge_errors(true: Recording, found: Recording) -> list[tuple[str, float]]:
    """``(beside, inward error s)`` of every static edge that meets motion (not the recording's ends)."""
    out = []
    last_group = true.group_ids[-1]
    for i, (t, f) in enumerate(zip(true.segments, found.segments)):
        if not t.is_static:
            continue
        group = true.group_segments(t.group)
        if i > 0:
            out.append(("rotation" if group[0] is not t else "handling", f.start - t.start))
        if i < len(true.segments) - 1:
            out.append(("rotation" if group[-1] is not t or t.group == last_group else "handling", t.end - f.end))
    return out


def one_sample_inward(rec: Recording) -> Recording:
    """The true description with every static edge that meets motion moved one sample inward (the rotations
    grow to meet them)."""
    segments = list(rec.segments)
    last = len(segments) - 1
    for i, seg in enumerate(segments):
        if seg.is_static:
            segments[i] = dataclasses.replace(seg, start=seg.start + (rec.dt if i > 0 else 0.0),
                                              end=seg.end - (rec.dt if i < last else 0.0))
    for i, seg in enumerate(segments):
        if not seg.is_static:
            segments[i] = dataclasses.replace(seg, start=segments[i - 1].end, end=segments[i + 1].start)
    return dataclasses.replace(rec, segments=segments)


def run_case(label: str, problem, seed: int) -> dict:
    """Segment one simulated recording and calibrate it with the true and the found segments."""
    rec = simulate(problem, seed=seed).recording
    t0 = time.perf_counter()
    found, notes = segment_recording(rec.time, rec.gyro, rec.accel, rec.rate_hz, rec.site, "found")
    segment_s = time.perf_counter() - t0
    key = [(s.kind, s.group, s.orientation, s.axis, s.angle_deg) for s in rec.segments]
    same = key == [(s.kind, s.group, s.orientation, s.axis, s.angle_deg) for s in found.segments]
    row = {"case": label, "seed": seed, "schedule matches": same, "segment s": segment_s}
    if not same:
        return row
    errors = edge_errors(rec, found)
    for beside in ("rotation", "handling"):
        values = np.array([e for b, e in errors if b == beside])
        row[f"{beside} edges"] = len(values)
        row[f"{beside} max |error| s"] = float(np.abs(values).max()) if len(values) else np.nan
    inward = np.array([e for _, e in errors])
    row["inward min s"], row["inward max s"] = float(inward.min()), float(inward.max())
    reference, result = calibrate(rec), calibrate(found)
    z = (result.parameters.values - reference.parameters.values) / reference.parameters.sigma
    row["calibration max |diff|/sigma"] = float(np.abs(z).max())
    row["largest in"] = reference.parameters.names[int(np.argmax(np.abs(z)))]
    nudged = calibrate(one_sample_inward(rec)).parameters.values
    row["one sample inward: max |diff|/sigma"] = float(np.abs((nudged - reference.parameters.values)
                                                             / reference.parameters.sigma).max())
    row["sway warnings"] = sum("sway" in w for w in result.warnings)
    row["trim warnings"] = sum("trimmed" in w for w in result.warnings)
    row["notes"] = len(notes)
    return row


def summary(rows: pd.DataFrame) -> pd.DataFrame:
    """One line per case: the worst over its seeds."""
    out = []
    for label, part in rows.groupby("case", sort=False):
        ok = part[part["schedule matches"]]
        out.append({"case": label, "seeds": len(part), "schedule found": f"{len(ok)}/{len(part)}",
                    "rotation edges: max abs error (s)": ok["rotation max |error| s"].max(),
                    "handling edges: max abs error (s)": ok["handling max |error| s"].max(),
                    "inward error range (s)": f"{ok['inward min s'].min():+.2f} .. {ok['inward max s'].max():+.2f}",
                    "calibration: max abs diff (sigma)": ok["calibration max |diff|/sigma"].max(),
                    "for scale, true edges one sample inward (sigma)": ok["one sample inward: max |diff|/sigma"].max(),
                    "sway warnings": int(ok["sway warnings"].sum()), "trim warnings": int(ok["trim warnings"].sum())})
    return pd.DataFrame(out)


def unusable_recordings(folder: Path) -> dict[str, Path]:
    """Recordings with no usable schedule: rest only, rests of 8 s, turns of 45 deg, a gyro bias of 470 (and
    more) times the Earth rate, pure noise; their descriptions' paths."""
    kang = load_problem(PROBLEMS / "kang2013.toml")
    out = {}
    rest = dataclasses.replace(kang, name="rest-only", groups=(dataclasses.replace(kang.groups[0], rotations=()),))
    out["rest only (one position, no turn)"] = write_simulation(simulate(rest, seed=1), folder / "rest")
    short = dataclasses.replace(kang, name="short-rests",
                                timing=dataclasses.replace(kang.timing, static_s=8.0, rotation_s=4.0))
    out["rests of 8 s"] = write_simulation(simulate(short, seed=1), folder / "short")
    values = kang.truth.as_dict()
    values.update({f"gyro_bias_{a}": 470.0 * EARTH_RATE for a in "xyz"})
    mems = dataclasses.replace(kang, name="mems-bias", truth=ParameterSet.from_dict(values))
    out["gyro bias 470x the Earth rate per axis"] = write_simulation(simulate(mems, seed=1), folder / "mems")
    out["turns of 45 deg"] = write_recording(turns_45(kang), folder / "turns45" / "turns45.toml")
    rng = np.random.default_rng(0)
    base = turns_45(kang)
    noise = dataclasses.replace(base, name="noise", gyro=rng.standard_normal(base.gyro.shape),
                                accel=rng.standard_normal(base.accel.shape))
    out["pure noise"] = write_recording(noise, folder / "noise" / "noise.toml")
    return out


def turns_45(problem) -> Recording:
    """Four 60 s rests joined by 10 s turns of 45 deg about a level axis (north), with the problem's truth and
    the paper's noise."""
    dt = 1.0 / problem.rate_hz
    attitude, pieces, t = orientation_to_dcm("NUE"), [], 0.0
    for k in range(4):
        pieces.append(MotionPiece(t, t + 60.0, attitude))
        t += 60.0
        if k < 3:
            turn = MotionPiece(t, t + 10.0, attitude, np.array([1.0, 0.0, 0.0]), np.radians(45.0))
            pieces.append(turn)
            attitude, t = turn.end_attitude, t + 10.0
    n = int(round(t / dt))
    dtheta, dv = true_increments(pieces, n, dt, problem.site.earth_rate, problem.site.g)
    rng = np.random.default_rng(1)
    dtheta += rng.standard_normal(dtheta.shape) * np.radians(0.01 / 3600.0) * dt
    dv += rng.standard_normal(dv.shape) * 50e-6 * 9.80665 * dt
    gyro, accel = output_model(dtheta, dv, problem.truth.core, dt)
    segments = simulate(problem, seed=1, noise=False).recording.segments[:1]
    segments = [dataclasses.replace(segments[0], start=0.0, end=60.0)]
    return Recording("turns45", problem.site, problem.rate_hz, segments, np.round(np.arange(1, n + 1) * dt, 9), gyro,
                     accel)


def segment_outcomes(folder: Path) -> pd.DataFrame:
    """What ``casadi-sins segment`` says on every problem's recording and on the unusable ones."""
    recordings = {}
    for path in sorted(PROBLEMS.glob("*.toml")):
        if 'format = "casadi-sins-problem/1"' not in path.read_text():
            continue  # error and tolerance sheets live beside the problems
        problem = load_problem(path)
        if problem.duration > 3600.0:  # the 10 h file: its schedule with 60 s statics
            problem = dataclasses.replace(problem, timing=dataclasses.replace(problem.timing, static_s=60.0),
                                          name=f"{problem.name}-shortened")
        recordings[f"problems/{path.name} ({problem.name})"] = write_simulation(simulate(problem, seed=3),
                                                                               folder / problem.name)
    recordings["kang2013 with 60 s of slow handling"] = write_simulation(simulate(kang_with_handling(), seed=3),
                                                                        folder / "kang-handling")
    recordings.update(unusable_recordings(folder))
    rows = []
    for label, toml in recordings.items():
        rate = f"{_stated_rate(toml):g}"
        stdout, stderr = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            status = main(["segment", str(Path(toml).with_suffix(".csv")), "--rate", rate, "--latitude", "37.5",
                           "--out", str(folder / f"{Path(toml).stem}-found.toml")])
        said = stderr.getvalue().strip() or stdout.getvalue().strip().splitlines()[-1]
        rows.append({"recording": label, "exit status": status, "lines on stderr": len(stderr.getvalue().splitlines()),
                     "traceback": "Traceback" in stderr.getvalue(),
                     "says": said.replace(str(folder) + "/", "")})
    return pd.DataFrame(rows)


def _stated_rate(toml: Path) -> float:
    """The sample rate a written description states."""
    for line in Path(toml).read_text().splitlines():
        if line.strip().startswith("rate_hz"):
            return float(line.split("=")[1])
    raise ValueError(f"{toml}: no rate_hz")


def main_benchmark() -> None:
    """Run every case, print and write the tables."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--out", default=str(ROOT / "results"))
    args = parser.parse_args()
    t0 = time.perf_counter()
    rows = []
    for label, problem in cases():
        for seed in range(1, args.seeds + 1):
            rows.append(run_case(label, problem, seed))
            r = dict({"largest in": "", "sway warnings": ""}, **rows[-1])
            get = lambda key: r.get(key, np.nan)  # noqa: E731
            print(f"{label}, seed {seed}: schedule {'ok' if r['schedule matches'] else 'WRONG'}; edges max |error| "
                  f"rotation {get('rotation max |error| s'):.3f} s, handling {get('handling max |error| s'):.3f} s, "
                  f"inward {get('inward min s'):+.3f}..{get('inward max s'):+.3f} s; calibration "
                  f"{get('calibration max |diff|/sigma'):.3f} sigma ({r['largest in']}); sway warnings "
                  f"{r['sway warnings']}", flush=True)
    frame = pd.DataFrame(rows)
    table = summary(frame)
    with tempfile.TemporaryDirectory() as tmp:
        outcomes = segment_outcomes(Path(tmp))
    print(table.to_string(index=False))
    print(outcomes.to_string(index=False))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    frame.to_csv(out / "segmentation-edges.csv", index=False, float_format="%.6g")
    text = ["# Segment edges next to slow handling (issue 16)", "",
            f"`benchmarks/bench_segmentation.py --seeds {args.seeds}`, {time.perf_counter() - t0:.0f} s. Errors of the "
            "static edges found by `segment` against the simulation's true ones: *inward* is positive when the "
            "found static is shorter (the safe side), negative when it runs into the motion. The calibration "
            "(NLP) with the found segments against the one with the true segments: the largest difference over "
            "the 21 parameters in units of sigma; for scale, the same with the true segments, every static edge "
            "beside motion moved one sample inward (as right a description: a tenth of sigma is the scatter of "
            "which samples and observation times a description picks, most with integer pulses). Every seed in "
            "`segmentation-edges.csv`.", "",
            markdown_table(table, "%.3f"), "",
            "## `casadi-sins segment` on every problem and on recordings with no usable schedule", "",
            "A description (exit 0) or one line saying why not (exit 2), never a traceback.", "",
            markdown_table(outcomes, "%.3f"), ""]
    (out / "segmentation-edges.md").write_text("\n".join(text))
    print(f"wrote {out}/segmentation-edges.{{csv,md}}")


if __name__ == "__main__":
    main_benchmark()
