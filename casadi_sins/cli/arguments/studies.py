"""Arguments of the studies: ``analyze``, ``montecarlo``, ``navcheck``, ``budget``, ``demo``, ``modulate``,
``modulate-mc``, ``design-scheme``, ``design``, ``thermal``."""

from __future__ import annotations

import argparse

from ...model.catalog import FIXED_MODELS, extra_group_labels
from ...studies.choices import DESIGN_CRITERIA, SCHEME_CRITERIA
from ...studies.modulation.shipped import shipped_names

PROBLEM_HELP = "problem file (default: the paper's experiment)"


def analyze(p) -> None:
    """The arguments of ``casadi-sins analyze``."""
    p.add_argument("inputs", nargs="+", help="problem files or recordings (several: compared side by side)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--accel-vrw-ug-rthz", type=float, help="accelerometer white noise density (velocity random "
                   "walk), ug/sqrt(Hz), as in a --noise datasheet (default: the problem's, or measured in the "
                   "recording)")
    p.add_argument("--gyro-arw-deg-rth", type=float, help="gyro white noise density (angle random walk), "
                   "deg/sqrt(h), as in a --noise datasheet (default: the problem's, or measured in the recording)")
    p.add_argument("--accel-noise-ug", type=float, help="refused (the old per-sample form): use --accel-vrw-ug-rthz")
    p.add_argument("--gyro-noise-deg-h", type=float, help="refused (the old per-sample form): use --gyro-arw-deg-rth")
    p.add_argument("--model", default="21", choices=FIXED_MODELS,
                   help="21: the paper's parameters (default); extended: also predict the extra groups of the "
                   f"registry ({', '.join(extra_group_labels())})")


def montecarlo(p) -> None:
    """The arguments of ``casadi-sins montecarlo``."""
    p.add_argument("problem", nargs="?", default=None, help=PROBLEM_HELP)
    p.add_argument("--runs", type=int, default=50, help="number of seeds (default 50)")
    p.add_argument("--first-seed", type=int, default=10000, help="first seed (default 10000)")
    p.add_argument("--solvers", nargs="+", default=["nlp", "ils"], choices=["nlp", "ils"],
                   help="solvers to run (default both)")
    p.add_argument("--workers", type=int, help="local worker processes (default: one per core)")
    p.add_argument("--dask", metavar="SCHEDULER", help="run on a Dask cluster: scheduler address, or 'local'")
    p.add_argument("--out", default="runs/montecarlo", help="output folder (default runs/montecarlo)")


def navcheck(p) -> None:
    """The arguments of ``casadi-sins navcheck``."""
    p.add_argument("problem", nargs="?", default=None, metavar="PROBLEM_OR_RECORDING",
                   help="problem file (sensors, truth, noise; default paper), or a recording REC.toml of the unit at "
                   "rest (its longest static segment is navigated)")
    p.add_argument("--params", nargs="+", required=True, help="parameter tables to check")
    p.add_argument("--seed", type=int, default=0, help="seed of the fresh static recording (default 0)")
    p.add_argument("--duration-s", type=float, help="navigation time, s (default 3600; on a recording: the rest of "
                   "its static segment)")
    p.add_argument("--align-s", type=float, default=300.0, help="alignment time before it, s (default 300)")
    p.add_argument("--out", required=True, help="output folder")


def budget(p) -> None:
    """The arguments of ``casadi-sins budget``."""
    p.add_argument("problem", nargs="?", default=None, metavar="PROBLEM_OR_RECORDING",
                   help="problem file: site, sensors, noise (default paper); or a recording REC.toml: its site and "
                   "measured noise, with --params")
    p.add_argument("--params", help="calibrated parameter table with sigma (default: the schedule's predicted "
                   "covariance)")
    p.add_argument("--orientation", help="orientation letters of the unit while navigating (default ENU; on a "
                   "recording, that of its longest static segment)")
    p.add_argument("--hours", type=float, default=24.0, help="navigation time, h (default 24)")
    p.add_argument("--out", required=True, help="output folder")


def demo(p) -> None:
    """The arguments of ``casadi-sins demo``."""
    p.add_argument("problem", nargs="?", default=None, help=PROBLEM_HELP)
    p.add_argument("--seed", type=int, default=1, help="random seed of the simulation (default 1)")
    p.add_argument("--out", default="runs/demo", help="output folder (default runs/demo; the published "
                   "results/ are made by benchmarks/regenerate_results.sh)")


def _shipped(kind: str) -> str:
    """The names of the shipped files of a kind (``"schemes"``, ``"sheets"``), for a help text."""
    return ", ".join(shipped_names(kind))


