"""``casadi-sins noise``: noise identification from a long recording at rest (issue 36).  Parsing and printing
only; the work is in :mod:`studies.static_noise`."""

from __future__ import annotations

import sys

from ..core.files import write_files
from .logs import progress_for


def add_noise_command(sub) -> None:
    """Register ``noise`` with the command line's sub-parsers."""
    p = sub.add_parser("noise", help="noise identification from hours at rest: Allan deviation, white noise, "
                       "quantization and Gauss-Markov bias per axis with uncertainties, plots, and the datasheet "
                       "calibrate --noise takes")
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
    p.set_defaults(func=cmd_noise)


def cmd_noise(args) -> int:
    """``noise``: read, identify, write every file together, print the terms."""
    from ..report.noise_identification import shown, units_of
    from ..studies.static_noise import noise_files, run_noise, scale_from
    scale = scale_from(args.params, tuple(args.scale) if args.scale else None)
    with progress_for(args, 1.0, "noise: reading", unit="") as reading, \
            progress_for(args, 6, "noise: fitting", unit="axis") as fitting:
        study = run_noise(args.recording, args.rate, args.segment, scale, reading, fitting)
    write_files(noise_files(study, args.out, plots=not args.no_plots))
    ident = study.identification
    print(f"{study.run.label}: {study.samples} samples, {ident.duration / 3600:.3g} h at {ident.rate_hz:g} Hz; "
          f"scale: {study.scale.source}")
    for axis, (name, fit) in enumerate(zip(ident.axes, ident.fits)):
        units = units_of(study, "gyro" if axis < 3 else "accel")
        tau = "" if fit.status == "not detected" else f", tau {shown(fit.gm_tau, 1.0)} s"
        print(f"{name:8s} white {shown(fit.white, units.white[0])} {units.white[1]}; quantization "
              f"{shown(fit.quantization, units.quantization[0])} {units.quantization[1]}; Gauss-Markov sigma "
              f"{shown(fit.gm_sigma, units.rate[0])} {units.rate[1]}{tau} ({fit.status})")
    notes, warnings = study.messages()
    for text in warnings:
        print(f"warning: {text}", file=sys.stderr)
    for text in notes:
        print(f"note: {text}", file=sys.stderr)
    written = ["noise.json", "noise.md"] + ([] if args.no_plots else ["allan-gyro.png", "allan-accel.png"]) + \
        (["datasheet.toml"] if study.scale.si else [])
    print(f"wrote {args.out}/{{{','.join(written)}}} ({study.seconds:.1f} s)")
    return 0
