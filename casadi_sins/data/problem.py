"""Problem files: an experiment to simulate (schedule, timing, site, truth, deviations).

A problem file is TOML (``format = "casadi-sins-problem/1"``)::

    name = "kang2013"
    [site]      latitude_deg, height_m, optional gravity_mps2
    [imu]       rate_hz
    [timing]    static_s, rotation_s, optional first_static_s, gap_s, rate_profile, handling
                (between groups: "turn", one turn with the rate profile, or "minimum-jerk", a hand
                tumble through random attitudes, about 15 deg/s; see :mod:`sim.motion`)
    [[groups]]  start = "NUE", rotations = ["+Z", "-Y 180", ...] (axis, optional angle),
                optional angle_deg = 90 (the default angle), statics_s = [...] (each static's duration),
                rotations_s = [...] (each rotation's duration; default [timing] rotation_s)
    [hand]      instead of [[groups]] and [timing]: a unit moved by hand through rests at random
                orientations (:class:`data.handplan.HandPlan`; IMU-TK's protocol; motion in :mod:`sim.hand`)
    [errors]    start_attitude_deg, rotation_rate_factor, cross_axis_rate,
                accel_noise_ug, gyro_noise_deg_h, quantize
    [truth]     parameter = value (table unit) or {value = ..., unit = "deg/pulse"}; the 21, and any
                extra group in full (accel_quadratic_*, accel_x/y_lever_*, accel_time_offset)

Recordings made from it follow the recording format (:mod:`data.description`); everything about
the problem that is not in that format (truth, deviations) stays here.
"""

from __future__ import annotations

import dataclasses
import math
from importlib import resources
from pathlib import Path

from ..core import orientation as orient
from ..core.earth import Site
from ..core.errors import InputError, shown
from ..core.files import safe_stem
from ..core.toml import read_toml
from ..core.units import TO_SI
from ..model.noise import NOISE_CEILINGS
from ..model.parameters import ParameterSet
from ..model.registry import is_known, unit_of
from .handplan import HandPlan, read_hand_plan
from .recording import Segment

FORMAT = "casadi-sins-problem/1"
PROFILES = ("half-sine", "versine")
HANDLINGS = ("turn", "minimum-jerk")


#: Most samples a problem's schedule may have (about 3 h at 100 kHz; a longer one fails only for memory).
MAX_SAMPLES = 1e9
#: The largest departures from nominal a bench could make (the noise terms: model.noise.NOISE_CEILINGS).
DEVIATION_CEILINGS = {"start_attitude_deg": 180.0, "rotation_rate_factor": 1.0, "cross_axis_rate": 1.0}


@dataclasses.dataclass(frozen=True)
class GroupPlan:
    """One group: its start orientation, the rotations (an axis, or ``"axis angle"`` such as ``"-Y 180"``),
    the default angle, and optionally each static segment's duration (one more than the rotations) and
    each rotation's duration."""

    start: str
    rotations: tuple[str, ...]
    angle_deg: float = 90.0
    statics_s: tuple[float, ...] | None = None
    rotations_s: tuple[float, ...] | None = None

    def turns(self) -> list[tuple[str, float]]:
        """``(axis, angle_deg)`` of each rotation."""
        out = []
        for entry in self.rotations:
            parts = entry.split()
            out.append((parts[0], float(parts[1]) if len(parts) > 1 else self.angle_deg))
        return out


@dataclasses.dataclass(frozen=True)
class Timing:
    """Segment durations (s): statics, rotations, the first static, handling gaps; the rotations' rate profile
    and the handling's kind (``"turn"`` or ``"minimum-jerk"``)."""

    static_s: float = 100.0
    rotation_s: float = 10.0
    first_static_s: float | None = None
    gap_s: float = 0.0
    rate_profile: str = "half-sine"
    handling: str = "turn"