def _residual_errors(p) -> None:
    """``--errors``, ``--params``, ``--covariance``: the errors ``modulate``, ``modulate-mc`` and
    ``design-scheme`` take."""
    p.add_argument("--errors", metavar="SHEET", help="error sheet: a file (TOML, format casadi-sins-errors/1, "
                   f"natural units) or a shipped name ({_shipped('sheets')})")
    p.add_argument("--params", metavar="P.csv", help="calibrated parameter table: its sigma (or its covariance) are "
                   "the residual sensor errors; the initial errors and noise come from --errors, if given")
    p.add_argument("--covariance", metavar="C.csv", help="full covariance of the --params table (square CSV, header "
                   "parameter,<names>, SI; default: the \"covariance\" of NAME.report.json beside the table, if any)")


def _static_site(p) -> None:
    """``--hours``, ``--latitude``, ``--height``: the run at a static site."""
    p.add_argument("--hours", type=float, required=True, help="length of the run, h")
    p.add_argument("--latitude", type=float, required=True, help="latitude of the static site, deg")
    p.add_argument("--height", type=float, default=0.0, help="height of the site, m (default 0)")


def _modulation_common(p) -> None:
    """The options ``modulate`` and ``modulate-mc`` share: schemes, errors, site, run length, output."""
    p.add_argument("--scheme", nargs="+", required=True, metavar="NAME|FILE",
                   help=f"rotation schemes: names of shipped ones ({_shipped('schemes')}) or scheme files (TOML, "
                   "format casadi-sins-scheme/1)")
    _residual_errors(p)
    _static_site(p)
    p.add_argument("--initial", choices=("sheet", "aligned"), default="sheet",
                   help="initial attitude error: the sheet's alone (default, as Guan et al. 2023), or a static "
                   "alignment at each scheme's start attitude (correlated with the sensor errors) plus the sheet's")
    p.add_argument("--strict", action="store_true", help="a warning (a scheme that does not return to its start "
                   "attitude after one period) is a failure")
    p.add_argument("--out", required=True, help="output folder")


def modulate(p) -> None:
    """The arguments of ``casadi-sins modulate``."""
    _modulation_common(p)
    p.add_argument("--turn-step-deg", type=float, default=5.0,
                   help="largest integration sub-step of a turn, deg (0.01-22.5, default 5)")
    p.add_argument("--output-step-s", type=float, default=60.0,
                   help="largest output interval in a dwell, s (default 60)")
    p.add_argument("--no-plots", action="store_true", help="write modulation.json and .md only")


def modulate_mc(p) -> None:
    """The arguments of ``casadi-sins modulate-mc``."""
    _modulation_common(p)
    p.add_argument("--runs", type=int, default=50, help="runs per error source (default 50)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--turn-step-deg", type=float, default=1.0,
                   help="navigation step in a turn, deg (0.01-22.5, default 1)")
    p.add_argument("--plain", action="store_true",
                   help="plain random draws of the constant errors (default: moment-matched, see docs/modulation.md)")
    p.add_argument("--workers", type=int, default=1,
                   help="local worker processes, one scheme each (default 1)")


def design_scheme(p) -> None:
    """The arguments of ``casadi-sins design-scheme``."""
    p.add_argument("--errors", metavar="SHEET", help=f"error sheet: a file or a shipped name ({_shipped('sheets')})")
    p.add_argument("--params", metavar="P.csv", help="calibrated parameter table: design for its residual errors "
                   "(its sigma or covariance); initial errors and noise from --errors, if given")
    p.add_argument("--covariance", metavar="C.csv", help="full covariance of the --params table (as modulate)")
    p.add_argument("--positions", type=int, required=True, help="stops per period (even: 180 deg turns must "
                   "return to the start)")
    p.add_argument("--axes", type=int, default=2, choices=(1, 2), help="1: the vertical IMU axis z alone; 2 "
                   "(default): z and a horizontal IMU axis (y and x both searched)")
    p.add_argument("--rate-deg-s", type=float, required=True, help="turn rate, deg/s")
    p.add_argument("--stop-s", type=float, required=True, help="stop after each turn, s")
    _static_site(p)
    p.add_argument("--criterion", choices=SCHEME_CRITERIA, default="position",
                   help="position (default): largest horizontal position error of the run; velocity: largest "
                   "horizontal velocity error; final: horizontal position error at the end of the run")
    p.add_argument("--samples", type=int, default=20000, help="random start sequences per inner axis "
                   "(default 20000; all of them when the space is small)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random start sequences (default 0)")
    p.add_argument("--out", required=True, help="output folder: scheme.toml, design.json, design.md")


