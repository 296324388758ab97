"""Arguments of the production-line commands: ``apply``, ``history``, ``batch``."""

from __future__ import annotations

from ...model.catalog import MODELS


def apply(p) -> None:
    """The arguments of ``casadi-sins apply``."""
    p.add_argument("table", nargs="?", help="parameter table CSV to apply (not with --thermal)")
    p.add_argument("recording", nargs="?", help="recording description NAME.toml (raw pulses)")
    p.add_argument("--thermal", metavar="thermal.csv", help="a thermal model (from thermal) instead of a table: "
                   "the table at --temperature-c, else at the recording's temperature (its [conditions] "
                   "temperature_c, or the mean of its temperature column over the rests)")
    p.add_argument("--temperature-c", type=float, help="temperature of the unit, degC (with --thermal)")
    p.add_argument("--out", required=True, help="output folder: NAME-compensated.toml/.csv and NAME-compensated-check"
                   ".csv/.md")


def history(p) -> None:
    """The arguments of ``casadi-sins history``."""
    p.add_argument("tables", nargs="+", help="parameter tables of one unit (each with its companion NAME.report.json "
                   "from calibrate: unit id, date, recording hash)")
    p.add_argument("--tolerance", help="tolerance sheet TOML: [change] and [drift_per_year] limits per group or "
                   "parameter in natural units, z_limit (default 4)")
    p.add_argument("--out", required=True, help="output folder: history-summary, -changes, -calibrations "
                   "(CSV, Markdown) and history-GROUP.png")


def batch(p) -> None:
    """The arguments of ``casadi-sins batch``."""
    p.add_argument("recordings", nargs="+", help="recording descriptions NAME.toml, one unit each (unit id: the "
                   "recording's name), or folders: every recording description in them")
    p.add_argument("--out", required=True, help="output folder: fleet.csv/.md, fleet-spread.csv/.md, units/NAME.csv "
                   "with NAME.report.json/.md")
    p.add_argument("--dask", metavar="SCHEDULER", help="run on a Dask cluster: scheduler address (the workers must "
                   "read the recordings at the same paths), or 'local'")
    p.add_argument("--workers", type=int, help="worker processes, local or of the local Dask cluster (default: one "
                   "per core)")
    p.add_argument("--solver", default="nlp", choices=["nlp", "ils"], help="solver for every unit (default nlp)")
    p.add_argument("--model", default="21", choices=MODELS,
                   help="parameters for every unit (default the paper's 21; see calibrate --model)")
    p.add_argument("--noise", help="sensor datasheet TOML of the unit type (see calibrate --noise)")
    p.add_argument("--no-resume", action="store_true", help="calibrate every unit again, even those already done "
                   "from the same recording")
    p.add_argument("--tolerance", metavar="SHEET", help="tolerance sheet TOML with [accept.sigma] / [accept.value]: "
                   "each unit's verdict in the fleet table and its report")
    p.add_argument("--certificate", nargs="?", const="html", choices=("html", "pdf"),
                   help="also each unit's certificate, units/NAME.certificate.html (or .pdf with 'pdf'; see calibrate)")