@dataclasses.dataclass(frozen=True)
class Deviations:
    """How the simulated experiment departs from nominal, and the sensor noise.

    White noise may be given per sample (``accel_noise_ug``, ``gyro_noise_deg_h``, the paper's way)
    or as a density (``accel_vrw_ug_rthz``, ``gyro_arw_deg_rth``); both add.  Bias instability is a
    first-order Gauss-Markov process per axis (steady-state 1 sigma, correlation time).  Sway turns
    the whole base about the unit's centre: per ENU axis ``sway_components`` sinusoids with
    amplitudes uniform in ``sway_amplitude_arcsec`` and periods log-uniform in ``sway_period_s``.
    Linear motion of the base (a deck's heave and surge) carries it along: on each ENU axis named in
    ``translation_axes``, ``translation_components`` sinusoids with amplitudes uniform in
    ``translation_amplitude_m`` and periods log-uniform in ``translation_period_s``, scaled down where
    their peak acceleration would exceed ``translation_peak_mg`` (0: no limit).  ``reference_attitude``
    writes an attitude reference of the base (a master INS) into the recording's optional columns, with
    white noise of ``reference_noise_arcsec`` per sample and angle.
    """

    start_attitude_deg: float = 0.4  # each start attitude angle off nominal by +/- this (random sign)
    rotation_rate_factor: float = 0.004  # rotation rate scaled by U(1 - r, 1 + r)
    cross_axis_rate: float = 0.004  # the two other body axes turn at this fraction of the rate
    accel_noise_ug: float = 50.0  # white, per sample, 1 sigma
    gyro_noise_deg_h: float = 0.01  # white, per sample, 1 sigma
    accel_vrw_ug_rthz: float = 0.0  # white, velocity random walk density, ug/sqrt(Hz)
    gyro_arw_deg_rth: float = 0.0  # white, angle random walk density, deg/sqrt(h)
    accel_bias_instability_ug: float = 0.0  # Gauss-Markov, steady-state 1 sigma
    accel_bias_tau_s: float = 900.0
    gyro_bias_instability_deg_h: float = 0.0
    gyro_bias_tau_s: float = 600.0
    sway_amplitude_arcsec: tuple[float, float] = (0.0, 0.0)
    sway_period_s: tuple[float, float] = (2.0, 20.0)
    sway_components: int = 2
    translation_amplitude_m: tuple[float, float] = (0.0, 0.0)
    translation_period_s: tuple[float, float] = (3.0, 13.0)
    translation_components: int = 1
    translation_axes: str = "NU"  # surge (north) and heave (up)
    translation_peak_mg: float = 0.0
    reference_attitude: bool = False  # write the base's attitude as the recording's reference columns
    reference_noise_arcsec: float = 0.0
    quantize: bool = False  # integer pulses, remainder carried

    @property
    def sways(self) -> bool:
        """Whether the base sways."""
        return max(self.sway_amplitude_arcsec) > 0.0

    @property
    def translates(self) -> bool:
        """Whether the base moves linearly."""
        return max(self.translation_amplitude_m) > 0.0 and bool(self.translation_axes)


@dataclasses.dataclass(frozen=True)
class Problem:
    """An experiment to simulate: site, rate, schedule, timing, deviations and truth (``hand``: a session by
    hand, whose ``groups`` are empty)."""

    name: str
    site: Site
    rate_hz: float
    groups: tuple[GroupPlan, ...]
    timing: Timing
    deviations: Deviations
    truth: ParameterSet
    source: Path | None = None
    description: str = ""
    hand: HandPlan | None = None

    def with_changes(self, **deviations) -> "Problem":
        """A copy with some deviation settings replaced (e.g. ``start_attitude_deg=5``)."""
        return dataclasses.replace(self, deviations=dataclasses.replace(self.deviations, **deviations))

    def segments(self) -> list[Segment]:
        """The nominal schedule as recording segments (a session by hand: rests at any orientation and free
        moves, one group)."""
        if self.hand is not None:
            return self.hand.segments()
        segs: list[Segment] = []
        t = 0.0
        for gi, plan in enumerate(self.groups, start=1):
            if gi > 1:
                t += self.timing.gap_s
            dcm = orient.orientation_to_dcm(plan.start)
            durations = plan.statics_s or ((self.timing.first_static_s or self.timing.static_s),) + \
                (self.timing.static_s,) * len(plan.rotations)
            segs.append(Segment(len(segs) + 1, gi, "static", t, t + durations[0], orientation=plan.start))
            t += durations[0]
            turn_s = plan.rotations_s or (self.timing.rotation_s,) * len(plan.rotations)
            for (axis, angle), duration, rotation_s in zip(plan.turns(), durations[1:], turn_s, strict=True):
                segs.append(Segment(len(segs) + 1, gi, "rotation", t, t + rotation_s, axis=axis, angle_deg=angle))
                t += rotation_s
                dcm = orient.rotate_body(dcm, axis, math.radians(angle))
                letters = orient.dcm_to_orientation(dcm, tol_deg=1e-6)
                segs.append(Segment(len(segs) + 1, gi, "static", t, t + duration, orientation=letters))
                t += duration
        return [dataclasses.replace(s, start=round(s.start, 9), end=round(s.end, 9)) for s in segs]

    @property
    def duration(self) -> float:
        """End of the schedule, s."""
        return self.segments()[-1].end


