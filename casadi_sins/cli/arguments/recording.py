"""Arguments of the commands on one recording or table: ``simulate``, ``validate``, ``rough``, ``navigate``,
``calibrate``, ``segment``, ``export``, ``compare``, ``import``, ``noise``."""

from __future__ import annotations

from ...data.formats import IMPORT_FORMATS, IMPORT_KEYS
from ...model.catalog import MODELS, extra_group_labels
from ...report.export_formats import EXPORT_FORMATS, export_formats_help

RECORDING_HELP = "recording description NAME.toml"


def simulate(p) -> None:
    """The arguments of ``casadi-sins simulate``."""
    p.add_argument("problem", nargs="?", default=None, help="problem file (default: the paper's experiment)")
    p.add_argument("--seed", type=int, default=0, help="random seed of deviations and noise (default 0)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--name", help="recording name (default PROBLEM-seedN)")
    p.add_argument("--no-noise", action="store_true", help="leave out the sensor noise")
    p.add_argument("--quantize", action="store_true", help="integer pulses, remainder carried")
    p.add_argument("--start-attitude-deg", type=float, help="start attitude deviation per angle, deg (default: "
                   "the problem's start_attitude_deg)")


def validate(p) -> None:
    """The arguments of ``casadi-sins validate``."""
    p.add_argument("recording", help=RECORDING_HELP)


def rough(p) -> None:
    """The arguments of ``casadi-sins rough``."""
    p.add_argument("recording", help=RECORDING_HELP)
    p.add_argument("--out", required=True, help="parameter table CSV to write")


def navigate(p) -> None:
    """The arguments of ``casadi-sins navigate``."""
    p.add_argument("recording", help=RECORDING_HELP)
    p.add_argument("--params", nargs="*", help="parameter tables (default: rough initial values)")
    p.add_argument("--out", required=True, help="output folder")


def calibrate(p) -> None:
    """The arguments of ``casadi-sins calibrate``."""
    p.add_argument("recording", help=RECORDING_HELP)
    p.add_argument("--solver", default="nlp", choices=["nlp", "ils"],
                   help="nlp: CasADi/Ipopt over all rotations (default); ils: the paper's iterative least squares")
    p.add_argument("--out", required=True, help="parameter table CSV to write")
    p.add_argument("--report", help="folder for the full report: per-iteration and parameter tables (CSV, "
                   "Markdown), the report (JSON, Markdown), residual and Allan-deviation plots (PNG)")
    p.add_argument("--truth", help="truth table: adds errors in natural units to the table and report")
    p.add_argument("--initial", help="starting parameter table (default: the paper's rough values)")
    p.add_argument("--max-iterations", type=int, help="iteration cap: nlp, Ipopt's (default 100, typically 3-5 "
                   "used); ils, the paper's iterations (default 10, typically 4 used)")
    p.add_argument("--noise", help="sensor datasheet (TOML, natural units: gyro_arw_deg_rth, accel_vrw_ug_rthz, "
                   "gyro_bias_instability_deg_h, gyro_bias_tau_s, ...); terms not given are measured in the data")
    p.add_argument("--strict", action="store_true", help="any warning is a failure: exit 2, no table")
    p.add_argument("--accept-distrusted", action="store_true",
                   help="write a table the calibration's own checks do not trust (by default: exit 2, no table), "
                   "marked: a trust column 'distrusted' in the table, the reasons in the report, exit 4")
    p.add_argument("--model", default=None, choices=MODELS,
                   help="parameters: the paper's 21; extended: also every extra group "
                   f"({', '.join(extra_group_labels())}); auto: the extra groups the data support (nlp only). "
                   "Default: 21, and 21 with the "
                   "gyro g-sensitivity for a MEMS unit moved by hand (rests at any orientation)")
    p.add_argument("--export", nargs="+", choices=list(EXPORT_FORMATS),
                   help=f"also write the table in these formats, beside it: {export_formats_help()}")
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


def segment(p) -> None:
    """The arguments of ``casadi-sins segment``."""
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


def export(p) -> None:
    """The arguments of ``casadi-sins export``."""
    p.add_argument("table", help="parameter table CSV (or a thermal model thermal.csv: --format c only)")
    p.add_argument("--format", required=True, choices=list(EXPORT_FORMATS), help=export_formats_help())
    p.add_argument("--out", required=True, help="file to write")
    p.add_argument("--unit-id", help="serial number of the unit")


def compare(p) -> None:
    """The arguments of ``casadi-sins compare``."""
    p.add_argument("recording", help=RECORDING_HELP)
    p.add_argument("--truth", help="truth table: errors against it in natural units")
    p.add_argument("--out", required=True, help="output folder")


def import_(p) -> None:
    """The arguments of ``casadi-sins import``."""
    p.add_argument("kind", choices=list(IMPORT_FORMATS),
                   help="; ".join(f"{kind}: {what}" for kind, what in IMPORT_FORMATS.items()))
    p.add_argument("src", help="the file to import")
    p.add_argument("--out", required=True, help="recording description NAME.toml to write (and NAME.csv)")
    p.add_argument("--map", nargs="+", metavar="KEY=NAME", help=f"names in the file for {', '.join(IMPORT_KEYS)} "
                   "(default: the keys themselves; gyro/accel: one array of three columns)")
    p.add_argument("--segments", help="a description to take site, rate, segments and conditions from")
    p.add_argument("--rate", type=float, help="sample rate, Hz (default: the description's, else the time column's)")
    p.add_argument("--latitude", type=float, help="latitude of the site, deg (to find the segments without "
                   "--segments)")
    p.add_argument("--height", type=float, default=0.0, help="height of the site, m (default 0)")
    p.add_argument("--name", help="recording name (default: the output's stem)")


def noise(p) -> None:
    """The arguments of ``casadi-sins noise``."""
    p.add_argument("recording", metavar="STATIC.toml|CSV",
                   help="recording description with one static segment (or none: all at rest), or a bare CSV of "
                   "samples (with --rate)")
    p.add_argument("--rate", type=float, metavar="HZ", help="sample rate of a bare CSV, Hz")
    p.add_argument("--segment", type=int, metavar="N", help="the static segment of a description with several "
                   "(its number in file order)")
    p.add_argument("--params", metavar="P.csv", help="parameter table of the unit (a calibration's): its scale "
                   "factors put the noise in SI and give the datasheet")
    p.add_argument("--scale", type=float, nargs=2, metavar=("GYRO", "ACCEL"),
                   help="nominal pulse weights instead of a table: rad/pulse and m/s/pulse (as a parameter table "
                   "has them); without --params or --scale the noise is in pulses and no datasheet is written")
    p.add_argument("--no-plots", action="store_true", help="leave out the Allan deviation plots")
    p.add_argument("--out", required=True, help="output folder: noise.json, noise.md, allan-gyro.png, "
                   "allan-accel.png, datasheet.toml")
