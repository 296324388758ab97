"""The commands: read the arguments, call the library, print what it found.  No physics here."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

from ..calibrate import calibrate
from ..calibrate.initial import rough_parameters
from ..calibrate.result import CalibrationError
from ..calibrate.wander import SENSOR_WORDS, natural_size
from ..core.earth import Site
from ..core.text import one_line, plural
from ..studies.parallel import check_scheduler
from ..core.files import atomic_write_text, check_writable, safe_stem, write_files
from ..data.datasheet import read_datasheet
from ..model.noise import NOISE_CEILINGS
from ..core.errors import InputError
from ..data.description import MAX_NAME, description_from_text, description_toml, read_description, read_recording
from ..data.problem import load_problem
from ..data.samples import read_samples
from ..data.segmentation import refine, segment_recording
from ..data.tables import read_table, write_table
from ..nav.navigation import navigate
from ..report.acceptance import judge, read_acceptance_sheet
from ..report.calibration import companion_paths
from ..report.calibration_files import calibration_files
from ..report.exports import EXPORTS
from ..report.plots import plot_navigation
from ..report.provenance import read_provenance
from ..report.rounding import display, float_columns
from ..report.tables import natural_table, parameter_report, recording_summary, static_velocity_table, write_frame
from ..sim import simulate, write_simulation
from ..studies import montecarlo as MC
from ..studies.apply import table_with_covariance
from ..studies.budget import problem_budget, write_budget
from ..studies.compare import compare, comparison_display, comparison_files, summary_display
from ..studies.demo import run_demo
from ..studies.navcheck import navigation_check, write_navigation_check
from ..studies.prediction import analysis_display, predict_file, predict_problem, write_analysis
from .command import CliError
from .logs import note, progress_for, steps_printer


def cmd_simulate(args) -> int:
    """``simulate``: a problem's experiment as a recording and its truth."""
    problem = load_problem(args.problem)
    changes = {}
    if args.start_attitude_deg is not None:
        changes["start_attitude_deg"] = args.start_attitude_deg
    if args.quantize:
        changes["quantize"] = True
    if changes:
        problem = problem.with_changes(**changes)
    t0 = time.perf_counter()
    with progress_for(args, 1, f"simulate {problem.name}", "") as progress:
        sim = simulate(problem, seed=args.seed, noise=not args.no_noise, name=args.name and safe_stem(args.name),
                       progress=progress)
    path = write_simulation(sim, args.out)
    print(f"wrote {path} (+ .csv, .truth.csv): {len(sim.recording.time)} samples, {time.perf_counter() - t0:.1f} s")
    return 0


def cmd_validate(args) -> int:
    """``validate``: read and check a recording, print its schedule."""
    rec = read_recording(args.recording)
    for text in rec.notes:
        note(text)
    print(recording_summary(rec))
    print("valid sins-recording/1")
    return 0


def cmd_rough(args) -> int:
    """``rough``: the paper's rough initial values of a recording."""
    path = write_table(args.out, rough_parameters(read_recording(args.recording)))
    print(f"wrote {path}")
    return 0


def cmd_navigate(args) -> int:
    """``navigate``: each group navigated with each table; the static segments' velocity and a plot."""
    rec = read_recording(args.recording)
    runs = ({Path(path).stem: read_table(path).values for path in args.params} if args.params
            else {"rough initial values": rough_parameters(rec).values})
    out = Path(args.out)
    navs = {}
    for label, values in runs.items():
        t0 = time.perf_counter()
        navs[label] = navigate(rec, values)
        print(f"navigated {rec.name} with {label} in {time.perf_counter() - t0:.2f} s")
        table = static_velocity_table(rec, navs[label])
        shown = display(table, sigmas=float_columns(table))
        write_frame(table, out / f"{rec.file_stem}-{safe_stem(label)}-static", f"{rec.name}: static segments, {label}",
                    display=shown)
        print(shown.to_string(index=False))
    print(f"wrote {plot_navigation(rec, navs, out / f'{rec.file_stem}-velocity.png')}")
    return 0


