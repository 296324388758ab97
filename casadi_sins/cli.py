"""Command line: argument parsing only; the work is done by the library modules."""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from . import __version__


class CliError(Exception):
    """A failure to report to the user in one line, with a non-zero exit status."""


def _known_errors():
    from .io import OutputError
    from .noise import NoiseSpecError
    from .parameters import ParameterTableError
    from .problem import ProblemError
    from .recording import RecordingError

    return (RecordingError, ParameterTableError, ProblemError, NoiseSpecError, OutputError, CliError)


# --------------------------------------------------------------------------- commands
def cmd_simulate(args) -> int:
    from .problem import load_problem
    from .simulate import simulate, write_simulation

    problem = load_problem(args.problem)
    changes = {}
    if args.start_attitude_deg is not None:
        changes["start_attitude_deg"] = args.start_attitude_deg
    if args.quantize:
        changes["quantize"] = True
    if changes:
        problem = problem.with_changes(**changes)
    t0 = time.perf_counter()
    sim = simulate(problem, seed=args.seed, noise=not args.no_noise, name=args.name)
    path = write_simulation(sim, args.out)
    print(f"wrote {path} (+ .csv, .truth.csv): {len(sim.recording.time)} samples, "
          f"{time.perf_counter() - t0:.1f} s")
    return 0


def cmd_validate(args) -> int:
    from .recording import read_recording
    from .report import recording_summary

    rec = read_recording(args.recording)
    print(recording_summary(rec))
    print("valid sins-recording/1")
    return 0


def cmd_rough(args) -> int:
    from .initial import rough_parameters
    from .parameters import write_table
    from .recording import read_recording

    rec = read_recording(args.recording)
    path = write_table(args.out, rough_parameters(rec))
    print(f"wrote {path}")
    return 0