def default_problem_path() -> Path:
    """The built-in default problem: the paper's experiment."""
    return Path(str(resources.files("casadi_sins.problems") / "kang2013.toml"))


class _Reader:
    """Typed access to one problem file's tables; every error names the file and the key."""

    def __init__(self, path: Path, doc: dict):
        self.path, self.doc = path, doc

    def fail(self, message: str) -> InputError:
        return InputError(self.path, message)

    def section(self, name: str) -> dict:
        value = self.doc.get(name, {})
        if not isinstance(value, dict):
            raise self.fail(f"[{name}] must be a table")
        return value

    def number(self, table: dict, key: str, where: str, default=None) -> float:
        value = table.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.fail(f"[{where}] {key} must be a finite number, found {shown(value)}")
        return float(value)

    def site(self) -> Site:
        doc = self.section("site")
        gravity = doc.get("gravity_mps2")
        return Site(math.radians(self.number(doc, "latitude_deg", "site")), self.number(doc, "height_m", "site", 0.0),
                    None if gravity is None else self.number(doc, "gravity_mps2", "site"))

    def rate_hz(self) -> float:
        rate = self.number(self.section("imu"), "rate_hz", "imu")
        if rate <= 0:
            raise self.fail("[imu] rate_hz must be positive")
        return rate

    def timing(self) -> Timing:
        doc = self.section("timing")
        timing = Timing(
            static_s=self.number(doc, "static_s", "timing", 100.0),
            rotation_s=self.number(doc, "rotation_s", "timing", 10.0),
            first_static_s=(self.number(doc, "first_static_s", "timing") if "first_static_s" in doc else None),
            gap_s=self.number(doc, "gap_s", "timing", 0.0),
            rate_profile=str(doc.get("rate_profile", "half-sine")),
            handling=str(doc.get("handling", "turn")),
        )
        if timing.rate_profile not in PROFILES:
            raise self.fail(f"[timing] rate_profile must be one of {', '.join(PROFILES)}")
        if timing.handling not in HANDLINGS:
            raise self.fail(f"[timing] handling must be one of {', '.join(HANDLINGS)}")
        if min(timing.static_s, timing.rotation_s) <= 0 or timing.gap_s < 0:
            raise self.fail("[timing] durations must be positive (gap_s may be 0)")
        return timing

    def hand(self) -> HandPlan | None:
        return read_hand_plan(self.doc.get("hand"), self.path)

    def groups(self) -> tuple[GroupPlan, ...]:
        if "hand" in self.doc:
            if self.doc.get("groups"):
                raise self.fail("a problem has [[groups]] (a turntable) or [hand] (a session by hand), not both")
            return ()
        items = self.doc.get("groups", [])
        if not isinstance(items, list) or not items:
            raise self.fail("no [[groups]]")
        return tuple(self.group(gi, item) for gi, item in enumerate(items, start=1))

    def group(self, gi: int, item) -> GroupPlan:
        try:
            start = str(item["start"]).upper()
            orient.orientation_to_dcm(start)
            rotations = tuple(" ".join(str(a).upper().split()) for a in item.get("rotations", []))
            for entry in rotations:
                parts = entry.split()
                orient.parse_axis(parts[0])
                if len(parts) > 2 or (len(parts) == 2 and not math.isfinite(float(parts[1]))):
                    raise ValueError(entry)
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            if isinstance(exc, orient.OrientationError):
                raise self.fail(f"[[groups]] {gi}: {exc}") from None
            raise self.fail(f"[[groups]] {gi}: missing or invalid {shown(str(exc))} (rotations are \"+Z\" or "
                            "\"-Y 180\")") from None
        statics = self.durations(gi, item, "statics_s", len(rotations) + 1)
        turn_s = self.durations(gi, item, "rotations_s", len(rotations))
        return GroupPlan(start, rotations, self.number(item, "angle_deg", f"groups {gi}", 90.0), statics, turn_s)

    def durations(self, gi: int, item, key: str, count: int) -> tuple[float, ...] | None:
        """A group's optional list of ``count`` positive durations (``statics_s``, ``rotations_s``)."""
        values = item.get(key)
        if values is None:
            return None
        if not isinstance(values, list) or len(values) != count:
            raise self.fail(f"[[groups]] {gi}: {key} must list {count} durations")
        values = tuple(self.number({"v": v}, "v", f"groups {gi} {key}") for v in values)
        if values and min(values) <= 0:
            raise self.fail(f"[[groups]] {gi}: {key} must be positive")
        return values or None

    def deviation(self, key: str, value):
        if key in ("quantize", "reference_attitude"):
            if not isinstance(value, bool):
                raise self.fail(f"[errors] {key} must be true or false")
            return value
        if key in ("sway_components", "translation_components"):
            count = self.number({key: value}, key, "errors")
            if count != int(count) or count < 1:
                raise self.fail(f"[errors] {key} must be a positive integer")
            return int(count)
        if key == "translation_axes":
            if not isinstance(value, str) or set(value.upper()) - set("ENU") or len(set(value.upper())) != len(value):
                raise self.fail(f"[errors] translation_axes must be letters of ENU, found {shown(value)}")
            return value.upper()
        if key in ("sway_amplitude_arcsec", "sway_period_s", "translation_amplitude_m", "translation_period_s"):
            pair = value if isinstance(value, list) else [value, value]
            if len(pair) != 2:
                raise self.fail(f"[errors] {key} must be a number or [low, high]")
            low, high = (self.number({"v": v}, "v", f"errors {key}") for v in pair)
            if not 0.0 <= low <= high or (key.endswith("_period_s") and low <= 0.0):
                raise self.fail(f"[errors] {key} must be 0 <= low <= high (periods > 0)")
            return (low, high)
        result = self.number({key: value}, key, "errors")
        if result < 0.0 or (key.endswith("_tau_s") and result == 0.0):
            raise self.fail(f"[errors] {key} must be positive")
        ceiling = NOISE_CEILINGS.get(key, DEVIATION_CEILINGS.get(key))
        if ceiling is not None and result > ceiling:
            raise self.fail(f"[errors] {key} {result:g} is beyond any inertial sensor or turntable (at most "
                            f"{ceiling:g}): check the unit")
        return result

    def deviations(self) -> Deviations:
        doc = self.section("errors")
        unknown = set(doc) - {f.name for f in dataclasses.fields(Deviations)}
        if unknown:
            raise self.fail(f"[errors] unknown key(s) {', '.join(sorted(unknown))}")
        return Deviations(**{k: self.deviation(k, v) for k, v in doc.items()})

    def truth(self) -> ParameterSet:
        values = {}
        for name, entry in self.section("truth").items():
            if not is_known(name):
                raise self.fail(f"[truth] unknown parameter {shown(name)}")
            value, unit = (entry.get("value"), entry.get("unit")) if isinstance(entry, dict) else (entry, unit_of(name))
            if unit not in TO_SI:
                raise self.fail(f"[truth] {name}: unknown unit {shown(unit)}")
            values[name] = self.number({"v": value}, "v", f"truth {name}") * TO_SI[unit]
        try:
            return ParameterSet.from_dict(values)
        except ValueError as exc:
            raise self.fail(f"[truth] {exc}") from None


