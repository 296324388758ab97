"""``casadi-sins import psins|mat|hdf5|parquet SRC --out REC.toml``: another tool's samples as a recording.

The schedule comes from a description (``--segments DESCRIPTION.toml``: its site, rate, segments and
conditions) or is found in the samples (``--latitude`` [``--height``]), as ``segment`` does.  The
recording (TOML and CSV) is written whole or not at all.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.earth import Site
from ..core.errors import InputError
from ..data.description import as_read, read_description, write_recording
from ..data.importers import FORMATS, KEYS, import_samples, imported_recording, parse_map
from .commands import CliError, check_name_option, check_rate_option, check_site_options
from .logs import note


def add_import_parser(sub) -> None:
    """The ``import`` subcommand's arguments."""
    p = sub.add_parser("import", help="samples of another tool (PSINS [wm vm t], MATLAB .mat, HDF5, Parquet) as a "
                       "recording (TOML + CSV)")
    p.add_argument("kind", choices=FORMATS, help="psins: [wm vm t] array (.mat variable 'imu' or a text file); mat: "
                   "variables by name; hdf5: datasets by path; parquet: columns by name")
    p.add_argument("src", help="the file to import")
    p.add_argument("--out", required=True, help="recording description NAME.toml to write (and NAME.csv)")
    p.add_argument("--map", nargs="+", metavar="KEY=NAME", help=f"names in the file for {', '.join(KEYS)} "
                   "(default: the keys themselves; gyro/accel: one array of three columns)")
    p.add_argument("--segments", help="a description to take site, rate, segments and conditions from")
    p.add_argument("--rate", type=float, help="sample rate, Hz (default: the description's, else the time column's)")
    p.add_argument("--latitude", type=float, help="latitude of the site, deg (to find the segments without --segments)")
    p.add_argument("--height", type=float, default=0.0, help="height of the site, m (default 0)")
    p.add_argument("--name", help="recording name (default: the output's stem)")
    p.set_defaults(func=cmd_import)


def cmd_import(args) -> int:
    """``import``: read, build and validate the recording, read it back in memory as the reader would once
    written, then write it (a recording our own reader refuses is never written)."""
    out = Path(args.out)
    name = check_name_option(args.name or out.stem)
    check_site_options(0.0 if args.latitude is None else args.latitude, args.height)
    check_rate_option(args.rate)
    names = parse_map(args.map)
    time, pulses, temperature = import_samples(args.kind, args.src, names)
    template = read_description(args.segments) if args.segments else None
    site = Site(np.radians(args.latitude), args.height) if template is None and args.latitude is not None else None
    rec, notes = imported_recording(time, pulses, temperature, name, template, args.rate, site, label=str(args.src))
    try:
        as_read(rec, out)
    except InputError as exc:
        raise CliError(f"{args.src}: imported, it would be a recording the reader refuses: {exc}") from None
    write_recording(rec, out)
    for text in notes:
        note(text)
    print(f"wrote {out} and {out.with_suffix('.csv').name}: {len(rec.time)} samples at {rec.rate_hz:g} Hz, "
          f"{len(rec.segments)} segments")
    return 0
