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
from ..data.importers import import_samples, imported_recording, parse_map
from .commands import CliError, check_name_option, check_rate_option, check_site_options
from .logs import note


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
