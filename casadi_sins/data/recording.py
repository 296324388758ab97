"""A recording of the interchange format ``sins-recording/1``: its schedule, its samples, their checks.

A recording is a TOML description (site, sample rate, segments) beside a CSV of raw pulse increments
(``time, gyro_x..z, accel_x..z``); reading and writing are :mod:`data.description` and
:mod:`data.samples`.  Segments are listed in time order; a group starts with a static segment (its
alignment) and alternates rotation / static.  Every problem found is an :class:`~core.errors.InputError`
naming the file and the line or segment it is in.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..core import orientation as orient
from ..core.earth import EARTH_RATE, G0, Site
from ..core.errors import InputError
from ..core.files import safe_stem
from .conditions import Conditions
from .formats import PULSE_COLUMNS

FORMAT = "sins-recording/1"
COLUMNS = ("time",) + PULSE_COLUMNS
#: Two times closer than this fraction of a sample interval are the same instant.
TIME_TOLERANCE = 1e-3
#: The mean sample interval may differ from 1/rate_hz by this much (relative) unnoticed; up to
#: RATE_ERROR_LIMIT it is a warning (a time column from another clock), beyond that an error: every
#: scale factor would absorb it (100.05 Hz labelled 100 Hz is +500 ppm on each).
RATE_WARNING = 1e-6
RATE_ERROR_LIMIT = 1e-4
#: How far (s) a segment may reach past the first or last sample: time-tag conventions differ
#: (a segment "from 0 s" over data whose first interval starts at one sample period).
SEGMENT_OVERHANG_S = 1.0

__all__ = ["FORMAT", "COLUMNS", "PULSE_COLUMNS", "Recording", "Segment", "Site", "validate_schedule",
           "check_rate", "check_physical_range"]


@dataclasses.dataclass(frozen=True)
class Segment:
    """One segment of the schedule.  ``number`` counts from 1 in file order."""

    number: int
    group: int
    kind: str  # "static" | "rotation"
    start: float
    end: float
    orientation: str | None = None  # static: nominal direction letters; None: a rest at any orientation
    axis: str | None = None  # rotation: "+X" ... "-Z"; None (with angle_deg): a free move
    angle_deg: float | None = None  # rotation: nominal angle

    @property
    def is_static(self) -> bool:
        """A static segment (else a rotation)."""
        return self.kind == "static"

    @property
    def is_free(self) -> bool:
        """A rest at any orientation (no letters) or a move without a nominal axis and angle: a session by hand."""
        return self.orientation is None if self.is_static else self.axis is None

    @property
    def what(self) -> str:
        """``"USE"``, ``"+Z 90 deg"``; ``"free"`` and ``"free move"`` for the segments of a session by hand."""
        if self.is_static:
            return self.orientation or "free"
        return "free move" if self.axis is None else f"{self.axis} {self.angle_deg:g} deg"

    def describe(self) -> str:
        """``"segment 3 (group 1, static USE, 110-210 s)"``, for messages."""
        return f"segment {self.number} (group {self.group}, {self.kind} {self.what}, {self.start:g}-{self.end:g} s)"


@dataclasses.dataclass
class Recording:
    """A validated recording: description plus raw pulses.

    Attributes
    ----------
    time : ndarray (N,)
        End of each sample interval, s.
    gyro, accel : ndarray (N, 3)
        Raw pulse increments per interval.
    conditions : Conditions
        The description's ``[conditions]`` (empty when not given).
    temperature : ndarray (N,) or None
        The CSV's optional ``temperature`` column, degC.
    notes : list of str
        What was found or assumed in reading it, without doubt (a schedule found from the samples, when the
        description has no segments); doubts are ``warnings``.
    reference : ndarray (N, 3) or None
        The CSV's optional reference attitude (roll, pitch, heading, rad; Z-Y-X Euler angles from
        north-east-down, :func:`core.rotations.euler_to_enu`): a master INS on the base, or a turntable's
        encoders turned into the table top's attitude.  Only its changes within a static segment are used.
    """

    name: str
    site: Site
    rate_hz: float
    segments: list[Segment]
    time: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    source: Path | None = None  # the description file, when read from one
    warnings: list[str] = dataclasses.field(default_factory=list)  # doubts about the data, for the reports
    conditions: Conditions = dataclasses.field(default_factory=Conditions)
    temperature: np.ndarray | None = None  # degC per sample, when the CSV has the column
    notes: list[str] = dataclasses.field(default_factory=list)  # what was found or assumed (a schedule found), no doubt
    reference: np.ndarray | None = None  # (N, 3) roll, pitch, heading of an attitude reference, rad

    @property
    def dt(self) -> float:
        """Sample interval, s."""
        return 1.0 / self.rate_hz

    @property
    def label(self) -> str:
        """The description file's path, or the name: how messages name the recording."""
        return str(self.source) if self.source else self.name

    @property
    def file_stem(self) -> str:
        """The name as a file name: no folders, nothing but letters, digits and ``-_.``."""
        return safe_stem(self.name)

    @property
    def group_ids(self) -> list[int]:
        """The groups, in schedule order."""
        seen: list[int] = []
        for seg in self.segments:
            if seg.group not in seen:
                seen.append(seg.group)
        return seen

    def group_segments(self, group: int) -> list[Segment]:
        """The segments of one group, in order."""
        return [s for s in self.segments if s.group == group]

    def sample_range(self, start: float, end: float) -> slice:
        """Samples whose interval ``[t - dt, t]`` lies inside ``[start, end]``."""
        tol = TIME_TOLERANCE * self.dt
        first = int(np.searchsorted(self.time, start + self.dt - tol, side="left"))
        stop = int(np.searchsorted(self.time, end + tol, side="right"))
        return slice(first, max(first, stop))

    def segment_samples(self, seg: Segment) -> slice:
        """The samples inside a segment."""
        return self.sample_range(seg.start, seg.end)

    def group_samples(self, group: int) -> slice:
        """All samples of a group, from its first segment's start to its last segment's end."""
        segs = self.group_segments(group)
        return self.sample_range(segs[0].start, segs[-1].end)

    @property
    def static_segments(self) -> list[Segment]:
        """Every static segment, in order."""
        return [s for s in self.segments if s.is_static]


