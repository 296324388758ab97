"""Every command of ``casadi-sins``, one record each (:class:`cli.command.Command`), in the order of the help.

The parser (:func:`cli.parser.build_parser`), the output guard, the progress options and the input scan
(:func:`cli.main`) all read these records; a new command is one record here, its arguments in
:mod:`cli.arguments` and its run function.
"""

from __future__ import annotations

from .arguments import production as P
from .arguments import recording as R
from .arguments import studies as S
from .command import Command

COMMANDS: tuple[Command, ...] = (
    Command("simulate", "simulate a problem's experiment into a recording and its truth (a thermal problem: one "
            "recording per temperature setpoint)", R.simulate, ".thermal:cmd_simulate_any", long=True,
            not_inputs=("name",)),
    Command("validate", "read and check a recording; print its summary", R.validate, ".commands:cmd_validate",
            output="none"),
    Command("rough", "the paper's rough initial parameters of a recording", R.rough, ".commands:cmd_rough",
            output="file"),
    Command("navigate", "navigate a recording's groups; velocity per static segment and a plot", R.navigate,
            ".commands:cmd_navigate"),
    Command("calibrate", "calibrate a recording: the parameter table (and a report)", R.calibrate,
            ".commands:cmd_calibrate", output="file", long=True, not_inputs=("report", "export"),
            owns="..report.calibration:calibration_outputs"),
    Command("segment", "find the static and rotation segments of a CSV and write its description", R.segment,
            ".commands:cmd_segment", output="file", not_inputs=("name",)),
    Command("export", "a parameter table as compensation matrices (JSON, YAML, C header) or PSINS clbt text, with "
            "the provenance from the table's companion report", R.export, ".thermal:cmd_export_any", output="file",
            not_inputs=("format",)),
    Command("compare", "run both solvers on a recording and compare them (CSV, Markdown, PNG)", R.compare,
            ".commands:cmd_compare", long=True),
    Command("analyze", "predicted accuracy of schedules before any data (problem or recording)", S.analyze,
            ".commands:cmd_analyze", long=True),
    Command("montecarlo", "simulate and calibrate many seeds: RMS error against sigma", S.montecarlo,
            ".commands:cmd_montecarlo", long=True, not_inputs=("dask",)),
    Command("navcheck", "free-inertial navigation at rest per table: a fresh simulated static recording of a "
            "problem, or the unit's own static recording", S.navcheck, ".production:cmd_navcheck_any", long=True),
    Command("budget", "static navigation error over 1 h and 24 h by source, by covariance (a problem, or the unit's "
            "recording with its table)", S.budget, ".production:cmd_budget_any", long=True),
    Command("demo", "simulate the paper's experiment, both solvers side by side, navigation check and error budget",
            S.demo, ".commands:cmd_demo", long=True),
    Command("modulate", "navigation error of a static INS under rotation schemes, by error source (covariance): "
            "modulation.json, .md and plots", S.modulate, ".modulation:cmd_modulate", long=True),
    Command("modulate-mc", "time-domain Monte Carlo of the rotation modulation against its covariance, per error "
            "source: montecarlo.json and .md", S.modulate_mc, ".modulation:cmd_modulate_mc", long=True),
    Command("apply", "compensate a recording with a table: the compensated recording (increments in rad and m/s) "
            "and its check against gravity and the Earth rate at rest", P.apply, ".production:cmd_apply",
            epilog="exit status: 0 the check at rest passed (every static segment within 5 sigma of gravity and "
            "the Earth rate, noise of the mean and the table's sigma combined); 3 some segment beyond; 2 bad input"),
    Command("history", "one unit's calibrations by date: change per parameter against the combined sigma (z), "
            "drift per year, pass/fail against a tolerance sheet, a plot per group", P.history,
            ".production:cmd_history"),
    Command("batch", "calibrate many units' recordings: a fleet table, the spread per parameter with outliers, "
            "each unit's table and report; resumable", P.batch, ".production:cmd_batch", long=True,
            incremental=True, not_inputs=("dask",),
            epilog="exit status: 0 every unit calibrated (and passed); 2 some unit failed to calibrate; 3 every "
            "unit calibrated but some failed its tolerance sheet"),
    Command("thermal", "a temperature model per parameter from one unit's calibrations at several temperatures: "
            "thermal.csv, thermal.md, plots, and tables at chosen temperatures", S.thermal, ".thermal:cmd_thermal"),
    Command("import", "samples of another tool (PSINS [wm vm t], MATLAB .mat, HDF5, Parquet) as a recording "
            "(TOML + CSV)", R.import_, ".importing:cmd_import", output="recording", not_inputs=("name",)),
    Command("design-scheme", "design a rotation scheme: search sequences of 180 deg turns for the smallest "
            "navigation error of the covariance; scheme.toml and design.json/.md", S.design_scheme,
            ".scheme_design:cmd_design_scheme", long=True),
    Command("design", "design a calibration schedule (positions, turns, dwell times) under a time budget: "
            "design.toml, design.md, design.png", S.design, ".design:cmd_design", long=True),
    Command("noise", "noise identification from hours at rest: Allan deviation, white noise, quantization and "
            "Gauss-Markov bias per axis with uncertainties, plots, and the datasheet calibrate --noise takes",
            R.noise, ".noise:cmd_noise", long=True),
)
#: The records by name.
BY_NAME = {c.name: c for c in COMMANDS}


def command(name: str) -> Command:
    """The record of the command ``name``."""
    return BY_NAME[name]