def cmd_segment(args) -> int:
    """``segment``: find the schedule of a CSV and write its description."""
    data = Path(args.data)
    site, rate, head = None, args.rate, None
    if data.suffix.lower() == ".toml":  # a description without segments: its site, rate, conditions and samples
        head = read_description(data)
        site, rate, data = head["site"], args.rate or head["rate_hz"], data.parent / head["data"]
    check_rate_option(args.rate)
    if args.latitude is not None or site is None:
        if args.latitude is None or rate is None:
            raise CliError("the samples of a CSV need --rate and --latitude (a description gives them)")
        check_site_options(args.latitude, args.height, args.gravity)
        site = Site(np.radians(args.latitude), args.height, args.gravity)
    name = check_name_option(args.name or Path(args.out).stem)
    time_, pulses = read_samples(data, rate)
    try:
        rec, notes = segment_recording(time_, pulses[:, :3], pulses[:, 3:], rate, site, name, args.min_static_s)
    except ValueError as exc:
        raise CliError(f"{data}: {exc}") from None
    if head is not None:
        rec.conditions = head["conditions"]
    out = Path(args.out)
    text = description_toml(rec, os.path.relpath(os.path.abspath(data), os.path.abspath(out.parent)))
    try:  # what the reader would refuse (a --gravity off the Earth) is never written
        description_from_text(text.encode("utf-8"), out)
    except InputError as exc:
        raise CliError(f"not written, the reader would refuse it: {exc}") from None
    atomic_write_text(out, text)
    for line in notes:
        note(line)
    print(recording_summary(rec))
    print(f"wrote {out}: {plural(len(rec.segments), 'segment')} in {plural(len(rec.group_ids), 'group')}")
    return 0


def check_site_options(latitude: float, height: float, gravity: float | None = None) -> None:
    """``--latitude``, ``--height`` and ``--gravity`` (None: not given) as a recording description accepts
    them (finite, on the ground, a gravity on Earth)."""
    if not -90.0 <= latitude <= 90.0 or not -500.0 <= height <= 10000.0:  # false for nan
        raise CliError(f"--latitude must be within -90..90 deg and --height within -500..10000 m, found "
                       f"{latitude:g} and {height:g}")
    if gravity is not None and not 9.7 < gravity < 9.9:
        raise CliError(f"--gravity must be a gravity on Earth (9.7..9.9 m/s^2), found {gravity:g}")


def check_rate_option(rate: float | None) -> None:
    """``--rate`` as a recording description accepts it (None: not given)."""
    if rate is not None and not 1.0 <= rate <= 1e5:
        raise CliError(f"--rate must be between 1 and 100000 Hz, found {rate:g}")


def check_name_option(name: str) -> str:
    """A recording name (``--name``) as a recording description accepts it."""
    if not name or len(name) > MAX_NAME or not name.isprintable():  # what read_recording accepts
        raise CliError(f"--name must be one line of 1 to {MAX_NAME} printable characters, found "
                       f"{one_line(repr(name), 80)}")
    return name


def cmd_export(args) -> int:
    """``export``: a table as compensation matrices or the PSINS struct."""
    params = read_table(args.table)
    origin = read_provenance(args.table)  # the companion report's unit id, date and recording hash
    if args.unit_id and origin.unit_id and args.unit_id != origin.unit_id:
        raise CliError(f"{one_line(args.table)}: --unit-id {one_line(args.unit_id, 60)} but the table's report says "
                       f"unit {one_line(origin.unit_id, 60)}")
    metadata = {**origin.metadata(), **({"unit_id": args.unit_id} if args.unit_id else {})}
    atomic_write_text(args.out, EXPORTS[args.format][1](params, metadata))
    print(f"wrote {args.out} ({args.format})")
    if not origin.from_report:
        note("no companion report beside the table, so no recording hash")
    return 0