#: Beyond these no navigation-grade unit measures and no turntable moves: rad/s and m/s^2.
MAX_RATE = np.radians(2000.0)
MAX_SPECIFIC_FORCE = 100.0 * G0


def check_physical_range(rec: Recording, data_path) -> None:
    """Reject samples far beyond anything a unit on a turntable measures (1e300, a lost decimal point),
    naming the line.  The pulses' sizes are unknown here; robust rough ones come from the static
    segments' medians (1 g of specific force, the Earth rate), which a few wild samples cannot move."""
    statics = [rec.segment_samples(seg) for seg in rec.static_segments]
    if not statics:
        return
    for sensor, pulses, columns, magnitude, limit, unit in (
            ("gyro", rec.gyro, PULSE_COLUMNS[:3], EARTH_RATE, MAX_RATE, "deg/s"),
            ("accel", rec.accel, PULSE_COLUMNS[3:], rec.site.g, MAX_SPECIFIC_FORCE, "g")):
        medians = np.array([np.median(pulses[sl], axis=0) for sl in statics])
        design = medians**2  # finite: the reader refuses pulses beyond 2**53 (no solve sees inf, none hangs)
        if not np.all(np.isfinite(design)) or not np.all(np.any(design > 0, axis=0)):
            continue
        u = np.linalg.lstsq(design, np.full(len(statics), (magnitude * rec.dt) ** 2), rcond=None)[0]
        if np.any(u <= 0):
            continue
        pulse_size = np.sqrt(u)  # per axis, SI per pulse
        values = np.abs(pulses) * pulse_size / rec.dt
        beyond = values > limit
        if beyond.any():
            row, col = np.argwhere(beyond)[0]
            shown = values[row, col] / (np.radians(1.0) if unit == "deg/s" else G0)
            raise InputError(data_path, f"{pulses[row, col]:.6g} pulses would be about {shown:.3g} {unit}: not a "
                             "physical measurement (a lost decimal point?)", line=int(row) + 2, column=columns[col])


def check_rate(time: np.ndarray, rate_hz: float, where) -> str | None:
    """Compare the time column's mean rate with ``rate_hz``; a warning text, or raise beyond the limit.

    The rate is the least-squares slope of time against sample number; its resolution follows from the
    scatter of the time tags about that line (rounded tags), so a short file with coarse tags is not
    blamed for what it cannot show.
    """
    n = len(time)
    index = np.arange(n, dtype=float) - (n - 1) / 2.0
    slope = float(index @ (time - time.mean()) / (index @ index))
    scatter = time - time.mean() - slope * index
    resolution = float(np.sqrt(np.mean(scatter**2) / (index @ index)))
    deviation = slope * rate_hz - 1.0
    if abs(deviation) <= max(RATE_WARNING, 5.0 * resolution * rate_hz):
        return None
    text = (f"the time column runs at {1.0 / slope:.9g} Hz, rate_hz says {rate_hz:g} Hz "
            f"({deviation * 1e6:+.3g} ppm); every scale factor would absorb the difference")
    if abs(deviation) > RATE_ERROR_LIMIT:
        raise InputError(where, text + ": correct rate_hz or the time column")
    return f"{where}: {text} (within 100 ppm: calibrated with rate_hz; check which clock is right)"


