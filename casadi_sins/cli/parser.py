"""The command line's arguments: every command, option and argument with its help."""

from __future__ import annotations

import argparse
import os

from ..core.version import build_identity
from ..report.exports import EXPORTS
from .commands import (cmd_analyze, cmd_calibrate, cmd_compare, cmd_demo, cmd_montecarlo,
                       cmd_navigate, cmd_rough, cmd_segment, cmd_validate)
from .logs import LONG_COMMANDS, add_log_options
from .design import add_design_command as add_schedule_design_command
from .modulation import cmd_modulate, cmd_modulate_mc
from .importing import add_import_parser
from .production import add_production_commands, cmd_budget_any, cmd_navcheck_any
from .thermal import add_thermal_command, cmd_export_any, cmd_simulate_any
from .scheme_design import add_design_command
from .noise import add_noise_command


class _PrintVersion(argparse.Action):
    """``--version``: the build identity on one line (argparse's own action would wrap it)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(build_identity())
        parser.exit()


class Parser(argparse.ArgumentParser):
    """argparse's parser, but a bad argument is one line (the command and what is wrong, where to look), exit 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:  # noqa: PLR0915 (one parser, every option in one place)
    """The argument parser of ``casadi-sins``."""
    parser = Parser(
        prog="casadi-sins",
        description="System-level calibration of strapdown inertial navigation systems (21-parameter model).")
    parser.add_argument("--version", action=_PrintVersion, nargs=0, help="print the build (version, commit) and exit")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("simulate", help="simulate a problem's experiment into a recording and its truth (a thermal "
                       "problem: one recording per temperature setpoint)")
    p.add_argument("problem", nargs="?", default=None, help="problem file (default: the paper's experiment)")
    p.add_argument("--seed", type=int, default=0, help="random seed of deviations and noise (default 0)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--name", help="recording name (default PROBLEM-seedN)")
    p.add_argument("--no-noise", action="store_true", help="leave out the sensor noise")
    p.add_argument("--quantize", action="store_true", help="integer pulses, remainder carried")
    p.add_argument("--start-attitude-deg", type=float, help="start attitude deviation per angle, deg (default: "
                   "the problem's start_attitude_deg)")
    p.set_defaults(func=cmd_simulate_any)  # a thermal problem ([thermal]): one recording per setpoint

    p = sub.add_parser("validate", help="read and check a recording; print its summary")
    p.add_argument("recording", help="recording description NAME.toml")
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("rough", help="the paper's rough initial parameters of a recording")
    p.add_argument("recording", help="recording description NAME.toml")
    p.add_argument("--out", required=True, help="parameter table CSV to write")
    p.set_defaults(func=cmd_rough)

    p = sub.add_parser("navigate", help="navigate a recording's groups; velocity per static segment and a plot")
    p.add_argument("recording", help="recording description NAME.toml")
    p.add_argument("--params", nargs="*", help="parameter tables (default: rough initial values)")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(func=cmd_navigate)

    p = sub.add_parser("calibrate", help="calibrate a recording: the parameter table (and a report)")
    p.add_argument("recording", help="recording description NAME.toml")
    p.add_argument("--solver", default="nlp", choices=["nlp", "ils"],
                   help="nlp: CasADi/Ipopt over all rotations (default); ils: the paper's iterative least squares")
    p.add_argument("--out", required=True, help="parameter table CSV to write")
    p.add_argument("--report", help="folder for the full report: per-iteration and parameter tables (CSV, Markdown), the report (JSON, Markdown), residual and Allan-deviation plots (PNG)")
    p.add_argument("--truth", help="truth table: adds errors in natural units to the table and report")
    p.add_argument("--initial", help="starting parameter table (default: the paper's rough values)")
    p.add_argument("--max-iterations", type=int, help="iteration cap: nlp, Ipopt's (default 100, typically 3-5 used); ils, the paper's iterations (default 10, typically 4 used)")
    p.add_argument("--noise", help="sensor datasheet (TOML, natural units: gyro_arw_deg_rth, accel_vrw_ug_rthz, "
                   "gyro_bias_instability_deg_h, gyro_bias_tau_s, ...); terms not given are measured in the data")
    p.add_argument("--strict", action="store_true", help="any warning is a failure: exit 2, no table")
    p.add_argument("--accept-distrusted", action="store_true",
                   help="write a table the calibration's own checks do not trust (by default: exit 2, no table), "
                   "marked: a trust column 'distrusted' in the table, the reasons in the report, exit 4")
    p.add_argument("--model", default=None, choices=["21", "extended", "auto"],
                   help="parameters: the paper's 21; extended: also every extra group (accelerometer "
                   "quadratic and cross-quadratic terms, lever arms, gyro/accel time offset, gyro g-sensitivity and "
                   "scale asymmetry); auto: the extra groups the data support (nlp only). Default: 21, and 21 with the "
                   "gyro g-sensitivity for a MEMS unit moved by hand (rests at any orientation)")
    p.add_argument("--export", nargs="+", choices=list(EXPORTS),
                   help="also write the table as compensation matrices (NAME.compensation.json / .yaml), a C header "
                   "(NAME.compensation.h) or the PSINS clbt struct (NAME.clbt.m)")
    p.add_argument("--unit-id", help="serial number of the unit, for the report and exports")
    p.add_argument("--tolerance", metavar="SHEET", help="tolerance sheet TOML: its [accept.sigma] and [accept.value] "
                   "limits give the verdict (report JSON \"verdict\"); exit 3 on fail, the table still written, with "
                   "an acceptance column marking the parameters out of their limits")
    p.add_argument("--certificate", nargs="?", const="html", choices=("html", "pdf"),
                   help="also write the certificate to sign: NAME.certificate.html (one self-contained file "
                   "printable on A4), or with 'pdf' NAME.certificate.pdf (needs the extra 'pdf'): certificate "
                   "number, unit id, recording and table hashes, table rounded to sigma with each limit and "
                   "margin, checks, verdict, approval fields, page X of Y")
    p.add_argument("--min-rest-s", type=float, help="shortest rest a static segment must keep, s (default: from the "
                   "measured noise and rate, stated in the report)")
    p.set_defaults(func=cmd_calibrate)

    p = sub.add_parser("segment", help="find the static and rotation segments of a CSV and write its description")
    p.add_argument("data", help="the samples, NAME.csv (time, gyro_x..z, accel_x..z), or a description NAME.toml "
                   "without [[segments]] (its site, rate and samples)")
    p.add_argument("--rate", type=float, help="sample rate, Hz (needed for a CSV; default: the description's)")
    p.add_argument("--latitude", type=float, help="latitude of the site, deg (needed for a CSV; with a description "
                   "it replaces its site)")
    p.add_argument("--height", type=float, default=0.0, help="height of the site, m (default 0)")
    p.add_argument("--gravity", type=float, help="local gravity, m/s^2 (default: WGS-84 normal gravity)")
    p.add_argument("--name", help="recording name (default: the output's stem)")
    p.add_argument("--min-static-s", type=float, help="shortest rest taken as a static segment, s (default: a "
                   "turntable schedule with rests of 20 s, else a session by hand with rests from the data)")
    p.add_argument("--out", required=True, help="recording description NAME.toml to write")
    p.set_defaults(func=cmd_segment)

    p = sub.add_parser("export", help="a parameter table as compensation matrices (JSON, YAML, C header) or PSINS "
                       "clbt text, with the provenance from the table's companion report")
    p.add_argument("table", help="parameter table CSV (or a thermal model thermal.csv: --format c only)")
    p.add_argument("--format", required=True, choices=list(EXPORTS), help="json or yaml: compensation matrices; "
                   "psins: the PSINS clbt struct; c: a C header for firmware (float64 arrays, inline function)")
    p.add_argument("--out", required=True, help="file to write")
    p.add_argument("--unit-id", help="serial number of the unit")
    p.set_defaults(func=cmd_export_any)  # a thermal.csv exports as a C header with casadi_sins_compensate_t

    p = sub.add_parser("compare", help="run both solvers on a recording and compare them (CSV, Markdown, PNG)")
    p.add_argument("recording", help="recording description NAME.toml")
    p.add_argument("--truth", help="truth table: errors against it in natural units")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("analyze", help="predicted accuracy of schedules before any data (problem or recording)")
    p.add_argument("inputs", nargs="+", help="problem files or recordings (several: compared side by side)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--accel-vrw-ug-rthz", type=float, help="accelerometer white noise density (velocity random "
                   "walk), ug/sqrt(Hz), as in a --noise datasheet (default: the problem's, or measured in the recording)")
    p.add_argument("--gyro-arw-deg-rth", type=float, help="gyro white noise density (angle random walk), "
                   "deg/sqrt(h), as in a --noise datasheet (default: the problem's, or measured in the recording)")
    p.add_argument("--accel-noise-ug", type=float, help="refused (the old per-sample form): use --accel-vrw-ug-rthz")
    p.add_argument("--gyro-noise-deg-h", type=float, help="refused (the old per-sample form): use --gyro-arw-deg-rth")
    p.add_argument("--model", default="21", choices=["21", "extended"],
                   help="21: the paper's parameters (default); extended: also predict the extra groups of the "
                   "registry (quadratic and cross-quadratic terms, lever arms, time offset, gyro g-sensitivity and "
                   "scale asymmetry)")
    p.set_defaults(func=cmd_analyze)

    p = sub.add_parser("montecarlo", help="simulate and calibrate many seeds: RMS error against sigma")
    p.add_argument("problem", nargs="?", default=None, help="problem file (default: the paper's experiment)")
    p.add_argument("--runs", type=int, default=50, help="number of seeds (default 50)")
    p.add_argument("--first-seed", type=int, default=10000, help="first seed (default 10000)")
    p.add_argument("--solvers", nargs="+", default=["nlp", "ils"], choices=["nlp", "ils"], help="solvers to run (default both)")
    p.add_argument("--workers", type=int, help="local worker processes (default: one per core)")
    p.add_argument("--dask", metavar="SCHEDULER", help="run on a Dask cluster: scheduler address, or 'local'")
    p.add_argument("--out", default="runs/montecarlo", help="output folder (default runs/montecarlo)")
    p.set_defaults(func=cmd_montecarlo)

    p = sub.add_parser("navcheck", help="free-inertial navigation at rest per table: a fresh simulated static "
                       "recording of a problem, or the unit's own static recording")
    p.add_argument("problem", nargs="?", default=None, metavar="PROBLEM_OR_RECORDING",
                   help="problem file (sensors, truth, noise; default paper), or a recording REC.toml of the unit at "
                   "rest (its longest static segment is navigated)")
    p.add_argument("--params", nargs="+", required=True, help="parameter tables to check")
    p.add_argument("--seed", type=int, default=0, help="seed of the fresh static recording (default 0)")
    p.add_argument("--duration-s", type=float, help="navigation time, s (default 3600; on a recording: the rest of "
                   "its static segment)")
    p.add_argument("--align-s", type=float, default=300.0, help="alignment time before it, s (default 300)")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(func=cmd_navcheck_any)

    p = sub.add_parser("budget", help="static navigation error over 1 h and 24 h by source, by covariance (a "
                       "problem, or the unit's recording with its table)")
    p.add_argument("problem", nargs="?", default=None, metavar="PROBLEM_OR_RECORDING",
                   help="problem file: site, sensors, noise (default paper); or a recording REC.toml: its site and "
                   "measured noise, with --params")
    p.add_argument("--params", help="calibrated parameter table with sigma (default: the schedule's predicted "
                   "covariance)")
    p.add_argument("--orientation", help="orientation letters of the unit while navigating (default ENU; on a "
                   "recording, that of its longest static segment)")
    p.add_argument("--hours", type=float, default=24.0, help="navigation time, h (default 24)")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(func=cmd_budget_any)

    p = sub.add_parser("demo", help="simulate the paper's experiment, both solvers side by side, navigation check and error budget")
    p.add_argument("problem", nargs="?", default=None, help="problem file (default: the paper's experiment)")
    p.add_argument("--seed", type=int, default=1, help="random seed of the simulation (default 1)")
    p.add_argument("--out", default="runs/demo", help="output folder (default runs/demo; the published "
                   "results/ are made by benchmarks/regenerate_results.sh)")
    p.set_defaults(func=cmd_demo)
    _add_modulation(sub)
    add_production_commands(sub)
    add_thermal_command(sub)
    add_import_parser(sub)
    add_design_command(sub)
    add_schedule_design_command(sub)
    add_noise_command(sub)
    for name in LONG_COMMANDS:
        add_log_options(sub.choices[name])
    for action in sub._choices_actions:  # each command's --help starts with its one-line description
        sub.choices[action.dest].description = sub.choices[action.dest].description or action.help
    _finite_numbers(parser)
    return parser