def cmd_calibrate(args) -> int:
    """``calibrate``: the parameter table, its report, plots and exports, all written together."""
    if args.report:  # before any computation (--out is checked in main)
        check_writable(args.report, directory=True)
    sheet = read_acceptance_sheet(args.tolerance) if args.tolerance else None
    rec = read_recording(args.recording)
    for text in rec.notes if not getattr(args, "quiet", False) else ():  # a schedule found from the samples (no [[segments]])
        note(text)
    rec = refine(rec, args.min_rest_s)  # approximate segment times: trimmed, or rejected
    truth = read_table(args.truth) if args.truth else None
    initial = read_table(args.initial) if args.initial else None
    noise = read_datasheet(args.noise) if args.noise else None
    options = {"max_iterations": args.max_iterations} if args.max_iterations else {}
    try:
        result = calibrate(rec, solver=args.solver, initial=initial, progress=steps_printer(args), noise=noise, model=args.model,
                           refine_segments=False, min_rest_s=args.min_rest_s, **options)  # refined above
    except CalibrationError as exc:
        raise CliError(f"{rec.label}: calibration failed, no parameter table written: {exc}") from None
    if args.strict and result.warnings:
        raise CliError(f"{rec.label}: --strict and {len(result.warnings)} warning(s), no parameter table written: "
                       + " | ".join(result.warnings))
    if result.distrust and not args.accept_distrusted:
        raise CliError(f"{rec.label}: the calibration's own checks do not trust its result, no parameter table "
                       "written: " + " | ".join(result.distrust)
                       + " (--accept-distrusted writes it, marked, with exit 4)")
    verdict = judge(result.parameters, sheet) if sheet else None
    files, report = calibration_files(result, rec, args.out, args.report, truth, command=" ".join(sys.argv),
                                      unit_id=args.unit_id, verdict=verdict, certificate=args.certificate,
                                      exports=args.export or ())
    write_files(files)
    print(natural_table(parameter_report(result, truth)).to_string(index=False))
    print(f"wrote {args.out} and its report ({', '.join(p.name for p in companion_paths(args.out))})"
          + (f", certificate {report['certificate']['number']} ({report['certificate']['file']})"
             if args.certificate else "") + (f" and {Path(args.report)}/" if args.report else "")
          + f"; {args.solver} solver, {result.nit} iterations, {result.wall_time:.2f} s")
    for left in (result.nlp.left_out.values() if result.nlp else ()):  # a note (also in the report)
        note(left["note"])
    for sensor, wander in result.noise.bias_wander.items():  # notes (also in the report): not with --quiet
        if not wander.included and not args.quiet:
            bound = natural_size(sensor, wander.upper) if np.isfinite(wander.upper) else "not bounded by the data"
            seen = ("the static data's misfit taken for model mismatch" if wander.mismatch
                    else "no significant wander in the static data")
            note(f"bias instability is not modelled for the {SENSOR_WORDS[sensor][0]} (no --noise datasheet, "
                 f"{seen}; 95 % upper bound {bound} at {wander.tau:.0f} s): the bias sigmas exclude it")
    for message in result.warnings:
        print(f"WARNING: {message}", file=sys.stderr)
    status = _verdict_status(verdict)
    if result.distrust:
        print(f"DISTRUSTED (written under --accept-distrusted, exit 4): {' | '.join(result.distrust)}", file=sys.stderr)
        return DISTRUSTED_STATUS
    return status


#: Exit status of a table written under ``--accept-distrusted`` although the calibration's checks distrust it.
DISTRUSTED_STATUS = 4


def _verdict_status(verdict) -> int:
    """Print the verdict against the tolerance sheet; the exit status: 0 (none, or pass), 3 (fail)."""
    if verdict is None:
        return 0
    print(f"verdict: {verdict.verdict.upper()} against {verdict.sheet}")
    for reason in verdict.reasons:
        print(f"  {reason}")
    return 0 if verdict.passed else 3


def cmd_compare(args) -> int:
    """``compare``: both solvers on one recording."""
    rec = read_recording(args.recording)
    truth = read_table(args.truth) if args.truth else None
    try:
        comparison = compare(rec, truth, progress=steps_printer(args))
    except CalibrationError as exc:
        raise CliError(f"{rec.label}: calibration failed: {exc}") from None
    write_files(comparison_files(rec, comparison, args.out, truth))
    print(summary_display(comparison.summary).drop(columns=["sigma means"]).to_string(index=False))
    print(comparison_display(comparison.table).to_string(index=False))
    print(f"wrote the comparison to {args.out}")
    return 0


def cmd_analyze(args) -> int:
    """``analyze``: predicted accuracy of schedules."""
    if args.accel_noise_ug is not None or args.gyro_noise_deg_h is not None:
        raise CliError("--accel-noise-ug and --gyro-noise-deg-h (white noise per sample) are gone: give the densities "
                       "as calibrate's --noise datasheet does, --accel-vrw-ug-rthz (ug/sqrt(Hz)) and "
                       "--gyro-arw-deg-rth (deg/sqrt(h)); per-sample sigma = density x sqrt(rate)")
    for key in ("accel_vrw_ug_rthz", "gyro_arw_deg_rth"):
        value = getattr(args, key)
        if value is not None and not 0 < value <= NOISE_CEILINGS[key]:
            raise CliError(f"--{key.replace('_', '-')} must be a positive density of at most {NOISE_CEILINGS[key]:g} "
                           f"(beyond any inertial sensor), found {value:g}")
    predictions = []
    for path in args.inputs:
        t0 = time.perf_counter()
        pred = predict_file(path, args.accel_vrw_ug_rthz, args.gyro_arw_deg_rth, model=args.model)
        predictions.append(pred)
        print(f"{pred.name}: predicted in {time.perf_counter() - t0:.1f} s; weakly observable: "
              f"{', '.join(pred.weak) or 'none'}")
    table = write_analysis(predictions, args.out)
    print(analysis_display(table).to_string(index=False))
    print(f"wrote the predicted sigma tables and plot to {args.out}")
    return 0