def validate_schedule(rec: Recording) -> None:
    """Check the segments against each other and against the data; raise :class:`~core.errors.InputError` naming the segment."""
    where = rec.label
    if not rec.segments:
        raise InputError(where, "no segments: a recording needs at least one group of static and rotation segments")
    tol = TIME_TOLERANCE * rec.dt
    t_first, t_last = rec.time[0] - rec.dt, rec.time[-1]
    prev: Segment | None = None
    finished_groups: set[int] = set()
    for seg in rec.segments:
        slack = SEGMENT_OVERHANG_S + tol
        if seg.start < t_first - slack or seg.end > t_last + slack:
            raise InputError(where, f"{seg.describe()} lies outside the data, "
                                 f"which cover {t_first:g}-{t_last:g} s")
        if prev is not None and seg.start < prev.end - tol:
            raise InputError(where, f"{seg.describe()} overlaps or precedes segment {prev.number} "
                                 f"(ends {prev.end:g} s); segments must be in time order")
        samples = rec.segment_samples(seg)
        if samples.stop - samples.start < 2:
            raise InputError(where, f"{seg.describe()} holds fewer than two samples")
        new_group = prev is None or seg.group != prev.group
        if new_group:
            if seg.group in finished_groups:
                raise InputError(where, f"{seg.describe()} returns to group {seg.group}, "
                                     "whose segments must be consecutive")
            if prev is not None:
                _check_group_end(prev, where)
                finished_groups.add(prev.group)
            if not seg.is_static:
                raise InputError(where, f"{seg.describe()} starts group {seg.group} with a rotation; "
                                     "a group must start with a static segment (its alignment)")
        elif seg.is_static == prev.is_static:
            raise InputError(where, f"{seg.describe()} follows a {prev.kind} segment; "
                                 "a group must alternate static and rotation segments")
        prev = seg
    _check_group_end(prev, where)
    _check_orientation_chain(rec)


def _check_group_end(seg: Segment, where: str) -> None:
    if not seg.is_static:
        raise InputError(where, f"{seg.describe()} ends group {seg.group}; "
                             "a group must end with a static segment")


#: A turn's stated angle within this of a multiple of 90 deg is that multiple for the letters' chain (a turn by
#: hand written as measured, 176.5 deg); the calibration navigates the measured motion either way.
CHAIN_ANGLE_TOLERANCE_DEG = 15.0


def _check_orientation_chain(rec: Recording) -> None:
    """The letters after each turn follow from those before.  A heading that does not follow (the same axis up,
    the others turned about it) is a warning: the calibration navigates the measured motion and uses the
    letters of no static segment but through gravity; anything else is an error naming the segment."""
    headings = []
    for group in rec.group_ids:
        segs = rec.group_segments(group)
        for before, rot, after in zip(segs[0::2], segs[1::2], segs[2::2]):
            if before.is_free or rot.is_free or after.is_free:
                continue  # no letters to chain: the measured gravity directions say what the move did
            nominal = 90.0 * round(rot.angle_deg / 90.0)
            angle = nominal if abs(rot.angle_deg - nominal) <= CHAIN_ANGLE_TOLERANCE_DEG else rot.angle_deg
            expected = orient.rotate_body(orient.orientation_to_dcm(before.orientation), rot.axis, np.radians(angle))
            stated = orient.orientation_to_dcm(after.orientation)
            if np.abs(expected[2] - stated[2]).max() <= 1e-6 < np.abs(expected - stated).max():
                headings.append(f"{after.number} ({before.orientation} {rot.axis} {rot.angle_deg:g} deg gives "
                                f"{orient.dcm_to_orientation(expected, tol_deg=1e-3)}, not {after.orientation})")
                continue
            if np.abs(expected - stated).max() > 1e-6:
                try:
                    result = f"gives {orient.dcm_to_orientation(expected, tol_deg=1e-3)}"
                except orient.OrientationError:
                    result = "gives no orientation of the letters N S E W U D"
                raise InputError(
                    rec.label, f"{after.describe()} does not follow from {before.orientation} and "
                    f"{rot.describe()}: turning {before.orientation} about {rot.axis} by {rot.angle_deg:g} deg "
                    f"{result}"
                )
    text = (f"{rec.label}: the heading of the letters of static segment(s) {', '.join(headings)} does not follow "
            "from the turns (the same axis is up): taken as nominal, the calibration navigates the measured motion")
    if headings and text not in rec.warnings:
        rec.warnings.append(text)