def cmd_navigate(args) -> int:
    from .initial import rough_parameters
    from .parameters import read_table
    from .recording import read_recording
    from .report import plot_navigation, static_velocity_table, write_frame
    from .strapdown import navigate

    rec = read_recording(args.recording)
    runs = {}
    if args.params:
        for path in args.params:
            runs[Path(path).stem] = read_table(path).values
    else:
        runs["rough initial values"] = rough_parameters(rec).values
    out = Path(args.out)
    navs = {}
    for label, values in runs.items():
        t0 = time.perf_counter()
        navs[label] = navigate(rec, values)
        print(f"navigated {rec.name} with {label} in {time.perf_counter() - t0:.2f} s")
        table = static_velocity_table(rec, navs[label])
        write_frame(table, out / f"{rec.file_stem}-{_slug(label)}-static", f"{rec.name}: static segments, {label}")
        print(table.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    plot = plot_navigation(rec, navs, out / f"{rec.file_stem}-velocity.png")
    print(f"wrote {plot}")
    return 0


def export_files(params, table_path, formats, metadata: dict) -> dict:
    """``{path: content}`` of the exports beside a table ``NAME.csv``: ``NAME.compensation.json`` ..."""
    from .export import EXPORTS

    stem = Path(table_path).with_suffix("")
    meta = {k: v for k, v in metadata.items() if v is not None}
    return {stem.with_name(f"{stem.name}.{EXPORTS[f][0]}"): EXPORTS[f][1](params, meta).encode() for f in formats}


def cmd_segment(args) -> int:
    from .io import atomic_write_text
    from .recording import RecordingError, Site, _read_samples, description_toml
    from .report import recording_summary
    from .segment import segment_recording

    data = Path(args.data)
    if not -90.0 <= args.latitude <= 90.0 or not -500.0 <= args.height <= 10000.0:
        raise CliError("--latitude must be within -90..90 deg and --height within -500..10000 m")
    time_, pulses = _read_samples(data.resolve(), args.rate)
    site = Site(np.radians(args.latitude), args.height, args.gravity)
    name = args.name or Path(args.out).stem
    try:
        rec, notes = segment_recording(time_, pulses[:, :3], pulses[:, 3:], args.rate, site, name, args.min_static_s)
    except RecordingError as exc:
        raise CliError(f"{data}: {exc}") from None
    out = Path(args.out)
    relative = os.path.relpath(data.resolve(), out.resolve().parent)
    atomic_write_text(out, description_toml(rec, relative))
    for note in notes:
        print(f"note: {note}")
    print(recording_summary(rec))
    print(f"wrote {out}: {len(rec.segments)} segments in {len(rec.group_ids)} groups")
    return 0


def cmd_export(args) -> int:
    from .export import EXPORTS
    from .io import atomic_write_text
    from .parameters import read_table

    params = read_table(args.table)
    text = EXPORTS[args.format][1](params, {k: v for k, v in (("unit_id", args.unit_id),
                                                               ("table", str(args.table))) if v})
    atomic_write_text(args.out, text)
    print(f"wrote {args.out} ({args.format})")
    return 0


def cmd_calibrate(args) -> int:
    from .calibration_report import recording_hash, report_files
    from .io import check_writable, write_files
    from .noise import read_noise_spec
    from .parameters import read_table, table_text
    from .recording import read_recording
    from .report import parameter_report
    from .result import CalibrationError
    from .segment import refine
    from .solvers import calibrate

    if args.report:  # before any computation (--out is checked in main)
        check_writable(args.report, directory=True)
    rec = refine(read_recording(args.recording))  # approximate segment times: trimmed, or rejected naming one
    truth = read_table(args.truth) if args.truth else None
    initial = read_table(args.initial) if args.initial else None
    noise = read_noise_spec(args.noise) if args.noise else None
    options = {"max_iterations": args.max_iterations} if args.max_iterations else {}
    try:
        result = calibrate(rec, solver=args.solver, initial=initial, progress=print, noise=noise, model=args.model,
                           **options)
    except CalibrationError as exc:
        raise CliError(f"{rec.label}: calibration failed, no parameter table written: {exc}") from None
    warnings = result.info.get("warnings", [])
    if args.strict and warnings:
        raise CliError(f"{rec.label}: --strict and {len(warnings)} warning(s), no parameter table written: "
                       + " | ".join(warnings))
    files = {Path(args.out): table_text(result.parameters, truth).encode()}
    files.update(report_files(result, rec, args.out, args.report, truth, command=" ".join(sys.argv),
                              unit_id=args.unit_id))
    files.update(export_files(result.parameters, args.out, args.export or (), {
        "unit_id": args.unit_id, "recording": rec.name, "recording_sha256": recording_hash(rec), "solver": args.solver}))
    write_files(files)
    frame = parameter_report(result, truth)
    print(natural_table(frame).to_string(index=False))
    print(f"{args.solver}: {result.iterations} iterations, {result.wall_time:.2f} s; wrote {args.out} and its report "
          f"({', '.join(p.name for p in list(files)[1:3])})" + (f" and {args.report}/" if args.report else ""))
    sources = result.info.get("noise_sources") or {}
    if "not modelled" in (sources.get("gyro_bias_instability"), sources.get("accel_bias_instability")):
        print("note: bias instability is not modelled (no --noise datasheet): the bias sigmas exclude a drift "
              "slower than this recording can show")
    for message in warnings:
        print(f"WARNING: {message}", file=sys.stderr)
    return 0


def natural_table(frame):
    """The terminal table: values and sigma in natural units (SI stays in the CSV)."""
    import pandas as pd

    from .parameters import natural_value_of

    values = [natural_value_of(name, value) for name, value in zip(frame["parameter"], frame["value"])]
    out = pd.DataFrame({"parameter": frame["parameter"],
                        "value": [f"{v:.9g}" if u == "m/s/pulse" else f"{v:.6g}" for v, u in values],
                        "unit": [u for _, u in values],
                        "1-sigma": [f"{s:.3g}" for s in frame["sigma (natural)"]],
                        "sigma unit": frame["natural unit"]})
    if "error (natural)" in frame:
        out["error"] = [f"{e:+.3g}" for e in frame["error (natural)"]]
        out["error/sigma"] = [f"{e:+.2f}" for e in frame["error/sigma"]]
    return out


def cmd_compare(args) -> int:
    from .compare import compare
    from .parameters import read_table
    from .recording import read_recording
    from .result import CalibrationError

    rec = read_recording(args.recording)
    truth = read_table(args.truth) if args.truth else None
    try:
        _, table, summary = compare(rec, args.out, truth, progress=print)
    except CalibrationError as exc:
        raise CliError(f"{rec.label}: calibration failed: {exc}") from None
    print(summary.drop(columns=["sigma means"]).to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    cols = [c for c in table.columns if "error (natural)" in c or c in ("parameter", "natural unit")]
    if truth is not None:
        print(table[cols].to_string(index=False, float_format=lambda x: f"{x:+.4f}"))
    print(f"wrote the comparison to {args.out}")
    return 0


def cmd_analyze(args) -> int:
    from .analysis import predict_file, write_analysis

    predictions = []
    for path in args.inputs:
        t0 = time.perf_counter()
        pred = predict_file(path, args.accel_noise_ug, args.gyro_noise_deg_h, model=args.model)
        predictions.append(pred)
        print(f"{pred.name}: predicted in {time.perf_counter() - t0:.1f} s; weakly observable: "
              f"{', '.join(pred.weak) or 'none'}")
    table = write_analysis(predictions, args.out)
    print(table.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    print(f"wrote the predicted sigma tables and plot to {args.out}")
    return 0


def cmd_montecarlo(args) -> int:
    from tqdm import tqdm

    from . import montecarlo as MC
    from .analysis import predict_problem
    from .problem import load_problem
    from .report import write_frame

    problem = load_problem(args.problem)
    out = Path(args.out)
    predicted = predict_problem(problem).sigma_natural
    seeds = range(args.first_seed, args.first_seed + args.runs)
    t0 = time.perf_counter()
    with tqdm(total=args.runs, desc=f"monte carlo {problem.name}", unit="run") as bar:
        rows = MC.run(problem, seeds, args.solvers, args.workers,
                      progress=lambda k, n: bar.update(k - bar.n), scheduler=args.dask)
    elapsed = time.perf_counter() - t0
    summary = MC.with_prediction(MC.summary(rows), predicted)
    stem = out / f"{problem.name}-montecarlo"
    write_frame(rows, out / f"{problem.name}-montecarlo-runs")
    cols = ["solver", "parameter", "unit", "rms_error", "mean_sigma", "predicted_sigma", "rms_over_predicted",
            "rms_over_sigma", "max_abs_z", "runs"]
    write_frame(summary[cols], stem, f"{problem.name}: {args.runs} runs in {elapsed:.0f} s; RMS error against "
                f"the solver's sigma and the predicted sigma (natural units)")
    MC.plot_summary(summary, stem.with_suffix(".png"))
    failed = rows[rows["failed"] != ""] if "failed" in rows else rows.iloc[:0]
    print(summary[cols].to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    print(f"{args.runs} runs in {elapsed:.1f} s ({len(failed)} failed); wrote {stem}.csv, .md, .png")
    return 0


def cmd_navcheck(args) -> int:
    from .navcheck import navigation_check, write_navigation_check
    from .parameters import read_table
    from .problem import load_problem

    problem = load_problem(args.problem)
    tables = {Path(p).stem: read_table(p).values for p in args.params}
    runs, table = navigation_check(problem, tables, seed=args.seed, duration_s=args.duration_s,
                                   align_s=args.align_s)
    write_navigation_check(runs, table, args.out, problem.name)
    print(table.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    print(f"wrote {args.out}/{problem.name}-navcheck.{{csv,md,png}}")
    return 0


def cmd_budget(args) -> int:
    import numpy as np

    from .analysis import predict_problem
    from .budget import error_budget, write_budget
    from .frames import orientation_to_dcm
    from .parameters import read_table
    from .problem import load_problem

    problem = load_problem(args.problem)
    if args.params:
        table = read_table(args.params)
        if table.sigma is None:
            raise CliError(f"{args.params}: the table has no sigma column; the budget needs the uncertainty")
        nominal, covariance = table.values, np.diag(np.nan_to_num(table.sigma) ** 2)
        source = f"{args.params} (sigma only: correlations between parameters not known)"
    else:
        pred = predict_problem(problem)
        nominal, covariance = pred.nominal.values, pred.nominal.covariance
        source = f"the predicted covariance of {problem.name}'s schedule"
    budget = error_budget(covariance, nominal, orientation_to_dcm(args.orientation), problem.site.latitude,
                          problem.site.height, problem.site.g, *_white_per_sample(problem),
                          problem.rate_hz, duration_s=args.hours * 3600.0)
    table = write_budget(budget, args.out, problem.name)
    print(f"parameter uncertainty from {source}")
    print(table.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    print(f"wrote {args.out}/{problem.name}-budget.{{csv,md,png}}")
    return 0


def cmd_demo(args) -> int:
    """Simulate the default problem and compare both solvers on it, into ``results/``."""
    from .compare import compare
    from .problem import load_problem
    from .simulate import simulate, write_simulation

    out = Path(args.out)
    problem = load_problem(args.problem)
    t0 = time.perf_counter()
    sim = simulate(problem, seed=args.seed)
    rec_path = write_simulation(sim, out / "recordings")
    print(f"simulated {problem.name} (seed {args.seed}): {rec_path} in {time.perf_counter() - t0:.1f} s")
    results, table, summary = compare(sim.recording, out, sim.truth, progress=print)
    print(summary.drop(columns=["sigma means"]).to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    cols = ["parameter", "natural unit", "nlp error (natural)", "ils error (natural)", "nlp sigma (natural)"]
    print(table[cols].to_string(index=False, float_format=lambda x: f"{x:+.4f}"))
    from .navcheck import navigation_check, write_navigation_check

    runs, nav_table = navigation_check(problem, {name: res.parameters.values for name, res in results.items()},
                                       seed=args.seed)
    write_navigation_check(runs, nav_table, out, sim.recording.name)
    print("navigation check, 1 h static free-inertial after alignment:")
    print(nav_table.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    from .budget import error_budget, write_budget
    from .frames import orientation_to_dcm

    nlp_params = results["nlp"].parameters
    budget = error_budget(nlp_params.covariance, nlp_params.values, orientation_to_dcm("ENU"),
                          problem.site.latitude, problem.site.height, problem.site.g,
                          *_white_per_sample(problem), problem.rate_hz)
    print("error budget of static navigation with the NLP's parameters (1 sigma, m):")
    print(write_budget(budget, out, sim.recording.name).to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    print(f"wrote {out}/{sim.recording.name}-compare.{{csv,md}}, -compare-summary.{{csv,md}}, "
          f"-compare-residuals.png, -navcheck.{{csv,md,png}}, -budget.{{csv,md,png}} and the parameter tables")
    return 0


def _white_per_sample(problem) -> tuple[float, float]:
    """A problem's white accelerometer (ug) and gyro (deg/h) noise per sample, densities included."""
    from .noise import SensorNoise
    from .units import DEG_PER_H, UG

    dt = 1.0 / problem.rate_hz
    noise = SensorNoise.from_deviations(problem.deviations, dt)
    return float(noise.accel_vrw[0]) / dt**0.5 / UG, float(noise.gyro_arw[0]) / dt**0.5 / DEG_PER_H


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in text).strip("-").lower()


# --------------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="casadi-sins",
        description="System-level calibration of strapdown inertial navigation systems (21-parameter model).")
    parser.add_argument("--version", action="version", version=f"casadi-sins {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("simulate", help="simulate a problem's experiment into a recording and its truth")
    p.add_argument("problem", nargs="?", default=None, help="problem file (default: the paper's experiment)")
    p.add_argument("--seed", type=int, default=0, help="random seed of deviations and noise (default 0)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--name", help="recording name (default PROBLEM-seedN)")
    p.add_argument("--no-noise", action="store_true", help="leave out the sensor noise")
    p.add_argument("--quantize", action="store_true", help="integer pulses, remainder carried")
    p.add_argument("--start-attitude-deg", type=float, help="start attitude deviation per angle, deg")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("validate", help="read and check a recording; print its summary")
    p.add_argument("recording", help="recording description NAME.toml")
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("rough", help="the paper's rough initial parameters of a recording")
    p.add_argument("recording")
    p.add_argument("--out", required=True, help="parameter table CSV to write")
    p.set_defaults(func=cmd_rough)

    p = sub.add_parser("navigate", help="navigate a recording's groups; velocity per static segment and a plot")
    p.add_argument("recording")
    p.add_argument("--params", nargs="*", help="parameter tables (default: rough initial values)")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(func=cmd_navigate)

    p = sub.add_parser("calibrate", help="calibrate a recording: the parameter table (and a report)")
    p.add_argument("recording")
    p.add_argument("--solver", default="nlp", choices=["nlp", "ils"],
                   help="nlp: CasADi/Ipopt over all rotations (default); ils: the paper's iterative least squares")
    p.add_argument("--out", required=True, help="parameter table CSV to write")
    p.add_argument("--report", help="folder for the per-iteration and parameter reports (CSV, Markdown)")
    p.add_argument("--truth", help="truth table: adds errors in natural units to the table and report")
    p.add_argument("--initial", help="starting parameter table (default: the paper's rough values)")
    p.add_argument("--max-iterations", type=int, help="iteration limit (default 10)")
    p.add_argument("--noise", help="sensor datasheet (TOML, natural units: gyro_arw_deg_rth, accel_vrw_ug_rthz, "
                   "gyro_bias_instability_deg_h, gyro_bias_tau_s, ...); terms not given are measured in the data")
    p.add_argument("--strict", action="store_true", help="any warning is a failure: exit 2, no table")
    p.add_argument("--model", default="21", choices=["21", "extended", "auto"],
                   help="parameters: the paper's 21 (default); extended: also accelerometer quadratic scale, lever "
                   "arms and the gyro/accel time offset; auto: the extra groups the data support (nlp only)")
    p.add_argument("--export", nargs="+", choices=["json", "yaml", "psins"],
                   help="also write the table as compensation matrices (NAME.compensation.json / .yaml) or as the "
                   "PSINS clbt struct (NAME.clbt.m)")
    p.add_argument("--unit-id", help="serial number of the unit, for the report and exports")
    p.set_defaults(func=cmd_calibrate)

    p = sub.add_parser("segment", help="find the static and rotation segments of a CSV and write its description")
    p.add_argument("data", help="the samples, NAME.csv (time, gyro_x..z, accel_x..z)")
    p.add_argument("--rate", type=float, required=True, help="sample rate, Hz")
    p.add_argument("--latitude", type=float, required=True, help="latitude of the site, deg")
    p.add_argument("--height", type=float, default=0.0, help="height of the site, m (default 0)")
    p.add_argument("--gravity", type=float, help="local gravity, m/s^2 (default: WGS-84 normal gravity)")
    p.add_argument("--name", help="recording name (default: the output's stem)")
    p.add_argument("--min-static-s", type=float, default=20.0, help="shortest rest taken as a static segment (s)")
    p.add_argument("--out", required=True, help="recording description NAME.toml to write")
    p.set_defaults(func=cmd_segment)

    p = sub.add_parser("export", help="a parameter table as compensation matrices (JSON, YAML) or PSINS clbt text")
    p.add_argument("table", help="parameter table CSV")
    p.add_argument("--format", required=True, choices=["json", "yaml", "psins"])
    p.add_argument("--out", required=True, help="file to write")
    p.add_argument("--unit-id", help="serial number of the unit")
    p.set_defaults(func=cmd_export)

    p = sub.add_parser("compare", help="run both solvers on a recording and compare them (CSV, Markdown, PNG)")
    p.add_argument("recording")
    p.add_argument("--truth", help="truth table: errors against it in natural units")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("analyze", help="predicted accuracy of schedules before any data (problem or recording)")
    p.add_argument("inputs", nargs="+", help="problem files or recordings (several: compared side by side)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--accel-noise-ug", type=float, help="accelerometer white noise per sample (default: the "
                   "problem's, or measured in the recording)")
    p.add_argument("--gyro-noise-deg-h", type=float, help="gyro white noise per sample (default: the "
                   "problem's, or measured in the recording)")
    p.add_argument("--model", default="21", choices=["21", "extended"],
                   help="extended: also predict the extra terms (quadratic scale, lever arms, time offset)")
    p.set_defaults(func=cmd_analyze)

    p = sub.add_parser("montecarlo", help="simulate and calibrate many seeds: RMS error against sigma")
    p.add_argument("problem", nargs="?", default=None, help="problem file (default: the paper's experiment)")
    p.add_argument("--runs", type=int, default=50)
    p.add_argument("--first-seed", type=int, default=10000)
    p.add_argument("--solvers", nargs="+", default=["nlp", "ils"], choices=["nlp", "ils"])
    p.add_argument("--workers", type=int, help="local worker processes (default: one per core)")
    p.add_argument("--dask", metavar="SCHEDULER", help="run on a Dask cluster: scheduler address, or 'local'")
    p.add_argument("--out", default="runs/montecarlo", help="output folder (default runs/montecarlo)")
    p.set_defaults(func=cmd_montecarlo)

    p = sub.add_parser("navcheck", help="1 h free-inertial navigation of a fresh static recording per table")
    p.add_argument("problem", nargs="?", default=None, help="problem file (sensors, truth, noise; default paper)")
    p.add_argument("--params", nargs="+", required=True, help="parameter tables to check")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--duration-s", type=float, default=3600.0)
    p.add_argument("--align-s", type=float, default=300.0)
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_navcheck)

    p = sub.add_parser("budget", help="static navigation error over 1 h and 24 h by source, by covariance")
    p.add_argument("problem", nargs="?", default=None, help="problem file: site, sensors, noise (default paper)")
    p.add_argument("--params", help="calibrated parameter table with sigma (default: the schedule's predicted "
                   "covariance)")
    p.add_argument("--orientation", default="ENU", help="orientation of the unit while navigating")
    p.add_argument("--hours", type=float, default=24.0)
    p.add_argument("--out", required=True)
    p.set_defaults(func=cmd_budget)

    p = sub.add_parser("demo", help="simulate the paper's experiment and compare both solvers into results/")
    p.add_argument("problem", nargs="?", default=None, help="problem file (default: the paper's experiment)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", default="runs/demo", help="output folder (default runs/demo; the published "
                   "results/ are made by benchmarks/regenerate_results.sh)")
    p.set_defaults(func=cmd_demo)
    return parser


#: Commands whose --out is a folder (the others write one file).
FOLDER_OUTPUTS = {"simulate", "navigate", "compare", "analyze", "montecarlo", "navcheck", "budget", "demo"}


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if getattr(args, "out", None):
            from .io import check_writable

            check_writable(args.out, directory=args.command in FOLDER_OUTPUTS)  # before any computation
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1):  # small matrices: BLAS threads spinning on them cost 3-5x under load
            return args.func(args)
    except _known_errors() as exc:
        print(f"casadi-sins {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except OSError as exc:  # a file system failure: one line naming the file, never a traceback
        where = exc.filename or ""
        print(f"casadi-sins {args.command}: error: {where}{': ' if where else ''}{exc.strerror or exc}",
              file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