def cmd_montecarlo(args) -> int:
    """``montecarlo``: simulate and calibrate many seeds."""
    check_scheduler(args.dask)  # before any work or progress bar
    MC.check_runs(args.runs)
    problem = load_problem(args.problem)
    predicted = predict_problem(problem).sigma_natural
    seeds = range(args.first_seed, args.first_seed + args.runs)
    t0 = time.perf_counter()
    with progress_for(args, args.runs, f"monte carlo {problem.name}", "run") as progress:
        rows = MC.run(problem, seeds, args.solvers, args.workers, progress=progress, scheduler=args.dask)
    elapsed = time.perf_counter() - t0
    summary = MC.with_prediction(MC.summary(rows), predicted)
    write_files(MC.montecarlo_files(problem, rows, summary, args.out, args.runs, elapsed))
    failed = rows[rows["failed"] != ""] if "failed" in rows else rows.iloc[:0]
    print(MC.summary_display(summary).to_string(index=False))
    print(f"{args.runs} runs in {elapsed:.1f} s ({len(failed)} failed); wrote {args.out}/{problem.name}-montecarlo."
          "{csv,md,png}")
    return 0


def cmd_navcheck(args) -> int:
    """``navcheck``: 1 h free-inertial navigation with each table."""
    problem = load_problem(args.problem)
    tables = {Path(p).stem: read_table(p).values for p in args.params}
    runs, table = navigation_check(problem, tables, seed=args.seed, duration_s=args.duration_s, align_s=args.align_s)
    write_navigation_check(runs, table, args.out, problem.name)
    print(display(table, sigmas=float_columns(table)).to_string(index=False))
    print(f"wrote {args.out}/{problem.name}-navcheck.{{csv,md,png}}")
    return 0


def cmd_budget(args) -> int:
    """``budget``: static navigation error by source."""
    problem = load_problem(args.problem)
    if args.params:
        table = table_with_covariance(args.params)  # the correlations of its report, when it has one
        if table.sigma is None:
            raise CliError(f"{args.params}: the table has no sigma column; the budget needs the uncertainty")
        if table.covariance is not None:
            nominal, covariance, names = table.values, table.covariance, table.names
            source = f"{args.params} (with the correlations of its report)"
        else:
            nominal, covariance, names = table.values, np.diag(np.nan_to_num(table.sigma) ** 2), table.names
            source = f"{args.params} (sigma only: no companion report, correlations between parameters not known)"
    else:
        pred = predict_problem(problem)
        nominal, covariance, names = pred.nominal.values, pred.nominal.covariance, pred.nominal.names
        source = f"the predicted covariance of {problem.name}'s schedule"
    budget = problem_budget(problem, nominal, covariance, args.orientation, args.hours, names)
    table = write_budget(budget, args.out, safe_stem(problem.name))
    print(f"parameter uncertainty from {source}")
    print(display(table, sigmas=float_columns(table)).to_string(index=False))
    print(f"wrote {args.out}/{safe_stem(problem.name)}-budget.{{csv,md,png}}")
    return 0


def cmd_demo(args) -> int:
    """``demo``: the main job on the default problem."""
    demo = run_demo(load_problem(args.problem), args.seed, args.out, progress=steps_printer(args))
    comparison = demo.comparison
    print(summary_display(comparison.summary).drop(columns=["sigma means"]).to_string(index=False))
    shown = comparison_display(comparison.table)
    print(shown[[c for c in shown.columns if "error" in c or c in ("parameter", "natural unit", "nlp sigma (natural)")]]
          .to_string(index=False))
    print("navigation check, 1 h static free-inertial after alignment:")
    print(display(demo.navigation, sigmas=float_columns(demo.navigation)).to_string(index=False))
    print("error budget of static navigation with the NLP's parameters (1 sigma, m):")
    print(display(demo.budget, sigmas=float_columns(demo.budget)).to_string(index=False))
    print(f"wrote the comparison, navigation check, budget and parameter tables to {args.out}")
    return 0
