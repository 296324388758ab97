"""``casadi-sins noise``: noise identification from a long recording at rest (issue 36).  Parsing and printing
only; the work is in :mod:`studies.static_noise`."""

from __future__ import annotations

import sys

from ..core.files import write_files
from .logs import progress_for


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
