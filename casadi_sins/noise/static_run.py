"""A long recording at rest for the noise identification: which samples, read once, checked.

Three forms (``casadi-sins noise``):

* a recording description (``sins-recording/1``) with one static segment: its samples;
* a description with no ``[[segments]]``: the whole recording is at rest;
* a bare CSV of samples (the format's columns) with its rate.

A description with several static segments names the one to use (``segment``); rotations elsewhere in it
are left alone.  The samples are streamed (:func:`data.samples.sample_blocks`) through the accumulator
(:class:`noise.rest.RestAccumulator`): the file is checked as every reader checks it (uniform time: a gap
is a time step that is not ``1 / rate_hz`` and is named by its line), the segment must lie within the data,
the rest must last :data:`MIN_REST_S`, and must be still (:mod:`noise.stillness`).  Every problem is one
:class:`~core.errors.InputError` naming the file, line or segment.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.inputs import COMPRESSED, COMPRESSION_RATIO
from ..data.description import read_description
from ..data.recording import PULSE_COLUMNS, SEGMENT_OVERHANG_S, TIME_TOLERANCE, Segment
from ..data.samples import sample_blocks
from .rest import RestAccumulator, RestRecord
from .stillness import find_motion

#: The shortest rest identified: ten minutes (a white noise needs far less, but no bias instability of a
#: navigation-grade sensor shows in less, and a shorter record is the calibration's raw estimate's business).
MIN_REST_S = 600.0


@dataclasses.dataclass(frozen=True)
class StaticRun:
    """Where the samples at rest are.

    Attributes
    ----------
    data : Path
        The CSV of samples.
    rate_hz : float
    name : str
        The recording's name (the description's, or the CSV's stem).
    description : Path or None
        The description, when given.
    segment : Segment or None
        The static segment used (None: every sample).
    notes : tuple of str
        What the description's reader noted.
    """

    data: Path
    rate_hz: float
    name: str
    description: Path | None = None
    segment: Segment | None = None
    notes: tuple[str, ...] = ()

    @property
    def label(self) -> str:
        """How messages name the samples: the segment of the description, or the file."""
        where = str(self.description or self.data)
        return f"{where}, {self.segment.describe()}" if self.segment else where


def static_run(path: str | Path, rate_hz: float | None = None, segment: int | None = None) -> StaticRun:
    """The samples at rest of a description (``.toml``) or a bare CSV (the three forms of the module docstring).

    Raises
    ------
    InputError
        A description with ``rate_hz`` given, a CSV without it, a segment that is not a static one, or several
        static segments and none chosen.
    """
    path = Path(path)
    if path.suffix.lower() != ".toml":
        if rate_hz is None:
            raise InputError(path, "a CSV of samples needs its sample rate (--rate HZ); a recording description "
                             "(.toml) gives it")
        if segment is not None:
            raise InputError(path, "--segment names a static segment of a recording description, not of a CSV")
        if not 1.0 <= rate_hz <= 1e5:
            raise InputError(path, f"the sample rate must be between 1 and 100000 Hz, found {rate_hz:g}")
        return StaticRun(path, float(rate_hz), path.name.split(".")[0] or "recording")
    if rate_hz is not None:
        raise InputError(path, "a recording description gives its rate ([imu] rate_hz): --rate is for a bare CSV")
    head = read_description(path, require_segments=False)
    statics = [s for s in head["segments"] if s.is_static]
    chosen = None
    if segment is not None:
        chosen = next((s for s in head["segments"] if s.number == segment), None)
        if chosen is None or not chosen.is_static:
            numbers = ", ".join(str(s.number) for s in statics) or "none"
            raise InputError(path, f"segment {segment} is not a static segment of the description (static: {numbers})")
    elif len(statics) == 1:
        chosen = statics[0]
    elif statics:
        raise InputError(path, f"{len(statics)} static segments: name the long rest to identify with --segment N "
                         f"(one of {', '.join(str(s.number) for s in statics)})")
    elif head["segments"]:
        raise InputError(path, "no static segment: the noise is identified on a rest (one static segment, or a "
                         "description without segments for a recording all at rest)")
    return StaticRun(path.parent / head["data"], head["rate_hz"], head["name"], path, chosen, tuple(head["warnings"]))


def read_rest(run: StaticRun, progress=None) -> RestRecord:
    """Stream the samples at rest through the accumulator; the checks of the module docstring.

    ``progress(done, total)`` is called with the bytes of text read and an estimate of the file's.
    """
    dt = 1.0 / run.rate_hz
    tol = TIME_TOLERANCE * dt
    try:
        size = run.data.stat().st_size
    except OSError:
        size = 0
    total = size * (COMPRESSION_RATIO if run.data.suffix in COMPRESSED else 1.0)
    acc = None
    first_time = last_time = None
    done = 0
    for time, pulses, text_bytes in sample_blocks(run.data, run.rate_hz):
        if acc is None:  # the record's length from the first block's bytes per sample sizes the blocks
            expected = len(time) * total / max(text_bytes, 1)
            if run.segment is not None:
                expected = min(expected, (run.segment.end - run.segment.start) * run.rate_hz)
            acc = RestAccumulator(run.rate_hz, expected_samples=int(expected))
        if first_time is None and len(time):
            first_time = float(time[0])
        if len(time):
            last_time = float(time[-1])
        done += text_bytes
        if run.segment is not None:
            inside = (time - dt >= run.segment.start - tol) & (time <= run.segment.end + tol)
            pulses = pulses[inside]
        acc.add(pulses)
        if progress is not None:
            progress(done, max(total, done))
        if run.segment is not None and len(time) and time[-1] > run.segment.end + tol:
            break  # the rest of the file lies after the segment
    if first_time is None:
        raise InputError(run.data, "no samples")
    if run.segment is not None:
        _check_within(run, first_time - dt, last_time)
    record = acc.result()
    if record.duration < MIN_REST_S:
        raise InputError(run.label, f"the rest lasts {record.duration:.6g} s ({record.samples} samples): the noise "
                         f"identification needs at least {MIN_REST_S:g} s at rest (calibrate's raw estimate measures "
                         "the white noise of shorter rests)")
    still = [PULSE_COLUMNS[i] for i in range(record.allan.avar.shape[1]) if not np.any(record.allan.avar[:, i] > 0)]
    if still:
        raise InputError(run.label, f"{', '.join(still)}: every sample the same, no noise to identify (a simulation "
                         "without noise, or a stuck counter)")
    motion = find_motion(record.window_means, record.window_s, record.window_samples)
    if motion is not None:
        start = (run.segment.start if run.segment else first_time - dt) + motion.start_s
        raise InputError(run.label, f"not at rest at {start:.6g}-{start + motion.end_s - motion.start_s:.6g} s: "
                         f"{motion.text}; identify a stretch without motion (a static segment of a description, "
                         "--segment)")
    return record


def _check_within(run: StaticRun, t_first: float, t_last: float) -> None:
    """The chosen segment lies within the data (as :func:`data.recording.validate_schedule` has it)."""
    seg = run.segment
    if seg.start < t_first - SEGMENT_OVERHANG_S or seg.end > t_last + SEGMENT_OVERHANG_S:
        raise InputError(run.description, f"{seg.describe()} lies outside the data, which cover "
                         f"{t_first:g}-{t_last:g} s")