def _angles(text: str) -> tuple[int, ...]:
    """``--angles 90,180``: whole degrees, sorted, each once."""
    try:
        return tuple(sorted({int(a) for a in text.split(",") if a.strip()}))
    except ValueError:
        raise argparse.ArgumentTypeError(f"angles must be whole degrees separated by commas, found {text!r}") from None


def design(p) -> None:
    """The arguments of ``casadi-sins design``."""
    p.add_argument("problem", help="problem file: the unit, its noise and site, and the schedule to beat")
    p.add_argument("--total-s", type=float, required=True, help="time budget, s: statics + turns + handling")
    p.add_argument("--table-axes", type=int, choices=(1, 2, 3), default=3,
                   help="axes of the turntable: 3 turns about any body axis, 2 about the mount and a horizontal "
                   "(north) axis, 1 about the mount only (other positions need a new group) (default 3)")
    p.add_argument("--model", default="21", choices=FIXED_MODELS, help="parameter model (default 21)")
    p.add_argument("--criterion", default="d", choices=DESIGN_CRITERIA,
                   help="d: log det of the predicted covariance (natural units); a: its trace in units of the "
                   "input's variances; worst: the largest sigma ratio to the input; navigation: static "
                   "navigation error after --hours, or with --scheme the largest error of the modulated INS "
                   "(default d)")
    p.add_argument("--hours", type=float, default=1.0, help="navigation time of --criterion navigation, h (default 1)")
    p.add_argument("--scheme", metavar="NAME|FILE",
                   help="with --criterion navigation: the rotation scheme the unit runs in operation (a shipped "
                   f"name: {_shipped('schemes')}; or a scheme file); the criterion is then "
                   "the largest position error of the modulated INS over --hours, as modulate --initial aligned "
                   "reports it with the problem's white noise")
    p.add_argument("--max-rate-deg-s", type=float, help="peak turn rate, deg/s (default: the input schedule's)")
    p.add_argument("--angles", type=_angles, default=(90, 180), help="turn angles allowed, deg (default 90,180)")
    p.add_argument("--min-rest-s", type=float, default=30.0, help="shortest static, s (default 30)")
    p.add_argument("--first-rest-s", type=float, default=60.0,
                   help="shortest first static of a group (its alignment), s (default 60)")
    p.add_argument("--handling-s", type=float, default=60.0,
                   help="time to handle the unit between groups, s; counts against --total-s (default 60)")
    p.add_argument("--cap", type=float, default=1.1,
                   help="a parameter's sigma above this times the input's is penalised (default 1.1)")
    p.add_argument("--evaluations", type=int, default=300,
                   help="orientation sequences scored by the search (default 300; each about 0.5 s)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the search (default 0)")
    p.add_argument("--verify", type=int, default=0, metavar="N",
                   help="Monte Carlo of the design: N simulated recordings (seeds from 10000, as montecarlo) "
                   "calibrated with both solvers; files in OUT/verify/")
    p.add_argument("--workers", type=int, help="local processes of the Monte Carlo (default one per core)")
    p.add_argument("--solvers", nargs="+", default=["nlp"], choices=["nlp", "ils"],
                   help="solvers whose predicted sigma the report gives: the search scores the NLP's (the default "
                   "solver); with ils also the paper's ILS's on both schedules (default nlp)")
    p.add_argument("--out", required=True, help="output folder")


def thermal(p) -> None:
    """The arguments of ``casadi-sins thermal``."""
    p.add_argument("tables", nargs="+", metavar="TABLE.csv[@T]",
                   help="parameter tables of one unit (their NAME.report.json gives the full covariance and the "
                   "temperature, conditions.temperature_c); NAME.csv@25 gives the temperature (degC) explicitly")
    p.add_argument("--temperatures", type=float, nargs="+", metavar="T",
                   help="temperature of each table, degC, in the order of the tables (instead of the reports')")
    p.add_argument("--order", choices=("auto", "1", "2"), default="auto",
                   help="polynomial order per parameter: auto (by evidence, default), 1 or 2 for all")
    p.add_argument("--reference-c", type=float, default=25.0, help="reference temperature T_ref, degC (default 25)")
    p.add_argument("--at", type=float, nargs="+", default=[], metavar="T",
                   help="write the parameter table at each temperature T (degC): DIR/at-<T>C.csv (default: none)")
    p.add_argument("--no-plots", action="store_true", help="leave out the plots")
    p.add_argument("--out", required=True, help="output folder")