def finite_float(text: str) -> float:
    """A number option: an ASCII decimal number, finite (``nan``, ``inf`` and ``1_000`` are refused by argparse
    in one line, before any command runs)."""
    from ..core.text import decimal_number

    try:
        return decimal_number(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite decimal number") from None


def counted(low: int, high: int, what: str):
    """An integer option within ``[low, high]`` (``what`` says why the bound)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{value} is not between {low} and {high} ({what})")
        return value
    return parse


#: Bounds of the integer options, by name: a seed is what NumPy's generator takes; more worker processes than
#: four per core gain nothing (and a typing error must not start a million processes).
INTEGER_OPTIONS = {"seed": (0, 2**63 - 1, "a random seed"), "first_seed": (0, 2**63 - 1, "a random seed"),
                   "workers": (1, 4 * (os.cpu_count() or 1), "worker processes, at most four per core"),
                   "max_iterations": (1, 10_000, "iterations of a solver"),
                   "runs": (1, 100_000, "Monte Carlo runs, each a simulation"), "verify": (0, 100_000, "Monte Carlo runs")}


def _finite_numbers(parser: argparse.ArgumentParser) -> None:
    """Every ``type=float`` option of every command reads through :func:`finite_float`, every seed and worker
    count within :data:`INTEGER_OPTIONS`."""
    for action in parser._actions:  # noqa: SLF001 (argparse keeps its actions there; no public walk)
        if action.type is float:
            action.type = finite_float
        if action.type is int and action.dest in INTEGER_OPTIONS:
            action.type = counted(*INTEGER_OPTIONS[action.dest])
        for child in (action.choices or {}).values() if isinstance(action.choices, dict) else ():
            _finite_numbers(child)


def _modulation_common(p: argparse.ArgumentParser) -> None:
    """The options ``modulate`` and ``modulate-mc`` share: schemes, errors, site, run length, output."""
    p.add_argument("--scheme", nargs="+", required=True, metavar="NAME|FILE",
                   help="rotation schemes: names of shipped ones (strapdown, single-axis-reciprocating, "
                   "dual-axis-16, yu-ruan2014-improved, ...) or scheme files (TOML, format casadi-sins-scheme/1)")
    p.add_argument("--errors", metavar="SHEET", help="error sheet: a file (TOML, format casadi-sins-errors/1, "
                   "natural units) or a shipped name (guan2023-table1, yu-ruan2014-sim)")
    p.add_argument("--params", metavar="P.csv", help="calibrated parameter table: its sigma (or its covariance) are "
                   "the residual sensor errors; the initial errors and noise come from --errors, if given")
    p.add_argument("--covariance", metavar="C.csv", help="full covariance of the --params table (square CSV, header "
                   "parameter,<names>, SI; default: the \"covariance\" of NAME.report.json beside the table, if any)")
    p.add_argument("--hours", type=float, required=True, help="length of the run, h")
    p.add_argument("--latitude", type=float, required=True, help="latitude of the static site, deg")
    p.add_argument("--height", type=float, default=0.0, help="height of the site, m (default 0)")
    p.add_argument("--initial", choices=("sheet", "aligned"), default="sheet",
                   help="initial attitude error: the sheet's alone (default, as Guan et al. 2023), or a static "
                   "alignment at each scheme's start attitude (correlated with the sensor errors) plus the sheet's")
    p.add_argument("--strict", action="store_true", help="a warning (a scheme that does not return to its start "
                   "attitude after one period) is a failure")
    p.add_argument("--out", required=True, help="output folder")


def _add_modulation(sub) -> None:
    """The rotation-modulation commands (issue 19)."""
    p = sub.add_parser("modulate", help="navigation error of a static INS under rotation schemes, by error source "
                       "(covariance): modulation.json, .md and plots")
    _modulation_common(p)
    p.add_argument("--turn-step-deg", type=float, default=5.0,
                   help="largest integration sub-step of a turn, deg (0.01-22.5, default 5)")
    p.add_argument("--output-step-s", type=float, default=60.0,
                   help="largest output interval in a dwell, s (default 60)")
    p.add_argument("--no-plots", action="store_true", help="write modulation.json and .md only")
    p.set_defaults(func=cmd_modulate)
    p = sub.add_parser("modulate-mc", help="time-domain Monte Carlo of the rotation modulation against its "
                       "covariance, per error source: montecarlo.json and .md")
    _modulation_common(p)
    p.add_argument("--runs", type=int, default=50, help="runs per error source (default 50)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--turn-step-deg", type=float, default=1.0,
                   help="navigation step in a turn, deg (0.01-22.5, default 1)")
    p.add_argument("--plain", action="store_true",
                   help="plain random draws of the constant errors (default: moment-matched, see docs/modulation.md)")
    p.add_argument("--workers", type=int, default=1,
                   help="local worker processes, one scheme each (default 1)")
    p.set_defaults(func=cmd_modulate_mc)