def load_problem(path: str | Path | None = None) -> Problem:
    """Read a problem file (default: the paper's experiment).

    Raises
    ------
    InputError
        Naming the file and the key at fault.
    """
    path = Path(path) if path is not None else default_problem_path()
    doc = read_toml(path, "problem file")
    if doc.get("format") != FORMAT:
        raise InputError(path, f"format must be {FORMAT!r}, found {shown(doc.get('format'))}")
    reader = _Reader(path, doc)
    problem = Problem(name=safe_stem(str(doc.get("name", path.stem))), site=reader.site(), rate_hz=reader.rate_hz(),
                      groups=reader.groups(), timing=reader.timing(), deviations=reader.deviations(),
                      truth=reader.truth(), source=path, description=str(doc.get("description", "")),
                      hand=reader.hand())
    try:
        problem.segments()
    except orient.OrientationError as exc:
        raise InputError(path, f"a rotation angle leads off the letter orientations ({exc})") from None
    samples = problem.duration * problem.rate_hz
    if not samples <= MAX_SAMPLES:
        raise InputError(path, f"the schedule lasts {problem.duration:.3g} s at {problem.rate_hz:g} Hz, {samples:.3g} "
                         f"samples: more than {MAX_SAMPLES:.0e} (a calibration runs minutes to hours)")
    return problem
